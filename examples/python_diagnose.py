"""The model-gap diagnosis from Python in a few lines (docs/diagnose.md, docs/python.md).

    .venv/bin/python examples/python_diagnose.py [LOG.mcap] [OUT_DIR]

Diagnoses a MuJoCo UR5 log with a hidden payload and viscous friction (default
fixtures/diagnose/viscous_payload.mcap), prints what is missing, and writes
diagnosis.json, report.html and residuals.mcap into OUT_DIR (default out/python_diagnose).
"""
import os
import sys

import ivdyn

ROOT = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..")
log = sys.argv[1] if len(sys.argv) > 1 else os.path.join(ROOT, "fixtures", "diagnose", "viscous_payload.mcap")
out = sys.argv[2] if len(sys.argv) > 2 else os.path.join(ROOT, "out", "python_diagnose")

robot = ivdyn.Robot.from_urdf(os.path.join(ROOT, "fixtures", "ur5.urdf"), base="base_link", tip="tool0")
d = ivdyn.diagnose(robot, log, out=out)            # the content of diagnosis.json

if not d["effects"]:
    print("nothing significant missing")
for e in d["effects"]:
    print(f'{e["name"]:<18} on {e["joints"] or "the last link"}: {e["parameters"]}')
for j, name in enumerate(d["joints"]):
    print(f'{name:<22} RMS {d["baseline_rms"][j]:8.3f} -> {d["final_rms"][j]:.3f} N m')
print(f"report: {os.path.join(out, 'report.html')}")

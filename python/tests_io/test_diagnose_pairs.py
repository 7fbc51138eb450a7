"""The diagnosis writes its three files for every pair of hidden effects, from the command
line and from Python (`ivdyn.diagnose(..., out=)`), and both write the same diagnosis.

A pair of effects is the case where the report once broke ("traces.predicted: expected
length 4, got 7": a search step found again later was merged in the report, the per-step
predictions were not). Each log is made here by MuJoCo, as the fixtures are
(python/tools/make_diagnose_cases.py: UR5, 2 s at 1 kHz, the six single-effect cases'
effects taken two at a time, torque noise and quantisation of the fixtures). Checked:
the command exits 0, diagnosis.json, report.html and residuals.mcap exist, the JSON is
the same from both front ends, and residuals.mcap holds one `/ivdyn/predicted/step<i>_*`
topic per reported effect, in the order of `effects`.
"""
import itertools
import json
import os
import subprocess
import sys

import pytest

import mcap.reader as mcap_reader

import ivdyn

ROOT = os.path.abspath(os.path.join(os.path.dirname(__file__), "..", ".."))
sys.path.insert(0, os.path.join(ROOT, "python", "tools"))
import make_diagnose_cases as gen  # noqa: E402

SINGLE = ["coulomb", "viscous", "armature", "payload", "torque_offset", "joint_spring"]
EFFECTS = {c["name"]: c["effects"][0] for c in gen.UR5_CASES if c["name"] in SINGLE}
PAIRS = list(itertools.combinations(SINGLE, 2))
UR5 = os.path.join(ROOT, "fixtures", "ur5.urdf")
CHAIN = ["--urdf", UR5, "--base", "base_link", "--tip", "tool0"]


@pytest.fixture(scope="module")
def robot():
    return ivdyn.Robot.from_urdf(UR5, base="base_link", tip="tool0")


def pair_log(robot, a, b, i, path):
    cfg = gen.robot_config("ur5", out=os.path.dirname(path))
    case = {"name": f"{a}+{b}", "seed": 300 + i, "effects": [EFFECTS[a], EFFECTS[b]]}
    sim, q, qd, tau, _ = gen.measured(cfg, case, robot, 2.0)
    gen.write_mcap(path, list(robot.joint_names), sim["t"], q, qd, tau)


def same(a, b, path="$"):
    """Equal JSON documents, numbers to 1e-9 relative (two builds of the same code)."""
    if isinstance(a, dict):
        assert isinstance(b, dict) and sorted(a) == sorted(b), path
        for k in a:
            same(a[k], b[k], f"{path}.{k}")
    elif isinstance(a, list):
        assert isinstance(b, list) and len(a) == len(b), path
        for i, (x, y) in enumerate(zip(a, b)):
            same(x, y, f"{path}[{i}]")
    elif isinstance(a, float) and isinstance(b, (int, float)):
        assert b == pytest.approx(a, rel=1e-9, abs=1e-12), path
    else:
        assert a == b, path


def step_topics(path):
    with open(path, "rb") as f:
        summary = mcap_reader.make_reader(f).get_summary()
    return sorted((c.topic for c in summary.channels.values() if c.topic.startswith("/ivdyn/predicted/step")),
                  key=lambda t: int(t.split("step")[1].split("_")[0]))


@pytest.mark.parametrize("a,b", PAIRS, ids=[f"{a}+{b}" for a, b in PAIRS])
def test_pair_writes_the_three_files_from_cli_and_python(robot, ivdyn_bin, tmp_path, a, b):
    log = str(tmp_path / "log.mcap")
    pair_log(robot, a, b, PAIRS.index((a, b)), log)
    cli_out, py_out = tmp_path / "cli", tmp_path / "py"
    r = subprocess.run([ivdyn_bin, "diagnose", *CHAIN, "--log", log, "--out", str(cli_out), "--quiet"],
                       capture_output=True, text=True)
    assert r.returncode == 0, r.stderr
    d = ivdyn.diagnose(robot, log, out=py_out)
    for out in (cli_out, py_out):
        assert sorted(os.listdir(out)) == ["diagnosis.json", "report.html", "residuals.mcap"]
        with open(out / "diagnosis.json") as f:
            same(json.load(f), d)
        names = [e["name"] for e in d["effects"]]
        topics = step_topics(out / "residuals.mcap")
        assert topics == [f"/ivdyn/predicted/step{i + 1}_{n}" for i, n in enumerate(names)]

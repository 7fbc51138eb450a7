#!/usr/bin/env python3
"""The main job from Python: simulate a UR5 before and after grasping 2 kg, identify the
unloaded arm, estimate the payload (the same pipelines and JSON as `ivdyn simulate /
identify / payload`, docs/python.md).

    .venv/bin/python examples/python_payload.py        # about 2 s
"""
import os

import ivdyn

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
ur5 = ivdyn.Robot.from_urdf(os.path.join(ROOT, "fixtures", "ur5.urdf"), base="base_link", tip="tool0")
friction = dict(fc=[2, 2, 1.5, 0.6, 0.6, 0.4], fv=[0.8, 0.8, 0.5, 0.2, 0.2, 0.1], noise=0.1)

before = ivdyn.simulate(ur5, seed=1, **friction)["log"]
after = ivdyn.simulate(ur5, seed=2, payload_mass=2.0, payload_com=[0.01, -0.02, 0.05], **friction)["log"]

rep = ivdyn.identify(ur5, before, method="wls")
print(f"identify: {len(rep['base'])} base parameters, validation rms {max(rep['validation']['rms']):.3f} N m,"
      f" {rep['dwh']['verdict']}")
pl = ivdyn.payload(ur5, after, before=before, progress=True)
print(f"payload on {pl['link']}: {pl['mass']:.4f} +- {pl['mass_std']:.4f} kg at "
      f"({', '.join(f'{c:.4f}' for c in pl['com'])}) m   (truth 2 kg at (0.01, -0.02, 0.05) m)")
ph = pl["physical"]
print(f"least-squares payload a rigid body: {ph['ls_possible']} (the reported one always is; squared Mahalanobis"
      f" distance to the nearest rigid body {ph['mahalanobis2']:.2f}, p = {ph['p_value']:.2f})")
for note in pl["notes"]:
    print("note:", note)

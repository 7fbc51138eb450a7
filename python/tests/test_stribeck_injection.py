"""Stribeck friction in the MuJoCo case generator (make_diagnose_cases.load_friction): the
joint's `frictionloss` set before every step to fc + fs exp(-(qd/vs)^2) at the step's velocity.
Checked against the formula on MuJoCo's own friction force (`qfrc_constraint`, the only
constraint: contacts and limits are off): while the joint slides it is the Stribeck level with
the sign of the motion, to rounding; near a reversal the constraint holds the joint (stick),
never beyond the static friction fc + fs. A random arm (random_arm.py), 2 s."""
import os
import sys

import numpy as np

ROOT = os.path.join(os.path.dirname(__file__), "..", "..")
sys.path.insert(0, os.path.join(ROOT, "python", "tools"))
import make_cad_cases as mcc  # noqa: E402
import make_diagnose_cases as mdc  # noqa: E402
import ivdyn  # noqa: E402


def test_stribeck_friction_is_the_formula_while_sliding(tmp_path):
    cfg = mcc.random_config("arm", str(tmp_path), joints_seed=(6, 15000))
    robot = ivdyn.Robot.from_urdf(cfg["urdf_path"], base=cfg["base"], tip=cfg["tip"])
    fc, fs, vs = 0.5, 0.4, 0.1
    case = {"name": "stribeck", "seed": 5, "effects": [
        {"name": "stribeck_friction", "joints": ["joint_2"], "parameters": {"fc": [fc], "fs": [fs], "vs": [vs]}}]}
    sim = mdc.simulate(cfg, case, robot, 2.0)
    qd, f = sim["qd"][:, 1], -sim["friction"][:, 1]     # the force opposing the motion
    level = fc + fs * np.exp(-(qd / vs) ** 2)
    sliding = np.abs(qd) > vs / 2
    assert sliding.sum() > 1000 and (np.abs(qd) < vs).sum() > 200    # both regimes are in the log
    assert np.allclose(f[sliding], level[sliding] * np.sign(qd[sliding]), rtol=1e-9, atol=1e-12)
    slow = np.abs(qd) > vs / 10
    assert np.all(np.abs(f[slow] - level[slow] * np.sign(qd[slow])) <= 0.05 * level[slow])
    assert np.all(np.abs(f) <= fc + fs + 1e-9)                          # never beyond static friction
    # the other joints feel no friction
    assert np.all(sim["friction"][:, [0, 2, 3, 4, 5]] == 0.0)
    # the oracle's formula (effect_torque) is the same level
    eff = mdc.effect_torque(case["effects"], list(robot.joint_names), sim["q"], sim["qd"], sim["qdd"], robot)
    assert np.allclose(eff[sliding, 1], level[sliding] * np.sign(qd[sliding]), rtol=1e-12)


def test_applied_stribeck_friction_is_the_formula_at_every_step(tmp_path):
    """`make_cad_cases.py --stribeck applied`: no constraint, the force -(fc + fs
    exp(-(qd/vs)^2)) sign(qd) applied at the step's velocity. Checked on the motion MuJoCo
    realised: the joint torque minus ivdyn's inverse dynamics of the true model at each step's
    state and realised acceleration is that force, to rounding, at every step (stick-like
    chatter at a reversal included)."""
    cfg = mcc.random_config("arm", str(tmp_path), joints_seed=(6, 15000))
    robot = ivdyn.Robot.from_urdf(cfg["urdf_path"], base=cfg["base"], tip=cfg["tip"])
    fc, fs, vs = 0.5, 0.4, 0.1
    case = {"name": "stribeck", "seed": 5, "effects": [
        {"name": "stribeck_friction", "joints": ["joint_2"], "parameters": {"fc": [fc], "fs": [fs], "vs": [vs]}}]}
    mdc.STRIBECK = "applied"
    try:
        sim = mdc.simulate(cfg, case, robot, 2.0)
    finally:
        mdc.STRIBECK = "constraint"
    assert np.all(sim["friction"] == 0.0)                               # no constraint force
    qd = sim["qd"][:, 1]
    force = -(fc + fs * np.exp(-(qd / vs) ** 2)) * np.sign(qd)
    assert (np.abs(qd) < vs).sum() > 200                                # the peak's speeds are in the log
    gap = robot.rnea(sim["q"], sim["qd"], sim["qdd"]) - sim["tau"]
    scale = np.abs(sim["tau"]).max()
    assert np.allclose(gap[:, 1], force, rtol=0, atol=1e-9 * scale)
    assert np.allclose(gap[:, [0, 2, 3, 4, 5]], 0.0, rtol=0, atol=1e-9 * scale)

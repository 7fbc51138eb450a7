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


def test_friction_levels_of_several_kinds_on_one_joint_add_up(tmp_path):
    """Coulomb friction beside Stribeck friction on joint 2, beside direction-dependent
    friction on joint 3, beside load-dependent friction on joint 4: MuJoCo's friction force
    while the joint slides is the sum of the levels, as the case's truth (`effect_torque`)
    has it. Until 2026-12-07 the Stribeck and load-dependent levels were set alone each step
    and a direction-dependent friction's level replaced a Coulomb one: the Coulomb friction
    of those joints was in the truth but not in the simulation (16 logs of the generated
    sets). The load is MuJoCo's at the previous step's acceleration, the truth's at the
    step's own, hence the tolerances on joint 4."""
    cfg = mcc.random_config("arm", str(tmp_path), joints_seed=(6, 15000))
    robot = ivdyn.Robot.from_urdf(cfg["urdf_path"], base=cfg["base"], tip=cfg["tip"])
    fc, fs, vs, mu = 0.3, 0.4, 0.1, 0.05
    case = {"name": "sum", "seed": 5, "effects": [
        {"name": "coulomb_friction", "joints": ["joint_2", "joint_3", "joint_4"], "parameters": {"fc": [fc] * 3}},
        {"name": "stribeck_friction", "joints": ["joint_2"], "parameters": {"fc": [0.5], "fs": [fs], "vs": [vs]}},
        {"name": "asymmetric_coulomb_friction", "joints": ["joint_3"],
         "parameters": {"fc_pos": [0.6], "fc_neg": [0.2]}},
        {"name": "load_dependent_friction", "joints": ["joint_4"], "parameters": {"mu": [mu]}}]}
    sim = mdc.simulate(cfg, case, robot, 2.0)
    names = list(robot.joint_names)
    eff = mdc.effect_torque(case["effects"], names, sim["q"], sim["qd"], sim["qdd"], robot)
    qd, f = sim["qd"], -sim["friction"]      # the constraint force opposing the motion
    for j in (1, 2):
        sliding = np.abs(qd[:, j]) > vs / 2
        assert sliding.sum() > 500, j
        # the constraint holds the symmetric part; direction-dependent friction's half
        # difference is an applied force (drive_force), so joint 3's constraint force is
        # fc + (fc_pos + fc_neg) / 2 and the truth's level that plus the half difference
        half = 0.5 * (0.6 - 0.2) if j == 2 else 0.0
        assert np.allclose(f[sliding, j], eff[sliding, j] - half, rtol=1e-9, atol=1e-12), j
    sliding = np.abs(qd[:, 3]) > vs / 2
    rigid = robot.rnea(sim["q"], sim["qd"], sim["qdd"])[:, 3]
    expected = (fc + mu * np.abs(rigid[sliding])) * np.sign(qd[sliding, 3])
    assert sliding.sum() > 500
    gap = np.abs(f[sliding, 3] - expected)
    # the step after a stick phase has the stuck step's acceleration in its load: up to 4 %
    # of the level there (measured 3.9 %); elsewhere within 0.5 %
    assert np.mean(gap <= 0.005 * np.abs(expected)) >= 0.99
    assert np.all(gap <= 0.05 * np.abs(expected))
    assert np.all(np.abs(f[sliding, 3]) >= fc - 1e-9)    # the Coulomb level is in it


def test_a_coulomb_level_folded_into_its_joints_other_friction_simulates_the_same(tmp_path):
    """`make_cad_cases.merge_levels`: a Coulomb friction drawn on a joint that also has a
    direction-dependent (joint 3) or Stribeck (joint 2) friction goes into that friction's
    levels, since no log can split the sum. The simulation of the merged case is the
    unmerged one's, step for step (the friction-loss levels add up either way)."""
    import copy
    cfg = mcc.random_config("arm", str(tmp_path), joints_seed=(6, 15000))
    robot = ivdyn.Robot.from_urdf(cfg["urdf_path"], base=cfg["base"], tip=cfg["tip"])
    drawn = [
        {"name": "coulomb_friction", "joints": ["joint_2", "joint_3", "joint_5"], "parameters": {"fc": [0.3, 0.2, 0.1]}},
        {"name": "stribeck_friction", "joints": ["joint_2"], "parameters": {"fc": [0.5], "fs": [0.4], "vs": [0.1]}},
        {"name": "asymmetric_coulomb_friction", "joints": ["joint_3"], "parameters": {"fc_pos": [0.6], "fc_neg": [0.2]}}]
    merged = mcc.merge_levels(copy.deepcopy(drawn))
    assert merged == [
        {"name": "coulomb_friction", "joints": ["joint_5"], "parameters": {"fc": [0.1]}},
        {"name": "stribeck_friction", "joints": ["joint_2"], "parameters": {"fc": [0.8], "fs": [0.4], "vs": [0.1]}},
        {"name": "asymmetric_coulomb_friction", "joints": ["joint_3"], "parameters": {"fc_pos": [0.8], "fc_neg": [0.4]}}]
    a = mdc.simulate(cfg, {"name": "a", "seed": 5, "effects": drawn}, robot, 1.0)
    b = mdc.simulate(cfg, {"name": "b", "seed": 5, "effects": merged}, robot, 1.0)
    np.testing.assert_allclose(b["q"], a["q"], rtol=0, atol=1e-12)
    np.testing.assert_allclose(b["friction"], a["friction"], rtol=0, atol=1e-9)

"""The random arms of the MuJoCo case generator (python/tools/random_arm.py) and the sensor
variants of their logs (python/tools/sensor_variants.py): physical inertials, the MJCF that
MuJoCo simulates and the URDF that ivdyn loads describe the same arm, and the logged stamps,
velocities and efforts are what the variant says."""
import math
import os
import sys

import numpy as np
import pytest

ROOT = os.path.join(os.path.dirname(__file__), "..", "..")
sys.path.insert(0, os.path.join(ROOT, "python", "tools"))
import make_cad_cases as mcc  # noqa: E402
import make_diagnose_cases as mdc  # noqa: E402
import random_arm  # noqa: E402
import sensor_variants  # noqa: E402
import ivdyn  # noqa: E402


@pytest.mark.parametrize("n", [6, 7])
def test_drawn_arms_have_physical_inertials_and_sensible_kinematics(n):
    for seed in range(40):
        arm = random_arm.draw_arm(n, seed)     # check_inertials runs inside: raises if not
        kin = arm["kinematics"]
        reach = sum(abs(a) + abs(d) for a, _, d in kin)
        assert random_arm.REACH[0] - 1e-9 <= reach <= random_arm.REACH[1] + 1e-9
        for a, alpha, d in kin[1:]:   # no two consecutive axes coincide
            assert alpha != 0.0 or a > 0.0
        masses = [lk["mass"] for lk in arm["links"]]
        assert all(random_arm.MASS[0] <= m <= random_arm.MASS[1] for m in masses)


def test_check_inertials_rejects_what_no_rigid_body_has():
    arm = random_arm.draw_arm(6, 1)
    bad = dict(arm["links"][2], inertia=np.diag([1.0, 0.1, 0.1]))   # 1 > 0.1 + 0.1
    with pytest.raises(ValueError, match="link_3: principal moments"):
        random_arm.check_inertials(arm["links"][:2] + [bad])
    far = dict(arm["links"][0], com=arm["links"][0]["com"] + np.array([0.0, 0.0, 1.0]))
    with pytest.raises(ValueError, match="link_1: COM"):
        random_arm.check_inertials([far])
    with pytest.raises(ValueError, match="link_1: mass"):
        random_arm.check_inertials([dict(arm["links"][0], mass=0.0)])


@pytest.mark.parametrize("joints_seed", [(6, 15000), (7, 15001), (7, 20_003)])
def test_mujoco_mjcf_and_ivdyn_urdf_are_the_same_arm(joints_seed, tmp_path):
    """MuJoCo's inverse dynamics and mass matrix on the MJCF against ivdyn's rnea and mass
    matrix on the URDF (two writers, one set of numbers), 100 random states."""
    cfg = mcc.random_config("arm", str(tmp_path), joints_seed=joints_seed)
    robot = ivdyn.Robot.from_urdf(cfg["urdf_path"], base=cfg["base"], tip=cfg["tip"])
    assert robot.joint_names == [f"joint_{i}" for i in range(1, joints_seed[0] + 1)]
    assert robot.link_names[-1] == cfg["terminal_link"]
    err_tau, err_m = mdc.check_agreement(robot, n=100, seed=7, cfg=cfg)
    assert err_tau < 1e-9 and err_m < 1e-9, (err_tau, err_m)
    assert all(s >= mcc.NOISE_FLOOR for s in cfg["torque_noise"])


def test_sensor_variants_are_what_the_log_holds(tmp_path):
    """A jittered, current-based, float32 log without velocity reads back with its own
    stamps, no velocity, and efforts that are the torques divided by the torque constants."""
    rng = np.random.default_rng(3)
    sensor = {"jitter": True, "float32": True, "velocity": False, "torque_constant": [2.0, 4.0, 8.0]}
    t = sensor_variants.stamps(sensor, 1.0, 1e-3, rng)
    steps = np.diff(t)
    assert steps.min() >= 0.7e-3 - 1e-12 and 0.9e-3 < np.median(steps) < 1.1e-3
    q = np.tile(np.array([0.1, -0.2, 0.3]), (len(t), 1)) + np.outer(t, [1.0, 2.0, 3.0])
    tau = np.round(np.outer(np.sin(t), [1.0, 2.0, 4.0]) / mdc.TAU_RES) * mdc.TAU_RES
    q_log, qd_log, effort, repeats = sensor_variants.finish(sensor, t, q, q, tau, rng)
    assert qd_log is None and repeats > 0
    assert np.all(effort == effort.astype(np.float32)) and np.all(q_log == q_log.astype(np.float32))
    moved = np.flatnonzero(np.any(q_log[1:] != q_log[:-1], axis=1))   # the re-published rows repeat
    assert len(t) - 1 - len(moved) == repeats
    names = ["joint_1", "joint_2", "joint_3"]
    path = str(tmp_path / "log.mcap")
    mdc.write_mcap(path, names, t, q_log, None, effort, stamps_ns=np.round(t * 1e9).astype(np.int64))
    log = ivdyn.read_joint_states(path, names)
    np.testing.assert_allclose(log["t"] - log["t"][0], t, atol=1e-9)
    assert log["qd"] is None
    kept = np.flatnonzero(np.all(q_log[1:] != q_log[:-1], axis=1)) + 1
    np.testing.assert_allclose((log["tau"] * np.array(sensor["torque_constant"]))[kept], tau[kept],
                               atol=sensor_variants.CURRENT_RES * 8.0)
    assert np.max(np.abs(log["q"] - q)[kept]) <= 0.5 * 2 * math.pi / mdc.ENCODER_COUNTS + 1e-7
    assert sensor_variants.diagnose_args(sensor)[:4] == ["--current-topic", "/joint_states", "--effort", "current"]


def test_wide_motion_sweeps_three_times_the_angles_at_the_same_speeds(tmp_path, monkeypatch):
    """`--motion wide`: amplitudes x3 at a base frequency of 0.13-0.2 Hz instead of 0.4-0.6.
    The three harmonics keep their draws, so over 60 s the RMS angle about the centre is ~3x,
    the RMS speed ~1x (f0 ratio 0.325-0.333 by the uniform draw, times 3: 0.975-1.0) and the
    RMS acceleration ~1/3 (times f0 ratio again: 0.32-0.33); +-10 % for the harmonics' own
    +-10 % frequency draws beating differently over the window."""
    cfgs = {}
    for motion in ("narrow", "wide"):
        monkeypatch.setattr(mcc, "MOTION", motion)
        cfgs[motion] = mcc.random_config("arm", str(tmp_path / motion), joints_seed=(7, 15001))
    assert np.allclose(cfgs["wide"]["amp_scale"], 3.0 * cfgs["narrow"]["amp_scale"])
    t = np.arange(60_000) * 1e-3
    rms = lambda x: np.sqrt(np.mean(x ** 2, axis=0))  # noqa: E731
    ref = {k: mdc.reference(c, 5003, t) for k, c in cfgs.items()}
    centre = np.array(cfgs["wide"]["centres"])
    ratio = [rms(ref["wide"][i] - (centre if i == 0 else 0)) / rms(ref["narrow"][i] - (centre if i == 0 else 0))
             for i in range(3)]
    assert np.all((2.7 < ratio[0]) & (ratio[0] < 3.3)), ratio[0]
    assert np.all((0.88 < ratio[1]) & (ratio[1] < 1.1)), ratio[1]
    assert np.all((0.29 < ratio[2]) & (ratio[2] < 0.37)), ratio[2]


def test_ripple_harmonics_off_the_diagnosis_grid(monkeypatch):
    """`--ripple-n`: a ripple's period is 2 pi / n for n drawn from the given list (harmonics
    the diagnosis's grid 4, 6, 8, 12, 16 does not hold), and a list that is not one of positive
    numbers is refused naming the option."""
    monkeypatch.setattr(mcc, "RIPPLE_N", [3.0, 5.0, 7.0, 10.0, 14.0, 20.0])
    rng = np.random.default_rng(3)
    js, sig = [0, 1, 2], np.full(3, 0.01)
    q = np.zeros((100, 3))
    p = mcc.drive_parameters("torque_ripple", js, [3.0] * 3, sig, q, q, q, rng)
    n = [2 * np.pi / x for x in p["period"]]
    assert all(min(abs(v - h) for h in mcc.RIPPLE_N) < 1e-12 for v in n), n
    for bad in ("4,x", "4,-2"):
        with pytest.raises(SystemExit):
            mcc.main(["--ripple-n", bad, "--out", "/nonexistent"])


def test_load_dependent_friction_stays_below_the_load_it_follows():
    """A load-dependent friction of 5-15 noise std is drawn only on joints whose rigid-body
    torque makes `mu` at most 0.5 (a drive's 1 - efficiency): a joint carrying a few noise std
    of load would need `mu` above 1, a friction larger than its load."""
    rng = np.random.default_rng(7)
    sig = np.full(6, 0.01)
    t = np.linspace(0.0, 10.0, 2001)[:, None]
    # RMS loads of 2, 10, 29, 31, 100 and 1000 noise std
    tau = np.sqrt(2.0) * np.sin(t * np.arange(1, 7)) * sig * np.array([2, 10, 29, 31, 100, 1000])
    picked = set()
    for _ in range(200):
        js = mcc.drive_joints("load_dependent_friction", 6, sig, tau, rng)
        picked.update(js)
        p = mcc.drive_parameters("load_dependent_friction", js, rng.uniform(5.0, 15.0, len(js)), sig,
                                 tau, tau, tau, rng)
        assert all(0.0 < mu <= 0.5 for mu in p["mu"]), (js, p)
    assert picked == {3, 4, 5}, picked

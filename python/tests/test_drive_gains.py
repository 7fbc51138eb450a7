"""``ivdyn.drive_gains`` on a simulated UR5 pair: the logs carry the true torques divided
by the true gains plus white noise as motor currents; the gains gravity loads come out
within 2 % of the truth, and the base joint of a pair that barely moves it is reported as
not identifiable (no value, no std, a reason), not as a number with a small std.
"""
import json
import os

import numpy as np
import pytest

import ivdyn

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
UR5 = os.path.join(ROOT, "fixtures", "ur5.urdf")

GAINS = np.array([12.0, 12.5, 11.0, 8.0, 8.5, 7.5])  # N m/A at the joints
FRICTION = dict(fc=[2, 2, 1.5, 0.6, 0.6, 0.4], fv=[0.8, 0.8, 0.5, 0.2, 0.2, 0.1])
PAYLOAD = dict(payload_mass=2.0, payload_com=[0.01, -0.02, 0.05], payload_inertia=[0.004, 0, 0.004, 0, 0, 0.003])


@pytest.fixture(scope="module")
def ur5():
    return ivdyn.Robot.from_urdf(UR5, base="base_link", tip="tool0")


def with_currents(log, seed):
    """The log with ``current = tau / g + noise`` (0.02 A) instead of its torques."""
    rng = np.random.default_rng(seed)
    i = log["tau"] / GAINS + 0.02 * rng.standard_normal(log["tau"].shape)
    return {"t": log["t"], "q": log["q"], "qd": log["qd"], "current": i}


def pair(ur5, traj=None):
    unloaded = ivdyn.simulate(ur5, seed=11, traj=None if traj is None else traj(11), **FRICTION)["log"]
    loaded = ivdyn.simulate(ur5, seed=12, traj=None if traj is None else traj(12), **FRICTION, **PAYLOAD)["log"]
    return with_currents(unloaded, 1), with_currents(loaded, 2)


def slow_still_base(seed):
    """Slow multi-sine motion (0.03 and 0.06 Hz) of joints 2-6, joint 1 still."""
    rng = np.random.default_rng(seed)
    t = np.arange(0.0, 20.0, 1.0 / 200.0)
    w = 2 * np.pi * 0.03
    q = np.zeros((t.size, 6))
    for j in range(1, 6):
        a, b, c, d = rng.uniform(-0.4, 0.4, 4)
        q[:, j] = a * np.sin(w * t) + b * np.cos(w * t) + c * np.sin(2 * w * t) + d * np.cos(2 * w * t)
    q[:, 1] -= 1.0
    return {"t": t, "q": q}


def test_gravity_loaded_gains_within_two_percent(ur5, tmp_path):
    unloaded, loaded = pair(ur5)
    out = tmp_path / "gains.json"
    rep = ivdyn.drive_gains(ur5, unloaded, loaded, payload_mass=2.0, out_json=out)
    assert json.loads(out.read_text()) == rep
    assert [g["joint"] for g in rep["gains"]] == ur5.joint_names
    for j in (1, 2, 3):
        g = rep["gains"][j]
        assert g["identifiable"] and abs(g["value"] - GAINS[j]) < 0.02 * GAINS[j], g
    assert rep["unloaded"]["current_from"] == "motor current"
    assert rep["payload"]["given"] == ["mass"]
    np.testing.assert_allclose(rep["payload"]["com"], PAYLOAD["payload_com"], atol=2e-3)
    # the COM and inertia given: the same gains, to within their stds
    given = ivdyn.drive_gains(ur5, unloaded, loaded, **PAYLOAD)
    for a, b in zip(rep["gains"][1:4], given["gains"][1:4]):
        assert abs(a["value"] - b["value"]) < 3 * a["std"], (a, b)


def test_still_base_joint_is_not_identifiable(ur5):
    unloaded, loaded = pair(ur5, traj=slow_still_base)
    rep = ivdyn.drive_gains(ur5, unloaded, loaded, payload_mass=2.0)
    base = rep["gains"][0]
    assert base["identifiable"] is False and base["value"] is None and base["std"] is None, base
    assert base["reason"], base
    for j in (1, 2):
        g = rep["gains"][j]
        assert g["identifiable"] and abs(g["value"] - GAINS[j]) < 0.02 * GAINS[j], g


def test_bad_options(ur5):
    unloaded, loaded = pair(ur5)
    with pytest.raises(ValueError, match="payload_mass must be positive"):
        ivdyn.drive_gains(ur5, unloaded, loaded, payload_mass=0.0)
    with pytest.raises(RuntimeError, match="has no drive currents"):
        ivdyn.drive_gains(ur5, {"t": unloaded["t"], "q": unloaded["q"]}, loaded, payload_mass=2.0)

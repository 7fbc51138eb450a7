"""ivdyn.terminal_link / terminal_base, ivdyn.closed_loop and ivdyn.control_experiment
against independent expectations: data made by the NumPy reference (python/reference)
with a known parameter change, the equations of motion of the reference, static
equilibrium, and the payloads the experiments add; plus the error paths.
"""
import os
import sys

import numpy as np
import pytest

import ivdyn

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
sys.path.insert(0, os.path.join(ROOT, "python", "reference"))

from ivdyn_ref import dynamics as dy  # noqa: E402
from ivdyn_ref import model as rm  # noqa: E402

UR5 = os.path.join(ROOT, "fixtures", "ur5.urdf")
# a payload on the paper arm's last link: [m, m cx, m cy, m cz, Ixx, Ixy, Iyy, Ixz, Iyz, Izz]
DX = np.array([0.4, 0.012, -0.008, 0.02, 2e-3, 1e-4, 3e-3, -2e-4, 1e-4, 1e-3])


def reference_data(t, seed, qdd_noise=0.0):
    """Random states of the paper arm and the torques of the arm WITH the payload DX,
    from the NumPy reference: (q, qd, qdd_true, qdd_measured, tau)."""
    rng = np.random.default_rng(seed)
    ref = rm.paper_robot()
    theta = ref.theta.copy()
    theta[50:60] += DX
    q = rng.uniform(-2, 2, (t, 6))
    qd = rng.uniform(-1.5, 1.5, (t, 6))
    qdd = rng.uniform(-5, 5, (t, 6))
    tau = np.array([dy.rnea(ref, q[k], qd[k], qdd[k], theta=theta) for k in range(t)])
    return q, qd, qdd, qdd + qdd_noise * rng.standard_normal((t, 6)), tau


def test_terminal_base_payload_columns():
    """Every joint's row sees the whole payload (10 columns identifiable); the paper's
    rows 5-6 alone do not see its mass (NOTES.md)."""
    robot = ivdyn.Robot.paper()
    all_rows = ivdyn.terminal_base(robot, first_row=0)
    assert all_rows.independent == list(range(10))
    assert all_rows.names[0] == "link6.m"
    wrist = ivdyn.terminal_base(robot, k=5)
    assert 0 not in wrist.independent and wrist.base_count < 10


def test_terminal_link_ls_recovers_exact_payload():
    q, qd, qdd, _, tau = reference_data(300, 1)
    r = ivdyn.terminal_link(ivdyn.Robot.paper(), q, qd, qdd, tau, "ls", first_row=0, p0=1e8, record=[50, 300])
    assert r["names"][:2] == ["link6.m", "link6.m*cx"] and r["method"] == "ls"
    np.testing.assert_allclose(r["theta"], DX, rtol=1e-6, atol=1e-8)
    assert r["trace"].shape == (2, 10) and np.array_equal(r["trace"][1], r["theta"])
    assert r["rows_used"] == 300 * 6 and r["rows_skipped"] == 0
    assert r["P"].shape == (10, 10)


def test_terminal_link_iv_removes_noise_bias():
    """Accelerations with noise: LS is biased (attenuation), IV with the noise-free
    acceleration as the instrument is not (the paper's point)."""
    q, qd, qdd, qdd_m, tau = reference_data(2000, 2, qdd_noise=3.0)
    robot = ivdyn.Robot.paper()
    ls = ivdyn.terminal_link(robot, q, qd, qdd_m, tau, "ls", first_row=0)
    iv = ivdyn.terminal_link(robot, q, qd, qdd_m, tau, "iv", qdd_instr=qdd, first_row=0)
    e_ls, e_iv = abs(ls["theta"][0] - DX[0]), abs(iv["theta"][0] - DX[0])
    assert e_iv < 0.02 * DX[0], iv["theta"][0]
    assert e_ls > 3 * e_iv, (ls["theta"][0], iv["theta"][0])


def test_terminal_link_eq35_instrument_runs_on_the_command():
    q, qd, qdd, _, tau = reference_data(200, 3)
    r = ivdyn.terminal_link(ivdyn.Robot.paper(), q, qd, qdd, tau, "iv", u=tau, first_row=0)
    assert r["rows_used"] == 199 * 6 and np.all(np.isfinite(r["theta"]))


def test_terminal_link_errors():
    robot = ivdyn.Robot.paper()
    q, qd, qdd, _, tau = reference_data(20, 4)
    with pytest.raises(ValueError, match="needs an instrument"):
        ivdyn.terminal_link(robot, q, qd, qdd, tau, "iv")
    with pytest.raises(ValueError, match="not both"):
        ivdyn.terminal_link(robot, q, qd, qdd, tau, "iv", qdd_instr=qdd, u=tau)
    with pytest.raises(ValueError, match="method must be"):
        ivdyn.terminal_link(robot, q, qd, qdd, tau, "ml")
    with pytest.raises(ValueError, match=r"qd must have shape \(20, 6\)"):
        ivdyn.terminal_link(robot, q, qd[:10], qdd, tau, "ls")
    with pytest.raises(ValueError, match=r"tau must have shape \(20, 6\)"):
        ivdyn.terminal_link(robot, q, qd, qdd, tau[:, :5], "ls")
    with pytest.raises(ValueError, match="unknown drive parameter"):
        ivdyn.terminal_link(robot, q, qd, qdd, tau, "ls", drive=["stiction"])
    with pytest.raises(ValueError, match="k < N"):
        ivdyn.terminal_link(robot, q, qd, qdd, tau, "ls", k=6)
    with pytest.raises(RuntimeError, match="column 40 out of range"):
        ivdyn.terminal_link(robot, q, qd, qdd, tau, "ls", columns=[0, 40])
    with pytest.raises(ValueError, match="row_weight"):
        ivdyn.terminal_link(robot, q, qd, qdd, tau, "ls", row_weight=[1.0] * 5)
    bad = tau.copy()
    bad[11, 3] = np.inf
    with pytest.raises(ValueError, match="sample 11"):
        ivdyn.terminal_link(robot, q, qd, qdd, bad, "ls", first_row=0)
    # lists and float32 are converted
    r = ivdyn.terminal_link(robot, q.tolist(), qd.astype(np.float32), qdd, tau, "ls", first_row=0)
    assert r["theta"].shape == (10,)


def smooth_reference(t, dt, q0, amp=0.3):
    tt = np.arange(t) * dt
    w = np.pi
    ph = np.arange(len(q0))
    q = q0 + amp * np.sin(w * tt[:, None] + ph)
    qd = amp * w * np.cos(w * tt[:, None] + ph)
    qdd = -amp * w * w * np.sin(w * tt[:, None] + ph)
    return q, qd, qdd


@pytest.fixture(scope="module")
def ur5_nofriction():
    robot = ivdyn.Robot.from_urdf(UR5, base="base_link", tip="tool0")
    theta = robot.params
    theta[60:] = 0.0  # no drive terms: the simulator's smoothed Coulomb term plays no part
    robot.params = theta
    ref = rm.from_urdf(UR5, base="base_link", tip="tool0")
    ref.set_theta(theta)
    return robot, ref


def test_closed_loop_obeys_the_equations_of_motion(ur5_nofriction):
    """The simulated motion under the held torques satisfies the reference's inverse
    dynamics: rnea_ref(q, qd, qdd) at the true states, with qdd from central differences
    of the true positions, equals the mean of the torques held over the two periods
    around each instant, to the O(dt^2) error of the difference (here ~1e-4 of the torque)."""
    robot, ref = ur5_nofriction
    dt = 1e-3
    q_des, qd_des, qdd_des = smooth_reference(600, dt, np.array([0.0, -1.2, 1.0, -1.0, 0.5, 0.0]))
    r = ivdyn.closed_loop(robot, q_des, qd_des, qdd_des, dt, coulomb_band=0.0)
    q, qd, tau = r["q"], r["qd"], r["tau"]
    ks = range(1, 599, 37)
    scale = np.abs(tau).max()
    for k in ks:
        qdd_k = (q[k + 1] - 2 * q[k] + q[k - 1]) / dt**2
        tau_k = dy.rnea(ref, q[k], qd[k], qdd_k)
        np.testing.assert_allclose(tau_k, 0.5 * (tau[k - 1] + tau[k]), rtol=0, atol=1e-3 * scale)


def test_closed_loop_holds_a_pose_with_gravity_compensation(ur5_nofriction):
    """PD + exact gravity at rest on the reference: a static equilibrium, the torque is
    the reference's gravity torque and nothing moves."""
    robot, ref = ur5_nofriction
    q0 = np.array([0.3, -1.0, 1.2, -0.4, 0.8, 0.1])
    zeros = np.zeros((200, 6))
    r = ivdyn.closed_loop(robot, zeros + q0, zeros, zeros, 1e-3, "pd_gravity")
    np.testing.assert_allclose(r["q"], zeros + q0, rtol=0, atol=1e-10)
    np.testing.assert_allclose(r["tau"][-1], dy.gravity_torque(ref, q0), rtol=0, atol=1e-9)


def test_closed_loop_tracking_and_measurements(ur5_nofriction):
    """Computed torque with the exact model tracks a smooth reference: after the start-up
    transient (poles at -wn = -20/s), the error left by the one-step lag of the
    backward-difference velocity (dt/2 qdd ~ 1.5e-3 rad/s through Kd = 40/s, over Kp =
    400/s^2: ~1.5e-4 rad) is below 5e-4 rad. Measurements: 16-bit encoders give
    positions on the 2 pi / 2^16 grid; id_qdd is the central difference of q_meas."""
    robot, _ = ur5_nofriction
    dt = 1e-3
    q_des, qd_des, qdd_des = smooth_reference(1500, dt, np.array([0.0, -1.2, 1.0, -1.0, 0.5, 0.0]))
    r = ivdyn.closed_loop(robot, q_des, qd_des, qdd_des, dt)
    assert np.abs(r["q"] - q_des)[500:].max() < 5e-4
    pd = ivdyn.closed_loop(robot, q_des, qd_des, qdd_des, dt, "pd")
    assert np.abs(pd["q"] - q_des)[500:].max() > 10 * np.abs(r["q"] - q_des)[500:].max()
    e = ivdyn.closed_loop(robot, q_des[:50], qd_des[:50], qdd_des[:50], dt, encoder_bits=16)
    res = 2 * np.pi / 2**16
    np.testing.assert_allclose(e["q_meas"] / res, np.round(e["q_meas"] / res), rtol=0, atol=1e-6)
    qm = e["q_meas"]
    # sample j is the instant t_{j+1} (one sample late); the last needs q_meas[50], not kept
    np.testing.assert_allclose(e["id_t"], (np.arange(49) + 1) * dt, rtol=1e-12)
    np.testing.assert_allclose(e["id_qdd"][:-1], (qm[2:] - 2 * qm[1:-1] + qm[:-2]) / dt**2, rtol=1e-9, atol=1e-6)
    assert e["id_t"].shape == (49,) and e["saturated"].shape == (50,)


def test_closed_loop_saturation_and_errors(ur5_nofriction):
    robot, _ = ur5_nofriction
    q, qd, qdd = smooth_reference(100, 1e-3, np.zeros(6))
    r = ivdyn.closed_loop(robot, q, qd, qdd, 1e-3, tau_limit=[1.0] * 6)
    assert r["saturated"].all() and np.abs(r["tau"]).max() <= 1.0 + 1e-12
    with pytest.raises(ValueError, match="controller must be"):
        ivdyn.closed_loop(robot, q, qd, qdd, 1e-3, "lqr")
    with pytest.raises(ValueError, match="dt must be finite and > 0"):
        ivdyn.closed_loop(robot, q, qd, qdd, 0.0)
    with pytest.raises(ValueError, match=r"qdd_des must have shape \(100, 6\)"):
        ivdyn.closed_loop(robot, q, qd, qdd[:50], 1e-3)
    with pytest.raises(ValueError, match="q0 must have shape"):
        ivdyn.closed_loop(robot, q, qd, qdd, 1e-3, q0=[0.0] * 5)
    with pytest.raises(ValueError, match="model has 7 joints"):
        ivdyn.closed_loop(robot, q, qd, qdd, 1e-3, model=ivdyn.Robot.from_dh([0.1] * 7, [0] * 7, [0] * 7))
    bad = q.copy()
    bad[30, 1] = np.nan
    with pytest.raises(ValueError, match="sample 30"):
        ivdyn.closed_loop(robot, bad, qd, qdd, 1e-3)


def test_control_experiment_estimates_the_grasped_payload():
    """The paper's arm grasps 0.25 kg (a 4 cm cube at (0.02, 0, 0.03) m in the last link,
    docs/control.md) at t = 2 s: the online IV estimate of its mass ends within 2 %, the
    controller switches to it, and tracking with it is far better than without."""
    est = ivdyn.control_experiment("ct_estimated", duration=5.0)
    nom = ivdyn.control_experiment("ct_nominal", duration=5.0)
    m = est["estimates"]["theta"][-1][est["mass_index"]]
    assert est["payload_mass"] == 0.25 and abs(m - 0.25) < 0.02 * 0.25
    assert est["switch_time"] is not None and 2.0 < est["switch_time"] < 4.5
    late = est["t_all"] >= est["switch_time"] + 0.5
    assert np.abs(est["err"][late]).mean() < 0.2 * np.abs(nom["err"][late]).mean()
    assert est["q"].shape == (len(est["t"]), 6)


def test_control_experiment_errors():
    with pytest.raises(ValueError, match="scheme must be one of"):
        ivdyn.control_experiment("mpc")
    with pytest.raises(ValueError, match="needs urdf"):
        ivdyn.control_experiment("pd", robot="panda")
    with pytest.raises(ValueError, match="robot must be"):
        ivdyn.control_experiment("pd", robot="kuka")
    with pytest.raises(ValueError, match="instrument must be"):
        ivdyn.control_experiment("pd", instrument="oracle")
    with pytest.raises(ValueError, match="duration"):
        ivdyn.control_experiment("pd", duration=-1.0)

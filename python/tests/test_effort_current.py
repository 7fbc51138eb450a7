"""Effort given as motor current from Python (``effort``, ``torque_constant``,
``gear_ratio``, ``motor_constant``, ``current_topic``): a simulated UR5 torque log divided
by known torque constants identifies as the torque log does, from a log dict and from a
CSV file with ``<joint>.i`` columns (the command line reads the same file to the same
report); the errors name the option and the joint.
"""
import json
import math
import os
import subprocess

import numpy as np
import pytest

import ivdyn

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
UR5 = os.path.join(ROOT, "fixtures", "ur5.urdf")
K_T = np.array([13.5, 13.5, 9.3, 4.8, 4.8, 4.8])  # N m/A at the joints


@pytest.fixture(scope="module")
def ur5():
    return ivdyn.Robot.from_urdf(UR5, base="base_link", tip="tool0")


@pytest.fixture(scope="module")
def sim(ur5):
    return ivdyn.simulate(ur5, duration=8, seed=3, noise=0.05, fc=[2, 2, 1.5, 0.6, 0.6, 0.4],
                          fv=[0.8, 0.8, 0.5, 0.2, 0.2, 0.1])["log"]


def currents(log):
    return {"t": log["t"], "q": log["q"], "qd": log["qd"], "current": log["tau"] / K_T}


def values(rep):
    return np.array([b["value"] for b in rep["base"]])


def test_log_dict_currents_identify_as_the_torques(ur5, sim):
    by_tau = values(ivdyn.identify(ur5, sim))
    by_i = values(ivdyn.identify(ur5, currents(sim), torque_constant=K_T))
    np.testing.assert_allclose(by_i, by_tau, rtol=1e-9, atol=1e-12)
    # by joint name, and as gear ratio x motor constant
    named = dict(zip(reversed(ur5.joint_names), reversed(K_T.tolist())))
    np.testing.assert_allclose(values(ivdyn.identify(ur5, currents(sim), torque_constant=named)), by_i, rtol=1e-12)
    geared = ivdyn.identify(ur5, currents(sim), gear_ratio=100.0, motor_constant=K_T / 100.0)
    np.testing.assert_allclose(values(geared), by_i, rtol=1e-9, atol=1e-12)
    # both efforts in the log: auto takes the torque, effort="current" the current
    both = dict(currents(sim), tau=np.zeros_like(sim["tau"]) + 1.0)
    np.testing.assert_allclose(values(ivdyn.identify(ur5, both, torque_constant=K_T, effort="current")), by_i,
                               rtol=1e-12)


def test_csv_currents_python_and_command_line_agree(ur5, sim, tmp_path, ivdyn_bin):
    n = ur5.dof
    cols = ["t"] + [f"{j}.q" for j in ur5.joint_names] + [f"{j}.i" for j in ur5.joint_names]
    data = np.column_stack([sim["t"], sim["q"], sim["tau"] / K_T])
    path = tmp_path / "i.csv"
    np.savetxt(path, data, delimiter=",", header=",".join(cols), comments="", fmt="%.17g")
    back = ivdyn.read_joint_states(path, ur5)
    assert back["tau"] is None and back["current"].shape == (len(sim["t"]), n)
    kt = ",".join(repr(float(k)) for k in K_T)
    rep = ivdyn.identify(ur5, path, torque_constant=kt)
    js = tmp_path / "cli.json"
    r = subprocess.run([ivdyn_bin, "--quiet", "identify", "--urdf", UR5, "--base", "base_link", "--tip", "tool0",
                        "--log", str(path), "--torque-constant", kt, "--json", str(js)],
                       capture_output=True, text=True)
    assert r.returncode == 0, r.stderr
    with open(js) as f:
        ref = json.load(f)
    for a, b in zip(rep["base"], ref["base"]):
        assert math.isclose(a["value"], b["value"], rel_tol=1e-9, abs_tol=1e-12), (a, b)
    # the same file read as torques gives the same fit
    by_tau = values(ivdyn.identify(ur5, {"t": sim["t"], "q": sim["q"], "tau": sim["tau"]}))
    np.testing.assert_allclose(values(rep), by_tau, rtol=1e-8, atol=1e-10)


def test_errors_name_the_option_and_the_joint(ur5, sim):
    log = currents(sim)
    with pytest.raises(ValueError, match="torque_constant is needed"):
        ivdyn.identify(ur5, log)
    with pytest.raises(ValueError, match="5 values for the 6 joints"):
        ivdyn.payload(ur5, log, torque_constant=K_T[:5])
    named = dict(zip(ur5.joint_names, K_T.tolist()))
    del named["wrist_2_joint"]
    with pytest.raises(ValueError, match="no value for joint 'wrist_2_joint'"):
        ivdyn.diagnose(ur5, log, torque_constant=named, report=False)
    with pytest.raises(ValueError, match="effort is 'current'"):
        ivdyn.identify(ur5, sim, effort="current", torque_constant=K_T)
    with pytest.raises(ValueError, match="effort must be"):
        ivdyn.identify(ur5, sim, effort="amps")


def test_a_motor_wired_the_other_way_is_an_error_until_its_torque_constant_is_negative(ur5, sim):
    """The elbow's current logged with the opposite sign (a motor wired the other way):
    ``identify`` stops naming the joint (``app::effort_check``; before, it fitted the
    reversed torque, and its Coulomb-shape choice on the spoiled fit hid the reversal from a
    check after it); the torque constant given negative, as the error says, identifies as
    the torque log does."""
    cur = currents(sim)
    cur["current"] = cur["current"].copy()
    cur["current"][:, 2] *= -1
    with pytest.raises(ValueError, match="joint 'elbow_joint': the logged effort runs opposite"):
        ivdyn.identify(ur5, cur, torque_constant=K_T)
    k_t = K_T.copy()
    k_t[2] = -k_t[2]
    np.testing.assert_allclose(values(ivdyn.identify(ur5, cur, torque_constant=k_t)), values(ivdyn.identify(ur5, sim)),
                               rtol=1e-9, atol=1e-12)

"""The NumPy reference against Pinocchio (pin 4.1) on UR5, Panda (arm), the paper's
robot and the hand-written test arm, plus internal identities and loader checks.

Run from the repo root: .venv/bin/python -m pytest python/reference
"""
import math
import os
import sys

import numpy as np
import pytest

sys.path.insert(0, os.path.dirname(os.path.dirname(os.path.abspath(__file__))))

from ivdyn_ref import dynamics as dy  # noqa: E402
from ivdyn_ref import model as rm  # noqa: E402
from ivdyn_ref import robots  # noqa: E402

import pinocchio as pin  # noqa: E402  (a hard requirement: the suite must not skip)
from ivdyn_ref import pinref  # noqa: E402
from ivdyn_ref.pinref import rel_err  # noqa: E402

TOL = 1e-10
N_STATES = 20
ROBOTS = list(robots.SPECS)


def random_state(ref, rng):
    lo, hi = ref.limits()
    lo = np.where(np.isfinite(lo), lo, -math.pi)
    hi = np.where(np.isfinite(hi), hi, math.pi)
    q = rng.uniform(lo, hi)
    qd = rng.uniform(-2, 2, ref.n)
    qd[rng.uniform(size=ref.n) < 0.1] = 0.0
    qdd = rng.uniform(-2, 2, ref.n)
    return q, qd, qdd


def random_drive(n, rng):
    return np.column_stack([rng.uniform(0.1, 2, n), rng.uniform(0.01, 0.5, n),
                            rng.uniform(0, 0.1, n), rng.uniform(-0.5, 0.5, n)])


@pytest.fixture(scope="module", params=ROBOTS)
def robot(request):
    name = request.param
    ref, pm = robots.build(name)
    pinref.joint_ids(pm, ref.joint_names)
    return name, ref, pm, pinref.PinEval(pm)


def states(ref, seed=123):
    rng = np.random.default_rng(seed)
    return [random_state(ref, rng) for _ in range(N_STATES)]


# ----------------------------------------------------------------- model vs Pinocchio
def test_model_matches_pinocchio(robot):
    name, ref, pm, _ = robot
    assert pm.nv == ref.n
    np.testing.assert_allclose(ref.links.ravel(), pinref.theta_rigid(pm), rtol=0, atol=1e-13)
    for k, j in enumerate(ref.joints):
        P = pm.jointPlacements[k + 1]
        np.testing.assert_allclose(j.R0, P.rotation, atol=1e-14)
        np.testing.assert_allclose(j.p0, P.translation, atol=1e-14)
    np.testing.assert_allclose(pm.gravity.linear, ref.gravity)


# ----------------------------------------------------------------- dynamics vs Pinocchio
def test_rnea(robot):
    _, ref, _, ev = robot
    for q, qd, qdd in states(ref):
        assert rel_err(dy.rnea(ref, q, qd, qdd, drive=False), ev.rnea(q, qd, qdd)) < TOL


def test_regressor(robot):
    _, ref, _, ev = robot
    n = ref.n
    for q, qd, qdd in states(ref):
        Y = dy.regressor(ref, q, qd, qdd)
        assert Y.shape == (n, 14 * n)
        assert rel_err(Y[:, :10 * n], ev.regressor(q, qd, qdd)) < TOL


def test_mass_matrix(robot):
    _, ref, _, ev = robot
    for q, _, _ in states(ref):
        assert rel_err(dy.mass_matrix(ref, q), ev.crba(q)) < TOL


def test_forward_dynamics(robot):
    _, ref, _, ev = robot
    rng = np.random.default_rng(7)
    for q, qd, _ in states(ref):
        tau = rng.uniform(-5, 5, ref.n)
        theta = np.concatenate([ref.links.ravel(), np.zeros(4 * ref.n)])  # rigid only
        assert rel_err(dy.forward_dynamics(ref, q, qd, tau, theta), ev.aba(q, qd, tau)) < TOL


def test_gravity(robot):
    _, ref, _, ev = robot
    for q, _, _ in states(ref):
        assert rel_err(dy.gravity_torque(ref, q), ev.gravity(q)) < TOL


def test_energies(robot):
    _, ref, _, ev = robot
    for q, qd, _ in states(ref):
        assert rel_err(dy.kinetic_energy(ref, q, qd), ev.kinetic_energy(q, qd)) < TOL
        assert rel_err(dy.potential_energy(ref, q), ev.potential_energy(q)) < TOL
        # T = 1/2 qd' M qd
        M = dy.mass_matrix(ref, q, armature=False)
        assert rel_err(dy.kinetic_energy(ref, q, qd), 0.5 * qd @ M @ qd) < TOL


def test_pinocchio_armature(robot):
    """Pinocchio 4 adds model.armature to rnea, crba and aba: same as our ia."""
    _, ref, pm, _ = robot
    rng = np.random.default_rng(11)
    drive = np.zeros((ref.n, 4))
    drive[:, 2] = rng.uniform(0, 0.1, ref.n)
    theta = np.concatenate([ref.links.ravel(), drive.ravel()])
    pa = pm.copy()
    pa.armature[:] = drive[:, 2]
    ev = pinref.PinEval(pa)
    for q, qd, qdd in states(ref)[:5]:
        assert rel_err(dy.rnea(ref, q, qd, qdd, theta), ev.rnea(q, qd, qdd)) < TOL
        assert rel_err(dy.mass_matrix(ref, q, theta), ev.crba(q)) < TOL
        tau = rng.uniform(-5, 5, ref.n)
        assert rel_err(dy.forward_dynamics(ref, q, qd, tau, theta), ev.aba(q, qd, tau)) < TOL


# ----------------------------------------------------------------- internal identities
def test_regressor_times_theta_is_rnea_with_drive(robot):
    _, ref, _, _ = robot
    rng = np.random.default_rng(5)
    drive = random_drive(ref.n, rng)
    theta = np.concatenate([ref.links.ravel(), drive.ravel()])
    for q, qd, qdd in states(ref):
        Y = dy.regressor(ref, q, qd, qdd)
        assert rel_err(Y @ theta, dy.rnea(ref, q, qd, qdd, theta)) < TOL
        # drive columns: only row i, [sign(qd_i), qd_i, qdd_i, 1]
        D = Y[:, 10 * ref.n:]
        for i in range(ref.n):
            row = np.zeros(4 * ref.n)
            row[4 * i:4 * i + 4] = [np.sign(qd[i]), qd[i], qdd[i], 1.0]
            np.testing.assert_array_equal(D[i], row)


def test_mass_matrix_spd_and_fd_inverse(robot):
    _, ref, _, _ = robot
    rng = np.random.default_rng(6)
    drive = random_drive(ref.n, rng)
    theta = np.concatenate([ref.links.ravel(), drive.ravel()])
    for q, qd, _ in states(ref):
        M = dy.mass_matrix(ref, q, theta)
        np.testing.assert_allclose(M, M.T, rtol=0, atol=1e-12 * max(1.0, np.abs(M).max()))
        assert np.linalg.eigvalsh(0.5 * (M + M.T)).min() > 0
        tau = rng.uniform(-5, 5, ref.n)
        qdd = dy.forward_dynamics(ref, q, qd, tau, theta)
        assert rel_err(dy.rnea(ref, q, qd, qdd, theta), tau) < TOL


def test_sign_zero_is_zero():
    ref = rm.paper_robot()
    z = np.zeros(6)
    Y = dy.regressor(ref, z, z, z)
    assert np.all(Y[:, 60::4] == 0.0)
    np.testing.assert_allclose(dy.rnea(ref, z, z, z), dy.gravity_torque(ref, z), atol=1e-15)


# ----------------------------------------------------------------- conversions, loader
def test_inertial_round_trip():
    rng = np.random.default_rng(3)
    for _ in range(10):
        m = rng.uniform(0.1, 3)
        com = rng.uniform(-0.2, 0.2, 3)
        rpy = rng.uniform(-1, 1, 3)
        A = rng.normal(size=(3, 3))
        I = A @ A.T * 0.01 + 0.001 * np.eye(3)
        phi = rm.inertial_from_urdf(m, com, rpy, I[0, 0], I[0, 1], I[0, 2], I[1, 1], I[1, 2],
                                    I[2, 2])
        u = rm.inertial_to_urdf(phi)
        phi2 = rm.inertial_from_urdf(u["mass"], u["com_xyz"], u["rpy"], u["ixx"], u["ixy"],
                                     u["ixz"], u["iyy"], u["iyz"], u["izz"])
        np.testing.assert_allclose(phi2, phi, rtol=1e-13, atol=1e-15)
        R = rm.rpy_to_matrix(rpy)
        Ic = R @ I @ R.T
        np.testing.assert_allclose(
            [u["ixx"], u["ixy"], u["ixz"], u["iyy"], u["iyz"], u["izz"]],
            [Ic[0, 0], Ic[0, 1], Ic[0, 2], Ic[1, 1], Ic[1, 2], Ic[2, 2]], atol=1e-15)
        np.testing.assert_allclose(u["com_xyz"], com, atol=1e-15)


def test_default_base_and_tip():
    ref = rm.from_urdf(robots.urdf_source("ur5"))  # root = world, only movable branch
    assert ref.base == "world" and ref.n == 6 and ref.tip == "wrist_3_link"
    ref2, _ = robots.build("ur5")
    np.testing.assert_allclose(ref.links, ref2.links, atol=1e-15)


def _write(tmp_path, text):
    p = tmp_path / "r.urdf"
    p.write_text(text)
    return str(p)


def test_loader_errors(tmp_path):
    src = robots.TEST_ARM_URDF
    # branch with movable joints and no tip
    with pytest.raises(ValueError, match="side_joint"):
        rm.from_urdf(_write(tmp_path, src), base="base_link")
    # floating joint on the chain
    bad = src.replace('<joint name="j4" type="revolute">', '<joint name="j4" type="floating">')
    with pytest.raises(ValueError, match="j4"):
        rm.from_urdf(_write(tmp_path, bad), base="base_link", tip="tool")
    bad = src.replace('<joint name="j4" type="revolute">', '<joint name="j4" type="planar">')
    with pytest.raises(ValueError, match="j4"):
        rm.from_urdf(_write(tmp_path, bad), base="base_link", tip="tool")
    bad = src.replace('<joint name="side_joint" type="revolute">',
                      '<joint name="side_joint" type="floating">')
    with pytest.raises(ValueError, match="side_joint"):
        rm.from_urdf(_write(tmp_path, bad), base="base_link", tip="tool")
    # mimic joint on the chain
    bad = src.replace('<axis xyz="0.36 -0.48 0.8"/>',
                      '<axis xyz="0.36 -0.48 0.8"/><mimic joint="j1"/>')
    with pytest.raises(ValueError, match="j4"):
        rm.from_urdf(_write(tmp_path, bad), base="base_link", tip="tool")
    # the side branch as tip instead: chain j1, j2, side_joint
    ref = rm.from_urdf(_write(tmp_path, src), base="base_link", tip="side_link")
    assert ref.joint_names == ["j1", "j2", "side_joint"]
    assert ref.locked_joints == ["j3", "j4", "j5"]


# ----------------------------------------------------------------- committed fixtures
FIXTURES = os.path.join(os.path.dirname(__file__), "..", "..", "..", "fixtures")


@pytest.mark.parametrize("name", ROBOTS)
def test_fixture_consistent_with_reference(name):
    import json

    fn = os.path.join(FIXTURES, f"dyn_{name}.json")
    assert os.path.exists(fn), f"{fn} missing: run `make fixtures`"
    with open(fn) as f:
        fx = json.load(f)
    spec = fx["model"]
    if spec["kind"] == "dh":
        ref = rm.paper_robot()
    else:
        ref = rm.from_urdf(os.path.join(FIXTURES, spec["file"]), spec["base"], spec["tip"])
        assert sorted(ref.locked_joints) == sorted(spec["locked_joints"])
    assert ref.joint_names == fx["joint_names"]
    n = ref.n
    theta = np.array(fx["theta"])
    np.testing.assert_allclose(theta[:10 * n], ref.links.ravel(), rtol=0, atol=1e-15)
    for s in fx["samples"]:
        q, qd, qdd = (np.array(s[k]) for k in ("q", "qd", "qdd"))
        Y = dy.regressor(ref, q, qd, qdd)
        assert rel_err(Y, np.array(s["Y"])) < TOL
        assert rel_err(Y[:, :10 * n], np.array(s["Y_rigid"])) < TOL
        assert rel_err(dy.rnea(ref, q, qd, qdd, theta), np.array(s["tau"])) < TOL
        assert rel_err(np.array(s["Y"]) @ theta, np.array(s["tau"])) < TOL
        assert rel_err(dy.mass_matrix(ref, q, theta), np.array(s["M"])) < TOL
        assert rel_err(dy.forward_dynamics(ref, q, qd, np.array(s["tau_fd"]), theta),
                       np.array(s["qdd_fd"])) < TOL

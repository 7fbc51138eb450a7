"""The `ivdyn` Python package (installed, native module built by maturin) against the
fixtures (Pinocchio values, fixtures/MANIFEST.md) and the independent NumPy reference
(python/reference/ivdyn_ref) on UR5, the Panda arm, the paper's robot and the test arm;
batched vs per-sample; input conversion; error paths.

Run from the repo root after `pip install .`:  .venv/bin/python -m pytest -q python/tests
"""
import copy
import json
import math
import os
import sys
import threading

import numpy as np
import pytest

import ivdyn

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
FIXTURES = os.path.join(ROOT, "fixtures")
sys.path.insert(0, os.path.join(ROOT, "python", "reference"))

from ivdyn_ref import dynamics as dy  # noqa: E402
from ivdyn_ref import model as rm  # noqa: E402

TOL = 1e-10
ROBOTS = ["ur5", "panda7", "paper", "test_arm"]


def rel(actual, expected):
    """|a - b| / max(|b|, 1) (2-norm), as the fixture generator measures it."""
    actual, expected = np.asarray(actual, float), np.asarray(expected, float)
    assert actual.shape == expected.shape, (actual.shape, expected.shape)
    return np.linalg.norm(actual - expected) / max(np.linalg.norm(expected), 1.0)


def load_fixture(name):
    with open(os.path.join(FIXTURES, f"dyn_{name}.json")) as f:
        return json.load(f)


def build(name):
    """(ivdyn.Robot, reference ChainModel, fixture), both models with the fixture's theta."""
    fx = load_fixture(name)
    m = fx["model"]
    if m["kind"] == "urdf":
        path = os.path.join(FIXTURES, m["file"])
        # the reference and Pinocchio's reduced model fuse the bodies below the tip too
        robot = ivdyn.Robot.from_urdf(path, base=m["base"], tip=m["tip"], fuse_beyond_tip=True)
        ref = rm.from_urdf(path, base=m["base"], tip=m["tip"])
    else:
        robot = ivdyn.Robot.paper()
        ref = rm.paper_robot()
    theta = np.array(fx["theta"])
    robot.params = theta
    ref.set_theta(theta)
    return robot, ref, fx


@pytest.fixture(scope="module", params=ROBOTS)
def case(request):
    return (request.param,) + build(request.param)


def stack(fx, key):
    return np.array([s[key] for s in fx["samples"]])


def random_states(robot, ref, t, seed):
    rng = np.random.default_rng(seed)
    lo, hi = ref.limits()
    lo = np.where(np.isfinite(lo), lo, -math.pi)
    hi = np.where(np.isfinite(hi), hi, math.pi)
    n = robot.dof
    q = rng.uniform(lo, hi, size=(t, n))
    qd = rng.uniform(-2, 2, size=(t, n))
    qd[rng.uniform(size=(t, n)) < 0.1] = 0.0
    qdd = rng.uniform(-2, 2, size=(t, n))
    return q, qd, qdd


# ----------------------------------------------------------------- the model
def test_description_matches_fixture(case):
    name, robot, ref, fx = case
    n = len(fx["joint_names"])
    assert robot.dof == n
    assert robot.num_params == 14 * n
    if fx["model"]["kind"] == "urdf":
        assert robot.joint_names == fx["joint_names"]
        assert sorted(robot.locked_joints) == sorted(fx["model"]["locked_joints"])
        assert robot.base_link == fx["model"]["base"]
        assert robot.tip_link == fx["model"]["tip"]
    else:
        assert robot.joint_names == [f"joint{i}" for i in range(1, 7)]
    assert len(robot.link_names) == n
    names = robot.param_names
    assert len(names) == 14 * n
    assert names[0] == f"{robot.link_names[0]}.m"
    assert names[10 * n - 1] == f"{robot.link_names[-1]}.Izz"
    assert names[10 * n] == f"{robot.joint_names[0]}.fc"
    assert names[-1] == f"{robot.joint_names[-1]}.tau0"


def test_loaded_params_are_pinocchios(case):
    name, _, _, fx = case
    m = fx["model"]
    robot = (ivdyn.Robot.from_urdf(os.path.join(FIXTURES, m["file"]), m["base"], m["tip"], fuse_beyond_tip=True)
             if m["kind"] == "urdf" else ivdyn.Robot.paper())
    n = robot.dof
    theta = np.array(fx["theta"])
    assert rel(robot.params[:10 * n], theta[:10 * n]) < 1e-12
    if m["kind"] == "dh":  # the paper's drive column: fc = F
        assert rel(robot.params, theta) < 1e-12


def test_params_roundtrip_and_copy(case):
    _, robot, _, fx = case
    r2 = robot.copy()
    theta = robot.params
    assert theta.shape == (robot.num_params,) and theta.dtype == np.float64
    theta2 = theta.copy()
    theta2[-1] += 1.0
    r2.params = theta2
    assert np.array_equal(r2.params, theta2)
    assert np.array_equal(robot.params, theta)  # the original is untouched
    r3 = copy.deepcopy(robot)
    assert np.array_equal(r3.params, theta)
    # the returned array is a copy: writing it changes nothing
    p = robot.params
    p[:] = 0.0
    assert np.array_equal(robot.params, theta)
    assert "Robot(" in repr(robot)


# ----------------------------------------------------------------- against the fixtures
def test_fixture_values(case):
    """All 16 samples in one batched call per quantity, to 1e-10 relative (per sample)."""
    name, robot, _, fx = case
    n = robot.dof
    q, qd, qdd = stack(fx, "q"), stack(fx, "qd"), stack(fx, "qdd")
    rigid = robot.copy()
    theta = robot.params
    theta[10 * n:] = 0.0
    rigid.params = theta
    got = {
        "tau": robot.rnea(q, qd, qdd),
        "tau_rigid": rigid.rnea(q, qd, qdd),
        "Y": robot.regressor(q, qd, qdd),
        "Y_rigid": robot.regressor(q, qd, qdd, rigid_only=True),
        "M": robot.mass_matrix(q),
        "M_rigid": rigid.mass_matrix(q),
        "g": robot.gravity(q),
        "qdd_fd": robot.forward_dynamics(q, qd, stack(fx, "tau_fd")),
        "qdd_fd_rigid": rigid.forward_dynamics(q, qd, stack(fx, "tau_fd")),
    }
    assert got["Y"].shape == (16, n, 14 * n)
    assert got["Y_rigid"].shape == (16, n, 10 * n)
    assert got["M"].shape == (16, n, n)
    for key, val in got.items():
        want = stack(fx, key)
        worst = max(rel(val[k], want[k]) for k in range(len(want)))
        assert worst < TOL, f"{name} {key}: rel error {worst:.2e}"


def test_fixture_values_per_sample(case):
    name, robot, _, fx = case
    for k, s in enumerate(fx["samples"]):
        q, qd, qdd = s["q"], s["qd"], s["qdd"]  # plain lists
        assert rel(robot.rnea(q, qd, qdd), s["tau"]) < TOL, (name, k)
        assert rel(robot.regressor(q, qd, qdd), s["Y"]) < TOL, (name, k)
        assert rel(robot.regressor(q, qd, qdd, rigid_only=True), s["Y_rigid"]) < TOL, (name, k)
        assert rel(robot.mass_matrix(q), s["M"]) < TOL, (name, k)
        assert rel(robot.gravity(q), s["g"]) < TOL, (name, k)
        assert rel(robot.forward_dynamics(q, qd, s["tau_fd"]), s["qdd_fd"]) < TOL, (name, k)


# ----------------------------------------------------------------- against the NumPy reference
@pytest.fixture(scope="module")
def ref_case(case):
    """The fixture robot with random drive parameters, and 40 random states."""
    name, robot, ref, _ = case
    n = robot.dof
    rng = np.random.default_rng(7)
    theta = robot.params
    theta[10 * n:] = np.column_stack([rng.uniform(0.1, 2, n), rng.uniform(0.01, 0.5, n),
                                      rng.uniform(0, 0.1, n), rng.uniform(-0.5, 0.5, n)]).ravel()
    robot = robot.copy()
    robot.params = theta
    ref = copy.deepcopy(ref)
    ref.set_theta(theta)
    return name, robot, ref, random_states(robot, ref, 40, seed=11)


def _check_ref(name, what, got, want):
    e = rel(got, want)
    assert e < TOL, f"{name} {what}: rel error {e:.2e}"


def test_rnea_vs_reference(ref_case):
    name, robot, ref, (q, qd, qdd) = ref_case
    tau = robot.rnea(q, qd, qdd)
    for k in range(len(q)):
        _check_ref(name, "rnea", tau[k], dy.rnea(ref, q[k], qd[k], qdd[k]))


def test_gravity_vs_reference(ref_case):
    name, robot, ref, (q, _, _) = ref_case
    g = robot.gravity(q)
    for k in range(len(q)):
        _check_ref(name, "gravity", g[k], dy.gravity_torque(ref, q[k]))


def test_regressor_vs_reference(ref_case):
    name, robot, ref, (q, qd, qdd) = ref_case
    n = robot.dof
    y = robot.regressor(q, qd, qdd)
    yr = robot.regressor(q, qd, qdd, rigid_only=True)
    assert np.array_equal(yr, y[:, :, :10 * n])
    for k in range(len(q)):
        _check_ref(name, "regressor", y[k], dy.regressor(ref, q[k], qd[k], qdd[k]))
    # Y theta == tau
    tau = robot.rnea(q, qd, qdd)
    assert rel(y @ robot.params, tau) < TOL


def test_mass_matrix_vs_reference(ref_case):
    name, robot, ref, (q, _, _) = ref_case
    m = robot.mass_matrix(q)
    assert np.array_equal(m, np.transpose(m, (0, 2, 1)))
    for k in range(len(q)):
        _check_ref(name, "mass_matrix", m[k], dy.mass_matrix(ref, q[k]))


def test_forward_dynamics_vs_reference(ref_case):
    name, robot, ref, (q, qd, qdd) = ref_case
    tau = robot.rnea(q, qd, qdd)
    qdd2 = robot.forward_dynamics(q, qd, tau)
    for k in range(len(q)):
        _check_ref(name, "forward_dynamics", qdd2[k], dy.forward_dynamics(ref, q[k], qd[k], tau[k]))
    # the round trip (through M^-1, so a looser bound: conditioning of M)
    assert rel(qdd2, qdd) < 1e-8


def test_from_dh_matches_paper():
    """The paper's DH table through from_dh, with the paper's parameters, is the paper robot."""
    rows = rm.paper_dh_rows()
    a, d, alpha = (np.array(c) for c in zip(*rows))
    robot = ivdyn.Robot.from_dh(a, d, alpha)
    assert robot.dof == 6 and robot.joint_names == [f"joint{i}" for i in range(1, 7)]
    assert np.all(robot.params == 0.0)
    paper = ivdyn.Robot.paper()
    robot.params = paper.params
    ref = rm.paper_robot()
    q, qd, qdd = random_states(robot, ref, 20, seed=3)
    assert rel(robot.rnea(q, qd, qdd), paper.rnea(q, qd, qdd)) < 1e-14
    assert rel(robot.regressor(q, qd, qdd), paper.regressor(q, qd, qdd)) < 1e-14
    for k in range(len(q)):
        assert rel(robot.rnea(q[k], qd[k], qdd[k]), dy.rnea(ref, q[k], qd[k], qdd[k])) < TOL


def test_from_dh_offset():
    """offset shifts the joint angle: q + offset with zero offset == q with offset."""
    a, d, alpha, off = [0.3, 0.2, 0.0], [0.1, 0.0, 0.05], [1.2, -0.4, 0.0], [0.3, -0.7, 0.2]
    r0 = ivdyn.Robot.from_dh(a, d, alpha)
    r1 = ivdyn.Robot.from_dh(a, d, alpha, offset=off)
    theta = np.random.default_rng(0).uniform(0.1, 1.0, r0.num_params)
    r0.params = theta
    r1.params = theta
    q = np.random.default_rng(1).uniform(-2, 2, (10, 3))
    assert rel(r1.gravity(q), r0.gravity(q + off)) < 1e-12


# ----------------------------------------------------------------- batched == per sample
def test_batched_equals_per_sample(ref_case):
    name, robot, _, (q, qd, qdd) = ref_case
    tau = robot.rnea(q, qd, qdd)
    g = robot.gravity(q)
    y = robot.regressor(q, qd, qdd)
    yr = robot.regressor(q, qd, qdd, rigid_only=True)
    m = robot.mass_matrix(q)
    fd = robot.forward_dynamics(q, qd, tau)
    for k in range(len(q)):
        assert np.array_equal(robot.rnea(q[k], qd[k], qdd[k]), tau[k])
        assert np.array_equal(robot.gravity(q[k]), g[k])
        assert np.array_equal(robot.regressor(q[k], qd[k], qdd[k]), y[k])
        assert np.array_equal(robot.regressor(q[k], qd[k], qdd[k], rigid_only=True), yr[k])
        assert np.array_equal(robot.mass_matrix(q[k]), m[k])
        assert np.array_equal(robot.forward_dynamics(q[k], qd[k], tau[k]), fd[k])


def test_large_batch_multithreaded_equals_small_batches():
    """Enough samples for several threads: identical to one-sample-at-a-time results."""
    robot, ref, _ = build("ur5")
    q, qd, qdd = random_states(robot, ref, 3001, seed=5)
    y = robot.regressor(q, qd, qdd, rigid_only=True)
    tau = robot.rnea(q, qd, qdd)
    assert y.shape == (3001, 6, 60) and tau.shape == (3001, 6)
    for k in range(0, 3001, 97):
        assert np.array_equal(y[k], robot.regressor(q[k], qd[k], qdd[k], rigid_only=True))
        assert np.array_equal(tau[k], robot.rnea(q[k], qd[k], qdd[k]))
    assert ivdyn._ivdyn.batch_threads(1) == 1


def test_shapes_and_empty_batch():
    robot = ivdyn.Robot.paper()
    z = np.zeros(6)
    assert robot.rnea(z, z, z).shape == (6,)
    assert robot.gravity(z).shape == (6,)
    assert robot.regressor(z, z, z).shape == (6, 84)
    assert robot.regressor(z, z, z, rigid_only=True).shape == (6, 60)
    assert robot.mass_matrix(z).shape == (6, 6)
    e = np.zeros((0, 6))
    assert robot.rnea(e, e, e).shape == (0, 6)
    assert robot.regressor(e, e, e).shape == (0, 6, 84)
    assert robot.mass_matrix(e).shape == (0, 6, 6)
    one = np.zeros((1, 6))
    assert robot.rnea(one, one, one).shape == (1, 6)
    for out in (robot.rnea(z, z, z), robot.regressor(one, one, one)):
        assert out.dtype == np.float64 and out.flags.c_contiguous


def test_calls_from_threads():
    """The GIL is released during the batch: concurrent calls from Python threads agree."""
    robot, ref, _ = build("panda7")
    q, qd, qdd = random_states(robot, ref, 2000, seed=9)
    want = robot.rnea(q, qd, qdd)
    results = [None] * 4

    def work(i):
        results[i] = robot.rnea(q, qd, qdd)

    threads = [threading.Thread(target=work, args=(i,)) for i in range(4)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    for r in results:
        assert np.array_equal(r, want)


# ----------------------------------------------------------------- input conversion
def test_other_dtypes_and_lists_accepted():
    robot = ivdyn.Robot.paper()
    rng = np.random.default_rng(2)
    q = rng.uniform(-1, 1, (5, 6)).astype(np.float32)
    qd = rng.integers(-2, 3, (5, 6))
    qdd = q.astype(np.float64).tolist()
    want = robot.rnea(q.astype(np.float64), qd.astype(np.float64), np.array(qdd))
    assert np.array_equal(robot.rnea(q, qd, qdd), want)
    assert np.array_equal(robot.rnea(q[0], qd[0].tolist(), tuple(qdd[0])), want[0])
    assert np.array_equal(robot.regressor([0] * 6, [0] * 6, [0] * 6),
                          robot.regressor(np.zeros(6), np.zeros(6), np.zeros(6)))
    assert np.array_equal(robot.gravity(np.float32(0.5) * np.ones(6, np.float32)),
                          robot.gravity(np.full(6, 0.5)))
    robot.params = robot.params.astype(np.float32)  # the setter converts too
    robot.params = list(robot.params)


def test_non_contiguous_accepted():
    robot = ivdyn.Robot.paper()
    rng = np.random.default_rng(3)
    wide = rng.uniform(-1, 1, (20, 12))
    q = wide[:, ::2]                      # strided columns
    qd = np.asfortranarray(rng.uniform(-1, 1, (20, 6)))
    qdd = rng.uniform(-1, 1, (40, 6))[::2]  # strided rows
    assert not q.flags.c_contiguous and not qd.flags.c_contiguous and not qdd.flags.c_contiguous
    want = robot.rnea(q.copy(), qd.copy(order="C"), qdd.copy())
    assert np.array_equal(robot.rnea(q, qd, qdd), want)
    assert np.array_equal(robot.mass_matrix(q), robot.mass_matrix(q.copy()))
    assert np.array_equal(robot.rnea(wide[3, ::2], qd[3], qdd[3]), want[3])
    # the native layer accepts strided float64 arrays as well (it copies them)
    assert np.array_equal(robot._r.rnea(q, qd, qdd), want)


# ----------------------------------------------------------------- errors
def test_wrong_shapes_raise_value_error():
    robot = ivdyn.Robot.paper()
    z = np.zeros(6)
    with pytest.raises(ValueError, match=r"q must have shape \(6,\) or \(T, 6\), got \(5,\)"):
        robot.rnea(np.zeros(5), z, z)
    with pytest.raises(ValueError, match=r"q must have shape \(6,\) or \(T, 6\), got \(10, 7\)"):
        robot.gravity(np.zeros((10, 7)))
    with pytest.raises(ValueError, match=r"got \(2, 3, 6\)"):
        robot.mass_matrix(np.zeros((2, 3, 6)))
    with pytest.raises(ValueError, match=r"got \(\)"):
        robot.gravity(0.0)
    with pytest.raises(ValueError, match=r"qd must have shape \(10, 6\) like q, got \(9, 6\)"):
        robot.rnea(np.zeros((10, 6)), np.zeros((9, 6)), np.zeros((10, 6)))
    with pytest.raises(ValueError, match=r"qdd must have shape \(6,\) like q, got \(1, 6\)"):
        robot.regressor(z, z, np.zeros((1, 6)))
    with pytest.raises(ValueError, match=r"tau must have shape \(6,\) like q, got \(5,\)"):
        robot.forward_dynamics(z, z, np.zeros(5))
    with pytest.raises(ValueError, match=r"params must have shape \(84,\), got \(83,\)"):
        robot.params = np.zeros(83)
    # the native layer checks too
    with pytest.raises(ValueError, match=r"qd must have shape \(3, 6\), got \(2, 6\)"):
        robot._r.rnea(np.zeros((3, 6)), np.zeros((2, 6)), np.zeros((3, 6)))
    with pytest.raises(ValueError, match=r"q must have shape \(T, 6\), got \(3, 5\)"):
        robot._r.gravity(np.zeros((3, 5)))


def test_non_finite_names_the_sample():
    robot = ivdyn.Robot.paper()
    q = np.zeros((100, 6))
    qd = np.zeros((100, 6))
    q[37, 2] = np.nan
    with pytest.raises(ValueError, match=r"sample 37: non-finite value in q\[2\]"):
        robot.rnea(q, qd, qd)
    with pytest.raises(ValueError, match=r"sample 37: non-finite value in q\[2\]"):
        robot.regressor(q, qd, qd, rigid_only=True)
    with pytest.raises(ValueError, match=r"sample 37"):
        robot.mass_matrix(q)
    with pytest.raises(ValueError, match=r"sample 37"):
        robot.gravity(q)
    tau = np.zeros((100, 6))
    tau[81, 5] = -np.inf
    with pytest.raises(ValueError, match=r"sample 81: non-finite value in tau\[5\]"):
        robot.forward_dynamics(np.zeros((100, 6)), qd, tau)
    qd1 = np.zeros(6)
    qd1[4] = np.inf
    with pytest.raises(ValueError, match=r"sample 0: non-finite value in qd\[4\]"):
        robot.rnea(np.zeros(6), qd1, np.zeros(6))
    theta = robot.params
    theta[3] = np.nan
    with pytest.raises(ValueError, match=r"theta\[3\]"):
        robot.params = theta


def test_singular_mass_matrix_is_runtime_error():
    robot = ivdyn.Robot.from_dh([0.1, 0.2], [0.0, 0.0], [0.0, 0.0])  # all parameters zero
    with pytest.raises(RuntimeError, match=r"sample 0: mass matrix is not positive definite"):
        robot.forward_dynamics(np.zeros(2), np.zeros(2), np.zeros(2))


def test_bad_urdf_path():
    with pytest.raises(FileNotFoundError, match="no_such.urdf"):
        ivdyn.Robot.from_urdf(os.path.join(FIXTURES, "no_such.urdf"))


def test_bad_urdf_contents(tmp_path):
    p = tmp_path / "broken.urdf"
    p.write_text("<robot name='x'><link name='a'></robot>")
    with pytest.raises(ValueError, match="broken.urdf"):
        ivdyn.Robot.from_urdf(p)  # a PathLike works


def test_unknown_links():
    path = os.path.join(FIXTURES, "ur5.urdf")
    with pytest.raises(ValueError, match=r"no link named 'tool42'"):
        ivdyn.Robot.from_urdf(path, base="base_link", tip="tool42")
    with pytest.raises(ValueError, match=r"no link named 'nowhere'"):
        ivdyn.Robot.from_urdf(path, base="nowhere")


def test_from_dh_errors():
    with pytest.raises(ValueError, match=r"d \(one per joint, as a: N = 3\): expected length 3, got 2"):
        ivdyn.Robot.from_dh([0, 0, 0], [0, 0], [0, 0, 0])
    with pytest.raises(ValueError, match=r"offset"):
        ivdyn.Robot.from_dh([0, 0], [0, 0], [0, 0], offset=[0.0])
    with pytest.raises(ValueError, match=r"13 movable joints; ivdyn supports 1..=12"):
        ivdyn.Robot.from_dh([0] * 13, [0] * 13, [0] * 13)
    with pytest.raises(ValueError, match=r"0 movable joints"):
        ivdyn.Robot.from_dh([], [], [])
    with pytest.raises(ValueError, match=r"non-finite value in alpha\[1\]"):
        ivdyn.Robot.from_dh([0, 0], [0, 0], [0, np.nan])


def test_robot_constructor_is_guarded():
    with pytest.raises(TypeError):
        ivdyn.Robot("not a native robot")
    assert ivdyn.MAX_DOF == 12
    assert isinstance(ivdyn.__version__, str)

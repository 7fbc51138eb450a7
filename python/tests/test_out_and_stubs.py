"""`out=` on the dynamics methods (written in place, same values as a fresh result from the
NumPy reference, checked and rejected with ValueError), and the type stubs: mypy's
stubtest compares python/ivdyn/_ivdyn.pyi with the installed native module."""
import os
import subprocess
import sys

import numpy as np
import pytest

import ivdyn

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
sys.path.insert(0, os.path.join(ROOT, "python", "reference"))

from ivdyn_ref import dynamics as dy  # noqa: E402
from ivdyn_ref import model as rm  # noqa: E402

UR5 = os.path.join(ROOT, "fixtures", "ur5.urdf")


@pytest.fixture(scope="module")
def ur5():
    robot = ivdyn.Robot.from_urdf(UR5, base="base_link", tip="tool0")
    ref = rm.from_urdf(UR5, base="base_link", tip="tool0")
    ref.set_theta(robot.params)
    return robot, ref


def test_out_is_written_in_place_and_reused(ur5):
    robot, ref = ur5
    rng = np.random.default_rng(3)
    buf = np.full((300, 6, 84), np.nan)
    for _ in range(2):  # a reused buffer: every entry overwritten each time
        q, qd, qdd = (rng.uniform(-2, 2, (300, 6)) for _ in range(3))
        y = robot.regressor(q, qd, qdd, out=buf)
        assert y is buf
        for k in (0, 151, 299):
            np.testing.assert_allclose(buf[k], dy.regressor(ref, q[k], qd[k], qdd[k]), rtol=0, atol=1e-10)
    one = np.empty((6, 60))
    assert robot.regressor(q[0], qd[0], qdd[0], rigid_only=True, out=one) is one
    np.testing.assert_allclose(one, dy.regressor(ref, q[0], qd[0], qdd[0])[:, :60], rtol=0, atol=1e-10)
    tau = np.empty((300, 6))
    assert robot.rnea(q, qd, qdd, out=tau) is tau
    np.testing.assert_allclose(tau[7], dy.rnea(ref, q[7], qd[7], qdd[7]), rtol=0, atol=1e-10)
    m = np.empty((300, 6, 6))
    robot.mass_matrix(q, out=m)
    np.testing.assert_allclose(m[9], dy.mass_matrix(ref, q[9]), rtol=0, atol=1e-10)
    g = np.empty(6)
    robot.gravity(q[4], out=g)
    np.testing.assert_allclose(g, dy.gravity_torque(ref, q[4]), rtol=0, atol=1e-10)
    a = np.empty((300, 6))
    robot.forward_dynamics(q, qd, tau, out=a)
    np.testing.assert_allclose(a, qdd, rtol=0, atol=1e-8)


def test_out_errors(ur5):
    robot, _ = ur5
    q = np.zeros((10, 6))
    with pytest.raises(ValueError, match=r"out must have shape \(10, 6, 84\)"):
        robot.regressor(q, q, q, out=np.empty((10, 6, 60)))
    with pytest.raises(ValueError, match="float64"):
        robot.regressor(q, q, q, out=np.empty((10, 6, 84), dtype=np.float32))
    with pytest.raises(ValueError, match="C-contiguous"):
        robot.regressor(q, q, q, out=np.empty((10, 6, 168))[:, :, ::2])
    ro = np.empty((10, 6))
    ro.flags.writeable = False
    with pytest.raises(ValueError, match="out"):
        robot.rnea(q, q, q, out=ro)
    with pytest.raises(ValueError, match="numpy.ndarray"):
        robot.rnea(q, q, q, out=[0.0] * 60)
    with pytest.raises(ValueError, match=r"out must have shape \(6,\)"):
        robot.gravity(np.zeros(6), out=np.empty((1, 6)))


def test_stubs_match_the_native_module(tmp_path):
    """mypy.stubtest: every name, signature and class property of ivdyn._ivdyn against
    _ivdyn.pyi (and a type check of the pure-Python modules)."""
    # Ray, matplotlib and tqdm ship type information, so mypy would analyse whole packages
    # (most of this test's time) for the few modules that import them: they are taken as
    # Any. tqdm.auto pulls in IPython and prompt_toolkit (~280 modules); matplotlib's own
    # .pyi files are followed unless follow_imports_for_stubs says otherwise (mypy alone on
    # the package, one run each: 18.4 s -> 11.0 s, 18 modules checked either way).
    cfg = tmp_path / "mypy.ini"
    cfg.write_text("[mypy]\n\n[mypy-ray,ray.*,matplotlib,matplotlib.*,tqdm,tqdm.*]\n"
                   "follow_imports = skip\nfollow_imports_for_stubs = True\n")
    r = subprocess.run([sys.executable, "-m", "mypy.stubtest", "ivdyn", "--mypy-config-file", str(cfg)],
                       cwd=tmp_path, capture_output=True, text=True, timeout=600,
                       env=dict(os.environ, MYPY_CACHE_DIR=str(tmp_path / "cache")))
    assert r.returncode == 0, r.stdout + r.stderr

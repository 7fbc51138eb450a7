"""Issue 16, hostile input from Python: sizes that would allocate without bound are refused
with a ValueError naming the argument and the limit, before anything is allocated (an
allocation failure aborts the interpreter, which no `except` can catch); docs/reliability.md."""
import math
import os

import pytest

import ivdyn

UR5 = os.path.join(os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__)))), "fixtures", "ur5.urdf")


@pytest.fixture(scope="module")
def ur5():
    return ivdyn.Robot.from_urdf(UR5, base="base_link", tip="tool0")


def test_rls_parameter_count_bounded():
    # a 30000 x 30000 covariance (7 GB) used to abort the interpreter
    with pytest.raises(ValueError, match=r"p must be in 1\.\.=4096, got 30000"):
        ivdyn.Rls(30000)
    assert ivdyn.Rls(4096).p == 4096


def test_base_params_samples_bounded(ur5):
    with pytest.raises(ValueError, match=r"samples must be at most 20000, got 100000000"):
        ivdyn.base_params(ur5, samples=10**8)


def test_simulate_duration_bounded(ur5):
    with pytest.raises(ValueError, match=r"duration 1000000000 s at 500 Hz is 5\.000e11 samples; at most 1e7"):
        ivdyn.simulate(ur5, duration=1e9)
    with pytest.raises(ValueError, match=r"duration must be finite and > 0, got inf"):
        ivdyn.simulate(ur5, duration=math.inf)
    with pytest.raises(ValueError, match=r"rate 1e\+300 Hz|at most 1e7"):
        ivdyn.simulate(ur5, rate=1e300)


def test_cutoff_out_of_range_is_a_value_error(ur5, tmp_path):
    log = tmp_path / "x.mcap"
    ivdyn.simulate(ur5, log, duration=2)
    with pytest.raises(ValueError, match=r"cutoff \(--cutoff\) 1e-30 Hz is out of range.*allowed"):
        ivdyn.identify(ur5, log, cutoff=1e-30)


def test_urdf_self_loop_is_an_error_not_a_crash(tmp_path):
    # a link that is its own child used to crash the interpreter (SIGSEGV: the recursive
    # tree walk overflowed the stack); the loader now names the loop
    link = ('<link name="{0}"><inertial><mass value="1"/><origin xyz="0 0 0"/>'
            '<inertia ixx="0.01" iyy="0.01" izz="0.01" ixy="0" ixz="0" iyz="0"/></inertial></link>')
    joint = ('<joint name="{0}" type="{1}"><parent link="{2}"/><child link="{3}"/><origin xyz="0 0 0.2"/>'
             '<axis xyz="0 0 1"/><limit lower="-3" upper="3" effort="10" velocity="2"/></joint>')
    body = "".join(link.format(n) for n in ("base", "arm", "tool"))
    body += joint.format("j1", "revolute", "base", "arm") + joint.format("j_self", "fixed", "tool", "tool")
    path = tmp_path / "loop.urdf"
    path.write_text(f'<?xml version="1.0"?><robot name="hostile">{body}</robot>')
    with pytest.raises(Exception, match=r"kinematic loop: 'tool' -> 'tool'") as e:
        ivdyn.Robot.from_urdf(str(path))
    assert isinstance(e.value, (ValueError, OSError, RuntimeError)), type(e.value)

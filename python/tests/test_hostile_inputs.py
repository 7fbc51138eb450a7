"""Issue 16 from Python: arrays that are not real numbers are refused by name (a complex
array's imaginary part used to be dropped with a mere warning, datetime64 stamps read as
raw ticks), option values out of range name the option, sizes are bounded before any
allocation, and every public entry point turns a Rust panic into RuntimeError
(docs/reliability.md)."""
import inspect
import os

import numpy as np
import pytest

import ivdyn
from ivdyn import _guard

UR5 = os.path.join(os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__)))), "fixtures", "ur5.urdf")


@pytest.fixture(scope="module")
def ur5():
    return ivdyn.Robot.from_urdf(UR5, base="base_link", tip="tool0")


@pytest.fixture(scope="module")
def log(ur5):
    return ivdyn.simulate(ur5, duration=4.0, rate=250.0, noise=0.05, fc=[1.0] * 6)["log"]


NOT_REAL = {
    "complex": lambda a: a.astype(np.complex128) + 1j,
    "datetime64": lambda a: (a * 1e9).astype("datetime64[ns]"),
    "timedelta64": lambda a: (a * 1e9).astype("timedelta64[ns]"),
    "bool": lambda a: a > 0,
    "string": lambda a: a.astype(str),
    "structured": lambda a: np.array([tuple(r) for r in np.atleast_2d(a)],
                                     dtype=[(f"f{i}", "f8") for i in range(np.atleast_2d(a).shape[1])]),
}


@pytest.mark.parametrize("kind", sorted(NOT_REAL))
def test_arrays_that_are_not_real_numbers_are_refused_by_name(ur5, log, kind):
    bad = NOT_REAL[kind]
    q = np.zeros((3, 6)) + 0.1
    with pytest.raises(ValueError, match=r"q must be an array of real numbers"):
        ur5.rnea(bad(q), q, q)
    with pytest.raises(ValueError, match=r"log\['tau'\] must be an array of real numbers"):
        ivdyn.identify(ur5, dict(log, tau=bad(log["tau"])))
    with pytest.raises(ValueError, match=r"log\['t'\] must be an array of real numbers"):
        ivdyn.identify(ur5, dict(log, t=bad(log["t"])))
    phi = np.ones((10, 2))
    with pytest.raises(ValueError, match=r"Phi must be an array of real numbers"):
        ivdyn.fit_ls(bad(phi), np.ones(10))
    with pytest.raises(ValueError, match=r"params must be an array of real numbers"):
        ur5.copy().params = bad(ur5.params)


def test_integer_and_object_arrays_of_numbers_still_work(ur5):
    q = np.zeros((2, 6), dtype=np.int64)
    assert np.allclose(ur5.rnea(q, q, q), ur5.rnea(q.astype(float), q.astype(float), q.astype(float)))
    obj = np.array([[0.1] * 6], dtype=object)
    assert np.allclose(ur5.rnea(obj, obj, obj), ur5.rnea(obj.astype(float), obj.astype(float), obj.astype(float)))


def test_option_values_out_of_range_name_the_option(ur5, log):
    with pytest.raises(ValueError, match=r"holdout must be in \[0, 0.9\], got 1.5"):
        ivdyn.identify(ur5, log, holdout=1.5)
    with pytest.raises(ValueError, match=r"alpha must be > 0 and at most 0.5, got 2"):
        ivdyn.diagnose(ur5, log, alpha=2.0)
    with pytest.raises(ValueError, match=r"encoder_bits must be in 1..=52, got 0"):
        ivdyn.simulate(ur5, duration=1.0, encoder_bits=0)
    with pytest.raises(ValueError, match=r"payload_inertia is not a body's inertia"):
        ivdyn.simulate(ur5, duration=1.0, payload_mass=1.0, payload_inertia=[-1, 0, 0, 1, 0, 1])
    with pytest.raises(ValueError, match=r"harmonics must be in 2..=100, got 100000"):
        ivdyn.excite(ur5, harmonics=100000)
    with pytest.raises(ValueError, match=r"samples must be at most 20000"):
        ivdyn.terminal_base(ur5, samples=10**9)
    # payload() offers no command topic: it does not use one
    assert "command_topic" not in inspect.signature(ivdyn.payload).parameters


def test_every_public_entry_point_is_guarded():
    # the Python functions and the methods of the Python classes of the public API
    for name in ivdyn.__all__:
        obj = getattr(ivdyn, name)
        if inspect.isfunction(obj):
            assert getattr(obj, "__ivdyn_guarded__", False), name
        elif inspect.isclass(obj) and obj.__module__.startswith("ivdyn") and "_ivdyn" not in obj.__module__:
            for key, attr in vars(obj).items():
                f = attr.fget if isinstance(attr, property) else getattr(attr, "__func__", attr)
                if inspect.isfunction(f) and (not key.startswith("_") or key == "__init__"):
                    assert getattr(f, "__ivdyn_guarded__", False), f"{name}.{key}"


def test_the_guard_turns_a_panic_into_runtime_error():
    # pyo3 raises `pyo3_runtime.PanicException`, a BaseException; the guard matches it by
    # name (its class is created inside the extension). A class of that name stands in.
    PanicException = type("PanicException", (BaseException,), {})

    def panics():
        raise PanicException("index out of bounds")

    with pytest.raises(RuntimeError, match=r"internal error in ivdyn \(please report\): index out of bounds"):
        _guard._no_panic(panics)()
    # anything else passes through unchanged
    with pytest.raises(KeyboardInterrupt):
        _guard._no_panic(lambda: (_ for _ in ()).throw(KeyboardInterrupt()))()

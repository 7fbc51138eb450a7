"""What the Python side checks before the native module, and what it turns into ordinary
exceptions after it (issue 16, docs/reliability.md).

- :func:`real_array`: every array argument becomes C-contiguous float64 here, and only from
  real numbers: complex (whose imaginary part a cast drops with a mere warning),
  datetime64 / timedelta64 (cast to raw ticks), bool, string and structured arrays are a
  ``ValueError`` naming the argument.
- :func:`guard`: a Rust panic reaches Python as pyo3's ``PanicException``, a
  ``BaseException`` that ``except Exception`` does not catch; every public function and
  method of the package turns it into ``RuntimeError("internal error in ivdyn (please
  report): ...")``. A panic is a bug in ivdyn; the caller's error handling should see it.
"""

from __future__ import annotations

import functools
import inspect
from typing import Any, Callable, Optional, Tuple

import numpy as np


def real_array(x: Any, name: str, ndim: Optional[int] = None, shape: str = "") -> np.ndarray:
    """``x`` as C-contiguous float64 from integers or floats (``ndim`` dimensions when
    given), or ``ValueError`` naming ``name``."""
    try:
        a = np.asarray(x)
        if a.dtype.kind == "O":
            # Python numbers in an object array (complex ones fail here)
            a = a.astype(np.float64)
    except (TypeError, ValueError) as e:
        raise ValueError(f"{name} must be an array of real numbers{' of shape ' + shape if shape else ''}: {e}") from None
    if a.dtype.kind not in "iuf":
        raise ValueError(f"{name} must be an array of real numbers (int or float), got dtype {a.dtype}")
    if ndim is not None and a.ndim != ndim:
        raise ValueError(f"{name} must have shape {shape or ndim}, got {a.shape}")
    # astype keeps a 0-d array 0-d (ascontiguousarray would make it 1-d)
    return a.astype(np.float64, order="C", copy=False)


def _no_panic(fn: Callable) -> Callable:
    @functools.wraps(fn)
    def call(*args, **kwargs):
        try:
            return fn(*args, **kwargs)
        except BaseException as e:  # noqa: B036 - only pyo3's PanicException is turned
            if type(e).__name__ != "PanicException":
                raise
            raise RuntimeError(f"internal error in ivdyn (please report): {e}") from None
    call.__ivdyn_guarded__ = True  # type: ignore[attr-defined]
    return call


def _guard_class(cls: type) -> type:
    for key, attr in list(vars(cls).items()):
        if key.startswith("__") and key not in ("__init__", "__call__", "__repr__"):
            continue
        if isinstance(attr, property):
            fget, fset, fdel = (None if f is None else _no_panic(f) for f in (attr.fget, attr.fset, attr.fdel))
            setattr(cls, key, property(fget, fset, fdel, attr.__doc__))
        elif isinstance(attr, (staticmethod, classmethod)):
            setattr(cls, key, type(attr)(_no_panic(attr.__func__)))
        elif inspect.isfunction(attr):
            setattr(cls, key, _no_panic(attr))
    return cls


def guard(namespace: dict, names: Tuple[str, ...]) -> None:
    """Wraps the Python functions and classes among ``names`` in ``namespace`` (a module's
    globals): classes implemented in Rust (``FitReport``) only have getters and are left."""
    for name in names:
        obj = namespace.get(name)
        if inspect.isclass(obj) and obj.__module__.startswith("ivdyn") and not obj.__module__.startswith("ivdyn._ivdyn"):
            _guard_class(obj)
        elif inspect.isfunction(obj) and not getattr(obj, "__ivdyn_guarded__", False):
            namespace[name] = _no_panic(obj)

"""Identification from NumPy: batch LS/IV fits, base parameters, payload, recursive
estimators and log reading. Wrappers over the native module (``ivdyn._ivdyn``): inputs
are checked and converted to C-contiguous float64 here, the work is done in Rust with the
GIL released.
"""
from __future__ import annotations

import os
from typing import List, Optional, Sequence, Union

import numpy as np

from . import _ivdyn
from ._guard import real_array

FitReport = _ivdyn.FitReport

#: Names of an inertia 6-vector's entries in ivdyn's order (that of ``robot.params``, Pinocchio's),
#: used by every inertia 6-vector of the Python and Rust APIs.
INERTIA_ORDER: List[str] = list(_ivdyn.INERTIA_ORDER)
#: URDF ``<inertia>`` attribute order, kept by URDF files and the JSON files that follow them
#: (``payload(...)["inertia"]``, ``diagnosis.json``).
INERTIA_URDF_ORDER: List[str] = list(_ivdyn.INERTIA_URDF_ORDER)
# the permutation, from the Rust conversion (its one implementation) applied to indices
_TO_URDF = np.array(_ivdyn.inertia_to_urdf([0.0, 1.0, 2.0, 3.0, 4.0, 5.0]), dtype=np.intp)
_FROM_URDF = np.array(_ivdyn.inertia_from_urdf([0.0, 1.0, 2.0, 3.0, 4.0, 5.0]), dtype=np.intp)


def _inertia6(x, name: str) -> np.ndarray:
    a = real_array(x, name)
    if a.ndim == 0 or a.shape[-1] != 6:
        raise ValueError(f"{name} must have shape (6,) or (..., 6), got {a.shape}")
    return a


def inertia_to_urdf(inertia) -> np.ndarray:
    """Inertia 6-vectors ``(..., 6)`` from ivdyn's order ``[Ixx, Ixy, Iyy, Ixz, Iyz, Izz]``
    to URDF attribute order ``[Ixx, Ixy, Ixz, Iyy, Iyz, Izz]`` (a new array)."""
    return _inertia6(inertia, "inertia")[..., _TO_URDF]


def inertia_from_urdf(inertia) -> np.ndarray:
    """Inertia 6-vectors ``(..., 6)`` from URDF attribute order ``[Ixx, Ixy, Ixz, Iyy, Iyz,
    Izz]`` (e.g. ``payload(...)["inertia"]``) to ivdyn's ``[Ixx, Ixy, Iyy, Ixz, Iyz, Izz]``."""
    return _inertia6(inertia, "inertia")[..., _FROM_URDF]


def _f64(x, name: str, ndim: int, shape: str) -> np.ndarray:
    """``x`` as C-contiguous float64 with ``ndim`` dimensions, or ``ValueError``."""
    return real_array(x, name, ndim, shape)


def _names(names, p: int) -> Optional[List[str]]:
    if names is None:
        return None
    names = [str(n) for n in names]
    if len(names) != p:
        raise ValueError(f"names must have {p} entries (one per column of Phi), got {len(names)}")
    return names


def _fit_inputs(Phi, y, w):
    Phi = _f64(Phi, "Phi", 2, "(M, P)")
    m = Phi.shape[0]
    y = _f64(y, "y", 1, f"({m},)")
    if y.shape[0] != m:
        raise ValueError(f"y must have shape ({m},) (one entry per row of Phi), got {y.shape}")
    if w is not None:
        w = _f64(w, "w", 1, f"({m},)")
        if w.shape[0] != m:
            raise ValueError(f"w must have shape ({m},) (one weight per row of Phi), got {w.shape}")
    return Phi, y, w


def fit_ls(Phi, y, w=None, names: Optional[Sequence[str]] = None) -> "FitReport":
    """Weighted least squares ``y ≈ Phi @ theta``.

    ``Phi``: ``(M, P)`` regressor rows; ``y``: ``(M,)`` outputs (e.g. torques, N m);
    ``w``: ``(M,)`` row weights (inverse noise variances, ``>= 0``; rows with ``w = 0``
    are ignored), default 1; ``names``: ``P`` parameter names (default ``theta[j]``).
    The rows are streamed through ``ivdyn::ident::LsAccumulator`` (QR, never the normal
    equations), so ``M`` may be large. Parameters the data do not excite are listed in
    ``unexcited`` and get ``NaN``. Returns a :class:`FitReport`.
    """
    Phi, y, w = _fit_inputs(Phi, y, w)
    return _ivdyn.fit_ls(Phi, y, w, _names(names, Phi.shape[1]))


def fit_iv(Phi, Z, y, w=None, names: Optional[Sequence[str]] = None) -> "FitReport":
    """Instrumental variables ``theta = (Z^T W Phi)^-1 Z^T W y``.

    ``Phi``, ``Z``: ``(M, P)`` regressor and instrument rows; ``y``, ``w``, ``names`` as
    in :func:`fit_ls`. The report also has the LS estimate on the same data
    (``theta_ls``) and the Durbin-Wu-Hausman test of LS against IV (``dwh``). Raises
    ``RuntimeError("singular matrix")`` when ``Z^T W Phi`` is singular (irrelevant
    instruments).
    """
    Phi, y, w = _fit_inputs(Phi, y, w)
    Z = _f64(Z, "Z", 2, f"{Phi.shape}")
    if Z.shape != Phi.shape:
        raise ValueError(f"Z must have the shape of Phi {Phi.shape}, got {Z.shape}")
    return _ivdyn.fit_iv(Phi, Z, y, w, _names(names, Phi.shape[1]))


class BaseParams:
    """Base (identifiable) parameters: ``theta_base = theta[independent] + K @
    theta[dependent]`` and ``Y_full @ theta == select(Y_full) @ project(theta)``.

    Attributes: ``names`` (``B`` readable combinations such as
    ``"link3.Ixx - link3.Iyy - 0.00784996*link4.m - ..."``; the same for any
    ``samples`` and ``seed``), ``independent`` / ``dependent``
    (column indices into the ``P`` full parameters), ``K`` (``(B, P - B)``),
    ``zero_columns`` (parameters with no effect at all), ``full_cols`` (``P``),
    ``base_count`` (``B``).
    """

    __slots__ = ("_b",)

    def __init__(self, native):
        if not isinstance(native, _ivdyn.BaseParams):
            raise TypeError("use ivdyn.base_params(robot) to build BaseParams")
        self._b = native

    @property
    def names(self) -> List[str]:
        return self._b.names

    @property
    def independent(self) -> List[int]:
        return self._b.independent

    @property
    def dependent(self) -> List[int]:
        return self._b.dependent

    @property
    def K(self) -> np.ndarray:
        return self._b.K

    @property
    def zero_columns(self) -> List[int]:
        return self._b.zero_columns

    @property
    def full_cols(self) -> int:
        return self._b.full_cols

    @property
    def base_count(self) -> int:
        return self._b.base_count

    def project(self, theta_full) -> np.ndarray:
        """Full parameters ``(..., P)`` -> base parameters ``(..., B)``."""
        p = self.full_cols
        t = real_array(theta_full, "theta_full")
        if t.ndim == 0 or t.shape[-1] != p:
            raise ValueError(f"theta_full must have shape ({p},) or (..., {p}), got {t.shape}")
        flat = np.ascontiguousarray(t.reshape(-1, p))
        out = np.stack([self._b.project(r) for r in flat]) if flat.shape[0] else np.zeros((0, self.base_count))
        return out.reshape(t.shape[:-1] + (self.base_count,))

    def select(self, Y_full) -> np.ndarray:
        """Full regressor ``(..., P)`` (e.g. ``robot.regressor`` output ``(T, N, P)``) ->
        base regressor ``(..., B)``: the independent columns."""
        p = self.full_cols
        y = real_array(Y_full, "Y_full")
        if y.ndim == 0 or y.shape[-1] != p:
            raise ValueError(f"Y_full must have shape ({p},) or (..., {p}), got {y.shape}")
        out = self._b.select(np.ascontiguousarray(y.reshape(-1, p)))
        return out.reshape(y.shape[:-1] + (self.base_count,))

    def to_full(self, theta_base) -> np.ndarray:
        """Base parameters ``(B,)`` -> one full vector ``(P,)`` with the same effect
        (dependent entries 0, so ``project(to_full(x)) == x``)."""
        b = self.base_count
        t = _f64(theta_base, "theta_base", 1, f"({b},)")
        return self._b.to_full(t)

    def __repr__(self) -> str:
        return f"BaseParams({self.base_count} of {self.full_cols} parameters identifiable)"

    def _repr_html_(self) -> str:
        from ._results import base_params_html
        return base_params_html(self)


def base_params(robot, samples: int = 100, seed: int = 1, rigid_only: bool = False) -> BaseParams:
    """Base parameters of ``robot`` (an :class:`ivdyn.Robot`), found numerically from the
    full regressors at ``samples`` random states (seeded): ``q`` within the joint limits,
    ``qd`` in +-1 rad/s, ``qdd`` in +-2 rad/s^2. Needs ``samples * dof >= 14 dof``.
    With ``rigid_only`` only the ``10 N`` inertial columns are considered (no drive
    parameters: a rigid-body-only model)."""
    native = getattr(robot, "_r", robot)
    if not isinstance(native, _ivdyn.Robot):
        raise TypeError(f"robot must be an ivdyn.Robot, got {type(robot).__name__}")
    if int(samples) < 1:
        raise ValueError(f"samples must be >= 1, got {samples}")
    return BaseParams(_ivdyn.base_params(native, int(samples), int(seed), bool(rigid_only)))


def fit_robot(robot, base: BaseParams, q, qd, qdd, tau, joint_weight=None) -> "FitReport":
    """Least-squares fit of the base parameters ``base`` from samples, in one fused,
    multi-threaded pass: ``q, qd, qdd`` (rad, rad/s, rad/s^2) and measured ``tau`` (N m),
    each ``(T, N)``; ``joint_weight`` ``(N,)`` inverse noise variances per joint (default 1).
    Each thread evaluates the regressor of its samples and streams the base columns into
    its own QR accumulator; they merge. The ``(T, N, P)`` regressor is never stored.
    Returns a :class:`FitReport` over ``base.names``."""
    native = getattr(robot, "_r", robot)
    if not isinstance(native, _ivdyn.Robot):
        raise TypeError(f"robot must be an ivdyn.Robot, got {type(robot).__name__}")
    if not isinstance(base, BaseParams):
        raise TypeError("base must be an ivdyn.BaseParams (from ivdyn.base_params)")
    n = native.dof
    arrs: List[np.ndarray] = []
    for name, x in (("q", q), ("qd", qd), ("qdd", qdd), ("tau", tau)):
        x = real_array(x, name)
        if x.ndim != 2 or x.shape[1] != n or (arrs and x.shape[0] != arrs[0].shape[0]):
            t = arrs[0].shape[0] if arrs else "T"
            raise ValueError(f"{name} must have shape ({t}, {n}), got {x.shape}")
        arrs.append(x)
    w = None if joint_weight is None else real_array(joint_weight, "joint_weight").reshape(-1)
    return _ivdyn.fit_robot(native, base._b, arrs[0], arrs[1], arrs[2], arrs[3], w)


def payload_from_fit(base: BaseParams, fit: "FitReport", cols: Sequence[int],
                     full_names: Sequence[str]) -> dict:
    """Payload (or any link) as mass, centre of mass and inertia about the centre of mass,
    with standard deviations propagated from ``fit.covariance``. The numbers are those of
    the physically possible rigid body nearest to the fit (in the metric of its
    covariance); the fit's own, what it violated and how far the two are apart are in
    ``physical``.

    ``fit`` is a fit over ``base`` (its ``B`` columns); ``cols`` the 10 full-parameter
    indices of the link's ``[m, m*cx, m*cy, m*cz, Ixx, Ixy, Iyy, Ixz, Iyz, Izz]``;
    ``full_names`` the ``P`` full names. Returns ``{"mass": kg, "com": (3,) m,
    "inertia": (6,) [Ixx, Ixy, Iyy, Ixz, Iyz, Izz] (ivdyn's order) kg m^2 about the com,
    "mass_std", "com_std", "inertia_std", "params": (10,) about the link origin,
    "physical": dict}`` (``physical`` as in :func:`payload`'s JSON report, whose
    ``ls_inertia`` keeps the file's URDF attribute order).
    Raises ``ValueError`` naming the parameters that are not identifiable by themselves
    and the base combination each one went into.
    """
    if not isinstance(base, BaseParams):
        raise TypeError("base must be an ivdyn.BaseParams (from ivdyn.base_params)")
    if not isinstance(fit, FitReport):
        raise TypeError("fit must be an ivdyn.FitReport (from ivdyn.fit_ls / fit_iv)")
    return _ivdyn.payload_from_fit(base._b, fit, [int(c) for c in cols], [str(n) for n in full_names])


def _opt_float(x: Optional[float]) -> Optional[float]:
    return None if x is None else float(x)


class Rls:
    """Recursive least squares (Bierman UD form) over scalar rows ``y = phi . theta + e``,
    ``var(e) = 1 / w``; starts at ``theta = 0``, covariance ``p0 I``; ``forgetting`` in
    ``(0, 1]`` (1 = none), directional: each row forgets only along its own ``phi``, so a
    direction that is never excited keeps its prior instead of winding up.

    ``max_variance`` (finite, > 0; ``None`` = ``p0``): anti-windup bound on every factor
    ``d_j`` of ``P = U D U^T`` under forgetting. ``outlier_gate`` (> 0; ``None`` = no gate):
    rows whose normalised innovation ``|e| / sqrt(1/w + phi^T P phi)`` exceeds it are
    refused with ``ValueError`` ("outlier row"). Rows with ``w phi^T P phi > 2e31`` (e.g.
    ``phi = 1e150``) are always refused with ``ValueError`` ("row out of range").

    ``update(phi (P,), y, w=1.0)``; ``update_many(Phi (M, P), y (M,), w (M,) or None)``
    (loop in Rust, GIL released). A degenerate or non-finite row raises with the Rust
    message (``"sample i: ..."`` in ``update_many``; rows before it stay applied) and
    leaves the state as it was before that row.
    """

    __slots__ = ("_e",)

    def __init__(self, p: int, p0: float = 1e4, forgetting: float = 1.0,
                 max_variance: Optional[float] = None, outlier_gate: Optional[float] = None):
        self._e = _ivdyn.Rls(int(p), float(p0), float(forgetting), _opt_float(max_variance),
                             _opt_float(outlier_gate))

    @property
    def p(self) -> int:
        return self._e.p

    def update(self, phi, y: float, w: float = 1.0) -> None:
        self._e.update(_f64(phi, "phi", 1, f"({self.p},)"), float(y), float(w))

    def update_many(self, Phi, y, w=None) -> None:
        Phi, y, w = _fit_inputs(Phi, y, w)
        if Phi.shape[1] != self.p:
            raise ValueError(f"Phi must have shape (M, {self.p}), got {Phi.shape}")
        self._e.update_many(Phi, y, w)

    @property
    def theta(self) -> np.ndarray:
        """Current estimate ``(P,)`` (a copy)."""
        return self._e.theta

    @property
    def covariance(self) -> np.ndarray:
        """Covariance ``(P, P)`` (``U D U^T``, symmetric positive definite)."""
        return self._e.covariance

    @property
    def count(self) -> int:
        """Rows processed."""
        return self._e.count

    @property
    def max_variance(self) -> float:
        """Anti-windup bound under forgetting."""
        return self._e.max_variance

    @property
    def outlier_gate(self) -> float:
        """Normalised-innovation gate (``inf`` = none)."""
        return self._e.outlier_gate

    def __repr__(self) -> str:
        return repr(self._e)


class Riv:
    """Recursive instrumental variables: rows ``phi``, instruments ``z``, outputs ``y``;
    starts at ``theta = 0``, ``P = p0 I``; ``P`` tracks ``(sum w z phi^T)^-1``.

    ``update(phi (P,), z (P,), y, w=1.0)``; ``update_many(Phi (M, P), Z (M, P), y (M,),
    w=None)`` (loop in Rust, GIL released). Degenerate updates (instrument uncorrelated
    with the regressor) raise ``RuntimeError`` and leave the state untouched.

    ``forgetting`` is exponential; ``max_variance`` (``None`` = ``p0``) bounds every
    ``|P_ii|`` under forgetting (a diagonal rescaling ``P <- S P S``). ``outlier_gate`` and
    the out-of-range rule are those of :class:`Rls`, with ``|phi| |P z|`` for
    ``phi^T P phi``.
    """

    __slots__ = ("_e",)

    def __init__(self, p: int, p0: float = 1e4, forgetting: float = 1.0,
                 max_variance: Optional[float] = None, outlier_gate: Optional[float] = None):
        self._e = _ivdyn.Riv(int(p), float(p0), float(forgetting), _opt_float(max_variance),
                             _opt_float(outlier_gate))

    @property
    def p(self) -> int:
        return self._e.p

    def update(self, phi, z, y: float, w: float = 1.0) -> None:
        shape = f"({self.p},)"
        self._e.update(_f64(phi, "phi", 1, shape), _f64(z, "z", 1, shape), float(y), float(w))

    def update_many(self, Phi, Z, y, w=None) -> None:
        Phi, y, w = _fit_inputs(Phi, y, w)
        if Phi.shape[1] != self.p:
            raise ValueError(f"Phi must have shape (M, {self.p}), got {Phi.shape}")
        Z = _f64(Z, "Z", 2, f"{Phi.shape}")
        if Z.shape != Phi.shape:
            raise ValueError(f"Z must have the shape of Phi {Phi.shape}, got {Z.shape}")
        self._e.update_many(Phi, Z, y, w)

    @property
    def theta(self) -> np.ndarray:
        """Current estimate ``(P,)`` (a copy)."""
        return self._e.theta

    @property
    def P(self) -> np.ndarray:
        """``(P, P)``, ``(sum w z phi^T)^-1`` (not symmetric in general)."""
        return self._e.P

    @property
    def count(self) -> int:
        """Rows processed."""
        return self._e.count

    @property
    def max_variance(self) -> float:
        """Anti-windup bound under forgetting."""
        return self._e.max_variance

    @property
    def outlier_gate(self) -> float:
        """Normalised-innovation gate (``inf`` = none)."""
        return self._e.outlier_gate

    def __repr__(self) -> str:
        return repr(self._e)


def read_joint_states(path: Union[str, os.PathLike], joint_names, topic: str = "/joint_states",
                      command_topic: Optional[str] = None) -> dict:
    """Reads a joint log: ``.csv`` (columns ``t``, ``<joint>.q``, ``.qd``, ``.tau``, ``.u``,
    ``.i``), or a ROS 2 recording of ``sensor_msgs/msg/JointState`` (streamed): a bag
    directory as ``ros2 bag record`` writes it (``metadata.yaml`` and its split ``.mcap``
    or ``.db3`` files read in order as one log, zstd-compressed or not), or one ``.mcap``,
    ``.db3``, ``.mcap.zstd`` or ``.db3.zstd`` file (docs/logs.md, "ROS 2 bags").

    ``joint_names``: the joints wanted, in order (a list, or an :class:`ivdyn.Robot`
    for its ``joint_names``); other joints in the log are ignored. ``topic``: measured
    topic; ``command_topic``: optional topic whose effort is the actuator command ``u``
    (MCAP only). Returns ``{"t": (T,) s since the first sample, "q": (T, N) rad,
    "qd": (T, N) rad/s or None, "tau": (T, N) N m or None, "u": (T, N) or None,
    "current": (T, N) A (motor current, CSV ``.i``) or None, "joint_names": [...], "t0_ns":
    int, "truncated": bool}``.
    Raises ``FileNotFoundError`` / ``ValueError`` (missing joints or topic, corrupt file,
    non-finite values, stamps going back) with the file, topic, sample and joint.
    """
    names = getattr(joint_names, "joint_names", joint_names)
    if isinstance(names, str):
        raise ValueError("joint_names must be a list of joint names, not a string")
    return _ivdyn.read_joint_states(os.fspath(path), [str(n) for n in names], str(topic),
                                    None if command_topic is None else str(command_topic))

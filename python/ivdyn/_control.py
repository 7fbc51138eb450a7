"""Terminal-link (payload) estimation and closed-loop simulation from NumPy.

Wrappers over the native module: inputs are checked and converted to C-contiguous float64
here; the work is done in Rust (``ivdyn::ident::arrays::terminal_link_run`` over the core's
``TerminalLink``, the core's ``Simulator`` with its ``ComputedTorque`` / ``Pd``
controllers, ``ivdyn_lab::control::Experiment``) with the GIL released.
"""
from __future__ import annotations

from typing import Any, Dict, Optional, Sequence, Union

import numpy as np

from . import _ivdyn
from ._guard import real_array
from ._ident import BaseParams

_DRIVE = ("fc", "fv", "ia", "tau0")


def _native(robot, name: str = "robot"):
    native = getattr(robot, "_r", robot)
    if not isinstance(native, _ivdyn.Robot):
        raise TypeError(f"{name} must be an ivdyn.Robot, got {type(robot).__name__}")
    return native


def _rows(x, name: str, t: Optional[int], n: int) -> np.ndarray:
    """``x`` as C-contiguous float64 ``(T, n)`` (``T`` = ``t`` when given), or ValueError."""
    want = f"({'T' if t is None else t}, {n})"
    a = real_array(x, name, shape=want)
    if a.ndim != 2 or a.shape[1] != n or (t is not None and a.shape[0] != t):
        raise ValueError(f"{name} must have shape {want}, got {a.shape}")
    return np.ascontiguousarray(a)


def _drive(drive: Sequence[str]) -> list:
    if isinstance(drive, str):
        drive = [drive]
    out = [str(d) for d in drive]
    for d in out:
        if d not in _DRIVE:
            raise ValueError(f"drive: unknown drive parameter {d!r} (expected some of {_DRIVE})")
    return out


def terminal_base(robot, k: Optional[int] = None, drive: Sequence[str] = (),
                  first_row: Optional[int] = None, samples: int = 200, seed: int = 42) -> BaseParams:
    """Identifiable columns of the terminal-link problem of ``robot`` (paper eqs 38-46).

    The unknowns are the 10 inertial parameters of links ``k..N-1`` (0-based; default
    ``N-1``, the last link, i.e. a payload) plus the drive parameters named in ``drive``
    (some of ``"fc", "fv", "ia", "tau0"``) of their joints; the rows are the torques of
    joints ``first_row..N-1`` (default ``k``, the paper's choice; ``0`` lets every joint
    see a payload, which makes its mass identifiable). Found numerically from the rows at
    ``samples`` random states. Returns a :class:`BaseParams` over the terminal columns:
    ``independent`` are the columns to estimate (pass them to :func:`terminal_link`),
    ``names`` the combinations their estimates stand for.
    """
    return BaseParams(_ivdyn.terminal_base(_native(robot), None if k is None else int(k), _drive(drive),
                                           None if first_row is None else int(first_row), int(samples), int(seed)))


def terminal_link(robot, q, qd, qdd, tau, method: str = "iv", *, qdd_instr=None, u=None,
                  k: Optional[int] = None, drive: Sequence[str] = (), first_row: Optional[int] = None,
                  columns: Optional[Sequence[int]] = None, row_weight=None, p0: float = 1e4,
                  min_speed: float = 0.0, record: Optional[Sequence[int]] = None) -> Dict[str, Any]:
    """Online terminal-link estimation (Kawasaki and Nishimura, eqs 38-54) over a batch of
    samples: the change of the last links' parameters from the torque residual against
    ``robot`` (the nominal model), ``tau - rnea_nominal(q, qd, qdd) = Y_terminal dx``,
    estimated recursively (``Rls`` / ``Riv`` from ``dx = 0``, ``P0 = p0 I``) sample by
    sample in Rust, GIL released.

    ``q`` (rad), ``qd`` (rad/s), ``qdd`` (rad/s^2, the measured, noisy acceleration) and
    ``tau`` (N m): ``(T, N)``. ``method``: ``"iv"`` (the paper's IVM) or ``"ls"`` (LSM,
    biased by acceleration noise). IV needs one instrument: ``qdd_instr`` ``(T, N)``
    (instrumental accelerations, e.g. the planned ones) or ``u`` ``(T, N)``, the actuator
    command (N m) driving the paper's eq-35 model with the nominal model's ``1 / M_ii`` and
    ``fv / M_ii`` at the mean pose (sample 0 is then not used: eq 35 needs ``qd(j-1)``).

    ``k``, ``drive``, ``first_row``: the unknown set, as in :func:`terminal_base`;
    ``columns``: estimated columns (default: ``terminal_base(...).independent``);
    ``row_weight``: ``(N,)`` weight of each joint's row (default 1); ``min_speed``: rows of
    joints slower than this (rad/s) are skipped; ``record``: strictly increasing sample
    counts after which the estimate is kept.

    Returns ``{"names": B names, "theta": (B,) final estimate (kg, kg m, kg m^2, N m, ...),
    "trace": (len(record), B), "record", "P": (B, B) (LS: the covariance of theta up to the
    noise variance; IV: (sum w z phi^T)^-1), "rows_used", "rows_skipped", "method"}``.
    Raises ``ValueError`` for bad shapes or options, ``RuntimeError`` naming the sample for
    a numerical failure (non-finite data, a degenerate update).
    """
    native = _native(robot)
    n = native.dof
    if method not in ("iv", "ls"):
        raise ValueError(f"method must be 'iv' or 'ls', got {method!r}")
    q = _rows(q, "q", None, n)
    t = q.shape[0]
    qd, qdd, tau = (_rows(x, name, t, n) for x, name in ((qd, "qd"), (qdd, "qdd"), (tau, "tau")))
    z = None if qdd_instr is None else _rows(qdd_instr, "qdd_instr", t, n)
    uu = None if u is None else _rows(u, "u", t, n)
    drive = _drive(drive)
    k_ = None if k is None else int(k)
    f_ = None if first_row is None else int(first_row)
    if columns is None:
        cols = _ivdyn.terminal_base(native, k_, drive, f_, 200, 42).independent
    else:
        cols = [int(c) for c in columns]
    w = None if row_weight is None else [float(x) for x in real_array(row_weight, "row_weight").ravel()]
    rec = [] if record is None else [int(r) for r in np.asarray(record).ravel()]
    return _ivdyn.terminal_link(native, q, qd, qdd, tau, cols, k_, drive, f_, method == "iv", z, uu, w,
                                float(p0), float(min_speed), rec)


def closed_loop(robot, q_des, qd_des, qdd_des, dt: float, controller: str = "computed_torque", *,
                model=None, wn: float = 20.0, zeta: float = 1.0, coulomb: str = "reference",
                q0=None, qd0=None, tau_limit=None, encoder_bits: Optional[int] = None,
                q_noise: float = 0.0, tau_noise: float = 0.0, substeps: int = 10,
                integrator: str = "rk4", coulomb_band: float = 0.05,
                velocity_cutoff_hz: float = 0.0, seed: int = 0) -> Dict[str, np.ndarray]:
    """Simulates ``robot`` (the true arm) tracking a reference under a controller, in Rust
    (``ivdyn_core::sim::Simulator`` with ``control::ComputedTorque`` or ``control::Pd``),
    one control step per reference sample, GIL released.

    Reference ``q_des`` (rad), ``qd_des`` (rad/s), ``qdd_des`` (rad/s^2): ``(T, N)``
    sampled every ``dt`` s. ``controller``: ``"computed_torque"`` (``tau = M(q)(qdd_des +
    Kd e' + Kp e) + h(q, qd)`` with ``model``), ``"pd"`` or ``"pd_gravity"`` (PD in torque
    units: the same acceleration gains times ``model``'s ``M_ii`` at the mean reference
    pose; plus ``model``'s gravity). ``model``: the controller's :class:`Robot` (default:
    ``robot``, a perfect model). Gains: natural frequency ``wn`` (rad/s) and damping
    ``zeta``; ``coulomb``: the velocity of the computed torque's Coulomb term,
    ``"reference"`` (default: no chatter) or ``"measured"`` (the differentiated encoder:
    its sign chatters at reversals, a ``2 fc`` torque square wave that throws a light
    wrist such as the paper's, ``M_66 ~ 1e-4 kg m^2``, ``fc = 0.1 N m``, off by a radian).

    Simulator: starts at ``q0``, ``qd0`` (default the first reference sample), torque held
    over each period (limits ``tau_limit`` ``(N,)`` N m, default none), ``substeps``
    integration steps (``"rk4"`` or ``"euler"``), Coulomb friction smoothed over
    ``coulomb_band`` rad/s; sensors: ``encoder_bits``-bit encoders, Gaussian ``q_noise``
    (rad) and ``tau_noise`` (N m), velocity by backward differences (optionally low-passed
    at ``velocity_cutoff_hz``), noise seed ``seed``.

    Returns arrays: ``t`` ``(T,)`` s; the true ``q``, ``qd`` and the measured ``q_meas``,
    ``qd_meas`` at ``t`` (before each step), ``u`` (command), ``tau`` (applied, after
    saturation), all ``(T, N)``; ``saturated`` ``(T,)`` bool; and the identification
    samples, one sample late (central differences of the measured position, torques
    averaged over the two periods around each instant): ``id_t`` ``(M,)``, ``id_q``,
    ``id_qd``, ``id_qdd``, ``id_tau`` (measured), ``id_u`` ``(M, N)`` with ``M = T - 1``.
    A failure raises ``RuntimeError`` / ``ValueError`` naming the step.
    """
    native = _native(robot)
    n = native.dof
    q_des = _rows(q_des, "q_des", None, n)
    t = q_des.shape[0]
    qd_des, qdd_des = _rows(qd_des, "qd_des", t, n), _rows(qdd_des, "qdd_des", t, n)
    ctrl = None if model is None else _native(model, "model")

    def vec(x, name):
        if x is None:
            return None
        a = real_array(x, name).ravel()
        if a.shape != (n,):
            raise ValueError(f"{name} must have shape ({n},), got {np.shape(x)}")
        return a.tolist()

    return _ivdyn.closed_loop(native, q_des, qd_des, qdd_des, float(dt), str(controller), ctrl, float(wn),
                              float(zeta), str(coulomb), vec(q0, "q0"), vec(qd0, "qd0"),
                              vec(tau_limit, "tau_limit"), None if encoder_bits is None else int(encoder_bits),
                              float(q_noise), float(tau_noise), int(substeps), str(integrator),
                              float(coulomb_band), float(velocity_cutoff_hz), int(seed))


SCHEMES = ("pd", "pd_gravity", "ct_nominal", "ct_estimated", "ct_true")


def control_experiment(scheme: str, robot: str = "paper", *, urdf: Union[str, None, Any] = None,
                       duration: Optional[float] = None, grasp_time: Optional[float] = None,
                       estimator: str = "iv", instrument: str = "planned", delay: int = 3,
                       p0: Optional[float] = None, switch_error_tol: Optional[float] = None,
                       record_every: Optional[int] = None) -> Dict[str, Any]:
    """One run of the paper's Fig. 5 experiment (``ivdyn_lab::control::Experiment``,
    ``docs/control.md``): an arm tracks a periodic trajectory at 1 kHz; at ``grasp_time``
    (default 2 s) a payload is added to the true last link; the controller is one of
    ``SCHEMES``: ``"pd"``, ``"pd_gravity"``, ``"ct_nominal"`` (computed torque, unloaded
    model), ``"ct_estimated"`` (switched online to nominal + the payload estimate of the
    recursive terminal-link estimator), ``"ct_true"``.

    ``robot``: ``"paper"`` (the paper's arm, 0.25 kg payload) or ``"panda"`` (``urdf`` =
    the Panda URDF, 2 kg). ``duration`` (s, default 10), ``estimator`` ``"iv"`` (with
    ``instrument`` ``"planned"`` acceleration or ``"eq35"`` model of the command, delayed
    ``delay`` samples) or ``"ls"``, ``p0``, ``switch_error_tol`` (rad), ``record_every``
    (control steps per record, default 5) override the experiment's defaults.

    Returns ``{"t": (R,), "q_des", "q", "tau": (R, N) records; "t_all": (K,), "err": (K, N)
    tracking error q_des - q at every step (rad); "estimates": {"t", "theta": (E, B),
    "mass_std", "err_std"} (ct_estimated only); "names": B estimated columns; "truth": (B,)
    the payload's values of them; "mass_index", "payload_mass" (kg), "grasp_time",
    "switch_time" (s or None), "saturated_steps", "rms_after_switch", "peak_after_switch"
    (N,) rad}``.
    """
    if scheme not in SCHEMES:
        raise ValueError(f"scheme must be one of {SCHEMES}, got {scheme!r}")
    import os
    return _ivdyn.control_experiment(scheme, str(robot), None if urdf is None else os.fspath(urdf),
                                     None if duration is None else float(duration),
                                     None if grasp_time is None else float(grasp_time), str(estimator),
                                     str(instrument), int(delay), None if p0 is None else float(p0),
                                     None if switch_error_tol is None else float(switch_error_tol),
                                     None if record_every is None else int(record_every))

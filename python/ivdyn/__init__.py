"""ivdyn: robot-arm dynamics from NumPy.

Inverse and forward dynamics, gravity torques, mass matrices and the joint-torque
regressor of serial arms (URDF, standard DH, or the paper's robot), computed by the
Rust library ``ivdyn`` (multi-threaded over samples, GIL released); identification
(:func:`fit_ls`, :func:`fit_iv`, :func:`base_params`, :func:`payload_from_fit`,
:class:`Rls`, :class:`Riv`, the terminal-link estimator :func:`terminal_link`), log
reading (:func:`read_joint_states`), closed-loop simulation (:func:`closed_loop`,
:func:`control_experiment`), the command line's pipelines (:func:`identify`,
:func:`payload`, :func:`drive_gains`, :func:`simulate`), the paper's simulation study
(:mod:`ivdyn.paper`) and plotting helpers (:mod:`ivdyn.plot`).

Conventions (SI units throughout: m, kg, s, rad, N, N m):

* ``N`` = number of movable joints (``robot.dof``), ``T`` = number of samples.
* Joint-space inputs ``q`` (rad or m), ``qd`` (rad/s or m/s), ``qdd`` (rad/s^2 or m/s^2),
  ``tau`` (N m or N) have shape ``(N,)`` for one sample or ``(T, N)`` for ``T`` samples;
  outputs follow the batchedness of the input. Anything ``np.asarray`` accepts works
  (lists, float32, strided views); it is converted to contiguous float64.
* Parameters ``theta`` (``robot.params``), shape ``(14 N,)``: per link
  ``[m, m*cx, m*cy, m*cz, Ixx, Ixy, Iyy, Ixz, Iyz, Izz]`` (kg, kg m, kg m^2; about the link
  frame origin in link coordinates, Pinocchio's order) for links 1..N, then per joint
  ``[fc, fv, ia, tau0]`` (Coulomb N m, viscous N m s/rad, armature kg m^2, offset N m)
  for joints 1..N. ``robot.param_names`` names them.
* Inertia 6-vectors everywhere in this API (``payload_inertia=``, :func:`payload_from_fit`)
  are in that order, ``[Ixx, Ixy, Iyy, Ixz, Iyz, Izz]`` (:data:`INERTIA_ORDER`); URDF files
  and the JSON reports that follow them (``payload(...)["inertia"]``, ``diagnosis.json``)
  keep URDF attribute order ``[Ixx, Ixy, Ixz, Iyy, Iyz, Izz]``: :func:`inertia_to_urdf`,
  :func:`inertia_from_urdf` convert.
* ``regressor(q, qd, qdd) @ robot.params == rnea(q, qd, qdd)``.

Example::

    import numpy as np, ivdyn
    robot = ivdyn.Robot.from_urdf("fixtures/ur5.urdf", base="base_link", tip="tool0")
    q = np.zeros(robot.dof)
    tau = robot.rnea(q, q, q)                       # (6,)
    Y = robot.regressor(np.random.rand(1000, 6), np.zeros((1000, 6)), np.zeros((1000, 6)))
    Y.shape                                         # (1000, 6, 84)
"""
from __future__ import annotations

import os
from typing import Optional, Sequence, Tuple

import numpy as np

from . import _ivdyn
from ._guard import real_array


__all__ = [
    "Robot", "MAX_DOF", "__version__",
    # identification (python/ivdyn/_ident.py)
    "fit_ls", "fit_iv", "fit_robot", "FitReport", "base_params", "BaseParams", "payload_from_fit",
    "Rls", "Riv", "read_joint_states",
    # inertia 6-vector orders (ivdyn's; URDF's in files)
    "INERTIA_ORDER", "INERTIA_URDF_ORDER", "inertia_to_urdf", "inertia_from_urdf",
    # terminal link, closed-loop simulation, control experiments (python/ivdyn/_control.py)
    "terminal_base", "terminal_link", "closed_loop", "control_experiment",
    # the command line's pipelines (python/ivdyn/_pipeline.py)
    "identify", "payload", "drive_gains", "simulate", "diagnose", "excite", "tqdm_progress",
    # readable results (python/ivdyn/_results.py)
    "IdentifyResult", "PayloadResult", "read_prediction",
    # submodules
    "paper", "plot",
]

__version__: str = _ivdyn.__version__
#: Largest supported number of movable joints.
MAX_DOF: int = _ivdyn.MAX_DOF

from ._ident import (  # noqa: E402
    INERTIA_ORDER, INERTIA_URDF_ORDER, BaseParams, FitReport, Riv, Rls, base_params, fit_iv, fit_ls,
    fit_robot, inertia_from_urdf, inertia_to_urdf, payload_from_fit, read_joint_states,
)
from ._results import IdentifyResult, PayloadResult, read_prediction  # noqa: E402
from ._control import closed_loop, control_experiment, terminal_base, terminal_link  # noqa: E402
from ._pipeline import diagnose, drive_gains, excite, identify, payload, simulate, tqdm_progress  # noqa: E402
from . import paper, plot  # noqa: E402


class Robot:
    """A serial robot arm: joint/link names, its parameters, and its dynamics.

    Build one with :meth:`from_urdf`, :meth:`from_dh` or :meth:`paper`. Every
    joint-space vector is ordered like :attr:`joint_names` (base to tip).
    """

    __slots__ = ("_r",)

    def __init__(self, native: "_ivdyn.Robot"):
        """Wraps a native robot; use the constructors :meth:`from_urdf`, :meth:`from_dh`,
        :meth:`paper` instead."""
        if not isinstance(native, _ivdyn.Robot):
            raise TypeError("use Robot.from_urdf, Robot.from_dh or Robot.paper to build a Robot")
        self._r = native

    # ------------------------------------------------------------------ constructors
    @classmethod
    def from_urdf(cls, path, base: Optional[str] = None, tip: Optional[str] = None,
                  fuse_beyond_tip: bool = False) -> "Robot":
        """Loads the serial chain from ``base`` to ``tip`` (link names) of a URDF file.

        Fixed joints are fused; movable joints off the chain (side branches) are locked at
        0 and fused (listed in :attr:`locked_joints` and :attr:`fused_links`). ``base``
        defaults to the root, ``tip`` to the end of the chain (required when the tree
        branches); the rigid bodies below that default tip (a flange, a fixed tool) are
        fused. A ``tip`` given ends the chain: the bodies below it (a hand and its fingers
        beyond a flange) are dropped (:attr:`dropped_links`), unless ``fuse_beyond_tip``
        fuses them into the last link as the tool the arm carries. Inertial parameters come
        from the file, drive parameters from ``<dynamics friction damping>`` (``fc``,
        ``fv``; zero when absent); gravity is ``(0, 0, -9.81)`` m/s^2
        in the base frame.

        Raises ``FileNotFoundError`` if the file does not exist and ``ValueError`` for
        unusable contents (parse errors, unknown links, unsupported joints, ...).
        """
        return cls(_ivdyn.Robot.from_urdf(os.fspath(path), base, tip, bool(fuse_beyond_tip)))

    @classmethod
    def from_dh(cls, a: Sequence[float], d: Sequence[float], alpha: Sequence[float],
                offset: Optional[Sequence[float]] = None) -> "Robot":
        """A revolute arm from a standard (distal) DH table, one entry per joint:
        ``T_{i-1,i} = Rz(q_i + offset_i) Tz(d_i) Tx(a_i) Rx(alpha_i)``.

        ``a``, ``d`` in m, ``alpha``, ``offset`` in rad (``offset`` defaults to 0). All
        parameters are zero (set :attr:`params`); joints ``joint1..``, links ``link1..``
        (link ``i``'s frame is joint ``i``'s frame: origin on joint ``i``'s axis, z along it).
        """
        def vec(x, name):
            return real_array(x, name).ravel().tolist()
        return cls(_ivdyn.Robot.from_dh(vec(a, "a"), vec(d, "d"), vec(alpha, "alpha"),
                                        None if offset is None else vec(offset, "offset")))

    @classmethod
    def paper(cls) -> "Robot":
        """The six-joint robot of Kawasaki and Nishimura's paper (Tables 1 and 2):
        DH geometry, link inertias, Coulomb friction ``fc = F``; joints ``joint1..6``."""
        return cls(_ivdyn.Robot.paper())

    def copy(self) -> "Robot":
        """An independent copy (e.g. to change :attr:`params` without touching this one)."""
        return Robot(self._r.copy())

    __copy__ = copy

    def __deepcopy__(self, memo) -> "Robot":
        return self.copy()

    # ------------------------------------------------------------------ description
    @property
    def name(self) -> str:
        """Robot name (URDF ``<robot name>``, ``"paper"``, ``"dh"``)."""
        return self._r.name

    @property
    def dof(self) -> int:
        """Number of movable joints ``N``."""
        return self._r.dof

    @property
    def joint_names(self) -> list:
        """Movable joint names, base to tip: the order of every joint-space vector."""
        return self._r.joint_names

    @property
    def link_names(self) -> list:
        """Link of each joint (its URDF child link), base to tip."""
        return self._r.link_names

    @property
    def base_link(self) -> str:
        """The base link (its frame is the base frame; gravity is given in it)."""
        return self._r.base_link

    @property
    def tip_link(self) -> str:
        """The tip link (the tool frame)."""
        return self._r.tip_link

    @property
    def locked_joints(self) -> list:
        """Movable joints off the chain, locked at q = 0 and fused into the chain."""
        return self._r.locked_joints

    @property
    def fused_links(self) -> list:
        """Links off the chain (side branches; the bodies below the tip when fused) whose
        inertia is in a model link, as ``(link, model link)`` pairs."""
        return self._r.fused_links

    @property
    def dropped_links(self) -> list:
        """Links below the given tip that are not in the model (see :meth:`from_urdf`)."""
        return self._r.dropped_links

    @property
    def notes(self) -> list:
        """What loading left out of the chain and where it went (fused, dropped links), and
        the links whose inertials no body has (a negative principal moment, broken triangle
        inequalities: CAD exports have them), one sentence each: the command line's ``note:``
        lines. Empty for a plain chain of physical links."""
        return self._r.notes

    @property
    def num_params(self) -> int:
        """``14 N``."""
        return 14 * self.dof

    @property
    def param_names(self) -> list:
        """Names of the ``14 N`` parameters: ``"<link>.m"``, ``"<link>.m*cx"``, ...,
        ``"<link>.Izz"`` for every link, then ``"<joint>.fc"``, ``.fv``, ``.ia``, ``.tau0``."""
        return self._r.param_names

    @property
    def params(self) -> np.ndarray:
        """Parameter vector ``theta``, shape ``(14 N,)`` (a copy; assign to change it).

        Layout: 10 inertial parameters per link ``[m, m*cx, m*cy, m*cz, Ixx, Ixy, Iyy,
        Ixz, Iyz, Izz]`` (kg, kg m, kg m^2, about the link origin, link coordinates) for
        links 1..N, then 4 drive parameters per joint ``[fc, fv, ia, tau0]`` (N m,
        N m s/rad, kg m^2, N m) for joints 1..N.
        """
        return self._r.params

    @params.setter
    def params(self, theta) -> None:
        theta = real_array(theta, "params")
        if theta.shape != (self.num_params,):
            raise ValueError(f"params must have shape ({self.num_params},), got {theta.shape}")
        self._r.params = theta

    def __repr__(self) -> str:
        return (f"Robot(name={self.name!r}, dof={self.dof}, base_link={self.base_link!r}, "
                f"tip_link={self.tip_link!r}, joints={self.joint_names!r})")

    # ------------------------------------------------------------------ inputs
    def _inputs(self, names, arrays) -> Tuple[list, bool]:
        """Converts the arrays to contiguous float64 ``(T, N)``; returns them and whether
        the call is batched. The first argument sets the batchedness and ``T``."""
        n = self._r.dof
        out = []
        first = None
        for name, x in zip(names, arrays):
            a = real_array(x, name)
            if first is None:
                first = a.shape
                if first == (n,):
                    batched = False
                elif a.ndim == 2 and first[1] == n:
                    batched = True
                else:
                    raise ValueError(f"{name} must have shape ({n},) or (T, {n}), got {first}")
            elif a.shape != first:
                raise ValueError(f"{name} must have shape {first} like {names[0]}, got {a.shape}")
            if not a.flags.c_contiguous:
                a = np.ascontiguousarray(a)
            out.append(a if batched else a.reshape(1, n))
        return out, batched

    @staticmethod
    def _out(out, batched: bool, shape: Tuple[int, ...]):
        """The caller's output array as the native batched shape (a view), or None."""
        if out is None:
            return None
        if not isinstance(out, np.ndarray):
            raise ValueError(f"out must be a numpy.ndarray of shape {shape} and dtype float64, "
                             f"got {type(out).__name__}")
        if out.shape != shape:
            raise ValueError(f"out must have shape {shape}, got {out.shape}")
        return out if batched else out[np.newaxis]

    # ------------------------------------------------------------------ dynamics
    def rnea(self, q, qd, qdd, out: Optional[np.ndarray] = None) -> np.ndarray:
        """Inverse dynamics: joint torques (N m; N for prismatic joints) that produce
        accelerations ``qdd`` at ``(q, qd)``, including the drive terms
        ``fc sign(qd) + fv qd + ia qdd + tau0``.

        ``q`` (rad), ``qd`` (rad/s), ``qdd`` (rad/s^2): shape ``(N,)`` -> ``(N,)``, or
        ``(T, N)`` -> ``(T, N)``. ``out``: an optional float64 C-contiguous array of the
        output's shape, written in place and returned (no allocation).
        """
        (q, qd, qdd), batched = self._inputs(("q", "qd", "qdd"), (q, qd, qdd))
        o = self._out(out, batched, q.shape if batched else (self.dof,))
        tau = self._r.rnea(q, qd, qdd, o)
        if out is not None:
            return out
        return tau if batched else tau[0]

    def gravity(self, q, out: Optional[np.ndarray] = None) -> np.ndarray:
        """Gravity torques ``g(q)`` (N m), no drive terms. ``q`` (rad): ``(N,)`` -> ``(N,)``
        or ``(T, N)`` -> ``(T, N)``; ``out`` as in :meth:`rnea`."""
        (q,), batched = self._inputs(("q",), (q,))
        g = self._r.gravity(q, self._out(out, batched, q.shape if batched else (self.dof,)))
        if out is not None:
            return out
        return g if batched else g[0]

    def regressor(self, q, qd, qdd, rigid_only: bool = False,
                  out: Optional[np.ndarray] = None) -> np.ndarray:
        """Joint-torque regressor ``Y`` with ``Y @ params == rnea(q, qd, qdd)``.

        ``(N,)`` inputs -> ``(N, P)``; ``(T, N)`` inputs -> ``(T, N, P)``, with ``P = 14 N``
        (columns ordered like :attr:`params`), or ``P = 10 N`` (the inertial columns only,
        equal to Pinocchio's ``computeJointTorqueRegressor``) when ``rigid_only``.

        ``out``: an optional float64 C-contiguous array of that shape, written in place
        (every entry) and returned. Reusing one buffer over calls saves the allocation and
        the kernel's zeroing of fresh pages, a large part of the time for big batches
        (``benches/README.md``: 100 000 UR5 samples are 288 MB).
        """
        (q, qd, qdd), batched = self._inputs(("q", "qd", "qdd"), (q, qd, qdd))
        n = self.dof
        p = (10 if rigid_only else 14) * n
        shape = (q.shape[0], n, p) if batched else (n, p)
        y = self._r.regressor(q, qd, qdd, bool(rigid_only), self._out(out, batched, shape))
        if out is not None:
            return out
        return y if batched else y[0]

    def mass_matrix(self, q, out: Optional[np.ndarray] = None) -> np.ndarray:
        """Joint-space mass matrix ``M(q)`` (kg m^2 for revolute joints), including the
        armature ``ia`` on the diagonal; symmetric positive definite for physical
        parameters. ``q`` (rad): ``(N,)`` -> ``(N, N)`` or ``(T, N)`` -> ``(T, N, N)``;
        ``out`` as in :meth:`rnea`."""
        (q,), batched = self._inputs(("q",), (q,))
        n = self.dof
        m = self._r.mass_matrix(q, self._out(out, batched, (q.shape[0], n, n) if batched else (n, n)))
        if out is not None:
            return out
        return m if batched else m[0]

    def forward_dynamics(self, q, qd, tau, out: Optional[np.ndarray] = None) -> np.ndarray:
        """Forward dynamics: accelerations ``qdd`` (rad/s^2) with
        ``rnea(q, qd, qdd) == tau``, i.e. ``M qdd = tau - h(q, qd) - fc sign(qd) - fv qd
        - tau0``. ``q`` (rad), ``qd`` (rad/s), ``tau`` (N m): ``(N,)`` -> ``(N,)`` or
        ``(T, N)`` -> ``(T, N)``.

        Raises ``RuntimeError`` naming the sample if a mass matrix is not positive
        definite (e.g. all-zero parameters). ``out`` as in :meth:`rnea`.
        """
        (q, qd, tau), batched = self._inputs(("q", "qd", "tau"), (q, qd, tau))
        qdd = self._r.forward_dynamics(q, qd, tau, self._out(out, batched, q.shape if batched else (self.dof,)))
        if out is not None:
            return out
        return qdd if batched else qdd[0]


# every public entry point: a Rust panic becomes RuntimeError, not PanicException (_guard.py)
from ._guard import guard as _guard_api  # noqa: E402

_guard_api(globals(), tuple(__all__))
_guard_api(vars(paper), ("setup", "batch_estimates", "recursive_traces"))


"""Type stubs of the native module ``ivdyn._ivdyn`` (crates/ivdyn-py).

Use the ``ivdyn`` package instead: its ``Robot`` wraps this one, accepts ``(N,)`` or
``(T, N)`` inputs of any dtype and layout, and documents shapes and units. The native
methods take C-contiguous float64 ``(T, N)`` arrays only.
"""
from os import PathLike
from typing import Any, Callable, Dict, List, Optional, Sequence, Tuple, Union, final

import numpy as np
import numpy.typing as npt
from typing_extensions import Self

__all__ = [
    "Robot", "FitReport", "BaseParams", "Rls", "Riv", "PaperSim", "fit_ls", "fit_iv", "base_params",
    "fit_robot", "payload_from_fit", "read_joint_states", "paper_estimators", "terminal_base",
    "terminal_link", "closed_loop", "control_experiment", "identify", "payload", "gains", "simulate", "diagnose",
    "excite", "fleet_log_stats", "fleet_merge", "fleet_stats_info", "fleet_fit", "fleet_drift",
    "fleet_fdr", "fleet_describe",
    "batch_threads", "__version__", "MAX_DOF", "inertia_to_urdf", "inertia_from_urdf", "INERTIA_ORDER",
    "INERTIA_URDF_ORDER",
]

__version__: str
MAX_DOF: int

_F64 = npt.NDArray[np.float64]

def batch_threads(t: int) -> int:
    """Number of threads the batch functions use for ``t`` samples."""

INERTIA_ORDER: List[str]
INERTIA_URDF_ORDER: List[str]

def inertia_to_urdf(i: Sequence[float]) -> List[float]:
    """``[Ixx, Ixy, Iyy, Ixz, Iyz, Izz]`` (ivdyn) -> ``[Ixx, Ixy, Ixz, Iyy, Iyz, Izz]`` (URDF)."""

def inertia_from_urdf(u: Sequence[float]) -> List[float]:
    """``[Ixx, Ixy, Ixz, Iyy, Iyz, Izz]`` (URDF) -> ``[Ixx, Ixy, Iyy, Ixz, Iyz, Izz]`` (ivdyn)."""

@final
class Robot:
    @staticmethod
    def from_urdf(path: Union[str, PathLike], base: Optional[str] = None,
                  tip: Optional[str] = None, fuse_beyond_tip: bool = False) -> Robot: ...
    @staticmethod
    def paper() -> Robot: ...
    @staticmethod
    def from_dh(a: Sequence[float], d: Sequence[float], alpha: Sequence[float],
                offset: Optional[Sequence[float]] = None) -> Robot: ...
    def copy(self) -> Robot: ...
    @property
    def name(self) -> str: ...
    @property
    def dof(self) -> int: ...
    @property
    def joint_names(self) -> List[str]: ...
    @property
    def link_names(self) -> List[str]: ...
    @property
    def base_link(self) -> str: ...
    @property
    def tip_link(self) -> str: ...
    @property
    def locked_joints(self) -> List[str]: ...
    @property
    def fused_links(self) -> List[Tuple[str, str]]: ...
    @property
    def dropped_links(self) -> List[str]: ...
    @property
    def notes(self) -> List[str]: ...
    @property
    def param_names(self) -> List[str]: ...
    @property
    def params(self) -> _F64:
        """``(14 N,)``"""
    @params.setter
    def params(self, theta: _F64) -> None: ...
    # ``out``: a float64 C-contiguous writeable array of the output's shape, written in
    # place and returned (ValueError otherwise)
    def rnea(self, q: _F64, qd: _F64, qdd: _F64, out: Optional[_F64] = None) -> _F64:
        """``(T, N)`` x3 -> ``(T, N)``"""
    def gravity(self, q: _F64, out: Optional[_F64] = None) -> _F64:
        """``(T, N)`` -> ``(T, N)``"""
    def regressor(self, q: _F64, qd: _F64, qdd: _F64, rigid_only: bool = False,
                  out: Optional[_F64] = None) -> _F64:
        """``(T, N)`` x3 -> ``(T, N, 14 N)`` or ``(T, N, 10 N)``"""
    def mass_matrix(self, q: _F64, out: Optional[_F64] = None) -> _F64:
        """``(T, N)`` -> ``(T, N, N)``"""
    def forward_dynamics(self, q: _F64, qd: _F64, tau: _F64, out: Optional[_F64] = None) -> _F64:
        """``(T, N)`` x3 -> ``(T, N)``"""

# ---------------------------------------------------------------- identification
# (wrapped by python/ivdyn/_ident.py; the native functions take C-contiguous float64)

@final
class FitReport:
    """Result of :func:`fit_ls` / :func:`fit_iv` (``P`` parameters, ``M`` rows)."""
    @property
    def method(self) -> str:
        """``"LS"`` or ``"IV"``."""
    @property
    def names(self) -> List[str]:
        """``P`` parameter names."""
    @property
    def theta(self) -> _F64:
        """``(P,)`` estimates (``NaN`` for unexcited parameters)."""
    @property
    def std(self) -> _F64:
        """``(P,)`` standard deviations ``sqrt(diag(covariance))``."""
    @property
    def rel_std_pct(self) -> _F64:
        """``(P,)`` ``100 std / |theta|`` (inf where theta is 0)."""
    @property
    def covariance(self) -> _F64:
        """``(P, P)`` covariance of ``theta`` (``NaN`` rows/columns for unexcited ones)."""
    @property
    def sigma2(self) -> float:
        """Noise variance estimate ``rss / (rows - rank)`` (weighted residuals)."""
    @property
    def rows(self) -> int:
        """Rows used (positive weight)."""
    @property
    def rank(self) -> int:
        """Number of estimated (excited) parameters."""
    @property
    def condition_number(self) -> float:
        """``sigma_max / sigma_min`` of ``R`` (``R^T R = Phi^T W Phi``) on the excited columns."""
    @property
    def unexcited(self) -> List[str]:
        """Names of the parameters the data do not excite."""
    @property
    def dwh(self) -> Optional[Dict[str, Any]]:
        """IV only: Durbin-Wu-Hausman test ``{"statistic", "dof", "p_value", "ls_biased"}``."""
    @property
    def theta_ls(self) -> Optional[_F64]:
        """IV only: the LS estimate ``(P,)`` on the same data."""
    def to_dict(self) -> Dict[str, Any]: ...
    def _repr_html_(self) -> str:
        """An HTML table for notebooks (drawn by ``ivdyn._results.fit_report_html``)."""

def fit_ls(phi: _F64, y: _F64, w: Optional[_F64] = None,
           names: Optional[List[str]] = None) -> FitReport:
    """``phi`` ``(M, P)``, ``y`` ``(M,)``, ``w`` ``(M,)`` -> weighted LS."""
def fit_iv(phi: _F64, z: _F64, y: _F64, w: Optional[_F64] = None,
           names: Optional[List[str]] = None) -> FitReport:
    """``phi``, ``z`` ``(M, P)``, ``y`` ``(M,)``, ``w`` ``(M,)`` -> instrumental variables."""

@final
class BaseParams:
    """``theta_base = theta[independent] + K @ theta[dependent]``."""
    @property
    def names(self) -> List[str]: ...
    @property
    def independent(self) -> List[int]: ...
    @property
    def dependent(self) -> List[int]: ...
    @property
    def zero_columns(self) -> List[int]: ...
    @property
    def K(self) -> _F64:
        """``(B, P - B)``"""
    @property
    def full_cols(self) -> int: ...
    @property
    def base_count(self) -> int: ...
    def project(self, theta_full: _F64) -> _F64:
        """``(P,)`` -> ``(B,)``"""
    def to_full(self, theta_base: _F64) -> _F64:
        """``(B,)`` -> ``(P,)``"""
    def select(self, y_full: _F64) -> _F64:
        """``(M, P)`` -> ``(M, B)``"""

def base_params(robot: Robot, samples: int = 100, seed: int = 1, rigid_only: bool = False) -> BaseParams: ...
def fit_robot(robot: Robot, base: BaseParams, q: _F64, qd: _F64, qdd: _F64, tau: _F64,
              joint_weight: Optional[_F64] = None) -> FitReport:
    """Fused multi-threaded LS fit of ``base`` from ``(T, N)`` samples (rad, rad/s,
    rad/s^2, N m); the regressor is never stored."""
def payload_from_fit(base: BaseParams, fit: FitReport, cols: List[int],
                     full_names: List[str]) -> Dict[str, Any]:
    """``{"mass", "com" (3,), "inertia" (6,), "mass_std", "com_std", "inertia_std",
    "params" (10,), "physical"}`` (the physically possible payload nearest to the fit;
    ``physical``: the fit's own and the distance); ``ValueError`` when not identifiable."""

@final
class Rls:
    def __new__(cls, p: int, p0: float = 1e4, forgetting: float = 1.0,
                max_variance: Optional[float] = None,
                outlier_gate: Optional[float] = None) -> Self: ...
    def update(self, phi: _F64, y: float, w: float = 1.0) -> None:
        """``phi`` ``(P,)``"""
    def update_many(self, phi: _F64, y: _F64, w: Optional[_F64] = None) -> None:
        """``phi`` ``(M, P)``, ``y``, ``w`` ``(M,)``"""
    @property
    def p(self) -> int: ...
    @property
    def theta(self) -> _F64:
        """``(P,)``"""
    @property
    def covariance(self) -> _F64:
        """``(P, P)``"""
    @property
    def count(self) -> int: ...
    @property
    def forgetting(self) -> float: ...
    @property
    def max_variance(self) -> float: ...
    @property
    def outlier_gate(self) -> float: ...

@final
class Riv:
    def __new__(cls, p: int, p0: float = 1e4, forgetting: float = 1.0,
                max_variance: Optional[float] = None,
                outlier_gate: Optional[float] = None) -> Self: ...
    def update(self, phi: _F64, z: _F64, y: float, w: float = 1.0) -> None:
        """``phi``, ``z`` ``(P,)``"""
    def update_many(self, phi: _F64, z: _F64, y: _F64, w: Optional[_F64] = None) -> None:
        """``phi``, ``z`` ``(M, P)``, ``y``, ``w`` ``(M,)``"""
    @property
    def p(self) -> int: ...
    @property
    def theta(self) -> _F64:
        """``(P,)``"""
    @property
    def P(self) -> _F64:
        """``(P, P)``, ``(sum w z phi^T)^-1``"""
    @property
    def count(self) -> int: ...
    @property
    def forgetting(self) -> float: ...
    @property
    def max_variance(self) -> float: ...
    @property
    def outlier_gate(self) -> float: ...

def read_joint_states(path: Union[str, PathLike], joint_names: List[str],
                      topic: str = "/joint_states",
                      command_topic: Optional[str] = None) -> Dict[str, Any]:
    """``{"t": (T,), "q": (T, N), "qd"/"tau"/"u": (T, N) or None, "joint_names",
    "t0_ns", "truncated"}``"""

@final
class PaperSim:
    """The paper's simulation set-up for one seed of nominal-model errors."""
    def __new__(cls, seed: int) -> Self: ...
    @property
    def seed(self) -> int: ...
    @property
    def base_names(self) -> List[str]: ...
    @property
    def full_names(self) -> List[str]: ...
    @property
    def truth_base(self) -> _F64:
        """``(B,)``"""
    @property
    def dt(self) -> float:
        """Sampling period, s."""
    @property
    def accel_noise(self) -> float:
        """Std of the measured-acceleration noise, rad/s^2 (settable, >= 0)."""
    @accel_noise.setter
    def accel_noise(self, v: float) -> None: ...
    @property
    def row_weight(self) -> List[float]: ...
    def batch_estimates(self, noise_seed: int, checkpoints: List[int]) -> _F64:
        """``(4, len(checkpoints), B)``"""
    def recursive_traces(self, noise_seed: int, record: List[int], p0: float = 1e4) -> _F64:
        """``(4, len(record), B)``"""

def paper_estimators() -> List[str]: ...

# ---------------------------------------------------------------- terminal link, control
# (wrapped by python/ivdyn/_control.py)

def terminal_base(robot: Robot, k: Optional[int] = None, drive: List[str] = ...,
                  first_row: Optional[int] = None, samples: int = 200, seed: int = 42) -> BaseParams:
    """Identifiable columns of the terminal unknowns (links ``k..N-1`` + ``drive``) seen by
    rows ``first_row..N-1``."""
def terminal_link(robot: Robot, q: _F64, qd: _F64, qdd: _F64, tau: _F64, columns: List[int],
                  k: Optional[int] = None, drive: List[str] = ..., first_row: Optional[int] = None,
                  iv: bool = True, qdd_instr: Optional[_F64] = None, u: Optional[_F64] = None,
                  row_weight: Optional[List[float]] = None, p0: float = 1e4, min_speed: float = 0.0,
                  record: List[int] = ...) -> Dict[str, Any]:
    """``(T, N)`` arrays -> ``{"names", "theta" (B,), "trace" (R, B), "record", "P" (B, B),
    "rows_used", "rows_skipped", "method"}``"""
def closed_loop(robot: Robot, q_des: _F64, qd_des: _F64, qdd_des: _F64, dt: float,
                controller: str = "computed_torque", model: Optional[Robot] = None, wn: float = 20.0,
                zeta: float = 1.0, coulomb: str = "reference", q0: Optional[List[float]] = None,
                qd0: Optional[List[float]] = None, tau_limit: Optional[List[float]] = None,
                encoder_bits: Optional[int] = None, q_noise: float = 0.0, tau_noise: float = 0.0,
                substeps: int = 10, integrator: str = "rk4", coulomb_band: float = 0.05,
                velocity_cutoff_hz: float = 0.0, seed: int = 0) -> Dict[str, Any]:
    """``(T, N)`` reference -> ``{"t", "q", "qd", "q_meas", "qd_meas", "u", "tau", "saturated",
    "id_t", "id_q", "id_qd", "id_qdd", "id_tau", "id_u"}``"""
def control_experiment(scheme: str, robot: str = "paper", urdf: Optional[Union[str, PathLike[str]]] = None,
                       duration: Optional[float] = None, grasp_time: Optional[float] = None,
                       estimator: str = "iv", instrument: str = "planned", delay: int = 3,
                       p0: Optional[float] = None, switch_error_tol: Optional[float] = None,
                       record_every: Optional[int] = None) -> Dict[str, Any]:
    """One Fig. 5 run (``ivdyn_lab::control::Experiment``)."""

# ---------------------------------------------------------------- pipelines
# (wrapped by python/ivdyn/_pipeline.py; they return the command line's --json text)

_Log = Union[str, PathLike[str], Dict[str, Any]]
_Callback = Optional[Callable[[str, int, int], Any]]
# a number (every joint), one number per joint, {joint: number}, or the command line's text
_PerJoint = Optional[Union[float, Sequence[float], Dict[str, float], str]]

def identify(robot: Robot, log: Union[_Log, List[_Log]], method: str = "wls", validate: Optional[_Log] = None,
             holdout: float = 0.25, topic: str = "/joint_states", command_topic: Optional[str] = None,
             log_time: bool = False, cutoff: Optional[float] = None, decimate: int = 0,
             params_json: Optional[str] = None, progress: _Callback = None,
             friction: Optional[List[str]] = None, armature: bool = True, offset: bool = True,
             consistent: bool = False, in_memory: bool = False, json_out: Optional[str] = None,
             out_params: Optional[str] = None, write_urdf: Optional[str] = None,
             out_mcap: Optional[str] = None, velocity: str = "auto",
             window: Optional[Tuple[float, float]] = None,
             exclude: Optional[List[Tuple[float, float]]] = None, stream: bool = False,
             current_topic: Optional[str] = None, effort: str = "auto",
             torque_constant: _PerJoint = None, gear_ratio: _PerJoint = None,
             motor_constant: _PerJoint = None, coulomb: str = "auto",
             write_mjcf: Optional[str] = None, report: Optional[str] = None) -> str:
    """``ivdyn identify`` -> its ``--json`` document."""
def fleet_log_stats(robot: Robot, log: _Log, name: str, topic: str = "/joint_states", log_time: bool = False,
                    cutoff: Optional[float] = None, decimate: int = 0, params_json: Optional[str] = None,
                    friction: Optional[List[str]] = None, armature: bool = True, offset: bool = True,
                    method: str = "wls", stream: bool = False) -> bytes:
    """One log's fleet statistics (versioned bytes with the model's fingerprint)."""
def fleet_merge(parts: List[bytes]) -> bytes:
    """The merge of fleet statistics."""
def fleet_stats_info(stats: bytes) -> str:
    """JSON ``{"model", "logs", "samples"}`` of fleet statistics."""
def fleet_fit(robot: Robot, stats: bytes, cutoff: Optional[float] = None, decimate: int = 0,
              params_json: Optional[str] = None, friction: Optional[List[str]] = None, armature: bool = True,
              offset: bool = True, method: str = "wls") -> str:
    """JSON ``{"report", "long_run", "logs"}``: the fit of fleet statistics."""
def fleet_drift(robot: Robot, reference: bytes, stats: bytes, robot_id: str, since: str,
                cutoff: Optional[float] = None, decimate: int = 0, params_json: Optional[str] = None,
                friction: Optional[List[str]] = None, armature: bool = True, offset: bool = True,
                method: str = "wls") -> str:
    """JSON list of drift tests (one per effect, with ``words``) of ``stats`` against ``reference``."""
def fleet_fdr(p_values: List[float], q: float) -> List[bool]:
    """Benjamini-Hochberg discoveries at false-discovery rate ``q``."""
def fleet_describe(robot_id: str, test_json: str, since: str) -> str:
    """The words of a drift test (JSON) for ``robot_id``, dated ``since``."""
def diagnose(robot: Robot, log: _Log, out: Optional[str] = None, topic: str = "/joint_states",
             log_time: bool = False, cutoff: Optional[float] = None, alpha: float = 1e-3,
             min_effect: float = 0.5, ignore_log_velocity: bool = False, report: bool = True,
             params_json: Optional[str] = None, json_out: Optional[str] = None,
             progress: _Callback = None, velocity: str = "auto",
             window: Optional[Tuple[float, float]] = None,
             exclude: Optional[List[Tuple[float, float]]] = None, current_topic: Optional[str] = None, effort: str = "auto",
             torque_constant: _PerJoint = None, gear_ratio: _PerJoint = None,
             motor_constant: _PerJoint = None, drives: Optional[bool] = None, verdict: bool = False,
             threads: Optional[int] = None, max_dictionary_gib: Optional[float] = None) -> str:
    """``ivdyn diagnose`` -> ``diagnosis.json`` (and the output directory's files with ``out``);
    with ``verdict``, plus the report's ``verdict`` and ``details``."""
def payload(robot: Robot, log: _Log, before: Optional[_Log] = None, topic: str = "/joint_states",
            log_time: bool = False, cutoff: Optional[float] = None,
            decimate: int = 0, params_json: Optional[str] = None, progress: _Callback = None,
            json_out: Optional[str] = None, write_urdf: Optional[str] = None, payload_as: str = "link",
            velocity: str = "auto", window: Optional[Tuple[float, float]] = None,
            exclude: Optional[List[Tuple[float, float]]] = None, current_topic: Optional[str] = None, effort: str = "auto", torque_constant: _PerJoint = None,
            gear_ratio: _PerJoint = None, motor_constant: _PerJoint = None,
            torque_constant_std: _PerJoint = None, gains: Optional[str] = None,
            write_mjcf: Optional[str] = None, report: Optional[str] = None) -> str:
    """``ivdyn payload`` -> its ``--json`` document."""
def gains(robot: Robot, unloaded: _Log, loaded: _Log, payload_mass: float,
          payload_com: Optional[List[float]] = None, payload_inertia: Optional[List[float]] = None,
          topic: str = "/joint_states", log_time: bool = False, cutoff: Optional[float] = None,
          decimate: int = 0, params_json: Optional[str] = None, progress: _Callback = None,
          json_out: Optional[str] = None, velocity: str = "auto",
          window: Optional[Tuple[float, float]] = None, current_topic: Optional[str] = None,
          effort: str = "auto", max_rel_std: float = 0.1) -> str:
    """``ivdyn gains`` -> its ``--json`` document."""
def simulate(robot: Robot, out: Optional[Union[str, PathLike[str]]] = None, traj_t: Optional[_F64] = None,
             traj_q: Optional[_F64] = None, duration: float = 20.0, rate: float = 500.0, seed: int = 1,
             amplitude: float = 0.8, payload_mass: Optional[float] = None,
             payload_com: Optional[List[float]] = None, payload_inertia: Optional[List[float]] = None,
             fc: Optional[List[float]] = None, fv: Optional[List[float]] = None, noise: float = 0.0,
             noise_q: float = 0.0, encoder_bits: Optional[int] = None, tau_resolution: Optional[float] = None,
             velocity: bool = True, command: bool = False,
             params_json: Optional[str] = None, json_out: Optional[str] = None) -> Tuple[str, Dict[str, Any]]:
    """``ivdyn simulate`` -> (its ``--json`` summary, the log as arrays)."""
def excite(robot: Robot, out: Optional[str] = None, out_mcap: Optional[str] = None, json_out: Optional[str] = None,
           duration: float = 20.0, harmonics: int = 5, f0: float = 0.1, rate: float = 100.0,
           criterion: str = "cond", acc_limit: Optional[List[float]] = None,
           vel_limit: Optional[List[float]] = None, margin: float = 0.01, starts: int = 6,
           iterations: int = 150, random: int = 20, seed: int = 1, params_json: Optional[str] = None,
           progress: _Callback = None) -> Tuple[str, Dict[str, Any]]:
    """``ivdyn excite`` -> (its ``--json`` report, the trajectory as arrays)."""

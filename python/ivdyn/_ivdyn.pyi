"""Type stubs of the native module ``ivdyn._ivdyn`` (crates/ivdyn-py).

Use the ``ivdyn`` package instead: its ``Robot`` wraps this one, accepts ``(N,)`` or
``(T, N)`` inputs of any dtype and layout, and documents shapes and units. The native
methods take C-contiguous float64 ``(T, N)`` arrays only.
"""
from os import PathLike
from typing import Any, Dict, List, Optional, Sequence, Union

import numpy as np
import numpy.typing as npt

__version__: str
MAX_DOF: int

_F64 = npt.NDArray[np.float64]

def batch_threads(t: int) -> int:
    """Number of threads the batch functions use for ``t`` samples."""

class Robot:
    @staticmethod
    def from_urdf(path: Union[str, PathLike], base: Optional[str] = None,
                  tip: Optional[str] = None) -> Robot: ...
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
    def param_names(self) -> List[str]: ...
    @property
    def params(self) -> _F64:
        """``(14 N,)``"""
    @params.setter
    def params(self, theta: _F64) -> None: ...
    def rnea(self, q: _F64, qd: _F64, qdd: _F64) -> _F64:
        """``(T, N)`` x3 -> ``(T, N)``"""
    def gravity(self, q: _F64) -> _F64:
        """``(T, N)`` -> ``(T, N)``"""
    def regressor(self, q: _F64, qd: _F64, qdd: _F64, rigid_only: bool = False) -> _F64:
        """``(T, N)`` x3 -> ``(T, N, 14 N)`` or ``(T, N, 10 N)``"""
    def mass_matrix(self, q: _F64) -> _F64:
        """``(T, N)`` -> ``(T, N, N)``"""
    def forward_dynamics(self, q: _F64, qd: _F64, tau: _F64) -> _F64:
        """``(T, N)`` x3 -> ``(T, N)``"""

# ---------------------------------------------------------------- identification
# (wrapped by python/ivdyn/_ident.py; the native functions take C-contiguous float64)

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

def fit_ls(phi: _F64, y: _F64, w: Optional[_F64] = None,
           names: Optional[List[str]] = None) -> FitReport:
    """``phi`` ``(M, P)``, ``y`` ``(M,)``, ``w`` ``(M,)`` -> weighted LS."""
def fit_iv(phi: _F64, z: _F64, y: _F64, w: Optional[_F64] = None,
           names: Optional[List[str]] = None) -> FitReport:
    """``phi``, ``z`` ``(M, P)``, ``y`` ``(M,)``, ``w`` ``(M,)`` -> instrumental variables."""

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
    "params" (10,)}``; ``ValueError`` when not identifiable."""

class Rls:
    def __init__(self, p: int, p0: float = 1e4, forgetting: float = 1.0) -> None: ...
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

class Riv:
    def __init__(self, p: int, p0: float = 1e4, forgetting: float = 1.0) -> None: ...
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

def read_joint_states(path: Union[str, PathLike], joint_names: List[str],
                      topic: str = "/joint_states",
                      command_topic: Optional[str] = None) -> Dict[str, Any]:
    """``{"t": (T,), "q": (T, N), "qd"/"tau"/"u": (T, N) or None, "joint_names",
    "t0_ns", "truncated"}``"""

class PaperSim:
    """The paper's simulation set-up for one seed of nominal-model errors."""
    def __init__(self, seed: int) -> None: ...
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

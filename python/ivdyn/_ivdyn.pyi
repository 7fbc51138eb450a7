"""Type stubs of the native module ``ivdyn._ivdyn`` (crates/ivdyn-py).

Use the ``ivdyn`` package instead: its ``Robot`` wraps this one, accepts ``(N,)`` or
``(T, N)`` inputs of any dtype and layout, and documents shapes and units. The native
methods take C-contiguous float64 ``(T, N)`` arrays only.
"""
from os import PathLike
from typing import List, Optional, Sequence, Union

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

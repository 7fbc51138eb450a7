"""ivdyn_ref: independent NumPy reference for ivdyn (model + Newton-Euler dynamics).

Only NumPy and the standard library are needed. `ivdyn_ref.pinref` (Pinocchio
counterparts for cross-checks) needs the `pin` wheel and is not imported here.
"""
from .model import (ChainModel, Joint, from_urdf, from_dh, paper_robot, inertial_from_urdf,
                    inertial_to_urdf, params_from_com, params_to_com, rpy_to_matrix)
from .dynamics import (rnea, regressor, mass_matrix, forward_dynamics, kinetic_energy,
                       potential_energy, gravity_torque, bias_torque, forward_kinematics)

__all__ = [
    "ChainModel", "Joint", "from_urdf", "from_dh", "paper_robot", "inertial_from_urdf",
    "inertial_to_urdf", "params_from_com", "params_to_com", "rpy_to_matrix", "rnea",
    "regressor", "mass_matrix", "forward_dynamics", "kinetic_energy", "potential_energy",
    "gravity_torque", "bias_torque", "forward_kinematics",
]

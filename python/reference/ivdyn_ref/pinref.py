"""Pinocchio counterparts of the reference models (for tests and the fixture generator).

Needs the `pin` wheel (module `pinocchio`) and `example-robot-data`. Joint-space
quantities need no conversion between Pinocchio's [linear; angular] spatial order and
ours; only continuous joints do (Pinocchio stores them as (cos q, sin q)).
"""
from __future__ import annotations

import math
import os

import numpy as np
import pinocchio as pin

from . import model as rm


def erd_robots_dir():
    """example-robot-data's robots folder inside the cmeel prefix of the pin wheel."""
    # pin.__file__ = <site-packages>/cmeel.prefix/lib/python3.X/site-packages/pinocchio/__init__.py
    here = os.path.dirname(os.path.abspath(pin.__file__))
    prefix = os.path.abspath(os.path.join(here, "..", "..", "..", ".."))
    d = os.path.join(prefix, "share", "example-robot-data", "robots")
    if not os.path.isdir(d):
        raise FileNotFoundError(f"example-robot-data robots folder not found at {d}")
    return d


def erd_urdf(name):
    d = erd_robots_dir()
    return {
        "ur5": os.path.join(d, "ur_description", "urdf", "ur5_robot.urdf"),
        "panda": os.path.join(d, "panda_description", "urdf", "panda.urdf"),
    }[name]


def urdf_model(path, locked_joints=()):
    """pin.buildModelFromUrdf + buildReducedModel locking `locked_joints` at neutral."""
    full = pin.buildModelFromUrdf(str(path))
    if not locked_joints:
        return full
    ids = [full.getJointId(j) for j in locked_joints]
    for name, jid in zip(locked_joints, ids):
        if jid >= full.njoints:
            raise ValueError(f"Pinocchio model has no joint '{name}'")
    return pin.buildReducedModel(full, ids, pin.neutral(full))


def paper_model():
    """The paper's robot built as shared/anchors/pinocchio/robots.hpp does (JointModelRZ,
    placement X_{i-1} = Tz(d) Tx(a) Rx(alpha)), with Table 2's inertias moved from DH
    frame i into joint frame i (COM' = X_i s_i, I' = Rx(alpha_i) I Rx(alpha_i)^T)."""
    m = pin.Model()
    m.name = "paper"
    parent = 0
    placement = pin.SE3.Identity()
    for i, ((a, d, al), (mass, s, Ic)) in enumerate(zip(rm.paper_dh_rows(), rm.paper_inertials())):
        jid = m.addJoint(parent, pin.JointModelRZ(), placement, f"joint{i + 1}")
        R = rm.rot_x(al)
        p = np.array([a, 0.0, d])
        m.appendBodyToJoint(jid, pin.Inertia(mass, R @ s + p, R @ Ic @ R.T), pin.SE3.Identity())
        parent = jid
        placement = pin.SE3(R, p)
    m.lowerPositionLimit[:] = -math.pi
    m.upperPositionLimit[:] = math.pi
    return m


def joint_ids(pmodel, names):
    ids = [pmodel.getJointId(n) for n in names]
    if ids != list(range(1, pmodel.njoints)):
        raise AssertionError(
            f"Pinocchio joint order {list(pmodel.names)[1:]} differs from chain {names}")
    return ids


def q_to_pin(pmodel, q):
    """Reference q (one angle per joint) -> Pinocchio configuration."""
    out = np.zeros(pmodel.nq)
    for k in range(1, pmodel.njoints):
        jm = pmodel.joints[k]
        if jm.nq == 1:
            out[jm.idx_q] = q[jm.idx_v]
        elif jm.nq == 2:  # unbounded revolute: (cos, sin)
            out[jm.idx_q] = math.cos(q[jm.idx_v])
            out[jm.idx_q + 1] = math.sin(q[jm.idx_v])
        else:
            raise ValueError(f"unsupported joint {jm.shortname()}")
    return out


def theta_rigid(pmodel):
    return np.concatenate([pmodel.inertias[k].toDynamicParameters()
                           for k in range(1, pmodel.njoints)])


class PinEval:
    """All rigid quantities from Pinocchio at one state (armature left at zero)."""

    def __init__(self, pmodel):
        self.model = pmodel
        self.data = pmodel.createData()

    def rnea(self, q, qd, qdd):
        return pin.rnea(self.model, self.data, q_to_pin(self.model, q), qd, qdd).copy()

    def regressor(self, q, qd, qdd):
        return pin.computeJointTorqueRegressor(
            self.model, self.data, q_to_pin(self.model, q), qd, qdd).copy()

    def crba(self, q):
        M = pin.crba(self.model, self.data, q_to_pin(self.model, q)).copy()
        return np.triu(M) + np.triu(M, 1).T

    def aba(self, q, qd, tau):
        return pin.aba(self.model, self.data, q_to_pin(self.model, q), qd, tau).copy()

    def gravity(self, q):
        return pin.computeGeneralizedGravity(self.model, self.data, q_to_pin(self.model, q)).copy()

    def kinetic_energy(self, q, qd):
        return float(pin.computeKineticEnergy(self.model, self.data, q_to_pin(self.model, q), qd))

    def potential_energy(self, q):
        return float(pin.computePotentialEnergy(self.model, self.data, q_to_pin(self.model, q)))


def rel_err(actual, expected):
    actual = np.asarray(actual, float)
    expected = np.asarray(expected, float)
    return float(np.linalg.norm(actual - expected) / max(np.linalg.norm(expected), 1.0))

"""Serial-chain model for the ivdyn NumPy reference.

Conventions (shared with the Rust core, see fixtures/MANIFEST.md):

* N one-DoF joints (revolute or prismatic), fixed base.
* Link i's frame is the frame of joint i (URDF child link frame of joint i).
  Joint i maps link i-1 (or the base) to link i by ``T = origin_i * Motion(axis_i, q_i)``
  with a constant origin (rotation + translation) and a unit axis expressed in link i,
  passing through link i's origin.
* Per link 10 inertial parameters about the link origin in link coordinates,
  ``[m, m*cx, m*cy, m*cz, Ixx, Ixy, Iyy, Ixz, Iyz, Izz]`` (Pinocchio's order).
* Per joint drive parameters ``[fc, fv, ia, tau0]``.
* theta = [link_1 .. link_N (10 each), drive_1 .. drive_N (4 each)], length 14 N.
"""
from __future__ import annotations

import math
import xml.etree.ElementTree as ET
from dataclasses import dataclass, field

import numpy as np

GRAVITY = np.array([0.0, 0.0, -9.81])


# --------------------------------------------------------------------- rotations
def rot_x(a):
    c, s = math.cos(a), math.sin(a)
    return np.array([[1.0, 0.0, 0.0], [0.0, c, -s], [0.0, s, c]])


def rot_y(a):
    c, s = math.cos(a), math.sin(a)
    return np.array([[c, 0.0, s], [0.0, 1.0, 0.0], [-s, 0.0, c]])


def rot_z(a):
    c, s = math.cos(a), math.sin(a)
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])


def rpy_to_matrix(rpy):
    """URDF fixed-axis roll-pitch-yaw: R = Rz(yaw) Ry(pitch) Rx(roll)."""
    r, p, y = (float(v) for v in rpy)
    return rot_z(y) @ rot_y(p) @ rot_x(r)


def axis_angle(axis, angle):
    """Rodrigues' formula, axis a unit 3-vector."""
    u = np.asarray(axis, dtype=float)
    K = skew(u)
    return np.eye(3) + math.sin(angle) * K + (1.0 - math.cos(angle)) * (K @ K)


def skew(v):
    return np.array([[0.0, -v[2], v[1]], [v[2], 0.0, -v[0]], [-v[1], v[0], 0.0]])


# --------------------------------------------------------------------- inertials
def inertia_matrix(ixx, ixy, ixz, iyy, iyz, izz):
    return np.array([[ixx, ixy, ixz], [ixy, iyy, iyz], [ixz, iyz, izz]], dtype=float)


def params_from_com(mass, com, I_com):
    """10 parameters about the frame origin from mass, COM and inertia about the COM
    (all in the same frame). Parallel-axis theorem: I_o = I_c + m (c.c E - c c^T)."""
    c = np.asarray(com, dtype=float)
    I_o = np.asarray(I_com, dtype=float) + mass * (c @ c * np.eye(3) - np.outer(c, c))
    mc = mass * c
    return np.array([mass, mc[0], mc[1], mc[2],
                     I_o[0, 0], I_o[0, 1], I_o[1, 1], I_o[0, 2], I_o[1, 2], I_o[2, 2]])


def params_to_com(phi):
    """Inverse of params_from_com: (mass, com, I_com). COM is zero when the mass is 0."""
    phi = np.asarray(phi, dtype=float)
    m = phi[0]
    mc = phi[1:4]
    c = mc / m if m != 0.0 else np.zeros(3)
    I_o = inertia_matrix(phi[4], phi[5], phi[7], phi[6], phi[8], phi[9])
    I_c = I_o - m * (c @ c * np.eye(3) - np.outer(c, c))
    return m, c, I_c


def inertial_from_urdf(mass, com_xyz, rpy, ixx, ixy, ixz, iyy, iyz, izz):
    """URDF <inertial> (mass, origin xyz/rpy, inertia about the COM in the rotated
    inertial frame) -> 10 parameters about the link origin in link coordinates."""
    R = rpy_to_matrix(rpy)
    I_c = R @ inertia_matrix(ixx, ixy, ixz, iyy, iyz, izz) @ R.T
    return params_from_com(float(mass), np.asarray(com_xyz, dtype=float), I_c)


def inertial_to_urdf(phi):
    """10 parameters -> dict(mass, com_xyz, rpy=(0,0,0), ixx, ixy, ixz, iyy, iyz, izz),
    the inertia about the COM expressed in link axes (rpy zero)."""
    m, c, I_c = params_to_com(phi)
    return dict(mass=float(m), com_xyz=tuple(float(x) for x in c), rpy=(0.0, 0.0, 0.0),
                ixx=float(I_c[0, 0]), ixy=float(I_c[0, 1]), ixz=float(I_c[0, 2]),
                iyy=float(I_c[1, 1]), iyz=float(I_c[1, 2]), izz=float(I_c[2, 2]))


def transform_params(phi, R, p):
    """Express 10 parameters given in frame B in frame A, where a point x_B maps to
    x_A = R x_B + p."""
    m, c, I_c = params_to_com(phi)
    return params_from_com(m, R @ c + p, R @ I_c @ R.T)


# --------------------------------------------------------------------- model
@dataclass
class Joint:
    name: str
    type: str  # 'revolute' | 'prismatic'
    R0: np.ndarray  # origin rotation (link i-1 -> link i at q = 0)
    p0: np.ndarray  # origin translation, in link i-1 coordinates
    axis: np.ndarray  # unit axis in link i coordinates
    lower: float = -math.inf
    upper: float = math.inf
    continuous: bool = False


@dataclass
class ChainModel:
    joints: list
    links: np.ndarray  # (N, 10)
    drive: np.ndarray  # (N, 4): fc, fv, ia, tau0
    gravity: np.ndarray = field(default_factory=lambda: GRAVITY.copy())
    name: str = ""
    base: str = ""
    tip: str = ""
    locked_joints: list = field(default_factory=list)

    @property
    def n(self):
        return len(self.joints)

    @property
    def joint_names(self):
        return [j.name for j in self.joints]

    @property
    def theta(self):
        return np.concatenate([np.asarray(self.links, float).ravel(),
                               np.asarray(self.drive, float).ravel()])

    def set_theta(self, theta):
        theta = np.asarray(theta, dtype=float)
        n = self.n
        if theta.shape != (14 * n,):
            raise ValueError(f"theta must have length {14 * n}, got {theta.shape}")
        self.links = theta[: 10 * n].reshape(n, 10).copy()
        self.drive = theta[10 * n:].reshape(n, 4).copy()

    def joint_transform(self, i, qi):
        """(R, p) of link i in link i-1 coordinates: origin_i * Motion(axis_i, q_i)."""
        j = self.joints[i]
        if j.type == "revolute":
            return j.R0 @ axis_angle(j.axis, qi), j.p0.copy()
        return j.R0.copy(), j.p0 + j.R0 @ (j.axis * qi)

    def limits(self):
        lo = np.array([j.lower for j in self.joints])
        hi = np.array([j.upper for j in self.joints])
        return lo, hi


# --------------------------------------------------------------------- URDF
def _floats(s, n, default):
    if s is None:
        return np.array(default, dtype=float)
    v = np.array([float(x) for x in s.split()], dtype=float)
    if v.shape != (n,):
        raise ValueError(f"expected {n} numbers, got '{s}'")
    return v


def _origin(elem):
    o = elem.find("origin") if elem is not None else None
    if o is None:
        return np.eye(3), np.zeros(3)
    return rpy_to_matrix(_floats(o.get("rpy"), 3, [0, 0, 0])), _floats(o.get("xyz"), 3, [0, 0, 0])


def _link_inertial(link_elem):
    """10 parameters of one URDF link in its own frame (zero when no <inertial>)."""
    inert = link_elem.find("inertial")
    if inert is None:
        return np.zeros(10)
    o = inert.find("origin")
    xyz = _floats(o.get("xyz") if o is not None else None, 3, [0, 0, 0])
    rpy = _floats(o.get("rpy") if o is not None else None, 3, [0, 0, 0])
    mass_el = inert.find("mass")
    mass = float(mass_el.get("value")) if mass_el is not None else 0.0
    ie = inert.find("inertia")
    vals = {k: float(ie.get(k, 0.0)) if ie is not None else 0.0
            for k in ("ixx", "ixy", "ixz", "iyy", "iyz", "izz")}
    return inertial_from_urdf(mass, xyz, rpy, **vals)


class _UrdfTree:
    """The link tree of a URDF: links, joints and each link's child joints."""

    def __init__(self, root):
        self.links = {le.get("name"): le for le in root.findall("link")}
        self.child_joint = {}  # child link -> joint element
        self.children = {name: [] for name in self.links}  # link -> [joint elements]
        for je in root.findall("joint"):
            name = je.get("name")
            parent = je.find("parent").get("link")
            child = je.find("child").get("link")
            if parent not in self.links or child not in self.links:
                raise ValueError(f"joint '{name}' refers to an unknown link")
            if child in self.child_joint:
                raise ValueError(f"link '{child}' has two parent joints (joint '{name}')")
            self.child_joint[child] = je
            self.children[parent].append(je)

    def root(self):
        roots = [l for l in self.links if l not in self.child_joint]
        if len(roots) != 1:
            raise ValueError(f"URDF has {len(roots)} root links: {roots}")
        return roots[0]

    def subtree_has_movable(self, link):
        return any(je.get("type") != "fixed" or self.subtree_has_movable(_child(je))
                   for je in self.children[link])

    def path(self, base, tip):
        """Joint elements base -> tip; tip None: follow the only branch with movable joints."""
        if tip is None:
            path_joints, link = [], base
            while True:
                nxt = [je for je in self.children[link]
                       if je.get("type") != "fixed" or self.subtree_has_movable(_child(je))]
                if not nxt:
                    return path_joints, link
                if len(nxt) > 1:
                    names = [je.get("name") for je in nxt]
                    raise ValueError(
                        f"link '{link}' branches into joints {names}: choose a tip link")
                path_joints.append(nxt[0])
                link = _child(nxt[0])
        if tip not in self.links:
            raise ValueError(f"tip link '{tip}' not in URDF")
        path_joints, link = [], tip
        while link != base:
            if link not in self.child_joint:
                raise ValueError(f"tip link '{tip}' is not below base link '{base}'")
            je = self.child_joint[link]
            path_joints.append(je)
            link = je.find("parent").get("link")
        return path_joints[::-1], tip


def _child(je):
    return je.find("child").get("link")


def _check_type(je, on_chain):
    t = je.get("type")
    name = je.get("name")
    if t in ("floating", "planar"):
        raise ValueError(f"joint '{name}' has unsupported type '{t}'")
    if t not in ("revolute", "continuous", "prismatic", "fixed"):
        raise ValueError(f"joint '{name}' has unknown type '{t}'")
    if on_chain and t != "fixed" and je.find("mimic") is not None:
        raise ValueError(f"joint '{name}' is a mimic joint on the chain (unsupported)")


def _movable_joint(je, R_o, p_o):
    """The chain Joint of a movable URDF joint whose origin is at (R_o, p_o) in its body."""
    t = je.get("type")
    axis = _floats(je.find("axis").get("xyz") if je.find("axis") is not None else None,
                   3, [1, 0, 0])
    nrm = np.linalg.norm(axis)
    if nrm == 0.0:
        raise ValueError(f"joint '{je.get('name')}' has a zero axis")
    lower, upper = -math.inf, math.inf
    lim = je.find("limit")
    if t in ("revolute", "prismatic") and lim is not None:
        lower = float(lim.get("lower", "0"))
        upper = float(lim.get("upper", "0"))
    return Joint(name=je.get("name"), type="prismatic" if t == "prismatic" else "revolute",
                 R0=R_o, p0=p_o, axis=axis / nrm, lower=lower, upper=upper,
                 continuous=(t == "continuous"))


def _walk_chain(tree, base, path_joints):
    """Chain joints, per body the (link, R, p) fused into it, and the locked joints.

    Body -1 (the base and what is fused into it) is dropped; body k is the k-th movable
    joint's child with every fixed-joint successor and off-path subtree fused in.
    """
    path_names = {je.get("name") for je in path_joints}
    chain, body_links, locked = [], [], []

    def fuse_offchain(link, R, p, target, on_path_child):
        """Attach `link` (at pose R, p in the body) and every off-path subtree below it."""
        target.append((link, R, p))
        for je in tree.children[link]:
            if je.get("name") in path_names or je.get("name") == on_path_child:
                continue
            _check_type(je, False)
            if je.get("type") != "fixed":
                locked.append(je.get("name"))
            Rj, pj = _origin(je)  # locked at q = 0: Motion is the identity
            fuse_offchain(_child(je), R @ Rj, R @ pj + p, target, None)

    R_acc, p_acc = np.eye(3), np.zeros(3)  # pose of the current link in the current body
    cur_list, link = [], base
    for je in path_joints:
        fuse_offchain(link, R_acc, p_acc, cur_list, je.get("name"))
        Rj, pj = _origin(je)
        # pose of the joint origin (= child link frame at q = 0) in the current body
        R_acc, p_acc = R_acc @ Rj, R_acc @ pj + p_acc
        if je.get("type") != "fixed":
            chain.append(_movable_joint(je, R_acc, p_acc))
            cur_list = []
            body_links.append(cur_list)
            R_acc, p_acc = np.eye(3), np.zeros(3)
        link = _child(je)
    fuse_offchain(link, R_acc, p_acc, cur_list, None)
    return chain, body_links, locked


def from_urdf(path, base=None, tip=None, drive=None, gravity=None):
    """Load the serial chain base -> tip from a URDF file (xml.etree only).

    Fixed joints on the chain are fused; every link hanging off a chain link (by any
    joint type allowed below) is rigidly fused into its chain ancestor with its movable
    joints locked at q = 0. Links above `base` and links fused into the base are ignored.
    base=None: the URDF root. tip=None: follow the only branch holding movable joints.
    """
    root = ET.parse(path).getroot()
    tree = _UrdfTree(root)
    base = tree.root() if base is None else base
    if base not in tree.links:
        raise ValueError(f"base link '{base}' not in URDF")
    path_joints, tip = tree.path(base, tip)
    for je in path_joints:
        _check_type(je, True)
    chain, body_links, locked = _walk_chain(tree, base, path_joints)
    if not chain:
        raise ValueError(f"no movable joint between '{base}' and '{tip}'")
    n = len(chain)
    phis = np.zeros((n, 10))
    for k, lst in enumerate(body_links):
        for lname, R, p in lst:
            phis[k] += transform_params(_link_inertial(tree.links[lname]), R, p)
    if drive is None:
        drive = np.zeros((n, 4))
    return ChainModel(joints=chain, links=phis, drive=np.asarray(drive, float).reshape(n, 4),
                      gravity=GRAVITY.copy() if gravity is None else np.asarray(gravity, float),
                      name=root.get("name", ""), base=base, tip=tip, locked_joints=locked)


# --------------------------------------------------------------------- DH
def dh_transform(a, d, alpha):
    """X = Tz(d) Tx(a) Rx(alpha) as (R, p)."""
    return rot_x(alpha), np.array([a, 0.0, d])


def from_dh(rows, inertials_in_dh_frame, drive=None, gravity=None, name="dh"):
    """Standard DH chain (T_{i-1,i} = Rz(q_i) Tz(d_i) Tx(a_i) Rx(alpha_i)), all revolute.

    Joint i rotates about z of its joint frame; its origin in joint frame i-1 is
    X_{i-1} = Tz(d_{i-1}) Tx(a_{i-1}) Rx(alpha_{i-1}) (identity for joint 1).
    rows: [(a, d, alpha[rad]), ...]. inertials_in_dh_frame: per link (mass, s, I_com)
    in DH frame i = joint frame i * X_i; converted into joint frame i here.
    """
    n = len(rows)
    joints = []
    R_prev, p_prev = np.eye(3), np.zeros(3)
    phis = np.zeros((n, 10))
    for i, (a, d, alpha) in enumerate(rows):
        joints.append(Joint(name=f"joint{i + 1}", type="revolute", R0=R_prev, p0=p_prev,
                            axis=np.array([0.0, 0.0, 1.0]), lower=-math.pi, upper=math.pi))
        R, p = dh_transform(a, d, alpha)
        m, s, I_c = inertials_in_dh_frame[i]
        phis[i] = params_from_com(m, R @ np.asarray(s, float) + p,
                                  R @ np.asarray(I_c, float) @ R.T)
        R_prev, p_prev = R, p
    if drive is None:
        drive = np.zeros((n, 4))
    return ChainModel(joints=joints, links=phis, drive=np.asarray(drive, float).reshape(n, 4),
                      gravity=GRAVITY.copy() if gravity is None else np.asarray(gravity, float),
                      name=name, base="joint0", tip=f"link{n}")


# The paper's robot: Table 1 (standard DH) and Table 2 (SI units), see paper/NOTES.md.
PAPER_DH = [  # a [m], d [m], alpha [deg]
    (-0.011, 0.0, 90.0),
    (-0.08, 0.0, 0.0),
    (-0.0886, 0.0, 0.0),
    (0.0, 0.0, 90.0),
    (0.0, 0.103, 90.0),
    (0.0, 0.0, 0.0),
]
PAPER_LINKS = [  # mass [kg], s [m] (COM in DH frame i), I about COM diag [kg m^2], F [N m]
    (0.800, (-0.04, -0.08, 0.0), 0.010, 0.470),
    (0.100, (-0.04, 0.02, 0.0), 0.005, 1.250),
    (0.350, (-0.07, 0.035, 0.0), 0.005, 1.250),
    (0.200, (0.0, 0.0, 0.0), 0.001, 0.450),
    (0.050, (-0.01, -0.03, 0.0), 0.0005, 0.250),
    (0.020, (0.01, 0.01, 0.0), 0.0001, 0.100),
]


def paper_dh_rows():
    return [(a, d, math.radians(al)) for a, d, al in PAPER_DH]


def paper_inertials():
    return [(m, np.array(s), I * np.eye(3)) for m, s, I, _ in PAPER_LINKS]


def paper_robot():
    """The paper's 6-DoF arm; drive = [F_i, 0, 0, 0] (Coulomb = Table 2's F column)."""
    drive = np.array([[F, 0.0, 0.0, 0.0] for *_, F in PAPER_LINKS])
    return from_dh(paper_dh_rows(), paper_inertials(), drive=drive, name="paper")

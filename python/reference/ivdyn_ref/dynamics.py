"""Newton-Euler dynamics of a serial chain, written from the paper's eqs 2-8
(Kawasaki & Nishimura, as corrected in paper/NOTES.md), in plain NumPy.

Differences from the paper's DH form, derived from first principles:

* Link frame i is joint i's frame (joint i's axis `u` passes through origin i), so the
  origin of link i is fixed in link i-1 (at p_i, the joint origin translation) instead
  of being fixed in link i (the paper's r_i). Forward recursion (all in frame i,
  A = R_{i-1,i}^T rotates frame i-1 into frame i):

      revolute:   w_i  = A w_{i-1} + u qd_i                                   (2)
                  wd_i = A wd_{i-1} + u qdd_i + (A w_{i-1}) x u qd_i           (3)
                  a_i  = A (a_{i-1} + sigma_{i-1}(p_i))                         (4)
      prismatic:  w_i = A w_{i-1},  wd_i = A wd_{i-1}
                  a_i  = A (a_{i-1} + sigma_{i-1}(p_i)) + 2 w_i x u qd_i + u qdd_i

  with sigma_k(v) = wd_k x v + w_k x (w_k x v), a_0 = -g (gravity as base acceleration).
* The link's force and moment use the 10 parameters about origin i (m, m c, I_o), so
  eqs 5-7 become (moments about origin i, the point on joint i's axis):

      F_i = m a_i + wd_i x (m c) + w_i x (w_i x (m c))                         (5, 6)
      N_i = I_o wd_i + w_i x (I_o w_i) + (m c) x a_i                            (7)
      f_i = F_i + R_{i,i+1} f_{i+1}
      n_i = N_i + R_{i,i+1} n_{i+1} + p_{i+1} x (R_{i,i+1} f_{i+1})

  and tau_i = u . n_i (revolute) or u . f_i (prismatic), plus the drive terms (8):
  fc sign(qd) + fv qd + ia qdd + tau0, with sign(0) = 0. A joint may shape its Coulomb
  term (ivdyn_core::CoulombShape): fc c(qd), c = s + asym |s|, s = tanh(qd / v_scale)
  (v_scale > 0) or sign(qd); ``regressor(..., coulomb=[(v_scale, asym), ...])``.
"""
from __future__ import annotations

import numpy as np

from .model import ChainModel, inertia_matrix


def _cross(a, b):
    return np.cross(a, b)


def _split_theta(model: ChainModel, theta):
    n = model.n
    if theta is None:
        return np.asarray(model.links, float), np.asarray(model.drive, float)
    theta = np.asarray(theta, dtype=float)
    if theta.shape != (14 * n,):
        raise ValueError(f"theta must have length {14 * n}, got {theta.shape}")
    return theta[: 10 * n].reshape(n, 10), theta[10 * n:].reshape(n, 4)


def _check(model, *vecs):
    n = model.n
    out = []
    for v in vecs:
        v = np.asarray(v, dtype=float)
        if v.shape != (n,):
            raise ValueError(f"expected a vector of length {n}, got shape {v.shape}")
        out.append(v)
    return out


def kinematics(model: ChainModel, q, qd, qdd, gravity=True):
    """Forward recursion. Returns per link (R_{i-1,i}, p_i, w_i, wd_i, a_i, v_i), where
    a_i includes the gravity base acceleration when `gravity` is true."""
    q, qd, qdd = _check(model, q, qd, qdd)
    w = np.zeros(3)
    wd = np.zeros(3)
    a = -np.asarray(model.gravity, float) if gravity else np.zeros(3)
    v = np.zeros(3)
    out = []
    for i, jt in enumerate(model.joints):
        R, p = model.joint_transform(i, q[i])
        A = R.T
        u = jt.axis
        # acceleration / velocity of origin i, still in frame i-1
        a_prev = a + _cross(wd, p) + _cross(w, _cross(w, p))
        v_prev = v + _cross(w, p)
        if jt.type == "revolute":
            w_i = A @ w + u * qd[i]                                         # eq 2
            wd_i = A @ wd + u * qdd[i] + _cross(A @ w, u * qd[i])           # eq 3
            a_i = A @ a_prev                                                # eq 4
            v_i = A @ v_prev
        else:
            w_i = A @ w
            wd_i = A @ wd
            a_i = A @ a_prev + 2.0 * _cross(w_i, u * qd[i]) + u * qdd[i]
            v_i = A @ v_prev + u * qd[i]
        out.append((R, p, w_i, wd_i, a_i, v_i))
        w, wd, a, v = w_i, wd_i, a_i, v_i
    return out


def _link_wrench(phi, w, wd, a):
    """Net force and moment (about the link origin) of one link, eqs 5-7."""
    m = phi[0]
    mc = phi[1:4]
    I = inertia_matrix(phi[4], phi[5], phi[7], phi[6], phi[8], phi[9])
    F = m * a + _cross(wd, mc) + _cross(w, _cross(w, mc))
    N = I @ wd + _cross(w, I @ w) + _cross(mc, a)
    return F, N


def _drive_torque(drive, qd, qdd, coulomb=None):
    fc, fv, ia, tau0 = drive[:, 0], drive[:, 1], drive[:, 2], drive[:, 3]
    c = np.sign(qd) if coulomb is None else np.array([coulomb_value(v, *s) for v, s in zip(qd, coulomb)])
    return fc * c + fv * qd + ia * qdd + tau0


def rnea(model: ChainModel, q, qd, qdd, theta=None, gravity=True, drive=True, coulomb=None):
    """Inverse dynamics tau(q, qd, qdd) including the drive terms (eq 8).
    theta (14 N) overrides the model's parameters; ``coulomb``: per joint
    ``(v_scale, asym)`` of the Coulomb term (default: sign)."""
    links, drv = _split_theta(model, theta)
    q, qd, qdd = _check(model, q, qd, qdd)
    kin = kinematics(model, q, qd, qdd, gravity)
    n = model.n
    tau = np.zeros(n)
    f = np.zeros(3)
    nm = np.zeros(3)
    for i in range(n - 1, -1, -1):
        R, p, w, wd, a, _ = kin[i]
        F, N = _link_wrench(links[i], w, wd, a)
        if i + 1 < n:
            R1, p1 = kin[i + 1][0], kin[i + 1][1]
            f_child = R1 @ f
            n_child = R1 @ nm + _cross(p1, f_child)
        else:
            f_child = np.zeros(3)
            n_child = np.zeros(3)
        f = F + f_child                                                     # eq 6
        nm = N + n_child                                                    # eq 7
        u = model.joints[i].axis
        tau[i] = u @ nm if model.joints[i].type == "revolute" else u @ f    # eq 8
    if drive:
        tau += _drive_torque(drv, qd, qdd, coulomb)
    return tau


def _wrench_blocks(w, wd, a):
    """3x10 matrices K_f, K_n with F = K_f phi, N = K_n phi (eqs 5-7 are linear in phi)."""
    Kf = np.zeros((3, 10))
    Kn = np.zeros((3, 10))
    Kf[:, 0] = a
    # wd x mc + w x (w x mc) = (S(wd) + S(w) S(w)) mc
    Sw = _skew(w)
    Kf[:, 1:4] = _skew(wd) + Sw @ Sw
    # mc x a = -S(a) mc
    Kn[:, 1:4] = -_skew(a)
    # I wd + w x (I w) = (L(wd) + S(w) L(w)) [Ixx, Ixy, Iyy, Ixz, Iyz, Izz]
    Kn[:, 4:10] = _L(wd) + Sw @ _L(w)
    return Kf, Kn


def _skew(v):
    return np.array([[0.0, -v[2], v[1]], [v[2], 0.0, -v[0]], [-v[1], v[0], 0.0]])


def _L(v):
    """I v = L(v) [Ixx, Ixy, Iyy, Ixz, Iyz, Izz]."""
    x, y, z = v
    return np.array([[x, y, 0.0, z, 0.0, 0.0],
                     [0.0, x, y, 0.0, z, 0.0],
                     [0.0, 0.0, 0.0, x, y, z]])


def coulomb_value(qd, v_scale=0.0, asym=0.0):
    """The Coulomb regressor entry c(qd) = s + asym |s|, s = tanh(qd / v_scale) or sign(qd)."""
    s = np.tanh(qd / v_scale) if v_scale > 0 else np.sign(qd)
    return s + asym * np.abs(s)


def regressor(model: ChainModel, q, qd, qdd, gravity=True, coulomb=None):
    """Y (N x 14N) with Y @ theta == rnea(q, qd, qdd, theta) (eq 21).
    ``coulomb``: per joint ``(v_scale, asym)`` of the Coulomb term (default: sign).

    For each link j the 3x10 blocks (K_f, K_n) of its own wrench are propagated back
    to every joint i <= j with the same recursion as the forces (eqs 6-7):
    f <- R f, n <- R n + p x (R f). Row i picks u_i . n (revolute) or u_i . f.
    """
    q, qd, qdd = _check(model, q, qd, qdd)
    kin = kinematics(model, q, qd, qdd, gravity)
    n = model.n
    Y = np.zeros((n, 14 * n))
    for j in range(n):
        _, _, w, wd, a, _ = kin[j]
        Bf, Bn = _wrench_blocks(w, wd, a)
        for i in range(j, -1, -1):
            if i < j:
                R1, p1 = kin[i + 1][0], kin[i + 1][1]
                Bf = R1 @ Bf
                Bn = R1 @ Bn + _skew(p1) @ Bf
            u = model.joints[i].axis
            Y[i, 10 * j:10 * j + 10] = u @ Bn if model.joints[i].type == "revolute" else u @ Bf
    for i in range(n):
        c = 10 * n + 4 * i
        ci = np.sign(qd[i]) if coulomb is None else coulomb_value(qd[i], *coulomb[i])
        Y[i, c:c + 4] = [ci, qd[i], qdd[i], 1.0]
    return Y


def gravity_torque(model: ChainModel, q, theta=None):
    """Rigid-body gravity torque g(q) (no drive terms)."""
    z = np.zeros(model.n)
    return rnea(model, q, z, z, theta, gravity=True, drive=False)


def mass_matrix(model: ChainModel, q, theta=None, armature=True):
    """M(q): column k = rnea(q, 0, e_k) - g(q), plus diag(ia)."""
    links, drv = _split_theta(model, theta)
    n = model.n
    z = np.zeros(n)
    g = rnea(model, q, z, z, theta, gravity=True, drive=False)
    M = np.zeros((n, n))
    for k in range(n):
        e = np.zeros(n)
        e[k] = 1.0
        M[:, k] = rnea(model, q, z, e, theta, gravity=True, drive=False) - g
    if armature:
        M += np.diag(drv[:, 2])
    return M


def bias_torque(model: ChainModel, q, qd, theta=None):
    """h(q, qd) = rnea_rigid(q, qd, 0): Coriolis, centrifugal and gravity."""
    return rnea(model, q, qd, np.zeros(model.n), theta, gravity=True, drive=False)


def forward_dynamics(model: ChainModel, q, qd, tau, theta=None):
    """qdd = M^-1 (tau - h - fc sign(qd) - fv qd - tau0), M with armature."""
    links, drv = _split_theta(model, theta)
    q, qd, tau = _check(model, q, qd, tau)
    rhs = tau - bias_torque(model, q, qd, theta) - (
        drv[:, 0] * np.sign(qd) + drv[:, 1] * qd + drv[:, 3])
    return np.linalg.solve(mass_matrix(model, q, theta, armature=True), rhs)


def kinetic_energy(model: ChainModel, q, qd, theta=None, armature=False):
    """Sum over links of 1/2 (m v.v + 2 v.(w x m c) + w.I_o w) with v the origin
    velocity; plus 1/2 ia qd^2 when `armature`."""
    links, drv = _split_theta(model, theta)
    q, qd = _check(model, q, qd)
    kin = kinematics(model, q, qd, np.zeros(model.n), gravity=False)
    T = 0.0
    for i, (_, _, w, _, _, v) in enumerate(kin):
        phi = links[i]
        I = inertia_matrix(phi[4], phi[5], phi[7], phi[6], phi[8], phi[9])
        T += 0.5 * (phi[0] * v @ v + 2.0 * v @ _cross(w, phi[1:4]) + w @ I @ w)
    if armature:
        T += 0.5 * float(drv[:, 2] @ (qd * qd))
    return float(T)


def forward_kinematics(model: ChainModel, q):
    """World (base) poses (R, p) of every link frame."""
    (q,) = _check(model, q)
    R_w, p_w = np.eye(3), np.zeros(3)
    out = []
    for i in range(model.n):
        R, p = model.joint_transform(i, q[i])
        p_w = p_w + R_w @ p
        R_w = R_w @ R
        out.append((R_w.copy(), p_w.copy()))
    return out


def potential_energy(model: ChainModel, q, theta=None):
    """V = -sum_i m_i g . c_i (world COM), i.e. -sum_i g . (m p_i + R_i (m c_i))."""
    links, _ = _split_theta(model, theta)
    g = np.asarray(model.gravity, float)
    V = 0.0
    for i, (R, p) in enumerate(forward_kinematics(model, q)):
        V -= g @ (links[i][0] * p + R @ links[i][1:4])
    return float(V)

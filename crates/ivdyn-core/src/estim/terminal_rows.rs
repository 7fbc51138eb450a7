//! What one terminal-link update needs from the dynamics, and nothing more (issue 19):
//! the regressor entries of the unknown links `k..N` on the rows used (joints
//! `first_row..N`), at the measured and at the instrumental accelerations, and the
//! nominal torque of those rows only.
//!
//! # Math note
//! - One outward recursion (paper eqs 2-4) gives `w, wd, acc` of every link: the
//!   terminal links' motion depends on every joint. The instrumental pass shares the
//!   velocity products (`(R^T w) x a qd` of eq 3, `w x (w x p)` of eq 4) and redoes only
//!   the parts linear in the acceleration.
//! - Regressor block `Y_il` (row `i`, link `l >= max(i, k)`), as in [`crate::regressor`]:
//!   joint `i`'s unit motion `(sw, sv)` carried into link `l`'s frame against link `l`'s
//!   `(w, wd, acc)`. Each entry splits into a velocity part (`w x (w x sv)`,
//!   `(sw x w)^T I w`) shared by both passes, and a part linear in `(wd, acc)`. Only the
//!   entries of estimated columns are formed.
//! - Nominal torque of rows `i >= r0 = min(first_row, k)`: the inward force recursion
//!   (paper eqs 6-8) over links `N-1 .. r0` only, projected on those joints only.
//! - Structure known from the model is used, never values: joint axes along a
//!   coordinate axis rotate two coordinates (4 multiplications, not 9 or 12), a constant
//!   joint placement whose entries are `0` or `+-1` (a DH twist of `0` or `+-90` degrees;
//!   entries within one `f64::EPSILON` of those values are their rounding residue and are
//!   taken as exact) permutes coordinates, zero coordinates of a placement or of gravity,
//!   and the zero angular velocity and acceleration of the base. Every 3-vector carries
//!   its structural zeros (`None`), which the operations propagate. The inertial and drive
//!   parameters are data: they are used dense.
//!
//! Sines and cosines of the joint angles are computed once per update (the full path
//! computed them three times: RNEA, regressor, instrumental regressor).

use crate::model::{JointKind, Model};
use crate::params::{CoulombShape, DRIVE_PARAMS, DriveParams, LINK_PARAMS};
use crate::regressor_matrix::Regressor;
use crate::scalar::{RealScalar, Sum};
use crate::types::Vec3;
use nalgebra::SVector;

/// A scalar with its structural zero: `None` is a zero known from the model's structure.
type Sz<T> = Option<T>;
/// A 3-vector with structural zeros.
type V3<T> = [Sz<T>; 3];

#[inline(always)]
fn add<T: RealScalar>(a: Sz<T>, b: Sz<T>) -> Sz<T> {
    match (a, b) {
        (Some(x), Some(y)) => Some(x + y),
        (x, None) => x,
        (None, y) => y,
    }
}

#[inline(always)]
fn sub<T: RealScalar>(a: Sz<T>, b: Sz<T>) -> Sz<T> {
    match (a, b) {
        (Some(x), Some(y)) => Some(x - y),
        (x, None) => x,
        (None, Some(y)) => Some(-y),
    }
}

#[inline(always)]
fn mul<T: RealScalar>(a: Sz<T>, b: Sz<T>) -> Sz<T> {
    match (a, b) {
        (Some(x), Some(y)) => Some(x * y),
        _ => None,
    }
}

/// `x c` for a model constant `c`: `0` is a structural zero, `+-1` costs nothing.
#[inline(always)]
fn kmul<T: RealScalar>(x: Sz<T>, c: f64) -> Sz<T> {
    let x = x?;
    if c == 0.0 {
        None
    } else if c == 1.0 {
        Some(x)
    } else if c == -1.0 {
        Some(-x)
    } else {
        Some(x * T::from_f64(c))
    }
}

#[inline(always)]
fn vadd<T: RealScalar>(a: &V3<T>, b: &V3<T>) -> V3<T> {
    [add(a[0], b[0]), add(a[1], b[1]), add(a[2], b[2])]
}

#[inline(always)]
fn vscale<T: RealScalar>(a: &V3<T>, s: T) -> V3<T> {
    [mul(a[0], Some(s)), mul(a[1], Some(s)), mul(a[2], Some(s))]
}

#[inline(always)]
fn dot<T: RealScalar>(a: &V3<T>, b: &V3<T>) -> Sz<T> {
    add(add(mul(a[0], b[0]), mul(a[1], b[1])), mul(a[2], b[2]))
}

#[inline(always)]
fn cross<T: RealScalar>(a: &V3<T>, b: &V3<T>) -> V3<T> {
    [
        sub(mul(a[1], b[2]), mul(a[2], b[1])),
        sub(mul(a[2], b[0]), mul(a[0], b[2])),
        sub(mul(a[0], b[1]), mul(a[1], b[0])),
    ]
}

/// A model constant as a vector with structural zeros (no operation).
#[inline(always)]
fn konst<T: RealScalar>(c: &Vec3) -> V3<T> {
    let k = |x: f64| if x == 0.0 { None } else { Some(T::from_f64(x)) };
    [k(c.x), k(c.y), k(c.z)]
}

/// `a x k` for a constant `k` (a joint axis).
#[inline(always)]
fn cross_k<T: RealScalar>(a: &V3<T>, k: &Vec3) -> V3<T> {
    [
        sub(kmul(a[1], k.z), kmul(a[2], k.y)),
        sub(kmul(a[2], k.x), kmul(a[0], k.z)),
        sub(kmul(a[0], k.y), kmul(a[1], k.x)),
    ]
}

/// `k x` for a constant `k` (a joint axis), scaled: `k s`.
#[inline(always)]
fn kscaled<T: RealScalar>(k: &Vec3, s: T) -> V3<T> {
    [kmul(Some(s), k.x), kmul(Some(s), k.y), kmul(Some(s), k.z)]
}

#[inline(always)]
fn or0<T: RealScalar>(x: Sz<T>) -> T {
    x.unwrap_or_else(T::zero)
}

/// The rotation of a joint at its angle: about a coordinate axis (`plane = (a, b)` the two
/// coordinates it mixes, sine with the axis sign folded in), or a general one.
#[derive(Debug, Clone, Copy)]
enum JointRot<T> {
    /// `Rot(e_k, angle)`: `(v_a, v_b) -> (c v_a - s v_b, s v_a + c v_b)`.
    Plane { a: usize, b: usize, s: T, c: T },
    /// Rodrigues' matrix (parent <- child) of a general axis.
    Full([[T; 3]; 3]),
    /// Prismatic: no rotation.
    None,
}

/// Per joint at the current `q`: placement of link `i` in link `i-1` as `E_i Rot_i`, `E_i`
/// the constant placement with its structure snapped (module docs), and the origin `p_i`.
#[derive(Debug, Clone, Copy)]
struct Frame<T> {
    e: [[f64; 3]; 3],
    rot: JointRot<T>,
    p: V3<T>,
}

impl<T: RealScalar> Frame<T> {
    fn new<const N: usize>(model: &Model<N>, i: usize, q: T) -> Self {
        let x = &model.x_tree[i];
        let snap = |v: f64| {
            if v.abs() <= f64::EPSILON {
                0.0
            } else if (v.abs() - 1.0).abs() <= f64::EPSILON {
                v.signum()
            } else {
                v
            }
        };
        let e = core::array::from_fn(|r| core::array::from_fn(|c| snap(x.rot[(r, c)])));
        let axis = model.joints[i].axis;
        match model.joints[i].kind {
            JointKind::Revolute => {
                let (s, c) = q.sin_cos();
                let coord = [(axis.y, axis.z, 0), (axis.z, axis.x, 1), (axis.x, axis.y, 2)];
                let rot = match coord.iter().find(|(u, v, _)| *u == 0.0 && *v == 0.0) {
                    Some(&(_, _, k)) => {
                        let sign = axis[k].signum();
                        Plane { a: (k + 1) % 3, b: (k + 2) % 3, s: if sign < 0.0 { -s } else { s }, c }
                    }
                    None => Full(rodrigues(&axis, s, c)),
                };
                Self { e, rot, p: konst(&x.trans) }
            }
            JointKind::Prismatic => {
                // p = trans + E (axis q)
                let d = kscaled::<T>(&axis, q);
                let p = vadd(&konst(&x.trans), &mat_k(&e, &d, false));
                Self { e, rot: JointRot::None, p }
            }
        }
    }

    /// Parent coordinates to this link's: `Rot^T E^T v`.
    #[inline(always)]
    fn in_child(&self, v: &V3<T>) -> V3<T> {
        let u = mat_k(&self.e, v, true);
        match self.rot {
            Plane { a, b, s, c } => {
                // Rot^T: (u_a, u_b) -> (c u_a + s u_b, c u_b - s u_a)
                let (s, c) = (Some(s), Some(c));
                let mut out = u;
                out[a] = add(mul(u[a], c), mul(u[b], s));
                out[b] = sub(mul(u[b], c), mul(u[a], s));
                out
            }
            Full(m) => mat_t(&m, &u, true),
            JointRot::None => u,
        }
    }

    /// This link's coordinates to the parent's: `E Rot v`.
    #[inline(always)]
    fn in_parent(&self, v: &V3<T>) -> V3<T> {
        let u = match self.rot {
            Plane { a, b, s, c } => {
                // Rot: (v_a, v_b) -> (c v_a - s v_b, s v_a + c v_b)
                let (s, c) = (Some(s), Some(c));
                let mut out = *v;
                out[a] = sub(mul(v[a], c), mul(v[b], s));
                out[b] = add(mul(v[a], s), mul(v[b], c));
                out
            }
            Full(m) => mat_t(&m, v, false),
            JointRot::None => *v,
        };
        mat_k(&self.e, &u, false)
    }
}

use JointRot::{Full, Plane};

/// `E v` or `E^T v` for a constant `E` (structure skipped).
#[inline(always)]
fn mat_k<T: RealScalar>(e: &[[f64; 3]; 3], v: &V3<T>, transpose: bool) -> V3<T> {
    core::array::from_fn(|r| {
        let el = |c: usize| if transpose { e[c][r] } else { e[r][c] };
        add(add(kmul(v[0], el(0)), kmul(v[1], el(1))), kmul(v[2], el(2)))
    })
}

/// `M v` or `M^T v` for a matrix of the current sample.
#[inline(always)]
fn mat_t<T: RealScalar>(m: &[[T; 3]; 3], v: &V3<T>, transpose: bool) -> V3<T> {
    core::array::from_fn(|r| {
        let el = |c: usize| Some(if transpose { m[c][r] } else { m[r][c] });
        add(add(mul(v[0], el(0)), mul(v[1], el(1))), mul(v[2], el(2)))
    })
}

/// Rotation about a unit `axis` (Rodrigues): `c I + s [a]x + (1 - c) a a^T`.
fn rodrigues<T: RealScalar>(axis: &Vec3, s: T, c: T) -> [[T; 3]; 3] {
    let t = T::one() - c;
    let k = |x: f64| T::from_f64(x);
    let (x, y, z) = (axis.x, axis.y, axis.z);
    [
        [c + t * k(x * x), t * k(x * y) - s * k(z), t * k(x * z) + s * k(y)],
        [t * k(x * y) + s * k(z), c + t * k(y * y), t * k(y * z) - s * k(x)],
        [t * k(x * z) - s * k(y), t * k(y * z) + s * k(x), c + t * k(z * z)],
    ]
}

/// What an update needs: the rows `first_row..N`, and of those rows' regressor entries
/// `link[row][link]` bit `e` for inertial entry `e`, `drive[row]` for the row's own drive
/// entries.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Needed<const N: usize> {
    /// First row (joint) used: the nominal torque is computed for rows `first_row..N`.
    pub first_row: usize,
    /// Bit `e` of `link[row][link]`: inertial entry `e` of block `(row, link)`.
    pub link: [[u16; N]; N],
    /// Drive entries of each row (its own joint's).
    pub drive: [[bool; DRIVE_PARAMS]; N],
}

impl<const N: usize> Needed<N> {
    /// Nothing.
    pub const NONE: Self = Self { first_row: N, link: [[0; N]; N], drive: [[false; DRIVE_PARAMS]; N] };
}

/// Link motion of one sample: `w, wd, acc` (paper eqs 2-4) and the instrumental
/// `wd, acc`, all in link coordinates.
#[derive(Debug, Clone, Copy)]
struct Motion<T, const N: usize> {
    w: [V3<T>; N],
    wd: [V3<T>; N],
    acc: [V3<T>; N],
    wd_z: [V3<T>; N],
    acc_z: [V3<T>; N],
}

/// Work buffers and results of [`terminal_rows`]: the needed regressor entries at the
/// measured (`y`) and instrumental (`y_z`) accelerations, and the nominal torque `tau`
/// of the rows used. Other entries are left as they were.
#[derive(Debug, Clone)]
pub struct TerminalRows<const N: usize, T = f64> {
    /// Regressor entries at `(q, qd, qdd)` (only those needed).
    pub y: Regressor<N, T>,
    /// Regressor entries at `(q, qd, qdd_instr)` (only those needed, when asked).
    pub y_z: Regressor<N, T>,
    /// Nominal torque (drive terms included) of the rows used; the others are not set.
    pub tau: SVector<T, N>,
    /// Bit `e` of `nz[row][link]`: entry `e` of that block is not a structural zero (the
    /// model's structure makes the others exactly zero at every state); set for the
    /// needed entries.
    pub nz: [[u16; N]; N],
}

impl<const N: usize, T: RealScalar> TerminalRows<N, T> {
    /// Zeroed buffers.
    pub fn new() -> Self {
        let z = T::zero();
        let y = Regressor { link: [[[z; LINK_PARAMS]; N]; N], drive: [[z; DRIVE_PARAMS]; N] };
        Self { y: y.clone(), y_z: y, tau: SVector::from_element(z), nz: [[0; N]; N] }
    }
}

impl<const N: usize, T: RealScalar> Default for TerminalRows<N, T> {
    fn default() -> Self {
        Self::new()
    }
}

/// The terminal-link rows (module docs): regressor entries `needed` of rows
/// `needed.first_row..N` at `(q, qd, qdd)` and, if `qdd_instr` is given, at
/// `(q, qd, qdd_instr)`, and the nominal torque of those rows, into `out`.
pub fn terminal_rows<const N: usize, T: RealScalar>(
    model: &Model<N>,
    needed: &Needed<N>,
    out: &mut TerminalRows<N, T>,
    q: &SVector<T, N>,
    qd: &SVector<T, N>,
    qdd: &SVector<T, N>,
    qdd_instr: Option<&SVector<T, N>>,
) {
    let frames: [Frame<T>; N] = core::array::from_fn(|i| Frame::new(model, i, q[i]));
    let m = outward(model, &frames, qd, qdd, qdd_instr);
    let r0 = needed.first_row;
    // the nominal torque from the blocks when every block of the rows is formed anyway
    // (rows k..N: Y_il pi_l costs a few products more per block), else by the inward recursion
    let by_blocks = (r0..N).all(|i| (i..N).all(|l| needed.link[i][l] != 0));
    for i in r0..N {
        let mut tau = Sum::new();
        for l in i..N {
            let need = needed.link[i][l];
            if need == 0 {
                continue;
            }
            let y = blocks(model, &frames, &m, i, l, need, by_blocks, qdd_instr.is_some(), out);
            if by_blocks {
                // tau_i += Y_il . pi_l                                              (eq 21)
                let pi = &model.inertia[l].0;
                for (e, &v) in y.iter().enumerate() {
                    if let Some(v) = v {
                        tau.add(v * T::from_f64(pi[e]));
                    }
                }
            }
        }
        let d = &model.drive[i];
        let dn = &needed.drive[i];
        let c = coulomb(&d.coulomb, qd[i]);
        drive_row(&mut out.y.drive[i], dn, c, qd[i], qdd[i]);
        if let Some(qz) = qdd_instr {
            drive_row(&mut out.y_z.drive[i], dn, c, qd[i], qz[i]);
        }
        if by_blocks {
            out.tau[i] = tau.get() + drive_torque(d, qd[i], qdd[i]);
        }
    }
    if !by_blocks {
        inward(model, &frames, &m, r0, qd, qdd, &mut out.tau);
    }
}

/// The drive regressor entries `[c(qd), qd, qdd, 1]` that are needed.
#[inline(always)]
fn drive_row<T: RealScalar>(out: &mut [T; DRIVE_PARAMS], need: &[bool; DRIVE_PARAMS], c: T, qd: T, qdd: T) {
    let all = [c, qd, qdd, T::one()];
    for k in 0..DRIVE_PARAMS {
        if need[k] {
            out[k] = all[k];
        }
    }
}

/// The Coulomb regressor entry `c(qd)` ([`CoulombShape::value`]).
#[inline(always)]
fn coulomb<T: RealScalar>(shape: &CoulombShape, qd: T) -> T {
    let z = T::zero();
    let s = if shape.v_scale > 0.0 {
        (qd / T::from_f64(shape.v_scale)).tanh()
    } else if qd > z {
        T::one()
    } else if qd < z {
        -T::one()
    } else {
        z
    };
    if shape.asym != 0.0 { s + T::from_f64(shape.asym) * s.abs() } else { s }
}

/// Drive torque `fc c(qd) + fv qd + ia qdd + tau0` ([`DriveParams::torque`]).
#[inline(always)]
fn drive_torque<T: RealScalar>(d: &DriveParams, qd: T, qdd: T) -> T {
    let k = T::from_f64;
    k(d.fc) * coulomb(&d.coulomb, qd) + k(d.fv) * qd + k(d.ia) * qdd + k(d.tau0)
}

/// Outward recursion (eqs 2-4, any axis, prismatic joints too), with the instrumental
/// accelerations sharing the velocity products.
fn outward<const N: usize, T: RealScalar>(
    model: &Model<N>,
    frames: &[Frame<T>; N],
    qd: &SVector<T, N>,
    qdd: &SVector<T, N>,
    qdd_instr: Option<&SVector<T, N>>,
) -> Motion<T, N> {
    let none: V3<T> = [None; 3];
    let mut m = Motion { w: [none; N], wd: [none; N], acc: [none; N], wd_z: [none; N], acc_z: [none; N] };
    let (mut w, mut wd, mut acc) = (none, none, konst::<T>(&-model.gravity));
    let (mut wd_z, mut acc_z) = (wd, acc);
    for i in 0..N {
        let f = &frames[i];
        let a = &model.joints[i].axis;
        // acc of the new origin, parent coords: acc + wd x p + w x (w x p)   (eq 4)
        let centripetal = cross(&w, &cross(&w, &f.p));
        let acc_p = vadd(&vadd(&acc, &cross(&wd, &f.p)), &centripetal);
        let w_c = f.in_child(&w);
        let acc_c = f.in_child(&acc_p);
        let acc_pz = qdd_instr.map(|_| vadd(&vadd(&acc_z, &cross(&wd_z, &f.p)), &centripetal));
        match model.joints[i].kind {
            JointKind::Revolute => {
                // w_i = R^T w_{i-1} + a qd;  wd_i = R^T wd_{i-1} + a qdd + (R^T w_{i-1}) x a qd  (eqs 2, 3)
                let coriolis = vscale(&cross_k(&w_c, a), qd[i]);
                w = vadd(&w_c, &kscaled(a, qd[i]));
                wd = vadd(&vadd(&f.in_child(&wd), &kscaled(a, qdd[i])), &coriolis);
                acc = acc_c;
                if let (Some(qz), Some(ap)) = (qdd_instr, acc_pz) {
                    wd_z = vadd(&vadd(&f.in_child(&wd_z), &kscaled(a, qz[i])), &coriolis);
                    acc_z = f.in_child(&ap);
                }
            }
            JointKind::Prismatic => {
                // the joint adds a qdd and the Coriolis term 2 w x a qd to the origin
                w = w_c;
                wd = f.in_child(&wd);
                let coriolis = vscale(&cross_k(&w, a), T::from_f64(2.0) * qd[i]);
                acc = vadd(&vadd(&acc_c, &kscaled(a, qdd[i])), &coriolis);
                if let (Some(qz), Some(ap)) = (qdd_instr, acc_pz) {
                    wd_z = f.in_child(&wd_z);
                    acc_z = vadd(&vadd(&f.in_child(&ap), &kscaled(a, qz[i])), &coriolis);
                }
            }
        }
        m.w[i] = w;
        m.wd[i] = wd;
        m.acc[i] = acc;
        m.wd_z[i] = wd_z;
        m.acc_z[i] = acc_z;
    }
    m
}

/// `u^T I v` split over the six entries of a symmetric `I` (order `Ixx, Ixy, Iyy, Ixz,
/// Iyz, Izz`): entry `(a, b)` is `u_a v_b + u_b v_a` off the diagonal, `u_a v_a` on it.
const I_PAIRS: [(usize, usize); 6] = [(0, 0), (0, 1), (1, 1), (0, 2), (1, 2), (2, 2)];

#[inline(always)]
fn sym_entry<T: RealScalar>(u: &V3<T>, v: &V3<T>, (a, b): (usize, usize)) -> Sz<T> {
    if a == b { mul(u[a], v[a]) } else { add(mul(u[a], v[b]), mul(u[b], v[a])) }
}

/// The needed entries of block `(i, l)` (bits of `need`) at the measured accelerations
/// into `out.y`, and at the instrumental ones into `out.y_z` when `instr`; their
/// structure into `out.nz`. Returns the measured block, all ten entries when `full`.
#[allow(clippy::too_many_arguments)]
fn blocks<const N: usize, T: RealScalar>(
    model: &Model<N>,
    frames: &[Frame<T>; N],
    m: &Motion<T, N>,
    i: usize,
    l: usize,
    need: u16,
    full: bool,
    instr: bool,
    out: &mut TerminalRows<N, T>,
) -> [Sz<T>; LINK_PARAMS] {
    // joint i's unit motion (sw, sv), carried to link l: sv' = R^T (sv + sw x p), sw' = R^T sw
    let a = &model.joints[i].axis;
    let none: V3<T> = [None; 3];
    let (mut sw, mut sv) = match model.joints[i].kind {
        JointKind::Revolute => (konst::<T>(a), none),
        JointKind::Prismatic => (none, konst::<T>(a)),
    };
    for j in i + 1..=l {
        sv = frames[j].in_child(&vadd(&sv, &cross(&sw, &frames[j].p)));
        sw = frames[j].in_child(&sw);
    }
    let need_y = if full { (1 << LINK_PARAMS) - 1 } else { need };
    let w = &m.w[l];
    let has = |e: usize| need_y & (1 << e) != 0;
    // velocity parts: Y[h] <- w x (w x sv); Y[I] <- (sw x w)^T I w
    let mut vel: [Sz<T>; LINK_PARAMS] = [None; LINK_PARAMS];
    if has(1) || has(2) || has(3) {
        let yh = cross(w, &cross(w, &sv));
        vel[1..4].copy_from_slice(&yh);
    }
    if (4..LINK_PARAMS).any(has) {
        let u2 = cross(&sw, w);
        for (k, &pair) in I_PAIRS.iter().enumerate() {
            if has(4 + k) {
                vel[4 + k] = sym_entry(&u2, w, pair);
            }
        }
    }
    let y = accel_part(&vel, need_y, &sw, &sv, &m.wd[l], &m.acc[l]);
    let mut nz = 0u16;
    for e in (0..LINK_PARAMS).filter(|e| need & (1 << e) != 0) {
        out.y.link[i][l][e] = or0(y[e]);
        nz |= u16::from(y[e].is_some()) << e;
    }
    if instr {
        let y_z = accel_part(&vel, need, &sw, &sv, &m.wd_z[l], &m.acc_z[l]);
        for e in (0..LINK_PARAMS).filter(|e| need & (1 << e) != 0) {
            out.y_z.link[i][l][e] = or0(y_z[e]);
            nz |= u16::from(y_z[e].is_some()) << e;
        }
    }
    out.nz[i][l] = nz;
    y
}

/// Adds the parts linear in `(wd, acc)` to the velocity parts: `Y[m] = sv . acc`,
/// `Y[h] += acc x sw + sv x wd`, `Y[I] += sw^T I wd`; the entries of `need`.
#[inline(always)]
fn accel_part<T: RealScalar>(
    vel: &[Sz<T>; LINK_PARAMS],
    need: u16,
    sw: &V3<T>,
    sv: &V3<T>,
    wd: &V3<T>,
    acc: &V3<T>,
) -> [Sz<T>; LINK_PARAMS] {
    let has = |e: usize| need & (1 << e) != 0;
    let mut out = [None; LINK_PARAMS];
    if has(0) {
        out[0] = dot(sv, acc);
    }
    if has(1) || has(2) || has(3) {
        let ya = vadd(&cross(acc, sw), &cross(sv, wd));
        for k in 0..3 {
            if has(1 + k) {
                out[1 + k] = add(ya[k], vel[1 + k]);
            }
        }
    }
    for (k, &pair) in I_PAIRS.iter().enumerate() {
        if has(4 + k) {
            out[4 + k] = add(sym_entry(sw, wd, pair), vel[4 + k]);
        }
    }
    out
}

/// Inward recursion (eqs 6-8) over links `N-1 .. r0`: the nominal torque of rows `r0..N`,
/// drive terms included.
fn inward<const N: usize, T: RealScalar>(
    model: &Model<N>,
    frames: &[Frame<T>; N],
    m: &Motion<T, N>,
    r0: usize,
    qd: &SVector<T, N>,
    qdd: &SVector<T, N>,
    tau: &mut SVector<T, N>,
) {
    let none: V3<T> = [None; 3];
    let (mut f_c, mut n_c) = (none, none); // the child's force and moment, this link's coords
    for i in (r0..N).rev() {
        let p = &model.inertia[i].0;
        let k = |x: f64| Some(T::from_f64(x));
        let (mass, h) = (k(p[0]), [k(p[1]), k(p[2]), k(p[3])]);
        let (w, wd, acc) = (&m.w[i], &m.wd[i], &m.acc[i]);
        // f = m acc + wd x h + w x (w x h) + f_c                                  (eq 6)
        let f = vadd(
            &vadd(&[mul(acc[0], mass), mul(acc[1], mass), mul(acc[2], mass)], &cross(wd, &h)),
            &cross(w, &cross(w, &h)),
        );
        let f = vadd(&f, &f_c);
        // n = I wd + w x (I w) + h x acc + n_c                                   (eq 7)
        let i_o = [[k(p[4]), k(p[5]), k(p[7])], [k(p[5]), k(p[6]), k(p[8])], [k(p[7]), k(p[8]), k(p[9])]];
        let imul = |v: &V3<T>| -> V3<T> {
            core::array::from_fn(|r| add(add(mul(i_o[r][0], v[0]), mul(i_o[r][1], v[1])), mul(i_o[r][2], v[2])))
        };
        let n = vadd(&vadd(&imul(wd), &cross(w, &imul(w))), &cross(&h, acc));
        let n = vadd(&n, &n_c);
        // tau_i = a . n (revolute) or a . f (prismatic), plus the drive              (eq 8)
        let joint = &model.joints[i];
        let proj = axis_dot(&joint.axis, if joint.kind == JointKind::Revolute { &n } else { &f });
        tau[i] = or0(proj) + drive_torque(&model.drive[i], qd[i], qdd[i]);
        if i > r0 {
            let fr = &frames[i];
            f_c = fr.in_parent(&f);
            n_c = vadd(&fr.in_parent(&n), &cross(&fr.p, &f_c));
        }
    }
}

/// `a . v` for a constant axis (structure skipped: a coordinate axis is a coordinate).
#[inline(always)]
fn axis_dot<T: RealScalar>(a: &Vec3, v: &V3<T>) -> Sz<T> {
    add(add(kmul(v[0], a.x), kmul(v[1], a.y)), kmul(v[2], a.z))
}

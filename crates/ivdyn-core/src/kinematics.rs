//! Kinematic passes shared by the dynamics algorithms.
//!
//! [`joint_transforms`] and [`forward_pass`] are written once for any [`Lanes`] scalar:
//! `f64` (one sample, as on a controller) or a SIMD pack such as simba's `AutoF64x4`
//! (four samples in lock step, as in `ivdyn`'s batch kernels). The model stays `f64`;
//! its constants are broadcast with `splat`, a no-op for `f64`.

use crate::data::Data;
pub use crate::data::Kinematics;
use crate::model::{JointKind, Model};
use crate::spatial::axis_angle_sc;
use crate::types::{Lanes, Mat3, Vec3, VecN};
use nalgebra::{Matrix3, SVector, Vector3};

/// `v` broadcast to every lane of `T`.
#[inline(always)]
pub fn splat3<T: Lanes>(v: &Vec3) -> Vector3<T> {
    Vector3::new(T::splat(v.x), T::splat(v.y), T::splat(v.z))
}

/// Joint placements at `q`: `kin.rot[i]`, `kin.pos[i]` (link `i` in link `i-1`).
#[inline(always)]
pub fn joint_transforms<T: Lanes, const N: usize>(model: &Model<N>, kin: &mut Kinematics<T, N>, q: &SVector<T, N>) {
    for i in 0..N {
        (kin.rot[i], kin.pos[i]) = joint_transform(model, i, q[i]);
    }
}

/// Placement `(R_i, p_i)` of link `i` in link `i-1` at `q_i = qi`.
#[inline(always)]
fn joint_transform<T: Lanes, const N: usize>(model: &Model<N>, i: usize, qi: T) -> (Matrix3<T>, Vector3<T>) {
    let x = &model.x_tree[i];
    let j = &model.joints[i];
    match j.kind {
        JointKind::Revolute => (rotate_about(&x.rot, &j.axis, qi), splat3(&x.trans)),
        JointKind::Prismatic => {
            let p = splat3::<T>(&x.trans) + x.rot.map(T::splat) * (splat3::<T>(&j.axis) * qi);
            (x.rot.map(T::splat), p)
        }
    }
}

/// `Some((k, sign))` if `axis` is `sign * e_k` (the common joint axes: DH, most URDF arms),
/// `sign = +-1`.
///
/// Runs for every joint and call, so it is cheap: on the bit patterns, `(a | b) << 1 == 0`
/// is `a == 0.0 && b == 0.0` (either zero, not NaN) in three integer instructions instead
/// of two compares and four branches; `copysign(1, a)` is `signum(a)` for the finite axes
/// `Model::new` accepts, without signum's NaN test (callgrind, paper RNEA: 52 fewer
/// instructions per call in `rotate_about`).
#[inline(always)]
pub fn coord_axis(axis: &Vec3) -> Option<(usize, f64)> {
    let zeros = |a: f64, b: f64| (a.to_bits() | b.to_bits()) << 1 == 0;
    if zeros(axis.x, axis.y) {
        Some((2, 1.0f64.copysign(axis.z)))
    } else if zeros(axis.x, axis.z) {
        Some((1, 1.0f64.copysign(axis.y)))
    } else if zeros(axis.y, axis.z) {
        Some((0, 1.0f64.copysign(axis.x)))
    } else {
        None
    }
}

/// `e * Rot(axis, angle)`, with a cheap path for the common axes `+-x, +-y, +-z`
/// (only two columns of `e` mix), as Pinocchio's RX/RY/RZ joints do.
#[inline(always)]
pub fn rotate_about<T: Lanes>(e: &Mat3, axis: &Vec3, angle: T) -> Matrix3<T> {
    let (s, c) = crate::trig::sin_cos(angle);
    // Rot(+-k, q) = Rot(k, +-q): fold the axis sign into the sine
    let (k, s) = match coord_axis(axis) {
        Some((k, sign)) => (k, s * T::splat(sign)),
        None => return e.map(T::splat) * axis_angle_sc(axis, s, c),
    };
    // columns (a, b) rotate in their plane: Rot(z) = [[c, -s], [s, c]] on (x, y), etc.;
    // one literal matrix per axis, so the columns stay in registers (no indexed stores)
    let col = |j: usize| splat3::<T>(&e.column(j).into_owned());
    let turn = |ca: Vector3<T>, cb: Vector3<T>| (ca * c + cb * s, cb * c - ca * s);
    match k {
        0 => {
            let (c1, c2) = turn(col(1), col(2));
            Matrix3::from_columns(&[col(0), c1, c2])
        }
        1 => {
            let (c2, c0) = turn(col(2), col(0));
            Matrix3::from_columns(&[c0, col(1), c2])
        }
        _ => {
            let (c0, c1) = turn(col(0), col(1));
            Matrix3::from_columns(&[c0, c1, col(2)])
        }
    }
}

/// Forward recursion of the Newton-Euler method, paper eqs (2)-(4) generalised to any
/// joint axis and to prismatic joints; fills `w`, `wd`, `acc` (gravity as base
/// acceleration `-g`). Needs `joint_transforms` first.
#[inline(always)]
pub fn forward_pass<T: Lanes, const N: usize>(
    model: &Model<N>,
    kin: &mut Kinematics<T, N>,
    qd: &SVector<T, N>,
    qdd: &SVector<T, N>,
) {
    if N == 0 {
        return;
    }
    // link 0 moves from the base at rest: with w = wd = 0 eq (4)'s cross products, R^T w and
    // R^T wd are zeros, left out (the same values; a zero may change sign)
    let acc = base_gravity_in(&kin.rot[0], &model.gravity);
    let a = splat3::<T>(&model.joints[0].axis);
    let mut s = match model.joints[0].kind {
        JointKind::Revolute => (a * qd[0], a * qdd[0], acc),
        JointKind::Prismatic => (Vector3::zeros(), Vector3::zeros(), acc + a * qdd[0]),
    };
    (kin.w[0], kin.wd[0], kin.acc[0]) = s;
    for i in 1..N {
        s = forward_step(model, i, &kin.rot[i], &kin.pos[i], s, qd[i], qdd[i]);
        (kin.w[i], kin.wd[i], kin.acc[i]) = s;
    }
}

/// Link 0's origin acceleration `R_0^T (-g)` (gravity as base acceleration). Gravity along
/// the base z axis (the usual `(0, 0, -9.81)`) needs only `R_0`'s last row: the products by
/// `g`'s zero entries are left out (the same values; a zero may change sign).
#[inline(always)]
fn base_gravity_in<T: Lanes>(r: &Matrix3<T>, g: &Vec3) -> Vector3<T> {
    if (g.x.to_bits() | g.y.to_bits()) << 1 == 0 {
        let gz = T::splat(-g.z);
        return Vector3::new(r[(2, 0)] * gz, r[(2, 1)] * gz, r[(2, 2)] * gz);
    }
    r.tr_mul(&splat3::<T>(&-g))
}

/// One step of the forward recursion: link `i`'s `(w, wd, acc)` from link `i-1`'s and
/// the joint placement `(r, p)`.
#[inline(always)]
fn forward_step<T: Lanes, const N: usize>(
    model: &Model<N>,
    i: usize,
    r: &Matrix3<T>,
    p: &Vector3<T>,
    (w, wd, acc): (Vector3<T>, Vector3<T>, Vector3<T>),
    qd: T,
    qdd: T,
) -> (Vector3<T>, Vector3<T>, Vector3<T>) {
    let a = splat3::<T>(&model.joints[i].axis);
    // acc of the new origin, in parent coords: acc + wd x p + w x (w x p)   (eq 4)
    let acc_p = acc + wd.cross(p) + w.cross(&w.cross(p));
    // R^T w, R^T wd, R^T acc_p as one matrix product: the same dot products (the same
    // bits), 15 instructions fewer per call than three products by a vector (paper RNEA)
    let m = r.tr_mul(&Matrix3::from_columns(&[w, wd, acc_p]));
    let (w_p, wd_p, acc) = (m.column(0).into_owned(), m.column(1).into_owned(), m.column(2).into_owned());
    match model.joints[i].kind {
        // w_i = R^T w_{i-1} + a qd                        (eq 2)
        // wd_i = R^T wd_{i-1} + a qdd + (R^T w_{i-1}) x a qd (eq 3)
        JointKind::Revolute => match coord_axis(&model.joints[i].axis) {
            Some((k, sign)) => {
                let (w, wd) = revolute_about_coord(k, T::splat(sign), &w_p, &wd_p, qd, qdd);
                (w, wd, acc)
            }
            None => (w_p + a * qd, wd_p + a * qdd + w_p.cross(&a) * qd, acc),
        },
        // the joint adds a qdd and the Coriolis term 2 w x a qd to the origin
        JointKind::Prismatic => (w_p, wd_p, acc + (a * qdd + w_p.cross(&a) * (T::splat(2.0) * qd))),
    }
}

/// Eqs (2)-(3) of a revolute joint about `a = sign * e_k`: `w = w_p + a qd`,
/// `wd = wd_p + a qdd + (w_p x a) qd` with `w_p x e_k` written out, so the products by
/// the axis' zero entries are left out (the same values; a zero may change sign).
#[inline(always)]
fn revolute_about_coord<T: Lanes>(
    k: usize,
    sign: T,
    w_p: &Vector3<T>,
    wd_p: &Vector3<T>,
    qd: T,
    qdd: T,
) -> (Vector3<T>, Vector3<T>) {
    let (sq, sqdd) = (sign * qd, sign * qdd);
    let (v, d) = (w_p, wd_p);
    match k {
        // v x e_x = (0, v_z, -v_y)
        0 => (Vector3::new(v.x + sq, v.y, v.z), Vector3::new(d.x + sqdd, d.y + v.z * sq, d.z - v.y * sq)),
        // v x e_y = (-v_z, 0, v_x)
        1 => (Vector3::new(v.x, v.y + sq, v.z), Vector3::new(d.x - v.z * sq, d.y + sqdd, d.z + v.x * sq)),
        // v x e_z = (v_y, -v_x, 0)
        _ => (Vector3::new(v.x, v.y, v.z + sq), Vector3::new(d.x + v.y * sq, d.y - v.x * sq, d.z + sqdd)),
    }
}

/// Placement of every link in the base frame at `q`: fills `o_rot`, `o_pos` (and
/// `rot`, `pos`).
pub fn forward_kinematics<const N: usize>(model: &Model<N>, data: &mut Data<N>, q: &VecN<N>) {
    joint_transforms(model, &mut data.kin, q);
    let mut r = crate::types::Mat3::identity();
    let mut p = Vec3::zeros();
    for i in 0..N {
        p += r * data.kin.pos[i];
        r *= data.kin.rot[i];
        data.o_rot[i] = r;
        data.o_pos[i] = p;
    }
}

/// Placement of the tool frame in the base frame at `q`.
pub fn tool_pose<const N: usize>(model: &Model<N>, data: &mut Data<N>, q: &VecN<N>) -> crate::spatial::Transform {
    forward_kinematics(model, data, q);
    if N == 0 {
        return model.tool;
    }
    crate::spatial::Transform::new(data.o_rot[N - 1], data.o_pos[N - 1]).compose(&model.tool)
}

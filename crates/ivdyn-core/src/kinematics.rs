//! Kinematic passes shared by the dynamics algorithms.

use crate::data::Data;
use crate::model::{JointKind, Model};
use crate::spatial::axis_angle_sc;
use crate::Mat3;
#[allow(unused_imports)] // needed without std (libm-backed trig), unused when std is unified in
use nalgebra::ComplexField;
use crate::{Vec3, VecN};

/// Joint placements at `q`: `data.rot[i]`, `data.pos[i]` (link `i` in link `i-1`).
#[inline]
pub fn joint_transforms<const N: usize>(model: &Model<N>, data: &mut Data<N>, q: &VecN<N>) {
    for i in 0..N {
        let x = &model.x_tree[i];
        let j = &model.joints[i];
        match j.kind {
            JointKind::Revolute => {
                data.rot[i] = rotate_about(&x.rot, &j.axis, q[i]);
                data.pos[i] = x.trans;
            }
            JointKind::Prismatic => {
                data.rot[i] = x.rot;
                data.pos[i] = x.trans + x.rot * (j.axis * q[i]);
            }
        }
    }
}

/// `e * Rot(axis, angle)`, with a cheap path for the common axes `+-x, +-y, +-z`
/// (only two columns of `e` mix), as Pinocchio's RX/RY/RZ joints do.
#[inline]
pub fn rotate_about(e: &Mat3, axis: &Vec3, angle: f64) -> Mat3 {
    let (s, c) = angle.sin_cos();
    // Rot(+-k, q) = Rot(k, +-q): fold the axis sign into the sine
    let (k, s) = if axis.x == 0.0 && axis.y == 0.0 {
        (2, s * axis.z.signum())
    } else if axis.x == 0.0 && axis.z == 0.0 {
        (1, s * axis.y.signum())
    } else if axis.y == 0.0 && axis.z == 0.0 {
        (0, s * axis.x.signum())
    } else {
        return e * axis_angle_sc(axis, s, c);
    };
    // columns (a, b) rotate in their plane: Rot(z) = [[c, -s], [s, c]] on (x, y), etc.
    let (a, b) = match k {
        0 => (1, 2),
        1 => (2, 0),
        _ => (0, 1),
    };
    let mut r = *e;
    let (ca, cb) = (e.column(a).into_owned(), e.column(b).into_owned());
    r.set_column(a, &(ca * c + cb * s));
    r.set_column(b, &(cb * c - ca * s));
    r
}

/// Forward recursion of the Newton-Euler method, paper eqs (2)-(4) generalised to any
/// joint axis and to prismatic joints; fills `w`, `wd`, `acc` (gravity as base
/// acceleration `-g`). Needs `joint_transforms` first.
#[inline]
pub fn forward_pass<const N: usize>(
    model: &Model<N>,
    data: &mut Data<N>,
    qd: &VecN<N>,
    qdd: &VecN<N>,
) {
    let mut w = Vec3::zeros();
    let mut wd = Vec3::zeros();
    let mut acc = -model.gravity;
    for i in 0..N {
        let r = &data.rot[i];
        let p = &data.pos[i];
        let a = &model.joints[i].axis;
        // acc of the new origin, in parent coords: acc + wd x p + w x (w x p)   (eq 4)
        let acc_p = acc + wd.cross(p) + w.cross(&w.cross(p));
        let w_p = r.tr_mul(&w);
        let wd_p = r.tr_mul(&wd);
        acc = r.tr_mul(&acc_p);
        match model.joints[i].kind {
            JointKind::Revolute => {
                // w_i = R^T w_{i-1} + a qd                        (eq 2)
                // wd_i = R^T wd_{i-1} + a qdd + (R^T w_{i-1}) x a qd (eq 3)
                w = w_p + a * qd[i];
                wd = wd_p + a * qdd[i] + w_p.cross(a) * qd[i];
            }
            JointKind::Prismatic => {
                // the joint adds a qdd and the Coriolis term 2 w x a qd to the origin
                w = w_p;
                wd = wd_p;
                acc += a * qdd[i] + 2.0 * w.cross(a) * qd[i];
            }
        }
        data.w[i] = w;
        data.wd[i] = wd;
        data.acc[i] = acc;
    }
}

/// Placement of every link in the base frame at `q`: fills `o_rot`, `o_pos` (and
/// `rot`, `pos`).
pub fn forward_kinematics<const N: usize>(model: &Model<N>, data: &mut Data<N>, q: &VecN<N>) {
    joint_transforms(model, data, q);
    let mut r = crate::Mat3::identity();
    let mut p = Vec3::zeros();
    for i in 0..N {
        p += r * data.pos[i];
        r *= data.rot[i];
        data.o_rot[i] = r;
        data.o_pos[i] = p;
    }
}

/// Placement of the tool frame in the base frame at `q`.
pub fn tool_pose<const N: usize>(
    model: &Model<N>,
    data: &mut Data<N>,
    q: &VecN<N>,
) -> crate::Transform {
    forward_kinematics(model, data, q);
    if N == 0 {
        return model.tool;
    }
    crate::Transform::new(data.o_rot[N - 1], data.o_pos[N - 1]).compose(&model.tool)
}

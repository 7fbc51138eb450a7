//! The joint-torque regressor `Y(q, qd, qdd)`: `tau = Y theta`, computed by its own
//! recursion (paper eq 21, with the standard 10-parameter link model of [Atkeson86]).
//!
//! # Math note
//! Link `j`'s force and moment about its origin are linear in its parameters `pi_j`:
//! `f = m acc + wd x h + w x (w x h)`, `n = I_o wd + w x (I_o w) + h x acc`. Joint `i`'s
//! torque is the projection of those wrenches of all outer links `j >= i` on joint
//! `i`'s motion subspace: `Y_ij pi_j = s_i^(j) . (n_j, f_j)`, where `s_i^(j) = (sw, sv)` is
//! joint `i`'s unit motion (angular `sw`, linear velocity of link `j`'s origin `sv`)
//! expressed in link `j`'s frame. Moving the dot products onto the parameters gives
//! (triple products and symmetry of `I_o`):
//! - `Y[m] = sv . acc`
//! - `Y[h] = acc x sw + sv x wd + w x (w x sv)`
//! - `Y[I] = sw^T I_o wd + (sw x w)^T I_o w`, spread over the six entries of `I_o`.
//!
//! `s_i` is carried outward from link `i` to `N` (6 numbers per step), so the cost is
//! `O(N^2)` small dot products rather than transforming 6x10 blocks inward.

use crate::data::Data;
use crate::kinematics::{Kinematics, forward_pass, joint_transforms, splat3};
use crate::model::{JointKind, Model};
use crate::params::{DRIVE_PARAMS, LINK_PARAMS};
use crate::types::{Lanes, VecN};
use nalgebra::{SVector, Vector3};

pub use crate::regressor_matrix::Regressor;

/// Fills one 10-entry block: joint motion `(sw, sv)` against link kinematics `(w, wd, acc)`.
#[inline(always)]
fn block<T: Lanes>(
    out: &mut [T; LINK_PARAMS],
    sw: &Vector3<T>,
    sv: &Vector3<T>,
    w: &Vector3<T>,
    wd: &Vector3<T>,
    acc: &Vector3<T>,
) {
    // Y[m] = sv . acc
    out[0] = sv.dot(acc);
    // Y[h] = acc x sw + sv x wd + w x (w x sv)
    let yh = acc.cross(sw) + sv.cross(wd) + w.cross(&w.cross(sv));
    out[1] = yh.x;
    out[2] = yh.y;
    out[3] = yh.z;
    // Y[I]: u1^T I v1 + u2^T I v2 with (u1, v1) = (sw, wd), (u2, v2) = (sw x w, w)
    let u2 = sw.cross(w);
    let (u1, v1, v2) = (sw, wd, w);
    out[4] = u1.x * v1.x + u2.x * v2.x;
    out[5] = u1.x * v1.y + u1.y * v1.x + u2.x * v2.y + u2.y * v2.x;
    out[6] = u1.y * v1.y + u2.y * v2.y;
    out[7] = u1.x * v1.z + u1.z * v1.x + u2.x * v2.z + u2.z * v2.x;
    out[8] = u1.y * v1.z + u1.z * v1.y + u2.y * v2.z + u2.z * v2.y;
    out[9] = u1.z * v1.z + u2.z * v2.z;
}

/// Unit motion of joint `i` in its own link frame: `(angular, linear)`.
#[inline(always)]
fn joint_motion<T: Lanes, const N: usize>(model: &Model<N>, i: usize) -> (Vector3<T>, Vector3<T>) {
    let a = splat3::<T>(&model.joints[i].axis);
    match model.joints[i].kind {
        JointKind::Revolute => (a, Vector3::zeros()),
        JointKind::Prismatic => (Vector3::zeros(), a),
    }
}

/// Carries a unit joint motion from link `j-1`'s frame into link `j`'s frame:
/// `sv' = R^T (sv + sw x p)`, `sw' = R^T sw`.
#[inline(always)]
fn carry<T: Lanes, const N: usize>(kin: &Kinematics<T, N>, j: usize, sw: &mut Vector3<T>, sv: &mut Vector3<T>) {
    let r = &kin.rot[j];
    *sv = r.tr_mul(&(*sv + sw.cross(&kin.pos[j])));
    *sw = r.tr_mul(sw);
}

/// The inertial blocks `y.link` of the regressor at `(q, qd, qdd)` (the drive blocks are
/// left alone): the recursion behind [`regressor`], written once for `f64` and for packs
/// of samples (`T` = simba's `AutoF64x4`: four samples per call, in the batch kernels).
#[inline(always)]
pub fn regressor_links<T: Lanes, const N: usize>(
    model: &Model<N>,
    kin: &mut Kinematics<T, N>,
    y: &mut Regressor<N, T>,
    q: &SVector<T, N>,
    qd: &SVector<T, N>,
    qdd: &SVector<T, N>,
) {
    joint_transforms(model, kin, q);
    forward_pass(model, kin, qd, qdd);
    let zero = [T::splat(0.0); LINK_PARAMS];
    for i in 0..N {
        let (mut sw, mut sv) = joint_motion::<T, N>(model, i);
        for j in 0..i {
            y.link[i][j] = zero;
        }
        for j in i..N {
            if j > i {
                carry(kin, j, &mut sw, &mut sv);
            }
            block(&mut y.link[i][j], &sw, &sv, &kin.w[j], &kin.wd[j], &kin.acc[j]);
        }
    }
}

/// The joint-torque regressor at `(q, qd, qdd)`; `regressor(..).mul(theta) == rnea(..)`
/// for the model's parameters `theta`. Returns `&data.y`.
pub fn regressor<'d, const N: usize>(
    model: &Model<N>,
    data: &'d mut Data<N>,
    q: &VecN<N>,
    qd: &VecN<N>,
    qdd: &VecN<N>,
) -> &'d Regressor<N> {
    regressor_links(model, &mut data.kin, &mut data.y, q, qd, qdd);
    for i in 0..N {
        data.y.drive[i] = model.drive[i].regressor_row(qd[i], qdd[i]);
    }
    &data.y
}

/// The static (gravity-only) regressor: `gravity_regressor(q).mul(theta) == gravity(q)`.
/// Inertia-tensor and drive columns are zero.
pub fn gravity_regressor<'d, const N: usize>(model: &Model<N>, data: &'d mut Data<N>, q: &VecN<N>) -> &'d Regressor<N> {
    joint_transforms(model, &mut data.kin, q);
    // acc_i = R_i^T acc_{i-1}, acc_0 = -g (no motion)
    let mut acc = -model.gravity;
    for i in 0..N {
        acc = data.kin.rot[i].tr_mul(&acc);
        data.kin.acc[i] = acc;
    }
    for i in 0..N {
        let (mut sw, mut sv) = joint_motion::<f64, N>(model, i);
        for j in 0..i {
            data.y.link[i][j] = [0.0; LINK_PARAMS];
        }
        for j in i..N {
            if j > i {
                carry(&data.kin, j, &mut sw, &mut sv);
            }
            let acc = &data.kin.acc[j];
            let yh = acc.cross(&sw);
            data.y.link[i][j] = [sv.dot(acc), yh.x, yh.y, yh.z, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0];
        }
        data.y.drive[i] = [0.0; DRIVE_PARAMS];
    }
    &data.y
}

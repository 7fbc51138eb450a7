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
use crate::params::{DRIVE_PARAMS, LINK_PARAMS, PARAMS_PER_JOINT};
use crate::{Lanes, VecN};
use nalgebra::{SVector, Vector3};

/// Joint-torque regressor of an `N`-joint chain, stored by blocks: `link[i][j]` is row
/// `i`'s 10 entries for link `j` (zero for `j < i`), `drive[i]` row `i`'s 4 entries for
/// joint `i`'s drive parameters (the other drive columns of row `i` are zero). `T` is
/// `f64`, or a pack of samples for the batch kernels (see [`regressor_links`]).
#[derive(Debug, Clone, PartialEq)]
pub struct Regressor<const N: usize, T = f64> {
    /// Inertial blocks, `link[row][link]`.
    pub link: [[[T; LINK_PARAMS]; N]; N],
    /// Drive blocks `[sign(qd), qd, qdd, 1]` per row.
    pub drive: [[T; DRIVE_PARAMS]; N],
}

impl<const N: usize, T: Lanes> Regressor<N, T> {
    /// All zero, for any lane type.
    pub fn zeros() -> Self {
        let z = T::splat(0.0);
        Self { link: [[[z; LINK_PARAMS]; N]; N], drive: [[z; DRIVE_PARAMS]; N] }
    }
}

impl<const N: usize> Default for Regressor<N> {
    fn default() -> Self {
        Self::new()
    }
}

impl<const N: usize> Regressor<N> {
    /// All zero.
    pub const fn new() -> Self {
        Self { link: [[[0.0; LINK_PARAMS]; N]; N], drive: [[0.0; DRIVE_PARAMS]; N] }
    }

    /// Number of columns (`14 N`).
    pub const fn cols(&self) -> usize {
        PARAMS_PER_JOINT * N
    }

    /// Entry `(row, col)` of the dense `N x 14N` matrix.
    pub fn get(&self, row: usize, col: usize) -> f64 {
        if col < LINK_PARAMS * N {
            self.link[row][col / LINK_PARAMS][col % LINK_PARAMS]
        } else {
            let c = col - LINK_PARAMS * N;
            if c / DRIVE_PARAMS == row { self.drive[row][c % DRIVE_PARAMS] } else { 0.0 }
        }
    }

    /// Writes row `row` of the dense matrix into `out` (length `14 N`).
    #[inline]
    pub fn write_row(&self, row: usize, out: &mut [f64]) {
        let nl = LINK_PARAMS * N;
        for j in 0..N {
            out[LINK_PARAMS * j..LINK_PARAMS * (j + 1)].copy_from_slice(&self.link[row][j]);
        }
        out[nl..].fill(0.0);
        out[nl + DRIVE_PARAMS * row..nl + DRIVE_PARAMS * (row + 1)].copy_from_slice(&self.drive[row]);
    }

    /// Writes the dense `N x 14N` matrix in row-major order into `out` (length `14 N^2`).
    pub fn write_row_major(&self, out: &mut [f64]) {
        let p = PARAMS_PER_JOINT * N;
        for i in 0..N {
            self.write_row(i, &mut out[p * i..p * (i + 1)]);
        }
    }

    /// Writes only the inertial `N x 10N` part in row-major order (length `10 N^2`).
    pub fn write_rigid_row_major(&self, out: &mut [f64]) {
        let p = LINK_PARAMS * N;
        for i in 0..N {
            for j in 0..N {
                let o = p * i + LINK_PARAMS * j;
                out[o..o + LINK_PARAMS].copy_from_slice(&self.link[i][j]);
            }
        }
    }

    /// The dense matrix; `P` must be `14 N` (checked at compile time).
    pub fn to_matrix<const P: usize>(&self) -> nalgebra::SMatrix<f64, N, P> {
        const { assert!(P == PARAMS_PER_JOINT * N, "P must be 14 * N") };
        nalgebra::SMatrix::<f64, N, P>::from_fn(|r, c| self.get(r, c))
    }

    /// `Y theta` for a parameter slice of length `14 N`.
    pub fn mul(&self, theta: &[f64]) -> VecN<N> {
        let nl = LINK_PARAMS * N;
        let mut tau = VecN::<N>::zeros();
        for i in 0..N {
            let mut s = 0.0;
            for j in i..N {
                let th = &theta[LINK_PARAMS * j..LINK_PARAMS * (j + 1)];
                s += self.link[i][j].iter().zip(th).map(|(a, b)| a * b).sum::<f64>();
            }
            let th = &theta[nl + DRIVE_PARAMS * i..nl + DRIVE_PARAMS * (i + 1)];
            s += self.drive[i].iter().zip(th).map(|(a, b)| a * b).sum::<f64>();
            tau[i] = s;
        }
        tau
    }
}

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

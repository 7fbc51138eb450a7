//! Work buffers of the algorithms, allocated once by the caller.

use crate::inertia::LinkInertia;
use crate::regressor_matrix::Regressor;
use crate::types::{Lanes, Mat3, MatN, Vec3, VecN};
use nalgebra::{Matrix3, Vector3};

/// Every intermediate buffer of the algorithms for an `N`-joint chain. Create it once
/// (it can be a `static` on a controller) and pass it to each call; algorithms return
/// references into it.
#[derive(Debug, Clone)]
pub struct Data<const N: usize> {
    /// Link kinematics (`rot`, `pos`, `w`, `wd`, `acc`), paper eqs (2)-(4); filled by
    /// every algorithm's kinematic pass.
    pub kin: Kinematics<f64, N>,
    /// Force on link `i` from link `i-1` (link `i` coords), paper eq (6).
    pub f: [Vec3; N],
    /// Moment on link `i` from link `i-1` about link `i`'s origin, paper eq (7).
    pub n: [Vec3; N],
    /// Joint torques; filled by `rnea`/`gravity`.
    pub tau: VecN<N>,
    /// Joint-torque regressor; filled by `regressor`/`gravity_regressor`.
    pub y: Regressor<N>,
    /// Composite inertia of links `i..N` in link `i`'s frame; filled by `mass_matrix`.
    pub ic: [LinkInertia; N],
    /// Joint-space mass matrix (armature included); filled by `mass_matrix`.
    pub m: MatN<N>,
    /// Cholesky factor workspace; filled by `forward_dynamics`.
    pub l: MatN<N>,
    /// Joint accelerations; filled by `forward_dynamics`.
    pub qdd: VecN<N>,
    /// Orientation of link `i` in the base frame; filled by `kinematics::forward_kinematics`.
    pub o_rot: [Mat3; N],
    /// Origin of link `i` in the base frame; filled by `kinematics::forward_kinematics`.
    pub o_pos: [Vec3; N],
    /// Linear velocity of link `i`'s origin (link coords); filled by `energy::kinetic_energy`.
    pub v: [Vec3; N],
}

impl<const N: usize> Data<N> {
    /// Zeroed buffers.
    pub fn new() -> Self {
        let z3 = Vec3::zeros();
        Self {
            kin: Kinematics::new(),
            f: [z3; N],
            n: [z3; N],
            tau: VecN::<N>::zeros(),
            y: Regressor::new(),
            ic: [LinkInertia::ZERO; N],
            m: MatN::<N>::zeros(),
            l: MatN::<N>::zeros(),
            qdd: VecN::<N>::zeros(),
            o_rot: [Mat3::identity(); N],
            o_pos: [z3; N],
            v: [z3; N],
        }
    }
}

impl<const N: usize> Default for Data<N> {
    fn default() -> Self {
        Self::new()
    }
}

/// Link kinematics at one sample (`T = f64`) or a pack of samples: filled by
/// [`crate::kinematics::joint_transforms`] and
/// [`crate::kinematics::forward_pass`], read by RNEA, CRBA and the regressor.
#[derive(Debug, Clone)]
pub struct Kinematics<T: nalgebra::Scalar, const N: usize> {
    /// Link `i` axes in link `i-1` coordinates (`R_i`, parent <- child); filled by every
    /// algorithm's kinematic pass.
    pub rot: [Matrix3<T>; N],
    /// Origin of link `i` in link `i-1` coordinates (includes prismatic displacement).
    pub pos: [Vector3<T>; N],
    /// Angular velocity of link `i` (link `i` coords), paper eq (2).
    pub w: [Vector3<T>; N],
    /// Angular acceleration of link `i`, paper eq (3).
    pub wd: [Vector3<T>; N],
    /// Linear acceleration of link `i`'s origin, gravity included as `-g`, paper eq (4).
    pub acc: [Vector3<T>; N],
}

impl<T: Lanes, const N: usize> Kinematics<T, N> {
    /// Identity rotations, zero vectors.
    pub fn new() -> Self {
        let z3 = Vector3::<T>::zeros();
        Self { rot: [Matrix3::<T>::identity(); N], pos: [z3; N], w: [z3; N], wd: [z3; N], acc: [z3; N] }
    }
}

impl<T: Lanes, const N: usize> Default for Kinematics<T, N> {
    fn default() -> Self {
        Self::new()
    }
}

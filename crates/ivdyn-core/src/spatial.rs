//! Rigid transforms and small 3-D helpers.
//!
//! A [`Transform`] `X = (rot, trans)` is the placement of a child frame in its parent:
//! a point `x_c` in child coordinates is `rot * x_c + trans` in parent coordinates, so the
//! columns of `rot` are the child axes seen from the parent.

use crate::types::{Mat3, Vec3};
#[allow(unused_imports)] // needed without std (libm-backed trig), unused when std is unified in
use nalgebra::{ComplexField, RealField};

/// Placement of a child frame in its parent frame.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Transform {
    /// Child axes in parent coordinates (parent <- child rotation).
    pub rot: Mat3,
    /// Child origin in parent coordinates.
    pub trans: Vec3,
}

impl Default for Transform {
    fn default() -> Self {
        Self::IDENTITY
    }
}

impl Transform {
    /// The identity placement.
    pub const IDENTITY: Transform =
        Transform { rot: Mat3::new(1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0), trans: Vec3::new(0.0, 0.0, 0.0) };

    /// From a rotation and a translation.
    pub fn new(rot: Mat3, trans: Vec3) -> Self {
        Self { rot, trans }
    }

    /// URDF `<origin xyz rpy>`: `rot = Rz(yaw) Ry(pitch) Rx(roll)` (fixed axes).
    pub fn from_xyz_rpy(xyz: [f64; 3], rpy: [f64; 3]) -> Self {
        Self { rot: rpy_to_rot(rpy), trans: Vec3::new(xyz[0], xyz[1], xyz[2]) }
    }

    /// `self * other`: placement of `other`'s child in `self`'s parent.
    pub fn compose(&self, other: &Transform) -> Transform {
        Transform { rot: self.rot * other.rot, trans: self.rot * other.trans + self.trans }
    }

    /// Inverse placement.
    pub fn inverse(&self) -> Transform {
        let rt = self.rot.transpose();
        Transform { rot: rt, trans: -(rt * self.trans) }
    }

    /// Maps a point from child to parent coordinates.
    pub fn apply(&self, p: &Vec3) -> Vec3 {
        self.rot * p + self.trans
    }
}

/// Rotation about `axis` (unit) by `angle` (Rodrigues): `c I + s [a]x + (1 - c) a a^T`.
#[inline]
pub fn axis_angle(axis: &Vec3, angle: f64) -> Mat3 {
    let (s, c) = angle.sin_cos();
    axis_angle_sc(axis, s, c)
}

/// [`axis_angle`] with sine and cosine given (per lane for a pack of samples).
#[inline]
pub fn axis_angle_sc<T: crate::types::Lanes>(a: &Vec3, s: T, c: T) -> nalgebra::Matrix3<T> {
    let t = T::splat(1.0) - c;
    let (x, y, z) = (T::splat(a.x), T::splat(a.y), T::splat(a.z));
    nalgebra::Matrix3::new(
        c + t * x * x,
        t * x * y - s * z,
        t * x * z + s * y,
        t * x * y + s * z,
        c + t * y * y,
        t * y * z - s * x,
        t * x * z - s * y,
        t * y * z + s * x,
        c + t * z * z,
    )
}

/// Roll-pitch-yaw (URDF, fixed axes X then Y then Z) to a rotation matrix.
pub fn rpy_to_rot(rpy: [f64; 3]) -> Mat3 {
    let (sr, cr) = rpy[0].sin_cos();
    let (sp, cp) = rpy[1].sin_cos();
    let (sy, cy) = rpy[2].sin_cos();
    Mat3::new(
        cy * cp,
        cy * sp * sr - sy * cr,
        cy * sp * cr + sy * sr,
        sy * cp,
        sy * sp * sr + cy * cr,
        sy * sp * cr - cy * sr,
        -sp,
        cp * sr,
        cp * cr,
    )
}

/// Rotation matrix to roll-pitch-yaw (inverse of [`rpy_to_rot`]).
pub fn rot_to_rpy(r: &Mat3) -> [f64; 3] {
    let pitch = (-r[(2, 0)]).atan2((r[(0, 0)] * r[(0, 0)] + r[(1, 0)] * r[(1, 0)]).sqrt());
    if pitch.cos().abs() < 1e-12 {
        // gimbal lock: put everything in yaw
        let yaw = (-r[(0, 1)]).atan2(r[(1, 1)]);
        [0.0, pitch, yaw]
    } else {
        [r[(2, 1)].atan2(r[(2, 2)]), pitch, r[(1, 0)].atan2(r[(0, 0)])]
    }
}

/// Skew-symmetric matrix `[v]x` with `[v]x u = v x u`.
#[inline]
pub fn skew(v: &Vec3) -> Mat3 {
    Mat3::new(0.0, -v.z, v.y, v.z, 0.0, -v.x, -v.y, v.x, 0.0)
}

/// Elementary rotation about x.
pub fn rot_x(angle: f64) -> Mat3 {
    axis_angle(&Vec3::x(), angle)
}

/// Elementary rotation about z.
pub fn rot_z(angle: f64) -> Mat3 {
    axis_angle(&Vec3::z(), angle)
}

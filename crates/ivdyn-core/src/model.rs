//! The constant description of a chain: joints, frames, gravity, nominal parameters.

use crate::error::Error;
use crate::inertia::LinkInertia;
use crate::params::{DRIVE_PARAMS, DriveParams, LINK_PARAMS, param_count};
use crate::spatial::Transform;
use crate::types::Vec3;

/// Kind of a one-degree-of-freedom joint.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum JointKind {
    /// Rotation about the axis (rad).
    Revolute,
    /// Translation along the axis (m).
    Prismatic,
}

/// A joint: kind and unit axis in its link's frame (through the link origin).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Joint {
    /// Revolute or prismatic.
    pub kind: JointKind,
    /// Unit axis in the joint's (child link's) frame.
    pub axis: Vec3,
}

impl Joint {
    /// Revolute joint about `axis`.
    pub fn revolute(axis: Vec3) -> Self {
        Self { kind: JointKind::Revolute, axis }
    }
    /// Prismatic joint along `axis`.
    pub fn prismatic(axis: Vec3) -> Self {
        Self { kind: JointKind::Prismatic, axis }
    }
    /// Revolute about z (the DH convention).
    pub fn revolute_z() -> Self {
        Self::revolute(Vec3::z())
    }
}

/// Joint limits (SI units); infinite where unlimited.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct JointLimits {
    /// Lower position limit.
    pub lower: f64,
    /// Upper position limit.
    pub upper: f64,
    /// Velocity limit (absolute value).
    pub velocity: f64,
    /// Effort (torque or force) limit (absolute value).
    pub effort: f64,
}

impl JointLimits {
    /// No limits.
    pub const UNLIMITED: JointLimits =
        JointLimits { lower: f64::NEG_INFINITY, upper: f64::INFINITY, velocity: f64::INFINITY, effort: f64::INFINITY };
}

impl Default for JointLimits {
    fn default() -> Self {
        Self::UNLIMITED
    }
}

/// Constant model of an `N`-joint serial chain on a fixed base.
///
/// Link `i`'s placement in link `i-1`'s frame (the base for `i = 0`) is
/// `x_tree[i] * Motion(joints[i], q[i])`.
#[derive(Debug, Clone, PartialEq)]
pub struct Model<const N: usize> {
    /// Joint kinds and axes.
    pub joints: [Joint; N],
    /// Placement of joint `i`'s frame in link `i-1`'s frame at `q_i = 0`.
    pub x_tree: [Transform; N],
    /// Inertial parameters of link `i` in link `i`'s frame.
    pub inertia: [LinkInertia; N],
    /// Drive parameters of joint `i`.
    pub drive: [DriveParams; N],
    /// Gravity vector in the base frame (m/s^2), e.g. `(0, 0, -9.81)`.
    pub gravity: Vec3,
    /// Joint limits.
    pub limits: [JointLimits; N],
    /// Placement of the tool (tip) frame in the last link's frame.
    pub tool: Transform,
}

/// Standard gravity pointing down the base z axis.
pub const GRAVITY_Z: Vec3 = Vec3::new(0.0, 0.0, -9.81);

impl<const N: usize> Model<N> {
    /// A model with the given joints and placements, massless links, no drive terms,
    /// gravity `(0, 0, -9.81)`, no limits, identity tool frame.
    pub fn new(joints: [Joint; N], x_tree: [Transform; N]) -> Result<Self, Error> {
        for (j, joint) in joints.iter().enumerate() {
            let n = joint.axis.norm();
            if !n.is_finite() || (n - 1.0).abs() > 1e-9 {
                return Err(Error::InvalidAxis { joint: j });
            }
        }
        Ok(Self {
            joints,
            x_tree,
            inertia: [LinkInertia::ZERO; N],
            drive: [DriveParams::ZERO; N],
            gravity: GRAVITY_Z,
            limits: [JointLimits::UNLIMITED; N],
            tool: Transform::IDENTITY,
        })
    }

    /// Number of joints.
    pub const fn nq(&self) -> usize {
        N
    }

    /// Number of parameters in `theta` (`14 N`).
    pub const fn np(&self) -> usize {
        param_count(N)
    }

    /// Writes the model's parameters into `theta` (length `14 N`, layout in [`crate::params`]).
    pub fn params_to_slice(&self, theta: &mut [f64]) -> Result<(), Error> {
        check_len("theta", theta.len(), param_count(N))?;
        for i in 0..N {
            theta[LINK_PARAMS * i..LINK_PARAMS * (i + 1)].copy_from_slice(&self.inertia[i].0);
            let d0 = LINK_PARAMS * N + DRIVE_PARAMS * i;
            theta[d0..d0 + DRIVE_PARAMS].copy_from_slice(&self.drive[i].to_array());
        }
        Ok(())
    }

    /// Sets the model's parameters from `theta` (length `14 N`). Rejects non-finite values.
    pub fn set_params_from_slice(&mut self, theta: &[f64]) -> Result<(), Error> {
        check_len("theta", theta.len(), param_count(N))?;
        crate::error::check_finite("theta", theta)?;
        for i in 0..N {
            self.inertia[i].0.copy_from_slice(&theta[LINK_PARAMS * i..LINK_PARAMS * (i + 1)]);
            let d0 = LINK_PARAMS * N + DRIVE_PARAMS * i;
            let mut d = [0.0; DRIVE_PARAMS];
            d.copy_from_slice(&theta[d0..d0 + DRIVE_PARAMS]);
            // the Coulomb shape is a model constant: kept
            self.drive[i] = DriveParams { coulomb: self.drive[i].coulomb, ..DriveParams::from_array(d) };
        }
        Ok(())
    }

    /// The parameters as a fixed-size vector; `P` must equal `14 N` (checked at compile time).
    pub fn params<const P: usize>(&self) -> nalgebra::SVector<f64, P> {
        const { assert!(P == crate::params::PARAMS_PER_JOINT * N, "P must be 14 * N") };
        let mut theta = nalgebra::SVector::<f64, P>::zeros();
        // Length is right by the assertion above.
        let _ = self.params_to_slice(theta.as_mut_slice());
        theta
    }
}

/// Length check helper.
pub(crate) fn check_len(what: &'static str, got: usize, expected: usize) -> Result<(), Error> {
    if got == expected { Ok(()) } else { Err(Error::Dimension { what, expected, got }) }
}

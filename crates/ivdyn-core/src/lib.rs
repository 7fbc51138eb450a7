//! `ivdyn-core`: robot-arm rigid-body dynamics for identification and control,
//! `#![no_std]` and allocation-free, with fixed sizes.
//!
//! # Conventions
//! - A serial chain of `N` one-degree-of-freedom joints (revolute or prismatic) on a
//!   fixed base. `N` is a const generic; every buffer lives in [`Data`], allocated once
//!   by the caller (Pinocchio's and MuJoCo's Model/Data split).
//! - Link `i`'s frame is the frame of joint `i`: its placement in link `i-1`'s frame is
//!   `x_tree[i] * Motion(axis_i, q_i)` (URDF convention: the joint axis passes through
//!   the link origin and is a constant unit vector in link coordinates). Standard DH
//!   tables are converted to this form by [`dh`].
//! - Vectors of link `i` (angular velocity `w`, angular acceleration `wd`, linear
//!   acceleration of the origin `acc`, force `f` and moment `n` exerted on link `i` by
//!   link `i-1`) are expressed in link `i`'s frame, as in the paper's eqs (2)-(8).
//! - Gravity is a vector in the base frame; it enters as the base acceleration `-g`.
//! - Inertial parameters per link ([`LinkInertia`]): `[m, m*cx, m*cy, m*cz, Ixx, Ixy, Iyy,
//!   Ixz, Iyz, Izz]` about the link origin in link coordinates (Pinocchio's order).
//!   Drive parameters per joint ([`DriveParams`]): `[fc, fv, ia, tau0]` (Coulomb,
//!   viscous, armature, offset). The full vector `theta` is the `N` link blocks followed by
//!   the `N` drive blocks, `P = 14 N` entries (see [`params`]).
//! - Units: SI (m, kg, s, rad, N, N m).
//!
//! # Quick start
//! ```
//! use ivdyn_core::{paper, rnea, regressor, mass_matrix, forward_dynamics, Data, VecN};
//!
//! let model = paper::robot();                 // Model<6>: Tables 1-2 of the paper
//! let mut data = Data::<6>::new();            // every work buffer, allocated once
//! let (q, qd, qdd) = (VecN::<6>::repeat(0.1), VecN::<6>::repeat(0.2), VecN::<6>::repeat(0.3));
//! let tau = *rnea(&model, &mut data, &q, &qd, &qdd);
//! let y = regressor(&model, &mut data, &q, &qd, &qdd);   // tau == Y theta
//! let theta = model.params::<84>();                       // 14 per joint
//! assert!((y.to_matrix::<84>() * theta - tau).norm() < 1e-12);
//! let m = *mass_matrix(&model, &mut data, &q);
//! let qdd2 = *forward_dynamics(&model, &mut data, &q, &qd, &tau).unwrap();
//! assert!((qdd2 - qdd).norm() < 1e-9 && m[(0, 0)] > 0.0);
//! ```
//!
//! # References
//! - \[KN\] H. Kawasaki, K. Nishimura, "Terminal-link parameter estimation and trajectory
//!   control of robotic manipulators" (the paper in `shared/paper`; equation numbers
//!   cite it, with the corrections of `NOTES.md`).
//! - \[RBDA\] R. Featherstone, *Rigid Body Dynamics Algorithms*, Springer 2008.
//! - \[Atkeson86\] C. Atkeson, C. An, J. Hollerbach, "Estimation of inertial parameters of
//!   manipulator loads and links", IJRR 5(3), 1986 (the inertial-parameter regressor).
#![no_std]
#![forbid(unsafe_code)]
#![warn(missing_docs)]
// `!(x > 0.0)` is deliberate throughout: it is true for NaN, which must be rejected too.
#![allow(clippy::neg_cmp_op_on_partial_ord)]

pub mod control;
pub mod crba;
pub mod data;
pub mod dh;
pub mod energy;
pub mod error;
pub mod estim;
pub mod fd;
pub mod inertia;
pub mod kinematics;
pub mod model;
pub mod paper;
pub mod params;
pub mod regressor;
pub mod regressor_matrix;
pub mod rnea;
pub mod rng;
pub mod scalar;
pub mod sim;
pub mod spatial;
pub mod trajectory;
pub mod trig;
pub mod types;

pub use crba::mass_matrix;
pub use data::Data;
pub use error::Error;
pub use fd::forward_dynamics;
pub use inertia::{
    INERTIA_ORDER, INERTIA_URDF_ORDER, LinkInertia, inertia_from_urdf, inertia_matrix, inertia_to_urdf, inertia_vector,
};
pub use model::{Joint, JointKind, JointLimits, Model};
pub use params::{CoulombShape, DRIVE_PARAMS, DriveParams, LINK_PARAMS};
pub use regressor::{Regressor, gravity_regressor, regressor};
pub use rnea::{gravity, rnea};
pub use spatial::Transform;
pub use types::{Lanes, Mat3, MatN, Real, Vec3, VecN};

/// Re-export of the linear-algebra crate, so users get the matching version.
pub use nalgebra;

/// The crate README's examples, compiled and run as doctests (they cannot rot).
#[cfg(doctest)]
#[doc = include_str!("../README.md")]
pub struct ReadmeDoctests;

//! Excitation design: a finite-Fourier-series trajectory (Swevers et al. 1997,
//! [`ivdyn_core::trajectory::Fourier`]) whose base regressor is as well conditioned as the
//! joint limits allow.
//!
//! # Problem
//! Joint `i` follows `q_i(t) = q0_i + sum_l a_il/(l w) sin(l w t) - b_il/(l w) cos(l w t)`
//! (`w = 2 pi f0`, `l = 1..H`). The criterion is evaluated on the stacked base regressor
//! `Phi` (rows of [`crate::ident::BaseParams`] found by [`crate::ident::robot_base_params`],
//! drive columns included) at `K` samples of one period:
//!
//! * `cond`: minimise `log cond(Phi) = log(s_max / s_min)` (unscaled, SI units, the number
//!   [`crate::ident::FitReport::condition_number`] reports);
//! * `logdet`: maximise `log det(Phi^T Phi / rows)` (D-optimality; unit-invariant in its argmax).
//!
//! # Constraints (scaling into the bounds)
//! Each joint's harmonics are first projected onto `qd(0) = 0`, `qdd(0) = 0`
//! (`sum_l a_il = 0`, `sum_l l b_il = 0`: the trajectory starts, and after every full
//! period ends, at rest), then scaled by the largest factor `s_i` that keeps the joint
//! inside its position, velocity and acceleration limits (shrunk by the safety margin) on a
//! dense time grid. The offset `q0_i = mid_i + half_i tanh(z_i)` stays strictly inside the
//! position range. So every candidate is feasible by construction and the optimiser works
//! on unconstrained variables `(z_i, c_i)`; the map is invariant to the scale of `c_i`.
//!
//! # Optimiser
//! Random multi-start (seeded) + L-BFGS with Armijo backtracking. The gradient is exact up
//! to finite differences of the regressor in `(q, qd, qdd)` per sample (central in `q` and
//! `qd`, which is exact for the quadratic velocity terms; the Coulomb `sign(qd)` columns are
//! piecewise constant and get zero derivative; `Y` is affine in `qdd`), contracted with
//! `dcrit/dPhi = Phi M` (`M = v1 v1^T/l1 - vb vb^T/lb` for `log cond`, `-2 (Phi^T Phi)^-1`
//! for `-log det`), then chained through the bound scaling (envelope theorem at the active
//! bound's sample). That costs `5 N + 1` regressor evaluations per sample, against
//! `2 H N + N + 1` for finite differences on the coefficients.
//!
//! # Files
//! * `fourier.rs`: the Fourier parametrisation (coefficients, per-harmonic basis, sampling);
//! * `bounds.rs`: the joint limits and the map of free variables into them (rest
//!   projection, scaling into the bounds);
//! * `criterion.rs`: the criterion and its gradient, and the reported scores;
//! * `lbfgs.rs`: the optimiser;
//! * `design.rs`: the design driver (multi-start, random comparison, report);
//! * `write.rs`: the trajectory writers (CSV, MCAP).

mod bounds;
mod criterion;
mod design;
mod fourier;
mod lbfgs;
mod write;

use serde::Serialize;

use crate::progress::ProgressSink;

pub use bounds::{JointBounds, joint_bounds};
pub use criterion::scores;
pub use design::design;
pub use fourier::{Coeffs, Samples, sample};
pub use write::{write_csv, write_mcap};

/// Acceleration limit (rad/s^2, or m/s^2 for prismatic joints) used when none is given:
/// URDF has no acceleration limit. Conservative for industrial and collaborative arms
/// (the Panda's datasheet allows 7.5-20 rad/s^2, UR arms more).
pub const DEFAULT_ACC_LIMIT: f64 = 5.0;
/// Velocity limit used for a joint whose URDF `<limit velocity>` is missing or zero.
pub const DEFAULT_VEL_LIMIT: f64 = 1.0;

/// Optimality criterion.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum Criterion {
    /// Minimise the condition number of the base regressor.
    Cond,
    /// Maximise `log det` of the information matrix `Phi^T Phi / rows`.
    Logdet,
}

/// Options of [`design`].
#[derive(Clone)]
pub struct ExciteOptions {
    /// Duration of the written trajectory (s).
    pub duration_s: f64,
    /// Number of harmonics `H` (>= 2: one is used up by the rest constraints).
    pub harmonics: usize,
    /// Fundamental frequency (Hz); the period is `1 / f0`.
    pub f0_hz: f64,
    /// Sample rate of the written trajectory (Hz).
    pub rate_hz: f64,
    /// Criterion.
    pub criterion: Criterion,
    /// Acceleration limit per joint (one value: all joints).
    pub acc_limit: Vec<f64>,
    /// Velocity limit per joint replacing the URDF's (one value: all joints).
    pub vel_limit: Option<Vec<f64>>,
    /// Safety margin: position ranges, velocity and acceleration limits shrink by this
    /// fraction (so that the continuous trajectory between samples stays inside).
    pub margin: f64,
    /// Random starts of the optimiser.
    pub starts: usize,
    /// L-BFGS iterations per start.
    pub iterations: usize,
    /// Samples of one period on which the criterion is optimised.
    pub opt_samples: usize,
    /// Random trajectories for the comparison (median reported).
    pub random_draws: usize,
    /// Seed of the starts, the random comparison and the base-parameter states.
    pub seed: u64,
    /// Progress sink.
    pub progress: ProgressSink,
}

impl Default for ExciteOptions {
    fn default() -> Self {
        ExciteOptions {
            duration_s: 20.0,
            harmonics: 5,
            f0_hz: 0.1,
            rate_hz: 100.0,
            criterion: Criterion::Cond,
            acc_limit: vec![DEFAULT_ACC_LIMIT],
            vel_limit: None,
            margin: 0.01,
            starts: 6,
            iterations: 150,
            opt_samples: 100,
            random_draws: 20,
            seed: 1,
            progress: None,
        }
    }
}

/// The criterion values of one trajectory, on the written samples.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Scores {
    /// Condition number of the base regressor (from its QR factor).
    pub cond: f64,
    /// `log det(Phi^T Phi / rows)`.
    pub logdet: f64,
}

/// The random-trajectory comparison.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct RandomComparison {
    /// Number of random trajectories.
    pub draws: usize,
    /// Median condition number.
    pub cond_median: f64,
    /// Smallest (best) condition number among the draws.
    pub cond_min: f64,
    /// Median `log det`.
    pub logdet_median: f64,
    /// Largest `log det` among the draws.
    pub logdet_max: f64,
}

/// The designed trajectory and its report.
#[derive(Debug, Clone, Serialize)]
pub struct ExciteReport {
    /// Robot name.
    pub robot: String,
    /// Joint names (order of every per-joint list).
    pub joints: Vec<String>,
    /// Criterion optimised.
    pub criterion: Criterion,
    /// Base parameters (columns of the regressor whose conditioning is optimised).
    pub base_count: usize,
    /// Fundamental frequency (Hz).
    pub f0_hz: f64,
    /// Harmonics.
    pub harmonics: usize,
    /// Duration (s).
    pub duration_s: f64,
    /// Sample rate of the written trajectory (Hz).
    pub rate_hz: f64,
    /// Safety margin.
    pub margin: f64,
    /// Limits per joint.
    pub bounds: Vec<JointBounds>,
    /// The optimised trajectory's criteria.
    pub optimised: Scores,
    /// Random Fourier trajectories of the same harmonics, scaled into the same bounds.
    pub random: RandomComparison,
    /// `random.cond_median / optimised.cond`.
    pub cond_improvement: f64,
    /// Offsets `q0` per joint.
    pub q0: Vec<f64>,
    /// Sine coefficients `a[joint][harmonic]` (as in `Fourier`).
    pub a: Vec<Vec<f64>>,
    /// Cosine coefficients `b[joint][harmonic]`.
    pub b: Vec<Vec<f64>>,
    /// Peak `|qd| / velocity limit` per joint on the written samples.
    pub velocity_use: Vec<f64>,
    /// Peak `|qdd| / acceleration limit` per joint.
    pub acceleration_use: Vec<f64>,
    /// Remarks.
    pub notes: Vec<String>,
    /// The written samples.
    #[serde(skip)]
    pub trajectory: Samples,
}

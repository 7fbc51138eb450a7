//! What a before log brings to `payload` besides the nominal model: the uncertainty of
//! that model (its parameter errors move the after log's residual, and through it the
//! payload estimate), and a check that it is the arm of the after log at all.
//!
//! # Uncertainty
//! The unloaded arm's base parameters `beta` come from the before log with covariance
//! `C_b`. Their error `d_beta` puts `Phi_B d_beta` into the after log's residual (`Phi_B`:
//! the after log's base regressor), and the weighted LS payload takes up
//! `G d_beta`, `G = (Phi_p^T W Phi_p)^-1 Phi_p^T W Phi_B`. The logs' noises are
//! independent, so the payload's covariance is the after fit's plus `G C_b G^T`. Without
//! it the stated std of the demo's payload were 2-3 times too small (the LS mass moved by
//! 4e-4 kg between before logs of six seeds, against a stated std of 1.4e-4 kg), and the
//! Mahalanobis distance to the nearest rigid body called a rigid point mass impossible.
//!
//! # Does the before log fit?
//! [`BeforeCheck`]: the after log's residual level against the before log's own.

use nalgebra::DMatrix;
use serde::Serialize;

use crate::error::Result;
use crate::ident::stats::f_quantile;
use crate::ident::{BaseParams, FitReport};
use crate::report::Quality;

/// The unloaded arm as identified on the before log: its base parameters (the columns of
/// `Phi_B`) and their covariance `C_b` (zero for the parameters the log did not excite:
/// their error is unknown, left at the nominal value).
pub(super) struct BeforeModel {
    /// Base parameters of the before fit.
    pub base: BaseParams,
    /// `b x b` covariance of the before fit's base parameters.
    pub cov: DMatrix<f64>,
    /// Its fit quality, and the number of parameters fitted (for [`BeforeCheck`]).
    pub quality: Quality,
    /// Parameters fitted.
    pub rank: usize,
}

impl BeforeModel {
    /// From the before log's identification (`fit` its fit, over `base`).
    pub fn new(base: BaseParams, fit: &FitReport, quality: Quality) -> Self {
        let cov = fit.covariance.map(|v| if v.is_finite() { v } else { 0.0 });
        BeforeModel { base, cov, quality, rank: fit.rank }
    }
}

/// `fit` (the payload's WLS fit over `phi_p`, `k` columns, row weights `w`) with the before
/// model's uncertainty added to its covariance and std (module docs); `phi_b` are the after
/// log's rows in the before model's base columns.
pub(super) fn add_before_uncertainty(
    fit: &mut FitReport,
    phi_p: &[f64],
    w: &[f64],
    phi_b: &[f64],
    before: &BeforeModel,
) -> Result<()> {
    let (k, b) = (fit.theta.len(), before.base.base_count());
    let mut a = DMatrix::<f64>::zeros(k, k);
    let mut c = DMatrix::<f64>::zeros(k, b);
    for (r, wr) in w.iter().enumerate() {
        let (p, q) = (&phi_p[r * k..(r + 1) * k], &phi_b[r * b..(r + 1) * b]);
        for i in 0..k {
            let wp = wr * p[i];
            for j in 0..k {
                a[(i, j)] += wp * p[j];
            }
            for j in 0..b {
                c[(i, j)] += wp * q[j];
            }
        }
    }
    // not identifiable: the payload is not read off, nothing to add
    let Some(ch) = a.cholesky() else { return Ok(()) };
    let g = ch.solve(&c);
    let extra = &g * &before.cov * g.transpose();
    fit.covariance += extra;
    fit.std = fit.covariance.diagonal().iter().map(|v| v.max(0.0).sqrt()).collect();
    fit.rel_std_pct = fit.std.iter().zip(&fit.theta).map(|(s, t)| 100.0 * s / t.abs()).collect();
    Ok(())
}

/// Does the unloaded arm identified on the before log, plus the payload, explain the after
/// log down to the noise? Per joint, the variance ratio `F = (rms_after / rms_before)^2` of
/// the two fits' residuals, against the F distribution's quantile (both residuals are white
/// noise of one level when the arm is the same and its model holds on both trajectories; a
/// before log of another arm, or of the arm at another friction, leaves the difference in
/// the after log's residual). Filtered samples are not quite independent and model errors
/// differ between trajectories, so on real logs a flag also means "the before model
/// extrapolates": the MuJoCo logs of `fixtures/diagnose` (one arm, two trajectories) give
/// variance ratios 0.5 to 3.8 against a critical 2.1.
#[derive(Debug, Clone, Serialize)]
pub struct BeforeCheck {
    /// Per joint RMS of the before log's own identification residual (N m).
    pub rms_before_log: Vec<f64>,
    /// Per joint RMS of this log's residual with the least-squares payload (N m).
    pub rms_after_log: Vec<f64>,
    /// Per joint `(rms_after_log / rms_before_log)^2`.
    pub variance_ratio: Vec<f64>,
    /// Degrees of freedom `[after, before]` of each joint's ratio: samples less the fitted
    /// parameters' share per joint.
    pub dof: [f64; 2],
    /// Confidence of the test over all joints (each joint at `confidence^(1/n)`, Sidak).
    pub confidence: f64,
    /// The ratio above which a joint is flagged: the F quantile at that per-joint level.
    pub critical_ratio: f64,
    /// Joints whose ratio is above it.
    pub flagged: Vec<String>,
    /// Whether the before log fits this one (no joint flagged).
    pub fits: bool,
}

/// Confidence of [`BeforeCheck`] over all joints.
pub const BEFORE_CHECK_CONFIDENCE: f64 = 0.999;

/// [`BeforeCheck`] from the before log's fit quality `q` (`rank` parameters over all joints)
/// and the after log's LS-payload quality `ls` (`k` parameters).
pub(super) fn before_check(joints: &[String], q: &Quality, rank: usize, ls: &Quality, k: usize) -> BeforeCheck {
    let n = joints.len() as f64;
    let dof = [ls.samples as f64 - k as f64 / n, q.samples as f64 - rank as f64 / n];
    let per_joint = BEFORE_CHECK_CONFIDENCE.powf(1.0 / n);
    let critical_ratio = f_quantile(per_joint, dof[0], dof[1]);
    let variance_ratio: Vec<f64> = ls.rms.iter().zip(&q.rms).map(|(a, b)| (a / b).powi(2)).collect();
    let flagged: Vec<String> =
        joints.iter().zip(&variance_ratio).filter(|(_, r)| !(**r <= critical_ratio)).map(|(j, _)| j.clone()).collect();
    BeforeCheck {
        rms_before_log: q.rms.clone(),
        rms_after_log: ls.rms.clone(),
        variance_ratio,
        dof,
        confidence: BEFORE_CHECK_CONFIDENCE,
        critical_ratio,
        fits: flagged.is_empty(),
        flagged,
    }
}

/// The note of a before log that does not fit.
pub(super) fn before_note(c: &BeforeCheck) -> Vec<String> {
    if c.fits {
        return vec![];
    }
    let worst = c.variance_ratio.iter().copied().fold(f64::NAN, f64::max);
    vec![format!(
        "the before log does not fit this log: on {} the residual after the payload is up to {:.2} times the before log's own (RMS; variance ratio {:.2}, above {:.2}, the F quantile at {} % confidence over all joints). Either the arm changed between the logs (friction or temperature, another tool or arm) or the before log does not excite what this log does (its model extrapolates); the payload estimate takes up part of the difference: check the before log, or compare with the payload found without it",
        c.flagged.join(", "),
        worst.sqrt(),
        worst,
        c.critical_ratio,
        100.0 * c.confidence
    )]
}

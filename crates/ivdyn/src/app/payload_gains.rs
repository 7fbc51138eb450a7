//! The torque constants' uncertainty in the payload: when both logs' currents were turned
//! into torques with constants `k` that are themselves estimates (an `ivdyn gains` fit, a
//! datasheet), their error moves the payload as much as the current noise does, or more.
//!
//! # Propagation
//! The payload's least-squares estimate `p` (in its base columns) is a function of the
//! logs' torques, `tau_j = k_j i_j` on joint `j` of both logs. To first order its error
//! from the constants is `S e`, with `e_j = dk_j / k_j` and `S_j = dp / d ln k_j`, so its
//! covariance grows by `S C S^T` (`C`: the covariance of `e`). `S_j` is taken by
//! differences: the whole estimate (the before log's identification, the after log's
//! residual against it, the weighted fit) rerun with joint `j`'s torques in both logs
//! scaled by `1 + H`. Differencing the whole pipeline keeps what an analytic
//! derivative of the payload fit alone would miss: the before log's model takes up part
//! of a constant's error (a 10 % larger `k` on the shoulder makes the identified arm
//! heavier there, too), and only the rest reaches the payload. The estimate is
//! homogeneous in the torques (all `k` scaled by `c` scale `p` by `c`), so
//! `sum_j S_j = p`: a common scale error of the constants is one of the payload.
//!
//! # From a gains report
//! [`TorqueConstantPrior::resolve`] takes the gains an `ivdyn gains` report determined
//! (its `value`s and `covariance`) as the torque constants, and for the joints it did not
//! determine the constants and standard deviations the user gives.

use nalgebra::DMatrix;
use serde::Deserialize;

use super::effort::PerJoint;
use crate::error::{Error, Result};
use crate::ident::FitReport;
use crate::log::JointLog;

/// Relative step of a torque constant in the differences (the estimate is linear in the
/// torques up to its weights, so the step's size barely matters).
const H: f64 = 1e-3;

/// `fit` (the payload's WLS fit) with the torque constants' covariance added: `rel_cov`
/// (`n x n`, of `dk/k`) through the sensitivities that `rerun` (the least-squares payload
/// of an (after, before) pair of logs) gives by differences (module docs).
pub(super) fn add_torque_constant_uncertainty(
    fit: &mut FitReport,
    rel_cov: &[f64],
    after: &JointLog,
    before: Option<&JointLog>,
    rerun: impl Fn(&JointLog, Option<&JointLog>) -> Result<Vec<f64>>,
) -> Result<()> {
    let n = after.dof();
    if rel_cov.len() != n * n || rel_cov.iter().any(|v| !v.is_finite()) {
        return Err(Error::option(
            "torque_constant_cov",
            format!("needs {n} x {n} finite values (one row per joint), got {}", rel_cov.len()),
        ));
    }
    let c = DMatrix::from_row_slice(n, n, rel_cov);
    let k = fit.theta.len();
    let mut s = DMatrix::<f64>::zeros(k, n);
    for j in 0..n {
        // a joint whose constant is exact moves nothing
        if c[(j, j)] == 0.0 {
            continue;
        }
        let a = scaled(after, j, 1.0 + H);
        let b = before.map(|b| scaled(b, j, 1.0 + H));
        let th = rerun(&a, b.as_ref())?;
        for (i, (t1, t0)) in th.iter().zip(&fit.theta).enumerate() {
            // a column the fit cannot estimate: no value, no sensitivity
            s[(i, j)] = if t1.is_finite() && t0.is_finite() { (t1 - t0) / H } else { 0.0 };
        }
    }
    fit.covariance += &s * c * s.transpose();
    fit.std = fit.covariance.diagonal().iter().map(|v| v.max(0.0).sqrt()).collect();
    fit.rel_std_pct = fit.std.iter().zip(&fit.theta).map(|(s, t)| 100.0 * s / t.abs()).collect();
    Ok(())
}

/// `log` with joint `j`'s torque times `f`.
fn scaled(log: &JointLog, j: usize, f: f64) -> JointLog {
    let n = log.dof();
    let mut out = log.clone();
    if let Some(tau) = out.tau.as_mut() {
        tau.iter_mut().skip(j).step_by(n).for_each(|v| *v *= f);
    }
    out
}

/// What is known of the torque constants' errors, as a user gives it (`payload`'s
/// `--torque-constant-std` and `--gains`).
#[derive(Debug, Clone, Default, PartialEq)]
pub struct TorqueConstantPrior {
    /// Standard deviation of each torque constant (N m/A), errors independent; with a
    /// gains report, only the joints it did not determine take theirs from here.
    pub std: Option<PerJoint>,
    /// The JSON text of an `ivdyn gains` report: the gains it determined, with their
    /// covariance, replace the torque constants given.
    pub gains_report: Option<String>,
}

/// The parts of an `ivdyn gains` report read here.
#[derive(Deserialize)]
struct GainsDoc {
    joints: Vec<String>,
    gains: Vec<GainDoc>,
    gain_covariance: Vec<Vec<Option<f64>>>,
}

#[derive(Deserialize)]
struct GainDoc {
    value: Option<f64>,
}

impl TorqueConstantPrior {
    /// Whether anything is given.
    pub fn is_given(&self) -> bool {
        self.std.is_some() || self.gains_report.is_some()
    }

    /// The torque constants of `joints` and the covariance of their relative errors
    /// (`n x n` row-major), from the constants given (`given`, `None` when none were) and
    /// this prior. Errors name the option and the joints it lacks.
    pub fn resolve(&self, joints: &[String], given: Option<&[f64]>) -> Result<(Vec<f64>, Vec<f64>)> {
        let n = joints.len();
        let (mut k, mut cov) = (vec![f64::NAN; n], DMatrix::<f64>::zeros(n, n));
        let mut open: Vec<usize> = (0..n).collect();
        if let Some(text) = &self.gains_report {
            let doc = read_gains(text, joints)?;
            open.retain(|&j| doc.gains[j].value.is_none());
            let fixed: Vec<usize> = (0..n).filter(|i| !open.contains(i)).collect();
            for &i in &fixed {
                k[i] = doc.gains[i].value.unwrap_or(f64::NAN);
                for &j in &fixed {
                    cov[(i, j)] = doc.gain_covariance[i][j].unwrap_or(0.0);
                }
            }
        }
        if !open.is_empty() {
            let names: Vec<&str> = open.iter().map(|&j| joints[j].as_str()).collect();
            let what = if self.gains_report.is_some() { "the gains report does not determine" } else { "needed for" };
            let given = given.ok_or_else(|| {
                Error::option("torque_constant", format!("is needed for {} ({what} them)", names.join(", ")))
            })?;
            let std = self.std.as_ref().ok_or_else(|| {
                Error::option("torque_constant_std", format!("is needed for {} ({what} them)", names.join(", ")))
            })?;
            let std = std.resolve("torque_constant_std", joints)?;
            for &j in &open {
                k[j] = given[j];
                cov[(j, j)] = std[j] * std[j];
            }
        }
        let rel = DMatrix::from_fn(n, n, |i, j| cov[(i, j)] / (k[i] * k[j]));
        Ok((k, rel.transpose().as_slice().to_vec()))
    }
}

/// The report `text` for the chain `joints`: the same joints in the same order, a gain
/// and a covariance row per joint.
fn read_gains(text: &str, joints: &[String]) -> Result<GainsDoc> {
    let doc: GainsDoc = serde_json::from_str(text).map_err(|e| {
        Error::option("gains", format!("is not an `ivdyn gains` report with `gains` and `gain_covariance` ({e})"))
    })?;
    if doc.joints != joints {
        return Err(Error::option(
            "gains",
            format!("is a report for the joints [{}], not this chain's [{}]", doc.joints.join(", "), joints.join(", ")),
        ));
    }
    let n = joints.len();
    if doc.gains.len() != n || doc.gain_covariance.len() != n || doc.gain_covariance.iter().any(|r| r.len() != n) {
        return Err(Error::option("gains", format!("needs {n} gains and an {n} x {n} gain_covariance")));
    }
    if doc.gains.iter().all(|g| g.value.is_none()) {
        return Err(Error::option("gains", "determines no gain (every `value` is null)"));
    }
    Ok(doc)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn joints() -> Vec<String> {
        ["a", "b", "c"].iter().map(|s| s.to_string()).collect()
    }

    const REPORT: &str = r#"{"joints": ["a", "b", "c"],
        "gains": [{"value": 2.0}, {"value": null}, {"value": 4.0}],
        "gain_covariance": [[0.04, null, 0.02], [null, null, null], [0.02, null, 0.16]]}"#;

    #[test]
    fn gains_report_and_the_fallback_for_the_joints_it_leaves_open() {
        let prior = TorqueConstantPrior { std: Some(PerJoint::All(0.3)), gains_report: Some(REPORT.into()) };
        let (k, rel) = prior.resolve(&joints(), Some(&[9.0, 3.0, 9.0])).unwrap();
        assert_eq!(k, vec![2.0, 3.0, 4.0]);
        let want = [0.01, 0.0, 0.0025, 0.0, 0.01, 0.0, 0.0025, 0.0, 0.01];
        for (a, b) in rel.iter().zip(want) {
            assert!((a - b).abs() < 1e-15, "{rel:?}");
        }
        let no_std = TorqueConstantPrior { std: None, ..prior.clone() };
        let e = no_std.resolve(&joints(), Some(&[9.0, 3.0, 9.0])).unwrap_err().to_string();
        assert!(e.starts_with("torque_constant_std is needed for b (the gains report"), "{e}");
        let e = prior.resolve(&joints(), None).unwrap_err().to_string();
        assert!(e.starts_with("torque_constant is needed for b"), "{e}");
        let other = ["a", "b", "x"].iter().map(|s| s.to_string()).collect::<Vec<_>>();
        assert!(prior.resolve(&other, Some(&[1.0; 3])).unwrap_err().to_string().contains("not this chain's"));
    }

    #[test]
    fn std_alone_is_diagonal() {
        let prior = TorqueConstantPrior { std: Some(PerJoint::List(vec![0.1, 0.2, 0.5])), gains_report: None };
        let (k, rel) = prior.resolve(&joints(), Some(&[1.0, 2.0, 5.0])).unwrap();
        assert_eq!(k, vec![1.0, 2.0, 5.0]);
        for (a, b) in rel.iter().zip([0.01, 0.0, 0.0, 0.0, 0.01, 0.0, 0.0, 0.0, 0.01]) {
            assert!((a - b).abs() < 1e-15, "{rel:?}");
        }
    }
}

//! Drift of a robot between periods: a Wald test on the difference of two fits of its
//! fleet statistics ([`super::fleet::fit_stats`]; the periods' data are disjoint, so the
//! covariance of the difference is the sum of the two), per effect, then the
//! Benjamini-Hochberg procedure across every test of a fleet, and the change in words.
//!
//! Effects, from the base parameters' names: a drive parameter that is a base parameter
//! of its own (`<joint>.fc`, `.fv`, `.ia`, `.tau0`) is tested alone (one degree of
//! freedom); the base parameters that involve the last link's inertials together
//! (`payload`: every base parameter whose combination holds one of the last link's ten
//! parameters, read off the base-parameter map, not off the names, which are shortened);
//! the remaining base parameters together (`rigid_body`).
//!
//! The fit's covariance is the iid one; the parallel filter leaves the residual
//! correlated, which it understates by the long-run factor of each joint
//! ([`super::fleet::FleetFit::long_run`]): both covariances are scaled by the largest
//! factor of their fit (conservative where joints differ).

use nalgebra::DMatrix;
use serde::{Deserialize, Serialize};

use super::IdentifyOptions;
use super::fleet::{FleetFit, LogStats, fit_stats, fleet_model};
use crate::error::{Error, Result};
use crate::ident::BaseParams;
use crate::ident::stats::chi2_sf;
use ivdyn_core::params::LINK_PARAMS;

/// One effect's test between a reference fit and a later one.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct DriftTest {
    /// `coulomb_friction`, `viscous_friction`, `armature`, `torque_offset`, `payload` or
    /// `rigid_body` (the vocabulary of `diagnose`).
    pub effect: String,
    /// The joint of a drive effect.
    pub joint: Option<String>,
    /// The base parameters tested.
    pub parameters: Vec<String>,
    /// Reference estimates.
    pub reference: Vec<f64>,
    /// Estimated changes (later minus reference).
    pub change: Vec<f64>,
    /// Standard deviations of the changes.
    pub std: Vec<f64>,
    /// Wald statistic `dᵀ (V_ref + V) ⁻¹ d` (pseudo-inverse on the rank of `V_ref + V`).
    pub statistic: f64,
    /// Degrees of freedom (that rank).
    pub dof: usize,
    /// `P(χ²(dof) > statistic)`.
    pub p_value: f64,
}

/// Drive parameter suffixes and their effect names and units.
const DRIVE: [(&str, &str, &str); 4] = [
    (".fc", "coulomb_friction", "N m"),
    (".fv", "viscous_friction", "N m s/rad"),
    (".ia", "armature", "kg m^2"),
    (".tau0", "torque_offset", "N m"),
];

/// Which base parameters of `robot`'s fleet model (as [`fit_stats`] fits it) hold one of
/// the last link's parameters: the payload's ([`drift_tests`]' `payload`).
pub fn payload_params(robot: &crate::Robot, opts: &IdentifyOptions) -> Result<Vec<bool>> {
    let (_, base) = fleet_model(robot, opts)?;
    Ok(payload_mask(&base, robot.dof()))
}

/// Which base parameters hold one of the last link's parameters (of `dof` links). Base
/// parameter `j` is `θ[independent[j]] + Σ_k K[j, k] θ[dependent[k]]`.
fn payload_mask(base: &BaseParams, dof: usize) -> Vec<bool> {
    let last = dof.saturating_sub(1) * LINK_PARAMS..dof * LINK_PARAMS;
    (0..base.independent.len())
        .map(|j| {
            last.contains(&base.independent[j])
                || base.dependent.iter().enumerate().any(|(k, d)| last.contains(d) && base.k[(j, k)].abs() > 1e-12)
        })
        .collect()
}

/// The tests of every effect between `reference` and `later` (fits of one model);
/// `payload[j]`: base parameter `j` holds the last link's inertials ([`payload_params`]).
pub fn drift_tests(reference: &FleetFit, later: &FleetFit, payload: &[bool]) -> Result<Vec<DriftTest>> {
    let (r0, r1) = (&reference.report, &later.report);
    let names: Vec<&str> = r0.base.iter().map(|b| b.name.as_str()).collect();
    if names != r1.base.iter().map(|b| b.name.as_str()).collect::<Vec<_>>() || payload.len() != names.len() {
        return Err(Error::Stats {
            what: "drift".into(),
            msg: "the two fits have different base parameters (another model)".into(),
        });
    }
    let (f0, f1) = (fit_of(reference)?, fit_of(later)?);
    let c0 = reference.long_run.iter().cloned().fold(1.0, f64::max);
    let c1 = later.long_run.iter().cloned().fold(1.0, f64::max);
    let v = f0.covariance.scale(c0) + f1.covariance.scale(c1);
    let excited = |i: &usize| f0.theta[*i].is_finite() && f1.theta[*i].is_finite();
    let mut groups: Vec<(String, Option<String>, Vec<usize>)> = vec![];
    let mut rest = vec![];
    for (i, name) in names.iter().enumerate().filter(|(i, _)| excited(i)) {
        if let Some((suffix, effect, _)) = DRIVE.iter().find(|(s, _, _)| name.ends_with(s) && !name.contains(' ')) {
            let joint = name.trim_end_matches(suffix).to_string();
            groups.push((effect.to_string(), Some(joint), vec![i]));
        } else if payload[i] {
            match groups.iter_mut().find(|g| g.0 == "payload") {
                Some(g) => g.2.push(i),
                None => groups.push(("payload".into(), None, vec![i])),
            }
        } else {
            rest.push(i);
        }
    }
    if !rest.is_empty() {
        groups.push(("rigid_body".into(), None, rest));
    }
    Ok(groups
        .into_iter()
        .map(|(effect, joint, idx)| {
            let d: Vec<f64> = idx.iter().map(|&i| f1.theta[i] - f0.theta[i]).collect();
            let vg = DMatrix::from_fn(idx.len(), idx.len(), |a, b| v[(idx[a], idx[b])]);
            let (statistic, dof) = wald(&d, &vg);
            DriftTest {
                effect,
                joint,
                parameters: idx.iter().map(|&i| names[i].to_string()).collect(),
                reference: idx.iter().map(|&i| f0.theta[i]).collect(),
                std: (0..idx.len()).map(|a| vg[(a, a)].sqrt()).collect(),
                change: d,
                statistic,
                dof,
                p_value: if dof == 0 { 1.0 } else { chi2_sf(statistic, dof as f64) },
            }
        })
        .collect())
}

/// [`drift_tests`] of the statistics `later` against `reference`, both fitted with
/// `robot`'s model ([`super::fleet::fit_stats`]); the payload is the last link's.
pub fn drift_of_stats(
    robot: &crate::Robot,
    reference: &LogStats,
    later: &LogStats,
    opts: &IdentifyOptions,
) -> Result<Vec<DriftTest>> {
    let payload = payload_params(robot, opts)?;
    drift_tests(&fit_stats(robot, reference, opts)?, &fit_stats(robot, later, opts)?, &payload)
}

fn fit_of(f: &FleetFit) -> Result<&crate::ident::FitReport> {
    f.report
        .fit_report
        .as_ref()
        .ok_or_else(|| Error::Stats { what: "drift".into(), msg: "a fit has no covariance".into() })
}

/// `dᵀ V⁺ d` and the rank of `V` (eigenvalues above `1e-12` of the largest).
fn wald(d: &[f64], v: &DMatrix<f64>) -> (f64, usize) {
    let e = v.clone().symmetric_eigen();
    let top = e.eigenvalues.iter().cloned().fold(0.0, f64::max);
    let (mut stat, mut rank) = (0.0, 0);
    for (k, &lam) in e.eigenvalues.iter().enumerate() {
        if lam > 1e-12 * top && lam > 0.0 {
            let proj: f64 = e.eigenvectors.column(k).iter().zip(d).map(|(a, b)| a * b).sum();
            stat += proj * proj / lam;
            rank += 1;
        }
    }
    (stat, rank)
}

/// Benjamini-Hochberg at false-discovery rate `q`: which of the p-values `p` are
/// discoveries (the largest `k` with `p_(k) <= k q / m`, and every smaller p-value).
pub fn benjamini_hochberg(p: &[f64], q: f64) -> Vec<bool> {
    let m = p.len();
    let mut order: Vec<usize> = (0..m).collect();
    order.sort_by(|&a, &b| p[a].total_cmp(&p[b]));
    let k = (1..=m).rev().find(|&k| p[order[k - 1]] <= k as f64 * q / m as f64).unwrap_or(0);
    let mut out = vec![false; m];
    order[..k].iter().for_each(|&i| out[i] = true);
    out
}

/// Half-width of the two-sided 95 % normal confidence interval, in standard deviations.
pub const CI95: f64 = 1.959_963_984_540_054;

/// The change in words, e.g. "arm-07, shoulder_lift_joint: coulomb friction +38 % ± 6 %
/// since 2026-11-02": the change against the reference with its 95 % confidence interval
/// (± [`CI95`] standard deviations), in percent of the reference value, or in the
/// parameter's unit when the reference is within two standard deviations of zero (where a
/// percentage says nothing); `since` dates it (the reference period, or the change's
/// onset: `ivdyn.fleet.changes`).
pub fn describe(robot: &str, t: &DriftTest, since: &str) -> String {
    let what = t.effect.replace('_', " ");
    let head = match &t.joint {
        Some(j) => format!("{robot}, {j}: {what}"),
        None => format!("{robot}: {what}"),
    };
    if t.change.len() != 1 {
        // below 1e-16 the p-value is rounding (or underflow) of the χ² tail
        let p = if t.p_value < 1e-16 { "p < 1e-16".to_string() } else { format!("p = {:.2e}", t.p_value) };
        return format!("{head} changed since {since} ({} parameters, chi2 {:.1}, {p})", t.dof, t.statistic);
    }
    let (r, d, s) = (t.reference[0], t.change[0], t.std[0]);
    let ci = CI95 * s;
    if r.abs() > 2.0 * s {
        let (pct, cpct) = (100.0 * d / r.abs(), 100.0 * ci / r.abs());
        let digits = if cpct < 1.0 { 1 } else { 0 };
        format!("{head} {pct:+.digits$} % ± {cpct:.digits$} % since {since}")
    } else {
        let unit = DRIVE.iter().find(|x| x.1 == t.effect).map_or("", |x| x.2);
        format!("{head} {d:+.3} ± {ci:.3} {unit} since {since}")
    }
}

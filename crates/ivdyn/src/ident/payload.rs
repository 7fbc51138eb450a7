//! A payload (or any link's parameter change) as mass, centre of mass and inertia about
//! the centre of mass, with uncertainty propagated from the fit's covariance.
//!
//! The estimate is a set of base combinations. The payload's 10 standard parameters are
//! read off it only when each of them is itself a base parameter (independent column with
//! no combination); otherwise the parameters that are not are reported as not
//! identifiable, with the base combinations they hide in, and no number is invented.
//!
//! The least-squares parameters need not be a rigid body (a point mass's inertia about its
//! COM comes out negative about half the time, and so does the mass of no payload): the
//! estimate reported is the nearest physically possible payload in the metric of the fit's
//! covariance ([`super::payload_consistent`]), with what the LS one violated and how far the
//! two are apart ([`PhysicalFit`]).
//!
//! Uncertainty: first-order (delta-method) propagation of the unconstrained fit's 10 x 10
//! covariance through `(m, h, I_o) -> (m, c = h / m, I_c = I_o + m [c]x [c]x)`, with a
//! numerical Jacobian at the reported (consistent) parameters. Where a constraint is active
//! the consistent estimate's spread is smaller than that along the bound; the stated
//! std are kept as the fit gives them (a statement about the data, not the constraint).

use serde::Serialize;

use crate::error::Result;
use crate::ident::payload_consistent::{Violation, project, violation};
use crate::ident::{BaseParams, FitReport};
use ivdyn_core::LinkInertia;
use nalgebra::{DMatrix, SMatrix, SVector};

/// Mass, centre of mass and inertia about the centre of mass (ivdyn's order
/// `[Ixx, Ixy, Iyy, Ixz, Iyz, Izz]`, [`ivdyn_core::inertia_to_urdf`] for URDF's), with
/// standard deviations.
#[derive(Debug, Clone, PartialEq)]
pub struct PayloadEstimate {
    /// Mass (kg).
    pub mass: f64,
    /// Centre of mass in the link frame (m).
    pub com: [f64; 3],
    /// Inertia about the centre of mass, `[Ixx, Ixy, Iyy, Ixz, Iyz, Izz]` (kg m^2).
    pub inertia: [f64; 6],
    /// Standard deviation of the mass.
    pub mass_std: f64,
    /// Standard deviations of the centre of mass.
    pub com_std: [f64; 3],
    /// Standard deviations of the inertia entries.
    pub inertia_std: [f64; 6],
    /// The 10 standard parameters `[m, mcx, mcy, mcz, Ixx, Ixy, Iyy, Ixz, Iyz, Izz]` about
    /// the link origin (the consistent ones, as the numbers above).
    pub params: [f64; 10],
    /// The unconstrained fit, what it violated, and how far the consistent estimate is from it.
    pub physical: PhysicalFit,
}

/// The least-squares payload against the physically possible one ([`super::payload_consistent`]).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct PhysicalFit {
    /// Whether the unconstrained least-squares payload is a rigid body.
    pub ls_possible: bool,
    /// How far the least-squares payload is from a rigid body.
    pub ls_violation: Violation,
    /// The least-squares 10 parameters about the link origin (same order as `params`).
    pub ls_params: [f64; 10],
    /// Least-squares centre of mass (m); `None` when its mass is not positive.
    pub ls_com: Option<[f64; 3]>,
    /// Least-squares inertia about its centre of mass `[Ixx, Ixy, Iyy, Ixz, Iyz, Izz]`
    /// (kg m^2; the JSON reports keep URDF attribute order); `None` when its mass is not positive.
    #[serde(serialize_with = "crate::report::urdf_inertia::serialize_opt")]
    pub ls_inertia: Option<[f64; 6]>,
    /// Squared Mahalanobis distance `(theta - theta_ls)^T Sigma^-1 (theta - theta_ls)` from the
    /// least-squares payload to the nearest rigid body (0 when it is one).
    pub mahalanobis2: f64,
    /// Degrees of freedom of its chi-square reference: the identifiable payload parameters.
    pub dof: usize,
    /// `P(chi2_dof > mahalanobis2)`: small when the data contradict a rigid payload (a
    /// conservative bound, see [`super::payload_consistent`]).
    pub p_value: f64,
    /// Whether the constraints moved the estimate: the least-squares payload was not possible,
    /// or within the margin of the boundary (1e-6 of the mass scale, see
    /// [`super::payload_consistent`]).
    pub constraints_active: bool,
    /// How far the reported payload is from the boundary (all margins positive).
    pub violation: Violation,
}

/// Why a payload cannot be read off the fit.
#[derive(Debug, Clone, PartialEq)]
pub struct NotIdentifiable {
    /// Names of the payload parameters that are not base parameters by themselves.
    pub parameters: Vec<String>,
    /// For each, the base combination it is part of (or "no effect on the data").
    pub combined_in: Vec<String>,
}

/// `(m, c, I_c)` from the 10 standard parameters (`I_c` in ivdyn's 6-vector order).
fn to_physical(p: &SVector<f64, 10>) -> Option<SVector<f64, 10>> {
    let li = LinkInertia([p[0], p[1], p[2], p[3], p[4], p[5], p[6], p[7], p[8], p[9]]);
    let (m, c, ic) = li.to_mass_com_inertia(0).ok()?;
    let i = ivdyn_core::inertia_vector(&ic);
    Some(SVector::<f64, 10>::from_column_slice(&[m, c.x, c.y, c.z, i[0], i[1], i[2], i[3], i[4], i[5]]))
}

/// Reads the payload from a fit over `base`. `cols` are the full-parameter indices of the
/// payload's 10 standard parameters (in `[m, mcx, .., Izz]` order), `full_names` the names
/// of all full parameters. Returns `Ok(Err(..))` when the data cannot identify it.
pub fn payload_from_fit(
    base: &BaseParams,
    fit: &FitReport,
    cols: &[usize; 10],
    full_names: &[String],
) -> Result<std::result::Result<PayloadEstimate, NotIdentifiable>> {
    // which base parameter carries each payload column, alone?
    let mut idx = [0usize; 10];
    let mut missing = NotIdentifiable { parameters: vec![], combined_in: vec![] };
    for (k, &c) in cols.iter().enumerate() {
        let name = full_names.get(c).cloned().unwrap_or_else(|| format!("theta[{c}]"));
        match base.independent.iter().position(|&j| j == c) {
            Some(b) if base.k.ncols() == 0 || base.k.row(b).iter().all(|v| v.abs() < 1e-12) => {
                if fit.theta[b].is_nan() {
                    missing.parameters.push(name);
                    missing.combined_in.push("not excited by this data".into());
                } else {
                    idx[k] = b;
                }
            }
            Some(b) => {
                missing.parameters.push(name);
                missing.combined_in.push(base.names[b].clone());
            }
            None => {
                missing.parameters.push(name);
                let d = base.dependent.iter().position(|&j| j == c);
                let host = d.and_then(|d| (0..base.base_count()).find(|&b| base.k[(b, d)].abs() > 1e-12));
                missing.combined_in.push(match host {
                    Some(b) => base.names[b].clone(),
                    None => "no effect on the data".into(),
                });
            }
        }
    }
    if !missing.parameters.is_empty() {
        return Ok(Err(missing));
    }
    let theta_ls: [f64; 10] = std::array::from_fn(|k| fit.theta[idx[k]]);
    let cov = SMatrix::<f64, 10, 10>::from_fn(|a, b| fit.covariance[(idx[a], idx[b])]);
    let proj = project(&theta_ls, &cov);
    let p = SVector::<f64, 10>::from(proj.params);
    // the margin of `project` keeps the mass positive: the conversion cannot fail
    let phys = to_physical(&p).unwrap_or_else(|| SVector::repeat(f64::NAN));
    let cov_phys = propagate(&p, &cov);
    let sd = |k: usize| cov_phys[(k, k)].max(0.0).sqrt();
    let ls_violation = violation(&theta_ls);
    let ls_phys = to_physical(&SVector::from(theta_ls));
    let physical = PhysicalFit {
        ls_possible: ls_violation.possible,
        ls_violation,
        ls_params: theta_ls,
        ls_com: ls_phys.map(|v| [v[1], v[2], v[3]]),
        ls_inertia: ls_phys.map(|v| [v[4], v[5], v[6], v[7], v[8], v[9]]),
        mahalanobis2: proj.distance2,
        dof: proj.dof,
        p_value: proj.p_value,
        constraints_active: proj.params != theta_ls,
        violation: violation(&proj.params),
    };
    Ok(Ok(PayloadEstimate {
        mass: phys[0],
        com: [phys[1], phys[2], phys[3]],
        inertia: [phys[4], phys[5], phys[6], phys[7], phys[8], phys[9]],
        mass_std: sd(0),
        com_std: [sd(1), sd(2), sd(3)],
        inertia_std: [sd(4), sd(5), sd(6), sd(7), sd(8), sd(9)],
        params: proj.params,
        physical,
    }))
}

/// The covariance of `(m, c, I_c)` from that of the 10 parameters, by the delta method at
/// `p` (central differences, steps ~ 1e-6 of each parameter's scale).
fn propagate(p: &SVector<f64, 10>, cov: &SMatrix<f64, 10, 10>) -> DMatrix<f64> {
    let mut jac = DMatrix::<f64>::zeros(10, 10);
    for k in 0..10 {
        let h = 1e-6 * p[k].abs().max(1e-9 * p[0].abs().max(1e-9));
        let (mut a, mut b) = (*p, *p);
        a[k] += h;
        b[k] -= h;
        if let (Some(fa), Some(fb)) = (to_physical(&a), to_physical(&b)) {
            jac.set_column(k, &((fa - fb) / (2.0 * h)));
        }
    }
    let cov_dm = DMatrix::from_fn(10, 10, |a, b| cov[(a, b)]);
    &jac * cov_dm * jac.transpose()
}

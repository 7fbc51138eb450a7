//! A payload (or any link's parameter change) as mass, centre of mass and inertia about
//! the centre of mass, with uncertainty propagated from the fit's covariance.
//!
//! The estimate is a set of base combinations. The payload's 10 standard parameters are
//! read off it only when each of them is itself a base parameter (independent column with
//! no combination); otherwise the parameters that are not are reported as not
//! identifiable, with the base combinations they hide in, and no number is invented.
//!
//! Uncertainty: first-order (delta-method) propagation of the 10 x 10 covariance through
//! `(m, h, I_o) -> (m, c = h / m, I_c = I_o + m [c]x [c]x)`, with a numerical Jacobian.

use crate::error::{Error, Result};
use crate::ident::{BaseParams, FitReport};
use ivdyn_core::LinkInertia;
use nalgebra::{DMatrix, SMatrix, SVector};

/// Mass, centre of mass and inertia about the centre of mass (URDF attribute order
/// `[Ixx, Ixy, Ixz, Iyy, Iyz, Izz]`), with standard deviations.
#[derive(Debug, Clone, PartialEq)]
pub struct PayloadEstimate {
    /// Mass (kg).
    pub mass: f64,
    /// Centre of mass in the link frame (m).
    pub com: [f64; 3],
    /// Inertia about the centre of mass, `[Ixx, Ixy, Ixz, Iyy, Iyz, Izz]` (kg m^2).
    pub inertia: [f64; 6],
    /// Standard deviation of the mass.
    pub mass_std: f64,
    /// Standard deviations of the centre of mass.
    pub com_std: [f64; 3],
    /// Standard deviations of the inertia entries.
    pub inertia_std: [f64; 6],
    /// The 10 standard parameters `[m, mcx, mcy, mcz, Ixx, Ixy, Iyy, Ixz, Iyz, Izz]` about
    /// the link origin.
    pub params: [f64; 10],
}

/// Why a payload cannot be read off the fit.
#[derive(Debug, Clone, PartialEq)]
pub struct NotIdentifiable {
    /// Names of the payload parameters that are not base parameters by themselves.
    pub parameters: Vec<String>,
    /// For each, the base combination it is part of (or "no effect on the data").
    pub combined_in: Vec<String>,
}

/// `(m, c, I_c in URDF order)` from the 10 standard parameters.
fn to_physical(p: &SVector<f64, 10>) -> Option<SVector<f64, 10>> {
    let li = LinkInertia([p[0], p[1], p[2], p[3], p[4], p[5], p[6], p[7], p[8], p[9]]);
    let (m, c, ic) = li.to_mass_com_inertia(0).ok()?;
    Some(SVector::<f64, 10>::from_column_slice(&[
        m,
        c.x,
        c.y,
        c.z,
        ic[(0, 0)],
        ic[(0, 1)],
        ic[(0, 2)],
        ic[(1, 1)],
        ic[(1, 2)],
        ic[(2, 2)],
    ]))
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
    let p = SVector::<f64, 10>::from_fn(|k, _| fit.theta[idx[k]]);
    let cov = SMatrix::<f64, 10, 10>::from_fn(|a, b| fit.covariance[(idx[a], idx[b])]);
    let phys = to_physical(&p).ok_or(Error::Core(ivdyn_core::Error::NonPhysicalInertia { link: 0 }))?;
    // numerical Jacobian of the map, central differences with steps ~ sqrt(eps) scale
    let mut jac = DMatrix::<f64>::zeros(10, 10);
    for k in 0..10 {
        let h = 1e-6 * p[k].abs().max(1e-9 * p[0].abs().max(1e-9));
        let (mut a, mut b) = (p, p);
        a[k] += h;
        b[k] -= h;
        if let (Some(fa), Some(fb)) = (to_physical(&a), to_physical(&b)) {
            jac.set_column(k, &((fa - fb) / (2.0 * h)));
        }
    }
    let cov_dm = DMatrix::from_fn(10, 10, |a, b| cov[(a, b)]);
    let cov_phys = &jac * cov_dm * jac.transpose();
    let sd = |k: usize| cov_phys[(k, k)].max(0.0).sqrt();
    Ok(Ok(PayloadEstimate {
        mass: phys[0],
        com: [phys[1], phys[2], phys[3]],
        inertia: [phys[4], phys[5], phys[6], phys[7], phys[8], phys[9]],
        mass_std: sd(0),
        com_std: [sd(1), sd(2), sd(3)],
        inertia_std: [sd(4), sd(5), sd(6), sd(7), sd(8), sd(9)],
        params: p.into(),
    }))
}

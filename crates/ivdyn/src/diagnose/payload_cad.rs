//! A payload's standard errors with the terminal link's CAD error in them (docs/diagnose.md,
//! "Uncertainty").
//!
//! A payload is a change of the terminal link, so the 10 inertial parameters the fit calls
//! the payload are the payload's plus the error of that link's nominal ones, and on top of
//! the nominal re-fit also the previous link's mass error (the payload's mass regroups into
//! that link's parameters, which the re-fit holds). Each error is taken as `LINK_SCALE_MAX`
//! of its size at 2 standard errors: the mass of its mass, every first moment of the norm of
//! its first moment (a centre of mass off in any direction), every inertia element of its
//! mean principal moment. They reach mass, centre of mass and inertia about it through the
//! Jacobian of `p10 -> (m, c, I_c)` at the fitted payload (central differences, as the delta
//! method of `uncertainty`), added in quadrature to the fit's own errors.

use super::score::LINK_SCALE_MAX;

type Params = serde_json::Map<String, serde_json::Value>;

/// Standard errors of the terminal link's 10 nominal parameters (`m, h, I` about its origin,
/// ivdyn's order)
/// from its CAD error, and of the previous link's mass (`m_prev`, on top of the re-fit) in
/// the mass.
pub(super) fn cad_std(terminal: &[f64; 10], m_prev: Option<f64>) -> [f64; 10] {
    let s = 0.5 * LINK_SCALE_MAX;
    let h = (terminal[1].powi(2) + terminal[2].powi(2) + terminal[3].powi(2)).sqrt();
    // trace of I_o in ivdyn's (xx, xy, yy, xz, yz, zz) order: elements 4, 6, 9
    let i_mean = (terminal[4] + terminal[6] + terminal[9]).abs() / 3.0;
    let mut out = [s * i_mean; 10];
    out[0] = (s * terminal[0]).hypot(m_prev.map_or(0.0, |m| s * m));
    out[1..4].fill(s * h);
    out
}

/// `(m, c, I_c in URDF order)` of 10 inertial parameters about the link's origin; `None`
/// where the mass is not positive.
fn mass_com_inertia(p10: &[f64; 10]) -> Option<[f64; 10]> {
    let (m, c, ic) = ivdyn_core::LinkInertia(*p10).to_mass_com_inertia(0).ok()?;
    let urdf = ivdyn_core::inertia_to_urdf(ivdyn_core::inertia_vector(&ic));
    let mut out = [m, c.x, c.y, c.z, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0];
    out[4..].copy_from_slice(&urdf);
    Some(out)
}

/// The standard errors of `(m, c, I_c)` from the parameter errors `cad` at the fitted payload
/// `p10`, to first order; `None` where a perturbed payload has no positive mass.
fn propagated(p10: &[f64; 10], cad: &[f64; 10]) -> Option<[f64; 10]> {
    let mut var = [0.0; 10];
    for (k, &s) in cad.iter().enumerate() {
        if s == 0.0 {
            continue;
        }
        let step = 1e-6 * p10[k].abs().max(s);
        let at = |d: f64| {
            let mut p = *p10;
            p[k] += d;
            mass_com_inertia(&p)
        };
        let (up, down) = (at(step)?, at(-step)?);
        for (v, (a, b)) in var.iter_mut().zip(up.iter().zip(&down)) {
            *v += ((a - b) / (2.0 * step) * s).powi(2);
        }
    }
    Some(var.map(f64::sqrt))
}

/// Adds the CAD errors `cad` (`cad_std`) to the payload's standard errors in `std`: the mass
/// always, centre of mass and inertia where the fit gave them (`null` where the payload's
/// parameters are; an inertia that is no body's stays without).
pub(super) fn add_to_std(p10: &[f64; 10], cad: &[f64; 10], params: &Params, std: &mut Params) {
    let fit_mass = std.get("mass").and_then(|v| v.as_f64()).unwrap_or(0.0);
    let Some(prop) = propagated(p10, cad) else {
        std.insert("mass".into(), fit_mass.hypot(cad[0]).into());
        return;
    };
    std.insert("mass".into(), fit_mass.hypot(prop[0]).into());
    for (key, range) in [("com", 1..4), ("inertia", 4..10)] {
        let given = params.get(key).is_some_and(|v| v.is_array());
        if let Some(fit) = std.get(key).and_then(|v| v.as_array()).filter(|_| given) {
            let total: Vec<f64> =
                fit.iter().zip(&prop[range]).map(|(a, b)| a.as_f64().unwrap_or(f64::NAN).hypot(*b)).collect();
            std.insert(key.into(), total.into());
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A point mass of 2 kg at (0.1, 0, 0) with no CAD error but 0.1 kg on its mass: the
    /// centre of mass `h / m` moves by `-c dm / m`, i.e. its x error is 0.1 * 0.1 / 2 = 0.005,
    /// and y, z (zero) none.
    #[test]
    fn a_mass_error_moves_the_centre_of_mass_by_c_dm_over_m() {
        let p10 = [2.0, 0.2, 0.0, 0.0, 0.0, 0.0, 0.02, 0.0, 0.0, 0.02];
        let mut cad = [0.0; 10];
        cad[0] = 0.1;
        let s = propagated(&p10, &cad).unwrap();
        assert!((s[0] - 0.1).abs() < 1e-9, "{s:?}");
        assert!((s[1] - 0.005).abs() < 1e-8, "{s:?}");
        assert!(s[2].abs() < 1e-12 && s[3].abs() < 1e-12, "{s:?}");
    }

    /// Errors of the terminal link: mass 4 kg -> 0.5 kg (12.5 %), on top of the re-fit with a
    /// 3 kg previous link -> hypot(0.5, 0.375); first moment norm 0.5 -> 0.0625 on each.
    #[test]
    fn cad_errors_are_an_eighth_of_each_size() {
        let t = [4.0, 0.3, 0.4, 0.0, 0.3, 0.0, 0.3, 0.0, 0.0, 0.3];
        let s = cad_std(&t, Some(3.0));
        assert!((s[0] - 0.5f64.hypot(0.375)).abs() < 1e-12);
        assert!(s[1..4].iter().all(|&v| (v - 0.0625).abs() < 1e-12));
        assert!(s[4..].iter().all(|&v| (v - 0.0375).abs() < 1e-12));
    }
}

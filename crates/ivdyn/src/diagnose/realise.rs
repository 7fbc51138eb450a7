//! Whether *some* physically consistent links have given base parameters (docs/diagnose.md,
//! "A consistent realisation of the re-fit").
//!
//! The re-fit corrects base parameters `theta_b = P theta` (eqs 11-13 of the paper), which
//! many full parameter sets share. `refit::corrected` checks one of them, the correction
//! spread over each combination in the nominal's scales; that puts much of it on the inertia
//! entries, whose scale `m L^2` is often tens of times the room a compact link has about its
//! COM, and rejects corrections a consistent arm makes easily. Here the whole set is
//! searched: Levenberg-Marquardt over each link's log-Cholesky factor
//! (`ident::consistent`: every value of it is a consistent link) from the nominal's,
//!
//! ```text
//! min_x  sum_b ((P theta(x) - target)_b / s_b)^2 + PULL ||x - x_nom||^2
//! ```
//!
//! `s_b` the nominal scale of each combination (`refit::prior_scales`). Realised when every
//! combination is within `TOL` of its scale; not when the cost stalls first. (A pull on the
//! parameters instead of the factors ran links into the boundary of the consistent set,
//! where the factors' logarithms run off and LM crawls: it stalled at a 3.4e-3 misfit on a
//! target a consistent arm has.)

use crate::ident::base::BaseParams;
use crate::ident::consistent::{self, link_from_log_cholesky, log_cholesky_from_link};
use crate::linalg::marquardt_step;
use ivdyn_core::params::LINK_PARAMS;
use nalgebra::{DMatrix, DVector};

/// Misfit of every base parameter, in its nominal scale, at which the target is realised.
const TOL: f64 = 1e-3;

/// Weight of the pull of the log-Cholesky factors toward the nominal's: a tie-breaker
/// among the many realisations, small against a `TOL` misfit (`TOL^2 = 1e-6` per term).
const PULL: f64 = 1e-6;

/// The search stops, unrealised, when its cost falls by less than `STALL` of itself over
/// `STALL_ITERS` iterations (a realisable target is reached within tens of iterations).
const STALL: f64 = 0.1;
const STALL_ITERS: usize = 20;

/// At most this many iterations.
const MAX_ITER: usize = 300;

/// The search's fixed data: the base map, the target and scales, the nominal factors.
struct Problem<'a> {
    /// `P` (`b x 10 L`) of the re-fitted links.
    pm: DMatrix<f64>,
    target: &'a [f64],
    scales: &'a [f64],
    x_nom: Vec<f64>,
}

/// Whether some physically consistent links (the `full_cols / 10` links of `base`) have the
/// base parameters `target`, each to `TOL` of its scale `scales` (module docs). `false` also
/// when a nominal link is not consistent itself (no factor to start from: `refit`'s own
/// check, which forgives such links, then decides).
pub(super) fn realisable(base: &BaseParams, nominal: &[f64], target: &[f64], scales: &[f64]) -> bool {
    let p = base.full_cols;
    let mut x_nom = Vec::with_capacity(p);
    for i in 0..p / LINK_PARAMS {
        let cols = LINK_PARAMS * i..LINK_PARAMS * (i + 1);
        // a link outside every combination (the terminal one) is a placeholder
        let unused = cols.clone().all(|c| base.zero_columns.contains(&c));
        match log_cholesky_from_link(&nominal[cols]) {
            Some(x) => x_nom.extend_from_slice(&x),
            None if unused => x_nom.extend_from_slice(&[0.0; LINK_PARAMS]),
            None => return false,
        }
    }
    let pr = Problem { pm: consistent::base_map(base, p), target, scales, x_nom };
    pr.solve()
}

impl Problem<'_> {
    /// `theta(x)`: the links of the factors.
    fn theta(&self, x: &[f64]) -> Vec<f64> {
        x.chunks(LINK_PARAMS).flat_map(link_from_log_cholesky).collect()
    }

    /// Scaled misfit of each base parameter: `(P theta - target)_b / s_b`.
    fn misfit(&self, theta: &[f64]) -> DVector<f64> {
        let tb = &self.pm * DVector::from_column_slice(theta);
        DVector::from_fn(tb.len(), |b, _| (tb[b] - self.target[b]) / self.scales[b])
    }

    /// Residual `[misfit; sqrt(PULL) (x - x_nom)]` and its cost.
    fn resid(&self, x: &[f64]) -> (DVector<f64>, f64) {
        let m = self.misfit(&self.theta(x));
        let b = m.len();
        let mut r = DVector::zeros(b + x.len());
        r.rows_mut(0, b).copy_from(&m);
        for (k, (a, a0)) in x.iter().zip(&self.x_nom).enumerate() {
            r[b + k] = PULL.sqrt() * (a - a0);
        }
        let c = r.norm_squared();
        (r, c)
    }

    /// Jacobian of the residual: `diag(1/s) P dtheta/dx` (block diagonal `dtheta/dx`,
    /// numerical per link) over `sqrt(PULL) I`.
    fn jacobian(&self, x: &[f64]) -> DMatrix<f64> {
        let (b, p) = self.pm.shape();
        let mut j = DMatrix::zeros(b + p, p);
        for (i, xi) in x.chunks(LINK_PARAMS).enumerate() {
            let o = LINK_PARAMS * i;
            let mut dl = DMatrix::<f64>::zeros(LINK_PARAMS, LINK_PARAMS);
            for k in 0..LINK_PARAMS {
                let h = 1e-6;
                let (mut a, mut c) = (xi.to_vec(), xi.to_vec());
                a[k] += h;
                c[k] -= h;
                let (fa, fc) = (link_from_log_cholesky(&a), link_from_log_cholesky(&c));
                for r in 0..LINK_PARAMS {
                    dl[(r, k)] = (fa[r] - fc[r]) / (2.0 * h);
                }
            }
            let block = self.pm.columns(o, LINK_PARAMS) * dl;
            for r in 0..b {
                for k in 0..LINK_PARAMS {
                    j[(r, o + k)] = block[(r, k)] / self.scales[r];
                }
            }
            for k in 0..LINK_PARAMS {
                j[(b + o + k, o + k)] = PULL.sqrt();
            }
        }
        j
    }

    fn realised(&self, x: &[f64]) -> bool {
        self.misfit(&self.theta(x)).amax() <= TOL
    }

    /// Levenberg-Marquardt (Marquardt's diagonal damping) from the nominal factors.
    fn solve(&self) -> bool {
        let mut x = self.x_nom.clone();
        let (mut r, mut cost) = self.resid(&x);
        let mut mu = 1e-3;
        let mut history = vec![cost];
        for _ in 0..MAX_ITER {
            if self.realised(&x) {
                return true;
            }
            let j = self.jacobian(&x);
            let (jtj, jtr) = (j.tr_mul(&j), j.tr_mul(&r));
            let Some((xn, rn, cn)) = marquardt_step(&x, &jtj, &jtr, &mut mu, cost, |x| self.resid(x)) else {
                return false; // no damping lowers the cost: a minimum short of the target
            };
            (x, r, cost) = (xn, rn, cn);
            history.push(cost);
            let h = history.len();
            if h > STALL_ITERS && history[h - 1 - STALL_ITERS] - cost <= STALL * history[h - 1 - STALL_ITERS] {
                return self.realised(&x);
            }
        }
        self.realised(&x)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::Robot;
    use crate::diagnose::dictionary::refit_base;
    use crate::diagnose::refit::prior_scales;
    use std::path::PathBuf;

    /// Committed random-arm fixtures (true arm, CAD model 5-30 % off) of docs/diagnose.md.
    const FIXTURES: [(&str, &str); 4] =
        [("rarm22_6j", "e30_3fx"), ("rarm24_6j", "e15_2fx"), ("rarm27_7j", "e30_0fx"), ("rarm36_6j", "e15_2fx")];

    fn dir(arm: &str) -> PathBuf {
        PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../fixtures/diagnose_unseen").join(arm)
    }

    /// The true arm's base parameters are those of consistent links (the true ones), so
    /// they are realisable from the CAD model's; their negatives (negative masses) are not.
    #[test]
    fn true_arms_are_realisable_from_their_cad_models_negatives_are_not() {
        for (arm, case) in FIXTURES {
            let truth = Robot::from_urdf(dir(arm).join("arm.urdf"), None, None).unwrap();
            let cad = Robot::from_urdf(dir(arm).join(format!("{case}_nominal.urdf")), None, None).unwrap();
            let base = refit_base(&cad).unwrap();
            let p = base.full_cols;
            let (nominal, true_params) = (cad.params(), truth.params());
            let target = base.project(&true_params[..p]).unwrap();
            let scales = prior_scales(&base, &nominal);
            // the CAD model itself is off by more than the tolerance somewhere
            let nom_base = base.project(&nominal[..p]).unwrap();
            let off = (0..target.len()).map(|b| (target[b] - nom_base[b]).abs() / scales[b]).fold(0.0, f64::max);
            assert!(off > 10.0 * TOL, "{arm}: CAD model only {off} off");
            assert!(realisable(&base, &nominal, &target, &scales), "{arm}/{case}");
            let negative: Vec<f64> = target.iter().map(|t| -t).collect();
            assert!(!realisable(&base, &nominal, &negative, &scales), "{arm}/{case}: negative");
        }
    }
}

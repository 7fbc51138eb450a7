//! Base (identifiable) parameters, found numerically from regressor rows.
//!
//! # Method
//! Given a regressor `Φ` (`m x p`) sampled at many generic states, the columns split into
//! `b` independent ones `Φ_i` and `d = p - b` dependent ones with `Φ_d = Φ_i K`, so that
//!
//! ```text
//! Φ θ = Φ_i θ_i + Φ_d θ_d = Φ_i (θ_i + K θ_d) = Φ_i θ_base.
//! ```
//!
//! The split comes from a Householder QR with column pivoting of the column-scaled
//! regressor `Φ D⁻¹` (`D = diag(‖Φ_j‖)`, so units do not bias the pivoting):
//! `Φ D⁻¹ P = Q [R11 R12; 0 R22]`. The rank `b` is the number of pivots with
//! `|R_ii| > RANK_TOL · |R_00|` with [`RANK_TOL`] `= 1e-9` (structural dependencies give
//! `|R_ii| / |R_00| ~ 1e-15`; generic random states keep true pivots above ~1e-6).
//! Then `K_s = R11⁻¹ R12` in scaled units and `K = D_i⁻¹ K_s D_d`.
//! Columns that are identically zero (`‖Φ_j‖ <= 1e-12 max_k ‖Φ_k‖`: parameters with no
//! effect at all) are dependent with a zero column of `K`, and listed in `zero_columns`.
//! To save work, the pivoted QR runs on the triangular factor of `Φ D⁻¹` (same Gram
//! matrix, hence same column geometry) rather than on the `m x p` matrix itself.

use super::accum::{back_substitute, triangular_factor};
use crate::error::{Error, Result};
use ivdyn_core::rng::Rng;
use nalgebra::DMatrix;

/// Rank tolerance of the pivoted QR, relative to the largest pivot `|R_00|` of the
/// column-scaled regressor.
pub const RANK_TOL: f64 = 1e-9;
/// A column whose norm is at most this times the largest column norm is "identically zero".
pub const ZERO_COL_TOL: f64 = 1e-12;
/// Coefficients of `K` below this in absolute value are left out of the names.
pub const NAME_COEF_TOL: f64 = 1e-10;

/// Base parameters: which full parameters are identifiable, and in which combinations.
/// `θ_base = θ[independent] + K θ[dependent]`.
#[derive(Debug, Clone, PartialEq)]
pub struct BaseParams {
    /// Number of full parameters `p`.
    pub full_cols: usize,
    /// Independent columns (ascending); base parameter `j` is built on `independent[j]`.
    pub independent: Vec<usize>,
    /// Dependent columns (ascending), including the zero columns.
    pub dependent: Vec<usize>,
    /// `b x d` combination matrix: `θ_base = θ[independent] + K θ[dependent]`.
    pub k: DMatrix<f64>,
    /// Columns that are identically zero (parameters with no effect on the data).
    pub zero_columns: Vec<usize>,
    /// Readable name of each base parameter, e.g. `"link3.Ixx + link3.Iyy - 0.225*link4.m"`.
    pub names: Vec<String>,
}

impl BaseParams {
    /// Finds the base parameters of the rows `phi` (`m x p`, `m >= p` generic samples);
    /// `names` are the `p` full parameter names (missing names become `"theta[j]"`).
    pub fn from_rows(phi: &DMatrix<f64>, names: &[String]) -> BaseParams {
        let p = phi.ncols();
        let norms: Vec<f64> = (0..p).map(|j| phi.column(j).norm()).collect();
        let max_norm = norms.iter().cloned().fold(0.0, f64::max);
        let zero_columns: Vec<usize> =
            (0..p).filter(|&j| !(norms[j] > ZERO_COL_TOL * max_norm) || max_norm == 0.0).collect();
        let nonzero: Vec<usize> = (0..p).filter(|j| !zero_columns.contains(j)).collect();

        // Column-scaled non-zero columns, compressed to their triangular factor.
        let mut scaled = DMatrix::zeros(phi.nrows(), nonzero.len());
        for (c, &j) in nonzero.iter().enumerate() {
            scaled.set_column(c, &(phi.column(j) / norms[j]));
        }
        let (r, perm) = pivoted_qr(triangular_factor(&scaled));
        let r00 = if r.nrows() > 0 { r[(0, 0)].abs() } else { 0.0 };
        let b = (0..r.nrows().min(r.ncols())).take_while(|&i| r[(i, i)].abs() > RANK_TOL * r00).count();

        // K_s = R11⁻¹ R12 column by column, then unscale: K = D_i⁻¹ K_s D_d.
        let indep_piv: Vec<usize> = perm[..b].iter().map(|&c| nonzero[c]).collect();
        let dep_piv: Vec<usize> = perm[b..].iter().map(|&c| nonzero[c]).collect();
        let r11 = r.view((0, 0), (b, b));
        let mut independent = indep_piv.clone();
        independent.sort_unstable();
        let mut dependent: Vec<usize> = dep_piv.iter().chain(zero_columns.iter()).cloned().collect();
        dependent.sort_unstable();
        let mut k = DMatrix::zeros(b, dependent.len());
        for (t, &jd) in dep_piv.iter().enumerate() {
            let rhs: Vec<f64> = (0..b).map(|i| r[(i, b + t)]).collect();
            let ks = back_substitute(&r11, &rhs);
            let col = dependent.binary_search(&jd).expect("dependent column listed");
            for (s, &ji) in indep_piv.iter().enumerate() {
                let row = independent.binary_search(&ji).expect("independent column listed");
                k[(row, col)] = ks[s] * norms[jd] / norms[ji];
            }
        }
        let full_names: Vec<String> =
            (0..p).map(|j| names.get(j).cloned().unwrap_or_else(|| format!("theta[{j}]"))).collect();
        let names = base_names(&independent, &dependent, &k, &full_names);
        BaseParams { full_cols: p, independent, dependent, k, zero_columns, names }
    }

    /// Number of base parameters `b`.
    pub fn base_count(&self) -> usize {
        self.independent.len()
    }

    /// `θ_base = θ[independent] + K θ[dependent]` for a full parameter vector.
    pub fn project(&self, theta_full: &[f64]) -> Result<Vec<f64>> {
        self.check_len("theta_full", self.full_cols, theta_full.len())?;
        Ok(self
            .independent
            .iter()
            .enumerate()
            .map(|(r, &i)| {
                theta_full[i]
                    + self.dependent.iter().enumerate().map(|(c, &d)| self.k[(r, c)] * theta_full[d]).sum::<f64>()
            })
            .collect())
    }

    /// Base regressor row: the independent entries of a full row (`out.len() == b`).
    pub fn select_row(&self, row_full: &[f64], out: &mut [f64]) -> Result<()> {
        self.check_len("row_full", self.full_cols, row_full.len())?;
        self.check_len("out", self.base_count(), out.len())?;
        for (o, &i) in out.iter_mut().zip(&self.independent) {
            *o = row_full[i];
        }
        Ok(())
    }

    /// Base regressor of `m` full rows (`phi_full`: `m x p` row-major) as `m x b`
    /// row-major.
    pub fn select_rows(&self, phi_full: &[f64], m: usize) -> Result<Vec<f64>> {
        let (p, b) = (self.full_cols, self.base_count());
        self.check_len("phi_full (m x p, row-major)", m * p, phi_full.len())?;
        let mut out = vec![0.0; m * b];
        for i in 0..m {
            self.select_row(&phi_full[i * p..(i + 1) * p], &mut out[i * b..(i + 1) * b])?;
        }
        Ok(out)
    }

    /// A full parameter vector with the same effect as `θ_base`: independent entries =
    /// base values, dependent entries = 0 (one particular solution; `project(to_full(x)) == x`).
    pub fn to_full(&self, theta_base: &[f64]) -> Result<Vec<f64>> {
        self.check_len("theta_base", self.base_count(), theta_base.len())?;
        let mut full = vec![0.0; self.full_cols];
        for (&i, &v) in self.independent.iter().zip(theta_base) {
            full[i] = v;
        }
        Ok(full)
    }

    /// `theta_nominal` with its identifiable part moved to `theta_base`:
    /// `theta_nominal + to_full(theta_base - project(theta_nominal))`. The parts the data
    /// cannot see keep their nominal values, which keeps a model physical in practice.
    /// With `alpha` in [0, 1] the move is partial (`alpha = 1`: all the way).
    pub fn apply(&self, theta_base: &[f64], theta_nominal: &[f64], alpha: f64) -> Result<Vec<f64>> {
        let nom_base = self.project(theta_nominal)?;
        self.check_len("theta_base", self.base_count(), theta_base.len())?;
        let delta: Vec<f64> = theta_base.iter().zip(&nom_base).map(|(a, b)| alpha * (a - b)).collect();
        Ok(self.to_full(&delta)?.iter().zip(theta_nominal).map(|(d, t)| t + d).collect())
    }

    fn check_len(&self, what: &str, expected: usize, got: usize) -> Result<()> {
        if expected != got {
            return Err(Error::Dimension { what: what.into(), expected, got });
        }
        Ok(())
    }
}

/// Householder QR with column pivoting (largest remaining column norm first; ties go to
/// the lowest index) of `a` in place: returns `R` (upper-trapezoidal, `a`'s shape) and the
/// permutation `perm` with `a[:, perm] = Q R`. Norms are recomputed each step (no
/// downdating, so no loss of accuracy on nearly dependent columns).
pub(crate) fn pivoted_qr(mut a: DMatrix<f64>) -> (DMatrix<f64>, Vec<usize>) {
    let (m, n) = a.shape();
    let mut perm: Vec<usize> = (0..n).collect();
    for j in 0..m.min(n) {
        let norm_below = |a: &DMatrix<f64>, c: usize| a.view((j, c), (m - j, 1)).norm_squared();
        let best = (j..n).fold(j, |best, c| if norm_below(&a, c) > norm_below(&a, best) { c } else { best });
        a.swap_columns(j, best);
        perm.swap(j, best);
        let x = a.view((j, j), (m - j, 1)).clone_owned();
        let alpha = x[0];
        let norm = x.norm();
        if norm == 0.0 {
            continue;
        }
        let beta = if alpha >= 0.0 { -norm } else { norm };
        let mut v = x;
        v[0] = alpha - beta;
        let vv = v.norm_squared();
        // apply H = I - 2 v vᵀ / (vᵀv) to the trailing block
        for c in j..n {
            let s = 2.0 * v.dot(&a.view((j, c), (m - j, 1))) / vv;
            for i in 0..m - j {
                a[(j + i, c)] -= s * v[i];
            }
        }
        a[(j, j)] = beta;
        for i in j + 1..m {
            a[(i, j)] = 0.0;
        }
    }
    (a, perm)
}

/// Names `names[i] ± c*names[d] ...` for every base parameter.
fn base_names(independent: &[usize], dependent: &[usize], k: &DMatrix<f64>, names: &[String]) -> Vec<String> {
    independent
        .iter()
        .enumerate()
        .map(|(r, &i)| {
            let mut s = names[i].clone();
            for (c, &d) in dependent.iter().enumerate() {
                let coef = k[(r, c)];
                if coef.abs() < NAME_COEF_TOL {
                    continue;
                }
                let sign = if coef < 0.0 { " - " } else { " + " };
                s.push_str(sign);
                if (coef.abs() - 1.0).abs() >= NAME_COEF_TOL {
                    s.push_str(&format_sig(coef.abs(), 6));
                    s.push('*');
                }
                s.push_str(&names[d]);
            }
            s
        })
        .collect()
}

/// `x` with `digits` significant digits, trailing zeros removed: `0.225`, `1.5`,
/// `3.14159e-7` (exponent form outside `[1e-4, 1e6)`).
pub fn format_sig(x: f64, digits: usize) -> String {
    let a = x.abs();
    if a == 0.0 || !a.is_finite() {
        return format!("{x}");
    }
    let trim = |s: String| -> String {
        if s.contains('.') { s.trim_end_matches('0').trim_end_matches('.').to_string() } else { s }
    };
    if (1e-4..1e6).contains(&a) {
        let decimals = (digits as i32 - 1 - a.log10().floor() as i32).max(0) as usize;
        trim(format!("{x:.decimals$}"))
    } else {
        let s = format!("{:.*e}", digits - 1, x);
        match s.split_once('e') {
            Some((mant, exp)) => format!("{}e{}", trim(mant.to_string()), exp),
            None => s,
        }
    }
}

/// Base parameters of a robot from `samples` random states (seeded `ivdyn_core::rng::Rng`): `q`
/// uniform within the joint limits where both are finite (else in `[-π, π]`), `qd`
/// uniform in `±1` (`±min(1, velocity limit)` if a finite positive limit exists) and
/// `qdd` uniform in `±2`; the full regressors (`dof x 14 dof` each) are stacked and
/// passed to [`BaseParams::from_rows`] with [`crate::Robot::param_names`].
/// Needs `samples * dof >= 14 dof` rows; use a few times more for a robust rank.
pub fn robot_base_params(robot: &crate::Robot, samples: usize, seed: u64) -> Result<BaseParams> {
    robot_base_params_with(robot, samples, seed, false)
}

/// Most random states [`robot_base_params_with`] samples: the regressor it factors is
/// `samples * dof x p` (20000 states of a 6-joint arm with 84 parameters: 80 MB). The
/// default is 100; the numerical rank settles within a few hundred.
pub const MAX_BASE_SAMPLES: usize = 20_000;

/// `samples` random states at most [`MAX_BASE_SAMPLES`] (each base-parameter search).
pub fn check_base_samples(samples: usize) -> Result<()> {
    if samples > MAX_BASE_SAMPLES {
        return Err(Error::Option {
            option: "samples".into(),
            msg: format!(
                "must be at most {MAX_BASE_SAMPLES}, got {samples} (random states for the base parameters; a few hundred suffice)"
            ),
        });
    }
    Ok(())
}

/// [`robot_base_params`] over the `10 N` inertial columns only (`rigid_only`), as a
/// rigid-body-only fit (e.g. Pinocchio's regressor) uses them, or over all `14 N`.
pub fn robot_base_params_with(robot: &crate::Robot, samples: usize, seed: u64, rigid_only: bool) -> Result<BaseParams> {
    robot_base_params_excluding(robot, samples, seed, rigid_only, &[])
}

/// [`robot_base_params_with`] with the columns `exclude` (full parameter indices) left out
/// of the model: they are zeroed in the sampled regressor, so they become zero columns
/// (no base parameter contains them; [`BaseParams::apply`] keeps their nominal values).
/// Used to fit a chosen subset of the drive parameters (e.g. no Coulomb friction).
pub fn robot_base_params_excluding(
    robot: &crate::Robot,
    samples: usize,
    seed: u64,
    rigid_only: bool,
    exclude: &[usize],
) -> Result<BaseParams> {
    let (n, p_all) = (robot.dof(), robot.num_params());
    let p = if rigid_only { ivdyn_core::params::LINK_PARAMS * n } else { p_all };
    // the sampled regressor is `samples * dof x p`, allocated at once: bounded so that an
    // argument cannot ask for terabytes (or overflow `samples * n`)
    check_base_samples(samples)?;
    if samples * n < p {
        return Err(Error::Dimension {
            what: "samples * dof (rows; must be >= parameter count)".into(),
            expected: p,
            got: samples * n,
        });
    }
    let cols: Vec<usize> = (0..p).collect();
    let mut phi = random_rows(robot, &cols, samples, seed)?;
    for &c in exclude.iter().filter(|&&c| c < p) {
        phi.column_mut(c).fill(0.0);
    }
    Ok(BaseParams::from_rows(&phi, &robot.param_names()[..p]))
}

/// The regressor columns `cols` at `samples` random states, stacked (`samples * n` rows):
/// `q` uniform within the joint limits (`[-pi, pi]` where there are none), `qd` within
/// the velocity limit capped at 1 rad/s, `qdd` within 2 rad/s^2. What the numerical
/// identifiability tests (base parameters, the payload's visible columns) sample: states
/// of the size an excitation reaches, so that no column is hidden by scale alone.
pub fn random_rows(robot: &crate::Robot, cols: &[usize], samples: usize, seed: u64) -> Result<DMatrix<f64>> {
    let (n, p_all) = (robot.dof(), robot.num_params());
    let limits = crate::with_model!(&robot.model, m => m.limits.to_vec());
    let mut rng = Rng::new(seed);
    let mut phi = DMatrix::zeros(samples * n, cols.len());
    let (mut q, mut qd, mut qdd) = (vec![0.0; n], vec![0.0; n], vec![0.0; n]);
    for s in 0..samples {
        for j in 0..n {
            let l = &limits[j];
            let (lo, hi) = if l.lower.is_finite() && l.upper.is_finite() && l.upper > l.lower {
                (l.lower, l.upper)
            } else {
                (-std::f64::consts::PI, std::f64::consts::PI)
            };
            let vmax = if l.velocity.is_finite() && l.velocity > 0.0 { l.velocity.min(1.0) } else { 1.0 };
            q[j] = rng.uniform(lo, hi);
            qd[j] = rng.uniform(-vmax, vmax);
            qdd[j] = rng.uniform(-2.0, 2.0);
        }
        let y = robot.regressor(&q, &qd, &qdd)?;
        for r in 0..n {
            for (c, &col) in cols.iter().enumerate() {
                phi[(s * n + r, c)] = y[r * p_all + col];
            }
        }
    }
    Ok(phi)
}

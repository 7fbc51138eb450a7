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
//! # Which columns are kept: a fixed preference order
//! The columns are scaled to unit norm (`Φ D⁻¹`, `D = diag(‖Φ_j‖)`, so units do not
//! matter) and visited in a fixed *preference order* that does not depend on the samples:
//! a column is kept when its residual after projection on the columns already kept has
//! norm above [`RANK_TOL`] `= 1e-9` (a Householder QR without pivoting that skips the
//! columns it rejects). Structural dependencies leave residuals ~1e-15; generic random
//! states keep independent columns far above 1e-9. So the samples only decide *whether*
//! a column depends on the ones before it, and since that is a property of the model,
//! every generic sample set, sample count and seed keeps the same columns and gives the
//! same names; only the coefficients of `K` move, by rounding, and names print them with
//! [`NAME_DIGITS`] significant digits.
//!
//! [`robot_base_params`] uses the textbook order ([`textbook_order`]), which reproduces
//! the regroupings of Gautier & Khalil (1990) / Khalil & Dombre (2002, ch. 12 and 14):
//! for a revolute joint `j` with axis `z` the kept parameters are `XXR_j = XX_j - YY_j`,
//! `XY_j`, `XZ_j`, `YZ_j`, `ZZR_j`, `MXR_j`, `MYR_j`, while `YY_j`, `MZ_j`, `M_j` are
//! regrouped into link `j-1`; joint-level parameters are kept as their own, except the
//! first joint's armature, which acts exactly as `ZZ_1` and enters `ZZR_1`.
//! [`BaseParams::from_rows`] without an order prefers the columns in index order.
//!
//! `K_s = R11⁻¹ R12` in scaled units and `K = D_i⁻¹ K_s D_d`. Columns that are identically
//! zero (`‖Φ_j‖ <= 1e-12 max_k ‖Φ_k‖`: parameters with no effect at all) are dependent
//! with a zero column of `K`, and listed in `zero_columns`. To save work, the QR runs on
//! the triangular factor of `Φ D⁻¹` (same Gram matrix, hence same column geometry) rather
//! than on the `m x p` matrix itself.
//!
//! [`BaseParams::from_rows_pivoted`] picks the columns by QR with column pivoting
//! (largest residual first) instead: the best-conditioned choice for *this* data, which
//! is what a fit wants when it drops the directions its data did not excite, but not a
//! reproducible naming.

use super::accum::{back_substitute, triangular_factor};
use crate::error::{Error, Result};
use ivdyn_core::model::JointKind;
use ivdyn_core::params::{DRIVE_PARAMS, IXX, IXY, IXZ, IYY, IYZ, IZZ, M, MC, drive_col, link_col};
use ivdyn_core::rng::Rng;
use nalgebra::DMatrix;

/// Rank tolerance: a column (scaled to unit norm) is independent of the columns before it
/// when its residual norm exceeds this.
pub const RANK_TOL: f64 = 1e-9;
/// A column whose norm is at most this times the largest column norm is "identically zero".
pub const ZERO_COL_TOL: f64 = 1e-12;
/// Coefficients of `K` below this in scaled units (`|K_s|`, columns of unit norm) are
/// structural zeros left by rounding, and left out of the names.
pub const NAME_COEF_TOL: f64 = 1e-9;
/// Significant digits of the coefficients in the names.
pub const NAME_DIGITS: usize = 6;

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
    /// Readable name of each base parameter, e.g. `"link3.Ixx - link3.Iyy - 0.00784996*link4.m - ..."`
    /// (the paper's robot: `XXR_3`, with `a_3^2 M_4` from link 4's mass at joint 4).
    pub names: Vec<String>,
}

/// How the independent columns are chosen among the non-zero ones.
enum Choice<'a> {
    /// In this preference order of the full columns (a permutation of `0..p`).
    Preference(&'a [usize]),
    /// By QR with column pivoting (largest residual first).
    Pivoted,
}

impl BaseParams {
    /// Finds the base parameters of the rows `phi` (`m x p`, `m >= p` generic samples),
    /// preferring the columns in index order (see the module docs); `names` are the `p`
    /// full parameter names (missing names become `"theta[j]"`).
    pub fn from_rows(phi: &DMatrix<f64>, names: &[String]) -> BaseParams {
        let order: Vec<usize> = (0..phi.ncols()).collect();
        Self::split(phi, names, Choice::Preference(&order))
    }

    /// [`from_rows`](Self::from_rows) keeping the columns in the preference order
    /// `preference` (a permutation of `0..p`, most preferred first): a column is kept when
    /// it is independent of the kept columns before it (e.g. [`textbook_order`]).
    pub fn from_rows_ordered(phi: &DMatrix<f64>, names: &[String], preference: &[usize]) -> Result<BaseParams> {
        let p = phi.ncols();
        let mut seen = vec![false; p];
        for &c in preference {
            if c >= p || std::mem::replace(&mut seen[c], true) {
                return Err(Error::option(
                    "preference",
                    format!("must be a permutation of the {p} columns, got column {c} out of range or twice"),
                ));
            }
        }
        if preference.len() != p {
            return Err(Error::Dimension {
                what: "preference (a permutation of the columns)".into(),
                expected: p,
                got: preference.len(),
            });
        }
        Ok(Self::split(phi, names, Choice::Preference(preference)))
    }

    /// [`from_rows`](Self::from_rows) choosing the columns by QR with column pivoting
    /// (largest scaled residual first): the best-conditioned choice for this `phi`, used
    /// to drop the directions a fit's data did not excite; the choice (and so the names)
    /// follows the data.
    pub fn from_rows_pivoted(phi: &DMatrix<f64>, names: &[String]) -> BaseParams {
        Self::split(phi, names, Choice::Pivoted)
    }

    fn split(phi: &DMatrix<f64>, names: &[String], choice: Choice<'_>) -> BaseParams {
        let p = phi.ncols();
        let norms: Vec<f64> = (0..p).map(|j| phi.column(j).norm()).collect();
        let max_norm = norms.iter().cloned().fold(0.0, f64::max);
        let is_zero = |j: usize| !(norms[j] > ZERO_COL_TOL * max_norm) || max_norm == 0.0;
        let zero_columns: Vec<usize> = (0..p).filter(|&j| is_zero(j)).collect();
        // the non-zero columns, in the order the QR visits them
        let visit: Vec<usize> = match choice {
            Choice::Preference(order) => order.iter().cloned().filter(|&j| !is_zero(j)).collect(),
            Choice::Pivoted => (0..p).filter(|&j| !is_zero(j)).collect(),
        };

        // Column-scaled non-zero columns, compressed to their triangular factor.
        let mut scaled = DMatrix::zeros(phi.nrows(), visit.len());
        for (c, &j) in visit.iter().enumerate() {
            scaled.set_column(c, &(phi.column(j) / norms[j]));
        }
        let (r, perm, b) = match choice {
            Choice::Preference(_) => ordered_qr(triangular_factor(&scaled), RANK_TOL),
            Choice::Pivoted => {
                let (r, perm) = pivoted_qr(triangular_factor(&scaled));
                let r00 = if r.nrows() > 0 { r[(0, 0)].abs() } else { 0.0 };
                let b = (0..r.nrows().min(r.ncols())).take_while(|&i| r[(i, i)].abs() > RANK_TOL * r00).count();
                (r, perm, b)
            }
        };
        let indep_qr: Vec<usize> = perm[..b].iter().map(|&c| visit[c]).collect();
        let dep_qr: Vec<usize> = perm[b..].iter().map(|&c| visit[c]).collect();
        let (k, independent, dependent) = combination(&r, b, &indep_qr, &dep_qr, &zero_columns, &norms);
        let full_names: Vec<String> =
            (0..p).map(|j| names.get(j).cloned().unwrap_or_else(|| format!("theta[{j}]"))).collect();
        let names = base_names(&independent, &dependent, &k, &norms, &full_names);
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

/// `K = D_i⁻¹ R11⁻¹ R12 D_d` from the QR factor `r` of the scaled columns (`b` kept
/// columns first, in the order `indep_qr`, then `dep_qr`), with the independent and
/// dependent (incl. `zero_columns`, zero in `K`) columns in ascending order.
fn combination(
    r: &DMatrix<f64>,
    b: usize,
    indep_qr: &[usize],
    dep_qr: &[usize],
    zero_columns: &[usize],
    norms: &[f64],
) -> (DMatrix<f64>, Vec<usize>, Vec<usize>) {
    let r11 = r.view((0, 0), (b, b));
    let mut independent = indep_qr.to_vec();
    independent.sort_unstable();
    let mut dependent: Vec<usize> = dep_qr.iter().chain(zero_columns).cloned().collect();
    dependent.sort_unstable();
    let mut k = DMatrix::zeros(b, dependent.len());
    for (t, &jd) in dep_qr.iter().enumerate() {
        // K_s = R11⁻¹ R12 column by column, then unscaled
        let rhs: Vec<f64> = (0..b).map(|i| r[(i, b + t)]).collect();
        let ks = back_substitute(&r11, &rhs);
        let col = dependent.binary_search(&jd).expect("dependent column listed");
        for (s, &ji) in indep_qr.iter().enumerate() {
            let row = independent.binary_search(&ji).expect("independent column listed");
            k[(row, col)] = ks[s] * norms[jd] / norms[ji];
        }
    }
    (k, independent, dependent)
}

/// Householder reflection `H = I - 2 v vᵀ / (vᵀv)` that zeroes `a[j+1.., j]`, applied to
/// rows `j..` of columns `j..` of `a`.
fn reflect(a: &mut DMatrix<f64>, j: usize) {
    let (m, n) = a.shape();
    let x = a.view((j, j), (m - j, 1)).clone_owned();
    let alpha = x[0];
    let norm = x.norm();
    if norm == 0.0 {
        return;
    }
    let beta = if alpha >= 0.0 { -norm } else { norm };
    let mut v = x;
    v[0] = alpha - beta;
    let vv = v.norm_squared();
    for c in j + 1..n {
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

/// Householder QR of `a` in its own column order that keeps a column only when its
/// residual (its part outside the span of the columns kept before it: the norm of its
/// entries below the current row) exceeds `tol`. Returns `R` with the `b` kept columns
/// first (upper-triangular `R11`, in their order) and the rejected ones after them
/// (`R12`), the permutation `perm` with `a[:, perm] = Q R`, and `b`.
pub(crate) fn ordered_qr(mut a: DMatrix<f64>, tol: f64) -> (DMatrix<f64>, Vec<usize>, usize) {
    let (m, n) = a.shape();
    let mut perm: Vec<usize> = (0..n).collect();
    let mut b = 0;
    for c in 0..n {
        if b == m {
            break;
        }
        if !(a.view((b, c), (m - b, 1)).norm() > tol) {
            continue;
        }
        // the rejected columns sit in b..c; the kept one joins R11 at b
        a.swap_columns(b, c);
        perm.swap(b, c);
        reflect(&mut a, b);
        b += 1;
    }
    (a, perm, b)
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
        reflect(&mut a, j);
    }
    (a, perm)
}

/// Names `names[i] ± c*names[d] ...` for every base parameter: the terms whose scaled
/// coefficient `|K_s|` reaches [`NAME_COEF_TOL`], `c` with [`NAME_DIGITS`] significant
/// digits (left out when it prints as 1).
fn base_names(
    independent: &[usize],
    dependent: &[usize],
    k: &DMatrix<f64>,
    norms: &[f64],
    names: &[String],
) -> Vec<String> {
    independent
        .iter()
        .enumerate()
        .map(|(r, &i)| {
            let mut s = names[i].clone();
            for (c, &d) in dependent.iter().enumerate() {
                let coef = k[(r, c)];
                // NaN (a zero column) or below the tolerance: no term
                if !(coef.abs() * norms[i] / norms[d] >= NAME_COEF_TOL) {
                    continue;
                }
                s.push_str(if coef < 0.0 { " - " } else { " + " });
                let digits = format_sig(coef.abs(), NAME_DIGITS);
                if digits != "1" {
                    s.push_str(&digits);
                    s.push('*');
                }
                s.push_str(&names[d]);
            }
            s
        })
        .collect()
}

/// `x` with `digits` significant digits, trailing zeros removed: `0.225`, `1.5`,
/// `3.14159e-7` (exponent form outside `[1e-4, 1e6)`). A value within [`TIE_WINDOW`] of a
/// last-digit unit from a rounding tie counts as the tie and is rounded away from zero, so
/// that rounding noise does not flip the last digit of an exact decimal such as
/// `0.39225 * 0.093 = 0.03647925` (printed `0.0364793` from either side).
pub fn format_sig(x: f64, digits: usize) -> String {
    let a = x.abs();
    if a == 0.0 || !a.is_finite() {
        return format!("{x}");
    }
    let trim = |s: String| -> String {
        if s.contains('.') { s.trim_end_matches('0').trim_end_matches('.').to_string() } else { s }
    };
    let exponent = a.log10().floor() as i32;
    if (1e-4..1e6).contains(&a) {
        let decimals = (digits as i32 - 1 - exponent).max(0);
        let v = x.signum() * round_ties_away(a, decimals);
        trim(format!("{v:.*}", decimals as usize))
    } else {
        let v = x.signum() * round_ties_away(a, digits as i32 - 1 - exponent);
        let s = format!("{:.*e}", digits - 1, v);
        match s.split_once('e') {
            Some((mant, exp)) => format!("{}e{}", trim(mant.to_string()), exp),
            None => s,
        }
    }
}

/// Distance from a rounding tie, in units of the last printed digit, within which
/// [`format_sig`] treats a value as the tie (rounding noise of a computed coefficient is
/// ~1e-12 relative, far inside it).
pub const TIE_WINDOW: f64 = 1e-4;

/// `a >= 0` rounded to `decimals` decimals (negative: tens, hundreds...), a value within
/// [`TIE_WINDOW`] units of a tie rounded up; other values unchanged (the formatter rounds them).
fn round_ties_away(a: f64, decimals: i32) -> f64 {
    let scale = 10f64.powi(decimals);
    let s = a * scale;
    if (s - s.floor() - 0.5).abs() < TIE_WINDOW { (s.floor() + 1.0) / scale } else { a }
}

/// Base parameters of a robot from `samples` random states (seeded `ivdyn_core::rng::Rng`): `q`
/// uniform within the joint limits where both are finite (else in `[-π, π]`), `qd`
/// uniform in `±1` (`±min(1, velocity limit)` if a finite positive limit exists) and
/// `qdd` uniform in `±2`; the full regressors (`dof x 14 dof` each) are stacked and
/// passed to [`BaseParams::from_rows_ordered`] with [`crate::Robot::param_names`] and
/// [`textbook_order`] (so the names do not depend on `samples` or `seed`).
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
        return Err(Error::option(
            "samples",
            format!(
                "must be at most {MAX_BASE_SAMPLES}, got {samples} (random states for the base parameters; a few hundred suffice)"
            ),
        ));
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
    BaseParams::from_rows_ordered(&phi, &robot.param_names()[..p], &textbook_order(robot, p))
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

/// The textbook preference order ([`BaseParams::from_rows_ordered`]) of the first `p`
/// parameters of `robot` (`p = 10 N`: inertial only, or `14 N`), after Khalil & Dombre
/// (2002, sec. 12.5.2): first, link by link from the base, the parameters a joint leaves
/// identifiable on its own link ([`link_preference`]); then every joint's drive
/// parameters; last, link by link from the base, the parameters the textbook regroups
/// into the link before (`YY_j, MZ_j, M_j` for a revolute joint about `z`). The greedy
/// choice in this order keeps the textbook's parameters wherever they are independent,
/// e.g. `XXR_j = XX_j - YY_j` and `ZZR_1 = ZZ_1 + Ia_1 + ...`.
pub fn textbook_order(robot: &crate::Robot, p: usize) -> Vec<usize> {
    let joints = crate::with_model!(&robot.model, m => m.joints.to_vec());
    let n = joints.len();
    let (mut kept, mut regrouped) = (vec![], vec![]);
    for (j, joint) in joints.iter().enumerate() {
        let (own, into_parent) = link_preference(joint.kind, joint.axis.as_slice());
        kept.extend(own.iter().map(|&k| link_col(j, k)));
        regrouped.extend(into_parent.iter().map(|&k| link_col(j, k)));
    }
    let drive = (0..n).flat_map(|j| (0..DRIVE_PARAMS).map(move |k| drive_col(n, j, k)));
    kept.into_iter().chain(drive).chain(regrouped).filter(|&c| c < p).collect()
}

/// A link's 10 inertial parameters (indices in `[m, mcx, mcy, mcz, Ixx, Ixy, Iyy, Ixz,
/// Iyz, Izz]`) split into those its joint leaves on the link and those the textbook
/// regroups into the previous link, for a joint of `kind` about/along `axis` (in the
/// link's frame; the coordinate axis nearest to it names the parameters, so a joint about
/// `y` keeps `ZZ - XX` and regroups `XX, MY, M`).
/// - revolute about `a`, with `(a, b, c)` cyclic: regrouped `I_cc`, `m c_a`, `m`
///   (axis `z`: `YY, MZ, M`); kept the other inertia entries and `m c_b`, `m c_c`;
/// - prismatic: regrouped the six inertia entries (the link does not turn relative to its
///   parent); kept `m c` and `m`.
pub fn link_preference(kind: JointKind, axis: &[f64]) -> (Vec<usize>, Vec<usize>) {
    let inertia = [IXX, IXY, IYY, IXZ, IYZ, IZZ];
    match kind {
        JointKind::Prismatic => (vec![MC, MC + 1, MC + 2, M], inertia.to_vec()),
        JointKind::Revolute => {
            // nearest coordinate axis (ties to the lowest index)
            let a = (0..3).fold(0, |best, k| if axis[k].abs() > axis[best].abs() { k } else { best });
            let (b, c) = ((a + 1) % 3, (a + 2) % 3);
            let diag = [IXX, IYY, IZZ];
            let own_inertia = inertia.iter().cloned().filter(|&k| k != diag[c]);
            let own_moments = [MC + b.min(c), MC + b.max(c)];
            (own_inertia.chain(own_moments).collect(), vec![diag[c], MC + a, M])
        }
    }
}

//! Batch solvers on accumulated statistics: weighted least squares (QR) and the
//! instrumental-variable method, with uncertainty, excitation diagnostics and the
//! Durbin-Wu-Hausman test of LS against IV.
//!
//! # Unexcited directions
//! The data may not excite every parameter (a joint that never moved, a column of
//! zeros, two columns that are equal on this data). The columns of `R` (`RᵀR = ΦᵀWΦ`)
//! are scaled to unit norm and factored by QR with column pivoting (tolerance
//! [`RANK_TOL`](super::base::RANK_TOL) `= 1e-9` relative to the largest pivot, zero
//! columns below `1e-12` of the largest column norm; exactly as in
//! [`BaseParams::from_rows_pivoted`]). Parameters outside the selected set are listed in
//! [`FitReport::unexcited`], get `NaN` estimates, standard deviations and covariance
//! rows, and the fit proceeds on the others (as if the unexcited ones were zero).

use super::accum::{IvAccumulator, LsAccumulator, back_substitute, triangular_factor};
use super::base::{BaseParams, format_sig};
use super::stats::chi2_sf;
use crate::error::{Error, Result};
use crate::linalg;
use nalgebra::{DMatrix, DVector};
use std::fmt;

/// Relative tolerance on the eigenvalues of the (scaled) covariance difference
/// `V_IV - V_LS` in the DWH test: directions below it are treated as "no difference"
/// (e.g. regressors that are their own instruments).
pub const DWH_TOL: f64 = 1e-8;

/// Relative residual `sqrt(rss / yᵀWy)` below which data count as fitted exactly (no
/// noise): the DWH test is then reported with `dof = 0`, `p_value = 1`.
pub const EXACT_FIT_TOL: f64 = 1e-12;

/// Durbin-Wu-Hausman test of `H0: LS is consistent` (the regressor is uncorrelated with
/// the noise) against the IV estimate:
/// `H = dᵀ (V_IV - V_LS)⁺ d`, `d = θ_IV - θ_LS`, `H ~ χ²(dof)` under `H0`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DwhTest {
    /// The statistic `H`.
    pub statistic: f64,
    /// Degrees of freedom: rank of `V_IV - V_LS`.
    pub dof: usize,
    /// `P(χ²(dof) > H)`.
    pub p_value: f64,
    /// `p_value < 0.01`: the LS estimate is biased at the 1 % level.
    pub ls_biased: bool,
    /// The parameter (index) where `|θ_IV - θ_LS|` is largest in units of its own standard
    /// deviation `sqrt(Var(d)_jj)`, and that ratio (`None` without a tested direction).
    pub worst: Option<(usize, f64)>,
}

/// Result of a batch fit.
#[derive(Debug, Clone, PartialEq)]
pub struct FitReport {
    /// `"LS"` or `"IV"`.
    pub method: String,
    /// Parameter names (as given).
    pub names: Vec<String>,
    /// Estimates (`NaN` for unexcited parameters).
    pub theta: Vec<f64>,
    /// Standard deviations `sqrt(diag(covariance))`.
    pub std: Vec<f64>,
    /// `100 std / |theta|` (infinite when `theta == 0`).
    pub rel_std_pct: Vec<f64>,
    /// `p x p` covariance of `theta` (`NaN` rows/columns for unexcited parameters).
    pub covariance: DMatrix<f64>,
    /// Noise variance estimate `rss / (rows - rank)` (for unit weights; with weights
    /// `w = 1/σ_i²` it should be near 1). `NaN` when `rows <= rank`.
    pub sigma2: f64,
    /// Rows used (positive weight).
    pub rows: usize,
    /// Number of estimated parameters (excited directions).
    pub rank: usize,
    /// Condition number `σ_max / σ_min` of `R` restricted to the estimated parameters
    /// (`RᵀR = ΦᵀWΦ`; unscaled, so it includes the parameters' unit scaling).
    pub condition_number: f64,
    /// Names of parameters not excited by this data (estimates `NaN`).
    pub unexcited: Vec<String>,
    /// Durbin-Wu-Hausman test (IV fits only).
    pub dwh: Option<DwhTest>,
    /// The LS estimate on the same data (IV fits only).
    pub theta_ls: Option<Vec<f64>>,
}

/// The LS solution restricted to the excited columns `sel`: `r_sel` is the
/// `(b+1) x (b+1)` triangular factor of `[√W Φ[:, sel] | √W y]`.
struct LsCore {
    sel: Vec<usize>,
    unexcited: Vec<usize>,
    r_sel: DMatrix<f64>,
    /// `R_aug` of all columns.
    r_aug: DMatrix<f64>,
}

impl LsCore {
    fn b(&self) -> usize {
        self.sel.len()
    }

    /// `θ_sel = R11⁻¹ (Q₁ᵀ√W y)` by back substitution.
    fn theta(&self) -> Vec<f64> {
        let b = self.b();
        let rhs: Vec<f64> = (0..b).map(|i| self.r_sel[(i, b)]).collect();
        back_substitute(&self.r_sel.view((0, 0), (b, b)), &rhs)
    }

    /// `rss = R_sel[b,b]²`.
    fn rss(&self) -> f64 {
        let b = self.b();
        self.r_sel[(b, b)].powi(2)
    }

    /// `R11⁻¹` by back substitution on the columns of the identity.
    fn r_inv(&self) -> DMatrix<f64> {
        let b = self.b();
        let r11 = self.r_sel.view((0, 0), (b, b));
        let mut inv = DMatrix::zeros(b, b);
        for c in 0..b {
            let mut e = vec![0.0; b];
            e[c] = 1.0;
            inv.set_column(c, &DVector::from_vec(back_substitute(&r11, &e)));
        }
        inv
    }

    /// `(ΦᵀWΦ)⁻¹ = R⁻¹ R⁻ᵀ` on the selected columns.
    fn unscaled_cov(&self) -> DMatrix<f64> {
        let ri = self.r_inv();
        &ri * ri.transpose()
    }

    /// `σ_max / σ_min` of `R11`.
    fn condition_number(&self) -> f64 {
        let b = self.b();
        if b == 0 {
            return f64::NAN;
        }
        let sv = self.r_sel.view((0, 0), (b, b)).into_owned().singular_values();
        let (mx, mn) = sv.iter().fold((0.0f64, f64::INFINITY), |(a, c), &s| (a.max(s), c.min(s)));
        mx / mn
    }
}

/// Splits the columns into excited / unexcited (see the module docs) and triangularises
/// `[R_aug[:, sel], R_aug[:, p]]`.
fn ls_core(acc: &LsAccumulator) -> LsCore {
    let p = acc.p();
    let r_aug = acc.r_aug();
    let r = r_aug.view((0, 0), (p, p)).into_owned();
    let split = BaseParams::from_rows_pivoted(&r, &[]);
    let sel = split.independent;
    let mut a = DMatrix::zeros(p + 1, sel.len() + 1);
    for (c, &j) in sel.iter().enumerate() {
        a.set_column(c, &r_aug.column(j));
    }
    a.set_column(sel.len(), &r_aug.column(p));
    LsCore { r_sel: triangular_factor(&a), sel, unexcited: split.dependent, r_aug }
}

fn check_names(names: &[String], p: usize) -> Result<()> {
    if names.len() != p {
        return Err(Error::Dimension { what: "names".into(), expected: p, got: names.len() });
    }
    Ok(())
}

/// `rss / (rows - rank)`, `NaN` without residual degrees of freedom.
fn sigma2(rss: f64, rows: usize, rank: usize) -> f64 {
    if rows > rank { rss / (rows - rank) as f64 } else { f64::NAN }
}

/// Spreads a vector on `sel` into a length-`p` vector (`NaN` elsewhere).
fn scatter(p: usize, sel: &[usize], v: &[f64]) -> Vec<f64> {
    let mut out = vec![f64::NAN; p];
    for (&j, &x) in sel.iter().zip(v) {
        out[j] = x;
    }
    out
}

/// Spreads a `b x b` matrix on `sel` into `p x p` (`NaN` elsewhere).
fn scatter_mat(p: usize, sel: &[usize], m: &DMatrix<f64>) -> DMatrix<f64> {
    let mut out = DMatrix::from_element(p, p, f64::NAN);
    for (a, &i) in sel.iter().enumerate() {
        for (b, &j) in sel.iter().enumerate() {
            out[(i, j)] = m[(a, b)];
        }
    }
    out
}

/// Fills `std` and `rel_std_pct` from the covariance.
fn std_and_rel(theta: &[f64], cov: &DMatrix<f64>) -> (Vec<f64>, Vec<f64>) {
    let std: Vec<f64> =
        (0..theta.len()).map(|i| cov[(i, i)]).map(|c| if c.is_nan() { f64::NAN } else { c.max(0.0).sqrt() }).collect();
    let rel =
        theta.iter().zip(&std).map(|(&t, &s)| if t == 0.0 { f64::INFINITY } else { 100.0 * s / t.abs() }).collect();
    (std, rel)
}

/// Weighted least squares on the accumulated statistics:
/// `θ = R⁻¹ Q₁ᵀ√W y` (back substitution), `σ² = rss / (rows - rank)`,
/// `cov = σ² (RᵀR)⁻¹ = σ² R⁻¹ R⁻ᵀ` (via `R⁻¹`, never by inverting `RᵀR`).
/// Unexcited parameters are reported and get `NaN` (module docs).
pub fn fit_ls(acc: &LsAccumulator, names: &[String]) -> Result<FitReport> {
    let p = acc.p();
    check_names(names, p)?;
    let core = ls_core(acc);
    let s2 = sigma2(core.rss(), acc.rows(), core.b());
    let theta = scatter(p, &core.sel, &core.theta());
    let covariance = scatter_mat(p, &core.sel, &(core.unscaled_cov() * s2));
    let (std, rel_std_pct) = std_and_rel(&theta, &covariance);
    Ok(FitReport {
        method: "LS".into(),
        names: names.to_vec(),
        theta,
        std,
        rel_std_pct,
        covariance,
        sigma2: s2,
        rows: acc.rows(),
        rank: core.b(),
        condition_number: core.condition_number(),
        unexcited: core.unexcited.iter().map(|&j| names[j].clone()).collect(),
        dwh: None,
        theta_ls: None,
    })
}

/// Sub-matrix `m[sel, sel]`.
fn sub(m: &DMatrix<f64>, sel: &[usize]) -> DMatrix<f64> {
    DMatrix::from_fn(sel.len(), sel.len(), |a, b| m[(sel[a], sel[b])])
}

/// Instrumental variables on the accumulated statistics (paper's IV method, square `Z`):
///
/// - `θ_IV = (ZᵀWΦ)⁻¹ ZᵀWy` by a fully pivoted LU solve (no explicit inverse);
/// - `rss = ‖√W (y - Φ θ_IV)‖² = ‖R_aug [θ_IV; -1]‖²` (the same number as
///   `yᵀWy - 2θᵀΦᵀWy + θᵀΦᵀWΦθ` with `ΦᵀWΦ = RᵀR`, without its cancellation);
/// - `σ² = rss / (rows - rank)`, `cov = σ² (ZᵀWΦ)⁻¹ (ZᵀWZ) (ΦᵀWZ)⁻¹`;
/// - the Durbin-Wu-Hausman test of LS against IV (see [`DwhTest`]), both covariances
///   with the IV `σ²` (skipped, `dof = 0`, when the data fit exactly: [`EXACT_FIT_TOL`]); `theta_ls` holds the LS estimate.
///
/// Parameters unexcited in `Φ` are dropped from both `Φ` and `Z`. Errors with
/// `Singular` when `ZᵀWΦ` on the excited columns is singular (irrelevant instruments).
pub fn fit_iv(acc: &IvAccumulator, names: &[String]) -> Result<FitReport> {
    let p = acc.p();
    check_names(names, p)?;
    let core = ls_core(acc.ls());
    let (sel, b) = (&core.sel, core.b());
    let a = sub(acc.ztwphi(), sel);
    let g = DVector::from_fn(b, |i, _| acc.ztwy()[sel[i]]);
    let lu = a.clone().full_piv_lu();
    let sv = a.singular_values();
    let smax = sv.iter().cloned().fold(0.0, f64::max);
    if b > 0 && !(sv.iter().cloned().fold(f64::INFINITY, f64::min) > 1e-13 * smax) {
        return Err(Error::Core(ivdyn_core::Error::Singular));
    }
    let theta_sel = lu.solve(&g).ok_or(Error::Core(ivdyn_core::Error::Singular))?;

    // rss from the stored factor: ‖R_aug [θ; -1]‖² (unexcited entries as 0).
    let mut v = DVector::zeros(p + 1);
    for (i, &j) in sel.iter().enumerate() {
        v[j] = theta_sel[i];
    }
    v[p] = -1.0;
    let rss = (&core.r_aug * v).norm_squared();
    let s2 = sigma2(rss, acc.rows(), b);

    // V_IV = σ² A⁻¹ S A⁻ᵀ with two LU solves: X = A⁻¹ S, V = A⁻¹ Xᵀ.
    let s = sub(acc.ztwz(), sel);
    let x = lu.solve(&s).ok_or(Error::Core(ivdyn_core::Error::Singular))?;
    let v_iv = lu.solve(&x.transpose()).ok_or(Error::Core(ivdyn_core::Error::Singular))? * s2;
    let v_iv = (&v_iv + v_iv.transpose()) * 0.5;
    let v_ls = core.unscaled_cov() * s2;
    let theta_ls_sel = core.theta();
    let d = DVector::from_fn(b, |i, _| theta_sel[i] - theta_ls_sel[i]);
    // With an exact fit (rss at rounding level) both estimates agree to rounding and
    // the scale-free statistic would only measure rounding noise: no test.
    let dwh = if rss <= EXACT_FIT_TOL * EXACT_FIT_TOL * acc.sum_wyy() {
        DwhTest { statistic: 0.0, dof: 0, p_value: 1.0, ls_biased: false, worst: None }
    } else {
        let mut t = dwh_test(&d, &v_iv, &v_ls);
        t.worst = t.worst.map(|(i, z)| (sel[i], z));
        t
    };

    let theta = scatter(p, sel, theta_sel.as_slice());
    let covariance = scatter_mat(p, sel, &v_iv);
    let (std, rel_std_pct) = std_and_rel(&theta, &covariance);
    Ok(FitReport {
        method: "IV".into(),
        names: names.to_vec(),
        theta,
        std,
        rel_std_pct,
        covariance,
        sigma2: s2,
        rows: acc.rows(),
        rank: b,
        condition_number: core.condition_number(),
        unexcited: core.unexcited.iter().map(|&j| names[j].clone()).collect(),
        dwh: Some(dwh),
        theta_ls: Some(scatter(p, sel, &theta_ls_sel)),
    })
}

/// `H = dᵀ (V_IV - V_LS)⁺ d` (Hausman's shortcut: `Var(d) = V_IV - V_LS` when LS is
/// efficient, i.e. iid residuals and weights `1 / σ_i²`); see [`dwh_var`].
pub fn dwh_test(d: &DVector<f64>, v_iv: &DMatrix<f64>, v_ls: &DMatrix<f64>) -> DwhTest {
    dwh_var(d, &(v_iv - v_ls), v_iv)
}

/// `H = dᵀ Var(d)⁺ d`: `Var(d)` is scaled by `s = sqrt(diag V_IV)` (unit free),
/// eigen-decomposed, and eigenvalues above [`DWH_TOL`] times the largest eigenvalue of the
/// scaled `V_IV` (a correlation matrix, so ~1) count towards the pseudo-inverse and the
/// degrees of freedom (directions where the instrument is the regressor itself have
/// `Var(d) = 0` and `d = 0`).
pub fn dwh_var(d: &DVector<f64>, var_d: &DMatrix<f64>, v_iv: &DMatrix<f64>) -> DwhTest {
    let b = d.len();
    let scale: Vec<f64> = (0..b).map(|i| v_iv[(i, i)].max(0.0).sqrt()).collect();
    let unit = |i: usize| if scale[i] > 0.0 { 1.0 / scale[i] } else { 0.0 };
    let diff = DMatrix::from_fn(b, b, |i, j| 0.5 * (var_d[(i, j)] + var_d[(j, i)]) * unit(i) * unit(j));
    let corr = DMatrix::from_fn(b, b, |i, j| v_iv[(i, j)] * unit(i) * unit(j));
    let ds = DVector::from_fn(b, |i, _| d[i] * unit(i));
    // a non-finite variance (a degenerate fit) would never converge: nothing is testable then
    let (Ok(ec), Ok(eig)) = (linalg::sym_eigen(corr, "DWH: V_IV"), linalg::sym_eigen(diff.clone(), "DWH: Var(d)"))
    else {
        return DwhTest { statistic: 0.0, dof: 0, p_value: 1.0, ls_biased: false, worst: None };
    };
    let top = if b > 0 { ec.eigenvalues.iter().cloned().fold(0.0, f64::max) } else { 0.0 };
    let (mut h, mut dof) = (0.0, 0usize);
    for (k, &lambda) in eig.eigenvalues.iter().enumerate() {
        if lambda > DWH_TOL * top {
            let u = eig.eigenvectors.column(k).dot(&ds);
            h += u * u / lambda;
            dof += 1;
        }
    }
    let p_value = if dof == 0 { 1.0 } else { chi2_sf(h, dof as f64) };
    let worst = (0..b)
        .filter(|&i| diff[(i, i)] > DWH_TOL * top)
        .map(|i| (i, ds[i].abs() / diff[(i, i)].sqrt()))
        .max_by(|a, b| a.1.total_cmp(&b.1));
    DwhTest { statistic: h, dof, p_value, ls_biased: p_value < 0.01, worst }
}

/// The DWH test with the variance of `d = θ_IV - θ_LS` computed directly (a sandwich), not
/// by Hausman's shortcut `V_IV - V_LS`, which needs LS to be efficient and fails when the
/// residual is autocorrelated (the parallel filter's low-pass) or the weights are not
/// `1 / σ_i²`. With `θ_IV = G_z ZᵀW y`, `θ_LS = G_φ ΦᵀW y`, `G_z = (ZᵀWΦ)⁻¹`,
/// `G_φ = (ΦᵀWΦ)⁻¹` (statistics `acc`, weights `W`) and the middle statistics `mid`, the
/// same rows accumulated with weights `Λ = W Ω W` (`Ω`: the residual's long-run variance
/// per row, e.g. `w_i² σ_i² c_i` for joint `i` with
/// [`JointAccs::long_run_factor`](crate::ident::joint_acc::JointAccs::long_run_factor)):
///
/// `Var(d) = G_z ZᵀΛZ G_zᵀ - G_z ZᵀΛΦ G_φ - G_φ ΦᵀΛZ G_zᵀ + G_φ ΦᵀΛΦ G_φ`.
///
/// Errors like [`fit_iv`] when `ZᵀWΦ` is singular.
pub fn dwh_sandwich(acc: &IvAccumulator, mid: &IvAccumulator) -> Result<DwhTest> {
    let core = ls_core(acc.ls());
    let (sel, b) = (&core.sel, core.b());
    let a = sub(acc.ztwphi(), sel);
    let lu = a.clone().full_piv_lu();
    let g = DVector::from_fn(b, |i, _| acc.ztwy()[sel[i]]);
    let theta_iv = lu.solve(&g).ok_or(Error::Core(ivdyn_core::Error::Singular))?;
    let theta_ls = core.theta();
    let d = DVector::from_fn(b, |i, _| theta_iv[i] - theta_ls[i]);
    let gz = lu.try_inverse().ok_or(Error::Core(ivdyn_core::Error::Singular))?;
    let gphi = core.unscaled_cov();
    let p = acc.p();
    let r_mid = mid.ls().r_aug();
    let r_mid = r_mid.view((0, 0), (p, p));
    let s_pp = sub(&(r_mid.transpose() * r_mid), sel);
    let (s_zz, s_zp) = (sub(mid.ztwz(), sel), sub(mid.ztwphi(), sel));
    let cross = &gz * &s_zp * &gphi;
    let v_iv = &gz * &s_zz * gz.transpose();
    let var_d = &v_iv - &cross - cross.transpose() + &gphi * s_pp * &gphi;
    let mut t = dwh_var(&d, &var_d, &v_iv);
    t.worst = t.worst.map(|(i, z)| (sel[i], z));
    Ok(t)
}

/// Widest line of [`FitReport`]'s text (Python's `repr`, notebooks, terminals).
pub const REPORT_WIDTH: usize = 100;

/// `text` in lines of at most `width` characters, broken at spaces (a base-parameter name
/// is a sum of many terms); a single word longer than `width` is cut.
pub fn wrap_words(text: &str, width: usize) -> Vec<String> {
    let mut lines = vec![String::new()];
    for word in text.split(' ').filter(|w| !w.is_empty()) {
        let cur = lines.last_mut().expect("never empty");
        if !cur.is_empty() && cur.chars().count() + 1 + word.chars().count() > width {
            lines.push(String::new());
        }
        let cur = lines.last_mut().expect("never empty");
        if !cur.is_empty() {
            cur.push(' ');
        }
        cur.push_str(word);
    }
    lines
        .into_iter()
        .flat_map(|l| {
            let c: Vec<char> = l.chars().collect();
            c.chunks(width.max(1)).map(|k| k.iter().collect::<String>()).collect::<Vec<_>>()
        })
        .collect()
}

impl fmt::Display for FitReport {
    /// One line per parameter, no line wider than [`REPORT_WIDTH`]: a name too long for its
    /// column (a base combination of many terms) gets lines of its own above its numbers.
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        writeln!(
            f,
            "{} fit: {} rows, rank {}/{}, sigma2 = {:.6e}, cond(R) = {:.3e}",
            self.method,
            self.rows,
            self.rank,
            self.theta.len(),
            self.sigma2,
            self.condition_number
        )?;
        let with_ls = self.theta_ls.is_some();
        let numbers = 2 + 14 + 2 + 12 + 2 + 9 + if with_ls { 2 + 14 } else { 0 };
        let longest = self.names.iter().map(|n| n.chars().count()).max().unwrap_or(4).max(9);
        let w = longest.min(REPORT_WIDTH - numbers);
        write!(f, "{:<w$}  {:>14}  {:>12}  {:>9}", "parameter", "theta", "std", "rel %")?;
        if with_ls {
            write!(f, "  {:>14}", "theta_LS")?;
        }
        writeln!(f)?;
        for i in 0..self.theta.len() {
            let name = if self.names[i].chars().count() <= w {
                self.names[i].clone()
            } else {
                for line in wrap_words(&self.names[i], REPORT_WIDTH) {
                    writeln!(f, "{line}")?;
                }
                String::new()
            };
            let (t, s) = (format_sig(self.theta[i], 6), format_sig(self.std[i], 3));
            write!(f, "{name:<w$}  {t:>14}  {s:>12}  {:>9.2}", self.rel_std_pct[i])?;
            if let Some(ls) = &self.theta_ls {
                write!(f, "  {:>14}", format_sig(ls[i], 6))?;
            }
            writeln!(f)?;
        }
        if !self.unexcited.is_empty() {
            let text = format!("not excited by this data (not estimated): {}", self.unexcited.join(", "));
            for line in wrap_words(&text, REPORT_WIDTH) {
                writeln!(f, "{line}")?;
            }
        }
        if let Some(t) = &self.dwh {
            writeln!(
                f,
                "Durbin-Wu-Hausman LS vs IV: H = {:.4} (dof {}), p = {:.4e}{}",
                t.statistic,
                t.dof,
                t.p_value,
                if t.ls_biased { ": LS is biased, use IV" } else { ": no evidence of LS bias" }
            )?;
        }
        Ok(())
    }
}

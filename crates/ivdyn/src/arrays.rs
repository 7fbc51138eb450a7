//! Identification and log reading on plain row-major arrays: the entry points of the
//! Python bindings (`crates/ivdyn-py`), usable from Rust as well.
//!
//! - [`fit_ls_rows`] / [`fit_iv_rows`]: a whole batch fit from `m x p` row-major arrays,
//!   streamed through [`LsAccumulator`] / [`IvAccumulator`] (memory independent of `m`);
//! - [`RecursiveLs`] / [`RecursiveIv`]: the core's recursive estimators with a run-time
//!   parameter count (`nalgebra::Dyn`) fed from slices;
//! - [`read_joint_log`]: an MCAP or CSV log, chosen by the file extension;
//! - [`not_identifiable_message`]: the text of a [`NotIdentifiable`] payload;
//! - [`flatten3`]: nested estimates (`[a][b] -> [c]`) as one row-major array.
//!
//! ```
//! use ivdyn::arrays::fit_ls_rows;
//! // y = 2 x + 1 on three rows
//! let phi = [0.0, 1.0, 1.0, 1.0, 2.0, 1.0];
//! let fit = fit_ls_rows(&phi, &[1.0, 3.0, 5.0], None, &["a".into(), "b".into()]).unwrap();
//! assert!((fit.theta[0] - 2.0).abs() < 1e-12 && (fit.theta[1] - 1.0).abs() < 1e-12);
//! ```

use std::path::Path;

use crate::error::{Error, Result};
use crate::ident::{FitReport, IvAccumulator, LsAccumulator, NotIdentifiable, fit_iv, fit_ls};
use crate::io::{JointLog, ReadOptions, read_csv, read_mcap};
use ivdyn_core::estim::{Riv, Rls};
use nalgebra::{DVector, Dyn};

/// Rows handed to an accumulator per call (bounds nothing but the granularity of the
/// input checks: the accumulators buffer and absorb rows in blocks themselves).
const CHUNK_ROWS: usize = 1 << 16;

/// `"theta[0]"`, ..., `"theta[p-1]"`.
pub fn default_names(p: usize) -> Vec<String> {
    (0..p).map(|j| format!("theta[{j}]")).collect()
}

fn check_len(what: &str, expected: usize, got: usize) -> Result<()> {
    if expected != got {
        return Err(Error::Dimension { what: what.into(), expected, got });
    }
    Ok(())
}

/// Weighted least squares of `y ≈ Φ θ` (`phi`: `m x p` row-major with `p = names.len()`,
/// `y`, `w`: `m`; `w` are inverse variances, default 1) through [`LsAccumulator`] and
/// [`fit_ls`].
pub fn fit_ls_rows(phi: &[f64], y: &[f64], w: Option<&[f64]>, names: &[String]) -> Result<FitReport> {
    let (p, m) = (names.len(), y.len());
    check_len("phi (rows x p, row-major)", m * p, phi.len())?;
    if let Some(w) = w {
        check_len("w", m, w.len())?;
    }
    let mut acc = LsAccumulator::new(p);
    for s in (0..m).step_by(CHUNK_ROWS) {
        let e = (s + CHUNK_ROWS).min(m);
        acc.add_rows(&phi[s * p..e * p], &y[s..e], w.map(|w| &w[s..e]))?;
    }
    acc.finish();
    fit_ls(&acc, names)
}

/// Instrumental variables `θ = (ZᵀWΦ)⁻¹ ZᵀWy` (`phi`, `z`: `m x p` row-major, `p =
/// names.len()`) through [`IvAccumulator`] and [`fit_iv`] (with the LS estimate and the
/// Durbin-Wu-Hausman test).
pub fn fit_iv_rows(phi: &[f64], z: &[f64], y: &[f64], w: Option<&[f64]>, names: &[String]) -> Result<FitReport> {
    let (p, m) = (names.len(), y.len());
    check_len("phi (rows x p, row-major)", m * p, phi.len())?;
    check_len("z (rows x p, row-major)", m * p, z.len())?;
    if let Some(w) = w {
        check_len("w", m, w.len())?;
    }
    let mut acc = IvAccumulator::new(p);
    for s in (0..m).step_by(CHUNK_ROWS) {
        let e = (s + CHUNK_ROWS).min(m);
        acc.add_rows(&phi[s * p..e * p], &z[s * p..e * p], &y[s..e], w.map(|w| &w[s..e]))?;
    }
    acc.finish();
    fit_iv(&acc, names)
}

fn check_start(p: usize, p0: f64, forgetting: f64) -> Result<()> {
    if p == 0 {
        return Err(Error::Estimation { msg: "recursive estimator: p must be at least 1".into() });
    }
    if !(p0 > 0.0 && p0.is_finite()) {
        return Err(Error::Estimation { msg: format!("recursive estimator: p0 must be finite and > 0, got {p0}") });
    }
    if !(forgetting > 0.0 && forgetting <= 1.0) {
        return Err(Error::Estimation { msg: format!("recursive estimator: forgetting must be in (0, 1], got {forgetting}") });
    }
    Ok(())
}

/// Row `i` of the optional weights (1 when absent).
fn weight(w: Option<&[f64]>, i: usize) -> f64 {
    w.map_or(1.0, |w| w[i])
}

/// Recursive least squares ([`ivdyn_core::estim::Rls`], Bierman UD form) with `p`
/// parameters chosen at run time, starting from `θ = 0`, `P = p0 I`.
#[derive(Debug, Clone)]
pub struct RecursiveLs {
    inner: Rls<Dyn>,
    phi: DVector<f64>,
}

impl RecursiveLs {
    /// `p` parameters, initial covariance `p0 I` (`p0 > 0`), forgetting factor in `(0, 1]`.
    pub fn new(p: usize, p0: f64, forgetting: f64) -> Result<Self> {
        check_start(p, p0, forgetting)?;
        let mut inner = Rls::new(DVector::zeros(p), p0);
        inner.forgetting = forgetting;
        Ok(Self { inner, phi: DVector::zeros(p) })
    }

    /// Number of parameters.
    pub fn p(&self) -> usize {
        self.phi.len()
    }

    /// One row `y = φ·θ + e` with weight `w > 0`; the state is unchanged on error.
    pub fn update(&mut self, phi: &[f64], y: f64, w: f64) -> Result<()> {
        check_len("phi", self.p(), phi.len())?;
        self.phi.copy_from_slice(phi);
        self.inner.update(&self.phi, y, w)?;
        Ok(())
    }

    /// `m` rows (`phi`: `m x p` row-major) in order. Stops at the first bad row with
    /// [`Error::Sample`] naming it; the rows before it stay applied.
    pub fn update_many(&mut self, phi: &[f64], y: &[f64], w: Option<&[f64]>) -> Result<()> {
        let (p, m) = (self.p(), y.len());
        check_len("phi (rows x p, row-major)", m * p, phi.len())?;
        if let Some(w) = w {
            check_len("w", m, w.len())?;
        }
        for i in 0..m {
            self.phi.copy_from_slice(&phi[i * p..(i + 1) * p]);
            self.inner
                .update(&self.phi, y[i], weight(w, i))
                .map_err(|source| Error::Sample { index: i, source })?;
        }
        Ok(())
    }

    /// Current estimate.
    pub fn theta(&self) -> &[f64] {
        self.inner.theta.as_slice()
    }

    /// Covariance `U D Uᵀ` (`p x p`, row-major; symmetric).
    pub fn covariance(&self) -> Vec<f64> {
        self.inner.covariance().transpose().as_slice().to_vec()
    }

    /// Rows processed.
    pub fn count(&self) -> u64 {
        self.inner.count
    }

    /// Forgetting factor.
    pub fn forgetting(&self) -> f64 {
        self.inner.forgetting
    }
}

/// Recursive instrumental variables ([`ivdyn_core::estim::Riv`]) with `p` parameters
/// chosen at run time, starting from `θ = 0`, `P = p0 I`.
#[derive(Debug, Clone)]
pub struct RecursiveIv {
    inner: Riv<Dyn>,
    phi: DVector<f64>,
    z: DVector<f64>,
}

impl RecursiveIv {
    /// `p` parameters, initial `P = p0 I` (`p0 > 0`), forgetting factor in `(0, 1]`.
    pub fn new(p: usize, p0: f64, forgetting: f64) -> Result<Self> {
        check_start(p, p0, forgetting)?;
        let mut inner = Riv::new(DVector::zeros(p), p0);
        inner.forgetting = forgetting;
        Ok(Self { inner, phi: DVector::zeros(p), z: DVector::zeros(p) })
    }

    /// Number of parameters.
    pub fn p(&self) -> usize {
        self.phi.len()
    }

    /// One row with regressor `φ`, instrument `z`, output `y`, weight `w > 0`; the state is
    /// unchanged on error.
    pub fn update(&mut self, phi: &[f64], z: &[f64], y: f64, w: f64) -> Result<()> {
        check_len("phi", self.p(), phi.len())?;
        check_len("z", self.p(), z.len())?;
        self.phi.copy_from_slice(phi);
        self.z.copy_from_slice(z);
        self.inner.update(&self.phi, &self.z, y, w)?;
        Ok(())
    }

    /// `m` rows (`phi`, `z`: `m x p` row-major) in order; stops at the first bad row with
    /// [`Error::Sample`] naming it (the rows before it stay applied).
    pub fn update_many(&mut self, phi: &[f64], z: &[f64], y: &[f64], w: Option<&[f64]>) -> Result<()> {
        let (p, m) = (self.p(), y.len());
        check_len("phi (rows x p, row-major)", m * p, phi.len())?;
        check_len("z (rows x p, row-major)", m * p, z.len())?;
        if let Some(w) = w {
            check_len("w", m, w.len())?;
        }
        for i in 0..m {
            self.phi.copy_from_slice(&phi[i * p..(i + 1) * p]);
            self.z.copy_from_slice(&z[i * p..(i + 1) * p]);
            self.inner
                .update(&self.phi, &self.z, y[i], weight(w, i))
                .map_err(|source| Error::Sample { index: i, source })?;
        }
        Ok(())
    }

    /// Current estimate.
    pub fn theta(&self) -> &[f64] {
        self.inner.theta.as_slice()
    }

    /// `P = (Σ w z φᵀ)⁻¹` (`p x p`, row-major; not symmetric in general).
    pub fn p_matrix(&self) -> Vec<f64> {
        self.inner.p.transpose().as_slice().to_vec()
    }

    /// Rows processed.
    pub fn count(&self) -> u64 {
        self.inner.count
    }

    /// Forgetting factor.
    pub fn forgetting(&self) -> f64 {
        self.inner.forgetting
    }
}

/// Reads a joint log by extension: `.mcap` with [`read_mcap`] (measured `topic`, optional
/// `command_topic` for `u`), `.csv` with [`read_csv`] (the topics are not used). Joints
/// come out in the order of `joint_names`.
pub fn read_joint_log(
    path: impl AsRef<Path>,
    joint_names: &[String],
    topic: &str,
    command_topic: Option<&str>,
) -> Result<JointLog> {
    let path = path.as_ref();
    let ext = path.extension().and_then(|e| e.to_str()).map(|e| e.to_ascii_lowercase());
    match ext.as_deref() {
        Some("mcap") => {
            let mut opts = ReadOptions::new(joint_names).topic(topic);
            if let Some(c) = command_topic {
                opts = opts.command_topic(c);
            }
            read_mcap(path, &opts)
        }
        Some("csv") => read_csv(path, joint_names),
        _ => Err(Error::Log {
            file: path.to_path_buf(),
            msg: "unknown log format: expected a .mcap or .csv file".into(),
        }),
    }
}

/// `"payload not identifiable from this data: link6.m*cx (in link6.m*cx + 0.1*link5.m), ..."`.
pub fn not_identifiable_message(n: &NotIdentifiable) -> String {
    let parts: Vec<String> =
        n.parameters.iter().zip(&n.combined_in).map(|(p, c)| format!("{p} (in {c})")).collect();
    format!("payload not identifiable from this data: {}", parts.join(", "))
}

/// `x[a][b][c]` (every `x[a][b]` of length `inner`) as one row-major array of shape
/// `(x.len(), x[0].len(), inner)`; returns the data and the two outer sizes.
pub fn flatten3(x: &[Vec<Vec<f64>>], inner: usize) -> Result<(Vec<f64>, usize, usize)> {
    let (a, b) = (x.len(), x.first().map_or(0, |v| v.len()));
    let mut out = Vec::with_capacity(a * b * inner);
    for row in x {
        check_len("estimates per estimator", b, row.len())?;
        for v in row {
            check_len("estimate", inner, v.len())?;
            out.extend_from_slice(v);
        }
    }
    Ok((out, a, b))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rls_matches_ls_and_errors_name_the_row() {
        let phi = [1.0, 0.0, 0.0, 1.0, 1.0, 1.0, 2.0, -1.0];
        let y = [1.0, 2.0, 3.0, 0.0];
        let mut r = RecursiveLs::new(2, 1e10, 1.0).unwrap();
        r.update_many(&phi, &y, None).unwrap();
        let fit = fit_ls_rows(&phi, &y, None, &default_names(2)).unwrap();
        for j in 0..2 {
            assert!((r.theta()[j] - fit.theta[j]).abs() < 1e-6);
        }
        let e = r.update_many(&[1.0, f64::NAN], &[1.0], None).unwrap_err();
        assert!(e.to_string().starts_with("sample 0:"), "{e}");
        assert!(RecursiveIv::new(0, 1.0, 1.0).is_err());
    }

    #[test]
    fn read_joint_log_rejects_unknown_extension() {
        let e = read_joint_log("x.bag", &["a".into()], "/joint_states", None).unwrap_err();
        assert!(e.to_string().contains(".mcap or .csv"), "{e}");
    }
}

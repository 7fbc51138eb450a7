//! Identification on plain row-major arrays: the entry points of the
//! Python bindings (`crates/ivdyn-py`), usable from Rust as well.
//!
//! - [`fit_ls_rows`] / [`fit_iv_rows`]: a whole batch fit from `m x p` row-major arrays,
//!   streamed through [`LsAccumulator`] / [`IvAccumulator`] (memory independent of `m`);
//! - [`RecursiveLs`] / [`RecursiveIv`]: the core's recursive estimators with a run-time
//!   parameter count (`nalgebra::Dyn`) fed from slices;
//! - [`not_identifiable_message`]: the text of a [`NotIdentifiable`] payload;
//! - [`flatten3`]: nested estimates (`[a][b] -> [c]`) as one row-major array;
//! - [`terminal_link_run`] / [`terminal_base`]: the core's terminal-link estimator over
//!   `T x N` arrays (any joint count), and its identifiable columns.
//!
//! ```
//! use ivdyn::ident::arrays::fit_ls_rows;
//! // y = 2 x + 1 on three rows
//! let phi = [0.0, 1.0, 1.0, 1.0, 2.0, 1.0];
//! let fit = fit_ls_rows(&phi, &[1.0, 3.0, 5.0], None, &["a".into(), "b".into()]).unwrap();
//! assert!((fit.theta[0] - 2.0).abs() < 1e-12 && (fit.theta[1] - 1.0).abs() < 1e-12);
//! ```

use std::f64::consts::PI;

use crate::Robot;
use crate::error::{Error, Result};
use crate::ident::{BaseParams, FitReport, IvAccumulator, LsAccumulator, NotIdentifiable, fit_iv, fit_ls};
use ivdyn_core::estim::{InstrumentModel, Riv, Rls, TerminalLink, TerminalSpec};
use ivdyn_core::rng::Rng;
use ivdyn_core::{Data, Model, VecN, regressor};
use nalgebra::{DMatrix, DVector, Dyn};

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

/// Most parameters of a [`RecursiveLs`]: its covariance is `p x p` and allocated up front,
/// so `Rls(30000)` asked for 7 GB and aborted the interpreter. 4096 is a 128 MB covariance,
/// 40x the parameters of a 7-joint arm with every drive term.
pub const MAX_RLS_PARAMS: usize = 4096;

fn check_start(p: usize, p0: f64, forgetting: f64) -> Result<()> {
    if p == 0 || p > MAX_RLS_PARAMS {
        return Err(Error::option(
            "p",
            format!(
                "must be in 1..={MAX_RLS_PARAMS}, got {p} (parameters of the recursive estimator; its covariance is p x p)"
            ),
        ));
    }
    if !(p0 > 0.0 && p0.is_finite()) {
        return Err(Error::option(
            "p0",
            format!("must be finite and > 0, got {p0} (initial covariance of the recursive estimator)"),
        ));
    }
    if !(forgetting > 0.0 && forgetting <= 1.0) {
        return Err(Error::option(
            "forgetting",
            format!("must be in (0, 1], got {forgetting} (forgetting factor of the recursive estimator)"),
        ));
    }
    Ok(())
}

/// `max_variance` of a recursive estimator: finite and `> 0`.
fn check_max_variance(v: f64) -> Result<()> {
    if v > 0.0 && v.is_finite() {
        return Ok(());
    }
    Err(Error::option(
        "max_variance",
        format!("must be finite and > 0, got {v} (anti-windup bound on the covariance under forgetting; default p0)"),
    ))
}

/// `outlier_gate` of a recursive estimator: `> 0`, infinity = no gate.
fn check_outlier_gate(g: f64) -> Result<()> {
    if g > 0.0 {
        return Ok(());
    }
    Err(Error::option(
        "outlier_gate",
        format!(
            "must be > 0 (inf or None = no gate), got {g} (largest normalised innovation |e| / sqrt(1/w + phi^T P phi) accepted)"
        ),
    ))
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
            self.inner.update(&self.phi, y[i], weight(w, i)).map_err(|source| Error::Sample { index: i, source })?;
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

    /// Anti-windup bound on each `d_j` of `P = U D Uᵀ` under forgetting (default `p0`).
    pub fn max_variance(&self) -> f64 {
        self.inner.max_variance
    }

    /// Sets [`Self::max_variance`] (finite, `> 0`).
    pub fn set_max_variance(&mut self, v: f64) -> Result<()> {
        check_max_variance(v)?;
        self.inner.max_variance = v;
        Ok(())
    }

    /// Largest normalised innovation accepted (infinity = no gate, the default).
    pub fn outlier_gate(&self) -> f64 {
        self.inner.outlier_gate
    }

    /// Sets [`Self::outlier_gate`] (`> 0`; infinity = no gate).
    pub fn set_outlier_gate(&mut self, g: f64) -> Result<()> {
        check_outlier_gate(g)?;
        self.inner.outlier_gate = g;
        Ok(())
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

    /// Anti-windup bound on each `|P_ii|` under forgetting (default `p0`).
    pub fn max_variance(&self) -> f64 {
        self.inner.max_variance
    }

    /// Sets [`Self::max_variance`] (finite, `> 0`).
    pub fn set_max_variance(&mut self, v: f64) -> Result<()> {
        check_max_variance(v)?;
        self.inner.max_variance = v;
        Ok(())
    }

    /// Largest normalised innovation accepted (infinity = no gate, the default).
    pub fn outlier_gate(&self) -> f64 {
        self.inner.outlier_gate
    }

    /// Sets [`Self::outlier_gate`] (`> 0`; infinity = no gate).
    pub fn set_outlier_gate(&mut self, g: f64) -> Result<()> {
        check_outlier_gate(g)?;
        self.inner.outlier_gate = g;
        Ok(())
    }
}

/// `"payload not identifiable from this data: link6.m*cx (in link6.m*cx + 0.1*link5.m), ..."`.
pub fn not_identifiable_message(n: &NotIdentifiable) -> String {
    let parts: Vec<String> = n.parameters.iter().zip(&n.combined_in).map(|(p, c)| format!("{p} (in {c})")).collect();
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

// ------------------------------------------------------------------ terminal link, batch

/// Instrument of [`terminal_link_run`] with the IV method.
#[derive(Debug, Clone, Copy)]
pub enum TerminalInstrument<'a> {
    /// No instrument (least squares).
    None,
    /// Instrumental accelerations `T x N` (e.g. the planned `qdd` of the trajectory).
    Qdd(&'a [f64]),
    /// The paper's eq-35 model driven by the actuator command `u` (`T x N`), with the
    /// "rough prior" coefficients of the nominal model at the mean measured pose
    /// ([`InstrumentModel::from_nominal`]); sample `j` uses `u(j)` and `qd(j-1)`, so
    /// sample 0 is not used.
    Eq35(&'a [f64]),
}

/// Settings of [`terminal_link_run`].
#[derive(Debug, Clone)]
pub struct TerminalOptions {
    /// Unknown links and rows (paper eqs 38-46).
    pub spec: TerminalSpec,
    /// Estimated columns (indices into `0..spec.cols(N)`), normally [`terminal_base`]'s
    /// `independent`.
    pub columns: Vec<usize>,
    /// Weight of each joint's row (`N`; only the rows of `spec` are used).
    pub row_weight: Vec<f64>,
    /// Instrumental variables (`true`) or least squares.
    pub iv: bool,
    /// Initial covariance scale `P0 = p0 I`.
    pub p0: f64,
    /// Rows of joints slower than this (rad/s) are skipped.
    pub min_speed: f64,
    /// Sample counts (strictly increasing) after which the estimate is recorded.
    pub record: Vec<usize>,
}

/// What [`terminal_link_run`] returns.
#[derive(Debug, Clone, PartialEq)]
pub struct TerminalRun {
    /// Final estimate of the selected columns' changes.
    pub theta: Vec<f64>,
    /// Estimates after each `record` count, `len(record) x B` row-major.
    pub trace: Vec<f64>,
    /// Final `P` (`B x B` row-major): the covariance for LS, `(sum w z phi^T)^-1` for IV.
    pub p: Vec<f64>,
    /// Rows used and skipped (slow joints).
    pub rows_used: u64,
    /// Rows skipped.
    pub rows_skipped: u64,
}

/// Names of the terminal unknowns of `robot`: `"<link>.m"`, ..., `"<joint>.fv"` (the full
/// parameter names of [`Robot::param_names`] at [`TerminalSpec::theta_index`]).
pub fn terminal_names(robot: &Robot, spec: &TerminalSpec) -> Vec<String> {
    let (n, all) = (robot.dof(), robot.param_names());
    (0..spec.cols(n)).map(|c| all[spec.theta_index(n, c)].clone()).collect()
}

fn check_spec(spec: &TerminalSpec, n: usize) -> Result<()> {
    if spec.k >= n || spec.first_row > spec.k {
        return Err(Error::TerminalLink {
            msg: format!("need first_row <= k < N = {n}, got k = {}, first_row = {}", spec.k, spec.first_row),
        });
    }
    Ok(())
}

/// Identifiable columns of the terminal problem of `robot` (its rows `spec.rows(N)` at
/// `samples` random states: `q` in the joint limits or +-pi, `qd` in +-2 rad/s, `qdd` in
/// +-10 rad/s^2), named by [`terminal_names`].
pub fn terminal_base(robot: &Robot, spec: &TerminalSpec, samples: usize, seed: u64) -> Result<BaseParams> {
    let n = robot.dof();
    check_spec(spec, n)?;
    // the sampled rows are allocated at once
    super::base::check_base_samples(samples)?;
    let names = terminal_names(robot, spec);
    let phi = crate::with_model!(&robot.model, m => terminal_rows_n(&**m, spec, samples, seed));
    Ok(BaseParams::from_rows(&phi, &names))
}

fn terminal_rows_n<const N: usize>(m: &Model<N>, spec: &TerminalSpec, samples: usize, seed: u64) -> DMatrix<f64> {
    let mut rng = Rng::new(seed);
    let rows: Vec<usize> = spec.rows(N).collect();
    let cols = spec.cols(N);
    let mut phi = DMatrix::<f64>::zeros(samples * rows.len(), cols);
    let mut data = Data::<N>::new();
    for s in 0..samples {
        let q = VecN::<N>::from_fn(|j, _| {
            let l = &m.limits[j];
            if l.lower.is_finite() && l.upper.is_finite() && l.upper > l.lower {
                rng.uniform(l.lower, l.upper)
            } else {
                rng.uniform(-PI, PI)
            }
        });
        let qd = VecN::<N>::from_fn(|_, _| rng.uniform(-2.0, 2.0));
        let qdd = VecN::<N>::from_fn(|_, _| rng.uniform(-10.0, 10.0));
        let y = regressor(m, &mut data, &q, &qd, &qdd);
        for (r, &row) in rows.iter().enumerate() {
            for c in 0..cols {
                phi[(s * rows.len() + r, c)] = spec.entry(y, row, c);
            }
        }
    }
    phi
}

/// Runs the online terminal-link estimator ([`ivdyn_core::estim::TerminalLink`], paper
/// eqs 38-54, starting from zero change) over `T` samples of measured `q, qd, qdd, tau`
/// (`T x N` row-major), with `robot` as the nominal model. A bad sample stops the run
/// with [`Error::Sample`] naming it.
pub fn terminal_link_run(
    robot: &Robot,
    opts: &TerminalOptions,
    q: &[f64],
    qd: &[f64],
    qdd: &[f64],
    tau: &[f64],
    instrument: TerminalInstrument<'_>,
) -> Result<TerminalRun> {
    let n = robot.dof();
    check_spec(&opts.spec, n)?;
    let t = q.len() / n;
    check_len("q (T x N)", t * n, q.len())?;
    for (what, x) in [("qd (T x N)", qd), ("qdd (T x N)", qdd), ("tau (T x N)", tau)] {
        check_len(what, t * n, x.len())?;
    }
    match instrument {
        TerminalInstrument::Qdd(z) => check_len("qdd_instr (T x N)", t * n, z.len())?,
        TerminalInstrument::Eq35(u) => check_len("u (T x N)", t * n, u.len())?,
        TerminalInstrument::None if opts.iv => {
            return Err(Error::TerminalLink { msg: "the IV method needs an instrument (qdd_instr or u)".into() });
        }
        TerminalInstrument::None => {}
    }
    check_len("row_weight (one per joint)", n, opts.row_weight.len())?;
    let cols = opts.spec.cols(n);
    if opts.columns.is_empty() {
        return Err(Error::TerminalLink { msg: "no columns to estimate".into() });
    }
    if let Some(&c) = opts.columns.iter().find(|&&c| c >= cols) {
        return Err(Error::TerminalLink {
            msg: format!("column {c} out of range (the unknown set has {cols} columns)"),
        });
    }
    check_start(opts.columns.len(), opts.p0, 1.0)?;
    if opts.record.first() == Some(&0) || opts.record.windows(2).any(|w| w[1] <= w[0]) {
        return Err(Error::TerminalLink { msg: "record must be strictly increasing positive sample counts".into() });
    }
    crate::with_model!(&robot.model, m => terminal_run_n(&**m, opts, t, q, qd, qdd, tau, instrument))
}

#[allow(clippy::too_many_arguments)]
fn terminal_run_n<const N: usize>(
    m: &Model<N>,
    opts: &TerminalOptions,
    t: usize,
    q: &[f64],
    qd: &[f64],
    qdd: &[f64],
    tau: &[f64],
    instrument: TerminalInstrument<'_>,
) -> Result<TerminalRun> {
    use ivdyn_core::estim::terminal::Method;
    let b = opts.columns.len();
    let zero = DVector::<f64>::zeros(b);
    let method = if opts.iv { Method::Iv(Riv::new(zero, opts.p0)) } else { Method::Ls(Rls::new(zero, opts.p0)) };
    let mut w = [0.0; N];
    w.copy_from_slice(&opts.row_weight);
    let mut tl = TerminalLink::<N, Dyn>::new(m.clone(), opts.spec, DVector::from_vec(opts.columns.clone()), w, method);
    tl.min_speed = opts.min_speed;
    let row = |x: &[f64], s: usize| VecN::<N>::from_column_slice(&x[s * N..(s + 1) * N]);
    let eq35 = match instrument {
        TerminalInstrument::Eq35(_) if t > 0 => {
            let mut mean = VecN::<N>::zeros();
            for s in 0..t {
                mean += row(q, s);
            }
            Some(InstrumentModel::from_nominal(m, &mut Data::<N>::new(), &(mean / t as f64)))
        }
        _ => None,
    };
    let mut trace = Vec::with_capacity(opts.record.len() * b);
    let mut next = 0;
    for s in 0..t {
        let (qs, qds, qdds, taus) = (row(q, s), row(qd, s), row(qdd, s), row(tau, s));
        let z = match instrument {
            TerminalInstrument::None => qdds,
            TerminalInstrument::Qdd(z) => row(z, s),
            TerminalInstrument::Eq35(u) => match (&eq35, s) {
                (Some(model), 1..) => model.qdd_hat(&row(u, s), &row(qd, s - 1)),
                _ => VecN::<N>::from_element(f64::NAN),
            },
        };
        let skip = matches!(instrument, TerminalInstrument::Eq35(_)) && s == 0;
        if !skip {
            ivdyn_core::error::check_finite("q", qs.as_slice())
                .and_then(|_| ivdyn_core::error::check_finite("qd", qds.as_slice()))
                .and_then(|_| tl.update(&qs, &qds, &qdds, &taus, &z))
                .map_err(|source| Error::Sample { index: s, source })?;
        }
        while next < opts.record.len() && s + 1 == opts.record[next] {
            trace.extend_from_slice(tl.theta().as_slice());
            next += 1;
        }
    }
    let p = match &tl.method {
        Method::Ls(r) => r.covariance().transpose().as_slice().to_vec(),
        Method::Iv(r) => r.p.transpose().as_slice().to_vec(),
        Method::IvInfo(r) => r.p().transpose().as_slice().to_vec(),
    };
    Ok(TerminalRun {
        theta: tl.theta().as_slice().to_vec(),
        trace,
        p,
        rows_used: tl.rows_used,
        rows_skipped: tl.rows_skipped,
    })
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

    /// The options name themselves; the defaults are the prior and no gate; an absurd row
    /// in a batch is an error naming the sample, with the rows before it applied.
    #[test]
    fn recursive_options_are_checked_and_absurd_rows_named() {
        let mut r = RecursiveLs::new(2, 1e3, 0.99).unwrap();
        assert_eq!((r.max_variance(), r.outlier_gate()), (1e3, f64::INFINITY));
        for v in [0.0, -1.0, f64::NAN, f64::INFINITY] {
            let e = r.set_max_variance(v).unwrap_err().to_string();
            assert!(e.contains("max_variance") && e.contains("finite and > 0"), "{e}");
        }
        for g in [0.0, -3.0, f64::NAN] {
            let e = r.set_outlier_gate(g).unwrap_err().to_string();
            assert!(e.contains("outlier_gate"), "{e}");
        }
        r.set_outlier_gate(f64::INFINITY).unwrap();
        let mut v = RecursiveIv::new(2, 1e3, 0.99).unwrap();
        assert!(v.set_max_variance(-1.0).is_err() && v.set_outlier_gate(f64::NAN).is_err());
        v.set_max_variance(10.0).unwrap();
        assert_eq!(v.max_variance(), 10.0);
        let e = r.update_many(&[1.0, 0.0, 1e150, 1e150], &[1.0, 1.0], Some(&[1.0, 1e300])).unwrap_err();
        assert!(e.to_string().starts_with("sample 1: row out of range"), "{e}");
        assert_eq!(r.count(), 1);
    }

    /// Exact data of the paper's arm with 0.5 kg added to its last link: least squares on
    /// the payload's identifiable columns recovers the change (projected on them).
    #[test]
    fn terminal_link_run_recovers_an_exact_payload() {
        let robot = Robot::paper();
        let n = robot.dof();
        let spec = TerminalSpec::payload(n);
        let base = terminal_base(&robot, &spec, 60, 3).unwrap();
        let mut truth = robot.clone();
        let mut th = truth.params();
        let dx = [0.5, 0.01, -0.02, 0.03, 2e-3, 1e-4, 3e-3, -2e-4, 1e-4, 1e-3];
        for (k, d) in dx.iter().enumerate() {
            th[10 * (n - 1) + k] += d;
        }
        truth.set_params(&th).unwrap();
        let t = 400;
        let mut rng = Rng::new(5);
        let mut draw = |s: f64| (0..t * n).map(|_| rng.uniform(-s, s)).collect::<Vec<f64>>();
        let (q, qd, qdd) = (draw(2.0), draw(1.5), draw(5.0));
        let mut tau = vec![0.0; t * n];
        crate::batch::rnea_batch(&truth, &q, &qd, &qdd, &mut tau).unwrap();
        let opts = TerminalOptions {
            spec,
            columns: base.independent.clone(),
            row_weight: vec![1.0; n],
            iv: false,
            p0: 1e6,
            min_speed: 0.0,
            record: vec![100, t],
        };
        let run = terminal_link_run(&robot, &opts, &q, &qd, &qdd, &tau, TerminalInstrument::None).unwrap();
        let want = base.project(&dx).unwrap();
        for (a, b) in run.theta.iter().zip(&want) {
            assert!((a - b).abs() < 1e-6 * (1.0 + b.abs()), "{:?} vs {want:?}", run.theta);
        }
        assert_eq!(run.trace.len(), 2 * want.len());
        assert_eq!(&run.trace[want.len()..], &run.theta[..]);
        assert_eq!(run.rows_used, (t * n) as u64);
        // IV without an instrument, and a NaN sample, are refused with their reason
        let e = terminal_link_run(
            &robot,
            &TerminalOptions { iv: true, ..opts.clone() },
            &q,
            &qd,
            &qdd,
            &tau,
            TerminalInstrument::None,
        )
        .unwrap_err();
        assert!(e.to_string().contains("instrument"), "{e}");
        let mut bad = tau.clone();
        bad[7 * n + 2] = f64::NAN;
        let e = terminal_link_run(&robot, &opts, &q, &qd, &qdd, &bad, TerminalInstrument::None).unwrap_err();
        assert!(e.to_string().starts_with("sample 7"), "{e}");
    }
}

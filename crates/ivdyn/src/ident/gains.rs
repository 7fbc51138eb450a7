//! Drive gains from runs of one arm without and with a payload of known mass: a fit with
//! the current as the output (maximum likelihood for current noise), whose uncertainty
//! says when a gain is not determined by the data.
//!
//! # Model
//! A drive reports a current `i_j`; the joint torque is `τ_j = g_j i_j`, with the gain
//! `g_j` in N m/A at the joint (the motor's torque constant times the gear ratio). With the
//! arm's base regressor `φ` (the same parameters `θ` in every run) and, in the runs with the
//! payload, the payload's ten columns `ψ` (the last link's standard-parameter columns) and
//! its parameters `π = [m, m cx, m cy, m cz, Ixx, Ixy, Iyy, Ixz, Iyz, Izz]` about the last
//! link's origin, row `r` of joint `j` reads
//!
//! ```text
//! i_r = h_j (φ_r θ + [loaded] ψ_r π) + ε_r,        h_j = 1 / g_j
//! ```
//!
//! One run alone gives `(g, θ)` only up to a common scale. The payload's known mass (and
//! its COM and inertia, when known) is a term of `ψ_r π` in absolute units, which fixes the
//! scale (Gautier and Briot, "Global identification of joint drive gains and dynamic
//! parameters of robots", ASME J. Dyn. Syst. Meas. Control 136(5), 2014).
//!
//! # Why the current is the output
//! The linear form `g_j i_r - φ_r θ - ψ_r,rest π_rest = ψ_r,m m` puts the measured current
//! in the regressor. Its noise then biases least squares toward `g = 0` by the ratio of
//! the noise power to the part of the current's signal the other columns do not explain
//! (errors in variables). For a joint the payload barely loads, that ratio is large, the
//! bias exceeds the standard deviation least squares reports, and the estimate shrinks
//! with a small std. Total least squares treats every column as equally noisy, which the
//! regressor columns (from filtered positions) are not. Here the current stays where it
//! was measured, as the output: for white Gaussian current noise (a variance per run and
//! joint) least squares on the model above is the maximum-likelihood estimate. The
//! parameters enter bilinearly (`h_j` times a form linear in `θ` and `π`).
//!
//! # Fit
//! The rows `[φ_r ψ_r | i_r]` of each run and joint are reduced once to their triangular
//! factor `R_aug` (as [`super::joint_acc`] does); the fit works on these factors only, so
//! an iteration costs the same for any log length. It starts from the linear form above
//! (biased, but near where a gain is determined), then runs Gauss-Newton with
//! Levenberg-Marquardt damping on `h`. Each step is the linear fit of
//! `i_r - h_j ψ_r,known π_known` on `[h_j φ_r | h_j ψ_r,free | τ̂_r e_j]` (new `θ`, new free
//! `π`, `δh`), where `τ̂_r` is the torque the current estimate predicts. The weights
//! `1 / (σ² f)` per run and joint (below) are then updated from the residual and the fit
//! repeated ([`ROUNDS`] times).
//!
//! # Uncertainty
//! `cov = (Jᵀ W J)⁻¹` at the solution (`J`: the step's regressor above), with `σ²` the
//! residual variance of each run and joint and `f` a variance inflation for the residual's
//! serial correlation, `f = max(1, 1 + 2 Σ_{k=1..L} (1 - k/(L+1)) ρ_k)` (Bartlett window,
//! `L` = [`ACF_LAGS`]). The parallel filter colours the noise, and a model error shows as
//! slow, correlated residuals that would otherwise count as independent evidence. A gain's
//! std is the delta method's `std(h_j) / h_j²`. The std covers the current noise, and
//! residuals that behave like it. It does not cover a model error correlated with a gain's
//! column (a friction law the model lacks, a current offset that changed between the runs,
//! a wrong payload mass: an error of `x %` in the mass is an error of `x %` in every gain).
//!
//! # Identifiable
//! A gain gets a value ([`GainVerdict::Identifiable`]) only if
//! 1. no null direction of the column-scaled Jacobian involves it (singular values below
//!    [`RANK_TOL`] of the largest), e.g. a joint that neither the payload nor the coupling
//!    to the other joints loads;
//! 2. its column is excited (not dropped by the rank-revealing QR of [`fit_ls`]);
//! 3. its relative standard deviation is at most [`GainOptions::max_rel_std`] (default 10 %):
//!    beyond it the data do not pin the gain down, and the linearisation behind the std
//!    stops being trustworthy as well.
//!
//! Otherwise its value and std are `NaN` and the verdict says why.

use std::ops::Range;

use nalgebra::DMatrix;

use super::base::RANK_TOL;
use super::{FitReport, LsAccumulator, fit_ls};
use crate::error::{Error, Result};
use ivdyn_core::params::{LINK_PARAM_NAMES, LINK_PARAMS};

/// Lags of the residual autocorrelation in the variance inflation (module docs).
pub const ACF_LAGS: usize = 10;
/// Rounds of weights from the residual after the first (unit-weight) fit.
pub const ROUNDS: usize = 3;
/// A gain is in a null direction when its entry in a unit null vector exceeds this.
const NULL_ENTRY_TOL: f64 = 1e-6;

/// One run for [`fit_gains`], after conditioning and the parallel filter.
#[derive(Debug, Clone, Copy)]
pub struct GainRun<'a> {
    /// `T x n x (b + 10)` rows, sample-major: each joint's base regressor row, then the ten
    /// columns of the last link's standard parameters (the payload's columns; ignored in a
    /// run without the payload).
    pub rows: &'a [f64],
    /// Measured currents, `T x n` (A, or any unit proportional to the torque per joint).
    pub current: &'a [f64],
    /// The sample ranges to fit, each continuous in time (a segment without its filter
    /// edges); the residual's autocorrelation is taken within each.
    pub pieces: &'a [Range<usize>],
    /// Whether the payload is on the arm in this run.
    pub loaded: bool,
}

/// Options of [`fit_gains`].
#[derive(Debug, Clone, PartialEq)]
pub struct GainOptions {
    /// Largest relative standard deviation of a gain reported as identifiable (0.1: 10 %).
    pub max_rel_std: f64,
    /// Gauss-Newton iterations per round.
    pub max_iter: usize,
    /// Convergence: largest relative step of a gain.
    pub tol: f64,
}

impl Default for GainOptions {
    fn default() -> Self {
        GainOptions { max_rel_std: 0.1, max_iter: 100, tol: 1e-10 }
    }
}

/// Why a gain has, or has no, value.
#[derive(Debug, Clone, PartialEq)]
pub enum GainVerdict {
    /// Determined by the data within `max_rel_std`.
    Identifiable,
    /// The fit could not estimate it at all (its column carries no information).
    Unexcited,
    /// It moves along a null direction of the fit together with these parameters (the
    /// largest other entries of the null vector).
    NullDirection {
        /// Parameters that trade off against it.
        with: Vec<String>,
    },
    /// The data give it only to this relative standard deviation.
    Loose {
        /// `std / |gain|`.
        rel_std: f64,
    },
}

/// Per-joint statistics of one run at the estimate (current units).
#[derive(Debug, Clone, PartialEq)]
pub struct RunStats {
    /// Samples fitted.
    pub samples: usize,
    /// RMS of `i - ĥ τ̂` per joint.
    pub rms: Vec<f64>,
    /// RMS of the measured current per joint.
    pub current_rms: Vec<f64>,
    /// `1 - SSE / SST` per joint.
    pub r2: Vec<f64>,
    /// Noise standard deviation used in the weights (the residual's, dof-corrected).
    pub noise_std: Vec<f64>,
    /// Variance inflation for the residual's serial correlation (module docs).
    pub inflation: Vec<f64>,
}

/// Result of [`fit_gains`].
#[derive(Debug, Clone)]
pub struct GainFit {
    /// Gain per joint (`NaN` unless identifiable).
    pub gain: Vec<f64>,
    /// Its standard deviation (`NaN` unless identifiable).
    pub gain_std: Vec<f64>,
    /// `std / |gain|` as the fit found it, also for the gains not reported (`NaN` when
    /// not estimated at all).
    pub rel_std: Vec<f64>,
    /// Why each gain has, or has no, value.
    pub verdict: Vec<GainVerdict>,
    /// Base parameters in absolute units (`NaN`: not excited).
    pub theta: Vec<f64>,
    /// Their standard deviations.
    pub theta_std: Vec<f64>,
    /// The payload's ten parameters (the given ones as given).
    pub payload: [f64; LINK_PARAMS],
    /// Their standard deviations (0 for the given ones).
    pub payload_std: [f64; LINK_PARAMS],
    /// Names of the fitted parameters: base parameters, free payload parameters
    /// (`"payload.m*cx"`...), then `"<joint>.inverse_gain"`.
    pub names: Vec<String>,
    /// Covariance of the fitted parameters (`h = 1 / g` for the gains).
    pub covariance: DMatrix<f64>,
    /// Per run, in the order given.
    pub runs: Vec<RunStats>,
    /// Gauss-Newton iterations, all rounds.
    pub iterations: usize,
    /// Whether every round converged.
    pub converged: bool,
}

/// The sufficient statistics and the parametrisation of a fit.
struct Problem {
    n: usize,
    b: usize,
    known: [Option<f64>; LINK_PARAMS],
    /// Payload parameters to estimate (indices into the ten).
    free: Vec<usize>,
    /// Per run and joint: `R_aug` of `[φ ψ | i]`, `(b + 11)²`.
    r: Vec<Vec<DMatrix<f64>>>,
    /// Per run: samples; per run and joint: `(Σ i, Σ i²)`.
    samples: Vec<usize>,
    sums: Vec<Vec<(f64, f64)>>,
    names: Vec<String>,
}

impl Problem {
    /// Data columns `b + 10`.
    fn m(&self) -> usize {
        self.b + LINK_PARAMS
    }

    /// Fitted parameters: `θ`, free `π`, `h`.
    fn p(&self) -> usize {
        self.b + self.free.len() + self.n
    }

    /// Column of `h_j`.
    fn hcol(&self, j: usize) -> usize {
        self.b + self.free.len() + j
    }
}

/// An estimate and its weights.
#[derive(Debug, Clone)]
struct State {
    theta: Vec<f64>,
    pi: [f64; LINK_PARAMS],
    h: Vec<f64>,
    /// Per run and joint: `1 / (σ² f)`.
    w: Vec<Vec<f64>>,
}

impl State {
    /// `[θ; π]` with unexcited entries as 0, so that `τ̂_r = [φ_r ψ_r] · coef`.
    fn coef(&self) -> Vec<f64> {
        self.theta.iter().chain(&self.pi).map(|v| if v.is_finite() { *v } else { 0.0 }).collect()
    }
}

/// Drive gains, base parameters and the payload's unknown parameters from runs without and
/// with the payload (module docs). `base_names` name the `b` base columns of the rows;
/// `known` holds the payload's given parameters (at least its mass, index 0).
pub fn fit_gains(
    n: usize,
    base_names: &[String],
    runs: &[GainRun],
    known: &[Option<f64>; LINK_PARAMS],
    opts: &GainOptions,
) -> Result<GainFit> {
    check_inputs(n, runs, known, opts)?;
    let p = problem(n, base_names, runs, known)?;
    let w0 = vec![vec![1.0; n]; runs.len()];
    let mut st = State { theta: vec![0.0; p.b], pi: known.map(|k| k.unwrap_or(0.0)), h: initial_h(&p)?, w: w0 };
    let (mut iterations, mut converged) = (0, true);
    for round in 0..=ROUNDS {
        if round > 0 {
            reweight(&p, runs, &mut st);
        }
        let (next, it, ok) = levenberg_marquardt(&p, st, opts)?;
        st = next;
        iterations += it;
        converged &= ok;
    }
    let stats = reweight(&p, runs, &mut st);
    let acc = gn_system(&p, &st, 0.0)?;
    let fit = fit_ls(&acc, &p.names)?;
    let mut out = assemble(&p, &st, &fit, stats, iterations, converged);
    out.verdict = verdicts(&p, &fit, &null_directions(&acc)?, &out.rel_std, opts.max_rel_std);
    for (j, v) in out.verdict.iter().enumerate() {
        if *v != GainVerdict::Identifiable {
            (out.gain[j], out.gain_std[j]) = (f64::NAN, f64::NAN);
        }
    }
    Ok(out)
}

fn check_inputs(n: usize, runs: &[GainRun], known: &[Option<f64>; LINK_PARAMS], opts: &GainOptions) -> Result<()> {
    if n == 0 {
        return Err(Error::Dimension { what: "joints".into(), expected: 1, got: 0 });
    }
    if !(runs.iter().any(|r| r.loaded) && runs.iter().any(|r| !r.loaded)) {
        return Err(Error::option("logs", "need a run without and a run with the payload"));
    }
    if !known[0].is_some_and(|m| m.is_finite() && m > 0.0) {
        return Err(Error::option(
            "payload_mass",
            format!("must be positive, got {:?} (the scale of every gain)", known[0]),
        ));
    }
    if let Some(k) = known.iter().position(|v| v.is_some_and(|v| !v.is_finite())) {
        return Err(Error::option("payload", format!("{} is not finite", LINK_PARAM_NAMES[k])));
    }
    if !(opts.max_rel_std.is_finite() && opts.max_rel_std > 0.0) {
        return Err(Error::option("max_rel_std", format!("must be finite and > 0, got {}", opts.max_rel_std)));
    }
    Ok(())
}

/// The per-run, per-joint factors and the names of the fitted parameters.
fn problem(n: usize, base_names: &[String], runs: &[GainRun], known: &[Option<f64>; LINK_PARAMS]) -> Result<Problem> {
    let b = base_names.len();
    let free: Vec<usize> = (0..LINK_PARAMS).filter(|&k| known[k].is_none()).collect();
    let (mut r, mut samples, mut sums) = (vec![], vec![], vec![]);
    for (k, run) in runs.iter().enumerate() {
        let (rk, t, s) = run_factors(n, b, run).map_err(|e| match e {
            Error::Dimension { what, expected, got } => {
                Error::Dimension { what: format!("run {k}: {what}"), expected, got }
            }
            e => e,
        })?;
        r.push(rk);
        samples.push(t);
        sums.push(s);
    }
    let mut names = base_names.to_vec();
    names.extend(free.iter().map(|&k| format!("payload.{}", LINK_PARAM_NAMES[k])));
    names.extend((0..n).map(|j| format!("joint {j} inverse gain")));
    Ok(Problem { n, b, known: *known, free, r, samples, sums, names })
}

/// One run's factors `R_aug` of `[φ ψ | i]` per joint, its sample count and current sums.
type RunFactors = (Vec<DMatrix<f64>>, usize, Vec<(f64, f64)>);

fn run_factors(n: usize, b: usize, run: &GainRun) -> Result<RunFactors> {
    let m = b + LINK_PARAMS;
    let t = run.current.len() / n;
    if run.current.len() != t * n || run.rows.len() != t * n * m {
        return Err(Error::Dimension {
            what: format!("rows (T x {n} x {m})"),
            expected: t * n * m,
            got: run.rows.len(),
        });
    }
    if let Some(p) = run.pieces.iter().find(|p| p.end > t || p.start > p.end) {
        return Err(Error::Dimension { what: "pieces (sample ranges within the run)".into(), expected: t, got: p.end });
    }
    let mut accs = vec![LsAccumulator::new(m); n];
    let mut sums = vec![(0.0, 0.0); n];
    let mut count = 0;
    for piece in run.pieces {
        count += piece.len();
        for j in 0..n {
            let mut phi = Vec::with_capacity(piece.len() * m);
            let mut y = Vec::with_capacity(piece.len());
            for s in piece.clone() {
                let row = &run.rows[(s * n + j) * m..(s * n + j + 1) * m];
                phi.extend_from_slice(&row[..b]);
                // without the payload its columns multiply nothing
                phi.extend(row[b..].iter().map(|v| if run.loaded { *v } else { 0.0 }));
                y.push(run.current[s * n + j]);
            }
            accs[j].add_rows(&phi, &y, None)?;
            sums[j].0 += y.iter().sum::<f64>();
            sums[j].1 += y.iter().map(|v| v * v).sum::<f64>();
        }
    }
    Ok((accs.iter().map(|a| a.r_aug()).collect(), count, sums))
}

/// `Σ_known ψ_k π_k` on row `row` of a factor (the payload's given part, torque units).
fn known_part(p: &Problem, r: &DMatrix<f64>, row: usize) -> f64 {
    (0..LINK_PARAMS).filter_map(|k| p.known[k].map(|v| r[(row, p.b + k)] * v)).sum()
}

/// The start: the linear equation-error fit `φ θ + ψ_free π_free - i g = -ψ_known π_known`
/// (torque units, unit weights). A gain it leaves undetermined (non-finite, zero, or with a
/// relative std above 1/2) starts at the median of the others.
fn initial_h(p: &Problem) -> Result<Vec<f64>> {
    let (m, b, pc) = (p.m(), p.b, p.p());
    let mut acc = LsAccumulator::new(pc);
    for rk in &p.r {
        for (j, r) in rk.iter().enumerate() {
            let (mut phi, mut y) = (vec![0.0; (m + 1) * pc], vec![0.0; m + 1]);
            for row in 0..=m {
                let out = &mut phi[row * pc..(row + 1) * pc];
                for c in 0..b {
                    out[c] = r[(row, c)];
                }
                for (i, &k) in p.free.iter().enumerate() {
                    out[b + i] = r[(row, b + k)];
                }
                out[p.hcol(j)] = -r[(row, m)];
                y[row] = -known_part(p, r, row);
            }
            acc.add_rows(&phi, &y, None)?;
        }
    }
    let fit = fit_ls(&acc, &p.names)?;
    let h: Vec<Option<f64>> = (0..p.n)
        .map(|j| {
            let (g, s) = (fit.theta[p.hcol(j)], fit.std[p.hcol(j)]);
            (g.is_finite() && g != 0.0 && s < 0.5 * g.abs()).then(|| 1.0 / g)
        })
        .collect();
    let mut good: Vec<f64> = h.iter().flatten().map(|v| v.abs()).collect();
    good.sort_by(f64::total_cmp);
    let fallback = good.get(good.len() / 2).copied().unwrap_or(1.0);
    Ok(h.into_iter().map(|v| v.unwrap_or(fallback)).collect())
}

/// Weighted residual sum of squares of run `k`, joint `j`: `‖R_aug [-h coef; 1]‖²`.
fn rss(p: &Problem, h: f64, coef: &[f64], k: usize, j: usize) -> f64 {
    let (r, m) = (&p.r[k][j], p.m());
    (0..=m)
        .map(|row| {
            let pred: f64 = (row..m).map(|c| r[(row, c)] * coef[c]).sum();
            (r[(row, m)] - h * pred).powi(2)
        })
        .sum()
}

/// The weighted cost `Σ w_kj rss_kj`.
fn cost(p: &Problem, st: &State) -> f64 {
    let coef = st.coef();
    (0..p.r.len())
        .flat_map(|k| (0..p.n).map(move |j| (k, j)))
        .map(|(k, j)| st.w[k][j] * rss(p, st.h[j], &coef, k, j))
        .sum()
}

/// The Gauss-Newton step's linear system at `st` (module docs), with damping rows
/// `√(λ ‖J_h‖²) δh_j = 0` when `lambda > 0`.
fn gn_system(p: &Problem, st: &State, lambda: f64) -> Result<LsAccumulator> {
    let (m, b, pc) = (p.m(), p.b, p.p());
    let coef = st.coef();
    let mut acc = LsAccumulator::new(pc);
    let mut h_norm2 = vec![0.0; p.n];
    for (k, rk) in p.r.iter().enumerate() {
        for (j, r) in rk.iter().enumerate() {
            let (h, w) = (st.h[j], st.w[k][j]);
            let (mut phi, mut y) = (vec![0.0; (m + 1) * pc], vec![0.0; m + 1]);
            for row in 0..=m {
                let out = &mut phi[row * pc..(row + 1) * pc];
                for c in 0..b {
                    out[c] = h * r[(row, c)];
                }
                for (i, &kk) in p.free.iter().enumerate() {
                    out[b + i] = h * r[(row, b + kk)];
                }
                // d i / d h_j = τ̂ (this row of the factor times [θ; π])
                out[p.hcol(j)] = (row..m).map(|c| r[(row, c)] * coef[c]).sum();
                h_norm2[j] += w * out[p.hcol(j)].powi(2);
                y[row] = r[(row, m)] - h * known_part(p, r, row);
            }
            acc.add_rows(&phi, &y, Some(&vec![w; m + 1]))?;
        }
    }
    if lambda > 0.0 {
        for j in 0..p.n {
            let mut row = vec![0.0; pc];
            row[p.hcol(j)] = (lambda * h_norm2[j]).sqrt();
            acc.add_rows(&row, &[0.0], None)?;
        }
    }
    Ok(acc)
}

/// `st` moved to the solution of its Gauss-Newton system, and the largest relative step
/// of a gain.
fn step(p: &Problem, st: &State, fit: &FitReport) -> (State, f64) {
    let mut next = st.clone();
    next.theta.copy_from_slice(&fit.theta[..p.b]);
    for (i, &k) in p.free.iter().enumerate() {
        next.pi[k] = fit.theta[p.b + i];
    }
    let mut largest = 0.0f64;
    for j in 0..p.n {
        let dh = fit.theta[p.hcol(j)];
        if dh.is_finite() {
            next.h[j] += dh;
            largest = largest.max((dh / st.h[j]).abs());
        }
    }
    (next, largest)
}

/// Gauss-Newton from `st`, damped (Levenberg-Marquardt on `h`) whenever a step does not
/// lower the cost. Returns the estimate, the iterations and whether it converged.
fn levenberg_marquardt(p: &Problem, mut st: State, opts: &GainOptions) -> Result<(State, usize, bool)> {
    let mut c = cost(p, &st);
    let mut lambda = 0.0;
    for it in 1..=opts.max_iter {
        let fit = fit_ls(&gn_system(p, &st, lambda)?, &p.names)?;
        let (next, largest) = step(p, &st, &fit);
        let c_next = cost(p, &next);
        if c_next <= c * (1.0 + 1e-12) {
            let done = largest < opts.tol || c - c_next <= 1e-15 * c;
            (st, c) = (next, c_next);
            lambda = if lambda > 1e-6 { lambda / 10.0 } else { 0.0 };
            if done {
                return Ok((st, it, true));
            }
        } else {
            lambda = if lambda == 0.0 { 1e-4 } else { lambda * 10.0 };
            if lambda > 1e10 {
                return Ok((st, it, false));
            }
        }
    }
    Ok((st, opts.max_iter, false))
}

/// New weights `1 / (σ² f)` from the residual of every run and joint at `st` (module docs);
/// returns the per-run statistics.
fn reweight(p: &Problem, runs: &[GainRun], st: &mut State) -> Vec<RunStats> {
    let coef = st.coef();
    let total: usize = p.samples.iter().map(|t| t * p.n).sum();
    let dof = total as f64 / (total.saturating_sub(p.p()).max(1)) as f64;
    let mut out = vec![];
    for (k, run) in runs.iter().enumerate() {
        let t = p.samples[k].max(1) as f64;
        let mut s = RunStats { samples: p.samples[k], ..empty_stats(p.n) };
        for j in 0..p.n {
            let sse = rss(p, st.h[j], &coef, k, j);
            let (si, sii) = p.sums[k][j];
            let floor = 1e-24 * (sii / t) + f64::MIN_POSITIVE;
            let var = (sse / t * dof).max(floor);
            let f = inflation(&residuals(p, run, st, &coef, j));
            st.w[k][j] = 1.0 / (var * f);
            s.rms.push((sse / t).sqrt());
            s.current_rms.push((sii / t).sqrt());
            s.r2.push(1.0 - sse / (sii - si * si / t));
            s.noise_std.push(var.sqrt());
            s.inflation.push(f);
        }
        out.push(s);
    }
    out
}

fn empty_stats(n: usize) -> RunStats {
    let v = || Vec::with_capacity(n);
    RunStats { samples: 0, rms: v(), current_rms: v(), r2: v(), noise_std: v(), inflation: v() }
}

/// Joint `j`'s residual `i - h τ̂` in each piece of `run`.
fn residuals(p: &Problem, run: &GainRun, st: &State, coef: &[f64], j: usize) -> Vec<Vec<f64>> {
    let (n, m) = (p.n, p.m());
    let payload = if run.loaded { m } else { p.b };
    run.pieces
        .iter()
        .map(|piece| {
            piece
                .clone()
                .map(|s| {
                    let row = &run.rows[(s * n + j) * m..(s * n + j + 1) * m];
                    let tau: f64 = row[..payload].iter().zip(coef).map(|(a, c)| a * c).sum();
                    run.current[s * n + j] - st.h[j] * tau
                })
                .collect()
        })
        .collect()
}

/// `max(1, 1 + 2 Σ_{k=1..L} (1 - k/(L+1)) ρ_k)` of residual pieces, `ρ_k` the lag-`k`
/// autocorrelation within the pieces (not mean-removed: an offset that the model lacks
/// is correlation too).
pub fn inflation(pieces: &[Vec<f64>]) -> f64 {
    let e0: f64 = pieces.iter().flatten().map(|e| e * e).sum();
    if !(e0 > 0.0) {
        return 1.0;
    }
    let l = ACF_LAGS;
    let mut f = 1.0;
    for k in 1..=l {
        let ek: f64 =
            pieces.iter().filter(|e| e.len() > k).map(|e| e.windows(k + 1).map(|w| w[0] * w[k]).sum::<f64>()).sum();
        f += 2.0 * (1.0 - k as f64 / (l + 1) as f64) * ek / e0;
    }
    f.max(1.0)
}

/// The unit null vectors of the column-scaled `R` (singular values below [`RANK_TOL`] of
/// the largest), as rows.
fn null_directions(acc: &LsAccumulator) -> Result<Vec<Vec<f64>>> {
    let r = acc.r();
    let norms: Vec<f64> = (0..r.ncols()).map(|c| r.column(c).norm()).collect();
    let scaled = DMatrix::from_fn(r.nrows(), r.ncols(), |i, c| if norms[c] > 0.0 { r[(i, c)] / norms[c] } else { 0.0 });
    let svd = crate::linalg::svd(scaled, false, true, "drive gains: null directions of the regressor")?;
    let Some(vt) = svd.v_t.as_ref() else { return Ok(vec![]) };
    let smax = svd.singular_values.max();
    Ok((0..svd.singular_values.len())
        .filter(|&k| svd.singular_values[k] < RANK_TOL * smax)
        .map(|k| vt.row(k).iter().copied().collect())
        .collect())
}

/// Each gain's verdict from the final fit (module docs).
fn verdicts(p: &Problem, fit: &FitReport, null: &[Vec<f64>], rel_std: &[f64], max_rel_std: f64) -> Vec<GainVerdict> {
    (0..p.n)
        .map(|j| {
            let c = p.hcol(j);
            // a null direction first: the pivoted QR may have dropped the gain's column from it
            let null_partners = null.iter().find(|v| v[c].abs() > NULL_ENTRY_TOL).map(|v| {
                let mut others: Vec<usize> = (0..v.len()).filter(|&i| i != c && v[i].abs() > NULL_ENTRY_TOL).collect();
                others.sort_by(|a, b| v[*b].abs().total_cmp(&v[*a].abs()));
                others.iter().take(3).map(|&i| p.names[i].clone()).collect::<Vec<_>>()
            });
            match null_partners {
                Some(with) if !with.is_empty() => return GainVerdict::NullDirection { with },
                _ if !fit.theta[c].is_finite() => return GainVerdict::Unexcited,
                _ => {}
            }
            if !(rel_std[j] <= max_rel_std) {
                return GainVerdict::Loose { rel_std: rel_std[j] };
            }
            GainVerdict::Identifiable
        })
        .collect()
}

/// The estimate with its uncertainty: `cov = (Jᵀ W J)⁻¹` (the fit's covariance without its
/// residual-variance factor: the weights already hold `1 / σ²`). Every gain is filled in;
/// the verdicts blank the ones not identifiable.
fn assemble(
    p: &Problem,
    st: &State,
    fit: &FitReport,
    runs: Vec<RunStats>,
    iterations: usize,
    converged: bool,
) -> GainFit {
    let scale = if fit.sigma2.is_finite() && fit.sigma2 > 0.0 { 1.0 / fit.sigma2 } else { 1.0 };
    let covariance = &fit.covariance * scale;
    let sd = |c: usize| covariance[(c, c)].max(0.0).sqrt();
    let (mut gain, mut gain_std, mut rel_std) = (vec![], vec![], vec![]);
    for j in 0..p.n {
        let (h, sh) = (st.h[j], sd(p.hcol(j)));
        let excited = fit.theta[p.hcol(j)].is_finite();
        gain.push(1.0 / h);
        // delta method: std(1/h) = std(h) / h²
        gain_std.push(sh / (h * h));
        rel_std.push(if excited { sh / h.abs() } else { f64::NAN });
    }
    let mut payload_std = [0.0; LINK_PARAMS];
    for (i, &k) in p.free.iter().enumerate() {
        payload_std[k] = sd(p.b + i);
    }
    GainFit {
        gain,
        gain_std,
        rel_std,
        verdict: vec![],
        theta: st.theta.clone(),
        theta_std: (0..p.b).map(sd).collect(),
        payload: st.pi,
        payload_std,
        names: p.names.clone(),
        covariance,
        runs,
        iterations,
        converged,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use ivdyn_core::rng::Rng;

    /// Two joints and two base parameters: joint 0 carries `x θ0` and, loaded, the
    /// payload's mass column `y m`; joint 1 only its own offset `θ1`. Returns the run's
    /// rows and currents (gains 4 and 5, white current noise).
    fn run(loaded: bool, seed: u64) -> (Vec<f64>, Vec<f64>) {
        let (t, m) = (600, 2 + LINK_PARAMS);
        let mut rng = Rng::new(seed);
        let (mut rows, mut current) = (vec![0.0; t * 2 * m], vec![0.0; t * 2]);
        for s in 0..t {
            let (x, y) = ((0.05 * s as f64).sin(), 1.5 + (0.031 * s as f64).cos());
            let r0 = &mut rows[2 * s * m..(2 * s + 1) * m];
            (r0[0], r0[2]) = (x, y);
            rows[(2 * s + 1) * m + 1] = 1.0;
            let tau0 = 2.0 * x + if loaded { 3.0 * y } else { 0.0 };
            current[2 * s] = tau0 / 4.0 + 0.01 * rng.normal();
            current[2 * s + 1] = 0.5 / 5.0 + 0.01 * rng.normal();
        }
        (rows, current)
    }

    #[test]
    fn a_gain_nothing_fixes_is_a_null_direction() {
        let ((ru, cu), (rl, cl)) = (run(false, 1), run(true, 2));
        let piece = 0..600;
        let pieces = std::slice::from_ref(&piece);
        let runs = [
            GainRun { rows: &ru, current: &cu, pieces, loaded: false },
            GainRun { rows: &rl, current: &cl, pieces, loaded: true },
        ];
        let mut known = [None; LINK_PARAMS];
        known[0] = Some(3.0);
        let names = ["a".to_string(), "offset".to_string()];
        let fit = fit_gains(2, &names, &runs, &known, &GainOptions::default()).unwrap();
        assert_eq!(fit.verdict[0], GainVerdict::Identifiable);
        assert!((fit.gain[0] - 4.0).abs() < 4.0 * fit.gain_std[0], "{} ± {}", fit.gain[0], fit.gain_std[0]);
        match &fit.verdict[1] {
            GainVerdict::NullDirection { with } => assert!(with.contains(&"offset".to_string()), "{with:?}"),
            v => panic!("joint 1: {v:?}"),
        }
        assert!(fit.gain[1].is_nan() && fit.gain_std[1].is_nan());
        // no payload mass: refused
        known[0] = None;
        assert!(fit_gains(2, &names, &runs, &known, &GainOptions::default()).is_err());
    }

    #[test]
    fn inflation_of_white_and_correlated_residuals() {
        let mut rng = Rng::new(3);
        let white: Vec<f64> = (0..20000).map(|_| rng.normal()).collect();
        let f = inflation(std::slice::from_ref(&white));
        assert!((1.0..1.1).contains(&f), "white: {f}");
        // AR(1), ρ = 0.5: (1 + ρ) / (1 - ρ) = 3 without the window, 2.8 with it
        let mut ar = vec![0.0; 20000];
        for k in 1..ar.len() {
            ar[k] = 0.5 * ar[k - 1] + white[k];
        }
        let f = inflation(&[ar[..10000].to_vec(), ar[10000..].to_vec()]);
        assert!((2.5..3.1).contains(&f), "AR(1): {f}");
    }
}

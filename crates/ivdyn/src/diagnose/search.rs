//! The search: candidate effects, their regressor columns, scoring, and the rules for
//! effects that look alike.
//!
//! Every effect of the vocabulary is linear in its parameters once its shape is fixed
//! (Stribeck's `vs` is chosen on a grid), so the torque the nominal model misses is
//! `r = tau - rnea_nominal(q, qd, qdd) = X theta + e`, with `X` built from a small
//! per-joint dictionary: `1, q, qd, sign(qd), qdd`, Stribeck shapes, and the terminal
//! link's 10 regressor columns (a payload is a change of the terminal link's inertial
//! parameters, eq. 14 of the paper: the terminal-link estimator with every joint's row).
//! The data enter only through per-joint, per-fold Gram matrices of that dictionary, so
//! scoring dozens of candidate models costs microseconds each, whatever the log length.
//!
//! A candidate (effect, joint) is *significant* when all of these hold (docs/diagnose.md):
//! 1. an F test of its columns (nested models, joint's rows, all data) rejects "no
//!    effect" at `alpha`, with the sample count divided by the residual's integrated
//!    autocorrelation time, since real residuals are not white;
//! 2. on held-out data (two-fold cross-validation over interleaved blocks of the log) it
//!    removes at least `min_share` of the residual that is above the noise and that the
//!    model with every candidate in can explain: a missing effect explains nearly all
//!    the structure it leaves on its joint, a look-alike only part of it;
//! 3. it matters: the torque it adds has an RMS of at least `min_effect` times the
//!    joint's noise level (estimated from sample-to-sample differences of the residual of
//!    a model with every candidate in, which slow structure barely moves);
//! 4. its parameters have their physical sign, and an armature or payload is larger than
//!    the uncertainty of the nominal (CAD) inertials;
//! 5. inertia-like effects (payload, armature, offset, spring) are not imitated as well by
//!    per-link scale errors of at most 25 % of the nominal inertials.
//!
//! Among the candidates with significant joints, the one that removes most of the
//! (noise-weighted) residual is added; all parameters are refit; effects that stopped
//! being significant are dropped again (backward step); repeat until none is left.
//! Look-alikes: viscous vs armature vs payload compete on how much they explain (their
//! columns are `qd`, `qdd` and rigid-body terms, which a moving log separates); Stribeck
//! is only tried as a refinement of Coulomb friction already found on a joint and needs a
//! positive `fs` (static friction above Coulomb); a joint spring contains an offset, so a
//! spring is named only when its position column is significant beyond the constant,
//! otherwise an offset.

use nalgebra::{DMatrix, DVector};

use super::{
    CandidateScore, Diagnosis, DiagnosisJson, EffectJson, EffectKind, JointScore, LogInfo, Regimes, Step, Traces,
};
use crate::Robot;
use crate::batch;
use crate::dsp::{self, Butterworth};
use crate::error::{Error, Result};
use crate::ident::stats::f_sf;
use crate::log::JointLog;
use crate::prep;

/// Options of [`diagnose`].
#[derive(Debug, Clone)]
pub struct DiagnoseOptions {
    /// Significance level of the per-joint F test on the effective sample count (default
    /// 1e-3; the held-out share, the size and the physics rules guard against what an
    /// F test on correlated residuals lets through).
    pub alpha: f64,
    /// An effect must add at least this many noise standard deviations of RMS torque on
    /// a joint to be named there (default 0.5).
    pub min_effect: f64,
    /// Share of the held-out residual above the noise a candidate must remove on a joint
    /// to be named there (default 0.75).
    pub min_share: f64,
    /// Zero-phase low-pass cutoff (Hz) for q / qd before differentiation (default: the
    /// one on a grid of 10-160 Hz, at most fs/4, that leaves the least residual).
    pub cutoff_hz: Option<f64>,
    /// Ignore the log's velocities and differentiate positions.
    pub ignore_log_velocity: bool,
    /// Cross-validation blocks per fold (default 8).
    pub blocks_per_fold: usize,
    /// Most effects to add (default 10).
    pub max_steps: usize,
    /// Log file name for the report (informational).
    pub log_name: String,
    /// URDF file name for the report (informational).
    pub urdf_name: String,
}

impl Default for DiagnoseOptions {
    fn default() -> Self {
        DiagnoseOptions {
            alpha: 1e-3,
            min_effect: 0.5,
            min_share: 0.75,
            cutoff_hz: None,
            ignore_log_velocity: false,
            blocks_per_fold: 8,
            max_steps: 10,
            log_name: String::new(),
            urdf_name: String::new(),
        }
    }
}

// ---------------------------------------------------------------------------------------
// Dictionary columns
// ---------------------------------------------------------------------------------------

const C_ONE: usize = 0;
const C_Q: usize = 1;
const C_QD: usize = 2;
const C_SIGN: usize = 3;
const C_QDD: usize = 4;
/// Stribeck shapes `exp(-(qd/vs)^2) sign(qd)`, `vs` = these fractions of the joint's RMS speed.
const STRIBECK_VS: [f64; 5] = [0.02, 0.05, 0.1, 0.2, 0.4];
const C_STRIBECK: usize = 5;
const C_PAYLOAD: usize = C_STRIBECK + STRIBECK_VS.len();
/// Link-scale columns of the look-alike check: link i's nominal torque on the joint,
/// `Y_i(q, qd, qdd) theta_i` (a wrong link mass or inertia scales it).
const C_LINK: usize = C_PAYLOAD + 10;
const NCOLS: usize = C_LINK + crate::MAX_DOF;
/// The target (the nominal residual) is the last Gram column.
const C_TARGET: usize = NCOLS;

/// One parameter of a model: which joints' rows it touches and through which column.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
struct Param {
    /// `None`: a link-scale parameter of the look-alike check (not an effect).
    kind: Option<EffectKind>,
    /// `Some(j)`: a per-joint parameter; `None`: payload (all joints).
    joint: Option<usize>,
    /// Dictionary column (for payload: `C_PAYLOAD + k`).
    col: usize,
}

/// The model: per joint, the effects on it (and the Stribeck shape), plus payload.
#[derive(Debug, Clone, PartialEq, Default)]
struct Model {
    per_joint: Vec<Vec<EffectKind>>,
    stribeck_vs: Vec<usize>,
    payload: bool,
    /// Per-link scale factors of the nominal inertials (look-alike check only).
    link_scale: bool,
}

impl Model {
    fn new(n: usize) -> Self {
        Model { per_joint: vec![vec![]; n], stribeck_vs: vec![0; n], payload: false, link_scale: false }
    }

    fn has(&self, j: usize, e: EffectKind) -> bool {
        self.per_joint[j].contains(&e)
    }

    fn with(&self, j: Option<usize>, e: EffectKind) -> Model {
        let mut m = self.clone();
        match j {
            None => m.payload = true,
            Some(j) => {
                if !m.has(j, e) {
                    m.per_joint[j].push(e);
                }
            }
        }
        m
    }

    fn without(&self, j: Option<usize>, e: EffectKind) -> Model {
        let mut m = self.clone();
        match j {
            None => m.payload = false,
            Some(j) => m.per_joint[j].retain(|&x| x != e),
        }
        m
    }

    /// The parameters, in a fixed order.
    fn params(&self) -> Vec<Param> {
        let mut p = vec![];
        for (j, effects) in self.per_joint.iter().enumerate() {
            let mut kinds = effects.clone();
            kinds.sort();
            for e in kinds {
                let cols: &[usize] = match e {
                    EffectKind::Coulomb => &[C_SIGN],
                    EffectKind::Viscous => &[C_QD],
                    EffectKind::Armature => &[C_QDD],
                    EffectKind::TorqueOffset => &[C_ONE],
                    // k (q - q0) = k q + c: the constant is the offset's column, so a
                    // spring and an offset on one joint share it (never both: see rules)
                    EffectKind::JointSpring => &[C_Q, C_ONE],
                    EffectKind::Stribeck => &[C_STRIBECK],
                    EffectKind::Payload => &[],
                };
                for &c in cols {
                    let c = if c == C_STRIBECK { C_STRIBECK + self.stribeck_vs[j] } else { c };
                    if !p.iter().any(|x: &Param| x.joint == Some(j) && x.col == c) {
                        p.push(Param { kind: Some(e), joint: Some(j), col: c });
                    }
                }
            }
        }
        if self.payload {
            for k in 0..10 {
                p.push(Param { kind: Some(EffectKind::Payload), joint: None, col: C_PAYLOAD + k });
            }
        }
        if self.link_scale {
            for i in 0..self.per_joint.len() {
                p.push(Param { kind: None, joint: None, col: C_LINK + i });
            }
        }
        p
    }
}

// ---------------------------------------------------------------------------------------
// Signals and Gram matrices
// ---------------------------------------------------------------------------------------

/// Conditioned signals, row-major `T x N`.
struct Signals {
    t: Vec<f64>,
    q: Vec<f64>,
    qd: Vec<f64>,
    qdd: Vec<f64>,
    tau: Vec<f64>,
    velocity_in_log: bool,
    dt: f64,
    /// Zero-phase cutoff used (Hz).
    cutoff_hz: f64,
    /// Torque-to-motion alignment in samples (see [`align`]).
    align: f64,
}

fn bad(msg: impl Into<String>) -> Error {
    Error::Estimation { msg: msg.into() }
}

fn condition(log: &JointLog, opts: &DiagnoseOptions, cutoff_hz: f64) -> Result<Signals> {
    let n = log.dof();
    let tau = log
        .tau
        .as_ref()
        .ok_or_else(|| bad("the log has no effort (torque) values: nothing to compare the model with"))?;
    let use_qd = log.qd.is_some() && !opts.ignore_log_velocity;
    let copts = prep::ConditionOptions {
        diff: dsp::DiffMethod::Butterworth { order: 4, cutoff_hz: Some(cutoff_hz) },
        ..Default::default()
    };
    // resampling, duplicates, and q-derived derivatives
    let c = prep::condition(log, &copts)?;
    let t_len = c.t.len();
    if t_len < 50 {
        return Err(bad(format!("the log has {t_len} usable samples; the diagnosis needs at least 50")));
    }
    let tau = c.tau.clone().unwrap_or_else(|| tau.clone());
    let (q, qd, qdd) = if use_qd && !c.resampled && c.duplicates == 0 {
        // the log's velocity (an encoder or simulator velocity is better than a
        // differentiated position), smoothed by the same zero-phase filter, and its
        // central difference for qdd
        let fs = 1.0 / c.dt;
        let f = Butterworth::zero_phase(4, cutoff_hz, fs)?;
        let qd_raw = log.qd.as_ref().expect("checked");
        if let Some(i) = qd_raw.iter().position(|v| !v.is_finite()) {
            return Err(bad(format!("sample {}, joint {}: velocity is {}", i / n, log.joint_names[i % n], qd_raw[i])));
        }
        let qd = f.filtfilt_columns(qd_raw, n)?;
        let qdd = dsp::central_diff(&qd, n, c.dt)?;
        (c.d.q.clone(), qd, qdd)
    } else {
        (c.d.q.clone(), c.d.qd.clone(), c.d.qdd.clone())
    };
    if let Some(i) = tau.iter().position(|v| !v.is_finite()) {
        return Err(bad(format!("sample {}, joint {}: effort is {}", i / n, log.joint_names[i % n], tau[i])));
    }
    // the first and last samples carry the filters' and differences' edge transients:
    // two time constants of the cutoff (at least 2 samples) are left out at both ends
    let trim = ((2.0 / (cutoff_hz * c.dt)).ceil() as usize).max(2);
    if t_len <= 2 * trim + 50 {
        return Err(bad(format!(
            "the log has {t_len} samples; with {trim} edge samples dropped at each end (cutoff {cutoff_hz} Hz) fewer than 50 are left"
        )));
    }
    let cut = |x: &[f64]| x[trim * n..(t_len - trim) * n].to_vec();
    Ok(Signals {
        t: c.t[trim..t_len - trim].to_vec(),
        q: cut(&q),
        qd: cut(&qd),
        qdd: cut(&qdd),
        tau: cut(&tau),
        velocity_in_log: use_qd,
        dt: c.dt,
        cutoff_hz,
        align: 0.0,
    })
}

/// Per joint: the dictionary columns over the log (`NCOLS` vectors of length `T`).
struct Dictionary {
    cols: Vec<Vec<Vec<f64>>>,
    /// Nominal residual per joint.
    r0: Vec<Vec<f64>>,
    /// Stribeck `vs` values per joint (rad/s or m/s).
    vs: Vec<[f64; 5]>,
    /// Mean position per joint (the spring's reference for conditioning).
    q_mean: Vec<f64>,
}

fn build_dictionary(robot: &Robot, s: &Signals, tau_nom: &[f64]) -> Result<Dictionary> {
    let n = robot.dof();
    let t_len = s.t.len();
    let p_full = robot.num_params();
    let mut cols = vec![vec![vec![0.0; t_len]; NCOLS]; n];
    let mut vs = vec![[0.0; 5]; n];
    let mut q_mean = vec![0.0; n];
    for j in 0..n {
        let qd_rms = ((0..t_len).map(|k| s.qd[k * n + j].powi(2)).sum::<f64>() / t_len as f64).sqrt().max(1e-9);
        q_mean[j] = (0..t_len).map(|k| s.q[k * n + j]).sum::<f64>() / t_len as f64;
        for (g, f) in STRIBECK_VS.iter().enumerate() {
            vs[j][g] = f * qd_rms;
        }
        let c = &mut cols[j];
        for k in 0..t_len {
            let (q, qd, qdd) = (s.q[k * n + j], s.qd[k * n + j], s.qdd[k * n + j]);
            let sg = if qd > 0.0 {
                1.0
            } else if qd < 0.0 {
                -1.0
            } else {
                0.0
            };
            c[C_ONE][k] = 1.0;
            c[C_Q][k] = q - q_mean[j];
            c[C_QD][k] = qd;
            c[C_SIGN][k] = sg;
            c[C_QDD][k] = qdd;
            for g in 0..STRIBECK_VS.len() {
                c[C_STRIBECK + g][k] = (-(qd / vs[j][g]).powi(2)).exp() * sg;
            }
        }
    }
    // the terminal link's 10 regressor columns, in blocks (the whole regressor would be
    // T x N x 14N doubles)
    let link = 10 * (n - 1);
    let theta_nom = robot.params();
    let block = 2048;
    let mut y = vec![0.0; block * n * p_full];
    for k0 in (0..t_len).step_by(block) {
        let k1 = (k0 + block).min(t_len);
        let m = k1 - k0;
        let out = &mut y[..m * n * p_full];
        batch::regressor_batch(robot, &s.q[k0 * n..k1 * n], &s.qd[k0 * n..k1 * n], &s.qdd[k0 * n..k1 * n], out, false)
            .map_err(|e| bad(format!("regressor: {e}")))?;
        for kk in 0..m {
            for j in 0..n {
                let row = &out[(kk * n + j) * p_full..(kk * n + j + 1) * p_full];
                for c in 0..10 {
                    cols[j][C_PAYLOAD + c][k0 + kk] = row[link + c];
                }
                for i in 0..n {
                    cols[j][C_LINK + i][k0 + kk] = (0..10).map(|c| row[10 * i + c] * theta_nom[10 * i + c]).sum();
                }
            }
        }
    }
    let r0 = (0..n).map(|j| (0..t_len).map(|k| s.tau[k * n + j] - tau_nom[k * n + j]).collect()).collect();
    Ok(Dictionary { cols, r0, vs, q_mean })
}

/// Gram matrices `[X r]^T [X r]` per joint and fold.
struct Grams {
    g: Vec<[DMatrix<f64>; 2]>,
    rows: Vec<[usize; 2]>,
}

fn fold_of(k: usize, t_len: usize, blocks_per_fold: usize) -> usize {
    let nb = 2 * blocks_per_fold;
    (k * nb / t_len) % 2
}

fn grams(d: &Dictionary, t_len: usize, blocks_per_fold: usize) -> Grams {
    let n = d.cols.len();
    let mut g = Vec::with_capacity(n);
    let mut rows = vec![[0usize; 2]; n];
    for j in 0..n {
        let mut gj = [DMatrix::<f64>::zeros(NCOLS + 1, NCOLS + 1), DMatrix::<f64>::zeros(NCOLS + 1, NCOLS + 1)];
        let mut x = [0.0; NCOLS + 1];
        for k in 0..t_len {
            let f = fold_of(k, t_len, blocks_per_fold);
            rows[j][f] += 1;
            for c in 0..NCOLS {
                x[c] = d.cols[j][c][k];
            }
            x[C_TARGET] = d.r0[j][k];
            let m = &mut gj[f];
            for a in 0..=NCOLS {
                let xa = x[a];
                if xa == 0.0 {
                    continue;
                }
                for b in a..=NCOLS {
                    m[(a, b)] += xa * x[b];
                }
            }
        }
        for m in gj.iter_mut() {
            for a in 0..=NCOLS {
                for b in 0..a {
                    m[(a, b)] = m[(b, a)];
                }
            }
        }
        g.push(gj);
    }
    Grams { g, rows }
}

// ---------------------------------------------------------------------------------------
// Fitting from the Gram matrices
// ---------------------------------------------------------------------------------------

/// A fitted model.
#[derive(Debug, Clone)]
struct Fit {
    params: Vec<Param>,
    theta: Vec<f64>,
}

fn joint_index(params: &[Param], j: usize) -> Vec<(usize, usize)> {
    params.iter().enumerate().filter(|(_, p)| p.joint.is_none_or(|x| x == j)).map(|(i, p)| (i, p.col)).collect()
}

fn sum_folds(g: &[DMatrix<f64>; 2], folds: &[usize]) -> DMatrix<f64> {
    let mut m = g[folds[0]].clone();
    for &f in &folds[1..] {
        m += &g[f];
    }
    m
}

/// Weighted LS over `folds` (weights `w[j]` per joint). Rank-deficient directions (e.g.
/// payload parameters this motion cannot see) get the minimum-norm solution.
fn fit(model_params: &[Param], gr: &Grams, w: &[f64], folds: &[usize]) -> Fit {
    let p = model_params.len();
    let n = gr.g.len();
    let mut a = DMatrix::<f64>::zeros(p, p);
    let mut b = DVector::<f64>::zeros(p);
    for j in 0..n {
        let g = sum_folds(&gr.g[j], folds);
        let idx = joint_index(model_params, j);
        for &(ia, ca) in &idx {
            b[ia] += w[j] * g[(ca, C_TARGET)];
            for &(ib, cb) in &idx {
                a[(ia, ib)] += w[j] * g[(ca, cb)];
            }
        }
    }
    if p == 0 {
        return Fit { params: vec![], theta: vec![] };
    }
    // scale to unit diagonal, then a pseudo-inverse with a relative threshold
    let s: Vec<f64> = (0..p).map(|i| if a[(i, i)] > 0.0 { 1.0 / a[(i, i)].sqrt() } else { 0.0 }).collect();
    let an = DMatrix::from_fn(p, p, |i, k| a[(i, k)] * s[i] * s[k]);
    let bn = DVector::from_fn(p, |i, _| b[i] * s[i]);
    let svd = an.clone().svd(true, true);
    let tol = 1e-10 * svd.singular_values.max();
    let pinv = svd.pseudo_inverse(tol).unwrap_or_else(|_| DMatrix::zeros(p, p));
    let xn = &pinv * &bn;
    let theta: Vec<f64> = (0..p).map(|i| xn[i] * s[i]).collect();
    Fit { params: model_params.to_vec(), theta }
}

/// Residual sum of squares of joint `j` over `folds` (unweighted, N m^2).
fn rss_joint(f: &Fit, gr: &Grams, j: usize, folds: &[usize]) -> f64 {
    let g = sum_folds(&gr.g[j], folds);
    let idx = joint_index(&f.params, j);
    let mut v = g[(C_TARGET, C_TARGET)];
    for &(ia, ca) in &idx {
        v -= 2.0 * f.theta[ia] * g[(ca, C_TARGET)];
        for &(ib, cb) in &idx {
            v += f.theta[ia] * f.theta[ib] * g[(ca, cb)];
        }
    }
    v.max(0.0)
}

/// RMS over the log of the torque the parameters of `which` add on joint `j`.
fn effect_rms(f: &Fit, gr: &Grams, j: usize, which: &dyn Fn(&Param) -> bool) -> f64 {
    let g = sum_folds(&gr.g[j], &[0, 1]);
    let idx: Vec<(usize, usize)> =
        joint_index(&f.params, j).into_iter().filter(|&(i, _)| which(&f.params[i])).collect();
    let mut v = 0.0;
    for &(ia, ca) in &idx {
        for &(ib, cb) in &idx {
            v += f.theta[ia] * f.theta[ib] * g[(ca, cb)];
        }
    }
    (v.max(0.0) / (gr.rows[j][0] + gr.rows[j][1]) as f64).sqrt()
}

/// Predicted extra torque of a fit over the whole log (`T x N`).
fn effect_torque(f: &Fit, d: &Dictionary, n: usize, t_len: usize) -> Vec<f64> {
    let mut out = vec![0.0; t_len * n];
    for (i, p) in f.params.iter().enumerate() {
        let js: Vec<usize> = match p.joint {
            Some(j) => vec![j],
            None => (0..n).collect(),
        };
        for j in js {
            let c = &d.cols[j][p.col];
            for k in 0..t_len {
                out[k * n + j] += f.theta[i] * c[k];
            }
        }
    }
    out
}

// ---------------------------------------------------------------------------------------
// Noise and statistics
// ---------------------------------------------------------------------------------------

fn median(mut v: Vec<f64>) -> f64 {
    if v.is_empty() {
        return f64::NAN;
    }
    v.sort_by(|a, b| a.total_cmp(b));
    let m = v.len() / 2;
    if v.len() % 2 == 1 { v[m] } else { 0.5 * (v[m - 1] + v[m]) }
}

/// Noise std and integrated autocorrelation time of the residual `r` on joint `j`.
///
/// The noise comes from sample-to-sample differences (MAD, robust to jumps), which slow
/// structure barely moves, when the residual is rough (lag-1 autocorrelation below 0.5,
/// a raw sensor). A smooth residual (a log low-passed by its authors) says nothing about
/// the noise through its differences: then its RMS is used, i.e. what no candidate
/// explains. The autocorrelation time `1 + 2 sum rho_k` (summed while `rho_k > 0.05`)
/// turns the sample count into an effective count for the F tests.
fn noise_and_tau(r: &[f64], n: usize, j: usize) -> (f64, f64) {
    let t_len = r.len() / n;
    let x = |k: usize| r[k * n + j];
    let mean = (0..t_len).map(x).sum::<f64>() / t_len as f64;
    let c0: f64 = (0..t_len).map(|k| (x(k) - mean).powi(2)).sum();
    let rho = |lag: usize| -> f64 {
        if c0 <= 0.0 {
            return 0.0;
        }
        (lag..t_len).map(|k| (x(k) - mean) * (x(k - lag) - mean)).sum::<f64>() / c0
    };
    let rho1 = rho(1);
    let mut tau = 1.0;
    for lag in 1..(t_len / 10).max(2) {
        let rk = if lag == 1 { rho1 } else { rho(lag) };
        if rk < 0.05 {
            break;
        }
        tau += 2.0 * rk;
    }
    let sigma = if rho1 < 0.5 {
        let dif: Vec<f64> = (1..t_len).map(|k| x(k) - x(k - 1)).collect();
        let med = median(dif.clone());
        let mad = median(dif.iter().map(|d| (d - med).abs()).collect());
        1.4826 * mad / 2f64.sqrt()
    } else {
        ((0..t_len).map(|k| x(k) * x(k)).sum::<f64>() / t_len as f64).sqrt()
    };
    (sigma.max(1e-12), tau)
}

fn rms_per_joint(r: &[f64], n: usize) -> Vec<f64> {
    let t_len = r.len() / n;
    (0..n).map(|j| ((0..t_len).map(|k| r[k * n + j].powi(2)).sum::<f64>() / t_len as f64).sqrt()).collect()
}

fn regimes(s: &Signals, r: &[f64], n: usize) -> Vec<Regimes> {
    let t_len = s.t.len();
    let window = ((0.02 / s.dt).round() as usize).max(2);
    (0..n)
        .map(|j| {
            let qd = |k: usize| s.qd[k * n + j];
            let rv = |k: usize| r[k * n + j];
            let mut near = vec![false; t_len];
            let mut jumps = vec![];
            for k in 1..t_len {
                if qd(k - 1) * qd(k) < 0.0 || (qd(k - 1) == 0.0 && qd(k) != 0.0 && k > 1 && qd(k - 2) * qd(k) < 0.0) {
                    let lo = k.saturating_sub(window);
                    let hi = (k + window).min(t_len);
                    for x in near.iter_mut().take(hi).skip(lo) {
                        *x = true;
                    }
                    if k >= 3 * window && k + 3 * window < t_len {
                        let before: f64 = (k - 3 * window..k - window).map(rv).sum::<f64>() / (2 * window) as f64;
                        let after: f64 = (k + window..k + 3 * window).map(rv).sum::<f64>() / (2 * window) as f64;
                        jumps.push((after - before) * qd(k).signum());
                    }
                }
            }
            let mut acc: Vec<f64> = (0..t_len).map(|k| s.qdd[k * n + j].abs()).collect();
            acc.sort_by(|a, b| a.total_cmp(b));
            let thr = acc[(0.8 * t_len as f64) as usize];
            let (mut sr, mut nr, mut sa, mut na, mut so, mut no) = (0.0, 0, 0.0, 0, 0.0, 0);
            for (k, &nk) in near.iter().enumerate() {
                let v = rv(k).powi(2);
                if nk {
                    sr += v;
                    nr += 1;
                } else if s.qdd[k * n + j].abs() >= thr {
                    sa += v;
                    na += 1;
                } else {
                    so += v;
                    no += 1;
                }
            }
            let ms = |s: f64, c: usize| if c > 0 { (s / c as f64).sqrt() } else { f64::NAN };
            let corr = |x: &dyn Fn(usize) -> f64| {
                let mx = (0..t_len).map(x).sum::<f64>() / t_len as f64;
                let mr = (0..t_len).map(rv).sum::<f64>() / t_len as f64;
                let (mut sxy, mut sxx, mut syy) = (0.0, 0.0, 0.0);
                for k in 0..t_len {
                    let (a, b) = (x(k) - mx, rv(k) - mr);
                    sxy += a * b;
                    sxx += a * a;
                    syy += b * b;
                }
                if sxx > 0.0 && syy > 0.0 { sxy / (sxx * syy).sqrt() } else { 0.0 }
            };
            Regimes {
                rms: ms((0..t_len).map(|k| rv(k).powi(2)).sum(), t_len),
                rms_reversal: ms(sr, nr),
                rms_high_acc: ms(sa, na),
                rms_rest: ms(so, no),
                reversal_jump: if jumps.is_empty() { f64::NAN } else { jumps.iter().sum::<f64>() / jumps.len() as f64 },
                reversals: jumps.len(),
                corr_q: corr(&|k| s.q[k * n + j]),
                corr_qd: corr(&|k| s.qd[k * n + j]),
                corr_qdd: corr(&|k| s.qdd[k * n + j]),
                mean: (0..t_len).map(rv).sum::<f64>() / t_len as f64,
            }
        })
        .collect()
}

// ---------------------------------------------------------------------------------------
// Scoring
// ---------------------------------------------------------------------------------------

struct Ctx<'a> {
    gr: &'a Grams,
    /// Mean diagonal of the nominal mass matrix over the log (kg m^2 or kg).
    m_diag: Vec<f64>,
    /// Nominal mass of the terminal link (kg).
    terminal_mass: f64,
    w: Vec<f64>,
    sigma: Vec<f64>,
    /// Held-out RSS per joint of the all-candidates model (two-fold).
    h_all: Vec<f64>,
    /// Integrated autocorrelation time of the residual per joint (samples).
    tau: Vec<f64>,
    n: usize,
    opts: &'a DiagnoseOptions,
}

impl Ctx<'_> {
    fn n_eff(&self, j: usize) -> f64 {
        let rows = (self.gr.rows[j][0] + self.gr.rows[j][1]) as f64;
        (rows / self.tau[j]).max(10.0)
    }

    /// Scores `larger` against `smaller` (nested) on joint `j`; `added` selects the new
    /// parameters (for the effect's RMS).
    fn joint_score(&self, smaller: &Model, larger: &Model, j: usize, added: &dyn Fn(&Param) -> bool) -> JointScore {
        let (ps, pl) = (smaller.params(), larger.params());
        let (fs, fl) = (fit(&ps, self.gr, &self.w, &[0, 1]), fit(&pl, self.gr, &self.w, &[0, 1]));
        let (r0, r1) = (rss_joint(&fs, self.gr, j, &[0, 1]), rss_joint(&fl, self.gr, j, &[0, 1]));
        let k_small = joint_index(&ps, j).len();
        let k_large = joint_index(&pl, j).len();
        let d1 = (k_large.saturating_sub(k_small)).max(1) as f64;
        let n_eff = self.n_eff(j);
        let d2 = (n_eff - k_large as f64).max(1.0);
        // RSS scaled to the effective count: the F statistic of an AR(1) residual
        let f_stat = ((r0 - r1).max(0.0) / d1) / (r1 / d2).max(1e-300)
            * (n_eff / (self.gr.rows[j][0] + self.gr.rows[j][1]) as f64);
        let p = f_sf(f_stat, d1, d2);
        // two-fold cross-validation
        let mut h0 = 0.0;
        let mut h1 = 0.0;
        for (train, test) in [(0usize, 1usize), (1, 0)] {
            let a = fit(&ps, self.gr, &self.w, &[train]);
            let b = fit(&pl, self.gr, &self.w, &[train]);
            h0 += rss_joint(&a, self.gr, j, &[test]);
            h1 += rss_joint(&b, self.gr, j, &[test]);
        }
        // the share of the held-out residual *above the noise* the candidate removes: a
        // missing effect explains (nearly) all of the structure it leaves on its joint; a
        // look-alike (e.g. an offset standing in for a wrong link mass) only part of it
        let n_test = (self.gr.rows[j][0] + self.gr.rows[j][1]) as f64;
        // "structure" = what is above the noise, or what the vocabulary can explain at all
        // (held-out residual of the all-candidates model) when that is less, e.g. when a
        // friction model leaves stick-slip bursts at reversals that nothing explains
        let explainable = (h0 - self.h_all[j]).min(h0 - n_test * self.sigma[j].powi(2));
        let structure = explainable.max(0.05 * h0);
        let heldout_gain = if h0 > 0.0 { ((h0 - h1) / structure).min(1.0) } else { 0.0 };
        let e_rms = effect_rms(&fl, self.gr, j, added);
        let significant = p < self.opts.alpha
            && heldout_gain >= self.opts.min_share
            && e_rms >= self.opts.min_effect * self.sigma[j]
            && Self::physical(&fl, j, added)
            && self.beyond_nominal_uncertainty(&fl, j, added);
        JointScore { f: f_stat, p, heldout_gain, effect_rms: e_rms, significant }
    }

    /// An armature below `NOMINAL_UNCERTAINTY` of the inertia the nominal model already
    /// puts on the joint, or a payload lighter than that share of the terminal link, is
    /// indistinguishable from an error of the links' own (CAD) inertias, which are rarely
    /// better than that: not named as a missing effect.
    fn beyond_nominal_uncertainty(&self, f: &Fit, j: usize, added: &dyn Fn(&Param) -> bool) -> bool {
        f.params.iter().zip(&f.theta).all(|(p, &v)| {
            let small_armature =
                p.joint == Some(j) && p.kind == Some(EffectKind::Armature) && v < NOMINAL_UNCERTAINTY * self.m_diag[j];
            let small_payload = p.kind == Some(EffectKind::Payload)
                && p.col == C_PAYLOAD
                && v < NOMINAL_UNCERTAINTY * self.terminal_mass;
            !(added(p) && (small_armature || small_payload))
        })
    }

    /// Whether the added parameters touching joint `j` have their physical sign: friction,
    /// armature and spring stiffness dissipate or store energy only when positive, and a
    /// payload has a positive mass. A negative fit is how differentiation lag or a model
    /// error imitates an effect, never the effect itself.
    fn physical(f: &Fit, j: usize, added: &dyn Fn(&Param) -> bool) -> bool {
        f.params.iter().zip(&f.theta).all(|(p, &v)| {
            if !added(p) || p.joint.is_some_and(|x| x != j) {
                return true;
            }
            match (p.kind, p.col) {
                (Some(EffectKind::Coulomb), C_SIGN)
                | (Some(EffectKind::Viscous), C_QD)
                | (Some(EffectKind::Armature), C_QDD)
                | (Some(EffectKind::JointSpring), C_Q)
                | (Some(EffectKind::Payload), C_PAYLOAD) => v > 0.0,
                _ => true,
            }
        })
    }

    /// Noise-weighted RSS reduction of `larger` over `smaller` (all joints, all data).
    fn gain(&self, smaller: &Model, larger: &Model) -> f64 {
        let (fs, fl) =
            (fit(&smaller.params(), self.gr, &self.w, &[0, 1]), fit(&larger.params(), self.gr, &self.w, &[0, 1]));
        (0..self.n)
            .map(|j| self.w[j] * (rss_joint(&fs, self.gr, j, &[0, 1]) - rss_joint(&fl, self.gr, j, &[0, 1])))
            .sum()
    }
}

/// Largest relative error of the nominal link inertials still taken as a plausible
/// explanation of a residual (CAD masses and inertias are rarely off by more).
const LINK_SCALE_MAX: f64 = 0.25;

/// The effects a wrong nominal link mass or inertia can imitate.
fn inertia_like(e: EffectKind) -> bool {
    matches!(e, EffectKind::Payload | EffectKind::Armature | EffectKind::TorqueOffset | EffectKind::JointSpring)
}

/// Look-alike check against the nominal model's own error: if scaling each link's nominal
/// inertials (by at most `LINK_SCALE_MAX`) explains the residual and the candidate is no
/// longer significant on joint `j` once those scales are free, the candidate is imitated
/// by a model error. Returns the largest scale (as a fraction) when it is.
fn model_error_lookalike(
    ctx: &Ctx,
    m: &Model,
    larger: &Model,
    j: usize,
    added: &dyn Fn(&Param) -> bool,
) -> Option<f64> {
    let mut base = m.clone();
    base.link_scale = true;
    let mut l = larger.clone();
    l.link_scale = true;
    let fb = fit(&base.params(), ctx.gr, &ctx.w, &[0, 1]);
    let smax =
        fb.params.iter().zip(&fb.theta).filter(|(p, _)| p.kind.is_none()).map(|(_, v)| v.abs()).fold(0.0, f64::max);
    if smax > LINK_SCALE_MAX {
        return None;
    }
    if ctx.joint_score(&base, &l, j, added).significant { None } else { Some(smax) }
}

/// The model with effect `e` added where it can go, for scoring on joint `j`.
fn propose(m: &Model, e: EffectKind, j: usize) -> Option<Model> {
    match e {
        EffectKind::Payload => None,
        EffectKind::Stribeck => None, // handled separately (needs Coulomb and a vs)
        EffectKind::TorqueOffset if m.has(j, EffectKind::JointSpring) => None,
        _ if m.has(j, e) => None,
        _ => Some(m.with(Some(j), e)),
    }
}

/// Scores every candidate against the current model.
fn score_candidates(ctx: &Ctx, m: &Model) -> Vec<(CandidateScore, Model)> {
    let n = ctx.n;
    let mut out = vec![];
    for e in EffectKind::ALL {
        let mut per_joint = vec![];
        let mut larger = m.clone();
        let mut lookalike: Vec<(usize, f64)> = vec![];
        match e {
            EffectKind::Payload => {
                if m.payload {
                    continue;
                }
                let l = m.with(None, e);
                let is_payload = |p: &Param| p.kind == Some(EffectKind::Payload);
                for j in 0..n {
                    let mut sc = ctx.joint_score(m, &l, j, &is_payload);
                    if sc.significant
                        && let Some(s) = model_error_lookalike(ctx, m, &l, j, &is_payload)
                    {
                        sc.significant = false;
                        lookalike.push((j, s));
                    }
                    per_joint.push(sc);
                }
                if per_joint.iter().any(|s| s.significant) {
                    larger = l;
                }
            }
            EffectKind::Stribeck => {
                for j in 0..n {
                    if !m.has(j, EffectKind::Coulomb) || m.has(j, EffectKind::Stribeck) {
                        per_joint.push(JointScore {
                            f: 0.0,
                            p: 1.0,
                            heldout_gain: 0.0,
                            effect_rms: 0.0,
                            significant: false,
                        });
                        continue;
                    }
                    // best vs on the grid, and fs > 0 (static above Coulomb friction)
                    let mut best: Option<(JointScore, Model)> = None;
                    for g in 0..STRIBECK_VS.len() {
                        let mut l = m.with(Some(j), EffectKind::Stribeck);
                        l.stribeck_vs[j] = g;
                        let f = fit(&l.params(), ctx.gr, &ctx.w, &[0, 1]);
                        let fs = f
                            .params
                            .iter()
                            .position(|p| p.kind == Some(EffectKind::Stribeck) && p.joint == Some(j))
                            .map(|i| f.theta[i]);
                        let mut sc = ctx.joint_score(m, &l, j, &|p| p.kind == Some(EffectKind::Stribeck));
                        if fs.is_none_or(|v| v <= 0.0) {
                            sc.significant = false;
                        }
                        if best.as_ref().is_none_or(|(b, _)| sc.f > b.f) {
                            best = Some((sc, l));
                        }
                    }
                    let (sc, l) = best.expect("grid not empty");
                    if sc.significant {
                        larger.per_joint[j] = l.per_joint[j].clone();
                        larger.stribeck_vs[j] = l.stribeck_vs[j];
                    }
                    per_joint.push(sc);
                }
            }
            _ => {
                for j in 0..n {
                    match propose(m, e, j) {
                        None => per_joint.push(JointScore {
                            f: 0.0,
                            p: 1.0,
                            heldout_gain: 0.0,
                            effect_rms: 0.0,
                            significant: false,
                        }),
                        Some(l) => {
                            // a spring is named only if its position column matters beyond
                            // a constant: test it against the model with an offset
                            let (base, sel): (Model, &dyn Fn(&Param) -> bool) = if e == EffectKind::JointSpring {
                                (m.with(Some(j), EffectKind::TorqueOffset), &|p: &Param| {
                                    p.kind == Some(EffectKind::JointSpring) && p.col == C_Q
                                })
                            } else {
                                (m.clone(), &move |p: &Param| p.kind == Some(e))
                            };
                            let l = if e == EffectKind::JointSpring {
                                l.without(Some(j), EffectKind::TorqueOffset)
                            } else {
                                l
                            };
                            let sc = ctx.joint_score(&base, &l, j, &|p| p.joint == Some(j) && sel(p));
                            if sc.significant {
                                larger.per_joint[j] = l.per_joint[j].clone();
                            }
                            per_joint.push(sc);
                        }
                    }
                }
            }
        }
        // look-alike check of inertia-like effects against the nominal model's own error,
        // with the effect in on the other joints where it is significant (so that a real
        // effect there does not inflate the link scales)
        if inertia_like(e) && e != EffectKind::Payload {
            for j in 0..n {
                if !per_joint[j].significant {
                    continue;
                }
                let mut base = larger.without(Some(j), e);
                let sel: Box<dyn Fn(&Param) -> bool> = if e == EffectKind::JointSpring {
                    base = base.with(Some(j), EffectKind::TorqueOffset);
                    Box::new(move |p: &Param| {
                        p.joint == Some(j) && p.kind == Some(EffectKind::JointSpring) && p.col == C_Q
                    })
                } else {
                    Box::new(move |p: &Param| p.joint == Some(j) && p.kind == Some(e))
                };
                if let Some(sc) = model_error_lookalike(ctx, &base, &larger, j, &*sel) {
                    per_joint[j].significant = false;
                    lookalike.push((j, sc));
                }
            }
            for &(j, _) in &lookalike {
                larger.per_joint[j] = m.per_joint[j].clone();
            }
        }
        let joints: Vec<usize> = (0..n).filter(|&j| per_joint[j].significant).collect();
        let score = if joints.is_empty() { 0.0 } else { ctx.gain(m, &larger) };
        let reason = if lookalike.is_empty() {
            String::new()
        } else {
            format!(
                "on joint(s) {} it is imitated as well by the nominal link inertials being off by up to {:.0} % (not named)",
                lookalike.iter().map(|(j, _)| (j + 1).to_string()).collect::<Vec<_>>().join(", "),
                100.0 * lookalike.iter().map(|x| x.1).fold(0.0, f64::max)
            )
        };
        out.push((CandidateScore { effect: e, per_joint, joints, score, accepted: false, reason }, larger));
    }
    out
}

/// Removes effects that are no longer significant given the others (backward step).
fn backward(ctx: &Ctx, m: &Model) -> Model {
    let mut m = m.clone();
    loop {
        let mut worst: Option<(f64, Option<usize>, EffectKind)> = None;
        for j in 0..ctx.n {
            for &e in &m.per_joint[j] {
                let smaller = m.without(Some(j), e);
                let sc = ctx.joint_score(&smaller, &m, j, &|p| p.joint == Some(j) && p.kind == Some(e));
                if !sc.significant && worst.as_ref().is_none_or(|w| sc.f < w.0) {
                    worst = Some((sc.f, Some(j), e));
                }
            }
        }
        if m.payload {
            let smaller = m.without(None, EffectKind::Payload);
            let any = (0..ctx.n)
                .any(|j| ctx.joint_score(&smaller, &m, j, &|p| p.kind == Some(EffectKind::Payload)).significant);
            if !any {
                worst = Some((0.0, None, EffectKind::Payload));
            }
        }
        match worst {
            Some((_, j, e)) => m = m.without(j, e),
            None => return m,
        }
    }
}

/// Smallest armature (payload) named, as a fraction of the nominal inertia on the joint
/// (of the terminal link's nominal mass).
const NOMINAL_UNCERTAINTY: f64 = 0.1;

/// Mean over (a subsample of) the log of the nominal mass matrix's diagonal.
fn mean_mass_diag(robot: &Robot, q: &[f64], n: usize) -> Result<Vec<f64>> {
    let t_len = q.len() / n;
    let step = (t_len / 200).max(1);
    let qs: Vec<f64> = (0..t_len).step_by(step).flat_map(|k| q[k * n..(k + 1) * n].to_vec()).collect();
    let m = qs.len() / n;
    let mut out = vec![0.0; m * n * n];
    batch::mass_matrix_batch(robot, &qs, &mut out).map_err(|e| bad(format!("mass matrix: {e}")))?;
    Ok((0..n).map(|j| (0..m).map(|k| out[k * n * n + j * n + j]).sum::<f64>() / m as f64).collect())
}

/// Differentiation cutoffs tried (Hz), at most a quarter of the sample rate.
const CUTOFF_GRID: [f64; 5] = [10.0, 20.0, 40.0, 80.0, 160.0];

/// Everything derived from the log for one conditioning.
struct Prepared {
    s: Signals,
    tau_nom: Vec<f64>,
    d: Dictionary,
    gr: Grams,
}

fn prepare(
    robot: &Robot,
    log: &JointLog,
    opts: &DiagnoseOptions,
    cutoff_hz: f64,
    align: Option<f64>,
) -> Result<Prepared> {
    let n = robot.dof();
    let mut s = condition(log, opts, cutoff_hz)?;
    if let Some(a) = align {
        let delta = accel_step(&s.qd, n, s.dt);
        for (x, dl) in s.qdd.iter_mut().zip(&delta) {
            *x += a * dl;
        }
        s.align = a;
    }
    let t_len = s.t.len();
    let mut tau_nom = vec![0.0; t_len * n];
    batch::rnea_batch(robot, &s.q, &s.qd, &s.qdd, &mut tau_nom).map_err(|e| bad(format!("nominal model: {e}")))?;
    let d = build_dictionary(robot, &s, &tau_nom)?;
    let gr = grams(&d, t_len, opts.blocks_per_fold.max(1));
    Ok(Prepared { s, tau_nom, d, gr })
}

/// `qdd_fwd[k] - qdd_fwd[k-1]` with `qdd_fwd[k] = (qd[k+1] - qd[k]) / dt`: adding `a` times
/// it to the central-difference acceleration moves it by `a` samples in time
/// (`a = 1/2`: the forward difference, the acceleration a torque applied over
/// `[t_k, t_k+1)` produces; `-1/2`: the backward difference).
fn accel_step(qd: &[f64], n: usize, dt: f64) -> Vec<f64> {
    let t_len = qd.len() / n;
    let mut out = vec![0.0; qd.len()];
    for k in 1..t_len.saturating_sub(1) {
        for j in 0..n {
            let f1 = (qd[(k + 1) * n + j] - qd[k * n + j]) / dt;
            let f0 = (qd[k * n + j] - qd[(k - 1) * n + j]) / dt;
            out[k * n + j] = f1 - f0;
        }
    }
    out
}

/// The model with every candidate on every joint (and a payload): what is left after it
/// is the noise plus what no effect of the vocabulary explains.
fn all_model(n: usize) -> Model {
    let mut all = Model::new(n);
    for j in 0..n {
        all.per_joint[j] =
            vec![EffectKind::Coulomb, EffectKind::Viscous, EffectKind::Armature, EffectKind::JointSpring];
    }
    all.payload = true;
    all
}

/// Noise std and lag-1 autocorrelation per joint from the residual of [`all_model`], and
/// that residual.
fn noise_of_all_model(d: &Dictionary, gr: &Grams, n: usize, t_len: usize) -> (Vec<f64>, Vec<f64>, Vec<f64>) {
    let unit = vec![1.0; n];
    let f_all = fit(&all_model(n).params(), gr, &unit, &[0, 1]);
    let e_all = effect_torque(&f_all, d, n, t_len);
    let r_all: Vec<f64> = (0..t_len * n).map(|i| d.r0[i % n][i / n] - e_all[i]).collect();
    let (sigma, rho): (Vec<f64>, Vec<f64>) = (0..n).map(|j| noise_and_tau(&r_all, n, j)).unzip();
    (sigma, rho, r_all)
}

impl Prepared {
    /// Sum over joints of log(RSS) of the all-candidates model (scale-free across joints).
    fn log_rss_all(&self) -> f64 {
        let n = self.d.cols.len();
        let unit = vec![1.0; n];
        let f = fit(&all_model(n).params(), &self.gr, &unit, &[0, 1]);
        (0..n).map(|j| rss_joint(&f, &self.gr, j, &[0, 1]).max(1e-300).ln()).sum()
    }

    /// The time alignment `a` (samples, clamped to +-1) between torque and motion that
    /// best explains the residual of the all-candidates model: the torque of the shift,
    /// `M(q) a accel_step`, regressed on it, weighted by the noise.
    fn alignment(&self, robot: &Robot) -> Result<f64> {
        let n = self.d.cols.len();
        let t_len = self.s.t.len();
        let (sigma, _, r_all) = noise_of_all_model(&self.d, &self.gr, n, t_len);
        let delta = accel_step(&self.s.qd, n, self.s.dt);
        let zero = vec![0.0; t_len * n];
        let (mut m_d, mut m_0) = (vec![0.0; t_len * n], vec![0.0; t_len * n]);
        batch::rnea_batch(robot, &self.s.q, &zero, &delta, &mut m_d).map_err(|e| bad(format!("alignment: {e}")))?;
        batch::rnea_batch(robot, &self.s.q, &zero, &zero, &mut m_0).map_err(|e| bad(format!("alignment: {e}")))?;
        let (mut num, mut den) = (0.0, 0.0);
        for k in 0..t_len {
            for j in 0..n {
                let c = m_d[k * n + j] - m_0[k * n + j];
                let w = 1.0 / (sigma[j] * sigma[j]);
                num += w * c * r_all[k * n + j];
                den += w * c * c;
            }
        }
        Ok(if den > 0.0 { (num / den).clamp(-1.0, 1.0) } else { 0.0 })
    }
}

// ---------------------------------------------------------------------------------------
// The diagnosis
// ---------------------------------------------------------------------------------------

/// Diagnoses `log` against the nominal `robot` (module docs for the method).
pub fn diagnose(robot: &Robot, log: &JointLog, opts: &DiagnoseOptions) -> Result<Diagnosis> {
    let n = robot.dof();
    if log.dof() != n {
        return Err(bad(format!("the log has {} joints, the robot {n}", log.dof())));
    }
    let fs = 1.0 / log.median_dt().ok_or_else(|| bad("need at least two distinct stamps"))?;
    // the differentiation cutoff: given, or the one on a grid that leaves the least
    // residual once every candidate effect is in (too low a cutoff removes real
    // acceleration the torque contains, too high lets differentiation noise through)
    let cutoffs: Vec<f64> = match opts.cutoff_hz {
        Some(c) => vec![c],
        None => CUTOFF_GRID.iter().copied().filter(|&c| c <= 0.25 * fs).collect(),
    };
    let cutoffs = if cutoffs.is_empty() { vec![dsp::default_cutoff(fs)] } else { cutoffs };
    let mut best: Option<(f64, Prepared)> = None;
    for &c in &cutoffs {
        let p = prepare(robot, log, opts, c, None)?;
        let score = p.log_rss_all();
        if best.as_ref().is_none_or(|b| score < b.0) {
            best = Some((score, p));
        }
    }
    let p = best.expect("at least one cutoff").1;
    // torque-to-motion alignment (a fraction of a sample), then everything again
    let alpha = p.alignment(robot)?;
    let Prepared { s, tau_nom, d, gr } = prepare(robot, log, opts, p.s.cutoff_hz, Some(alpha))?;
    let t_len = s.t.len();
    let (sigma, rho, _) = noise_of_all_model(&d, &gr, n, t_len);
    let w: Vec<f64> = sigma.iter().map(|s| 1.0 / (s * s)).collect();
    let m_diag = mean_mass_diag(robot, &s.q, n)?;
    let terminal_mass = robot.params()[10 * (n - 1)];
    let h_all: Vec<f64> = {
        let pa = all_model(n).params();
        let (f0, f1) = (fit(&pa, &gr, &w, &[0]), fit(&pa, &gr, &w, &[1]));
        (0..n).map(|j| rss_joint(&f0, &gr, j, &[1]) + rss_joint(&f1, &gr, j, &[0])).collect()
    };
    let ctx = Ctx { gr: &gr, m_diag, terminal_mass, w, sigma: sigma.clone(), h_all, tau: rho, n, opts };

    let r_nom: Vec<f64> = (0..t_len * n).map(|i| d.r0[i % n][i / n]).collect();
    let baseline_rms = rms_per_joint(&r_nom, n);
    let mut m = Model::new(n);
    let mut steps: Vec<(Step, Model)> = vec![];
    let mut rms_cur = baseline_rms.clone();
    let mut final_candidates = vec![];
    for _ in 0..opts.max_steps {
        let mut cands = score_candidates(&ctx, &m);
        let best = cands
            .iter()
            .enumerate()
            .filter(|(_, c)| !c.0.joints.is_empty())
            .max_by(|a, b| a.1.0.score.total_cmp(&b.1.0.score))
            .map(|(i, _)| i);
        let Some(bi) = best else {
            for c in cands.iter_mut() {
                if c.0.reason.is_empty() {
                    c.0.reason = "not significant on any joint".into();
                }
            }
            final_candidates = cands.into_iter().map(|c| c.0).collect();
            break;
        };
        let best_score = cands[bi].0.score;
        let best_name = cands[bi].0.effect.label();
        for (i, c) in cands.iter_mut().enumerate() {
            c.0.accepted = i == bi;
            c.0.reason = if i == bi {
                "explains the most residual".into()
            } else if c.0.joints.is_empty() {
                if c.0.reason.is_empty() { "not significant on any joint".into() } else { c.0.reason.clone() }
            } else {
                format!(
                    "explains less than {best_name} ({:.0} % of its weighted residual reduction)",
                    100.0 * c.0.score / best_score
                )
            };
        }
        let effect = cands[bi].0.effect;
        let joints = cands[bi].0.joints.clone();
        let m_new = backward(&ctx, &cands[bi].1);
        let f = fit(&m_new.params(), &gr, &ctx.w, &[0, 1]);
        let e = effect_torque(&f, &d, n, t_len);
        let r: Vec<f64> = (0..t_len * n).map(|i| d.r0[i % n][i / n] - e[i]).collect();
        let rms_after = rms_per_joint(&r, n);
        let step = Step {
            effect,
            joints,
            evidence: vec![],
            candidates: cands.into_iter().map(|c| c.0).collect(),
            rms_before: rms_cur.clone(),
            rms_after: rms_after.clone(),
        };
        rms_cur = rms_after;
        if m_new == m {
            break; // the backward step undid it: nothing new
        }
        m = m_new;
        steps.push((step, m.clone()));
    }
    let _ = &d.q_mean;
    assemble(robot, opts, &s, &d, &ctx, &tau_nom, steps, final_candidates, &m, baseline_rms, &r_nom)
}

#[allow(clippy::too_many_arguments)]
fn assemble(
    robot: &Robot,
    opts: &DiagnoseOptions,
    s: &Signals,
    d: &Dictionary,
    ctx: &Ctx,
    tau_nom: &[f64],
    steps: Vec<(Step, Model)>,
    final_candidates: Vec<CandidateScore>,
    m: &Model,
    baseline_rms: Vec<f64>,
    r_nom: &[f64],
) -> Result<Diagnosis> {
    let n = ctx.n;
    let t_len = s.t.len();
    let names = &robot.joint_names;
    let f = fit(&m.params(), ctx.gr, &ctx.w, &[0, 1]);
    let e = effect_torque(&f, d, n, t_len);
    let r_final: Vec<f64> = (0..t_len * n).map(|i| r_nom[i] - e[i]).collect();
    let final_rms = rms_per_joint(&r_final, n);
    let raw: Vec<(EffectKind, Model)> = steps.iter().map(|(st, ms)| (st.effect, ms.clone())).collect();
    let regimes_before = regimes(s, r_nom, n);
    let regimes_after = regimes(s, &r_final, n);

    // effects in the order found, with the final fit's parameters; an effect whose
    // joints were all dropped by a later backward step is not reported
    let theta_of = |j: usize, kind: EffectKind, col: usize| -> f64 {
        f.params
            .iter()
            .position(|p| p.joint == Some(j) && p.kind == Some(kind) && p.col == col)
            .map(|i| f.theta[i])
            .unwrap_or(0.0)
    };
    let mut effects = vec![];
    let mut out_steps = vec![];
    let mut seen: Vec<EffectKind> = vec![];
    for (mut st, _) in steps {
        if seen.contains(&st.effect) {
            // the same effect found again on more joints: merge into the first entry
            let pos = out_steps.iter().position(|x: &Step| x.effect == st.effect).expect("seen");
            out_steps[pos].joints.extend(st.joints.iter().copied());
            out_steps[pos].rms_after = st.rms_after.clone();
            continue;
        }
        seen.push(st.effect);
        st.joints.sort();
        out_steps.push(st);
    }
    for st in out_steps.iter_mut() {
        let kind = st.effect;
        let joints: Vec<usize> = match kind {
            EffectKind::Payload => (0..n).collect(),
            // Stribeck replaces Coulomb on its joints
            EffectKind::Coulomb => (0..n).filter(|&j| m.has(j, kind) && !m.has(j, EffectKind::Stribeck)).collect(),
            _ => (0..n).filter(|&j| m.has(j, kind)).collect(),
        };
        if kind != EffectKind::Payload && joints.is_empty() || kind == EffectKind::Payload && !m.payload {
            continue;
        }
        let mut params = serde_json::Map::new();
        let list = |v: Vec<f64>| serde_json::Value::from(v);
        match kind {
            EffectKind::Coulomb => {
                params.insert(
                    "fc".into(),
                    list(joints.iter().map(|&j| theta_of(j, EffectKind::Coulomb, C_SIGN)).collect()),
                );
            }
            EffectKind::Viscous => {
                params.insert("fv".into(), list(joints.iter().map(|&j| theta_of(j, kind, C_QD)).collect()));
            }
            EffectKind::Armature => {
                params.insert("ia".into(), list(joints.iter().map(|&j| theta_of(j, kind, C_QDD)).collect()));
            }
            EffectKind::TorqueOffset => {
                params.insert("tau0".into(), list(joints.iter().map(|&j| theta_of(j, kind, C_ONE)).collect()));
            }
            EffectKind::JointSpring => {
                // k (q - qm) + c = k (q - q0) with q0 = qm - c / k
                let k: Vec<f64> = joints.iter().map(|&j| theta_of(j, kind, C_Q)).collect();
                let q0: Vec<f64> =
                    joints.iter().zip(&k).map(|(&j, &k)| d.q_mean[j] - theta_of(j, kind, C_ONE) / k).collect();
                params.insert("k".into(), list(k));
                params.insert("q0".into(), list(q0));
            }
            EffectKind::Stribeck => {
                params.insert(
                    "fc".into(),
                    list(joints.iter().map(|&j| theta_of(j, EffectKind::Coulomb, C_SIGN)).collect()),
                );
                params.insert(
                    "fs".into(),
                    list(joints.iter().map(|&j| theta_of(j, kind, C_STRIBECK + m.stribeck_vs[j])).collect()),
                );
                params.insert("vs".into(), list(joints.iter().map(|&j| d.vs[j][m.stribeck_vs[j]]).collect()));
            }
            EffectKind::Payload => {
                let mut p10 = [0.0; 10];
                for (i, p) in f.params.iter().enumerate() {
                    if p.kind == Some(EffectKind::Payload) {
                        p10[p.col - C_PAYLOAD] = f.theta[i];
                    }
                }
                let li = ivdyn_core::LinkInertia(p10);
                match li.to_mass_com_inertia(n - 1) {
                    Ok((mass, c, ic)) => {
                        params.insert("mass".into(), mass.into());
                        params.insert("com".into(), list(vec![c.x, c.y, c.z]));
                        params.insert(
                            "inertia".into(),
                            list(vec![ic[(0, 0)], ic[(0, 1)], ic[(0, 2)], ic[(1, 1)], ic[(1, 2)], ic[(2, 2)]]),
                        );
                    }
                    Err(_) => {
                        params.insert("mass".into(), p10[0].into());
                        params.insert("com".into(), serde_json::Value::Null);
                        params.insert("inertia".into(), serde_json::Value::Null);
                    }
                }
            }
        }
        st.joints = joints.clone();
        st.evidence = evidence(st, &params, names, d, &regimes_before, ctx);
        effects.push(EffectJson {
            name: kind.name().into(),
            joints: if kind == EffectKind::Payload {
                vec![]
            } else {
                joints.iter().map(|&j| names[j].clone()).collect()
            },
            parameters: params,
            rms_before: st.rms_before.clone(),
            rms_after: st.rms_after.clone(),
        });
    }
    let kept: Vec<Step> =
        out_steps.into_iter().filter(|st| effects.iter().any(|e| e.name == st.effect.name())).collect();
    let predicted = step_predictions(&raw, &kept, ctx, d, tau_nom);
    let gaps = remaining_gaps(ctx, m, &final_rms, &regimes_after, names);
    let verdict = if effects.is_empty() && gaps.is_empty() {
        "nothing significant missing: the nominal model explains the log down to the noise".to_string()
    } else if effects.is_empty() {
        format!("no effect of the vocabulary is significantly missing, but {gaps}")
    } else {
        let list: Vec<String> = kept
            .iter()
            .map(|st| {
                if st.effect == EffectKind::Payload {
                    st.effect.label().to_string()
                } else {
                    format!(
                        "{} on {}",
                        st.effect.label(),
                        st.joints.iter().map(|&j| names[j].as_str()).collect::<Vec<_>>().join(", ")
                    )
                }
            })
            .collect();
        if gaps.is_empty() {
            format!("missing: {}; after adding them nothing significant is left", list.join("; "))
        } else {
            format!("missing: {}; after adding them no other effect is significant, but {gaps}", list.join("; "))
        }
    };
    let traces =
        Traces { t: s.t.clone(), q: s.q.clone(), qd: s.qd.clone(), qdd: s.qdd.clone(), tau: s.tau.clone(), predicted };
    Ok(Diagnosis {
        json: DiagnosisJson { effects, baseline_rms, final_rms, joints: names.clone() },
        steps: kept,
        final_candidates,
        noise_std: ctx.sigma.clone(),
        regimes_before,
        regimes_after,
        verdict,
        traces,
        info: LogInfo {
            file: opts.log_name.clone(),
            urdf: opts.urdf_name.clone(),
            samples: t_len,
            duration: s.t.last().copied().unwrap_or(0.0) - s.t.first().copied().unwrap_or(0.0),
            rate: 1.0 / s.dt,
            velocity_in_log: s.velocity_in_log,
            cutoff_hz: s.cutoff_hz,
            align_samples: s.align,
        },
    })
}

/// The predicted torques of the report: the nominal model, then one per reported step.
/// A step found again later (more joints) is merged into its first report, so reported
/// step `i` shows the model after the last search step that added nothing reported later
/// than `i` (effects not reported at all count as earlier): with nothing merged, the model
/// after each search step; the last one is always the model after the last search step.
fn step_predictions(
    raw: &[(EffectKind, Model)],
    kept: &[Step],
    ctx: &Ctx,
    d: &Dictionary,
    tau_nom: &[f64],
) -> Vec<Vec<f64>> {
    let (n, t_len) = (ctx.n, tau_nom.len() / ctx.n);
    let rank = |e: EffectKind| kept.iter().position(|st| st.effect == e).unwrap_or(0);
    let mut predicted = vec![tau_nom.to_vec()];
    for i in 0..kept.len() {
        let Some(k) = raw.iter().take_while(|(e, _)| rank(*e) <= i).count().checked_sub(1) else {
            predicted.push(tau_nom.to_vec());
            continue;
        };
        let fs = fit(&raw[k].1.params(), ctx.gr, &ctx.w, &[0, 1]);
        let es = effect_torque(&fs, d, n, t_len);
        predicted.push((0..t_len * n).map(|j| tau_nom[j] + es[j]).collect());
    }
    predicted
}

/// What is left above the noise after the final model, in words (empty if nothing): per
/// joint whose final RMS exceeds 1.5 noise std, where the residual is (velocity reversals)
/// and whether per-link scale factors of the nominal inertials explain it (a wrong nominal
/// model rather than a missing effect).
fn remaining_gaps(ctx: &Ctx, m: &Model, final_rms: &[f64], reg: &[Regimes], names: &[String]) -> String {
    let mut scaled = m.clone();
    scaled.link_scale = true;
    let (f0, f1) = (fit(&m.params(), ctx.gr, &ctx.w, &[0, 1]), fit(&scaled.params(), ctx.gr, &ctx.w, &[0, 1]));
    let smax =
        f1.params.iter().zip(&f1.theta).filter(|(p, _)| p.kind.is_none()).map(|(_, v)| v.abs()).fold(0.0, f64::max);
    let mut parts = vec![];
    for j in 0..ctx.n {
        if final_rms[j] <= 1.5 * ctx.sigma[j] {
            continue;
        }
        let rows = (ctx.gr.rows[j][0] + ctx.gr.rows[j][1]) as f64;
        let (r0, r1) = (rss_joint(&f0, ctx.gr, j, &[0, 1]), rss_joint(&f1, ctx.gr, j, &[0, 1]));
        let above = (r0 - rows * ctx.sigma[j].powi(2)).max(1e-300);
        let share = ((r0 - r1) / above).clamp(0.0, 1.0);
        let mut why = vec![];
        let r = &reg[j];
        if r.rms_reversal.is_finite() && r.rms_reversal > 2.0 * r.rms_rest {
            why.push(format!(
                "concentrated at velocity reversals ({:.3} N m there vs {:.3} elsewhere: friction near zero speed that the friction models describe only roughly)",
                r.rms_reversal, r.rms_rest
            ));
        }
        if share >= 0.5 && smax <= LINK_SCALE_MAX {
            why.push(format!(
                "scaling the nominal link inertials by up to {:.0} % explains {:.0} % of it: the nominal model's own parameters look off (re-identify them: ivdyn identify)",
                100.0 * smax,
                100.0 * share
            ));
        } else if share >= 0.5 {
            why.push(format!(
                "it follows the rigid-body terms (per-link scale factors of the nominal inertials explain {:.0} % of it, with factors up to {:.1}): the nominal inertials are far off (re-identify them: ivdyn identify)",
                100.0 * share,
                1.0 + smax
            ));
        }
        if why.is_empty() {
            why.push("not explained by any effect of the vocabulary".into());
        }
        parts.push(format!(
            "{}: {:.3} N m vs noise {:.3} N m, {}",
            names[j],
            final_rms[j],
            ctx.sigma[j],
            why.join("; ")
        ));
    }
    if parts.is_empty() {
        String::new()
    } else {
        format!("the residual stays above the noise on {}", parts.join(" | "))
    }
}

/// Sentences a user understands, from the regimes of the nominal residual and the fit.
fn evidence(
    st: &Step,
    params: &serde_json::Map<String, serde_json::Value>,
    names: &[String],
    _d: &Dictionary,
    reg: &[Regimes],
    ctx: &Ctx,
) -> Vec<String> {
    let get = |k: &str, i: usize| params.get(k).and_then(|v| v.get(i)).and_then(|v| v.as_f64()).unwrap_or(f64::NAN);
    let mut out = vec![];
    let cand = st.candidates.iter().find(|c| c.effect == st.effect);
    for (i, &j) in st.joints.iter().enumerate() {
        let r = &reg[j];
        let name = &names[j];
        let gain = cand.map(|c| c.per_joint[j].heldout_gain).unwrap_or(f64::NAN);
        let tail = format!(
            "on held-out data it removes {:.0} % of the residual that any effect can explain (RMS {:.3} -> {:.3} N m, noise {:.3} N m)",
            100.0 * gain,
            st.rms_before[j],
            st.rms_after[j],
            ctx.sigma[j]
        );
        let s = match st.effect {
            EffectKind::Coulomb => format!(
                "{name}: the residual jumps by {:.3} N m at each of its {} velocity reversals, in the direction of the new velocity: Coulomb friction fc = {:.3} N m; {tail}",
                r.reversal_jump,
                r.reversals,
                get("fc", i)
            ),
            EffectKind::Stribeck => format!(
                "{name}: near zero velocity the friction rises {:.3} N m above its Coulomb level {:.3} N m and decays within {:.3} rad/s: Stribeck friction; {tail}",
                get("fs", i),
                get("fc", i),
                get("vs", i)
            ),
            EffectKind::Viscous => format!(
                "{name}: the residual grows in proportion to the velocity (correlation {:.2}), {:.3} N m per rad/s: viscous friction; {tail}",
                r.corr_qd,
                get("fv", i)
            ),
            EffectKind::Armature => format!(
                "{name}: the residual follows the acceleration (correlation {:.2}), {:.4} kg m^2: inertia the links do not have, rotor inertia (armature); {tail}",
                r.corr_qdd,
                get("ia", i)
            ),
            EffectKind::TorqueOffset => format!(
                "{name}: the residual has a constant mean of {:.3} N m at every pose and speed: torque offset; {tail}",
                get("tau0", i)
            ),
            EffectKind::JointSpring => format!(
                "{name}: the residual grows with the position (correlation {:.2}), {:.3} N m per rad, zero at q = {:.3} rad: joint spring; {tail}",
                r.corr_q,
                get("k", i),
                get("q0", i)
            ),
            EffectKind::Payload => String::new(),
        };
        if !s.is_empty() {
            out.push(s);
        }
    }
    if st.effect == EffectKind::Payload {
        let m = params.get("mass").and_then(|v| v.as_f64()).unwrap_or(f64::NAN);
        let com = params
            .get("com")
            .and_then(|v| v.as_array())
            .map(|a| {
                format!(
                    "[{}]",
                    a.iter().map(|x| format!("{:.4}", x.as_f64().unwrap_or(f64::NAN))).collect::<Vec<_>>().join(", ")
                )
            })
            .unwrap_or_else(|| "(not identifiable)".into());
        let js: Vec<&str> = cand.map(|c| c.joints.iter().map(|&j| names[j].as_str()).collect()).unwrap_or_default();
        out.push(format!(
            "the residuals of {} follow pose and acceleration together, as the torques of one rigid body on the last link would: a payload of {m:.3} kg with its centre of mass at {com} m (terminal link frame)",
            js.join(", ")
        ));
        for &j in &st.joints {
            if st.rms_before[j] > 1.5 * ctx.sigma[j] {
                out.push(format!(
                    "{}: RMS {:.3} -> {:.3} N m (noise {:.3} N m)",
                    names[j], st.rms_before[j], st.rms_after[j], ctx.sigma[j]
                ));
            }
        }
    }
    // the look-alikes it beat
    for c in &st.candidates {
        if c.effect != st.effect && !c.joints.is_empty() {
            out.push(format!("{} also explains part of it, {}", c.effect.label(), c.reason));
        }
    }
    out
}

//! End-to-end pipelines behind the `ivdyn` command line (and, later, the Python
//! bindings): [`identify`], [`payload`] and [`simulate`]. Each takes a [`Robot`] and
//! in-memory logs and returns a serialisable report; the command line only adds file
//! handling, progress bars and printing.
//!
//! Choices made here (documented in `docs/cli.md`):
//!
//! * conditioning: [`signal::condition`] (duplicate stamps dropped, uneven stamps
//!   resampled, `q` smoothed and differentiated: zero-phase Butterworth + central
//!   differences; the log's own velocities are not used);
//! * **parallel filtering**: the measured torque and every column of the stacked base
//!   regressor go through the same zero-phase low-pass ([`signal::Decimator`], default
//!   factor 1: the default differentiation filter), then are decimated by the same factor;
//! * `iv` instrument: with a command topic (`u`), the regressor at `(q, qd, qdd_hat)` with
//!   `qdd_hat = FD_nominal(q, qd, u)` (the nominal model's forward dynamics driven by the
//!   command, which carries no torque-measurement noise). The paper's per-joint LTI model
//!   eq (35) was tried first and is a poor instrument on a UR5 (the command is dominated by
//!   gravity, which a per-joint LTI model ignores: validation RMS 0.17 N m against 0.016 for
//!   WLS). Without a command: the regressor on a closed-loop simulation of the nominal model
//!   tracking the measured positions (the stand-in control law of `idim-iv`). The
//!   pointwise "forward dynamics driven by the measured torque" instrument was also tried
//!   and rejected: it shares the torque noise with the output (biased, DWH always rejects);
//! * `idim-iv`: [`ident::idim_iv`] with a stand-in control law, a stiff PD on the measured
//!   positions scaled by the nominal mass matrix plus the nominal inverse dynamics of the
//!   measured motion as feed-forward (10 Hz bandwidth, damping 0.7);
//! * [`simulate`]: inverse dynamics (`rnea`) of the true model along the trajectory (exact
//!   torques, no integration), then noise and quantisation on the recorded signals.

use std::sync::Arc;

use nalgebra::{DMatrix, Matrix3, Vector3};
use serde::{Deserialize, Serialize};

use crate::error::{Error, Result};
use crate::ident::{self, fit_iv, fit_ls, BaseParams, FitReport, LsAccumulator};
use crate::joint_acc::JointAccs;
use crate::io::JointLog;
use crate::signal::{self, Butterworth, ConditionOptions, Decimator};
use crate::Robot;
use ivdyn_core::estim::TerminalSpec;
use ivdyn_core::params::LINK_PARAMS;
use ivdyn_core::rng::Rng;
use ivdyn_core::LinkInertia;

// ---------------------------------------------------------------------------------------
// Progress reporting
// ---------------------------------------------------------------------------------------

/// Receives progress of the long steps (the command line draws bars with it).
pub trait Progress: Send + Sync {
    /// A step starts, `total` units of work (0: unknown).
    fn begin(&self, stage: &str, total: u64);
    /// `n` more units done.
    fn advance(&self, n: u64);
    /// The step is over.
    fn end(&self);
}

/// Shared progress sink.
pub type ProgressSink = Option<Arc<dyn Progress>>;

pub(crate) struct Stage<'a>(&'a ProgressSink);
impl<'a> Stage<'a> {
    pub(crate) fn begin(p: &'a ProgressSink, name: &str, total: u64) -> Self {
        if let Some(p) = p {
            p.begin(name, total);
        }
        Stage(p)
    }
    pub(crate) fn advance(&self, n: u64) {
        if let Some(p) = self.0 {
            p.advance(n);
        }
    }
}
impl Drop for Stage<'_> {
    fn drop(&mut self) {
        if let Some(p) = self.0 {
            p.end();
        }
    }
}

// ---------------------------------------------------------------------------------------
// Options and reports
// ---------------------------------------------------------------------------------------

/// Estimation method of [`identify`].
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum Method {
    /// Ordinary least squares.
    Ols,
    /// Two-step weighted LS: OLS, then weights = 1 / (per-joint residual variance).
    Wls,
    /// Instrumental variables (weighted as WLS); see the module docs for the instrument.
    Iv,
    /// IDIM-IV: the instrument is the regressor on a closed-loop simulation.
    IdimIv,
}

impl Method {
    /// The name used on the command line and in JSON.
    pub fn name(&self) -> &'static str {
        match self {
            Method::Ols => "ols",
            Method::Wls => "wls",
            Method::Iv => "iv",
            Method::IdimIv => "idim-iv",
        }
    }
}

/// Options of [`identify`].
#[derive(Clone)]
pub struct IdentifyOptions {
    /// Estimation method (default WLS).
    pub method: Method,
    /// Conditioning (resampling, differentiation).
    pub condition: ConditionOptions,
    /// Decimation factor after the parallel filter (default 0: automatic, see
    /// [`auto_decimation`]; 1: filter only).
    pub decimate: usize,
    /// Fraction of the log (its tail) held out for validation when no validation log is
    /// given (default 0.25; 0 disables validation).
    pub validation_fraction: f64,
    /// A second log for validation (then the whole first log is used for the fit).
    pub validation_log: Option<JointLog>,
    /// Random states used to find the base parameters (default 200) and their seed.
    pub base_samples: usize,
    /// Seed of the base-parameter states.
    pub seed: u64,
    /// IDIM-IV iterations and relative tolerance.
    pub idim_max_iter: usize,
    /// IDIM-IV convergence tolerance on the relative change of the estimate.
    pub idim_tol: f64,
    /// Drive parameters to estimate (default: all of `fc, fv, ia, tau0`).
    pub drive: DriveTerms,
    /// Progress sink.
    pub progress: ProgressSink,
    /// Also fit physically consistent full parameters ([`ident::consistent`]).
    pub consistent: bool,
}

impl Default for IdentifyOptions {
    fn default() -> Self {
        IdentifyOptions {
            method: Method::Wls,
            condition: ConditionOptions::default(),
            decimate: 0,
            validation_fraction: 0.25,
            validation_log: None,
            base_samples: 200,
            seed: 1,
            idim_max_iter: 10,
            idim_tol: 1e-3,
            drive: DriveTerms::default(),
            progress: None,
            consistent: false,
        }
    }
}

/// One base parameter of the report.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct BaseValue {
    /// Readable combination, e.g. `"wrist_1_link.Izz + ..."`.
    pub name: String,
    /// Estimate (`null` when not excited).
    pub value: f64,
    /// Standard deviation.
    pub std: f64,
    /// Relative standard deviation in percent.
    pub rel_std_pct: f64,
    /// Value of the nominal (URDF) model for the same combination.
    pub nominal: f64,
}

/// Per-joint quality of a torque prediction.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct Quality {
    /// Which data: `"fit"`, `"tail 25% of the log"`, or the validation log's name.
    pub data: String,
    /// Samples used.
    pub samples: usize,
    /// RMS of `measured - predicted` per joint (N m).
    pub rms: Vec<f64>,
    /// Coefficient of determination per joint.
    pub r2: Vec<f64>,
    /// RMS of the measured torque per joint (N m), for scale.
    pub tau_rms: Vec<f64>,
}

/// The Durbin-Wu-Hausman LS-vs-IV test.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct Dwh {
    /// Statistic (chi-square under "LS unbiased").
    pub statistic: f64,
    /// Degrees of freedom.
    pub dof: usize,
    /// p-value.
    pub p_value: f64,
    /// `p < 0.01`: LS is biased.
    pub ls_biased: bool,
    /// The verdict in words.
    pub verdict: String,
}

/// Full parameter vector, reloadable with [`load_params`].
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
pub struct ParamsFile {
    /// Robot name.
    pub robot: String,
    /// Joint names, base to tip.
    pub joints: Vec<String>,
    /// Parameter names (`<link>.m`, ..., `<joint>.fc`, ...).
    pub names: Vec<String>,
    /// Values (SI).
    pub theta: Vec<f64>,
}

/// Result of [`identify`].
#[derive(Debug, Clone, Serialize)]
pub struct IdentifyReport {
    /// Method used.
    pub method: String,
    /// The instrument (IV methods), in words; `null` for LS.
    pub instrument: Option<String>,
    /// Joint names (order of every per-joint list).
    pub joints: Vec<String>,
    /// Drive parameters estimated per joint (subset of `fc, fv, ia, tau0`).
    pub drive_terms: Vec<String>,
    /// Sample rate of the data fitted (after decimation), Hz.
    pub sample_rate_hz: f64,
    /// Decimation factor.
    pub decimation: usize,
    /// Zero-phase cut-off of the parallel filter, Hz.
    pub filter_cutoff_hz: f64,
    /// Rows (samples x joints) in the fit.
    pub rows: usize,
    /// Numerical rank.
    pub rank: usize,
    /// Condition number of the (scaled) regressor.
    pub condition_number: f64,
    /// Residual variance (weighted units).
    pub sigma2: f64,
    /// Per-joint weights (1 for OLS).
    pub weights: Vec<f64>,
    /// Base parameters.
    pub base: Vec<BaseValue>,
    /// Base parameters not excited by the data (left at their nominal values).
    pub unexcited: Vec<String>,
    /// Fit quality on the fitted data.
    pub fit: Quality,
    /// Validation on held-out data (`null` when disabled).
    pub validation: Option<Quality>,
    /// LS-vs-IV test (`null` when no instrument could be built).
    pub dwh: Option<Dwh>,
    /// Identified full parameters (nominal + base correction).
    pub params: ParamsFile,
    /// Warnings and remarks.
    pub notes: Vec<String>,
    /// Physical consistency of `params` ([`ident::physical`]).
    pub physical: ident::physical::PhysicalCheck,
    /// The fit with physical consistency enforced (`IdentifyOptions::consistent`).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub consistent: Option<ident::consistent::ConsistentReport>,
    /// The log was streamed block by block (bounded memory) rather than read whole.
    pub streamed: bool,
    /// The underlying fit.
    #[serde(skip)]
    pub fit_report: Option<FitReport>,
}

/// Writes nothing; loads a [`ParamsFile`] into `robot`, checking joint and parameter names.
pub fn load_params(robot: &mut Robot, p: &ParamsFile) -> Result<()> {
    let names = robot.param_names();
    if p.names != names {
        return Err(Error::Estimation {
            msg: format!(
                "parameter file for robot '{}' (joints {:?}) does not match this chain (joints {:?})",
                p.robot, p.joints, robot.joint_names
            ),
        });
    }
    robot.set_params(&p.theta)
}

// ---------------------------------------------------------------------------------------
// Preparation: conditioning, regressor stacking, parallel filtering
// ---------------------------------------------------------------------------------------

struct Prepared {
    n: usize,
    dt: f64,
    q: Vec<f64>,
    qd: Vec<f64>,
    qdd: Vec<f64>,
    /// `T x n x b`
    phi: Vec<f64>,
    /// `T x n`
    tau: Vec<f64>,
    /// `T x n x b` instrument rows.
    z: Option<Vec<f64>>,
    instrument: Option<String>,
    cutoff_hz: f64,
    factor: usize,
}

impl Prepared {
    fn len(&self) -> usize {
        self.tau.len() / self.n
    }
}

pub(crate) fn err_est(msg: impl Into<String>) -> Error {
    Error::Estimation { msg: msg.into() }
}

/// Base regressor rows (`T x n x b`) at the given states, in chunks, with progress.
fn stack_rows(robot: &Robot, cols: &[usize], q: &[f64], qd: &[f64], qdd: &[f64], st: Option<&Stage>) -> Result<Vec<f64>> {
    let (n, p, b) = (robot.dof(), robot.num_params(), cols.len());
    let t = q.len() / n;
    let mut out = Vec::with_capacity(t * n * b);
    const CHUNK: usize = 2048;
    let mut full = vec![];
    for s in (0..t).step_by(CHUNK) {
        let e = (s + CHUNK).min(t);
        full.resize((e - s) * n * p, 0.0);
        let r = s * n..e * n;
        crate::batch::regressor_batch(robot, &q[r.clone()], &qd[r.clone()], &qdd[r], &mut full, false).map_err(|e| match e {
            Error::Sample { index, source } => Error::Sample { index: index + s, source },
            e => e,
        })?;
        for row in full.chunks_exact(p) {
            out.extend(cols.iter().map(|&c| row[c]));
        }
        if let Some(st) = st {
            st.advance((e - s) as u64);
        }
    }
    Ok(out)
}

fn prepare(robot: &Robot, base: &BaseParams, log: &JointLog, opts: &IdentifyOptions, instrument: bool, what: &str) -> Result<Prepared> {
    let n = robot.dof();
    if log.dof() != n || log.joint_names != robot.joint_names {
        return Err(err_est(format!("{what}: log joints {:?} are not the robot's {:?}", log.joint_names, robot.joint_names)));
    }
    if log.tau.is_none() {
        return Err(err_est(format!("{what}: the log has no effort (torque) data; identification needs measured torques")));
    }
    let c = signal::condition(log, &opts.condition)?;
    let fs = 1.0 / c.dt;
    let dec = parallel_filter(opts.decimate, fs, &opts.condition)?;
    let tau_raw = c.tau.clone().expect("checked");
    let t = c.t.len();
    let b = base.base_count();
    let st = Stage::begin(&opts.progress, &format!("{what}: regressor"), t as u64);
    let phi_raw = stack_rows(robot, &base.independent, &c.d.q, &c.d.qd, &c.d.qdd, Some(&st))?;
    drop(st);
    let _st = Stage::begin(&opts.progress, &format!("{what}: filtering"), 0);
    let phi = dec.apply(&phi_raw, n * b)?;
    drop(phi_raw);
    let tau = dec.apply(&tau_raw, n)?;
    let mut inst_name = None;
    let z = if instrument {
        let (qz, qdz, qddz) = match &c.u {
            Some(u) => {
                inst_name = Some("nominal model's forward dynamics at the (filtered) measured state driven by the command u: qdd_hat = FD_nom(q, qd, u)".to_string());
                let mut qh = vec![0.0; t * n];
                crate::batch::forward_dynamics_batch(robot, &c.d.q, &c.d.qd, u, &mut qh)?;
                (c.d.q.clone(), c.d.qd.clone(), qh)
            }
            None => {
                inst_name = Some(TRACKING_INSTRUMENT.to_string());
                nominal_tracking(robot, &c.d.q, &c.d.qd, &c.d.qdd, c.dt)?
            }
        };
        let z_raw = stack_rows(robot, &base.independent, &qz, &qdz, &qddz, None)?;
        Some(dec.apply(&z_raw, n * b)?)
    } else {
        None
    };
    let q = dec.apply(&c.d.q, n)?;
    let qd = dec.apply(&c.d.qd, n)?;
    let qdd = dec.apply(&c.d.qdd, n)?;
    Ok(Prepared { n, dt: c.dt * dec.factor as f64, q, qd, qdd, phi, tau, z, instrument: inst_name, cutoff_hz: dec.filter.cutoff_hz, factor: dec.factor })
}

/// The instrument without a command topic, in words.
pub(crate) const TRACKING_INSTRUMENT: &str = "regressor on a closed-loop simulation of the nominal model tracking the measured positions (stand-in M-scaled PD, 10 Hz, damping 0.7, plus nominal inverse-dynamics feed-forward; no command topic in the log)";

/// Closed-loop simulation (semi-implicit Euler at `dt`) of the nominal model tracking the
/// measured motion: `tau = rnea(q_m, qd_m, qdd_m) + M(q_m) (kp (q_m - q) + kd (qd_m - qd))`.
/// Returns the simulated `(q, qd, qdd)`.
fn nominal_tracking(robot: &Robot, q: &[f64], qd: &[f64], qdd: &[f64], dt: f64) -> Result<(Vec<f64>, Vec<f64>, Vec<f64>)> {
    Tracker::new(dt).run(robot, q, qd, qdd)
}

/// The state of [`nominal_tracking`] between blocks of samples, so that a log can be
/// simulated block by block (streaming) with the same result as in one piece.
pub(crate) struct Tracker {
    dt: f64,
    kp: f64,
    kd: f64,
    /// Simulated `(q, qd)` at the next sample (`None` before the first block: starts at
    /// the measured state).
    state: Option<(Vec<f64>, Vec<f64>)>,
    /// Samples simulated so far (for error messages).
    done: usize,
}

impl Tracker {
    /// PD gains of the stand-in control law at sample time `dt`: 10 Hz bandwidth (at most
    /// `0.05 / dt` Hz), damping 0.7.
    pub(crate) fn gains(dt: f64) -> (f64, f64) {
        let wn = 2.0 * std::f64::consts::PI * 10.0f64.min(0.05 / dt);
        (wn * wn, 2.0 * 0.7 * wn)
    }

    pub(crate) fn new(dt: f64) -> Self {
        let (kp, kd) = Self::gains(dt);
        Tracker { dt, kp, kd, state: None, done: 0 }
    }

    /// Simulates the next samples (`T x N` measured `q, qd, qdd`), returns the simulated
    /// `(q, qd, qdd)` of these samples.
    pub(crate) fn run(&mut self, robot: &Robot, q: &[f64], qd: &[f64], qdd: &[f64]) -> Result<(Vec<f64>, Vec<f64>, Vec<f64>)> {
        let n = robot.dof();
        let t = q.len() / n;
        if t == 0 {
            return Ok((vec![], vec![], vec![]));
        }
        let mut ff = vec![0.0; t * n];
        crate::batch::rnea_batch(robot, q, qd, qdd, &mut ff)?;
        let mut mm = vec![0.0; t * n * n];
        crate::batch::mass_matrix_batch(robot, q, &mut mm)?;
        let (kp, kd, dt) = (self.kp, self.kd, self.dt);
        let (mut qs, mut qds) = self.state.take().unwrap_or_else(|| (q[..n].to_vec(), qd[..n].to_vec()));
        let (mut oq, mut oqd, mut oqdd) = (Vec::with_capacity(t * n), Vec::with_capacity(t * n), Vec::with_capacity(t * n));
        let done = self.done;
        // one work buffer for the block (the per-call `Robot::forward_dynamics` allocates one)
        crate::with_model!(&robot.model, m => {
            let mut data = Box::new(ivdyn_core::Data::new());
            let mut tau = ivdyn_core::VecN::zeros();
            for k in 0..t {
                let s = done + k;
                let e: Vec<f64> = (0..n).map(|i| kp * (q[k * n + i] - qs[i]) + kd * (qd[k * n + i] - qds[i])).collect();
                for i in 0..n {
                    tau[i] = ff[k * n + i] + (0..n).map(|j| mm[k * n * n + i * n + j] * e[j]).sum::<f64>();
                }
                let (qv, qdv) = (ivdyn_core::VecN::from_column_slice(&qs), ivdyn_core::VecN::from_column_slice(&qds));
                let a = ivdyn_core::forward_dynamics(&**m, &mut data, &qv, &qdv, &tau)
                    .map_err(|e| err_est(format!("instrument: simulating the nominal model failed at sample {s}: {e}")))?;
                if a.iter().chain(&qs).any(|v| !v.is_finite() || v.abs() > 1e6) {
                    return Err(err_est(format!("instrument: the simulation of the nominal model diverged at sample {s}")));
                }
                oq.extend_from_slice(&qs);
                oqd.extend_from_slice(&qds);
                oqdd.extend_from_slice(a.as_slice());
                for i in 0..n {
                    qds[i] += a[i] * dt;
                    qs[i] += qds[i] * dt;
                }
            }
        });
        self.done += t;
        self.state = Some((qs, qds));
        Ok((oq, oqd, oqdd))
    }
}

/// Decimation factor chosen by `decimate == 0` ("auto"): the output rate is about 2.5x the
/// differentiation cut-off, so that the low-passed noise left in the residual is close to
/// white at the output rate (the LS/IV covariances and the DWH test assume white residuals).
pub fn auto_decimation(fs: f64, condition: &ConditionOptions) -> usize {
    let fc = match &condition.diff {
        signal::DiffMethod::Butterworth { cutoff_hz: Some(c), .. } => *c,
        _ => signal::default_cutoff(fs),
    };
    ((fs / (2.5 * fc) + 1e-9).floor() as usize).max(1)
}

/// The parallel filter: [`Decimator::new`] for a factor > 1 (`0` = [`auto_decimation`]),
/// else the default differentiation filter alone.
pub(crate) fn parallel_filter(decimate: usize, fs: f64, condition: &ConditionOptions) -> Result<Decimator> {
    let f = if decimate == 0 { auto_decimation(fs, condition) } else { decimate };
    if f > 1 { Decimator::new(f, fs) } else { Decimator::with_filter(1, Butterworth::default_for(fs)?) }
}

fn rows_of(x: &[f64], width: usize, r: std::ops::Range<usize>) -> &[f64] {
    &x[r.start * width..r.end * width]
}

fn quality(data: String, phi: &[f64], tau: &[f64], theta: &[f64], n: usize) -> Quality {
    let b = theta.len();
    let t = tau.len() / n;
    let (mut sse, mut sum, mut sum2) = (vec![0.0; n], vec![0.0; n], vec![0.0; n]);
    for k in 0..t {
        for i in 0..n {
            let r = k * n + i;
            let pred: f64 = phi[r * b..(r + 1) * b].iter().zip(theta).map(|(a, b)| a * b).sum();
            let y = tau[r];
            sse[i] += (y - pred).powi(2);
            sum[i] += y;
            sum2[i] += y * y;
        }
    }
    let tf = t.max(1) as f64;
    let rms = sse.iter().map(|s| (s / tf).sqrt()).collect();
    let r2 = (0..n)
        .map(|i| {
            let sst = sum2[i] - sum[i] * sum[i] / tf;
            if sst > 0.0 { 1.0 - sse[i] / sst } else { f64::NAN }
        })
        .collect();
    let tau_rms = sum2.iter().map(|s| (s / tf).sqrt()).collect();
    Quality { data, samples: t, rms, r2, tau_rms }
}

/// Two-step WLS weights: `1 / rms_j^2` per joint (floored at `1e-6` of the largest RMS).
fn per_joint_weights(rms: &[f64]) -> Vec<f64> {
    let floor = rms.iter().cloned().fold(0.0, f64::max) * 1e-6 + 1e-12;
    rms.iter().map(|r| 1.0 / (r * r).max(floor * floor)).collect()
}

fn row_weights(w: &[f64], rows: usize) -> Vec<f64> {
    let n = w.len();
    (0..rows).map(|r| w[r % n]).collect()
}

// ---------------------------------------------------------------------------------------
// identify
// ---------------------------------------------------------------------------------------

/// Which drive (per-joint) parameters [`identify`] estimates. The parameters left out
/// keep their nominal values (URDF or `--params`; zero unless set) and no base parameter
/// contains them. Default: all four.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
pub struct DriveTerms {
    /// Coulomb friction `fc` (torque `fc sign(qd)`).
    pub coulomb: bool,
    /// Viscous friction `fv` (torque `fv qd`).
    pub viscous: bool,
    /// Armature (rotor inertia reflected to the joint) `ia` (torque `ia qdd`).
    pub armature: bool,
    /// Constant torque offset `tau0`.
    pub offset: bool,
}

impl Default for DriveTerms {
    fn default() -> Self {
        DriveTerms { coulomb: true, viscous: true, armature: true, offset: true }
    }
}

impl DriveTerms {
    /// No drive parameter: the rigid-body model only.
    pub const NONE: DriveTerms = DriveTerms { coulomb: false, viscous: false, armature: false, offset: false };

    /// The per-joint parameter suffixes estimated (`fc`, `fv`, `ia`, `tau0`, in layout order).
    pub fn names(&self) -> Vec<String> {
        let on = [self.coulomb, self.viscous, self.armature, self.offset];
        ["fc", "fv", "ia", "tau0"].iter().zip(on).filter(|(_, o)| *o).map(|(s, _)| s.to_string()).collect()
    }

    /// Full-parameter indices left out for `n` joints (layout: `10 n` link parameters,
    /// then per joint `[fc, fv, ia, tau0]`).
    pub fn excluded_columns(&self, n: usize) -> Vec<usize> {
        let on = [self.coulomb, self.viscous, self.armature, self.offset];
        (0..n).flat_map(|j| (0..4).filter(move |&k| !on[k]).map(move |k| LINK_PARAMS * n + 4 * j + k)).collect()
    }
}

/// The base parameters [`identify`] fits: [`ident::robot_base_params`] over the inertial
/// parameters and the drive parameters of `opts.drive`.
pub fn identify_base(robot: &Robot, opts: &IdentifyOptions) -> Result<BaseParams> {
    let n = robot.dof();
    let samples = opts.base_samples.max(2 * robot.num_params() / n.max(1));
    ident::robot_base_params_excluding(robot, samples, opts.seed, false, &opts.drive.excluded_columns(n))
}

/// Fit and held-out decimated-sample ranges of a prepared log of `t` samples: 1 % of the
/// samples (at most 20) dropped at each end (filter edges), the last
/// `validation_fraction` held out unless a validation log is given.
pub(crate) fn split_ranges(t: usize, opts: &IdentifyOptions) -> (std::ops::Range<usize>, Option<std::ops::Range<usize>>) {
    let edge = (t / 100).min(20);
    if opts.validation_log.is_some() || opts.validation_fraction <= 0.0 {
        (edge..t - edge, None)
    } else {
        let cut = ((1.0 - opts.validation_fraction.min(0.9)) * t as f64) as usize;
        (edge..cut.max(edge), Some(cut.max(edge)..t - edge))
    }
}

/// What [`finish_identify`] needs from a prepared log (in memory or streamed).
pub(crate) struct FitData {
    /// Statistics of the fit rows (with instrument sums when an instrument was built).
    pub fit: JointAccs,
    /// Held-out statistics and their label.
    pub validation: Option<(String, JointAccs)>,
    /// The instrument in words.
    pub instrument: Option<String>,
    /// Sample time of the fitted data (after decimation).
    pub dt: f64,
    /// Decimation factor.
    pub factor: usize,
    /// Cut-off of the parallel filter.
    pub cutoff_hz: f64,
    /// The IDIM-IV fit (method `idim-iv`), computed on the arrays.
    pub idim: Option<FitReport>,
    /// Remarks so far.
    pub notes: Vec<String>,
}

/// Identifies the base parameters of `robot` from `log` (see the module docs). The whole
/// log is held in memory; [`crate::stream::identify_mcap`] streams a log file instead.
pub fn identify(robot: &Robot, log: &JointLog, opts: &IdentifyOptions) -> Result<IdentifyReport> {
    let n = robot.dof();
    let mut notes = vec![];
    let base = {
        let _st = Stage::begin(&opts.progress, "base parameters", 0);
        identify_base(robot, opts)?
    };
    let b = base.base_count();
    let want_iv = opts.method != Method::IdimIv;
    let prep = prepare(robot, &base, log, opts, want_iv, "log")?;
    let t = prep.len();
    let (fit_range, val_range) = split_ranges(t, opts);
    if fit_range.len() * n < 2 * b {
        return Err(err_est(format!(
            "log too short: {} samples of {n} joints after conditioning for {b} base parameters",
            fit_range.len()
        )));
    }
    let w_row = n * b;
    let phi_fit = rows_of(&prep.phi, w_row, fit_range.clone());
    let tau_fit = rows_of(&prep.tau, n, fit_range.clone());
    let mut fit = JointAccs::new(n, b, prep.z.is_some());
    fit.add(phi_fit, prep.z.as_ref().map(|z| rows_of(z, w_row, fit_range.clone())), tau_fit)?;
    let validation = match (&opts.validation_log, val_range) {
        (Some(vlog), _) => {
            let vp = prepare(robot, &base, vlog, opts, false, "validation log")?;
            let t2 = vp.len();
            let e2 = (t2 / 100).min(20);
            let mut v = JointAccs::new(n, b, false);
            v.add(rows_of(&vp.phi, w_row, e2..t2 - e2), None, rows_of(&vp.tau, n, e2..t2 - e2))?;
            Some(("validation log".to_string(), v))
        }
        (None, Some(r)) if r.len() > 1 => {
            let mut v = JointAccs::new(n, b, false);
            v.add(rows_of(&prep.phi, w_row, r.clone()), None, rows_of(&prep.tau, n, r))?;
            Some((format!("tail {:.0}% of the log", 100.0 * opts.validation_fraction), v))
        }
        _ => None,
    };
    let idim = if opts.method == Method::IdimIv {
        let r = fit_range.clone();
        let (q, qd, qdd) = (rows_of(&prep.q, n, r.clone()), rows_of(&prep.qd, n, r.clone()), rows_of(&prep.qdd, n, r.clone()));
        let tf = r.len();
        let mut ff = vec![0.0; tf * n];
        crate::batch::rnea_batch(robot, q, qd, qdd, &mut ff)?;
        let mut mm = vec![0.0; tf * n * n];
        crate::batch::mass_matrix_batch(robot, q, &mut mm)?;
        let (kp, kd) = Tracker::gains(prep.dt);
        let control = |k: usize, qs: &[f64], qds: &[f64]| -> Vec<f64> {
            let e: Vec<f64> = (0..n).map(|i| kp * (q[k * n + i] - qs[i]) + kd * (qd[k * n + i] - qds[i])).collect();
            (0..n).map(|i| ff[k * n + i] + (0..n).map(|j| mm[k * n * n + i * n + j] * e[j]).sum::<f64>()).collect()
        };
        let exp = ident::Experiment { dt: prep.dt, q, qd, qdd, tau: tau_fit };
        let _st = Stage::begin(&opts.progress, "IDIM-IV iterations", 0);
        let res = ident::idim_iv(robot, &base, &exp, control, opts.idim_max_iter, opts.idim_tol)?;
        if !res.converged {
            notes.push(format!("IDIM-IV did not converge in {} iterations", opts.idim_max_iter));
        }
        notes.push("IDIM-IV control law: stand-in stiff PD on the measured positions (M-scaled, 10 Hz, damping 0.7) + nominal inverse dynamics feed-forward".into());
        Some(res.fit)
    } else {
        None
    };
    if log.truncated {
        notes.push("the log was truncated; only the samples before the damage were used".into());
    }
    let data = FitData { fit, validation, instrument: prep.instrument.clone(), dt: prep.dt, factor: prep.factor, cutoff_hz: prep.cutoff_hz, idim, notes };
    finish_identify(robot, &base, opts, data)
}

/// The fits (OLS, two-step WLS, IV), the DWH test, fit quality and validation, from the
/// per-joint statistics of a prepared log: the part shared by the in-memory and the
/// streaming `identify`.
pub(crate) fn finish_identify(robot: &Robot, base: &BaseParams, opts: &IdentifyOptions, d: FitData) -> Result<IdentifyReport> {
    let n = robot.dof();
    let b = base.base_count();
    let mut notes = d.notes;
    if d.fit.samples() * n < 2 * b {
        return Err(err_est(format!("log too short: {} samples of {n} joints after conditioning for {b} base parameters", d.fit.samples())));
    }
    let nominal = robot.params();
    let nom_base = base.project(&nominal)?;
    let fill = |theta: &[f64]| -> Vec<f64> { theta.iter().zip(&nom_base).map(|(t, nb)| if t.is_finite() { *t } else { *nb }).collect() };
    let st = Stage::begin(&opts.progress, "fitting", 3);
    let ones = vec![1.0; n];
    let ols = fit_ls(&d.fit.ls(&ones)?, &base.names)?;
    st.advance(1);
    let mut weights = vec![1.0; n];
    let mut iv_fit: Option<std::result::Result<FitReport, Error>> = None;
    let fit = match opts.method {
        Method::Ols => ols.clone(),
        Method::Wls | Method::Iv => {
            weights = per_joint_weights(&d.fit.quality(String::new(), &fill(&ols.theta)).rms);
            let wls = fit_ls(&d.fit.ls(&weights)?, &base.names)?;
            st.advance(1);
            let iv = d.fit.iv(&weights).map(|acc| acc.and_then(|a| fit_iv(&a, &base.names)));
            st.advance(1);
            if opts.method == Method::Iv {
                match iv {
                    Some(Ok(f)) => {
                        iv_fit = Some(Ok(f.clone()));
                        f
                    }
                    Some(Err(e)) => return Err(err_est(format!("IV fit failed ({e}): the instrument is not correlated with the regressor; try --method wls or idim-iv"))),
                    None => return Err(err_est("IV fit: no instrument was built")),
                }
            } else {
                iv_fit = iv;
                wls
            }
        }
        Method::IdimIv => d.idim.clone().ok_or_else(|| err_est("IDIM-IV: no fit"))?,
    };
    drop(st);
    let theta = fill(&fit.theta);
    let fit_q = d.fit.quality("fit".into(), &theta);
    let validation = d.validation.as_ref().map(|(label, v)| v.quality(label.clone(), &theta)).filter(|q| q.samples > 1);
    let dwh_src = match opts.method {
        Method::IdimIv => fit.dwh,
        _ => match &iv_fit {
            Some(Ok(f)) => f.dwh,
            Some(Err(e)) => {
                notes.push(format!("no LS-vs-IV test: the IV fit failed ({e})"));
                None
            }
            None => None,
        },
    };
    let dwh = dwh_src.map(|d| Dwh {
        statistic: d.statistic,
        dof: d.dof,
        p_value: d.p_value,
        ls_biased: d.ls_biased,
        verdict: if d.dof == 0 {
            "not tested: the data fit exactly".into()
        } else if d.ls_biased {
            format!("LS is biased (p = {:.2e} < 0.01): prefer an IV estimate", d.p_value)
        } else {
            format!("no evidence of LS bias (p = {:.3})", d.p_value)
        },
    });
    // full parameters: nominal + base correction
    let full = base.apply(&theta, &nominal, 1.0)?;
    let physical = ident::physical::check_robot_params(robot, &full);
    let consistent = if opts.consistent {
        let _st = Stage::begin(&opts.progress, "consistent fit", 0);
        let cacc = d.fit.ls(&weights)?;
        let cf = ident::consistent::fit_consistent(&cacc, base, &full, &nominal, &robot.link_names, &robot.joint_names, &Default::default())?;
        let val = d.validation.as_ref().map(|(label, v)| v.quality(label.clone(), &cf.theta_base)).filter(|q| q.samples > 1);
        Some(ident::consistent::ConsistentReport {
            fit: d.fit.quality("fit".into(), &cf.theta_base),
            validation: val,
            params: ParamsFile { robot: robot.name.clone(), joints: robot.joint_names.clone(), names: robot.param_names(), theta: cf.theta.clone() },
            result: cf,
        })
    } else {
        None
    };
    let base_vals = (0..b)
        .map(|i| BaseValue { name: base.names[i].clone(), value: fit.theta[i], std: fit.std[i], rel_std_pct: fit.rel_std_pct[i], nominal: nom_base[i] })
        .collect();
    Ok(IdentifyReport {
        method: opts.method.name().into(),
        instrument: match opts.method {
            Method::Ols | Method::Wls => d.instrument.clone().map(|s| format!("(DWH test only) {s}")),
            Method::Iv => d.instrument.clone(),
            Method::IdimIv => Some("IDIM-IV closed-loop simulation of the current estimate".into()),
        },
        joints: robot.joint_names.clone(),
        drive_terms: opts.drive.names(),
        sample_rate_hz: 1.0 / d.dt,
        decimation: d.factor,
        filter_cutoff_hz: d.cutoff_hz,
        rows: fit.rows,
        rank: fit.rank,
        condition_number: fit.condition_number,
        sigma2: fit.sigma2,
        weights,
        base: base_vals,
        unexcited: fit.unexcited.clone(),
        fit: fit_q,
        validation,
        dwh,
        params: ParamsFile { robot: robot.name.clone(), joints: robot.joint_names.clone(), names: robot.param_names(), theta: full },
        notes,
        physical,
        consistent,
        streamed: false,
        fit_report: Some(fit),
    })
}

/// Writes `log`'s measured torques, the torques predicted by `model` (e.g. the identified
/// robot) and the residuals to the MCAP file `path`
/// ([`crate::io::PredictionWriter`]). The samples are the conditioned ones (duplicated
/// stamps dropped, uneven stamps resampled, as `identify` sees them), the prediction is
/// `rnea(q, qd, qdd)` of `model` at the smoothed state, the measured copy is the log's
/// values at those samples (resampled like the torque if the stamps were uneven).
/// Returns the samples written.
pub fn write_prediction(path: &std::path::Path, model: &Robot, log: &JointLog, condition: &ConditionOptions) -> Result<usize> {
    let n = model.dof();
    let c = signal::condition(log, condition)?;
    let tau = c.tau.as_ref().ok_or_else(|| err_est("the log has no effort (torque) data"))?;
    let dd = signal::dedup_stamps(&log.t)?;
    let t_kept: Vec<f64> = dd.keep.iter().map(|&k| log.t[k]).collect();
    let measured = |a: &[f64]| -> Result<Vec<f64>> {
        let kept = signal::take_rows(a, n, &dd.keep);
        if c.resampled { Ok(signal::resample_uniform(&t_kept, &kept, n, c.dt, condition.interp)?.1) } else { Ok(kept) }
    };
    let q_meas = measured(&log.q)?;
    let qd_meas = log.qd.as_ref().map(|a| measured(a)).transpose()?.unwrap_or_default();
    let mut pred = vec![0.0; c.d.q.len()];
    crate::batch::rnea_batch(model, &c.d.q, &c.d.qd, &c.d.qdd, &mut pred)?;
    let stamps: Vec<i64> = c.t.iter().map(|t| log.t0_ns.saturating_add((t * 1e9).round() as i64)).collect();
    let mut w = crate::io::PredictionWriter::create(path, &model.joint_names)?;
    w.write_block(&stamps, &q_meas, &qd_meas, tau, &c.d.q, &c.d.qd, &pred)?;
    let k = w.samples();
    w.finish()?;
    Ok(k)
}

// ---------------------------------------------------------------------------------------
// payload
// ---------------------------------------------------------------------------------------

/// Options of [`payload`].
#[derive(Clone)]
pub struct PayloadOptions {
    /// Conditioning.
    pub condition: ConditionOptions,
    /// Decimation factor after the parallel filter (0: automatic).
    pub decimate: usize,
    /// Random states for the payload's base columns, and their seed.
    pub base_samples: usize,
    /// Seed.
    pub seed: u64,
    /// Options for identifying the unloaded arm on the `before` log.
    pub before: IdentifyOptions,
    /// Progress sink.
    pub progress: ProgressSink,
}

impl Default for PayloadOptions {
    fn default() -> Self {
        PayloadOptions {
            condition: ConditionOptions::default(),
            decimate: 0,
            base_samples: 200,
            seed: 2,
            before: IdentifyOptions { validation_fraction: 0.0, method: Method::Wls, ..Default::default() },
            progress: None,
        }
    }
}

/// A payload parameter that the data cannot give alone.
#[derive(Debug, Clone, Serialize)]
pub struct Hidden {
    /// Payload parameter.
    pub parameter: String,
    /// The base combination it is part of.
    pub combined_in: String,
}

/// Result of [`payload`].
#[derive(Debug, Clone, Serialize)]
pub struct PayloadReport {
    /// Link carrying the payload (the last movable link; COM and inertia in its frame).
    pub link: String,
    /// Whether every payload parameter is identifiable from this data.
    pub identifiable: bool,
    /// Mass (kg); `null` when not identifiable.
    pub mass: Option<f64>,
    /// Centre of mass in the link frame (m).
    pub com: Option<[f64; 3]>,
    /// Inertia about the COM, `[Ixx, Ixy, Ixz, Iyy, Iyz, Izz]` (kg m^2).
    pub inertia: Option<[f64; 6]>,
    /// Standard deviation of the mass.
    pub mass_std: Option<f64>,
    /// Standard deviations of the COM.
    pub com_std: Option<[f64; 3]>,
    /// Standard deviations of the inertia entries.
    pub inertia_std: Option<[f64; 6]>,
    /// The 10 standard parameters about the link origin `[m, mcx, mcy, mcz, Ixx, Ixy, Iyy, Ixz, Iyz, Izz]`.
    pub params: Option<[f64; 10]>,
    /// Parameters that are not identifiable, with the combination hiding them.
    pub not_identifiable: Vec<Hidden>,
    /// What the residual is taken against: `"urdf"` or `"before log"`.
    pub nominal: String,
    /// Joint names.
    pub joints: Vec<String>,
    /// Samples used.
    pub samples: usize,
    /// RMS of the residual (measured - nominal) per joint before the payload fit (N m).
    pub rms_before: Vec<f64>,
    /// RMS after subtracting the fitted payload's torques (N m).
    pub rms_after: Vec<f64>,
    /// Remarks.
    pub notes: Vec<String>,
}

/// Estimates the payload on the last link from `after` (see the module docs); with
/// `before`, the unloaded arm is identified on it first and used as the nominal model.
pub fn payload(robot: &Robot, after: &JointLog, before: Option<&JointLog>, opts: &PayloadOptions) -> Result<PayloadReport> {
    let n = robot.dof();
    let mut notes = vec![];
    let mut nom = robot.clone();
    let nominal = if let Some(b) = before {
        let mut o = opts.before.clone();
        o.progress = opts.progress.clone();
        let rep = identify(robot, b, &o)?;
        nom.set_params(&rep.params.theta)?;
        "before log".to_string()
    } else {
        "urdf".to_string()
    };
    let spec = TerminalSpec::payload(n);
    let cols: Vec<usize> = (0..spec.cols(n)).map(|c| spec.theta_index(n, c)).collect();
    debug_assert_eq!(cols.len(), LINK_PARAMS);
    let all_names = robot.param_names();
    let names10: Vec<String> = cols.iter().map(|&c| all_names[c].clone()).collect();
    // payload base columns from random states
    let bp = {
        let _st = Stage::begin(&opts.progress, "payload base columns", 0);
        let rows = random_rows(robot, &cols, opts.base_samples, opts.seed)?;
        BaseParams::from_rows(&rows, &names10)
    };
    if after.tau.is_none() {
        return Err(err_est("the log has no effort (torque) data; payload estimation needs measured torques"));
    }
    if after.joint_names != robot.joint_names {
        return Err(err_est(format!("log joints {:?} are not the robot's {:?}", after.joint_names, robot.joint_names)));
    }
    let c = signal::condition(after, &opts.condition)?;
    let fs = 1.0 / c.dt;
    let dec = parallel_filter(opts.decimate, fs, &opts.condition)?;
    let t = c.t.len();
    let mut tau_nom = vec![0.0; t * n];
    crate::batch::rnea_batch(&nom, &c.d.q, &c.d.qd, &c.d.qdd, &mut tau_nom)?;
    let res: Vec<f64> = c.tau.as_ref().expect("checked").iter().zip(&tau_nom).map(|(a, b)| a - b).collect();
    let st = Stage::begin(&opts.progress, "payload regressor", t as u64);
    let phi10 = stack_rows(robot, &cols, &c.d.q, &c.d.qd, &c.d.qdd, Some(&st))?;
    drop(st);
    let _st = Stage::begin(&opts.progress, "filtering and fitting", 0);
    let phi10 = dec.apply(&phi10, n * 10)?;
    let res = dec.apply(&res, n)?;
    let tt = res.len() / n;
    let edge = (tt / 100).min(20);
    let r = edge..tt - edge;
    let phi10 = rows_of(&phi10, n * 10, r.clone());
    let res = rows_of(&res, n, r.clone());
    let phib = bp.select_rows(phi10, res.len())?;
    let nb = bp.base_count();
    // 2-step WLS
    let mut acc = LsAccumulator::new(nb);
    acc.add_rows(&phib, res, None)?;
    let ols = fit_ls(&acc, &bp.names)?;
    let th0: Vec<f64> = ols.theta.iter().map(|v| if v.is_finite() { *v } else { 0.0 }).collect();
    let w = per_joint_weights(&quality(String::new(), &phib, res, &th0, n).rms);
    let mut acc = LsAccumulator::new(nb);
    acc.add_rows(&phib, res, Some(&row_weights(&w, res.len())))?;
    let fit = fit_ls(&acc, &bp.names)?;
    let thf: Vec<f64> = fit.theta.iter().map(|v| if v.is_finite() { *v } else { 0.0 }).collect();
    let zero = vec![0.0; nb];
    let before_q = quality(String::new(), &phib, res, &zero, n);
    let after_q = quality(String::new(), &phib, res, &thf, n);
    let idx: [usize; 10] = std::array::from_fn(|k| k);
    let est = ident::payload_from_fit(&bp, &fit, &idx, &names10)?;
    if after.truncated {
        notes.push("the log was truncated; only the samples before the damage were used".into());
    }
    let mut rep = PayloadReport {
        link: robot.link_names[n - 1].clone(),
        identifiable: false,
        mass: None,
        com: None,
        inertia: None,
        mass_std: None,
        com_std: None,
        inertia_std: None,
        params: None,
        not_identifiable: vec![],
        nominal,
        joints: robot.joint_names.clone(),
        samples: res.len() / n,
        rms_before: before_q.rms,
        rms_after: after_q.rms,
        notes,
    };
    match est {
        Ok(e) => {
            rep.identifiable = true;
            rep.mass = Some(e.mass);
            rep.com = Some(e.com);
            rep.inertia = Some(e.inertia);
            rep.mass_std = Some(e.mass_std);
            rep.com_std = Some(e.com_std);
            rep.inertia_std = Some(e.inertia_std);
            rep.params = Some(e.params);
        }
        Err(ni) => {
            rep.not_identifiable = ni.parameters.into_iter().zip(ni.combined_in).map(|(parameter, combined_in)| Hidden { parameter, combined_in }).collect();
        }
    }
    Ok(rep)
}

/// Regressor columns `cols` at `samples` random states (as [`ident::robot_base_params`]).
fn random_rows(robot: &Robot, cols: &[usize], samples: usize, seed: u64) -> Result<DMatrix<f64>> {
    let (n, p) = (robot.dof(), robot.num_params());
    let limits = crate::with_model!(&robot.model, m => m.limits.to_vec());
    let mut rng = Rng::new(seed);
    let mut phi = DMatrix::zeros(samples * n, cols.len());
    let (mut q, mut qd, mut qdd) = (vec![0.0; n], vec![0.0; n], vec![0.0; n]);
    for s in 0..samples {
        for j in 0..n {
            let l = &limits[j];
            let (lo, hi) = if l.lower.is_finite() && l.upper.is_finite() && l.upper > l.lower { (l.lower, l.upper) } else { (-std::f64::consts::PI, std::f64::consts::PI) };
            q[j] = rng.uniform(lo, hi);
            qd[j] = rng.uniform(-1.0, 1.0);
            qdd[j] = rng.uniform(-2.0, 2.0);
        }
        let y = robot.regressor(&q, &qd, &qdd)?;
        for r in 0..n {
            for (c, &col) in cols.iter().enumerate() {
                phi[(s * n + r, c)] = y[r * p + col];
            }
        }
    }
    Ok(phi)
}

// ---------------------------------------------------------------------------------------
// simulate
// ---------------------------------------------------------------------------------------

/// A payload to add to the last link.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct PayloadSpec {
    /// Mass (kg).
    pub mass: f64,
    /// COM in the last link's frame (m).
    pub com: [f64; 3],
    /// Inertia about the COM `[Ixx, Ixy, Ixz, Iyy, Iyz, Izz]`.
    pub inertia: [f64; 6],
}

/// The trajectory to simulate.
#[derive(Debug, Clone, PartialEq)]
pub enum Trajectory {
    /// Built-in random Fourier excitation (options in [`SimulateOptions`]).
    Fourier,
    /// Given positions `T x N` at times `t` (velocity and acceleration by central
    /// differences).
    Samples {
        /// Times (s), increasing.
        t: Vec<f64>,
        /// Positions `T x N`.
        q: Vec<f64>,
    },
}

/// Options of [`simulate`].
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct SimulateOptions {
    /// Sample rate (Hz) of the Fourier trajectory (default 500).
    pub rate_hz: f64,
    /// Duration (s) of the Fourier trajectory (default 20).
    pub duration_s: f64,
    /// Seed of the trajectory and the noise.
    pub seed: u64,
    /// Fourier: fundamental frequency (Hz, default 0.1) and harmonics (default 5).
    pub base_freq_hz: f64,
    /// Number of harmonics.
    pub harmonics: usize,
    /// Fourier: peak amplitude per joint (rad or m, default 0.8), capped to 40 % of the
    /// joint range.
    pub amplitude: f64,
    /// Payload on the last link.
    pub payload: Option<PayloadSpec>,
    /// Coulomb friction per joint (replaces the model's).
    pub fc: Option<Vec<f64>>,
    /// Viscous friction per joint.
    pub fv: Option<Vec<f64>>,
    /// Standard deviation of white noise on the recorded torque (N m).
    pub noise_tau: f64,
    /// Standard deviation of white noise on the recorded position.
    pub noise_q: f64,
    /// Encoder resolution: positions rounded to `2 pi / 2^bits`.
    pub encoder_bits: Option<u32>,
    /// Torque resolution (N m): recorded torques rounded to multiples of it.
    pub tau_resolution: Option<f64>,
    /// Write the exact velocities in the log (default true).
    pub write_velocity: bool,
    /// Record the noise-free true torque as the actuator command `u` (MCAP topic
    /// `/ivdyn/command`, CSV columns `<joint>.u`), as a torque-controlled arm's command.
    pub write_command: bool,
}

impl Default for SimulateOptions {
    fn default() -> Self {
        SimulateOptions {
            rate_hz: 500.0,
            duration_s: 20.0,
            seed: 1,
            base_freq_hz: 0.1,
            harmonics: 5,
            amplitude: 0.8,
            payload: None,
            fc: None,
            fv: None,
            noise_tau: 0.0,
            noise_q: 0.0,
            encoder_bits: None,
            tau_resolution: None,
            write_velocity: true,
            write_command: false,
        }
    }
}

/// The true model of a simulation: `robot` with the payload and friction of `opts`.
pub fn true_robot(robot: &Robot, opts: &SimulateOptions) -> Result<Robot> {
    let n = robot.dof();
    let mut r = robot.clone();
    let mut theta = r.params();
    if let Some(p) = &opts.payload {
        let ic = &p.inertia;
        let i_c = Matrix3::new(ic[0], ic[1], ic[2], ic[1], ic[3], ic[4], ic[2], ic[4], ic[5]);
        let li = LinkInertia::from_mass_com_inertia(p.mass, &Vector3::new(p.com[0], p.com[1], p.com[2]), &Matrix3::identity(), &i_c);
        let off = (n - 1) * LINK_PARAMS;
        for k in 0..LINK_PARAMS {
            theta[off + k] += li.0[k];
        }
    }
    for (idx, v) in [(0usize, &opts.fc), (1, &opts.fv)] {
        if let Some(v) = v {
            if v.len() != n {
                return Err(Error::Dimension { what: if idx == 0 { "fc (one per joint)".into() } else { "fv (one per joint)".into() }, expected: n, got: v.len() });
            }
            for j in 0..n {
                theta[LINK_PARAMS * n + 4 * j + idx] = v[j];
            }
        }
    }
    r.set_params(&theta)?;
    Ok(r)
}

/// The built-in excitation: `(t, q, qd, qdd)`, `q_j(t) = q0_j + sum_l A_jl sin(2 pi l f0 t + phi_jl)`.
pub fn fourier_trajectory(robot: &Robot, opts: &SimulateOptions) -> (Vec<f64>, Vec<f64>, Vec<f64>, Vec<f64>) {
    let n = robot.dof();
    let limits = crate::with_model!(&robot.model, m => m.limits.to_vec());
    let mut rng = Rng::new(opts.seed);
    let h = opts.harmonics.max(1);
    let mut coef = vec![(0.0, 0.0); n * h];
    let mut q0 = vec![0.0; n];
    for j in 0..n {
        let l = &limits[j];
        let mut amp = opts.amplitude;
        if l.lower.is_finite() && l.upper.is_finite() && l.upper > l.lower {
            q0[j] = if l.upper - l.lower < 2.0 * std::f64::consts::TAU { 0.5 * (l.lower + l.upper) } else { 0.0 };
            amp = amp.min(0.4 * (l.upper - l.lower));
        }
        let raw: Vec<(f64, f64)> = (0..h).map(|k| (rng.uniform(0.3, 1.0) / (k + 1) as f64, rng.uniform(0.0, std::f64::consts::TAU))).collect();
        let s: f64 = raw.iter().map(|(a, _)| a).sum();
        for k in 0..h {
            coef[j * h + k] = (raw[k].0 * amp / s, raw[k].1);
        }
    }
    let steps = (opts.duration_s * opts.rate_hz).round().max(2.0) as usize;
    let (mut t, mut q, mut qd, mut qdd) = (Vec::with_capacity(steps), vec![0.0; steps * n], vec![0.0; steps * n], vec![0.0; steps * n]);
    for s in 0..steps {
        let ts = s as f64 / opts.rate_hz;
        t.push(ts);
        for j in 0..n {
            let (mut a, mut v, mut acc) = (q0[j], 0.0, 0.0);
            for k in 0..h {
                let w = std::f64::consts::TAU * opts.base_freq_hz * (k + 1) as f64;
                let (c, ph) = coef[j * h + k];
                a += c * (w * ts + ph).sin();
                v += c * w * (w * ts + ph).cos();
                acc -= c * w * w * (w * ts + ph).sin();
            }
            q[s * n + j] = a;
            qd[s * n + j] = v;
            qdd[s * n + j] = acc;
        }
    }
    (t, q, qd, qdd)
}

/// A synthetic log: the true model's inverse dynamics (`rnea`, with payload and friction)
/// along the trajectory, then noise and quantisation of the recorded `q` and `tau`.
pub fn simulate(robot: &Robot, traj: &Trajectory, opts: &SimulateOptions) -> Result<JointLog> {
    let n = robot.dof();
    let truth = true_robot(robot, opts)?;
    let (t, q, qd, qdd) = match traj {
        Trajectory::Fourier => fourier_trajectory(robot, opts),
        Trajectory::Samples { t, q } => {
            if t.len() < 3 || q.len() != t.len() * n {
                return Err(Error::Dimension { what: "trajectory q (T x N, T >= 3)".into(), expected: t.len().max(3) * n, got: q.len() });
            }
            let dt = signal::median_dt(t).ok_or_else(|| err_est("trajectory: need increasing times"))?;
            if t.windows(2).any(|w| ((w[1] - w[0]) - dt).abs() > 1e-6 * dt.max(1e-9) + 1e-9) {
                return Err(err_est("trajectory: times must be uniformly spaced"));
            }
            (t.clone(), q.clone(), signal::central_diff(q, n, dt)?, signal::second_diff(q, n, dt)?)
        }
    };
    let mut tau = vec![0.0; q.len()];
    crate::batch::rnea_batch(&truth, &q, &qd, &qdd, &mut tau)?;
    let u = if opts.write_command { Some(tau.clone()) } else { None };
    let mut rng = Rng::new(opts.seed.wrapping_add(0x5eed));
    let mut qm = q.clone();
    for v in qm.iter_mut() {
        if opts.noise_q > 0.0 {
            *v += opts.noise_q * rng.normal();
        }
        if let Some(bits) = opts.encoder_bits {
            let r = std::f64::consts::TAU / 2f64.powi(bits as i32);
            *v = (*v / r).round() * r;
        }
    }
    for v in tau.iter_mut() {
        if opts.noise_tau > 0.0 {
            *v += opts.noise_tau * rng.normal();
        }
        if let Some(r) = opts.tau_resolution
            && r > 0.0
        {
            *v = (*v / r).round() * r;
        }
    }
    Ok(JointLog {
        joint_names: robot.joint_names.clone(),
        t0_ns: 0,
        t,
        q: qm,
        qd: if opts.write_velocity { Some(qd) } else { None },
        tau: Some(tau),
        u,
        truncated: false,
    })
}

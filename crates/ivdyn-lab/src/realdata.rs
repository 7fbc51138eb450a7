//! Identification on the two real arms of the development data (readers in
//! [`crate::real`]; results and the reasoning behind each choice in
//! `docs/real-data.md`).
//!
//! * [`identify_tx40`]: Stäubli TX40, motor side, coupled wrist. The motor positions are
//!   low-passed (zero-phase Butterworth) and differentiated at 5 kHz, the states and the
//!   anti-aliased motor torques are decimated to 500 Hz, the motor-side regressor
//!   ([`ivdyn::ident::transmission::MotorRegressor`]: `K⁻ᵀ Y` plus motor friction, rotor inertia
//!   and offset per motor) is built there, and torque and regressor go through the same
//!   decimating filter (parallel filtering) down to 100 Hz.
//! * [`identify_lwr`]: KUKA LWR4+, joint torques, runs already filtered by their
//!   authors: the joint-torque regressor (velocities and accelerations recomputed, every
//!   column through the authors' torque filter) plus a position-dependent torque `k_j q_j`
//!   per joint, every `step`-th sample; settings chosen by [`lwr_cross_validation`]
//!   within the fitted runs.
//!
//! Both fit the base parameters with [`Estimator::Ols`] or [`Estimator::Wls`] (per-joint
//! weights `1/σ_j²` from the OLS residuals, the `ivdyn identify --method wls` rule) and
//! report per-joint R² and RMS on held-out data. With `consistent`, they also fit
//! physically consistent full parameters ([`ivdyn::ident::consistent`]: log-Cholesky link
//! inertias, non-negative friction and armature) on the same weighted statistics, and
//! report how much the validation degrades ([`ConsistentPart`]). On the TX40 the link
//! parameters are joint-side and the drive parameters motor-side (`fc, fv, ia` of the
//! motors, `>= 0` as well): the full vector of [`MotorRegressor`] has the layout of
//! `ivdyn_core::params` (`10 n` link, then `4 n` drive), so the same fit applies.

use serde::Serialize;

use crate::real::{LwrRun, Tx40Data, tx40_transmission};
use ivdyn::Robot;
use ivdyn::dsp::{Butterworth, Decimator, central_diff, second_diff, take_rows};
use ivdyn::error::{Error, Result};
use ivdyn::ident::consistent::{ConsistentFit, fit_consistent};
use ivdyn::ident::transmission::MotorRegressor;
use ivdyn::ident::{BaseParams, FitReport, LsAccumulator, fit_ls, robot_base_params};
use ivdyn::report::{BaseValue, Quality};

/// How the base parameters are estimated.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
pub enum Estimator {
    /// Ordinary least squares.
    Ols,
    /// Weighted least squares, per-joint weights `1/σ_j²` from the OLS residual RMS.
    Wls,
}

impl Estimator {
    /// `"OLS"` / `"WLS"`.
    pub fn name(&self) -> &'static str {
        match self {
            Estimator::Ols => "OLS",
            Estimator::Wls => "WLS",
        }
    }
}

/// What a consistent fit needs besides the rows: the nominal full parameters (pulled
/// toward on the directions the data do not see) and the link and joint (or motor) names
/// for the violation reports.
#[derive(Debug, Clone, Copy)]
pub struct ConsistentInput<'a> {
    /// Nominal (URDF) full parameters.
    pub nominal: &'a [f64],
    /// Link names (`n`).
    pub links: &'a [String],
    /// Joint or motor names for the drive parameters (`n`).
    pub joints: &'a [String],
}

/// Stacked regressor rows: `T` samples of `n` joints, `p` full-parameter columns.
#[derive(Debug, Clone, Default)]
pub struct Rows {
    /// Joints.
    pub n: usize,
    /// Columns (full parameters).
    pub p: usize,
    /// Sample times (s), `T`.
    pub t: Vec<f64>,
    /// Regressor, `T x n x p` row-major.
    pub phi: Vec<f64>,
    /// Measured torques, `T x n`.
    pub tau: Vec<f64>,
}

impl Rows {
    /// Number of samples `T`.
    pub fn len(&self) -> usize {
        self.t.len()
    }
    /// No samples.
    pub fn is_empty(&self) -> bool {
        self.t.is_empty()
    }
    /// Samples `r` only.
    pub fn slice(&self, r: std::ops::Range<usize>) -> Rows {
        let (n, p) = (self.n, self.p);
        Rows {
            n,
            p,
            t: self.t[r.clone()].to_vec(),
            phi: self.phi[r.start * n * p..r.end * n * p].to_vec(),
            tau: self.tau[r.start * n..r.end * n].to_vec(),
        }
    }
    /// The samples `keep` (indices, ascending).
    pub fn select(&self, keep: &[usize]) -> Rows {
        let (n, p) = (self.n, self.p);
        Rows {
            n,
            p,
            t: keep.iter().map(|&k| self.t[k]).collect(),
            phi: take_rows(&self.phi, n * p, keep),
            tau: take_rows(&self.tau, n, keep),
        }
    }
    /// Appends the samples of `other` (same `n`, `p`).
    pub fn append(&mut self, other: &Rows) {
        self.t.extend_from_slice(&other.t);
        self.phi.extend_from_slice(&other.phi);
        self.tau.extend_from_slice(&other.tau);
    }
    /// `Φ θ` for a full parameter vector, `T x n`.
    pub fn predict(&self, theta: &[f64]) -> Vec<f64> {
        self.phi.chunks_exact(self.p).map(|r| r.iter().zip(theta).map(|(a, b)| a * b).sum()).collect()
    }
}

/// Per-joint R² and RMS of a prediction (`T x n` each): [`ivdyn::report::quality_of`].
pub fn quality(data: &str, measured: &[f64], predicted: &[f64], n: usize) -> Quality {
    ivdyn::report::quality_of(data, measured, predicted, n)
}

/// A fitted model.
#[derive(Debug, Clone)]
pub struct Fitted {
    /// Full parameters that reproduce the fit (`base.to_full` of the base estimate).
    pub theta_full: Vec<f64>,
    /// The base-parameter fit (with covariance and relative standard deviations).
    pub base_fit: FitReport,
    /// Per-joint weights used (1 for OLS).
    pub weights: Vec<f64>,
    /// The physically consistent fit on the same weighted statistics, when asked for.
    pub consistent: Option<ConsistentFit>,
}

/// Fits `rows` (full columns) with `est` on the base parameters `base`; with
/// `consistent`, also the physically consistent full parameters on the same weighted
/// statistics, starting from the estimate as full parameters (nominal + base correction,
/// [`BaseParams::apply`]).
pub fn fit_rows(rows: &Rows, base: &BaseParams, est: Estimator, consistent: Option<ConsistentInput>) -> Result<Fitted> {
    let (n, p, b) = (rows.n, rows.p, base.base_count());
    if base.full_cols != p {
        return Err(Error::Dimension {
            what: "base parameters' full columns".into(),
            expected: p,
            got: base.full_cols,
        });
    }
    let m = rows.tau.len();
    let phi_b = base.select_rows(&rows.phi, m)?;
    let fit_with = |w: &[f64]| -> Result<FitReport> {
        let rw: Vec<f64> = (0..m).map(|r| w[r % n]).collect();
        let mut acc = LsAccumulator::new(b);
        acc.add_rows(&phi_b, &rows.tau, Some(&rw))?;
        fit_ls(&acc, &base.names)
    };
    let ones = vec![1.0; n];
    let ols = fit_with(&ones)?;
    let (base_fit, weights) = match est {
        Estimator::Ols => (ols, ones),
        Estimator::Wls => {
            let full = base.to_full(&nan_to_zero(&ols.theta))?;
            let q = quality("", &rows.tau, &rows.predict(&full), n);
            let w = ivdyn::ident::wls::per_joint_weights(&q.rms);
            (fit_with(&w)?, w)
        }
    };
    let theta_base = nan_to_zero(&base_fit.theta);
    let theta_full = base.to_full(&theta_base)?;
    let consistent = match consistent {
        None => None,
        Some(c) => {
            let p0 = c.nominal.len();
            if p0 > p
                || base.independent.len() < p - p0
                || base.independent[b - (p - p0)..].iter().zip(p0..p).any(|(a, e)| *a != e)
            {
                return Err(Error::Dimension {
                    what: "nominal full parameters (the columns before the free extra ones)".into(),
                    expected: p,
                    got: p0,
                });
            }
            let rw: Vec<f64> = (0..m).map(|r| weights[r % n]).collect();
            Some(fit_consistent_with_free(&phi_b, &rows.tau, &rw, base, p - p0, &theta_base, c)?)
        }
    };
    Ok(Fitted { theta_full, base_fit, weights, consistent })
}

/// The consistent fit when the last `s` columns (full and base) are free parameters with
/// no physical constraint (LWR: joint springs `k_j q_j`). They are eliminated first: with
/// the columns ordered `[free | base0]`, `R = [[R11, R12], [0, R22]]`, `Qᵀy = [z1; z2]`, and
/// `‖R11 k + R12 θ0 - z1‖² + ‖R22 θ0 - z2‖²` is minimised over `k` by
/// `k = R11⁻¹ (z1 - R12 θ0)` for every `θ0`, so the consistent fit runs on `(R22, z2)`
/// (plus the LS residual) and `k` follows from its result. With `s = 0` it is the plain fit.
fn fit_consistent_with_free(
    phi_b: &[f64],
    tau: &[f64],
    rw: &[f64],
    base: &BaseParams,
    s: usize,
    theta_base: &[f64],
    c: ConsistentInput,
) -> Result<ConsistentFit> {
    let b = base.base_count();
    let m = tau.len();
    let b0 = b - s;
    let base0 = BaseParams {
        full_cols: base.full_cols - s,
        independent: base.independent[..b0].to_vec(),
        dependent: base.dependent.clone(),
        k: base.k.rows(0, b0).into_owned(),
        zero_columns: base.zero_columns.clone(),
        names: base.names[..b0].to_vec(),
    };
    let theta_ls = base0.apply(&theta_base[..b0], c.nominal, 1.0)?;
    if s == 0 {
        let mut acc = LsAccumulator::new(b);
        acc.add_rows(phi_b, tau, Some(rw))?;
        return fit_consistent(&acc, &base0, &theta_ls, c.nominal, c.links, c.joints, &Default::default());
    }
    let reordered: Vec<f64> = phi_b.chunks_exact(b).flat_map(|r| r[b0..].iter().chain(&r[..b0]).copied()).collect();
    let mut acc = LsAccumulator::new(b);
    acc.add_rows(&reordered, tau, Some(rw))?;
    let (r, z) = (acc.r(), acc.qty());
    let r22: Vec<f64> = (s..b).flat_map(|i| (s..b).map(move |j| (i, j))).map(|(i, j)| r[(i, j)]).collect();
    let mut red = LsAccumulator::new(b0);
    red.add_rows(&r22, z.as_slice()[s..].as_ref(), None)?;
    red.add_rows(&vec![0.0; b0], &[acc.rss().sqrt()], None)?;
    let mut cf = fit_consistent(&red, &base0, &theta_ls, c.nominal, c.links, c.joints, &Default::default())?;
    let r11 = r.view((0, 0), (s, s)).into_owned();
    let rhs = z.rows(0, s) - r.view((0, s), (s, b0)) * nalgebra::DVector::from_column_slice(&cf.theta_base);
    let k = r11.solve_upper_triangular(&rhs).ok_or_else(|| Error::Numerical {
        what: "consistent fit".into(),
        msg: format!("the {s} free columns are singular ({m} rows)"),
    })?;
    cf.theta.extend(k.iter());
    cf.theta_base.extend(k.iter());
    Ok(cf)
}

fn nan_to_zero(x: &[f64]) -> Vec<f64> {
    x.iter().map(|v| if v.is_finite() { *v } else { 0.0 }).collect()
}

/// Measured and predicted torques on the validation data (for plots).
#[derive(Debug, Clone, Serialize)]
pub struct Series {
    /// Sample times (s).
    pub t: Vec<f64>,
    /// Measured, `T x n` row-major.
    pub measured: Vec<f64>,
    /// Predicted, `T x n` row-major.
    pub predicted: Vec<f64>,
    /// Predicted by the physically consistent parameters, when fitted.
    pub predicted_consistent: Option<Vec<f64>>,
}

/// The physically consistent fit of a real arm next to the LS one.
#[derive(Debug, Clone, Serialize)]
pub struct ConsistentPart {
    /// Problems of the LS estimate as full parameters (nominal + base correction,
    /// [`BaseParams::apply`]), `"<link or joint>: <problem>"` ([`ivdyn::robot::physical`]).
    pub ls_violations: Vec<String>,
    /// Problems of the consistent parameters (empty when they are physically valid).
    pub violations: Vec<String>,
    /// The cost of consistency and the solver's figures (flattened into the JSON).
    #[serde(flatten)]
    pub cost: ivdyn::ident::consistent::ConsistentCost,
    /// Parameter names and the consistent full parameters (TX40: joint-side links, then
    /// motor-side `fc, fv, ia, tau0` per motor).
    pub names: Vec<String>,
    /// See `names`.
    pub theta: Vec<f64>,
    /// Quality on the fitted data (joint torques).
    pub fit: Quality,
    /// Quality on the validation data (joint torques).
    pub validation: Quality,
    /// TX40 only: on the validation data in motor torques.
    pub validation_motor: Option<Quality>,
}

/// Result of [`identify_tx40`] / [`identify_lwr`] (written as JSON by the example).
#[derive(Debug, Clone, Serialize)]
pub struct RealReport {
    /// Data set.
    pub dataset: String,
    /// Robot name.
    pub robot: String,
    /// Joint names (order of every per-joint list).
    pub joints: Vec<String>,
    /// Estimator.
    pub method: String,
    /// Which data were fitted and which validated.
    pub split: String,
    /// Signal processing, in words.
    pub preprocessing: String,
    /// Rate of the fitted rows (Hz).
    pub sample_rate_hz: f64,
    /// Rows (samples x joints) fitted.
    pub rows: usize,
    /// Base parameters (rank of the fit).
    pub rank: usize,
    /// Condition number of the base regressor (unscaled).
    pub condition_number: f64,
    /// Per-joint weights.
    pub weights: Vec<f64>,
    /// Base parameters with standard deviations (nominal: the URDF's value of the same
    /// combination, with the motor-side terms at zero).
    pub base: Vec<BaseValue>,
    /// Base parameters the fitted data do not excite.
    pub unexcited: Vec<String>,
    /// Quality on the fitted data (joint torques).
    pub fit: Quality,
    /// Quality on the validation data (joint torques; for the TX40 `τ = Kᵀ τ_m`).
    pub validation: Quality,
    /// TX40 only: quality on the validation data in motor torques (as measured).
    pub validation_motor: Option<Quality>,
    /// LWR only: quality on every sample of the validation run (the dropped edges included).
    pub validation_all: Option<Quality>,
    /// The plain least-squares floor of `../shared/data/README.md` (validation R²).
    pub floor_r2: Vec<f64>,
    /// Validation torques (joint side), for plots.
    pub series: Series,
    /// The physically consistent fit (with `consistent` in the options).
    pub consistent: Option<ConsistentPart>,
    /// Remarks.
    pub notes: Vec<String>,
}

/// The README's validation R² floor for the TX40 (with the wrist-coupling terms).
pub const TX40_FLOOR_R2: [f64; 6] = [0.96, 0.97, 0.97, 0.88, 0.23, 0.71];
/// The README's validation R² floor for the LWR4+ (fit runs 1+3, validate run 2).
pub const LWR_FLOOR_R2: [f64; 7] = [0.88, 1.00, 0.99, 1.00, 0.88, 0.51, 0.47];

/// Options of [`identify_tx40`].
#[derive(Debug, Clone)]
pub struct Tx40Options {
    /// Zero-phase -3 dB cut-off of the position low-pass before differentiation (Hz).
    pub cutoff_hz: f64,
    /// Butterworth order of that low-pass (per pass).
    pub order: usize,
    /// First decimation (5 kHz -> 500 Hz): states sub-sampled, torque anti-aliased.
    pub decimate_states: usize,
    /// Second decimation with the parallel filter on torque and regressor (500 -> 100 Hz).
    pub decimate_parallel: usize,
    /// Keep the joint-side drive columns besides the motor-side ones.
    pub joint_drive: bool,
    /// Estimator.
    pub estimator: Estimator,
    /// Fit the joint-side equations `Kᵀ τ_m = Kᵀ Φ θ` instead of the motor-side ones
    /// (the same model; ordinary least squares then weighs motor `i` by `Σ_j K_ji²`, the
    /// big joints most).
    pub fit_joint_side: bool,
    /// Fitted raw rows (5 kHz sample indices). FIGAROH's example: 0..24750.
    pub fit_rows: std::ops::Range<usize>,
    /// Validation raw rows. FIGAROH's example: 29250..45000.
    pub val_rows: std::ops::Range<usize>,
    /// Random states for the base parameters, and their seed.
    pub base_samples: usize,
    /// Seed.
    pub seed: u64,
    /// Also fit physically consistent parameters ([`ConsistentPart`]; not with `joint_drive`).
    pub consistent: bool,
    /// Motor Coulomb friction as `tanh(qd_m / v0)` instead of `sign(qd_m)`, with `v0` per
    /// motor `SMOOTH_COULOMB_NOISE_FACTOR` times the motor velocity's noise level (the RMS
    /// of its part above [`VELOCITY_NOISE_HZ`] over the fitted rows): near standstill the
    /// sign of a noisy velocity flips at random while real friction holds the arm.
    pub smooth_coulomb: bool,
    /// Drop the samples at which the arm stands still (every motor's `|qd_m|` below the
    /// `v0` of `smooth_coulomb`) from the fit and the validation: there the position loop
    /// holds the arm against static friction, which the Coulomb + viscous model does not
    /// describe. The whole validation window is reported as well (`validation_all`).
    pub exclude_standstill: bool,
}

/// Motor velocities above this frequency (Hz) count as noise for [`Tx40Options::smooth_coulomb`]:
/// 99.9 % of the joint-velocity energy lies below 4-7 Hz (docs/real-data.md).
pub const VELOCITY_NOISE_HZ: f64 = 20.0;
/// `v0` of the smooth Coulomb term in multiples of the velocity noise RMS: beyond 3 sigma
/// the sign of the measured velocity is the true one (99.7 % for Gaussian noise).
pub const SMOOTH_COULOMB_NOISE_FACTOR: f64 = 3.0;

impl Default for Tx40Options {
    fn default() -> Self {
        Tx40Options {
            cutoff_hz: 100.0,
            order: 4,
            decimate_states: 10,
            decimate_parallel: 20,
            joint_drive: false,
            estimator: Estimator::Ols,
            fit_joint_side: false,
            fit_rows: 0..24750,
            val_rows: 29250..45000,
            base_samples: 200,
            seed: 1,
            consistent: false,
            smooth_coulomb: false,
            exclude_standstill: false,
        }
    }
}

/// Identifies the TX40 (module docs) and validates on the held-out rows.
pub fn identify_tx40(data: &Tx40Data, opts: &Tx40Options) -> Result<RealReport> {
    let robot = &data.robot;
    let n = robot.dof();
    let trans = tx40_transmission();
    let reg = MotorRegressor::new(robot, &trans, opts.joint_drive)?;
    check_tx40_windows(data.len(), opts)?;
    let fs = 1.0 / data.dt;
    let sig = tx40_signals(data, &reg, opts)?;
    let split = sig.split(opts);
    let (fitted, nom_base) = fit_tx40(&reg, &split.fit, opts)?;
    let (fm, fp) = joint_side_torques(&trans, &split.fit, &fitted.theta_full)?;
    let (vm, vp) = joint_side_torques(&trans, &split.val, &fitted.theta_full)?;
    let validation_motor =
        Some(quality("validation, motor torques", &split.val.tau, &split.val.predict(&fitted.theta_full), n));
    let consistent = match &fitted.consistent {
        None => None,
        Some(cf) => Some(tx40_consistent_part(cf, &reg, &split)?),
    };
    let rate = fs / (sig.d1 * sig.d2) as f64;
    Ok(RealReport {
        dataset: "Stäubli TX40 (FIGAROH example data)".into(),
        robot: robot.name.clone(),
        joints: robot.joint_names.clone(),
        method: fitted.base_fit.method.replace("LS", opts.estimator.name()),
        split: tx40_split_text(opts, data.dt),
        preprocessing: tx40_preprocessing_text(opts, &sig, fs, rate, split.standstill),
        sample_rate_hz: rate,
        rows: fitted.base_fit.rows,
        rank: fitted.base_fit.rank,
        condition_number: fitted.base_fit.condition_number,
        weights: fitted.weights.clone(),
        base: base_values(&fitted.base_fit, &nom_base),
        unexcited: fitted.base_fit.unexcited.clone(),
        fit: quality("fit, joint torques K^T tau_m", &fm, &fp, n),
        validation: quality("validation, joint torques K^T tau_m", &vm, &vp, n),
        validation_all: if split.standstill.is_some() {
            let (am, ap) = joint_side_torques(&trans, &split.val_all, &fitted.theta_full)?;
            Some(quality("validation, whole window (standstill included)", &am, &ap, n))
        } else {
            None
        },
        validation_motor,
        floor_r2: TX40_FLOOR_R2.to_vec(),
        series: Series {
            t: split.val.t.clone(),
            measured: vm,
            predicted: vp,
            predicted_consistent: consistent.as_ref().map(|c| c.1.clone()),
        },
        consistent: consistent.map(|c| c.0),
        notes: vec![],
    })
}

/// Both raw windows of `opts` non-empty and inside the record of `t_raw` samples.
fn check_tx40_windows(t_raw: usize, opts: &Tx40Options) -> Result<()> {
    for (what, r) in [("fit_rows", &opts.fit_rows), ("val_rows", &opts.val_rows)] {
        if r.end > t_raw || r.start >= r.end {
            return Err(Error::option(what, format!("{r:?} is outside the TX40 record's {t_raw} samples")));
        }
    }
    Ok(())
}

/// Motor states and torques at the intermediate rate `fs / d1` (steps 1-2 of the module
/// docs), `T1 x n` each.
struct MotorStates {
    /// Raw sample index of each intermediate row.
    keep: Vec<usize>,
    /// Low-passed motor positions and their central first and second differences.
    q: Vec<f64>,
    qd: Vec<f64>,
    qdd: Vec<f64>,
    /// Anti-aliased motor torques.
    tau: Vec<f64>,
}

/// Steps 1-2 of the module docs: positions low-passed (zero phase) and differentiated at
/// the raw rate `fs`, then the states sub-sampled and the torques decimated by `d1`.
fn tx40_motor_states(data: &Tx40Data, opts: &Tx40Options, d1: usize) -> Result<MotorStates> {
    let n = data.robot.dof();
    let fs = 1.0 / data.dt;
    // 1. positions: zero-phase low-pass, central differences at 5 kHz
    let lp = Butterworth::zero_phase(opts.order, opts.cutoff_hz, fs)?;
    let qf = lp.filtfilt_columns(&data.q_m, n)?;
    let qd = central_diff(&qf, n, data.dt)?;
    let qdd = second_diff(&qf, n, data.dt)?;
    // 2. states sub-sampled (band-limited well below the new Nyquist), torque anti-aliased
    let keep: Vec<usize> = (0..data.len()).step_by(d1).collect();
    let (q, qd, qdd) = (take_rows(&qf, n, &keep), take_rows(&qd, n, &keep), take_rows(&qdd, n, &keep));
    let tau = if d1 > 1 { Decimator::new(d1, fs)?.apply(&data.tau_m, n)? } else { data.tau_m.clone() };
    Ok(MotorStates { keep, q, qd, qdd, tau })
}

/// The TX40 record through the signal chain of the module docs, with what the split and
/// the report need from it.
struct Tx40Signals {
    /// Every sample at the output rate `fs / (d1 d2)`: motor-side regressor and torques.
    all: Rows,
    /// Motor velocities at the intermediate rate `fs1`, `T1 x n` (the standstill test).
    qd1: Vec<f64>,
    /// Per-motor `v0` of [`Tx40Options::smooth_coulomb`] and
    /// [`Tx40Options::exclude_standstill`], when either is asked for.
    v0: Option<Vec<f64>>,
    /// The intermediate rate (Hz).
    fs1: f64,
    /// The state decimation (raw -> intermediate) and the parallel filter's (-> output).
    d1: usize,
    d2: usize,
    /// The parallel filter's -3 dB cut-off (Hz).
    par_cutoff_hz: f64,
}

/// Steps 1-3 of the module docs: motor states at the intermediate rate, the motor-side
/// regressor there, then torque and regressor through the same decimating filter
/// (parallel filtering: the fit sees both with the same phase and gain).
fn tx40_signals(data: &Tx40Data, reg: &MotorRegressor, opts: &Tx40Options) -> Result<Tx40Signals> {
    let n = data.robot.dof();
    let fs = 1.0 / data.dt;
    let d1 = opts.decimate_states.max(1);
    let s1 = tx40_motor_states(data, opts, d1)?;
    // 3. regressor at the intermediate rate, then the same decimating filter on both
    let fs1 = fs / d1 as f64;
    let mut phi1 = reg.rows(&s1.q, &s1.qd, &s1.qdd)?;
    let p = reg.num_params();
    let v0 = if opts.smooth_coulomb || opts.exclude_standstill {
        let v0 = motor_velocity_v0(&s1.qd, n, fs1, d1, opts)?;
        if opts.smooth_coulomb {
            smooth_coulomb_columns(&mut phi1, &s1.qd, &v0, reg);
        }
        Some(v0)
    } else {
        None
    };
    let d2 = opts.decimate_parallel.max(1);
    let par =
        if d2 > 1 { Decimator::new(d2, fs1)? } else { Decimator::with_filter(1, Butterworth::default_for(fs1)?)? };
    let phi = par.apply(&phi1, n * p)?;
    let tau = par.apply(&s1.tau, n)?;
    let t: Vec<f64> = s1.keep.iter().step_by(d2).map(|&k| k as f64 * data.dt).collect();
    let all = Rows { n, p, t, phi, tau };
    Ok(Tx40Signals { all, qd1: s1.qd, v0, fs1, d1, d2, par_cutoff_hz: par.filter.cutoff_hz })
}

/// Per-motor `v0`: [`SMOOTH_COULOMB_NOISE_FACTOR`] times the RMS of the motor velocity's
/// part above [`VELOCITY_NOISE_HZ`] (its noise) over the fitted rows; `qd1` is at the
/// intermediate rate `fs1`, `d1` raw samples per row.
fn motor_velocity_v0(qd1: &[f64], n: usize, fs1: f64, d1: usize, opts: &Tx40Options) -> Result<Vec<f64>> {
    // noise level: the part of the motor velocity above VELOCITY_NOISE_HZ, fitted rows only
    let qd1_low = Butterworth::zero_phase(opts.order, VELOCITY_NOISE_HZ, fs1)?.filtfilt_columns(qd1, n)?;
    let fit1 = opts.fit_rows.start / d1..(opts.fit_rows.end / d1).min(qd1.len() / n);
    Ok((0..n)
        .map(|i| {
            let ss: f64 = fit1.clone().map(|k| (qd1[k * n + i] - qd1_low[k * n + i]).powi(2)).sum();
            SMOOTH_COULOMB_NOISE_FACTOR * (ss / fit1.len() as f64).sqrt()
        })
        .collect())
}

/// Each motor's Coulomb column `sign(qd_m)` of the regressor rows `phi1` replaced by
/// `tanh(qd_m / v0)` ([`Tx40Options::smooth_coulomb`]).
fn smooth_coulomb_columns(phi1: &mut [f64], qd1: &[f64], v0: &[f64], reg: &MotorRegressor) {
    let (n, p) = (v0.len(), reg.num_params());
    for (k, blk) in phi1.chunks_exact_mut(n * p).enumerate() {
        for i in 0..n {
            blk[i * p + reg.motor_col(i, ivdyn_core::params::FC)] = (qd1[k * n + i] / v0[i]).tanh();
        }
    }
}

/// The TX40's fitted and validated rows.
struct Tx40Split {
    /// Rows of the fitted window (standstill dropped when asked for).
    fit: Rows,
    /// Rows of the validation window (standstill dropped when asked for).
    val: Rows,
    /// Every row of the validation window.
    val_all: Rows,
    /// Standstill rows dropped (fitted, validated), with [`Tx40Options::exclude_standstill`].
    standstill: Option<(usize, usize)>,
}

impl Tx40Signals {
    /// The output rows of the raw windows `fit_rows` and `val_rows`; with
    /// `exclude_standstill`, without the rows at which every motor is slower than its `v0`.
    fn split(&self, opts: &Tx40Options) -> Tx40Split {
        let (n, d2, all) = (self.all.n, self.d2, &self.all);
        let step = self.d1 * d2;
        let to_rows = |r: &std::ops::Range<usize>| r.start.div_ceil(step)..r.end.div_ceil(step).min(all.len());
        let (fit, val) = (all.slice(to_rows(&opts.fit_rows)), all.slice(to_rows(&opts.val_rows)));
        let val_all = val.clone();
        let (fit, val, standstill) = match (&self.v0, opts.exclude_standstill) {
            (Some(v0), true) => {
                // the velocity at each parallel-filtered row: qd1 at the same instant
                let moving = |k: usize| (0..n).any(|i| self.qd1[k * d2 * n + i].abs() >= v0[i]);
                let fr = to_rows(&opts.fit_rows);
                let vr = to_rows(&opts.val_rows);
                let fit_keep: Vec<usize> = fr.clone().filter(|&k| moving(k)).map(|k| k - fr.start).collect();
                let val_keep: Vec<usize> = vr.clone().filter(|&k| moving(k)).map(|k| k - vr.start).collect();
                let dropped = (fr.len() - fit_keep.len(), vr.len() - val_keep.len());
                (fit.select(&fit_keep), val.select(&val_keep), Some(dropped))
            }
            _ => (fit, val, None),
        };
        Tx40Split { fit, val, val_all, standstill }
    }
}

/// Fits `rows` (module docs: motor side, or joint side with `fit_joint_side`) on the
/// motor-side regressor's base parameters; also returns the nominal (URDF, motor terms at
/// zero) value of each base parameter.
fn fit_tx40(reg: &MotorRegressor, rows: &Rows, opts: &Tx40Options) -> Result<(Fitted, Vec<f64>)> {
    let robot = reg.robot;
    let n = robot.dof();
    let base = reg.base_params(opts.base_samples, opts.seed)?;
    let nominal = reg.params(&vec![Default::default(); n])?;
    let nom_base = base.project(&nominal)?;
    if opts.consistent && opts.joint_drive {
        return Err(Error::option(
            "consistent",
            "needs the 10 n + 4 n layout of the TX40 (no joint-side drive columns): leave joint_drive off",
        ));
    }
    let motors: Vec<String> = robot.joint_names.iter().map(|j| format!("{j}.motor")).collect();
    let cin =
        opts.consistent.then_some(ConsistentInput { nominal: &nominal, links: &robot.link_names, joints: &motors });
    let fitted = if opts.fit_joint_side {
        fit_rows_checked(&joint_side_rows(rows, reg.trans)?, &base, opts.estimator, cin)?
    } else {
        fit_rows_checked(rows, &base, opts.estimator, cin)?
    };
    Ok((fitted, nom_base))
}

/// Measured and predicted (by `theta`) torques of `rows` on the joint side, `Kᵀ τ_m`: the
/// common ground of the motor-side and joint-side fits.
fn joint_side_torques(
    trans: &ivdyn::ident::transmission::Transmission,
    rows: &Rows,
    theta: &[f64],
) -> Result<(Vec<f64>, Vec<f64>)> {
    Ok((trans.joint_torques(&rows.tau)?, trans.joint_torques(&rows.predict(theta))?))
}

/// The consistent fit's part of the TX40 report (quality on the joint side, and on the
/// motor side for the validation), with its joint-side validation prediction for the plots.
fn tx40_consistent_part(
    cf: &ConsistentFit,
    reg: &MotorRegressor,
    split: &Tx40Split,
) -> Result<(ConsistentPart, Vec<f64>)> {
    let n = reg.robot.dof();
    let (cfm, cfp) = joint_side_torques(reg.trans, &split.fit, &cf.theta)?;
    let (cvm, cvp) = joint_side_torques(reg.trans, &split.val, &cf.theta)?;
    let mut part = consistent_part(
        cf,
        reg.param_names(),
        quality("fit, joint torques K^T tau_m", &cfm, &cfp, n),
        quality("validation, joint torques K^T tau_m", &cvm, &cvp, n),
    );
    part.validation_motor =
        Some(quality("validation, motor torques", &split.val.tau, &split.val.predict(&cf.theta), n));
    Ok((part, cvp))
}

/// The report's `split`: the raw windows, in samples and seconds (`dt`: raw sample time).
fn tx40_split_text(opts: &Tx40Options, dt: f64) -> String {
    format!(
        "fit on raw rows {}..{} ({:.2}-{:.2} s), validate on raw rows {}..{} ({:.2}-{:.2} s), FIGAROH's split",
        opts.fit_rows.start,
        opts.fit_rows.end,
        opts.fit_rows.start as f64 * dt,
        opts.fit_rows.end as f64 * dt,
        opts.val_rows.start,
        opts.val_rows.end,
        opts.val_rows.start as f64 * dt,
        opts.val_rows.end as f64 * dt
    )
}

/// The report's `preprocessing`: the signal chain's settings in words (`fs`: raw rate,
/// `rate`: output rate, `standstill`: rows dropped).
fn tx40_preprocessing_text(
    opts: &Tx40Options,
    sig: &Tx40Signals,
    fs: f64,
    rate: f64,
    standstill: Option<(usize, usize)>,
) -> String {
    let (d1, d2) = (sig.d1, sig.d2);
    format!(
        "motor positions: zero-phase Butterworth order {} at {} Hz (-3 dB), central differences at {} Hz; states sub-sampled x{d1} and motor torques decimated x{d1} (zero-phase anti-alias) to {} Hz; motor-side regressor (K^-T Y{} + motor fc, fv, ia, tau0) there; torque and regressor through the same decimator x{d2} (zero-phase -3 dB at {:.0} Hz) to {} Hz",
        opts.order,
        opts.cutoff_hz,
        fs,
        sig.fs1,
        if opts.joint_drive { " with joint-side drive columns" } else { "" },
        sig.par_cutoff_hz,
        rate
    ) + &sig.v0.as_ref().map_or(String::new(), |v| {
        format!(
            "; v0 = {} rad/s (3x the motor velocity noise RMS above {VELOCITY_NOISE_HZ} Hz)",
            v.iter().map(|x| format!("{x:.3}")).collect::<Vec<_>>().join(", ")
        )
    }) + if opts.smooth_coulomb { "; motor Coulomb friction tanh(qd_m / v0)" } else { "" }
        + &standstill.map_or(String::new(), |(f, v)| {
            format!("; standstill rows (every |qd_m| < v0) dropped: {f} fitted, {v} validated")
        })
}

/// The rows mapped to the joint side: each sample's `n x p` block and torques times `Kᵀ`.
pub fn joint_side_rows(rows: &Rows, trans: &ivdyn::ident::transmission::Transmission) -> Result<Rows> {
    let (n, p) = (rows.n, rows.p);
    let kt = trans.k().transpose();
    let mut phi = vec![0.0; rows.phi.len()];
    for (blk, out) in rows.phi.chunks_exact(n * p).zip(phi.chunks_exact_mut(n * p)) {
        for i in 0..n {
            for j in 0..n {
                let c = kt[(i, j)];
                if c != 0.0 {
                    for (o, v) in out[i * p..(i + 1) * p].iter_mut().zip(&blk[j * p..(j + 1) * p]) {
                        *o += c * v;
                    }
                }
            }
        }
    }
    Ok(Rows { n, p, t: rows.t.clone(), phi, tau: trans.joint_torques(&rows.tau)? })
}

fn fit_rows_checked(
    rows: &Rows,
    base: &BaseParams,
    est: Estimator,
    consistent: Option<ConsistentInput>,
) -> Result<Fitted> {
    if rows.tau.len() < 2 * base.base_count() {
        return Err(Error::TooFewSamples {
            samples: rows.tau.len() / rows.n.max(1),
            joints: rows.n,
            params: base.base_count(),
        });
    }
    fit_rows(rows, base, est, consistent)
}

fn consistent_part(cf: &ConsistentFit, names: Vec<String>, fit: Quality, validation: Quality) -> ConsistentPart {
    ConsistentPart {
        ls_violations: cf.ls_check.lines(),
        violations: cf.check.lines(),
        cost: cf.cost,
        names,
        theta: cf.theta.clone(),
        fit,
        validation,
        validation_motor: None,
    }
}

fn base_values(fit: &FitReport, nominal: &[f64]) -> Vec<BaseValue> {
    (0..fit.theta.len())
        .map(|i| BaseValue {
            name: fit.names[i].clone(),
            value: fit.theta[i],
            std: fit.std[i],
            rel_std_pct: fit.rel_std_pct[i],
            nominal: nominal[i],
        })
        .collect()
}

/// Options of [`identify_lwr`].
#[derive(Debug, Clone)]
pub struct LwrOptions {
    /// Use every `step`-th sample (the data are low-passed at 2-3 Hz by their authors, so
    /// 100 Hz loses nothing).
    pub step: usize,
    /// Estimator.
    pub estimator: Estimator,
    /// `None`: use the data's velocities and accelerations. `Some(fc)`: recompute them
    /// from the positions by central differences and pass every regressor column through
    /// the zero-phase Butterworth the authors applied to the torques (FloBaRoID
    /// `excite.py`: `scipy.signal.butter(6, 2 Hz)` + `filtfilt`, i.e. order 6, -6 dB at
    /// `fc` after the two passes), so torque and regressor carry the same filtering.
    /// Default `Some(2.0)`.
    pub matched_filter_hz: Option<f64>,
    /// Random states for the base parameters.
    pub base_samples: usize,
    /// Seed.
    pub seed: u64,
    /// Also fit physically consistent parameters ([`ConsistentPart`]).
    pub consistent: bool,
    /// Seconds dropped at both ends of every run (fitted and validated), e.g.
    /// [`butterworth_settling_s`]`(6, 2.0)` = 1.42 s: the transients of the authors'
    /// zero-phase 2 Hz filter, whose end handling (SciPy `filtfilt`, 21 samples of odd
    /// extension) the regressor's filter does not reproduce. Default 0 (chosen by
    /// cross-validation within the fitted runs, docs/real-data.md).
    pub edge_s: f64,
    /// Joints (0-based) given a position-dependent torque `k_j q_j` (a linear spring: cable
    /// and hose stiffness, a sensor offset varying with the joint angle), a free parameter
    /// appended after the `14 n` columns. Default: every joint (chosen by cross-validation
    /// within the fitted runs, docs/real-data.md).
    pub springs: Vec<usize>,
}

impl Default for LwrOptions {
    fn default() -> Self {
        LwrOptions {
            step: 2,
            estimator: Estimator::Wls,
            matched_filter_hz: Some(2.0),
            base_samples: 200,
            seed: 1,
            consistent: false,
            edge_s: 0.0,
            springs: (0..7).collect(),
        }
    }
}

/// `base` with `s` more columns appended as independent base parameters (free columns
/// such as the LWR's springs, not combinations of the rigid-body ones).
fn with_free_columns(base: BaseParams, names: &[String]) -> BaseParams {
    let mut b = base;
    let (p0, b0, d) = (b.full_cols, b.base_count(), b.dependent.len());
    b.full_cols += names.len();
    b.independent.extend(p0..p0 + names.len());
    b.k = b.k.resize_vertically(b0 + names.len(), 0.0);
    debug_assert_eq!(b.k.ncols(), d);
    b.names.extend(names.iter().cloned());
    b
}

/// The joint-torque rows of one LWR run (every `step`-th sample, full `14 n` columns,
/// then one `q_j` column per spring joint of `opts`), without the first and last `edge_s`
/// seconds.
pub fn lwr_rows(robot: &Robot, run: &LwrRun, opts: &LwrOptions, edge_s: f64) -> Result<Rows> {
    let n = robot.dof();
    let p14 = robot.num_params();
    let springs = &opts.springs;
    if let Some(&j) = springs.iter().find(|&&j| j >= n) {
        return Err(Error::option("springs", format!("joint index {j} is not one of the LWR's {n} joints")));
    }
    let p = p14 + springs.len();
    let t_all = run.len();
    let dt = (run.t[t_all - 1] - run.t[0]) / (t_all - 1) as f64;
    let (qd, qdd) = match opts.matched_filter_hz {
        None => (run.qd.clone(), run.qdd.clone()),
        Some(_) => (central_diff(&run.q, n, dt)?, second_diff(&run.q, n, dt)?),
    };
    let mut y = vec![0.0; t_all * n * p14];
    ivdyn::batch::regressor_batch(robot, &run.q, &qd, &qdd, &mut y, false)?;
    let mut phi = vec![0.0; t_all * n * p];
    for (r, (out, yr)) in phi.chunks_exact_mut(p).zip(y.chunks_exact(p14)).enumerate() {
        out[..p14].copy_from_slice(yr);
        let (k, i) = (r / n, r % n);
        for (c, &j) in springs.iter().enumerate() {
            if j == i {
                out[p14 + c] = run.q[k * n + i];
            }
        }
    }
    if let Some(fc) = opts.matched_filter_hz {
        phi = Butterworth::lowpass(6, fc, 1.0 / dt)?.filtfilt_columns(&phi, n * p)?;
    }
    let edge = (edge_s / dt).round() as usize;
    if 2 * edge >= t_all {
        return Err(Error::ShortLog {
            what: format!("LWR {}", run.file.display()),
            samples: t_all,
            needed: 2 * edge + 1,
            needed_by: format!("dropping {edge_s} s at each end"),
        });
    }
    let keep: Vec<usize> = (edge..t_all - edge).step_by(opts.step.max(1)).collect();
    Ok(Rows {
        n,
        p,
        t: keep.iter().map(|&k| run.t[k]).collect(),
        phi: take_rows(&phi, n * p, &keep),
        tau: take_rows(&run.tau, n, &keep),
    })
}

/// Seconds for the slowest pole of an order-`order` Butterworth low-pass at `fc_hz` to
/// decay to 1 % (`ln 100 / (2π fc sin(π / 2 order))`): the length of its start-up and
/// end transients.
pub fn butterworth_settling_s(order: usize, fc_hz: f64) -> f64 {
    100f64.ln() / (2.0 * std::f64::consts::PI * fc_hz * (std::f64::consts::PI / (2.0 * order as f64)).sin())
}

/// Identifies the LWR4+ on `fit` runs and validates on `val` (FloBaRoID's split: fit on
/// runs 1 and 3, validate on run 2).
pub fn identify_lwr(robot: &Robot, fit: &[&LwrRun], val: &LwrRun, opts: &LwrOptions) -> Result<RealReport> {
    let n = robot.dof();
    let spring_names: Vec<String> = opts
        .springs
        .iter()
        .map(|&j| format!("{}.spring", robot.joint_names.get(j).map_or("?", |s| s.as_str())))
        .collect();
    let mut fit_rows = Rows { n, p: robot.num_params() + spring_names.len(), ..Default::default() };
    for r in fit {
        fit_rows.append(&lwr_rows(robot, r, opts, opts.edge_s)?);
    }
    let val_rows = lwr_rows(robot, val, opts, opts.edge_s)?;
    let val_all = lwr_rows(robot, val, opts, 0.0)?;
    let base = with_free_columns(robot_base_params(robot, opts.base_samples, opts.seed)?, &spring_names);
    let nominal = robot.params();
    let mut names = robot.param_names();
    names.extend(spring_names.iter().cloned());
    let cin = opts.consistent.then_some(ConsistentInput {
        nominal: &nominal,
        links: &robot.link_names,
        joints: &robot.joint_names,
    });
    let fitted = fit_rows_checked(&fit_rows, &base, opts.estimator, cin)?;
    let mut nominal_ext = nominal.clone();
    nominal_ext.resize(fit_rows.p, 0.0);
    let nom_base = base.project(&nominal_ext)?;
    let vp = val_rows.predict(&fitted.theta_full);
    let consistent = fitted.consistent.as_ref().map(|cf| {
        let cvp = val_rows.predict(&cf.theta);
        let part = consistent_part(
            cf,
            names.clone(),
            quality("fit", &fit_rows.tau, &fit_rows.predict(&cf.theta), n),
            quality("validation", &val_rows.tau, &cvp, n),
        );
        (part, cvp)
    });
    let name = |r: &LwrRun| r.file.file_name().map(|s| s.to_string_lossy().into_owned()).unwrap_or_default();
    let dt = ivdyn::dsp::median_dt(&val.t).unwrap_or(f64::NAN);
    Ok(RealReport {
        dataset: "KUKA LWR4+ (FloBaRoID data)".into(),
        robot: robot.name.clone(),
        joints: robot.joint_names.clone(),
        method: fitted.base_fit.method.replace("LS", opts.estimator.name()),
        split: format!("fit on {}, validate on {}", fit.iter().map(|r| name(r)).collect::<Vec<_>>().join(" + "), name(val)),
        preprocessing: format!(
            "{}; every {}th sample; the first and last {:.2} s of every run dropped (filter transients){}",
            match opts.matched_filter_hz {
                None => "positions, velocities, accelerations and torques as filtered by the data's authors (2-3 Hz zero-phase)".to_string(),
                Some(fc) => format!("positions as filtered by the authors (3 Hz); velocities and accelerations by central differences (uniform step: the mean stamp interval); every regressor column through the authors' torque filter (Butterworth order 6, {fc} Hz, forward-backward); torques as given"),
            },
            opts.step,
            opts.edge_s,
            if spring_names.is_empty() { String::new() } else { format!("; position-dependent torque k q on {}", spring_names.join(", ")) }
        ),
        sample_rate_hz: 1.0 / (dt * opts.step as f64),
        rows: fitted.base_fit.rows,
        rank: fitted.base_fit.rank,
        condition_number: fitted.base_fit.condition_number,
        weights: fitted.weights.clone(),
        base: base_values(&fitted.base_fit, &nom_base),
        unexcited: fitted.base_fit.unexcited.clone(),
        fit: quality("fit", &fit_rows.tau, &fit_rows.predict(&fitted.theta_full), n),
        validation: quality("validation", &val_rows.tau, &vp, n),
        validation_all: Some(quality("validation, whole run (edges included)", &val_all.tau, &val_all.predict(&fitted.theta_full), n)),
        validation_motor: None,
        floor_r2: LWR_FLOOR_R2.to_vec(),
        series: Series { t: val_rows.t.clone(), measured: val_rows.tau.clone(), predicted: vp, predicted_consistent: consistent.as_ref().map(|c| c.1.clone()) },
        consistent: consistent.map(|c| c.0),
        notes: vec![],
    })
}

/// Cross-validation within the fitted runs, to choose settings without the validation
/// run: each run in turn is held out and predicted from a fit on the others. Returns the
/// held-out per-joint R² of each fold (`runs.len()` folds; needs two runs or more).
pub fn lwr_cross_validation(robot: &Robot, runs: &[&LwrRun], opts: &LwrOptions) -> Result<Vec<Vec<f64>>> {
    if runs.len() < 2 {
        return Err(Error::option("runs", format!("LWR cross-validation needs two or more, got {}", runs.len())));
    }
    let o = LwrOptions { consistent: false, ..opts.clone() };
    (0..runs.len())
        .map(|k| {
            let others: Vec<&LwrRun> = runs.iter().enumerate().filter(|(i, _)| *i != k).map(|(_, r)| *r).collect();
            Ok(identify_lwr(robot, &others, runs[k], &o)?.validation.r2)
        })
        .collect()
}

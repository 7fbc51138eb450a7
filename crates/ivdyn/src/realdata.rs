//! Identification on the two real arms of the development data (readers in
//! [`crate::io::real`]; results and the reasoning behind each choice in
//! `docs/real-data.md`).
//!
//! * [`identify_tx40`]: Stäubli TX40, motor side, coupled wrist. The motor positions are
//!   low-passed (zero-phase Butterworth) and differentiated at 5 kHz, the states and the
//!   anti-aliased motor torques are decimated to 500 Hz, the motor-side regressor
//!   ([`crate::transmission::MotorRegressor`]: `K⁻ᵀ Y` plus motor friction, rotor inertia
//!   and offset per motor) is built there, and torque and regressor go through the same
//!   decimating filter (parallel filtering) down to 100 Hz.
//! * [`identify_lwr`]: KUKA LWR4+, joint torques, runs already filtered by their
//!   authors: the joint-torque regressor on the given states, every `step`-th sample.
//!
//! Both fit the base parameters with [`Estimator::Ols`] or [`Estimator::Wls`] (per-joint
//! weights `1/σ_j²` from the OLS residuals, the `ivdyn identify --method wls` rule), or
//! with a caller's fit on the full-parameter statistics ([`FullFit`], the hook for a
//! physically consistent fit), and report per-joint R² and RMS on held-out data.

use serde::Serialize;

use crate::error::{Error, Result};
use crate::ident::{fit_ls, robot_base_params, BaseParams, FitReport, LsAccumulator};
use crate::io::real::{tx40_transmission, LwrRun, Tx40Data};
use crate::pipeline::{BaseValue, Quality};
use crate::signal::{central_diff, second_diff, take_rows, Butterworth, Decimator};
use crate::transmission::MotorRegressor;
use crate::Robot;

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

/// A fit of full parameters from the weighted full-column statistics: receives the
/// [`LsAccumulator`] of `[√W Φ_full | √W τ]` (all `p` columns, the weights of the chosen
/// estimator) and the parameter names, returns a full parameter vector (`p`). A
/// physically consistent fit (e.g. log-Cholesky) plugs in here; the regressor's
/// triangular factor is all it needs, since `‖√W (τ - Φ θ)‖² = ‖R_aug [θ; -1]‖²`.
pub type FullFit<'a> = &'a dyn Fn(&LsAccumulator, &[String]) -> Result<Vec<f64>>;

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
        Rows { n, p, t: self.t[r.clone()].to_vec(), phi: self.phi[r.start * n * p..r.end * n * p].to_vec(), tau: self.tau[r.start * n..r.end * n].to_vec() }
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

/// Per-joint R² and RMS of a prediction (`T x n` each).
pub fn quality(data: &str, measured: &[f64], predicted: &[f64], n: usize) -> Quality {
    let t = measured.len() / n;
    let (mut sse, mut sum, mut sum2) = (vec![0.0; n], vec![0.0; n], vec![0.0; n]);
    for k in 0..t {
        for i in 0..n {
            let (y, e) = (measured[k * n + i], measured[k * n + i] - predicted[k * n + i]);
            sse[i] += e * e;
            sum[i] += y;
            sum2[i] += y * y;
        }
    }
    let tf = t.max(1) as f64;
    Quality {
        data: data.into(),
        samples: t,
        rms: sse.iter().map(|s| (s / tf).sqrt()).collect(),
        r2: (0..n).map(|i| {
            let sst = sum2[i] - sum[i] * sum[i] / tf;
            if sst > 0.0 { 1.0 - sse[i] / sst } else { f64::NAN }
        }).collect(),
        tau_rms: sum2.iter().map(|s| (s / tf).sqrt()).collect(),
    }
}

/// A fitted model.
#[derive(Debug, Clone)]
pub struct Fitted {
    /// Full parameters that reproduce the fit (`base.to_full` of the base estimate, or
    /// the custom fit's result).
    pub theta_full: Vec<f64>,
    /// The base-parameter fit (with covariance and relative standard deviations).
    pub base_fit: FitReport,
    /// Per-joint weights used (1 for OLS).
    pub weights: Vec<f64>,
}

/// Fits `rows` (full columns) with `est` on the base parameters `base`; with `custom`,
/// the final parameters come from it instead (the base fit is still reported).
pub fn fit_rows(rows: &Rows, base: &BaseParams, est: Estimator, custom: Option<FullFit>, full_names: &[String]) -> Result<Fitted> {
    let (n, p, b) = (rows.n, rows.p, base.base_count());
    if base.full_cols != p {
        return Err(Error::Dimension { what: "base parameters' full columns".into(), expected: p, got: base.full_cols });
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
            let floor = q.rms.iter().cloned().fold(0.0, f64::max) * 1e-6 + 1e-12;
            let w: Vec<f64> = q.rms.iter().map(|r| 1.0 / (r * r).max(floor * floor)).collect();
            (fit_with(&w)?, w)
        }
    };
    let theta_full = match custom {
        None => base.to_full(&nan_to_zero(&base_fit.theta))?,
        Some(f) => {
            let rw: Vec<f64> = (0..m).map(|r| weights[r % n]).collect();
            let mut acc = LsAccumulator::new(p);
            acc.add_rows(&rows.phi, &rows.tau, Some(&rw))?;
            let th = f(&acc, full_names)?;
            if th.len() != p {
                return Err(Error::Dimension { what: "custom fit result (full parameters)".into(), expected: p, got: th.len() });
            }
            th
        }
    };
    Ok(Fitted { theta_full, base_fit, weights })
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
    /// The plain least-squares floor of `../shared/data/README.md` (validation R²).
    pub floor_r2: Vec<f64>,
    /// Validation torques (joint side), for plots.
    pub series: Series,
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
}

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
        }
    }
}

/// Identifies the TX40 (module docs) and validates on the held-out rows.
pub fn identify_tx40(data: &Tx40Data, opts: &Tx40Options, custom: Option<FullFit>) -> Result<RealReport> {
    let robot = &data.robot;
    let n = robot.dof();
    let trans = tx40_transmission();
    let reg = MotorRegressor::new(robot, &trans, opts.joint_drive)?;
    let t_raw = data.len();
    for (what, r) in [("fit_rows", &opts.fit_rows), ("val_rows", &opts.val_rows)] {
        if r.end > t_raw || r.start >= r.end {
            return Err(Error::Estimation { msg: format!("TX40: {what} {r:?} outside the {t_raw} samples") });
        }
    }
    let fs = 1.0 / data.dt;
    // 1. positions: zero-phase low-pass, central differences at 5 kHz
    let lp = Butterworth::zero_phase(opts.order, opts.cutoff_hz, fs)?;
    let qf = lp.filtfilt_columns(&data.q_m, n)?;
    let qd = central_diff(&qf, n, data.dt)?;
    let qdd = second_diff(&qf, n, data.dt)?;
    // 2. states sub-sampled (band-limited well below the new Nyquist), torque anti-aliased
    let d1 = opts.decimate_states.max(1);
    let keep: Vec<usize> = (0..t_raw).step_by(d1).collect();
    let (q1, qd1, qdd1) = (take_rows(&qf, n, &keep), take_rows(&qd, n, &keep), take_rows(&qdd, n, &keep));
    let tau1 = if d1 > 1 { Decimator::new(d1, fs)?.apply(&data.tau_m, n)? } else { data.tau_m.clone() };
    // 3. regressor at the intermediate rate, then the same decimating filter on both
    let fs1 = fs / d1 as f64;
    let phi1 = reg.rows(&q1, &qd1, &qdd1)?;
    let p = reg.num_params();
    let d2 = opts.decimate_parallel.max(1);
    let par = if d2 > 1 { Decimator::new(d2, fs1)? } else { Decimator::with_filter(1, Butterworth::default_for(fs1)?)? };
    let phi = par.apply(&phi1, n * p)?;
    let tau = par.apply(&tau1, n)?;
    let t: Vec<f64> = keep.iter().step_by(d2).map(|&k| k as f64 * data.dt).collect();
    let all = Rows { n, p, t, phi, tau };
    let step = d1 * d2;
    let to_rows = |r: &std::ops::Range<usize>| r.start.div_ceil(step)..r.end.div_ceil(step).min(all.len());
    let (fit_rows, val_rows) = (all.slice(to_rows(&opts.fit_rows)), all.slice(to_rows(&opts.val_rows)));

    let base = reg.base_params(opts.base_samples, opts.seed)?;
    let names = reg.param_names();
    let fitted = if opts.fit_joint_side {
        fit_rows_checked(&joint_side_rows(&fit_rows, &trans)?, &base, opts.estimator, custom, &names)?
    } else {
        fit_rows_checked(&fit_rows, &base, opts.estimator, custom, &names)?
    };
    let nominal = reg.params(&vec![Default::default(); n])?;
    let nom_base = base.project(&nominal)?;

    let joint_side = |r: &Rows, theta: &[f64]| -> Result<(Vec<f64>, Vec<f64>)> {
        Ok((trans.joint_torques(&r.tau)?, trans.joint_torques(&r.predict(theta))?))
    };
    let (fm, fp) = joint_side(&fit_rows, &fitted.theta_full)?;
    let (vm, vp) = joint_side(&val_rows, &fitted.theta_full)?;
    let validation_motor = Some(quality("validation, motor torques", &val_rows.tau, &val_rows.predict(&fitted.theta_full), n));
    let rate = fs / step as f64;
    Ok(RealReport {
        dataset: "Stäubli TX40 (FIGAROH example data)".into(),
        robot: robot.name.clone(),
        joints: robot.joint_names.clone(),
        method: custom.map_or(fitted.base_fit.method.replace("LS", opts.estimator.name()), |_| "custom full-parameter fit".into()),
        split: format!(
            "fit on raw rows {}..{} ({:.2}-{:.2} s), validate on raw rows {}..{} ({:.2}-{:.2} s), FIGAROH's split",
            opts.fit_rows.start, opts.fit_rows.end, opts.fit_rows.start as f64 * data.dt, opts.fit_rows.end as f64 * data.dt,
            opts.val_rows.start, opts.val_rows.end, opts.val_rows.start as f64 * data.dt, opts.val_rows.end as f64 * data.dt
        ),
        preprocessing: format!(
            "motor positions: zero-phase Butterworth order {} at {} Hz (-3 dB), central differences at {} Hz; states sub-sampled x{d1} and motor torques decimated x{d1} (zero-phase anti-alias) to {} Hz; motor-side regressor (K^-T Y{} + motor fc, fv, ia, tau0) there; torque and regressor through the same decimator x{d2} (zero-phase -3 dB at {:.0} Hz) to {} Hz",
            opts.order, opts.cutoff_hz, fs, fs1, if opts.joint_drive { " with joint-side drive columns" } else { "" }, par.filter.cutoff_hz, rate
        ),
        sample_rate_hz: rate,
        rows: fitted.base_fit.rows,
        rank: fitted.base_fit.rank,
        condition_number: fitted.base_fit.condition_number,
        weights: fitted.weights.clone(),
        base: base_values(&fitted.base_fit, &nom_base),
        unexcited: fitted.base_fit.unexcited.clone(),
        fit: quality("fit, joint torques K^T tau_m", &fm, &fp, n),
        validation: quality("validation, joint torques K^T tau_m", &vm, &vp, n),
        validation_motor,
        floor_r2: TX40_FLOOR_R2.to_vec(),
        series: Series { t: val_rows.t.clone(), measured: vm, predicted: vp },
        notes: vec![],
    })
}

/// The rows mapped to the joint side: each sample's `n x p` block and torques times `Kᵀ`.
pub fn joint_side_rows(rows: &Rows, trans: &crate::transmission::Transmission) -> Result<Rows> {
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

fn fit_rows_checked(rows: &Rows, base: &BaseParams, est: Estimator, custom: Option<FullFit>, names: &[String]) -> Result<Fitted> {
    if rows.tau.len() < 2 * base.base_count() {
        return Err(Error::Estimation { msg: format!("{} rows for {} base parameters", rows.tau.len(), base.base_count()) });
    }
    fit_rows(rows, base, est, custom, names)
}

fn base_values(fit: &FitReport, nominal: &[f64]) -> Vec<BaseValue> {
    (0..fit.theta.len())
        .map(|i| BaseValue { name: fit.names[i].clone(), value: fit.theta[i], std: fit.std[i], rel_std_pct: fit.rel_std_pct[i], nominal: nominal[i] })
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
}

impl Default for LwrOptions {
    fn default() -> Self {
        LwrOptions { step: 2, estimator: Estimator::Wls, matched_filter_hz: Some(2.0), base_samples: 200, seed: 1 }
    }
}

/// The joint-torque rows of one LWR run (every `step`-th sample, full `14 n` columns).
pub fn lwr_rows(robot: &Robot, run: &LwrRun, step: usize, matched_filter_hz: Option<f64>) -> Result<Rows> {
    let n = robot.dof();
    let p = robot.num_params();
    let t_all = run.len();
    let (phi_all, tau_all) = match matched_filter_hz {
        None => {
            let mut phi = vec![0.0; t_all * n * p];
            crate::batch::regressor_batch(robot, &run.q, &run.qd, &run.qdd, &mut phi, false)?;
            (phi, run.tau.clone())
        }
        Some(fc) => {
            let dt = (run.t[t_all - 1] - run.t[0]) / (t_all - 1) as f64;
            let (qd, qdd) = (central_diff(&run.q, n, dt)?, second_diff(&run.q, n, dt)?);
            let mut phi = vec![0.0; t_all * n * p];
            crate::batch::regressor_batch(robot, &run.q, &qd, &qdd, &mut phi, false)?;
            let f = Butterworth::lowpass(6, fc, 1.0 / dt)?;
            (f.filtfilt_columns(&phi, n * p)?, run.tau.clone())
        }
    };
    let keep: Vec<usize> = (0..t_all).step_by(step.max(1)).collect();
    Ok(Rows { n, p, t: keep.iter().map(|&k| run.t[k]).collect(), phi: take_rows(&phi_all, n * p, &keep), tau: take_rows(&tau_all, n, &keep) })
}

/// Identifies the LWR4+ on `fit` runs and validates on `val` (FloBaRoID's split: fit on
/// runs 1 and 3, validate on run 2).
pub fn identify_lwr(robot: &Robot, fit: &[&LwrRun], val: &LwrRun, opts: &LwrOptions, custom: Option<FullFit>) -> Result<RealReport> {
    let n = robot.dof();
    let mut fit_rows = Rows { n, p: robot.num_params(), ..Default::default() };
    for r in fit {
        fit_rows.append(&lwr_rows(robot, r, opts.step, opts.matched_filter_hz)?);
    }
    let val_rows = lwr_rows(robot, val, opts.step, opts.matched_filter_hz)?;
    let base = robot_base_params(robot, opts.base_samples, opts.seed)?;
    let names = robot.param_names();
    let fitted = fit_rows_checked(&fit_rows, &base, opts.estimator, custom, &names)?;
    let nom_base = base.project(&robot.params())?;
    let vp = val_rows.predict(&fitted.theta_full);
    let name = |r: &LwrRun| r.file.file_name().map(|s| s.to_string_lossy().into_owned()).unwrap_or_default();
    let dt = crate::signal::median_dt(&val.t).unwrap_or(f64::NAN);
    Ok(RealReport {
        dataset: "KUKA LWR4+ (FloBaRoID data)".into(),
        robot: robot.name.clone(),
        joints: robot.joint_names.clone(),
        method: custom.map_or(fitted.base_fit.method.replace("LS", opts.estimator.name()), |_| "custom full-parameter fit".into()),
        split: format!("fit on {}, validate on {}", fit.iter().map(|r| name(r)).collect::<Vec<_>>().join(" + "), name(val)),
        preprocessing: match opts.matched_filter_hz {
            None => format!("positions, velocities, accelerations and torques as filtered by the data's authors (2-3 Hz zero-phase); every {}th sample", opts.step),
            Some(fc) => format!("positions as filtered by the authors (3 Hz); velocities and accelerations by central differences (uniform step: the mean stamp interval); every regressor column through the authors' torque filter (Butterworth order 6, {fc} Hz, forward-backward); torques as given; every {}th sample", opts.step),
        },
        sample_rate_hz: 1.0 / (dt * opts.step as f64),
        rows: fitted.base_fit.rows,
        rank: fitted.base_fit.rank,
        condition_number: fitted.base_fit.condition_number,
        weights: fitted.weights.clone(),
        base: base_values(&fitted.base_fit, &nom_base),
        unexcited: fitted.base_fit.unexcited.clone(),
        fit: quality("fit", &fit_rows.tau, &fit_rows.predict(&fitted.theta_full), n),
        validation: quality("validation", &val_rows.tau, &vp, n),
        validation_motor: None,
        floor_r2: LWR_FLOOR_R2.to_vec(),
        series: Series { t: val_rows.t.clone(), measured: val_rows.tau.clone(), predicted: vp },
        notes: vec![],
    })
}

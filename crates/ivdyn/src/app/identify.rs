//! End-to-end pipelines behind the `ivdyn` command line (and, later, the Python
//! bindings): [`identify`], [`payload`] and [`simulate`]. Each takes a [`Robot`] and
//! in-memory logs and returns a serialisable report; the command line only adds file
//! handling, progress bars and printing.
//!
//! Choices made here (documented in `docs/cli.md`):
//!
//! * conditioning: [`prep::condition_segments`] (log hygiene, segments at gaps, uneven
//!   stamps resampled, the log's velocity where it agrees with the differentiated
//!   positions, else `q` smoothed and differentiated: zero-phase Butterworth + central
//!   differences);
//! * the Coulomb term's shape per joint (sign, smooth, direction-dependent), chosen by
//!   cross-validation on the fit rows ([`super::coulomb`], `--coulomb auto`);
//! * **parallel filtering**: the measured torque and every column of the stacked base
//!   regressor go through the same zero-phase low-pass ([`dsp::Decimator`], default
//!   factor 1: the default differentiation filter), then are decimated by the same factor;
//! * `iv` instrument: the simulated *identified* model, iterated ([`iterate_instrument`]):
//!   from the WLS estimate, the regressor on a closed-loop simulation of the current model
//!   tracking the measured positions (the stand-in control law of `idim-iv`), or with a
//!   command topic (`u`) at `(q, qd, FD_model(q, qd, u))` (forward dynamics driven by the
//!   command, which carries no torque-measurement noise). The DWH test of `ols`/`wls` uses
//!   the same construction with the nominal model, in one pass (the streaming path does the
//!   same). The paper's per-joint LTI model
//!   eq (35) was tried first and is a poor instrument on a UR5 (the command is dominated by
//!   gravity, which a per-joint LTI model ignores: validation RMS 0.17 N m against 0.016 for
//!   WLS). The
//!   pointwise "forward dynamics driven by the measured torque" instrument was also tried
//!   and rejected: it shares the torque noise with the output (biased, DWH always rejects);
//! * `idim-iv`: [`ident::idim_iv`] with a stand-in control law, a stiff PD on the measured
//!   positions scaled by the nominal mass matrix plus the nominal inverse dynamics of the
//!   measured motion as feed-forward (10 Hz bandwidth, damping 0.7);
//! * [`simulate`]: inverse dynamics (`rnea`) of the true model along the trajectory (exact
//!   torques, no integration), then noise and quantisation on the recorded signals.

use serde::Serialize;

use super::prepare::{Prepared, prepare, rows_of};
use crate::Robot;
use crate::dsp;
use crate::error::{Error, Result};
use crate::ident::coulomb::CoulombChoice;
use crate::ident::instrument::Tracker;
use crate::ident::joint_acc::{JointAccs, hac_lags};
use crate::ident::wls::per_joint_weights;
use crate::ident::{self, BaseParams, FitReport, fit_iv, fit_ls};
use crate::log::JointLog;
use crate::prep::{self, ConditionOptions, ConditionSummary};
use crate::progress::{ProgressSink, Stage};
use crate::report::{BaseValue, Dwh, ParamsFile, Quality};
use crate::robot::physical;

// ---------------------------------------------------------------------------------------
// Options and reports
// ---------------------------------------------------------------------------------------

pub use super::identify_options::{CoulombMode, IdentifyOptions, MAX_IDIM_ITER, Method};

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
    /// The Coulomb-friction shape chosen per joint and the held-out RMS that chose it
    /// (empty when the shapes were not chosen: `--coulomb sign`, a streamed log, too few
    /// samples; a note says why).
    pub coulomb: Vec<CoulombChoice>,
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
    pub physical: physical::PhysicalCheck,
    /// The fit with physical consistency enforced (`IdentifyOptions::consistent`).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub consistent: Option<ident::consistent::ConsistentReport>,
    /// What conditioning did to the log: window, repeated samples, duplicated stamps,
    /// resampling, and the velocity's source per joint.
    pub conditioning: ConditionSummary,
    /// The log was streamed block by block (bounded memory) rather than read whole.
    pub streamed: bool,
    /// The underlying fit.
    #[serde(skip)]
    pub fit_report: Option<FitReport>,
}

// ---------------------------------------------------------------------------------------
// Preparation: conditioning, regressor stacking, parallel filtering
// ---------------------------------------------------------------------------------------

// ---------------------------------------------------------------------------------------
// identify
// ---------------------------------------------------------------------------------------

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
pub(crate) fn split_ranges(
    t: usize,
    opts: &IdentifyOptions,
) -> (std::ops::Range<usize>, Option<std::ops::Range<usize>>) {
    let edge = (t / 100).min(20);
    if opts.validation_log.is_some() || opts.validation_fraction <= 0.0 {
        (edge..t - edge, None)
    } else {
        let cut = ((1.0 - opts.validation_fraction) * t as f64) as usize;
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
    /// What conditioning did to the (fit) log.
    pub conditioning: ConditionSummary,
}

/// Identifies the base parameters of `robot` from `log` (see the module docs). The whole
/// log is held in memory; [`crate::app::stream::identify_mcap`] streams a log file instead.
pub fn identify(robot: &Robot, log: &JointLog, opts: &IdentifyOptions) -> Result<IdentifyReport> {
    identify_logs(robot, &[log], opts)
}

/// [`identify`] on several logs of the same arm at once: their segments are conditioned
/// and filtered apart and fitted together; the held-out tail is the last log's.
pub fn identify_logs(robot: &Robot, logs: &[&JointLog], opts: &IdentifyOptions) -> Result<IdentifyReport> {
    opts.check()?;
    let robot = &starting_shapes(robot, opts.coulomb)?;
    let n = robot.dof();
    let mut notes = vec![];
    let base = {
        let _st = Stage::begin(&opts.progress, "base parameters", 0);
        identify_base(robot, opts)?
    };
    let b = base.base_count();
    // the nominal-model instrument serves the DWH test of OLS/WLS; `iv` builds its own
    let want_iv = matches!(opts.method, Method::Ols | Method::Wls);
    let cols = &base.independent;
    let mut prep = prepare(robot, cols, logs, opts, "log")?;
    let t = prep.len();
    let (fit_range, val_range) = split_ranges(t, opts);
    if opts.coulomb == CoulombMode::Auto {
        // a reversed or mis-scaled effort spoils every joint's Coulomb-shape choice, and the
        // check on the shaped rows after it: checked first on the rows with sign(qd)
        let mut acc = JointAccs::new(n, b, false);
        accumulate(&mut acc, &prep, fit_range.clone(), false)?;
        super::effort_check::check(&acc, &base.project(&robot.params())?, &robot.joint_names)?;
    }
    let (shaped, coulomb) = coulomb_shapes(robot, cols, &mut prep, fit_range.clone(), opts, &mut notes)?;
    let robot = &shaped;
    if want_iv {
        prep.add_instrument(robot, cols, false)?;
    }
    notes.extend(prep.notes.iter().cloned());
    let lags = hac_lags(prep.dt, prep.cutoff_hz);
    let fit = if opts.method == Method::Iv {
        let _st = Stage::begin(&opts.progress, "IV: simulated identified model as the instrument", 0);
        iterate_instrument(robot, &base, &mut prep, fit_range.clone(), opts, &mut notes)?
    } else {
        let mut fit = JointAccs::new(n, b, prep.z.is_some()).with_lags(lags);
        accumulate(&mut fit, &prep, fit_range.clone(), true)?;
        fit
    };
    if fit.samples() * n < 2 * b {
        return Err(Error::TooFewSamples { samples: fit.samples(), joints: n, params: b });
    }
    let validation = match (&opts.validation_log, val_range) {
        (Some(vlog), _) => {
            let vp = prepare(robot, cols, &[vlog], opts, "validation log")?;
            let t2 = vp.len();
            let e2 = (t2 / 100).min(20);
            let mut v = JointAccs::new(n, b, false);
            accumulate(&mut v, &vp, e2..t2 - e2, false)?;
            Some(("validation log".to_string(), v))
        }
        (None, Some(r)) if r.len() > 1 => {
            let mut v = JointAccs::new(n, b, false);
            accumulate(&mut v, &prep, r, false)?;
            let of = if logs.len() > 1 { "the logs" } else { "the log" };
            Some((format!("tail {:.0}% of {of}", 100.0 * opts.validation_fraction), v))
        }
        _ => None,
    };
    if opts.method == Method::IdimIv && prep.bounds.len() > 2 {
        return Err(Error::option(
            "method",
            format!(
                "idim-iv simulates the arm over one continuous log; this one has {} segments (gaps, or several logs): give one log, or a window without gaps",
                prep.bounds.len() - 1
            ),
        ));
    }
    let idim = if opts.method == Method::IdimIv {
        Some(idim_fit(robot, &base, &prep, fit_range.clone(), opts, &mut notes)?)
    } else {
        None
    };
    if logs.iter().any(|l| l.truncated) {
        notes.push("the log was truncated; only the samples before the damage were used".into());
    }
    let data = FitData {
        fit,
        validation,
        instrument: prep.instrument.clone(),
        dt: prep.dt,
        factor: prep.factor,
        cutoff_hz: prep.cutoff_hz,
        idim,
        notes,
        conditioning: prep.conditioning,
    };
    let mut r = finish_identify(robot, &base, opts, data)?;
    r.coulomb = coulomb;
    Ok(r)
}

/// `--method idim-iv` on the fit rows of one continuous log: [`ident::idim_iv`] with the
/// stand-in control law, a stiff PD on the measured positions scaled by the nominal mass
/// matrix plus the nominal inverse dynamics as feed-forward.
fn idim_fit(
    robot: &Robot,
    base: &BaseParams,
    prep: &Prepared,
    r: std::ops::Range<usize>,
    opts: &IdentifyOptions,
    notes: &mut Vec<String>,
) -> Result<FitReport> {
    let n = robot.dof();
    let tau_fit = rows_of(&prep.tau, n, r.clone());
    let (q, qd, qdd) =
        (rows_of(&prep.q, n, r.clone()), rows_of(&prep.qd, n, r.clone()), rows_of(&prep.qdd, n, r.clone()));
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
    let res = ident::idim_iv(robot, base, &exp, control, opts.idim_max_iter, opts.idim_tol)?;
    if !res.converged {
        notes.push(format!("IDIM-IV did not converge in {} iterations", opts.idim_max_iter));
    }
    notes.push("IDIM-IV control law: stand-in stiff PD on the measured positions (M-scaled, 10 Hz, damping 0.7) + nominal inverse dynamics feed-forward".into());
    Ok(res.fit)
}

/// The model with each joint's Coulomb shape: chosen on the fit rows ([`super::coulomb`])
/// with [`CoulombMode::Auto`], else the paper's sign; a note says which joints changed
/// or why nothing was chosen.
fn coulomb_shapes(
    robot: &Robot,
    cols: &[usize],
    prep: &mut Prepared,
    fit: std::ops::Range<usize>,
    opts: &IdentifyOptions,
    notes: &mut Vec<String>,
) -> Result<(Robot, Vec<CoulombChoice>)> {
    if opts.coulomb != CoulombMode::Auto {
        return Ok((robot.clone(), vec![]));
    }
    let _st = Stage::begin(&opts.progress, "Coulomb friction shapes", 0);
    match super::coulomb::choose(robot, cols, prep, fit)? {
        Ok((shaped, choices)) => {
            let changed: Vec<String> = choices
                .iter()
                .filter(|c| c.shape != "sign")
                .map(|c| {
                    let gain = 100.0 * (1.0 - c.heldout_rms / c.heldout_rms_sign);
                    format!(
                        "{} {} (v_scale {:.3}, asym {:.2}; held-out RMS -{gain:.1} %)",
                        c.joint, c.shape, c.v_scale, c.asym
                    )
                })
                .collect();
            if !changed.is_empty() {
                notes.push(format!(
                    "Coulomb friction shape chosen on held-out data: {}; sign elsewhere",
                    changed.join(", ")
                ));
            }
            Ok((shaped, choices))
        }
        Err(why) => {
            notes.push(format!("Coulomb friction kept as sign(qd): {why}"));
            Ok((robot.clone(), vec![]))
        }
    }
}

/// The model a fit starts from: with [`CoulombMode::Model`] `robot` as it is, else with the
/// paper's `sign(qd)` on every joint (the shapes a parameter file may have set are chosen
/// again, or reset by [`CoulombMode::Sign`]).
pub(crate) fn starting_shapes(robot: &Robot, mode: CoulombMode) -> Result<Robot> {
    let mut r = robot.clone();
    if mode != CoulombMode::Model {
        r.set_coulomb_shapes(&vec![ivdyn_core::CoulombShape::SIGN; robot.dof()])?;
    }
    Ok(r)
}

/// Adds the rows `r` of `p` (inside its segments, [`Prepared::pieces`]) to `acc`, with the
/// instrument rows when `with_z`.
pub(crate) fn accumulate(acc: &mut JointAccs, p: &Prepared, r: std::ops::Range<usize>, with_z: bool) -> Result<()> {
    let w = p.n * (p.phi.len() / p.tau.len().max(1));
    for piece in p.pieces(r) {
        acc.gap();
        let z = if with_z { p.z.as_ref().map(|z| rows_of(z, w, piece.clone())) } else { None };
        acc.add(rows_of(&p.phi, w, piece.clone()), z, rows_of(&p.tau, p.n, piece))?;
    }
    Ok(())
}

/// Two-step WLS weights (`1 / rms²` of the OLS residual per joint) and the WLS estimate
/// (unexcited parameters at their nominal base values `nom_base`) of the statistics `acc`.
fn wls_of(acc: &JointAccs, base: &BaseParams, nom_base: &[f64]) -> Result<(Vec<f64>, Vec<f64>)> {
    let ones = vec![1.0; acc.joints()];
    let ols = fit_ls(&acc.ls(&ones)?, &base.names)?;
    let weights = per_joint_weights(&acc.quality(String::new(), &fill_nominal(&ols.theta, nom_base)).rms);
    let wls = fit_ls(&acc.ls(&weights)?, &base.names)?;
    Ok((weights, fill_nominal(&wls.theta, nom_base)))
}

/// `--method iv`'s instrument, the simulated identified model (IDIM-IV's instrument,
/// Gautier et al. 2013; the paper's eq 32 with `Z` from noise-free simulated states): start
/// from the WLS estimate, simulate that model tracking the measured motion (per segment,
/// [`Prepared::instrument_rows`]), rebuild the instrument rows, fit IV with the WLS
/// weights, and repeat with the IV estimate until its relative change is below
/// `opts.idim_tol` (at most `opts.idim_max_iter` rounds). A model that cannot be simulated
/// (e.g. a mass matrix that is not positive definite) is stepped toward the nominal one.
/// Returns the fit statistics with the last instrument (their IV fit is the estimate).
fn iterate_instrument(
    robot: &Robot,
    base: &BaseParams,
    prep: &mut Prepared,
    fit_range: std::ops::Range<usize>,
    opts: &IdentifyOptions,
    notes: &mut Vec<String>,
) -> Result<JointAccs> {
    let (n, b) = (robot.dof(), base.base_count());
    let nominal = robot.params();
    let nom_base = base.project(&nominal)?;
    let mut ls_acc = JointAccs::new(n, b, false);
    accumulate(&mut ls_acc, prep, fit_range.clone(), false)?;
    if ls_acc.samples() * n < 2 * b {
        return Err(Error::TooFewSamples { samples: ls_acc.samples(), joints: n, params: b });
    }
    let (weights, mut theta) = wls_of(&ls_acc, base, &nom_base)?;
    let mut sim = robot.clone();
    let lags = hac_lags(prep.dt, prep.cutoff_hz);
    let mut rounds = 0;
    let mut last_alpha;
    let (fit, converged) = loop {
        let mut built = None;
        for alpha in [1.0, 0.5, 0.25, 0.125, 0.0] {
            sim.set_params(&base.apply(&theta, &nominal, alpha)?)?;
            match prep.instrument_rows(robot, &sim, &base.independent) {
                Ok(z) => {
                    built = Some(Ok((alpha, z)));
                    break;
                }
                Err(e) => built = Some(Err(e)),
            }
        }
        let (alpha, z) = built.expect("tried")?;
        last_alpha = alpha;
        prep.z = Some(z);
        let mut fit = JointAccs::new(n, b, true).with_lags(lags);
        accumulate(&mut fit, prep, fit_range.clone(), true)?;
        let iv = fit.iv(&weights).expect("instrument sums").and_then(|a| fit_iv(&a, &base.names));
        let iv = iv.map_err(|e| Error::SingularInstrument { msg: e.to_string() })?;
        let next = fill_nominal(&iv.theta, &nom_base);
        let change = next.iter().zip(&theta).map(|(a, b)| (a - b).powi(2)).sum::<f64>().sqrt();
        let size = theta.iter().map(|a| a * a).sum::<f64>().sqrt().max(f64::MIN_POSITIVE);
        theta = next;
        rounds += 1;
        let converged = change / size < opts.idim_tol;
        if converged || rounds >= opts.idim_max_iter.max(1) {
            prep.instrument = Some(format!(
                "regressor on a closed-loop simulation of the identified model tracking the measured motion (IDIM-IV's instrument, iterated: {rounds} rounds, {}; stand-in M-scaled PD, 10 Hz, damping 0.7, plus inverse-dynamics feed-forward{})",
                if converged { "converged" } else { "not converged" },
                if prep.segments.iter().all(|c| c.u.is_some()) {
                    "; with the command u: the identified model's forward dynamics driven by u"
                } else {
                    ""
                }
            ));
            break (fit, converged);
        }
    };
    if !converged {
        notes.push(format!(
            "IV: the simulated-model instrument did not converge in {rounds} rounds (relative change above {})",
            opts.idim_tol
        ));
    }
    if last_alpha < 1.0 {
        notes.push(format!(
            "IV: the identified model could not be simulated (not physical: a mass matrix that is not positive definite); the instrument's model is nominal + {last_alpha} x (estimate - nominal){}",
            if last_alpha == 0.0 { ", i.e. the nominal model's instrument" } else { "" }
        ));
    }
    Ok(fit)
}

/// The fits (OLS, two-step WLS, IV), the DWH test, fit quality and validation, from the
/// per-joint statistics of a prepared log: the part shared by the in-memory and the
/// streaming `identify`.
pub(crate) fn finish_identify(
    robot: &Robot,
    base: &BaseParams,
    opts: &IdentifyOptions,
    mut d: FitData,
) -> Result<IdentifyReport> {
    let n = robot.dof();
    let b = base.base_count();
    let mut notes = std::mem::take(&mut d.notes);
    notes.extend(conditioning_notes(&d.conditioning));
    if d.fit.samples() * n < 2 * b {
        return Err(Error::TooFewSamples { samples: d.fit.samples(), joints: n, params: b });
    }
    let nominal = robot.params();
    let nom_base = base.project(&nominal)?;
    super::effort_check::check(&d.fit, &nom_base, &robot.joint_names)?;
    let Fits { fit, weights, iv } = fits(n, &d, base, opts, &nom_base)?;
    let theta = fill_nominal(&fit.theta, &nom_base);
    let fit_q = d.fit.quality("fit".into(), &theta);
    let validation = d.validation.as_ref().map(|(label, v)| v.quality(label.clone(), &theta)).filter(|q| q.samples > 1);
    let dwh = dwh_report(opts.method, &fit, &iv, &mut notes);
    // full parameters: nominal + base correction
    let full = base.apply(&theta, &nominal, 1.0)?;
    let physical = physical::check_robot_params(robot, &full);
    let consistent = if opts.consistent {
        Some(consistent_report(robot, base, &d, &weights, &full, &nominal, &opts.progress)?)
    } else {
        None
    };
    Ok(IdentifyReport {
        method: opts.method.name().into(),
        instrument: instrument_text(opts.method, &d.instrument),
        joints: robot.joint_names.clone(),
        drive_terms: opts.drive.names(),
        coulomb: vec![],
        sample_rate_hz: 1.0 / d.dt,
        decimation: d.factor,
        filter_cutoff_hz: d.cutoff_hz,
        rows: fit.rows,
        rank: fit.rank,
        condition_number: fit.condition_number,
        sigma2: fit.sigma2,
        weights,
        base: base_values(base, &fit, &nom_base),
        unexcited: fit.unexcited.clone(),
        fit: fit_q,
        validation,
        dwh,
        params: params_file(robot, full),
        notes,
        physical,
        consistent,
        conditioning: d.conditioning,
        streamed: false,
        fit_report: Some(fit),
    })
}

/// The conditioning worth a remark: the window, repeated samples, resampling, and where
/// the velocity came from when the log had one.
pub(crate) fn conditioning_notes(c: &ConditionSummary) -> Vec<String> {
    let mut notes = vec![];
    if let Some((a, b)) = c.hygiene.window {
        notes.push(format!(
            "window {a} s to {b} s of the log: {} samples outside it left out",
            c.hygiene.outside_window
        ));
    }
    if c.hygiene.excluded > 0 {
        notes.push(format!("{} samples in the excluded spans left out", c.hygiene.excluded));
    }
    for k in &c.hygiene.clipped {
        notes.push(format!(
            "{}: the torque sits at its extreme value {} N m in {} samples: clipped by the drive or the sensor? (those samples are fitted as measured; --exclude them if so)",
            k.joint, k.value, k.samples
        ));
    }
    if c.hygiene.standstill_s > 0.0 {
        notes.push(format!(
            "{:.1} s of standstill (every joint below {:.0} % of its RMS velocity for at least {} s): friction and inertia are not excited there, and a Coulomb term cannot say which way the joint is held",
            c.hygiene.standstill_s,
            100.0 * prep::hygiene::STANDSTILL_SHARE,
            prep::hygiene::STANDSTILL_MIN_S
        ));
    }
    if c.hygiene.repeated > 0 {
        notes.push(format!(
            "{} samples repeated the previous position under a new stamp (a state published twice) and were dropped",
            c.hygiene.repeated
        ));
    }
    if c.resampled {
        notes.push(format!("uneven stamps: resampled to a uniform {:.3} ms grid", 1e3 * c.dt));
    }
    if c.velocity.iter().any(|v| v.gain.is_some() || v.source == "log") {
        let from_log: Vec<&str> = c.velocity.iter().filter(|v| v.source == "log").map(|v| v.joint.as_str()).collect();
        notes.push(format!("velocity from the log on {} of {} joints", from_log.len(), c.velocity.len()));
        for v in c.velocity.iter().filter(|v| v.source != "log") {
            notes.push(format!("{}: velocity differentiated from positions: {}", v.joint, v.why));
        }
    }
    notes
}

/// `theta` with its non-finite entries (unexcited base parameters) replaced by the nominal
/// base values `nom_base`.
fn fill_nominal(theta: &[f64], nom_base: &[f64]) -> Vec<f64> {
    theta.iter().zip(nom_base).map(|(t, nb)| if t.is_finite() { *t } else { *nb }).collect()
}

/// The fit of [`finish_identify`]'s method, the per-joint weights it used and the IV fit
/// (for the DWH test; `None` when no instrument was built or not asked).
struct Fits {
    fit: FitReport,
    weights: Vec<f64>,
    iv: Option<std::result::Result<FitReport, Error>>,
}

/// Runs the fits of `opts.method` (`n` joints): OLS; two-step WLS (weights `1 / rms` of the OLS
/// residual per joint) with the IV fit alongside; IV (an error when it fails); or the
/// IDIM-IV fit computed earlier.
fn fits(n: usize, d: &FitData, base: &BaseParams, opts: &IdentifyOptions, nom_base: &[f64]) -> Result<Fits> {
    let st = Stage::begin(&opts.progress, "fitting", 3);
    let ones = vec![1.0; n];
    let ols = fit_ls(&d.fit.ls(&ones)?, &base.names)?;
    st.advance(1);
    if opts.method == Method::Ols {
        return Ok(Fits { fit: ols, weights: ones, iv: None });
    }
    if opts.method == Method::IdimIv {
        let fit = d
            .idim
            .clone()
            .ok_or_else(|| Error::internal("IDIM-IV: the method was chosen but no IDIM-IV fit was made"))?;
        return Ok(Fits { fit, weights: ones, iv: None });
    }
    let weights = per_joint_weights(&d.fit.quality(String::new(), &fill_nominal(&ols.theta, nom_base)).rms);
    let wls = fit_ls(&d.fit.ls(&weights)?, &base.names)?;
    st.advance(1);
    let wls_theta = fill_nominal(&wls.theta, nom_base);
    let iv = d.fit.iv(&weights).map(|acc| acc.and_then(|a| iv_with_robust_dwh(&d.fit, &a, &weights, &wls_theta, base)));
    st.advance(1);
    if opts.method == Method::Wls {
        return Ok(Fits { fit: wls, weights, iv });
    }
    match iv {
        Some(Ok(f)) => Ok(Fits { fit: f.clone(), weights, iv: Some(Ok(f)) }),
        Some(Err(e)) => Err(Error::SingularInstrument { msg: e.to_string() }),
        None => Err(Error::internal("IV fit: the method was chosen but no instrument was built")),
    }
}

/// The IV fit of the statistics `acc` (weights `weights`) with its DWH test computed by
/// [`ident::dwh_sandwich`]: the residual's variance per joint from the WLS estimate
/// `theta`, `σ_i² = rss_i / (T - b / n)`, times its long-run factor `c_i`
/// ([`JointAccs::long_run_factor`]), so that `Var(θ_IV - θ_LS)` holds for the parallel-
/// filtered (autocorrelated) residual and any weights. Why: with the iid shortcut
/// `V_IV - V_LS` the statistic was inflated by `c ≈ 1.2` at the automatic decimation and
/// `≈ 10` without decimation, and the test over-rejected on logs where LS is unbiased.
fn iv_with_robust_dwh(
    stats: &JointAccs,
    acc: &ident::IvAccumulator,
    weights: &[f64],
    theta: &[f64],
    base: &BaseParams,
) -> Result<FitReport> {
    let mut fit = fit_iv(acc, &base.names)?;
    if fit.dwh.is_some_and(|t| t.dof == 0) {
        return Ok(fit);
    }
    let n = weights.len();
    let t = stats.samples() as f64;
    let dof_t = (t - base.base_count() as f64 / n as f64).max(1.0);
    let lambda: Vec<f64> = (0..n)
        .map(|i| weights[i] * weights[i] * stats.rss(i, theta) / dof_t * stats.long_run_factor(i, theta))
        .collect();
    if let Some(mid) = stats.iv(&lambda) {
        fit.dwh = Some(ident::dwh_sandwich(acc, &mid?)?);
    }
    Ok(fit)
}

/// The LS-vs-IV (Durbin-Wu-Hausman) test as reported, from the IDIM-IV fit or the IV fit
/// (a note when that failed).
fn dwh_report(
    method: Method,
    fit: &FitReport,
    iv: &Option<std::result::Result<FitReport, Error>>,
    notes: &mut Vec<String>,
) -> Option<Dwh> {
    let dwh_src = match method {
        Method::IdimIv => fit.dwh,
        _ => match iv {
            Some(Ok(f)) => f.dwh,
            Some(Err(e)) => {
                notes.push(format!("no LS-vs-IV test: the IV fit failed ({e})"));
                None
            }
            None => None,
        },
    };
    dwh_src.map(|d| {
        let worst = d.worst.map(|(i, z)| (fit.names.get(i).cloned().unwrap_or_default(), z));
        Dwh {
            statistic: d.statistic,
            dof: d.dof,
            p_value: d.p_value,
            ls_biased: d.ls_biased,
            largest_difference: worst.as_ref().map(|(_, z)| *z),
            largest_difference_param: worst.as_ref().map(|(p, _)| p.clone()),
            verdict: dwh_verdict(method, &d, worst),
        }
    })
}

/// The DWH verdict in words: agreement keeps LS; a rejection says by how much the
/// estimates differ (largest `|θ_IV - θ_LS|` in standard deviations of that difference)
/// and what to do.
fn dwh_verdict(method: Method, d: &ident::DwhTest, worst: Option<(String, f64)>) -> String {
    if d.dof == 0 {
        return "not tested: the data fit exactly".into();
    }
    let by = worst.map(|(p, z)| format!("; largest difference {z:.1} std ({p})")).unwrap_or_default();
    if !d.ls_biased {
        let kept = if method == Method::Iv {
            "the IV estimate is not needed (WLS gives the same within its uncertainty)"
        } else {
            "LS is kept"
        };
        return format!("LS and IV agree within their uncertainty (p = {:.3}{by}): {kept}", d.p_value);
    }
    let todo = match method {
        Method::Iv | Method::IdimIv => {
            "keep this IV estimate, and compare the validation of WLS and IV: a difference that validation does not confirm points at a model gap (friction, flexibility, a missing load: `ivdyn diagnose`) rather than noise in the regressor"
        }
        _ => {
            "try `--method iv` (the simulated identified model as the instrument) and keep it if its validation is as good; a difference that validation does not confirm points at a model gap (`ivdyn diagnose`) rather than noise in the regressor"
        }
    };
    format!("LS and IV differ beyond their uncertainty (p = {:.2e} < 0.01{by}): {todo}", d.p_value)
}

/// The consistent fit ([`ident::consistent`]) on the same weighted statistics, started from
/// the identified full parameters `full`, with its fit quality and validation.
fn consistent_report(
    robot: &Robot,
    base: &BaseParams,
    d: &FitData,
    weights: &[f64],
    full: &[f64],
    nominal: &[f64],
    progress: &ProgressSink,
) -> Result<ident::consistent::ConsistentReport> {
    let _st = Stage::begin(progress, "consistent fit", 0);
    let cacc = d.fit.ls(weights)?;
    let cf = ident::consistent::fit_consistent(
        &cacc,
        base,
        full,
        nominal,
        &robot.link_names,
        &robot.joint_names,
        &Default::default(),
    )?;
    let val =
        d.validation.as_ref().map(|(label, v)| v.quality(label.clone(), &cf.theta_base)).filter(|q| q.samples > 1);
    Ok(ident::consistent::ConsistentReport {
        fit: d.fit.quality("fit".into(), &cf.theta_base),
        validation: val,
        params: params_file(robot, cf.theta.clone()),
        result: cf,
    })
}

/// The base parameters as reported: value, standard deviation and nominal value.
fn base_values(base: &BaseParams, fit: &FitReport, nom_base: &[f64]) -> Vec<BaseValue> {
    (0..base.base_count())
        .map(|i| BaseValue {
            name: base.names[i].clone(),
            value: fit.theta[i],
            std: fit.std[i],
            rel_std_pct: fit.rel_std_pct[i],
            nominal: nom_base[i],
        })
        .collect()
}

/// The instrument in words for the report: for LS only used by the DWH test.
fn instrument_text(method: Method, instrument: &Option<String>) -> Option<String> {
    match method {
        Method::Ols | Method::Wls => instrument.clone().map(|s| format!("(DWH test only) {s}")),
        Method::Iv => instrument.clone(),
        Method::IdimIv => Some("IDIM-IV closed-loop simulation of the current estimate".into()),
    }
}

/// Full parameters `theta` of `robot` as a reloadable params file.
pub(crate) fn params_file(robot: &Robot, theta: Vec<f64>) -> ParamsFile {
    ParamsFile::new(&robot.name, robot.joint_names.clone(), robot.param_names(), theta, &robot.coulomb_shapes())
}

/// Writes `log`'s measured torques, the torques predicted by `model` (e.g. the identified
/// robot) and the residuals to the MCAP file `path`
/// ([`crate::log::PredictionWriter`]). The samples are the conditioned ones (duplicated
/// stamps dropped, uneven stamps resampled, as `identify` sees them), the prediction is
/// `rnea(q, qd, qdd)` of `model` at the smoothed state, the measured copy is the log's
/// values at those samples (resampled like the torque if the stamps were uneven).
/// Returns the samples written.
pub fn write_prediction(
    path: &std::path::Path,
    model: &Robot,
    log: &JointLog,
    condition: &ConditionOptions,
) -> Result<usize> {
    let n = model.dof();
    let c = prep::condition(log, condition)?;
    let tau =
        c.tau.as_ref().ok_or_else(|| Error::NoTorque { what: "log".into(), needed_by: "the prediction".into() })?;
    // the measured copy: the rows conditioning kept (window, repeated samples, duplicates)
    let (log, _) = prep::hygiene::clean(log, condition.window, &condition.exclude)?;
    let dd = dsp::dedup_stamps(&log.t)?;
    let t_kept: Vec<f64> = dd.keep.iter().map(|&k| log.t[k]).collect();
    let measured = |a: &[f64]| -> Result<Vec<f64>> {
        let kept = dsp::take_rows(a, n, &dd.keep);
        if c.resampled { Ok(dsp::resample_uniform(&t_kept, &kept, n, c.dt, condition.interp)?.1) } else { Ok(kept) }
    };
    let q_meas = measured(&log.q)?;
    let qd_meas = log.qd.as_ref().map(|a| measured(a)).transpose()?.unwrap_or_default();
    let mut pred = vec![0.0; c.d.q.len()];
    crate::batch::rnea_batch(model, &c.d.q, &c.d.qd, &c.d.qdd, &mut pred)?;
    let stamps: Vec<i64> = c.t.iter().map(|t| log.t0_ns.saturating_add((t * 1e9).round() as i64)).collect();
    let mut w = crate::log::PredictionWriter::create(path, &model.joint_names)?;
    w.write_block(&stamps, &q_meas, &qd_meas, tau, &c.d.q, &c.d.qd, &pred)?;
    let k = w.samples();
    w.finish()?;
    Ok(k)
}

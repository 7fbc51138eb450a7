//! `payload`: the payload on the last link from a log after the grasp, with the unloaded
//! arm identified first on a before-log when one is given (see `docs/cli.md`).

use serde::Serialize;

use std::path::{Path, PathBuf};

use super::Outcome;
use super::effort::{Effort, PerJoint, TorqueConstants};
use super::html::{PayloadPage, Series, payload_page};
use super::identify::{IdentifyOptions, Method, identify, identify_base, params_file};
use super::identify_job::input_name;
use super::io::{LogInput, LogSource};
pub use super::payload_before::{BEFORE_CHECK_CONFIDENCE, BeforeCheck};
use super::payload_before::{BeforeModel, add_before_uncertainty, before_check, before_note};
pub use super::payload_gains::TorqueConstantPrior;
use super::payload_gains::add_torque_constant_uncertainty;
use super::prepare::rows_of;
use crate::Robot;
use crate::batch::stack_rows;
use crate::dsp::Decimator;
use crate::error::{Error, Result};
use crate::ident::payload_consistent::{Violation, violation};
use crate::ident::wls::{per_joint_weights, row_weights};
use crate::ident::{self, BaseParams, FitReport, LsAccumulator, PhysicalFit, fit_ls};
use crate::log::JointLog;
use crate::output::OutputSet;
use crate::prep::{self, ConditionOptions, parallel_filter};
use crate::progress::{ProgressSink, Stage};
use crate::report::quality;
use crate::report::{ParamsFile, PayloadSpec};
use ivdyn_core::estim::TerminalSpec;
use ivdyn_core::params::LINK_PARAMS;

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
    /// Covariance of the relative errors `dk_i/k_i` of the torque constants that turned
    /// both logs' currents into torques, `n x n` row-major (an `ivdyn gains` fit's, or the
    /// datasheet's); added to the payload's ([`super::payload_gains`]). `None`: not
    /// covered (torques measured, or constants taken as exact).
    pub torque_constant_cov: Option<Vec<f64>>,
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
            torque_constant_cov: None,
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
    /// Inertia about the COM, `[Ixx, Ixy, Iyy, Ixz, Iyz, Izz]` (kg m^2, ivdyn's order; the
    /// JSON report keeps URDF attribute order `[Ixx, Ixy, Ixz, Iyy, Iyz, Izz]`).
    #[serde(serialize_with = "crate::report::urdf_inertia::serialize_opt")]
    pub inertia: Option<[f64; 6]>,
    /// Standard deviation of the mass.
    pub mass_std: Option<f64>,
    /// Standard deviations of the COM.
    pub com_std: Option<[f64; 3]>,
    /// Standard deviations of the inertia entries (same orders as `inertia`).
    #[serde(serialize_with = "crate::report::urdf_inertia::serialize_opt")]
    pub inertia_std: Option<[f64; 6]>,
    /// The 10 standard parameters about the link origin `[m, mcx, mcy, mcz, Ixx, Ixy, Iyy, Ixz, Iyz, Izz]`
    /// of the reported (physically possible) payload; the least-squares ones are in `physical`.
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
    /// RMS after subtracting the reported payload's torques (N m).
    pub rms_after: Vec<f64>,
    /// The least-squares payload against the physically possible one reported above: what it
    /// violated, its Mahalanobis distance to the nearest rigid body and the p-value; `null` when not
    /// identifiable.
    pub physical: Option<PhysicalFit>,
    /// With a before log: whether it fits this log (the residual level of both); else `null`.
    pub before_check: Option<BeforeCheck>,
    /// What the stated std cover: [`STD_NOISE`] always, [`STD_BEFORE`] with a before log,
    /// [`STD_TORQUE_CONSTANTS`] when the torque constants' covariance was given.
    pub uncertainty_sources: Vec<String>,
    /// Remarks.
    pub notes: Vec<String>,
    /// The full parameters of the model the residual is taken against (`nominal`), for
    /// the HTML report's plots.
    #[serde(skip)]
    pub nominal_params: Option<ParamsFile>,
}

/// [`PayloadReport::uncertainty_sources`]: the log's own noise (the WLS covariance).
pub const STD_NOISE: &str = "noise";
/// The before log's model error ([`super::payload_before`]).
pub const STD_BEFORE: &str = "before model";
/// The torque constants' covariance ([`super::payload_gains`]).
pub const STD_TORQUE_CONSTANTS: &str = "torque constants";

/// Below this p-value the Mahalanobis distance to the nearest rigid body says the data
/// contradict a rigid payload (a note; the number is in `physical.p_value`).
pub const RIGID_P_VALUE: f64 = 1e-3;

/// Estimates the payload on the last link from `after` (see the module docs); with
/// `before`, the unloaded arm is identified on it first and used as the nominal model.
pub fn payload(
    robot: &Robot,
    after: &JointLog,
    before: Option<&JointLog>,
    opts: &PayloadOptions,
) -> Result<PayloadReport> {
    let n = robot.dof();
    let mut notes = vec![];
    let (cols, names10) = payload_columns(robot);
    // payload base columns from random states
    let bp = {
        let _st = Stage::begin(&opts.progress, "payload base columns", 0);
        let rows = ident::base::random_rows(robot, &cols, opts.base_samples, opts.seed)?;
        BaseParams::from_rows(&rows, &names10)
    };
    check_log(robot, after)?;
    let LsPayload { nom, rows, phib, mut fit, w } = ls_payload(robot, after, before, opts, &bp, &cols)?;
    let res = &rows.res;
    let thf: Vec<f64> = fit.theta.iter().map(|v| if v.is_finite() { *v } else { 0.0 }).collect();
    let ls_q = quality(String::new(), &phib, res, &thf, n);
    let mut sources = vec![STD_NOISE.to_string()];
    if let Some(b) = &nom.before {
        add_before_uncertainty(&mut fit, &phib, &w, &rows.phi_before, b)?;
        sources.push(STD_BEFORE.into());
    }
    if let Some(c) = &opts.torque_constant_cov {
        let _st = Stage::begin(&opts.progress, "torque-constant sensitivity", 0);
        // the before log's Coulomb shapes stay those chosen above: a choice that flipped
        // under a 0.1 % torque step would be a jump, not a derivative
        let mut fixed = robot.clone();
        fixed.set_coulomb_shapes(&nom.robot.coulomb_shapes())?;
        let mut quiet = PayloadOptions { progress: None, ..opts.clone() };
        quiet.before.coulomb = super::identify::CoulombMode::Model;
        let rerun = |a: &JointLog, b: Option<&JointLog>| -> Result<Vec<f64>> {
            Ok(ls_payload(&fixed, a, b, &quiet, &bp, &cols)?.fit.theta)
        };
        add_torque_constant_uncertainty(&mut fit, c, after, before, rerun)?;
        sources.push(STD_TORQUE_CONSTANTS.into());
    }
    let idx: [usize; 10] = std::array::from_fn(|k| k);
    let est = ident::payload_from_fit(&bp, &fit, &idx, &names10)?;
    // the reported payload's torques: the consistent one when identifiable
    let th_rep = match &est {
        Ok(e) => bp.project(&e.params)?,
        Err(_) => thf.clone(),
    };
    let zero = vec![0.0; bp.base_count()];
    let before_q = quality(String::new(), &phib, res, &zero, n);
    let after_q = quality(String::new(), &phib, res, &th_rep, n);
    if after.truncated {
        notes.push("the log was truncated; only the samples before the damage were used".into());
    }
    let before_check =
        nom.before.as_ref().map(|b| before_check(&robot.joint_names, &b.quality, b.rank, &ls_q, bp.base_count()));
    notes.extend(before_check.as_ref().map(before_note).unwrap_or_default());
    let rep = PayloadReport {
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
        nominal: nom.name.clone(),
        joints: robot.joint_names.clone(),
        samples: res.len() / n,
        rms_before: before_q.rms,
        rms_after: after_q.rms,
        physical: None,
        before_check,
        uncertainty_sources: sources,
        notes,
        nominal_params: Some(params_file(&nom.robot, nom.robot.params())),
    };
    Ok(with_estimate(rep, est))
}

/// The least-squares payload of one (after, before) pair of logs: the nominal model, the
/// filtered rows, the payload's base rows `phib`, its WLS fit and the row weights.
struct LsPayload {
    nom: Nominal,
    rows: Rows,
    phib: Vec<f64>,
    fit: FitReport,
    w: Vec<f64>,
}

/// [`LsPayload`] of `after` (and `before`) over the payload base columns `bp` of the
/// full-parameter columns `cols`: what [`payload`] runs once, and again per torque
/// constant for its sensitivity.
fn ls_payload(
    robot: &Robot,
    after: &JointLog,
    before: Option<&JointLog>,
    opts: &PayloadOptions,
    bp: &BaseParams,
    cols: &[usize],
) -> Result<LsPayload> {
    let n = robot.dof();
    let nom = nominal_model(robot, before, opts)?;
    let raw = RawRows::new(robot, &nom, after, cols, opts)?;
    let _st = Stage::begin(&opts.progress, "filtering and fitting", 0);
    let rows = raw.filtered(n)?;
    let phib = bp.select_rows(&rows.phi10, rows.res.len())?;
    let (fit, w) = fit_wls(bp, &phib, &rows.res, n)?;
    Ok(LsPayload { nom, rows, phib, fit, w })
}

/// The model the residual is taken against ([`nominal_model`]).
struct Nominal {
    robot: Robot,
    /// `"before log"` or `"urdf"`.
    name: String,
    /// With a before log: the model identified on it, with its uncertainty.
    before: Option<BeforeModel>,
}

/// The unloaded arm identified on `before` when given, else the URDF's.
fn nominal_model(robot: &Robot, before: Option<&JointLog>, opts: &PayloadOptions) -> Result<Nominal> {
    let mut nom = Nominal { robot: robot.clone(), name: "urdf".into(), before: None };
    if let Some(b) = before {
        let mut o = opts.before.clone();
        o.progress = opts.progress.clone();
        // the same conditioning as the after-log (the window is the after-log's)
        o.condition = ConditionOptions { window: None, ..opts.condition.clone() };
        let rep = identify(robot, b, &o)?;
        // with the Coulomb shapes identify chose: its fc belong to them
        crate::robot::load::load_params(&mut nom.robot, &rep.params)?;
        nom.name = "before log".into();
        let fit =
            rep.fit_report.as_ref().ok_or_else(|| Error::internal("before log: identify returned no fit report"))?;
        nom.before = Some(BeforeModel::new(identify_base(robot, &o)?, fit, rep.fit.clone()));
    }
    Ok(nom)
}

/// The full-parameter columns of the last link (the payload's 10 parameters) and their names.
fn payload_columns(robot: &Robot) -> (Vec<usize>, Vec<String>) {
    let n = robot.dof();
    let spec = TerminalSpec::payload(n);
    let cols: Vec<usize> = (0..spec.cols(n)).map(|c| spec.theta_index(n, c)).collect();
    debug_assert_eq!(cols.len(), LINK_PARAMS);
    let all_names = robot.param_names();
    let names10: Vec<String> = cols.iter().map(|&c| all_names[c].clone()).collect();
    (cols, names10)
}

/// The log must have torques and the robot's joints.
fn check_log(robot: &Robot, after: &JointLog) -> Result<()> {
    if after.tau.is_none() {
        return Err(Error::NoTorque { what: "log".into(), needed_by: "payload estimation".into() });
    }
    if after.joint_names != robot.joint_names {
        return Err(Error::JointMismatch {
            what: "log".into(),
            log: after.joint_names.clone(),
            robot: robot.joint_names.clone(),
        });
    }
    crate::prep::hygiene::torque_check(after)
}

/// The conditioned log's torque residual (measured - nominal `rnea`) and payload regressor
/// rows (and, with a before log, its base regressor rows), before the parallel filter.
struct RawRows {
    /// `T x n x 10`.
    phi10: Vec<f64>,
    /// `T x n x b`: the before model's base columns (empty without a before log).
    phi_before: Vec<f64>,
    /// `T x n`.
    res: Vec<f64>,
    /// The parallel filter and decimation for this log's rate.
    dec: Decimator,
}

/// [`RawRows`] filtered, decimated and without the filter edges.
struct Rows {
    /// `T' x n x 10`.
    phi10: Vec<f64>,
    /// `T' x n x b`.
    phi_before: Vec<f64>,
    /// `T' x n`.
    res: Vec<f64>,
}

impl RawRows {
    /// Conditions `after`, takes the residual against `nom` and stacks the regressor
    /// columns `cols` (and the before model's base columns).
    fn new(robot: &Robot, nom: &Nominal, after: &JointLog, cols: &[usize], opts: &PayloadOptions) -> Result<Self> {
        let n = robot.dof();
        let c = prep::condition(after, &opts.condition)?;
        let fs = 1.0 / c.dt;
        let dec = parallel_filter(opts.decimate, fs, c.t.len(), &opts.condition)?;
        let t = c.t.len();
        let mut tau_nom = vec![0.0; t * n];
        crate::batch::rnea_batch(&nom.robot, &c.d.q, &c.d.qd, &c.d.qdd, &mut tau_nom)?;
        let res: Vec<f64> = c.tau.as_ref().expect("checked").iter().zip(&tau_nom).map(|(a, b)| a - b).collect();
        let st = Stage::begin(&opts.progress, "payload regressor", t as u64);
        let phi10 = stack_rows(robot, cols, &c.d.q, &c.d.qd, &c.d.qdd, Some(&st))?;
        let phi_before = match &nom.before {
            Some(b) => stack_rows(robot, &b.base.independent, &c.d.q, &c.d.qd, &c.d.qdd, None)?,
            None => vec![],
        };
        Ok(RawRows { phi10, phi_before, res, dec })
    }

    /// All through the same zero-phase filter and decimation, with the filter edges (1 %
    /// of the samples, at most 20, at each end) dropped.
    fn filtered(self, n: usize) -> Result<Rows> {
        let res = self.dec.apply(&self.res, n)?;
        let tt = res.len() / n;
        let edge = (tt / 100).min(20);
        let r = edge..tt - edge;
        let cut = |rows: &[f64]| -> Result<Vec<f64>> {
            if rows.is_empty() {
                return Ok(vec![]);
            }
            let width = rows.len() / (self.res.len() / n);
            Ok(rows_of(&self.dec.apply(rows, width)?, width, r.clone()).to_vec())
        };
        Ok(Rows {
            phi10: cut(&self.phi10)?,
            phi_before: cut(&self.phi_before)?,
            res: rows_of(&res, n, r.clone()).to_vec(),
        })
    }
}

/// Two-step WLS of the residual on the payload's base columns: OLS, then weights
/// `1 / rms^2` of the OLS residual per joint. Returns the fit and the row weights.
fn fit_wls(bp: &BaseParams, phib: &[f64], res: &[f64], n: usize) -> Result<(FitReport, Vec<f64>)> {
    let nb = bp.base_count();
    let mut acc = LsAccumulator::new(nb);
    acc.add_rows(phib, res, None)?;
    let ols = fit_ls(&acc, &bp.names)?;
    let th0: Vec<f64> = ols.theta.iter().map(|v| if v.is_finite() { *v } else { 0.0 }).collect();
    let w = row_weights(&per_joint_weights(&quality(String::new(), phib, res, &th0, n).rms), res.len());
    let mut acc = LsAccumulator::new(nb);
    acc.add_rows(phib, res, Some(&w))?;
    Ok((fit_ls(&acc, &bp.names)?, w))
}

/// `rep` with the payload estimate filled in (and the notes on it), or the parameters that
/// are not identifiable.
fn with_estimate(
    mut rep: PayloadReport,
    est: std::result::Result<ident::PayloadEstimate, ident::NotIdentifiable>,
) -> PayloadReport {
    match est {
        Ok(e) => {
            rep.notes.extend(physical_notes(&e, &rep.link));
            rep.identifiable = true;
            rep.mass = Some(e.mass);
            rep.com = Some(e.com);
            rep.inertia = Some(e.inertia);
            rep.mass_std = Some(e.mass_std);
            rep.com_std = Some(e.com_std);
            rep.inertia_std = Some(e.inertia_std);
            rep.params = Some(e.params);
            rep.physical = Some(e.physical);
        }
        Err(ni) => {
            rep.not_identifiable = ni
                .parameters
                .into_iter()
                .zip(ni.combined_in)
                .map(|(parameter, combined_in)| Hidden { parameter, combined_in })
                .collect();
        }
    }
    rep
}

/// What a user must know about the estimate `e` on `link`: no payload seen, an LS payload
/// that was no body, active constraints, data that contradict a rigid payload.
fn physical_notes(e: &ident::PayloadEstimate, link: &str) -> Vec<String> {
    let ph = &e.physical;
    let mut notes = vec![];
    let m_ls = ph.ls_params[0];
    if m_ls < 3.0 * e.mass_std {
        notes.push(format!(
            "no payload detected: the least-squares mass {m_ls:.4} kg is within 3 std ({:.2e} kg) of zero; the centre of mass and inertia of so light a payload are not determined by the data (see their std)",
            3.0 * e.mass_std
        ));
    }
    if !ph.ls_possible {
        notes.push(format!(
            "the least-squares payload is not a physically possible rigid body ({}); the payload reported is the nearest possible one, at squared Mahalanobis distance {:.3} from it",
            violation_words(&ph.ls_violation),
            ph.mahalanobis2
        ));
    }
    if ph.constraints_active {
        notes.push("the physical constraints are active: the stated std are those of the unconstrained fit (along the bound the reported estimate varies less)".into());
    }
    if ph.p_value < RIGID_P_VALUE {
        notes.push(format!(
            "the data contradict a rigid payload: the nearest rigid body is at squared Mahalanobis distance {:.1} from the least-squares payload (p = {:.1e}, chi-square with {} degrees of freedom). The residual holds something a rigid body fixed to '{link}' cannot explain: a payload that moves or swings, a nominal-model error, or a before log that does not match",
            ph.mahalanobis2, ph.p_value, ph.dof
        ));
    }
    notes
}

/// The violations of `v`, in words.
fn violation_words(v: &Violation) -> String {
    let mut w = vec![];
    if v.mass <= 0.0 {
        w.push(format!("mass {:.3e} kg", v.mass));
    }
    if let Some(ip) = v.min_principal_moment.filter(|x| *x <= 0.0) {
        w.push(format!("a principal moment of inertia about the COM of {ip:.3e} kg m^2"));
    }
    if let Some(t) = v.triangle_margin.filter(|x| *x < 0.0) {
        w.push(format!("the triangle inequality I1 + I2 >= I3 short by {:.3e} kg m^2", -t));
    }
    w.push(format!("smallest pseudo-inertia eigenvalue {:.3e}", v.min_eig_pseudo_inertia));
    w.join(", ")
}

/// How `payload` writes the payload into a URDF copy.
pub use crate::robot::write::PayloadMode;

/// One `payload` run: the log after the grasp, optionally the log before it, and what to
/// write.
#[derive(Clone)]
pub struct PayloadJob {
    /// The log after the grasp.
    pub log: LogInput,
    /// The log before the grasp (the same arm without payload).
    pub before: Option<LogInput>,
    /// How log files are read.
    pub source: LogSource,
    /// Options (the before-log is conditioned and decimated like the log).
    pub opts: PayloadOptions,
    /// The JSON report.
    pub json: Option<PathBuf>,
    /// The HTML report (one self-contained page, [`super::html`]).
    pub report: Option<PathBuf>,
    /// A copy of the URDF `.0` with the payload, written to `.1` (when identifiable).
    pub urdf: Option<(PathBuf, PathBuf, PayloadMode)>,
    /// An MJCF of the arm as loaded with the payload welded to the last link (when
    /// identifiable), [`crate::robot::mjcf`].
    pub mjcf: Option<PathBuf>,
    /// The torque constants' uncertainty (their std, or an `ivdyn gains` report), added to
    /// the payload's ([`super::payload_gains`]).
    pub torque_constant_prior: TorqueConstantPrior,
}

/// Runs `job` on `robot`, then writes its outputs.
pub fn payload_job(robot: &Robot, job: &PayloadJob) -> Result<Outcome<PayloadReport>> {
    let (source, kt_cov) = with_torque_constant_prior(robot, &job.source, &job.torque_constant_prior)?;
    let after = read(robot, &job.log, &source, &job.opts.progress)?;
    let before = job.before.as_ref().map(|b| read(robot, b, &source, &job.opts.progress)).transpose()?;
    let mut opts = job.opts.clone();
    opts.torque_constant_cov = kt_cov.or(opts.torque_constant_cov);
    opts.before.condition = opts.condition.clone();
    opts.before.decimate = opts.decimate;
    let rep = payload(robot, &after, before.as_deref(), &opts).map_err(|e| job.log.context(e))?;
    let mut written = vec![];
    // all of the command's files or none of them
    let mut set = OutputSet::new();
    if let Some(p) = &job.json {
        set.write_json(p, &rep)?;
        written.push(format!("report written to {}", p.display()));
    }
    if let (Some((input, out, mode)), true) = (&job.urdf, rep.identifiable) {
        stage_urdf(&mut set, robot, &rep, input, out, *mode)?;
        written.push(format!("URDF with the payload written to {}", out.display()));
    }
    if let (Some(out), true) = (&job.mjcf, rep.identifiable) {
        let spec = written_spec(&rep);
        check_writable(&spec, out)?;
        let mj = crate::robot::mjcf::to_mjcf(robot, Some(&spec), vec![WRITTEN_NOTE.into()])
            .map_err(|e| Error::InFile { file: out.clone(), source: Box::new(e) })?;
        crate::robot::mjcf::stage_files(&mut set, out, &mj)?;
        written.push(format!("MJCF with the payload written to {}", out.display()));
    }
    if let Some(p) = &job.report {
        let _st = Stage::begin(&opts.progress, "HTML report", 0);
        let log = report_series(robot, &rep, &after, &opts.condition).map_err(|e| job.log.context(e))?;
        let logs = std::iter::once(&job.log).chain(&job.before).map(input_name).collect();
        let page = payload_page(&PayloadPage { report: &rep, logs, log: &log }, p)?;
        set.write_bytes(p, page.as_bytes())?;
        written.push(format!("HTML report written to {}", p.display()));
    }
    set.commit()?;
    Ok(Outcome { report: rep, written })
}

/// The report's plot data: `after` predicted by the nominal model of `rep` and by that
/// model with the reported payload added to the last link's parameters (the columns the
/// payload was fitted on); without an estimate, by the nominal model twice.
fn report_series(robot: &Robot, rep: &PayloadReport, after: &JointLog, cond: &ConditionOptions) -> Result<Series> {
    let mut nominal = robot.clone();
    if let Some(p) = &rep.nominal_params {
        crate::robot::load::load_params(&mut nominal, p)?;
    }
    let mut loaded = nominal.clone();
    if let Some(add) = &rep.params {
        let (cols, _) = payload_columns(robot);
        let mut theta = loaded.params();
        for (c, v) in cols.iter().zip(add) {
            theta[*c] += v;
        }
        loaded.set_params(&theta)?;
    }
    Series::of(&[&nominal, &loaded], after, cond)
}

/// `src` with the torque constants `prior` settles (a gains report's replace the given
/// ones), the effort the current, and the covariance of the constants' relative errors;
/// `src` unchanged and `None` without a prior.
fn with_torque_constant_prior(
    robot: &Robot,
    src: &LogSource,
    prior: &TorqueConstantPrior,
) -> Result<(LogSource, Option<Vec<f64>>)> {
    if !prior.is_given() {
        return Ok((src.clone(), None));
    }
    let effort = match src.effort {
        Effort::Torque => {
            return Err(Error::option(
                "effort",
                "is 'torque', but a torque-constant uncertainty (torque_constant_std, gains) is for an effort given as current",
            ));
        }
        // the constants' uncertainty only means something for the current
        Effort::Auto | Effort::Current => Effort::Current,
    };
    let given = src.torque_constants.resolve(&robot.joint_names)?;
    let (k, rel_cov) = prior.resolve(&robot.joint_names, given.as_deref())?;
    let torque_constants = TorqueConstants { torque_constant: Some(PerJoint::List(k)), ..Default::default() };
    Ok((LogSource { effort, torque_constants, ..src.clone() }, Some(rel_cov)))
}

/// Note in the written files: where the arm's parameters come from.
const WRITTEN_NOTE: &str = "ivdyn payload: the arm as loaded (URDF, --params or side file) plus the identified payload";

/// The payload of `rep` as written (NaN where the report has no number, refused by
/// [`check_writable`]).
fn written_spec(rep: &PayloadReport) -> PayloadSpec {
    PayloadSpec {
        mass: rep.mass.unwrap_or(f64::NAN),
        com: rep.com.unwrap_or([f64::NAN; 3]),
        inertia: rep.inertia.unwrap_or([f64::NAN; 6]),
    }
}

/// Stages a copy of the URDF `input` with the payload of `rep` for `out` (and its side
/// file), after [`check_writable`]: nothing is written for a payload that is no body.
fn stage_urdf(
    set: &mut OutputSet,
    robot: &Robot,
    rep: &PayloadReport,
    input: &Path,
    out: &Path,
    mode: PayloadMode,
) -> Result<()> {
    let spec = written_spec(rep);
    check_writable(&spec, out)?;
    let text = std::fs::read_to_string(input).map_err(|e| Error::Io { file: input.to_path_buf(), source: e })?;
    let wb = crate::robot::write::write_back(
        &text,
        input,
        robot,
        Some(&robot.params()),
        Some((&spec, mode)),
        vec![WRITTEN_NOTE.into()],
    )?;
    crate::robot::write::stage_files(set, out, &wb)
}

/// Refuses (before anything is written to `out`) a payload that is not a rigid body with a
/// positive mass, positive principal moments about its COM and strict triangle inequalities:
/// simulators refuse it (MuJoCo: "inertia must have positive eigenvalues"), and it describes
/// no object. The estimate is consistent by construction; this guards the file.
pub fn check_writable(spec: &PayloadSpec, out: &Path) -> Result<()> {
    let p = spec.link_inertia().0;
    let v = violation(&p);
    let fine = |x: Option<f64>| x.is_some_and(|x| x > 0.0);
    if p.iter().all(|x| x.is_finite()) && v.mass > 0.0 && fine(v.min_principal_moment) && fine(v.triangle_margin) {
        return Ok(());
    }
    Err(Error::PhysicallyInconsistent {
        what: format!("writing {}", out.display()),
        problems: format!(
            "the payload (mass {} kg, inertia about the COM {:?} kg m^2) is not a physically possible rigid body ({}); nothing was written",
            spec.mass,
            spec.inertia,
            violation_words(&v)
        ),
    })
}

fn read<'a>(
    robot: &Robot,
    input: &'a LogInput,
    src: &LogSource,
    progress: &ProgressSink,
) -> Result<std::borrow::Cow<'a, JointLog>> {
    let _st = input.path().map(|p| Stage::begin(progress, &format!("reading {}", p.display()), 0));
    input.load(robot, src)
}

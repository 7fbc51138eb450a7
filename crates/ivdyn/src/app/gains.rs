//! `gains`: the drive gains (the torque constants at the joint, N m/A, gear included) from
//! a log without and a log with a payload of known mass, with the arm's base parameters in
//! absolute units (`docs/cli.md`, "ivdyn gains"; the estimator is [`crate::ident::gains`]).
//!
//! Both logs go through the one conditioning policy and the parallel filter, each on its
//! own (as `identify` prepares a log: segments at gaps, repeated samples dropped, the
//! log's velocity where it agrees with the positions); the fit sees their filtered rows.

use std::borrow::Cow;
use std::ops::Range;
use std::path::PathBuf;

use nalgebra::{Matrix3, Vector3};
use serde::Serialize;

use super::Outcome;
use super::identify::{IdentifyOptions, conditioning_notes, identify_base};
use super::io::{LogInput, LogSource};
use super::prepare::{Prepared, prepare};
use crate::Robot;
use crate::error::{Error, Result};
use crate::ident::gains::{GainFit, GainOptions, GainRun, GainVerdict, RunStats, fit_gains};
use crate::log::JointLog;
use crate::output::write_json;
use crate::prep::{ConditionOptions, ConditionSummary};
use crate::progress::{ProgressSink, Stage};
use crate::report::BaseValue;
use ivdyn_core::LinkInertia;
use ivdyn_core::params::{LINK_PARAM_NAMES, LINK_PARAMS};

/// The payload as known: its mass always, its COM and inertia when known (else estimated).
#[derive(Debug, Clone, PartialEq)]
pub struct KnownPayload {
    /// Mass (kg): what fixes the scale of every gain.
    pub mass: f64,
    /// COM in the last link's frame (m).
    pub com: Option<[f64; 3]>,
    /// Inertia about the COM `[Ixx, Ixy, Iyy, Ixz, Iyz, Izz]` (kg m^2, ivdyn's order); needs `com`.
    pub inertia: Option<[f64; 6]>,
}

impl KnownPayload {
    /// From its parts as a user gives them; errors name the option.
    pub fn from_parts(mass: f64, com: Option<&[f64]>, inertia: Option<&[f64]>) -> Result<Self> {
        if inertia.is_some() && com.is_none() {
            return Err(Error::option("payload_inertia", "needs payload_com (the inertia is about the COM)"));
        }
        // the mass sets the scale of every gain: checked like any payload's
        let (mass, com, inertia) = crate::limits::payload_parts(mass, com, inertia)?;
        Ok(KnownPayload { mass, com, inertia })
    }

    /// The given standard parameters `[m, m cx, m cy, m cz, Ixx, Ixy, Iyy, Ixz, Iyz, Izz]`
    /// about the last link's origin (`None`: estimated).
    pub fn known(&self) -> [Option<f64>; LINK_PARAMS] {
        let mut k = [None; LINK_PARAMS];
        k[0] = Some(self.mass);
        if let Some(c) = self.com {
            let i_c = ivdyn_core::inertia_matrix(&self.inertia.unwrap_or([0.0; 6]));
            let li = LinkInertia::from_mass_com_inertia(self.mass, &Vector3::from(c), &Matrix3::identity(), &i_c);
            let given = if self.inertia.is_some() { LINK_PARAMS } else { 4 };
            for (kk, v) in k.iter_mut().zip(li.0).take(given) {
                *kk = Some(v);
            }
        }
        k
    }

    /// What was given, in words.
    fn given(&self) -> Vec<String> {
        let mut g = vec!["mass".to_string()];
        g.extend(self.com.map(|_| "com".to_string()));
        g.extend(self.inertia.map(|_| "inertia".to_string()));
        g
    }
}

/// Options of [`drive_gains`].
#[derive(Clone)]
pub struct GainsOptions {
    /// Conditioning of both logs.
    pub condition: ConditionOptions,
    /// Decimation factor after the parallel filter (0: automatic).
    pub decimate: usize,
    /// Random states for the base parameters, and their seed.
    pub base_samples: usize,
    /// Seed of the base-parameter states.
    pub seed: u64,
    /// Largest relative std of a gain reported as identifiable (default 0.1).
    pub max_rel_std: f64,
    /// Progress sink.
    pub progress: ProgressSink,
}

impl Default for GainsOptions {
    fn default() -> Self {
        GainsOptions {
            condition: ConditionOptions::default(),
            decimate: 0,
            base_samples: 200,
            seed: 1,
            max_rel_std: GainOptions::default().max_rel_std,
            progress: None,
        }
    }
}

/// One joint's gain as reported.
#[derive(Debug, Clone, Serialize)]
pub struct GainValue {
    /// Joint.
    pub joint: String,
    /// Whether the pair determines it (`docs/cli.md`).
    pub identifiable: bool,
    /// Gain, N m/A at the joint (`null` when not identifiable).
    pub value: Option<f64>,
    /// Its standard deviation (`null` when not identifiable).
    pub std: Option<f64>,
    /// Relative standard deviation the fit found, percent, also when not identifiable
    /// (`null` when the fit could not estimate the gain at all).
    pub rel_std_pct: Option<f64>,
    /// Why it is not identifiable.
    pub reason: Option<String>,
}

/// One payload parameter.
#[derive(Debug, Clone, Serialize)]
pub struct PayloadParam {
    /// `payload.m`, `payload.m*cx`, ... (about the last link's origin, in its frame).
    pub name: String,
    /// Value (given or estimated; `null`: not excited).
    pub value: f64,
    /// Standard deviation (0 when given).
    pub std: f64,
    /// Whether it was given.
    pub given: bool,
}

/// The payload in the fit.
#[derive(Debug, Clone, Serialize)]
pub struct GainsPayload {
    /// The link carrying it (the last of the chain).
    pub link: String,
    /// Mass (kg), as given.
    pub mass: f64,
    /// What was given: `mass`, `com`, `inertia`.
    pub given: Vec<String>,
    /// COM in the link frame (m), given or estimated.
    pub com: [f64; 3],
    /// Its standard deviation (0 when given).
    pub com_std: [f64; 3],
    /// The ten standard parameters.
    pub params: Vec<PayloadParam>,
}

/// One log in the fit (current units: A when the log's currents are in A).
#[derive(Debug, Clone, Serialize)]
pub struct GainsRun {
    /// The signal used as the current: `motor current` or `effort field`.
    pub current_from: String,
    /// Samples fitted (after the parallel filter and decimation, filter edges dropped).
    pub samples: usize,
    /// Sample rate of the fitted rows (Hz).
    pub sample_rate_hz: f64,
    /// Decimation factor.
    pub decimation: usize,
    /// Zero-phase cut-off of the parallel filter (Hz).
    pub filter_cutoff_hz: f64,
    /// RMS of the residual `i - τ̂ / g` per joint.
    pub rms: Vec<f64>,
    /// RMS of the current per joint.
    pub current_rms: Vec<f64>,
    /// Coefficient of determination per joint.
    pub r2: Vec<f64>,
    /// Noise std per joint used in the weights.
    pub noise_std: Vec<f64>,
    /// Variance inflation per joint for the residual's serial correlation.
    pub inflation: Vec<f64>,
    /// What conditioning did.
    pub conditioning: ConditionSummary,
}

/// Result of [`drive_gains`] (the `--json` document of `ivdyn gains`).
#[derive(Debug, Clone, Serialize)]
pub struct GainsReport {
    /// Joints, base to tip.
    pub joints: Vec<String>,
    /// The gains.
    pub gains: Vec<GainValue>,
    /// Covariance of the gains, (N m/A)^2, joint by joint in the order of `joints` (`null`
    /// in the row and column of a gain that is not identifiable): what `payload --gains`
    /// adds to the payload's uncertainty (the gains share the payload's mass and the arm's
    /// parameters, so their errors are correlated).
    pub gain_covariance: Vec<Vec<Option<f64>>>,
    /// The payload.
    pub payload: GainsPayload,
    /// Base parameters in absolute units (N m from the currents through the gains).
    pub base: Vec<BaseValue>,
    /// The log without the payload.
    pub unloaded: GainsRun,
    /// The log with the payload.
    pub loaded: GainsRun,
    /// The identifiability limit on a gain's relative std.
    pub max_rel_std: f64,
    /// Gauss-Newton iterations.
    pub iterations: usize,
    /// Whether the fit converged.
    pub converged: bool,
    /// Remarks.
    pub notes: Vec<String>,
}

/// One log's filtered rows and the sample ranges fitted.
struct Run {
    prep: Prepared,
    pieces: Vec<Range<usize>>,
}

/// `log` conditioned and parallel-filtered into rows of the columns `cols` (its `tau` is
/// the current), the filter edges of every segment left out.
fn prepare_run(robot: &Robot, cols: &[usize], log: &JointLog, io: &IdentifyOptions, what: &str) -> Result<Run> {
    if log.tau.is_none() {
        return Err(Error::NoCurrent { what: what.into() });
    }
    let prep = prepare(robot, cols, &[log], io, what)?;
    let t = prep.len();
    let edge = (t / 100).min(20);
    let pieces = if t > 2 * edge { prep.pieces(edge..t - edge) } else { vec![] };
    let kept: usize = pieces.iter().map(|p| p.len()).sum();
    if kept < 3 {
        return Err(Error::TooFewSamples { samples: kept, joints: robot.dof(), params: cols.len() });
    }
    Ok(Run { prep, pieces })
}

/// The drive gains of `robot` from `unloaded` and `loaded` (logs whose `tau` is the drive
/// current, as [`LogInput::load_current`] gives them), the payload `payload` on the last
/// link in `loaded` (module docs).
pub fn drive_gains(
    robot: &Robot,
    unloaded: &JointLog,
    loaded: &JointLog,
    payload: &KnownPayload,
    opts: &GainsOptions,
) -> Result<GainsReport> {
    let n = robot.dof();
    let io = IdentifyOptions {
        condition: opts.condition.clone(),
        decimate: opts.decimate,
        base_samples: opts.base_samples,
        seed: opts.seed,
        progress: opts.progress.clone(),
        ..Default::default()
    };
    let base = {
        let _st = Stage::begin(&opts.progress, "base parameters", 0);
        identify_base(robot, &io)?
    };
    // the base columns, then the last link's ten (the payload's)
    let mut cols = base.independent.clone();
    cols.extend(LINK_PARAMS * (n - 1)..LINK_PARAMS * n);
    let u = prepare_run(robot, &cols, unloaded, &io, "unloaded log")?;
    let l = prepare_run(robot, &cols, loaded, &io, "loaded log")?;
    let runs = [(&u, false), (&l, true)].map(|(r, loaded)| GainRun {
        rows: &r.prep.phi,
        current: &r.prep.tau,
        pieces: &r.pieces,
        loaded,
    });
    let fit = {
        let _st = Stage::begin(&opts.progress, "fitting the gains", 0);
        let go = GainOptions { max_rel_std: opts.max_rel_std, ..Default::default() };
        fit_gains(n, &base.names, &runs, &payload.known(), &go)?
    };
    let nominal = base.project(&robot.params())?;
    let mut notes = vec![];
    for (what, log, run) in [("unloaded log", unloaded, &u), ("loaded log", loaded, &l)] {
        notes.extend(conditioning_notes(&run.prep.conditioning).into_iter().map(|s| format!("{what}: {s}")));
        if log.truncated {
            notes.push(format!("{what}: truncated; only the samples before the damage were used"));
        }
    }
    notes.extend(fit_notes(robot, &fit, payload));
    Ok(GainsReport {
        joints: robot.joint_names.clone(),
        gains: gain_values(robot, &fit, opts.max_rel_std),
        gain_covariance: gain_covariance(&fit),
        payload: payload_report(robot, &fit, payload),
        base: (0..base.base_count())
            .map(|i| BaseValue {
                name: base.names[i].clone(),
                value: fit.theta[i],
                std: fit.theta_std[i],
                rel_std_pct: 100.0 * fit.theta_std[i] / fit.theta[i].abs(),
                nominal: nominal[i],
            })
            .collect(),
        unloaded: run_report(&u, &fit.runs[0]),
        loaded: run_report(&l, &fit.runs[1]),
        max_rel_std: opts.max_rel_std,
        iterations: fit.iterations,
        converged: fit.converged,
        notes,
    })
}

/// Each gain with its verdict in words.
fn gain_values(robot: &Robot, fit: &GainFit, max_rel_std: f64) -> Vec<GainValue> {
    let pct = |x: f64| x.is_finite().then_some(100.0 * x);
    (0..robot.dof())
        .map(|j| {
            let ok = fit.verdict[j] == GainVerdict::Identifiable;
            GainValue {
                joint: robot.joint_names[j].clone(),
                identifiable: ok,
                value: ok.then_some(fit.gain[j]),
                std: ok.then_some(fit.gain_std[j]),
                rel_std_pct: pct(fit.rel_std[j]),
                reason: reason(&fit.verdict[j], max_rel_std),
            }
        })
        .collect()
}

/// The gains' covariance from that of the inverse gains `h = 1/g` (the fit's last `n`
/// parameters): `dg = -g^2 dh` (delta method), only among the identifiable gains.
fn gain_covariance(fit: &GainFit) -> Vec<Vec<Option<f64>>> {
    let n = fit.gain.len();
    let off = fit.covariance.nrows() - n;
    let ok = |j: usize| fit.verdict[j] == GainVerdict::Identifiable;
    (0..n)
        .map(|i| {
            (0..n)
                .map(|j| {
                    let (gi, gj) = (fit.gain[i], fit.gain[j]);
                    (ok(i) && ok(j)).then(|| fit.covariance[(off + i, off + j)] * gi * gi * gj * gj)
                })
                .collect()
        })
        .collect()
}

/// Why a gain is not identifiable, in words (`None` when it is).
fn reason(v: &GainVerdict, max_rel_std: f64) -> Option<String> {
    match v {
        GainVerdict::Identifiable => None,
        GainVerdict::Unexcited => Some(
            "no information: the fit cannot estimate it (does the joint move, and carry current, in both logs?)".into(),
        ),
        GainVerdict::NullDirection { with } => Some(format!(
            "not identifiable from this pair: it trades off exactly against {}; neither the payload nor the coupling to the other joints loads this joint",
            with.join(", ")
        )),
        GainVerdict::Loose { rel_std } => Some(format!(
            "the pair determines it only to ±{:.1} % (1 std), above the {:.1} % limit: the payload and the coupling to the other joints barely load this joint; move it with larger accelerations in both logs, or use a heavier payload",
            100.0 * rel_std,
            100.0 * max_rel_std
        )),
    }
}

/// The payload part of the report: the ten parameters and the COM.
fn payload_report(robot: &Robot, fit: &GainFit, payload: &KnownPayload) -> GainsPayload {
    let known = payload.known();
    let params = (0..LINK_PARAMS)
        .map(|k| PayloadParam {
            name: format!("payload.{}", LINK_PARAM_NAMES[k]),
            value: fit.payload[k],
            std: fit.payload_std[k],
            given: known[k].is_some(),
        })
        .collect();
    let m = payload.mass;
    GainsPayload {
        link: robot.link_names[robot.dof() - 1].clone(),
        mass: m,
        given: payload.given(),
        com: std::array::from_fn(|a| fit.payload[1 + a] / m),
        com_std: std::array::from_fn(|a| fit.payload_std[1 + a] / m),
        params,
    }
}

/// A log's part of the report (its current source is filled in by the job).
fn run_report(r: &Run, s: &RunStats) -> GainsRun {
    GainsRun {
        current_from: "tau".into(),
        samples: s.samples,
        sample_rate_hz: 1.0 / r.prep.dt,
        decimation: r.prep.factor,
        filter_cutoff_hz: r.prep.cutoff_hz,
        rms: s.rms.clone(),
        current_rms: s.current_rms.clone(),
        r2: s.r2.clone(),
        noise_std: s.noise_std.clone(),
        inflation: s.inflation.clone(),
        conditioning: r.prep.conditioning.clone(),
    }
}

/// Remarks on the fit: convergence, reversed currents, correlated residuals, what the std
/// does not cover.
fn fit_notes(robot: &Robot, fit: &GainFit, payload: &KnownPayload) -> Vec<String> {
    let mut notes = vec![];
    if !fit.converged {
        notes.push(format!("the fit did not converge in {} Gauss-Newton iterations", fit.iterations));
    }
    for (j, g) in fit.gain.iter().enumerate() {
        if *g < 0.0 {
            notes.push(format!(
                "{}: the gain is negative: the current is measured against the joint's direction",
                robot.joint_names[j]
            ));
        }
    }
    for (what, s) in [("unloaded log", &fit.runs[0]), ("loaded log", &fit.runs[1])] {
        for (j, f) in s.inflation.iter().enumerate() {
            if *f > 4.0 {
                notes.push(format!(
                    "{what}, {}: the residual is strongly correlated in time (variance x{f:.1}): a model error more than noise; the stds are widened by it",
                    robot.joint_names[j]
                ));
            }
        }
    }
    notes.push(format!(
        "every gain scales with the payload mass given ({} kg): an error of x % in it is an error of x % in every gain; the stds cover the current noise, not that",
        payload.mass
    ));
    notes
}

/// One `gains` run: the two logs, how they are read, the payload as known, and the JSON file.
#[derive(Clone)]
pub struct GainsJob {
    /// The log without the payload.
    pub unloaded: LogInput,
    /// The log with the payload on the last link.
    pub loaded: LogInput,
    /// How log files are read (`effort` picks the current: [`LogInput::load_current`]).
    pub source: LogSource,
    /// The payload.
    pub payload: KnownPayload,
    /// Options.
    pub opts: GainsOptions,
    /// The JSON report.
    pub json: Option<PathBuf>,
}

/// Runs `job` on `robot`, then writes its report.
pub fn gains_job(robot: &Robot, job: &GainsJob) -> Result<Outcome<GainsReport>> {
    let (unloaded, from_u) = read(robot, job, &job.unloaded, "unloaded log")?;
    let (loaded, from_l) = read(robot, job, &job.loaded, "loaded log")?;
    let mut rep = drive_gains(robot, &unloaded, &loaded, &job.payload, &job.opts)?;
    rep.unloaded.current_from = from_u.into();
    rep.loaded.current_from = from_l.into();
    let mut written = vec![];
    if let Some(p) = &job.json {
        write_json(p, &rep)?;
        written.push(format!("report written to {}", p.display()));
    }
    Ok(Outcome { report: rep, written })
}

/// A log of `job` with its current as the effort, and which signal that is.
fn read<'a>(
    robot: &Robot,
    job: &GainsJob,
    input: &'a LogInput,
    what: &str,
) -> Result<(Cow<'a, JointLog>, &'static str)> {
    let _st = input.path().map(|p| Stage::begin(&job.opts.progress, &format!("reading {}", p.display()), 0));
    input.load_current(robot, &job.source, what)
}

//! Fleet identification, the engine-neutral part: a function from one log to its
//! sufficient statistics ([`log_stats`]), an associative merge of statistics
//! ([`LogStats::merge`]) and a fit of merged statistics with covariances ([`fit_stats`]).
//! A distributed engine (the Ray driver in `python/ivdyn/fleet`, or a process pool) maps
//! logs to statistics, ships them as bytes ([`LogStats::to_bytes`]) and reduces them per
//! robot and period in any tree: the fit depends on the rows only, not on the order.
//!
//! A log's statistics are those of `identify` on that log alone, with no held-out tail
//! (every row is fitted) and Coulomb friction as `sign(qd)` (the shape is not chosen per
//! log: every log of a fleet must share one parameter layout). With `stream` (the Python
//! default), an MCAP file is streamed as
//! the streamed `identify` streams it ([`super::stream`]: the same hygiene, conditioning,
//! parallel filter, decimation and dropped edge rows, in memory bounded by the stream's
//! buffers whatever the log's length); CSV files, arrays and files the stream cannot take
//! (uneven stamps, motor currents) are prepared in memory as `identify --in-memory` does
//! ([`super::prepare`]); the two agree to about 1e-6 of a standard deviation (both take the
//! log's velocity where it agrees with the positions; the stream checks it on its first
//! 10 000 samples, the in-memory path on the whole log). The statistics
//! of several logs are those of their rows concatenated, each log conditioned on its own
//! (a log boundary is a segment break: no filter and no lagged product spans it).

use serde::{Deserialize, Serialize};

use super::identify::{
    CoulombMode, FitData, IdentifyOptions, IdentifyReport, Method, finish_identify, identify_base, split_ranges,
    starting_shapes,
};
use super::io::{LogInput, LogSource};
use super::prepare::prepare;
use super::stream::{self, Streamed};
use crate::Robot;
use crate::error::{Error, Result};
use crate::ident::BaseParams;
use crate::ident::joint_acc::{JointAccs, JointStats, hac_lags};
use crate::log::JointLog;
use crate::prep;

/// Version of the byte format of [`LogStats`] (bumped on any change of its meaning).
pub const STATS_FORMAT: u32 = 2;
/// First bytes of serialised statistics.
const MAGIC: &[u8; 8] = b"IVDYNFS\0";

/// What statistics depend on besides the data: two sets of statistics merge only when
/// these are equal. `kinematics` is a hash of the joint kinds, axes, placements and
/// gravity (the regressor's geometry); `parameters` the base parameters' names (their
/// coefficients carry the geometry too) and `drive_terms` the drive model.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ModelFingerprint {
    /// Robot name (URDF `<robot name>`).
    pub robot: String,
    /// Joint names, base to tip.
    pub joints: Vec<String>,
    /// FNV-1a 64 hash of the kinematics, hex.
    pub kinematics: String,
    /// Base parameter names (the parameter layout).
    pub parameters: Vec<String>,
    /// Drive terms per joint (`fc`, `fv`, ...).
    pub drive_terms: Vec<String>,
}

impl ModelFingerprint {
    /// The fingerprint of `robot` with base parameters `base` and the drive terms of `opts`.
    pub fn of(robot: &Robot, base: &BaseParams, opts: &IdentifyOptions) -> Self {
        let c = robot.model.to_chain();
        let text = format!("{:?}|{:?}|{:?}", c.joints, c.x_tree, c.gravity);
        ModelFingerprint {
            robot: robot.name.clone(),
            joints: robot.joint_names.clone(),
            kinematics: format!("{:016x}", fnv1a(text.as_bytes())),
            parameters: base.names.clone(),
            drive_terms: opts.drive.names(),
        }
    }

    /// The model in a few words, for errors that name both sides of a mismatch.
    pub fn describe(&self) -> String {
        format!(
            "robot '{}' (joints {}, kinematics {}, {} base parameters, drive terms {})",
            self.robot,
            self.joints.join(","),
            self.kinematics,
            self.parameters.len(),
            self.drive_terms.join(",")
        )
    }
}

/// FNV-1a, 64 bits: a stable hash (the standard library's may change between releases).
fn fnv1a(bytes: &[u8]) -> u64 {
    bytes.iter().fold(0xcbf2_9ce4_8422_2325, |h, &b| (h ^ u64::from(b)).wrapping_mul(0x0100_0000_01b3))
}

/// One log behind a set of statistics.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct LogInfo {
    /// The log's name (its path or URI, as the caller gave it).
    pub name: String,
    /// Rows fitted (after decimation and the dropped edges).
    pub samples: usize,
    /// Sample time of the fitted rows (s, after decimation).
    pub dt: f64,
    /// Decimation factor.
    pub factor: usize,
    /// Cut-off of the parallel filter (Hz).
    pub cutoff_hz: f64,
    /// Time of the first and the last sample (s since the Unix epoch for MCAP logs; the
    /// log's own time for CSV and arrays).
    pub span_s: (f64, f64),
    /// Streamed (an MCAP file, bounded memory) or read into memory (CSV, arrays, a file
    /// the stream cannot take: the reason is in `notes`).
    pub streamed: bool,
    /// What conditioning did that is worth a remark.
    pub notes: Vec<String>,
}

/// Sufficient statistics of one or more logs of one robot model: per joint the triangular
/// factor of the (base regressor | torque) rows, the torque sums and the lagged products
/// of the residual's autocovariance ([`JointAccs`]), the logs they came from and the
/// model's fingerprint.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct LogStats {
    /// The model the rows were built with.
    pub model: ModelFingerprint,
    /// The logs, ordered by start time then name (the same whatever the merge order).
    pub logs: Vec<LogInfo>,
    /// Rows per joint.
    pub samples: usize,
    joints: Vec<JointStats>,
}

impl LogStats {
    /// "arm-07.mcap" or "3 logs (arm-07.mcap ... arm-07-3.mcap)": names these statistics in errors.
    pub fn label(&self) -> String {
        match self.logs.as_slice() {
            [one] => one.name.clone(),
            [first, .., last] => format!("{} logs ({} ... {})", self.logs.len(), first.name, last.name),
            [] => "(no logs)".into(),
        }
    }

    /// The statistics as bytes: [`MAGIC`], [`STATS_FORMAT`] (u32, little-endian), then
    /// JSON (floats written to round-trip exactly).
    pub fn to_bytes(&self) -> Result<Vec<u8>> {
        let mut out = MAGIC.to_vec();
        out.extend_from_slice(&STATS_FORMAT.to_le_bytes());
        serde_json::to_writer(&mut out, self)
            .map_err(|e| Error::Stats { what: self.label(), msg: format!("cannot serialise: {e}") })?;
        Ok(out)
    }

    /// Statistics from [`to_bytes`](Self::to_bytes); `what` names the source in errors.
    /// Refuses other data, another format version and damaged bytes.
    pub fn from_bytes(bytes: &[u8], what: &str) -> Result<Self> {
        let err = |msg: String| Error::Stats { what: what.into(), msg };
        if bytes.len() < 12 || &bytes[..8] != MAGIC {
            return Err(err("not ivdyn fleet statistics (no IVDYNFS header)".into()));
        }
        let version = u32::from_le_bytes(bytes[8..12].try_into().expect("4 bytes"));
        if version != STATS_FORMAT {
            return Err(err(format!(
                "format version {version}, but this ivdyn reads version {STATS_FORMAT}: compute the statistics again with this version"
            )));
        }
        let s: LogStats = serde_json::from_slice(&bytes[12..]).map_err(|e| err(format!("damaged: {e}")))?;
        s.accs().map_err(|e| err(format!("damaged: {e}")))?;
        Ok(s)
    }

    /// Merges `other` into `self`: afterwards `self` holds the statistics of both sets of
    /// rows (associative and, to rounding, commutative). Statistics of another model are
    /// refused with an error naming both.
    pub fn merge(&mut self, other: &LogStats) -> Result<()> {
        self.check_model(&other.model, &other.label())?;
        let mut acc = self.accs()?;
        acc.merge(&other.accs()?)?;
        self.joints = acc.joint_stats();
        self.samples = acc.samples();
        self.logs.extend(other.logs.iter().cloned());
        sort_logs(&mut self.logs);
        Ok(())
    }

    /// The merge of all `parts` (at least one), pairwise in a balanced tree.
    pub fn merge_all(mut parts: Vec<LogStats>) -> Result<LogStats> {
        if parts.is_empty() {
            return Err(Error::Stats { what: "(none)".into(), msg: "nothing to merge".into() });
        }
        while parts.len() > 1 {
            let mut next = Vec::with_capacity(parts.len().div_ceil(2));
            let mut it = parts.into_iter();
            while let Some(mut a) = it.next() {
                if let Some(b) = it.next() {
                    a.merge(&b)?;
                }
                next.push(a);
            }
            parts = next;
        }
        Ok(parts.pop().expect("one left"))
    }

    /// Error unless `model` is this statistics' model.
    fn check_model(&self, model: &ModelFingerprint, other: &str) -> Result<()> {
        if *model == self.model {
            return Ok(());
        }
        Err(Error::Stats {
            what: self.label(),
            msg: format!(
                "built with {}; {other} built with {}: statistics of different models cannot be combined",
                self.model.describe(),
                model.describe()
            ),
        })
    }

    /// The statistics as accumulators.
    fn accs(&self) -> Result<JointAccs> {
        if self.joints.len() != self.model.joints.len() {
            return Err(Error::Dimension {
                what: "joint statistics (one per joint of the model)".into(),
                expected: self.model.joints.len(),
                got: self.joints.len(),
            });
        }
        JointAccs::from_joint_stats(self.model.parameters.len(), self.samples, &self.joints)
    }
}

/// The model statistics are built and fitted with: Coulomb friction as `sign(qd)` (or the
/// model's shapes with [`CoulombMode::Model`]) and its base parameters. Refuses options
/// that need the data again (IV, IDIM-IV) or a validation log.
pub(crate) fn fleet_model(robot: &Robot, opts: &IdentifyOptions) -> Result<(Robot, BaseParams)> {
    opts.check()?;
    if !matches!(opts.method, Method::Ols | Method::Wls) {
        return Err(Error::Option {
            option: "method".into(),
            msg: format!("'{}' iterates over the data; fleet statistics fit 'ols' or 'wls'", opts.method.name()),
        });
    }
    if opts.validation_log.is_some() {
        return Err(Error::Option {
            option: "validation_log".into(),
            msg: "is not used by fleet statistics (every row of every log is fitted)".into(),
        });
    }
    let mode = if opts.coulomb == CoulombMode::Model { CoulombMode::Model } else { CoulombMode::Sign };
    let robot = starting_shapes(robot, mode)?;
    let base = identify_base(&robot, opts)?;
    Ok((robot, base))
}

/// Adds the rows of the log `input` to `acc` (created when `None`) as one more segment;
/// `name` names the log. With `stream`, an MCAP file is streamed ([`stream::fit_rows_mcap`]:
/// bounded memory, the rows of the streamed `identify`); otherwise, and for CSV, arrays, and
/// a file the stream cannot take (uneven stamps, motor currents, ...), the log is read into
/// memory ([`add_in_memory`]). Both take the log's velocity where it agrees with the
/// positions: differentiated 18-bit encoder positions miscalibrate the drift tests of the
/// inertial parameters (docs/fleet.md, "Memory"). `robot` and `base` as [`fleet_model`]
/// makes them.
#[allow(clippy::too_many_arguments)]
fn add_log(
    acc: &mut Option<JointAccs>,
    robot: &Robot,
    base: &BaseParams,
    input: &LogInput,
    src: &LogSource,
    name: &str,
    opts: &IdentifyOptions,
    stream: bool,
) -> Result<LogInfo> {
    let mut why_not = if stream { src.in_memory_reason() } else { Some("streaming is off".into()) };
    if let (Some(path), None) = (input.mcap_path(), &why_not) {
        let read = src.read_options(robot);
        match stream::fit_rows_mcap(robot, base, path, &read, opts, acc.as_ref()).map_err(|e| input.context(e))? {
            Streamed::Done(r) => {
                let before = acc.as_ref().map_or(0, JointAccs::samples);
                let info = LogInfo {
                    name: name.into(),
                    samples: r.fit.samples() - before,
                    dt: r.dt,
                    factor: r.factor,
                    cutoff_hz: r.cutoff_hz,
                    span_s: (r.span_ns.0 as f64 * 1e-9, r.span_ns.1 as f64 * 1e-9),
                    streamed: true,
                    notes: r.notes,
                };
                *acc = Some(r.fit);
                return Ok(info);
            }
            Streamed::Unsupported(why) => why_not = Some(why),
        }
    }
    let log = input.load(robot, src)?;
    let mut info = add_in_memory(acc, robot, base, &log, name, opts).map_err(|e| input.context(e))?;
    if let (Some(why), Some(_), true) = (why_not, input.path(), stream) {
        info.notes.push(format!("read into memory (not streamed): {why}"));
    }
    Ok(info)
}

/// [`add_log`] of a log in memory, conditioned as the in-memory `identify` does it.
fn add_in_memory(
    acc: &mut Option<JointAccs>,
    robot: &Robot,
    base: &BaseParams,
    log: &JointLog,
    name: &str,
    opts: &IdentifyOptions,
) -> Result<LogInfo> {
    let (n, b) = (robot.dof(), base.base_count());
    let p = prepare(robot, &base.independent, &[log], opts, "log")?;
    let every_row = IdentifyOptions { validation_fraction: 0.0, ..IdentifyOptions::default() };
    let (range, _) = split_ranges(p.len(), &every_row);
    let lags = hac_lags(p.dt, p.cutoff_hz);
    let acc = acc.get_or_insert_with(|| JointAccs::new(n, b, false).with_lags(lags));
    // the lags every log has, as a merge keeps them
    acc.keep_lags(lags);
    let before = acc.samples();
    super::identify::accumulate(acc, &p, range, false)?;
    let t0 = log.t0_ns as f64 * 1e-9;
    let mut notes = p.notes.clone();
    notes.extend(super::identify::conditioning_notes(&p.conditioning));
    Ok(LogInfo {
        name: name.into(),
        samples: acc.samples() - before,
        dt: p.dt,
        factor: p.factor,
        cutoff_hz: p.cutoff_hz,
        span_s: (t0 + log.t.first().copied().unwrap_or(0.0), t0 + log.t.last().copied().unwrap_or(0.0)),
        streamed: false,
        notes,
    })
}

/// The sufficient statistics of one log (see the module docs), read from a file or given
/// as arrays; `name` names it in the statistics and in errors; `stream`: stream an MCAP
/// file (bounded memory; see [`add_log`] for why it is not the default).
pub fn log_stats(
    robot: &Robot,
    log: &LogInput,
    src: &LogSource,
    name: &str,
    opts: &IdentifyOptions,
    stream: bool,
) -> Result<LogStats> {
    let (robot, base) = fleet_model(robot, opts)?;
    let mut acc = None;
    let info = add_log(&mut acc, &robot, &base, log, src, name, opts, stream)?;
    stats_of(&robot, &base, opts, acc, vec![info])
}

/// The statistics of `logs` (name, log) in one process and one pass over their rows, log
/// after log, each read as [`log_stats`] reads it (what [`LogStats::merge`] of their
/// [`log_stats`] equals, to rounding; the in-process engine).
pub fn logs_stats(
    robot: &Robot,
    logs: &[(&str, &LogInput)],
    src: &LogSource,
    opts: &IdentifyOptions,
    stream: bool,
) -> Result<LogStats> {
    let (robot, base) = fleet_model(robot, opts)?;
    let mut acc = None;
    let mut infos = vec![];
    for (name, log) in logs {
        let e = |e: Error| Error::Stats { what: name.to_string(), msg: e.to_string() };
        infos.push(add_log(&mut acc, &robot, &base, log, src, name, opts, stream).map_err(e)?);
    }
    sort_logs(&mut infos);
    stats_of(&robot, &base, opts, acc, infos)
}

/// By start time, then name: one order whatever order the logs came in.
fn sort_logs(logs: &mut [LogInfo]) {
    logs.sort_by(|a, b| a.span_s.0.total_cmp(&b.span_s.0).then_with(|| a.name.cmp(&b.name)));
}

fn stats_of(
    robot: &Robot,
    base: &BaseParams,
    opts: &IdentifyOptions,
    acc: Option<JointAccs>,
    logs: Vec<LogInfo>,
) -> Result<LogStats> {
    let acc = acc.ok_or_else(|| Error::Stats { what: "(none)".into(), msg: "no logs".into() })?;
    Ok(LogStats {
        model: ModelFingerprint::of(robot, base, opts),
        logs,
        samples: acc.samples(),
        joints: acc.joint_stats(),
    })
}

/// A fit of merged statistics.
#[derive(Debug, Clone, Serialize)]
pub struct FleetFit {
    /// `identify`'s report of the fit (base parameters with standard deviations, the
    /// covariance in `fit_report`, the parameter file in `params`).
    pub report: IdentifyReport,
    /// Per joint, the long-run variance factor of the residual
    /// ([`JointAccs::long_run_factor`]) at the estimate: the iid covariance understates
    /// the variance of the estimate by about this factor when the residual is correlated.
    pub long_run: Vec<f64>,
    /// The covariance of the base parameters (rows of `report.base`; `NaN`, i.e. JSON
    /// `null`, for the unexcited ones): the report keeps it out of its JSON.
    pub covariance: Vec<Vec<f64>>,
    /// The logs fitted.
    pub logs: Vec<LogInfo>,
}

/// Fits `stats` with `robot`'s model (which must be the one the statistics were built
/// with) as `identify` fits one log's statistics (`opts.method`: `ols` or `wls`).
pub fn fit_stats(robot: &Robot, stats: &LogStats, opts: &IdentifyOptions) -> Result<FleetFit> {
    let (robot, base) = fleet_model(robot, opts)?;
    stats.check_model(&ModelFingerprint::of(&robot, &base, opts), &format!("the model of {}", robot.name))?;
    let first = stats.logs.first().ok_or_else(|| Error::Stats { what: stats.label(), msg: "no logs".into() })?;
    let mut notes = vec![format!("fleet statistics of {}: {} rows per joint", stats.label(), stats.samples)];
    if stats.logs.iter().any(|l| l.dt != first.dt || l.factor != first.factor) {
        notes.push("the logs differ in sample time or decimation: the reported rate is the first log's".into());
    }
    let acc = stats.accs()?;
    let data = FitData {
        fit: acc.clone(),
        validation: None,
        instrument: None,
        dt: first.dt,
        factor: first.factor,
        cutoff_hz: first.cutoff_hz,
        idim: None,
        notes,
        conditioning: prep::ConditionSummary {
            hygiene: prep::Hygiene::default(),
            duplicate_stamps: 0,
            resampled: false,
            dt: first.dt / first.factor as f64,
            velocity: vec![],
        },
    };
    let report = finish_identify(&robot, &base, opts, data)?;
    // unexcited parameters (no estimate) at their nominal values, as identify's residuals
    let theta: Vec<f64> = report.base.iter().map(|v| if v.value.is_nan() { v.nominal } else { v.value }).collect();
    let long_run = (0..robot.dof()).map(|i| acc.long_run_factor(i, &theta)).collect();
    let cov = &report.fit_report.as_ref().expect("finish_identify keeps its fit").covariance;
    let covariance = cov.row_iter().map(|r| r.iter().copied().collect()).collect();
    Ok(FleetFit { report, long_run, covariance, logs: stats.logs.clone() })
}

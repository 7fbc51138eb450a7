//! `identify` on an MCAP log of any length with bounded memory: the log is read, conditioned,
//! turned into regressor rows, parallel-filtered, decimated and accumulated block by
//! block, and nothing of length `T` is ever held.
//!
//! The steps and their numbers are those of [`super::identify::identify`] on the whole log:
//!
//! 1. a reader thread decodes the messages ([`crate::log::for_each_sample`]) in batches;
//! 2. duplicated stamps are dropped; the sample time is the median interval of the first
//!    [`DT_PROBE`] samples (the whole log's median when it is shorter) and every interval
//!    must be within `max_jitter` of it: a log that needs resampling is reported as
//!    [`Streamed::Unsupported`] (the caller reads it into memory instead);
//! 3. `q` is smoothed with the zero-phase Butterworth and differentiated
//!    ([`crate::prep::stream::StreamCondition`], block-wise `filtfilt`, see [`crate::prep::filtfilt`]);
//!    on the joints where the log's velocity is consistent with the positions' derivative
//!    the log's velocity is smoothed and differentiated instead, as in memory
//!    ([`crate::prep::velocity`]), the choice made on the probe's samples (the in-memory
//!    path makes it on the whole log);
//! 4. base regressor rows (and the instrument rows: the nominal model tracking the
//!    measured motion, [`crate::ident::instrument::Tracker`], state carried across blocks) are stacked with
//!    the torque and parallel-filtered and decimated by [`crate::prep::filtfilt::StreamFiltfilt`] on two
//!    threads (columns split in two); entries of the regressor that are structurally zero
//!    (a joint's row never depends on the links before it) are not filtered;
//! 5. decimated rows go to per-joint accumulators ([`JointAccs`]): the fit part, and the
//!    held-out tail (the split is placed from the message count in the MCAP summary);
//! 6. the fits, the DWH test and the quality figures come from the accumulators
//!    ([`super::identify::finish_identify`], shared with the in-memory path).
//!
//! The instrument streamed is the nominal model's (it serves the DWH test of `ols`/`wls`,
//! identical to the in-memory path's); `--method iv`, whose instrument is the simulated
//! *identified* model, iterated, needs the data again each round and is not streamed.
//!
//! What is not streamed (use [`super::identify::identify`]): IDIM-IV and IV (iterate over the data), a
//! command topic, torque outlier rejection, Savitzky-Golay differentiation, a forced
//! resampling step, and logs with uneven stamps.

use std::collections::VecDeque;
use std::path::{Path, PathBuf};
use std::sync::mpsc::{Receiver, sync_channel};

use super::identify::{FitData, IdentifyOptions, IdentifyReport, Method};
use crate::Robot;
use crate::dsp::{self, Butterworth, DiffMethod};
use crate::error::{Error, Result};
use crate::ident::BaseParams;
use crate::ident::instrument::Tracker;
use crate::ident::joint_acc::JointAccs;
use crate::log::{ReadOptions, StreamSummary, for_each_sample};
use crate::prep;
use crate::prep::filtfilt::StreamFiltfilt;
use crate::prep::stream::{CondRows, StreamCondition};
use crate::progress::Stage;

/// Samples whose median interval is the sample time.
pub const DT_PROBE: usize = 10_000;
/// Samples per batch from the reader thread, and per conditioned block.
const BATCH: usize = 4096;
/// Rows finished per block by the stream filters.
const FILTER_BLOCK: usize = 16384;
/// Samples stacked and filtered at a time.
const SUB_BLOCK: usize = 2048;
/// Samples per regressor call when packing (below `batch::threads_for`'s threshold: one
/// thread; `14 N` columns of 120 samples stay in the L2 cache).
const PACK_CHUNK: usize = 120;

/// Outcome of a streaming run.
#[derive(Debug)]
pub enum Streamed<T> {
    /// Done.
    Done(T),
    /// This log or these options need the in-memory path; the reason in words.
    Unsupported(String),
}

/// Why `opts` cannot be streamed (`None`: they can).
pub fn unsupported(opts: &IdentifyOptions, read: &ReadOptions) -> Option<String> {
    if opts.method == Method::IdimIv {
        return Some("IDIM-IV iterates over the data".into());
    }
    if opts.method == Method::Iv {
        return Some("IV simulates the identified model over the data, round after round".into());
    }
    if read.command_topic.is_some() {
        return Some("a command topic is aligned in memory".into());
    }
    if read.current_topic.is_some() {
        return Some("motor currents are turned into torques in memory".into());
    }
    if opts.condition.tau_outliers.is_some() {
        return Some("torque outlier rejection".into());
    }
    if opts.condition.dt.is_some() {
        return Some("a forced resampling step".into());
    }
    if opts.condition.window.is_some() {
        return Some("a time window".into());
    }
    if !matches!(opts.condition.diff, DiffMethod::Butterworth { .. }) {
        return Some("Savitzky-Golay differentiation".into());
    }
    if opts.validation_log.is_some() {
        return Some("an in-memory validation log".into());
    }
    None
}

/// Measured messages on `topic` in the log at `path` (an MCAP file or a ROS 2 bag):
/// [`crate::log::message_count`] (`None` when unknown, e.g. an interrupted recording).
pub fn message_count(path: &Path, topic: &str) -> Result<Option<u64>> {
    crate::log::message_count(path, topic)
}

// ---------------------------------------------------------------------------------------
// Reader thread and conditioning front
// ---------------------------------------------------------------------------------------

/// Decoded messages, in the wanted joint order.
struct RawBatch {
    stamps: Vec<i64>,
    q: Vec<f64>,
    qd: Option<Vec<f64>>,
    tau: Option<Vec<f64>>,
}

/// Starts the reader thread: batches of [`BATCH`] messages over a bounded channel (at
/// most two batches in flight). The thread's result is the reader's.
fn spawn_reader(
    path: &Path,
    read: &ReadOptions,
) -> (Receiver<RawBatch>, std::thread::JoinHandle<Result<StreamSummary>>) {
    let (tx, rx) = sync_channel::<RawBatch>(2);
    let (path, read) = (path.to_path_buf(), read.clone());
    let h = std::thread::spawn(move || {
        let new = || RawBatch { stamps: Vec::with_capacity(BATCH), q: vec![], qd: None, tau: None };
        let mut cur = new();
        let r = for_each_sample(&path, &read, |s| {
            cur.stamps.push(s.stamp_ns);
            cur.q.extend_from_slice(s.q.unwrap_or(&[]));
            for (dst, src) in [(&mut cur.qd, s.qd), (&mut cur.tau, s.tau)] {
                if let Some(v) = src {
                    dst.get_or_insert_with(Vec::new).extend_from_slice(v);
                }
            }
            if cur.stamps.len() == BATCH {
                let full = std::mem::replace(&mut cur, new());
                tx.send(full).map_err(|_| Error::internal("streaming: the fitting side stopped before the reader"))?;
            }
            Ok(())
        });
        if r.is_ok() && !cur.stamps.is_empty() {
            let _ = tx.send(cur);
        }
        r
    });
    (rx, h)
}

/// Conditioned samples in order (from sample `first`), with what was measured at them.
#[derive(Debug, Default)]
struct Block {
    first: usize,
    c: CondRows,
    tau: Vec<f64>,
    stamps: Vec<i64>,
    q_raw: Vec<f64>,
    qd_raw: Vec<f64>,
}

impl Block {
    fn len(&self, n: usize) -> usize {
        self.tau.len() / n
    }
}

/// Deduplication, sample-time check and conditioning of the raw stream.
struct Front {
    n: usize,
    joints: Vec<String>,
    file: PathBuf,
    max_jitter: f64,
    diff: (usize, Option<f64>),
    /// Where the velocity comes from (`--velocity`), and the choice per joint once made.
    policy: prep::VelocitySource,
    velocity: Vec<prep::VelocityChoice>,
    /// Samples kept until the sample time is known.
    probe: Vec<RawBatch>,
    probed: usize,
    t0: Option<i64>,
    last: Option<i64>,
    dt: Option<f64>,
    cond: Option<StreamCondition>,
    /// Measured rows not yet matched by a conditioned row.
    fifo_tau: VecDeque<f64>,
    fifo_stamp: VecDeque<i64>,
    fifo_q: VecDeque<f64>,
    fifo_qd: VecDeque<f64>,
    has_qd: bool,
    samples: usize,
    duplicates: usize,
    emitted: usize,
    /// Raw samples received (the index the hygiene errors name).
    received: usize,
    /// Joints whose torque was nonzero somewhere ([`prep::hygiene::zero_torque_check`]).
    nonzero: Vec<bool>,
    /// Re-published samples ([`prep::hygiene::repeated_samples`]), and the row compared.
    repeat: prep::hygiene::RepeatWatch,
    row: Vec<f64>,
    /// The last raw positions received (a wrapped angle is a step from them).
    q_prev: Vec<f64>,
}

impl Front {
    fn new(joints: &[String], file: &Path, opts: &IdentifyOptions) -> Self {
        let n = joints.len();
        let diff = match opts.condition.diff {
            DiffMethod::Butterworth { order, cutoff_hz } => (order, cutoff_hz),
            _ => (dsp::DEFAULT_ORDER, None),
        };
        Front {
            n,
            joints: joints.to_vec(),
            file: file.to_path_buf(),
            max_jitter: opts.condition.max_jitter,
            diff,
            policy: opts.condition.velocity,
            velocity: vec![],
            probe: vec![],
            probed: 0,
            t0: None,
            last: None,
            dt: None,
            cond: None,
            fifo_tau: VecDeque::new(),
            fifo_stamp: VecDeque::new(),
            fifo_q: VecDeque::new(),
            fifo_qd: VecDeque::new(),
            has_qd: false,
            samples: 0,
            duplicates: 0,
            emitted: 0,
            received: 0,
            nonzero: vec![false; n],
            repeat: Default::default(),
            row: Vec::with_capacity(2 * n),
            q_prev: vec![],
        }
    }

    fn log_err(&self, msg: String) -> Error {
        Error::Log { file: self.file.clone(), msg }
    }

    /// Takes a raw batch; conditioned rows that are final go to `out`. `Ok(Err(reason))`:
    /// the stamps need resampling.
    fn push(&mut self, b: RawBatch, out: &mut Block) -> Result<std::result::Result<(), String>> {
        let Some(tau) = &b.tau else {
            return Err(Error::NoTorque { what: "log".into(), needed_by: "identification".into() });
        };
        // the in-memory path's hygiene rules, on each batch as it comes
        for (field, a) in [("q", Some(&b.q)), ("qd", b.qd.as_ref()), ("tau", Some(tau))] {
            if let Some(a) = a {
                prep::hygiene::magnitude_in(field, a, &self.joints, self.received)
                    .map_err(|e| self.log_err(e.to_string()))?;
            }
        }
        // an angle reported modulo 2 pi: the in-memory path knows which joints are angles
        // and unwraps them (`prep::hygiene::unwrap_angles`)
        let prev = (!self.q_prev.is_empty()).then_some(&self.q_prev[..]);
        if let Some((k, j)) = prep::hygiene::first_wrap(&b.q, self.n, prev) {
            return Ok(Err(format!(
                "joint '{}' steps by more than pi at sample {} (an angle wrapped modulo 2 pi), unwrapped in memory",
                self.joints[j],
                self.received + k
            )));
        }
        if let Some(last) = b.q.rchunks_exact(self.n).next() {
            self.q_prev = last.to_vec();
        }
        prep::hygiene::nonzero_joints(tau, self.n, &mut self.nonzero);
        self.received += b.stamps.len();
        self.has_qd = b.qd.is_some();
        if self.dt.is_none() {
            self.probed += b.stamps.len();
            self.probe.push(b);
            if self.probed >= DT_PROBE {
                return self.start(out);
            }
            return Ok(Ok(()));
        }
        self.feed(b, out)
    }

    /// The sample time from the probe, then the probe is fed.
    fn start(&mut self, out: &mut Block) -> Result<std::result::Result<(), String>> {
        let t0 = self.probe.first().and_then(|b| b.stamps.first().copied()).unwrap_or(0);
        let mut t: Vec<f64> =
            self.probe.iter().flat_map(|b| b.stamps.iter().map(|&s| (s - t0) as f64 * 1e-9)).collect();
        t.dedup();
        let Some(dt) = dsp::median_dt(&t) else {
            return Err(self.log_err(format!(
                "all {} samples have the same stamp (header stamps not set?); try --log-time",
                self.probed
            )));
        };
        // before the filters are designed at 1 / dt: their state grows with the rate
        prep::check_sample_time(dt).map_err(|e| self.log_err(e.to_string()))?;
        self.t0 = Some(t0);
        self.dt = Some(dt);
        let fs = 1.0 / dt;
        let (order, cutoff) = self.diff;
        let f = Butterworth::zero_phase(order, dsp::resolve_cutoff(cutoff, fs)?, fs)?;
        self.velocity = self.decide_velocity(dt)?;
        let log = self.velocity.iter().map(|c| c.source == "log").collect();
        self.cond = Some(StreamCondition::with_log_velocity(&f, self.n, dt, FILTER_BLOCK, log));
        for b in std::mem::take(&mut self.probe) {
            if let Err(why) = self.feed(b, out)? {
                return Ok(Err(why));
            }
        }
        Ok(Ok(()))
    }

    /// The velocity per joint ([`prep::velocity::decide`]), decided on the probe's samples
    /// (duplicated stamps dropped) as the in-memory path decides it on the whole log.
    fn decide_velocity(&self, dt: f64) -> Result<Vec<prep::VelocityChoice>> {
        let n = self.n;
        let (mut q, mut qd, mut last) = (vec![], Some(vec![]), None);
        for b in &self.probe {
            for (k, &s) in b.stamps.iter().enumerate() {
                if last.replace(s) == Some(s) {
                    continue;
                }
                q.extend_from_slice(&b.q[k * n..(k + 1) * n]);
                match (&mut qd, &b.qd) {
                    (Some(v), Some(src)) => v.extend_from_slice(&src[k * n..(k + 1) * n]),
                    _ => qd = None,
                }
            }
        }
        let method = DiffMethod::Butterworth { order: self.diff.0, cutoff_hz: self.diff.1 };
        let lv = match (&qd, self.policy) {
            (Some(v), prep::VelocitySource::Auto | prep::VelocitySource::Log) => Some(
                prep::velocity::LogVelocity::new(v, &self.joints, dt, &method)
                    .map_err(|e| self.log_err(e.to_string()))?,
            ),
            _ => None,
        };
        let d = match &lv {
            Some(_) => dsp::differentiate(&q, n, dt, &method).map_err(|e| self.log_err(e.to_string()))?,
            None => dsp::Derivatives::default(),
        };
        let mut choices = prep::velocity::decide(&[(&d, lv.as_ref())], &self.joints, self.policy)?;
        for c in choices.iter_mut().filter(|c| c.gain.is_some()) {
            c.why = format!("{} (checked on the first {} samples: streamed)", c.why, q.len() / n.max(1));
        }
        Ok(choices)
    }

    fn feed(&mut self, b: RawBatch, out: &mut Block) -> Result<std::result::Result<(), String>> {
        let n = self.n;
        let (t0, dt) = (self.t0.expect("started"), self.dt.expect("started"));
        let tau = b.tau.as_ref().expect("checked");
        let log_qd = self.cond.as_ref().expect("started").needs_velocity();
        if log_qd && b.qd.is_none() {
            return Ok(Err(format!(
                "the log's velocity, taken on some joints, is missing from the messages after sample {}",
                self.samples + self.duplicates
            )));
        }
        let mut q = Vec::with_capacity(b.q.len());
        let mut qd_log = Vec::with_capacity(if log_qd { b.q.len() } else { 0 });
        for (k, &s) in b.stamps.iter().enumerate() {
            if let Some(prev) = self.last {
                if s == prev {
                    self.duplicates += 1;
                    continue;
                }
                let d = (s - t0) as f64 * 1e-9 - (prev - t0) as f64 * 1e-9;
                if (d - dt).abs() > self.max_jitter * dt {
                    return Ok(Err(format!(
                        "uneven stamps: interval {d:.6} s before sample {} (sample time {dt:.6} s); the log needs resampling",
                        self.samples + self.duplicates
                    )));
                }
            }
            // the in-memory path drops re-published samples and resamples the holes
            self.row.clear();
            self.row.extend_from_slice(&b.q[k * n..(k + 1) * n]);
            self.row.extend(b.qd.iter().flat_map(|qd| &qd[k * n..(k + 1) * n]));
            if let Some(run) = self.repeat.push(&self.row) {
                return Ok(Err(format!(
                    "{run} re-published sample(s) (the previous sample repeated under new stamps) before sample {}; the log needs resampling",
                    self.samples + self.duplicates
                )));
            }
            self.last = Some(s);
            self.samples += 1;
            q.extend_from_slice(&b.q[k * n..(k + 1) * n]);
            if log_qd {
                let v = &b.qd.as_ref().expect("checked")[k * n..(k + 1) * n];
                if let Some(j) = v.iter().position(|x| !x.is_finite()) {
                    let k = self.samples + self.duplicates - 1;
                    return Err(self.log_err(format!("sample {k}, joint '{}': velocity is {}", self.joints[j], v[j])));
                }
                qd_log.extend_from_slice(v);
            }
            self.fifo_tau.extend(&tau[k * n..(k + 1) * n]);
            self.fifo_stamp.push_back(s);
            self.fifo_q.extend(&b.q[k * n..(k + 1) * n]);
            if let Some(qd) = &b.qd {
                self.fifo_qd.extend(&qd[k * n..(k + 1) * n]);
            }
        }
        let cond = self.cond.as_mut().expect("started");
        cond.push(&q, log_qd.then_some(&qd_log[..]), &mut out.c);
        self.drain(out);
        Ok(Ok(()))
    }

    /// Ends the stream (a log shorter than the probe is conditioned here).
    fn finish(&mut self, out: &mut Block) -> Result<std::result::Result<(), String>> {
        prep::hygiene::zero_torque_check(&self.nonzero, &self.joints, self.received)
            .map_err(|e| self.log_err(e.to_string()))?;
        if self.dt.is_none() {
            if self.probed < 2 {
                return Err(self.log_err(format!("only {} samples", self.probed)));
            }
            if let Err(why) = self.start(out)? {
                return Ok(Err(why));
            }
        }
        self.cond.as_mut().expect("started").finish(&mut out.c);
        self.drain(out);
        Ok(Ok(()))
    }

    /// Matches the new conditioned rows of `out` with their measured rows.
    fn drain(&mut self, out: &mut Block) {
        let n = self.n;
        let rows = out.c.q.len() / n - out.tau.len() / n;
        for _ in 0..rows {
            out.tau.extend(self.fifo_tau.drain(..n));
            out.stamps.push(self.fifo_stamp.pop_front().expect("aligned"));
            out.q_raw.extend(self.fifo_q.drain(..n));
            if self.has_qd {
                out.qd_raw.extend(self.fifo_qd.drain(..n));
            }
        }
        self.emitted += rows;
    }
}

/// What streaming did to a log: duplicated stamps dropped, the velocity per joint.
fn streamed_summary(info: &PassInfo) -> prep::ConditionSummary {
    prep::ConditionSummary {
        hygiene: prep::Hygiene::default(),
        duplicate_stamps: info.duplicates,
        resampled: false,
        dt: info.dt,
        velocity: info.velocity.clone(),
    }
}

/// What a pass over a log found.
struct PassInfo {
    dt: f64,
    /// Samples after dropping duplicated stamps.
    samples: usize,
    duplicates: usize,
    truncated: bool,
    /// Stamps of the first and the last sample kept (ns).
    span_ns: (i64, i64),
    /// The velocity per joint.
    velocity: Vec<prep::VelocityChoice>,
}

/// Reads and conditions the log at `path` block by block, calling `sink` with each
/// block of conditioned samples (at most [`BATCH`]-ish samples, in order).
fn conditioned_pass(
    path: &Path,
    read: &ReadOptions,
    opts: &IdentifyOptions,
    stage: Option<&Stage>,
    mut sink: impl FnMut(&Block, f64) -> Result<()>,
) -> Result<Streamed<PassInfo>> {
    let n = read.joint_names.len();
    let (rx, reader) = spawn_reader(path, read);
    let mut front = Front::new(&read.joint_names, path, opts);
    let mut block = Block::default();
    let mut first = 0;
    let mut outcome: Result<std::result::Result<(), String>> = Ok(Ok(()));
    let mut flush = |block: &mut Block, front: &Front, first: &mut usize| -> Result<()> {
        let rows = block.len(n);
        if rows == 0 {
            return Ok(());
        }
        block.first = *first;
        sink(block, front.dt.expect("rows imply a sample time"))?;
        *first += rows;
        *block = Block::default();
        Ok(())
    };
    for b in rx.iter() {
        if let Some(st) = stage {
            st.advance(b.stamps.len() as u64);
        }
        match front.push(b, &mut block) {
            Ok(Ok(())) => {}
            other => {
                outcome = other;
                break;
            }
        }
        if block.len(n) >= BATCH
            && let Err(e) = flush(&mut block, &front, &mut first)
        {
            outcome = Err(e);
            break;
        }
    }
    drop(rx); // stops the reader if we broke off
    let summary = reader.join().unwrap_or_else(|p| std::panic::resume_unwind(p));
    match outcome {
        Ok(Ok(())) => {}
        Ok(Err(why)) => return Ok(Streamed::Unsupported(why)),
        Err(e) => return Err(e),
    }
    let summary = summary?;
    match front.finish(&mut block)? {
        Ok(()) => {}
        Err(why) => return Ok(Streamed::Unsupported(why)),
    }
    flush(&mut block, &front, &mut first)?;
    Ok(Streamed::Done(PassInfo {
        dt: front.dt.expect("finished"),
        samples: front.samples,
        duplicates: front.duplicates,
        truncated: summary.truncated,
        span_ns: (front.t0.expect("finished"), front.last.expect("finished")),
        velocity: std::mem::take(&mut front.velocity),
    }))
}

// ---------------------------------------------------------------------------------------
// Regressor rows, parallel filter, decimation
// ---------------------------------------------------------------------------------------

/// Stacks `[Y (packed) | Z (packed) | tau]` rows of conditioned blocks and runs them
/// through the parallel filter, two column groups on two threads.
struct Stacker<'a> {
    robot: &'a Robot,
    base: &'a BaseParams,
    n: usize,
    /// Indices (into a sample's `n x b` base rows) of the entries that are not
    /// structurally zero.
    packed: Vec<usize>,
    tracker: Option<Tracker>,
    groups: Vec<(std::ops::Range<usize>, StreamFiltfilt)>,
    width: usize,
    /// Packers of the regressor and of the instrument rows (one each: they run in parallel).
    py: RowPacker<'a>,
    pz: RowPacker<'a>,
    /// Work buffers, kept between blocks.
    y: Vec<f64>,
    z: Vec<f64>,
}

/// Entries of the `n x b` base regressor rows that are zero at every one of 32 random
/// states: structural zeros (joint `i`'s row does not depend on the links before it, nor
/// on the other joints' drive parameters). They are checked to stay zero in the data.
fn structural_nonzeros(robot: &Robot, base: &BaseParams) -> Result<Vec<usize>> {
    let (n, p, b) = (robot.dof(), robot.num_params(), base.base_count());
    let mut rng = ivdyn_core::rng::Rng::new(7);
    let mut nz = vec![false; n * b];
    for _ in 0..32 {
        let mut state = || (0..n).map(|_| rng.uniform(-3.0, 3.0)).collect::<Vec<f64>>();
        let (q, qd, qdd) = (state(), state(), state());
        let y = robot.regressor(&q, &qd, &qdd)?;
        for i in 0..n {
            for (c, &col) in base.independent.iter().enumerate() {
                nz[i * b + c] |= y[i * p + col] != 0.0;
            }
        }
    }
    Ok((0..n * b).filter(|&k| nz[k]).collect())
}

/// Base regressor rows, packed to the entries that are not structurally zero.
struct RowPacker<'a> {
    robot: &'a Robot,
    base: &'a BaseParams,
    /// Index of each packed entry in a sample's full `n x 14n` regressor rows.
    src: Vec<usize>,
    /// The packed entries as indices into a sample's `n x b` base rows (ascending).
    packed: Vec<usize>,
    checked: bool,
    /// Work buffer (full regressor rows), kept between blocks.
    full: Vec<f64>,
}

impl RowPacker<'_> {
    /// Base regressor rows of the samples, packed: `T x C`. The entries taken as
    /// structural zeros are checked on the first block.
    fn rows(&mut self, q: &[f64], qd: &[f64], qdd: &[f64], first: usize, out: &mut Vec<f64>) -> Result<()> {
        let (n, p, b) = (self.robot.dof(), self.robot.num_params(), self.base.base_count());
        let t = q.len() / n;
        let c = self.src.len();
        out.clear();
        out.resize(t * c, 0.0);
        // small chunks: the full rows stay in cache between writing and gathering (and
        // run on this thread: the data and the instrument rows are built in parallel)
        for s in (0..t).step_by(PACK_CHUNK) {
            let e = (s + PACK_CHUNK).min(t);
            self.full.resize((e - s) * n * p, 0.0);
            let r = s * n..e * n;
            crate::batch::regressor_batch(self.robot, &q[r.clone()], &qd[r.clone()], &qdd[r], &mut self.full, false)
                .map_err(|e| match e {
                    Error::Sample { index, source } => Error::Sample { index: index + first + s, source },
                    e => e,
                })?;
            for (o, y) in out[s * c..e * c].chunks_exact_mut(c).zip(self.full.chunks_exact(n * p)) {
                for (o, &i) in o.iter_mut().zip(&self.src) {
                    *o = y[i];
                }
            }
        }
        if !self.checked {
            self.full.resize(t * n * p, 0.0);
            crate::batch::regressor_batch(self.robot, q, qd, qdd, &mut self.full, false)?;
            self.checked = true;
            for (k, y) in self.full.chunks_exact(n * p).enumerate() {
                for i in 0..n {
                    for (c, &col) in self.base.independent.iter().enumerate() {
                        let v = y[i * p + col];
                        if v != 0.0 && self.packed.binary_search(&(i * b + c)).is_err() {
                            return Err(Error::internal(format!(
                                "sample {}: regressor entry (joint {i}, base parameter {c}) taken as structurally zero is {v}",
                                first + k
                            )));
                        }
                    }
                }
            }
        }
        Ok(())
    }
}

impl<'a> Stacker<'a> {
    fn new(robot: &'a Robot, base: &'a BaseParams, dt: f64, dec: &dsp::Decimator, instrument: bool) -> Result<Self> {
        let n = robot.dof();
        let packed = structural_nonzeros(robot, base)?;
        let c = packed.len();
        let width = c * if instrument { 2 } else { 1 } + n;
        let half = width.div_ceil(2);
        let groups = [0..half, half..width]
            .into_iter()
            .map(|r| {
                let f = StreamFiltfilt::new(&dec.filter, r.len(), dec.factor, FILTER_BLOCK);
                (r, f)
            })
            .collect();
        let (p, b) = (robot.num_params(), base.base_count());
        let src: Vec<usize> = packed.iter().map(|&k| (k / b) * p + base.independent[k % b]).collect();
        let tracker = instrument.then(|| Tracker::new(dt));
        let py = RowPacker { robot, base, src, packed: packed.clone(), checked: false, full: vec![] };
        let pz = RowPacker { robot, base, src: py.src.clone(), packed: packed.clone(), checked: false, full: vec![] };
        Ok(Stacker { robot, base, n, packed, tracker, groups, width, py, pz, y: vec![], z: vec![] })
    }

    /// Filters a conditioned block; decimated rows (`width` wide) with their decimated
    /// index go to `out`.
    fn push(&mut self, blk: &Block, out: &mut Vec<(usize, Vec<f64>)>) -> Result<()> {
        let n = self.n;
        let t = blk.len(n);
        // sub-blocks keep the work buffers small
        for s in (0..t).step_by(SUB_BLOCK) {
            let e = (s + SUB_BLOCK).min(t);
            let r = s * n..e * n;
            self.push_rows(
                blk.first + s,
                &blk.c.q[r.clone()],
                &blk.c.qd[r.clone()],
                &blk.c.qdd[r.clone()],
                &blk.tau[r],
                out,
            )?;
        }
        Ok(())
    }

    fn push_rows(
        &mut self,
        first: usize,
        q: &[f64],
        qd: &[f64],
        qdd: &[f64],
        tau: &[f64],
        out: &mut Vec<(usize, Vec<f64>)>,
    ) -> Result<()> {
        let n = self.n;
        let t = tau.len() / n;
        let (mut y, mut z) = (std::mem::take(&mut self.y), std::mem::take(&mut self.z));
        let iv = self.tracker.is_some();
        let robot = self.robot;
        let (py, pz, tracker) = (&mut self.py, &mut self.pz, self.tracker.as_mut());
        // the instrument (a sequential simulation) on its own thread, beside the regressor
        std::thread::scope(|s| -> Result<()> {
            let zz = &mut z;
            let hz = tracker.map(|tr| {
                s.spawn(move || -> Result<()> {
                    let (qz, qdz, qddz) = tr.run(robot, q, qd, qdd)?;
                    pz.rows(&qz, &qdz, &qddz, first, zz)
                })
            });
            let ry = py.rows(q, qd, qdd, first, &mut y);
            if let Some(h) = hz {
                h.join().unwrap_or_else(|p| std::panic::resume_unwind(p))?;
            }
            ry
        })?;
        let c = self.packed.len();
        let parts: [(&[f64], usize); 3] = [(&y, c), (if iv { &z } else { &[] }, if iv { c } else { 0 }), (tau, n)];
        self.filter(&parts, t, false, out);
        (self.y, self.z) = (y, z);
        Ok(())
    }

    fn finish(&mut self, out: &mut Vec<(usize, Vec<f64>)>) {
        self.filter(&[], 0, true, out);
    }

    /// Runs the column groups (two threads) on the `t` rows `[part 0 | part 1 | ...]`
    /// (each part row-major with its width) and joins their decimated rows.
    fn filter(&mut self, parts: &[(&[f64], usize)], t: usize, finish: bool, out: &mut Vec<(usize, Vec<f64>)>) {
        let width = self.width;
        let results: Vec<(Vec<usize>, Vec<f64>)> = std::thread::scope(|s| {
            let hs: Vec<_> = self
                .groups
                .iter_mut()
                .map(|(r, f)| {
                    s.spawn(move || {
                        // this group's columns of the concatenated rows, straight from the parts
                        let mut off = 0;
                        let mut pieces = vec![];
                        for &(x, w) in parts {
                            let (a, b) = (r.start.max(off), r.end.min(off + w));
                            if a < b {
                                pieces.push((x, w, a - off, b - off));
                            }
                            off += w;
                        }
                        let (mut idx, mut rows) = (vec![], vec![]);
                        let mut take = |g: usize, row: &[f64]| {
                            idx.push(g);
                            rows.extend_from_slice(row);
                        };
                        let fill = |k: usize, dst: &mut Vec<f64>| {
                            for &(x, w, a, b) in &pieces {
                                dst.extend_from_slice(&x[k * w + a..k * w + b]);
                            }
                        };
                        f.push_with(t, fill, &mut take);
                        if finish {
                            f.finish(&mut take);
                        }
                        (idx, rows)
                    })
                })
                .collect();
            hs.into_iter().map(|h| h.join().unwrap_or_else(|p| std::panic::resume_unwind(p))).collect()
        });
        let (idx0, rows0) = &results[0];
        let (idx1, rows1) = &results[1];
        debug_assert_eq!(idx0, idx1);
        let (m0, m1) = (self.groups[0].0.len(), self.groups[1].0.len());
        let factor = self.groups[0].1.factor();
        debug_assert_eq!(m0 + m1, width);
        for (k, &g) in idx0.iter().enumerate() {
            let mut row = Vec::with_capacity(width);
            row.extend_from_slice(&rows0[k * m0..(k + 1) * m0]);
            row.extend_from_slice(&rows1[k * m1..(k + 1) * m1]);
            out.push((g / factor, row));
        }
    }

    /// Unpacks decimated rows into `phi` (`T x n x b`), `z` and `tau` (`T x n`).
    fn unpack(&self, rows: &[Vec<f64>], phi: &mut Vec<f64>, z: &mut Vec<f64>, tau: &mut Vec<f64>) {
        let (n, b, c) = (self.n, self.base.base_count(), self.packed.len());
        for row in rows {
            let at = phi.len();
            phi.resize(at + n * b, 0.0);
            for (k, &idx) in self.packed.iter().enumerate() {
                phi[at + idx] = row[k];
            }
            let mut off = c;
            if self.tracker.is_some() {
                let at = z.len();
                z.resize(at + n * b, 0.0);
                for (k, &idx) in self.packed.iter().enumerate() {
                    z[at + idx] = row[c + k];
                }
                off += c;
            }
            tau.extend_from_slice(&row[off..off + n]);
        }
    }
}

/// Routes decimated rows: the first `edge` dropped, the last `edge` held back (dropped at
/// the end), the rest to the fit (index `< cut`) or the held-out statistics.
struct Route {
    edge: usize,
    cut: Option<usize>,
    pending: VecDeque<(usize, Vec<f64>)>,
    fit: JointAccs,
    val: Option<JointAccs>,
}

impl Route {
    fn take(&mut self, st: &Stacker, rows: Vec<(usize, Vec<f64>)>) -> Result<()> {
        let (mut fit_rows, mut val_rows) = (vec![], vec![]);
        for (d, row) in rows {
            if d < self.edge {
                continue;
            }
            self.pending.push_back((d, row));
            if self.pending.len() > self.edge {
                let (d, row) = self.pending.pop_front().expect("non-empty");
                match self.cut {
                    Some(c) if d >= c => val_rows.push(row),
                    _ => fit_rows.push(row),
                }
            }
        }
        for (rows, acc) in [(fit_rows, Some(&mut self.fit)), (val_rows, self.val.as_mut())] {
            let Some(acc) = acc else { continue };
            if rows.is_empty() {
                continue;
            }
            let (mut phi, mut z, mut tau) = (vec![], vec![], vec![]);
            st.unpack(&rows, &mut phi, &mut z, &mut tau);
            let zz = if acc.has_iv() { Some(&z[..]) } else { None };
            acc.add(&phi, zz, &tau)?;
        }
        Ok(())
    }
}

/// Statistics of one streamed log: conditioned, stacked, filtered, decimated, routed.
struct Accumulated {
    fit: JointAccs,
    val: Option<JointAccs>,
    info: PassInfo,
    dec: dsp::Decimator,
    decimated: usize,
    /// Decimated samples expected from the message count.
    expected: usize,
}

#[allow(clippy::too_many_arguments)]
fn accumulate(
    robot: &Robot,
    base: &BaseParams,
    path: &Path,
    read: &ReadOptions,
    opts: &IdentifyOptions,
    instrument: bool,
    holdout: bool,
    what: &str,
    samples: Option<usize>,
    start: Option<&JointAccs>,
) -> Result<Streamed<Accumulated>> {
    let n = robot.dof();
    let b = base.base_count();
    let Some(hint) = samples
        .map_or_else(|| Ok(message_count(path, &read.topic)?.map(|c| c as usize)), |s| Ok::<_, Error>(Some(s)))?
    else {
        return Ok(Streamed::Unsupported(format!(
            "{what}: message count unknown (an MCAP file without summary statistics, a bag without metadata.yaml)"
        )));
    };
    let st = Stage::begin(&opts.progress, &format!("{what}: streaming"), hint as u64);
    let mut state: Option<(Stacker, Route, dsp::Decimator)> = None;
    let mut decimated = 0usize;
    let mut expected = 0;
    let pass = conditioned_pass(path, read, opts, Some(&st), |blk, dt| {
        if state.is_none() {
            let dec = prep::parallel_filter(opts.decimate, 1.0 / dt, hint, &opts.condition)?;
            let stacker = Stacker::new(robot, base, dt, &dec, instrument)?;
            // the split of the in-memory path, placed from the message count
            expected = hint.div_ceil(dec.factor);
            let split = IdentifyOptions {
                validation_fraction: if holdout { opts.validation_fraction } else { 0.0 },
                ..IdentifyOptions::default()
            };
            let (fit, val) = super::identify::split_ranges(expected, &split);
            let (edge, cut) = (fit.start, val.map(|v| v.start));
            let lags = crate::ident::joint_acc::hac_lags(dt * dec.factor as f64, dec.filter.cutoff_hz);
            let fit = match start {
                // this log's rows after those of `start`, as one more segment
                Some(a) => {
                    let mut a = a.clone();
                    a.gap();
                    a.keep_lags(lags);
                    a
                }
                None => JointAccs::new(n, b, instrument).with_lags(lags),
            };
            let route =
                Route { edge, cut, pending: VecDeque::new(), fit, val: cut.map(|_| JointAccs::new(n, b, false)) };
            state = Some((stacker, route, dec));
        }
        let (stacker, route, _) = state.as_mut().expect("set");
        let mut rows = vec![];
        stacker.push(blk, &mut rows)?;
        decimated += rows.len();
        route.take(stacker, rows)
    })?;
    let info = match pass {
        Streamed::Done(i) => i,
        Streamed::Unsupported(why) => return Ok(Streamed::Unsupported(why)),
    };
    let (mut stacker, mut route, dec) = state.ok_or_else(|| Error::ShortLog {
        what: what.to_string(),
        samples: 0,
        needed: 1,
        needed_by: "identification".into(),
    })?;
    let mut rows = vec![];
    stacker.finish(&mut rows);
    decimated += rows.len();
    route.take(&stacker, rows)?;
    Ok(Streamed::Done(Accumulated { fit: route.fit, val: route.val, info, dec, decimated, expected }))
}

/// What a streamed pass did to the log that is worth a remark.
fn pass_notes(a: &Accumulated) -> Vec<String> {
    let mut notes = vec![];
    if a.info.truncated {
        notes.push("the log was truncated; only the samples before the damage were used".into());
    }
    if a.info.duplicates > 0 {
        notes.push(format!("{} samples with a duplicated stamp were dropped", a.info.duplicates));
    }
    notes
}

/// One log's fitted rows, streamed: what fleet statistics take from a log file.
pub(crate) struct StreamedRows {
    /// The statistics given as `start`, then this log's rows (one more segment).
    pub fit: JointAccs,
    /// Sample time of the fitted rows (s, after decimation).
    pub dt: f64,
    /// Decimation factor and the parallel filter's cut-off (Hz).
    pub factor: usize,
    pub cutoff_hz: f64,
    /// Stamps of the first and the last sample (ns).
    pub span_ns: (i64, i64),
    /// What the pass did worth a remark.
    pub notes: Vec<String>,
}

/// The rows of the MCAP log at `path` as [`identify_mcap`] fits them with no held-out
/// tail (every row but the dropped edges, no instrument), added to (a copy of) `start` as
/// one more segment: no filter and no lagged product spans the two. `robot` and `base` as
/// the fit uses them (Coulomb shapes already chosen).
pub(crate) fn fit_rows_mcap(
    robot: &Robot,
    base: &BaseParams,
    path: &Path,
    read: &ReadOptions,
    opts: &IdentifyOptions,
    start: Option<&JointAccs>,
) -> Result<Streamed<StreamedRows>> {
    if let Some(why) = unsupported(opts, read) {
        return Ok(Streamed::Unsupported(why));
    }
    let mut a = match accumulate(robot, base, path, read, opts, false, false, "log", None, start)? {
        Streamed::Done(a) => a,
        Streamed::Unsupported(w) => return Ok(Streamed::Unsupported(w)),
    };
    // the dropped edges depend on the row count (`split_ranges`): when the message count
    // overstated it (duplicated stamps, a truncated file), once more with the count known
    if a.expected != a.decimated {
        a = match accumulate(robot, base, path, read, opts, false, false, "log", Some(a.info.samples), start)? {
            Streamed::Done(a) => a,
            Streamed::Unsupported(w) => return Ok(Streamed::Unsupported(w)),
        };
    }
    let mut notes = pass_notes(&a);
    notes.extend(super::identify::conditioning_notes(&streamed_summary(&a.info)));
    Ok(Streamed::Done(StreamedRows {
        dt: a.info.dt * a.dec.factor as f64,
        factor: a.dec.factor,
        cutoff_hz: a.dec.filter.cutoff_hz,
        span_ns: a.info.span_ns,
        notes,
        fit: a.fit,
    }))
}

/// [`super::identify::identify`] streamed from the MCAP file `path` (and the validation log
/// `validation`, if any), with bounded memory. The numbers are those of the in-memory
/// path to rounding (see the module docs for what differs and what is not streamed).
pub fn identify_mcap(
    robot: &Robot,
    path: &Path,
    validation: Option<&Path>,
    read: &ReadOptions,
    opts: &IdentifyOptions,
) -> Result<Streamed<IdentifyReport>> {
    opts.check()?;
    if let Some(why) = unsupported(opts, read) {
        return Ok(Streamed::Unsupported(why));
    }
    if read.joint_names != robot.joint_names {
        return Err(Error::JointMismatch {
            what: "log".into(),
            log: read.joint_names.clone(),
            robot: robot.joint_names.clone(),
        });
    }
    let robot = &super::identify::starting_shapes(robot, opts.coulomb)?;
    let base = {
        let _st = Stage::begin(&opts.progress, "base parameters", 0);
        super::identify::identify_base(robot, opts)?
    };
    let holdout = validation.is_none();
    let mut main = match accumulate(robot, &base, path, read, opts, true, holdout, "log", None, None)? {
        Streamed::Done(a) => a,
        Streamed::Unsupported(w) => return Ok(Streamed::Unsupported(w)),
    };
    // duplicated stamps (or a truncated file) make the message count overstate the
    // samples: the held-out tail is then placed again from the count now known, in a
    // second pass, so that it is the in-memory path's tail exactly
    if holdout && main.expected != main.decimated {
        let samples = Some(main.info.samples);
        main =
            match accumulate(robot, &base, path, read, opts, true, holdout, "log (split placed again)", samples, None)?
            {
                Streamed::Done(a) => a,
                Streamed::Unsupported(w) => return Ok(Streamed::Unsupported(w)),
            };
    }
    let mut notes = vec![];
    if opts.coulomb == super::identify::CoulombMode::Auto {
        notes.push("Coulomb friction kept as sign(qd): a streamed log is not held to choose its shape per joint (--in-memory chooses it)".into());
    }
    notes.extend(pass_notes(&main));
    if main.expected != main.decimated {
        notes.push(format!(
            "the fit/validation split was placed from the message count in the MCAP summary ({} decimated samples expected, {} found)",
            main.expected,
            main.decimated
        ));
    }
    let validation = match validation {
        Some(v) => match accumulate(robot, &base, v, read, opts, false, false, "validation log", None, None)? {
            Streamed::Done(a) => Some(("validation log".to_string(), a.fit)),
            Streamed::Unsupported(w) => return Ok(Streamed::Unsupported(format!("validation log: {w}"))),
        },
        None => main.val.map(|v| (format!("tail {:.0}% of the log", 100.0 * opts.validation_fraction), v)),
    };
    let instrument = Some(crate::ident::instrument::TRACKING_INSTRUMENT.to_string());
    let data = FitData {
        fit: main.fit,
        validation,
        instrument,
        dt: main.info.dt * main.dec.factor as f64,
        factor: main.dec.factor,
        cutoff_hz: main.dec.filter.cutoff_hz,
        idim: None,
        notes,
        conditioning: streamed_summary(&main.info),
    };
    let mut rep = super::identify::finish_identify(robot, &base, opts, data)?;
    rep.streamed = true;
    Ok(Streamed::Done(rep))
}

/// [`super::identify::write_prediction`] streamed: reads and conditions the MCAP log at `log`
/// block by block and writes measured, predicted (`rnea` of `model`) and residual torques
/// to `out`. Returns the samples written.
pub fn write_prediction_mcap(
    out: &Path,
    model: &Robot,
    log: &Path,
    read: &ReadOptions,
    opts: &IdentifyOptions,
) -> Result<Streamed<usize>> {
    if let Some(why) = unsupported(opts, read) {
        return Ok(Streamed::Unsupported(why));
    }
    let n = model.dof();
    let st =
        Stage::begin(&opts.progress, "writing the prediction", message_count(log, &read.topic)?.unwrap_or(0) as u64);
    let mut w = crate::log::PredictionWriter::create(out, &model.joint_names)?;
    let mut pred = vec![];
    let pass = conditioned_pass(log, read, opts, Some(&st), |blk, _| {
        pred.resize(blk.c.q.len(), 0.0);
        let t = blk.len(n);
        crate::batch::rnea_batch(model, &blk.c.q[..t * n], &blk.c.qd[..t * n], &blk.c.qdd[..t * n], &mut pred)?;
        w.write_block(&blk.stamps, &blk.q_raw, &blk.qd_raw, &blk.tau, &blk.c.q[..t * n], &blk.c.qd[..t * n], &pred)
    })?;
    match pass {
        Streamed::Done(_) => {
            let k = w.samples();
            w.finish()?;
            Ok(Streamed::Done(k))
        }
        // dropping the writer removes its staged file
        Streamed::Unsupported(why) => Ok(Streamed::Unsupported(why)),
    }
}

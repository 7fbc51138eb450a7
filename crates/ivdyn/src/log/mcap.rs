//! Streaming reader of ROS 2 MCAP logs (`sensor_msgs/msg/JointState`, CDR).
//!
//! The file is read in one pass through [`mcap::sans_io::LinearReader`] with a 256 KiB
//! buffer: memory stays bounded by the largest chunk record (ros2 bag writes 1 MiB chunks
//! by default), whatever the file size. Chunked, uncompressed, zstd and lz4 files are read.
//! Chunk CRCs are checked when the writer stored them.
//!
//! Summary and index records are not needed and not used, so a log whose recording was
//! interrupted (no footer) can still be read with [`ReadOptions::allow_truncated`].

use std::collections::HashMap;
use std::fs::File;
use std::io::{BufReader, Read};
use std::path::{Path, PathBuf};

use super::mcap_rec::{Rec, bounded, each_record};
use ::mcap::McapError;
use ::mcap::sans_io::linear_reader::{LinearReadEvent, LinearReader, LinearReaderOptions};

use super::cdr::{JointState, decode_joint_state_into};
use super::{first_duplicate, name_list};
use crate::error::{Error, Result};

/// The schema names accepted for JointState (ROS 2, and the ROS 1 spelling some
/// converters keep).
pub const JOINT_STATE_SCHEMAS: [&str; 2] = ["sensor_msgs/msg/JointState", "sensor_msgs/JointState"];

/// Which field of the command topic's JointState is the actuator input `u`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum CommandField {
    /// `position` (position-controlled drives).
    Position,
    /// `velocity`.
    Velocity,
    /// `effort` (torque or current command, the paper's input): the default.
    #[default]
    Effort,
}

/// How command samples are aligned to the measurement stamps.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum CommandAlign {
    /// The last command at or before each measurement stamp (what a drive does with a
    /// sampled command); the default. Measurements before the first command take the first.
    #[default]
    ZeroOrderHold,
    /// Linear interpolation between the two commands around each measurement stamp,
    /// held constant outside the command's time span.
    Linear,
}

/// Options of [`super::read_mcap`] and [`super::for_each_sample`].
#[derive(Debug, Clone, PartialEq)]
pub struct ReadOptions {
    /// The measured JointState topic (default `/joint_states`).
    pub topic: String,
    /// An optional second JointState topic carrying the actuator command `u`.
    pub command_topic: Option<String>,
    /// An optional JointState topic whose `effort` field is the motor current (A), read
    /// into [`JointLog::current`] (aligned to the measurement stamps by linear
    /// interpolation). It may be the measured topic itself, for drives that publish their
    /// current as effort: its effort is then the current, and the log has no torque.
    pub current_topic: Option<String>,
    /// Which field of the command messages is `u` (default: effort).
    pub command_field: CommandField,
    /// Alignment of commands to measurement stamps (default: zero-order hold).
    pub command_align: CommandAlign,
    /// The joints wanted, in the order wanted (normally `Robot::joint_names`). Each must
    /// be in every message; other joints in the log are ignored.
    pub joint_names: Vec<String>,
    /// Use the MCAP log time (when the recorder received the message) instead of the
    /// message's `header.stamp` (when the driver sampled it, the default). Use it when
    /// the driver leaves the stamp at zero.
    pub use_log_time: bool,
    /// Accept a file that ends in the middle of a record (an interrupted recording):
    /// keep the messages read before the cut and set [`JointLog::truncated`]. Default
    /// false: a truncated file is an error.
    pub allow_truncated: bool,
}

impl ReadOptions {
    /// Defaults (`/joint_states`, header stamps, no command topic) for these joints.
    pub fn new<S: AsRef<str>>(joint_names: &[S]) -> Self {
        ReadOptions {
            topic: "/joint_states".into(),
            command_topic: None,
            current_topic: None,
            command_field: CommandField::Effort,
            command_align: CommandAlign::ZeroOrderHold,
            joint_names: joint_names.iter().map(|s| s.as_ref().to_string()).collect(),
            use_log_time: false,
            allow_truncated: false,
        }
    }
    /// Sets the measured topic.
    pub fn topic(mut self, topic: &str) -> Self {
        self.topic = topic.into();
        self
    }
    /// Sets the command topic.
    pub fn command_topic(mut self, topic: &str) -> Self {
        self.command_topic = Some(topic.into());
        self
    }
    /// Sets (or clears) the command topic.
    pub fn command_topic_opt(mut self, topic: Option<&str>) -> Self {
        self.command_topic = topic.map(Into::into);
        self
    }
    /// Sets (or clears) the current topic ([`ReadOptions::current_topic`]).
    pub fn current_topic_opt(mut self, topic: Option<&str>) -> Self {
        self.current_topic = topic.map(Into::into);
        self
    }
    /// Stamps from the MCAP log times instead of the headers ([`ReadOptions::use_log_time`]).
    pub fn log_time(mut self, yes: bool) -> Self {
        self.use_log_time = yes;
        self
    }
}

/// Which topic a streamed [`Sample`] comes from.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Source {
    /// The measured topic ([`ReadOptions::topic`]).
    Measured,
    /// The command topic ([`ReadOptions::command_topic`]).
    Command,
    /// The current topic ([`ReadOptions::current_topic`], when it is not the measured one);
    /// the current is in [`Sample::tau`].
    Current,
}

/// One decoded message, in the joint order of [`ReadOptions::joint_names`].
#[derive(Debug, Clone, Copy)]
pub struct Sample<'a> {
    /// Which topic.
    pub source: Source,
    /// Index of this message within its topic (0-based).
    pub index: usize,
    /// Time in nanoseconds (header stamp, or log time with `use_log_time`).
    pub stamp_ns: i64,
    /// Positions; always present for [`Source::Measured`].
    pub q: Option<&'a [f64]>,
    /// Velocities, if the message has them.
    pub qd: Option<&'a [f64]>,
    /// Efforts, if the message has them.
    pub tau: Option<&'a [f64]>,
}

/// What a streaming pass found.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct StreamSummary {
    /// Messages on the measured topic.
    pub measured: usize,
    /// Messages on the command topic.
    pub commands: usize,
    /// Every topic in the file with its schema name, in order of appearance.
    pub topics: Vec<(String, String)>,
    /// The file ended mid-record and `allow_truncated` accepted it.
    pub truncated: bool,
    /// Bytes read (of every file of a bag).
    pub bytes: u64,
    /// How the log's files were found, when the user should know (e.g. a bag directory
    /// without `metadata.yaml`).
    pub notes: Vec<String>,
}

/// Per-topic decoding state: name mapping cache, stamp order, field presence.
struct TopicState {
    topic: String,
    source: Source,
    count: usize,
    last_stamp: Option<i64>,
    cached_names: Vec<String>,
    map: Vec<usize>,
    has_qd: Option<bool>,
    has_tau: Option<bool>,
    q: Vec<f64>,
    qd: Vec<f64>,
    tau: Vec<f64>,
    /// Messages that name none of the wanted joints (another publisher on the topic, e.g. a
    /// gripper's beside the arm's), skipped; and the joints the first of them names.
    foreign: usize,
    foreign_names: Vec<String>,
}

impl TopicState {
    fn new(topic: &str, source: Source, n: usize) -> Self {
        TopicState {
            topic: topic.into(),
            source,
            count: 0,
            last_stamp: None,
            cached_names: vec![],
            map: vec![],
            has_qd: None,
            has_tau: None,
            q: vec![0.0; n],
            qd: vec![0.0; n],
            tau: vec![0.0; n],
            foreign: 0,
            foreign_names: vec![],
        }
    }

    /// Validates `m` and fills `q/qd/tau` in the wanted joint order; `Ok(false)`: `m` names
    /// none of the wanted joints (another publisher's message, skipped and counted).
    fn load(&mut self, m: &JointState, stamp_ns: i64, want: &[String]) -> std::result::Result<bool, String> {
        let k = self.count;
        let topic = &self.topic;
        if m.name != self.cached_names && !want.is_empty() && !want.iter().any(|w| m.name.contains(w)) {
            if self.foreign == 0 {
                self.foreign_names = m.name.clone();
            }
            self.foreign += 1;
            return Ok(false);
        }
        if m.name != self.cached_names {
            if let Some((name, a, b)) = first_duplicate(&m.name) {
                return Err(format!("topic {topic}, sample {k}: joint '{name}' is named twice (entries {a} and {b})"));
            }
            let mut map = Vec::with_capacity(want.len());
            let mut missing = vec![];
            for w in want {
                match m.name.iter().position(|x| x == w) {
                    Some(i) => map.push(i),
                    None => missing.push(w.as_str()),
                }
            }
            if !missing.is_empty() {
                return Err(format!(
                    "topic {topic}, sample {k}: joints {} are not in the log; the log has {}",
                    name_list(&missing),
                    name_list(&m.name)
                ));
            }
            self.map = map;
            self.cached_names = m.name.clone();
        }
        let nn = m.name.len();
        for (field, len) in [("position", m.position.len()), ("velocity", m.velocity.len()), ("effort", m.effort.len())]
        {
            if len != 0 && len != nn {
                return Err(format!("topic {topic}, sample {k}: {field} has {len} entries for {nn} joint names"));
            }
        }
        if self.source == Source::Measured && m.position.is_empty() {
            return Err(format!("topic {topic}, sample {k}: position is empty"));
        }
        for (field, len, has) in
            [("velocity", m.velocity.len(), &mut self.has_qd), ("effort", m.effort.len(), &mut self.has_tau)]
        {
            let now = len != 0;
            match *has {
                None => *has = Some(now),
                Some(before) if before != now => {
                    return Err(format!(
                        "topic {topic}, sample {k}: {field} is {} but was {} in sample 0",
                        if now { "present" } else { "empty" },
                        if before { "present" } else { "empty" }
                    ));
                }
                _ => {}
            }
        }
        if let Some(prev) = self.last_stamp
            && stamp_ns < prev
        {
            return Err(format!(
                "topic {topic}, sample {k}: stamp goes back in time ({} s, {:.9} s before sample {})",
                fmt_stamp(stamp_ns),
                (prev - stamp_ns) as f64 * 1e-9,
                k - 1
            ));
        }
        self.last_stamp = Some(stamp_ns);
        for (field, src, dst) in [
            ("position", &m.position, &mut self.q),
            ("velocity", &m.velocity, &mut self.qd),
            ("effort", &m.effort, &mut self.tau),
        ] {
            if src.is_empty() {
                continue;
            }
            for (j, &i) in self.map.iter().enumerate() {
                let v = src[i];
                if !v.is_finite() {
                    return Err(format!("topic {topic}, sample {k}: joint '{}' {field} is {v}", want[j]));
                }
                dst[j] = v;
            }
        }
        Ok(true)
    }

    fn sample(&self, stamp_ns: i64, m: &JointState) -> Sample<'_> {
        Sample {
            source: self.source,
            index: self.count,
            stamp_ns,
            q: (!m.position.is_empty()).then_some(&self.q[..]),
            qd: (!m.velocity.is_empty()).then_some(&self.qd[..]),
            tau: (!m.effort.is_empty()).then_some(&self.tau[..]),
        }
    }
}

fn fmt_stamp(ns: i64) -> String {
    format!("{}.{:09}", ns.div_euclid(1_000_000_000), ns.rem_euclid(1_000_000_000))
}

/// Streams one MCAP file into `pass` (which keeps its topics' state from earlier files).
pub(super) fn stream_mcap_file<F>(pass: &mut Pass<'_>, path: &Path, f: &mut F) -> Result<()>
where
    F: FnMut(&Sample<'_>) -> Result<()>,
{
    let file = File::open(path).map_err(|e| Error::Io { file: path.to_path_buf(), source: e })?;
    let size = file.metadata().map(|m| m.len()).ok();
    pass.begin_file(path);
    stream_into(pass, BufReader::with_capacity(256 * 1024, file), size, f)
}

/// [`super::for_each_sample`] on any byte source (a pipe, a socket, a decompressor); `name` is
/// used in error messages.
pub fn for_each_sample_from<R: Read, F>(source: R, name: &Path, opts: &ReadOptions, f: F) -> Result<StreamSummary>
where
    F: FnMut(&Sample<'_>) -> Result<()>,
{
    let mut f = f;
    let mut pass = Pass::new(name, opts)?;
    pass.begin_file(name);
    stream_into(&mut pass, source, None, &mut f)?;
    pass.finish()
}

/// Largest MCAP record, and largest chunk once decompressed, that is read (bytes): the
/// reader holds one decompressed chunk at a time, so this bounds its memory whatever the
/// file claims (a 157 KB file used to decompress to 930 MB). Recorders write chunks of
/// about 1 MB; 256 MiB leaves room for chunks of camera images beside the joint states.
pub const MAX_MCAP_RECORD: usize = 256 << 20;

/// The streaming pass behind [`super::for_each_sample`]: reads the MCAP bytes `src` (of `size`
/// bytes if known) through a [`LinearReader`] and hands each record to `pass`.
pub(super) fn stream_into<R: Read, F>(pass: &mut Pass<'_>, mut src: R, size: Option<u64>, f: &mut F) -> Result<()>
where
    F: FnMut(&Sample<'_>) -> Result<()>,
{
    let path = pass.path.clone();
    let mut reader = top_level_reader();
    let size_note = size.map(|s| format!(" of {s}")).unwrap_or_default();
    while let Some(ev) = reader.next_event() {
        let ev = match ev {
            Ok(ev) => ev,
            Err(e) => {
                // returns only when a truncated file is accepted
                pass.read_error(e, &size_note)?;
                break;
            }
        };
        match ev {
            LinearReadEvent::ReadRequest(need) => {
                let buf = reader.insert(need);
                let got = read_some(&mut src, buf).map_err(|e| Error::Io { file: path.clone(), source: e })?;
                reader.notify_read(got);
                pass.offset += got as u64;
            }
            LinearReadEvent::Record { opcode, data } => {
                let mut buf = std::mem::take(&mut pass.chunk);
                let at = pass.offset;
                let bad = |e| log_err(&path, format!("corrupt MCAP chunk at or before byte {at}{size_note}: {e}"));
                let walked = each_record(opcode, data, &mut buf, MAX_MCAP_RECORD, |o, d| pass.record(o, d, f), bad);
                pass.chunk = buf;
                walked?
            }
        }
    }
    Ok(())
}

/// A reader of the file's top-level records: chunks are handed over whole (at most
/// [`MAX_MCAP_RECORD`] bytes) and opened by ivdyn (`mcap_rec`): mcap 0.26's own walk
/// through an uncompressed chunk subtracts a record's claimed length from what is left
/// unchecked (a panic, found by the `mcap` fuzz target).
fn top_level_reader() -> LinearReader {
    LinearReader::new_with_options(
        LinearReaderOptions::default().with_emit_chunks(true).with_record_length_limit(MAX_MCAP_RECORD),
    )
}

/// A log error naming the file `path`.
pub(super) fn log_err(path: &Path, msg: String) -> Error {
    Error::Log { file: path.to_path_buf(), msg }
}

/// What a streaming pass keeps between records: schemas, channels, per-topic decoding
/// state and the position in the file. One pass reads the files of a split bag one after
/// the other: the topic state (counts, stamp order) carries over, the ids do not.
pub(super) struct Pass<'o> {
    opts: &'o ReadOptions,
    /// The file being read (named in errors).
    path: PathBuf,
    /// schema id -> (name, encoding), of the current file
    schemas: HashMap<u16, (String, String)>,
    /// channel (MCAP) or topic (sqlite3) id of the current file -> index into `states`
    /// (or None: a topic we ignore)
    channels: HashMap<i64, Option<usize>>,
    /// The measured topic, then the command and current topics if any.
    states: Vec<TopicState>,
    summary: StreamSummary,
    /// one decoded message, overwritten in place by each message (no allocation per message)
    msg: JointState,
    /// Bytes read so far.
    offset: u64,
    /// Records parsed so far.
    records: u64,
    /// Each message's data is zstd-compressed (rosbag2 `compression_mode: message`): the
    /// buffer it is decompressed into.
    unzstd: Option<Vec<u8>>,
    /// The chunk being walked, decompressed (reused from chunk to chunk).
    chunk: Vec<u8>,
}

impl<'o> Pass<'o> {
    /// Checks the options (joint names given, command topic distinct) and sets up the topics.
    pub(super) fn new(path: &Path, opts: &'o ReadOptions) -> Result<Self> {
        if opts.joint_names.is_empty() {
            return Err(log_err(path, "no joint names given to match the log against".into()));
        }
        let n = opts.joint_names.len();
        let mut states = vec![TopicState::new(&opts.topic, Source::Measured, n)];
        if let Some(c) = &opts.command_topic {
            if *c == opts.topic {
                return Err(log_err(path, format!("command topic {c} is the measured topic")));
            }
            states.push(TopicState::new(c, Source::Command, n));
        }
        if let Some(c) = opts.current_topic.as_ref().filter(|c| **c != opts.topic) {
            if opts.command_topic.as_ref() == Some(c) {
                return Err(log_err(path, format!("current topic {c} is the command topic")));
            }
            states.push(TopicState::new(c, Source::Current, n));
        }
        Ok(Pass {
            opts,
            path: path.to_path_buf(),
            schemas: HashMap::new(),
            channels: HashMap::new(),
            states,
            summary: StreamSummary::default(),
            msg: JointState::default(),
            offset: 0,
            records: 0,
            unzstd: None,
            chunk: Vec::new(),
        })
    }

    /// Starts reading `path`, the next file of the log: its ids are its own.
    pub(super) fn begin_file(&mut self, path: &Path) {
        self.path = path.to_path_buf();
        self.summary.bytes += self.offset;
        self.schemas.clear();
        self.channels.clear();
        self.offset = 0;
        self.records = 0;
    }

    /// Messages are zstd-compressed one by one (rosbag2 `compression_mode: message`).
    pub(super) fn set_message_zstd(&mut self, yes: bool) {
        self.unzstd = yes.then(Vec::new);
    }

    /// The id (of the current file) is bound to one of our topics.
    pub(super) fn is_wanted(&self, id: i64) -> bool {
        matches!(self.channels.get(&id), Some(Some(_)))
    }

    /// A log error naming this pass's file.
    pub(super) fn err(&self, msg: String) -> Error {
        log_err(&self.path, msg)
    }

    /// A reader error as the error to report; `Ok` (and `summary.truncated`) when the file
    /// ends mid-record and `allow_truncated` accepts it (past the 8 magic bytes).
    fn read_error(&mut self, e: McapError, size_note: &str) -> Result<()> {
        let (offset, records) = (self.offset, self.records);
        match e {
            McapError::UnexpectedEof | McapError::UnexpectedEoc if self.opts.allow_truncated && offset > 8 => {
                self.summary.truncated = true;
                Ok(())
            }
            McapError::UnexpectedEof => Err(self.err(format!(
                "truncated MCAP: the file ends in the middle of a record at byte {offset} after {records} records \
                 ({} messages on {}); set allow_truncated to keep what was read",
                self.states[0].count, self.opts.topic
            ))),
            McapError::BadMagic => {
                Err(self.err(format!("not an MCAP file (bad magic bytes at the start or end; {offset} bytes read)")))
            }
            McapError::ChunkTooLarge(len) | McapError::RecordTooLarge { len, .. } | McapError::ChunkBufferTooLarge(len) => {
                Err(self.err(format!(
                    "a record or decompressed chunk of {len} bytes at or before byte {offset}{size_note}: at most {MAX_MCAP_RECORD} bytes are read (a corrupt length?)"
                )))
            }
            e => {
                Err(self
                    .err(format!("corrupt MCAP at or before byte {offset}{size_note} (after {records} records): {e}")))
            }
        }
    }

    /// Parses one record: schemas and channels are remembered, messages of our topics
    /// decoded and passed to `f`, everything else skipped.
    fn record<F>(&mut self, opcode: u8, data: &[u8], f: &mut F) -> Result<()>
    where
        F: FnMut(&Sample<'_>) -> Result<()>,
    {
        self.records += 1;
        let (offset, records) = (self.offset, self.records);
        let rec = super::mcap_rec::parse(opcode, data).map_err(|e| {
            self.err(format!("corrupt MCAP record #{records} (opcode {opcode:#04x}) at or before byte {offset}: {e}"))
        })?;
        match rec {
            Rec::Schema { id, name, encoding } => {
                self.schemas.insert(id, (name, encoding));
            }
            Rec::Channel { id, schema_id, topic, message_encoding } => {
                let schema = self.schemas.get(&schema_id).cloned();
                self.bind(i64::from(id), &topic, schema, &message_encoding)?
            }
            Rec::Message { channel_id, log_time, data } => self.message(i64::from(channel_id), log_time, data, f)?,
            Rec::Chunk { .. } | Rec::Other => {}
        }
        Ok(())
    }

    /// Maps the id of a topic of the current file (an MCAP channel, a sqlite3 `topics`
    /// row) to one of our topics, whose schema must be JointState in CDR, or to none;
    /// notes the topic in the summary. `schema`: (name, schema encoding).
    pub(super) fn bind(
        &mut self,
        id: i64,
        topic: &str,
        schema: Option<(String, String)>,
        encoding: &str,
    ) -> Result<()> {
        if self.channels.contains_key(&id) {
            return Ok(()); // repeated in the summary section
        }
        let schema_name = schema.as_ref().map(|s| s.0.clone()).unwrap_or_else(|| "(no schema)".into());
        if !self.summary.topics.iter().any(|(t, _)| *t == topic) {
            self.summary.topics.push((topic.to_string(), schema_name.clone()));
        }
        let which = self.states.iter().position(|s| s.topic == topic);
        if which.is_some() {
            let ok = schema.as_ref().is_some_and(|(name, enc)| {
                JOINT_STATE_SCHEMAS.contains(&name.as_str()) && (enc == "ros2msg" || enc == "ros2idl")
            }) && encoding == "cdr";
            if !ok {
                let enc = schema.as_ref().map(|s| s.1.as_str()).unwrap_or("");
                return Err(self.err(format!(
                    "topic {topic} has schema '{schema_name}' (schema encoding '{enc}', message encoding '{encoding}'); \
                     expected sensor_msgs/msg/JointState (ros2msg, cdr)"
                )));
            }
        }
        self.channels.insert(id, which);
        Ok(())
    }

    /// Decodes a message of the topic `id` (as bound by [`Pass::bind`]), received at
    /// `log_time` (ns), into its [`TopicState`] and calls `f` on it; other topics are skipped.
    pub(super) fn message<F>(&mut self, id: i64, log_time: u64, data: &[u8], f: &mut F) -> Result<()>
    where
        F: FnMut(&Sample<'_>) -> Result<()>,
    {
        let Some(&Some(w)) = self.channels.get(&id) else { return Ok(()) };
        let mut buf = self.unzstd.take();
        let r = self.decode(w, log_time, data, buf.as_mut(), f);
        self.unzstd = buf;
        r
    }

    /// [`Pass::message`] for the topic state `w`; `unzstd`: the buffer to decompress
    /// `data` into first (message-compressed bags).
    fn decode<F>(&mut self, w: usize, log_time: u64, data: &[u8], unzstd: Option<&mut Vec<u8>>, f: &mut F) -> Result<()>
    where
        F: FnMut(&Sample<'_>) -> Result<()>,
    {
        let path = &self.path;
        let st = &mut self.states[w];
        let at = |e: String| log_err(path, format!("topic {}, sample {}: {e}", st.topic, st.count));
        let data = match unzstd {
            Some(buf) => {
                let bad = |e| at(format!("bad zstd-compressed message: {e}"));
                bounded(::zstd::Decoder::new(data).map_err(bad)?, buf, MAX_MCAP_RECORD).map_err(bad)?
            }
            None => data,
        };
        decode_joint_state_into(data, &mut self.msg).map_err(|e| at(format!("bad message: {e}")))?;
        let m = &self.msg;
        let stamp = if self.opts.use_log_time { i64::try_from(log_time).unwrap_or(i64::MAX) } else { m.stamp_ns() };
        if !st.load(m, stamp, &self.opts.joint_names).map_err(|msg| log_err(path, msg))? {
            return Ok(());
        }
        f(&st.sample(stamp, m))?;
        st.count += 1;
        Ok(())
    }

    /// The summary of the pass; an error naming the topic when one of ours had no message
    /// (not in the file, or empty).
    pub(super) fn finish(mut self) -> Result<StreamSummary> {
        self.summary.bytes += self.offset;
        self.summary.measured = self.states[0].count;
        self.summary.commands = self.states.iter().find(|s| s.source == Source::Command).map_or(0, |s| s.count);
        for st in self.states.iter().filter(|st| st.foreign > 0 && st.count > 0) {
            self.summary.notes.push(format!(
                "topic {}: {} message(s) naming none of the chain's joints (the first names {}) skipped: another publisher's",
                st.topic,
                st.foreign,
                name_list(&st.foreign_names)
            ));
        }
        let summary = &self.summary;
        for st in &self.states {
            if st.count > 0 {
                continue;
            }
            if st.foreign > 0 {
                return Err(self.err(format!(
                    "topic {}: none of its {} messages names the chain's joints {}; the first names {}",
                    st.topic,
                    st.foreign,
                    name_list(&self.opts.joint_names),
                    name_list(&st.foreign_names)
                )));
            }
            let known = summary.topics.iter().any(|(t, _)| *t == st.topic);
            let listing = if summary.topics.is_empty() {
                "the log has no topics".to_string()
            } else {
                let l: Vec<String> = summary.topics.iter().map(|(t, s)| format!("{t} ({s})")).collect();
                format!("the log has {}", l.join(", "))
            };
            return Err(self.err(if known {
                format!(
                    "topic {} has no messages{}",
                    st.topic,
                    if summary.truncated { " before the truncation" } else { "" }
                )
            } else {
                format!("topic {} not found; {listing}", st.topic)
            }));
        }
        Ok(self.summary)
    }
}

/// Measured messages on `topic` according to the MCAP summary of the file `path` (`None`
/// when the file has no summary statistics, e.g. an interrupted recording, or a summary
/// that does not parse: the summary is an index, the caller then counts in a pass over the
/// data, which is checked record by record). Read by `mcap_rec` (every length checked) from
/// the footer and the summary section, at most [`MAX_MCAP_RECORD`] bytes of it.
pub(super) fn summary_count(path: &Path, topic: &str) -> Result<Option<u64>> {
    use super::mcap_rec::{FOOTER_LEN, summary_start, summary_topic_count};
    use std::io::{Seek, SeekFrom};
    let io = |e: std::io::Error| Error::Io { file: path.to_path_buf(), source: e };
    let mut file = File::open(path).map_err(io)?;
    let size = file.metadata().map_err(io)?.len();
    if size < (8 + FOOTER_LEN) as u64 {
        return Ok(None);
    }
    let mut tail = [0u8; FOOTER_LEN];
    file.seek(SeekFrom::Start(size - FOOTER_LEN as u64)).map_err(io)?;
    file.read_exact(&mut tail).map_err(io)?;
    let Ok(Some(start)) = summary_start(&tail) else { return Ok(None) };
    let end = size - FOOTER_LEN as u64;
    if start < 8 || start > end || end - start > MAX_MCAP_RECORD as u64 {
        return Ok(None);
    }
    let mut summary = vec![0u8; (end - start) as usize];
    file.seek(SeekFrom::Start(start)).map_err(io)?;
    file.read_exact(&mut summary).map_err(io)?;
    Ok(summary_topic_count(&summary, topic).unwrap_or(None))
}

/// Reads until `buf` is full or EOF (a short read from a pipe is not EOF).
fn read_some<R: Read>(src: &mut R, buf: &mut [u8]) -> std::io::Result<usize> {
    let mut got = 0;
    while got < buf.len() {
        match src.read(&mut buf[got..]) {
            Ok(0) => break,
            Ok(k) => got += k,
            Err(e) if e.kind() == std::io::ErrorKind::Interrupted => {}
            Err(e) => return Err(e),
        }
    }
    Ok(got)
}

/// Lists the topics of an MCAP file with their schema names and message counts (one
/// streaming pass; for error messages and `ivdyn info`).
pub fn list_topics(path: impl AsRef<Path>) -> Result<Vec<(String, String, usize)>> {
    let path: PathBuf = path.as_ref().to_path_buf();
    let file = File::open(&path).map_err(|e| Error::Io { file: path.clone(), source: e })?;
    let mut src = BufReader::with_capacity(256 * 1024, file);
    let mut reader = top_level_reader();
    let mut schemas: HashMap<u16, String> = HashMap::new();
    let mut chan: HashMap<u16, usize> = HashMap::new();
    let mut out: Vec<(String, String, usize)> = vec![];
    let (mut offset, mut buf) = (0u64, vec![]);
    let bad = |offset: u64, e: String| Error::Log {
        file: path.clone(),
        msg: format!("corrupt MCAP at or before byte {offset}: {e}"),
    };
    while let Some(ev) = reader.next_event() {
        match ev.map_err(|e| bad(offset, e.to_string()))? {
            LinearReadEvent::ReadRequest(need) => {
                let got = read_some(&mut src, reader.insert(need))
                    .map_err(|e| Error::Io { file: path.clone(), source: e })?;
                reader.notify_read(got);
                offset += got as u64;
            }
            LinearReadEvent::Record { opcode, data } => {
                let mut count = |opcode: u8, data: &[u8]| {
                    match super::mcap_rec::parse(opcode, data).map_err(|e| bad(offset, e))? {
                        Rec::Schema { id, name, .. } => {
                            schemas.insert(id, name);
                        }
                        Rec::Channel { id, schema_id, topic, .. } => {
                            if let std::collections::hash_map::Entry::Vacant(e) = chan.entry(id) {
                                let s = schemas.get(&schema_id).cloned().unwrap_or_default();
                                let i = out.iter().position(|(t, _, _)| *t == topic).unwrap_or_else(|| {
                                    out.push((topic.clone(), s, 0));
                                    out.len() - 1
                                });
                                e.insert(i);
                            }
                        }
                        Rec::Message { channel_id, .. } => {
                            if let Some(&i) = chan.get(&channel_id) {
                                out[i].2 += 1;
                            }
                        }
                        Rec::Chunk { .. } | Rec::Other => {}
                    }
                    Ok(())
                };
                each_record(opcode, data, &mut buf, MAX_MCAP_RECORD, &mut count, |e| bad(offset, e))?;
            }
        }
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn stamps_print_as_seconds() {
        assert_eq!(fmt_stamp(-1), "-1.999999999");
    }
}

//! Log hygiene: the time window and the excluded spans the user asked for, samples that
//! repeat the previous one under a new stamp (a recorder that published a state the
//! controller had not refreshed), torques stuck at their extreme value (clipped), and
//! standstills. All reported, never silent.

use serde::Serialize;

use crate::error::{Error, Result};
use crate::log::JointLog;

/// Longest run of repeated samples dropped: a longer run of identical rows is a
/// standstill (or a quantised slow joint), which is data.
pub const MAX_REPEAT_RUN: usize = 3;

/// What [`clean`] did to a log.
#[derive(Debug, Clone, Default, PartialEq, Serialize)]
pub struct Hygiene {
    /// The window kept, in seconds from the log's first sample (`null`: the whole log).
    pub window: Option<(f64, f64)>,
    /// Samples outside the window.
    pub outside_window: usize,
    /// Samples dropped as repeats of the previous one (same `q` and `qd`, new stamp,
    /// inside motion).
    pub repeated: usize,
    /// Gaps (intervals of more than `prep::GAP_INTERVALS` sample times) the log was cut at.
    pub gaps: usize,
    /// Segments used.
    pub segments: usize,
    /// Samples in segments between gaps too short to use.
    pub short_samples: usize,
    /// Segments left out because one continuous signal was needed (the longest was kept).
    pub unused_segments: usize,
    /// The spans excluded, in seconds from the log's first sample.
    pub exclude: Vec<(f64, f64)>,
    /// Samples in them.
    pub excluded: usize,
    /// Joints whose torque sits at its extreme value in many samples (clipped?).
    pub clipped: Vec<Clip>,
    /// Seconds of standstill: every joint below [`STANDSTILL_SHARE`] of its RMS velocity
    /// for at least [`STANDSTILL_MIN_S`] (friction and inertia are not excited there).
    pub standstill_s: f64,
}

/// A torque that reaches its extreme value in many samples.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Clip {
    /// Joint name.
    pub joint: String,
    /// The extreme value (N m).
    pub value: f64,
    /// Samples at exactly that value.
    pub samples: usize,
}

/// A joint stands still below this share of its RMS velocity over the log.
pub const STANDSTILL_SHARE: f64 = 0.02;
/// Shortest standstill reported (s).
pub const STANDSTILL_MIN_S: f64 = 0.5;
/// A torque at its extreme value in at least this share of the samples (and 5) is
/// reported as clipped: a measured torque with noise reaches its maximum once.
pub const CLIP_SHARE: f64 = 0.002;

/// Parses a window `START:END` in seconds; either side may be empty (`5:` from 5 s to
/// the end, `:30` the first 30 s).
pub fn parse_window(s: &str) -> Result<(f64, f64)> {
    parse_span(s, "window")
}

/// Parses a span `START:END` (seconds) given to `option`; an empty side is 0 or the end.
pub fn parse_span(s: &str, option: &str) -> Result<(f64, f64)> {
    let bad = || Error::option(option, format!("must be START:END in seconds, got '{s}'"));
    let (a, b) = s.split_once(':').ok_or_else(bad)?;
    let num =
        |x: &str, empty: f64| if x.trim().is_empty() { Ok(empty) } else { x.trim().parse::<f64>().map_err(|_| bad()) };
    Ok((num(a, 0.0)?, num(b, f64::INFINITY)?))
}

/// Indices of the samples with `t - t[0]` in `[start, end]`.
fn window_rows(t: &[f64], (start, end): (f64, f64)) -> Result<Vec<usize>> {
    let bad = |msg: String| Error::option("window", msg);
    if !start.is_finite() || start < 0.0 || end.is_nan() {
        return Err(bad(format!("{start}:{end}: start must be a time >= 0 s and end a later time (s)")));
    }
    if end <= start {
        return Err(bad(format!("{start}:{end}: the end must come after the start")));
    }
    let (t0, span) = match (t.first(), t.last()) {
        (Some(&a), Some(&b)) => (a, b - a),
        _ => return Ok(vec![]),
    };
    if start > span {
        return Err(bad(format!("{start}:{end}: the log lasts {span:.3} s, the window starts after it")));
    }
    Ok((0..t.len()).filter(|&k| (start..=end).contains(&(t[k] - t0))).collect())
}

/// Whether rows `a` and `b` of `q` (and of `qd`, when given) are identical.
fn same_row(q: &[f64], qd: Option<&[f64]>, n: usize, a: usize, b: usize) -> bool {
    let eq = |x: &[f64]| x[a * n..(a + 1) * n] == x[b * n..(b + 1) * n];
    eq(q) && qd.is_none_or(eq)
}

/// Samples that repeat the previous sample's `q` (and `qd`) exactly under a later stamp,
/// in runs of at most [`MAX_REPEAT_RUN`] after which the motion goes on (the row after the
/// run differs from the one before it). Equal stamps are left to `dedup_stamps`, and the
/// "previous sample" is the first of its stamp, the one `dedup_stamps` keeps: a
/// re-published copy of the next sample under the previous stamp must not make the next
/// sample itself look repeated (the streamed path keeps it too).
pub fn repeated_samples(log: &JointLog) -> Vec<usize> {
    let n = log.dof();
    let qd = log.qd.as_deref();
    // the rows dedup_stamps keeps, in order
    let rows: Vec<usize> = (0..log.len()).filter(|&k| k == 0 || log.t[k] != log.t[k - 1]).collect();
    let same = |a: usize, b: usize| same_row(&log.q, qd, n, rows[a], rows[b]);
    let mut out = vec![];
    let mut k = 1;
    while k < rows.len() {
        if !same(k, k - 1) {
            k += 1;
            continue;
        }
        // a run k..end of rows equal to row k - 1
        let mut end = k + 1;
        while end < rows.len() && same(end, k - 1) {
            end += 1;
        }
        if end - k <= MAX_REPEAT_RUN && end < rows.len() {
            out.extend(rows[k..end].iter().copied());
        }
        k = end;
    }
    out
}

/// [`repeated_samples`]' rule as the rows come, for the streamed path (which cannot fill
/// the holes by resampling, so it hands such a log back): `push` returns the length of a
/// run of repeated rows that just ended within [`MAX_REPEAT_RUN`].
#[derive(Debug, Clone, Default)]
pub struct RepeatWatch {
    prev: Vec<f64>,
    run: usize,
}

impl RepeatWatch {
    /// The next kept row (`q`, then `qd` when the log has it).
    pub fn push(&mut self, row: &[f64]) -> Option<usize> {
        if !self.prev.is_empty() && self.prev == row {
            self.run += 1;
            return None;
        }
        let ended = std::mem::take(&mut self.run);
        self.prev.clear();
        self.prev.extend_from_slice(row);
        (1..=MAX_REPEAT_RUN).contains(&ended).then_some(ended)
    }
}

/// Indices of the samples outside every span of `exclude` (seconds from `t0`).
fn outside(t: &[f64], exclude: &[(f64, f64)], t0: f64) -> Result<Vec<usize>> {
    for &(a, b) in exclude {
        if !(a.is_finite() && a >= 0.0 && b > a) {
            return Err(Error::option("exclude", format!("{a}:{b}: must be START:END with 0 <= START < END (s)")));
        }
    }
    Ok((0..t.len()).filter(|&k| !exclude.iter().any(|&(a, b)| (a..=b).contains(&(t[k] - t0)))).collect())
}

/// Joints whose torque is at its largest or smallest value in at least [`CLIP_SHARE`] of
/// the samples (and 5).
pub fn clipped(log: &JointLog) -> Vec<Clip> {
    let (Some(tau), n) = (log.tau.as_deref(), log.dof()) else { return vec![] };
    let t = log.len();
    let least = ((CLIP_SHARE * t as f64).ceil() as usize).max(5);
    let mut out = vec![];
    for j in 0..n {
        let col = || (0..t).map(|k| tau[k * n + j]);
        let (lo, hi) = col().fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), v| (a.min(v), b.max(v)));
        for value in [hi, lo] {
            let samples = col().filter(|&v| v == value).count();
            if samples >= least && hi > lo {
                out.push(Clip { joint: log.joint_names[j].clone(), value, samples });
            }
        }
    }
    out
}

/// The standstills of a conditioned segment's velocities `qd` (`T x n`, step `dt`): runs
/// of rows, at least [`STANDSTILL_MIN_S`] long, where every joint is below its threshold
/// `thr`.
pub fn standstills(qd: &[f64], n: usize, dt: f64, thr: &[f64]) -> Vec<std::ops::Range<usize>> {
    let min_run = (STANDSTILL_MIN_S / dt).ceil() as usize;
    let still: Vec<bool> = qd.chunks_exact(n).map(|row| row.iter().zip(thr).all(|(v, th)| v.abs() < *th)).collect();
    let mut out = vec![];
    let mut k = 0;
    while k < still.len() {
        let end = still[k..].iter().position(|s| !s).map_or(still.len(), |p| k + p);
        if end - k >= min_run {
            out.push(k..end);
        }
        k = end + 1;
    }
    out
}

/// The window, the excluded spans, then repeated samples dropped; clipped torques found.
/// Borrows the log when nothing changes.
pub fn clean<'a>(
    log: &'a JointLog,
    window: Option<(f64, f64)>,
    exclude: &[(f64, f64)],
) -> Result<(std::borrow::Cow<'a, JointLog>, Hygiene)> {
    use std::borrow::Cow;
    magnitude_check(log)?;
    let mut h = Hygiene { window, exclude: exclude.to_vec(), ..Default::default() };
    let t0 = log.t.first().copied().unwrap_or(0.0);
    let mut log = Cow::Borrowed(log);
    if let Some(w) = window {
        let keep = window_rows(&log.t, w)?;
        h.outside_window = log.len() - keep.len();
        if h.outside_window > 0 {
            log = Cow::Owned(log.rows(&keep));
        }
    }
    if !exclude.is_empty() {
        let keep = outside(&log.t, exclude, t0)?;
        h.excluded = log.len() - keep.len();
        if h.excluded > 0 {
            log = Cow::Owned(log.rows(&keep));
        }
    }
    h.clipped = clipped(&log);
    let rep = repeated_samples(&log);
    if !rep.is_empty() {
        h.repeated = rep.len();
        let mut drop = rep.into_iter().peekable();
        let keep: Vec<usize> = (0..log.len()).filter(|&k| drop.next_if_eq(&k).is_none()).collect();
        log = Cow::Owned(log.rows(&keep));
    }
    Ok((log, h))
}

pub use crate::limits::MAX_MAGNITUDE;

/// Refuses a finite value beyond [`MAX_MAGNITUDE`], naming the sample, the joint and the
/// signal. Non-finite values are left to the finiteness checks, which know whether the
/// signal is used (a NaN log velocity is harmless when velocities come from positions).
pub fn magnitude_check(log: &JointLog) -> Result<()> {
    for (field, a) in log.fields() {
        if let Some(a) = a {
            magnitude_in(field, a, &log.joint_names, 0)?;
        }
    }
    Ok(())
}

/// [`magnitude_check`] on one `T x N` array (rows from sample `first` on): the in-memory
/// and the streamed paths apply the same rule with the same words.
pub fn magnitude_in(field: &str, a: &[f64], joints: &[String], first: usize) -> Result<()> {
    let n = joints.len().max(1);
    if let Some(i) = a.iter().position(|x| x.is_finite() && x.abs() > MAX_MAGNITUDE) {
        let joint = joints.get(i % n).map_or("?", String::as_str);
        return Err(Error::Signal {
            msg: format!(
                "sample {}: joint '{joint}' {field} is {:e}, beyond the {MAX_MAGNITUDE:e} accepted in SI units (a corrupt sample?)",
                first + i / n,
                a[i]
            ),
        });
    }
    Ok(())
}

/// Refuses joints whose torque is exactly 0 in every one of `samples` samples: no arm
/// measures a torque of exactly zero throughout a motion (gravity, friction and noise
/// move it), so the log carries no torque for them (a driver that leaves the effort
/// field at 0); fitted, every parameter came out 0 with std 0. `nonzero[j]`: joint j's
/// torque was nonzero somewhere.
pub fn zero_torque_check(nonzero: &[bool], joints: &[String], samples: usize) -> Result<()> {
    let zero: Vec<&str> = joints.iter().zip(nonzero).filter(|(_, nz)| !**nz).map(|(j, _)| j.as_str()).collect();
    if zero.is_empty() || samples == 0 {
        return Ok(());
    }
    Err(Error::Signal {
        msg: format!(
            "the torque (effort) of joints {zero:?} is exactly 0 in all {samples} samples: the log carries no torque for them (a driver that does not fill the effort field? with motor currents, give --effort current)"
        ),
    })
}

/// [`zero_torque_check`] on a log's torque (if it has one): run by every job that fits
/// torques (identify, payload, gains, diagnose), not by the conditioning itself, which
/// also serves logs whose torque is not used.
pub fn torque_check(log: &JointLog) -> Result<()> {
    let Some(tau) = &log.tau else { return Ok(()) };
    let mut nonzero = vec![false; log.dof()];
    nonzero_joints(tau, log.dof().max(1), &mut nonzero);
    zero_torque_check(&nonzero, &log.joint_names, log.len())
}

/// Which joints' torque is nonzero in at least one sample of the `T x N` array `tau`.
pub fn nonzero_joints(tau: &[f64], n: usize, acc: &mut [bool]) {
    for row in tau.chunks_exact(n) {
        for (a, &x) in acc.iter_mut().zip(row) {
            *a |= x != 0.0;
        }
    }
}

/// A correlation of a joint's measured torque with its model torque above this, at a
/// slope outside [`EFFORT_SCALE`], is an effort in another unit ([`effort_units`]).
pub const EFFORT_CORRELATION: f64 = 0.8;

/// Slopes of a joint's measured on its model torque within which the effort is read as
/// N m: CAD inertials are off by tens of percent, not a factor 100, and mN m (1000) or
/// kN m (0.001) is outside. Slopes seen at a correlation above 0.8, on every joint but the
/// terminal one: `diagnose` (centred, on the nominal torque) 0.51-11.2 on 984 generated
/// logs (inertials up to 30 % off, payloads up to 2 kg); `identify` (uncentred, on the
/// nominal base parameters' torque) 0.39-7.15 on 199 generated logs, 0.73-1.16 on the real
/// LWR4+ runs.
pub const EFFORT_SCALE: (f64, f64) = (0.01, 100.0);

/// An error naming the first joint but the terminal one (a payload can outweigh its
/// link's torque) whose measured torque follows the model's (`agreement[j]`: correlation,
/// of the kind `kind`, and slope of joint `j`'s measured on its model torque) closely at a
/// slope outside [`EFFORT_SCALE`]: an effort in another unit, for `diagnose` and
/// `identify` alike.
pub fn effort_units(agreement: &[(f64, f64)], names: &[String], kind: &str) -> Result<()> {
    for (name, &(r, slope)) in names.iter().zip(agreement).take(names.len().saturating_sub(1)) {
        if r > EFFORT_CORRELATION && !(EFFORT_SCALE.0..=EFFORT_SCALE.1).contains(&slope) {
            return Err(Error::Signal {
                msg: format!(
                    "joint '{name}': the logged effort is {slope:.4e} times the torque of the URDF's model ({kind} {r:.3}): it is not in N m (mN m? a motor current without its torque constant: --effort current --torque-constant), or the URDF's inertials are not in kg and m"
                ),
            });
        }
    }
    Ok(())
}

/// Logged positions of a revolute joint that lie far outside its limits (by more than
/// half the range) but inside them once read as degrees: the log is in degrees (ROS
/// `JointState` positions are radians). `limits[j]`: joint `j`'s `(lower, upper)` in rad,
/// `None` for a prismatic joint or one without limits. Errors naming the joint.
pub fn degrees_check(log: &JointLog, limits: &[Option<(f64, f64)>]) -> Result<()> {
    let n = log.dof();
    for (j, lim) in limits.iter().enumerate().take(n) {
        let Some((lo, hi)) = *lim else { continue };
        let (mn, mx) = log
            .q
            .iter()
            .skip(j)
            .step_by(n)
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), v| (a.min(*v), b.max(*v)));
        let slack = 0.5 * (hi - lo);
        let inside = |a: f64, b: f64| a >= lo - slack && b <= hi + slack;
        let d = std::f64::consts::PI / 180.0;
        if mn.is_finite() && !inside(mn, mx) && inside(mn * d, mx * d) {
            return Err(Error::Signal {
                msg: format!(
                    "joint '{}': positions span {mn:.1} to {mx:.1}, far outside its limits [{lo:.3}, {hi:.3}] rad, and inside them read as degrees: give positions in radians",
                    log.joint_names[j]
                ),
            });
        }
    }
    Ok(())
}

/// Revolute joints' positions made continuous where they wrap: a step of more than pi
/// between consecutive samples (over 3000 rad/s at 1 kHz, which no arm turns) is an angle
/// reported modulo 2 pi (a continuous joint's driver, a `(-pi, pi]` convention), and is
/// undone by the multiple of 2 pi that brings the step within pi. A revolute joint's
/// dynamics are 2 pi-periodic in its angle, so this changes nothing but the differences
/// the velocity and acceleration come from, which a wrap turns into a spike of 2 pi / dt.
/// `angle[j]`: joint `j` is revolute (a prismatic joint's positions are left as they are).
/// Returns the wraps undone per joint.
pub fn unwrap_angles(q: &mut [f64], n: usize, angle: &[bool]) -> Vec<usize> {
    use std::f64::consts::{PI, TAU};
    let mut wraps = vec![0; n];
    for (j, w) in wraps.iter_mut().enumerate().filter(|(j, _)| angle.get(*j) == Some(&true)) {
        // the raw previous sample: a wrap is a step between raw samples
        let (mut prev, mut offset) = (f64::NAN, 0.0);
        for x in q.iter_mut().skip(j).step_by(n) {
            let raw = *x;
            let step = raw - prev;
            if step.abs() > PI {
                offset -= TAU * (step / TAU).round();
                *w += 1;
            }
            if raw.is_finite() {
                prev = raw;
            }
            *x = raw + offset;
        }
    }
    wraps
}

/// The first step of more than pi between consecutive positions of any joint (a wrapped
/// angle, or a jump), as `(sample, joint)`; the streaming path leaves such a log to the
/// in-memory one, which knows the joints' kinds ([`unwrap_angles`]). `prev`: the last row
/// before `q` (`None` at the log's start).
pub fn first_wrap(q: &[f64], n: usize, prev: Option<&[f64]>) -> Option<(usize, usize)> {
    let rows = q.chunks_exact(n);
    let mut last = prev;
    for (k, row) in rows.enumerate() {
        if let Some(p) = last
            && let Some(j) = (0..n).find(|&j| (row[j] - p[j]).abs() > std::f64::consts::PI)
        {
            return Some((k, j));
        }
        last = Some(row);
    }
    None
}

#[cfg(test)]
mod tests {
    use super::*;

    fn ramp_log(t: &[f64], q: &[f64]) -> JointLog {
        JointLog { joint_names: vec!["a".into()], t: t.to_vec(), q: q.to_vec(), ..Default::default() }
    }

    #[test]
    fn repeats_inside_motion_are_dropped_standstills_kept() {
        let t: Vec<f64> = (0..12).map(|k| k as f64 * 1e-3).collect();
        // sample 3 repeats sample 2 inside a ramp; samples 7..11 are a standstill (run of 4)
        let q = [0.0, 1.0, 2.0, 2.0, 4.0, 5.0, 6.0, 7.0, 7.0, 7.0, 7.0, 7.0];
        let log = ramp_log(&t, &q);
        assert_eq!(repeated_samples(&log), vec![3]);
        let (c, h) = clean(&log, None, &[]).unwrap();
        assert_eq!(h.repeated, 1);
        assert_eq!(c.len(), 11);
        assert!(!c.t.contains(&3e-3));
        // a repeat at the very end is kept (the motion cannot be seen to go on)
        let log = ramp_log(&t[..4], &q[..4]);
        assert!(repeated_samples(&log).is_empty());
        // with velocities, a row repeats only if qd repeats too
        let mut log = ramp_log(&t, &q);
        log.qd = Some((0..12).map(|k| k as f64).collect());
        assert!(repeated_samples(&log).is_empty());
    }

    #[test]
    fn window_keeps_seconds_from_the_first_sample() {
        let t: Vec<f64> = (0..11).map(|k| 5.0 + k as f64 * 0.1).collect();
        let log = ramp_log(&t, &[0.0; 11]);
        let (c, h) = clean(&log, Some((0.25, 0.55)), &[]).unwrap();
        assert_eq!(c.t.len(), 3, "{:?}", c.t);
        assert_eq!(h.outside_window, 8);
        let e = clean(&log, Some((2.0, 3.0)), &[]).unwrap_err().to_string();
        assert!(e.contains("window") && e.contains("lasts 1.000 s"), "{e}");
        let e = clean(&log, Some((0.5, 0.2)), &[]).unwrap_err().to_string();
        assert!(e.contains("end must come after"), "{e}");
        assert!(clean(&log, Some((f64::NAN, 1.0)), &[]).is_err());
        assert_eq!(clean(&log, Some((0.0, f64::INFINITY)), &[]).unwrap().0.len(), 11);
        assert_eq!(parse_window("0.25:0.55").unwrap(), (0.25, 0.55));
        assert_eq!(parse_window(":3").unwrap(), (0.0, 3.0));
        assert_eq!(parse_window("2:").unwrap(), (2.0, f64::INFINITY));
        assert!(parse_window("2-3").unwrap_err().to_string().contains("window must be START:END"));
        assert!(parse_window("a:3").is_err());
    }

    #[test]
    fn wrapped_angles_are_unwrapped_prismatic_left() {
        use std::f64::consts::{PI, TAU};
        // joint 0 turns at 2 rad/s through pi, reported in (-pi, pi]; joint 1 (prismatic)
        // jumps by 4 m once, which no wrap explains
        let true_q: Vec<f64> = (0..400).map(|k| 2.5 + 0.002 * k as f64).collect();
        let mut q = vec![];
        for (k, a) in true_q.iter().enumerate() {
            q.push((a + PI).rem_euclid(TAU) - PI);
            q.push(if k < 200 { 0.1 } else { 4.1 });
        }
        let wraps = unwrap_angles(&mut q, 2, &[true, false]);
        assert_eq!(wraps, vec![1, 0]);
        for (k, a) in true_q.iter().enumerate() {
            // the first sample is kept, so the unwrapped angle is the true one
            assert!((q[2 * k] - a).abs() < 1e-12, "sample {k}: {} vs {a}", q[2 * k]);
        }
        assert_eq!(q[2 * 399 + 1], 4.1);
        // the streaming check names the first such step, on either kind of joint
        let wrapped: Vec<f64> = true_q.iter().flat_map(|a| [(a + PI).rem_euclid(TAU) - PI, 0.0]).collect();
        let k = true_q.iter().position(|a| *a > PI).unwrap();
        assert_eq!(first_wrap(&wrapped, 2, None), Some((k, 0)));
        assert_eq!(first_wrap(&wrapped[2 * k..], 2, Some(&wrapped[2 * k - 2..2 * k])), Some((0, 0)));
        assert_eq!(first_wrap(&true_q.iter().flat_map(|a| [*a, 0.0]).collect::<Vec<_>>(), 2, None), None);
    }
}

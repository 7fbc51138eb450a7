//! `identify`'s data preparation: every log conditioned into segments (gaps are never
//! interpolated across), each segment's base regressor rows stacked and parallel-filtered
//! on their own, then the segments concatenated with their inner filter edges marked
//! for leaving out.

use std::ops::Range;

use super::identify_options::IdentifyOptions;
use crate::Robot;
use crate::batch::stack_rows;
use crate::dsp::Decimator;
use crate::error::{Error, Result};
use crate::ident::coulomb;
use crate::ident::instrument::{TRACKING_INSTRUMENT, nominal_tracking};
use crate::log::JointLog;
use crate::prep::{self, ConditionSummary, Conditioned, parallel_filter};
use crate::progress::Stage;

/// Rows `r` of a row-major array of `width` columns.
pub(crate) fn rows_of(x: &[f64], width: usize, r: Range<usize>) -> &[f64] {
    &x[r.start * width..r.end * width]
}

/// The prepared rows of one or more logs, segments concatenated (decimated rows).
pub(crate) struct Prepared {
    pub n: usize,
    pub dt: f64,
    pub q: Vec<f64>,
    pub qd: Vec<f64>,
    pub qdd: Vec<f64>,
    /// `T x n x b` (`b` = the columns asked for)
    pub phi: Vec<f64>,
    /// `T x n`
    pub tau: Vec<f64>,
    /// `T x n x b` instrument rows.
    pub z: Option<Vec<f64>>,
    pub instrument: Option<String>,
    pub cutoff_hz: f64,
    pub factor: usize,
    /// First row of each segment, then the total.
    pub bounds: Vec<usize>,
    pub conditioning: ConditionSummary,
    /// Remarks (an instrument that could not be built).
    pub notes: Vec<String>,
    /// The conditioned segments (for the instrument and the Coulomb-shape candidates,
    /// built after `phi`) and their filter.
    pub segments: Vec<Conditioned>,
    pub dec: Decimator,
}

impl Prepared {
    pub fn len(&self) -> usize {
        self.tau.len() / self.n
    }

    /// The parts of the rows `r` that lie inside one segment, without the filter edges at
    /// the segments' inner ends (1 % of a segment's rows, at most 20; the outer ends of
    /// the whole are `split_ranges`'s). One segment: `[r]`.
    pub fn pieces(&self, r: Range<usize>) -> Vec<Range<usize>> {
        let last = self.bounds.len() - 2;
        (0..=last)
            .filter_map(|p| {
                let (s, e) = (self.bounds[p], self.bounds[p + 1]);
                let edge = ((e - s) / 100).min(20);
                let lo = if p > 0 { s + edge } else { s };
                let hi = if p < last { e - edge } else { e };
                let (a, b) = (r.start.max(lo), r.end.min(hi));
                (a < b).then_some(a..b)
            })
            .collect()
    }
}

/// Checks a log against the robot before preparing it.
fn check_log(robot: &Robot, log: &JointLog, what: &str) -> Result<()> {
    if log.dof() != robot.dof() || log.joint_names != robot.joint_names {
        return Err(Error::JointMismatch {
            what: what.into(),
            log: log.joint_names.clone(),
            robot: robot.joint_names.clone(),
        });
    }
    if log.tau.is_none() {
        return Err(Error::NoTorque { what: what.into(), needed_by: "identification".into() });
    }
    prep::hygiene::torque_check(log)
}

/// Every log conditioned into segments, on the first log's sample time (a later log with
/// another rate is resampled onto it). Returns the segments and the merged summary.
fn condition_all(logs: &[&JointLog], opts: &IdentifyOptions) -> Result<(Vec<Conditioned>, ConditionSummary)> {
    let mut parts: Vec<Conditioned> = vec![];
    let mut summaries = vec![];
    for log in logs {
        let mut segs = prep::condition_segments(log, &opts.condition)?;
        if let Some(dt) = parts.first().map(|p| p.dt)
            && (segs[0].dt - dt).abs() > 1e-9 * dt
        {
            let forced = prep::ConditionOptions { dt: Some(dt), ..opts.condition.clone() };
            segs = prep::condition_segments(log, &forced)?;
        }
        summaries.push(ConditionSummary::of(&segs));
        parts.extend(segs);
    }
    Ok((parts, ConditionSummary::merge(&summaries)))
}

/// One segment's filtered, decimated rows: `(phi, tau, q, qd, qdd)`.
type Rows = (Vec<f64>, Vec<f64>, Vec<f64>, Vec<f64>, Vec<f64>);

/// One segment: regressor rows stacked, then torque and rows through the same filter and
/// decimation.
fn segment_rows(
    robot: &Robot,
    cols: &[usize],
    c: &Conditioned,
    dec: &Decimator,
    stage: Option<&Stage>,
) -> Result<Rows> {
    let n = robot.dof();
    let b = cols.len();
    let phi_raw = stack_rows(robot, cols, &c.d.q, &c.d.qd, &c.d.qdd, stage)?;
    let phi = dec.apply(&phi_raw, n * b)?;
    drop(phi_raw);
    let tau = dec.apply(c.tau.as_ref().expect("checked"), n)?;
    Ok((phi, tau, dec.apply(&c.d.q, n)?, dec.apply(&c.d.qd, n)?, dec.apply(&c.d.qdd, n)?))
}

/// One segment's instrument rows, the base regressor (of `robot`'s structure) at the motion
/// of `model` (the nominal model, or for `--method iv` the identified one), filtered and
/// decimated like the regressor rows: with a command `u`, at `(q, qd, FD_model(q, qd, u))`;
/// otherwise on a closed-loop simulation of `model` tracking the measured motion
/// ([`nominal_tracking`], the stand-in control law of IDIM-IV). The simulated states carry
/// none of the torque noise, so the rows are uncorrelated with it (the paper's eq 32 with
/// `Z` from noise-free states).
pub(crate) fn segment_instrument(
    robot: &Robot,
    model: &Robot,
    cols: &[usize],
    c: &Conditioned,
    dec: &Decimator,
) -> Result<Vec<f64>> {
    let n = robot.dof();
    let (qz, qdz, qddz) = match &c.u {
        Some(u) => {
            let mut qh = vec![0.0; c.t.len() * n];
            crate::batch::forward_dynamics_batch(model, &c.d.q, &c.d.qd, u, &mut qh)?;
            (c.d.q.clone(), c.d.qd.clone(), qh)
        }
        None => nominal_tracking(model, &c.d.q, &c.d.qd, &c.d.qdd, c.dt)?,
    };
    let z_raw = stack_rows(robot, cols, &qz, &qdz, &qddz, None)?;
    dec.apply(&z_raw, n * cols.len())
}

/// One segment's Coulomb-shape candidate columns ([`coulomb::candidate_row`]) at the
/// conditioned velocity, through the same filter as the regressor.
fn segment_candidates(c: &Conditioned, n: usize, scales: &[[f64; coulomb::K]], dec: &Decimator) -> Result<Vec<f64>> {
    let mut raw = Vec::with_capacity(c.t.len() * n * coulomb::WIDTH);
    for qd in c.d.qd.chunks_exact(n) {
        coulomb::candidate_row(qd, scales, &mut raw);
    }
    dec.apply(&raw, n * coulomb::WIDTH)
}

/// Conditions `logs` (segments at gaps), stacks and parallel-filters each segment's rows
/// of the full-regressor columns `cols` (the base parameters' independent columns, for
/// identify) and concatenates them (see the module docs). The instrument comes after,
/// from [`Prepared::add_instrument`].
pub(crate) fn prepare(
    robot: &Robot,
    cols: &[usize],
    logs: &[&JointLog],
    opts: &IdentifyOptions,
    what: &str,
) -> Result<Prepared> {
    let n = robot.dof();
    for log in logs {
        check_log(robot, log, what)?;
    }
    let (parts, conditioning) = condition_all(logs, opts)?;
    let dt = parts[0].dt;
    let total: usize = parts.iter().map(|c| c.t.len()).sum();
    let dec = parallel_filter(opts.decimate, 1.0 / dt, total, &opts.condition)?;
    let st = Stage::begin(&opts.progress, &format!("{what}: regressor and filtering"), total as u64);
    let mut p = Prepared {
        n,
        dt: dt * dec.factor as f64,
        q: vec![],
        qd: vec![],
        qdd: vec![],
        phi: vec![],
        tau: vec![],
        z: None,
        instrument: None,
        cutoff_hz: dec.filter.cutoff_hz,
        factor: dec.factor,
        bounds: vec![0],
        conditioning,
        notes: vec![],
        segments: vec![],
        dec,
    };
    for c in &parts {
        let (phi, tau, q, qd, qdd) = segment_rows(robot, cols, c, &p.dec, Some(&st))?;
        p.phi.extend(phi);
        p.tau.extend(tau);
        p.q.extend(q);
        p.qd.extend(qd);
        p.qdd.extend(qdd);
        p.bounds.push(p.tau.len() / n);
    }
    p.segments = parts;
    Ok(p)
}

impl Prepared {
    /// The RMS velocity and acceleration of each joint over all segments (conditioned,
    /// before filtering).
    pub fn rms_motion(&self) -> (Vec<f64>, Vec<f64>) {
        let n = self.n;
        let rms = |x: fn(&Conditioned) -> &Vec<f64>| -> Vec<f64> {
            let mut s = vec![0.0; n];
            let mut k = 0usize;
            for v in self.segments.iter().flat_map(|c| x(c).chunks_exact(n)) {
                s.iter_mut().zip(v).for_each(|(a, v)| *a += v * v);
                k += 1;
            }
            s.iter().map(|a| (a / k.max(1) as f64).sqrt()).collect()
        };
        (rms(|c| &c.d.qd), rms(|c| &c.d.qdd))
    }

    /// The instrument rows of every segment with `model` as the simulated arm (its
    /// parameters; `robot` gives the regressor), filtered and decimated as the regressor:
    /// [`segment_instrument`].
    pub fn instrument_rows(&self, robot: &Robot, model: &Robot, cols: &[usize]) -> Result<Vec<f64>> {
        let mut z = Vec::with_capacity(self.phi.len());
        for c in &self.segments {
            z.extend(segment_instrument(robot, model, cols, c, &self.dec)?);
        }
        Ok(z)
    }

    /// The Coulomb-shape candidate columns of every segment for the velocity scales
    /// `scales` (`T x n x` [`coulomb::WIDTH`], aligned with `phi`).
    pub fn coulomb_candidates(&self, scales: &[[f64; coulomb::K]]) -> Result<Vec<f64>> {
        let mut out = Vec::with_capacity(self.len() * self.n * coulomb::WIDTH);
        for c in &self.segments {
            out.extend(segment_candidates(c, self.n, scales, &self.dec)?);
        }
        Ok(out)
    }

    /// Builds the instrument rows of every segment with `robot` (whose Coulomb shapes are
    /// the chosen ones) for the columns `cols`. An instrument that cannot be built (e.g.
    /// the model's mass matrix is not positive definite, so it cannot be simulated) is an
    /// error only when `need`; otherwise it is left out with a note (it only serves the
    /// LS-vs-IV test then).
    pub fn add_instrument(&mut self, robot: &Robot, cols: &[usize], need: bool) -> Result<()> {
        let mut z = Vec::with_capacity(self.phi.len());
        for c in &self.segments {
            match segment_instrument(robot, robot, cols, c, &self.dec) {
                Ok(zs) => z.extend(zs),
                Err(e) if !need => {
                    self.notes.push(format!("no instrument ({e}): the LS-vs-IV test is skipped"));
                    return Ok(());
                }
                Err(e) => return Err(e),
            }
        }
        let with_command = self.segments.iter().all(|c| c.u.is_some());
        self.instrument = Some(if with_command {
            "nominal model's forward dynamics at the (filtered) measured state driven by the command u: qdd_hat = FD_nom(q, qd, u)".to_string()
        } else {
            TRACKING_INSTRUMENT.to_string()
        });
        self.z = Some(z);
        Ok(())
    }
}

//! Everything derived from the log before the search: the conditioned signals, the
//! nominal prediction, the dictionary and its Gram matrices, at the differentiation
//! cutoff and torque-to-motion alignment that explain the log best.

use super::DiagnoseOptions;
use super::dictionary::{C_BASE, Dictionary, Grams, build_dictionary, grams};
use super::model::{basic_all_model, fit, noise_floor, noise_of_all_model, rss_joint};
use super::residual::{difference_lag1, median, sample_noise};
use super::signals::{SUBSAMPLE_BLOCK, Signals, accel_step, condition};
use crate::Robot;
use crate::batch;
use crate::dsp;
use crate::error::{Error, Result};
use crate::log::JointLog;

/// Differentiation cutoffs tried (Hz), at most a quarter of the sample rate.
const CUTOFF_GRID: [f64; 5] = [10.0, 20.0, 40.0, 80.0, 160.0];
/// Samples the cutoff is chosen on: a longer log is subsampled in blocks spread over all of
/// it ([`Signals::every_kth_block`]). 20 000 samples give each joint's residual RSS a
/// relative standard error of ~1 % (`sqrt(2 / T)`), far below the differences between
/// the grid's cutoffs; the log's full length enters only the final pass.
const CUTOFF_ROWS: usize = 20_000;

/// Everything derived from the log for one conditioning.
pub(super) struct Prepared {
    pub(super) s: Signals,
    pub(super) tau_nom: Vec<f64>,
    pub(super) d: Dictionary,
    pub(super) gr: Grams,
    /// Whether the effects of real drives are searched ([`DiagnoseOptions::drives_for`] of
    /// the samples used), and why; set by [`prepare_best`].
    pub(super) drives: bool,
    pub(super) drives_why: String,
    /// Whether `s` is a subsample of the conditioned log ([`Signals::every_kth_block`]).
    pub(super) subsampled: bool,
    /// Why the log is diagnosed on a subsample of it, when its dictionary would pass
    /// [`DiagnoseOptions::max_dictionary_bytes`] (`memory_cap`).
    pub(super) memory_note: Option<String>,
}

/// The most samples whose dictionary (`C_BASE` columns, the re-fit's base columns when
/// `with_base`: at most 10 per link but the terminal one) fits `max_bytes` on `n` joints,
/// and the note that says so when the log's `t_len` samples are more.
fn memory_cap(n: usize, with_base: bool, t_len: usize, max_bytes: usize) -> (usize, Option<String>) {
    let cols = C_BASE + if with_base { 10 * n.saturating_sub(1) } else { 0 };
    let per_sample = 8 * n * cols;
    let rows = (max_bytes / per_sample).max(1);
    let size = |b: usize| match b as f64 / (1u64 << 30) as f64 {
        g if g >= 1.0 => format!("{g:.1} GiB"),
        g => format!("{:.0} MiB", 1024.0 * g),
    };
    let note = (t_len > rows).then(|| {
        format!(
            "all of them would take up to {} of candidate columns, over the {} allowed (--max-dictionary-gib, DiagnoseOptions::max_dictionary_bytes), so blocks of {SUBSAMPLE_BLOCK} samples spread over the whole log are used; the report and residuals.mcap show those (--window diagnoses one part whole)",
            size(t_len * per_sample),
            size(max_bytes)
        )
    });
    (rows, note)
}

/// The log prepared at the best cutoff, then again with the acceleration aligned to the
/// torque (and the re-fit's base-parameter columns, which choosing the cutoff does not use).
/// On a long log the cutoffs are compared on at most [`CUTOFF_ROWS`] samples; the noise's
/// whiteness, the alignment and the final pass use all of them.
pub(super) fn prepare_best(robot: &Robot, log: &JointLog, opts: &DiagnoseOptions) -> Result<Prepared> {
    let dt = log.median_dt().ok_or_else(|| Error::ShortLog {
        what: "the log".into(),
        samples: log.t.len(),
        needed: 2,
        needed_by: "the sample time (distinct stamps)".into(),
    })?;
    crate::prep::check_sample_time(dt)?;
    let fs = 1.0 / dt;
    // the differentiation cutoff: given, or the one on a grid that leaves the least
    // residual once every candidate effect is in (too low a cutoff removes real
    // acceleration the torque contains, too high lets differentiation noise through)
    // (the given or default cutoff is checked against the sample rate first: an absurd one
    // or absurd stamps get an error naming the option, not a filter of NaN)
    let checked = dsp::resolve_cutoff(opts.cutoff_hz, fs)?;
    let cutoffs: Vec<f64> = match opts.cutoff_hz {
        Some(_) => vec![checked],
        None => CUTOFF_GRID.iter().copied().filter(|&c| c <= 0.25 * fs && c >= dsp::MIN_CUTOFF_FRACTION * fs).collect(),
    };
    let cutoffs = if cutoffs.is_empty() { vec![dsp::default_cutoff(fs)] } else { cutoffs };
    let rows = (cutoffs.len() > 1).then_some(CUTOFF_ROWS);
    // each thread keeps the best of its run of cutoffs (a pass's columns are ~100 MB), then
    // the first of the lowest scores wins, as in one loop over the grid
    let best_of = |cs: &[f64]| -> Result<Option<(f64, Prepared)>> {
        let mut best: Option<(f64, Prepared)> = None;
        for &c in cs {
            let p = prepare(robot, log, opts, c, None, false, rows)?;
            let score = p.log_rss_all();
            if best.as_ref().is_none_or(|b| score < b.0) {
                best = Some((score, p));
            }
        }
        Ok(best)
    };
    let mut best: Option<(f64, Prepared)> = None;
    for run in crate::par::map_chunks(opts.threads_for(log.t.len()), &cutoffs, best_of) {
        if let Some((score, p)) = run?
            && best.as_ref().is_none_or(|b| score < b.0)
        {
            best = Some((score, p));
        }
    }
    let mut p = best.expect("at least one cutoff").1;
    if p.subsampled {
        // the alignment of a third of a 5 kHz log came out at the clamp (+1 sample) where
        // the whole log's is ~0: the one-sample step is too small a signal to subsample
        p = prepare(robot, log, opts, p.s.cutoff_hz, None, false, None)?;
    }
    let (duration, lag1) = (p.s.duration(), p.noise_lag1());
    let drives = opts.drives_for(duration, lag1);
    // torque-to-motion alignment (a fraction of a sample), then everything again
    let alpha = p.alignment(robot, drives)?;
    let drives_why = drives_why(opts.drives, duration, lag1);
    // this pass's dictionary goes before the final one is built (both at once were the
    // diagnosis' peak memory)
    let cutoff_hz = p.s.cutoff_hz;
    drop(p);
    Ok(Prepared { drives, drives_why, ..prepare(robot, log, opts, cutoff_hz, Some(alpha), true, None)? })
}

/// Why the effects of real drives were searched or not ([`DiagnoseOptions::drives_for`]).
fn drives_why(given: Option<bool>, duration: f64, lag1: f64) -> String {
    let (min, white) = (super::DRIVES_MIN_DURATION_S, super::WHITE_NOISE_MAX_LAG1);
    match given {
        Some(true) => "searched, as asked".into(),
        Some(false) => "not searched, as asked".into(),
        None if duration < min => format!(
            "not searched: the log spans {duration:.1} s, under {min} s, where their candidates take up inertial error and noise (--drives, drives=True searches them)"
        ),
        None if lag1 > white => format!(
            "not searched: the torque noise is not white at the sample rate (the residual's differences have lag-1 autocorrelation {lag1:.2}, where white noise gives -0.5: a torque low-passed before it was logged), where their candidates fit smooth model error (--drives, drives=True searches them)"
        ),
        None => format!(
            "searched: the log spans {duration:.1} s, at least {min} s, with white torque noise (--no-drives, drives=False leaves them out)"
        ),
    }
}

fn prepare(
    robot: &Robot,
    log: &JointLog,
    opts: &DiagnoseOptions,
    cutoff_hz: f64,
    align: Option<f64>,
    with_base: bool,
    max_rows: Option<usize>,
) -> Result<Prepared> {
    let n = robot.dof();
    let mut s = condition(log, opts, cutoff_hz)?;
    if s.resampled {
        s.sample_noise = log.tau.as_ref().map(|tau| sample_noise(&log.t, tau, n));
    }
    let t_log = s.t.len();
    let (cap, memory_note) = memory_cap(n, with_base, t_log, opts.max_dictionary_bytes);
    // the cutoff's passes on every k-th block (as before the cap); the final ones on as many
    // blocks as the cap holds
    let sub = match max_rows {
        Some(m) => s.every_kth_block(n, m.min(cap)),
        None => s.spread_blocks(n, cap),
    };
    let subsampled = sub.is_some();
    if let Some(sub) = sub {
        s = sub;
    }
    let memory_note = memory_note.map(|why| format!("log diagnosed on {} of its {t_log} samples: {why}", s.t.len()));
    if let Some(a) = align {
        s.align_acceleration(a, n);
    }
    let t_len = s.t.len();
    let mut tau_nom = vec![0.0; t_len * n];
    batch::rnea_batch(robot, &s.q, &s.qd, &s.qdd, &mut tau_nom).map_err(|e| Error::during("nominal model", e))?;
    let threads = opts.threads_for(log.t.len());
    let d = build_dictionary(robot, &s, &tau_nom, with_base, threads)?;
    let gr = grams(&d, t_len, opts.blocks_per_fold.max(1), threads);
    // every fit of the search decomposes these sums: a non-finite one would not converge
    if let Some(j) = gr.g.iter().position(|g| g.iter().any(|m| m.iter().any(|x| !x.is_finite()))) {
        return Err(Error::Numerical {
            what: format!("joint '{}'", log.joint_names.get(j).map_or("?", String::as_str)),
            msg: "the regressor sums overflow (values in the log too large)".into(),
        });
    }
    Ok(Prepared { s, tau_nom, d, gr, drives: false, drives_why: String::new(), subsampled, memory_note })
}

impl Prepared {
    /// Median over joints of the lag-1 autocorrelation of the differences of the basic
    /// all-candidates residual ([`difference_lag1`]): how white the torque noise is. A joint
    /// whose noise is at its floor (`model::noise_floor`: an exact log, where the residual is
    /// the conditioning's own smooth error) counts as white, -0.5, as the tests take it.
    fn noise_lag1(&self) -> f64 {
        let n = self.d.cols.len();
        let (sigma, _, r_all) = noise_of_all_model(&self.d, &self.gr, n, self.s.t.len(), 0, false);
        let lag1 = |j: usize| if sigma[j] <= noise_floor(&self.d, j) { -0.5 } else { difference_lag1(&r_all, n, j) };
        median((0..n).map(lag1).collect())
    }

    /// Sum over joints of log(RSS) of the all-candidates model (scale-free across joints).
    fn log_rss_all(&self) -> f64 {
        let n = self.d.cols.len();
        let unit = vec![1.0; n];
        let f = fit(&basic_all_model(n).params(), &self.gr, &unit, &[0, 1]);
        (0..n).map(|j| rss_joint(&f, &self.gr, j, &[0, 1]).max(1e-300).ln()).sum()
    }

    /// The time alignment `a` (samples, clamped to +-1) between torque and motion that
    /// best explains the residual of the all-candidates model: the torque of the shift,
    /// `M(q) a accel_step`, regressed on it, weighted by the noise.
    fn alignment(&self, robot: &Robot, drives: bool) -> Result<f64> {
        let n = self.d.cols.len();
        let t_len = self.s.t.len();
        let (sigma, _, r_all) = noise_of_all_model(&self.d, &self.gr, n, t_len, 0, drives);
        let delta = accel_step(&self.s.qd, n, self.s.dt, &self.s.starts);
        let zero = vec![0.0; t_len * n];
        let (mut m_d, mut m_0) = (vec![0.0; t_len * n], vec![0.0; t_len * n]);
        batch::rnea_batch(robot, &self.s.q, &zero, &delta, &mut m_d).map_err(|e| Error::during("alignment", e))?;
        batch::rnea_batch(robot, &self.s.q, &zero, &zero, &mut m_0).map_err(|e| Error::during("alignment", e))?;
        let (mut num, mut den) = (0.0, 0.0);
        for k in 0..t_len {
            for j in 0..n {
                let c = m_d[k * n + j] - m_0[k * n + j];
                let w = 1.0 / (sigma[j] * sigma[j]);
                num += w * c * r_all[k * n + j];
                den += w * c * c;
            }
        }
        Ok(if den > 0.0 { (num / den).clamp(-1.0, 1.0) } else { 0.0 })
    }
}

//! The design driver: checks the options, sets up the [`Problem`], runs the random
//! comparison and the multi-start optimisation, and reports on the written samples.

use super::bounds::{Box1, joint_bounds, margin_boxes};
use super::criterion::{Problem, scores};
use super::fourier::{Basis, Coeffs, Samples, sample};
use super::lbfgs::lbfgs;
use super::{Criterion, ExciteOptions, ExciteReport, RandomComparison, Scores};
use crate::Robot;
use crate::error::{Error, Result};
use crate::ident::{BaseParams, robot_base_params};
use crate::limits;
use ivdyn_core::params::{FC, drive_col};
use ivdyn_core::rng::Rng;

/// Designs the excitation trajectory (see the module docs).
pub fn design(robot: &Robot, opts: &ExciteOptions) -> Result<ExciteReport> {
    let n = robot.dof();
    check_options(opts)?;
    let bounds = joint_bounds(robot, opts)?;
    let boxes = margin_boxes(robot, &bounds, opts.margin)?;
    let base = robot_base_params(robot, 200.max(2 * robot.num_params() / n), opts.seed)?;
    let span = (1.0 / opts.f0_hz).min(opts.duration_s);
    let pr = problem(robot, &base, opts, boxes, span);
    let written = Written::new(&pr, opts, span);

    let prog = opts.progress.clone();
    let total = (opts.starts * opts.iterations + opts.random_draws) as u64;
    if let Some(p) = &prog {
        p.begin("excitation design", total);
    }
    let tick = || {
        if let Some(p) = &prog {
            p.advance(1);
        }
    };
    let random = random_comparison(&pr, &written, opts, &tick)?;
    let xb = optimise(&pr, opts, &tick)?;
    if let Some(p) = &prog {
        p.end();
    }
    let (co, traj, sc) = written.finish(&xb)?;

    let h = opts.harmonics;
    let peak = |x: &[f64], i: usize| (0..traj.t.len()).map(|k| x[k * n + i].abs()).fold(0.0, f64::max);
    Ok(ExciteReport {
        robot: robot.name.clone(),
        joints: robot.joint_names.clone(),
        criterion: opts.criterion,
        base_count: base.base_count(),
        f0_hz: opts.f0_hz,
        harmonics: h,
        duration_s: opts.duration_s,
        rate_hz: opts.rate_hz,
        margin: opts.margin,
        velocity_use: (0..n).map(|i| peak(&traj.qd, i) / bounds[i].velocity).collect(),
        acceleration_use: (0..n).map(|i| peak(&traj.qdd, i) / bounds[i].acceleration).collect(),
        bounds,
        cond_improvement: random.cond_median / sc.cond,
        optimised: sc,
        random,
        q0: co.q0.clone(),
        a: (0..n).map(|i| co.a[i * h..(i + 1) * h].to_vec()).collect(),
        b: (0..n).map(|i| co.b[i * h..(i + 1) * h].to_vec()).collect(),
        notes: notes(opts),
        trajectory: traj,
    })
}

/// Most random starts, L-BFGS iterations per start, and random trajectories compared: each
/// is a loop of whole criterion evaluations, so an unbounded count is a hang.
pub const MAX_STARTS: usize = 1000;
/// See [`MAX_STARTS`].
pub const MAX_ITERATIONS: usize = 100_000;
/// See [`MAX_STARTS`].
pub const MAX_RANDOM: usize = 10_000;
/// Most samples of one period the criterion is evaluated on.
pub const MAX_OPT_SAMPLES: usize = 100_000;

/// Rejects options the design cannot use (docs/reliability.md): harmonics outside
/// `2..=MAX_HARMONICS` or reaching the Nyquist frequency, non-positive duration, f0 or
/// rate, more than `MAX_SAMPLES` written samples, a margin outside `[0, 0.5)`, counts
/// outside their bounds, limits beyond `MAX_MAGNITUDE`.
fn check_options(opts: &ExciteOptions) -> Result<()> {
    let h = opts.harmonics;
    if h < 2 {
        return Err(Error::option(
            "harmonics",
            format!("must be at least 2 (one is used by the rest constraints), got {h}"),
        ));
    }
    limits::count_in("harmonics", h, 2, limits::MAX_HARMONICS)?;
    for (what, v) in [("duration", opts.duration_s), ("f0", opts.f0_hz), ("rate", opts.rate_hz)] {
        if !(v > 0.0 && v.is_finite()) {
            return Err(Error::option(what, format!("must be positive, got {v}")));
        }
    }
    limits::samples_bounded(opts.duration_s, opts.rate_hz)?;
    // the written samples must resolve the highest harmonic
    let top = h as f64 * opts.f0_hz;
    if !(top < 0.5 * opts.rate_hz) {
        return Err(Error::option(
            "f0",
            format!(
                "{h} harmonics of {} Hz reach {top} Hz, above the Nyquist frequency {} Hz of --rate",
                opts.f0_hz,
                0.5 * opts.rate_hz
            ),
        ));
    }
    if !(0.0..0.5).contains(&opts.margin) {
        return Err(Error::option("margin", format!("must be in [0, 0.5), got {}", opts.margin)));
    }
    if opts.starts == 0 {
        return Err(Error::option("starts", "must be at least 1"));
    }
    limits::count_in("starts", opts.starts, 1, MAX_STARTS)?;
    limits::count_in("iterations", opts.iterations, 0, MAX_ITERATIONS)?;
    limits::count_in("random", opts.random_draws, 0, MAX_RANDOM)?;
    if opts.opt_samples < 2 {
        return Err(Error::option("opt_samples", format!("must be at least 2, got {}", opts.opt_samples)));
    }
    limits::count_in("opt_samples", opts.opt_samples, 2, MAX_OPT_SAMPLES)?;
    // non-positive and non-finite limits are refused per joint, by name, in `bounds`
    for (what, v) in [("acc_limit", &opts.acc_limit[..]), ("vel_limit", opts.vel_limit.as_deref().unwrap_or(&[]))] {
        if let Some(x) = v.iter().find(|x| x.is_finite() && **x > limits::MAX_MAGNITUDE) {
            return Err(Error::option(
                what,
                format!("must be at most {}, got {}", limits::num(limits::MAX_MAGNITUDE), limits::num(*x)),
            ));
        }
    }
    Ok(())
}

/// The optimisation problem over one period (or `span`, the duration when shorter): the
/// criterion on `opt_samples` samples (at least enough rows for the base parameters), the
/// bounds on a grid of `64 h` points (at least as fine).
fn problem<'a>(
    robot: &'a Robot,
    base: &'a BaseParams,
    opts: &ExciteOptions,
    boxes: Vec<Box1>,
    span: f64,
) -> Problem<'a> {
    let (n, h) = (robot.dof(), opts.harmonics);
    let rows_needed = base.base_count().div_ceil(n) + 1;
    let kk = opts.opt_samples.max(rows_needed);
    let omega = std::f64::consts::TAU * opts.f0_hz;
    // half-step offset: t = 0 is a rest point (qd = 0), where the Coulomb column sign(qd)
    // would flip with rounding
    let crit_times: Vec<f64> = (0..kk).map(|k| span * (k as f64 + 0.5) / kk as f64).collect();
    let nb = (64 * h).max(kk);
    let bound_times: Vec<f64> = (0..=nb).map(|k| span * k as f64 / nb as f64).collect();
    let coulomb = base.independent.iter().map(|&c| (0..n).any(|j| drive_col(n, j, FC) == c)).collect();
    Problem {
        robot,
        base,
        n,
        h,
        omega,
        boxes,
        crit_grid: Basis::new(omega, h, &crit_times),
        bound_grid: Basis::new(omega, h, &bound_times),
        criterion: opts.criterion,
        coulomb,
    }
}

/// The written samples: the final scaling into the bounds is done on the written samples
/// themselves (those within the span), so the trajectory a robot replays is inside the
/// limits at every written sample; then sampled over the whole duration and scored.
struct Written<'p, 'a> {
    pr: &'p Problem<'a>,
    /// Every written time, `0..=duration` at the rate.
    times: Vec<f64>,
    /// The basis at the written times within the span.
    grid: Basis,
}

impl<'p, 'a> Written<'p, 'a> {
    /// The written times at `opts.rate_hz` and their basis within `span`.
    fn new(pr: &'p Problem<'a>, opts: &ExciteOptions, span: f64) -> Self {
        let steps = (opts.duration_s * opts.rate_hz).round() as usize;
        let times: Vec<f64> = (0..=steps).map(|k| k as f64 / opts.rate_hz).collect();
        let in_span: Vec<f64> = times.iter().copied().filter(|&t| t <= span + 1e-12).collect();
        let grid = Basis::new(pr.omega, pr.h, &in_span);
        Written { pr, times, grid }
    }

    /// Coefficients, written samples and their scores for the variables `x`.
    fn finish(&self, x: &[f64]) -> Result<(Coeffs, Samples, Scores)> {
        let (co, _) = self.pr.realise(x, &self.grid);
        let s = sample(&co, &self.times);
        let sc = scores(self.pr.robot, self.pr.base, &s)?;
        Ok((co, s, sc))
    }
}

/// Scores of `opts.random_draws` random trajectories (their own seed stream) on the
/// written samples: median and best of each criterion.
fn random_comparison(
    pr: &Problem,
    written: &Written,
    opts: &ExciteOptions,
    tick: &dyn Fn(),
) -> Result<RandomComparison> {
    let mut rng = Rng::new(opts.seed.wrapping_mul(0x9E37_79B9).wrapping_add(17));
    let mut rc = vec![];
    let mut rl = vec![];
    for _ in 0..opts.random_draws {
        let x = pr.random_x(&mut rng);
        let (_, _, sc) = written.finish(&x)?;
        rc.push(sc.cond);
        rl.push(sc.logdet);
        tick();
    }
    Ok(RandomComparison {
        draws: rc.len(),
        cond_min: rc.iter().cloned().fold(f64::INFINITY, f64::min),
        logdet_max: rl.iter().cloned().fold(f64::NEG_INFINITY, f64::max),
        cond_median: median(&mut rc),
        logdet_median: median(&mut rl),
    })
}

/// Median (NaN when empty); sorts `v`.
fn median(v: &mut [f64]) -> f64 {
    if v.is_empty() {
        return f64::NAN;
    }
    v.sort_by(|a, b| a.total_cmp(b));
    let m = v.len();
    if m % 2 == 1 { v[m / 2] } else { 0.5 * (v[m / 2 - 1] + v[m / 2]) }
}

/// Multi-start optimisation (seeded starts): the variables of the start that ends lowest
/// (the first on ties).
fn optimise(pr: &Problem, opts: &ExciteOptions, tick: &dyn Fn()) -> Result<Vec<f64>> {
    let mut rng = Rng::new(opts.seed);
    let mut best: Option<(Vec<f64>, f64)> = None;
    for _ in 0..opts.starts {
        let x0 = pr.random_x(&mut rng);
        let (x, f) = optimise_from(pr, x0, opts, tick)?;
        if best.as_ref().is_none_or(|(_, fb)| f < *fb) {
            best = Some((x, f));
        }
    }
    Ok(best.expect("at least one start").0)
}

/// One start: L-BFGS by continuation on the smooth surrogate of log cond (the exact one is
/// a min-max, non-smooth where eigenvalues cross, on which L-BFGS stalls), then the exact
/// one; the iterations shared between the stages. Returns the end point and its criterion.
fn optimise_from(pr: &Problem, x0: Vec<f64>, opts: &ExciteOptions, tick: &dyn Fn()) -> Result<(Vec<f64>, f64)> {
    let stages: &[Option<f64>] = match opts.criterion {
        Criterion::Cond => &[Some(4.0), Some(16.0), None],
        Criterion::Logdet => &[None],
    };
    let mut x = x0;
    let mut f = f64::INFINITY;
    for (si, &sh) in stages.iter().enumerate() {
        let it = opts.iterations * (si + 1) / stages.len() - opts.iterations * si / stages.len();
        (x, _) = lbfgs(pr, x, it, sh, tick)?;
        f = pr.eval(&x, false, None)?.f;
        if std::env::var("IVDYN_DEBUG").is_ok() {
            eprintln!("stage {si} f {f}");
        }
    }
    Ok((x, f))
}

/// Remarks on the options (a duration that is not a whole number of periods).
fn notes(opts: &ExciteOptions) -> Vec<String> {
    let mut notes = vec![];
    let periods = opts.duration_s * opts.f0_hz;
    if (periods - periods.round()).abs() > 1e-9 {
        notes.push(format!("the duration is {periods:.3} periods of 1/f0: the trajectory does not end at rest (choose a whole number of periods)"));
    }
    notes
}

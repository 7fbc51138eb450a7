//! Each joint's Coulomb-friction shape, chosen by held-out validation.
//!
//! The paper's friction `fc sign(qd)` (eq 8) steps at zero velocity. A real drive's
//! friction rises over a velocity band, and a logged or differentiated velocity dithers
//! around zero while a joint is held, so the step puts `±fc` into samples where the joint
//! does not move. The candidates per joint ([`ivdyn_core::CoulombShape`]) are the smooth
//! sign `s(qd) = tanh(qd / v_s)` on a grid of velocity scales ([`SCALES`] times the joint's
//! RMS velocity) and, for the sign and the chosen smooth sign, a direction-dependent
//! variant: an extra column `|s(qd)|` with its own coefficient `fd` (`fc± = fc ± fd`,
//! kept in the model as `asym = fd / fc`). The extra column differs from the offset
//! `tau0` only where `|s| < 1`, at low speed and standstill.
//!
//! Every candidate is scored by cross-validation over [`FOLDS`] blocks of time: each block's
//! residual under a fit on the others, all joints fitted together (they share the inertial
//! parameters). A richer shape
//! replaces a simpler one only when it lowers that joint's held-out RMS by [`GAIN`].
//! The statistics are per-joint QR factors of `[phi_i | candidates_i | tau_i]`
//! ([`ShapeStats`]): any candidate's fit and held-out residual follow from them without
//! the data, so the choice costs one pass over the rows.

use ivdyn_core::CoulombShape;
use nalgebra::DVector;
use serde::Serialize;

use crate::error::{Error, Result};
use crate::ident::{LsAccumulator, fit_ls};

/// Velocity scales tried, as fractions of the joint's RMS velocity (a factor 2 apart).
pub const SCALES: [f64; 9] = [0.002, 0.004, 0.008, 0.016, 0.032, 0.064, 0.128, 0.256, 0.512];
/// Number of velocity scales.
pub const K: usize = SCALES.len();
/// Candidate columns per joint: `s_1..s_K`, `|sign|`, `|s_1|..|s_K|`.
pub const WIDTH: usize = 2 * K + 1;
/// Relative cross-validated RMS a richer shape must gain to be chosen: a guard against
/// the best of ~20 candidates winning by chance. On simulated UR5 logs whose truth is the
/// exact sign (0.05 N m noise, seeds 3-8), the best smooth candidate gained at most 0.27 %;
/// a real smooth friction gains tens of percent.
pub const GAIN: f64 = 0.01;
/// The direction-dependent coefficient `fd` must exceed this many of its standard
/// deviations (two-sided 99.7 % under the fit's noise model; the held-out gain alone lets a
/// column that soaks up a little unmodelled structure through).
pub const ASYM_Z: f64 = 3.0;
/// Largest direction asymmetry kept (`|fd / fc|`): beyond it the "Coulomb" term is mostly
/// an offset and the split is not trusted.
pub const MAX_ASYM: f64 = 0.9;

/// The candidate columns of one sample's joint velocities `qd` (`n`), scales `v` (`n x K`,
/// absolute): `n x WIDTH`, joint-major, appended to `out`.
pub fn candidate_row(qd: &[f64], v: &[[f64; K]], out: &mut Vec<f64>) {
    for (x, vj) in qd.iter().zip(v) {
        let s: [f64; K] = core::array::from_fn(|k| CoulombShape { v_scale: vj[k], asym: 0.0 }.value(*x));
        out.extend_from_slice(&s);
        out.push(CoulombShape::SIGN.value(*x).abs());
        out.extend(s.iter().map(|s| s.abs()));
    }
}

/// The absolute scales of each joint: [`SCALES`] times its RMS velocity `rms` (a joint
/// that does not move gets the fractions themselves, in rad/s).
pub fn scales_for(rms: &[f64]) -> Vec<[f64; K]> {
    rms.iter().map(|r| SCALES.map(|f| f * if *r > 0.0 { *r } else { 1.0 })).collect()
}

/// The smallest velocity scale the data can tell from the sign: the transition `|qd| < v`
/// lasts about `v / |qdd|` at a reversal, and after the parallel low-pass (cut-off `f_c`)
/// one shorter than `1 / (2 pi f_c)` looks like a step. So `v_min = rms(qdd) / (2 pi f_c)`
/// per joint; smaller scales only let a candidate fit the noise near reversals (on
/// simulated logs whose truth is the exact sign they were picked, with scales of 0.1-0.3 %
/// of the RMS velocity).
pub fn resolvable_scale(rms_qdd: &[f64], cutoff_hz: f64) -> Vec<f64> {
    rms_qdd.iter().map(|a| a / (2.0 * core::f64::consts::PI * cutoff_hz)).collect()
}

/// The scales of a second, finer pass: around each joint's chosen smooth scale, a factor
/// `2^(1/4)` apart over a factor 2 either way (the coarse grid's step); a joint that kept
/// the sign keeps the coarse grid.
pub fn refine(scales: &[[f64; K]], sel: &Selection) -> Vec<[f64; K]> {
    scales
        .iter()
        .zip(&sel.columns)
        .map(|(v, (smooth, _))| match smooth {
            Some(k) => core::array::from_fn(|i| v[*k] * 2f64.powf((i as f64 - (K / 2) as f64) / 4.0)),
            None => *v,
        })
        .collect()
}

/// Per-joint statistics of the rows `[phi_i (b) | candidates_i (WIDTH)] -> tau_i` in
/// [`FOLDS`] contiguous folds: each fold is scored by a fit on the others (cross-validation
/// over blocks of time, so that one unusual stretch does not decide).
pub struct ShapeStats {
    n: usize,
    b: usize,
    /// `[fold][joint]`.
    folds: Vec<Vec<LsAccumulator>>,
    samples: usize,
}

/// Folds of the cross-validation.
pub const FOLDS: usize = 4;

impl ShapeStats {
    /// Empty statistics for `n` joints and `b` base parameters.
    pub fn new(n: usize, b: usize) -> Self {
        let folds = (0..FOLDS).map(|_| (0..n).map(|_| LsAccumulator::new(b + WIDTH)).collect()).collect();
        ShapeStats { n, b, folds, samples: 0 }
    }

    /// Adds `T` samples to fold `fold`: `phi` `T x n x b`, `cand` `T x n x WIDTH`, `tau` `T x n`.
    pub fn add(&mut self, fold: usize, phi: &[f64], cand: &[f64], tau: &[f64]) -> Result<()> {
        let (n, b) = (self.n, self.b);
        let t = tau.len() / n;
        if phi.len() != t * n * b || cand.len() != t * n * WIDTH || fold >= FOLDS {
            return Err(Error::Dimension {
                what: "ShapeStats::add: phi and candidates".into(),
                expected: t * n * b,
                got: phi.len(),
            });
        }
        let mut row = Vec::with_capacity(t * (b + WIDTH));
        for (i, acc) in self.folds[fold].iter_mut().enumerate() {
            row.clear();
            for k in 0..t {
                row.extend_from_slice(&phi[(k * n + i) * b..(k * n + i + 1) * b]);
                row.extend_from_slice(&cand[(k * n + i) * WIDTH..(k * n + i + 1) * WIDTH]);
            }
            let y: Vec<f64> = (0..t).map(|k| tau[k * n + i]).collect();
            acc.add_rows(&row, &y, None)?;
        }
        self.samples += t;
        Ok(())
    }

    /// The statistics of every fold but `skip` (`None`: all), per joint.
    fn merged(&self, skip: Option<usize>) -> Result<Vec<LsAccumulator>> {
        let mut out: Vec<LsAccumulator> = (0..self.n).map(|_| LsAccumulator::new(self.b + WIDTH)).collect();
        for (f, fold) in self.folds.iter().enumerate().filter(|(f, _)| Some(*f) != skip) {
            debug_assert!(Some(f) != skip);
            for (o, a) in out.iter_mut().zip(fold) {
                o.merge(a)?;
            }
        }
        out.iter_mut().for_each(LsAccumulator::finish);
        Ok(out)
    }
}

/// The training statistics of each fold (all the others) and of all folds together.
struct Training {
    per_fold: Vec<Vec<LsAccumulator>>,
    all: Vec<LsAccumulator>,
}

impl Training {
    fn of(s: &ShapeStats) -> Result<Self> {
        Ok(Training { per_fold: (0..FOLDS).map(|f| s.merged(Some(f))).collect::<Result<_>>()?, all: s.merged(None)? })
    }
}

/// One joint's candidate: the smooth sign's scale index (`None`: the exact sign) and
/// whether the direction-dependent column is added.
#[derive(Debug, Clone, Copy, PartialEq)]
struct Opt {
    smooth: Option<usize>,
    asym: bool,
}

const SIGN: Opt = Opt { smooth: None, asym: false };

/// The shape chosen for one joint, as reported.
#[derive(Debug, Clone, Serialize)]
pub struct CoulombChoice {
    /// Joint name.
    pub joint: String,
    /// `"sign"`, `"smooth"`, `"sign, direction-dependent"` or `"smooth, direction-dependent"`.
    pub shape: String,
    /// Velocity scale of the smooth sign (0: the exact sign).
    pub v_scale: f64,
    /// Direction asymmetry `fd / fc` (0: symmetric).
    pub asym: f64,
    /// Held-out RMS residual of this joint with the sign (as in the paper).
    pub heldout_rms_sign: f64,
    /// Held-out RMS residual of this joint with the chosen shape.
    pub heldout_rms: f64,
}

/// The per-joint choice and the shapes to give the model.
pub struct Selection {
    /// One per joint.
    pub choices: Vec<CoulombChoice>,
    /// The model's Coulomb shapes.
    pub shapes: Vec<CoulombShape>,
    /// Per joint: the smooth sign's candidate column (`None`: the sign) and the
    /// direction-dependent column when chosen (indices into a joint's [`WIDTH`] columns).
    pub columns: Vec<(Option<usize>, Option<usize>)>,
}

/// A candidate set's fit: every joint's held-out residual sum of squares and the
/// direction coefficients `fd` and `fc` of each joint (0 when not fitted).
struct Scored {
    rss: Vec<f64>,
    fc: Vec<f64>,
    fd: Vec<f64>,
    fd_std: Vec<f64>,
}

/// The local columns of joint `i`'s statistics under `o` and their global columns
/// (`b` base parameters, then one `fd` per joint with `asym`, in joint order).
fn columns(b: usize, fc_col: Option<usize>, o: Opt, fd_col: usize) -> Vec<(usize, usize)> {
    let mut m: Vec<(usize, usize)> = (0..b).map(|c| (c, c)).collect();
    if let (Some(fc), Some(k)) = (fc_col, o.smooth) {
        m[fc] = (b + k, fc);
    }
    if o.asym {
        m.push((o.smooth.map_or(b + K, |k| b + K + 1 + k), fd_col));
    }
    m
}

/// Fits all joints under `opts` (weights `w`) on each fold's training statistics and
/// scores every joint on the fold held out (the sum over the folds); `fc`, `fd` come from
/// the fit on all folds.
fn score(s: &ShapeStats, tr: &Training, fc_col: &[Option<usize>], opts: &[Opt], w: &[f64]) -> Result<Scored> {
    let (n, b) = (s.n, s.b);
    let fd_cols: Vec<usize> = opts
        .iter()
        .scan(b, |next, o| {
            Some(if o.asym {
                *next += 1;
                *next - 1
            } else {
                usize::MAX
            })
        })
        .collect();
    let g = b + opts.iter().filter(|o| o.asym).count();
    let maps: Vec<_> = (0..n).map(|i| columns(b, fc_col[i], opts[i], fd_cols[i])).collect();
    let mut rss = vec![0.0; n];
    for (f, train) in tr.per_fold.iter().enumerate() {
        let theta = fit_global(train, &maps, g, b, w)?.theta;
        for (i, r) in rss.iter_mut().enumerate() {
            *r += held_out_rss(&s.folds[f][i], &maps[i], &theta, b);
        }
    }
    let fit = fit_global(&tr.all, &maps, g, b, w)?;
    let theta = finite(&fit.theta);
    let fc = (0..n).map(|i| fc_col[i].map_or(0.0, |c| theta[c])).collect();
    let fd = (0..n).map(|i| if opts[i].asym { theta[fd_cols[i]] } else { 0.0 }).collect();
    let fd_std = (0..n).map(|i| if opts[i].asym { fit.std[fd_cols[i]] } else { f64::NAN }).collect();
    Ok(Scored { rss, fc, fd, fd_std })
}

/// `theta` with unexcited (NaN) entries at 0.
fn finite(theta: &[f64]) -> Vec<f64> {
    theta.iter().map(|t| if t.is_finite() { *t } else { 0.0 }).collect()
}

/// Joint `i`'s residual sum of squares on `test` for the global parameters `theta`.
fn held_out_rss(test: &LsAccumulator, map: &[(usize, usize)], theta: &[f64], b: usize) -> f64 {
    let theta = finite(theta);
    let mut v = DVector::zeros(b + WIDTH + 1);
    for &(l, c) in map {
        v[l] = theta[c];
    }
    v[b + WIDTH] = -1.0;
    (test.r_aug() * v).norm_squared()
}

/// The LS fit of all joints' statistics `train` (joint `i` weighted by `w[i]`) in the
/// `g` global columns: every joint's `‖R_aug,i [θ_i; -1]‖²` with its columns mapped.
fn fit_global(
    train: &[LsAccumulator],
    maps: &[Vec<(usize, usize)>],
    g: usize,
    b: usize,
    w: &[f64],
) -> Result<crate::ident::FitReport> {
    let mut acc = LsAccumulator::new(g);
    for (i, tr) in train.iter().enumerate() {
        let r = tr.r_aug();
        let (mut rows, mut y) = (vec![], vec![]);
        for row in 0..r.nrows() {
            let mut x = vec![0.0; g];
            for &(l, c) in &maps[i] {
                x[c] = r[(row, l)];
            }
            rows.extend(x);
            y.push(r[(row, b + WIDTH)]);
        }
        acc.add_rows(&rows, &y, Some(&vec![w[i]; y.len()]))?;
    }
    acc.finish();
    let names: Vec<String> = (0..g).map(|c| format!("c{c}")).collect();
    fit_ls(&acc, &names)
}

/// Chooses each joint's shape (see the module docs). `fc_col[i]`: the base column of
/// joint `i`'s `fc` (`None`: Coulomb friction not fitted there, the sign is kept);
/// `scales` from [`scales_for`]; `joints` names them.
/// Scales below `v_min[j]` are not tried ([`resolvable_scale`]).
pub fn select(
    s: &ShapeStats,
    fc_col: &[Option<usize>],
    scales: &[[f64; K]],
    v_min: &[f64],
    joints: &[String],
) -> Result<Selection> {
    let n = s.n;
    let rms = |rss: f64| (rss / s.samples.max(1) as f64).sqrt();
    let tr = Training::of(s)?;
    // weights from the sign model's held-out residuals (two-step WLS, as the fit)
    let ones = vec![1.0; n];
    let mut opts = vec![SIGN; n];
    let first = score(s, &tr, fc_col, &opts, &ones)?;
    let w = crate::ident::wls::per_joint_weights(&first.rss.iter().map(|r| rms(*r)).collect::<Vec<_>>());
    let sign = score(s, &tr, fc_col, &opts, &w)?;
    let mut best = sign.rss.clone();
    let mut fd_fc = vec![(0.0, 0.0); n];
    for j in (0..n).filter(|&j| fc_col[j].is_some()) {
        let better = |new: f64, old: f64| new < old * (1.0 - GAIN).powi(2);
        let (mut smooth, mut smooth_rss) = (SIGN, f64::INFINITY);
        for o in (0..K).filter(|&k| scales[j][k] >= v_min[j]).map(|k| Opt { smooth: Some(k), asym: false }) {
            let trial = try_opt(&mut opts, j, o, s, &tr, fc_col, &w)?;
            if trial.rss[j] < smooth_rss {
                (smooth, smooth_rss) = (o, trial.rss[j]);
            }
        }
        if better(smooth_rss, best[j]) {
            (opts[j], best[j]) = (smooth, smooth_rss);
        }
        let o = Opt { asym: true, ..opts[j] };
        let trial = try_opt(&mut opts, j, o, s, &tr, fc_col, &w)?;
        let (fc, fd) = (trial.fc[j], trial.fd[j]);
        let significant = fd.abs() > ASYM_Z * trial.fd_std[j];
        if better(trial.rss[j], best[j]) && significant && fc > 0.0 && (fd / fc).abs() <= MAX_ASYM {
            (opts[j], best[j], fd_fc[j]) = (o, trial.rss[j], (fd, fc));
        }
    }
    let shapes: Vec<CoulombShape> = (0..n)
        .map(|j| CoulombShape {
            v_scale: opts[j].smooth.map_or(0.0, |k| scales[j][k]),
            asym: if opts[j].asym { fd_fc[j].0 / fd_fc[j].1 } else { 0.0 },
        })
        .collect();
    let choices = (0..n)
        .map(|j| CoulombChoice {
            joint: joints[j].clone(),
            shape: match (opts[j].smooth, opts[j].asym) {
                (None, false) => "sign",
                (Some(_), false) => "smooth",
                (None, true) => "sign, direction-dependent",
                (Some(_), true) => "smooth, direction-dependent",
            }
            .into(),
            v_scale: shapes[j].v_scale,
            asym: shapes[j].asym,
            heldout_rms_sign: rms(sign.rss[j]),
            heldout_rms: rms(best[j]),
        })
        .collect();
    let columns = opts.iter().map(|o| (o.smooth, o.asym.then(|| o.smooth.map_or(K, |k| K + 1 + k)))).collect();
    Ok(Selection { choices, shapes, columns })
}

/// Scores `opts` with joint `j`'s candidate replaced by `o` (restored afterwards).
fn try_opt(
    opts: &mut [Opt],
    j: usize,
    o: Opt,
    s: &ShapeStats,
    tr: &Training,
    fc_col: &[Option<usize>],
    w: &[f64],
) -> Result<Scored> {
    let keep = opts[j];
    opts[j] = o;
    let r = score(s, tr, fc_col, opts, w);
    opts[j] = keep;
    r
}

//! The candidate effects' regressor columns and their Gram matrices.
//!
//! Every effect of the vocabulary is linear in its parameters once its shape is fixed
//! (Stribeck's `vs` is chosen on a grid), so the torque the nominal model misses is
//! `r = tau - rnea_nominal(q, qd, qdd) = X theta + e`, with `X` built from a small
//! per-joint dictionary: `1, q, qd, sign(qd), qdd`, Stribeck shapes, and the terminal
//! link's 10 regressor columns (a payload is a change of the terminal link's inertial
//! parameters, eqs 39-40 of the paper: the terminal-link model with every joint's row).
//! The data enter only through per-joint, per-fold Gram matrices of that dictionary, so
//! scoring dozens of candidate models costs microseconds each, whatever the log length.

use nalgebra::DMatrix;

use super::signals::Signals;
use crate::Robot;
use crate::batch;
use crate::error::{Error, Result};
use crate::ident::base::BaseParams;

pub(super) const C_ONE: usize = 0;
pub(super) const C_Q: usize = 1;
pub(super) const C_QD: usize = 2;
pub(super) const C_SIGN: usize = 3;
pub(super) const C_QDD: usize = 4;
/// Stribeck shapes `exp(-(qd/vs)^2) sign(qd)`, `vs` = these fractions of the joint's RMS speed.
pub(super) const STRIBECK_VS: [f64; 5] = [0.02, 0.05, 0.1, 0.2, 0.4];
pub(super) const C_STRIBECK: usize = 5;
/// The positive-velocity indicator `[qd > 0]`: with `sign(qd)`, direction-dependent
/// Coulomb friction `fc_pos [qd > 0] - fc_neg [qd < 0]`.
pub(super) const C_SIGN_POS: usize = C_STRIBECK + STRIBECK_VS.len();
/// Smooth Coulomb shapes `tanh(qd / vs)`, `vs` = these fractions of the joint's RMS speed: a
/// sigmoid narrower than that is Coulomb friction seen through a stick phase or a
/// differentiated velocity (both smear the sign over a few % of the speed).
pub(super) const SMOOTH_VS: [f64; 5] = [0.15, 0.2, 0.3, 0.4, 0.6];
pub(super) const C_TANH: usize = C_SIGN_POS + 1;
/// Load-dependent friction `|tau_nom| sign(qd)` (the joint's nominal rigid-body torque as
/// its load, as in a harmonic drive).
pub(super) const C_LOAD: usize = C_TANH + SMOOTH_VS.len();
/// Torque gain: the joint's nominal rigid-body torque (measured = k x true: `(k - 1) tau_nom`).
pub(super) const C_GAIN: usize = C_LOAD + 1;
/// Time delay, first order: `-d tau_nom / dt` (`tau(t - d) = tau(t) - d tau'(t) + ..`).
pub(super) const C_DELAY: usize = C_GAIN + 1;
/// Ripple harmonics `sin(n q), cos(n q)` (period `2 pi / n`) for these `n`.
pub(super) const RIPPLE_N: [f64; 5] = [4.0, 6.0, 8.0, 12.0, 16.0];
pub(super) const C_RIPPLE: usize = C_DELAY + 1;
/// The stick phase, `sign(qd)` where the joint is at rest (`REST_SHARE` of its RMS speed) and
/// 0 elsewhere: there a joint held by its friction has any friction within the static level,
/// not the Stribeck shape's peak (`Model::stick`).
pub(super) const C_STUCK: usize = C_RIPPLE + 2 * RIPPLE_N.len();
pub(super) const C_PAYLOAD: usize = C_STUCK + 1;
/// Link-scale columns of the look-alike check and the nominal re-fit: link i's nominal
/// torque on the joint split by the parts of its inertial parameters, `Y_i,g theta_i,g`
/// for g = its mass, its first moment (mass times COM) and its rotational inertia, at
/// `C_LINK + LINK_GROUPS i + g` (a wrong mass, COM or inertia scales one of them).
pub(super) const C_LINK: usize = C_PAYLOAD + 10;
/// Parts of a link's 10 inertial parameters that are scaled separately: `[lo, hi)`.
pub(super) const LINK_GROUPS: [(usize, usize); 3] = [(0, 1), (1, 4), (4, 10)];
const NCOLS: usize = C_LINK + LINK_GROUPS.len() * crate::MAX_DOF;
/// The target (the nominal residual) is the Gram column after the fixed dictionary.
pub(super) const C_TARGET: usize = NCOLS;
/// Base-parameter columns of the nominal re-fit (`refit`), after the target: the base
/// regressor of the links before the terminal one, `Y_b` with `tau = Y_b theta_b`
/// (`Dictionary::base` says which combinations of inertial parameters they are).
pub(super) const C_BASE: usize = C_TARGET + 1;

/// Per joint: the dictionary columns over the log (`NCOLS` vectors of length `T`).
pub(super) struct Dictionary {
    pub(super) cols: Vec<Vec<Vec<f64>>>,
    /// Nominal residual per joint.
    pub(super) r0: Vec<Vec<f64>>,
    /// Stribeck `vs` values per joint (rad/s or m/s).
    pub(super) vs: Vec<[f64; 5]>,
    /// Smooth Coulomb `vs` values per joint (rad/s or m/s).
    pub(super) smooth_vs: Vec<[f64; 5]>,
    /// Mean position per joint (the spring's reference for conditioning).
    pub(super) q_mean: Vec<f64>,
    /// The ripple harmonic of each slot `C_RIPPLE + 2 g` per joint: `RIPPLE_N`, but for a
    /// named ripple's period fitted between them (`ripple_period`), and that fit's standard
    /// error (`None`: a grid entry).
    pub(super) ripple_h: Vec<[(f64, Option<f64>); RIPPLE_N.len()]>,
    /// The rigid-body base parameters of the links before the terminal one (the columns
    /// from `C_BASE` on; the terminal link's are left out: a change there is a payload).
    pub(super) base: BaseParams,
    /// The log's contiguous segments (sample ranges) and sample period (s): time shifts
    /// stop at a segment's ends.
    pub(super) segments: Vec<std::ops::Range<usize>>,
    pub(super) dt: f64,
}

impl Dictionary {
    /// Number of base-parameter columns of the nominal re-fit.
    pub(super) fn nbase(&self) -> usize {
        self.base.base_count()
    }
}

/// Random states for the base parameters of the re-fit (the rank settles within a few
/// hundred; seeded, so the columns and their names do not depend on the log).
const BASE_SAMPLES: usize = 200;

/// The rigid-body base parameters of every link but the terminal one (whose 10 columns
/// are zeroed, so no base parameter contains them).
pub(super) fn refit_base(robot: &Robot) -> Result<BaseParams> {
    let n = robot.dof();
    let terminal: Vec<usize> = (10 * (n - 1)..10 * n).collect();
    crate::ident::base::robot_base_params_excluding(robot, BASE_SAMPLES, 15, true, &terminal)
}

/// No base-parameter columns (the passes that only choose the conditioning).
fn no_base(n: usize) -> BaseParams {
    BaseParams {
        full_cols: 10 * n,
        independent: vec![],
        dependent: vec![],
        k: DMatrix::zeros(0, 0),
        zero_columns: vec![],
        names: vec![],
    }
}

/// The dictionary over the conditioned log `s`, and the nominal residual `tau - tau_nom`;
/// the re-fit's base-parameter columns only `with_base`.
pub(super) fn build_dictionary(
    robot: &Robot,
    s: &Signals,
    tau_nom: &[f64],
    with_base: bool,
    threads: usize,
) -> Result<Dictionary> {
    let n = robot.dof();
    let t_len = s.t.len();
    let p_full = robot.num_params();
    let base = if with_base { refit_base(robot)? } else { no_base(n) };
    let nb = base.base_count();
    // each joint's own columns (independent: on the machine's cores, `par`)
    let joints: Vec<usize> = (0..n).collect();
    let per_joint = crate::par::map(threads, &joints, |&j| joint_columns(s, tau_nom, n, j, C_BASE + nb));
    let mut cols = Vec::with_capacity(n);
    let (mut vs, mut smooth_vs, mut q_mean) = (vec![], vec![], vec![]);
    for (c, v, sv, qm) in per_joint {
        cols.push(c);
        vs.push(v);
        smooth_vs.push(sv);
        q_mean.push(qm);
    }
    // the terminal link's 10 regressor columns, in blocks (the whole regressor would be
    // T x N x 14N doubles)
    let link = 10 * (n - 1);
    let theta_nom = robot.params();
    let block = 2048;
    let mut y = vec![0.0; block * n * p_full];
    for k0 in (0..t_len).step_by(block) {
        let k1 = (k0 + block).min(t_len);
        let m = k1 - k0;
        let out = &mut y[..m * n * p_full];
        batch::regressor_batch(robot, &s.q[k0 * n..k1 * n], &s.qd[k0 * n..k1 * n], &s.qdd[k0 * n..k1 * n], out, false)
            .map_err(|e| Error::during("regressor", e))?;
        // each joint's rows into its own columns (on the machine's cores, `par`)
        let out = &*out;
        crate::par::for_each_mut(threads, &mut cols, |j, cj| {
            for kk in 0..m {
                let row = &out[(kk * n + j) * p_full..(kk * n + j + 1) * p_full];
                for c in 0..10 {
                    cj[C_PAYLOAD + c][k0 + kk] = row[link + c];
                }
                for i in 0..n {
                    for (g, &(lo, hi)) in LINK_GROUPS.iter().enumerate() {
                        cj[C_LINK + LINK_GROUPS.len() * i + g][k0 + kk] =
                            (lo..hi).map(|c| row[10 * i + c] * theta_nom[10 * i + c]).sum();
                    }
                }
                for (b, &c) in base.independent.iter().enumerate() {
                    cj[C_BASE + b][k0 + kk] = row[c];
                }
            }
        });
    }
    let r0 = (0..n).map(|j| (0..t_len).map(|k| s.tau[k * n + j] - tau_nom[k * n + j]).collect()).collect();
    let ripple_h = vec![RIPPLE_N.map(|h| (h, None)); n];
    Ok(Dictionary { cols, r0, vs, smooth_vs, q_mean, ripple_h, base, segments: s.segments(), dt: s.dt })
}

/// Joint `j`'s own columns over the log (`size` slots; the target's and the rigid-body
/// ones are filled by the caller), its Stribeck and smooth-friction speeds and its mean `q`.
fn joint_columns(s: &Signals, tau_nom: &[f64], n: usize, j: usize, size: usize) -> JointColumns {
    let t_len = s.t.len();
    // the target's slot stays empty (the residual is `r0`)
    let mut c: Vec<Vec<f64>> = (0..size).map(|c| if c == C_TARGET { vec![] } else { vec![0.0; t_len] }).collect();
    let (mut vs, mut smooth_vs) = ([0.0; 5], [0.0; 5]);
    let qd_rms = ((0..t_len).map(|k| s.qd[k * n + j].powi(2)).sum::<f64>() / t_len as f64).sqrt().max(1e-9);
    let q_mean = (0..t_len).map(|k| s.q[k * n + j]).sum::<f64>() / t_len as f64;
    for (g, f) in STRIBECK_VS.iter().enumerate() {
        vs[g] = f * qd_rms;
    }
    for (g, f) in SMOOTH_VS.iter().enumerate() {
        smooth_vs[g] = f * qd_rms;
    }
    for k in 0..t_len {
        let (q, qd, qdd) = (s.q[k * n + j], s.qd[k * n + j], s.qdd[k * n + j]);
        let sg = if qd > 0.0 {
            1.0
        } else if qd < 0.0 {
            -1.0
        } else {
            0.0
        };
        c[C_ONE][k] = 1.0;
        c[C_Q][k] = q - q_mean;
        c[C_QD][k] = qd;
        c[C_SIGN][k] = sg;
        c[C_QDD][k] = qdd;
        // the Stribeck shapes where the joint slides; at rest the stick column stands for them
        let stuck = qd.abs() <= REST_SHARE * qd_rms;
        for g in 0..STRIBECK_VS.len() {
            c[C_STRIBECK + g][k] = if stuck { 0.0 } else { (-(qd / vs[g]).powi(2)).exp() * sg };
        }
        c[C_STUCK][k] = if stuck { sg } else { 0.0 };
        drive_columns(&mut c, k, q, qd, tau_nom[k * n + j], &smooth_vs);
    }
    delay_column(&mut c[C_DELAY], tau_nom, n, j, s.dt, &s.segments());
    (c, vs, smooth_vs, q_mean)
}

/// A joint's columns, Stribeck speeds, smooth-friction speeds and mean `q`.
type JointColumns = (Vec<Vec<f64>>, [f64; 5], [f64; 5], f64);

/// Sample `k` of the real-drive columns of one joint (`tau`: its nominal rigid-body torque).
fn drive_columns(c: &mut [Vec<f64>], k: usize, q: f64, qd: f64, tau: f64, smooth_vs: &[f64; 5]) {
    let sg = c[C_SIGN][k];
    c[C_SIGN_POS][k] = if qd > 0.0 { 1.0 } else { 0.0 };
    for (g, v) in smooth_vs.iter().enumerate() {
        c[C_TANH + g][k] = (qd / v).tanh();
    }
    c[C_LOAD][k] = tau.abs() * sg;
    c[C_GAIN][k] = tau;
    for (g, h) in RIPPLE_N.iter().enumerate() {
        let (sn, cs) = (h * q).sin_cos();
        c[C_RIPPLE + 2 * g][k] = sn;
        c[C_RIPPLE + 2 * g + 1][k] = cs;
    }
}

/// `-d tau_nom / dt` of joint `j` (central differences, one-sided at the ends of each
/// segment `segs`): the first-order column of a torque that lags the motion.
fn delay_column(out: &mut [f64], tau_nom: &[f64], n: usize, j: usize, dt: f64, segs: &[std::ops::Range<usize>]) {
    let at = |k: usize| tau_nom[k * n + j];
    for seg in segs.iter().filter(|s| s.len() >= 2) {
        for k in seg.clone() {
            let (a, b) = (k.saturating_sub(1).max(seg.start), (k + 1).min(seg.end - 1));
            out[k] = -(at(b) - at(a)) / ((b - a) as f64 * dt);
        }
    }
}

/// Gram matrices `[X r]^T [X r]` per joint and fold.
#[derive(Clone)]
pub(super) struct Grams {
    pub(super) g: Vec<[DMatrix<f64>; 2]>,
    pub(super) rows: Vec<[usize; 2]>,
    /// Ridge on the link-scale parameters in every fit (unit-diagonal normal equations;
    /// 0 unless the nominal re-fit chose one, `refit`).
    pub(super) ridge: f64,
    /// Nominal scale of each re-fit correction (`Dictionary::base` order,
    /// `refit::prior_scales`): with a ridge, the corrections also get a physical prior.
    pub(super) prior: Vec<f64>,
    /// Nominal scale of each of the terminal link's 10 inertial parameters (`m`, `m L`, `m
    /// L^2`, `ident::consistent::scales`): with a ridge, its CAD-error correction
    /// (`Model::terminal_cad`) gets the re-fit's physical prior too.
    pub(super) terminal_prior: Vec<f64>,
}

/// The fold of sample `k`: the log cut into `2 blocks_per_fold` blocks, alternately in
/// fold 0 and 1, so that both folds see every part of the motion.
pub(super) fn fold_of(k: usize, t_len: usize, blocks_per_fold: usize) -> usize {
    let nb = 2 * blocks_per_fold;
    (k * nb / t_len) % 2
}

/// Samples per block of the Gram accumulation (`X^T X` of a block by one matrix product).
const GRAM_BLOCK: usize = 256;

/// The Gram matrices of `d` (and its target), per joint and fold: per block of samples of
/// one fold, `G_f += X^T X` with `X` the block's used columns, by the matrix product
/// (blocked and vectorised: the search's whole cost on a long log was this sum, sample by
/// sample).
pub(super) fn grams(d: &Dictionary, t_len: usize, blocks_per_fold: usize, threads: usize) -> Grams {
    let n = d.cols.len();
    let size = C_BASE + d.nbase();
    // the columns in use (the link columns of links beyond the robot's stay zero)
    let used: Vec<usize> = (0..C_LINK + LINK_GROUPS.len() * n).chain(C_TARGET..size).collect();
    let u = used.len();
    // the joints' sums are independent: on the machine's cores (`par`), each as alone
    let joints: Vec<usize> = (0..n).collect();
    let per_joint = crate::par::map(threads, &joints, |&j| {
        let mut x = DMatrix::<f64>::zeros(GRAM_BLOCK, u);
        let mut rows = [0usize; 2];
        let mut gu = [DMatrix::<f64>::zeros(u, u), DMatrix::<f64>::zeros(u, u)];
        let mut k0 = 0;
        while k0 < t_len {
            let f = fold_of(k0, t_len, blocks_per_fold);
            let mut k1 = k0 + 1;
            while k1 < t_len && k1 - k0 < GRAM_BLOCK && fold_of(k1, t_len, blocks_per_fold) == f {
                k1 += 1;
            }
            let m = k1 - k0;
            for (i, &c) in used.iter().enumerate() {
                let src = if c == C_TARGET { &d.r0[j][k0..k1] } else { &d.cols[j][c][k0..k1] };
                x.view_mut((0, i), (m, 1)).copy_from_slice(src);
            }
            let xb = x.rows(0, m);
            // `gemm` of a transposed copy: nalgebra's `gemm` runs the blocked, vectorised
            // kernel (matrixmultiply) for f64, `gemm_tr` a dot product per entry
            let xt = xb.transpose();
            gu[f].gemm(1.0, &xt, &xb, 1.0);
            rows[f] += m;
            k0 = k1;
        }
        let gj = gu.map(|gf| {
            let mut full = DMatrix::<f64>::zeros(size, size);
            for (ia, &a) in used.iter().enumerate() {
                for (ib, &b) in used.iter().enumerate() {
                    full[(a, b)] = gf[(ia, ib)];
                }
            }
            full
        });
        (gj, rows)
    });
    let (g, rows) = per_joint.into_iter().unzip();
    Grams { g, rows, ridge: 0.0, prior: vec![], terminal_prior: vec![] }
}

/// Joint `j`'s Gram entries of the columns `new` (index, values over the log), which take
/// the place of the dictionary's: each one's products with every column in use, per fold (as
/// `grams` sums them). The dictionary itself is not changed.
pub(super) fn regram(d: &Dictionary, gr: &mut Grams, j: usize, new: &[(usize, &[f64])], blocks_per_fold: usize) {
    let (n, t_len) = (d.cols.len(), d.r0[j].len());
    let size = gr.g[j][0].nrows();
    let rows = Rows::every(t_len, 1, blocks_per_fold);
    let used: Vec<usize> = (0..C_LINK + LINK_GROUPS.len() * n).chain(C_TARGET..size).collect();
    regram_over(d, gr, j, new, &rows, &used);
}

/// Samples of the log (every `stride`-th), each with its fold, and the factor that scales
/// sums over them to sums over the log.
pub(super) struct Rows {
    pub(super) k: Vec<usize>,
    fold: Vec<usize>,
    scale: f64,
}

impl Rows {
    pub(super) fn every(t_len: usize, stride: usize, blocks_per_fold: usize) -> Self {
        let k: Vec<usize> = (0..t_len).step_by(stride.max(1)).collect();
        let fold = k.iter().map(|&k| fold_of(k, t_len, blocks_per_fold)).collect();
        Rows { scale: t_len as f64 / k.len().max(1) as f64, k, fold }
    }
}

/// [`regram`] over the columns `used` alone (the others' entries left as they are) and the
/// samples `rows` (the new columns' values given on those samples only).
pub(super) fn regram_over(
    d: &Dictionary,
    gr: &mut Grams,
    j: usize,
    new: &[(usize, &[f64])],
    rows: &Rows,
    used: &[usize],
) {
    let values = |c: usize| -> std::borrow::Cow<[f64]> {
        let col = match new.iter().find(|x| x.0 == c) {
            Some(x) => return x.1.into(),
            None if c == C_TARGET => &d.r0[j],
            None => &d.cols[j][c],
        };
        if rows.k.len() == col.len() { col.as_slice().into() } else { rows.k.iter().map(|&k| col[k]).collect() }
    };
    for &(c, v) in new {
        for &u in used {
            let mut s = [0.0; 2];
            for ((a, b), &f) in v.iter().zip(values(u).iter()).zip(&rows.fold) {
                s[f] += a * b;
            }
            for (f, sf) in s.into_iter().enumerate() {
                gr.g[j][f][(c, u)] = rows.scale * sf;
                gr.g[j][f][(u, c)] = rows.scale * sf;
            }
        }
    }
}

/// A joint is at rest below this share of its RMS speed (the standstill share of
/// `prep::hygiene`): a stick phase's velocity is zero up to the velocity's noise; the
/// smooth-friction grid starts at 0.15 of the speed (`SMOOTH_VS`), far above it. (Random
/// tuning part, Coulomb levels within 10 %: 0.01, 0.02 and 0.05 alike, 12 of 12;
/// docs/diagnose.md, "Friction levels where the joint moves".)
const REST_SHARE: f64 = crate::prep::hygiene::STANDSTILL_SHARE;

/// The samples where joint `j` moves (`|qd|` above `REST_SHARE` of its RMS speed).
pub(super) fn moving(d: &Dictionary, j: usize) -> Vec<bool> {
    let qd = &d.cols[j][C_QD];
    let rms = (qd.iter().map(|v| v * v).sum::<f64>() / qd.len().max(1) as f64).sqrt();
    qd.iter().map(|v| v.abs() > REST_SHARE * rms).collect()
}

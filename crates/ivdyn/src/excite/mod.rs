//! Excitation design: a finite-Fourier-series trajectory (Swevers et al. 1997,
//! [`ivdyn_core::trajectory::Fourier`]) whose base regressor is as well conditioned as the
//! joint limits allow.
//!
//! # Problem
//! Joint `i` follows `q_i(t) = q0_i + sum_l a_il/(l w) sin(l w t) - b_il/(l w) cos(l w t)`
//! (`w = 2 pi f0`, `l = 1..H`). The criterion is evaluated on the stacked base regressor
//! `Phi` (rows of [`crate::ident::BaseParams`] found by [`crate::ident::robot_base_params`],
//! drive columns included) at `K` samples of one period:
//!
//! * `cond`: minimise `log cond(Phi) = log(s_max / s_min)` (unscaled, SI units, the number
//!   [`crate::ident::FitReport::condition_number`] reports);
//! * `logdet`: maximise `log det(Phi^T Phi / rows)` (D-optimality; unit-invariant in its argmax).
//!
//! # Constraints (scaling into the bounds)
//! Each joint's harmonics are first projected onto `qd(0) = 0`, `qdd(0) = 0`
//! (`sum_l a_il = 0`, `sum_l l b_il = 0`: the trajectory starts, and after every full
//! period ends, at rest), then scaled by the largest factor `s_i` that keeps the joint
//! inside its position, velocity and acceleration limits (shrunk by the safety margin) on a
//! dense time grid. The offset `q0_i = mid_i + half_i tanh(z_i)` stays strictly inside the
//! position range. So every candidate is feasible by construction and the optimiser works
//! on unconstrained variables `(z_i, c_i)`; the map is invariant to the scale of `c_i`.
//!
//! # Optimiser
//! Random multi-start (seeded) + L-BFGS with Armijo backtracking. The gradient is exact up
//! to finite differences of the regressor in `(q, qd, qdd)` per sample (central in `q` and
//! `qd`, which is exact for the quadratic velocity terms; the Coulomb `sign(qd)` columns are
//! piecewise constant and get zero derivative; `Y` is affine in `qdd`), contracted with
//! `dcrit/dPhi = Phi M` (`M = v1 v1^T/l1 - vb vb^T/lb` for `log cond`, `-2 (Phi^T Phi)^-1`
//! for `-log det`), then chained through the bound scaling (envelope theorem at the active
//! bound's sample). That costs `5 N + 1` regressor evaluations per sample, against
//! `2 H N + N + 1` for finite differences on the coefficients.

use std::path::Path;

use nalgebra::DMatrix;
use serde::Serialize;

use crate::Robot;
use crate::error::{Error, Result};
use crate::ident::{BaseParams, LsAccumulator, robot_base_params};
use crate::log::JointLog;
use crate::progress::ProgressSink;
use ivdyn_core::params::{FC, PARAMS_PER_JOINT, drive_col};
use ivdyn_core::rng::Rng;
use ivdyn_core::trajectory::Fourier;

/// Acceleration limit (rad/s^2, or m/s^2 for prismatic joints) used when none is given:
/// URDF has no acceleration limit. Conservative for industrial and collaborative arms
/// (the Panda's datasheet allows 7.5-20 rad/s^2, UR arms more).
pub const DEFAULT_ACC_LIMIT: f64 = 5.0;
/// Velocity limit used for a joint whose URDF `<limit velocity>` is missing or zero.
pub const DEFAULT_VEL_LIMIT: f64 = 1.0;

/// Optimality criterion.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum Criterion {
    /// Minimise the condition number of the base regressor.
    Cond,
    /// Maximise `log det` of the information matrix `Phi^T Phi / rows`.
    Logdet,
}

/// Options of [`design`].
#[derive(Clone)]
pub struct ExciteOptions {
    /// Duration of the written trajectory (s).
    pub duration_s: f64,
    /// Number of harmonics `H` (>= 2: one is used up by the rest constraints).
    pub harmonics: usize,
    /// Fundamental frequency (Hz); the period is `1 / f0`.
    pub f0_hz: f64,
    /// Sample rate of the written trajectory (Hz).
    pub rate_hz: f64,
    /// Criterion.
    pub criterion: Criterion,
    /// Acceleration limit per joint (one value: all joints).
    pub acc_limit: Vec<f64>,
    /// Velocity limit per joint replacing the URDF's (one value: all joints).
    pub vel_limit: Option<Vec<f64>>,
    /// Safety margin: position ranges, velocity and acceleration limits shrink by this
    /// fraction (so that the continuous trajectory between samples stays inside).
    pub margin: f64,
    /// Random starts of the optimiser.
    pub starts: usize,
    /// L-BFGS iterations per start.
    pub iterations: usize,
    /// Samples of one period on which the criterion is optimised.
    pub opt_samples: usize,
    /// Random trajectories for the comparison (median reported).
    pub random_draws: usize,
    /// Seed of the starts, the random comparison and the base-parameter states.
    pub seed: u64,
    /// Progress sink.
    pub progress: ProgressSink,
}

impl Default for ExciteOptions {
    fn default() -> Self {
        ExciteOptions {
            duration_s: 20.0,
            harmonics: 5,
            f0_hz: 0.1,
            rate_hz: 100.0,
            criterion: Criterion::Cond,
            acc_limit: vec![DEFAULT_ACC_LIMIT],
            vel_limit: None,
            margin: 0.01,
            starts: 6,
            iterations: 150,
            opt_samples: 100,
            random_draws: 20,
            seed: 1,
            progress: None,
        }
    }
}

/// The limits one joint is held to (before the margin).
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct JointBounds {
    /// Lower position limit (`null`/infinite: none).
    pub lower: f64,
    /// Upper position limit.
    pub upper: f64,
    /// Velocity limit.
    pub velocity: f64,
    /// Acceleration limit.
    pub acceleration: f64,
}

/// The criterion values of one trajectory, on the written samples.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Scores {
    /// Condition number of the base regressor (from its QR factor).
    pub cond: f64,
    /// `log det(Phi^T Phi / rows)`.
    pub logdet: f64,
}

/// The random-trajectory comparison.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct RandomComparison {
    /// Number of random trajectories.
    pub draws: usize,
    /// Median condition number.
    pub cond_median: f64,
    /// Smallest (best) condition number among the draws.
    pub cond_min: f64,
    /// Median `log det`.
    pub logdet_median: f64,
    /// Largest `log det` among the draws.
    pub logdet_max: f64,
}

/// The designed trajectory and its report.
#[derive(Debug, Clone, Serialize)]
pub struct ExciteReport {
    /// Robot name.
    pub robot: String,
    /// Joint names (order of every per-joint list).
    pub joints: Vec<String>,
    /// Criterion optimised.
    pub criterion: Criterion,
    /// Base parameters (columns of the regressor whose conditioning is optimised).
    pub base_count: usize,
    /// Fundamental frequency (Hz).
    pub f0_hz: f64,
    /// Harmonics.
    pub harmonics: usize,
    /// Duration (s).
    pub duration_s: f64,
    /// Sample rate of the written trajectory (Hz).
    pub rate_hz: f64,
    /// Safety margin.
    pub margin: f64,
    /// Limits per joint.
    pub bounds: Vec<JointBounds>,
    /// The optimised trajectory's criteria.
    pub optimised: Scores,
    /// Random Fourier trajectories of the same harmonics, scaled into the same bounds.
    pub random: RandomComparison,
    /// `random.cond_median / optimised.cond`.
    pub cond_improvement: f64,
    /// Offsets `q0` per joint.
    pub q0: Vec<f64>,
    /// Sine coefficients `a[joint][harmonic]` (as in `Fourier`).
    pub a: Vec<Vec<f64>>,
    /// Cosine coefficients `b[joint][harmonic]`.
    pub b: Vec<Vec<f64>>,
    /// Peak `|qd| / velocity limit` per joint on the written samples.
    pub velocity_use: Vec<f64>,
    /// Peak `|qdd| / acceleration limit` per joint.
    pub acceleration_use: Vec<f64>,
    /// Remarks.
    pub notes: Vec<String>,
    /// The written samples.
    #[serde(skip)]
    pub trajectory: Samples,
}

/// A sampled trajectory, row-major `T x N`.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Samples {
    /// Times (s).
    pub t: Vec<f64>,
    /// Positions.
    pub q: Vec<f64>,
    /// Velocities.
    pub qd: Vec<f64>,
    /// Accelerations.
    pub qdd: Vec<f64>,
}

/// Fourier coefficients of all joints (`a`, `b`: `n x h`, row-major), runtime-sized.
#[derive(Debug, Clone, PartialEq)]
pub struct Coeffs {
    /// Joints.
    pub n: usize,
    /// Harmonics.
    pub h: usize,
    /// Fundamental angular frequency (rad/s).
    pub omega: f64,
    /// Offsets.
    pub q0: Vec<f64>,
    /// Sine coefficients, `a[i * h + l]`.
    pub a: Vec<f64>,
    /// Cosine coefficients.
    pub b: Vec<f64>,
}

/// Values of each harmonic's unit coefficient at the times of a grid: `q[k][c]`, with
/// `c < h` the sine coefficient `a_l` and `c >= h` the cosine coefficient `b_l`. A series
/// is the sum of its harmonics, and harmonic `l` is the one-harmonic [`Fourier`] of
/// frequency `l w`, so the basis is taken from `Fourier<1, 1>` (one implementation of the
/// series).
struct Basis {
    h: usize,
    q: Vec<f64>,
    qd: Vec<f64>,
    qdd: Vec<f64>,
}

impl Basis {
    fn new(omega: f64, h: usize, times: &[f64]) -> Basis {
        let (mut q, mut qd, mut qdd) =
            (vec![0.0; times.len() * 2 * h], vec![0.0; times.len() * 2 * h], vec![0.0; times.len() * 2 * h]);
        for (k, &t) in times.iter().enumerate() {
            for l in 0..h {
                for (c, (a, b)) in [(l, (1.0, 0.0)), (h + l, (0.0, 1.0))] {
                    let f = Fourier::<1, 1> { omega: (l + 1) as f64 * omega, q0: [0.0], a: [[a]], b: [[b]] };
                    let (x, v, acc) = f.eval(t);
                    q[k * 2 * h + c] = x[0];
                    qd[k * 2 * h + c] = v[0];
                    qdd[k * 2 * h + c] = acc[0];
                }
            }
        }
        Basis { h, q, qd, qdd }
    }
    fn len(&self) -> usize {
        self.q.len() / (2 * self.h)
    }
    fn row<'a>(&self, which: &'a [f64], k: usize) -> &'a [f64] {
        &which[k * 2 * self.h..(k + 1) * 2 * self.h]
    }
}

fn dot(a: &[f64], b: &[f64]) -> f64 {
    a.iter().zip(b).map(|(x, y)| x * y).sum()
}

/// Per-joint limits after the margin, as used by the scaling.
#[derive(Debug, Clone, Copy)]
struct Box1 {
    lower: f64,
    upper: f64,
    vel: f64,
    acc: f64,
}

impl Box1 {
    fn finite_pos(&self) -> bool {
        self.lower.is_finite() && self.upper.is_finite()
    }
    fn offset(&self, z: f64) -> (f64, f64) {
        if self.finite_pos() {
            let (mid, half) = (0.5 * (self.lower + self.upper), 0.5 * (self.upper - self.lower));
            let th = z.tanh();
            (mid + half * th, half * (1.0 - th * th))
        } else {
            (z, 1.0)
        }
    }
}

/// Which bound limits a joint's scale, at which grid sample, with which sign.
#[derive(Debug, Clone, Copy)]
enum Active {
    Vel(usize, f64),
    Acc(usize, f64),
    Upper(usize),
    Lower(usize),
}

/// `qd(0) = 0` and `qdd(0) = 0`: orthogonal projection of `c = [a; b]` onto
/// `sum a_l = 0`, `sum l b_l = 0` (symmetric, so it is its own adjoint in the gradient).
fn project_rest(c: &mut [f64], h: usize) {
    let sa: f64 = c[..h].iter().sum::<f64>() / h as f64;
    c[..h].iter_mut().for_each(|v| *v -= sa);
    let w: Vec<f64> = (1..=h).map(|l| l as f64).collect();
    let ww: f64 = w.iter().map(|x| x * x).sum();
    let sb = dot(&c[h..], &w) / ww;
    c[h..].iter_mut().zip(&w).for_each(|(v, wl)| *v -= sb * wl);
}

/// Largest scale keeping `q0 + s pc` inside the box on `grid`; the active bound.
fn scale_into(pc: &[f64], q0: f64, bx: &Box1, grid: &Basis) -> (f64, Active) {
    let (mut best, mut act) = (f64::INFINITY, Active::Vel(0, 1.0));
    let (mut pmax, mut kmax, mut pmin, mut kmin) = (f64::NEG_INFINITY, 0, f64::INFINITY, 0);
    let (mut vmax, mut kv, mut amax, mut ka) = (0.0f64, 0, 0.0f64, 0);
    for k in 0..grid.len() {
        let p = dot(grid.row(&grid.q, k), pc);
        if p > pmax {
            (pmax, kmax) = (p, k);
        }
        if p < pmin {
            (pmin, kmin) = (p, k);
        }
        let v = dot(grid.row(&grid.qd, k), pc).abs();
        if v > vmax {
            (vmax, kv) = (v, k);
        }
        let a = dot(grid.row(&grid.qdd, k), pc).abs();
        if a > amax {
            (amax, ka) = (a, k);
        }
    }
    let sgn = |x: f64| if x < 0.0 { -1.0 } else { 1.0 };
    if bx.vel.is_finite() && vmax > 0.0 && bx.vel / vmax < best {
        best = bx.vel / vmax;
        act = Active::Vel(kv, sgn(dot(grid.row(&grid.qd, kv), pc)));
    }
    if bx.acc.is_finite() && amax > 0.0 && bx.acc / amax < best {
        best = bx.acc / amax;
        act = Active::Acc(ka, sgn(dot(grid.row(&grid.qdd, ka), pc)));
    }
    if bx.finite_pos() {
        if pmax > 0.0 && (bx.upper - q0) / pmax < best {
            best = (bx.upper - q0) / pmax;
            act = Active::Upper(kmax);
        }
        if pmin < 0.0 && (q0 - bx.lower) / -pmin < best {
            best = (q0 - bx.lower) / -pmin;
            act = Active::Lower(kmin);
        }
    }
    (best, act)
}

/// The optimisation problem: robot, base columns, grids, bounds.
struct Problem<'a> {
    robot: &'a Robot,
    base: &'a BaseParams,
    n: usize,
    h: usize,
    omega: f64,
    boxes: Vec<Box1>,
    crit_grid: Basis,
    bound_grid: Basis,
    criterion: Criterion,
    /// base columns that are Coulomb columns (zero derivative in qd)
    coulomb: Vec<bool>,
}

/// Per joint: scale, active bound, projected coefficients, `dq0/dz`.
type JointMap = (f64, Active, Vec<f64>, f64);

/// Result of one evaluation.
struct Eval {
    f: f64,
    grad: Option<Vec<f64>>,
}

impl<'a> Problem<'a> {
    fn nvar(&self) -> usize {
        self.n * (1 + 2 * self.h)
    }

    /// Maps the variables `x = [z_i, c_i (2h)]_i` to coefficients (scaled into the bounds
    /// on `grid`), with per joint the scale, the active bound and the projected `c`.
    fn realise(&self, x: &[f64], grid: &Basis) -> (Coeffs, Vec<JointMap>) {
        let (n, h) = (self.n, self.h);
        let mut co = Coeffs { n, h, omega: self.omega, q0: vec![0.0; n], a: vec![0.0; n * h], b: vec![0.0; n * h] };
        let mut info = Vec::with_capacity(n);
        for i in 0..n {
            let xi = &x[i * (1 + 2 * h)..(i + 1) * (1 + 2 * h)];
            let (q0, dq0) = self.boxes[i].offset(xi[0]);
            let mut pc = xi[1..].to_vec();
            project_rest(&mut pc, h);
            let (s, act) = scale_into(&pc, q0, &self.boxes[i], grid);
            let s = if s.is_finite() { s } else { 0.0 };
            co.q0[i] = q0;
            for l in 0..h {
                co.a[i * h + l] = s * pc[l];
                co.b[i * h + l] = s * pc[h + l];
            }
            info.push((s, act, pc, dq0));
        }
        (co, info)
    }

    /// Criterion (to be minimised) and optionally its gradient.
    fn eval(&self, x: &[f64], want_grad: bool, sharpness: Option<f64>) -> Result<Eval> {
        let (n, h) = (self.n, self.h);
        let (co, info) = self.realise(x, &self.bound_grid);
        let g = &self.crit_grid;
        let kk = g.len();
        // states: base sample, then (if gradient) q +- h_q e_i, qd +- h_v e_i, qdd + e_i
        let per = if want_grad { 1 + 5 * n } else { 1 };
        let (hq, hv) = (1e-6, 1e-2);
        let (mut q, mut qd, mut qdd) = (vec![0.0; kk * per * n], vec![0.0; kk * per * n], vec![0.0; kk * per * n]);
        for k in 0..kk {
            let (mut q0, mut v0, mut a0) = (vec![0.0; n], vec![0.0; n], vec![0.0; n]);
            for i in 0..n {
                let e: Vec<f64> =
                    (0..2 * h).map(|c| if c < h { co.a[i * h + c] } else { co.b[i * h + c - h] }).collect();
                q0[i] = co.q0[i] + dot(g.row(&g.q, k), &e);
                v0[i] = dot(g.row(&g.qd, k), &e);
                a0[i] = dot(g.row(&g.qdd, k), &e);
            }
            for s in 0..per {
                let o = (k * per + s) * n;
                q[o..o + n].copy_from_slice(&q0);
                qd[o..o + n].copy_from_slice(&v0);
                qdd[o..o + n].copy_from_slice(&a0);
                if s == 0 {
                    continue;
                }
                let (kind, i) = ((s - 1) / n, (s - 1) % n);
                match kind {
                    0 => q[o + i] += hq,
                    1 => q[o + i] -= hq,
                    2 => qd[o + i] += hv,
                    3 => qd[o + i] -= hv,
                    _ => qdd[o + i] += 1.0,
                }
            }
        }
        let p = PARAMS_PER_JOINT * n;
        let mut full = vec![0.0; kk * per * n * p];
        crate::batch::regressor_batch(self.robot, &q, &qd, &qdd, &mut full, false)?;
        let b = self.base.base_count();
        let cols = &self.base.independent;
        // base rows of state s of sample k: row r of joint torque r
        let base_row = |k: usize, s: usize, r: usize, c: usize| full[((k * per + s) * n + r) * p + cols[c]];
        let rows = kk * n;
        let mut phi = DMatrix::<f64>::zeros(rows, b);
        for k in 0..kk {
            for r in 0..n {
                for c in 0..b {
                    phi[(k * n + r, c)] = base_row(k, 0, r, c);
                }
            }
        }
        let a_mat = phi.tr_mul(&phi);
        let eig = a_mat.clone().symmetric_eigen();
        let (mut imax, mut imin) = (0, 0);
        for j in 0..b {
            if eig.eigenvalues[j] > eig.eigenvalues[imax] {
                imax = j;
            }
            if eig.eigenvalues[j] < eig.eigenvalues[imin] {
                imin = j;
            }
        }
        let (lmax, lmin) = (eig.eigenvalues[imax], eig.eigenvalues[imin]);
        if !(lmin > 0.0) {
            return Ok(Eval { f: f64::INFINITY, grad: None });
        }
        // f as a function of the eigenvalues of Phi^T Phi, and w_j = df/dlambda_j
        let lam = &eig.eigenvalues;
        let (f, w): (f64, Vec<f64>) = match (self.criterion, sharpness) {
            (Criterion::Cond, None) => {
                let mut w = vec![0.0; b];
                w[imax] += 0.5 / lmax;
                w[imin] -= 0.5 / lmin;
                (0.5 * (lmax / lmin).ln(), w)
            }
            (Criterion::Cond, Some(p)) => {
                // smooth upper bound of log cond: (log sum (l/lmax)^p + log sum (lmin/l)^p) / 2p
                // + log(lmax/lmin) / 2, which tends to log cond as p grows
                let up: Vec<f64> = lam.iter().map(|l| (l / lmax).powf(p)).collect();
                let dn: Vec<f64> = lam.iter().map(|l| (lmin / l).powf(p)).collect();
                let (su, sd) = (up.iter().sum::<f64>(), dn.iter().sum::<f64>());
                let f = 0.5 * (lmax / lmin).ln() + (su.ln() + sd.ln()) / (2.0 * p);
                let w = (0..b).map(|j| 0.5 * (up[j] / su - dn[j] / sd) / lam[j]).collect();
                (f, w)
            }
            (Criterion::Logdet, _) => {
                (-lam.iter().map(|l| (l / rows as f64).ln()).sum::<f64>(), lam.iter().map(|l| -1.0 / l).collect())
            }
        };
        if !want_grad {
            return Ok(Eval { f, grad: None });
        }
        // d lambda_j = 2 v_j^T Phi^T dPhi v_j, so dF = <dPhi, Phi M> with M = 2 V diag(w) V^T
        let m = &eig.eigenvectors
            * DMatrix::from_diagonal(&nalgebra::DVector::from_vec(w.iter().map(|x| 2.0 * x).collect()))
            * eig.eigenvectors.transpose();
        let gm = &phi * m;
        // per sample and joint: sensitivities to q_i, qd_i, qdd_i
        let mut ge = vec![0.0; n * 2 * h];
        let mut gq0 = vec![0.0; n];
        for k in 0..kk {
            for i in 0..n {
                let (mut sq, mut sv, mut sa) = (0.0, 0.0, 0.0);
                for r in 0..n {
                    for c in 0..b {
                        let w = gm[(k * n + r, c)];
                        let y0 = base_row(k, 0, r, c);
                        sq += w * (base_row(k, 1 + i, r, c) - base_row(k, 1 + n + i, r, c)) / (2.0 * hq);
                        if !self.coulomb[c] {
                            sv +=
                                w * (base_row(k, 1 + 2 * n + i, r, c) - base_row(k, 1 + 3 * n + i, r, c)) / (2.0 * hv);
                        }
                        sa += w * (base_row(k, 1 + 4 * n + i, r, c) - y0);
                    }
                }
                gq0[i] += sq;
                let (bq, bv, ba) = (g.row(&g.q, k), g.row(&g.qd, k), g.row(&g.qdd, k));
                for c in 0..2 * h {
                    ge[i * 2 * h + c] += sq * bq[c] + sv * bv[c] + sa * ba[c];
                }
            }
        }
        // chain through e = s pc, s = s(pc, q0), q0 = q0(z), pc = P c
        let bg = &self.bound_grid;
        let mut grad = vec![0.0; self.nvar()];
        for i in 0..n {
            let (s, act, pc, dq0) = (&info[i].0, info[i].1, &info[i].2, info[i].3);
            let gei = &ge[i * 2 * h..(i + 1) * 2 * h];
            let gdotpc = dot(gei, pc);
            let mut gpc: Vec<f64> = gei.iter().map(|v| s * v).collect();
            let mut dsdq0 = 0.0;
            let (row, coef): (&[f64], f64) = match act {
                Active::Vel(k, sg) => {
                    let r = bg.row(&bg.qd, k);
                    let pk = sg * dot(r, pc);
                    (r, -s / pk * sg)
                }
                Active::Acc(k, sg) => {
                    let r = bg.row(&bg.qdd, k);
                    let pk = sg * dot(r, pc);
                    (r, -s / pk * sg)
                }
                Active::Upper(k) => {
                    let r = bg.row(&bg.q, k);
                    let pk = dot(r, pc);
                    dsdq0 = -1.0 / pk;
                    (r, -s / pk)
                }
                Active::Lower(k) => {
                    let r = bg.row(&bg.q, k);
                    let pk = -dot(r, pc);
                    dsdq0 = 1.0 / pk;
                    (r, s / pk)
                }
            };
            for c in 0..2 * h {
                gpc[c] += gdotpc * coef * row[c];
            }
            project_rest(&mut gpc, h);
            let off = i * (1 + 2 * h);
            grad[off] = (gq0[i] + gdotpc * dsdq0) * dq0;
            grad[off + 1..off + 1 + 2 * h].copy_from_slice(&gpc);
        }
        Ok(Eval { f, grad: Some(grad) })
    }

    fn random_x(&self, rng: &mut Rng) -> Vec<f64> {
        let mut x = vec![0.0; self.nvar()];
        for i in 0..self.n {
            let off = i * (1 + 2 * self.h);
            x[off] = if self.boxes[i].finite_pos() { 0.5 * rng.normal() } else { 0.0 };
            for c in 0..2 * self.h {
                // higher harmonics smaller (a smooth trajectory), as a random excitation would be
                let l = (c % self.h + 1) as f64;
                x[off + 1 + c] = rng.normal() / l;
            }
        }
        x
    }

    /// Rescales each joint's `c` to unit norm (the map is invariant to it).
    fn normalise(&self, x: &mut [f64]) {
        for i in 0..self.n {
            let off = i * (1 + 2 * self.h) + 1;
            let c = &mut x[off..off + 2 * self.h];
            let nrm = c.iter().map(|v| v * v).sum::<f64>().sqrt();
            if nrm > 0.0 {
                c.iter_mut().for_each(|v| *v /= nrm);
            }
        }
    }
}

/// L-BFGS (memory 8) with Armijo backtracking; memory reset when a step fails, stop when
/// steepest descent fails too or `iters` is reached. `tick` is called once per iteration.
fn lbfgs(
    pr: &Problem,
    mut x: Vec<f64>,
    iters: usize,
    sharpness: Option<f64>,
    tick: &dyn Fn(),
) -> Result<(Vec<f64>, f64)> {
    let mut e = pr.eval(&x, true, sharpness)?;
    if !e.f.is_finite() {
        return Ok((x, e.f));
    }
    let mut g = e.grad.take().expect("gradient asked");
    let (mut ss, mut ys): (Vec<Vec<f64>>, Vec<Vec<f64>>) = (vec![], vec![]);
    let mut f = e.f;
    let mut done = 0;
    while done < iters {
        done += 1;
        tick();
        // two-loop recursion
        let mut d = g.clone();
        let mut alphas = vec![0.0; ss.len()];
        for j in (0..ss.len()).rev() {
            let rho = 1.0 / dot(&ys[j], &ss[j]);
            alphas[j] = rho * dot(&ss[j], &d);
            d.iter_mut().zip(&ys[j]).for_each(|(v, y)| *v -= alphas[j] * y);
        }
        let gamma = if let (Some(s), Some(y)) = (ss.last(), ys.last()) {
            dot(s, y) / dot(y, y)
        } else {
            0.1 / dot(&g, &g).sqrt().max(1e-12)
        };
        d.iter_mut().for_each(|v| *v *= gamma);
        for j in 0..ss.len() {
            let rho = 1.0 / dot(&ys[j], &ss[j]);
            let beta = rho * dot(&ys[j], &d);
            d.iter_mut().zip(&ss[j]).for_each(|(v, s)| *v += (alphas[j] - beta) * s);
        }
        let mut slope = -dot(&g, &d);
        if !(slope < 0.0) {
            ss.clear();
            ys.clear();
            let sc = 0.1 / dot(&g, &g).sqrt().max(1e-12);
            d = g.iter().map(|v| v * sc).collect();
            slope = -dot(&g, &d);
        }
        // backtracking on x - t d
        let mut t = 1.0;
        let mut accepted = None;
        for _ in 0..30 {
            let xn: Vec<f64> = x.iter().zip(&d).map(|(a, b)| a - t * b).collect();
            let en = pr.eval(&xn, true, sharpness)?;
            if en.f.is_finite() && en.f <= f + 1e-4 * t * slope {
                accepted = Some((xn, en));
                break;
            }
            t *= 0.5;
        }
        match accepted {
            Some((xn, mut en)) => {
                let gn = en.grad.take().expect("gradient asked");
                let s: Vec<f64> = xn.iter().zip(&x).map(|(a, b)| a - b).collect();
                let y: Vec<f64> = gn.iter().zip(&g).map(|(a, b)| a - b).collect();
                if dot(&s, &y) > 1e-12 * dot(&s, &s).sqrt() * dot(&y, &y).sqrt() {
                    ss.push(s);
                    ys.push(y);
                    if ss.len() > 8 {
                        ss.remove(0);
                        ys.remove(0);
                    }
                }
                let improvement = f - en.f;
                x = xn;
                f = en.f;
                g = gn;
                // keep the scale-invariant coefficient blocks near unit norm
                let drift = (0..pr.n).any(|i| {
                    let off = i * (1 + 2 * pr.h) + 1;
                    let nrm = x[off..off + 2 * pr.h].iter().map(|v| v * v).sum::<f64>().sqrt();
                    !(0.5..2.0).contains(&nrm)
                });
                if drift {
                    pr.normalise(&mut x);
                    let mut e2 = pr.eval(&x, true, sharpness)?;
                    f = e2.f;
                    g = e2.grad.take().expect("gradient asked");
                    ss.clear();
                    ys.clear();
                }
                if improvement.abs() < 1e-10 * f.abs().max(1.0) && ss.is_empty() {
                    break;
                }
            }
            None if !ss.is_empty() => {
                ss.clear();
                ys.clear();
            }
            None => break,
        }
    }
    Ok((x, f))
}

fn per_joint(what: &str, v: &[f64], n: usize) -> Result<Vec<f64>> {
    match v.len() {
        1 => Ok(vec![v[0]; n]),
        l if l == n => Ok(v.to_vec()),
        l => Err(Error::Dimension { what: format!("{what} (one value, or one per joint)"), expected: n, got: l }),
    }
}

fn bad(msg: String) -> Error {
    Error::Estimation { msg: format!("excite: {msg}") }
}

/// The limits of `robot` with the options' overrides (before the margin).
pub fn joint_bounds(robot: &Robot, opts: &ExciteOptions) -> Result<Vec<JointBounds>> {
    let n = robot.dof();
    let lim = crate::with_model!(&robot.model, m => m.limits.to_vec());
    let acc = per_joint("acceleration limit", &opts.acc_limit, n)?;
    let vel = match &opts.vel_limit {
        Some(v) => per_joint("velocity limit", v, n)?,
        None => lim
            .iter()
            .map(|l| if l.velocity.is_finite() && l.velocity > 0.0 { l.velocity } else { DEFAULT_VEL_LIMIT })
            .collect(),
    };
    (0..n)
        .map(|i| {
            let ok = |v: f64| v > 0.0 && v.is_finite(); // false for NaN too
            if !ok(acc[i]) || !ok(vel[i]) {
                return Err(bad(format!(
                    "joint '{}': velocity and acceleration limits must be positive and finite (got {} and {})",
                    robot.joint_names[i], vel[i], acc[i]
                )));
            }
            Ok(JointBounds { lower: lim[i].lower, upper: lim[i].upper, velocity: vel[i], acceleration: acc[i] })
        })
        .collect()
}

/// Criterion values of a sampled trajectory on the base regressor: the condition number
/// from the triangular factor of the stacked rows (accumulated with [`LsAccumulator`], no
/// squaring of the condition number) and `log det(Phi^T Phi / rows)`.
pub fn scores(robot: &Robot, base: &BaseParams, s: &Samples) -> Result<Scores> {
    let n = robot.dof();
    let p = robot.num_params();
    let b = base.base_count();
    let t = s.t.len();
    let mut acc = LsAccumulator::new(b);
    const CHUNK: usize = 1024;
    let mut full = vec![];
    for st in (0..t).step_by(CHUNK) {
        let e = (st + CHUNK).min(t);
        full.resize((e - st) * n * p, 0.0);
        let r = st * n..e * n;
        crate::batch::regressor_batch(robot, &s.q[r.clone()], &s.qd[r.clone()], &s.qdd[r], &mut full, false)?;
        let rows = base.select_rows(&full, (e - st) * n)?;
        acc.add_rows(&rows, &vec![0.0; (e - st) * n], None)?;
    }
    let r = acc.r();
    let sv = r.singular_values();
    let (mx, mn) = sv.iter().fold((0.0f64, f64::INFINITY), |(a, c), &v| (a.max(v), c.min(v)));
    let rows = (t * n) as f64;
    let logdet = sv.iter().map(|v| (v * v / rows).ln()).sum();
    Ok(Scores { cond: mx / mn, logdet })
}

/// Samples `co` at `times` (through [`Basis`], i.e. `Fourier`).
pub fn sample(co: &Coeffs, times: &[f64]) -> Samples {
    let (n, h) = (co.n, co.h);
    let g = Basis::new(co.omega, h, times);
    let mut s = Samples {
        t: times.to_vec(),
        q: vec![0.0; times.len() * n],
        qd: vec![0.0; times.len() * n],
        qdd: vec![0.0; times.len() * n],
    };
    for k in 0..times.len() {
        for i in 0..n {
            let e: Vec<f64> = (0..2 * h).map(|c| if c < h { co.a[i * h + c] } else { co.b[i * h + c - h] }).collect();
            s.q[k * n + i] = co.q0[i] + dot(g.row(&g.q, k), &e);
            s.qd[k * n + i] = dot(g.row(&g.qd, k), &e);
            s.qdd[k * n + i] = dot(g.row(&g.qdd, k), &e);
        }
    }
    s
}

/// Designs the excitation trajectory (see the module docs).
pub fn design(robot: &Robot, opts: &ExciteOptions) -> Result<ExciteReport> {
    let n = robot.dof();
    let h = opts.harmonics;
    if h < 2 {
        return Err(bad(format!("--harmonics must be at least 2 (one is used by the rest constraints), got {h}")));
    }
    for (what, v) in [("duration", opts.duration_s), ("f0", opts.f0_hz), ("rate", opts.rate_hz)] {
        if !(v > 0.0 && v.is_finite()) {
            return Err(bad(format!("{what} must be positive, got {v}")));
        }
    }
    if !(0.0..0.5).contains(&opts.margin) {
        return Err(bad(format!("margin must be in [0, 0.5), got {}", opts.margin)));
    }
    if opts.starts == 0 || opts.opt_samples < 2 {
        return Err(bad("need at least one start and two optimisation samples".into()));
    }
    let bounds = joint_bounds(robot, opts)?;
    let boxes: Vec<Box1> = bounds
        .iter()
        .map(|b| {
            let d =
                if b.lower.is_finite() && b.upper.is_finite() { opts.margin * 0.5 * (b.upper - b.lower) } else { 0.0 };
            Box1 {
                lower: b.lower + d,
                upper: b.upper - d,
                vel: b.velocity * (1.0 - opts.margin),
                acc: b.acceleration * (1.0 - opts.margin),
            }
        })
        .collect();
    for (i, b) in boxes.iter().enumerate() {
        if b.finite_pos() && !(b.upper > b.lower) {
            return Err(bad(format!("joint '{}': empty position range", robot.joint_names[i])));
        }
    }
    let base = robot_base_params(robot, 200.max(2 * robot.num_params() / n), opts.seed)?;
    let b = base.base_count();
    let period = 1.0 / opts.f0_hz;
    let span = period.min(opts.duration_s);
    let rows_needed = b.div_ceil(n) + 1;
    let kk = opts.opt_samples.max(rows_needed);
    let omega = std::f64::consts::TAU * opts.f0_hz;
    // half-step offset: t = 0 is a rest point (qd = 0), where the Coulomb column sign(qd)
    // would flip with rounding
    let crit_times: Vec<f64> = (0..kk).map(|k| span * (k as f64 + 0.5) / kk as f64).collect();
    let nb = (64 * h).max(kk);
    let bound_times: Vec<f64> = (0..=nb).map(|k| span * k as f64 / nb as f64).collect();
    let coulomb = base.independent.iter().map(|&c| (0..n).any(|j| drive_col(n, j, FC) == c)).collect();
    let pr = Problem {
        robot,
        base: &base,
        n,
        h,
        omega,
        boxes,
        crit_grid: Basis::new(omega, h, &crit_times),
        bound_grid: Basis::new(omega, h, &bound_times),
        criterion: opts.criterion,
        coulomb,
    };
    // written samples
    let steps = (opts.duration_s * opts.rate_hz).round() as usize;
    let out_times: Vec<f64> = (0..=steps).map(|k| k as f64 / opts.rate_hz).collect();
    let out_span: Vec<f64> = out_times.iter().copied().filter(|&t| t <= span + 1e-12).collect();
    let out_grid = Basis::new(omega, h, &out_span);
    let finish = |x: &[f64]| -> Result<(Coeffs, Samples, Scores)> {
        // final scaling on the written samples (a superset of nothing: the written grid)
        let (co, _) = pr.realise(x, &out_grid);
        let s = sample(&co, &out_times);
        let sc = scores(robot, &base, &s)?;
        Ok((co, s, sc))
    };

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
    // random comparison (its own seed stream), on the written samples
    let mut rng = Rng::new(opts.seed.wrapping_mul(0x9E37_79B9).wrapping_add(17));
    let mut rc = vec![];
    let mut rl = vec![];
    for _ in 0..opts.random_draws {
        let x = pr.random_x(&mut rng);
        let (_, _, sc) = finish(&x)?;
        rc.push(sc.cond);
        rl.push(sc.logdet);
        tick();
    }
    // multi-start optimisation
    let mut rng = Rng::new(opts.seed);
    let mut best: Option<(Vec<f64>, f64)> = None;
    for _ in 0..opts.starts {
        let x0 = pr.random_x(&mut rng);
        // continuation on the smooth surrogate of log cond (the exact one is a min-max,
        // non-smooth where eigenvalues cross, on which L-BFGS stalls), then the exact one
        let stages: &[Option<f64>] = match opts.criterion {
            Criterion::Cond => &[Some(4.0), Some(16.0), None],
            Criterion::Logdet => &[None],
        };
        let mut x = x0;
        let mut f = f64::INFINITY;
        for (si, &sh) in stages.iter().enumerate() {
            let it = opts.iterations * (si + 1) / stages.len() - opts.iterations * si / stages.len();
            (x, _) = lbfgs(&pr, x, it, sh, &tick)?;
            f = pr.eval(&x, false, None)?.f;
            if std::env::var("IVDYN_DEBUG").is_ok() {
                eprintln!("stage {si} f {f}");
            }
        }
        if best.as_ref().is_none_or(|(_, fb)| f < *fb) {
            best = Some((x, f));
        }
    }
    if let Some(p) = &prog {
        p.end();
    }
    let (xb, _) = best.expect("at least one start");
    let (co, traj, sc) = finish(&xb)?;

    let median = |v: &mut Vec<f64>| -> f64 {
        if v.is_empty() {
            return f64::NAN;
        }
        v.sort_by(|a, b| a.total_cmp(b));
        let m = v.len();
        if m % 2 == 1 { v[m / 2] } else { 0.5 * (v[m / 2 - 1] + v[m / 2]) }
    };
    let random = RandomComparison {
        draws: rc.len(),
        cond_min: rc.iter().cloned().fold(f64::INFINITY, f64::min),
        logdet_max: rl.iter().cloned().fold(f64::NEG_INFINITY, f64::max),
        cond_median: median(&mut rc),
        logdet_median: median(&mut rl),
    };
    let mut notes = vec![];
    let periods = opts.duration_s * opts.f0_hz;
    if (periods - periods.round()).abs() > 1e-9 {
        notes.push(format!("the duration is {periods:.3} periods of 1/f0: the trajectory does not end at rest (choose a whole number of periods)"));
    }
    let peak = |x: &[f64], i: usize| (0..traj.t.len()).map(|k| x[k * n + i].abs()).fold(0.0, f64::max);
    Ok(ExciteReport {
        robot: robot.name.clone(),
        joints: robot.joint_names.clone(),
        criterion: opts.criterion,
        base_count: b,
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
        notes,
        trajectory: traj,
    })
}

/// Writes the trajectory as CSV: `t`, `<joint>.q`, `<joint>.qd`, `<joint>.qdd` (the
/// `docs/logs.md` naming; `io::read_csv` reads `t`, `q`, `qd` and ignores `qdd`), shortest
/// round-trip decimals, via a temporary file renamed on success.
pub fn write_csv(path: &Path, joints: &[String], s: &Samples) -> Result<()> {
    crate::log::csv::write_columns(path, 0, joints, &s.t, &[("q", &s.q), ("qd", &s.qd), ("qdd", &s.qdd)])
}

/// Writes the trajectory as MCAP `/joint_states` (position and velocity; no effort) for a
/// robot to replay.
pub fn write_mcap(path: &Path, joints: &[String], s: &Samples) -> Result<()> {
    let log = JointLog {
        joint_names: joints.to_vec(),
        t0_ns: 0,
        t: s.t.clone(),
        q: s.q.clone(),
        qd: Some(s.qd.clone()),
        tau: None,
        u: None,
        truncated: false,
    };
    crate::log::write_mcap(path, &log, &[]).map(|_| ())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The analytic gradient matches central differences of the criterion.
    #[test]
    fn gradient_matches_finite_differences() {
        let robot = Robot::from_urdf(
            concat!(env!("CARGO_MANIFEST_DIR"), "/../../fixtures/ur5.urdf"),
            Some("base_link"),
            Some("tool0"),
        )
        .unwrap();
        let opts = ExciteOptions { harmonics: 3, opt_samples: 30, ..Default::default() };
        for crit in [Criterion::Cond, Criterion::Logdet] {
            let n = robot.dof();
            let base = robot_base_params(&robot, 200, 1).unwrap();
            let bounds = joint_bounds(&robot, &opts).unwrap();
            let boxes = bounds
                .iter()
                .map(|b| Box1 { lower: b.lower, upper: b.upper, vel: b.velocity, acc: b.acceleration })
                .collect();
            let h = opts.harmonics;
            let omega = std::f64::consts::TAU * 0.1;
            let ct: Vec<f64> = (0..30).map(|k| 10.0 * (k as f64 + 0.5) / 30.0).collect();
            let bt: Vec<f64> = (0..=200).map(|k| 10.0 * k as f64 / 200.0).collect();
            let coulomb = base.independent.iter().map(|&c| (0..n).any(|j| drive_col(n, j, FC) == c)).collect();
            let pr = Problem {
                robot: &robot,
                base: &base,
                n,
                h,
                omega,
                boxes,
                crit_grid: Basis::new(omega, h, &ct),
                bound_grid: Basis::new(omega, h, &bt),
                criterion: crit,
                coulomb,
            };
            let mut rng = Rng::new(3);
            let x = pr.random_x(&mut rng);
            for sh in [None, Some(8.0)] {
                let g = pr.eval(&x, true, sh).unwrap().grad.unwrap();
                let mut worst: f64 = 0.0;
                let gn = g.iter().map(|v| v * v).sum::<f64>().sqrt();
                for j in 0..x.len() {
                    let eps = 1e-6;
                    let (mut xp, mut xm) = (x.clone(), x.clone());
                    xp[j] += eps;
                    xm[j] -= eps;
                    let fd = (pr.eval(&xp, false, sh).unwrap().f - pr.eval(&xm, false, sh).unwrap().f) / (2.0 * eps);
                    worst = worst.max((fd - g[j]).abs() / gn);
                }
                assert!(worst < 1e-5, "{crit:?} {sh:?}: gradient error {worst:e} relative to |g| = {gn:e}");
            }
        }
    }
}

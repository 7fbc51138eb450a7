//! Per-joint sufficient statistics of an identification data set, from which the OLS,
//! two-step WLS and IV fits and the per-joint fit quality all follow **without keeping the
//! data** (what lets `identify` stream a log of any length).
//!
//! Rows of joint `i` (one per sample) go to accumulator `i`, together with `Σ τ_i` and
//! `Σ τ_i²`. Then, for any `θ`:
//!
//! * `rss_i(θ) = ‖√W_i (τ_i - Φ_i θ)‖² = ‖R_aug,i [θ; -1]‖²` (the QR factor of joint `i`'s
//!   rows, [`LsAccumulator::r_aug`]): the per-joint residual without a second pass;
//! * two-step WLS with per-joint weights `w_i = 1 / σ_i²` is the merge of the accumulators
//!   scaled by `w_i` ([`LsAccumulator::scaled`]): the same statistics as adding every row
//!   with its weight, known only after the OLS fit;
//! * with [`with_lags`](JointAccs::with_lags)`(L)`, the lagged products `M_l = Σ_k a_k a_{k+l}ᵀ`
//!   of `a_k = [φ_k; τ_k]` (`l = 1..L`, consecutive rows of one segment): the residual's
//!   autocovariance `γ_i(l) = [θ; -1]ᵀ M_l [θ; -1] / T` for any `θ`, hence its long-run
//!   variance ([`long_run_factor`](JointAccs::long_run_factor)) without a second pass.

use std::collections::VecDeque;

use nalgebra::DVector;

use crate::error::Result;
use crate::ident::{IvAccumulator, LsAccumulator};
use crate::report::Quality;

/// Per-joint accumulators of one data set (the fit part or the held-out part).
#[derive(Debug, Clone)]
pub struct JointAccs {
    n: usize,
    b: usize,
    /// Per joint: the IV statistics (which hold the LS factor), or the LS factor alone.
    per: Vec<Acc>,
    sum_y: Vec<f64>,
    sum_yy: Vec<f64>,
    samples: usize,
    /// Per joint: the lagged products (empty without lags).
    lags: Vec<LagSums>,
}

/// Lagged products `M_l = Σ_k a_k a_{k+l}ᵀ`, `a_k = [φ_k; τ_k]` (`b + 1` entries), of one
/// joint's rows, `l = 1..=L`, row-major, and the last `L` rows (carried across blocks).
#[derive(Debug, Clone, Default)]
struct LagSums {
    m: Vec<Vec<f64>>,
    carry: VecDeque<Vec<f64>>,
}

impl LagSums {
    /// Adds the rows `ph` (`T x b`) with outputs `y` (`T`), after the carried rows.
    fn add(&mut self, ph: &[f64], y: &[f64]) {
        let lags = self.m.len();
        if lags == 0 {
            return;
        }
        let b = ph.len() / y.len().max(1);
        for (k, &yk) in y.iter().enumerate() {
            let mut a = Vec::with_capacity(b + 1);
            a.extend_from_slice(&ph[k * b..(k + 1) * b]);
            a.push(yk);
            for (l, prev) in self.carry.iter().rev().enumerate() {
                let m = &mut self.m[l];
                for (r, &pr) in prev.iter().enumerate() {
                    if pr != 0.0 {
                        let row = &mut m[r * (b + 1)..(r + 1) * (b + 1)];
                        row.iter_mut().zip(&a).for_each(|(o, &ac)| *o += pr * ac);
                    }
                }
            }
            if self.carry.len() == lags {
                self.carry.pop_front();
            }
            self.carry.push_back(a);
        }
    }

    /// `vᵀ M_l v` for `l = 1..=L`.
    fn quad(&self, v: &[f64]) -> Vec<f64> {
        let w = v.len();
        self.m.iter().map(|m| (0..w).map(|r| v[r] * (0..w).map(|c| m[r * w + c] * v[c]).sum::<f64>()).sum()).collect()
    }
}

#[derive(Debug, Clone)]
enum Acc {
    Ls(LsAccumulator),
    Iv(Box<IvAccumulator>),
}

impl Acc {
    fn ls(&self) -> &LsAccumulator {
        match self {
            Acc::Ls(a) => a,
            Acc::Iv(a) => a.ls(),
        }
    }
}

impl JointAccs {
    /// Empty statistics for `n` joints and `b` base parameters; `with_iv`: also the
    /// instrument sums (then every [`add`](Self::add) needs `z`).
    pub fn new(n: usize, b: usize, with_iv: bool) -> Self {
        let per = (0..n)
            .map(|_| if with_iv { Acc::Iv(Box::new(IvAccumulator::new(b))) } else { Acc::Ls(LsAccumulator::new(b)) })
            .collect();
        JointAccs { n, b, per, sum_y: vec![0.0; n], sum_yy: vec![0.0; n], samples: 0, lags: vec![] }
    }

    /// Also keeps the lagged products of lags `1..=lags` (module docs), for
    /// [`long_run_factor`](Self::long_run_factor). Call before adding rows.
    pub fn with_lags(mut self, lags: usize) -> Self {
        let w = self.b + 1;
        self.lags = (0..self.n).map(|_| LagSums { m: vec![vec![0.0; w * w]; lags], carry: VecDeque::new() }).collect();
        self
    }

    /// Marks a break in the rows (a new segment): no lagged product spans it.
    pub fn gap(&mut self) {
        self.lags.iter_mut().for_each(|l| l.carry.clear());
    }

    /// The long-run variance of joint `i`'s residual for `theta` relative to its variance,
    /// `c_i = 1 + 2 Σ_{l=1..L} (1 - l / (L + 1)) γ_i(l) / γ_i(0)` (Bartlett window,
    /// Newey-West): the factor by which the iid covariance `σ² (ΦᵀΦ)⁻¹` understates the
    /// variance of an estimate when the residual is autocorrelated (the parallel filter's
    /// low-pass, a pre-filtered log) and the regressor is slow against that correlation.
    /// `1` without lags; at least `1 / (L + 1)` (a Bartlett estimate is never negative).
    pub fn long_run_factor(&self, i: usize, theta: &[f64]) -> f64 {
        let Some(ls) = self.lags.get(i) else { return 1.0 };
        let g0 = self.rss(i, theta);
        if g0 <= 0.0 || ls.m.is_empty() {
            return 1.0;
        }
        let mut v: Vec<f64> = theta.to_vec();
        v.push(-1.0);
        let big_l = ls.m.len() as f64;
        let sum: f64 =
            ls.quad(&v).iter().enumerate().map(|(l, g)| (1.0 - (l + 1) as f64 / (big_l + 1.0)) * g / g0).sum();
        (1.0 + 2.0 * sum).max(1.0 / (big_l + 1.0))
    }

    /// Joints.
    pub fn joints(&self) -> usize {
        self.n
    }

    /// Samples added.
    pub fn samples(&self) -> usize {
        self.samples
    }

    /// Whether the instrument sums are kept.
    pub fn has_iv(&self) -> bool {
        matches!(self.per.first(), Some(Acc::Iv(_)))
    }

    /// Adds `T` samples: `phi` and `z` are `T x n x b` (sample-major, the `n` rows of a
    /// sample together), `tau` is `T x n`. The joints are accumulated on up to two threads.
    pub fn add(&mut self, phi: &[f64], z: Option<&[f64]>, tau: &[f64]) -> Result<()> {
        let (n, b) = (self.n, self.b);
        let t = tau.len() / n.max(1);
        if phi.len() != t * n * b || tau.len() != t * n || z.is_some_and(|z| z.len() != t * n * b) {
            return Err(crate::Error::Dimension {
                what: "JointAccs::add: phi, z (T x n x b) and tau (T x n)".into(),
                expected: t * n * b,
                got: phi.len(),
            });
        }
        if self.has_iv() && z.is_none() {
            return Err(crate::Error::Dimension {
                what: "JointAccs::add: instrument rows z (T x n x b)".into(),
                expected: t * n * b,
                got: 0,
            });
        }
        for k in 0..t {
            for i in 0..n {
                let y = tau[k * n + i];
                self.sum_y[i] += y;
                self.sum_yy[i] += y * y;
            }
        }
        self.samples += t;
        // joint i's rows: rows i, i + n, i + 2n, ... of the sample-major block
        let gather = |x: &[f64], i: usize| -> Vec<f64> {
            let mut out = Vec::with_capacity(t * b);
            for k in 0..t {
                out.extend_from_slice(&x[(k * n + i) * b..(k * n + i + 1) * b]);
            }
            out
        };
        let work = |i: usize, (acc, lag): (&mut Acc, Option<&mut LagSums>)| -> Result<()> {
            let ph = gather(phi, i);
            let y: Vec<f64> = (0..t).map(|k| tau[k * n + i]).collect();
            if let Some(lag) = lag {
                lag.add(&ph, &y);
            }
            match acc {
                Acc::Ls(a) => a.add_rows(&ph, &y, None),
                Acc::Iv(a) => a.add_rows(&ph, &gather(z.expect("checked"), i), &y, None),
            }
        };
        let mut lags = self.lags.iter_mut();
        let pairs: Vec<(&mut Acc, Option<&mut LagSums>)> = self.per.iter_mut().map(|a| (a, lags.next())).collect();
        if t * n < 256 || crate::batch::threads_for(t * n) < 2 {
            for (i, pair) in pairs.into_iter().enumerate() {
                work(i, pair)?;
            }
            return Ok(());
        }
        // two workers, joints interleaved (every joint's rows cost the same)
        let (even, odd): (Vec<_>, Vec<_>) = pairs.into_iter().enumerate().partition(|(i, _)| i % 2 == 0);
        let work = &work;
        let res: Vec<Result<()>> = std::thread::scope(|s| {
            let h = s.spawn(move || odd.into_iter().try_for_each(|(i, a)| work(i, a)));
            let r0 = even.into_iter().try_for_each(|(i, a)| work(i, a));
            vec![r0, h.join().unwrap_or_else(|p| std::panic::resume_unwind(p))]
        });
        res.into_iter().collect()
    }

    /// Residual sum of squares of joint `i` for the base parameters `theta`.
    pub fn rss(&self, i: usize, theta: &[f64]) -> f64 {
        let r = self.per[i].ls().r_aug();
        let mut v = DVector::zeros(self.b + 1);
        for (k, t) in theta.iter().enumerate() {
            v[k] = *t;
        }
        v[self.b] = -1.0;
        (r * v).norm_squared()
    }

    /// Per-joint RMS residual, `R²` and torque RMS for `theta` (same definitions as a
    /// direct pass over the data).
    pub fn quality(&self, data: String, theta: &[f64]) -> Quality {
        let tf = self.samples.max(1) as f64;
        let sse: Vec<f64> = (0..self.n).map(|i| self.rss(i, theta)).collect();
        let rms = sse.iter().map(|s| (s / tf).sqrt()).collect();
        let r2 = (0..self.n)
            .map(|i| {
                let sst = self.sum_yy[i] - self.sum_y[i] * self.sum_y[i] / tf;
                if sst > 0.0 { 1.0 - sse[i] / sst } else { f64::NAN }
            })
            .collect();
        let tau_rms = self.sum_yy.iter().map(|s| (s / tf).sqrt()).collect();
        Quality { data, samples: self.samples, rms, r2, tau_rms }
    }

    /// Least-squares statistics of all joints, joint `i`'s rows weighted by `w[i]`.
    pub fn ls(&self, w: &[f64]) -> Result<LsAccumulator> {
        let mut acc = LsAccumulator::new(self.b);
        for (a, &wi) in self.per.iter().zip(w) {
            acc.merge(&a.ls().scaled(wi)?)?;
        }
        acc.finish();
        Ok(acc)
    }

    /// IV statistics of all joints, joint `i`'s rows weighted by `w[i]` (`None` without
    /// instrument sums).
    pub fn iv(&self, w: &[f64]) -> Option<Result<IvAccumulator>> {
        if !self.has_iv() {
            return None;
        }
        let mut acc = IvAccumulator::new(self.b);
        for (a, &wi) in self.per.iter().zip(w) {
            let Acc::Iv(a) = a else { unreachable!("has_iv") };
            if let Err(e) = a.scaled(wi).and_then(|s| acc.merge(&s)) {
                return Some(Err(e));
            }
        }
        acc.finish();
        Some(Ok(acc))
    }
}

/// One joint's least-squares statistics as plain numbers, the form in which per-log
/// statistics travel between processes ([`JointAccs::joint_stats`]).
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct JointStats {
    /// `R_aug` (`(b + 1) x (b + 1)`, row-major, upper triangular) of the joint's rows.
    pub r_aug: Vec<f64>,
    /// Rows accumulated.
    pub rows: usize,
    /// `Σ τ²` as the accumulator keeps it (unit weights).
    pub sum_wyy: f64,
    /// `Σ τ_i`.
    pub sum_y: f64,
    /// `Σ τ_i²`.
    pub sum_yy: f64,
    /// Lagged products `M_l` (`l = 1..=L`, each `(b + 1)²`, row-major).
    pub lags: Vec<Vec<f64>>,
}

impl JointAccs {
    /// Each joint's least-squares statistics (the instrument sums are not carried).
    pub fn joint_stats(&self) -> Vec<JointStats> {
        (0..self.n)
            .map(|i| {
                let ls = self.per[i].ls();
                let r = ls.r_aug();
                let w = self.b + 1;
                JointStats {
                    r_aug: (0..w * w).map(|k| r[(k / w, k % w)]).collect(),
                    rows: ls.rows(),
                    sum_wyy: ls.sum_wyy(),
                    sum_y: self.sum_y[i],
                    sum_yy: self.sum_yy[i],
                    lags: self.lags.get(i).map(|l| l.m.clone()).unwrap_or_default(),
                }
            })
            .collect()
    }

    /// Least-squares statistics rebuilt from [`joint_stats`](Self::joint_stats) (`b` base
    /// parameters, `samples` samples): every joint must carry the same number of lags.
    pub fn from_joint_stats(b: usize, samples: usize, stats: &[JointStats]) -> Result<Self> {
        let w = b + 1;
        let lags = stats.first().map_or(0, |s| s.lags.len());
        let mut acc = JointAccs::new(stats.len(), b, false);
        acc.samples = samples;
        for (i, s) in stats.iter().enumerate() {
            if s.r_aug.len() != w * w || s.lags.len() != lags || s.lags.iter().any(|m| m.len() != w * w) {
                return Err(crate::Error::Dimension {
                    what: format!("joint statistics of joint {i}: R_aug and lagged products ((b + 1)² each)"),
                    expected: w * w,
                    got: s.r_aug.len(),
                });
            }
            let r = nalgebra::DMatrix::from_row_slice(w, w, &s.r_aug);
            acc.per[i] = Acc::Ls(LsAccumulator::from_r_aug(r, s.rows, s.sum_wyy)?);
            acc.sum_y[i] = s.sum_y;
            acc.sum_yy[i] = s.sum_yy;
        }
        if lags > 0 {
            acc.lags = stats.iter().map(|s| LagSums { m: s.lags.clone(), carry: VecDeque::new() }).collect();
        }
        Ok(acc)
    }

    /// Adds the statistics of other rows (another log: no lagged product spans the two),
    /// so that `self` describes both row sets; the lagged products kept are the lags both
    /// have. Least-squares statistics only (instrument sums are not merged).
    pub fn merge(&mut self, other: &JointAccs) -> Result<()> {
        if (other.n, other.b) != (self.n, self.b) {
            return Err(crate::Error::Dimension {
                what: "JointAccs::merge: joints x base parameters of the other statistics".into(),
                expected: self.n * self.b,
                got: other.n * other.b,
            });
        }
        if self.has_iv() || other.has_iv() {
            return Err(crate::error::Error::Stats {
                what: "JointAccs::merge".into(),
                msg: "instrument sums are not merged (statistics with an instrument cannot be merged)".into(),
            });
        }
        for (a, o) in self.per.iter_mut().zip(&other.per) {
            let Acc::Ls(a) = a else { unreachable!("checked") };
            a.merge(o.ls())?;
        }
        for i in 0..self.n {
            self.sum_y[i] += other.sum_y[i];
            self.sum_yy[i] += other.sum_yy[i];
        }
        self.samples += other.samples;
        self.keep_lags(other.lags.first().map_or(0, |l| l.m.len()));
        for (l, o) in self.lags.iter_mut().zip(&other.lags) {
            l.m.iter_mut().zip(&o.m).for_each(|(m, om)| m.iter_mut().zip(om).for_each(|(x, y)| *x += y));
            l.carry.clear();
        }
        Ok(())
    }

    /// Keeps the lagged products of lags `1..=lags` at most (a data set whose rows are
    /// correlated over fewer lags joins: the lags kept are those every part has).
    pub fn keep_lags(&mut self, lags: usize) {
        if lags == 0 {
            self.lags.clear();
        }
        for l in &mut self.lags {
            l.m.truncate(lags);
            while l.carry.len() > lags {
                l.carry.pop_front();
            }
        }
    }

    /// The least-squares fits of all joints with one joint's torque negated: row 0 the fit
    /// of the rows as they are, row `1 + j` that with joint `j`'s torque negated, each row
    /// holding every joint's residual `rss_i / T` as a fraction of its torque power
    /// `Σ τ_i² / T`. What tells a joint whose effort sign convention is the other one of
    /// the model's joint axis (`app::effort_check`). The negation is exact on the
    /// statistics: `R_aug` of `[Φ_j | -τ_j]` is that of `[Φ_j | τ_j]` with its last column
    /// negated. Each joint's rows are weighted by the inverse of its torque power (its
    /// share does not depend on its size or unit), and every fit carries the same ridge,
    /// `1e-4 max |R_kk|` per parameter, which keeps the solve regular where a column is
    /// unexcited. `(n + 1) n` products of `(b + 1)²` factors: nothing is read again.
    pub fn negated_fits(&self) -> Result<Vec<Vec<f64>>> {
        let (b, tf) = (self.b, self.samples.max(1) as f64);
        let power: Vec<f64> = self.sum_yy.iter().map(|s| s / tf).collect();
        let floor = (1e-12 * power.iter().copied().fold(0.0, f64::max)).max(f64::MIN_POSITIVE);
        // each joint's weighted factor, buffered rows absorbed once
        let r_aug = (0..self.n)
            .map(|i| Ok(self.per[i].ls().scaled(1.0 / power[i].max(floor))?.r_aug()))
            .collect::<Result<Vec<_>>>()?;
        let s = 1e-4 * r_aug.iter().flat_map(|r| (0..b).map(move |k| r[(k, k)].abs())).fold(0.0, f64::max);
        let mut eye = vec![0.0; b * b];
        (0..b).for_each(|k| eye[k * b + k] = s);
        let mut ridge = LsAccumulator::new(b);
        ridge.add_rows(&eye, &vec![0.0; b], None)?;
        let fit = |flip: Option<usize>| -> Result<Vec<f64>> {
            let rs: Vec<_> = (0..self.n)
                .map(|i| {
                    let mut r = r_aug[i].clone();
                    if Some(i) == flip {
                        r.column_mut(b).neg_mut();
                    }
                    r
                })
                .collect();
            let mut acc = ridge.clone();
            for r in &rs {
                acc.merge(&LsAccumulator::from_r_aug(r.clone(), 0, 0.0)?)?;
            }
            let v = DVector::from_vec(acc.solve()?).push(-1.0);
            Ok(rs.iter().map(|r| (r * &v).norm_squared() / tf).collect())
        };
        std::iter::once(None).chain((0..self.n).map(Some)).map(fit).collect()
    }
}

impl JointAccs {
    /// Per joint, how the measured torque `τ_i` follows the torque `Φ_i θ` of the
    /// parameters `theta`: the uncentred correlation `⟨Φ_i θ, τ_i⟩ / (‖Φ_i θ‖ ‖τ_i‖)` and
    /// the slope `⟨Φ_i θ, τ_i⟩ / ‖Φ_i θ‖²`, both from `R_aug` (its Gram matrix is that of
    /// `[Φ_i | τ_i]`). `(0, 0)` where either torque is zero.
    pub fn agreement(&self, theta: &[f64]) -> Vec<(f64, f64)> {
        let mut v = DVector::from_column_slice(theta);
        v = v.push(0.0);
        (0..self.n)
            .map(|i| {
                let r = self.per[i].ls().r_aug();
                let (p, q) = (&r * &v, r.column(self.b).into_owned());
                let (pq, pp, qq) = (p.dot(&q), p.norm_squared(), q.norm_squared());
                if pp > 0.0 && qq > 0.0 { (pq / (pp * qq).sqrt(), pq / pp) } else { (0.0, 0.0) }
            })
            .collect()
    }
}

/// Lags of [`JointAccs::long_run_factor`] for rows at sample time `dt` after a zero-phase
/// low-pass at `cutoff_hz`: twice the filter's correlation time `1 / cutoff_hz` in samples
/// (5 at the automatic decimation, 2.5 samples per cut-off period), between 2 and 12 (the
/// lagged products cost `L (b + 1)²` per row; with `--decimate 1` the residual stays
/// correlated over more than 12 rows and the correction is short).
pub fn hac_lags(dt: f64, cutoff_hz: f64) -> usize {
    ((2.0 / (cutoff_hz * dt)).ceil() as usize).clamp(2, MAX_HAC_LAGS)
}

/// The most lags [`hac_lags`] returns.
pub const MAX_HAC_LAGS: usize = 12;

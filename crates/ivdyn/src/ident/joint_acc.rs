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
//!   with its weight, known only after the OLS fit.

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
        JointAccs { n, b, per, sum_y: vec![0.0; n], sum_yy: vec![0.0; n], samples: 0 }
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
        let work = |i: usize, acc: &mut Acc| -> Result<()> {
            let ph = gather(phi, i);
            let y: Vec<f64> = (0..t).map(|k| tau[k * n + i]).collect();
            match acc {
                Acc::Ls(a) => a.add_rows(&ph, &y, None),
                Acc::Iv(a) => a.add_rows(&ph, &gather(z.expect("checked"), i), &y, None),
            }
        };
        if t * n < 256 || crate::batch::threads_for(t * n) < 2 {
            for (i, acc) in self.per.iter_mut().enumerate() {
                work(i, acc)?;
            }
            return Ok(());
        }
        // two workers, joints interleaved (every joint's rows cost the same)
        let (even, odd): (Vec<_>, Vec<_>) = self.per.iter_mut().enumerate().partition(|(i, _)| i % 2 == 0);
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

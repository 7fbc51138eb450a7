//! The optimiser: L-BFGS (memory 8) with Armijo backtracking (Nocedal & Wright,
//! Numerical Optimization, 2nd ed. 2006: Algorithms 7.4 and 7.5, and 3.1 for the line
//! search).

use super::criterion::{Eval, Problem};
use super::fourier::dot;
use crate::error::Result;

/// Pairs kept in the L-BFGS memory.
const MEMORY: usize = 8;

/// L-BFGS (memory 8) with Armijo backtracking; memory reset when a step fails, stop when
/// steepest descent fails too or `iters` is reached. `tick` is called once per iteration.
pub(super) fn lbfgs(
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
    let mut mem = Memory::default();
    let mut f = e.f;
    let mut done = 0;
    while done < iters {
        done += 1;
        tick();
        let (d, slope) = mem.descent(&g);
        match backtrack(pr, &x, &d, f, slope, sharpness)? {
            Some((xn, mut en)) => {
                let gn = en.grad.take().expect("gradient asked");
                mem.push(diff(&xn, &x), diff(&gn, &g));
                let improvement = f - en.f;
                x = xn;
                f = en.f;
                g = gn;
                // keep the scale-invariant coefficient blocks near unit norm
                if drifted(pr, &x) {
                    pr.normalise(&mut x);
                    let mut e2 = pr.eval(&x, true, sharpness)?;
                    f = e2.f;
                    g = e2.grad.take().expect("gradient asked");
                    mem.clear();
                }
                if improvement.abs() < 1e-10 * f.abs().max(1.0) && mem.is_empty() {
                    break;
                }
            }
            None if !mem.is_empty() => mem.clear(),
            None => break,
        }
    }
    Ok((x, f))
}

/// The L-BFGS memory: the last steps `s = x_{k+1} - x_k` and gradient changes `y`.
#[derive(Default)]
struct Memory {
    ss: Vec<Vec<f64>>,
    ys: Vec<Vec<f64>>,
}

impl Memory {
    /// No pair kept (the next direction is a scaled gradient).
    fn is_empty(&self) -> bool {
        self.ss.is_empty()
    }

    /// Forgets every pair (after a failed step or a renormalisation, which invalidate them).
    fn clear(&mut self) {
        self.ss.clear();
        self.ys.clear();
    }

    /// Keeps the pair when its curvature `s . y` is safely positive, dropping the oldest
    /// beyond [`MEMORY`] pairs.
    fn push(&mut self, s: Vec<f64>, y: Vec<f64>) {
        if dot(&s, &y) > 1e-12 * dot(&s, &s).sqrt() * dot(&y, &y).sqrt() {
            self.ss.push(s);
            self.ys.push(y);
            if self.ss.len() > MEMORY {
                self.ss.remove(0);
                self.ys.remove(0);
            }
        }
    }

    /// The step `d` (the iterate moves along `-d`) and the slope `-g . d`: the two-loop
    /// recursion, or (memory cleared) a scaled gradient when that is not a descent direction.
    fn descent(&mut self, g: &[f64]) -> (Vec<f64>, f64) {
        let d = self.two_loop(g);
        let slope = -dot(g, &d);
        if slope < 0.0 {
            return (d, slope);
        }
        self.clear();
        let sc = 0.1 / dot(g, g).sqrt().max(1e-12);
        let d: Vec<f64> = g.iter().map(|v| v * sc).collect();
        let slope = -dot(g, &d);
        (d, slope)
    }

    /// `H g` by the two-loop recursion, `H_0 = gamma I` with `gamma = s.y / y.y` of the last
    /// pair (`0.1 / |g|` with an empty memory).
    fn two_loop(&self, g: &[f64]) -> Vec<f64> {
        let (ss, ys) = (&self.ss, &self.ys);
        let mut d = g.to_vec();
        let mut alphas = vec![0.0; ss.len()];
        for j in (0..ss.len()).rev() {
            let rho = 1.0 / dot(&ys[j], &ss[j]);
            alphas[j] = rho * dot(&ss[j], &d);
            d.iter_mut().zip(&ys[j]).for_each(|(v, y)| *v -= alphas[j] * y);
        }
        let gamma = if let (Some(s), Some(y)) = (ss.last(), ys.last()) {
            dot(s, y) / dot(y, y)
        } else {
            0.1 / dot(g, g).sqrt().max(1e-12)
        };
        d.iter_mut().for_each(|v| *v *= gamma);
        for j in 0..ss.len() {
            let rho = 1.0 / dot(&ys[j], &ss[j]);
            let beta = rho * dot(&ys[j], &d);
            d.iter_mut().zip(&ss[j]).for_each(|(v, s)| *v += (alphas[j] - beta) * s);
        }
        d
    }
}

/// Backtracking on `x - t d` (`t = 1, 1/2, ...`, 30 tries): the first point with the
/// Armijo decrease `f(x - t d) <= f + 1e-4 t slope`, with its evaluation (gradient included).
fn backtrack(
    pr: &Problem,
    x: &[f64],
    d: &[f64],
    f: f64,
    slope: f64,
    sharpness: Option<f64>,
) -> Result<Option<(Vec<f64>, Eval)>> {
    let mut t = 1.0;
    for _ in 0..30 {
        let xn: Vec<f64> = x.iter().zip(d).map(|(a, b)| a - t * b).collect();
        let en = pr.eval(&xn, true, sharpness)?;
        if en.f.is_finite() && en.f <= f + 1e-4 * t * slope {
            return Ok(Some((xn, en)));
        }
        t *= 0.5;
    }
    Ok(None)
}

/// `a - b`, elementwise.
fn diff(a: &[f64], b: &[f64]) -> Vec<f64> {
    a.iter().zip(b).map(|(a, b)| a - b).collect()
}

/// Whether some joint's coefficient block has drifted out of `[0.5, 2)` in norm (the map
/// is invariant to it, but far from 1 the steps lose scale).
fn drifted(pr: &Problem, x: &[f64]) -> bool {
    (0..pr.n).any(|i| {
        let off = i * (1 + 2 * pr.h) + 1;
        let nrm = x[off..off + 2 * pr.h].iter().map(|v| v * v).sum::<f64>().sqrt();
        !(0.5..2.0).contains(&nrm)
    })
}

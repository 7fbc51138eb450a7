//! One joint's model with some of its columns replaced by a shape between the dictionary's
//! grid points, scored without rebuilding the dictionary: the Gram matrices of the joint's
//! row are summed again over the columns that row uses (`dictionary::regram_over`), on a
//! stride of the log while searching (`SEARCH_ROWS`) and on every sample for the result.
//! Shared by the fitted ripple period (`ripple_period`) and the fitted velocity scales of
//! smooth and Stribeck friction (`shape_scale`), with the one-dimensional search and the
//! Gauss-Newton standard error both use.

use super::dictionary::{C_TARGET, Dictionary, Grams, Rows, regram_over};
use super::model::{Fit, Model, fit, joint_index, rss_joint};
use super::score::Ctx;

/// Samples the search sums the new columns over (every k-th of the log, the sums scaled by
/// k): the log's signals are sampled far above their bandwidth (a ripple at 20 per turn on a
/// joint at 2 rad/s is 6 Hz), so a few thousand samples give the sums to a fraction of the
/// differences between shapes; the result is scored on all of them. (Every sample: 1.0-1.6 s
/// more on 32-56 s logs with two or three ripples.)
const SEARCH_ROWS: usize = 4000;

/// Model `m` with joint `j`'s columns open to replacement.
pub(super) struct Reshape<'c, 'a> {
    pub(super) ctx: &'c Ctx<'a>,
    pub(super) d: &'c Dictionary,
    pub(super) m: &'c Model,
    pub(super) j: usize,
    /// The columns joint `j`'s row of `m` uses, and the target.
    used: Vec<usize>,
    /// The samples the search sums over (`SEARCH_ROWS`), and all of them.
    pub(super) search: Rows,
    pub(super) all: Rows,
}

impl<'c, 'a> Reshape<'c, 'a> {
    pub(super) fn new(ctx: &'c Ctx<'a>, d: &'c Dictionary, m: &'c Model, j: usize) -> Self {
        let (t_len, bpf) = (d.r0[j].len(), ctx.opts.blocks_per_fold.max(1));
        let mut used: Vec<usize> = joint_index(&m.params(), j).into_iter().map(|(_, c)| c).collect();
        used.push(C_TARGET);
        let search = Rows::every(t_len, t_len.div_ceil(SEARCH_ROWS), bpf);
        Reshape { ctx, d, m, j, used, search, all: Rows::every(t_len, 1, bpf) }
    }

    /// The Gram matrices with the columns `new` (values on `rows`), summed over `rows`.
    pub(super) fn grams(&self, new: &[(usize, &[f64])], rows: &Rows) -> Grams {
        let mut gr = self.ctx.gr.clone();
        regram_over(self.d, &mut gr, self.j, new, rows, &self.used);
        gr
    }

    /// The whole model's held-out residual (`Ctx::heldout_rss`) with the columns `new`.
    pub(super) fn heldout(&self, new: &[(usize, &[f64])], rows: &Rows) -> f64 {
        self.ctx.on(&self.grams(new, rows)).heldout_rss(self.m)
    }

    /// The model fitted on the whole log with the columns `new`, and joint `j`'s residual
    /// sum of squares under it.
    pub(super) fn fit(&self, new: &[(usize, &[f64])], rows: &Rows) -> (Fit, f64) {
        let gr = self.grams(new, rows);
        let f = fit(&self.m.params(), &gr, &self.ctx.w, &[0, 1]);
        let rss = rss_joint(&f, &gr, self.j, &[0, 1]);
        (f, rss)
    }

    /// Joint `j`'s residual sum of squares over the folds `folds` alone, the model fitted on
    /// them with the columns `new` (a fold's own fit, for the two-block jackknife of a shape's
    /// scale, `uncertainty`).
    pub(super) fn rss_on(&self, new: &[(usize, &[f64])], rows: &Rows, folds: &[usize]) -> f64 {
        let gr = self.grams(new, rows);
        rss_joint(&fit(&self.m.params(), &gr, &self.ctx.w, folds), &gr, self.j, folds)
    }

    /// Joint `j`'s per-sample variance the Gauss-Newton error reads: its noise variance times
    /// the residual's autocorrelation time.
    pub(super) fn noise_var(&self) -> f64 {
        self.ctx.sigma[self.j].powi(2) * self.ctx.tau[self.j]
    }
}

/// The minimum of `f` on `[a, b]` by golden-section search, to `tol`.
pub(super) fn golden(f: &dyn Fn(f64) -> f64, mut a: f64, mut b: f64, tol: f64) -> f64 {
    let g = (5f64.sqrt() - 1.0) / 2.0;
    let (mut c, mut d) = (b - g * (b - a), a + g * (b - a));
    let (mut fc, mut fd) = (f(c), f(d));
    while b - a > tol {
        if fc < fd {
            (b, d, fd) = (d, c, fc);
            c = b - g * (b - a);
            fc = f(c);
        } else {
            (a, c, fc) = (c, d, fd);
            d = a + g * (b - a);
            fd = f(d);
        }
    }
    (a + b) / 2.0
}

/// The Gauss-Newton standard error of the minimiser `x` of the residual sum of squares
/// `rss` with per-sample variance `var` (noise variance times its autocorrelation time):
/// `sqrt(2 var / rss''(x))`, the curvature by central differences of step `dx`; `None`
/// where it is not positive.
pub(super) fn gauss_newton_std(rss: &dyn Fn(f64) -> f64, x: f64, dx: f64, var: f64) -> Option<f64> {
    let curv = (rss(x + dx) - 2.0 * rss(x) + rss(x - dx)) / (dx * dx);
    (curv > 0.0 && var.is_finite()).then(|| (2.0 * var / curv).sqrt())
}

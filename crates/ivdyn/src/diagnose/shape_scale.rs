//! The velocity scale of a named smooth or Stribeck friction fitted between the grid's points.
//!
//! The search chooses smooth friction's `tanh(qd / vs)` and Stribeck friction's
//! `exp(-(qd / vs)^2) sign(qd)` on grids of `vs` (`SMOOTH_VS`, steps of 1.33-1.5x;
//! `STRIBECK_VS`, steps of 2-2.5x), which alone put up to 20 % and 60 % on the reported `vs`
//! and pull the level fitted with it (`fc`, `fs`) along. For the parameters of
//! `diagnosis.json`, `ln vs` is fitted by golden-section search on the joint's residual sum of
//! squares under the final model (fitted on the whole log), between the chosen grid point's
//! neighbours (one grid step beyond the grid's ends); the level is the fit's at that `vs`, and
//! `vs` gets the Gauss-Newton standard error `vs sqrt(2 sigma^2 tau / RSS''(ln vs))` (noise
//! variance times the residual's autocorrelation time over half the curvature), or where
//! larger half the difference of the scales the same search finds on each fold alone (a
//! two-block jackknife; the other parameters' errors hold a 16-block one: `uncertainty`). The names,
//! the final fit and the residuals stay the grid's: the scale is read, not searched again.

use super::EffectKind;
use super::dictionary::{C_SIGN, C_STRIBECK, C_STUCK, C_TANH, Dictionary, Rows};
use super::model::{Fit, Model};
use super::reshape::{Reshape, gauss_newton_std, golden};
use super::score::Ctx;

/// The search's tolerance on `ln vs` (0.2 % of `vs`).
const LN_TOL: f64 = 0.002;

/// Step in `ln vs` of the curvature's central differences (2 %).
const LN_STEP: f64 = 0.02;

/// A friction shape's fitted scale on one joint.
#[derive(Debug, Clone, Copy)]
pub(super) struct Scale {
    /// The velocity scale (rad/s or m/s) and its standard error (`None` where the residual's
    /// curvature in `ln vs` is not positive).
    pub(super) vs: f64,
    pub(super) vs_std: Option<f64>,
    /// The level the shape multiplies (smooth: `fc`; Stribeck: `fs`) and Coulomb friction's
    /// `fc` beside it (Stribeck), from the fit at `vs`.
    pub(super) level: f64,
    pub(super) fc: f64,
}

/// Joint `j`'s smooth (`SmoothCoulomb`) or Stribeck friction of the final model `m`, its
/// scale fitted (module docs).
pub(super) fn fit_scale(ctx: &Ctx, m: &Model, d: &Dictionary, j: usize, kind: EffectKind) -> Scale {
    let (grid, g, col) = match kind {
        EffectKind::Stribeck => (&d.vs[j], m.stribeck_vs[j], C_STRIBECK + m.stribeck_vs[j]),
        _ => (&d.smooth_vs[j], m.smooth_vs[j], C_TANH + m.smooth_vs[j]),
    };
    let x: Vec<f64> = grid.iter().map(|v| v.ln()).collect();
    let last = x.len() - 1;
    let lo = if g == 0 { 2.0 * x[0] - x[1] } else { x[g - 1] };
    let hi = if g == last { 2.0 * x[last] - x[last - 1] } else { x[g + 1] };
    let r = Reshape::new(ctx, d, m, j);
    let column = |vs: f64, rows: &Rows| -> Vec<f64> {
        let (qd, sg, stuck) = (&d.cols[j][super::dictionary::C_QD], &d.cols[j][C_SIGN], &d.cols[j][C_STUCK]);
        rows.k
            .iter()
            .map(|&k| match kind {
                // at rest the stick column stands for the Stribeck shape (`dictionary`)
                EffectKind::Stribeck if stuck[k] != 0.0 => 0.0,
                EffectKind::Stribeck => (-(qd[k] / vs).powi(2)).exp() * sg[k],
                _ => (qd[k] / vs).tanh(),
            })
            .collect()
    };
    let rss = |x: f64, rows: &Rows| r.fit(&[(col, &column(x.exp(), rows))], rows).1;
    let best = golden(&|x| rss(x, &r.search), lo, hi, LN_TOL);
    // the grid point's own where the search lands no lower (a valley outside the range)
    let xv = if rss(best, &r.search) < rss(x[g], &r.search) { best } else { x[g] };
    let (f, _) = r.fit(&[(col, &column(xv.exp(), &r.all))], &r.all);
    let vs = xv.exp();
    // the same search on each fold alone: half the difference of the two minimisers is a
    // two-block jackknife of `ln vs`, kept where larger than the noise's error (`uncertainty`)
    let on = |folds: &[usize]| {
        golden(&|x| r.rss_on(&[(col, &column(x.exp(), &r.search))], &r.search, folds), lo, hi, LN_TOL)
    };
    let jack = 0.5 * (on(&[0]) - on(&[1])).abs();
    let x_std = gauss_newton_std(&|x| rss(x, &r.search), xv, LN_STEP, r.noise_var()).map(|s| s.max(jack));
    Scale { vs, vs_std: x_std.map(|s| vs * s), level: theta(&f, j, col), fc: theta(&f, j, C_SIGN) }
}

/// The fitted value of joint `j`'s parameter in column `col` (0 if absent).
fn theta(f: &Fit, j: usize, col: usize) -> f64 {
    f.params.iter().position(|p| p.joint == Some(j) && p.col == col).map_or(0.0, |i| f.theta[i])
}

//! A named ripple's period fitted between the grid's harmonics.
//!
//! The search names a ripple at one of the harmonics `sin(n q), cos(n q)` of `RIPPLE_N`, the
//! one whose held-out share is largest. A drive's ripple need not sit on that grid (cogging
//! has as many periods per turn as the motor's slots, poles and gear make): off it, the
//! nearest harmonic drifts out of phase over the sweep, its amplitude comes out low and what
//! it leaves goes to look-alikes (a spring, an offset). So once the search is done, each named
//! ripple's harmonic `h` is fitted over `[H_LO, H_HI]` times its grid entry, which spans the
//! gaps between neighbouring entries and a margin beyond the ends of the grid: a scan of the
//! whole model's two-fold held-out residual (`Ctx::heldout_rss`, the criterion the grid
//! shapes are chosen again by, `regrid`) with the ripple's columns at `h`, in steps of
//! `PHASE_STEP` radian of phase over the joint's sweep, then a golden-section search around
//! the best. (A scan of the residual the rest of the model leaves, fitted with the ripple
//! alone, was tried first: over the third of a radian some joints of the random arms sweep,
//! a harmonic trades against the joint's offset and spring, and it chose 15 for a true 10.)
//! The fitted harmonic is kept when that held-out residual is lower than with the grid's;
//! its standard error is the Gauss-Newton one, `s^2 = 2 sigma^2 tau / RSS''(h)`
//! (noise variance times the residual's autocorrelation time over half the curvature of the
//! residual sum of squares in `h`).

use super::EffectKind;
use super::dictionary::{C_Q, C_RIPPLE, Dictionary, Rows, regram};
use super::drive_rules::RIPPLE_MIN_PERIODS;
use super::model::Model;
use super::prepare::Prepared;
use super::reshape::{Reshape, gauss_newton_std, golden};
use super::score::Ctx;

/// The range of the fitted harmonic, as factors of its grid entry: the grid's neighbours are
/// 1.33-1.5 apart (`RIPPLE_N`), so from either side of a gap the range reaches across it.
const H_LO: f64 = 0.7;
const H_HI: f64 = 1.4;

/// The scan's step in phase over the joint's sweep (rad): the held-out residual's valley
/// around the best harmonic is about 2 pi of phase wide (a harmonic a period off over the
/// sweep fits nothing), so a step of a twelfth of it lands the golden-section search in it.
const PHASE_STEP: f64 = 0.5;

/// The least held-out gain of a fitted harmonic over the grid's, in noise variances times the
/// residual's autocorrelation time (the weighted residual's unit): the 99.9 % quantile of
/// chi-square with one degree of freedom, the harmonic being one parameter more.
const GAIN_CHI2: f64 = 10.83;

/// The least held-out gain of a fitted harmonic as a share of what the ripple explains at the
/// grid's: below it, what the period gains is the other effects' misfit, not the ripple's.
/// (On the UR5 drive fixture, exact inertials, the true periods on the grid moved 2-3 % for
/// 0.07-0.13 %, and an amplitude went 20 % off; on the wide-motion random arms the true grid
/// periods moved for 0.01-0.1 %. Off-grid ripples on joints sweeping 0.3-1.3 rad gained
/// 0.2-22 %, a few of them less: at 0.002, 3 of 18 fitted periods that were right stay on
/// the grid, `ripple_off` tuning part, docs/diagnose.md.)
const MIN_GAIN_SHARE: f64 = 0.002;

/// How close to an end of the scanned range a fitted harmonic is at that end, in radian of
/// phase over the joint's sweep (twice the golden-section search's tolerance). There the
/// held-out residual still falls beyond the range (most often below its lower end: a period
/// longer than twice the sweep, which the sweep cannot tell from a trend), so the harmonic
/// is a bound, not an estimate: it gets no standard error (on the twelve random arms
/// rarm24-35, five fitted periods 5-64 % off had Gauss-Newton standard errors of 0.4-2 %,
/// docs/diagnose.md).
const AT_END: f64 = 0.02;

/// A ripple's fitted harmonic on one joint: the slot it takes and its new columns.
pub(super) struct Refined {
    pub(super) j: usize,
    pub(super) slot: usize,
    pub(super) h: f64,
    pub(super) h_std: Option<f64>,
    /// `h` is at an end of the scanned range (the least held-out residual lies beyond it).
    at_end: bool,
    cols: [Vec<f64>; 2],
    /// The whole model's held-out residual with it, as a fraction of that with the grid's.
    ratio: f64,
}

/// The fitted harmonic of every ripple in `m` where it beats the grid's (module docs).
pub(super) fn refine(ctx: &Ctx, d: &Dictionary, m: &Model) -> Vec<Refined> {
    // against the terminal link's own CAD error too, when the re-fit leaves it out and no
    // payload holds it (`search::with_terminal_cad`): a terminal joint's ripple at a wrong
    // period otherwise takes part of it
    let m = &Model { terminal_cad: ctx.refit && !m.payload, ..m.clone() };
    let h_grid = ctx.heldout_rss(m);
    let mut out = vec![];
    for j in (0..ctx.n).filter(|&j| m.has(j, EffectKind::TorqueRipple)) {
        let slot = m.ripple_n[j];
        let h0 = d.ripple_h[j][slot].0;
        let span = ctx.q_span[j];
        let lo = (H_LO * h0).max(RIPPLE_MIN_PERIODS * std::f64::consts::TAU / span);
        let hi = H_HI * h0;
        let step = PHASE_STEP / span;
        if hi <= lo {
            continue;
        }
        let at = Harmonic::new(ctx, d, m, j);
        let hs: Vec<f64> = (0..=((hi - lo) / step).ceil() as usize).map(|i| (lo + i as f64 * step).min(hi)).collect();
        let scores = crate::par::map(ctx.threads, &hs, |&h| at.heldout(h, &at.r.search));
        let best = (0..hs.len()).min_by(|&a, &b| scores[a].total_cmp(&scores[b])).unwrap_or(0);
        // to a hundredth of a radian of phase over the sweep
        let h =
            golden(&|h| at.heldout(h, &at.r.search), (hs[best] - step).max(lo), (hs[best] + step).min(hi), 0.01 / span);
        let h_new = at.heldout(h, &at.r.all);
        // what the ripple explains at the grid's harmonic
        let share = ctx.heldout_rss(&m.without(Some(j), EffectKind::TorqueRipple)) - h_grid;
        if h_grid - h_new > (GAIN_CHI2 * ctx.tau[j]).max(MIN_GAIN_SHARE * share) {
            // at an end of the range the residual still falls beyond it: no curvature there
            let at_end = h - lo <= AT_END / span || hi - h <= AT_END / span;
            let h_std = if at_end { None } else { gauss_newton_std(&|h| at.rss(h), h, step / 4.0, at.r.noise_var()) };
            out.push(Refined { j, slot, h, h_std, at_end, cols: at.cols(h, &at.r.all), ratio: h_new / h_grid });
        }
    }
    out
}

/// The model `m` with joint `j`'s ripple at any harmonic (`reshape::Reshape`).
struct Harmonic<'c, 'a> {
    r: Reshape<'c, 'a>,
    /// Joint `j`'s positions (rad).
    q: Vec<f64>,
}

impl<'c, 'a> Harmonic<'c, 'a> {
    fn new(ctx: &'c Ctx<'a>, d: &'c Dictionary, m: &'c Model, j: usize) -> Self {
        let q: Vec<f64> = d.cols[j][C_Q].iter().map(|x| x + d.q_mean[j]).collect();
        Harmonic { r: Reshape::new(ctx, d, m, j), q }
    }

    /// `sin(h q), cos(h q)` on the samples `rows`.
    fn cols(&self, h: f64, rows: &Rows) -> [Vec<f64>; 2] {
        let (sin, cos) = rows.k.iter().map(|&k| (h * self.q[k]).sin_cos()).unzip();
        [sin, cos]
    }

    /// The whole model's held-out residual (`Ctx::heldout_rss`) at harmonic `h`, the new
    /// columns' sums over `rows`.
    fn heldout(&self, h: f64, rows: &Rows) -> f64 {
        let c = C_RIPPLE + 2 * self.r.m.ripple_n[self.r.j];
        let [sin, cos] = self.cols(h, rows);
        self.r.heldout(&[(c, &sin), (c + 1, &cos)], rows)
    }

    /// Joint `j`'s residual sum of squares of the model fitted on the whole log at `h`.
    fn rss(&self, h: f64) -> f64 {
        let c = C_RIPPLE + 2 * self.r.m.ripple_n[self.r.j];
        let [sin, cos] = self.cols(h, &self.r.search);
        self.r.fit(&[(c, &sin), (c + 1, &cos)], &self.r.search).1
    }
}

/// Writes the fitted harmonics into the prepared log's dictionary and Gram matrices; a note
/// for each (joint names `names`).
pub(super) fn apply(p: &mut Prepared, refined: Vec<Refined>, blocks_per_fold: usize, names: &[String]) -> Vec<String> {
    let mut notes = vec![];
    for r in refined {
        let c = C_RIPPLE + 2 * r.slot;
        regram(&p.d, &mut p.gr, r.j, &[(c, &r.cols[0]), (c + 1, &r.cols[1])], blocks_per_fold);
        let h_grid = p.d.ripple_h[r.j][r.slot].0;
        let [sin, cos] = r.cols;
        p.d.cols[r.j][c] = sin;
        p.d.cols[r.j][c + 1] = cos;
        p.d.ripple_h[r.j][r.slot] = (r.h, r.h_std);
        let tau = std::f64::consts::TAU;
        let end = match r.at_end {
            true => "; at the end of the range the sweep can tell, so a bound, without a standard error",
            false => "",
        };
        notes.push(format!(
            "torque ripple on {}: period fitted between the grid's harmonics, {:.4} rad ({:.2} per turn; the grid's nearest {:.4} rad), the whole model's held-out residual {:.1} % lower{end}",
            names[r.j],
            tau / r.h,
            r.h,
            tau / h_grid,
            100.0 * (1.0 - r.ratio)
        ));
    }
    notes
}

#[cfg(test)]
mod tests {
    use super::super::dictionary::fold_of;
    use super::*;

    /// Per fold, the sums of the two-column fit of `e` on `sin(h q), cos(h q)`:
    /// `[ss, sc, cc, se, ce, ee]`.
    struct Sums([[f64; 6]; 2]);

    impl Sums {
        /// Over samples `k` in fold `fold[k]` (all in fold 0 when `fold` is empty).
        fn of(q: &[f64], e: &[f64], fold: &[usize], h: f64) -> Self {
            let mut s = [[0.0; 6]; 2];
            for (k, (&x, &r)) in q.iter().zip(e).enumerate() {
                let (sn, cs) = (h * x).sin_cos();
                let f = &mut s[fold.get(k).copied().unwrap_or(0)];
                for (acc, v) in f.iter_mut().zip([sn * sn, sn * cs, cs * cs, sn * r, cs * r, r * r]) {
                    *acc += v;
                }
            }
            Sums(s)
        }

        /// Fold `f`'s residual sum of squares at fold `g`'s least-squares `(a, b)`.
        fn rss(&self, f: usize, g: usize) -> f64 {
            let [ss, sc, cc, se, ce, _] = self.0[g];
            let det = ss * cc - sc * sc;
            let (a, b) = ((cc * se - sc * ce) / det, (ss * ce - sc * se) / det);
            let [ss, sc, cc, se, ce, ee] = self.0[f];
            ee - 2.0 * (a * se + b * ce) + a * a * ss + 2.0 * a * b * sc + b * b * cc
        }

        fn heldout(&self) -> f64 {
            self.rss(1, 0) + self.rss(0, 1)
        }

        fn rss_all(&self) -> f64 {
            self.rss(0, 0)
        }
    }

    /// A sampled ripple `0.3 sin(h q + 0.4)` over a sweep: the scan's criterion and the
    /// golden-section search find `h` where the residual vanishes, and the held-out residual
    /// of a wrong harmonic is not below it.
    #[test]
    fn the_period_of_a_clean_ripple_is_found_between_grid_entries() {
        let h_true = 9.3;
        let q: Vec<f64> = (0..4000).map(|k| 1.2 * (k as f64 * 0.003).sin()).collect();
        let e: Vec<f64> = q.iter().map(|x| 0.3 * (h_true * x + 0.4).sin()).collect();
        let fold: Vec<usize> = (0..q.len()).map(|k| fold_of(k, q.len(), 8)).collect();
        let score = |h: f64| Sums::of(&q, &e, &fold, h).heldout();
        let h = golden(&score, 9.0, 9.6, 1e-6);
        assert!((h - h_true).abs() < 1e-4, "h = {h}");
        assert!(score(h) < 1e-8 && score(8.0) > 1.0, "{} {}", score(h), score(8.0));
    }

    /// With white noise of std 0.05 on the ripple, the Gauss-Newton standard error is the
    /// fitted harmonic's spread over seeded draws.
    #[test]
    fn the_period_standard_error_matches_the_spread_over_noise_draws() {
        let h_true = 6.7;
        let q: Vec<f64> = (0..3000).map(|k| 1.5 * (k as f64 * 0.004).sin()).collect();
        let mut fits = vec![];
        let mut stds = vec![];
        let mut beyond = 0;
        let mut state = 12345u64;
        let mut normal = || {
            // Box-Muller over a 64-bit LCG (Knuth's constants)
            let mut u = || {
                state = state.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
                ((state >> 11) as f64 + 0.5) / (1u64 << 53) as f64
            };
            let (u1, u2) = (u(), u());
            (-2.0 * u1.ln()).sqrt() * (std::f64::consts::TAU * u2).cos()
        };
        for _ in 0..40 {
            let e: Vec<f64> = q.iter().map(|x| 0.2 * (h_true * x).cos() + 0.05 * normal()).collect();
            let rss = |h: f64| Sums::of(&q, &e, &[], h).rss_all();
            let h = golden(&rss, 6.4, 7.0, 1e-6);
            let s = gauss_newton_std(&rss, h, 0.01, 0.05 * 0.05).unwrap();
            beyond += usize::from((h - h_true).abs() > 3.0 * s);
            fits.push(h);
            stds.push(s);
        }
        let mean = fits.iter().sum::<f64>() / fits.len() as f64;
        let spread = (fits.iter().map(|h| (h - mean).powi(2)).sum::<f64>() / (fits.len() - 1) as f64).sqrt();
        let s = stds.iter().sum::<f64>() / stds.len() as f64;
        // beyond 3 std: 0.11 expected of 40 (P(>= 3) < 2e-4); the spread of 40 draws is
        // within 30 % of the true std with > 99.5 % probability (chi-square, 39 dof)
        assert!(beyond <= 2, "{beyond} of 40 beyond 3 std");
        assert!(spread > 0.7 * s && spread < 1.4 * s, "spread {spread} vs std {s}");
    }
}

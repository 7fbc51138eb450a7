//! Smooth friction, or Coulomb friction seen through a stick phase.
//!
//! A friction smooth across zero speed is one of two things. A drive whose friction is a
//! function of the velocity, `fc tanh(qd / vs)` (lubricated, or modelled so), and Coulomb
//! friction whose stick is compliant: a drive's pre-sliding, or a simulator's friction
//! constraint solved softly (MuJoCo's `frictionloss` under its default `solref`: inside a
//! band of speeds the constraint force is `-k (qdd + b qd)`, `k` = d / (1 - d) times the
//! joint's inertia, until it reaches `fc`). Both fit a tanh over the log; only the second
//! holds the joint near zero speed: there its torque resists the acceleration, an inertia
//! the joint has at low speed only. So once the search is done, on each joint with smooth
//! friction the final fit's residual is regressed on `qdd` inside the tanh's band
//! (`|qd| < vs`) and outside it, and where the band's slope exceeds the outside one by
//! `STICK_SHARE` of the friction level (slope difference times the band's `qdd` std) at
//! one-sided 5 % (its standard error with the residual's autocorrelation time), the friction
//! is named Coulomb friction, with a note saying why.
//!
//! On MuJoCo's soft `frictionloss` (a random-arm set, docs/diagnose.md) the 23 Coulomb
//! frictions named smooth had a share of 0.048-0.21; the 41 true smooth frictions alone on
//! their joint -0.045 to +0.015, those of the sharp-constraint set -0.085 to +0.007.

use super::EffectKind;
use super::assemble::Found;
use super::dictionary::{C_QD, C_QDD, C_TANH, Dictionary};
use super::model::{Fit, effect_torque, fit};
use super::score::Ctx;
use super::shape_scale::fit_scale;

/// Least excess of the band's `qdd` slope over the outside one, times the band's `qdd`
/// std, as a share of the friction level (module docs: 0.015 and 0.048 the nearest
/// smooth and stick cases measured).
const STICK_SHARE: f64 = 0.03;

/// One-sided 5 % normal quantile: the excess must be positive beyond its noise.
const STICK_Z: f64 = 1.645;

/// The level of Coulomb friction read from a stick phase is read where `|qd|` exceeds this
/// many of the tanh's `vs` (`levels`): beyond it the soft stick is saturated at `fc` (a tanh
/// reaches 96 % of its level at 2 `vs`).
const STICK_LEVEL_BAND: f64 = 2.0;

/// Fewest samples in the band and outside it for the test.
const MIN_ROWS: usize = 50;

/// Smooth friction replaced by Coulomb friction on the joints where the residual shows a
/// stick phase (module docs), with a note for each; the joints it replaced it on.
pub(super) fn coulomb_through_stick(ctx: &Ctx, d: &Dictionary, names: &[String], found: &mut Found) -> Vec<usize> {
    let m = &found.model;
    let smooth: Vec<usize> = (0..ctx.n).filter(|&j| m.has(j, EffectKind::SmoothCoulomb)).collect();
    let mut replaced = vec![];
    if smooth.is_empty() {
        return replaced;
    }
    let f = fit(&m.params(), ctx.gr, &ctx.w, &[0, 1]);
    let t_len = d.r0[0].len();
    let e = effect_torque(&f, d, ctx.n, t_len);
    let mut model = m.clone();
    for j in smooth {
        let r: Vec<f64> = (0..t_len).map(|k| d.r0[j][k] - e[k * ctx.n + j]).collect();
        let vs = fit_scale(ctx, m, d, j, EffectKind::SmoothCoulomb).vs;
        let fc = level(&f, j, C_TANH + m.smooth_vs[j]).abs();
        let Some(s) = stick_test(&d.cols[j][C_QD], &d.cols[j][C_QDD], &r, vs, ctx.tau[j]) else { continue };
        if s.excess * s.qdd_std < STICK_SHARE * fc || s.excess < STICK_Z * s.se {
            continue;
        }
        model = model.without(Some(j), EffectKind::SmoothCoulomb);
        model.stick_band[j] = STICK_LEVEL_BAND * vs;
        replaced.push(j);
        found.notes.push(format!(
            "{}: smooth Coulomb friction named Coulomb friction: where |qd| < vs = {vs:.3} ({:.0} % of the samples) the residual rises with qdd by {:.3} more per unit qdd than at speed (+- {:.3}), {:.0} % of the friction level {fc:.3} N m over the band's qdd: the joint sticks there (a compliant stick phase, e.g. a drive's pre-sliding or a simulator's soft friction constraint), which a friction of the velocity alone does not do",
            names[j],
            100.0 * s.band_share,
            s.excess,
            s.se,
            100.0 * s.excess * s.qdd_std / fc.max(f64::MIN_POSITIVE),
        ));
    }
    found.model = model;
    replaced
}

/// Joint `j`'s fitted parameter in column `col` (0 if absent).
fn level(f: &Fit, j: usize, col: usize) -> f64 {
    f.params.iter().position(|p| p.joint == Some(j) && p.col == col).map_or(0.0, |i| f.theta[i])
}

/// The band's `qdd` slope of the residual against the outside one.
#[derive(Debug, Clone, Copy, PartialEq)]
struct Stick {
    /// Slope inside `|qd| < vs` minus slope outside (N m s^2/rad or N s^2/m).
    excess: f64,
    /// Its standard error (the residual's variance times `tau` over each side's `Sxx`).
    se: f64,
    /// Standard deviation of `qdd` inside the band.
    qdd_std: f64,
    /// Share of the samples inside the band.
    band_share: f64,
}

/// The residual `r` regressed on `qdd` (with a constant) inside `|qd| < vs` and outside;
/// `None` with fewer than `MIN_ROWS` samples on a side or no spread of `qdd` there. `tau`:
/// the residual's integrated autocorrelation time (samples).
fn stick_test(qd: &[f64], qdd: &[f64], r: &[f64], vs: f64, tau: f64) -> Option<Stick> {
    let inside = |k: &usize| qd[*k].abs() < vs;
    let band: Vec<usize> = (0..r.len()).filter(inside).collect();
    let out: Vec<usize> = (0..r.len()).filter(|k| !inside(k)).collect();
    let (b, sb, qdd_std) = slope(&band, qdd, r, tau)?;
    let (o, so, _) = slope(&out, qdd, r, tau)?;
    Some(Stick { excess: b - o, se: sb.hypot(so), qdd_std, band_share: band.len() as f64 / r.len() as f64 })
}

/// Least-squares slope of `y` on `x` with a constant over `rows`, its standard error
/// (residual variance times `tau`) and the std of `x` there.
fn slope(rows: &[usize], x: &[f64], y: &[f64], tau: f64) -> Option<(f64, f64, f64)> {
    if rows.len() < MIN_ROWS {
        return None;
    }
    let n = rows.len() as f64;
    let (mx, my) = (rows.iter().map(|&k| x[k]).sum::<f64>() / n, rows.iter().map(|&k| y[k]).sum::<f64>() / n);
    let (mut sxx, mut sxy) = (0.0, 0.0);
    for &k in rows {
        sxx += (x[k] - mx).powi(2);
        sxy += (x[k] - mx) * (y[k] - my);
    }
    if sxx <= 0.0 {
        return None;
    }
    let c = sxy / sxx;
    let var = rows.iter().map(|&k| (y[k] - my - c * (x[k] - mx)).powi(2)).sum::<f64>() / (n - 2.0);
    Some((c, (var * tau.max(1.0) / sxx).sqrt(), (sxx / n).sqrt()))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A residual `k qdd` inside the band and nothing outside: the excess is `k`, exactly
    /// (no noise), and its standard error 0.
    #[test]
    fn excess_is_the_band_slope_over_the_outside_one() {
        let t: Vec<f64> = (0..2000).map(|k| k as f64 * 1e-3).collect();
        let qd: Vec<f64> = t.iter().map(|t| (3.0 * t).sin()).collect();
        let qdd: Vec<f64> = t.iter().map(|t| 3.0 * (3.0 * t).cos()).collect();
        let r: Vec<f64> = (0..t.len()).map(|k| if qd[k].abs() < 0.2 { 0.7 * qdd[k] } else { 0.0 }).collect();
        let s = stick_test(&qd, &qdd, &r, 0.2, 1.0).unwrap();
        assert!((s.excess - 0.7).abs() < 1e-9, "{s:?}");
        assert!(s.se < 1e-9);
        // the same slope everywhere (an inertia error): no excess
        let r: Vec<f64> = qdd.iter().map(|a| 0.7 * a).collect();
        assert!(stick_test(&qd, &qdd, &r, 0.2, 1.0).unwrap().excess.abs() < 1e-9);
        // too few samples in the band: no test
        assert!(stick_test(&qd, &qdd, &r, 1e-4, 1.0).is_none());
    }
}

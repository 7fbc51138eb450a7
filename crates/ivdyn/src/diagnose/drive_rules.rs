//! The rules of the real-drive effects that refine or compete with the basic vocabulary
//! (docs/diagnose.md, "Effects of real drives"):
//!
//! * **direction-dependent Coulomb friction** refines Coulomb friction found on a joint
//!   with the column `[qd > 0]` (`fc_pos [qd > 0] - fc_neg [qd < 0]`). On a moving joint it
//!   spans the same columns as Coulomb friction plus a torque offset, so the two readings
//!   are told apart by physics: an offset smaller than `ASYMMETRY_MAX` of the friction
//!   level (both `fc_pos` and `fc_neg` positive, within a factor 12) is read as
//!   direction-dependent friction, a larger one as an offset. It loses to plain Coulomb
//!   friction when its extra column fails the F test or the held-out share, i.e. when
//!   `fc_pos == fc_neg` within the data's uncertainty. Where Coulomb friction alone fails,
//!   the two are tried as one candidate (`pairs`).
//! * **smooth Coulomb friction** `fc tanh(qd / vs)` replaces Coulomb friction on a joint
//!   when held-out data prefer it: `vs` on a grid, the one removing most of the held-out
//!   residual; named only when the torque it changes against Coulomb friction's sign has
//!   an RMS of at least `min_effect` noise std (a sharp Coulomb friction fits a tanh with
//!   a tiny `vs` equally well, and changes nothing). Stribeck competes with it on the same
//!   joint (both refine Coulomb friction; the one that explains more is added first and
//!   the other is then not tried there).
//! * **torque ripple**: the harmonic pair `sin(n q), cos(n q)` on a grid of `n`, the one
//!   removing most of the held-out residual, among the harmonics of which the joint sweeps
//!   at least half a period (over less, a harmonic is a smooth trend in `q`); and, as gravity
//!   is periodic in `q` too, it must pass the look-alike check against the nominal model's
//!   own error (`rules::model_error_lookalike`).

use super::EffectKind;
use super::JointScore;
use super::dictionary::Dictionary;
use super::dictionary::{C_BASE, C_GAIN, C_ONE, C_SIGN, C_SIGN_POS, C_TANH, RIPPLE_N, SMOOTH_VS};
use super::model::{Fit, Model, Param, effect_rms, fit};
use super::score::{Ctx, Scored, not_scored};

/// The fitted value of joint `j`'s parameter in column `col` (0 if absent).
fn theta_at(f: &Fit, j: usize, col: usize) -> f64 {
    f.params.iter().position(|p| p.joint == Some(j) && p.col == col).map_or(0.0, |i| f.theta[i])
}

/// Largest asymmetry `|fc_pos - fc_neg| / (fc_pos + fc_neg)` read as direction-dependent
/// friction; beyond it one direction's level is below 1/12 of the other's, which is an
/// offset beside Coulomb friction (a sensor's, a load's) rather than a drive's asymmetry. It
/// is `|tau0| / fc` of the same columns read as Coulomb friction `fc` and an offset `tau0`.
/// (0.75, levels within a factor 7, turned true asymmetries of 0.70 into Coulomb friction +
/// offset on the tuning parts: estimates scatter by a few %; docs/diagnose.md.)
const ASYMMETRY_MAX: f64 = 0.85;

/// A significant offset on a joint with Coulomb friction (`l`: the model with it) is, on a
/// moving joint, direction-dependent friction when it is smaller than `ASYMMETRY_MAX` of the
/// friction level: rejected there as that look-alike (the asymmetric candidate names it).
pub(super) fn offset_or_asymmetric(ctx: &Ctx, l: &Model, j: usize, sc: &mut JointScore) {
    if let Some((fc, tau0)) = offset_reads_as_asymmetric(ctx, l, j) {
        sc.significant = false;
        sc.rejected_by = Some(format!(
            "look-alike: with Coulomb friction fc {fc:.3} N m, an offset of {tau0:.3} N m is direction-dependent friction (fc_pos {:.3}, fc_neg {:.3} N m)",
            fc + tau0,
            fc - tau0
        ));
    }
}

/// Coulomb friction `fc` and offset `tau0` fitted on joint `j` of `l` (which has both) when
/// the offset is smaller than `ASYMMETRY_MAX` of the friction level: on a moving joint,
/// direction-dependent friction.
pub(super) fn offset_reads_as_asymmetric(ctx: &Ctx, l: &Model, j: usize) -> Option<(f64, f64)> {
    let f = fit(&l.params(), ctx.gr, &ctx.w, &[0, 1]);
    let (fc, tau0) = (theta_at(&f, j, C_SIGN), theta_at(&f, j, C_ONE));
    (fc > 0.0 && tau0.abs() < ASYMMETRY_MAX * fc).then_some((fc, tau0))
}

/// Why a refinement of Coulomb friction (Stribeck, smooth, direction-dependent) is not tried
/// on a joint without Coulomb friction found (a URDF's friction is the nominal's, not found).
pub(super) const NO_COULOMB_TO_REFINE: &str = "no Coulomb friction found on the joint for it to refine";

/// Whether the grid effect `e` can go on joint `j` of `m` (why not, when it cannot).
fn precondition(ctx: &Ctx, m: &Model, e: EffectKind, j: usize) -> Option<String> {
    let refined = [EffectKind::Stribeck, EffectKind::SmoothCoulomb, EffectKind::AsymmetricCoulomb];
    let why = match e {
        EffectKind::TorqueRipple if m.has(j, e) => "already in the model on this joint",
        EffectKind::TorqueRipple if ripple_grid(ctx, j).is_empty() => {
            return Some(format!(
                "the joint moves over {:.3} rad, less than half a period of every ripple harmonic ({:.3} rad the longest): a periodic torque is not told from a position-dependent trend there",
                ctx.q_span[j],
                std::f64::consts::TAU / RIPPLE_N[0]
            ));
        }
        EffectKind::TorqueRipple => return None,
        _ if !m.has(j, EffectKind::Coulomb) => NO_COULOMB_TO_REFINE,
        _ if refined.iter().any(|&r| m.has(j, r)) => "Coulomb friction on the joint is already refined",
        EffectKind::AsymmetricCoulomb if m.has(j, EffectKind::TorqueOffset) || m.has(j, EffectKind::JointSpring) => {
            "an offset on the joint already spans its column"
        }
        _ => return None,
    };
    Some(why.to_string())
}

/// The share of a ripple harmonic's period a joint must sweep for it to be tried: over half a
/// period `sin(n q)` passes an extremum between two zeros, a shape no slow trend has; over
/// less it is a monotone or parabolic trend in `q`. (On the tuning parts, 1.0 also dropped
/// true ripples of the UR5 drive fixture; 0 named ripples on 44 of the random arms' joints
/// where there was none; docs/diagnose.md.)
pub(super) const RIPPLE_MIN_PERIODS: f64 = 0.5;

/// The ripple harmonics (indices into `RIPPLE_N`) of which joint `j` sweeps at least
/// `RIPPLE_MIN_PERIODS` of a period.
fn ripple_grid(ctx: &Ctx, j: usize) -> Vec<usize> {
    (0..RIPPLE_N.len())
        .filter(|&g| RIPPLE_MIN_PERIODS * std::f64::consts::TAU / ctx.ripple_h[j][g] <= ctx.q_span[j])
        .collect()
}

/// The grid of the effect's shape on joint `j` (one entry for the asymmetric friction).
pub(super) fn grid(ctx: &Ctx, e: EffectKind, j: usize) -> Vec<usize> {
    match e {
        EffectKind::SmoothCoulomb => (0..SMOOTH_VS.len()).collect(),
        EffectKind::TorqueRipple => ripple_grid(ctx, j),
        _ => vec![0],
    }
}

/// `m` with `e` on joint `j` at grid entry `g`.
pub(super) fn with_shape(m: &Model, e: EffectKind, j: usize, g: usize) -> Model {
    let mut l = m.with(Some(j), e);
    match e {
        EffectKind::SmoothCoulomb => l.smooth_vs[j] = g,
        EffectKind::TorqueRipple => l.ripple_n[j] = g,
        _ => {}
    }
    l
}

/// Scores a refinement of Coulomb friction (smooth, direction-dependent) or a torque ripple
/// on every joint where it can go, its shape chosen on the grid by the held-out share.
pub(super) fn score_grid_effect(ctx: &Ctx, m: &Model, e: EffectKind) -> Scored {
    let mut per_joint = vec![];
    let mut larger = m.clone();
    for j in 0..ctx.n {
        if let Some(why) = precondition(ctx, m, e, j) {
            per_joint.push(not_scored(&why));
            continue;
        }
        let mut best: Option<(JointScore, Model)> = None;
        for g in grid(ctx, e, j) {
            let l = with_shape(m, e, j, g);
            let mut sc = ctx.joint_score(m, &l, j, &|p: &Param| p.joint == Some(j) && p.kind == Some(e));
            match e {
                EffectKind::SmoothCoulomb => smooth_size(ctx, m, &l, j, &mut sc),
                EffectKind::AsymmetricCoulomb => asymmetric_sign(ctx, &l, j, &mut sc),
                _ => {}
            }
            if best.as_ref().is_none_or(|(b, _)| sc.heldout_gain > b.heldout_gain) {
                best = Some((sc, l));
            }
        }
        let (sc, l) = best.expect("grid not empty");
        if sc.significant {
            larger.per_joint[j] = l.per_joint[j].clone();
            larger.smooth_vs[j] = l.smooth_vs[j];
            larger.ripple_n[j] = l.ripple_n[j];
        }
        per_joint.push(sc);
    }
    (per_joint, larger, vec![])
}

/// Smooth friction is named only where it changes the torque against Coulomb friction's
/// sign by at least `min_effect` noise std RMS (module docs): the size rule, applied to
/// that change.
pub(super) fn smooth_size(ctx: &Ctx, m: &Model, l: &Model, j: usize, sc: &mut JointScore) {
    let (fm, fl) = (fit(&m.params(), ctx.gr, &ctx.w, &[0, 1]), fit(&l.params(), ctx.gr, &ctx.w, &[0, 1]));
    let tanh = C_TANH + l.smooth_vs[j];
    let diff = Fit {
        params: vec![
            Param { kind: Some(EffectKind::SmoothCoulomb), joint: Some(j), col: tanh },
            Param { kind: Some(EffectKind::Coulomb), joint: Some(j), col: C_SIGN },
        ],
        theta: vec![theta_at(&fl, j, tanh), -theta_at(&fm, j, C_SIGN)],
    };
    sc.effect_rms = effect_rms(&diff, ctx.gr, j, &|_| true);
    if sc.significant || sc.rejected_by.as_deref().is_some_and(|r| r.starts_with("size")) {
        sc.rejected_by = ctx
            .statistical_rule(sc, j, ctx.refinement_share())
            .or_else(|| Ctx::unphysical(&fl, j, &|p| p.kind == Some(EffectKind::SmoothCoulomb)));
        sc.significant = sc.rejected_by.is_none();
    }
}

/// Direction-dependent friction is friction in both directions: `fc_pos` and `fc_neg`
/// positive (otherwise the column is an offset larger than the friction), their asymmetry
/// at most `ASYMMETRY_MAX`.
pub(super) fn asymmetric_sign(ctx: &Ctx, l: &Model, j: usize, sc: &mut JointScore) {
    if !sc.significant {
        return;
    }
    let f = fit(&l.params(), ctx.gr, &ctx.w, &[0, 1]);
    let fc_neg = theta_at(&f, j, C_SIGN);
    let fc_pos = fc_neg + theta_at(&f, j, C_SIGN_POS);
    let why = if fc_pos <= 0.0 || fc_neg <= 0.0 {
        format!("sign: fc_pos {fc_pos:.4}, fc_neg {fc_neg:.4} N m are not both positive")
    } else if (fc_pos - fc_neg).abs() > ASYMMETRY_MAX * (fc_pos + fc_neg) {
        format!(
            "size: fc_pos {fc_pos:.4}, fc_neg {fc_neg:.4} N m differ by more than {:.0} % of their sum (an offset beside Coulomb friction)",
            100.0 * ASYMMETRY_MAX
        )
    } else {
        return;
    };
    sc.significant = false;
    sc.rejected_by = Some(why);
}

/// Load-dependent friction's `mu` on joint `j` against the load the final fit `f` models:
/// the nominal torque corrected by the fit's rigid-body part (the re-fit's base corrections,
/// a payload), `|tau_nom + Y delta| sign(qd)`, regressed on what the rest of the fit leaves
/// on the joint; `None` when the fit has no rigid-body part. The search's column holds the
/// nominal torque (CAD inertials 20-50 % off), and `mu` scales with the load it is read
/// against: a drive's friction follows the torque it carries, not the CAD model's.
pub(super) fn load_mu_on_fitted_load(f: &Fit, d: &Dictionary, j: usize) -> Option<f64> {
    let (load, y, rigid) = fitted_torque_and_rest(f, d, j, &[EffectKind::LoadDependent]);
    if !rigid {
        return None;
    }
    // the residual without load-dependent friction, against the fitted load's column, where
    // the joint moves (`dictionary::moving`: at rest the friction is static, not `mu |load|`)
    let moving = super::dictionary::moving(d, j);
    let (mut num, mut den) = (0.0, 0.0);
    for t in (0..load.len()).filter(|&t| moving[t]) {
        let c = load[t].abs() * d.cols[j][C_SIGN][t];
        num += c * y[t];
        den += c * c;
    }
    (den > 0.0).then(|| num / den)
}

/// On joint `j`: the rigid-body torque the fit `f` models (the nominal one, `C_GAIN`'s
/// column, plus the re-fit's base corrections and a payload), and what the fit leaves for
/// the effects `e` (the nominal residual less every other effect and the rigid-body part),
/// and whether the fit has a rigid-body part on the joint.
pub(super) fn fitted_torque_and_rest(
    f: &Fit,
    d: &Dictionary,
    j: usize,
    e: &[EffectKind],
) -> (Vec<f64>, Vec<f64>, bool) {
    let rigid = |p: &Param| p.kind == Some(EffectKind::Payload) || p.kind.is_none() && p.col >= C_BASE;
    let on_j = |p: &Param| p.joint.is_none_or(|pj| pj == j);
    let cols = &d.cols[j];
    let mut tau = cols[C_GAIN].clone();
    let mut rest = d.r0[j].clone();
    for (p, &v) in f.params.iter().zip(&f.theta).filter(|(p, _)| on_j(p) && !p.kind.is_some_and(|k| e.contains(&k))) {
        if rigid(p) {
            tau.iter_mut().zip(&cols[p.col]).for_each(|(a, c)| *a += v * c);
        }
        rest.iter_mut().zip(&cols[p.col]).for_each(|(a, c)| *a -= v * c);
    }
    let has_rigid = f.params.iter().any(|p| rigid(p) && on_j(p));
    (tau, rest, has_rigid)
}

/// The time delay on joint `j` that makes the fitted rigid-body torque, shifted exactly,
/// `tau(t - delay) - tau(t)` (linear interpolation within each segment), best explain what
/// the fit `f` leaves for it; searched from the first-order estimate `delay0` (`-delay
/// tau'`, the search's column). The first order reads a delay short by `(w delay)^2 / 6` of
/// it at each frequency `w` of the torque: 3-5 % on the UR5 drive fixture, up to 15 % on the
/// random arms' faster torques (docs/diagnose.md). `delay0` when it is not positive.
pub(super) fn delay_exact(f: &Fit, d: &Dictionary, j: usize, delay0: f64) -> f64 {
    if delay0.is_nan() || delay0 <= 0.0 {
        return delay0;
    }
    let (tau, y, _) = fitted_torque_and_rest(f, d, j, &[EffectKind::TimeDelay]);
    // the samples with the longest shift's history in their segment
    let skip = (2.0 * delay0 / d.dt).ceil() as usize + 1;
    let rows: Vec<std::ops::Range<usize>> =
        d.segments.iter().filter(|s| s.len() > skip).map(|s| s.start + skip..s.end).collect();
    if rows.is_empty() {
        return delay0;
    }
    // residual sum of squares with the shift `delay`
    let sse = |delay: f64| -> f64 {
        let (i, frac) = ((delay / d.dt).floor() as usize, (delay / d.dt).fract());
        let mut s = 0.0;
        for k in rows.iter().flat_map(|r| r.clone()) {
            let past = tau[k - i] + frac * (tau[k - i - 1] - tau[k - i]);
            s += (y[k] - (past - tau[k])).powi(2);
        }
        s
    };
    // golden-section search on [delay0 / 2, 2 delay0] (the first order is within a few tens of %)
    let (mut a, mut b) = (0.5 * delay0, 2.0 * delay0);
    let g = (5f64.sqrt() - 1.0) / 2.0;
    for _ in 0..40 {
        let (c, e) = (b - g * (b - a), a + g * (b - a));
        if sse(c) <= sse(e) { b = e } else { a = c }
    }
    0.5 * (a + b)
}

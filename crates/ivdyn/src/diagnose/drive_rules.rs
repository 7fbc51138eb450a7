//! The rules of the real-drive effects that refine or compete with the basic vocabulary
//! (docs/diagnose.md, "Effects of real drives"):
//!
//! * **direction-dependent Coulomb friction** refines Coulomb friction found on a joint
//!   with the column `[qd > 0]` (`fc_pos [qd > 0] - fc_neg [qd < 0]`). On a moving joint it
//!   spans the same columns as Coulomb friction plus a torque offset, so the two readings
//!   are told apart by physics: an offset smaller than the friction level (both `fc_pos`
//!   and `fc_neg` positive) is read as direction-dependent friction, a larger one as an
//!   offset. It loses to plain Coulomb friction when its extra column fails the F test or
//!   the held-out share, i.e. when `fc_pos == fc_neg` within the data's uncertainty.
//! * **smooth Coulomb friction** `fc tanh(qd / vs)` replaces Coulomb friction on a joint
//!   when held-out data prefer it: `vs` on a grid, the one removing most of the held-out
//!   residual; named only when the torque it changes against Coulomb friction's sign has
//!   an RMS of at least `min_effect` noise std (a sharp Coulomb friction fits a tanh with
//!   a tiny `vs` equally well, and changes nothing). Stribeck competes with it on the same
//!   joint (both refine Coulomb friction; the one that explains more is added first and
//!   the other is then not tried there).
//! * **torque ripple**: the harmonic pair `sin(n q), cos(n q)` on a grid of `n`, the one
//!   removing most of the held-out residual.

use super::EffectKind;
use super::JointScore;
use super::dictionary::{C_ONE, C_SIGN, C_SIGN_POS, C_TANH, RIPPLE_N, SMOOTH_VS};
use super::model::{Fit, Model, Param, effect_rms, fit};
use super::score::{Ctx, Scored, not_scored};

/// The fitted value of joint `j`'s parameter in column `col` (0 if absent).
fn theta_at(f: &Fit, j: usize, col: usize) -> f64 {
    f.params.iter().position(|p| p.joint == Some(j) && p.col == col).map_or(0.0, |i| f.theta[i])
}

/// A significant offset on a joint with Coulomb friction (`l`: the model with it) is, on a
/// moving joint, direction-dependent friction when it is smaller than the friction level:
/// rejected there as that look-alike (the asymmetric candidate names it).
pub(super) fn offset_or_asymmetric(ctx: &Ctx, l: &Model, j: usize, sc: &mut JointScore) {
    let f = fit(&l.params(), ctx.gr, &ctx.w, &[0, 1]);
    let (fc, tau0) = (theta_at(&f, j, C_SIGN), theta_at(&f, j, C_ONE));
    if fc > 0.0 && tau0.abs() < fc {
        sc.significant = false;
        sc.rejected_by = Some(format!(
            "look-alike: with Coulomb friction fc {fc:.3} N m, an offset of {tau0:.3} N m is direction-dependent friction (fc_pos {:.3}, fc_neg {:.3} N m)",
            fc + tau0,
            fc - tau0
        ));
    }
}

/// Whether the grid effect `e` can go on joint `j` of `m` (why not, when it cannot).
fn precondition(m: &Model, e: EffectKind, j: usize) -> Option<&'static str> {
    let refined = [EffectKind::Stribeck, EffectKind::SmoothCoulomb, EffectKind::AsymmetricCoulomb];
    match e {
        EffectKind::TorqueRipple if m.has(j, e) => Some("already in the model on this joint"),
        EffectKind::TorqueRipple => None,
        _ if !m.has(j, EffectKind::Coulomb) => Some("a refinement of Coulomb friction already found on the joint"),
        _ if refined.iter().any(|&r| m.has(j, r)) => Some("Coulomb friction on the joint is already refined"),
        EffectKind::AsymmetricCoulomb if m.has(j, EffectKind::TorqueOffset) || m.has(j, EffectKind::JointSpring) => {
            Some("an offset on the joint already spans its column")
        }
        _ => None,
    }
}

/// The grid of the effect's shape (one entry for the asymmetric friction).
fn grid_len(e: EffectKind) -> usize {
    match e {
        EffectKind::SmoothCoulomb => SMOOTH_VS.len(),
        EffectKind::TorqueRipple => RIPPLE_N.len(),
        _ => 1,
    }
}

/// `m` with `e` on joint `j` at grid entry `g`.
fn with_shape(m: &Model, e: EffectKind, j: usize, g: usize) -> Model {
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
        if let Some(why) = precondition(m, e, j) {
            per_joint.push(not_scored(why));
            continue;
        }
        let mut best: Option<(JointScore, Model)> = None;
        for g in 0..grid_len(e) {
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
fn smooth_size(ctx: &Ctx, m: &Model, l: &Model, j: usize, sc: &mut JointScore) {
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
            .statistical_rule(sc, j)
            .or_else(|| Ctx::unphysical(&fl, j, &|p| p.kind == Some(EffectKind::SmoothCoulomb)));
        sc.significant = sc.rejected_by.is_none();
    }
}

/// Direction-dependent friction is friction in both directions: `fc_pos` and `fc_neg`
/// positive (otherwise the column is an offset larger than the friction).
fn asymmetric_sign(ctx: &Ctx, l: &Model, j: usize, sc: &mut JointScore) {
    if !sc.significant {
        return;
    }
    let f = fit(&l.params(), ctx.gr, &ctx.w, &[0, 1]);
    let fc_neg = theta_at(&f, j, C_SIGN);
    let fc_pos = fc_neg + theta_at(&f, j, C_SIGN_POS);
    if fc_pos <= 0.0 || fc_neg <= 0.0 {
        sc.significant = false;
        sc.rejected_by = Some(format!("sign: fc_pos {fc_pos:.4}, fc_neg {fc_neg:.4} N m are not both positive"));
    }
}

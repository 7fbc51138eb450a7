//! Two effects on one joint as one candidate.
//!
//! Where a joint lacks two effects (Coulomb friction and an offset, a spring and viscous
//! friction, ...), each alone removes only its part of the held-out structure and fails the
//! share of rule 2 (`rules`), though together they explain it. So when no single candidate
//! is significant anywhere (the search would stop), pairs of the basic per-joint vocabulary
//! are tried on each joint: a pair is named when it passes every rule on its joint and each
//! member passes every rule given the other (what the backward step asks of it), an
//! inertia-like member also the look-alike rule 5 against the nominal link inertials.

use super::dictionary::C_Q;
use super::model::{Model, Param};
use super::rules::model_error_lookalike;
use super::score::{Ctx, not_scored};
use super::{CandidateScore, EffectKind, JointScore};

/// The effects tried in pairs (the per-joint basic vocabulary).
const KINDS: [EffectKind; 5] =
    [EffectKind::Coulomb, EffectKind::Viscous, EffectKind::Armature, EffectKind::TorqueOffset, EffectKind::JointSpring];

/// The best pair over all joints (largest weighted residual reduction), as a candidate of
/// its first effect on its joint, the model with both, and the second effect.
pub(super) fn best_pair(ctx: &Ctx, m: &Model) -> Option<(CandidateScore, Model, EffectKind)> {
    let mut best: Option<(f64, usize, JointScore, Model, EffectKind, EffectKind)> = None;
    for j in 0..ctx.n {
        for (i, &a) in KINDS.iter().enumerate() {
            for &b in &KINDS[i + 1..] {
                let Some((sc, l)) = score_pair(ctx, m, j, a, b) else { continue };
                let gain = ctx.gain(m, &l);
                if best.as_ref().is_none_or(|x| gain > x.0) {
                    best = Some((gain, j, sc, l, a, b));
                }
            }
        }
    }
    let (score, j, sc, l, a, b) = best?;
    let mut per_joint: Vec<JointScore> = (0..ctx.n).map(|_| not_scored("a pair is scored on one joint")).collect();
    per_joint[j] = sc;
    let reason = format!("with {} on the same joint as one candidate: neither alone passes every rule", b.label());
    let cand = CandidateScore { effect: a, per_joint, joints: vec![j], score, accepted: false, reason };
    Some((cand, l, b))
}

/// Selects joint `j`'s parameters of effect `e` (a spring's position column only: its
/// constant is an offset's).
fn of(j: usize, e: EffectKind) -> impl Fn(&Param) -> bool {
    move |p: &Param| p.joint == Some(j) && p.kind == Some(e) && (e != EffectKind::JointSpring || p.col == C_Q)
}

/// The pair `(a, b)` on joint `j` with its score, when it can go there and passes.
fn score_pair(ctx: &Ctx, m: &Model, j: usize, a: EffectKind, b: EffectKind) -> Option<(JointScore, Model)> {
    use EffectKind::{AsymmetricCoulomb, JointSpring, TorqueOffset};
    // a spring holds an offset's column, direction-dependent friction one too
    let offset_like = |e: EffectKind| matches!(e, TorqueOffset | JointSpring);
    let blocked = |e: EffectKind| match e {
        TorqueOffset => m.has(j, JointSpring) || m.has(j, AsymmetricCoulomb),
        JointSpring => m.has(j, TorqueOffset),
        _ => m.has(j, e),
    };
    if offset_like(a) && offset_like(b) || blocked(a) || blocked(b) {
        return None;
    }
    let l = m.with(Some(j), a).with(Some(j), b);
    let (sa, sb) = (of(j, a), of(j, b));
    let sc = ctx.joint_score(m, &l, j, &|p| sa(p) || sb(p));
    if !sc.significant {
        return None;
    }
    for (x, sel) in [(a, &sa), (b, &sb)] {
        let without = l.without(Some(j), x);
        // a spring's position column is tested beside the constant, as a single spring is
        let base = if x == EffectKind::JointSpring { without.with(Some(j), EffectKind::TorqueOffset) } else { without };
        if !ctx.joint_score(&base, &l, j, sel).significant {
            return None;
        }
        if super::rules::inertia_like(x) && model_error_lookalike(ctx, &base, &l, j, sel).is_some() {
            return None;
        }
    }
    Some((sc, l))
}

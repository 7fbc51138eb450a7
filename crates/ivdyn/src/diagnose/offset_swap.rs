//! An offset beside Coulomb friction read as direction-dependent friction once the search
//! would stop (docs/diagnose.md, "Effects of real drives").
//!
//! On a moving joint Coulomb friction plus an offset spans what direction-dependent friction
//! spans, and an offset smaller than `ASYMMETRY_MAX` of the friction level is read as the
//! latter: the forward step rejects such an offset as its look-alike
//! (`drive_rules::offset_or_asymmetric`) and the pair search prefers the asymmetry at equal
//! gain (`pairs`). An offset named before the joint's Coulomb friction (a member of a pair
//! with viscous friction, say) escapes both, and the search never revisits it. So when
//! nothing else passes, such an offset is replaced by the `[qd > 0]` column of
//! direction-dependent friction where that column passes every rule given Coulomb friction
//! and both levels are positive within the asymmetry bound (`drive_rules::asymmetric_sign`),
//! as `pairs::score_asymmetric` asks of it.

use super::model::{Model, Param};
use super::score::{Ctx, not_scored};
use super::{CandidateScore, EffectKind, JointScore};
use EffectKind::{AsymmetricCoulomb, Coulomb, JointSpring, SmoothCoulomb, Stribeck, TorqueOffset};

/// Joint `j`'s direction-dependent friction in place of its offset (`m` has Coulomb
/// friction of sign shape and an offset there), scored against the model without the
/// offset; `None` where the offset does not read as one or the column fails a rule.
fn in_place_of_offset(ctx: &Ctx, m: &Model, j: usize) -> Option<(JointScore, Model)> {
    let others = [AsymmetricCoulomb, JointSpring, SmoothCoulomb, Stribeck];
    if !(m.has(j, Coulomb) && m.has(j, TorqueOffset)) || others.iter().any(|&e| m.has(j, e)) {
        return None;
    }
    super::drive_rules::offset_reads_as_asymmetric(ctx, m, j)?;
    let base = m.without(Some(j), TorqueOffset);
    let l = base.with(Some(j), AsymmetricCoulomb);
    let mut sc = ctx.joint_score(&base, &l, j, &|p: &Param| p.joint == Some(j) && p.kind == Some(AsymmetricCoulomb));
    super::drive_rules::asymmetric_sign(ctx, &l, j, &mut sc);
    sc.significant.then_some((sc, l))
}

/// The joint whose offset reads best as direction-dependent friction (largest weighted
/// residual reduction of its `[qd > 0]` column), as a candidate of that effect with the model
/// it makes; `None` when no joint has such an offset.
pub(super) fn best_offset_swap(ctx: &Ctx, m: &Model) -> Option<(CandidateScore, Model, EffectKind)> {
    let mut best: Option<(f64, usize, JointScore, Model)> = None;
    for j in 0..ctx.n {
        let Some((sc, l)) = in_place_of_offset(ctx, m, j) else { continue };
        let gain = ctx.gain(&m.without(Some(j), TorqueOffset), &l);
        if best.as_ref().is_none_or(|b| gain > b.0) {
            best = Some((gain, j, sc, l));
        }
    }
    let (score, j, sc, l) = best?;
    let mut per_joint: Vec<JointScore> = (0..ctx.n).map(|_| not_scored("an offset is read on its own joint")).collect();
    per_joint[j] = sc;
    let reason = "in place of the torque offset on the same joint: on a moving joint they span the same torque, and the offset is smaller than the friction level".to_string();
    let cand = CandidateScore { effect: AsymmetricCoulomb, per_joint, joints: vec![j], score, accepted: false, reason };
    Some((cand, l, AsymmetricCoulomb))
}

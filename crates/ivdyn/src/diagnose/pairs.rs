//! Two effects on one joint as one candidate, or three.
//!
//! Where a joint lacks two effects (Coulomb friction and an offset, a spring and viscous
//! friction, ...), each alone removes only its part of the held-out structure and fails the
//! share of rule 2 (`rules`), though together they explain it. So when no single candidate
//! is significant anywhere (the search would stop), pairs of the per-joint vocabulary (with
//! the effects of real drives: load-dependent friction, gain, delay, ripple) are tried on
//! each joint: a pair is named when it passes every rule on its joint and each member
//! passes every rule given the other (what the backward step asks of it) and is above the
//! noise, an inertia-like member also the look-alike rule 5 against the nominal link
//! inertials. Where no pair passes either, three effects on one joint are tried the same way
//! (`best_triple`): a drive's Coulomb and viscous friction and rotor inertia, or a spring
//! beside two frictions, leave each one and each two of them short of the share.
//! Direction-dependent Coulomb friction (Coulomb friction and its `[qd > 0]` column) is
//! tried the same way: it refines Coulomb friction found on a joint, so without this it
//! would never be tried where Coulomb friction alone fails the share. So is smooth (tanh)
//! friction, with the effects of real drives (`score_smooth`), and as a member of a pair
//! beside another effect (not beside another friction shape, nor beside an offset: with a
//! constant a tanh stands for direction-dependent friction), its tanh kept only where it
//! beats the same pair with `sign(qd)` as a refinement must (`smooth_over_sign`): a real
//! arm's joint often lacks smooth friction, viscous friction and a third effect at once, and
//! viscous friction named first takes the tanh's slope.

use super::dictionary::C_Q;
use super::drive_rules::{grid, with_shape};
use super::model::{Model, Param, fit, rss_joint};
use super::rules::model_error_lookalike;
use super::score::{Ctx, not_scored};
use super::{CandidateScore, EffectKind, JointScore};

/// The effects tried in pairs: the per-joint basic vocabulary, then the per-joint effects
/// of real drives (searched only with them; a ripple with its harmonic on its grid).
const KINDS: [EffectKind; 10] = [
    EffectKind::Coulomb,
    EffectKind::Viscous,
    EffectKind::Armature,
    EffectKind::TorqueOffset,
    EffectKind::JointSpring,
    EffectKind::LoadDependent,
    EffectKind::TorqueGain,
    EffectKind::TimeDelay,
    EffectKind::TorqueRipple,
    EffectKind::SmoothCoulomb,
];

/// Smallest RMS (in noise standard deviations of the joint) of the torque each member of a
/// pair adds. Two columns fitted together take up part of the nominal model's own error
/// where one alone would not, so a pair, named only where no single effect passes, names
/// only members above the noise. (At `min_effect`, 0.5, a Coulomb friction and a ripple of
/// 1.0 and 0.56 noise std were named together on a payload-only log of the tuning part.)
const PAIR_MIN_EFFECT: f64 = 1.0;

/// The effects of `KINDS` the search may name (the drives' ones only when it searches them).
fn kinds(ctx: &Ctx) -> Vec<EffectKind> {
    KINDS.into_iter().filter(|e| ctx.drives || !e.needs_drives()).collect()
}

/// The best pair over all joints (largest weighted residual reduction), as a candidate of
/// its first effect on its joint, the model with both, and the second effect.
pub(super) fn best_pair(ctx: &Ctx, m: &Model) -> Option<(CandidateScore, Model, EffectKind)> {
    // every joint's candidates scored on the machine's cores (`par`), then chosen in one
    // order: the pairs joint by joint, then direction-dependent friction, then smooth friction
    let joints: Vec<usize> = (0..ctx.n).collect();
    let scored = crate::par::map(ctx.threads, &joints, |&j| joint_candidates(ctx, m, j));
    let mut best: Option<(f64, usize, JointScore, Model, EffectKind, EffectKind)> = None;
    for (j, (pairs, _, _)) in scored.iter().enumerate() {
        for (gain, sc, l, a, b) in pairs {
            if best.as_ref().is_none_or(|x| *gain > x.0) {
                best = Some((*gain, j, sc.clone(), l.clone(), *a, *b));
            }
        }
    }
    for (j, (_, asym, _)) in scored.iter().enumerate() {
        let Some((gain, sc, l)) = asym else { continue };
        // on a moving joint it spans what Coulomb friction + offset spans: the same gain but
        // for rounding, and read as direction-dependent friction (one effect, not two), as
        // the forward step reads an offset within `ASYMMETRY_MAX` of the friction level
        // (`drive_rules::offset_or_asymmetric`)
        if best.as_ref().is_none_or(|x| *gain >= x.0 * (1.0 - 1e-9)) {
            best = Some((*gain, j, sc.clone(), l.clone(), EffectKind::Coulomb, EffectKind::AsymmetricCoulomb));
        }
    }
    for (j, (_, _, smooth)) in scored.iter().enumerate() {
        let Some((gain, sc, l)) = smooth else { continue };
        if best.as_ref().is_none_or(|x| *gain > x.0) {
            best = Some((*gain, j, sc.clone(), l.clone(), EffectKind::Coulomb, EffectKind::SmoothCoulomb));
        }
    }
    let (score, j, sc, l, a, b) = best?;
    let mut per_joint: Vec<JointScore> = (0..ctx.n).map(|_| not_scored("a pair is scored on one joint")).collect();
    per_joint[j] = sc;
    let reason = format!("with {} on the same joint as one candidate: neither alone passes every rule", b.label());
    let cand = CandidateScore { effect: a, per_joint, joints: vec![j], score, accepted: false, reason };
    Some((cand, l, b))
}

/// The best three effects on one joint as one candidate (largest weighted residual
/// reduction), where no single effect and no pair passes: a drive's Coulomb and viscous
/// friction and its rotor inertia, or a spring beside two frictions, each remove only a
/// part of the held-out structure, and so does any two of them. As a candidate of its first
/// effect on its joint, the model with all three, and the second effect.
pub(super) fn best_triple(ctx: &Ctx, m: &Model) -> Option<(CandidateScore, Model, EffectKind)> {
    let kinds = kinds(ctx);
    let joints = joints_with_room(ctx, m, 3);
    let scored = crate::par::map(ctx.threads, &joints, |&j| {
        let mut best: Option<(f64, JointScore, Model, [EffectKind; 3])> = None;
        for (i, &a) in kinds.iter().enumerate() {
            for (k, &b) in kinds.iter().enumerate().skip(i + 1) {
                for &c in &kinds[k + 1..] {
                    let Some((sc, l)) = score_group(ctx, m, j, &[a, b, c]) else { continue };
                    let gain = ctx.gain(m, &l);
                    if best.as_ref().is_none_or(|x| gain > x.0) {
                        best = Some((gain, sc, l, [a, b, c]));
                    }
                }
            }
        }
        best
    });
    let (j, (score, sc, l, [a, b, c])) =
        joints.iter().zip(scored).filter_map(|(&j, x)| x.map(|x| (j, x))).max_by(|x, y| x.1.0.total_cmp(&y.1.0))?;
    let mut per_joint: Vec<JointScore> = (0..ctx.n).map(|_| not_scored("a triple is scored on one joint")).collect();
    per_joint[j] = sc;
    let reason = format!(
        "with {} and {} on the same joint as one candidate: no one or two of them pass every rule",
        b.label(),
        c.label()
    );
    let cand = CandidateScore { effect: a, per_joint, joints: vec![j], score, accepted: false, reason };
    Some((cand, l, b))
}

/// The joints whose residual on `m` leaves room for `members` effects of at least
/// `PAIR_MIN_EFFECT` noise std each beside the noise: mean square above `1 + members`
/// times the noise variance. Only a bound of thumb (the members' torques may partly
/// cancel), it spares the search most joints: where triples were named on the random arms
/// (docs/diagnose.md) the joint's mean square was 40-220 noise variances, while most other
/// joints' are 1-3.
fn joints_with_room(ctx: &Ctx, m: &Model, members: usize) -> Vec<usize> {
    let f = fit(&m.params(), ctx.gr, &ctx.w, &[0, 1]);
    (0..ctx.n)
        .filter(|&j| {
            let rows = (ctx.gr.rows[j][0] + ctx.gr.rows[j][1]).max(1) as f64;
            let room = (1.0 + members as f64 * PAIR_MIN_EFFECT * PAIR_MIN_EFFECT) * ctx.sigma[j] * ctx.sigma[j];
            rss_joint(&f, ctx.gr, j, &[0, 1]) / rows > room
        })
        .collect()
}

/// A scored candidate with its weighted residual reduction (`Ctx::gain`) and model.
type Gained = (f64, JointScore, Model);

/// A passing pair: its gain, score and model, and its two effects.
type GainedPair = (f64, JointScore, Model, EffectKind, EffectKind);

/// Joint `j`'s passing pairs (each with its two effects), its direction-dependent and its
/// smooth friction candidates, when they pass.
fn joint_candidates(ctx: &Ctx, m: &Model, j: usize) -> (Vec<GainedPair>, Option<Gained>, Option<Gained>) {
    let kinds = kinds(ctx);
    let mut pairs = vec![];
    for (i, &a) in kinds.iter().enumerate() {
        for &b in &kinds[i + 1..] {
            if let Some((sc, l)) = score_pair(ctx, m, j, a, b) {
                pairs.push((ctx.gain(m, &l), sc, l, a, b));
            }
        }
    }
    let gained = |x: Option<(JointScore, Model)>| x.map(|(sc, l)| (ctx.gain(m, &l), sc, l));
    (pairs, gained(score_asymmetric(ctx, m, j)), gained(score_smooth(ctx, m, j)))
}

/// Selects joint `j`'s parameters of effect `e` (a spring's position column only: its
/// constant is an offset's; smooth friction's tanh, held as Coulomb friction's shape).
fn of(j: usize, e: EffectKind) -> impl Fn(&Param) -> bool {
    use EffectKind::{Coulomb, JointSpring, SmoothCoulomb};
    move |p: &Param| {
        p.joint == Some(j)
            && (p.kind == Some(e) || e == SmoothCoulomb && p.kind == Some(Coulomb))
            && (e != JointSpring || p.col == C_Q)
    }
}

/// `m` with `e` on joint `j` at grid entry `g`: smooth friction as Coulomb friction with its
/// `sign(qd)` replaced by the tanh (as `score_smooth` builds it).
fn add(m: &Model, e: EffectKind, j: usize, g: usize) -> Model {
    match e {
        EffectKind::SmoothCoulomb => with_shape(&m.with(Some(j), EffectKind::Coulomb), e, j, g),
        _ => with_shape(m, e, j, g),
    }
}

/// `m` without `e` on joint `j` (smooth friction: its Coulomb friction too).
fn remove(m: &Model, e: EffectKind, j: usize) -> Model {
    match e {
        EffectKind::SmoothCoulomb => m.without(Some(j), EffectKind::Coulomb).without(Some(j), e),
        _ => m.without(Some(j), e),
    }
}

/// Friction shapes: one per joint, so a pair holds at most one.
fn friction_shape(e: EffectKind) -> bool {
    use EffectKind::{AsymmetricCoulomb, Coulomb, LoadDependent, SmoothCoulomb, Stribeck};
    matches!(e, Coulomb | AsymmetricCoulomb | SmoothCoulomb | Stribeck | LoadDependent)
}

/// The pair `(a, b)` on joint `j` with its score, when it can go there and passes.
fn score_pair(ctx: &Ctx, m: &Model, j: usize, a: EffectKind, b: EffectKind) -> Option<(JointScore, Model)> {
    score_group(ctx, m, j, &[a, b])
}

/// The effects `group` together on joint `j` with their score, when they can go there and
/// pass: the group every rule on the joint, each member every rule given the others and
/// above the noise (`PAIR_MIN_EFFECT`), an inertia-like member also rule 5.
fn score_group(ctx: &Ctx, m: &Model, j: usize, group: &[EffectKind]) -> Option<(JointScore, Model)> {
    use EffectKind::{AsymmetricCoulomb, Coulomb, JointSpring, SmoothCoulomb, Stribeck, TorqueGain, TorqueOffset};
    // a spring holds an offset's column, direction-dependent friction one too; a gain on the
    // terminal joint is a scale of the terminal link (as `rules::score_joint_effect` says);
    // smooth friction only where the joint has no friction of a shape yet (`score_smooth`)
    let offset_like = |e: &&EffectKind| matches!(e, TorqueOffset | JointSpring);
    let blocked = |e: EffectKind| match e {
        TorqueOffset => m.has(j, JointSpring) || m.has(j, AsymmetricCoulomb),
        TorqueGain if j + 1 == ctx.n => true,
        SmoothCoulomb => [Coulomb, AsymmetricCoulomb, Stribeck, SmoothCoulomb].iter().any(|&x| m.has(j, x)),
        _ => m.has(j, e),
    };
    // with an offset, smooth friction would stand for direction-dependent friction (on a
    // moving joint its level plus a constant), which `score_asymmetric` names
    let smooth = group.contains(&SmoothCoulomb);
    let shapes = group.iter().filter(|&&e| friction_shape(e)).count();
    let smooth_blocked = smooth && (shapes > 1 || group.contains(&TorqueOffset));
    if group.iter().filter(offset_like).count() > 1 || group.iter().any(|&e| blocked(e)) || smooth_blocked {
        return None;
    }
    // a spring replaces an offset found on the joint (its constant is the offset's column),
    // as the single spring candidate does
    let start = if group.contains(&JointSpring) { m.without(Some(j), TorqueOffset) } else { m.clone() };
    let sel = |p: &Param| group.iter().any(|&e| of(j, e)(p));
    // a ripple's harmonic on its grid, the one removing most of the held-out residual (as
    // `drive_rules::score_grid_effect` chooses it alone); one entry for the other effects
    let mut best: Option<(JointScore, Model)> = None;
    for entries in grid_product(ctx, group, j) {
        let l = group.iter().zip(&entries).fold(start.clone(), |l, (&e, &g)| add(&l, e, j, g));
        let sc = ctx.joint_score(m, &l, j, &sel);
        if best.as_ref().is_none_or(|(x, _)| sc.heldout_gain > x.heldout_gain) {
            best = Some((sc, l));
        }
    }
    let (sc, l) = best?;
    if !sc.significant {
        return None;
    }
    for &x in group {
        let without = remove(&l, x, j);
        // a spring's position column is tested beside the constant, as a single spring is
        let base = if x == JointSpring { without.with(Some(j), TorqueOffset) } else { without };
        let member = ctx.joint_score(&base, &l, j, &of(j, x));
        if !member.significant || member.effect_rms < PAIR_MIN_EFFECT * ctx.sigma[j] {
            return None;
        }
        if super::rules::inertia_like(x) && model_error_lookalike(ctx, &base, &l, j, x, &of(j, x)).is_some() {
            return None;
        }
    }
    if smooth && !smooth_over_sign(ctx, &l, j) {
        return None;
    }
    Some((sc, l))
}

/// Every combination of the grid entries of `group`'s effects on joint `j`.
fn grid_product(ctx: &Ctx, group: &[EffectKind], j: usize) -> Vec<Vec<usize>> {
    group.iter().fold(vec![vec![]], |acc, &e| {
        let g = grid(ctx, e, j);
        acc.iter().flat_map(|head| g.iter().map(move |&x| [head.as_slice(), &[x]].concat())).collect()
    })
}

/// The tanh of a pair's smooth friction is what the data ask for, not a sharp Coulomb
/// friction's look-alike: against the same pair with `sign(qd)` it passes the rules of a
/// refinement and changes the torque by the size rule (`drive_rules::smooth_size`), and the
/// pair with direction-dependent friction in its place leaves more of the held-out residual
/// (a tanh and its partner otherwise stand for levels that differ with the direction).
fn smooth_over_sign(ctx: &Ctx, l: &Model, j: usize) -> bool {
    use EffectKind::{AsymmetricCoulomb, Coulomb, SmoothCoulomb};
    let sign = l.without(Some(j), SmoothCoulomb).with(Some(j), Coulomb);
    let mut sc = ctx.joint_score(&sign, l, j, &|p: &Param| p.joint == Some(j) && p.kind == Some(SmoothCoulomb));
    super::drive_rules::smooth_size(ctx, &sign, l, j, &mut sc);
    sc.significant && ctx.heldout_rss(l) < ctx.heldout_rss(&sign.with(Some(j), AsymmetricCoulomb))
}

/// Direction-dependent Coulomb friction on joint `j` as one candidate: Coulomb friction
/// with its `[qd > 0]` column. On a joint that never stops it spans what Coulomb friction
/// and an offset span; the offset is a look-alike of the nominal model's error (rule 5),
/// while a friction level that differs with the direction is not, so this pair is named where
/// the other fails that rule, as `drive_rules::offset_or_asymmetric` reads an offset smaller
/// than the friction level in the forward step. It must pass every rule on the joint, its
/// `[qd > 0]` column every rule given Coulomb friction, and both levels be positive and
/// within the asymmetry bound (`drive_rules::asymmetric_sign`).
fn score_asymmetric(ctx: &Ctx, m: &Model, j: usize) -> Option<(JointScore, Model)> {
    use EffectKind::{AsymmetricCoulomb, Coulomb, JointSpring, SmoothCoulomb, Stribeck, TorqueOffset};
    if [Coulomb, AsymmetricCoulomb, TorqueOffset, JointSpring, Stribeck, SmoothCoulomb].iter().any(|&e| m.has(j, e)) {
        return None;
    }
    let with_coulomb = m.with(Some(j), Coulomb);
    let l = with_coulomb.with(Some(j), AsymmetricCoulomb);
    let friction = |p: &Param| p.joint == Some(j) && matches!(p.kind, Some(Coulomb | AsymmetricCoulomb));
    let mut sc = ctx.joint_score(m, &l, j, &friction);
    let asym = |p: &Param| p.joint == Some(j) && p.kind == Some(AsymmetricCoulomb);
    if !sc.significant || !ctx.joint_score(&with_coulomb, &l, j, &asym).significant {
        return None;
    }
    super::drive_rules::asymmetric_sign(ctx, &l, j, &mut sc);
    sc.significant.then_some((sc, l))
}

/// Smooth (sigmoid) Coulomb friction on joint `j` as one candidate: Coulomb friction with
/// its `sign(qd)` column replaced by `tanh(qd / vs)`, `vs` on the grid by the held-out share.
/// It refines Coulomb friction found on a joint, so where a smooth friction leaves Coulomb
/// friction's sharp step short of the share of rule 2 (it overshoots at low speed), it would
/// never be tried. Searched with the effects of real drives only; it must pass every rule on
/// the joint and change the torque against Coulomb friction's sign by the size rule
/// (`drive_rules::smooth_size`). Not on a joint with friction of another shape already
/// (beside true load-dependent friction on the UR5 drive fixture's elbow, the tanh took what
/// the load column's sharp step leaves near zero speed and was named too).
fn score_smooth(ctx: &Ctx, m: &Model, j: usize) -> Option<(JointScore, Model)> {
    use super::drive_rules::smooth_size;
    use EffectKind::{AsymmetricCoulomb, Coulomb, LoadDependent, SmoothCoulomb, Stribeck};
    let friction_there = [Coulomb, AsymmetricCoulomb, Stribeck, SmoothCoulomb, LoadDependent];
    if !ctx.drives || friction_there.iter().any(|&e| m.has(j, e)) {
        return None;
    }
    let with_coulomb = m.with(Some(j), Coulomb);
    let friction = |p: &Param| p.joint == Some(j) && matches!(p.kind, Some(Coulomb | SmoothCoulomb));
    let mut best: Option<(JointScore, Model)> = None;
    for g in grid(ctx, SmoothCoulomb, j) {
        let l = with_shape(&with_coulomb, SmoothCoulomb, j, g);
        let sc = ctx.joint_score(m, &l, j, &friction);
        if best.as_ref().is_none_or(|(b, _)| sc.heldout_gain > b.heldout_gain) {
            best = Some((sc, l));
        }
    }
    let (mut sc, l) = best?;
    if !sc.significant {
        return None;
    }
    smooth_size(ctx, &with_coulomb, &l, j, &mut sc);
    sc.significant.then_some((sc, l))
}

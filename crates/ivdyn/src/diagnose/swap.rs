//! Friction's shape on a joint decided on held-out data (issue 15, item 2: "Stribeck vs
//! Coulomb decided per joint on held-out data"; here the shapes that are not nested).
//!
//! Coulomb friction `fc sign(qd)`, smooth friction `fc tanh(qd / vs)` and load-dependent
//! friction `fl |tau_load| sign(qd)` are three shapes of one physical thing. Smooth friction
//! refines Coulomb friction (nested: `drive_rules` decides it), but load-dependent friction
//! competes with both: the forward step adds whichever explains most at that step, and once
//! a joint has one of them the other is not tried there (beside a true load-dependent
//! friction a tanh takes what the load column's step leaves near zero speed, `pairs`). So
//! when the search would stop, each joint whose friction is one of these shapes alone is
//! tried with the other in its place: the best such swap is made when the other shape
//! passes every rule on the joint against the model without friction there and leaves less
//! held-out residual over all joints (the re-fit couples them) than the shape it replaces.

use super::drive_rules::{grid, smooth_size, with_shape};
use super::model::{Model, Param};
use super::score::{Ctx, not_scored};
use super::{CandidateScore, EffectKind, JointScore};
use EffectKind::{AsymmetricCoulomb, Coulomb, LoadDependent, SmoothCoulomb, Stribeck};

/// A friction shape of a joint.
#[derive(Debug, Clone, Copy, PartialEq)]
enum Shape {
    /// Coulomb friction.
    Sign,
    /// Coulomb friction with its sign replaced by a tanh (smooth friction).
    Smooth,
    /// Load-dependent friction.
    Load,
}

impl Shape {
    /// The effect a step adding this shape names first (smooth friction comes with the
    /// Coulomb friction it refines, as `pairs` adds it).
    fn effect(self) -> EffectKind {
        match self {
            Shape::Sign | Shape::Smooth => Coulomb,
            Shape::Load => LoadDependent,
        }
    }

    /// The shapes tried in place of this one.
    fn others(self) -> &'static [Shape] {
        match self {
            Shape::Sign | Shape::Smooth => &[Shape::Load],
            Shape::Load => &[Shape::Sign, Shape::Smooth],
        }
    }
}

/// Joint `j`'s friction shape in `m`, when it is one of `Shape` alone.
fn shape_of(m: &Model, j: usize) -> Option<Shape> {
    if m.has(j, AsymmetricCoulomb) || m.has(j, Stribeck) {
        return None;
    }
    match (m.has(j, Coulomb), m.has(j, SmoothCoulomb), m.has(j, LoadDependent)) {
        (true, false, false) => Some(Shape::Sign),
        (true, true, false) => Some(Shape::Smooth),
        (false, false, true) => Some(Shape::Load),
        _ => None,
    }
}

/// Selects joint `j`'s friction parameters of the compared shapes.
fn friction(j: usize) -> impl Fn(&Param) -> bool {
    move |p: &Param| p.joint == Some(j) && matches!(p.kind, Some(Coulomb | SmoothCoulomb | LoadDependent))
}

/// `base` (no friction on joint `j`) with shape `s` there, scored on `j` against `base`:
/// smooth friction with the `vs` of its grid removing most of the held-out residual, and its
/// size rule (`drive_rules::smooth_size`).
fn score_shape(ctx: &Ctx, base: &Model, j: usize, s: Shape) -> (JointScore, Model) {
    let with_coulomb = base.with(Some(j), Coulomb);
    match s {
        Shape::Sign => (ctx.joint_score(base, &with_coulomb, j, &friction(j)), with_coulomb),
        Shape::Load => {
            let l = base.with(Some(j), LoadDependent);
            (ctx.joint_score(base, &l, j, &friction(j)), l)
        }
        Shape::Smooth => {
            let mut best: Option<(JointScore, Model)> = None;
            for g in grid(ctx, SmoothCoulomb, j) {
                let l = with_shape(&with_coulomb, SmoothCoulomb, j, g);
                let sc = ctx.joint_score(base, &l, j, &friction(j));
                if best.as_ref().is_none_or(|(b, _)| sc.heldout_gain > b.heldout_gain) {
                    best = Some((sc, l));
                }
            }
            let (mut sc, l) = best.expect("grid not empty");
            if sc.significant {
                smooth_size(ctx, &with_coulomb, &l, j, &mut sc);
            }
            (sc, l)
        }
    }
}

/// The best swap of a friction shape (module docs) in `m`, as a candidate of the new shape's
/// effect on its joint, with the model it makes and the effect it brings beside (smooth
/// friction beside its Coulomb friction; else the effect itself); `None` when none passes.
pub(super) fn best_swap(ctx: &Ctx, m: &Model) -> Option<(CandidateScore, Model, EffectKind)> {
    if !ctx.drives {
        return None;
    }
    // each joint's alternatives scored on the machine's cores (`par`); the held-out residual
    // over all joints only for those that pass on their joint
    let joints: Vec<usize> = (0..ctx.n).filter(|&j| shape_of(m, j).is_some()).collect();
    let passing = crate::par::map(ctx.threads, &joints, |&j| {
        let now = shape_of(m, j).expect("filtered");
        let base = [Coulomb, SmoothCoulomb, LoadDependent].iter().fold(m.clone(), |x, &e| x.without(Some(j), e));
        let scored = now.others().iter().map(|&s| (s, score_shape(ctx, &base, j, s)));
        scored.filter(|(_, (sc, _))| sc.significant).map(|(s, (sc, l))| (j, now, s, sc, l)).collect::<Vec<_>>()
    });
    let passing: Vec<_> = passing.into_iter().flatten().collect();
    if passing.is_empty() {
        return None;
    }
    let h = ctx.heldout_rss(m);
    let mut best: Option<(f64, usize, Shape, Shape, JointScore, Model)> = None;
    for (j, now, s, sc, l) in passing {
        let gain = h - ctx.heldout_rss(&l);
        if gain > 0.0 && best.as_ref().is_none_or(|b| gain > b.0) {
            best = Some((gain, j, now, s, sc, l));
        }
    }
    let (score, j, now, s, sc, l) = best?;
    let mut per_joint: Vec<JointScore> =
        (0..ctx.n).map(|_| not_scored("a friction shape is scored on its own joint")).collect();
    per_joint[j] = sc;
    let reason = format!(
        "in place of {} on the same joint: it leaves less held-out residual (noise-weighted, all joints: {:.4e} less) and passes every rule there",
        label(now),
        score
    );
    let cand = CandidateScore { effect: s.effect(), per_joint, joints: vec![j], score, accepted: false, reason };
    let beside = if s == Shape::Smooth { SmoothCoulomb } else { s.effect() };
    Some((cand, l, beside))
}

/// The shape in words.
fn label(s: Shape) -> &'static str {
    match s {
        Shape::Sign => "Coulomb friction",
        Shape::Smooth => "smooth Coulomb friction",
        Shape::Load => "load-dependent friction",
    }
}

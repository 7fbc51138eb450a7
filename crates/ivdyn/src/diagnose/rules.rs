//! The candidate effects scored against the current model, and the rules for effects that
//! look alike (the per-joint score of rules 1-4 is [`super::score`]'s).
//!
//! A candidate (effect, joint) is *significant* when all of these hold (docs/diagnose.md):
//! 1. an F test of its columns (nested models, joint's rows, all data) rejects "no
//!    effect" at `alpha`, with the sample count divided by the residual's integrated
//!    autocorrelation time, since real residuals are not white;
//! 2. on held-out data (two-fold cross-validation over interleaved blocks of the log) it
//!    removes at least `min_share` of the residual that is above the noise and that the
//!    model with every candidate in can explain: a missing effect explains nearly all
//!    the structure it leaves on its joint, a look-alike only part of it;
//! 3. it matters: the torque it adds has an RMS of at least `min_effect` times the
//!    joint's noise level (estimated from differences two samples apart of the residual
//!    of a model with every candidate in, which slow structure barely moves; on a
//!    resampled log at least the noise on its own samples, `Signals::sample_noise`);
//! 4. its parameters have their physical sign, and an armature or payload is larger than
//!    the uncertainty of the nominal (CAD) inertials;
//! 5. inertia-like effects (payload, armature, offset, spring, gain, ripple) are not imitated
//!    as well by per-link scale errors of at most 50 % of the nominal inertials (CAD's range)
//!    nor by the terminal link's own CAD error, which the nominal re-fit leaves out.
//!
//! Look-alikes: viscous vs armature vs payload compete on how much they explain (their
//! columns are `qd`, `qdd` and rigid-body terms, which a moving log separates); Stribeck
//! is only tried as a refinement of Coulomb friction already found on a joint and needs a
//! positive `fs` (static friction above Coulomb); a joint spring contains an offset, so a
//! spring is named only when its position column is significant beyond the constant,
//! otherwise an offset.

use super::dictionary::{C_Q, C_SIGN, C_STUCK, STRIBECK_VS};
use super::drive_rules::NO_COULOMB_TO_REFINE;
use super::model::{Model, Param, fit};
use super::score::{CAD_ERROR_MAX, CAD_TERMINAL_MARGIN, Ctx, Scored, not_scored};
use super::{CandidateScore, EffectKind, JointScore};

/// The effects a wrong nominal link mass or inertia can imitate (a torque gain scales the
/// joint's rigid-body torque as a link-mass error partly does; gravity is periodic in `q`, as
/// a ripple is).
pub(super) fn inertia_like(e: EffectKind) -> bool {
    matches!(
        e,
        EffectKind::Payload
            | EffectKind::Armature
            | EffectKind::TorqueOffset
            | EffectKind::JointSpring
            | EffectKind::TorqueGain
            | EffectKind::TorqueRipple
    )
}

/// Look-alike check against the nominal model's own error, on joint `j`: what imitates the
/// candidate as well (a phrase for the rule's message), or `None`.
/// * Per-link scales of the nominal inertials, each within `CAD_ERROR_MAX`: if they explain
///   the residual and the candidate is no longer significant once they are free.
/// * The terminal link's CAD error: the re-fit leaves that link out (a change there is what
///   a payload is), and without the re-fit no link is re-fitted, so its error stays in the
///   residual either way (the per-link scales hold it only roughly: its mass, COM and
///   inertia are off independently). It imitates the candidate if a change of its 10
///   inertial parameters making less torque than `CAD_ERROR_MAX` of its nominal torque on
///   every joint (what a link-scale error of that size makes) leaves the candidate no
///   longer significant, and removes at least as much of the held-out residual of all
///   joints as the candidate does; on the terminal joint that change is fitted to the
///   joint's own row and may make up to `CAD_TERMINAL_MARGIN`, the payload's margin.
pub(super) fn model_error_lookalike(
    ctx: &Ctx,
    m: &Model,
    larger: &Model,
    j: usize,
    e: EffectKind,
    added: &dyn Fn(&Param) -> bool,
) -> Option<String> {
    link_scale_lookalike(ctx, m, larger, j, added)
        .map(|s| format!("the nominal link inertials off by up to {:.0} %", 100.0 * s))
        .or_else(|| terminal_error_lookalike(ctx, m, larger, j, e, added))
}

/// Per-link scales within `CAD_ERROR_MAX` imitate the candidate: the largest scale.
fn link_scale_lookalike(ctx: &Ctx, m: &Model, larger: &Model, j: usize, added: &dyn Fn(&Param) -> bool) -> Option<f64> {
    let mut base = m.clone();
    base.link_scale = true;
    let mut l = larger.clone();
    l.link_scale = true;
    let fb = fit(&base.params(), ctx.gr, &ctx.w, &[0, 1]);
    let smax =
        fb.params.iter().zip(&fb.theta).filter(|(p, _)| p.kind.is_none()).map(|(_, v)| v.abs()).fold(0.0, f64::max);
    if smax > CAD_ERROR_MAX {
        return None;
    }
    if ctx.joint_score(&base, &l, j, added).significant { None } else { Some(smax) }
}

/// A terminal-link change within the CAD margin imitates the candidate (never asked of the
/// payload itself): the phrase, with that change's size.
fn terminal_error_lookalike(
    ctx: &Ctx,
    m: &Model,
    larger: &Model,
    j: usize,
    e: EffectKind,
    added: &dyn Fn(&Param) -> bool,
) -> Option<String> {
    if m.payload || larger.payload {
        return None;
    }
    // on the terminal joint, whose torque is the terminal link's alone, that link's
    // parameters on its row alone (the other rows carry the other links' errors too)
    let terminal = j + 1 == ctx.n;
    let with_terminal = |x: &Model| {
        let mut x = x.clone();
        if terminal {
            x.terminal_row = Some(j)
        } else {
            x.payload = true
        }
        x
    };
    let (base, l) = (with_terminal(m), with_terminal(larger));
    let fb = fit(&base.params(), ctx.gr, &ctx.w, &[0, 1]);
    let rows = if terminal { j..j + 1 } else { 0..ctx.n };
    let share = rows.map(|i| ctx.terminal_share(&fb, i)).fold(0.0, f64::max);
    // on its own row the terminal link's CAD error is bounded as the payload's is (mass, COM
    // and inertia each off); on all rows at once, as a link scale (125 % there took true
    // armatures on the CAD set, docs/diagnose.md)
    // and a ripple on any row as on the terminal one: a harmonic of one joint's angle
    // (`RIPPLE_N`, 4 and more per turn) is no torque a link's inertials make, so where that
    // link's change takes the ripple's significance away the ripple was reading its error
    // (two effect-free logs of the wide-motion random set named one on the joint before the
    // terminal one, where the change needed 93 % of the link's torque)
    let margin = if terminal || e == EffectKind::TorqueRipple { CAD_TERMINAL_MARGIN } else { CAD_ERROR_MAX };
    // off the terminal joint that change is fitted to every row, which it must all fit: it
    // imitates the candidate only if it removes as much of the held-out residual of all
    // joints as the candidate does (a gain on joint 1 it takes from that row alone, at
    // the other rows' cost, and the final model holds no such change)
    if share >= margin
        || ctx.joint_score(&base, &l, j, added).significant
        || !terminal && ctx.heldout_rss(&base) > ctx.heldout_rss(larger)
    {
        return None;
    }
    Some(format!(
        "the terminal link's own CAD error (a change of its inertials making at most {:.0} % of its nominal torque)",
        100.0 * share
    ))
}

/// The model with effect `e` added where it can go, for scoring on joint `j`.
fn propose(m: &Model, e: EffectKind, j: usize) -> Option<Model> {
    match e {
        EffectKind::Payload => None,
        EffectKind::Stribeck => None, // handled separately (needs Coulomb and a vs)
        // refinements of Coulomb friction and the ripple's period grid: scored separately
        EffectKind::SmoothCoulomb | EffectKind::AsymmetricCoulomb | EffectKind::TorqueRipple => None,
        // an offset beside direction-dependent friction is the same column
        EffectKind::TorqueOffset if m.has(j, EffectKind::JointSpring) || m.has(j, EffectKind::AsymmetricCoulomb) => {
            None
        }
        _ if m.has(j, e) => None,
        _ => Some(m.with(Some(j), e)),
    }
}

/// Scores every candidate against the current model.
/// (Each effect is scored independently of the others: on the machine's cores, `par`.)
pub(super) fn score_candidates(ctx: &Ctx, m: &Model) -> Vec<(CandidateScore, Model)> {
    let effects: Vec<EffectKind> = EffectKind::ALL
        .into_iter()
        .filter(|e| ctx.drives || !e.needs_drives())
        .filter(|&e| !(e == EffectKind::Payload && m.payload))
        .collect();
    crate::par::map(ctx.threads, &effects, |&e| score_effect(ctx, m, e))
}

/// The candidate `e` scored against `m`, with the model it makes.
fn score_effect(ctx: &Ctx, m: &Model, e: EffectKind) -> (CandidateScore, Model) {
    let (mut per_joint, mut larger, mut lookalike) = match e {
        EffectKind::Payload => score_payload(ctx, m),
        EffectKind::Stribeck => score_stribeck(ctx, m),
        EffectKind::SmoothCoulomb | EffectKind::AsymmetricCoulomb | EffectKind::TorqueRipple => {
            super::drive_rules::score_grid_effect(ctx, m, e)
        }
        _ => score_joint_effect(ctx, m, e),
    };
    if inertia_like(e) && e != EffectKind::Payload {
        lookalike = reject_link_scale_lookalikes(ctx, m, e, &mut per_joint, &mut larger);
    }
    let joints: Vec<usize> = (0..ctx.n).filter(|&j| per_joint[j].significant).collect();
    let score = if joints.is_empty() { 0.0 } else { ctx.gain(m, &larger) };
    let reason = lookalike_reason(&lookalike);
    (CandidateScore { effect: e, per_joint, joints, score, accepted: false, reason }, larger)
}

/// A payload acts on every joint at once: one model, scored joint by joint, each
/// significant joint checked against link-scale errors right away.
fn score_payload(ctx: &Ctx, m: &Model) -> Scored {
    let mut per_joint = vec![];
    let mut lookalike = vec![];
    let l = m.with(None, EffectKind::Payload);
    let is_payload = |p: &Param| p.kind == Some(EffectKind::Payload);
    for j in 0..ctx.n {
        let mut sc = ctx.joint_score(m, &l, j, &is_payload);
        if sc.significant
            && let Some(s) = link_scale_lookalike(ctx, m, &l, j, &is_payload)
        {
            let why = format!("the nominal link inertials off by up to {:.0} %", 100.0 * s);
            reject_as_lookalike(&mut sc, &why);
            lookalike.push((j, why));
        }
        per_joint.push(sc);
    }
    let larger = if per_joint.iter().any(|s| s.significant) { l } else { m.clone() };
    (per_joint, larger, lookalike)
}

/// Stribeck friction refines Coulomb friction already found on a joint (module docs).
fn score_stribeck(ctx: &Ctx, m: &Model) -> Scored {
    let mut per_joint = vec![];
    let mut larger = m.clone();
    for j in 0..ctx.n {
        let refined = [EffectKind::Stribeck, EffectKind::SmoothCoulomb, EffectKind::AsymmetricCoulomb];
        if !m.has(j, EffectKind::Coulomb) {
            per_joint.push(not_scored(NO_COULOMB_TO_REFINE));
            continue;
        }
        if refined.iter().any(|&r| m.has(j, r)) {
            per_joint.push(not_scored("Coulomb friction on the joint is already refined"));
            continue;
        }
        let (sc, l) = best_stribeck(ctx, m, j);
        if sc.significant {
            larger.per_joint[j] = l.per_joint[j].clone();
            larger.stribeck_vs[j] = l.stribeck_vs[j];
        }
        per_joint.push(sc);
    }
    (per_joint, larger, vec![])
}

/// Smallest Stribeck rise `fs` named, as a share of the joint's Coulomb level: below it is
/// what Coulomb friction's own transition at a reversal leaves once the velocity is
/// differentiated and filtered (random 5-12 s tuning part, MuJoCo's Coulomb friction: rises
/// fitted up to 8.4 % of fc, one passing every other rule at 7.8 %; true Stribeck rises of
/// the Stribeck set 56-98 %; real drives' static friction is 10-50 % above Coulomb's).
const STRIBECK_MIN_RISE: f64 = 0.15;

/// The Stribeck shape on joint `j` with the largest F on the `vs` grid; significant only
/// with `fs > 0` (static friction above the Coulomb level).
fn best_stribeck(ctx: &Ctx, m: &Model, j: usize) -> (JointScore, Model) {
    let mut best: Option<(JointScore, Model)> = None;
    for g in 0..STRIBECK_VS.len() {
        let mut l = m.with(Some(j), EffectKind::Stribeck);
        l.stribeck_vs[j] = g;
        let f = fit(&l.params(), ctx.gr, &ctx.w, &[0, 1]);
        let fs = f
            .params
            .iter()
            .position(|p| p.kind == Some(EffectKind::Stribeck) && p.joint == Some(j))
            .map(|i| f.theta[i]);
        // against Coulomb friction with the stick column (`Model::stick`): the shape alone
        let mut stick = m.clone();
        stick.stick[j] = true;
        let mut sc = ctx.joint_score(&stick, &l, j, &stribeck_shape);
        let v = fs.unwrap_or(0.0);
        let fc =
            f.params.iter().zip(&f.theta).find(|(p, _)| p.joint == Some(j) && p.col == C_SIGN).map_or(0.0, |x| *x.1);
        if v <= 0.0 && sc.significant {
            sc.significant = false;
            sc.rejected_by = Some(format!("sign: fs = {v:.4} is not positive (static friction not above Coulomb)"));
        } else if v < STRIBECK_MIN_RISE * fc && sc.significant {
            sc.significant = false;
            sc.rejected_by = Some(format!(
                "size: fs = {v:.4} N m is {:.0} % of the Coulomb level {fc:.4} N m, needs {:.0} %",
                100.0 * v / fc,
                100.0 * STRIBECK_MIN_RISE
            ));
        }
        if best.as_ref().is_none_or(|(b, _)| sc.f > b.f) {
            best = Some((sc, l));
        }
    }
    best.expect("grid not empty")
}

/// Stribeck friction's shape column (not the stick column it brings, `Model::stick`).
fn stribeck_shape(p: &Param) -> bool {
    p.kind == Some(EffectKind::Stribeck) && p.col != C_STUCK
}

/// A per-joint effect (Coulomb, viscous, armature, offset, spring) scored on each joint
/// where it can go.
fn score_joint_effect(ctx: &Ctx, m: &Model, e: EffectKind) -> Scored {
    let mut per_joint = vec![];
    let mut larger = m.clone();
    for j in 0..ctx.n {
        if e == EffectKind::TorqueGain && j + 1 == ctx.n {
            // the terminal joint's torque is the terminal link's alone: a gain there is a
            // scale of that link's inertials, which a payload or its CAD error is
            per_joint.push(not_scored("on the terminal joint a gain is a scale of the terminal link's inertials"));
            continue;
        }
        let Some(l) = propose(m, e, j) else {
            per_joint.push(not_scored("already in the model on this joint"));
            continue;
        };
        // a spring is named only if its position column matters beyond
        // a constant: test it against the model with an offset
        let (base, sel): (Model, &dyn Fn(&Param) -> bool) = if e == EffectKind::JointSpring {
            (m.with(Some(j), EffectKind::TorqueOffset), &|p: &Param| {
                p.kind == Some(EffectKind::JointSpring) && p.col == C_Q
            })
        } else {
            (m.clone(), &move |p: &Param| p.kind == Some(e))
        };
        let l = if e == EffectKind::JointSpring { l.without(Some(j), EffectKind::TorqueOffset) } else { l };
        let mut sc = ctx.joint_score(&base, &l, j, &|p| p.joint == Some(j) && sel(p));
        if sc.significant && e == EffectKind::TorqueOffset && m.has(j, EffectKind::Coulomb) {
            super::drive_rules::offset_or_asymmetric(ctx, &l, j, &mut sc);
        }
        if sc.significant {
            larger.per_joint[j] = l.per_joint[j].clone();
        }
        per_joint.push(sc);
    }
    (per_joint, larger, vec![])
}

/// Look-alike check of an inertia-like per-joint effect against the nominal model's own
/// error, with the effect in on the other joints where it is significant (so that a real
/// effect there does not inflate the link scales). Clears `significant` and takes the
/// effect out of `larger` where it is imitated; returns those joints with their scale.
fn reject_link_scale_lookalikes(
    ctx: &Ctx,
    m: &Model,
    e: EffectKind,
    per_joint: &mut [JointScore],
    larger: &mut Model,
) -> Vec<(usize, String)> {
    let mut lookalike = vec![];
    for j in 0..ctx.n {
        if !per_joint[j].significant {
            continue;
        }
        let mut base = larger.without(Some(j), e);
        let sel: Box<dyn Fn(&Param) -> bool> = if e == EffectKind::JointSpring {
            base = base.with(Some(j), EffectKind::TorqueOffset);
            Box::new(move |p: &Param| p.joint == Some(j) && p.kind == Some(EffectKind::JointSpring) && p.col == C_Q)
        } else {
            Box::new(move |p: &Param| p.joint == Some(j) && p.kind == Some(e))
        };
        if let Some(why) = model_error_lookalike(ctx, &base, larger, j, e, &*sel) {
            reject_as_lookalike(&mut per_joint[j], &why);
            lookalike.push((j, why));
        }
    }
    for &(j, _) in &lookalike {
        larger.per_joint[j] = m.per_joint[j].clone();
    }
    lookalike
}

/// Marks a score rejected by the look-alike rule (`why`: what imitates it).
fn reject_as_lookalike(sc: &mut JointScore, why: &str) {
    sc.significant = false;
    sc.rejected_by = Some(format!("look-alike: {why} explain(s) it as well"));
}

/// Why a candidate was not named on joints where the nominal model's error imitates it
/// (empty if none).
fn lookalike_reason(lookalike: &[(usize, String)]) -> String {
    lookalike
        .iter()
        .map(|(j, why)| format!("on joint {} it is imitated as well by {why} (not named)", j + 1))
        .collect::<Vec<_>>()
        .join("; ")
}

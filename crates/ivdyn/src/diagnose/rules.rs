//! Scoring a candidate effect, and the rules for effects that look alike.
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
//!    joint's noise level (estimated from sample-to-sample differences of the residual of
//!    a model with every candidate in, which slow structure barely moves);
//! 4. its parameters have their physical sign, and an armature or payload is larger than
//!    the uncertainty of the nominal (CAD) inertials;
//! 5. inertia-like effects (payload, armature, offset, spring) are not imitated as well by
//!    per-link scale errors of at most 25 % of the nominal inertials.
//!
//! Look-alikes: viscous vs armature vs payload compete on how much they explain (their
//! columns are `qd`, `qdd` and rigid-body terms, which a moving log separates); Stribeck
//! is only tried as a refinement of Coulomb friction already found on a joint and needs a
//! positive `fs` (static friction above Coulomb); a joint spring contains an offset, so a
//! spring is named only when its position column is significant beyond the constant,
//! otherwise an offset.

use super::dictionary::{C_DELAY, C_LOAD, C_PAYLOAD, C_Q, C_QD, C_QDD, C_SIGN, Grams, STRIBECK_VS};
use super::model::{Fit, Model, Param, all_model, effect_rms, fit, joint_index, noise_of_all_model, rss_joint};
use super::prepare::Prepared;
use super::{CandidateScore, DiagnoseOptions, EffectKind, JointScore};
use crate::Robot;
use crate::batch;
use crate::error::{Error, Result};
use crate::ident::stats::f_sf;

/// Smallest armature (payload) named, as a fraction of the nominal inertia on the joint
/// (of the terminal link's nominal mass); smallest torque gain error `|k - 1|` named.
const NOMINAL_UNCERTAINTY: f64 = 0.1;

/// Largest relative error of the nominal link inertials still taken as a plausible
/// explanation of a residual (CAD masses and inertias are rarely off by more).
pub(super) const LINK_SCALE_MAX: f64 = 0.25;

/// What the rules compare a candidate with: the Gram matrices, the noise, the nominal
/// inertias, and the options' thresholds.
#[derive(Clone)]
pub(super) struct Ctx<'a> {
    pub(super) gr: &'a Grams,
    /// Mean diagonal of the nominal mass matrix over the log (kg m^2 or kg).
    m_diag: Vec<f64>,
    /// Nominal mass of the terminal link (kg).
    terminal_mass: f64,
    pub(super) w: Vec<f64>,
    pub(super) sigma: Vec<f64>,
    /// Held-out RSS per joint of the all-candidates model (two-fold; with the nominal
    /// re-fit when there is one).
    h_all: Vec<f64>,
    /// Integrated autocorrelation time of the residual per joint (samples).
    tau: Vec<f64>,
    pub(super) n: usize,
    pub(super) opts: &'a DiagnoseOptions,
}

/// Mean over (a subsample of) the log of the nominal mass matrix's diagonal.
fn mean_mass_diag(robot: &Robot, q: &[f64], n: usize) -> Result<Vec<f64>> {
    let t_len = q.len() / n;
    let step = (t_len / 200).max(1);
    let qs: Vec<f64> = (0..t_len).step_by(step).flat_map(|k| q[k * n..(k + 1) * n].to_vec()).collect();
    let m = qs.len() / n;
    let mut out = vec![0.0; m * n * n];
    batch::mass_matrix_batch(robot, &qs, &mut out).map_err(|e| Error::during("mass matrix", e))?;
    Ok((0..n).map(|j| (0..m).map(|k| out[k * n * n + j * n + j]).sum::<f64>() / m as f64).collect())
}

impl<'a> Ctx<'a> {
    /// The noise (weights), autocorrelation times, held-out floor and nominal inertias of
    /// the prepared log; `refit`: the search runs on top of the nominal re-fit (this many
    /// base columns, 0: without).
    pub(super) fn new(robot: &Robot, p: &'a Prepared, opts: &'a DiagnoseOptions, refit: usize) -> Result<Self> {
        let n = robot.dof();
        let (s, d, gr) = (&p.s, &p.d, &p.gr);
        let t_len = s.t.len();
        let (sigma, rho, _) = noise_of_all_model(d, gr, n, t_len, refit, opts.drives);
        let w: Vec<f64> = sigma.iter().map(|s| 1.0 / (s * s)).collect();
        let m_diag = mean_mass_diag(robot, &s.q, n)?;
        let terminal_mass = robot.params()[10 * (n - 1)];
        let h_all: Vec<f64> = {
            let mut all = all_model(n, opts.drives);
            all.refit = refit;
            let pa = all.params();
            let (f0, f1) = (fit(&pa, gr, &w, &[0]), fit(&pa, gr, &w, &[1]));
            (0..n).map(|j| rss_joint(&f0, gr, j, &[1]) + rss_joint(&f1, gr, j, &[0])).collect()
        };
        Ok(Ctx { gr, m_diag, terminal_mass, w, sigma, h_all, tau: rho, n, opts })
    }
}

impl Ctx<'_> {
    fn n_eff(&self, j: usize) -> f64 {
        let rows = (self.gr.rows[j][0] + self.gr.rows[j][1]) as f64;
        (rows / self.tau[j]).max(10.0)
    }

    /// Scores `larger` against `smaller` (nested) on joint `j`; `added` selects the new
    /// parameters (for the effect's RMS).
    pub(super) fn joint_score(
        &self,
        smaller: &Model,
        larger: &Model,
        j: usize,
        added: &dyn Fn(&Param) -> bool,
    ) -> JointScore {
        let (ps, pl) = (smaller.params(), larger.params());
        let (fs, fl) = (fit(&ps, self.gr, &self.w, &[0, 1]), fit(&pl, self.gr, &self.w, &[0, 1]));
        let (r0, r1) = (rss_joint(&fs, self.gr, j, &[0, 1]), rss_joint(&fl, self.gr, j, &[0, 1]));
        let k_small = joint_index(&ps, j).len();
        let k_large = joint_index(&pl, j).len();
        let d1 = (k_large.saturating_sub(k_small)).max(1) as f64;
        let rows = (self.gr.rows[j][0] + self.gr.rows[j][1]) as f64;
        let n_eff = self.n_eff(j);
        let d2 = (n_eff - k_large as f64).max(1.0);
        // a correlated residual inflates the explained sum by its autocorrelation time
        // (r0 - r1 ~ tau sigma^2 chi2(d1)) but not the per-sample variance r1 / (rows - k):
        // the former divided by tau = rows / n_eff over the latter is the F statistic, its
        // denominator on d2 effective degrees of freedom (dividing both by tau, as before
        // 2026-12-03, divided the statistic by tau once too often)
        let f_stat = ((r0 - r1).max(0.0) / d1) / (r1 / (rows - k_large as f64).max(1.0)).max(1e-300) * (n_eff / rows);
        let p = f_sf(f_stat, d1, d2);
        // two-fold cross-validation
        let mut h0 = 0.0;
        let mut h1 = 0.0;
        for (train, test) in [(0usize, 1usize), (1, 0)] {
            let a = fit(&ps, self.gr, &self.w, &[train]);
            let b = fit(&pl, self.gr, &self.w, &[train]);
            h0 += rss_joint(&a, self.gr, j, &[test]);
            h1 += rss_joint(&b, self.gr, j, &[test]);
        }
        // the share of the held-out residual *above the noise* the candidate removes: a
        // missing effect explains (nearly) all of the structure it leaves on its joint; a
        // look-alike (e.g. an offset standing in for a wrong link mass) only part of it
        let n_test = (self.gr.rows[j][0] + self.gr.rows[j][1]) as f64;
        // "structure" = what is above the noise, or what the vocabulary can explain at all
        // (held-out residual of the all-candidates model) when that is less, e.g. when a
        // friction model leaves stick-slip bursts at reversals that nothing explains
        let explainable = (h0 - self.h_all[j]).min(h0 - n_test * self.sigma[j].powi(2));
        let structure = explainable.max(0.05 * h0);
        let heldout_gain = if h0 > 0.0 { ((h0 - h1) / structure).min(1.0) } else { 0.0 };
        let e_rms = effect_rms(&fl, self.gr, j, added);
        let mut sc =
            JointScore { f: f_stat, p, heldout_gain, effect_rms: e_rms, significant: false, rejected_by: None };
        sc.rejected_by = self
            .statistical_rule(&sc, j)
            .or_else(|| Self::unphysical(&fl, j, added))
            .or_else(|| self.within_nominal_uncertainty(&fl, j, added));
        sc.significant = sc.rejected_by.is_none();
        sc
    }

    /// The first statistical rule (F test, held-out share, size) a score fails on joint
    /// `j`, in words with its numbers.
    pub(super) fn statistical_rule(&self, sc: &JointScore, j: usize) -> Option<String> {
        let o = self.opts;
        if sc.p >= o.alpha {
            Some(format!("F test: F {:.3}, p {:.1e} >= alpha {:.0e}", sc.f, sc.p, o.alpha))
        } else if sc.heldout_gain < o.min_share {
            Some(format!(
                "held-out share: removes {:.0} % of the explainable held-out residual, needs {:.0} %",
                100.0 * sc.heldout_gain,
                100.0 * o.min_share
            ))
        } else if sc.effect_rms < o.min_effect * self.sigma[j] {
            Some(format!(
                "size: adds {:.3} N m RMS, {:.2} noise std, needs {:.2}",
                sc.effect_rms,
                sc.effect_rms / self.sigma[j],
                o.min_effect
            ))
        } else {
            None
        }
    }

    /// An armature below `NOMINAL_UNCERTAINTY` of the inertia the nominal model already
    /// puts on the joint, or a payload lighter than that share of the terminal link, is
    /// indistinguishable from an error of the links' own (CAD) inertias, which are rarely
    /// better than that: not named as a missing effect (the rule, in words, when it applies).
    fn within_nominal_uncertainty(&self, f: &Fit, j: usize, added: &dyn Fn(&Param) -> bool) -> Option<String> {
        f.params.iter().zip(&f.theta).find_map(|(p, &v)| {
            if !added(p) {
                return None;
            }
            if p.joint == Some(j) && p.kind == Some(EffectKind::Armature) && v < NOMINAL_UNCERTAINTY * self.m_diag[j] {
                return Some(format!(
                    "CAD-uncertainty margin: ia {v:.4} kg m^2 is below {:.0} % of the nominal inertia on the joint ({:.4})",
                    100.0 * NOMINAL_UNCERTAINTY,
                    self.m_diag[j]
                ));
            }
            if p.joint == Some(j) && p.kind == Some(EffectKind::TorqueGain) && v.abs() < NOMINAL_UNCERTAINTY {
                // measured = (1 + v) x true: a few % of the joint's rigid-body torque is what
                // CAD inertial errors leave too
                return Some(format!(
                    "CAD-uncertainty margin: gain k {:.4} is within {:.0} % of 1",
                    1.0 + v,
                    100.0 * NOMINAL_UNCERTAINTY
                ));
            }
            let payload = p.kind == Some(EffectKind::Payload) && p.col == C_PAYLOAD;
            (payload && v < NOMINAL_UNCERTAINTY * self.terminal_mass).then(|| {
                format!(
                    "CAD-uncertainty margin: payload mass {v:.3} kg is below {:.0} % of the terminal link's {:.3} kg",
                    100.0 * NOMINAL_UNCERTAINTY,
                    self.terminal_mass
                )
            })
        })
    }

    /// The added parameter touching joint `j` without its physical sign, in words (none
    /// when all have it): friction, armature and spring stiffness dissipate or store
    /// energy only when positive, and a payload has a positive mass. A negative fit is how
    /// differentiation lag or a model error imitates an effect, never the effect itself.
    pub(super) fn unphysical(f: &Fit, j: usize, added: &dyn Fn(&Param) -> bool) -> Option<String> {
        f.params.iter().zip(&f.theta).find_map(|(p, &v)| {
            if !added(p) || p.joint.is_some_and(|x| x != j) {
                return None;
            }
            if p.kind == Some(EffectKind::TorqueGain) {
                // measured = k x true with k = 1 + theta: a sensor cannot flip the sign
                return (v <= -1.0).then(|| format!("sign: gain k = {:.4} is not positive", 1.0 + v));
            }
            let name = match (p.kind, p.col) {
                (Some(EffectKind::Coulomb), C_SIGN) => "fc",
                (Some(EffectKind::SmoothCoulomb), _) => "fc",
                (Some(EffectKind::LoadDependent), C_LOAD) => "mu",
                (Some(EffectKind::TimeDelay), C_DELAY) => "delay_s",
                (Some(EffectKind::Viscous), C_QD) => "fv",
                (Some(EffectKind::Armature), C_QDD) => "ia",
                (Some(EffectKind::JointSpring), C_Q) => "k",
                (Some(EffectKind::Payload), C_PAYLOAD) => "payload mass",
                _ => return None,
            };
            (v <= 0.0).then(|| format!("sign: {name} = {v:.4} is not positive"))
        })
    }

    /// Noise-weighted RSS reduction of `larger` over `smaller` (all joints, all data).
    fn gain(&self, smaller: &Model, larger: &Model) -> f64 {
        let (fs, fl) =
            (fit(&smaller.params(), self.gr, &self.w, &[0, 1]), fit(&larger.params(), self.gr, &self.w, &[0, 1]));
        (0..self.n)
            .map(|j| self.w[j] * (rss_joint(&fs, self.gr, j, &[0, 1]) - rss_joint(&fl, self.gr, j, &[0, 1])))
            .sum()
    }
}

/// The effects a wrong nominal link mass or inertia can imitate (a torque gain scales the
/// joint's rigid-body torque as a link-mass error partly does).
fn inertia_like(e: EffectKind) -> bool {
    matches!(
        e,
        EffectKind::Payload
            | EffectKind::Armature
            | EffectKind::TorqueOffset
            | EffectKind::JointSpring
            | EffectKind::TorqueGain
    )
}

/// Look-alike check against the nominal model's own error: if scaling each link's nominal
/// inertials (by at most `LINK_SCALE_MAX`) explains the residual and the candidate is no
/// longer significant on joint `j` once those scales are free, the candidate is imitated
/// by a model error. Returns the largest scale (as a fraction) when it is.
fn model_error_lookalike(
    ctx: &Ctx,
    m: &Model,
    larger: &Model,
    j: usize,
    added: &dyn Fn(&Param) -> bool,
) -> Option<f64> {
    let mut base = m.clone();
    base.link_scale = true;
    let mut l = larger.clone();
    l.link_scale = true;
    let fb = fit(&base.params(), ctx.gr, &ctx.w, &[0, 1]);
    let smax =
        fb.params.iter().zip(&fb.theta).filter(|(p, _)| p.kind.is_none()).map(|(_, v)| v.abs()).fold(0.0, f64::max);
    if smax > LINK_SCALE_MAX {
        return None;
    }
    if ctx.joint_score(&base, &l, j, added).significant { None } else { Some(smax) }
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

/// The score of a candidate that cannot go on a joint (already there, or its
/// precondition missing).
pub(super) fn not_scored(why: &str) -> JointScore {
    JointScore {
        f: 0.0,
        p: 1.0,
        heldout_gain: 0.0,
        effect_rms: 0.0,
        significant: false,
        rejected_by: Some(format!("not tried: {why}")),
    }
}

/// One candidate effect scored on every joint: the scores, the model with it added where
/// it is significant, and the joints where a link-scale error imitates it (with the
/// largest scale).
pub(super) type Scored = (Vec<JointScore>, Model, Vec<(usize, f64)>);

/// Scores every candidate against the current model.
pub(super) fn score_candidates(ctx: &Ctx, m: &Model) -> Vec<(CandidateScore, Model)> {
    let n = ctx.n;
    let mut out = vec![];
    for e in EffectKind::ALL.into_iter().filter(|e| ctx.opts.drives || !e.is_drive()) {
        let (mut per_joint, mut larger, mut lookalike) = match e {
            EffectKind::Payload if m.payload => continue,
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
        let joints: Vec<usize> = (0..n).filter(|&j| per_joint[j].significant).collect();
        let score = if joints.is_empty() { 0.0 } else { ctx.gain(m, &larger) };
        let reason = lookalike_reason(&lookalike);
        out.push((CandidateScore { effect: e, per_joint, joints, score, accepted: false, reason }, larger));
    }
    out
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
            && let Some(s) = model_error_lookalike(ctx, m, &l, j, &is_payload)
        {
            reject_as_lookalike(&mut sc, s);
            lookalike.push((j, s));
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
        if !m.has(j, EffectKind::Coulomb) || refined.iter().any(|&r| m.has(j, r)) {
            per_joint.push(not_scored("a refinement of Coulomb friction already found on the joint"));
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
        let mut sc = ctx.joint_score(m, &l, j, &|p| p.kind == Some(EffectKind::Stribeck));
        let v = fs.unwrap_or(0.0);
        if v <= 0.0 && sc.significant {
            sc.significant = false;
            sc.rejected_by = Some(format!("sign: fs = {v:.4} is not positive (static friction not above Coulomb)"));
        }
        if best.as_ref().is_none_or(|(b, _)| sc.f > b.f) {
            best = Some((sc, l));
        }
    }
    best.expect("grid not empty")
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
) -> Vec<(usize, f64)> {
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
        if let Some(sc) = model_error_lookalike(ctx, &base, larger, j, &*sel) {
            reject_as_lookalike(&mut per_joint[j], sc);
            lookalike.push((j, sc));
        }
    }
    for &(j, _) in &lookalike {
        larger.per_joint[j] = m.per_joint[j].clone();
    }
    lookalike
}

/// Marks a score rejected by the look-alike rule (link scales of at most `scale` imitate it).
fn reject_as_lookalike(sc: &mut JointScore, scale: f64) {
    sc.significant = false;
    sc.rejected_by =
        Some(format!("look-alike: the nominal link inertials off by up to {:.0} % explain it as well", 100.0 * scale));
}

/// Why a candidate was not named on joints where link-scale errors imitate it (empty if
/// none).
fn lookalike_reason(lookalike: &[(usize, f64)]) -> String {
    if lookalike.is_empty() {
        return String::new();
    }
    format!(
        "on joint(s) {} it is imitated as well by the nominal link inertials being off by up to {:.0} % (not named)",
        lookalike.iter().map(|(j, _)| (j + 1).to_string()).collect::<Vec<_>>().join(", "),
        100.0 * lookalike.iter().map(|x| x.1).fold(0.0, f64::max)
    )
}

//! The [`Diagnosis`] of the model the search found: the effects with the final fit's
//! parameters, the evidence in words, the predictions after each step, what is left above
//! the noise, and the verdict.

use super::constant_view;
use super::detectable::detectable;
use super::dictionary::{
    C_DELAY, C_GAIN, C_LOAD, C_ONE, C_PAYLOAD, C_Q, C_QD, C_QDD, C_RIPPLE, C_SIGN, C_SIGN_POS, C_STRIBECK, C_TANH,
    Dictionary,
};
use super::model::{Fit, Model, effect_torque, fit, rss_joint};
use super::prepare::Prepared;
use super::refit::{self, RefitDecision};
use super::residual::{regimes, rms_per_joint};
use super::score::{Ctx, LINK_SCALE_MAX};
use super::signals::Signals;
use super::uncertainty;
use super::{
    CandidateScore, DiagnoseOptions, Diagnosis, DiagnosisJson, EffectJson, EffectKind, LogInfo, NominalRefitJson,
    Regimes, Step, Traces,
};
use crate::Robot;
use crate::error::Result;

type Params = serde_json::Map<String, serde_json::Value>;

/// What the search found.
pub(super) struct Found {
    /// The steps, each with the model after it.
    pub(super) steps: Vec<(Step, Model)>,
    /// The candidates scored at the final step, when none was significant.
    pub(super) final_candidates: Vec<CandidateScore>,
    /// The final model.
    pub(super) model: Model,
    /// The nominal re-fit the search ran on (the final model has it too).
    pub(super) refit: Option<RefitDecision>,
    /// Notes for the details (an armature the re-fit held, `rotor`).
    pub(super) notes: Vec<String>,
}

/// The diagnosis of `found` on the prepared log (`r_nom`: the nominal residual, `T x N`).
pub(super) fn assemble(
    robot: &Robot,
    opts: &DiagnoseOptions,
    p: &Prepared,
    ctx: &Ctx,
    found: Found,
    baseline_rms: Vec<f64>,
    r_nom: &[f64],
) -> Result<Diagnosis> {
    let Found { steps, final_candidates, model: m, refit, notes } = found;
    let (s, d) = (&p.s, &p.d);
    let n = ctx.n;
    let t_len = s.t.len();
    let names = &robot.joint_names;
    let f = fit(&m.params(), ctx.gr, &ctx.w, &[0, 1]);
    let e = effect_torque(&f, d, n, t_len);
    let r_final: Vec<f64> = (0..t_len * n).map(|i| r_nom[i] - e[i]).collect();
    let final_rms = rms_per_joint(&r_final, n);
    let spread = uncertainty::spread(&f, ctx.gr, d, &ctx.w, &r_final, 2 * opts.blocks_per_fold.max(1));
    let nominal_refit = match &refit {
        Some(dec) => {
            // the re-fit's own part of the final fit (its base corrections, no effect)
            let only = Fit {
                params: f.params.clone(),
                theta: f.params.iter().zip(&f.theta).map(|(p, &v)| if p.kind.is_none() { v } else { 0.0 }).collect(),
            };
            let e_refit = effect_torque(&only, d, n, t_len);
            let r: Vec<f64> = (0..t_len * n).map(|i| r_nom[i] - e_refit[i]).collect();
            Some(refit::report(robot, d, dec, &f, baseline_rms.clone(), rms_per_joint(&r, n), names)?)
        }
        None => None,
    };
    let raw: Vec<(EffectKind, Model)> = steps.iter().map(|(st, ms)| (st.effect, ms.clone())).collect();
    let regimes_before = regimes(s, r_nom, n);
    let regimes_after = regimes(s, &r_final, n);

    let mut out_steps = merge_repeats(steps);
    let effects = report_effects(&mut out_steps, (&f, spread.as_ref()), &m, d, names, &regimes_before, ctx);
    let kept: Vec<Step> =
        out_steps.into_iter().filter(|st| effects.iter().any(|e| e.name == st.effect.name())).collect();
    let predicted = step_predictions(&raw, &kept, ctx, d, &p.tau_nom);
    let gaps = remaining_gaps(ctx, &m, &final_rms, &regimes_after, names);
    let next_command = next_command(&kept, nominal_refit.is_some(), opts);
    let (verdict, mut details) = verdict(&kept, &effects, &gaps, nominal_refit.as_ref(), names);
    let shown = detectable(ctx.gr, d.nbase(), ctx.sigma_size());
    if nominal_refit.is_some() {
        details.extend(constant_view::note(&shown, &ctx.q_span, names));
    } else {
        details.extend(constant_view::unrefitted_note(&shown, &ctx.q_span, names, &effects));
    }
    details.extend(notes);
    details.extend(robot.inertial_notes().into_iter().map(|n| format!("nominal model: {n}")));
    details.push(format!("effects of real drives {}", p.drives_why));
    let traces =
        Traces { t: s.t.clone(), q: s.q.clone(), qd: s.qd.clone(), qdd: s.qdd.clone(), tau: s.tau.clone(), predicted };
    Ok(Diagnosis {
        json: DiagnosisJson {
            effects,
            baseline_rms,
            final_rms,
            joints: names.clone(),
            nominal_refit,
            next_command,
            detectable: Some(shown),
        },
        steps: kept,
        final_candidates,
        noise_std: ctx.sigma.clone(),
        regimes_before,
        regimes_after,
        verdict,
        details,
        traces,
        info: log_info(opts, s),
    })
}

/// The steps in the order found, an effect found again later (on more joints) merged
/// into its first step: the report names each effect once.
fn merge_repeats(steps: Vec<(Step, Model)>) -> Vec<Step> {
    let mut out_steps = vec![];
    let mut seen: Vec<EffectKind> = vec![];
    for (mut st, _) in steps {
        if seen.contains(&st.effect) {
            // the same effect found again on more joints: merge into the first entry
            let pos = out_steps.iter().position(|x: &Step| x.effect == st.effect).expect("seen");
            carry_scores(&mut out_steps[pos], &st);
            out_steps[pos].joints.extend(st.joints.iter().copied());
            out_steps[pos].rms_after = st.rms_after.clone();
            continue;
        }
        seen.push(st.effect);
        st.joints.sort();
        out_steps.push(st);
    }
    out_steps
}

/// The scores of `later`'s joints (its candidate of its own effect) into `first`'s candidate
/// of that effect, where the evidence reads them, and its reason beside the first's.
fn carry_scores(first: &mut Step, later: &Step) {
    let of = |st: &Step| st.candidates.iter().position(|c| c.effect == st.effect);
    let (Some(a), Some(b)) = (of(first), of(later)) else { return };
    let src = &later.candidates[b];
    for &j in &later.joints {
        first.candidates[a].per_joint[j] = src.per_joint[j].clone();
    }
    if !first.candidates[a].reason.contains(&src.reason) {
        first.candidates[a].reason += &format!("; then: {}", src.reason);
    }
}

/// The effects in the order found, with the final fit's parameters and their standard
/// errors (from `spread`: the fit's noise, folds and ridge, `uncertainty`); an effect whose joints were
/// all dropped by a later backward step is not reported. Sets each reported step's joints
/// (those of the final model) and evidence.
fn report_effects(
    out_steps: &mut [Step],
    (f, spread): (&Fit, Option<&uncertainty::Spread>),
    m: &Model,
    d: &Dictionary,
    names: &[String],
    regimes_before: &[Regimes],
    ctx: &Ctx,
) -> Vec<EffectJson> {
    let n = ctx.n;
    let mut effects = vec![];
    for st in out_steps.iter_mut() {
        let kind = st.effect;
        let joints = reported_joints(kind, m, n);
        if kind != EffectKind::Payload && joints.is_empty() || kind == EffectKind::Payload && !m.payload {
            continue;
        }
        let (mut params, scales) = fitted_parameters(kind, &joints, f, m, d, ctx);
        let mut parameters_std = spread
            .map(|s| uncertainty::parameters_std(f, s, &|g| effect_parameters(kind, &joints, g, m, d, n)))
            .unwrap_or_default();
        if kind == EffectKind::Payload {
            let prev = super::score::has_refit(f).then_some(ctx.prev_link_mass);
            payload_with_cad_error(f, &mut params, &mut parameters_std, &ctx.terminal_p10, prev);
        }
        if kind == EffectKind::TorqueRipple {
            period_std(&joints, m, d, &mut parameters_std);
        }
        if !scales.is_empty() && !parameters_std.is_empty() {
            let std: Vec<serde_json::Value> = scales.iter().map(|s| s.vs_std.into()).collect();
            parameters_std.insert("vs".into(), std.into());
        }
        st.joints = joints.clone();
        st.evidence = evidence(st, &params, names, regimes_before, ctx);
        effects.push(EffectJson {
            name: kind.name().into(),
            joints: if kind == EffectKind::Payload {
                vec![]
            } else {
                joints.iter().map(|&j| names[j].clone()).collect()
            },
            parameters: params,
            parameters_std,
            rms_before: st.rms_before.clone(),
            rms_after: st.rms_after.clone(),
        });
    }
    effects
}

/// The joints a named effect is reported on: every joint for a payload; a Coulomb friction
/// only where no refinement (Stribeck, smooth, direction-dependent) replaces it.
fn reported_joints(kind: EffectKind, m: &Model, n: usize) -> Vec<usize> {
    match kind {
        EffectKind::Payload => (0..n).collect(),
        // Stribeck replaces Coulomb on its joints
        EffectKind::Coulomb => (0..n)
            .filter(|&j| m.has(j, kind))
            .filter(|&j| {
                let refined = [EffectKind::Stribeck, EffectKind::SmoothCoulomb, EffectKind::AsymmetricCoulomb];
                !refined.iter().any(|&r| m.has(j, r))
            })
            .collect(),
        _ => (0..n).filter(|&j| m.has(j, kind)).collect(),
    }
}

/// A named effect's parameters from the fit `f`, with those read beyond its columns: the
/// smooth and Stribeck friction's `vs` between the grid points (and its scales, returned),
/// a delay's exact shift, Coulomb levels where the joint moves, `mu` on the fitted load.
fn fitted_parameters(
    kind: EffectKind,
    joints: &[usize],
    f: &Fit,
    m: &Model,
    d: &Dictionary,
    ctx: &Ctx,
) -> (Params, Vec<super::shape_scale::Scale>) {
    let mut params = effect_parameters(kind, joints, f, m, d, ctx.n);
    // smooth and Stribeck friction's `vs` fitted between the grid points, the levels with it
    let scales: Vec<super::shape_scale::Scale> = match kind {
        EffectKind::SmoothCoulomb | EffectKind::Stribeck => {
            joints.iter().map(|&j| super::shape_scale::fit_scale(ctx, m, d, j, kind)).collect()
        }
        _ => vec![],
    };
    if !scales.is_empty() {
        let list = |g: &dyn Fn(&super::shape_scale::Scale) -> f64| scales.iter().map(g).collect::<Vec<_>>();
        params.insert("vs".into(), list(&|s| s.vs).into());
        if kind == EffectKind::Stribeck {
            params.insert("fs".into(), list(&|s| s.level).into());
            params.insert("fc".into(), list(&|s| s.fc).into());
        } else {
            params.insert("fc".into(), list(&|s| s.level).into());
        }
    }
    if kind == EffectKind::TimeDelay {
        // the exact shift, not its first order (`drive_rules::delay_exact`)
        let first = params["delay_s"].as_array().cloned().unwrap_or_default();
        let exact: Vec<f64> = joints
            .iter()
            .zip(&first)
            .map(|(&j, d0)| super::drive_rules::delay_exact(f, d, j, d0.as_f64().unwrap_or(f64::NAN)))
            .collect();
        params.insert("delay_s".into(), exact.into());
    }
    if kind == EffectKind::Coulomb || kind == EffectKind::AsymmetricCoulomb {
        // the levels where the joint moves, not through its stick phases (`levels`)
        let asym = kind == EffectKind::AsymmetricCoulomb;
        let lv: Option<Vec<(f64, f64)>> =
            joints.iter().map(|&j| super::levels::coulomb_levels(f, d, j, asym, m.stick_band[j])).collect();
        if let Some(lv) = lv {
            let (neg, pos): (Vec<f64>, Vec<f64>) = lv.into_iter().unzip();
            if asym {
                params.insert("fc_neg".into(), neg.into());
                params.insert("fc_pos".into(), pos.into());
            } else {
                params.insert("fc".into(), neg.into());
            }
        }
    }
    if kind == EffectKind::LoadDependent {
        // `mu` against the load the fit models (`drive_rules::load_mu_on_fitted_load`)
        let mu: Option<Vec<f64>> =
            joints.iter().map(|&j| super::drive_rules::load_mu_on_fitted_load(f, d, j)).collect();
        if let Some(mu) = mu {
            params.insert("mu".into(), mu.into());
        }
    }
    (params, scales)
}

/// The fitted value of joint `j`'s parameter of `kind` in column `col` (0 if absent).
fn theta_of(f: &Fit, j: usize, kind: EffectKind, col: usize) -> f64 {
    f.params
        .iter()
        .position(|p| p.joint == Some(j) && p.kind == Some(kind) && p.col == col)
        .map(|i| f.theta[i])
        .unwrap_or(0.0)
}

/// The `parameters` of an effect in `diagnosis.json` (DESIGN.md), lists over `joints`.
fn effect_parameters(kind: EffectKind, joints: &[usize], f: &Fit, m: &Model, d: &Dictionary, n: usize) -> Params {
    let mut params = serde_json::Map::new();
    let list = |v: Vec<f64>| serde_json::Value::from(v);
    let per_joint = |kind: EffectKind, col: usize| list(joints.iter().map(|&j| theta_of(f, j, kind, col)).collect());
    match kind {
        EffectKind::Coulomb => {
            params.insert("fc".into(), per_joint(EffectKind::Coulomb, C_SIGN));
        }
        EffectKind::Viscous => {
            params.insert("fv".into(), per_joint(kind, C_QD));
        }
        EffectKind::Armature => {
            params.insert("ia".into(), per_joint(kind, C_QDD));
        }
        EffectKind::TorqueOffset => {
            params.insert("tau0".into(), per_joint(kind, C_ONE));
        }
        EffectKind::JointSpring => {
            // k (q - qm) + c = k (q - q0) with q0 = qm - c / k
            let k: Vec<f64> = joints.iter().map(|&j| theta_of(f, j, kind, C_Q)).collect();
            let q0: Vec<f64> =
                joints.iter().zip(&k).map(|(&j, &k)| d.q_mean[j] - theta_of(f, j, kind, C_ONE) / k).collect();
            params.insert("k".into(), list(k));
            params.insert("q0".into(), list(q0));
        }
        EffectKind::Stribeck => {
            params.insert("fc".into(), per_joint(EffectKind::Coulomb, C_SIGN));
            params.insert(
                "fs".into(),
                list(joints.iter().map(|&j| theta_of(f, j, kind, C_STRIBECK + m.stribeck_vs[j])).collect()),
            );
            params.insert("vs".into(), list(joints.iter().map(|&j| d.vs[j][m.stribeck_vs[j]]).collect()));
        }
        EffectKind::Payload => payload_parameters(f, n, &mut params),
        _ => drive_parameters(kind, joints, f, m, d, &mut params),
    }
    params
}

/// The `parameters` of a real-drive effect (DESIGN.md), lists over `joints`.
fn drive_parameters(kind: EffectKind, joints: &[usize], f: &Fit, m: &Model, d: &Dictionary, params: &mut Params) {
    let list = |v: Vec<f64>| serde_json::Value::from(v);
    let over = |g: &dyn Fn(usize) -> f64| list(joints.iter().map(|&j| g(j)).collect());
    match kind {
        EffectKind::AsymmetricCoulomb => {
            // fc sign(qd) + d [qd > 0]: fc_neg = fc, fc_pos = fc + d
            let fc = |j: usize| theta_of(f, j, EffectKind::Coulomb, C_SIGN);
            params.insert("fc_pos".into(), over(&|j: usize| fc(j) + theta_of(f, j, kind, C_SIGN_POS)));
            params.insert("fc_neg".into(), over(&|j: usize| fc(j)));
        }
        EffectKind::SmoothCoulomb => {
            params.insert("fc".into(), over(&|j: usize| theta_of(f, j, kind, C_TANH + m.smooth_vs[j])));
            params.insert("vs".into(), over(&|j: usize| d.smooth_vs[j][m.smooth_vs[j]]));
        }
        EffectKind::LoadDependent => {
            params.insert("mu".into(), over(&|j: usize| theta_of(f, j, kind, C_LOAD)));
        }
        EffectKind::TorqueGain => {
            // residual (k - 1) tau_nom
            params.insert("k".into(), over(&|j: usize| 1.0 + theta_of(f, j, kind, C_GAIN)));
        }
        EffectKind::TorqueRipple => {
            let col = |j: usize| C_RIPPLE + 2 * m.ripple_n[j];
            params.insert("period".into(), over(&|j: usize| std::f64::consts::TAU / d.ripple_h[j][m.ripple_n[j]].0));
            params.insert("a".into(), over(&|j: usize| theta_of(f, j, kind, col(j))));
            params.insert("b".into(), over(&|j: usize| theta_of(f, j, kind, col(j) + 1)));
        }
        EffectKind::TimeDelay => {
            params.insert("delay_s".into(), over(&|j: usize| theta_of(f, j, kind, C_DELAY)));
        }
        _ => {}
    }
}

/// A ripple's period's standard error where it was fitted between the grid's harmonics
/// (`ripple_period`; `null` on a grid entry): `2 pi s_h / h^2` for harmonic `h`, error `s_h`.
fn period_std(joints: &[usize], m: &Model, d: &Dictionary, std: &mut Params) {
    let of = |j: usize| {
        let (h, s) = d.ripple_h[j][m.ripple_n[j]];
        s.map_or(serde_json::Value::Null, |s| (std::f64::consts::TAU * s / (h * h)).into())
    };
    if !std.is_empty() {
        std.insert("period".into(), joints.iter().map(|&j| of(j)).collect());
    }
}

/// The payload's 10 fitted inertial parameters (zero where `f` has none).
fn payload_p10(f: &Fit) -> [f64; 10] {
    let mut p10 = [0.0; 10];
    for (i, p) in f.params.iter().enumerate() {
        if p.kind == Some(EffectKind::Payload) {
            p10[p.col - C_PAYLOAD] = f.theta[i];
        }
    }
    p10
}

/// A payload's mass, centre of mass and inertia from its 10 fitted inertial parameters:
/// only the mass when it is not positive; the inertia null when it is not that of a body
/// (pseudo-inertia not positive semi-definite: a negative principal moment, or one above
/// the sum of the other two), as where the fit trades it against the re-fitted links'.
fn payload_parameters(f: &Fit, n: usize, params: &mut Params) {
    let list = |v: Vec<f64>| serde_json::Value::from(v);
    let p10 = payload_p10(f);
    let li = ivdyn_core::LinkInertia(p10);
    match li.to_mass_com_inertia(n - 1) {
        Ok((mass, c, ic)) => {
            params.insert("mass".into(), mass.into());
            params.insert("com".into(), list(vec![c.x, c.y, c.z]));
            // diagnosis.json keeps URDF attribute order (docs/diagnose.md)
            let urdf = ivdyn_core::inertia_to_urdf(ivdyn_core::inertia_vector(&ic));
            let body = li.is_physically_consistent(0.0);
            params.insert("inertia".into(), if body { list(urdf.to_vec()) } else { serde_json::Value::Null });
        }
        Err(_) => {
            params.insert("mass".into(), p10[0].into());
            params.insert("com".into(), serde_json::Value::Null);
            params.insert("inertia".into(), serde_json::Value::Null);
        }
    }
}

/// A payload is a change of the terminal link, so its fitted parameters are the payload's
/// plus that link's own CAD error, and on top of the nominal re-fit (`m_prev`: the previous
/// link's nominal mass) also that link's mass error: the payload's mass regroups into its
/// parameters, which the re-fit holds. Those errors go into the standard errors
/// (`payload_cad`). On the re-fit the payload is kept when its mass stays positive beyond 2
/// standard errors; otherwise mass, centre of mass (`m c / m`) and inertia about it are not
/// separable and set to null (docs/diagnose.md, "Payload on top of the re-fit").
fn payload_with_cad_error(f: &Fit, params: &mut Params, std: &mut Params, terminal: &[f64; 10], m_prev: Option<f64>) {
    if std.is_empty() && m_prev.is_none() {
        return;
    }
    let cad = super::payload_cad::cad_std(terminal, m_prev);
    super::payload_cad::add_to_std(&payload_p10(f), &cad, params, std);
    let mass = params.get("mass").and_then(|v| v.as_f64()).unwrap_or(f64::NAN);
    let s = std.get("mass").and_then(|v| v.as_f64()).unwrap_or(f64::NAN);
    if m_prev.is_none() || mass - 2.0 * s > 0.0 {
        return;
    }
    for k in ["mass", "com", "inertia"] {
        params.insert(k.into(), serde_json::Value::Null);
        std.insert(k.into(), serde_json::Value::Null);
    }
}

/// Longest headline (characters): one sentence a person reads first.
pub(super) const HEADLINE_MAX: usize = 200;

/// The headline (one sentence, at most `HEADLINE_MAX` characters, naming what is missing)
/// and the details below it: each effect with its joints and parameters (value ± 2
/// standard errors), the nominal re-fit, what is left above the noise per joint, and what
/// the next command (`next_command`, shown beside them) leaves out.
fn verdict(
    kept: &[Step],
    effects: &[EffectJson],
    gaps: &[String],
    refit: Option<&NominalRefitJson>,
    names: &[String],
) -> (String, Vec<String>) {
    let on = |st: &Step, full: bool| -> String {
        let js: Vec<&str> = st.joints.iter().map(|&j| names[j].as_str()).collect();
        match st.effect {
            EffectKind::Payload => st.effect.label().to_string(),
            _ if full || js.len() <= 2 => format!("{} on {}", st.effect.label(), js.join(", ")),
            _ => format!("{} on {} joints", st.effect.label(), js.len()),
        }
    };
    let mut details: Vec<String> = kept
        .iter()
        .map(|st| match effects.iter().find(|e| e.name == st.effect.name()) {
            Some(e) if e.parameters.values().all(|v| v.is_null()) => format!(
                "missing: {}: its mass and centre of mass are not separable from the re-fitted links' inertials (weigh it, or estimate it with `ivdyn payload` on logs before and after it was attached)",
                on(st, true)
            ),
            Some(e) if !e.parameters_std.is_empty() => format!(
                "missing: {}: {} (\u{b1} 2 standard errors)",
                on(st, true),
                uncertainty::with_two_std(&e.parameters, &e.parameters_std, &|k| super::report::param_meta(st.effect, k).0)
            ),
            _ => format!("missing: {}", on(st, true)),
        })
        .collect();
    if let Some(r) = refit {
        details.push(format!("nominal model re-fitted: {}", r.why));
    }
    details.extend(gaps.iter().map(|g| format!("left above the noise: {g}")));
    let has = |e: EffectKind| kept.iter().any(|st| st.effect == e);
    if has(EffectKind::Payload) {
        details.push(
            "the payload is not part of identify's model: estimate it with `ivdyn payload` on a log after the grasp"
                .into(),
        );
    }
    if has(EffectKind::JointSpring) {
        details.push("identify has no joint spring: it stays in identify's residual".into());
    }
    let refit_note = if refit.is_some() { " (on the re-fitted nominal inertials)" } else { "" };
    let left = if gaps.is_empty() {
        String::new()
    } else {
        format!("; residual above the noise left on {} joint(s)", gaps.len())
    };
    let headline = if kept.is_empty() && gaps.is_empty() {
        format!("Nothing significant missing: the model explains the log down to the noise{refit_note}.")
    } else if kept.is_empty() {
        format!("No effect of the vocabulary is missing{refit_note}{left} (details below).")
    } else {
        let long: Vec<String> = kept.iter().map(|st| on(st, false)).collect();
        let short: Vec<String> = kept.iter().map(|st| st.effect.label().to_string()).collect();
        let h = format!("Missing: {}{refit_note}{left}.", long.join("; "));
        if h.chars().count() <= HEADLINE_MAX { h } else { format!("Missing: {}{refit_note}{left}.", short.join("; ")) }
    };
    (headline, details)
}

/// `arg` as one shell word: as it is when it holds only characters no shell treats
/// specially, else in single quotes.
fn shell_word(arg: &str) -> String {
    let plain = |c: char| c.is_ascii_alphanumeric() || "_-./:=,@+%".contains(c);
    if !arg.is_empty() && arg.chars().all(plain) {
        arg.to_string()
    } else {
        format!("'{}'", arg.replace('\'', "'\\''"))
    }
}

/// The `ivdyn identify` command that fits the named effects into the model (physically
/// consistent inertials, written as a URDF), reading the robot and the log as this run
/// did (`opts.next_args`); `None` when nothing was named and the nominal model was not
/// re-fitted. Stribeck friction is identify's Coulomb friction with its shape chosen per
/// joint (`--coulomb auto`, the default); a payload and a spring are not in its model (the
/// details say so).
fn next_command(kept: &[Step], refit: bool, opts: &DiagnoseOptions) -> Option<String> {
    if kept.is_empty() && !refit {
        return None;
    }
    let has = |e: EffectKind| kept.iter().any(|st| st.effect == e);
    let mut friction = vec![];
    let coulomb_like =
        [EffectKind::Coulomb, EffectKind::Stribeck, EffectKind::SmoothCoulomb, EffectKind::AsymmetricCoulomb];
    if coulomb_like.iter().any(|&e| has(e)) {
        friction.push("coulomb");
    }
    if has(EffectKind::Viscous) {
        friction.push("viscous");
    }
    let or = |s: &str, d: &str| if s.is_empty() { d.to_string() } else { s.to_string() };
    let mut args: Vec<String> =
        vec!["--urdf".into(), or(&opts.urdf_name, "URDF"), "--log".into(), or(&opts.log_name, "LOG")];
    args.extend(opts.next_args.iter().cloned());
    args.push("--consistent".into());
    args.push("--friction".into());
    args.push(if friction.is_empty() { "none".into() } else { friction.join(",") });
    if !has(EffectKind::Armature) {
        args.push("--no-armature".into());
    }
    if !has(EffectKind::TorqueOffset) {
        args.push("--no-offset".into());
    }
    args.extend(["--write-urdf".to_string(), "identified.urdf".to_string()]);
    let words: Vec<String> = args.iter().map(|a| shell_word(a)).collect();
    Some(format!("ivdyn identify {}", words.join(" ")))
}

/// The facts about the input the report shows.
fn log_info(opts: &DiagnoseOptions, s: &Signals) -> LogInfo {
    LogInfo {
        file: opts.log_name.clone(),
        urdf: opts.urdf_name.clone(),
        samples: s.t.len(),
        duration: s.duration(),
        rate: 1.0 / s.dt,
        velocity_in_log: s.velocity_in_log,
        velocity: s.velocity.clone(),
        cutoff_hz: s.cutoff_hz,
        align_samples: s.align,
    }
}

/// The predicted torques of the report: the nominal model, then one per reported step.
/// A step found again later (more joints) is merged into its first report, so reported
/// step `i` shows the model after the last search step that added nothing reported later
/// than `i` (effects not reported at all count as earlier): with nothing merged, the model
/// after each search step; the last one is always the model after the last search step.
fn step_predictions(
    raw: &[(EffectKind, Model)],
    kept: &[Step],
    ctx: &Ctx,
    d: &Dictionary,
    tau_nom: &[f64],
) -> Vec<Vec<f64>> {
    let (n, t_len) = (ctx.n, tau_nom.len() / ctx.n);
    let rank = |e: EffectKind| kept.iter().position(|st| st.effect == e).unwrap_or(0);
    let mut predicted = vec![tau_nom.to_vec()];
    for i in 0..kept.len() {
        let Some(k) = raw.iter().take_while(|(e, _)| rank(*e) <= i).count().checked_sub(1) else {
            predicted.push(tau_nom.to_vec());
            continue;
        };
        let fs = fit(&raw[k].1.params(), ctx.gr, &ctx.w, &[0, 1]);
        let es = effect_torque(&fs, d, n, t_len);
        predicted.push((0..t_len * n).map(|j| tau_nom[j] + es[j]).collect());
    }
    predicted
}

/// What is left above the noise after the final model, in words, one entry per
/// joint whose final RMS exceeds 1.5 noise std, where the residual is (velocity reversals)
/// and whether per-link scale factors of the nominal inertials explain it (a wrong nominal
/// model rather than a missing effect).
fn remaining_gaps(ctx: &Ctx, m: &Model, final_rms: &[f64], reg: &[Regimes], names: &[String]) -> Vec<String> {
    let mut scaled = m.clone();
    scaled.link_scale = true;
    let (f0, f1) = (fit(&m.params(), ctx.gr, &ctx.w, &[0, 1]), fit(&scaled.params(), ctx.gr, &ctx.w, &[0, 1]));
    let smax =
        f1.params.iter().zip(&f1.theta).filter(|(p, _)| p.kind.is_none()).map(|(_, v)| v.abs()).fold(0.0, f64::max);
    let mut parts = vec![];
    for j in 0..ctx.n {
        if final_rms[j] <= 1.5 * ctx.sigma[j] {
            continue;
        }
        let rows = (ctx.gr.rows[j][0] + ctx.gr.rows[j][1]) as f64;
        let (r0, r1) = (rss_joint(&f0, ctx.gr, j, &[0, 1]), rss_joint(&f1, ctx.gr, j, &[0, 1]));
        let above = (r0 - rows * ctx.sigma[j].powi(2)).max(1e-300);
        let share = ((r0 - r1) / above).clamp(0.0, 1.0);
        let mut why = vec![];
        let r = &reg[j];
        if r.rms_reversal.is_finite() && r.rms_reversal > 2.0 * r.rms_rest {
            why.push(format!(
                "concentrated at velocity reversals ({:.3} N m there vs {:.3} elsewhere: friction near zero speed that the friction models describe only roughly)",
                r.rms_reversal, r.rms_rest
            ));
        }
        if share >= 0.5 && smax <= LINK_SCALE_MAX {
            why.push(format!(
                "scaling the nominal link inertials by up to {:.0} % explains {:.0} % of it: the nominal model's own parameters look off (re-identify them: ivdyn identify)",
                100.0 * smax,
                100.0 * share
            ));
        } else if share >= 0.5 {
            why.push(format!(
                "it follows the rigid-body terms (per-link scale factors of the nominal inertials explain {:.0} % of it, with factors up to {:.1}): the nominal inertials are far off (re-identify them: ivdyn identify)",
                100.0 * share,
                1.0 + smax
            ));
        }
        if why.is_empty() {
            why.push("not explained by any effect of the vocabulary".into());
        }
        parts.push(format!(
            "{}: {:.3} N m vs noise {:.3} N m, {}",
            names[j],
            final_rms[j],
            ctx.sigma[j],
            why.join("; ")
        ));
    }
    parts
}

/// Sentences a user understands, from the regimes of the nominal residual and the fit.
fn evidence(st: &Step, params: &Params, names: &[String], reg: &[Regimes], ctx: &Ctx) -> Vec<String> {
    let mut out = vec![];
    let cand = st.candidates.iter().find(|c| c.effect == st.effect);
    for (i, &j) in st.joints.iter().enumerate() {
        let gain = cand.map(|c| c.per_joint[j].heldout_gain).unwrap_or(f64::NAN);
        let tail = format!(
            "on held-out data it removes {:.0} % of the residual that any effect can explain (RMS {:.3} -> {:.3} N m, noise {:.3} N m)",
            100.0 * gain,
            st.rms_before[j],
            st.rms_after[j],
            ctx.sigma[j]
        );
        let s = joint_evidence(st.effect, &names[j], &reg[j], |k| param_at(params, k, i), &tail);
        if !s.is_empty() {
            out.push(s);
        }
    }
    if st.effect == EffectKind::Payload {
        payload_evidence(st, params, names, cand, ctx, &mut out);
    }
    // the look-alikes it beat
    for c in &st.candidates {
        if c.effect != st.effect && !c.joints.is_empty() {
            out.push(format!("{} also explains part of it, {}", c.effect.label(), c.reason));
        }
    }
    out
}

/// Entry `i` of the parameter list `k` (NaN if absent).
fn param_at(params: &Params, k: &str, i: usize) -> f64 {
    params.get(k).and_then(|v| v.get(i)).and_then(|v| v.as_f64()).unwrap_or(f64::NAN)
}

/// The sentence for one joint of a per-joint effect: the regime of the nominal residual
/// that gives the effect away, and its fitted parameters (`get`); empty for a payload.
fn joint_evidence(effect: EffectKind, name: &str, r: &Regimes, get: impl Fn(&str) -> f64, tail: &str) -> String {
    match effect {
        EffectKind::Coulomb => format!(
            "{name}: the residual jumps by {:.3} N m at each of its {} velocity reversals, in the direction of the new velocity: Coulomb friction fc = {:.3} N m; {tail}",
            r.reversal_jump,
            r.reversals,
            get("fc")
        ),
        EffectKind::Stribeck => format!(
            "{name}: near zero velocity the friction rises {:.3} N m above its Coulomb level {:.3} N m and decays within {:.3} rad/s: Stribeck friction; {tail}",
            get("fs"),
            get("fc"),
            get("vs")
        ),
        EffectKind::Viscous => format!(
            "{name}: the residual grows in proportion to the velocity (correlation {:.2}), {:.3} N m per rad/s: viscous friction; {tail}",
            r.corr_qd,
            get("fv")
        ),
        EffectKind::Armature => format!(
            "{name}: the residual follows the acceleration (correlation {:.2}), {:.4} kg m^2: inertia the links do not have, rotor inertia (armature); {tail}",
            r.corr_qdd,
            get("ia")
        ),
        EffectKind::TorqueOffset => format!(
            "{name}: the residual has a constant mean of {:.3} N m at every pose and speed: torque offset; {tail}",
            get("tau0")
        ),
        EffectKind::JointSpring => format!(
            "{name}: the residual grows with the position (correlation {:.2}), {:.3} N m per rad, zero at q = {:.3} rad: joint spring; {tail}",
            r.corr_q,
            get("k"),
            get("q0")
        ),
        EffectKind::Payload => String::new(),
        _ => drive_evidence(effect, name, r, get, tail),
    }
}

/// The sentence for one joint of a real-drive effect.
fn drive_evidence(effect: EffectKind, name: &str, r: &Regimes, get: impl Fn(&str) -> f64, tail: &str) -> String {
    match effect {
        EffectKind::AsymmetricCoulomb => format!(
            "{name}: the friction level depends on the direction of motion: {:.3} N m moving forward, {:.3} N m backward (jump {:.3} N m at its {} reversals): direction-dependent Coulomb friction; {tail}",
            get("fc_pos"),
            get("fc_neg"),
            r.reversal_jump,
            r.reversals
        ),
        EffectKind::SmoothCoulomb => format!(
            "{name}: the friction changes sign smoothly across zero velocity, {:.3} N m reached within about {:.3} rad/s: smooth Coulomb friction fc tanh(qd/vs); {tail}",
            get("fc"),
            get("vs")
        ),
        EffectKind::LoadDependent => format!(
            "{name}: the friction grows with the torque the joint carries, {:.4} N m per N m of load: load-dependent friction; {tail}",
            get("mu")
        ),
        EffectKind::TorqueGain => format!(
            "{name}: the measured torque is the rigid-body torque times {:.4}: a torque-constant (gain) error; {tail}",
            get("k")
        ),
        EffectKind::TorqueRipple => format!(
            "{name}: the residual repeats every {:.3} rad of joint position (amplitude {:.3} N m): torque ripple; {tail}",
            get("period"),
            get("a").hypot(get("b"))
        ),
        EffectKind::TimeDelay => format!(
            "{name}: the measured torque lags the model by {:.2} ms: a torque-to-motion delay; {tail}",
            1e3 * get("delay_s")
        ),
        _ => String::new(),
    }
}

/// A payload's sentences: one rigid body on the last link explains the joints together
/// (mass and centre of mass), then the RMS of each joint it moved above the noise.
fn payload_evidence(
    st: &Step,
    params: &Params,
    names: &[String],
    cand: Option<&CandidateScore>,
    ctx: &Ctx,
    out: &mut Vec<String>,
) {
    let m = params.get("mass").and_then(|v| v.as_f64()).unwrap_or(f64::NAN);
    let com = params
        .get("com")
        .and_then(|v| v.as_array())
        .map(|a| {
            format!(
                "[{}]",
                a.iter().map(|x| format!("{:.4}", x.as_f64().unwrap_or(f64::NAN))).collect::<Vec<_>>().join(", ")
            )
        })
        .unwrap_or_else(|| "(not identifiable)".into());
    let js: Vec<&str> = cand.map(|c| c.joints.iter().map(|&j| names[j].as_str()).collect()).unwrap_or_default();
    let body = if m.is_nan() {
        "a payload, whose mass and centre of mass are not separable from the re-fitted links' inertials (weigh it, or estimate it with `ivdyn payload` on logs before and after it was attached)".to_string()
    } else {
        format!("a payload of {m:.3} kg with its centre of mass at {com} m (terminal link frame)")
    };
    out.push(format!(
        "the residuals of {} follow pose and acceleration together, as the torques of one rigid body on the last link would: {body}",
        js.join(", ")
    ));
    for &j in &st.joints {
        if st.rms_before[j] > 1.5 * ctx.sigma[j] {
            out.push(format!(
                "{}: RMS {:.3} -> {:.3} N m (noise {:.3} N m)",
                names[j], st.rms_before[j], st.rms_after[j], ctx.sigma[j]
            ));
        }
    }
}

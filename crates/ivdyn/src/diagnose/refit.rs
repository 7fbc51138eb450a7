//! The nominal model's own error, re-fitted inside the diagnosis (docs/diagnose.md, "The
//! nominal re-fit"; DESIGN.md's `nominal_refit`).
//!
//! CAD inertials are typically 20-50 % off. A wrong link mass or inertia leaves structure
//! that a payload, an armature, an offset or a spring imitate, and it dilutes the held-out
//! share of a real effect (friction) until nothing is named. So when the log says the
//! rigid-body model is off, the search runs on top of a re-fitted one:
//!
//! * **What is re-fitted**: three scale factors per link on its nominal inertial
//!   parameters, one each for its mass, its first moment (mass times COM) and its
//!   rotational inertia (the torque of each part, `Y_i,g theta_i,g`, as a column, `1 + s`
//!   times it), every link but the terminal one: a change of the terminal link is what a
//!   payload is, and the payload candidate with its own rules (size beyond the CAD
//!   margin, held-out share, look-alike check) decides it.
//! * **Regularised toward the nominal**: a ridge on the scales (unit-diagonal normal
//!   equations), the largest on a grid whose two-fold held-out residual, with friction
//!   on every joint fitted jointly, is within 1 % of the best; grid values that leave a
//!   re-fitted link physically inconsistent are skipped. In a joint fit the ridge leaves
//!   to an effect's (unpenalised) column what it and a scale explain alike (armature on a
//!   vertical first joint and that link's inertia).
//! * **Turned on** when, on top of friction (Coulomb and viscous) on every joint, the
//!   effects a link inertial cannot imitate, it removes on some joint at least
//!   `REFIT_MIN_SHARE` of the held-out residual above the noise, with a torque of at least
//!   `min_effect` noise standard deviations RMS. (No F test: a rigid-body error leaves a
//!   smooth residual whose effective sample count is too small for one; the held-out
//!   test is the validation.) The look-alikes (offset, spring, armature, payload) are not
//!   in that base: they would absorb the error the re-fit is for.
//!
//! The effects are then searched with the re-fit in every model, so a look-alike the
//! re-fit explains on held-out data is not significant, and `effects` keeps only what the
//! model lacks.

use super::dictionary::{C_LINK, Grams, LINK_GROUPS};
use super::model::{Fit, Model, effect_rms, fit, friction_model, rss_joint};
use super::rules::Ctx;
use super::{BaseParamsJson, NominalRefitJson};
use crate::Robot;
use crate::error::Result;

/// Ridges tried (unit-diagonal normal equations: 1 weighs a scale as much as all the
/// data on its column).
const RIDGE_GRID: [f64; 7] = [1e-5, 1e-4, 1e-3, 1e-2, 1e-1, 1.0, 10.0];

/// Share of the held-out residual above the noise (friction in) the re-fit must remove
/// on a joint to be turned on.
const REFIT_MIN_SHARE: f64 = 0.5;

/// A held-out residual within this fraction of the best counts as as good (the largest
/// such ridge, the one closest to the nominal, is kept).
const RIDGE_TOLERANCE: f64 = 0.01;

/// Random states for the base parameters of the report.
const BASE_SAMPLES: usize = 200;

/// The re-fit the search runs on, and why.
#[derive(Debug, Clone)]
pub(super) struct RefitDecision {
    /// Ridge chosen (unit-diagonal normal equations).
    pub(super) ridge: f64,
    /// Share of the held-out residual above the noise it removes per joint (friction in).
    pub(super) share: Vec<f64>,
    /// Joints where it is significant.
    pub(super) joints: Vec<usize>,
}

/// The scales of a fit's link-scale parameters: (link, part of `LINK_GROUPS`, scale).
pub(super) fn link_scales(f: &Fit) -> Vec<(usize, usize, f64)> {
    let g = LINK_GROUPS.len();
    f.params
        .iter()
        .zip(&f.theta)
        .filter(|(p, _)| p.kind.is_none())
        .map(|(p, &v)| ((p.col - C_LINK) / g, (p.col - C_LINK) % g, v))
        .collect()
}

/// The nominal inertial parameters with each link's parts scaled by `1 + s`.
fn scaled(nominal: &[f64], scales: &[(usize, usize, f64)]) -> Vec<f64> {
    let mut theta = nominal.to_vec();
    for &(i, g, s) in scales {
        let (lo, hi) = LINK_GROUPS[g];
        for v in &mut theta[10 * i + lo..10 * i + hi] {
            *v *= 1.0 + s;
        }
    }
    theta
}

/// Whether every re-fitted link of `theta` is physically consistent (positive mass,
/// inertia about the COM positive definite with the triangle inequalities).
fn consistent(theta: &[f64], scales: &[(usize, usize, f64)]) -> bool {
    scales.iter().all(|&(i, _, _)| {
        let p: [f64; 10] = theta[10 * i..10 * i + 10].try_into().expect("10 parameters");
        ivdyn_core::LinkInertia(p).is_physically_consistent(0.0)
    })
}

/// Weighted held-out RSS (both folds) of the model `m`, and its scales fitted on all data.
fn heldout(ctx: &Ctx, gr: &Grams, m: &Model) -> (f64, Vec<(usize, usize, f64)>) {
    let ps = m.params();
    let (f0, f1) = (fit(&ps, gr, &ctx.w, &[0]), fit(&ps, gr, &ctx.w, &[1]));
    let h = (0..ctx.n).map(|j| ctx.w[j] * (rss_joint(&f0, gr, j, &[1]) + rss_joint(&f1, gr, j, &[0]))).sum();
    (h, link_scales(&fit(&ps, gr, &ctx.w, &[0, 1])))
}

/// The ridge of the re-fit on top of friction (module docs), or `None` when no grid value
/// keeps every link physically consistent.
fn choose_ridge(ctx: &Ctx, with: &Model, nominal: &[f64]) -> Option<f64> {
    let mut tried = vec![];
    for &ridge in &RIDGE_GRID {
        let mut gr = ctx.gr.clone();
        gr.ridge = ridge;
        let (h, scales) = heldout(ctx, &gr, with);
        if consistent(&scaled(nominal, &scales), &scales) {
            tried.push((ridge, h));
        }
    }
    let best = tried.iter().map(|x| x.1).fold(f64::INFINITY, f64::min);
    tried
        .iter()
        .filter(|x| x.1 <= best * (1.0 + RIDGE_TOLERANCE))
        .map(|x| x.0)
        .fold(None, |a, r| Some(a.map_or(r, |a: f64| a.max(r))))
}

/// Whether the log calls for the re-fit, and with which ridge (module docs).
pub(super) fn decide(ctx: &Ctx, robot: &Robot) -> Option<RefitDecision> {
    let n = ctx.n;
    if n < 2 {
        return None; // one link: its change is a payload's business
    }
    let base = friction_model(n);
    let mut with = base.clone();
    with.refit = true;
    let ridge = choose_ridge(ctx, &with, &robot.params())?;
    let mut gr = ctx.gr.clone();
    gr.ridge = ridge;
    let (pb, pw) = (base.params(), with.params());
    let f_all = fit(&pw, &gr, &ctx.w, &[0, 1]);
    let mut share = vec![0.0; n];
    let mut joints = vec![];
    for (j, sh) in share.iter_mut().enumerate() {
        let (mut h0, mut h1) = (0.0, 0.0);
        for (train, test) in [(0usize, 1usize), (1, 0)] {
            h0 += rss_joint(&fit(&pb, &gr, &ctx.w, &[train]), &gr, j, &[test]);
            h1 += rss_joint(&fit(&pw, &gr, &ctx.w, &[train]), &gr, j, &[test]);
        }
        let rows = (gr.rows[j][0] + gr.rows[j][1]) as f64;
        let above = h0 - rows * ctx.sigma[j].powi(2);
        *sh = if above > 0.0 { (h0 - h1) / above } else { 0.0 };
        let size = effect_rms(&f_all, &gr, j, &|p| p.kind.is_none());
        if *sh >= REFIT_MIN_SHARE && size >= ctx.opts.min_effect * ctx.sigma[j] {
            joints.push(j);
        }
    }
    if joints.is_empty() { None } else { Some(RefitDecision { ridge, share, joints }) }
}

/// `nominal_refit` of `diagnosis.json`: the base parameters of the nominal model and of
/// the re-fitted one (the final fit's scales), the RMS before and after the re-fit alone
/// (`rms_after`: the nominal residual minus the re-fit's part of the final fit), and why.
pub(super) fn report(
    robot: &Robot,
    dec: &RefitDecision,
    f: &Fit,
    rms_before: Vec<f64>,
    rms_after: Vec<f64>,
    names: &[String],
) -> Result<NominalRefitJson> {
    let scales = link_scales(f);
    let nominal = robot.params();
    let theta = scaled(&nominal, &scales);
    let bp = crate::ident::base::robot_base_params_with(robot, BASE_SAMPLES, 15, true)?;
    // the rigid-body base parameters are over the 10 N inertial parameters only
    let k = bp.full_cols.min(theta.len());
    let base_params = BaseParamsJson {
        names: bp.names.clone(),
        nominal: bp.project(&nominal[..k])?,
        values: bp.project(&theta[..k])?,
    };
    let (worst, part, s) =
        scales.iter().copied().fold((0usize, 0usize, 0.0f64), |a, x| if x.2.abs() > a.2.abs() { x } else { a });
    let link = robot.link_names.get(worst).cloned().unwrap_or_else(|| format!("link {}", worst + 1));
    let part = ["mass", "first moment (mass x COM)", "rotational inertia"][part];
    let on: Vec<String> =
        dec.joints.iter().map(|&j| format!("{} ({:.0} %)", names[j], 100.0 * dec.share[j].min(1.0))).collect();
    let why = format!(
        "the nominal rigid-body model is off: on top of friction on every joint, per-link scale factors of the nominal inertials (all links but the terminal one, ridge {:.0e} toward the nominal chosen on held-out data) still remove this share of the held-out residual above the noise on {}; largest change: {link} {part} x{:.2}",
        dec.ridge,
        on.join(", "),
        1.0 + s
    );
    Ok(NominalRefitJson { base_params, rms_before, rms_after, why })
}

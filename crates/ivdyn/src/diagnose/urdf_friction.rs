//! The URDF's joint friction, checked against the log rather than taken as known
//! (docs/diagnose.md, "The URDF's friction").
//!
//! A URDF's `<dynamics friction damping>` (loaded as each joint's `fc` and `fv`) is most
//! often a simulator's placeholder; on the LWR4+ data set's URDF (0.2-0.8 N m, 0.2-1.2 N m
//! s/rad) it stood in the nominal torque, the friction the log has came out as corrections
//! of the wrong sign (rule 4 rejects them), and no friction was named. So the search runs on
//! the rigid-body model alone, friction found is reported at its own level, and afterwards
//! each named Coulomb or viscous friction the URDF already holds (its value within
//! `URDF_MARGIN` of the named one, or two standard errors) is taken out of `effects`: the
//! model does not lack it. The details give the URDF's values beside the log's.

use super::EffectJson;
use super::EffectKind;
use crate::Robot;
use crate::error::Result;
use ivdyn_core::params::{FC, FV, drive_col};

/// Relative difference within which the URDF's friction level counts as the named one (the
/// prior's CAD margin of the re-fit, `model::PRIOR_C`: a level known to about 30 %).
const URDF_MARGIN: f64 = 0.3;

/// The URDF's Coulomb and viscous friction per joint (`fc`, `fv`).
pub(super) fn of(robot: &Robot) -> Vec<(f64, f64)> {
    let (n, theta) = (robot.dof(), robot.params());
    (0..n).map(|j| (theta[drive_col(n, j, FC)], theta[drive_col(n, j, FV)])).collect()
}

/// `robot` without its joints' Coulomb and viscous friction (its armature and offset kept).
pub(super) fn without(robot: &Robot) -> Result<Robot> {
    let (n, mut theta) = (robot.dof(), robot.params());
    for j in 0..n {
        theta[drive_col(n, j, FC)] = 0.0;
        theta[drive_col(n, j, FV)] = 0.0;
    }
    let mut rigid = robot.clone();
    rigid.set_params(&theta)?;
    Ok(rigid)
}

/// The (effect, joint) of `effects` whose level the URDF holds (module docs), and the
/// details: per joint with URDF friction, its values beside the log's.
pub(super) fn held(
    effects: &[EffectJson],
    urdf: &[(f64, f64)],
    names: &[String],
) -> (Vec<(EffectKind, usize)>, Vec<String>) {
    let (mut held, mut details) = (vec![], vec![]);
    for (j, &(fc_u, fv_u)) in urdf.iter().enumerate().filter(|(_, f)| f.0 != 0.0 || f.1 != 0.0) {
        let mut said = vec![];
        for (kind, key, urdf_level) in [(EffectKind::Coulomb, "fc", fc_u), (EffectKind::Viscous, "fv", fv_u)] {
            let Some((v, sd)) = level(effects, kind, key, &names[j]) else {
                said.push(shaped(effects, kind, &names[j]));
                continue;
            };
            let holds = (v - urdf_level).abs() <= (URDF_MARGIN * v.abs().max(urdf_level.abs())).max(2.0 * sd);
            if holds {
                held.push((kind, j));
            }
            let verb = if holds { "holds it" } else { "is off" };
            said.push(format!("{key} {v:.3} ± {:.3} (the URDF's {urdf_level:.3} {verb})", 2.0 * sd));
        }
        details.push(format!(
            "URDF friction on {} (fc {fc_u:.3} N m, fv {fv_u:.3} N m s/rad) checked against the log, not taken as known: {}",
            names[j],
            said.join(", ")
        ));
    }
    (held, details)
}

/// The named level of `kind`'s parameter `key` on joint `name`, with its standard error (0
/// when there is none).
fn level(effects: &[EffectJson], kind: EffectKind, key: &str, name: &str) -> Option<(f64, f64)> {
    let e = effects.iter().find(|e| e.name == kind.name())?;
    let i = e.joints.iter().position(|x| x == name)?;
    let v = e.parameters.get(key)?.as_array()?.get(i)?.as_f64()?;
    let sd = e.parameters_std.get(key).and_then(|s| s.as_array()?.get(i)?.as_f64()).unwrap_or(0.0);
    Some((v, sd))
}

/// What the log says of `kind` on joint `name` when it is not named: a refined Coulomb
/// friction (direction-dependent, smooth, Stribeck), which the URDF's `fc` cannot hold, or none.
fn shaped(effects: &[EffectJson], kind: EffectKind, name: &str) -> String {
    let refined = [EffectKind::AsymmetricCoulomb, EffectKind::SmoothCoulomb, EffectKind::Stribeck];
    let on = |e: &EffectKind| effects.iter().any(|x| x.name == e.name() && x.joints.iter().any(|j| j == name));
    match refined.iter().find(|e| kind == EffectKind::Coulomb && on(e)) {
        Some(e) => format!("{} named (a shape the URDF's fc cannot hold)", e.label()),
        None => format!("no {} named", kind.label()),
    }
}

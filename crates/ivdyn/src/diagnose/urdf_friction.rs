//! A URDF's joint friction the log contradicts outright (docs/diagnose.md, "The URDF's
//! friction").
//!
//! A URDF's `<dynamics friction damping>` (each joint's `fc`, `fv`) is part of the nominal
//! torque, so what the search names there is the change of friction against the model (the
//! fleet's contract: an arm's friction rise against its own identified model). But URDF
//! friction is often a simulator's placeholder: on the LWR4+ data set's URDF (0.05-0.8 N m,
//! 0.2-1.2 N m s/rad) the change the log calls for is negative and larger than the URDF's
//! level, which rule 4 rejects, and no friction was named. When that happens on some joint
//! (a Coulomb or viscous change that passes every rule but its sign, with a total level, URDF
//! plus change, below the size rule's `min_effect` noise std), the URDF's friction is not the
//! joint's, and the diagnosis is redone on the model without the URDF's friction; a detail
//! says so and why.

use super::EffectKind;
use super::dictionary::{C_QD, C_SIGN};
use super::model::{Fit, Model, Param, effect_rms, fit};
use super::score::Ctx;
use crate::Robot;
use crate::error::Result;
use ivdyn_core::params::{FC, FV, drive_col};

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

/// Why the log contradicts the URDF's friction outright on the final model `m` (module
/// docs), in words with the numbers; `None` when it does not (or the URDF has none).
pub(super) fn contradicted(ctx: &Ctx, m: &Model, urdf: &[(f64, f64)], names: &[String]) -> Option<String> {
    for (j, &(fc, fv)) in urdf.iter().enumerate() {
        for (kind, col, level, unit) in
            [(EffectKind::Coulomb, C_SIGN, fc, "N m"), (EffectKind::Viscous, C_QD, fv, "N m s/rad")]
        {
            if level <= 0.0 || m.has(j, kind) {
                continue;
            }
            let l = m.with(Some(j), kind);
            let sel = |p: &Param| p.joint == Some(j) && p.kind == Some(kind);
            let sc = ctx.joint_score(m, &l, j, &sel);
            if !sc.rejected_by.as_deref().is_some_and(|r| r.starts_with("sign")) {
                continue;
            }
            let f = fit(&l.params(), ctx.gr, &ctx.w, &[0, 1]);
            let change = f.params.iter().zip(&f.theta).find(|(p, _)| sel(p) && p.col == col).map_or(0.0, |x| *x.1);
            let total = level + change;
            let at = Fit { params: vec![Param { kind: Some(kind), joint: Some(j), col }], theta: vec![total.max(0.0)] };
            if effect_rms(&at, ctx.gr, j, &|_| true) < ctx.opts.min_effect * ctx.sigma[j] {
                return Some(format!(
                    "the URDF's friction is not the log's: on {} its {} {level:.3} {unit} would need a change of {change:.3} (every rule passed but the sign), a total of {total:.3}, below the noise; the diagnosis is of the model without the URDF's joint friction and damping (`<dynamics>`), the friction named is the log's own",
                    names[j],
                    kind.label()
                ));
            }
        }
    }
    None
}

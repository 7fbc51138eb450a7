//! The grid shapes chosen again once the model has grown (smooth friction's `vs`, a ripple's
//! harmonic).
//!
//! A grid effect's shape is chosen at the step that adds it, by the held-out share against
//! the model of that step. An effect found later, on its joint or on another (the re-fit
//! couples them), changes what that choice should have been, and a shape left at its first
//! choice leaves structure that a later effect is then named for. So the backward step first
//! chooses every grid shape again, each on the held-out residual of the whole model
//! (`Ctx::heldout_rss`, the criterion `swap` compares shapes by), and what the model stopped
//! needing then goes. (On the wide-motion random set, session 29: a smooth friction added at
//! `vs` 20 % of its joint's RMS speed, re-chosen at 30 % once direction-dependent friction and
//! a gain were in, and the viscous friction named beside it to make up the slope went; tuning
//! part 58 -> 59 of 96 right, extra 41 -> 37, parameters within 10 % 197 -> 205 of 270; on the
//! friction-everywhere set 17 -> 18 of 48 right, extra 38 -> 36, 200 -> 204 of 268; on the
//! CAD set 64 -> 65 of 80 parameters; the other sets unchanged.)

use super::EffectKind;
use super::dictionary::SMOOTH_VS;
use super::drive_rules::{grid, with_shape};
use super::model::Model;
use super::score::Ctx;

/// The effects with a shape on a grid, and their current grid entry on joint `j`.
fn shape_of(m: &Model, e: EffectKind, j: usize) -> usize {
    match e {
        EffectKind::SmoothCoulomb => m.smooth_vs[j],
        _ => m.ripple_n[j],
    }
}

/// The shape in words (for the note), on joint `j`.
fn label(ctx: &Ctx, e: EffectKind, j: usize, g: usize) -> String {
    match e {
        EffectKind::SmoothCoulomb => format!("vs {:.0} % of the joint's RMS speed", 100.0 * SMOOTH_VS[g]),
        _ => format!("period {:.3} rad", std::f64::consts::TAU / ctx.ripple_h[j][g]),
    }
}

/// `m` with each grid shape at the entry leaving the least held-out residual given the rest
/// of `m`, joint by joint; a note for each one changed.
pub(super) fn regrid(ctx: &Ctx, m: &Model) -> (Model, Vec<String>) {
    let mut m = m.clone();
    let mut notes = vec![];
    for j in 0..ctx.n {
        for e in [EffectKind::SmoothCoulomb, EffectKind::TorqueRipple] {
            if !m.has(j, e) {
                continue;
            }
            let now = shape_of(&m, e, j);
            let h_now = ctx.heldout_rss(&m);
            let best = grid(ctx, e, j)
                .into_iter()
                .filter(|&g| g != now)
                .map(|g| (ctx.heldout_rss(&with_shape(&m, e, j, g)), g))
                .min_by(|a, b| a.0.total_cmp(&b.0));
            if let Some((h, g)) = best.filter(|b| b.0 < h_now) {
                notes.push(format!(
                    "{} on joint {}: {} chosen again once the later effects were in ({} when it was added), the held-out residual {:.1} % lower",
                    e.label(),
                    j + 1,
                    label(ctx, e, j, g),
                    label(ctx, e, j, now),
                    100.0 * (1.0 - h / h_now)
                ));
                m = with_shape(&m, e, j, g);
            }
        }
    }
    (m, notes)
}

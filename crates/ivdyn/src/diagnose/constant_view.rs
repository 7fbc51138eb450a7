//! What the log shows of a constant torque beside the nominal re-fit (docs/diagnose.md, "What
//! the log can tell").
//!
//! On a joint that sweeps little, a constant torque on it (a torque offset, or the part of a
//! friction that differs with the direction while the joint moves) is mostly a change of the
//! links' base parameters: gravity's torque over a short arc is nearly constant, and the
//! re-fit holds such a change. No rule can then tell the two apart, so the details say, per
//! joint, how much of a constant the log shows beside the re-fit and how large an offset or
//! an asymmetry of friction would have to be to show the `SEEN` noise std a candidate needs:
//! the user's next log can sweep that joint wider. (On the 5-12 s tuning parts, default and
//! wide motion and CAD arms, of the true offsets and direction-dependent frictions leaving
//! under 1 noise std beside the rigid-body columns, 12 of 55 were found; at 2 or more, 43 of
//! 47: `python/tools/lookalike_identifiability.py`.)

use super::dictionary::{C_BASE, C_ONE};
use super::score::Ctx;
use nalgebra::{DMatrix, DVector};

/// Share of a constant's RMS left beside the re-fit below which a joint is listed.
const SHOWN_MAX: f64 = 0.25;

/// Noise standard deviations of RMS a constant must leave beside the re-fit to be seen (the
/// order of the size rules; docs/diagnose.md).
const SEEN: f64 = 2.0;

/// Per joint, the share of a constant torque's RMS that the re-fit's base columns leave over
/// this log (weighted least squares over all joints' rows, no ridge: the data's own view).
fn shown(ctx: &Ctx, nbase: usize) -> Vec<f64> {
    let sum = |i: usize, a: usize, b: usize| ctx.gr.g[i][0][(a, b)] + ctx.gr.g[i][1][(a, b)];
    let bb = DMatrix::from_fn(nbase, nbase, |a, b| {
        (0..ctx.n).map(|i| ctx.w[i] * sum(i, C_BASE + a, C_BASE + b)).sum::<f64>()
    });
    let svd = bb.svd(true, true);
    let eps = 1e-12 * svd.singular_values.max();
    (0..ctx.n)
        .map(|j| {
            let cc = ctx.w[j] * sum(j, C_ONE, C_ONE);
            let cb = DVector::from_fn(nbase, |b, _| ctx.w[j] * sum(j, C_ONE, C_BASE + b));
            let spanned = svd.solve(&cb, eps).map_or(0.0, |x| cb.dot(&x));
            if cc > 0.0 { ((cc - spanned) / cc).max(0.0).sqrt() } else { 1.0 }
        })
        .collect()
}

/// The detail listing the joints where a constant shows less than `SHOWN_MAX` of its size
/// beside the re-fit, each with its sweep and the smallest offset it would show; `None` when
/// there is none.
pub(super) fn note(ctx: &Ctx, nbase: usize, names: &[String]) -> Option<String> {
    let shown = shown(ctx, nbase);
    let joints: Vec<String> = (0..ctx.n)
        .filter(|&j| shown[j] < SHOWN_MAX)
        .map(|j| {
            let limit = SEEN * ctx.sigma[j] / shown[j].max(1e-12);
            format!(
                "{} (sweeps {:.2} rad; a constant shows {:.1} % of its size: offsets under {:.3} N m, friction levels differing by under {:.3} N m between the directions)",
                names[j],
                ctx.q_span[j],
                100.0 * shown[j],
                limit,
                2.0 * limit
            )
        })
        .collect();
    (!joints.is_empty()).then(|| {
        format!(
            "offsets and direction-dependent friction are not told from the re-fitted inertials on these joints (over their sweep a constant torque is mostly a change of the links' base parameters; a candidate needs {SEEN} noise std left beside it): {}; a log sweeping them wider tells them apart",
            joints.join(", ")
        )
    })
}

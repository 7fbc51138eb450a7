//! What the log shows of a constant torque beside the nominal re-fit (docs/diagnose.md, "What
//! the log can tell").
//!
//! On a joint that sweeps little, a constant torque on it (a torque offset, or the part of a
//! friction that differs with the direction while the joint moves) is mostly a change of the
//! links' base parameters: gravity's torque over a short arc is nearly constant, and the
//! re-fit holds such a change. No rule can then tell the two apart, so the details say, per
//! joint, how much of a constant the log shows beside the re-fit and how large an offset or
//! an asymmetry of friction would have to be to show the 2 noise std a candidate needs
//! (`detectable`, which measures it for every look-alike):
//! the user's next log can sweep that joint wider. (On the 5-12 s tuning parts, default and
//! wide motion and CAD arms, of the true offsets and direction-dependent frictions leaving
//! under 1 noise std beside the rigid-body columns, 12 of 55 were found; at 2 or more, 43 of
//! 47: `python/tools/lookalike_identifiability.py`.)

use super::DetectableJson;

/// Share of a constant's RMS left beside the re-fit below which a joint is listed.
const SHOWN_MAX: f64 = 0.25;

/// The detail listing the joints where a constant shows less than `SHOWN_MAX` of its size
/// beside the re-fit's columns (`detectable`: the smallest offset `d` shows
/// `noise_std sigma` RMS, so a constant shows `noise_std sigma / d` of its size), each with
/// its sweep `q_span` and the smallest offset and asymmetry of friction the log would show;
/// `None` when there is none.
pub(super) fn note(det: &DetectableJson, q_span: &[f64], names: &[String]) -> Option<String> {
    let limit = |v: &[Option<f64>], j: usize| v.get(j).copied().flatten().unwrap_or(f64::INFINITY);
    let joints: Vec<String> = (0..names.len())
        .filter_map(|j| {
            let offset = limit(&det.torque_offset, j);
            let shown = det.noise_std * det.sigma[j] / offset;
            (shown < SHOWN_MAX).then(|| {
                if !offset.is_finite() {
                    return format!("{} (sweeps {:.2} rad; a constant does not show at all)", names[j], q_span[j]);
                }
                format!(
                    "{} (sweeps {:.2} rad; a constant shows {:.1} % of its size: offsets under {:.3} N m, friction levels differing by under {:.3} N m between the directions)",
                    names[j],
                    q_span[j],
                    100.0 * shown,
                    offset,
                    limit(&det.asymmetric_coulomb_friction, j)
                )
            })
        })
        .collect();
    (!joints.is_empty()).then(|| {
        format!(
            "offsets and direction-dependent friction are not told from the re-fitted inertials on these joints (over their sweep a constant torque is mostly a change of the links' base parameters; a candidate needs {} noise std left beside it): {}; a log sweeping them wider tells them apart (`ivdyn excite` designs one within the joint limits)",
            det.noise_std,
            joints.join(", ")
        )
    })
}

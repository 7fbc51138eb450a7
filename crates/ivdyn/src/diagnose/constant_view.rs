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
//!
//! With the re-fit off, the look-alikes of the decision base (an offset explaining a joint's
//! held-out residual as well as the re-fit) can be named at sizes the log does not show
//! beside the links' inertials: the nominal model's own error over a short sweep makes the
//! same torque (a random arm with inertials 5 % off, 0.41 rad on its second joint: an
//! offset of 0.497 N m named where only 14.9 N m would show). Those are listed with their
//! sizes (`unrefitted_note`), so that a user with a CAD model knows which to doubt.

use super::{DetectableJson, EffectJson};

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

/// With the re-fit off, the named torque offsets and direction-dependent frictions whose
/// constant is below what the log shows beside the links' base parameters (`detectable`:
/// an offset under `torque_offset[j]`, levels differing by under
/// `asymmetric_coulomb_friction[j]`): the nominal model's own error makes the same torque
/// over such a sweep, and only the model without the re-fit gave it to the look-alike.
/// `None` when there is none.
pub(super) fn unrefitted_note(
    det: &DetectableJson,
    q_span: &[f64],
    names: &[String],
    effects: &[EffectJson],
) -> Option<String> {
    let limit = |v: &[Option<f64>], j: usize| v.get(j).copied().flatten().unwrap_or(f64::INFINITY);
    let mut listed = vec![];
    for e in effects {
        for (i, jn) in e.joints.iter().enumerate() {
            let Some(j) = names.iter().position(|n| n == jn) else { continue };
            let value = |key: &str| e.parameters.get(key).and_then(|v| v.get(i)).and_then(|v| v.as_f64());
            let (what, size, below) = match e.name.as_str() {
                "torque_offset" => ("torque offset", value("tau0").map(f64::abs), limit(&det.torque_offset, j)),
                "asymmetric_coulomb_friction" => (
                    "direction dependence of friction",
                    value("fc_pos").zip(value("fc_neg")).map(|(a, b)| (a - b).abs()),
                    limit(&det.asymmetric_coulomb_friction, j),
                ),
                _ => continue,
            };
            if let Some(size) = size.filter(|s| *s < below) {
                let shows = if below.is_finite() {
                    format!("a constant shows beside the links' inertials from {below:.3} N m")
                } else {
                    "a constant does not show beside the links' inertials at all".into()
                };
                listed.push(format!("{what} {size:.3} N m on {jn} (it sweeps {:.2} rad; {shows})", q_span[j]));
            }
        }
    }
    (!listed.is_empty()).then(|| {
        format!(
            "the nominal model was not re-fitted, and a change of its inertials makes the same torque as these constants over their joints' sweeps: {}; they may be the CAD model's error instead (a log sweeping those joints wider tells them apart: `ivdyn excite` designs one within the joint limits)",
            listed.join(", ")
        )
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use serde_json::json;

    fn effect(name: &str, joints: &[&str], parameters: serde_json::Value) -> EffectJson {
        EffectJson {
            name: name.into(),
            joints: joints.iter().map(|j| j.to_string()).collect(),
            parameters: parameters.as_object().unwrap().clone(),
            parameters_std: Default::default(),
            rms_before: vec![],
            rms_after: vec![],
        }
    }

    /// Listed: a constant below what its joint's sweep shows beside the links (`detectable`'s
    /// sizes; `null`: nothing shows); not listed: one above it, and the effects that are not
    /// constants.
    #[test]
    fn a_named_constant_below_what_the_sweep_shows_is_flagged() {
        let names: Vec<String> = ["j1", "j2", "j3"].iter().map(|s| s.to_string()).collect();
        let det = DetectableJson {
            noise_std: 2.0,
            sigma: vec![0.1; 3],
            torque_offset: vec![Some(14.9), Some(0.3), None],
            asymmetric_coulomb_friction: vec![Some(29.8), Some(0.6), None],
            joint_spring: vec![None; 3],
            torque_gain: vec![None; 3],
            armature: vec![None; 3],
        };
        let effects = [
            effect("torque_offset", &["j1", "j2", "j3"], json!({"tau0": [-0.5, 0.5, 0.5]})),
            effect("asymmetric_coulomb_friction", &["j1", "j2"], json!({"fc_pos": [0.4, 0.9], "fc_neg": [0.2, 0.1]})),
            effect("viscous_friction", &["j1"], json!({"fv": [1.0]})),
        ];
        let note = unrefitted_note(&det, &[0.41, 2.0, 3.0], &names, &effects).unwrap();
        assert!(note.contains("torque offset 0.500 N m on j1 (it sweeps 0.41 rad"), "{note}");
        assert!(note.contains("direction dependence of friction 0.200 N m on j1"), "{note}");
        assert!(note.contains("torque offset 0.500 N m on j3 (it sweeps 3.00 rad; a constant does not show"), "{note}");
        assert!(!note.contains("on j2") && !note.contains("viscous"), "{note}");
        let shown = [effect("asymmetric_coulomb_friction", &["j2"], json!({"fc_pos": [0.9], "fc_neg": [0.1]}))];
        assert!(unrefitted_note(&det, &[0.41, 2.0, 3.0], &names, &shown).is_none());
    }
}

//! What the log can tell from the links' inertials: per joint, the smallest look-alike
//! (offset, direction dependence of friction, spring, torque gain, armature) whose torque
//! beyond what the re-fitted links can make reaches `DETECTABLE_NOISE_STD` noise standard
//! deviations RMS (docs/diagnose.md, "What the log can show").
//!
//! Each of these effects adds a column that a change of the links' inertials spans in part:
//! over a short sweep a constant on a gravity-loaded joint is a change of a link's first
//! moment, `tau_nom` is the links' own torque, `qdd` a link's inertia about the axis. An
//! effect whose part outside the base regressor's columns (eqs 11-13 of the paper, the
//! links before the terminal one, as the nominal re-fit has them) stays below the noise
//! cannot be named from the log by any method: the CAD error it would have to be told from
//! is as likely. The smallest size of each that clears it is the log's own statement of
//! what a wider or longer motion would add. (On the generated sets, true look-alikes with
//! that part at least 2 noise std were found in 70-100 % of cases, below 1 in 0-30 %.)

use super::DetectableJson;
use super::EffectKind;
use super::dictionary::{C_BASE, C_GAIN, C_ONE, C_Q, C_QDD, C_SIGN, C_SIGN_POS, Grams};
use super::model::rms_beyond;

/// The RMS, in the joint's noise standard deviations, an effect's torque beyond the
/// re-fitted links must reach to count as shown by the log.
pub const DETECTABLE_NOISE_STD: f64 = 2.0;

/// The look-alikes, each with its torque per unit parameter on its joint as columns
/// `(coefficient, column)`: offset `tau0`; the difference `fc_pos - fc_neg` of
/// direction-dependent friction, `(fc_pos - fc_neg) / 2 [qd != 0]` beside its Coulomb part
/// (`[qd != 0] = 2 [qd > 0] - sign(qd)`); spring `k` (its `q0` free: an offset beside it);
/// gain `k - 1`, `(k - 1) tau_nom`; armature `ia`.
const LOOKALIKES: [(EffectKind, &[(f64, usize)]); 5] = [
    (EffectKind::TorqueOffset, &[(1.0, C_ONE)]),
    (EffectKind::AsymmetricCoulomb, &[(1.0, C_SIGN_POS), (-0.5, C_SIGN)]),
    (EffectKind::JointSpring, &[(1.0, C_Q)]),
    (EffectKind::TorqueGain, &[(1.0, C_GAIN)]),
    (EffectKind::Armature, &[(1.0, C_QDD)]),
];

/// Smallest size per look-alike and joint the log shows (`None`: none of it, its column
/// within the links' span or zero on the log), against the noise `sigma`, with the `nbase`
/// base columns of the links before the terminal one.
pub(super) fn detectable(gr: &Grams, nbase: usize, sigma: &[f64]) -> DetectableJson {
    let n = sigma.len();
    let links: Vec<(usize, Option<usize>)> = (C_BASE..C_BASE + nbase).map(|c| (c, None)).collect();
    let smallest = |kind: EffectKind, cols: &[(f64, usize)], j: usize| -> Option<f64> {
        let own: Vec<(f64, usize, Option<usize>)> = cols.iter().map(|&(t, c)| (t, c, Some(j))).collect();
        let mut absorb = links.clone();
        if kind == EffectKind::JointSpring {
            absorb.push((C_ONE, Some(j)));
        }
        let whole = rms_beyond(gr, &own, &[], j);
        let left = rms_beyond(gr, &own, &absorb, j);
        // a column the links hold to rounding shows nothing
        (left > 1e-6 * whole && left > 0.0).then(|| DETECTABLE_NOISE_STD * sigma[j] / left)
    };
    let per_joint = |kind: EffectKind, cols: &[(f64, usize)]| -> Vec<Option<f64>> {
        (0..n).map(|j| smallest(kind, cols, j)).collect()
    };
    let mut v = LOOKALIKES.iter().map(|(k, c)| per_joint(*k, c));
    DetectableJson {
        noise_std: DETECTABLE_NOISE_STD,
        sigma: sigma.to_vec(),
        torque_offset: v.next().unwrap_or_default(),
        asymmetric_coulomb_friction: v.next().unwrap_or_default(),
        joint_spring: v.next().unwrap_or_default(),
        torque_gain: v.next().unwrap_or_default(),
        armature: v.next().unwrap_or_default(),
    }
}

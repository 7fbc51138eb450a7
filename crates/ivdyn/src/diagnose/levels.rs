//! Coulomb friction's levels as reported, read where the joint moves.
//!
//! A joint that reverses sticks for a while: its velocity is (nearly) zero and the friction
//! there is static, whatever balances the drive's torque within `[-fc, fc]`, not `fc
//! sign(qd)`. The search's `sign(qd)` column takes those samples at their noisy sign, which
//! is what a stick phase looks like to every friction column alike and changes no name; but
//! the level it fits is pulled toward the static torques' mean, i.e. low (the random tuning
//! part: every one of 12 Coulomb frictions named was 2-14 % below truth). The reported
//! levels are therefore re-read on the samples where the joint moves, against what the
//! final fit leaves for them (docs/diagnose.md, "Friction levels where the joint moves").

use super::EffectKind;
use super::dictionary::{C_QD, C_SIGN, C_SIGN_POS, Dictionary, moving};
use super::drive_rules::fitted_torque_and_rest;
use super::model::Fit;

/// Coulomb friction's `fc` on joint `j`, or direction-dependent friction's `(fc_neg,
/// fc_pos)` (`asymmetric`), from what the final fit `f` leaves for them on the moving
/// samples (and above `band`, the speed below which the friction was read as a soft stick
/// phase, `stick`); `None` when too few move to read them.
pub(super) fn coulomb_levels(f: &Fit, d: &Dictionary, j: usize, asymmetric: bool, band: f64) -> Option<(f64, f64)> {
    let kinds = [EffectKind::Coulomb, EffectKind::AsymmetricCoulomb];
    let (_, y, _) = fitted_torque_and_rest(f, d, j, &kinds);
    let (sg, pos) = (&d.cols[j][C_SIGN], &d.cols[j][C_SIGN_POS]);
    // normal equations of y ~ a sign + b [qd > 0] (b = 0 for plain Coulomb friction)
    let (mut s, mut t) = ([[0.0; 2]; 2], [0.0; 2]);
    let qd = &d.cols[j][C_QD];
    for k in moving(d, j).iter().enumerate().filter(|&(k, m)| *m && qd[k].abs() > band).map(|(k, _)| k) {
        let x = [sg[k], if asymmetric { pos[k] } else { 0.0 }];
        for a in 0..2 {
            t[a] += x[a] * y[k];
            for b in 0..2 {
                s[a][b] += x[a] * x[b];
            }
        }
    }
    if !asymmetric {
        return (s[0][0] > 0.0).then(|| (t[0] / s[0][0], t[0] / s[0][0]));
    }
    let det = s[0][0] * s[1][1] - s[0][1] * s[1][0];
    if det.abs() <= 1e-12 * s[0][0] * s[1][1] {
        return None;
    }
    let a = (t[0] * s[1][1] - t[1] * s[0][1]) / det;
    let b = (s[0][0] * t[1] - s[1][0] * t[0]) / det;
    Some((a, a + b))
}

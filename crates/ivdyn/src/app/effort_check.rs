//! A joint whose logged effort is not its torque in N m, checked on the fit's rows before
//! `identify` fits them (in memory, streamed, fleet): its sign reversed ([`sign`]) or its
//! unit another ([`units`]).
//!
//! **Sign** (a driver's sign convention, a motor wired the other way), told by the data
//! alone. The links' parameters are shared by the rows of every joint at or before them, so
//! one joint's torque reversed cannot be fitted without spoiling the others' (only a joint's
//! own friction and offset, and the parameters of the terminal link that no other row sees,
//! are its row's alone). Of the least-squares fits with each joint's torque negated in turn
//! ([`JointAccs::negated_fits`]), the one that leaves every joint's residual nearest its
//! lowest names the reversed joint. Unlike `diagnose`'s check on the nominal torque,
//! nothing here trusts the URDF's inertials, which `identify` is there to replace, and the
//! terminal joint is checked too. With `--coulomb auto` (the in-memory default) the check
//! runs first on the rows with `sign(qd)`, before each joint's Coulomb shape is chosen: the
//! choice, scored by fits a reversed joint spoils, picked shapes that hid the reversal from
//! the check after it (a simulated UR5 with friction, its elbow's current negated: named
//! only on the rows before the choice).
//!
//! The residual of a fit is summed over joints as each joint's residual over its lowest in
//! any of the fits (its noise floor): a wrist joint whose torque is mostly noise counts as
//! much as a shoulder. On the 56 fixture logs of `fixtures/diagnose*` (13 arms, 6 and 7
//! joints, CAD inertials exact or 5-30 % off, every effect of the vocabulary), the
//! fit as logged is never beaten by more than a factor 1.23 (ur3 e15_2fx: no joint's
//! negation changes its fit), and negating a joint raises the sum up to 16000 times: at
//! the factor 5 asked here, 273 of the 352 joints would be named if their effort were
//! reversed (mostly a wrist joint whose torque its own friction and offset carry is not,
//! and no joint of three logs whose fit no negation changes by more than 3x;
//! `tests/it/identify_effort_check.rs` measures it). On the real LWR4+ (three runs) and TX40
//! logs the fit as logged is beaten by at most a factor 1.46 (LWR run 1, joint 5, where
//! friction carries most of the torque). A set generated afterwards and run once
//! (`make_cad_cases.py --set random --arms 12 --duration 5:12 --motion wide
//! --friction-solref mujoco`, 144 logs): none refused as logged (the best negation gains
//! at most a factor 1.81); of the 115 with a torque
//! effort, 635 of 742 negated joints named (the terminal joint on 35), never another joint.
//!
//! **Unit** (mN m, a motor current without its torque constant): the consistency of the
//! joints cannot tell a scale of every torque from one of every parameter, so this one
//! trusts the URDF to within a factor 100: a joint's torque that follows the nominal
//! model's (uncentred correlation above 0.8, [`JointAccs::agreement`]) at a slope outside
//! 0.01..100 is an error. Every joint but the terminal one, whose torque a payload can
//! outweigh (slopes up to 23 seen). Slopes at a correlation above 0.8 on the joints
//! checked: 0.61-7.15 on the fixture logs, 0.39-3.98 on the 144 generated logs above
//! (inertials up to 30 % off, payloads up to 2 kg), 0.73-1.16 on the real LWR4+ runs; the
//! TX40's joints agree less (correlations 0.34-0.79; its joint 4 at slope 11.8).

use crate::error::{Error, Result};
use crate::ident::joint_acc::JointAccs;
use crate::prep;

/// The fit with one joint's torque negated leaving less than this fraction of the summed
/// residual (module docs) of the fit as logged is a reversed effort on that joint.
const MAX_RATIO: f64 = 0.2;

/// An error naming a joint whose logged effort is not its torque in N m: its sign
/// reversed ([`sign`]) or its unit another ([`units`]), from the fit's rows `fit` and the
/// nominal base parameters `nom_base`.
pub(crate) fn check(fit: &JointAccs, nom_base: &[f64], names: &[String]) -> Result<()> {
    units(fit, nom_base, names)?;
    sign(fit, names)
}

/// An error naming the joint whose torque negated fits the rows `fit` best, when that fit
/// leaves less than [`MAX_RATIO`] of the summed residual of the fit as logged.
fn sign(fit: &JointAccs, names: &[String]) -> Result<()> {
    let fits = fit.negated_fits()?;
    let n = names.len();
    let lowest: Vec<f64> =
        (0..n).map(|i| fits.iter().map(|f| f[i]).fold(f64::INFINITY, f64::min).max(f64::MIN_POSITIVE)).collect();
    let sum = |f: &[f64]| f.iter().zip(&lowest).map(|(u, m)| u / m).sum::<f64>();
    let logged = sum(&fits[0]);
    let Some((j, best)) = (0..n).map(|j| (j, sum(&fits[j + 1]))).min_by(|a, b| a.1.total_cmp(&b.1)) else {
        return Ok(());
    };
    if best < MAX_RATIO * logged {
        return Err(Error::Signal {
            msg: format!(
                "joint '{}': the logged effort runs opposite to the model's joint torque: the fit with that joint's effort negated leaves {:.1} % of the residual of the fit as logged (each joint's residual over its lowest); its sign convention is the opposite of the URDF joint axis's (negate that joint's effort in the log; for a motor current, give its torque constant negative)",
                names[j],
                100.0 * best / logged
            ),
        });
    }
    Ok(())
}

/// An error naming a joint but the terminal one whose torque follows the nominal model's
/// (uncentred correlation, from the rows `fit`) at a slope outside 0.01..100
/// ([`prep::hygiene::effort_units`]).
fn units(fit: &JointAccs, nom_base: &[f64], names: &[String]) -> Result<()> {
    prep::hygiene::effort_units(&fit.agreement(nom_base), names, "uncentred correlation")
}

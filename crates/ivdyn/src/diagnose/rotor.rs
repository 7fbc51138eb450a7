//! An armature the nominal re-fit holds (docs/diagnose.md, "Rotor or link inertia").
//!
//! On a joint whose inner joints all turn about axes perpendicular to its own (the first
//! joint; the second behind a perpendicular first one; ...), a rotor inertia `ia` adds
//! `ia qd_j^2 / 2` to the kinetic energy and the link's axial inertia `Izz_j` adds
//! `Izz_j (omega_j . z_j)^2 / 2` with `omega_j . z_j = qd_j` there: the same Lagrangian,
//! hence the same regressor column on any log. The re-fit's base parameter built on that
//! column then takes the armature, and no held-out test can give it back; only the size can.
//! CAD inertials are at most `CAD_ERROR_MAX` off, so a re-fitted change of that base
//! parameter beyond what errors of that share in each of its terms make (`term_sizes`) is
//! inertia the links do not have: the armature is named with the whole change (the link's
//! own CAD error included: the log cannot tell them apart, and the note says so), and the
//! base parameter leaves the re-fit.
//!
//! The twin is found on the log's own columns (the Gram matrices), not from the kinematics,
//! so any arm with such joints is covered; the terminal link is not re-fitted, so its
//! joint is not.

use super::dictionary::{C_BASE, C_QDD, Grams};
use super::model::{Model, fit};
use super::refit::base_corrections;
use super::score::{CAD_ERROR_MAX, Ctx};
use super::{EffectKind, JointScore};
use crate::error::Result;
use crate::ident::base::BaseParams;

/// Largest squared distance between two columns over the log, relative to the squared
/// norm of one, at which they are the same column: the regressor's rounding leaves about
/// 1e-30, a column 1e-4 (relative) off another is at 1e-8.
const SAME_COLUMN: f64 = 1e-12;

/// An armature named where the re-fit held it.
pub(super) struct Rotor {
    pub(super) joint: usize,
    pub(super) score: JointScore,
    /// Why, in words, with the numbers.
    pub(super) note: String,
    /// The model with it (and the ones named before it).
    pub(super) model: Model,
    /// That model without it and without its twin in the re-fit: what it is scored against.
    pub(super) without: Model,
}

/// The re-fit's base column that is joint `j`'s armature column on this log (zero on every
/// other joint's rows, `s qdd_j` on joint `j`'s), with `s`.
fn armature_twin(gr: &Grams, j: usize, nbase: usize) -> Option<(usize, f64)> {
    let sum = |i: usize, a: usize, b: usize| gr.g[i][0][(a, b)] + gr.g[i][1][(a, b)];
    let aa = sum(j, C_QDD, C_QDD);
    if aa <= 0.0 {
        return None;
    }
    (0..nbase).find_map(|b| {
        let c = C_BASE + b;
        let cc = sum(j, c, c);
        let s = sum(j, c, C_QDD) / aa;
        // what is left of the base column after its projection on qdd_j, on every joint
        let left = (cc - s * s * aa) + (0..gr.g.len()).filter(|&i| i != j).map(|i| sum(i, c, c)).sum::<f64>();
        (cc > 0.0 && left <= SAME_COLUMN * cc).then_some((b, s))
    })
}

/// The sum of the magnitudes of each base parameter's terms at the nominal parameters
/// `theta` (`theta_b = theta[independent] + K theta[dependent]`): the largest change errors
/// of a given share in every term make is that share of it. Where the terms cancel (a mass
/// times a COM coordinate beside inertias) the value is far smaller than its uncertainty.
pub(super) fn term_sizes(base: &BaseParams, theta: &[f64]) -> Vec<f64> {
    (0..base.base_count())
        .map(|b| {
            let own = theta[base.independent[b]].abs();
            own + base.dependent.iter().enumerate().map(|(d, &c)| (base.k[(b, d)] * theta[c]).abs()).sum::<f64>()
        })
        .collect()
}

/// The armatures the re-fit of the model `m` holds (module docs), each with the model after
/// it. `base`: the re-fit's base parameters, `theta`: the nominal inertial parameters;
/// `joint_names`: for the notes.
pub(super) fn rotors_in_refit(
    ctx: &Ctx,
    m: &Model,
    base: &BaseParams,
    theta: &[f64],
    joint_names: &[String],
) -> Result<Vec<Rotor>> {
    let nominal_base = base.project(&theta[..base.full_cols])?;
    let sizes = term_sizes(base, theta);
    let nbase = nominal_base.len();
    let delta = base_corrections(&fit(&m.params(), ctx.gr, &ctx.w, &[0, 1]), nbase);
    let mut m = m.clone();
    let mut rotors = vec![];
    for j in 0..ctx.n {
        let Some((b, s)) = armature_twin(ctx.gr, j, nbase) else { continue };
        // as an armature: ia = s x the base parameter's change; CAD's largest change of it
        let (ia, nom, margin) = (s * delta[b], s * nominal_base[b], CAD_ERROR_MAX * s.abs() * sizes[b]);
        if m.has(j, EffectKind::Armature) || m.refit_skip.contains(&b) || ia <= margin {
            continue;
        }
        let mut smaller = m.clone();
        smaller.refit_skip.push(b);
        let larger = smaller.with(Some(j), EffectKind::Armature);
        let sel = |p: &super::model::Param| p.joint == Some(j) && p.kind == Some(EffectKind::Armature);
        let score = ctx.joint_score(&smaller, &larger, j, &sel);
        if !score.significant {
            continue;
        }
        let note = format!(
            "armature on {}: on this arm its column is the same as that of {} (the joints before it turn about perpendicular axes: the same kinetic energy), so no log tells rotor from link inertia there; named because the re-fit changed that base parameter by {:+.4} (nominal {:.4}), beyond the {:.4} that errors of {:.0} % in each of its terms make; ia holds the link's own CAD error too",
            joint_names[j],
            base.names[b],
            ia,
            nom,
            margin,
            100.0 * CAD_ERROR_MAX
        );
        m = larger;
        rotors.push(Rotor { joint: j, score, note, model: m.clone(), without: smaller });
    }
    Ok(rotors)
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::DMatrix;

    /// Gram matrices (one fold, the other empty) of per-joint columns `cols[j]`: pairs of
    /// (dictionary column, samples).
    fn grams(cols: &[Vec<(usize, Vec<f64>)>], nbase: usize) -> Grams {
        let size = C_BASE + nbase;
        let g = cols
            .iter()
            .map(|cj| {
                let mut g0 = DMatrix::<f64>::zeros(size, size);
                for (a, xa) in cj {
                    for (b, xb) in cj {
                        g0[(*a, *b)] = xa.iter().zip(xb).map(|(u, v)| u * v).sum();
                    }
                }
                [g0, DMatrix::zeros(size, size)]
            })
            .collect();
        Grams { g, rows: vec![[50, 0]; cols.len()], ridge: 0.0, prior: vec![], terminal_prior: vec![] }
    }

    #[test]
    fn the_twin_is_the_base_column_equal_to_the_armature_column_on_every_joint() {
        let t = |k: usize, f: f64| ((k as f64) * f).sin();
        let qdd0: Vec<f64> = (0..50).map(|k| t(k, 0.37)).collect();
        let other: Vec<f64> = (0..50).map(|k| t(k, 0.91)).collect();
        let twice: Vec<f64> = qdd0.iter().map(|x| 2.0 * x).collect();
        // base 0: qdd_0 on joint 0 and something on joint 1 (a link's inertia seen by an
        // inner joint with a parallel axis: no twin); base 1: 2 qdd_0 on joint 0 alone;
        // base 2: another signal
        let j0 = vec![(C_QDD, qdd0.clone()), (C_BASE, qdd0.clone()), (C_BASE + 1, twice), (C_BASE + 2, other.clone())];
        let j1 = vec![(C_QDD, other.clone()), (C_BASE, other.clone())];
        let gr = grams(&[j0, j1], 3);
        let (b, s) = armature_twin(&gr, 0, 3).expect("a twin");
        assert_eq!(b, 1);
        assert!((s - 2.0).abs() < 1e-12, "s {s}");
        // joint 1's armature column (`other`) is base 0's there, but base 0 also acts on joint 0
        assert!(armature_twin(&gr, 1, 3).is_none());
        // a column a little off the armature's is not its twin
        let near: Vec<f64> = qdd0.iter().zip(&other).map(|(x, y)| x + 1e-4 * y).collect();
        let gr = grams(&[vec![(C_QDD, qdd0.clone()), (C_BASE, near)]], 1);
        assert!(armature_twin(&gr, 0, 1).is_none());
    }

    #[test]
    fn a_combination_whose_terms_cancel_has_the_sum_of_their_sizes() {
        // theta_b = theta_0 + 0.5 theta_1 - 2 theta_2 = 1 + 1 - 0.5: value 1.5, terms 2.5
        let base = BaseParams {
            full_cols: 3,
            independent: vec![0],
            dependent: vec![1, 2],
            k: DMatrix::from_row_slice(1, 2, &[0.5, -2.0]),
            zero_columns: vec![],
            names: vec!["b".into()],
        };
        let theta = [1.0, 2.0, 0.25];
        assert_eq!(base.project(&theta).unwrap(), vec![1.5]);
        assert_eq!(term_sizes(&base, &theta), vec![2.5]);
    }
}

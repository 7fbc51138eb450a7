//! `identify`'s choice of each joint's Coulomb-friction shape ([`ident::coulomb`]): the
//! fit part of the prepared rows is cut into [`coulomb::FOLDS`] blocks of time, each scored
//! by a fit on the others, every candidate on a coarse grid of velocity scales and then on
//! a finer one around the choice; the chosen shapes are written into the regressor rows
//! and the model.

use std::ops::Range;

use ivdyn_core::params::{FC, drive_col};

use super::prepare::{Prepared, rows_of};
use crate::Robot;
use crate::error::Result;
use crate::ident::coulomb::{self, CoulombChoice, Selection, ShapeStats, WIDTH};

/// Fewest samples in a fold worth a choice.
const MIN_FOLD: usize = 50;

/// Chooses the shapes on the rows `fit` of `prep` (base columns `cols`), rewrites the
/// `fc` columns of `prep.phi` with them and returns the model with those shapes and the
/// per-joint report; `Ok(Err(why))` when there is nothing to choose.
pub(crate) fn choose(
    robot: &Robot,
    cols: &[usize],
    prep: &mut Prepared,
    fit: Range<usize>,
) -> Result<std::result::Result<(Robot, Vec<CoulombChoice>), String>> {
    let n = prep.n;
    let fc_col: Vec<Option<usize>> = (0..n).map(|j| cols.iter().position(|&c| c == drive_col(n, j, FC))).collect();
    if fc_col.iter().all(Option::is_none) {
        return Ok(Err("no Coulomb friction is fitted".into()));
    }
    let fold_len = fit.len() / coulomb::FOLDS;
    if fold_len < MIN_FOLD {
        return Ok(Err(format!("too few samples to hold out ({fold_len} a fold, < {MIN_FOLD})")));
    }
    let folds: Vec<Range<usize>> = (0..coulomb::FOLDS)
        .map(|f| {
            fit.start + f * fold_len..if f + 1 == coulomb::FOLDS { fit.end } else { fit.start + (f + 1) * fold_len }
        })
        .collect();
    let (rms_qd, rms_qdd) = prep.rms_motion();
    let v_min = coulomb::resolvable_scale(&rms_qdd, prep.cutoff_hz);
    let mut scales = coulomb::scales_for(&rms_qd);
    let mut cand = prep.coulomb_candidates(&scales)?;
    let mut sel = pass(prep, cols, &cand, (&fc_col, &v_min), &scales, &folds, robot)?;
    if sel.columns.iter().any(|(s, _)| s.is_some()) {
        scales = coulomb::refine(&scales, &sel);
        cand = prep.coulomb_candidates(&scales)?;
        sel = pass(prep, cols, &cand, (&fc_col, &v_min), &scales, &folds, robot)?;
    }
    let mut shaped = robot.clone();
    shaped.set_coulomb_shapes(&sel.shapes)?;
    rewrite_fc(prep, cols.len(), &cand, &fc_col, &sel);
    Ok(Ok((shaped, sel.choices)))
}

/// One choice over the candidates `cand` (scales `scales`), cross-validated over `folds`.
fn pass(
    prep: &Prepared,
    cols: &[usize],
    cand: &[f64],
    (fc_col, v_min): (&[Option<usize>], &[f64]),
    scales: &[[f64; coulomb::K]],
    folds: &[Range<usize>],
    robot: &Robot,
) -> Result<Selection> {
    let (n, b) = (prep.n, cols.len());
    let mut stats = ShapeStats::new(n, b);
    for (f, r) in folds.iter().enumerate() {
        for piece in prep.pieces(r.clone()) {
            let phi = rows_of(&prep.phi, n * b, piece.clone());
            stats.add(f, phi, rows_of(cand, n * WIDTH, piece.clone()), rows_of(&prep.tau, n, piece))?;
        }
    }
    coulomb::select(&stats, fc_col, scales, v_min, &robot.joint_names)
}

/// Writes the chosen shapes into the `fc` columns of `prep.phi`: `c(qd) = s(qd) + asym |s(qd)|`,
/// and a combination of filtered columns is the filtered combination.
fn rewrite_fc(prep: &mut Prepared, b: usize, cand: &[f64], fc_col: &[Option<usize>], sel: &Selection) {
    let n = prep.n;
    for (j, (&(smooth, abs), fc)) in sel.columns.iter().zip(fc_col).enumerate() {
        let (Some(fc), true) = (fc, smooth.is_some() || abs.is_some()) else { continue };
        let asym = sel.shapes[j].asym;
        for k in 0..prep.len() {
            let c = &cand[(k * n + j) * WIDTH..(k * n + j + 1) * WIDTH];
            let v = &mut prep.phi[(k * n + j) * b + fc];
            *v = smooth.map_or(*v, |s| c[s]) + abs.map_or(0.0, |a| asym * c[a]);
        }
    }
}

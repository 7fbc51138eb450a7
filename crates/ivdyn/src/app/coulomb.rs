//! `identify`'s choice of each joint's Coulomb-friction shape ([`ident::coulomb`]): the
//! fit part of the prepared rows is split again (its first 75 % fitted, the rest held
//! out), every candidate scored on a coarse grid of velocity scales and then on a finer
//! one around the choice, and the chosen shapes written into the regressor rows and the
//! model.

use std::ops::Range;

use ivdyn_core::params::{FC, drive_col};

use super::prepare::{Prepared, rows_of};
use crate::Robot;
use crate::error::Result;
use crate::ident::coulomb::{self, CoulombChoice, Selection, ShapeStats, WIDTH};

/// Share of the fit rows the candidates are fitted on (the rest scores them).
const TRAIN_SHARE: f64 = 0.75;
/// Fewest held-out samples worth a choice.
const MIN_HELD_OUT: usize = 50;

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
    let cut = fit.start + ((fit.end - fit.start) as f64 * TRAIN_SHARE) as usize;
    if fit.end - cut < MIN_HELD_OUT {
        return Ok(Err(format!("too few samples to hold out ({} < {MIN_HELD_OUT})", fit.end - cut)));
    }
    let mut scales = coulomb::scales_for(&prep.rms_velocity());
    let mut cand = prep.coulomb_candidates(&scales)?;
    let mut sel = pass(prep, cols, &cand, &fc_col, &scales, fit.start..cut, cut..fit.end, robot)?;
    if sel.columns.iter().any(|(s, _)| s.is_some()) {
        scales = coulomb::refine(&scales, &sel);
        cand = prep.coulomb_candidates(&scales)?;
        sel = pass(prep, cols, &cand, &fc_col, &scales, fit.start..cut, cut..fit.end, robot)?;
    }
    let mut shaped = robot.clone();
    shaped.set_coulomb_shapes(&sel.shapes)?;
    rewrite_fc(prep, cols.len(), &cand, &fc_col, &sel);
    Ok(Ok((shaped, sel.choices)))
}

/// One choice over the candidates `cand` (scales `scales`): fitted on `train`, scored on
/// `held_out`.
#[allow(clippy::too_many_arguments)]
fn pass(
    prep: &Prepared,
    cols: &[usize],
    cand: &[f64],
    fc_col: &[Option<usize>],
    scales: &[[f64; coulomb::K]],
    train: Range<usize>,
    held_out: Range<usize>,
    robot: &Robot,
) -> Result<Selection> {
    let (n, b) = (prep.n, cols.len());
    let mut stats = ShapeStats::new(n, b);
    for (test, r) in [(false, train), (true, held_out)] {
        for piece in prep.pieces(r) {
            let phi = rows_of(&prep.phi, n * b, piece.clone());
            stats.add(test, phi, rows_of(cand, n * WIDTH, piece.clone()), rows_of(&prep.tau, n, piece))?;
        }
    }
    coulomb::select(&stats, fc_col, scales, &robot.joint_names)
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

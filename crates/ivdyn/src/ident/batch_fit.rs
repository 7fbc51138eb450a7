//! Least squares straight from states: the regressor evaluated and accumulated per
//! thread, never stored.

use crate::Robot;
use crate::batch::{dim_err, row, threads_for};
use crate::error::Error;
use crate::ident::{BaseParams, FitReport, LsAccumulator, fit_ls};
use ivdyn_core::Model;
use ivdyn_core::params::{LINK_PARAMS, PARAMS_PER_JOINT};
use ivdyn_core::{self as core_, Data};

/// Least-squares fit of the base parameters `base` from `T` samples, fused and
/// multi-threaded: each thread evaluates its samples' regressor rows (all `14 N` columns,
/// or the `10 N` inertial ones when `base` was built on those), keeps the base columns and
/// streams them into its own [`LsAccumulator`]; the accumulators merge into
/// exactly the statistics of all rows. The `T x N x P` regressor is never stored.
/// `tau`: measured torques `T x N`; `joint_weight`: optional weight per joint (N).
pub fn fit_ls_batch(
    robot: &Robot,
    base: &BaseParams,
    q: &[f64],
    qd: &[f64],
    qdd: &[f64],
    tau: &[f64],
    joint_weight: Option<&[f64]>,
) -> crate::error::Result<FitReport> {
    let n = robot.dof();
    let rigid_only = match base.full_cols {
        c if c == LINK_PARAMS * n => true,
        c if c == PARAMS_PER_JOINT * n => false,
        c => {
            return Err(dim_err(
                format!("base parameters over {c} columns (must be 10 N or 14 N, N = {n})"),
                PARAMS_PER_JOINT * n,
                c,
            ));
        }
    };
    let t = q.len() / n.max(1);
    for (what, x) in [("q", q), ("qd", qd), ("qdd", qdd), ("tau", tau)] {
        if x.len() != t * n {
            return Err(dim_err(format!("{what} (T x N = {t} x {n})"), t * n, x.len()));
        }
    }
    if let Some(w) = joint_weight
        && w.len() != n
    {
        return Err(dim_err("joint_weight (N)".into(), n, w.len()));
    }
    let acc =
        crate::with_model!(&robot.model, m => fit_ls_n(&**m, base, rigid_only, t, q, qd, qdd, tau, joint_weight))?;
    fit_ls(&acc, &base.names)
}

#[allow(clippy::too_many_arguments)]
fn fit_ls_n<const N: usize>(
    m: &Model<N>,
    base: &BaseParams,
    rigid_only: bool,
    t: usize,
    q: &[f64],
    qd: &[f64],
    qdd: &[f64],
    tau: &[f64],
    joint_weight: Option<&[f64]>,
) -> crate::error::Result<LsAccumulator> {
    use LsAccumulator;
    let b = base.base_count();
    let cols = if rigid_only { LINK_PARAMS * N } else { PARAMS_PER_JOINT * N };
    let block = 512; // samples per absorbed block
    let work = |first: usize, last: usize| -> crate::error::Result<LsAccumulator> {
        let mut acc = LsAccumulator::new(b);
        let mut data = Box::new(Data::<N>::new());
        let mut yrow = vec![0.0; N * cols];
        let (mut phi, mut y, mut w) =
            (Vec::with_capacity(block * N * b), Vec::with_capacity(block * N), Vec::with_capacity(block * N));
        let mut rb = vec![0.0; b];
        for s in first..last {
            let at = |e: core_::Error| Error::Sample { index: s, source: e };
            let (qv, qdv, qddv) = (
                row::<N>("q", q, s).map_err(at)?,
                row::<N>("qd", qd, s).map_err(at)?,
                row::<N>("qdd", qdd, s).map_err(at)?,
            );
            let taus = row::<N>("tau", tau, s).map_err(at)?;
            let yr = core_::regressor(m, &mut data, &qv, &qdv, &qddv);
            if rigid_only {
                yr.write_rigid_row_major(&mut yrow);
            } else {
                yr.write_row_major(&mut yrow);
            }
            for i in 0..N {
                base.select_row(&yrow[i * cols..(i + 1) * cols], &mut rb)?;
                phi.extend_from_slice(&rb);
                y.push(taus[i]);
                w.push(joint_weight.map_or(1.0, |jw| jw[i]));
            }
            if y.len() >= block * N || s + 1 == last {
                acc.add_rows(&phi, &y, Some(&w))?;
                phi.clear();
                y.clear();
                w.clear();
            }
        }
        acc.finish();
        Ok(acc)
    };
    let nthreads = threads_for(t);
    let per = t.div_ceil(nthreads.max(1)).max(1);
    let parts: Vec<crate::error::Result<LsAccumulator>> = std::thread::scope(|scope| {
        let handles: Vec<_> = (0..t)
            .step_by(per)
            .map(|first| {
                let work = &work;
                scope.spawn(move || work(first, (first + per).min(t)))
            })
            .collect();
        handles.into_iter().map(|h| h.join().unwrap_or_else(|p| std::panic::resume_unwind(p))).collect()
    });
    let mut total = LsAccumulator::new(b);
    for p in parts {
        total.merge(&p?)?;
    }
    Ok(total)
}

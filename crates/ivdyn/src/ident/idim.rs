//! IDIM-IV (Gautier, Janot, Vandanjon, "A new closed-loop output error method for
//! parameter identification of robot dynamics", IEEE TCST 2013; Janot, Vandanjon,
//! Gautier, "A generic instrumental variable approach for industrial robot
//! identification", IEEE TCST 2014): the instrument is the regressor evaluated on a
//! *simulation* of the robot model with the previous estimate, driven by the same
//! reference and the same control law as the real robot. The simulated states carry no
//! measurement noise, so the instrument is uncorrelated with it; iterating makes the
//! instrument track the real motion better, and stops when the estimate settles.
//!
//! The control law must be the robot's (it is part of the method); when the controller is
//! unknown, a stiff PD on the commanded positions is the usual stand-in (say so).

use crate::Robot;
use crate::error::{Error, Result};
use crate::ident::{BaseParams, FitReport, IvAccumulator, LsAccumulator, fit_iv, fit_ls};

/// The measured experiment: `T x N` row-major arrays at a fixed sample time.
#[derive(Debug, Clone, Copy)]
pub struct Experiment<'a> {
    /// Sample time (s).
    pub dt: f64,
    /// Measured (conditioned) positions, velocities, accelerations and torques.
    pub q: &'a [f64],
    /// Velocities.
    pub qd: &'a [f64],
    /// Accelerations (the noisy ones: the reason for IV).
    pub qdd: &'a [f64],
    /// Torques.
    pub tau: &'a [f64],
}

/// Iteration history and the final fit.
#[derive(Debug, Clone)]
pub struct IdimIvResult {
    /// The final IV fit (with the DWH test against LS on the same data).
    pub fit: FitReport,
    /// The IDIM-LS starting point.
    pub ls: FitReport,
    /// Base estimates after each iteration (the first is IDIM-LS).
    pub history: Vec<Vec<f64>>,
    /// Whether the relative change fell below the tolerance.
    pub converged: bool,
    /// Per iteration, the step `alpha` toward the estimate that gave a simulable model
    /// (1 = the estimate itself; smaller when it had to be pulled toward the nominal model).
    pub shrink: Vec<f64>,
}

/// Runs IDIM-IV. `control(k, q_sim, qd_sim) -> tau` is the robot's control law at sample
/// `k` (with its reference inside). The simulated model has the parameters
/// `theta_nom + to_full(theta_base - project(theta_nom))`: the base estimate, with the
/// unidentifiable parts left at the robot's current (nominal) values, which keeps the
/// simulated mass matrix physical in practice.
pub fn idim_iv<F>(
    robot: &Robot,
    base: &BaseParams,
    exp: &Experiment,
    mut control: F,
    max_iter: usize,
    tol: f64,
) -> Result<IdimIvResult>
where
    F: FnMut(usize, &[f64], &[f64]) -> Vec<f64>,
{
    let (n, p, b) = (robot.dof(), robot.num_params(), base.base_count());
    let t = exp.q.len() / n;
    for (what, x) in [("qd", exp.qd), ("qdd", exp.qdd), ("tau", exp.tau)] {
        if x.len() != t * n {
            return Err(Error::Dimension {
                what: format!("{what} (T x N = {t} x {n})"),
                expected: t * n,
                got: x.len(),
            });
        }
    }
    // regressor rows at the measured states, once
    let mut phi = Vec::with_capacity(t * n * b);
    let mut row_b = vec![0.0; b];
    for k in 0..t {
        let s = k * n..(k + 1) * n;
        let y = robot.regressor(&exp.q[s.clone()], &exp.qd[s.clone()], &exp.qdd[s])?;
        for i in 0..n {
            base.select_row(&y[i * p..(i + 1) * p], &mut row_b)?;
            phi.extend_from_slice(&row_b);
        }
    }
    let mut ls_acc = LsAccumulator::new(b);
    ls_acc.add_rows(&phi, exp.tau, None)?;
    let ls = fit_ls(&ls_acc, &base.names)?;
    let theta_nom = robot.params();
    let mut theta = ls.theta.clone();
    let mut history = vec![theta.clone()];
    let mut sim = robot.clone();
    let mut fit = ls.clone();
    let mut converged = false;
    let mut z = Vec::with_capacity(phi.len());
    let mut shrink = vec![];
    for iter in 0..max_iter {
        // simulate the current estimate; if it is not physical (the simulation fails, e.g. a
        // mass matrix that is not positive definite, typical of a biased IDIM-LS start),
        // step back toward the nominal model: theta_nom + alpha (theta - theta_nom)
        let mut used = None;
        let mut last_err = None;
        for alpha in [1.0, 0.5, 0.25, 0.125, 1.0 / 16.0, 1.0 / 32.0, 0.0] {
            let full = base.apply(&theta, &theta_nom, alpha)?;
            sim.set_params(&full)?;
            match simulate(&sim, robot, base, exp, &mut control, &mut z) {
                Ok(()) => {
                    used = Some(alpha);
                    break;
                }
                Err(e) => last_err = Some(e),
            }
        }
        let Some(alpha) = used else {
            let source = last_err.unwrap_or_else(|| Error::internal("IDIM-IV: no step size was tried"));
            return Err(Error::During {
                step: format!("IDIM-IV iteration {iter}: even the nominal model's simulation failed"),
                source: Box::new(source),
            });
        };
        shrink.push(alpha);
        let mut acc = IvAccumulator::new(b);
        acc.add_rows(&phi, &z, exp.tau, None)?;
        fit = fit_iv(&acc, &base.names)?;
        let change = fit.theta.iter().zip(&theta).map(|(a, b)| (a - b).powi(2)).sum::<f64>().sqrt();
        let size = theta.iter().map(|a| a * a).sum::<f64>().sqrt().max(f64::MIN_POSITIVE);
        theta = fit.theta.clone();
        history.push(theta.clone());
        if change / size < tol {
            converged = true;
            break;
        }
    }
    Ok(IdimIvResult { fit, ls, history, converged, shrink })
}

/// Closed-loop simulation of `sim` under `control` (semi-implicit Euler at the sample
/// time), writing the instrument rows (base regressor at the simulated states) into `z`.
fn simulate<F>(
    sim: &Robot,
    robot: &Robot,
    base: &BaseParams,
    exp: &Experiment,
    control: &mut F,
    z: &mut Vec<f64>,
) -> Result<()>
where
    F: FnMut(usize, &[f64], &[f64]) -> Vec<f64>,
{
    let (n, p, b) = (robot.dof(), robot.num_params(), base.base_count());
    let t = exp.q.len() / n;
    let mut row_b = vec![0.0; b];
    z.clear();
    let (mut q, mut qd) = (exp.q[..n].to_vec(), exp.qd[..n].to_vec());
    for k in 0..t {
        let tau = control(k, &q, &qd);
        let what = || "IDIM-IV: the simulation of the current estimate".to_string();
        let qdd = sim.forward_dynamics(&q, &qd, &tau).map_err(|e| Error::Diverged {
            what: what(),
            sample: k,
            detail: format!(" ({e})"),
        })?;
        if qdd.iter().chain(&q).any(|v| !v.is_finite() || v.abs() > 1e6) {
            return Err(Error::Diverged { what: what(), sample: k, detail: String::new() });
        }
        let y = robot.regressor(&q, &qd, &qdd)?;
        for i in 0..n {
            base.select_row(&y[i * p..(i + 1) * p], &mut row_b)?;
            z.extend_from_slice(&row_b);
        }
        for i in 0..n {
            qd[i] += qdd[i] * exp.dt;
            q[i] += qd[i] * exp.dt;
        }
    }
    Ok(())
}

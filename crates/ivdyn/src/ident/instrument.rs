//! The instrument without a command topic: the regressor on a closed-loop simulation of
//! the nominal model tracking the measured positions (the stand-in control law of IDIM-IV).

use crate::Robot;
use crate::error::{Error, Result};

/// The instrument without a command topic, in words.
pub const TRACKING_INSTRUMENT: &str = "regressor on a closed-loop simulation of the nominal model tracking the measured positions (stand-in M-scaled PD, 10 Hz, damping 0.7, plus nominal inverse-dynamics feed-forward; no command topic in the log)";

/// Closed-loop simulation (semi-implicit Euler at `dt`) of the nominal model tracking the
/// measured motion: `tau = rnea(q_m, qd_m, qdd_m) + M(q_m) (kp (q_m - q) + kd (qd_m - qd))`.
/// Returns the simulated `(q, qd, qdd)`.
pub fn nominal_tracking(
    robot: &Robot,
    q: &[f64],
    qd: &[f64],
    qdd: &[f64],
    dt: f64,
) -> Result<(Vec<f64>, Vec<f64>, Vec<f64>)> {
    Tracker::new(dt).run(robot, q, qd, qdd)
}

/// The state of [`nominal_tracking`] between blocks of samples, so that a log can be
/// simulated block by block (streaming) with the same result as in one piece.
pub struct Tracker {
    dt: f64,
    kp: f64,
    kd: f64,
    /// Simulated `(q, qd)` at the next sample (`None` before the first block: starts at
    /// the measured state).
    state: Option<(Vec<f64>, Vec<f64>)>,
    /// Samples simulated so far (for error messages).
    done: usize,
}

impl Tracker {
    /// PD gains of the stand-in control law at sample time `dt`: 10 Hz bandwidth (at most
    /// `0.05 / dt` Hz), damping 0.7.
    pub fn gains(dt: f64) -> (f64, f64) {
        let wn = 2.0 * std::f64::consts::PI * 10.0f64.min(0.05 / dt);
        (wn * wn, 2.0 * 0.7 * wn)
    }

    /// A tracker at sample time `dt`, starting at the first measured state.
    pub fn new(dt: f64) -> Self {
        let (kp, kd) = Self::gains(dt);
        Tracker { dt, kp, kd, state: None, done: 0 }
    }

    /// Simulates the next samples (`T x N` measured `q, qd, qdd`), returns the simulated
    /// `(q, qd, qdd)` of these samples.
    pub fn run(&mut self, robot: &Robot, q: &[f64], qd: &[f64], qdd: &[f64]) -> Result<(Vec<f64>, Vec<f64>, Vec<f64>)> {
        let n = robot.dof();
        let t = q.len() / n;
        if t == 0 {
            return Ok((vec![], vec![], vec![]));
        }
        let mut ff = vec![0.0; t * n];
        crate::batch::rnea_batch(robot, q, qd, qdd, &mut ff)?;
        let mut mm = vec![0.0; t * n * n];
        crate::batch::mass_matrix_batch(robot, q, &mut mm)?;
        let (kp, kd, dt) = (self.kp, self.kd, self.dt);
        let (mut qs, mut qds) = self.state.take().unwrap_or_else(|| (q[..n].to_vec(), qd[..n].to_vec()));
        let (mut oq, mut oqd, mut oqdd) =
            (Vec::with_capacity(t * n), Vec::with_capacity(t * n), Vec::with_capacity(t * n));
        let done = self.done;
        // one work buffer for the block (the per-call `Robot::forward_dynamics` allocates one)
        crate::with_model!(&robot.model, m => {
            let mut data = Box::new(ivdyn_core::Data::new());
            let mut tau = ivdyn_core::VecN::zeros();
            for k in 0..t {
                let s = done + k;
                let e: Vec<f64> = (0..n).map(|i| kp * (q[k * n + i] - qs[i]) + kd * (qd[k * n + i] - qds[i])).collect();
                for i in 0..n {
                    tau[i] = ff[k * n + i] + (0..n).map(|j| mm[k * n * n + i * n + j] * e[j]).sum::<f64>();
                }
                let (qv, qdv) = (ivdyn_core::VecN::from_column_slice(&qs), ivdyn_core::VecN::from_column_slice(&qds));
                let a = ivdyn_core::forward_dynamics(&**m, &mut data, &qv, &qdv, &tau)
                    .map_err(|e| Error::Diverged { what: "instrument: the closed-loop simulation of the model".into(), sample: s, detail: format!(" ({e})") })?;
                if a.iter().chain(&qs).any(|v| !v.is_finite() || v.abs() > 1e6) {
                    return Err(Error::Diverged { what: "instrument: the closed-loop simulation of the model".into(), sample: s, detail: String::new() });
                }
                oq.extend_from_slice(&qs);
                oqd.extend_from_slice(&qds);
                oqdd.extend_from_slice(a.as_slice());
                for i in 0..n {
                    qds[i] += a[i] * dt;
                    qs[i] += qds[i] * dt;
                }
            }
        });
        self.done += t;
        self.state = Some((qs, qds));
        Ok((oq, oqd, oqdd))
    }
}

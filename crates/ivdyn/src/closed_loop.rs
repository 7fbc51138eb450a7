//! Closed-loop simulation of a runtime-sized robot: the core's [`Simulator`] (the true
//! arm: integrator, held torque, encoders, noise, torque limits) driven by its
//! [`ComputedTorque`] or [`Pd`] controller (on a controller model, which may differ from
//! the truth) along a reference given as arrays. What a user needs to try a controller or
//! record identification data before running an arm. The loop itself is [`run_loop`]: a
//! [`StepHook`] called before and after every control step records, changes the truth
//! (a grasp) or the controller's model; the paper's Fig. 5 experiments (`ivdyn-lab`) run
//! their online payload estimator as such a hook.

use std::any::Any;
use std::time::{Duration, Instant};

use crate::Robot;
use crate::error::{Error, Result};
use ivdyn_core::control::{ComputedTorque, CoulombVelocity, Gains, Pd, Reference};
use ivdyn_core::sim::{IdSample, Integrator, SimConfig, Simulator};
use ivdyn_core::{Data, Model, VecN, mass_matrix};

/// The controller of a closed-loop run.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Controller {
    /// Computed torque on the controller model (paper eq. 58).
    ComputedTorque,
    /// Joint PD, gains scaled by the controller model's `M_ii` at the mean reference pose.
    Pd,
    /// Joint PD plus the controller model's gravity torque.
    PdGravity,
}

/// Settings of one closed-loop run (checked by [`closed_loop`]).
#[derive(Debug, Clone, PartialEq)]
pub struct LoopSettings {
    /// The controller.
    pub controller: Controller,
    /// Closed-loop bandwidth (rad/s) of the error dynamics.
    pub wn: f64,
    /// Damping ratio of the error dynamics.
    pub zeta: f64,
    /// Computed torque: Coulomb friction from the reference velocity (else the measured).
    pub coulomb_reference: bool,
    /// Control period (s).
    pub dt: f64,
    /// Integration steps per control period.
    pub substeps: usize,
    /// The simulator's integrator.
    pub integrator: Integrator,
    /// Velocity band (rad/s) over which Coulomb friction is smoothed in the simulator.
    pub coulomb_band: f64,
    /// Torque limit per joint (inf: none).
    pub tau_limit: Vec<f64>,
    /// Encoder resolution (bits per turn).
    pub encoder_bits: Option<u32>,
    /// Position noise std (rad).
    pub q_noise: f64,
    /// Torque noise std (N m).
    pub tau_noise: f64,
    /// Cut-off (Hz) of the velocity estimate from the encoder (0: exact velocity).
    pub velocity_cutoff_hz: f64,
    /// Seed of the noise.
    pub seed: u64,
}

impl LoopSettings {
    /// Defaults for `n` joints at control period `dt`: computed torque, 20 rad/s, critically
    /// damped, RK4 with 10 substeps, no limits, no noise.
    pub fn new(n: usize, dt: f64) -> Self {
        LoopSettings {
            controller: Controller::ComputedTorque,
            wn: 20.0,
            zeta: 1.0,
            coulomb_reference: true,
            dt,
            substeps: 10,
            integrator: Integrator::Rk4,
            coulomb_band: 0.05,
            tau_limit: vec![f64::INFINITY; n],
            encoder_bits: None,
            q_noise: 0.0,
            tau_noise: 0.0,
            velocity_cutoff_hz: 0.0,
            seed: 0,
        }
    }

    /// Rejects settings the simulator cannot run, naming the option.
    pub fn check(&self, n: usize) -> Result<()> {
        for (name, x) in [("dt", self.dt), ("wn", self.wn), ("zeta", self.zeta)] {
            if !(x > 0.0 && x.is_finite()) {
                return Err(Error::option(name, format!("must be finite and > 0, got {x}")));
            }
        }
        let nonneg = [
            ("q_noise", self.q_noise),
            ("tau_noise", self.tau_noise),
            ("coulomb_band", self.coulomb_band),
            ("velocity_cutoff_hz", self.velocity_cutoff_hz),
        ];
        for (name, x) in nonneg {
            if !(x >= 0.0 && x.is_finite()) {
                return Err(Error::option(name, format!("must be finite and >= 0, got {x}")));
            }
        }
        if self.substeps == 0 {
            return Err(Error::option("substeps", "must be >= 1"));
        }
        if self.encoder_bits.is_some_and(|b| !(1..=62).contains(&b)) {
            return Err(Error::option("encoder_bits", "must be in 1..=62"));
        }
        if self.tau_limit.len() != n {
            return Err(Error::option(
                "tau_limit",
                format!("must have {n} entries (one per joint), got {}", self.tau_limit.len()),
            ));
        }
        if self.tau_limit.iter().any(|x| !(*x > 0.0)) {
            return Err(Error::option("tau_limit", "must be > 0 (inf for none)"));
        }
        Ok(())
    }
}

/// Everything recorded, row-major `T x N` (`id_*`: `M x N`, the simulator's
/// identification samples).
#[derive(Debug, Clone, Default, PartialEq)]
pub struct LoopRecord {
    /// Times (s).
    pub t: Vec<f64>,
    /// True positions.
    pub q: Vec<f64>,
    /// True velocities.
    pub qd: Vec<f64>,
    /// Measured positions.
    pub q_meas: Vec<f64>,
    /// Measured velocities.
    pub qd_meas: Vec<f64>,
    /// Commanded torques.
    pub u: Vec<f64>,
    /// Applied torques (after the limits).
    pub tau: Vec<f64>,
    /// Whether a limit clipped the command.
    pub saturated: Vec<bool>,
    /// Identification samples: times.
    pub id_t: Vec<f64>,
    /// Identification samples: positions.
    pub id_q: Vec<f64>,
    /// Identification samples: velocities.
    pub id_qd: Vec<f64>,
    /// Identification samples: accelerations.
    pub id_qdd: Vec<f64>,
    /// Identification samples: measured torques.
    pub id_tau: Vec<f64>,
    /// Identification samples: commands.
    pub id_u: Vec<f64>,
}

/// The fixed-size model of `r` if it has `N` joints.
fn model_n<const N: usize>(r: &Robot) -> Option<&Model<N>> {
    crate::with_model!(&r.model, m => (&**m as &dyn Any).downcast_ref::<Model<N>>())
}

/// Runs `truth` under the controller of `s` on `model` (the controller's model, same
/// joints) along the reference `q_des, qd_des, qdd_des` (`T x N`, one row per control
/// period), from `q0, qd0` (default: the reference's first sample).
#[allow(clippy::too_many_arguments)]
pub fn closed_loop(
    truth: &Robot,
    model: &Robot,
    s: &LoopSettings,
    q_des: &[f64],
    qd_des: &[f64],
    qdd_des: &[f64],
    q0: Option<&[f64]>,
    qd0: Option<&[f64]>,
) -> Result<LoopRecord> {
    let n = truth.dof();
    if model.dof() != n {
        return Err(Error::option("model", format!("has {} joints, the robot {n}", model.dof())));
    }
    let t = q_des.len() / n;
    if t == 0 || q_des.len() != t * n || qd_des.len() != t * n || qdd_des.len() != t * n {
        return Err(Error::Dimension {
            what: "q_des, qd_des, qdd_des (T x N, T >= 1)".into(),
            expected: t.max(1) * n,
            got: q_des.len(),
        });
    }
    s.check(n)?;
    let q0 = q0.unwrap_or(&q_des[..n]);
    let qd0 = qd0.unwrap_or(&qd_des[..n]);
    for (name, v) in [("q0", q0), ("qd0", qd0)] {
        if v.len() != n {
            return Err(Error::option(name, format!("must have {n} entries (one per joint), got {}", v.len())));
        }
    }
    crate::with_model!(&truth.model, m => closed_loop_n(&**m, model_n(model).expect("same dof"), s, q_des, qd_des, qdd_des, q0, qd0))
}

#[allow(clippy::too_many_arguments)]
fn closed_loop_n<const N: usize>(
    truth: &Model<N>,
    model: &Model<N>,
    s: &LoopSettings,
    q_des: &[f64],
    qd_des: &[f64],
    qdd_des: &[f64],
    q0: &[f64],
    qd0: &[f64],
) -> Result<LoopRecord> {
    let t = q_des.len() / N;
    let v = |x: &[f64], k: usize| VecN::<N>::from_column_slice(&x[k * N..(k + 1) * N]);
    let mut cfg = SimConfig::<N>::ideal();
    if let Some(b) = s.encoder_bits {
        cfg = cfg.with_encoder_bits(b);
    }
    cfg.dt = s.dt;
    cfg.substeps = s.substeps;
    cfg.integrator = s.integrator;
    cfg.coulomb_band = s.coulomb_band;
    cfg.tau_limit = VecN::<N>::from_column_slice(&s.tau_limit);
    cfg.q_noise = VecN::<N>::repeat(s.q_noise);
    cfg.tau_noise = VecN::<N>::repeat(s.tau_noise);
    cfg.velocity_cutoff_hz = s.velocity_cutoff_hz;
    cfg.seed = s.seed;
    let mut sim = Simulator::new(truth.clone(), cfg, &v(q0, 0), &v(qd0, 0))?;
    let gains = Gains::<N>::from_bandwidth(&VecN::<N>::repeat(s.wn), s.zeta);
    let coulomb = if s.coulomb_reference { CoulombVelocity::Reference } else { CoulombVelocity::Measured };
    // PD gains scaled at the mean reference pose
    let mut mean = VecN::<N>::zeros();
    for k in 0..t {
        mean += v(q_des, k);
    }
    let mut ctrl = LoopController::new(s.controller, model.clone(), gains, coulomb, &(mean / t.max(1) as f64));
    let mut rec = LoopRecord::default();
    let reference = |k: usize| Reference { q: v(q_des, k), qd: v(qd_des, k), qdd: v(qdd_des, k) };
    run_loop(&mut sim, &mut ctrl, t, reference, &mut rec)?;
    Ok(rec)
}

/// The controller of a closed loop and the model its law uses, which a [`StepHook`] may
/// change between steps (a payload estimate written in, the true loaded arm).
#[derive(Debug, Clone)]
pub struct LoopController<const N: usize> {
    /// Which law.
    pub kind: Controller,
    /// Computed torque on `model` (gains in acceleration units).
    pub ct: ComputedTorque<N>,
    /// PD: the same gains times `M_ii` of the initial model at a pose; with
    /// [`Controller::PdGravity`] plus `model`'s gravity torque.
    pub pd: Pd<N>,
    /// The controller's model.
    pub model: Model<N>,
}

impl<const N: usize> LoopController<N> {
    /// The `kind` controller on `model` with the error dynamics `gains`, computed torque's
    /// Coulomb term from `coulomb`, PD gains in torque units through `model`'s mass matrix
    /// at `pd_pose` (the acceleration gains times `M_ii`).
    pub fn new(
        kind: Controller,
        model: Model<N>,
        gains: Gains<N>,
        coulomb: CoulombVelocity,
        pd_pose: &VecN<N>,
    ) -> Self {
        let mut ct = ComputedTorque::new(gains);
        ct.coulomb = coulomb;
        let m0 = *mass_matrix(&model, &mut Data::<N>::new(), pd_pose);
        let pd = Pd {
            gains: gains.scaled(&m0.diagonal()),
            tau_limit: VecN::<N>::repeat(f64::INFINITY),
            gravity: kind == Controller::PdGravity,
        };
        LoopController { kind, ct, pd, model }
    }

    /// The command from the measured `q, qd` and the reference `r`.
    pub fn torque(
        &self,
        data: &mut Data<N>,
        q: &VecN<N>,
        qd: &VecN<N>,
        r: &Reference<N>,
    ) -> core::result::Result<VecN<N>, ivdyn_core::Error> {
        Ok(match self.kind {
            Controller::ComputedTorque => *self.ct.torque(&self.model, data, q, qd, r)?,
            Controller::Pd | Controller::PdGravity => *self.pd.torque(&self.model, data, q, qd, r)?,
        })
    }
}

/// What one control step of [`run_loop`] did.
#[derive(Debug, Clone, Copy)]
pub struct StepOutcome<const N: usize> {
    /// The command.
    pub u: VecN<N>,
    /// The identification sample the step completed (one step late: central differences).
    pub sample: Option<IdSample<N>>,
    /// Wall-clock time of the control law.
    pub control_time: Duration,
}

/// Called by [`run_loop`] around every control step: records, changes the truth (a grasp),
/// runs an online estimator and updates the controller's model.
pub trait StepHook<const N: usize> {
    /// Before control step `k` (reference `r`), the simulator not yet advanced.
    fn before(
        &mut self,
        k: usize,
        r: &Reference<N>,
        sim: &mut Simulator<N>,
        ctrl: &mut LoopController<N>,
    ) -> Result<()>;
    /// After control step `k`.
    fn after(
        &mut self,
        k: usize,
        step: &StepOutcome<N>,
        sim: &Simulator<N>,
        ctrl: &mut LoopController<N>,
    ) -> Result<()>;
}

/// `steps` control steps of `sim` under `ctrl` along `reference(k)`: per step the hook's
/// `before`, the command from the sensors, the simulator's step, the hook's `after`. An
/// error of the controller or the simulator names the step ([`Error::Sample`]).
pub fn run_loop<const N: usize>(
    sim: &mut Simulator<N>,
    ctrl: &mut LoopController<N>,
    steps: usize,
    mut reference: impl FnMut(usize) -> Reference<N>,
    hook: &mut impl StepHook<N>,
) -> Result<()> {
    let mut data = Data::<N>::new();
    for k in 0..steps {
        let r = reference(k);
        hook.before(k, &r, sim, ctrl)?;
        let sens = *sim.sensors();
        let t0 = Instant::now();
        let u = ctrl.torque(&mut data, &sens.q, &sens.qd, &r).map_err(|source| Error::Sample { index: k, source })?;
        let control_time = t0.elapsed();
        let sample = sim.step(&u).map_err(|source| Error::Sample { index: k, source })?;
        hook.after(k, &StepOutcome { u, sample, control_time }, sim, ctrl)?;
    }
    Ok(())
}

/// [`closed_loop`]'s record: the state and sensors before each step, the command, applied
/// torque and identification sample after it.
impl<const N: usize> StepHook<N> for LoopRecord {
    fn before(&mut self, _: usize, _: &Reference<N>, sim: &mut Simulator<N>, _: &mut LoopController<N>) -> Result<()> {
        let sens = *sim.sensors();
        self.t.push(sim.t);
        self.q.extend_from_slice(sim.q.as_slice());
        self.qd.extend_from_slice(sim.qd.as_slice());
        self.q_meas.extend_from_slice(sens.q.as_slice());
        self.qd_meas.extend_from_slice(sens.qd.as_slice());
        Ok(())
    }

    fn after(&mut self, _: usize, step: &StepOutcome<N>, sim: &Simulator<N>, _: &mut LoopController<N>) -> Result<()> {
        self.u.extend_from_slice(step.u.as_slice());
        self.tau.extend_from_slice(sim.tau_applied.as_slice());
        self.saturated.push(sim.saturated);
        if let Some(x) = step.sample {
            self.id_t.push(x.t);
            self.id_q.extend_from_slice(x.x.q.as_slice());
            self.id_qd.extend_from_slice(x.x.qd.as_slice());
            self.id_qdd.extend_from_slice(x.x.qdd.as_slice());
            self.id_tau.extend_from_slice(x.tau.as_slice());
            self.id_u.extend_from_slice(x.u.as_slice());
        }
        Ok(())
    }
}

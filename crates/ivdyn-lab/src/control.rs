//! Closed-loop simulation and the computed-torque experiments (paper Fig. 5).
//!
//! An arm tracks a smooth periodic trajectory; at `grasp_time` a payload is added to the
//! last link of the TRUE model (the simulator's); from then on an online estimator of the
//! change of the last link ([`ivdyn_core::control::PayloadEstimator`], recursive IV or
//! LS, rows = every joint, unknowns = the identifiable entries of the last link's 10
//! inertial parameters found by [`ivdyn::ident::BaseParams`]) runs at the control rate
//! on the measured data (encoder positions differentiated, noisy torque). The
//! computed-torque controller of scheme [`Scheme::CtEstimated`] uses the nominal model
//! until the estimated mass's standard deviation falls below `switch_rel_std` of the
//! estimate, then nominal + estimate (refreshed every step).
//!
//! The nominal model is either the unloaded arm exactly (`Experiment::paper()`, so that
//! every difference between the schemes comes from the payload), or, as in the paper's
//! experiment, the unloaded arm *identified* first from an unloaded run starting from a
//! wrong prior ([`Experiment::with_identified_nominal`]): then `truth` (what the simulator
//! runs) and `nominal` (what the controllers and the estimator use) differ.
//!
//! ```no_run
//! use ivdyn_lab::control::{Experiment, Scheme};
//! let exp = Experiment::paper().unwrap();
//! let run = exp.run(Scheme::CtEstimated).unwrap();
//! let (rms, peak) = run.rms_peak(run.switch_time.unwrap_or(exp.grasp_time));
//! println!("{rms:?} {peak:?}");
//! ```

use ivdyn::closed_loop::{Controller, LoopController, StepHook, StepOutcome, run_loop};
use ivdyn::error::{Error, Result};
use ivdyn::ident::{BaseParams, FitReport, IvAccumulator, fit_iv};
use ivdyn_core::control::{CoulombVelocity, Gains, PayloadEstimator, Reference};
use ivdyn_core::estim::terminal::Method;
use ivdyn_core::estim::{InstrumentModel, Riv, Rls};
use ivdyn_core::params::{DRIVE_PARAM_NAMES, LINK_PARAM_NAMES, LINK_PARAMS, param_count};
use ivdyn_core::sim::{IdSample, SimConfig, Simulator};
use ivdyn_core::trajectory::Fourier;
use ivdyn_core::{Data, LinkInertia, Mat3, MatN, Model, Vec3, VecN, mass_matrix, regressor};
use nalgebra::{DMatrix, DVector, Dyn};
use std::collections::VecDeque;
use std::time::{Duration, Instant};

/// Tolerance of the physical-consistency test of the estimated last link (kg m^2 scale):
/// far below any real link's inertia, so only clearly impossible estimates are refused.
pub const CONSISTENCY_TOL: f64 = 1e-12;

/// A rigid payload fused to the last link.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Payload {
    /// Mass (kg).
    pub mass: f64,
    /// Centre of mass in the last link's frame (m).
    pub com: Vec3,
    /// Inertia about the centre of mass, last-link axes (kg m^2).
    pub inertia_com: Mat3,
}

impl Payload {
    /// A solid cube of side `side` (m) centred at `com`.
    pub fn cube(mass: f64, com: Vec3, side: f64) -> Self {
        Self { mass, com, inertia_com: Mat3::identity() * (mass * side * side / 6.0) }
    }

    /// Its 10 standard parameters about the last link's origin.
    pub fn inertia(&self) -> LinkInertia {
        LinkInertia::from_mass_com_inertia(self.mass, &self.com, &Mat3::identity(), &self.inertia_com)
    }

    /// `model` with the payload added to its last link.
    pub fn attach<const N: usize>(&self, model: &Model<N>) -> Model<N> {
        let mut m = model.clone();
        m.inertia[N - 1] = m.inertia[N - 1].add(&self.inertia());
        m
    }
}

/// The controllers compared in Fig. 5.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Scheme {
    /// (a) PD feedback only (the paper's position/velocity feedback).
    Pd,
    /// (a') PD plus the nominal (unloaded) model's gravity.
    PdGravity,
    /// (b) computed torque with the nominal (unloaded) model.
    CtNominal,
    /// (c) computed torque, switched online to nominal + payload estimate.
    CtEstimated,
    /// (d) computed torque with the true (loaded) parameters from the grasp on.
    CtTrue,
}

impl Scheme {
    /// The control law of the scheme (its model: the nominal, changed by the run for (c)
    /// and (d)).
    pub fn controller(&self) -> Controller {
        match self {
            Scheme::Pd => Controller::Pd,
            Scheme::PdGravity => Controller::PdGravity,
            Scheme::CtNominal | Scheme::CtEstimated | Scheme::CtTrue => Controller::ComputedTorque,
        }
    }

    /// All schemes, in table order.
    pub const ALL: [Scheme; 5] =
        [Scheme::Pd, Scheme::PdGravity, Scheme::CtNominal, Scheme::CtEstimated, Scheme::CtTrue];

    /// Short label.
    pub fn label(&self) -> &'static str {
        match self {
            Scheme::Pd => "a: PD",
            Scheme::PdGravity => "a': PD + nominal gravity",
            Scheme::CtNominal => "b: CT nominal",
            Scheme::CtEstimated => "c: CT + IVM estimate",
            Scheme::CtTrue => "d: CT true",
        }
    }

    /// Key for file names and JSON.
    pub fn key(&self) -> &'static str {
        match self {
            Scheme::Pd => "pd",
            Scheme::PdGravity => "pd_gravity",
            Scheme::CtNominal => "ct_nominal",
            Scheme::CtEstimated => "ct_estimated",
            Scheme::CtTrue => "ct_true",
        }
    }
}

/// Which instrument the IV estimator uses.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Instrument {
    /// The planned acceleration `qdd_d(t)` of the trajectory: noise free, exact, free.
    Planned,
    /// The paper's eq-35 model driven by the commanded torque `u`, with `b0 = 1 / M_ii` and
    /// `a = fv / M_ii` of the nominal model at the trajectory's mean pose, fed with the
    /// input and velocity `delay` samples earlier. In closed loop `u` is computed from the
    /// same encoder readings whose quantisation noise is in the measured acceleration, so
    /// an undelayed `u` is correlated with the equation error (a closed-loop IV bias);
    /// `delay >= 2` decorrelates it.
    Eq35 {
        /// Delay in samples.
        delay: usize,
    },
}

/// The online estimator's method.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum EstimatorKind {
    /// Recursive IV with this instrument (the paper's IVM).
    Iv(Instrument),
    /// Recursive least squares (the paper's LSM, biased by the acceleration noise).
    Ls,
}

/// An experiment: truth, trajectory, controller gains, sensors, estimator settings.
#[derive(Debug, Clone)]
pub struct Experiment<const N: usize> {
    /// Name (for reports).
    pub name: String,
    /// The unloaded arm as the controllers and the estimator know it.
    pub nominal: Model<N>,
    /// The unloaded arm as the simulator runs it (the truth before the grasp).
    pub truth: Model<N>,
    /// The payload grasped at `grasp_time`.
    pub payload: Payload,
    /// Reference trajectory.
    pub traj: Fourier<N, 2>,
    /// Length of the run (s).
    pub duration: f64,
    /// Grasp instant (s).
    pub grasp_time: f64,
    /// Closed-loop natural frequency (rad/s), every joint, critically damped. The PD gains
    /// are the same acceleration gains times the nominal `M_ii` at the mean pose.
    pub wn: f64,
    /// Coulomb compensation velocity of the computed-torque controllers.
    pub coulomb: CoulombVelocity,
    /// Simulator and sensors.
    pub sim: SimConfig<N>,
    /// Estimator kind.
    pub estimator: EstimatorKind,
    /// Initial covariance scale `P0 = p0 I` of the estimator.
    pub p0: f64,
    /// Rows of joints slower than this are skipped (rad/s).
    pub min_speed: f64,
    /// Switch when `std(dm) < switch_rel_std |dm|` ...
    pub switch_rel_std: f64,
    /// ... and the tracking error the estimate's uncertainty would cause,
    /// `max_i torque_std_i / (M_ii Kp)` ([`PayloadEstimator::torque_std`], nominal `M_ii`
    /// at the mean pose), is below this (rad) ...
    pub switch_error_tol: f64,
    /// ... and at least this long after the grasp (s).
    pub switch_min_time: f64,
    /// Estimated entries of the last link's inertial block (from [`BaseParams`]).
    pub columns: Vec<usize>,
    /// Their names.
    pub column_names: Vec<String>,
    /// Record every this many control steps.
    pub record_every: usize,
}

/// One recorded estimator state.
#[derive(Debug, Clone, PartialEq)]
pub struct EstimatePoint {
    /// Time (s).
    pub t: f64,
    /// Estimated changes of `columns`.
    pub theta: Vec<f64>,
    /// Standard deviation of the mass estimate (from `P`), NaN if the mass is not estimated.
    pub mass_std: f64,
    /// Tracking error the estimate's uncertainty would cause (rad), max over joints.
    pub err_std: f64,
}

/// Record of one closed-loop run.
#[derive(Debug, Clone, PartialEq)]
pub struct RunLog {
    /// The scheme.
    pub scheme: Scheme,
    /// Time (s) of each record.
    pub t: Vec<f64>,
    /// Desired positions (rad), one row per record.
    pub q_des: Vec<Vec<f64>>,
    /// True positions (rad).
    pub q: Vec<Vec<f64>>,
    /// Applied torques (N m).
    pub tau: Vec<Vec<f64>>,
    /// Tracking error `q_des - q_true` at EVERY control step (rad), one row per step.
    pub err_all: Vec<Vec<f64>>,
    /// Time of every control step.
    pub t_all: Vec<f64>,
    /// Estimator trace (only [`Scheme::CtEstimated`]).
    pub estimates: Vec<EstimatePoint>,
    /// When the controller switched to the estimate.
    pub switch_time: Option<f64>,
    /// Control steps with a saturated command.
    pub saturated_steps: usize,
    /// Wall-clock microseconds per control step (controller + estimator), mean.
    pub step_us: f64,
}

impl RunLog {
    /// RMS and peak absolute tracking error per joint over `t >= from` (rad).
    pub fn rms_peak(&self, from: f64) -> (Vec<f64>, Vec<f64>) {
        let n = self.err_all.first().map_or(0, |r| r.len());
        let (mut ss, mut pk, mut cnt) = (vec![0.0; n], vec![0.0f64; n], 0usize);
        for (t, e) in self.t_all.iter().zip(&self.err_all) {
            if *t >= from {
                cnt += 1;
                for i in 0..n {
                    ss[i] += e[i] * e[i];
                    pk[i] = pk[i].max(e[i].abs());
                }
            }
        }
        (ss.iter().map(|s| (s / cnt.max(1) as f64).sqrt()).collect(), pk)
    }

    /// Final estimate (empty if none).
    pub fn final_estimate(&self) -> Vec<f64> {
        self.estimates.last().map(|e| e.theta.clone()).unwrap_or_default()
    }
}

/// A Fourier reference `q_i(t) = q0_i + A_i [sin(w t + phi_i) + 0.3 sin(2 w t + 2 phi_i)]`
/// with `phi_i = 0.3 i`: every joint on a similar trajectory, slightly shifted.
pub fn similar_trajectories<const N: usize>(q0: [f64; N], amp: [f64; N], omega: f64) -> Fourier<N, 2> {
    let mut f = Fourier { omega, q0, a: [[0.0; 2]; N], b: [[0.0; 2]; N] };
    for i in 0..N {
        let phi = 0.3 * i as f64;
        for (l, (k, ph)) in [(1.0, phi), (0.3, 2.0 * phi)].into_iter().enumerate() {
            // (a sin - b cos) / (l w) = k A sin(l w t + ph) with a = k A l w cos ph, b = -k A l w sin ph
            let lw = (l + 1) as f64 * omega;
            f.a[i][l] = k * amp[i] * lw * ph.cos();
            f.b[i][l] = -k * amp[i] * lw * ph.sin();
        }
    }
    f
}

/// Names of the last link's 10 inertial entries, e.g. `"link6.m*cx"`.
fn last_link_names<const N: usize>() -> Vec<String> {
    LINK_PARAM_NAMES.iter().map(|p| format!("link{N}.{p}")).collect()
}

/// The identifiable entries of the last link's inertial block seen from ALL joints, from
/// the regressor sampled at `samples` random states ([`BaseParams::from_rows`]).
pub fn last_link_base<const N: usize>(model: &Model<N>, samples: usize, seed: u64) -> BaseParams {
    let mut rng = ivdyn_core::rng::Rng::new(seed);
    let mut data = Data::<N>::new();
    let mut phi = DMatrix::<f64>::zeros(samples * N, LINK_PARAMS);
    for s in 0..samples {
        let mut r = |scale: f64| VecN::<N>::from_fn(|_, _| scale * rng.uniform(-1.0, 1.0));
        let (q, qd, qdd) = (r(std::f64::consts::PI), r(1.0), r(1.0));
        let y = regressor(model, &mut data, &q, &qd, &qdd);
        for i in 0..N {
            for c in 0..LINK_PARAMS {
                phi[(s * N + i, c)] = y.link[i][N - 1][c];
            }
        }
    }
    BaseParams::from_rows(&phi, &last_link_names::<N>())
}

impl Experiment<6> {
    /// The paper's robot, 250 g payload (a 4 cm cube 3 cm out along the last link's z
    /// and 2 cm along x), 10 s run, grasp at 2 s, period-2 s trajectories of 0.5 rad,
    /// 1 kHz, 18-bit encoders, torque noise 0.01 N m, `wn = 20 rad/s`, IV with the planned
    /// acceleration.
    pub fn paper() -> Result<Self> {
        let nominal = ivdyn_core::paper::robot();
        let payload = Payload::cube(0.25, Vec3::new(0.02, 0.0, 0.03), 0.04);
        let traj = similar_trajectories([0.0, 0.8, -1.2, 0.6, 0.5, 0.0], [0.5; 6], std::f64::consts::PI);
        let mut sim = SimConfig::<6>::ideal().with_encoder_bits(18);
        sim.tau_noise = VecN::<6>::repeat(0.01);
        sim.tau_limit = VecN::<6>::repeat(20.0);
        Self::new("paper", nominal, payload, traj, sim)
    }
}

impl Experiment<7> {
    /// The Panda (`fixtures/panda.urdf`, panda_link0 -> panda_hand, the fingers locked
    /// and fused into the last link), 2 kg payload (a 10 cm
    /// cube 10 cm beyond the hand's tool origin on its z axis), torque noise 0.1 N m, URDF
    /// effort limits; otherwise as [`Experiment::paper`].
    pub fn panda(urdf: impl AsRef<std::path::Path>) -> Result<Self> {
        let opts = ivdyn::robot::urdf::UrdfOptions {
            fuse_beyond_tip: true,
            ..ivdyn::robot::urdf::UrdfOptions::new(Some("panda_link0"), Some("panda_hand"))
        };
        let robot = ivdyn::Robot::from_urdf_with(urdf, &opts)?;
        let nominal = match robot.model {
            ivdyn::DynModel::N7(m) => *m,
            _ => return Err(Error::Dimension { what: "panda chain dof".into(), expected: 7, got: robot.dof() }),
        };
        let tool = nominal.tool;
        let com = tool.rot * Vec3::new(0.0, 0.0, 0.10) + tool.trans;
        let payload = Payload::cube(2.0, com, 0.10);
        let traj = similar_trajectories([0.0, -0.3, 0.0, -2.0, 0.0, 1.8, 0.8], [0.5; 7], std::f64::consts::PI);
        let mut sim = SimConfig::<7>::ideal().with_encoder_bits(18);
        sim.tau_noise = VecN::<7>::repeat(0.1);
        sim.tau_limit = VecN::<7>::from_fn(|i, _| nominal.limits[i].effort);
        Self::new("panda", nominal, payload, traj, sim)
    }
}

impl<const N: usize> Experiment<N> {
    /// An experiment with default settings (see [`Experiment::paper`]); the estimated
    /// columns come from [`last_link_base`].
    pub fn new(
        name: &str,
        nominal: Model<N>,
        payload: Payload,
        traj: Fourier<N, 2>,
        sim: SimConfig<N>,
    ) -> Result<Self> {
        let (columns, column_names) = last_link_columns(&nominal);
        Ok(Self {
            name: name.to_string(),
            truth: nominal.clone(),
            nominal,
            payload,
            traj,
            duration: 10.0,
            grasp_time: 2.0,
            wn: 20.0,
            coulomb: CoulombVelocity::Reference,
            sim,
            estimator: EstimatorKind::Iv(Instrument::Planned),
            p0: 1e3,
            min_speed: 0.2,
            switch_rel_std: 0.05,
            switch_error_tol: 5e-3,
            switch_min_time: 0.2,
            columns,
            column_names,
            record_every: 5,
        })
    }

    /// The truth after the grasp.
    pub fn loaded(&self) -> Model<N> {
        self.payload.attach(&self.truth)
    }

    /// The true change of the estimated columns (the payload's parameters).
    pub fn truth_columns(&self) -> Vec<f64> {
        let p = self.payload.inertia();
        self.columns.iter().map(|&c| p.0[c]).collect()
    }

    /// Mean pose of the trajectory.
    fn mean_pose(&self) -> VecN<N> {
        VecN::<N>::from_column_slice(&self.traj.q0)
    }

    /// Row weights `1 / var(row error)`: torque noise plus the acceleration noise of the
    /// central second difference of quantised positions (`0.71 res / dt^2` per joint)
    /// through the nominal mass matrix at the mean pose (a first-order model of each row's
    /// equation-error variance).
    fn row_weights(&self) -> [f64; N] {
        let mut data = Data::<N>::new();
        let m = *mass_matrix(&self.nominal, &mut data, &self.mean_pose());
        let dt2 = self.sim.dt * self.sim.dt;
        let sq = |x: f64| x * x;
        let mut w = [0.0; N];
        for i in 0..N {
            let mut v = sq(self.sim.tau_noise[i]);
            for j in 0..N {
                let s_qdd =
                    (0.5f64.sqrt() * self.sim.encoder_resolution[j]).hypot(6f64.sqrt() * self.sim.q_noise[j]) / dt2;
                v += sq(m[(i, j)] * s_qdd);
            }
            w[i] = 1.0 / v.max(1e-12);
        }
        w
    }

    /// A fresh online estimator (no allocation in its update for a fixed column count;
    /// here `Dyn` since the count is found at run time).
    pub fn make_estimator(&self) -> Result<PayloadEstimator<N, Dyn>> {
        let b = self.columns.len();
        let method = match self.estimator {
            EstimatorKind::Iv(_) => Method::Iv(Riv::new(DVector::zeros(b), self.p0)),
            EstimatorKind::Ls => Method::Ls(Rls::new(DVector::zeros(b), self.p0)),
        };
        Ok(PayloadEstimator::new(
            self.nominal.clone(),
            DVector::from_vec(self.columns.clone()),
            self.row_weights(),
            self.min_speed,
            method,
        )?)
    }

    /// Runs one scheme: [`ivdyn::closed_loop::run_loop`] with the scheme's controller on
    /// the nominal model, the grasp, the record and the online estimation as its
    /// [`SchemeRun`] hook.
    pub fn run(&self, scheme: Scheme) -> Result<RunLog> {
        let (r0q, r0qd, _) = self.traj.eval(0.0);
        let mut sim = Simulator::new(self.truth.clone(), self.sim, &r0q, &r0qd)?;
        let mut data = Data::<N>::new();
        let m0 = *mass_matrix(&self.nominal, &mut data, &self.mean_pose());
        let gains = Gains::<N>::critically_damped(self.wn);
        let mut ctrl =
            LoopController::new(scheme.controller(), self.nominal.clone(), gains, self.coulomb, &self.mean_pose());
        let steps = (self.duration / self.sim.dt).round() as usize;
        let mut run = SchemeRun {
            exp: self,
            scheme,
            loaded: self.loaded(),
            grasped: false,
            online: OnlineEstimation::new(self, &mut data, m0, gains)?,
            log: RunLog::with_capacity(scheme, steps),
            busy: Duration::ZERO,
        };
        let dt = self.sim.dt;
        run_loop(&mut sim, &mut ctrl, steps, |k| Reference::from_tuple(self.traj.eval(k as f64 * dt)), &mut run)?;
        let mut log = run.log;
        log.step_us = run.busy.as_secs_f64() * 1e6 / steps.max(1) as f64;
        Ok(log)
    }
}

/// One run of a Fig. 5 scheme, called around each control step of [`run_loop`]: the
/// grasp, the record, and scheme (c)'s online estimation writing into the controller's model.
struct SchemeRun<'a, const N: usize> {
    exp: &'a Experiment<N>,
    scheme: Scheme,
    /// The truth after the grasp.
    loaded: Model<N>,
    grasped: bool,
    online: OnlineEstimation<N>,
    log: RunLog,
    /// Wall-clock time of the controller and the estimator.
    busy: Duration,
}

impl<const N: usize> StepHook<N> for SchemeRun<'_, N> {
    fn before(
        &mut self,
        k: usize,
        r: &Reference<N>,
        sim: &mut Simulator<N>,
        ctrl: &mut LoopController<N>,
    ) -> Result<()> {
        let t = k as f64 * self.exp.sim.dt;
        if !self.grasped && t >= self.exp.grasp_time {
            self.grasped = true;
            sim.set_model(self.loaded.clone());
            // scheme (d) is told the true loaded model, the others keep theirs
            if self.scheme == Scheme::CtTrue {
                ctrl.model = self.loaded.clone();
            }
        }
        self.log.record(self.exp.record_every, k, t, r, sim);
        Ok(())
    }

    fn after(
        &mut self,
        k: usize,
        step: &StepOutcome<N>,
        sim: &Simulator<N>,
        ctrl: &mut LoopController<N>,
    ) -> Result<()> {
        self.busy += step.control_time;
        if sim.saturated {
            self.log.saturated_steps += 1;
        }
        // online estimation from the grasp on (the controller knows when it closes its
        // gripper), one sample late (central differences)
        if let (Scheme::CtEstimated, Some(smp)) = (self.scheme, step.sample) {
            let t = k as f64 * self.exp.sim.dt;
            self.busy += self.online.update(self.exp, smp, t, k, &mut ctrl.model, &mut self.log);
        }
        Ok(())
    }
}

impl RunLog {
    /// An empty log of `scheme` with room for `steps` control steps (no reallocation in the loop).
    fn with_capacity(scheme: Scheme, steps: usize) -> Self {
        RunLog {
            scheme,
            t: vec![],
            q_des: vec![],
            q: vec![],
            tau: vec![],
            err_all: Vec::with_capacity(steps),
            t_all: Vec::with_capacity(steps),
            estimates: vec![],
            switch_time: None,
            saturated_steps: 0,
            step_us: 0.0,
        }
    }

    /// Logs control step `k` at time `t` before the simulator advances: the tracking error
    /// `q_d - q` every step (for the RMS tables), the reference, true position and applied
    /// torque every `every` steps (for the plots).
    fn record<const N: usize>(&mut self, every: usize, k: usize, t: f64, r: &Reference<N>, sim: &Simulator<N>) {
        let e: Vec<f64> = (0..N).map(|i| r.q[i] - sim.q[i]).collect();
        if k.is_multiple_of(every) {
            self.t.push(t);
            self.q_des.push(r.q.as_slice().to_vec());
            self.q.push(sim.q.as_slice().to_vec());
            self.tau.push(sim.tau_applied.as_slice().to_vec());
        }
        self.t_all.push(t);
        self.err_all.push(e);
    }
}

/// The online payload estimation of scheme (c) (paper eqs 38-54 with only the last link
/// unknown) and its rule for switching the controller to nominal + estimate.
struct OnlineEstimation<const N: usize> {
    /// The recursive IV (or LS) estimator of the last link's change.
    est: PayloadEstimator<N, Dyn>,
    /// The eq-35 model of the acceleration from the input ([`Instrument::Eq35`]).
    instr: InstrumentModel<N>,
    /// The last 8 identification samples, for the delayed eq-35 instrument.
    history: VecDeque<IdSample<N>>,
    /// Position of the mass among the estimated columns, if estimated.
    mass_col: Option<usize>,
    /// Nominal mass matrix at the mean pose and the acceleration gains `Kp`: turn a torque
    /// uncertainty into a tracking error.
    m0: MatN<N>,
    kp: VecN<N>,
    /// Scratch: the estimate's torque standard deviation per joint.
    tstd: VecN<N>,
}

impl<const N: usize> OnlineEstimation<N> {
    /// A fresh estimator of `exp` ([`Experiment::make_estimator`]) and its instrument model.
    fn new(exp: &Experiment<N>, data: &mut Data<N>, m0: MatN<N>, gains: Gains<N>) -> Result<Self> {
        let est = exp.make_estimator()?;
        let instr = InstrumentModel::from_nominal(&exp.nominal, data, &exp.mean_pose());
        let mass_col = est.column_of(0);
        Ok(Self { est, instr, history: VecDeque::new(), mass_col, m0, kp: gains.kp, tstd: VecN::<N>::zeros() })
    }

    /// Feeds the identification sample `smp` (returned at control step `k`, time `t`) to
    /// the estimator once the payload is grasped, then switches to or refreshes the
    /// estimate in `ctrl_model`. Returns the wall-clock time spent (part of the step time).
    fn update(
        &mut self,
        exp: &Experiment<N>,
        smp: IdSample<N>,
        t: f64,
        k: usize,
        ctrl_model: &mut Model<N>,
        log: &mut RunLog,
    ) -> Duration {
        self.history.push_back(smp);
        if self.history.len() > 8 {
            self.history.pop_front();
        }
        if smp.t < exp.grasp_time {
            return Duration::ZERO;
        }
        let t1 = Instant::now();
        let Some(zacc) = self.instrument(exp, &smp) else { return Duration::ZERO };
        // a degenerate row leaves the estimator unchanged: skip it
        let _ = self.est.update(&smp.x.q, &smp.x.qd, &smp.x.qdd, &smp.tau, &zacc);
        let mass_std = self.mass_col.map_or(f64::NAN, |b| self.est.variance(b).max(0.0).sqrt());
        let err_std = if log.switch_time.is_none() {
            self.switch_if_ready(exp, smp.t, t, mass_std, ctrl_model, log)
        } else {
            // refresh every step; an inconsistent estimate keeps the last good one
            self.est.write_model_if_consistent(ctrl_model, CONSISTENCY_TOL);
            f64::NAN
        };
        let busy = t1.elapsed();
        if k.is_multiple_of(exp.record_every) {
            let theta = self.est.theta().iter().copied().collect();
            log.estimates.push(EstimatePoint { t: smp.t, theta, mass_std, err_std });
        }
        busy
    }

    /// The instrumental acceleration for `smp`: the planned one (LS ignores it), or the
    /// eq-35 model driven by the input `delay` samples earlier (`None` while the history
    /// is shorter than that).
    fn instrument(&self, exp: &Experiment<N>, smp: &IdSample<N>) -> Option<VecN<N>> {
        match exp.estimator {
            EstimatorKind::Iv(Instrument::Planned) | EstimatorKind::Ls => Some(exp.traj.eval(smp.t).2),
            EstimatorKind::Iv(Instrument::Eq35 { delay }) => {
                let n = self.history.len();
                if n < delay + 2 {
                    return None;
                }
                let (uu, prev) = (&self.history[n - 1 - delay], &self.history[n - 2 - delay]);
                Some(self.instr.qdd_hat(&uu.u, &prev.x.qd))
            }
        }
    }

    /// Before the switch: the tracking error the estimate's uncertainty would cause,
    /// `max_i torque_std_i / (M_ii Kp_i)` (returned, rad), and the switch at the next step
    /// (`t + dt`) once the sample at `smp_t` is `switch_min_time` past the grasp, the mass
    /// is known to `switch_rel_std`, that error is below `switch_error_tol` and the
    /// estimate is physically consistent.
    fn switch_if_ready(
        &mut self,
        exp: &Experiment<N>,
        smp_t: f64,
        t: f64,
        mass_std: f64,
        ctrl_model: &mut Model<N>,
        log: &mut RunLog,
    ) -> f64 {
        self.est.torque_std(&mut self.tstd);
        let err_std = (0..N).map(|i| self.tstd[i] / (self.m0[(i, i)] * self.kp[i])).fold(0.0, f64::max);
        if let Some(b) = self.mass_col {
            let dm = self.est.theta()[b];
            if smp_t - exp.grasp_time >= exp.switch_min_time
                && mass_std < exp.switch_rel_std * dm.abs()
                && err_std < exp.switch_error_tol
                && self.est.write_model_if_consistent(ctrl_model, CONSISTENCY_TOL)
            {
                log.switch_time = Some(t + exp.sim.dt);
            }
        }
        err_std
    }
}

/// What [`Experiment::with_identified_nominal`] found.
#[derive(Debug, Clone)]
pub struct NominalIdentification {
    /// The batch IV fit of the unloaded arm's base parameters.
    pub fit: ivdyn::ident::FitReport,
    /// Rows used.
    pub rows: usize,
    /// RMS over one period of the reference trajectory of the torque difference to the
    /// true unloaded arm (simulation only: the truth is known), per joint (N m), for the
    /// prior model.
    pub rms_prior: Vec<f64>,
    /// The same for the identified model.
    pub rms_identified: Vec<f64>,
}

impl<const N: usize> Experiment<N> {
    /// The paper's experiment: identify the unloaded arm first. Starting from `prior` (a
    /// wrong model), the TRUE unloaded arm tracks the trajectory for `seconds` under computed
    /// torque with the prior; its base parameters (all links, Coulomb and viscous friction)
    /// are fitted by batch IV (instrument: the planned acceleration; rows of joints slower
    /// than `min_speed` skipped), and the nominal model becomes
    /// `prior + to_full(theta_base - project(prior))`: the prior with its identifiable part
    /// replaced. The payload is then estimated against that model.
    pub fn with_identified_nominal(mut self, prior: Model<N>, seconds: f64) -> Result<(Self, NominalIdentification)> {
        // one RNEA workspace for the base-parameter search, the controller and the rows
        let mut data = Data::<N>::new();
        let base = arm_base_params(&prior, &mut data);
        let rows = self.unloaded_iv_rows(&prior, &base, seconds, &mut data)?;
        let fit = rows.fit()?;
        let identified = replace_identifiable(&prior, &base, &fit.theta)?;
        let info = NominalIdentification {
            rows: rows.y.len(),
            rms_prior: self.model_torque_rms(&prior),
            rms_identified: self.model_torque_rms(&identified),
            fit,
        };
        (self.columns, self.column_names) = last_link_columns(&identified);
        self.nominal = identified;
        Ok((self, info))
    }

    /// The unloaded truth tracking the reference for `seconds` under computed torque with
    /// `prior`, and its batch-IV rows from 0.5 s on (after the start-up transient).
    fn unloaded_iv_rows<'a>(
        &self,
        prior: &'a Model<N>,
        base: &'a BaseParams,
        seconds: f64,
        data: &mut Data<N>,
    ) -> Result<UnloadedRows<'a, N>> {
        let (r0q, r0qd, _) = self.traj.eval(0.0);
        let mut sim = Simulator::new(self.truth.clone(), self.sim, &r0q, &r0qd)?;
        let gains = Gains::<N>::critically_damped(self.wn);
        let mut ctrl =
            LoopController::new(Controller::ComputedTorque, prior.clone(), gains, self.coulomb, &self.mean_pose());
        let mut run = UnloadedRun { rows: UnloadedRows::new(prior, base, self.min_speed), data, traj: &self.traj };
        let steps = (seconds / self.sim.dt).round() as usize;
        let dt = self.sim.dt;
        run_loop(&mut sim, &mut ctrl, steps, |k| Reference::from_tuple(self.traj.eval(k as f64 * dt)), &mut run)?;
        Ok(run.rows)
    }

    /// RMS over one period of the reference (2000 points) of `rnea(m) - rnea(truth)` per
    /// joint (N m): how far `m` is from the true unloaded arm (simulation only).
    fn model_torque_rms(&self, m: &Model<N>) -> Vec<f64> {
        let (mut d1, mut d2) = (Data::<N>::new(), Data::<N>::new());
        let mut s2 = vec![0.0; N];
        let n = 2000;
        for k in 0..n {
            let (q, qd, qdd) = self.traj.eval(k as f64 * self.traj.period() / n as f64);
            let a = *ivdyn_core::rnea(m, &mut d1, &q, &qd, &qdd);
            let t = *ivdyn_core::rnea(&self.truth, &mut d2, &q, &qd, &qdd);
            for i in 0..N {
                s2[i] += (a[i] - t[i]).powi(2);
            }
        }
        s2.iter().map(|v| (v / n as f64).sqrt()).collect()
    }
}

/// Names of the `14 N` full parameters: `link<j>.<inertial>`, then `joint<j>.<drive>`.
fn full_param_names<const N: usize>() -> Vec<String> {
    (0..param_count(N))
        .map(|c| {
            if c < LINK_PARAMS * N {
                format!("link{}.{}", c / LINK_PARAMS + 1, LINK_PARAM_NAMES[c % LINK_PARAMS])
            } else {
                let d = c - LINK_PARAMS * N;
                format!("joint{}.{}", d / 4 + 1, DRIVE_PARAM_NAMES[d % 4])
            }
        })
        .collect()
}

/// The base parameters of the whole arm (inertial + drive), from the regressor of `prior`
/// at random states (seed 11): what a batch fit of the unloaded arm can identify.
fn arm_base_params<const N: usize>(prior: &Model<N>, data: &mut Data<N>) -> BaseParams {
    let p = param_count(N);
    let names = full_param_names::<N>();
    let mut rng = ivdyn_core::rng::Rng::new(11);
    let samples = 12 * p / N + 20;
    let mut phi_r = DMatrix::<f64>::zeros(samples * N, p);
    let mut row = vec![0.0; N * p];
    for s in 0..samples {
        let mut r = |scale: f64| VecN::<N>::from_fn(|_, _| scale * rng.uniform(-1.0, 1.0));
        let (q, qd, qdd) = (r(std::f64::consts::PI), r(1.0), r(1.0));
        regressor(prior, data, &q, &qd, &qdd).write_row_major(&mut row);
        for i in 0..N {
            for c in 0..p {
                phi_r[(s * N + i, c)] = row[i * p + c];
            }
        }
    }
    // pivoted, as when docs/control.md's runs were made (the choice of columns decides
    // which full parameters a fit moves)
    BaseParams::from_rows_pivoted(&phi_r, &names)
}

/// The unloaded run of [`Experiment::with_identified_nominal`] as a [`StepHook`]: each
/// identification sample from 0.5 s on (after the start-up transient) becomes rows.
struct UnloadedRun<'a, 'b, const N: usize> {
    rows: UnloadedRows<'a, N>,
    data: &'b mut Data<N>,
    traj: &'b Fourier<N, 2>,
}

impl<const N: usize> StepHook<N> for UnloadedRun<'_, '_, N> {
    fn before(&mut self, _: usize, _: &Reference<N>, _: &mut Simulator<N>, _: &mut LoopController<N>) -> Result<()> {
        Ok(())
    }

    fn after(&mut self, _: usize, step: &StepOutcome<N>, _: &Simulator<N>, _: &mut LoopController<N>) -> Result<()> {
        match step.sample {
            Some(smp) if smp.t >= 0.5 => self.rows.push(self.data, &smp, &self.traj.eval(smp.t).2),
            _ => Ok(()),
        }
    }
}

/// Batch-IV rows of the unloaded arm in the base columns of `base`: the regressor of
/// `prior` at the measured state, the instrument (the same regressor at the planned
/// acceleration, noise free), the measured torque.
struct UnloadedRows<'a, const N: usize> {
    /// The model the regressor is evaluated with (its parameters do not enter the rows).
    prior: &'a Model<N>,
    /// The base parameters the rows are reduced to.
    base: &'a BaseParams,
    /// Rows of joints slower than this are skipped (rad/s): see [`Experiment::min_speed`].
    min_speed: f64,
    /// Regressor rows, `rows x b` row-major.
    phi: Vec<f64>,
    /// Instrument rows, `rows x b` row-major.
    z: Vec<f64>,
    /// Measured torques, `rows`.
    y: Vec<f64>,
    /// Scratch: the full `N x 14N` regressor at the measured and at the planned
    /// acceleration (row-major), one row in base columns, and the latter's workspace.
    row: Vec<f64>,
    zrow: Vec<f64>,
    rb: Vec<f64>,
    dz: Data<N>,
}

impl<'a, const N: usize> UnloadedRows<'a, N> {
    /// No rows yet.
    fn new(prior: &'a Model<N>, base: &'a BaseParams, min_speed: f64) -> Self {
        let p = param_count(N);
        Self {
            prior,
            base,
            min_speed,
            phi: vec![],
            z: vec![],
            y: vec![],
            row: vec![0.0; N * p],
            zrow: vec![0.0; N * p],
            rb: vec![0.0; base.base_count()],
            dz: Data::<N>::new(),
        }
    }

    /// Adds the rows of sample `smp`, instrument at the planned acceleration `zacc`: one
    /// per joint moving faster than `min_speed`.
    fn push(&mut self, data: &mut Data<N>, smp: &IdSample<N>, zacc: &VecN<N>) -> Result<()> {
        let p = param_count(N);
        regressor(self.prior, data, &smp.x.q, &smp.x.qd, &smp.x.qdd).write_row_major(&mut self.row);
        regressor(self.prior, &mut self.dz, &smp.x.q, &smp.x.qd, zacc).write_row_major(&mut self.zrow);
        for i in 0..N {
            if smp.x.qd[i].abs() < self.min_speed {
                continue;
            }
            self.base.select_row(&self.row[i * p..(i + 1) * p], &mut self.rb)?;
            self.phi.extend_from_slice(&self.rb);
            self.base.select_row(&self.zrow[i * p..(i + 1) * p], &mut self.rb)?;
            self.z.extend_from_slice(&self.rb);
            self.y.push(smp.tau[i]);
        }
        Ok(())
    }

    /// The batch IV fit of the base parameters; an error if the trajectory leaves some of
    /// them unexcited (the nominal model would then be a guess there).
    fn fit(&self) -> Result<FitReport> {
        let mut acc = IvAccumulator::new(self.base.base_count());
        acc.add_rows(&self.phi, &self.z, &self.y, None)?;
        let fit = fit_iv(&acc, &self.base.names)?;
        if !fit.unexcited.is_empty() {
            return Err(Error::Numerical {
                what: "unloaded-arm identification".into(),
                msg: format!("not excited by the trajectory: {:?}", fit.unexcited),
            });
        }
        Ok(fit)
    }
}

/// `prior + to_full(theta_base - project(prior))` ([`BaseParams::apply`]): the prior with
/// its identifiable part replaced by the fitted base parameters `theta_base`.
fn replace_identifiable<const N: usize>(prior: &Model<N>, base: &BaseParams, theta_base: &[f64]) -> Result<Model<N>> {
    let mut theta_prior = vec![0.0; param_count(N)];
    prior.params_to_slice(&mut theta_prior)?;
    let full = base.apply(theta_base, &theta_prior, 1.0)?;
    let mut identified = prior.clone();
    identified.set_params_from_slice(&full)?;
    Ok(identified)
}

/// The entries of the last link's inertial block the payload estimator estimates
/// ([`last_link_base`] of `model`), and their base-parameter names.
fn last_link_columns<const N: usize>(model: &Model<N>) -> (Vec<usize>, Vec<String>) {
    let base = last_link_base(model, 40, 7);
    let names = base.independent.iter().map(|&c| base_name(&base, c)).collect();
    (base.independent, names)
}

/// Name of full column `c` in `base` (the base parameter built on it).
fn base_name(base: &BaseParams, c: usize) -> String {
    base.independent
        .iter()
        .position(|&i| i == c)
        .map(|j| base.names[j].clone())
        .unwrap_or_else(|| format!("theta[{c}]"))
}

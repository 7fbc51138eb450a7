//! `simulate`: a synthetic log, the true model's inverse dynamics (`rnea`, exact torques,
//! no integration) along a trajectory, then noise and quantisation of the recorded signals.

use serde::Serialize;

use crate::dsp;
use crate::error::{Error, Result};
use crate::limits;
use crate::log::JointLog;
use std::path::{Path, PathBuf};

use super::Outcome;
use super::io::stage_log;
use crate::Robot;
use crate::output::OutputSet;
use crate::progress::{ProgressSink, Stage};
use crate::report::{ParamsFile, PayloadSpec};
use ivdyn_core::params::LINK_PARAMS;
use ivdyn_core::rng::Rng;

// ---------------------------------------------------------------------------------------
// simulate
// ---------------------------------------------------------------------------------------

/// The trajectory to simulate.
#[derive(Debug, Clone, PartialEq)]
pub enum Trajectory {
    /// Built-in random Fourier excitation (options in [`SimulateOptions`]).
    Fourier,
    /// Given positions `T x N` at times `t` (velocity and acceleration by central
    /// differences).
    Samples {
        /// Times (s), increasing.
        t: Vec<f64>,
        /// Positions `T x N`.
        q: Vec<f64>,
    },
}

/// Options of [`simulate`].
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct SimulateOptions {
    /// Sample rate (Hz) of the Fourier trajectory (default 500).
    pub rate_hz: f64,
    /// Duration (s) of the Fourier trajectory (default 20).
    pub duration_s: f64,
    /// Seed of the trajectory and the noise.
    pub seed: u64,
    /// Fourier: fundamental frequency (Hz, default 0.1) and harmonics (default 5).
    pub base_freq_hz: f64,
    /// Number of harmonics.
    pub harmonics: usize,
    /// Fourier: peak amplitude per joint (rad or m, default 0.8), capped to 40 % of the
    /// joint range.
    pub amplitude: f64,
    /// Payload on the last link.
    pub payload: Option<PayloadSpec>,
    /// Coulomb friction per joint (replaces the model's).
    pub fc: Option<Vec<f64>>,
    /// Viscous friction per joint.
    pub fv: Option<Vec<f64>>,
    /// Standard deviation of white noise on the recorded torque (N m).
    pub noise_tau: f64,
    /// Standard deviation of white noise on the recorded position.
    pub noise_q: f64,
    /// Encoder resolution: positions rounded to `2 pi / 2^bits`.
    pub encoder_bits: Option<u32>,
    /// Torque resolution (N m): recorded torques rounded to multiples of it.
    pub tau_resolution: Option<f64>,
    /// Write the exact velocities in the log (default true).
    pub write_velocity: bool,
    /// Record the noise-free true torque as the actuator command `u` (MCAP topic
    /// `/ivdyn/command`, CSV columns `<joint>.u`), as a torque-controlled arm's command.
    pub write_command: bool,
}

impl Default for SimulateOptions {
    fn default() -> Self {
        SimulateOptions {
            rate_hz: 500.0,
            duration_s: 20.0,
            seed: 1,
            base_freq_hz: 0.1,
            harmonics: 5,
            amplitude: 0.8,
            payload: None,
            fc: None,
            fv: None,
            noise_tau: 0.0,
            noise_q: 0.0,
            encoder_bits: None,
            tau_resolution: None,
            write_velocity: true,
            write_command: false,
        }
    }
}

/// The true model of a simulation: `robot` with the payload and friction of `opts`.
pub fn true_robot(robot: &Robot, opts: &SimulateOptions) -> Result<Robot> {
    let n = robot.dof();
    let mut r = robot.clone();
    let mut theta = r.params();
    if let Some(p) = &opts.payload {
        let li = p.link_inertia();
        let off = (n - 1) * LINK_PARAMS;
        for k in 0..LINK_PARAMS {
            theta[off + k] += li.0[k];
        }
    }
    for (idx, v) in [(0usize, &opts.fc), (1, &opts.fv)] {
        if let Some(v) = v {
            if v.len() != n {
                return Err(Error::Dimension {
                    what: if idx == 0 { "fc (one per joint)".into() } else { "fv (one per joint)".into() },
                    expected: n,
                    got: v.len(),
                });
            }
            for j in 0..n {
                theta[LINK_PARAMS * n + 4 * j + idx] = v[j];
            }
        }
    }
    r.set_params(&theta)?;
    Ok(r)
}

/// The built-in excitation: `(t, q, qd, qdd)`, `q_j(t) = q0_j + sum_l A_jl sin(2 pi l f0 t + phi_jl)`
/// with random amplitudes `A_jl` (falling as `1/l`, summing to the joint's amplitude) and
/// phases `phi_jl`. Sampled by [`crate::excite::sample`], the one Fourier series (the core's
/// [`ivdyn_core::trajectory::Fourier`]), in its sine/cosine coefficients:
/// `A sin(x + phi) = A cos(phi) sin(x) + A sin(phi) cos(x)`, and the core's harmonic `l` is
/// `(a sin(x) - b cos(x)) / (l w)`, so `a = l w A cos(phi)` and `b = -l w A sin(phi)`.
pub fn fourier_trajectory(robot: &Robot, opts: &SimulateOptions) -> (Vec<f64>, Vec<f64>, Vec<f64>, Vec<f64>) {
    let n = robot.dof();
    let limits = crate::with_model!(&robot.model, m => m.limits.to_vec());
    let mut rng = Rng::new(opts.seed);
    let h = opts.harmonics.max(1);
    let omega = std::f64::consts::TAU * opts.base_freq_hz;
    let mut co = crate::excite::Coeffs { n, h, omega, q0: vec![0.0; n], a: vec![0.0; n * h], b: vec![0.0; n * h] };
    for j in 0..n {
        let l = &limits[j];
        let mut amp = opts.amplitude;
        if l.lower.is_finite() && l.upper.is_finite() && l.upper > l.lower {
            co.q0[j] = if l.upper - l.lower < 2.0 * std::f64::consts::TAU { 0.5 * (l.lower + l.upper) } else { 0.0 };
            amp = amp.min(0.4 * (l.upper - l.lower));
        }
        let raw: Vec<(f64, f64)> =
            (0..h).map(|k| (rng.uniform(0.3, 1.0) / (k + 1) as f64, rng.uniform(0.0, std::f64::consts::TAU))).collect();
        let s: f64 = raw.iter().map(|(a, _)| a).sum();
        for (k, &(r, phase)) in raw.iter().enumerate() {
            let (lw, amp_k) = ((k + 1) as f64 * omega, r * amp / s);
            co.a[j * h + k] = lw * amp_k * phase.cos();
            co.b[j * h + k] = -lw * amp_k * phase.sin();
        }
    }
    let steps = (opts.duration_s * opts.rate_hz).round().max(2.0) as usize;
    let t: Vec<f64> = (0..steps).map(|s| s as f64 / opts.rate_hz).collect();
    let s = crate::excite::sample(&co, &t);
    (s.t, s.q, s.qd, s.qdd)
}

/// A synthetic log: the true model's inverse dynamics (`rnea`, with payload and friction)
/// along the trajectory, then noise and quantisation of the recorded `q` and `tau`.
pub fn simulate(robot: &Robot, traj: &Trajectory, opts: &SimulateOptions) -> Result<JointLog> {
    opts.check()?;
    let n = robot.dof();
    let truth = true_robot(robot, opts)?;
    let (t, q, qd, qdd) = match traj {
        Trajectory::Fourier => fourier_trajectory(robot, opts),
        Trajectory::Samples { t, q } => {
            if t.len() < 3 || q.len() != t.len() * n {
                return Err(Error::Dimension {
                    what: "trajectory q (T x N, T >= 3)".into(),
                    expected: t.len().max(3) * n,
                    got: q.len(),
                });
            }
            let dt = dsp::median_dt(t).ok_or_else(|| Error::option("traj", "needs increasing times"))?;
            if t.windows(2).any(|w| ((w[1] - w[0]) - dt).abs() > 1e-6 * dt.max(1e-9) + 1e-9) {
                return Err(Error::option("traj", "times must be uniformly spaced"));
            }
            (t.clone(), q.clone(), dsp::central_diff(q, n, dt)?, dsp::second_diff(q, n, dt)?)
        }
    };
    let mut tau = vec![0.0; q.len()];
    crate::batch::rnea_batch(&truth, &q, &qd, &qdd, &mut tau)?;
    let u = if opts.write_command { Some(tau.clone()) } else { None };
    let mut rng = Rng::new(opts.seed.wrapping_add(0x5eed));
    let mut qm = q.clone();
    for v in qm.iter_mut() {
        if opts.noise_q > 0.0 {
            *v += opts.noise_q * rng.normal();
        }
        if let Some(bits) = opts.encoder_bits {
            let r = std::f64::consts::TAU / 2f64.powi(bits as i32);
            *v = (*v / r).round() * r;
        }
    }
    for v in tau.iter_mut() {
        if opts.noise_tau > 0.0 {
            *v += opts.noise_tau * rng.normal();
        }
        if let Some(r) = opts.tau_resolution
            && r > 0.0
        {
            *v = (*v / r).round() * r;
        }
    }
    let log = JointLog {
        joint_names: robot.joint_names.clone(),
        t0_ns: 0,
        t,
        q: qm,
        qd: if opts.write_velocity { Some(qd) } else { None },
        tau: Some(tau),
        u,
        current: None,
        truncated: false,
    };
    check_simulated(&log)?;
    Ok(log)
}

/// The simulated values are finite and within [`limits::MAX_MAGNITUDE`]: options that
/// are each in range can still combine into torques no reader accepts (a 1e4 kg payload
/// on a long arm, a URDF with huge inertials); that must fail here, not write the log.
fn check_simulated(log: &JointLog) -> Result<()> {
    let n = log.dof().max(1);
    for (field, a) in log.fields() {
        let Some(a) = a else { continue };
        if let Some(i) = a.iter().position(|x| !(x.abs() <= limits::MAX_MAGNITUDE)) {
            return Err(Error::Diverged {
                what: "simulate".into(),
                sample: i / n,
                detail: format!(
                    ": joint '{}' {field} is {:e}, beyond the {:e} a log may hold (check the payload, friction and noise options, and the URDF's inertials)",
                    log.joint_names[i % n],
                    a[i],
                    limits::MAX_MAGNITUDE
                ),
            });
        }
    }
    Ok(())
}

impl PayloadSpec {
    /// A payload from its parts as a user gives them (`mass` in kg, `com` x, y, z in m,
    /// `inertia` Ixx, Ixy, Iyy, Ixz, Iyz, Izz (ivdyn's order) in kg m^2 about the COM; the last two
    /// default to zero); `None` when nothing is given.
    pub fn from_parts(mass: Option<f64>, com: Option<&[f64]>, inertia: Option<&[f64]>) -> Result<Option<PayloadSpec>> {
        let Some(m) = mass else {
            return match (com, inertia) {
                (None, None) => Ok(None),
                _ => Err(Error::option("payload_com/payload_inertia", "need payload_mass")),
            };
        };
        let (m, com, inertia) = crate::limits::payload_parts(m, com, inertia)?;
        let (com, inertia) = (com.unwrap_or([0.0; 3]), inertia.unwrap_or([0.0; 6]));
        Ok(Some(PayloadSpec { mass: m, com, inertia }))
    }
}

/// Most bits of a simulated encoder: beyond 52 the step `2 pi / 2^bits` is below the
/// spacing of f64 angles near pi, so the rounding would do nothing.
pub const MAX_ENCODER_BITS: u32 = 52;

impl SimulateOptions {
    /// Rejects values that cannot give a log (docs/reliability.md): non-finite or
    /// non-positive duration and rate, more than [`limits::MAX_SAMPLES`] samples, harmonics
    /// outside `1..=MAX_HARMONICS` or above the Nyquist frequency, noises, amplitude,
    /// friction and torque resolution outside `[0, MAX_MAGNITUDE]`, encoder bits outside
    /// `1..=MAX_ENCODER_BITS`.
    pub fn check(&self) -> Result<()> {
        for (name, x) in [("duration", self.duration_s), ("rate", self.rate_hz), ("base_freq", self.base_freq_hz)] {
            if !(x > 0.0 && x.is_finite()) {
                return Err(Error::option(name, format!("must be finite and > 0, got {x}")));
            }
        }
        limits::samples_bounded(self.duration_s, self.rate_hz)?;
        limits::count_in("harmonics", self.harmonics, 1, limits::MAX_HARMONICS)?;
        let top = self.harmonics as f64 * self.base_freq_hz;
        if !(top < 0.5 * self.rate_hz) {
            return Err(Error::option(
                "base_freq",
                format!(
                    "{} harmonics of {} Hz reach {top} Hz, above the Nyquist frequency {} Hz of the rate",
                    self.harmonics,
                    self.base_freq_hz,
                    0.5 * self.rate_hz
                ),
            ));
        }
        let mag = limits::MAX_MAGNITUDE;
        for (name, x) in [("noise", self.noise_tau), ("noise_q", self.noise_q), ("amplitude", self.amplitude)] {
            limits::in_range(name, x, 0.0, mag)?;
        }
        limits::in_range("tau_resolution", self.tau_resolution.unwrap_or(0.0), 0.0, mag)?;
        limits::count_in("encoder_bits", self.encoder_bits.unwrap_or(1) as usize, 1, MAX_ENCODER_BITS as usize)?;
        limits::all_in_range("fc", self.fc.as_deref().unwrap_or(&[]), 0.0, mag)?;
        limits::all_in_range("fv", self.fv.as_deref().unwrap_or(&[]), 0.0, mag)
    }
}

/// One `simulate` run: the options, the trajectory, and where the log and the summary go.
#[derive(Debug, Clone)]
pub struct SimulateJob {
    /// Options (checked by [`SimulateOptions::check`]).
    pub opts: SimulateOptions,
    /// The trajectory.
    pub traj: Trajectory,
    /// The log file (`.mcap` or `.csv`).
    pub out: Option<PathBuf>,
    /// The JSON summary.
    pub json: Option<PathBuf>,
}

/// What was simulated (`simulate --json`): the options and the true parameters.
#[derive(Debug, Clone, Serialize)]
pub struct SimulateSummary {
    /// The log file.
    pub out: Option<String>,
    /// Samples written.
    pub samples: usize,
    /// Joint names.
    pub joints: Vec<String>,
    /// The options.
    pub options: SimulateOptions,
    /// Parameters of the true model (payload and friction included).
    pub true_params: ParamsFile,
}

impl Trajectory {
    /// A trajectory from a CSV file (columns `t`, `<joint>.q`; uniform times).
    pub fn from_csv(path: &Path, robot: &Robot) -> Result<Trajectory> {
        let l = crate::log::read_csv(path, &robot.joint_names)?;
        l.validate(path)?;
        Ok(Trajectory::Samples { t: l.t, q: l.q })
    }
}

/// Runs `job` on `robot`: the log, written to `job.out`, and the summary (both files or
/// neither).
pub fn simulate_job(
    robot: &Robot,
    job: &SimulateJob,
    progress: &ProgressSink,
) -> Result<Outcome<(JointLog, SimulateSummary)>> {
    job.opts.check()?;
    let log = {
        let _st = Stage::begin(progress, "simulating", 0);
        simulate(robot, &job.traj, &job.opts)?
    };
    let truth = true_robot(robot, &job.opts)?;
    let mut written = vec![];
    // all of the command's files or none of them
    let mut set = OutputSet::new();
    if let Some(p) = &job.out {
        stage_log(&mut set, p, &log)?;
        let secs = log.t.last().copied().unwrap_or(0.0);
        written.push(format!("wrote {} samples of {} joints ({secs:.2} s) to {}", log.len(), log.dof(), p.display()));
    }
    let true_params = ParamsFile::new(
        &robot.name,
        robot.joint_names.clone(),
        robot.param_names(),
        truth.params(),
        &truth.coulomb_shapes(),
    );
    let summary = SimulateSummary {
        out: job.out.as_ref().map(|p| p.display().to_string()),
        samples: log.len(),
        joints: robot.joint_names.clone(),
        options: job.opts.clone(),
        true_params,
    };
    if let Some(p) = &job.json {
        set.write_json(p, &summary)?;
    }
    set.commit()?;
    Ok(Outcome { report: (log, summary), written })
}

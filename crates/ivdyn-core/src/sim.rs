//! Closed-loop simulation of the true model: fixed-step integration, torque limits, sensor
//! noise and quantisation, and encoder differentiation as on a real robot.
//!
//! # The loop
//! At the control instant `t_k` the controller reads [`Simulator::sensors`] (the encoder
//! position `q_k`, quantised and noisy, and the velocity from backward differences),
//! computes the command `u_k`, and calls [`Simulator::step`]: the torque
//! `sat(u_k)` is held over `[t_k, t_k + dt)` (zero-order hold) and the true forward
//! dynamics ([`crate::forward_dynamics`], Coulomb, viscous, armature and offset drive
//! terms included) are integrated over `substeps` fixed steps (RK4 or semi-implicit
//! Euler). `step` then samples the sensors at `t_{k+1}` and returns the
//! identification sample of the previous instant `t_k` (one sample late, see
//! [`Differentiator`]).
//!
//! # Coulomb friction
//! `fc sign(qd)` is discontinuous: an explicit integrator overshoots zero velocity and
//! chatters, and RK4 loses its order at every reversal. Inside the simulator only, the
//! sign is smoothed to `tanh(qd / v_band)` ([`SimConfig::coulomb_band`]). That band is a
//! viscous slope `fc / v_band` near rest, i.e. a stiff mode with rate
//! `fc / (v_band M_ii)`; RK4 is stable on the negative real axis up to `|lambda h| = 2.78`,
//! so the step must satisfy `h < 2.78 v_band M_ii / fc`. On the paper's wrist
//! (`M_66 ~ 1e-4 kg m^2`, `fc = 0.1 N m`) with `v_band = 0.05 rad/s` that is
//! `h < 1.4e-4 s`: the default is 10 substeps of 0.1 ms per 1 ms control period. Outside
//! the band the friction is `fc sign(qd)` to `1 - tanh(2) = 4 %` at `2 v_band`, and to
//! `1e-4` at `5 v_band`. `v_band = 0` gives the exact (discontinuous) sign.
//!
//! # Measurements
//! - position: `q_meas = quantise(q + N(0, sigma_q))` with the encoder resolution;
//! - torque: `tau_meas = sat(u) + N(0, sigma_tau)` (the torque actually applied plus
//!   sensor noise), and the command `u` itself (the paper's actuator input, eq 35);
//! - velocity and acceleration by differentiating `q_meas` ([`Differentiator`]).
//!
//! Noise comes from [`crate::rng::Rng`] (SplitMix64 + Box-Muller), deterministic from a seed.

use crate::control::saturate;
use crate::data::Data;
use crate::energy;
use crate::error::{Error, check_finite};
use crate::fd::forward_dynamics;
use crate::model::Model;
use crate::rng::Rng;
use crate::types::VecN;

/// Fixed-step integration scheme.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Integrator {
    /// Classical 4th-order Runge-Kutta (4 forward-dynamics calls per step), torque held.
    Rk4,
    /// Semi-implicit (symplectic) Euler: `qd += h qdd(q, qd)`, then `q += h qd`
    /// (1 forward-dynamics call per step, first order).
    SemiImplicitEuler,
}

/// Simulator settings.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SimConfig<const N: usize> {
    /// Control (and sensor) period (s).
    pub dt: f64,
    /// Integration steps per control period.
    pub substeps: usize,
    /// Integration scheme.
    pub integrator: Integrator,
    /// Actuator torque limits (absolute value; infinite = none).
    pub tau_limit: VecN<N>,
    /// Velocity band of the smoothed Coulomb friction (rad/s); 0 = exact sign.
    pub coulomb_band: f64,
    /// Encoder resolution (rad per count; 0 = no quantisation).
    pub encoder_resolution: VecN<N>,
    /// Standard deviation of position noise added before quantisation (rad).
    pub q_noise: VecN<N>,
    /// Standard deviation of torque-measurement noise (N m).
    pub tau_noise: VecN<N>,
    /// First-order low-pass on the control velocity, cutoff (Hz); 0 or infinity = none.
    pub velocity_cutoff_hz: f64,
    /// Noise seed.
    pub seed: u64,
}

impl<const N: usize> SimConfig<N> {
    /// 1 kHz control, RK4 with 10 substeps, Coulomb band 0.05 rad/s, no limits, ideal
    /// sensors (no noise, no quantisation), no velocity filter.
    pub fn ideal() -> Self {
        Self {
            dt: 1e-3,
            substeps: 10,
            integrator: Integrator::Rk4,
            tau_limit: VecN::<N>::repeat(f64::INFINITY),
            coulomb_band: 0.05,
            encoder_resolution: VecN::<N>::zeros(),
            q_noise: VecN::<N>::zeros(),
            tau_noise: VecN::<N>::zeros(),
            velocity_cutoff_hz: 0.0,
            seed: 0,
        }
    }

    /// `bits`-bit absolute encoders on every joint (resolution `2 pi / 2^bits`).
    pub fn with_encoder_bits(mut self, bits: u32) -> Self {
        self.encoder_resolution = VecN::<N>::repeat(core::f64::consts::TAU / (1u64 << bits) as f64);
        self
    }
}

/// Encoder differentiation as on a real robot.
///
/// - For control, now: `qd_k = (q_k - q_{k-1}) / dt` (backward difference), optionally
///   low-passed (first order, `alpha = 1 - exp(-2 pi fc dt)`): no delay from the
///   difference itself beyond half a sample, the filter adds `1 / (2 pi fc)`.
/// - For identification, one sample late: at `t_{k-1}` the central differences
///   `qd = (q_k - q_{k-2}) / (2 dt)`, `qdd = (q_k - 2 q_{k-1} + q_{k-2}) / dt^2` are
///   second-order accurate and have no phase lag, so the regressor and the torque line up
///   in time (a causal filter would delay the acceleration against the torque, a bias no
///   instrument removes). The price is one sample of latency, harmless for an estimator.
///   The quantisation noise on `qdd` has standard deviation `sqrt(6) (res / sqrt 12) / dt^2`
///   (`0.71 res / dt^2`).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Differentiator<const N: usize> {
    /// Sample period (s).
    pub dt: f64,
    /// Low-pass coefficient for the control velocity (1 = no filter).
    pub alpha: f64,
    hist: [VecN<N>; 3],
    count: u32,
    qd_filt: VecN<N>,
}

/// Identification sample at one instant: central differences of the encoder.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CentralSample<const N: usize> {
    /// Position (encoder reading) at the sample instant.
    pub q: VecN<N>,
    /// Central-difference velocity.
    pub qd: VecN<N>,
    /// Central-difference acceleration.
    pub qdd: VecN<N>,
}

impl<const N: usize> Differentiator<N> {
    /// With a velocity low-pass of cutoff `cutoff_hz` (0 or infinite = none).
    pub fn new(dt: f64, cutoff_hz: f64) -> Self {
        let alpha = if cutoff_hz > 0.0 && cutoff_hz.is_finite() {
            1.0 - libm::exp(-core::f64::consts::TAU * cutoff_hz * dt)
        } else {
            1.0
        };
        Self { dt, alpha, hist: [VecN::<N>::zeros(); 3], count: 0, qd_filt: VecN::<N>::zeros() }
    }

    /// Starts from rest at `q` (the history is filled with `q`, velocity zero).
    pub fn reset(&mut self, q: &VecN<N>) {
        self.hist = [*q; 3];
        self.count = 3;
        self.qd_filt = VecN::<N>::zeros();
    }

    /// Pushes the encoder reading `q_k`; returns the control velocity at `t_k` and, once
    /// three readings are in, the central sample at `t_{k-1}`.
    pub fn push(&mut self, q: &VecN<N>) -> (VecN<N>, Option<CentralSample<N>>) {
        self.hist = [self.hist[1], self.hist[2], *q];
        self.count = self.count.saturating_add(1);
        let [q2, q1, q0] = self.hist; // q_{k-2}, q_{k-1}, q_k
        if self.count < 2 {
            return (self.qd_filt, None);
        }
        let back = (q0 - q1) / self.dt;
        self.qd_filt += (back - self.qd_filt) * self.alpha;
        if self.count < 3 {
            return (self.qd_filt, None);
        }
        let s =
            CentralSample { q: q1, qd: (q0 - q2) / (2.0 * self.dt), qdd: (q0 - 2.0 * q1 + q2) / (self.dt * self.dt) };
        (self.qd_filt, Some(s))
    }

    /// The current control velocity.
    pub fn velocity(&self) -> &VecN<N> {
        &self.qd_filt
    }
}

/// What the controller reads at the current instant.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Sensors<const N: usize> {
    /// Time (s).
    pub t: f64,
    /// Encoder position.
    pub q: VecN<N>,
    /// Velocity from backward differences (filtered).
    pub qd: VecN<N>,
}

/// Identification sample of the previous instant, returned by [`Simulator::step`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct IdSample<const N: usize> {
    /// Time of the sample (s).
    pub t: f64,
    /// Encoder position, central-difference velocity and acceleration.
    pub x: CentralSample<N>,
    /// Measured torque at that instant: mean of the two held intervals around it
    /// (a central second difference averages the acceleration over both).
    pub tau: VecN<N>,
    /// Commanded torque (actuator input `u` of eq 35), averaged the same way.
    pub u: VecN<N>,
}

/// Simulator of the true model (see the module docs).
#[derive(Debug, Clone)]
pub struct Simulator<const N: usize> {
    /// Settings.
    pub cfg: SimConfig<N>,
    /// True position.
    pub q: VecN<N>,
    /// True velocity.
    pub qd: VecN<N>,
    /// Time (s).
    pub t: f64,
    /// Torque applied over the last control period (after saturation).
    pub tau_applied: VecN<N>,
    /// Whether the last command saturated.
    pub saturated: bool,
    model: Model<N>,
    /// The true model with `fc = 0`: Coulomb friction is added smoothed.
    smooth: Model<N>,
    data: Data<N>,
    rng: Rng,
    diff: Differentiator<N>,
    sensors: Sensors<N>,
    /// Previous (measured torque, command), for the central sample's averages.
    prev: Option<(VecN<N>, VecN<N>)>,
}

impl<const N: usize> Simulator<N> {
    /// Starts the true model `model` at `(q0, qd0)`, time 0. Rejects a non-positive `dt`
    /// or zero substeps (as [`Error::Dimension`] on `"dt"`/`"substeps"`) and non-finite state.
    pub fn new(model: Model<N>, cfg: SimConfig<N>, q0: &VecN<N>, qd0: &VecN<N>) -> Result<Self, Error> {
        check_finite("q0", q0.as_slice())?;
        check_finite("qd0", qd0.as_slice())?;
        if !(cfg.dt > 0.0) || !cfg.dt.is_finite() {
            return Err(Error::NonFinite { what: "dt", index: 0 });
        }
        if cfg.substeps == 0 {
            return Err(Error::Dimension { what: "substeps", expected: 1, got: 0 });
        }
        let mut s = Self {
            cfg,
            q: *q0,
            qd: *qd0,
            t: 0.0,
            tau_applied: VecN::<N>::zeros(),
            saturated: false,
            smooth: model.clone(),
            model,
            data: Data::new(),
            rng: Rng::new(cfg.seed),
            diff: Differentiator::new(cfg.dt, cfg.velocity_cutoff_hz),
            sensors: Sensors { t: 0.0, q: *q0, qd: *qd0 },
            prev: None,
        };
        s.set_model(s.model.clone());
        let qm = s.measure_q();
        s.diff.reset(&qm);
        s.sensors = Sensors { t: 0.0, q: qm, qd: VecN::<N>::zeros() };
        Ok(s)
    }

    /// The true model.
    pub fn model(&self) -> &Model<N> {
        &self.model
    }

    /// Replaces the true model (e.g. a payload grasped: the last link changes), keeping
    /// the state.
    pub fn set_model(&mut self, model: Model<N>) {
        self.smooth = model.clone();
        if self.cfg.coulomb_band > 0.0 {
            for d in self.smooth.drive.iter_mut() {
                d.fc = 0.0;
            }
        }
        self.model = model;
    }

    /// What the controller reads now.
    pub fn sensors(&self) -> &Sensors<N> {
        &self.sensors
    }

    /// True acceleration at `(q, qd)` under torque `tau` (smoothed Coulomb friction).
    pub fn acceleration(&mut self, q: &VecN<N>, qd: &VecN<N>, tau: &VecN<N>) -> Result<VecN<N>, Error> {
        let mut t = *tau;
        let band = self.cfg.coulomb_band;
        if band > 0.0 {
            for i in 0..N {
                // the model's own smooth shape wins; a sign gets the simulator's band
                let mut c = self.model.drive[i].coulomb;
                if c.v_scale <= 0.0 {
                    c.v_scale = band;
                }
                t[i] -= self.model.drive[i].fc * c.value(qd[i]);
            }
        }
        Ok(*forward_dynamics(&self.smooth, &mut self.data, q, qd, &t)?)
    }

    /// Integrates one control period under the held torque `sat(u)` and samples the
    /// sensors at the new time. Returns the identification sample of the instant the
    /// command was applied (`t - dt`), available from the second call on. On error (a
    /// non-finite command, a mass matrix that is not positive definite) the state is
    /// left as it was.
    pub fn step(&mut self, u: &VecN<N>) -> Result<Option<IdSample<N>>, Error> {
        check_finite("u", u.as_slice())?;
        let mut tau = *u;
        let saturated = saturate(&mut tau, &self.cfg.tau_limit);
        let h = self.cfg.dt / self.cfg.substeps as f64;
        let (mut q, mut qd) = (self.q, self.qd);
        for _ in 0..self.cfg.substeps {
            match self.cfg.integrator {
                Integrator::Rk4 => {
                    let k1v = self.acceleration(&q, &qd, &tau)?;
                    let (q2, qd2) = (q + qd * (0.5 * h), qd + k1v * (0.5 * h));
                    let k2v = self.acceleration(&q2, &qd2, &tau)?;
                    let (q3, qd3) = (q + qd2 * (0.5 * h), qd + k2v * (0.5 * h));
                    let k3v = self.acceleration(&q3, &qd3, &tau)?;
                    let (q4, qd4) = (q + qd3 * h, qd + k3v * h);
                    let k4v = self.acceleration(&q4, &qd4, &tau)?;
                    q += (qd + qd2 * 2.0 + qd3 * 2.0 + qd4) * (h / 6.0);
                    qd += (k1v + k2v * 2.0 + k3v * 2.0 + k4v) * (h / 6.0);
                }
                Integrator::SemiImplicitEuler => {
                    let a = self.acceleration(&q, &qd, &tau)?;
                    qd += a * h;
                    q += qd * h;
                }
            }
        }
        self.q = q;
        self.qd = qd;
        self.t += self.cfg.dt;
        self.tau_applied = tau;
        self.saturated = saturated;
        // torque sensor over the period just simulated
        let mut tau_meas = tau;
        for i in 0..N {
            tau_meas[i] += self.cfg.tau_noise[i] * self.rng.normal();
        }
        let qm = self.measure_q();
        let (qd_ctrl, central) = self.diff.push(&qm);
        self.sensors = Sensors { t: self.t, q: qm, qd: qd_ctrl };
        let out = match (central, self.prev) {
            (Some(x), Some((tau_prev, u_prev))) => {
                Some(IdSample { t: self.t - self.cfg.dt, x, tau: (tau_prev + tau_meas) * 0.5, u: (u_prev + u) * 0.5 })
            }
            _ => None,
        };
        self.prev = Some((tau_meas, *u));
        Ok(out)
    }

    fn measure_q(&mut self) -> VecN<N> {
        let mut qm = self.q;
        for i in 0..N {
            qm[i] += self.cfg.q_noise[i] * self.rng.normal();
            let r = self.cfg.encoder_resolution[i];
            if r > 0.0 {
                qm[i] = libm::round(qm[i] / r) * r;
            }
        }
        qm
    }

    /// Kinetic plus potential energy of the true state (J).
    pub fn energy(&mut self) -> f64 {
        energy::kinetic_energy(&self.model, &mut self.data, &self.q, &self.qd)
            + energy::potential_energy(&self.model, &mut self.data, &self.q)
    }
}

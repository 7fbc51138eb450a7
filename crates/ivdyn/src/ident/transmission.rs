//! Transmissions: robots measured on the motor side (encoders and drive currents on the
//! motor shafts, before the gears), with gear ratios and coupled joints.
//!
//! # Model
//! A motor-to-joint matrix `K` (`n x n`: motor `i` turns by `Σ_j K_ij` times the joint
//! angles) and joint offsets `q0` give
//!
//! ```text
//! q_m = K (q - q0)          q = K⁻¹ q_m + q0          (qd, qdd: the same without q0)
//! τ_m = K⁻ᵀ τ + D(qd_m, qdd_m) θ_m                    τ = Kᵀ (τ_m - D θ_m)
//! ```
//!
//! `τ` are the joint torques of the rigid-body model (with, optionally, its joint-side
//! drive terms), `K⁻ᵀ τ` is the virtual-work map of joint torques to motor torques, and
//! `D θ_m` the motor-side drive terms of each motor `i`:
//! `fc_i sign(qd_m,i) + fv_i qd_m,i + ia_i qdd_m,i + tau0_i` (Coulomb and viscous friction of
//! the motor and the first gear stage, rotor inertia, current offset). A diagonal `K`
//! holds plain gear ratios (a negative ratio flips the direction); an off-diagonal entry
//! couples joints, as industrial wrists do: the Stäubli TX40's sixth motor turns with
//! `N6 (q5 + q6)` (`K[5][4] = K[5][5] = N6`), so motor 6's friction depends on `qd5 + qd6`
//! and its rotor inertia on `qdd5 + qdd6`: columns that no joint-side model has.
//!
//! # Regressor
//! `τ_m = [K⁻ᵀ Y(q, qd, qdd) | D(qd_m, qdd_m)] [θ; θ_m]`: the joint-torque regressor of
//! [`crate::Robot`] (the `10 n` inertial columns, or all `14 n` with the joint-side drive
//! terms), each sample's `n x p` block multiplied by `K⁻ᵀ`, then `4 n` motor-drive columns.
//! It is linear in the parameters, so the identification is the usual one
//! ([`crate::ident`]: base parameters, least squares, IV) on these rows.
//!
//! # Drive gains
//! Drives report currents `i`, and `τ_m = g ∘ i` with a per-motor gain `g` (N m/A) that
//! data sheets give only roughly. From one experiment `g` cannot be found: `(g, θ)` and
//! `(c g, c θ)` predict the same currents. A payload of **known mass** `m_L` breaks this:
//! with runs before and after attaching it, `g_i i_i = φ_i θ + φ_i^L θ_L` on the loaded
//! rows, where the payload's mass column `φ^L_m m_L` is known in absolute units; its other
//! nine parameters (first moments, inertia) are unknowns like `θ`. [`fit_drive_gains`]
//! fits `i_i = (φ_i θ + [loaded] φ^L_i θ_L) / g_i` with the current as the output
//! ([`crate::ident::gains`]: the linear form with the current in the regressor is biased
//! toward `g = 0` by the current's noise). A gain is identifiable when the known mass
//! loads its motor (or loads parameters shared with motors whose gain is fixed) enough for
//! its relative std to stay within 10 %; the others are reported as not identifiable
//! instead of a number.
//! (Gautier and Briot, "Global identification of joint drive gains and dynamic parameters
//! of robots", ASME J. Dyn. Syst. Meas. Control 136(5), 2014.)

use nalgebra::DMatrix;

use crate::Robot;
use crate::batch::regressor_batch;
use crate::error::{Error, Result};
use crate::ident::BaseParams;
use crate::ident::gains::{GainFit, GainOptions, GainRun, GainVerdict, fit_gains};
use ivdyn_core::params::{DRIVE_PARAM_NAMES, DRIVE_PARAMS, DriveParams, LINK_PARAMS, PARAMS_PER_JOINT};
use ivdyn_core::rng::Rng;

/// Relative tolerance for `K` being invertible (smallest / largest singular value).
pub const K_RCOND_TOL: f64 = 1e-12;

/// A motor-to-joint map: `q_m = K (q - q0)` (module docs).
#[derive(Debug, Clone, PartialEq)]
pub struct Transmission {
    k: DMatrix<f64>,
    k_inv: DMatrix<f64>,
    /// Joint offsets `q0` (rad or m): the joint angle when the motor encoder reads 0.
    pub joint_offset: Vec<f64>,
}

fn dim(what: &str, expected: usize, got: usize) -> Error {
    Error::Dimension { what: what.into(), expected, got }
}

/// `y_k = M x_k` for every row `x_k` of the row-major `T x n` array `x`.
fn map_rows(m: &DMatrix<f64>, x: &[f64], what: &str) -> Result<Vec<f64>> {
    let n = m.ncols();
    if !x.len().is_multiple_of(n) {
        return Err(dim(
            &format!("{what} (T x {n}, row-major; length a multiple of {n})"),
            x.len().div_ceil(n) * n,
            x.len(),
        ));
    }
    let mut y = vec![0.0; x.len()];
    for (xk, yk) in x.chunks_exact(n).zip(y.chunks_exact_mut(n)) {
        for i in 0..n {
            yk[i] = (0..n).map(|j| m[(i, j)] * xk[j]).sum();
        }
    }
    Ok(y)
}

impl Transmission {
    /// From `K` (`n x n`, row-major) and optional joint offsets `q0` (default 0). Errors
    /// on a non-finite entry or a singular `K` (`σ_min < 1e-12 σ_max`).
    pub fn new(k_row_major: &[f64], n: usize, joint_offset: Option<&[f64]>) -> Result<Self> {
        if n == 0 || k_row_major.len() != n * n {
            return Err(dim("K (n x n, row-major)", n * n, k_row_major.len()));
        }
        if let Some(i) = k_row_major.iter().position(|v| !v.is_finite()) {
            return Err(Error::Transmission { msg: format!("K[{}][{}] is {}", i / n, i % n, k_row_major[i]) });
        }
        let k = DMatrix::from_row_slice(n, n, k_row_major);
        let sv = k.singular_values();
        let (smax, smin) = (sv.max(), sv.min());
        if !(smin > K_RCOND_TOL * smax) {
            return Err(Error::Transmission {
                msg: format!(
                    "K is singular (singular values {smin:.3e} .. {smax:.3e}); every motor must drive an independent joint combination"
                ),
            });
        }
        let k_inv = k.clone().try_inverse().ok_or_else(|| Error::Transmission { msg: "K is not invertible".into() })?;
        let joint_offset = match joint_offset {
            Some(o) if o.len() != n => return Err(dim("joint_offset (n)", n, o.len())),
            Some(o) => o.to_vec(),
            None => vec![0.0; n],
        };
        Ok(Transmission { k, k_inv, joint_offset })
    }

    /// Plain gears: `K = diag(ratios)` (motor turns per joint turn; negative = reversed).
    pub fn gears(ratios: &[f64]) -> Result<Self> {
        let n = ratios.len();
        let mut k = vec![0.0; n * n];
        for i in 0..n {
            k[i * n + i] = ratios[i];
        }
        Self::new(&k, n, None)
    }

    /// The same transmission with `K[motor][joint] = value` (a coupling), e.g.
    /// `with_coupling(5, 4, N6)` for a wrist whose sixth motor turns with `N6 (q5 + q6)`.
    pub fn with_coupling(self, motor: usize, joint: usize, value: f64) -> Result<Self> {
        let n = self.dof();
        if motor >= n || joint >= n {
            return Err(dim("coupling index (motor, joint) < n", n, motor.max(joint)));
        }
        let mut k: Vec<f64> = (0..n * n).map(|i| self.k[(i / n, i % n)]).collect();
        k[motor * n + joint] = value;
        Self::new(&k, n, Some(&self.joint_offset))
    }

    /// The same transmission with joint offsets `q0`.
    pub fn with_offset(mut self, joint_offset: &[f64]) -> Result<Self> {
        if joint_offset.len() != self.dof() {
            return Err(dim("joint_offset (n)", self.dof(), joint_offset.len()));
        }
        self.joint_offset = joint_offset.to_vec();
        Ok(self)
    }

    /// Number of joints (= motors).
    pub fn dof(&self) -> usize {
        self.k.nrows()
    }

    /// `K`.
    pub fn k(&self) -> &DMatrix<f64> {
        &self.k
    }

    /// `K⁻¹`.
    pub fn k_inv(&self) -> &DMatrix<f64> {
        &self.k_inv
    }

    /// Joint positions `q = K⁻¹ q_m + q0` of motor positions (`T x n`, row-major).
    pub fn joint_positions(&self, q_m: &[f64]) -> Result<Vec<f64>> {
        let mut q = map_rows(&self.k_inv, q_m, "q_m")?;
        let n = self.dof();
        for (i, v) in q.iter_mut().enumerate() {
            *v += self.joint_offset[i % n];
        }
        Ok(q)
    }

    /// Motor positions `q_m = K (q - q0)`.
    pub fn motor_positions(&self, q: &[f64]) -> Result<Vec<f64>> {
        let n = self.dof();
        let shifted: Vec<f64> = q.iter().enumerate().map(|(i, v)| v - self.joint_offset[i % n]).collect();
        map_rows(&self.k, &shifted, "q")
    }

    /// Joint velocities or accelerations of motor ones: `K⁻¹ x_m`.
    pub fn joint_rates(&self, x_m: &[f64]) -> Result<Vec<f64>> {
        map_rows(&self.k_inv, x_m, "motor velocities/accelerations")
    }

    /// Motor velocities or accelerations of joint ones: `K x`.
    pub fn motor_rates(&self, x: &[f64]) -> Result<Vec<f64>> {
        map_rows(&self.k, x, "joint velocities/accelerations")
    }

    /// Motor torques that produce the joint torques `tau` (virtual work): `K⁻ᵀ τ`.
    pub fn motor_torques(&self, tau: &[f64]) -> Result<Vec<f64>> {
        map_rows(&self.k_inv.transpose(), tau, "tau")
    }

    /// Joint torques produced by motor torques: `τ = Kᵀ τ_m`.
    pub fn joint_torques(&self, tau_m: &[f64]) -> Result<Vec<f64>> {
        map_rows(&self.k.transpose(), tau_m, "tau_m")
    }
}

/// Motor-side inverse dynamics by the Newton-Euler path (no regressor): joint states from
/// motor states, `τ = rnea(q, qd, qdd)` (with the robot's joint-side drive terms), then
/// `τ_m = K⁻ᵀ τ + D θ_m`. `motor` holds one [`DriveParams`] per motor. All `T x n`.
pub fn motor_torque(
    robot: &Robot,
    trans: &Transmission,
    motor: &[DriveParams],
    q_m: &[f64],
    qd_m: &[f64],
    qdd_m: &[f64],
) -> Result<Vec<f64>> {
    let n = check_pair(robot, trans)?;
    if motor.len() != n {
        return Err(dim("motor drive parameters (one per motor)", n, motor.len()));
    }
    let (q, qd, qdd) = (trans.joint_positions(q_m)?, trans.joint_rates(qd_m)?, trans.joint_rates(qdd_m)?);
    let mut tau = vec![0.0; q.len()];
    crate::batch::rnea_batch(robot, &q, &qd, &qdd, &mut tau)?;
    let mut tau_m = trans.motor_torques(&tau)?;
    for (i, t) in tau_m.iter_mut().enumerate() {
        *t += motor[i % n].torque(qd_m[i], qdd_m[i]);
    }
    Ok(tau_m)
}

fn check_pair(robot: &Robot, trans: &Transmission) -> Result<usize> {
    let n = robot.dof();
    if trans.dof() != n {
        return Err(dim("transmission size (the robot's joint count)", n, trans.dof()));
    }
    Ok(n)
}

/// The motor-side regressor `[K⁻ᵀ Y | D]` of a robot behind a transmission (module docs).
#[derive(Debug, Clone, Copy)]
pub struct MotorRegressor<'a> {
    /// The rigid-body model (joint side).
    pub robot: &'a Robot,
    /// The transmission.
    pub trans: &'a Transmission,
    /// Keep the robot's joint-side drive columns (`fc, fv, ia, tau0` per joint, mapped
    /// by `K⁻ᵀ`) besides the motor-side ones. With a diagonal `K` they duplicate the motor
    /// columns (the base parameters merge them); on coupled joints they differ (joint
    /// friction in `qd6` next to motor friction in `qd5 + qd6`).
    pub joint_drive: bool,
}

impl<'a> MotorRegressor<'a> {
    /// A regressor; errors if the transmission's size is not the robot's.
    pub fn new(robot: &'a Robot, trans: &'a Transmission, joint_drive: bool) -> Result<Self> {
        check_pair(robot, trans)?;
        Ok(MotorRegressor { robot, trans, joint_drive })
    }

    /// Columns taken from the robot's regressor (`10 n`, or `14 n` with joint drive).
    pub fn robot_cols(&self) -> usize {
        if self.joint_drive { PARAMS_PER_JOINT * self.robot.dof() } else { LINK_PARAMS * self.robot.dof() }
    }

    /// Number of parameters: robot columns + `4 n` motor-drive columns.
    pub fn num_params(&self) -> usize {
        self.robot_cols() + DRIVE_PARAMS * self.robot.dof()
    }

    /// Column of motor `i`'s drive entry `k` (`ivdyn_core::params::FC`, `FV`, `IA`, `TAU0`).
    pub fn motor_col(&self, i: usize, k: usize) -> usize {
        self.robot_cols() + DRIVE_PARAMS * i + k
    }

    /// Parameter names: the robot's (`"link_6.Izz"`, `"joint_6.fv"`), then
    /// `"<joint>.motor.fc"`, `.fv`, `.ia`, `.tau0` per motor (motor `i` is named after
    /// joint `i`).
    pub fn param_names(&self) -> Vec<String> {
        let mut names: Vec<String> = self.robot.param_names()[..self.robot_cols()].to_vec();
        for j in &self.robot.joint_names {
            names.extend(DRIVE_PARAM_NAMES.iter().map(|p| format!("{j}.motor.{p}")));
        }
        names
    }

    /// The full parameter vector for the robot's current parameters and motor drives.
    pub fn params(&self, motor: &[DriveParams]) -> Result<Vec<f64>> {
        let n = self.robot.dof();
        if motor.len() != n {
            return Err(dim("motor drive parameters (one per motor)", n, motor.len()));
        }
        let mut theta = self.robot.params()[..self.robot_cols()].to_vec();
        for d in motor {
            theta.extend(d.to_array());
        }
        Ok(theta)
    }

    /// Regressor rows at motor states (`T x n` each): `T x n x P` row-major, with
    /// `rows · θ = motor_torque(...)`.
    pub fn rows(&self, q_m: &[f64], qd_m: &[f64], qdd_m: &[f64]) -> Result<Vec<f64>> {
        let (robot, trans) = (self.robot, self.trans);
        let n = robot.dof();
        let (q, qd, qdd) = (trans.joint_positions(q_m)?, trans.joint_rates(qd_m)?, trans.joint_rates(qdd_m)?);
        let t = q.len() / n;
        if qd.len() != t * n || qdd.len() != t * n {
            return Err(dim(&format!("qd_m, qdd_m (T x n = {t} x {n})"), t * n, qd.len().min(qdd.len())));
        }
        let rc = self.robot_cols();
        let mut y = vec![0.0; t * n * rc];
        regressor_batch(robot, &q, &qd, &qdd, &mut y, !self.joint_drive)?;
        let p = self.num_params();
        let kit = trans.k_inv.transpose();
        let mut out = vec![0.0; t * n * p];
        for s in 0..t {
            let ys = &y[s * n * rc..(s + 1) * n * rc];
            let os = &mut out[s * n * p..(s + 1) * n * p];
            // row i of K⁻ᵀ Y: Σ_j K⁻ᵀ_ij Y_j (skipping the zeros of a sparse K)
            for i in 0..n {
                let orow = &mut os[i * p..i * p + rc];
                for j in 0..n {
                    let c = kit[(i, j)];
                    if c != 0.0 {
                        for (o, v) in orow.iter_mut().zip(&ys[j * rc..(j + 1) * rc]) {
                            *o += c * v;
                        }
                    }
                }
                let d = DriveParams::regressor(qd_m[s * n + i], qdd_m[s * n + i]);
                os[i * p + rc + DRIVE_PARAMS * i..i * p + rc + DRIVE_PARAMS * (i + 1)].copy_from_slice(&d);
            }
        }
        Ok(out)
    }

    /// Base parameters of this regressor from `samples` random states (seeded): joint
    /// positions uniform within the URDF limits (else `±π`), velocities in `±1`,
    /// accelerations in `±2` (joint side), mapped to the motors.
    pub fn base_params(&self, samples: usize, seed: u64) -> Result<BaseParams> {
        let n = self.robot.dof();
        let p = self.num_params();
        if samples * n < p {
            return Err(dim("samples * dof (rows; must be >= parameter count)", p, samples * n));
        }
        let limits = crate::with_model!(&self.robot.model, m => m.limits.to_vec());
        let mut rng = Rng::new(seed);
        let (mut q, mut qd, mut qdd) =
            (Vec::with_capacity(samples * n), Vec::with_capacity(samples * n), Vec::with_capacity(samples * n));
        for _ in 0..samples {
            for l in &limits {
                let (lo, hi) = if l.lower.is_finite() && l.upper.is_finite() && l.upper > l.lower {
                    (l.lower, l.upper)
                } else {
                    (-std::f64::consts::PI, std::f64::consts::PI)
                };
                q.push(rng.uniform(lo, hi));
                qd.push(rng.uniform(-1.0, 1.0));
                qdd.push(rng.uniform(-2.0, 2.0));
            }
        }
        let (q_m, qd_m, qdd_m) =
            (self.trans.motor_positions(&q)?, self.trans.motor_rates(&qd)?, self.trans.motor_rates(&qdd)?);
        let rows = self.rows(&q_m, &qd_m, &qdd_m)?;
        let phi = DMatrix::from_row_slice(samples * n, p, &rows);
        Ok(BaseParams::from_rows(&phi, &self.param_names()))
    }
}

// ---------------------------------------------------------------------------------------
// Drive gains from a known payload mass
// ---------------------------------------------------------------------------------------

/// One experiment for [`fit_drive_gains`]: motor states and measured currents (`T x n`).
#[derive(Debug, Clone, Copy)]
pub struct CurrentLog<'a> {
    /// Motor positions.
    pub q_m: &'a [f64],
    /// Motor velocities.
    pub qd_m: &'a [f64],
    /// Motor accelerations.
    pub qdd_m: &'a [f64],
    /// Measured currents (A, or any unit proportional to torque per motor).
    pub current: &'a [f64],
}

/// Result of [`fit_drive_gains`].
#[derive(Debug, Clone)]
pub struct DriveGains {
    /// Gain per motor (N m per current unit); `NaN` where not identifiable.
    pub gains: Vec<f64>,
    /// Standard deviation of each gain (`NaN` where not identifiable).
    pub std: Vec<f64>,
    /// Whether each gain is determined by the data ([`crate::ident::gains`]: excited, in
    /// no null direction, relative std within the limit).
    pub identifiable: Vec<bool>,
    /// The whole fit: base parameters in absolute units, the payload's parameters, the
    /// verdict on each gain, per-joint residual statistics.
    pub fit: GainFit,
}

/// Drive gains and the base parameters (in absolute units) from a run without and a run
/// with a payload of known mass `payload_mass` fixed to the last link (module docs), by
/// [`crate::ident::gains::fit_gains`] on the motor-side rows: the currents are the
/// output, and a gain the data cannot pin down is reported as not identifiable (`NaN`),
/// never as a number with a small std. `base` are the base parameters of `reg` (e.g.
/// [`MotorRegressor::base_params`]). The rows are used as given (no filtering): give
/// states and currents that are already smooth, or use `ivdyn::app::drive_gains`, which
/// conditions and filters joint-side logs.
pub fn fit_drive_gains(
    reg: &MotorRegressor,
    base: &BaseParams,
    unloaded: &CurrentLog,
    loaded: &CurrentLog,
    payload_mass: f64,
) -> Result<DriveGains> {
    let n = reg.robot.dof();
    let p = reg.num_params();
    if base.full_cols != p {
        return Err(dim("base parameters' full column count (the regressor's parameters)", p, base.full_cols));
    }
    // each row: the base columns, then the last link's ten (the payload's, through K⁻ᵀ)
    let gain_rows = |log: &CurrentLog| -> Result<Vec<f64>> {
        let full = reg.rows(log.q_m, log.qd_m, log.qdd_m)?;
        let (b, last) = (base.base_count(), LINK_PARAMS * (n - 1));
        let mut out = vec![0.0; full.len() / p * (b + LINK_PARAMS)];
        for (f, o) in full.chunks_exact(p).zip(out.chunks_exact_mut(b + LINK_PARAMS)) {
            base.select_row(f, &mut o[..b])?;
            o[b..].copy_from_slice(&f[last..last + LINK_PARAMS]);
        }
        Ok(out)
    };
    let (ru, rl) = (gain_rows(unloaded)?, gain_rows(loaded)?);
    // one continuous piece each
    let (pu, pl) = (0..unloaded.current.len() / n, 0..loaded.current.len() / n);
    let runs = [
        GainRun { rows: &ru, current: unloaded.current, pieces: std::slice::from_ref(&pu), loaded: false },
        GainRun { rows: &rl, current: loaded.current, pieces: std::slice::from_ref(&pl), loaded: true },
    ];
    let mut known = [None; LINK_PARAMS];
    known[0] = Some(payload_mass);
    let fit = fit_gains(n, &base.names, &runs, &known, &GainOptions::default())?;
    let identifiable: Vec<bool> = fit.verdict.iter().map(|v| *v == GainVerdict::Identifiable).collect();
    Ok(DriveGains { gains: fit.gain.clone(), std: fit.gain_std.clone(), identifiable, fit })
}

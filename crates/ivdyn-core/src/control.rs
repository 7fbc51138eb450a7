//! Controllers: computed torque and PD (with or without gravity compensation), and the
//! online payload estimator that feeds the computed-torque model (paper Section 5, Fig. 5).
//!
//! # Computed torque
//! `tau = M(q) (qdd_d + Kd ed + Kp e) + h(q, qd)` with `e = q_d - q`, `ed = qd_d - qd`
//! and `h` the Coriolis, centrifugal, gravity and drive (friction, offset) terms. It is ONE
//! inverse-dynamics call, `tau = rnea(q, qd, qdd_ref)` at the reference acceleration
//! `qdd_ref = qdd_d + Kd ed + Kp e`, because RNEA evaluates `M(q) qdd + h(q, qd)` exactly
//! (armature included); `M` is never formed. With the exact model the closed loop is
//! `ë + Kd ė + Kp e = 0` per joint, so the gains are in acceleration units (`Kp` 1/s^2,
//! `Kd` 1/s) and [`Gains::critically_damped`] places both poles at `-wn`.
//!
//! # PD
//! `tau = Kp e + Kd ed (+ g(q))`, gains in torque units (N m/rad, N m s/rad). A fair
//! comparison with computed torque scales the acceleration gains by the nominal diagonal
//! inertia, [`Gains::scaled`].
//!
//! All controllers take the model by reference at every call: when the payload estimator
//! writes its estimate into that model ([`PayloadEstimator::write_model`]) the controller
//! uses it at the next step. They reuse a caller-provided [`Data`] and return a reference
//! into it (`data.tau`).

use crate::data::Data;
use crate::error::{Error, check_finite};
use crate::estim::terminal::{Method, TerminalLink, TerminalSpec};
use crate::model::Model;
use crate::params::{DRIVE_PARAMS, LINK_PARAMS};
use crate::rnea;
use crate::types::VecN;
use nalgebra::allocator::Allocator;
use nalgebra::{DefaultAllocator, Dim, OMatrix, OVector};

/// Per-joint proportional and derivative gains.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Gains<const N: usize> {
    /// Proportional gains.
    pub kp: VecN<N>,
    /// Derivative gains.
    pub kd: VecN<N>,
}

impl<const N: usize> Gains<N> {
    /// From both vectors.
    pub fn new(kp: VecN<N>, kd: VecN<N>) -> Self {
        Self { kp, kd }
    }

    /// `Kp = wn^2`, `Kd = 2 zeta wn` per joint: the error dynamics `ë + Kd ė + Kp e = 0`
    /// of computed torque with natural frequency `wn` (rad/s) and damping ratio `zeta`.
    pub fn from_bandwidth(wn: &VecN<N>, zeta: f64) -> Self {
        Self { kp: wn.component_mul(wn), kd: wn * (2.0 * zeta) }
    }

    /// Critically damped (`zeta = 1`), the same `wn` on every joint.
    pub fn critically_damped(wn: f64) -> Self {
        Self::from_bandwidth(&VecN::<N>::repeat(wn), 1.0)
    }

    /// Both gains multiplied per joint by `s` (e.g. the nominal `M_ii(q0)`: acceleration
    /// gains become torque gains for PD).
    pub fn scaled(&self, s: &VecN<N>) -> Self {
        Self { kp: self.kp.component_mul(s), kd: self.kd.component_mul(s) }
    }
}

/// The desired motion at one instant.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Reference<const N: usize> {
    /// Desired position.
    pub q: VecN<N>,
    /// Desired velocity.
    pub qd: VecN<N>,
    /// Desired acceleration.
    pub qdd: VecN<N>,
}

impl<const N: usize> Reference<N> {
    /// From a `(q, qd, qdd)` triple (as returned by [`crate::trajectory::Fourier::eval`]).
    pub fn from_tuple(x: (VecN<N>, VecN<N>, VecN<N>)) -> Self {
        Self { q: x.0, qd: x.1, qdd: x.2 }
    }

    /// Holding still at `q`.
    pub fn hold(q: VecN<N>) -> Self {
        Self { q, qd: VecN::<N>::zeros(), qdd: VecN::<N>::zeros() }
    }
}

/// Clamps each `tau_i` to `[-limit_i, limit_i]` (infinite limit = none). Returns whether
/// any joint saturated.
pub fn saturate<const N: usize>(tau: &mut VecN<N>, limit: &VecN<N>) -> bool {
    let mut hit = false;
    for i in 0..N {
        let l = limit[i];
        if tau[i] > l {
            tau[i] = l;
            hit = true;
        } else if tau[i] < -l {
            tau[i] = -l;
            hit = true;
        }
    }
    hit
}

/// Which velocity the computed-torque controller's Coulomb term `fc sign(.)` uses.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum CoulombVelocity {
    /// The measured velocity (what `rnea` does): exact when the measurement is clean, but
    /// with a differentiated encoder the sign chatters around reversals (a `2 fc` torque
    /// square wave).
    Measured,
    /// The reference velocity `qd_d`: no chatter; wrong only while the tracking error makes
    /// the actual and desired velocities differ in sign.
    Reference,
}

/// Computed-torque controller `tau = M(q)(qdd_d + Kd ed + Kp e) + h(q, qd)`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ComputedTorque<const N: usize> {
    /// Gains in acceleration units (`Kp` 1/s^2, `Kd` 1/s).
    pub gains: Gains<N>,
    /// Torque limits (absolute value per joint; infinite = none).
    pub tau_limit: VecN<N>,
    /// Velocity used for the Coulomb friction compensation.
    pub coulomb: CoulombVelocity,
}

impl<const N: usize> ComputedTorque<N> {
    /// No torque limits, Coulomb compensation from the measured velocity.
    pub fn new(gains: Gains<N>) -> Self {
        Self { gains, tau_limit: VecN::<N>::repeat(f64::INFINITY), coulomb: CoulombVelocity::Measured }
    }

    /// The reference acceleration `qdd_d + Kd (qd_d - qd) + Kp (q_d - q)`.
    #[inline]
    pub fn qdd_ref(&self, q: &VecN<N>, qd: &VecN<N>, r: &Reference<N>) -> VecN<N> {
        r.qdd + self.gains.kd.component_mul(&(r.qd - qd)) + self.gains.kp.component_mul(&(r.q - q))
    }

    /// The torque, with one RNEA call of `model` at `(q, qd, qdd_ref)`, saturated to
    /// `tau_limit`. Returns `&data.tau`. Rejects non-finite measurements.
    pub fn torque<'d>(
        &self,
        model: &Model<N>,
        data: &'d mut Data<N>,
        q: &VecN<N>,
        qd: &VecN<N>,
        r: &Reference<N>,
    ) -> Result<&'d VecN<N>, Error> {
        check_finite("q", q.as_slice())?;
        check_finite("qd", qd.as_slice())?;
        let qdd = self.qdd_ref(q, qd, r);
        rnea(model, data, q, qd, &qdd);
        if self.coulomb == CoulombVelocity::Reference {
            for i in 0..N {
                let c = &model.drive[i].coulomb;
                data.tau[i] += model.drive[i].fc * (c.value(r.qd[i]) - c.value(qd[i]));
            }
        }
        saturate(&mut data.tau, &self.tau_limit);
        Ok(&data.tau)
    }
}

/// PD controller `tau = Kp e + Kd ed`, optionally plus the model's gravity torque `g(q)`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Pd<const N: usize> {
    /// Gains in torque units (N m/rad, N m s/rad).
    pub gains: Gains<N>,
    /// Torque limits (absolute value per joint; infinite = none).
    pub tau_limit: VecN<N>,
    /// Add `g(q)` of the model (PD with gravity compensation).
    pub gravity: bool,
}

impl<const N: usize> Pd<N> {
    /// Plain PD, no limits.
    pub fn new(gains: Gains<N>) -> Self {
        Self { gains, tau_limit: VecN::<N>::repeat(f64::INFINITY), gravity: false }
    }

    /// PD plus gravity compensation, no limits.
    pub fn with_gravity(gains: Gains<N>) -> Self {
        Self { gravity: true, ..Self::new(gains) }
    }

    /// The torque (into `data.tau`), saturated. The model is used only for gravity.
    pub fn torque<'d>(
        &self,
        model: &Model<N>,
        data: &'d mut Data<N>,
        q: &VecN<N>,
        qd: &VecN<N>,
        r: &Reference<N>,
    ) -> Result<&'d VecN<N>, Error> {
        check_finite("q", q.as_slice())?;
        check_finite("qd", qd.as_slice())?;
        let pd = self.gains.kp.component_mul(&(r.q - q)) + self.gains.kd.component_mul(&(r.qd - qd));
        if self.gravity {
            crate::rnea::gravity(model, data, q);
            data.tau += pd;
        } else {
            data.tau = pd;
        }
        saturate(&mut data.tau, &self.tau_limit);
        Ok(&data.tau)
    }
}

/// Online estimator of a payload grasped by the last link: the change of the last link's
/// parameters (paper eqs 38-54 with only link `N` unknown) from the torque residual of
/// ALL joints against the nominal model,
///
/// `tau_i(measured) - rnea_nominal_i(q, qd, qdd) = Y_i,N(q, qd, qdd) dx_N`, `i = 1..N`.
///
/// [`crate::estim::TerminalLink`] uses the rows `k..N` of its unknown links (the paper's
/// choice); with only the last link unknown those are the wrist rows alone, from which the
/// payload mass is not identifiable on the paper's robot (`NOTES.md`). Every joint sees
/// the last link, so here every row is used, which makes the mass identifiable.
///
/// `columns` are indices into the last link's block `[m, m cx, m cy, m cz, Ixx, Ixy, Iyy,
/// Ixz, Iyz, Izz, fc, fv, ia, tau0]` (`0..14`; the drive entries are the last joint's),
/// normally an identifiable (base) set found numerically on the desktop
/// (`ivdyn::ident::BaseParams`). The estimate is the change of those entries; the other
/// entries are taken as unchanged.
///
/// Rows of joints moving slower than `min_speed` are skipped: near a velocity reversal the
/// Coulomb term `fc sign(qd)` of the nominal model does not describe the real friction
/// (stiction, pre-sliding, a differentiated and noisy velocity), and that error, correlated
/// with the motion, would bias any estimator (IV included). No allocation.
#[derive(Debug, Clone)]
pub struct PayloadEstimator<const N: usize, D: Dim>
where
    DefaultAllocator: Allocator<D, D> + Allocator<D> + Allocator<D, nalgebra::U1>,
{
    /// The terminal-link estimator it runs: last link unknown with its four drive
    /// parameters, every joint's row ([`TerminalSpec`] with `first_row = 0`).
    pub link: TerminalLink<N, D>,
}

impl<const N: usize, D: Dim> PayloadEstimator<N, D>
where
    DefaultAllocator: Allocator<D, D> + Allocator<D> + Allocator<D, nalgebra::U1>,
{
    /// The unknown set: the last link's 14-entry block seen by every row.
    pub const SPEC: TerminalSpec = TerminalSpec { k: N - 1, drive: [true; DRIVE_PARAMS], first_row: 0 };

    /// New estimator. Fails on a column index outside `0..14`.
    pub fn new(
        nominal: Model<N>,
        columns: OVector<usize, D>,
        row_weight: [f64; N],
        min_speed: f64,
        method: Method<D>,
    ) -> Result<Self, Error> {
        if let Some(&c) = columns.iter().find(|&&c| c >= LINK_PARAMS + DRIVE_PARAMS) {
            return Err(Error::Dimension { what: "columns", expected: LINK_PARAMS + DRIVE_PARAMS, got: c });
        }
        let mut link = TerminalLink::new(nominal, Self::SPEC, columns, row_weight, method);
        link.min_speed = min_speed;
        Ok(Self { link })
    }

    /// Current estimate of the selected changes.
    pub fn theta(&self) -> &OVector<f64, D> {
        self.link.theta()
    }

    /// Variance of estimate `b` (index into `columns`). LS: the diagonal of the
    /// covariance. IV: the diagonal of `P = (sum w z phi^T)^{-1}`, the IV covariance
    /// `P (sum w z z^T) P^T` with the instrument replaced by the regressor (exact when they
    /// coincide; tried: the full sandwich form with this crate's heuristic row weights was
    /// 10-100 x too pessimistic on the paper's robot; this form was ~3 x pessimistic on one
    /// Panda run, judged against the estimate's actual error). Both assume the row weights are the inverse
    /// variances of the rows' equation errors. `O(1)` for IV, `O(D^2)` for LS, `O(D^3)` for
    /// IV in information form (`P` by `D` solves).
    pub fn variance(&self, b: usize) -> f64 {
        match &self.link.method {
            Method::Iv(r) => r.p[(b, b)],
            Method::IvInfo(r) => r.p()[(b, b)],
            Method::Ls(r) => {
                let mut v = r.theta.clone();
                r.variances(&mut v);
                v[b]
            }
        }
    }

    /// Position in `columns` of last-link entry `entry` (`0` = mass), if estimated.
    pub fn column_of(&self, entry: usize) -> Option<usize> {
        self.link.columns.iter().position(|&c| c == entry)
    }

    /// One sample: measured `q, qd, qdd`, torque `tau`, and the instrumental acceleration
    /// `qdd_instr` (ignored by least squares). See [`TerminalLink::update`].
    pub fn update(
        &mut self,
        q: &VecN<N>,
        qd: &VecN<N>,
        qdd: &VecN<N>,
        tau: &VecN<N>,
        qdd_instr: &VecN<N>,
    ) -> Result<(), Error> {
        self.link.update(q, qd, qdd, tau, qdd_instr)
    }

    /// Writes nominal + estimate into `model`'s last link and last drive (the entries not
    /// estimated are set to their nominal values). The controller holding `model` then
    /// uses the estimate at its next call. `O(14)`.
    pub fn write_model(&self, model: &mut Model<N>) {
        let l = N - 1;
        model.inertia[l] = self.link.nominal.inertia[l];
        model.drive[l] = self.link.nominal.drive[l];
        let mut drive = model.drive[l].to_array();
        for (b, &c) in self.link.columns.iter().enumerate() {
            let v = self.theta()[b];
            if c < LINK_PARAMS {
                model.inertia[l].0[c] += v;
            } else {
                drive[c - LINK_PARAMS] += v;
            }
        }
        model.drive[l] = crate::params::DriveParams::from_array(drive);
    }

    /// The last link as nominal + estimate (inertial entries only).
    pub fn estimated_last_link(&self) -> crate::inertia::LinkInertia {
        let mut li = self.link.nominal.inertia[N - 1];
        for (b, &c) in self.link.columns.iter().enumerate() {
            if c < LINK_PARAMS {
                li.0[c] += self.theta()[b];
            }
        }
        li
    }

    /// [`Self::write_model`] only if the estimated last link is physically consistent
    /// (positive mass, pseudo-inertia positive semi-definite,
    /// [`crate::LinkInertia::is_physically_consistent`] with tolerance `tol`); otherwise
    /// `model` is left as it is (e.g. holding the last consistent estimate). Early
    /// estimates can have a negative inertia about an axis, which makes computed torque
    /// unstable on that joint. Returns whether the model was written.
    pub fn write_model_if_consistent(&self, model: &mut Model<N>, tol: f64) -> bool {
        if !self.estimated_last_link().is_physically_consistent(tol) {
            return false;
        }
        self.write_model(model);
        true
    }

    /// Standard deviation of the estimated payload torque on each joint at the last
    /// sample, `sqrt(phi_i^T C phi_i)` with `phi_i` the row of joint `i` at the last
    /// update's state and `C` the covariance of [`Self::variance`]. Divided by `M_ii` it is
    /// the acceleration error the estimate's uncertainty would cause under computed torque,
    /// divided again by `Kp` the tracking error: a switching criterion in the controller's
    /// own units. `O(N D^2)` for IV.
    pub fn torque_std(&mut self, out: &mut VecN<N>) {
        let cov_ls = match &self.link.method {
            Method::Ls(r) => Some(r.covariance()),
            Method::IvInfo(r) => Some(r.p()),
            Method::Iv(_) => None,
        };
        let mut phi = self.link.theta().clone();
        for row in 0..N {
            for (b, &c) in self.link.columns.iter().enumerate() {
                phi[b] = Self::SPEC.entry(self.link.last_regressor(), row, c);
            }
            let v = match (&self.link.method, &cov_ls) {
                (_, Some(c)) => quad(c, &phi),
                (Method::Iv(r), None) => quad(&r.p, &phi),
                (Method::Ls(_) | Method::IvInfo(_), None) => 0.0,
            };
            out[row] = libm::sqrt(v.max(0.0));
        }
    }
}

/// `x^T A x`.
fn quad<D: Dim>(a: &OMatrix<f64, D, D>, x: &OVector<f64, D>) -> f64
where
    DefaultAllocator: Allocator<D, D> + Allocator<D>,
{
    let mut s = 0.0;
    for i in 0..x.len() {
        if x[i] == 0.0 {
            continue;
        }
        let mut t = 0.0;
        for j in 0..x.len() {
            t += a[(i, j)] * x[j];
        }
        s += x[i] * t;
    }
    s
}

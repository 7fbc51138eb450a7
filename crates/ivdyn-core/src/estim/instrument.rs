//! The paper's instrumental model, eq (35): one linear time-invariant model per joint,
//! driven by the actuator input `u_i`, predicting the acceleration without the
//! measurement noise:
//!
//! `qdd_hat_i(j) = -a_i qd_i(j-1) + b0_i u_i(j) + b1_i qd_i(j-1)`.
//!
//! Because `u` and the previous velocity do not contain the current acceleration noise,
//! the regressor evaluated at `qdd_hat` is a valid instrument (eqs 36-37).

use crate::data::Data;
use crate::model::Model;
use crate::types::VecN;

/// Coefficients of eq (35) per joint.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct InstrumentModel<const N: usize> {
    /// `a_i` (1/s).
    pub a: [f64; N],
    /// `b0_i`: acceleration per unit input (for a torque input, `1 / M_ii`).
    pub b0: [f64; N],
    /// `b1_i` (1/s).
    pub b1: [f64; N],
}

impl<const N: usize> InstrumentModel<N> {
    /// "Rough prior information" (paper): `b0_i = 1 / M_ii(q0)` of the nominal model,
    /// `a_i = fv_i / M_ii(q0)` (viscous damping), `b1_i = 0`.
    pub fn from_nominal(model: &Model<N>, data: &mut Data<N>, q0: &VecN<N>) -> Self {
        let m = crate::crba::mass_matrix(model, data, q0);
        let mut s = Self { a: [0.0; N], b0: [0.0; N], b1: [0.0; N] };
        for i in 0..N {
            let mii = m[(i, i)].max(f64::MIN_POSITIVE);
            s.b0[i] = 1.0 / mii;
            s.a[i] = model.drive[i].fv / mii;
        }
        s
    }

    /// Eq (35): the instrumental acceleration from the input `u(j)` and `qd(j-1)`.
    #[inline]
    pub fn qdd_hat(&self, u: &VecN<N>, qd_prev: &VecN<N>) -> VecN<N> {
        VecN::<N>::from_fn(|i, _| -self.a[i] * qd_prev[i] + self.b0[i] * u[i] + self.b1[i] * qd_prev[i])
    }
}

//! What the recursive estimators share: the row guard (which rows are refused, and why)
//! and the information weight of a row under directional forgetting.
//!
//! # Math note
//! A row `y = phi^T theta + e`, `var(e) = 1 / w`, shrinks the variance of `phi^T theta`
//! from `s = phi^T P phi` to `s / (1 + w s)`: `w s` is the row's information relative to
//! what the estimator already holds along `phi`. The factored (UD) covariance represents
//! a covariance of condition number up to about `1 / eps^2` (the square-root argument,
//! [Bierman 1977, ch. V]); a row with `w s > 1 / eps^2 ~ 2.0e31` would leave `P`
//! numerically singular along `phi` and the estimate frozen there for good, so it is
//! refused ([`Error::RowOutOfRange`]) with the state untouched. `1e150`-sized rows,
//! `1e300` weights and overflowing products all land here; a legitimate row with a
//! flat prior (`p0 = 1e12`, `|phi|^2 = 1e4`, `w = 1`: `w s = 1e16`) does not.
//!
//! The normalised innovation `|e| / sqrt(1 / w + s)` is standard normal for a row that
//! fits the model with the stated `w` and `P`; the optional outlier gate refuses rows
//! above a threshold ([`Error::Outlier`]). It is off by default: after a real parameter
//! change (a grasped payload) the large innovations are the signal to track.

use crate::error::Error;
use crate::scalar::RealScalar;
use nalgebra::allocator::Allocator;
use nalgebra::{DefaultAllocator, Dim, OVector};

/// Largest information ratio `w phi^T P phi` a row may carry: `1 / eps^2 ~ 2.03e31`.
pub const MAX_INFORMATION_RATIO: f64 = 1.0 / (f64::EPSILON * f64::EPSILON);

/// Non-finite `y` or a weight outside `(0, inf)`: degenerate; non-finite `v[index]`:
/// [`Error::NonFinite`] naming `what`.
pub(crate) fn check_inputs<D: Dim, T: RealScalar>(
    what: &'static str,
    v: &OVector<T, D>,
    y: T,
    w: f64,
) -> Result<(), Error>
where
    DefaultAllocator: Allocator<D>,
{
    if !(w > 0.0) || !w.is_finite() || !y.is_finite() {
        return Err(Error::DegenerateUpdate);
    }
    match v.iter().position(|x| !x.is_finite()) {
        Some(index) => Err(Error::NonFinite { what, index }),
        None => Ok(()),
    }
}

/// The row guard: `ratio = w s` (at most [`MAX_INFORMATION_RATIO`], finite), and the
/// normalised innovation `|e| / sqrt(1 / w + s)` at most `gate` (infinity = no gate).
/// `w` enters as `w_t` (the same weight in `T`); with no gate (`gate` infinite, the
/// default) the normalised innovation is not computed.
pub(crate) fn check_row<T: RealScalar>(w: f64, w_t: T, s: T, innovation: T, gate: f64) -> Result<(), Error> {
    let ratio = w_t * s;
    if !(ratio <= T::from_f64(MAX_INFORMATION_RATIO)) {
        return Err(Error::RowOutOfRange { ratio: ratio.to_f64() });
    }
    if !innovation.is_finite() {
        return Err(Error::NonFinite { what: "innovation y - phi . theta", index: 0 });
    }
    if gate.is_finite() {
        // nu = |e| / sqrt(1 / w + s)
        let nu = innovation.abs() / (T::from_f64(1.0 / w) + s).sqrt();
        if nu > T::from_f64(gate) {
            return Err(Error::Outlier { innovation: nu.to_f64(), gate });
        }
    }
    Ok(())
}

/// Kulhavý and Kárný's directional forgetting: the information weight `eps` with which this row
/// enters the information matrix, `R <- R + eps phi phi^T`, `eps = w - (1 - lambda) / s`
/// (forget the fraction `1 - lambda` of the information along `phi`, then add the row's
/// `w`). `lambda = 1` or `s = 0` (no direction): `eps = w` exactly.
pub(crate) fn directional_weight<T: RealScalar>(lambda: f64, w: T, s: T) -> T {
    if lambda < 1.0 && s > T::zero() { w - T::from_f64(1.0 - lambda) / s } else { w }
}

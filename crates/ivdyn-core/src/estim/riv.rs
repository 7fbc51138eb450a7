//! Recursive instrumental-variable estimator, the recursive form of the paper's eq (32)
//! (`theta = (Z^T W A)^{-1} Z^T W y`, `W` the row weights) [Young, *Recursive Estimation
//! and Time-Series Analysis*, 2011, ch. 7].
//!
//! # Math note
//! `P = (sum w z phi^T)^{-1}` is not symmetric, so no factorised form keeps it
//! positive definite; the Sherman-Morrison update
//! `P <- (P - P z phi^T P / (lambda / w + phi^T P z)) / lambda`
//! is guarded instead: a denominator that is not finite or is tiny relative to its terms
//! scale `lambda / w + |phi| |P z|`
//! (the instrument uncorrelated with the regressor in the current direction) is reported
//! as [`Error::DegenerateUpdate`] and the state is left untouched.

use crate::error::Error;
use nalgebra::allocator::Allocator;
use nalgebra::{DefaultAllocator, Dim, OMatrix, OVector};

/// Recursive IV: regressor rows `phi`, instrument rows `z`, outputs `y`.
#[derive(Debug, Clone)]
pub struct Riv<D: Dim>
where
    DefaultAllocator: Allocator<D, D> + Allocator<D>,
{
    /// Current estimate.
    pub theta: OVector<f64, D>,
    /// `(sum w z phi^T)^{-1}` (scaled by the noise variance it is the IV covariance's core).
    pub p: OMatrix<f64, D, D>,
    /// Forgetting factor in (0, 1].
    pub forgetting: f64,
    /// Rows processed.
    pub count: u64,
    pz: OVector<f64, D>,
    ptphi: OVector<f64, D>,
}

impl<D: Dim> Riv<D>
where
    DefaultAllocator: Allocator<D, D> + Allocator<D>,
{
    /// Starts from `theta0` with `P = p0 * I`.
    pub fn new(theta0: OVector<f64, D>, p0: f64) -> Self {
        let (dim, _) = theta0.shape_generic();
        Self {
            p: OMatrix::identity_generic(dim, dim) * p0,
            pz: OVector::zeros_generic(dim, nalgebra::Const::<1>),
            ptphi: OVector::zeros_generic(dim, nalgebra::Const::<1>),
            theta: theta0,
            forgetting: 1.0,
            count: 0,
        }
    }

    /// Starts from a batch solution: `info = sum w z phi^T` (invertible), `rhs = sum w z y`.
    pub fn from_information(info: &OMatrix<f64, D, D>, rhs: &OVector<f64, D>) -> Result<Self, Error>
    where
        D: nalgebra::DimMin<D, Output = D>,
        DefaultAllocator: Allocator<D>,
    {
        let lu = info.clone().lu();
        let theta = lu.solve(rhs).ok_or(Error::Singular)?;
        let p = lu.try_inverse().ok_or(Error::Singular)?;
        let mut s = Self::new(theta, 1.0);
        s.p = p;
        Ok(s)
    }

    /// One scalar row with instrument `z` and weight `w > 0`.
    pub fn update(&mut self, phi: &OVector<f64, D>, z: &OVector<f64, D>, y: f64, w: f64) -> Result<(), Error> {
        if !(w > 0.0) || !w.is_finite() || !y.is_finite() {
            return Err(Error::DegenerateUpdate);
        }
        if let Some(index) = phi.iter().position(|v| !v.is_finite()) {
            return Err(Error::NonFinite { what: "phi", index });
        }
        if let Some(index) = z.iter().position(|v| !v.is_finite()) {
            return Err(Error::NonFinite { what: "z", index });
        }
        self.p.mul_to(z, &mut self.pz);
        self.p.tr_mul_to(phi, &mut self.ptphi);
        let r = self.forgetting / w;
        let s = phi.dot(&self.pz);
        let den = r + s;
        // scale of the terms by Cauchy-Schwarz: |phi^T P z| <= |phi| |P z|
        let scale = r.abs() + phi.norm() * self.pz.norm();
        if !den.is_finite() || den.abs() <= 1e-12 * scale {
            return Err(Error::DegenerateUpdate);
        }
        let innovation = y - phi.dot(&self.theta);
        self.theta.axpy(innovation / den, &self.pz, 1.0);
        // P <- (P - pz ptphi^T / den) / lambda
        self.p.ger(-1.0 / den, &self.pz, &self.ptphi, 1.0);
        if self.forgetting < 1.0 {
            self.p /= self.forgetting;
        }
        self.count += 1;
        Ok(())
    }
}

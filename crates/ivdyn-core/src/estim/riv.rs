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
//! as [`Error::DegenerateUpdate`] and the state is left untouched. Rows then pass the
//! shared guard ([`super::guard`]) with `|phi| |P z|` standing in for `phi^T P phi`.
//!
//! Forgetting is exponential (the division by `lambda` above), with an anti-windup cap:
//! after each row with `lambda < 1`, `P <- S P S`, `S = diag(min(1, sqrt(cap / |P_ii|)))`,
//! so no `|P_ii|` exceeds `max_variance` (default `p0`, the prior) and a direction that is
//! never excited stays at the prior instead of growing as `lambda^-k` (a per-coordinate
//! form of the bounded-covariance remedy for estimator windup in Åström & Wittenmark,
//! *Adaptive Control*, 2nd ed. 1995). The directional forgetting of [`super::Rls`] needs `phi^T P z > 0` and is
//! singular as it tends to 0, which an instrument does not guarantee.

use super::guard;
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
    /// Bound on every `|P_ii|` when `forgetting < 1` (anti-windup); default `p0`.
    pub max_variance: f64,
    /// Largest normalised innovation `|e| / sqrt(1 / w + |phi| |P z|)` accepted;
    /// infinity (default) = no outlier gate.
    pub outlier_gate: f64,
    /// Rows processed.
    pub count: u64,
    pz: OVector<f64, D>,
    ptphi: OVector<f64, D>,
}

impl<D: Dim> Riv<D>
where
    DefaultAllocator: Allocator<D, D> + Allocator<D>,
{
    /// Starts from `theta0` with `P = p0 * I`; no forgetting, `max_variance = p0`, no gate.
    pub fn new(theta0: OVector<f64, D>, p0: f64) -> Self {
        let (dim, _) = theta0.shape_generic();
        Self {
            p: OMatrix::identity_generic(dim, dim) * p0,
            pz: OVector::zeros_generic(dim, nalgebra::Const::<1>),
            ptphi: OVector::zeros_generic(dim, nalgebra::Const::<1>),
            theta: theta0,
            forgetting: 1.0,
            max_variance: p0,
            outlier_gate: f64::INFINITY,
            count: 0,
        }
    }

    /// Starts from a batch solution: `info = sum w z phi^T` (invertible), `rhs = sum w z y`;
    /// `max_variance` is the largest `|P_ii|` of `info^-1`.
    pub fn from_information(info: &OMatrix<f64, D, D>, rhs: &OVector<f64, D>) -> Result<Self, Error>
    where
        D: nalgebra::DimMin<D, Output = D>,
        DefaultAllocator: Allocator<D>,
    {
        let lu = info.clone().lu();
        let theta = lu.solve(rhs).ok_or(Error::Singular)?;
        let p = lu.try_inverse().ok_or(Error::Singular)?;
        let mut s = Self::new(theta, 1.0);
        s.max_variance = p.diagonal().amax();
        s.p = p;
        Ok(s)
    }

    /// One scalar row with instrument `z` and weight `w > 0`; errors (as [`super::Rls`]'s)
    /// leave the state untouched.
    pub fn update(&mut self, phi: &OVector<f64, D>, z: &OVector<f64, D>, y: f64, w: f64) -> Result<(), Error> {
        guard::check_inputs("phi", phi, y, w)?;
        guard::check_inputs("z", z, y, w)?;
        let lambda = self.forgetting;
        self.p.mul_to(z, &mut self.pz);
        self.p.tr_mul_to(phi, &mut self.ptphi);
        let r = lambda / w;
        let s = phi.dot(&self.pz);
        let den = r + s;
        // scale of the terms by Cauchy-Schwarz: |phi^T P z| <= |phi| |P z|
        let s_scale = phi.norm() * self.pz.norm();
        if !(w * s_scale).is_finite() {
            return Err(Error::RowOutOfRange { ratio: w * s_scale });
        }
        if !(lambda > 0.0 && lambda <= 1.0 && den.is_finite()) || den.abs() <= 1e-12 * (r.abs() + s_scale) {
            return Err(Error::DegenerateUpdate);
        }
        let innovation = y - phi.dot(&self.theta);
        guard::check_row(w, s_scale, innovation, self.outlier_gate)?;
        self.theta.axpy(innovation / den, &self.pz, 1.0);
        // P <- (P - pz ptphi^T / den) / lambda
        self.p.ger(-1.0 / den, &self.pz, &self.ptphi, 1.0);
        if lambda < 1.0 {
            self.p /= lambda;
            self.cap_diagonal();
        }
        self.count += 1;
        Ok(())
    }

    /// Anti-windup: `P <- S P S`, `S = diag(min(1, sqrt(max_variance / |P_ii|)))`.
    fn cap_diagonal(&mut self) {
        let (n, cap) = (self.p.nrows(), self.max_variance);
        if (0..n).all(|i| !(self.p[(i, i)].abs() > cap)) {
            return;
        }
        // S in the free scratch vector
        for i in 0..n {
            self.ptphi[i] = libm::sqrt(cap / self.p[(i, i)].abs()).min(1.0);
        }
        for j in 0..n {
            for i in 0..n {
                self.p[(i, j)] *= self.ptphi[i] * self.ptphi[j];
            }
        }
    }
}

//! Recursive least squares over scalar rows, in Bierman's UD form.
//!
//! # Math note
//! The covariance `P = U D U^T` (`U` unit upper triangular, `D` diagonal) is never formed:
//! Bierman's measurement update keeps `D > 0` by construction (each new `d_j` is the old one
//! times a ratio of positive numbers), so `P` stays symmetric positive definite over any
//! number of updates, where the textbook `P - K phi^T P` loses symmetry and definiteness in
//! floating point. Forgetting divides `D` by `lambda`; an optional cap on `D` bounds the
//! wind-up of unexcited directions.
//!
//! A vector output (one row per joint per sample) is processed as scalar rows: with
//! independent row noises (row weights `w = 1 / variance`) this is exact.
//!
//! Reference: G. J. Bierman, *Factorization Methods for Discrete Sequential Estimation*,
//! Academic Press 1977, ch. V.

use crate::error::Error;
use nalgebra::allocator::Allocator;
use nalgebra::{DefaultAllocator, Dim, OMatrix, OVector};

/// Recursive least squares `y = phi^T theta + e`, `var(e) = 1 / w`.
#[derive(Debug, Clone)]
pub struct Rls<D: Dim>
where
    DefaultAllocator: Allocator<D, D> + Allocator<D>,
{
    /// Current estimate.
    pub theta: OVector<f64, D>,
    /// Unit upper-triangular factor of the covariance.
    u: OMatrix<f64, D, D>,
    /// Diagonal factor of the covariance.
    d: OVector<f64, D>,
    /// Forgetting factor `lambda` in (0, 1]; 1 = none.
    pub forgetting: f64,
    /// Upper bound on each `d_j` (anti-windup with forgetting); infinity = none.
    pub max_variance: f64,
    /// Rows processed.
    pub count: u64,
    f: OVector<f64, D>,
    g: OVector<f64, D>,
}

impl<D: Dim> Rls<D>
where
    DefaultAllocator: Allocator<D, D> + Allocator<D>,
{
    /// Starts from `theta0` with covariance `p0 * I` (a large `p0` = little prior knowledge).
    pub fn new(theta0: OVector<f64, D>, p0: f64) -> Self {
        let (dim, _) = theta0.shape_generic();
        Self {
            u: OMatrix::identity_generic(dim, dim),
            d: OVector::from_element_generic(dim, nalgebra::Const::<1>, p0),
            f: OVector::zeros_generic(dim, nalgebra::Const::<1>),
            g: OVector::zeros_generic(dim, nalgebra::Const::<1>),
            theta: theta0,
            forgetting: 1.0,
            max_variance: f64::INFINITY,
            count: 0,
        }
    }

    /// Starts from a batch solution: `info = sum w phi phi^T` (must be positive definite)
    /// and `rhs = sum w phi y`, so that the recursion continues the batch estimate exactly.
    pub fn from_information(info: &OMatrix<f64, D, D>, rhs: &OVector<f64, D>) -> Result<Self, Error> {
        let (dim, _) = rhs.shape_generic();
        let chol = info.clone().cholesky().ok_or(Error::Singular)?;
        let theta = chol.solve(rhs);
        let p = chol.inverse();
        let mut s = Self::new(theta, 1.0);
        s.set_covariance(&p)?;
        let _ = dim;
        Ok(s)
    }

    /// Replaces the covariance (symmetric positive definite) by its UD factors.
    pub fn set_covariance(&mut self, p: &OMatrix<f64, D, D>) -> Result<(), Error> {
        // UD decomposition from the last column backwards: P = U D U^T
        let n = p.nrows();
        let mut p = p.clone();
        self.u.fill(0.0);
        for j in (0..n).rev() {
            let dj = p[(j, j)];
            if !(dj > 0.0) || !dj.is_finite() {
                return Err(Error::Singular);
            }
            self.d[j] = dj;
            self.u[(j, j)] = 1.0;
            for i in 0..j {
                self.u[(i, j)] = p[(i, j)] / dj;
            }
            for i in 0..j {
                for k in 0..=i {
                    let v = p[(k, i)] - self.u[(k, j)] * self.u[(i, j)] * dj;
                    p[(k, i)] = v;
                    p[(i, k)] = v;
                }
            }
        }
        Ok(())
    }

    /// The covariance `U D U^T` (forms it: `O(P^3)`, for reporting only).
    pub fn covariance(&self) -> OMatrix<f64, D, D> {
        let mut ud = self.u.clone();
        for j in 0..ud.ncols() {
            let dj = self.d[j];
            ud.column_mut(j).scale_mut(dj);
        }
        &ud * self.u.transpose()
    }

    /// Variance of each parameter (diagonal of the covariance), `O(P^2)`.
    pub fn variances(&self, out: &mut OVector<f64, D>) {
        let n = self.d.len();
        for i in 0..n {
            let mut s = 0.0;
            for j in i..n {
                s += self.u[(i, j)] * self.u[(i, j)] * self.d[j];
            }
            out[i] = s;
        }
    }

    /// One scalar row: `y = phi . theta + e` with weight `w > 0` (inverse noise variance).
    /// Rejects non-finite input; leaves the state untouched on error.
    pub fn update(&mut self, phi: &OVector<f64, D>, y: f64, w: f64) -> Result<(), Error> {
        if !(w > 0.0) || !w.is_finite() || !y.is_finite() {
            return Err(Error::DegenerateUpdate);
        }
        if let Some(index) = phi.iter().position(|v| !v.is_finite()) {
            return Err(Error::NonFinite { what: "phi", index });
        }
        let n = self.d.len();
        // f = U^T phi, g = D f
        self.u.tr_mul_to(phi, &mut self.f);
        for j in 0..n {
            self.g[j] = self.d[j] * self.f[j];
        }
        let r = 1.0 / w;
        let alpha_end = r + self.f.dot(&self.g);
        if !(alpha_end > 0.0) || !alpha_end.is_finite() {
            return Err(Error::DegenerateUpdate);
        }
        let innovation = y - phi.dot(&self.theta);
        // Bierman's measurement update
        let mut alpha = r;
        for j in 0..n {
            let alpha_prev = alpha;
            alpha += self.f[j] * self.g[j];
            let lambda = -self.f[j] / alpha_prev;
            self.d[j] *= alpha_prev / alpha;
            let gj = self.g[j];
            for i in 0..j {
                let beta = self.u[(i, j)];
                self.u[(i, j)] = beta + self.g[i] * lambda;
                self.g[i] += gj * beta;
            }
        }
        // gain K = g / alpha
        let step = innovation / alpha;
        self.theta.axpy(step, &self.g, 1.0);
        if self.forgetting < 1.0 {
            let inv = 1.0 / self.forgetting;
            for j in 0..n {
                self.d[j] = (self.d[j] * inv).min(self.max_variance);
            }
        }
        self.count += 1;
        Ok(())
    }
}

//! Recursive least squares over scalar rows, in Bierman's UD form, with directional
//! forgetting and an anti-windup cap.
//!
//! # Math note
//! The covariance `P = U D U^T` (`U` unit upper triangular, `D` diagonal) is never formed:
//! Bierman's measurement update keeps `D > 0` by construction (each new `d_j` is the old one
//! times a ratio of positive numbers), so `P` stays symmetric positive definite over any
//! number of updates, where the textbook `P - K phi^T P` loses symmetry and definiteness in
//! floating point.
//!
//! Forgetting is directional [Kulhavý & Kárný 1984; Bittanti, Bolzern, Campi 1990]: each row first
//! removes the fraction `1 - lambda` of the information held along its own `phi`, then adds
//! its own, `R <- R - (1 - lambda) phi phi^T / s + w phi phi^T` (`R = P^-1`,
//! `s = phi^T P phi`). The variance of `phi^T theta` grows by `1 / lambda` as with
//! exponential forgetting and the gain is the same, `K = P phi / (lambda / w + s)`, but
//! the information about any combination `c^T theta` with `c^T phi = 0` is kept: a
//! direction that is never excited keeps its covariance (exponential forgetting divides
//! all of `D` by `lambda` every row, so an unexcited `d_j` grows as `lambda^-k` and
//! overflows after `ln(f64::MAX / p0) / -ln lambda` rows, 69,707 at `lambda = 0.99`,
//! `p0 = 1e4`). The combined
//! change is one rank-one update with weight `eps = w - (1 - lambda) / s`, which is
//! Bierman's update with `r = 1 / eps` (negative when the row adds less than it forgets:
//! every `alpha` is then negative and `D` grows, by at most `1 / lambda`).
//!
//! Anti-windup: with forgetting, every `d_j` is capped at `max_variance` after each row;
//! the default is the prior `p0`, so forgetting never makes a factor larger than the
//! prior did (directional forgetting can still inflate a direction whose rows carry
//! little information, `w s << 1 - lambda`). Without forgetting `D` only decreases and the
//! cap is not applied: `lambda = 1` results are those of plain RLS.
//!
//! A vector output (one row per joint per sample) is processed as scalar rows: with
//! independent row noises (row weights `w = 1 / variance`) this is exact. Rows are
//! checked by the shared guard ([`super::guard`]): non-finite input, rows out of
//! numerical range, and (optionally) outliers are errors that leave the state untouched.
//!
//! References: G. J. Bierman, *Factorization Methods for Discrete Sequential Estimation*,
//! Academic Press 1977, ch. V. R. Kulhavý, M. Kárný, "Tracking of slowly varying
//! parameters by directional forgetting", 9th IFAC World Congress, Budapest, 1984 (the
//! weighted form above, with `w`, is ours). S. Bittanti, P. Bolzern, M. Campi,
//! "Convergence and exponential convergence of identification algorithms with directional
//! forgetting factor", *Automatica* 26(5):929-932, 1990.

use super::guard;
use crate::error::Error;
use crate::scalar::{RealScalar, Sum};
use nalgebra::allocator::Allocator;
use nalgebra::{DefaultAllocator, Dim, OMatrix, OVector};

/// Recursive least squares `y = phi^T theta + e`, `var(e) = 1 / w`. `T` is the scalar
/// ([`RealScalar`]: `f64` by default).
#[derive(Debug, Clone)]
pub struct Rls<D: Dim, T: RealScalar = f64>
where
    DefaultAllocator: Allocator<D, D> + Allocator<D>,
{
    /// Current estimate.
    pub theta: OVector<T, D>,
    /// Unit upper-triangular factor of the covariance.
    u: OMatrix<T, D, D>,
    /// Diagonal factor of the covariance.
    d: OVector<T, D>,
    /// Forgetting factor `lambda` in (0, 1]; 1 = none. Directional (module docs).
    pub forgetting: f64,
    /// Upper bound on each `d_j` when `forgetting < 1` (anti-windup); default `p0`.
    pub max_variance: f64,
    /// Largest normalised innovation `|e| / sqrt(1 / w + phi^T P phi)` accepted;
    /// infinity (default) = no outlier gate.
    pub outlier_gate: f64,
    /// Rows processed.
    pub count: u64,
    f: OVector<T, D>,
    g: OVector<T, D>,
}

impl<D: Dim, T: RealScalar> Rls<D, T>
where
    DefaultAllocator: Allocator<D, D> + Allocator<D>,
{
    /// Starts from `theta0` with covariance `p0 * I` (a large `p0` = little prior knowledge);
    /// no forgetting, `max_variance = p0`, no outlier gate.
    pub fn new(theta0: OVector<T, D>, p0: f64) -> Self {
        let (dim, _) = theta0.shape_generic();
        let mut u = OMatrix::from_element_generic(dim, dim, T::zero());
        for i in 0..u.nrows() {
            u[(i, i)] = T::one();
        }
        Self {
            u,
            d: OVector::from_element_generic(dim, nalgebra::Const::<1>, T::from_f64(p0)),
            f: OVector::from_element_generic(dim, nalgebra::Const::<1>, T::zero()),
            g: OVector::from_element_generic(dim, nalgebra::Const::<1>, T::zero()),
            theta: theta0,
            forgetting: 1.0,
            max_variance: p0,
            outlier_gate: f64::INFINITY,
            count: 0,
        }
    }

    /// Variance of each parameter (diagonal of the covariance), `O(P^2)`.
    pub fn variances(&self, out: &mut OVector<T, D>) {
        let n = self.d.len();
        for i in 0..n {
            let mut s = T::zero();
            for j in i..n {
                s += self.u[(i, j)] * self.u[(i, j)] * self.d[j];
            }
            out[i] = s;
        }
    }

    /// The diagonal factor `D` of `P = U D U^T` (every entry `> 0`).
    pub fn d(&self) -> &OVector<T, D> {
        &self.d
    }

    /// One scalar row: `y = phi . theta + e` with weight `w > 0` (inverse noise variance).
    /// Errors leave the state untouched: non-finite input, a weight outside `(0, inf)`,
    /// a row out of numerical range ([`Error::RowOutOfRange`]) or above the outlier gate
    /// ([`Error::Outlier`]).
    pub fn update(&mut self, phi: &OVector<T, D>, y: T, w: f64) -> Result<(), Error> {
        self.update_on(phi, None, y, w)
    }

    /// [`Self::update`] for a row known to be zero outside `support` (entries outside it
    /// are not read): the products with those zeros are skipped, which is all the
    /// difference (the terminal-link rows).
    pub fn update_sparse(
        &mut self,
        phi: &OVector<T, D>,
        support: &OVector<bool, D>,
        y: T,
        w: f64,
    ) -> Result<(), Error> {
        self.update_on(phi, Some(support), y, w)
    }

    fn update_on(
        &mut self,
        phi: &OVector<T, D>,
        support: Option<&OVector<bool, D>>,
        y: T,
        w: f64,
    ) -> Result<(), Error> {
        guard::check_inputs("phi", phi, y, w)?;
        let on = |j: usize| support.is_none_or(|s| s[j]);
        let (n, lambda) = (self.d.len(), self.forgetting);
        // f = U^T phi (U unit upper triangular: f_j = phi_j + sum_{i<j} U_ij phi_i), g = D f,
        // and phi . theta, over the support only
        let mut pred = Sum::new();
        for j in 0..n {
            let mut fj = Sum::new();
            if on(j) {
                fj.add(phi[j]);
                pred.add(phi[j] * self.theta[j]);
            }
            for i in (0..j).filter(|&i| on(i)) {
                fj.add(self.u[(i, j)] * phi[i]);
            }
            let fj = fj.get();
            self.f[j] = fj;
            self.g[j] = self.d[j] * fj;
        }
        let pred = pred.get();
        // s = phi^T P phi
        let mut s = Sum::new();
        for j in 0..n {
            s.add(self.f[j] * self.g[j]);
        }
        let s = s.get();
        let innovation = y - pred;
        let w_t = T::from_f64(w);
        guard::check_row(w, w_t, s, innovation, self.outlier_gate)?;
        let den = T::from_f64(lambda / w) + s;
        if !(lambda > 0.0 && lambda <= 1.0 && den > T::zero() && den.is_finite()) {
            return Err(Error::DegenerateUpdate);
        }
        // R <- R + eps phi phi^T, i.e. Bierman's update with r = 1 / eps
        let eps = guard::directional_weight(lambda, w_t, s);
        let alpha = self.bierman(T::one() / eps);
        // gain K = P phi / (lambda / w + s); with lambda = 1, eps = w and that is alpha
        let step = innovation / if lambda < 1.0 { den } else { alpha };
        for j in 0..n {
            self.theta[j] += step * self.g[j];
        }
        if lambda < 1.0 {
            // anti-windup: d_j <= max_variance
            let cap = T::from_f64(self.max_variance);
            for j in 0..n {
                if !(self.d[j] <= cap) {
                    self.d[j] = cap;
                }
            }
        }
        self.count += 1;
        Ok(())
    }

    /// Bierman's measurement update `P <- P - P phi phi^T P / (r + s)` on the factors,
    /// from `f = U^T phi` and `g = D f`; leaves `g = P phi` (old `P`) and returns `r + s`.
    /// `r` infinite (`eps = 0`): `P` unchanged.
    fn bierman(&mut self, r: T) -> T {
        let mut alpha = r;
        for j in 0..self.d.len() {
            let alpha_prev = alpha;
            alpha += self.f[j] * self.g[j];
            let mu = -self.f[j] / alpha_prev;
            if r.is_finite() {
                self.d[j] *= alpha_prev / alpha;
            }
            let gj = self.g[j];
            for i in 0..j {
                let beta = self.u[(i, j)];
                self.u[(i, j)] = beta + self.g[i] * mu;
                self.g[i] += gj * beta;
            }
        }
        alpha
    }
}

impl<D: Dim> Rls<D, f64>
where
    DefaultAllocator: Allocator<D, D> + Allocator<D>,
{
    /// Starts from a batch solution: `info = sum w phi phi^T` (must be positive definite)
    /// and `rhs = sum w phi y`, so that the recursion continues the batch estimate exactly.
    /// `max_variance` is the largest batch variance (the diagonal of `info^-1`).
    pub fn from_information(info: &OMatrix<f64, D, D>, rhs: &OVector<f64, D>) -> Result<Self, Error> {
        let (dim, _) = rhs.shape_generic();
        let chol = info.clone().cholesky().ok_or(Error::Singular)?;
        let theta = chol.solve(rhs);
        let p = chol.inverse();
        let mut s = Self::new(theta, 1.0);
        s.set_covariance(&p)?;
        s.max_variance = p.diagonal().max();
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
}

//! Recursive instrumental-variable estimator, the recursive form of the paper's eq (32)
//! (`theta = (Z^T W A)^{-1} Z^T W y`, `W` the row weights) [Young, *Recursive Estimation
//! and Time-Series Analysis*, 2011, ch. 7].
//!
//! # Math note
//! `P = (sum w z phi^T)^{-1}` is not symmetric, so no factorised form keeps it
//! positive definite (and it is dense whatever the rows' sparsity: [`super::RivInfo`] holds
//! `P^-1` as LU factors instead, in fewer operations, without forgetting); the
//! Sherman-Morrison update
//! `P <- (P - P z phi^T P / (lambda / w + phi^T P z)) / lambda`
//! is guarded instead: a denominator that is not finite or is tiny relative to its terms
//! scale `lambda / w + |phi|_1 |P z|_inf`
//! (the instrument uncorrelated with the regressor in the current direction) is reported
//! as [`Error::DegenerateUpdate`] and the state is left untouched. Rows then pass the
//! shared guard ([`super::guard`]) with `|phi|_1 |P z|_inf` standing in for `phi^T P phi`.
//! Both bound `|phi^T P z|` (Hölder); the 1- and infinity-norms need no products and no
//! square roots (Cauchy-Schwarz's `|phi|_2 |P z|_2` cost 25 % of the multiplications a
//! terminal-link row spends outside `P`, issue 19), and differ from it by at most
//! `sqrt(D)`, far inside the guard's margins (`1e-12`, `1 / eps^2`).
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
use crate::scalar::{RealScalar, Sum};
use nalgebra::allocator::Allocator;
use nalgebra::{DefaultAllocator, Dim, OMatrix, OVector};

/// Recursive IV: regressor rows `phi`, instrument rows `z`, outputs `y`. `T` is the
/// scalar ([`RealScalar`]: `f64` by default).
#[derive(Debug, Clone)]
pub struct Riv<D: Dim, T: RealScalar = f64>
where
    DefaultAllocator: Allocator<D, D> + Allocator<D>,
{
    /// Current estimate.
    pub theta: OVector<T, D>,
    /// `(sum w z phi^T)^{-1}` (scaled by the noise variance it is the IV covariance's core).
    pub p: OMatrix<T, D, D>,
    /// Forgetting factor in (0, 1].
    pub forgetting: f64,
    /// Bound on every `|P_ii|` when `forgetting < 1` (anti-windup); default `p0`.
    pub max_variance: f64,
    /// Largest normalised innovation `|e| / sqrt(1 / w + |phi|_1 |P z|_inf)` accepted;
    /// infinity (default) = no outlier gate.
    pub outlier_gate: f64,
    /// Rows processed.
    pub count: u64,
    pz: OVector<T, D>,
    ptphi: OVector<T, D>,
}

impl<D: Dim, T: RealScalar> Riv<D, T>
where
    DefaultAllocator: Allocator<D, D> + Allocator<D>,
{
    /// Starts from `theta0` with `P = p0 * I`; no forgetting, `max_variance = p0`, no gate.
    pub fn new(theta0: OVector<T, D>, p0: f64) -> Self {
        let (dim, _) = theta0.shape_generic();
        let mut p = OMatrix::from_element_generic(dim, dim, T::zero());
        for i in 0..p.nrows() {
            p[(i, i)] = T::from_f64(p0);
        }
        Self {
            p,
            pz: OVector::from_element_generic(dim, nalgebra::Const::<1>, T::zero()),
            ptphi: OVector::from_element_generic(dim, nalgebra::Const::<1>, T::zero()),
            theta: theta0,
            forgetting: 1.0,
            max_variance: p0,
            outlier_gate: f64::INFINITY,
            count: 0,
        }
    }

    /// One scalar row with instrument `z` and weight `w > 0`; errors (as [`super::Rls`]'s)
    /// leave the state untouched.
    pub fn update(&mut self, phi: &OVector<T, D>, z: &OVector<T, D>, y: T, w: f64) -> Result<(), Error> {
        self.update_on(phi, z, None, y, w)
    }

    /// [`Self::update`] for rows known to be zero outside `support` (both `phi` and `z`;
    /// entries outside it are not read): the products with those zeros are skipped, which is
    /// all the difference (the terminal-link rows, where a joint's row does not see the
    /// links inside it).
    pub fn update_sparse(
        &mut self,
        phi: &OVector<T, D>,
        z: &OVector<T, D>,
        support: &OVector<bool, D>,
        y: T,
        w: f64,
    ) -> Result<(), Error> {
        self.update_on(phi, z, Some(support), y, w)
    }

    fn update_on(
        &mut self,
        phi: &OVector<T, D>,
        z: &OVector<T, D>,
        support: Option<&OVector<bool, D>>,
        y: T,
        w: f64,
    ) -> Result<(), Error> {
        guard::check_inputs("phi", phi, y, w)?;
        guard::check_inputs("z", z, y, w)?;
        let on = |j: usize| support.is_none_or(|s| s[j]);
        let (n, lambda) = (self.theta.len(), self.forgetting);
        // pz = P z, ptphi = P^T phi, over the support only
        let mut first = true;
        for j in (0..n).filter(|&j| on(j)) {
            let (zj, phij) = (z[j], phi[j]);
            for i in 0..n {
                let (a, b) = (self.p[(i, j)] * zj, self.p[(j, i)] * phij);
                if first {
                    self.pz[i] = a;
                    self.ptphi[i] = b;
                } else {
                    self.pz[i] += a;
                    self.ptphi[i] += b;
                }
            }
            first = false;
        }
        if first {
            self.pz.fill(T::zero());
            self.ptphi.fill(T::zero());
        }
        let w_t = T::from_f64(w);
        let r = T::from_f64(lambda / w);
        // s = phi . P z, |phi|_1 and phi . theta together
        let (mut s, mut phi1, mut pred) = (Sum::new(), Sum::new(), Sum::new());
        for j in (0..n).filter(|&j| on(j)) {
            s.add(phi[j] * self.pz[j]);
            phi1.add(phi[j].abs());
            pred.add(phi[j] * self.theta[j]);
        }
        let (s, phi1, pred) = (s.get(), phi1.get(), pred.get());
        let den = r + s;
        // scale of the terms by Hölder: |phi^T P z| <= |phi|_1 |P z|_inf (a NaN or an
        // infinity, once met, stays: the row is then refused below)
        let mut pz_inf = T::zero();
        for i in 0..n {
            let a = self.pz[i].abs();
            if !(a <= pz_inf) && pz_inf.is_finite() {
                pz_inf = a;
            }
        }
        let s_scale = phi1 * pz_inf;
        if !(w_t * s_scale).is_finite() {
            return Err(Error::RowOutOfRange { ratio: (w_t * s_scale).to_f64() });
        }
        if !(lambda > 0.0 && lambda <= 1.0 && den.is_finite()) || den.abs() <= T::from_f64(1e-12) * (r.abs() + s_scale)
        {
            return Err(Error::DegenerateUpdate);
        }
        let innovation = y - pred;
        guard::check_row(w, w_t, s_scale, innovation, self.outlier_gate)?;
        // gain k = P z / den (in pz); theta += k e; P <- (P - k ptphi^T) / lambda
        let inv_den = T::one() / den;
        for i in 0..n {
            self.pz[i] *= inv_den;
            self.theta[i] += self.pz[i] * innovation;
        }
        for j in 0..n {
            let tj = self.ptphi[j];
            for i in 0..n {
                self.p[(i, j)] -= self.pz[i] * tj;
            }
        }
        if lambda < 1.0 {
            let inv = T::from_f64(1.0 / lambda);
            for v in self.p.iter_mut() {
                *v *= inv;
            }
            self.cap_diagonal();
        }
        self.count += 1;
        Ok(())
    }

    /// Anti-windup: `P <- S P S`, `S = diag(min(1, sqrt(max_variance / |P_ii|)))`.
    fn cap_diagonal(&mut self) {
        let (n, cap) = (self.p.nrows(), T::from_f64(self.max_variance));
        if (0..n).all(|i| !(self.p[(i, i)].abs() > cap)) {
            return;
        }
        // S in the free scratch vector
        for i in 0..n {
            let si = (cap / self.p[(i, i)].abs()).sqrt();
            self.ptphi[i] = if si < T::one() { si } else { T::one() };
        }
        for j in 0..n {
            for i in 0..n {
                let sij = self.ptphi[i] * self.ptphi[j];
                self.p[(i, j)] *= sij;
            }
        }
    }
}

impl<D: Dim> Riv<D, f64>
where
    DefaultAllocator: Allocator<D, D> + Allocator<D>,
{
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
}

//! SVD and symmetric eigen-decomposition with an iteration limit; the damped step of
//! Levenberg-Marquardt.
//!
//! nalgebra's `svd()` and `symmetric_eigen()` iterate until convergence with no limit;
//! on a matrix holding an infinite or NaN entry (a log value of 1e300 squared) they never
//! converge and the job hangs. Every decomposition in the library goes through these
//! wrappers instead, which give up after [`MAX_ITER`] sweeps with an error naming what was
//! being decomposed.

use nalgebra::allocator::Allocator;
use nalgebra::{
    DMatrix, DVector, DefaultAllocator, Dim, DimDiff, DimMin, DimSub, Dyn, OMatrix, SVD, SymmetricEigen, U1,
};

use crate::error::{Error, Result};

/// Iterations allowed. A finite matrix converges in a few sweeps per dimension (tens to
/// hundreds for the sizes here); this is orders of magnitude above that.
pub const MAX_ITER: usize = 100_000;

fn not_converged(what: &str) -> Error {
    Error::Numerical {
        what: what.into(),
        msg: format!("the decomposition did not converge in {MAX_ITER} iterations (non-finite or huge values?)"),
    }
}

/// Thin SVD of `m`; `what` names the matrix in the error.
pub fn svd(m: DMatrix<f64>, u: bool, v: bool, what: &str) -> Result<SVD<f64, Dyn, Dyn>> {
    if m.iter().any(|x| !x.is_finite()) {
        return Err(Error::Numerical { what: what.into(), msg: "the matrix has non-finite entries".into() });
    }
    SVD::try_new(m, u, v, f64::EPSILON, MAX_ITER).ok_or_else(|| not_converged(what))
}

/// Eigen-decomposition of the symmetric `m`; `what` names the matrix in the error.
pub fn sym_eigen<D>(m: OMatrix<f64, D, D>, what: &str) -> Result<SymmetricEigen<f64, D>>
where
    D: Dim + DimSub<U1> + DimMin<D>,
    DefaultAllocator: Allocator<D, D> + Allocator<DimDiff<D, U1>> + Allocator<D>,
{
    if m.iter().any(|x| !x.is_finite()) {
        return Err(Error::Numerical { what: what.into(), msg: "the matrix has non-finite entries".into() });
    }
    SymmetricEigen::try_new(m, f64::EPSILON, MAX_ITER).ok_or_else(|| not_converged(what))
}

/// One Levenberg-Marquardt step with Marquardt's diagonal scaling: solves
/// `(J^T J + mu diag(J^T J)) dx = -J^T r` with growing damping (x10 when the matrix is not
/// positive definite, x4 when `eval` does not lower `cost`; up to 30 tries) and returns the
/// first `x + dx` that lowers `cost`, with what `eval` made of it (then `mu` shrinks by 3, to
/// at least 1e-12). `eval(x)` gives the residual (or whatever the caller keeps) and its cost.
/// `None`: no damping lowers the cost, a (local) minimum to rounding.
pub fn marquardt_step<T>(
    x: &[f64],
    jtj: &DMatrix<f64>,
    jtr: &DVector<f64>,
    mu: &mut f64,
    cost: f64,
    eval: impl Fn(&[f64]) -> (T, f64),
) -> Option<(Vec<f64>, T, f64)> {
    // a zero diagonal entry (a variable the cost does not see) still gets some damping
    let floor = 1e-12 * jtj.diagonal().max();
    for _ in 0..30 {
        let mut m = jtj.clone();
        for k in 0..x.len() {
            m[(k, k)] += *mu * jtj[(k, k)].max(floor);
        }
        let Some(ch) = m.cholesky() else {
            *mu *= 10.0;
            continue;
        };
        let dx = ch.solve(&(-jtr));
        let xn: Vec<f64> = x.iter().zip(dx.iter()).map(|(a, d)| a + d).collect();
        let (t, cn) = eval(&xn);
        if cn.is_finite() && cn < cost {
            *mu = (*mu / 3.0).max(1e-12);
            return Some((xn, t, cn));
        }
        *mu *= 4.0;
    }
    None
}

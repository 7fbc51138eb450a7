//! SVD and symmetric eigen-decomposition with an iteration limit.
//!
//! nalgebra's `svd()` and `symmetric_eigen()` iterate until convergence with no limit;
//! on a matrix holding an infinite or NaN entry (a log value of 1e300 squared) they never
//! converge and the job hangs. Every decomposition in the library goes through these
//! wrappers instead, which give up after [`MAX_ITER`] sweeps with an error naming what was
//! being decomposed.

use nalgebra::allocator::Allocator;
use nalgebra::{DMatrix, DefaultAllocator, Dim, DimDiff, DimMin, DimSub, Dyn, OMatrix, SVD, SymmetricEigen, U1};

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

//! Forward dynamics: `qdd` from `tau` by CRBA + Cholesky.

use crate::data::Data;
use crate::error::Error;
use crate::model::Model;
use crate::types::VecN;
use crate::{crba, rnea};
#[allow(unused_imports)] // needed without std (libm-backed sqrt), unused when std is unified in
use nalgebra::ComplexField;

/// Joint accelerations for torques `tau`: solves `M(q) qdd = tau - rnea(q, qd, 0)`, where
/// `M` includes the armature and `rnea(q, qd, 0)` the Coulomb, viscous and offset terms
/// (treated as known torques at this `qd`). Returns `&data.qdd`.
pub fn forward_dynamics<'d, const N: usize>(
    model: &Model<N>,
    data: &'d mut Data<N>,
    q: &VecN<N>,
    qd: &VecN<N>,
    tau: &VecN<N>,
) -> Result<&'d VecN<N>, Error> {
    let zero = VecN::<N>::zeros();
    let bias = *rnea::rnea(model, data, q, qd, &zero);
    // the RNEA left the joint placements at q in data.kin: no second kinematic pass
    crba::mass_matrix_at_transforms(model, data);
    let mut x = tau - bias;
    cholesky_solve(&data.m, &mut data.l, &mut x)?;
    data.qdd = x;
    Ok(&data.qdd)
}

/// Solves `a x = b` in place for symmetric positive definite `a`; `l` receives the
/// lower Cholesky factor. Fails with the failing pivot's index.
pub fn cholesky_solve<const N: usize>(
    a: &crate::types::MatN<N>,
    l: &mut crate::types::MatN<N>,
    b: &mut VecN<N>,
) -> Result<(), Error> {
    for j in 0..N {
        let mut d = a[(j, j)];
        for k in 0..j {
            d -= l[(j, k)] * l[(j, k)];
        }
        if !(d > 0.0) {
            return Err(Error::MassMatrixNotPositiveDefinite { joint: j });
        }
        let d = d.sqrt();
        l[(j, j)] = d;
        for i in j + 1..N {
            let mut s = a[(i, j)];
            for k in 0..j {
                s -= l[(i, k)] * l[(j, k)];
            }
            l[(i, j)] = s / d;
        }
    }
    // L y = b
    for i in 0..N {
        let mut s = b[i];
        for k in 0..i {
            s -= l[(i, k)] * b[k];
        }
        b[i] = s / l[(i, i)];
    }
    // L^T x = y
    for i in (0..N).rev() {
        let mut s = b[i];
        for k in i + 1..N {
            s -= l[(k, i)] * b[k];
        }
        b[i] = s / l[(i, i)];
    }
    Ok(())
}

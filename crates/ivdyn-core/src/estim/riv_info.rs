//! Recursive instrumental variables in information form: the paper's eq (32) as
//! `theta = R^-1 r`, `R = R0 + sum w z phi^T`, `r = R0 theta0 + sum w z y` (`R0 = I / p0`),
//! with `R` held as its LU factors and updated row by row.
//!
//! # Math note
//! A row adds `x y^T` to `R = L U` (`x = w z`, `y = phi`; `L` unit lower, `U` upper
//! triangular). With the first index split off (`u11`, row `u` of `U`, column `l` of `L`):
//!
//! `u11' = u11 + x1 y1,  u' = u + x1 y2,  x~ = x2 - x1 l,  l' = l + (y1 / u11') x~,`
//! `y~ = y2 - (y1 / u11') u'`,
//!
//! and the trailing block is `L2 U2 + x~ y~^T`: the same update one size smaller
//! [J. M. Bennett, "Triangular factors of modified matrices", Numer. Math. 7, 1965]. Step
//! `j` reads only the old row `j` of `U` and column `j` of `L`, and changes nothing while
//! `x_j = y_j = 0`: a row whose first `f` entries are structurally zero starts at `f`. A row
//! costs `2 (D - f)^2` products, the estimate two triangular solves (`D^2`).
//!
//! Why a second IV recursion beside [`super::Riv`]: the covariance form spends `3 D^2`
//! products per row (`P z`, `P^T phi`, the rank-one update of `P`), and `P`, not symmetric,
//! is dense whatever the rows' sparsity. Here the rank-one updates are cheaper than the
//! covariance form's and a sample of several rows pays for one estimate: on the paper's
//! terminal-link problem (`D = 18`, rows of joints 5 and 6, row 6 blind to the first 8
//! columns) the estimator spends 1280 products (46 of them divisions) against 1680, which
//! brings the whole update within the paper's count (`tests/op_count.rs`). Fewer
//! operations are not less time on a desktop core: its steps are short dependent loops,
//! and the instructions per update are about the covariance form's (`benches/README.md`).
//!
//! No pivoting: `z` is the regressor at instrumental accelerations, near `phi`, so `R`
//! stays near the positive definite `R0 + sum w phi phi^T`, whose leading minors are
//! positive. A row is refused, with the state untouched ([`Error::DegenerateUpdate`]),
//! when a pivot collapses, `|u_jj'| <= 1e-12 (|u_jj| + |x_j y_j|)` (the instrument
//! uncorrelated with the regressor in that direction: the covariance form's vanishing
//! denominator), and ([`Error::RowOutOfRange`]) when a term dwarfs what is held,
//! `|x_j y_j| > |u_jj| / eps^2` (the information ratio of [`super::guard`]), or any result
//! is not finite.
//!
//! What it does not do: forgetting, the anti-windup cap and the outlier gate need `P`'s
//! diagonal or `phi^T P z`, which this form does not hold: [`super::Riv`] has them.

use super::guard::{self, MAX_INFORMATION_RATIO};
use crate::error::Error;
use crate::scalar::RealScalar;
use nalgebra::allocator::Allocator;
use nalgebra::{DefaultAllocator, Dim, OMatrix, OVector};

/// Recursive IV in information form (see the module docs). `T` is the scalar
/// ([`RealScalar`]: `f64` by default).
#[derive(Debug, Clone)]
pub struct RivInfo<D: Dim, T: RealScalar = f64>
where
    DefaultAllocator: Allocator<D, D> + Allocator<D>,
{
    /// The estimate after the last [`Self::estimate`] (or [`Self::update`]).
    pub theta: OVector<T, D>,
    /// Rows added.
    pub count: u64,
    /// `L` of `R = L U`, strictly below the diagonal (unit diagonal implied).
    l: OMatrix<T, D, D>,
    /// `U^T` on and below the diagonal (column-major: column `j` is row `j` of `U`, contiguous).
    ut: OMatrix<T, D, D>,
    /// `r = R0 theta0 + sum w z y`.
    rhs: OVector<T, D>,
    /// `L`, `U^T` before the row being added (a refused row is undone from them).
    saved: (OMatrix<T, D, D>, OMatrix<T, D, D>),
    x: OVector<T, D>,
    y: OVector<T, D>,
}

impl<D: Dim, T: RealScalar> RivInfo<D, T>
where
    DefaultAllocator: Allocator<D, D> + Allocator<D>,
{
    /// Starts from `theta0` with the prior `R0 = I / p0` (the covariance form's `P = p0 I`).
    pub fn new(theta0: OVector<T, D>, p0: f64) -> Self {
        let (dim, u1) = theta0.shape_generic();
        let r0 = T::from_f64(1.0 / p0);
        let l = OMatrix::from_element_generic(dim, dim, T::zero());
        let mut ut = l.clone();
        ut.fill_diagonal(r0);
        let rhs = theta0.map(|t| t * r0);
        Self {
            saved: (l.clone(), ut.clone()),
            l,
            ut,
            rhs,
            x: OVector::from_element_generic(dim, u1, T::zero()),
            y: OVector::from_element_generic(dim, u1, T::zero()),
            theta: theta0,
            count: 0,
        }
    }

    /// Adds one scalar row (regressor `phi`, instrument `z`, output `y`, weight `w > 0`)
    /// and re-estimates `theta`.
    pub fn update(&mut self, phi: &OVector<T, D>, z: &OVector<T, D>, y: T, w: f64) -> Result<(), Error> {
        self.add_row_on(phi, z, None, y, w)?;
        self.estimate()
    }

    /// Adds one row zero outside `support` (both `phi` and `z`; entries outside it are
    /// not read) without re-estimating: call [`Self::estimate`] after the sample's rows.
    /// Errors leave the state untouched.
    pub fn add_row_sparse(
        &mut self,
        phi: &OVector<T, D>,
        z: &OVector<T, D>,
        support: &OVector<bool, D>,
        y: T,
        w: f64,
    ) -> Result<(), Error> {
        self.add_row_on(phi, z, Some(support), y, w)
    }

    fn add_row_on(
        &mut self,
        phi: &OVector<T, D>,
        z: &OVector<T, D>,
        support: Option<&OVector<bool, D>>,
        y: T,
        w: f64,
    ) -> Result<(), Error> {
        guard::check_inputs("phi", phi, y, w)?;
        guard::check_inputs("z", z, y, w)?;
        let n = self.theta.len();
        let on = |j: usize| support.is_none_or(|s| s[j]);
        let Some(f) = (0..n).find(|&j| on(j)) else {
            self.count += 1; // an empty row adds nothing
            return Ok(());
        };
        let w_t = T::from_f64(w);
        for j in f..n {
            let o = on(j);
            self.x[j] = if o { w_t * z[j] } else { T::zero() };
            self.y[j] = if o { phi[j] } else { T::zero() };
        }
        // the update changes columns f.. of L and U^T only
        let k = f * n;
        self.saved.0.as_mut_slice()[k..].copy_from_slice(&self.l.as_slice()[k..]);
        self.saved.1.as_mut_slice()[k..].copy_from_slice(&self.ut.as_slice()[k..]);
        if let Err(e) = self.bennett(f) {
            self.l.as_mut_slice()[k..].copy_from_slice(&self.saved.0.as_slice()[k..]);
            self.ut.as_mut_slice()[k..].copy_from_slice(&self.saved.1.as_slice()[k..]);
            return Err(e);
        }
        // r += (w y) z over the support
        let wy = w_t * y;
        for j in (f..n).filter(|&j| on(j)) {
            self.rhs[j] += z[j] * wy;
        }
        self.count += 1;
        Ok(())
    }

    /// Bennett's update of `L U` by `x y^T` from step `f` on (module docs); `x`, `y` are
    /// consumed. Column `j` of `L` and row `j` of `U` (column `j` of `U^T`) are contiguous:
    /// the step is four contiguous streams.
    fn bennett(&mut self, f: usize) -> Result<(), Error> {
        let n = self.theta.len();
        let (eps_rel, max_ratio) = (T::from_f64(1e-12), T::from_f64(MAX_INFORMATION_RATIO));
        let (l, ut) = (self.l.as_mut_slice(), self.ut.as_mut_slice());
        let (x, y) = (self.x.as_mut_slice(), self.y.as_mut_slice());
        let mut finite = true;
        for j in f..n {
            let (xj, yj, ujj) = (x[j], y[j], ut[j * n + j]);
            let xy = xj * yj;
            let pivot = ujj + xy;
            if !(xy.abs() <= max_ratio * ujj.abs()) {
                return Err(Error::RowOutOfRange { ratio: (xy / ujj).abs().to_f64() });
            }
            if !pivot.is_finite() || pivot.abs() <= eps_rel * (ujj.abs() + xy.abs()) {
                return Err(Error::DegenerateUpdate);
            }
            ut[j * n + j] = pivot;
            let c = yj / pivot;
            let below = j * n + j + 1..(j + 1) * n;
            let (l_col, u_row) = (&mut l[below.clone()], &mut ut[below]);
            for (((li, ui), xi), yi) in l_col.iter_mut().zip(u_row).zip(&mut x[j + 1..]).zip(&mut y[j + 1..]) {
                // u' = u + x1 y2; y~ = y2 - c u'
                *ui += xj * *yi;
                *yi -= c * *ui;
                // x~ = x2 - x1 l; l' = l + c x~
                *xi -= xj * *li;
                *li += c * *xi;
                finite &= li.is_finite();
            }
        }
        // an entry of L that overflowed (one of U, or of x or y, makes a later pivot
        // non-finite, which the tests above refuse)
        if finite { Ok(()) } else { Err(Error::RowOutOfRange { ratio: f64::INFINITY }) }
    }

    /// `theta = R^-1 r` by the two triangular solves.
    pub fn estimate(&mut self) -> Result<(), Error> {
        let n = self.theta.len();
        let (l, ut) = (self.l.as_slice(), self.ut.as_slice());
        // L w = r (w in y)
        self.y.copy_from(&self.rhs);
        let w = self.y.as_mut_slice();
        for j in 0..n {
            let wj = w[j];
            for (wi, lij) in w[j + 1..].iter_mut().zip(&l[j * n + j + 1..(j + 1) * n]) {
                *wi -= *lij * wj;
            }
        }
        // U theta = w, in place in y, row by row (row i of U is column i of U^T,
        // contiguous); a non-finite result leaves theta as it was
        for i in (0..n).rev() {
            let (head, tail) = w.split_at_mut(i + 1);
            let mut acc = head[i];
            for (uij, tj) in ut[i * n + i + 1..(i + 1) * n].iter().zip(tail.iter()) {
                acc -= *uij * *tj;
            }
            head[i] = acc / ut[i * n + i];
        }
        if let Some(index) = self.y.iter().position(|v| !v.is_finite()) {
            return Err(Error::NonFinite { what: "IV estimate", index });
        }
        self.theta.copy_from(&self.y);
        Ok(())
    }

    /// `P = R^-1` (the IV covariance's core, as [`super::Riv::p`]): `D` solves, for reports,
    /// not for every sample.
    pub fn p(&self) -> OMatrix<T, D, D> {
        let mut s = self.clone();
        let mut p = self.l.clone();
        let n = self.theta.len();
        for c in 0..n {
            s.rhs.fill(T::zero());
            s.rhs[c] = T::one();
            let ok = s.estimate().is_ok();
            for i in 0..n {
                p[(i, c)] = if ok { s.y[i] } else { T::from_f64(f64::NAN) };
            }
        }
        p
    }
}

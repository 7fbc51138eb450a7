//! Streaming sufficient statistics for least squares and instrumental variables.
//!
//! Memory does not depend on the number of rows, and two accumulators built on disjoint
//! chunks of the same log [`merge`](LsAccumulator::merge) into exactly the statistics of
//! the whole log (up to rounding): split a huge log over workers, then merge.
//!
//! # Least squares: the triangular factor of the augmented, weighted data
//! With `W = diag(w)` (inverse variances), the weighted data `A = [√W Φ | √W y]`
//! (`m x (p+1)`) has the QR factorisation `A = Q R_aug`,
//!
//! ```text
//! R_aug = [ R   Q₁ᵀ√W y ]      (R: p x p upper triangular)
//!         [ 0   ±√rss   ]
//! ```
//!
//! so `θ_LS = R⁻¹ (Q₁ᵀ √W y)` by back substitution, `ΦᵀWΦ = RᵀR` and
//! `rss = min ‖√W (y - Φθ)‖² = R_aug[p,p]²`. Because `AᵀA = R_augᵀ R_aug`, stacking
//! `[R_aug; new rows]` and re-triangularising (Householder) gives the factor of the longer
//! data set: this is both the streaming update and the merge. Incoming rows are buffered
//! (up to `4 (p+1)` rows) and absorbed in blocks.

use crate::error::{Error, Result};
use nalgebra::{DMatrix, DVector};

/// Rows absorbed per block: at least this many (or `4 (p + 1)`), so that the O(p^2) work on
/// the rows of `R` per block is amortised over many data rows.
const MIN_BLOCK_ROWS: usize = 512;
/// Rows buffered per parameter column before a re-triangularisation.
const BUFFER_FACTOR: usize = 4;

/// Absorbs the `k` rows of `b` (row-major, `k x n`) into the upper-triangular `r`
/// (`n x n`) by Householder reflections: afterwards `r_newᵀ r_new = rᵀ r + bᵀ b`.
/// `b` is consumed (overwritten).
pub(crate) fn absorb_rows(r: &mut DMatrix<f64>, b: &mut [f64], k: usize) {
    let n = r.ncols();
    debug_assert_eq!(b.len(), k * n);
    // column-major copy: every inner loop below runs over one contiguous column
    let mut bc = vec![0.0; k * n];
    for i in 0..k {
        for j in 0..n {
            bc[j * k + i] = b[i * n + j];
        }
    }
    absorb_cols(r, &mut bc, k);
}

/// [`absorb_rows`] on a column-major block `bc` (`k x n`, column `j` at `bc[j k..(j+1) k]`).
///
/// Column `j`'s reflection acts on `r[j, j]` and `b[.., j]` only (the rest of column `j` of
/// `r` is already zero), so the cost is `2 k n^2` flops, in dot products and axpys over
/// contiguous columns (which the compiler vectorises).
pub(crate) fn absorb_cols(r: &mut DMatrix<f64>, bc: &mut [f64], k: usize) {
    #[cfg(target_arch = "x86_64")]
    if std::is_x86_feature_detected!("avx2") && std::is_x86_feature_detected!("fma") {
        // SAFETY: the CPU supports AVX2 and FMA, checked just above; the function is the
        // same safe code compiled with those features enabled.
        unsafe { absorb_cols_avx2(r, bc, k) };
        return;
    }
    absorb_cols_generic(r, bc, k)
}

/// [`absorb_cols_generic`] compiled for AVX2 + FMA (4-wide f64 lanes, fused multiply-add),
/// selected at run time: the default x86-64 target only has SSE2.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,fma")]
unsafe fn absorb_cols_avx2(r: &mut DMatrix<f64>, bc: &mut [f64], k: usize) {
    absorb_cols_generic(r, bc, k)
}

#[inline(always)]
fn absorb_cols_generic(r: &mut DMatrix<f64>, bc: &mut [f64], k: usize) {
    let n = r.ncols();
    for j in 0..n {
        let (head, tail) = bc.split_at_mut((j + 1) * k);
        let x = &mut head[j * k..];
        let alpha = r[(j, j)];
        let sigma = dot(x, x);
        if sigma == 0.0 {
            continue;
        }
        // H = I - tau v vᵀ, v = [1; x / (alpha - beta)], maps (alpha, x) to (beta, 0).
        let norm = alpha.hypot(sigma.sqrt());
        let beta = if alpha >= 0.0 { -norm } else { norm };
        let tau = (beta - alpha) / beta;
        let scale = 1.0 / (alpha - beta);
        x.iter_mut().for_each(|v| *v *= scale);
        r[(j, j)] = beta;
        for (c, col) in tail.chunks_exact_mut(k).enumerate() {
            let c = j + 1 + c;
            let s = tau * (r[(j, c)] + dot(x, col));
            r[(j, c)] -= s;
            for (b, v) in col.iter_mut().zip(x.iter()) {
                *b -= s * v;
            }
        }
    }
}

/// Dot product with eight independent partial sums (two SIMD registers of four lanes, so
/// the additions do not wait on each other).
#[inline(always)]
fn dot(a: &[f64], b: &[f64]) -> f64 {
    let mut acc = [0.0f64; 8];
    let (ca, cb) = (a.chunks_exact(8), b.chunks_exact(8));
    let (ra, rb) = (ca.remainder(), cb.remainder());
    for (x, y) in ca.zip(cb) {
        for l in 0..8 {
            acc[l] += x[l] * y[l];
        }
    }
    let mut s = ((acc[0] + acc[4]) + (acc[1] + acc[5])) + ((acc[2] + acc[6]) + (acc[3] + acc[7]));
    for (x, y) in ra.iter().zip(rb) {
        s += x * y;
    }
    s
}

/// Upper-triangular factor of a general matrix `a` (`rows x n`): `Rᵀ R = aᵀ a`.
pub(crate) fn triangular_factor(a: &DMatrix<f64>) -> DMatrix<f64> {
    let n = a.ncols();
    let mut r = DMatrix::zeros(n, n);
    let mut b: Vec<f64> = Vec::with_capacity(a.len());
    for i in 0..a.nrows() {
        b.extend(a.row(i).iter());
    }
    absorb_rows(&mut r, &mut b, a.nrows());
    r
}

/// Checks lengths (`phi`: `m x p` row-major, `y`, `w`: `m`) and finiteness of one block;
/// weights must be finite and `>= 0` (a negative weight is reported as
/// `NonFinite { what: "w" }`: its square root is not a real number).
fn check_block(p: usize, phi: &[f64], y: &[f64], w: Option<&[f64]>) -> Result<()> {
    let m = y.len();
    if phi.len() != m * p {
        return Err(Error::Dimension { what: "phi (rows x p, row-major)".into(), expected: m * p, got: phi.len() });
    }
    if let Some(w) = w
        && w.len() != m
    {
        return Err(Error::Dimension { what: "w".into(), expected: m, got: w.len() });
    }
    for i in 0..m {
        check_row(p, "phi", phi, i)?;
        if !y[i].is_finite() {
            return Err(non_finite("y", i));
        }
        if let Some(w) = w
            && !(w[i].is_finite() && w[i] >= 0.0)
        {
            return Err(non_finite("w", i));
        }
    }
    Ok(())
}

/// Error if row `i` of the row-major `x` (width `p`) has a NaN or infinity.
fn check_row(p: usize, what: &'static str, x: &[f64], i: usize) -> Result<()> {
    if x[i * p..(i + 1) * p].iter().any(|v| !v.is_finite()) {
        return Err(non_finite(what, i));
    }
    Ok(())
}

/// Rows per absorbed block for `p` parameters.
fn block_rows(p: usize) -> usize {
    (BUFFER_FACTOR * (p + 1)).max(MIN_BLOCK_ROWS)
}

fn non_finite(what: &'static str, index: usize) -> Error {
    Error::Core(ivdyn_core::Error::NonFinite { what, index })
}

fn mismatch(what: &str, expected: usize, got: usize) -> Error {
    Error::Dimension { what: what.into(), expected, got }
}

/// Streaming weighted least-squares statistics: the triangular factor `R_aug` of
/// `[√W Φ | √W y]` (see the module docs), the row count and `Σ w y²`.
#[derive(Debug, Clone, PartialEq)]
pub struct LsAccumulator {
    p: usize,
    /// `(p+1) x (p+1)` upper triangular (excluding the buffered rows).
    r: DMatrix<f64>,
    /// Pending weighted rows `[√w φᵀ, √w y]`, row-major, width `p + 1`.
    buf: Vec<f64>,
    rows: usize,
    sum_wyy: f64,
}

impl LsAccumulator {
    /// Empty statistics for `p` parameters.
    pub fn new(p: usize) -> Self {
        LsAccumulator {
            p,
            r: DMatrix::zeros(p + 1, p + 1),
            buf: Vec::with_capacity(block_rows(p) * (p + 1)),
            rows: 0,
            sum_wyy: 0.0,
        }
    }

    /// Statistics rebuilt from an upper-triangular factor `r_aug` (`(p+1) x (p+1)`, e.g.
    /// [`r_aug`](Self::r_aug) of another accumulator), its row count and `Σ w y²`.
    pub fn from_r_aug(r_aug: DMatrix<f64>, rows: usize, sum_wyy: f64) -> Result<Self> {
        let n = r_aug.nrows();
        if n == 0 || r_aug.ncols() != n {
            return Err(mismatch("LsAccumulator::from_r_aug: columns of the square R_aug", n, r_aug.ncols()));
        }
        if let Some(i) = r_aug.iter().position(|v| !v.is_finite()) {
            return Err(non_finite("r_aug", i));
        }
        if !sum_wyy.is_finite() {
            return Err(non_finite("sum_wyy", 0));
        }
        if (0..n).any(|i| (0..i).any(|j| r_aug[(i, j)] != 0.0)) {
            return Err(Error::Stats {
                what: "LsAccumulator::from_r_aug".into(),
                msg: "R_aug is not upper triangular".into(),
            });
        }
        let mut acc = LsAccumulator::new(n - 1);
        acc.r = r_aug;
        acc.rows = rows;
        acc.sum_wyy = sum_wyy;
        Ok(acc)
    }

    /// Number of parameters `p`.
    pub fn p(&self) -> usize {
        self.p
    }

    /// Number of rows added with a positive weight (rows of weight 0 carry no
    /// information and do not count towards the degrees of freedom).
    pub fn rows(&self) -> usize {
        self.rows
    }

    /// `Σ w y²` (`yᵀ W y`).
    pub fn sum_wyy(&self) -> f64 {
        self.sum_wyy
    }

    /// Adds `m = y.len()` rows: `phi` is `m x p` row-major, `w` optional weights
    /// (inverse variances, default 1). Every row `[φᵀ, y]` is scaled by `√w`. All input is
    /// checked before anything is added: on error the accumulator is unchanged, and the
    /// error names the argument and row index.
    pub fn add_rows(&mut self, phi: &[f64], y: &[f64], w: Option<&[f64]>) -> Result<()> {
        check_block(self.p, phi, y, w)?;
        let p = self.p;
        for i in 0..y.len() {
            let wi = w.map_or(1.0, |w| w[i]);
            self.push_weighted(&phi[i * p..(i + 1) * p], y[i], wi);
        }
        Ok(())
    }

    /// Adds one checked row with weight `w`.
    fn push_weighted(&mut self, phi: &[f64], y: f64, w: f64) {
        if w == 0.0 {
            return;
        }
        let s = w.sqrt();
        self.buf.extend(phi.iter().map(|v| s * v));
        self.buf.push(s * y);
        self.rows += 1;
        self.sum_wyy += w * y * y;
        self.flush_if_full();
    }

    /// Adds raw rows of width `p + 1` (already weighted) to the buffer.
    fn push_raw(&mut self, rows: &[f64]) {
        let n = self.p + 1;
        for row in rows.chunks_exact(n) {
            self.buf.extend_from_slice(row);
            self.flush_if_full();
        }
    }

    fn flush_if_full(&mut self) {
        if self.buf.len() >= block_rows(self.p) * (self.p + 1) {
            self.finish();
        }
    }

    /// Absorbs the buffered rows into `R_aug` (idempotent; accessors that need the
    /// factor work on a flushed copy, so calling this is only an optimisation).
    pub fn finish(&mut self) {
        let k = self.buf.len() / (self.p + 1);
        if k > 0 {
            absorb_rows(&mut self.r, &mut self.buf, k);
            self.buf.clear();
        }
    }

    /// Merges the statistics of `other` (rows from another chunk of data): afterwards
    /// `self` describes the union of both row sets. Errors if the `p` differ.
    pub fn merge(&mut self, other: &LsAccumulator) -> Result<()> {
        if other.p != self.p {
            return Err(mismatch("LsAccumulator::merge: p of the other accumulator", self.p, other.p));
        }
        // [R_self; R_other; buffered rows of other] has the same Gram matrix as all rows.
        let n = self.p + 1;
        let mut rows = Vec::with_capacity(n * n);
        for i in 0..n {
            rows.extend(other.r.row(i).iter());
        }
        self.push_raw(&rows);
        self.push_raw(&other.buf);
        self.rows += other.rows;
        self.sum_wyy += other.sum_wyy;
        Ok(())
    }

    /// The statistics of the same rows with every weight multiplied by `c > 0`
    /// (`R_aug` scaled by `√c`, `Σ w y²` by `c`; the row count is unchanged). Per-joint
    /// accumulators combined this way give a weighted fit whose weights are chosen after
    /// the data has been seen (two-step WLS in one pass over the data).
    pub fn scaled(&self, c: f64) -> Result<LsAccumulator> {
        if !(c.is_finite() && c > 0.0) {
            return Err(non_finite("scale", 0));
        }
        let s = c.sqrt();
        let mut out = self.clone();
        out.r *= s;
        out.buf.iter_mut().for_each(|v| *v *= s);
        out.sum_wyy *= c;
        Ok(out)
    }

    /// The `(p+1) x (p+1)` upper-triangular factor `R_aug` of `[√W Φ | √W y]`, including
    /// any buffered rows (signs of rows are arbitrary, as in any QR).
    pub fn r_aug(&self) -> DMatrix<f64> {
        let mut r = self.r.clone();
        let mut b = self.buf.clone();
        let k = b.len() / (self.p + 1);
        absorb_rows(&mut r, &mut b, k);
        r
    }

    /// The `p x p` factor `R` with `RᵀR = ΦᵀWΦ`.
    pub fn r(&self) -> DMatrix<f64> {
        self.r_aug().view((0, 0), (self.p, self.p)).into_owned()
    }

    /// `Q₁ᵀ √W y` (the last column of `R_aug` above the corner), so that
    /// `ΦᵀWy = Rᵀ (Q₁ᵀ √W y)`.
    pub fn qty(&self) -> DVector<f64> {
        self.r_aug().view((0, self.p), (self.p, 1)).column(0).into_owned()
    }

    /// Residual sum of squares of the full least-squares fit, `R_aug[p,p]²`.
    pub fn rss(&self) -> f64 {
        let r = self.r_aug();
        r[(self.p, self.p)].powi(2)
    }

    /// The least-squares solution `θ = R⁻¹ Q₁ᵀ√W y` by back substitution (all `p`
    /// columns; [`crate::ident::fit_ls`] handles rank deficiency). Errors with
    /// `Singular` if a diagonal entry of `R` is below `1e-13 max|R_ii|` (or zero).
    pub fn solve(&self) -> Result<Vec<f64>> {
        let ra = self.r_aug();
        let p = self.p;
        let rmax = (0..p).map(|i| ra[(i, i)].abs()).fold(0.0, f64::max);
        if p > 0 && (0..p).any(|i| !(ra[(i, i)].abs() > 1e-13 * rmax)) {
            return Err(Error::Core(ivdyn_core::Error::Singular));
        }
        let r = ra.view((0, 0), (p, p));
        let qty: Vec<f64> = (0..p).map(|i| ra[(i, p)]).collect();
        Ok(back_substitute(&r, &qty))
    }
}

/// Solves `R x = b` for upper-triangular `R` (`n x n`, non-zero diagonal) by back
/// substitution: `x_i = (b_i - Σ_{j>i} R_ij x_j) / R_ii`.
pub(crate) fn back_substitute<S>(r: &nalgebra::Matrix<f64, nalgebra::Dyn, nalgebra::Dyn, S>, b: &[f64]) -> Vec<f64>
where
    S: nalgebra::storage::Storage<f64, nalgebra::Dyn, nalgebra::Dyn>,
{
    let n = b.len();
    let mut x = vec![0.0; n];
    for i in (0..n).rev() {
        let mut s = b[i];
        for j in i + 1..n {
            s -= r[(i, j)] * x[j];
        }
        x[i] = s / r[(i, i)];
    }
    x
}

/// Streaming statistics for the (square) instrumental-variable estimate:
/// `ZᵀWΦ`, `ZᵀWy`, `ZᵀWZ` (plain sums, which merge by addition) plus an
/// [`LsAccumulator`] of `(Φ, y)` for the residuals, `Σ w y²` and the LS comparison.
/// `Z` has as many columns as `Φ` (one instrument per parameter).
#[derive(Debug, Clone, PartialEq)]
pub struct IvAccumulator {
    p: usize,
    ls: LsAccumulator,
    ztwphi: DMatrix<f64>,
    ztwy: DVector<f64>,
    ztwz: DMatrix<f64>,
}

impl IvAccumulator {
    /// Empty statistics for `p` parameters (and `p` instruments).
    pub fn new(p: usize) -> Self {
        IvAccumulator {
            p,
            ls: LsAccumulator::new(p),
            ztwphi: DMatrix::zeros(p, p),
            ztwy: DVector::zeros(p),
            ztwz: DMatrix::zeros(p, p),
        }
    }

    /// Number of parameters `p`.
    pub fn p(&self) -> usize {
        self.p
    }

    /// Rows added with a positive weight.
    pub fn rows(&self) -> usize {
        self.ls.rows()
    }

    /// Adds `m = y.len()` rows: `phi` and `z` are `m x p` row-major (regressor and
    /// instrument rows), `w` optional weights. Input is checked before anything is
    /// added (errors name `"phi"`, `"z"`, `"y"` or `"w"` and the row).
    pub fn add_rows(&mut self, phi: &[f64], z: &[f64], y: &[f64], w: Option<&[f64]>) -> Result<()> {
        let (m, p) = (y.len(), self.p);
        check_block(p, phi, y, w)?;
        if z.len() != m * p {
            return Err(mismatch("z (rows x p, row-major)", m * p, z.len()));
        }
        for i in 0..m {
            check_row(p, "z", z, i)?;
        }
        self.ls.add_rows(phi, y, w)?;
        // Block update with matrix products: Zw = W Z, then ZᵀWΦ += Zwᵀ Φ, ...
        let phi_m = DMatrix::from_row_slice(m, p, phi);
        let z_m = DMatrix::from_row_slice(m, p, z);
        let y_v = DVector::from_column_slice(y);
        let mut zw = z_m.clone();
        if let Some(w) = w {
            for (i, mut row) in zw.row_iter_mut().enumerate() {
                row *= w[i];
            }
        }
        self.ztwphi.gemm_tr(1.0, &zw, &phi_m, 1.0);
        self.ztwz.gemm_tr(1.0, &zw, &z_m, 1.0);
        self.ztwy.gemv_tr(1.0, &zw, &y_v, 1.0);
        Ok(())
    }

    /// Merges another chunk's statistics (sums add; the LS factors merge).
    pub fn merge(&mut self, other: &IvAccumulator) -> Result<()> {
        if other.p != self.p {
            return Err(mismatch("IvAccumulator::merge: p of the other accumulator", self.p, other.p));
        }
        self.ls.merge(&other.ls)?;
        self.ztwphi += &other.ztwphi;
        self.ztwy += &other.ztwy;
        self.ztwz += &other.ztwz;
        Ok(())
    }

    /// The statistics of the same rows with every weight multiplied by `c > 0`
    /// (see [`LsAccumulator::scaled`]; the sums scale by `c`).
    pub fn scaled(&self, c: f64) -> Result<IvAccumulator> {
        Ok(IvAccumulator {
            p: self.p,
            ls: self.ls.scaled(c)?,
            ztwphi: &self.ztwphi * c,
            ztwy: &self.ztwy * c,
            ztwz: &self.ztwz * c,
        })
    }

    /// Absorbs buffered rows of the inner LS factor.
    pub fn finish(&mut self) {
        self.ls.finish();
    }

    /// The least-squares statistics of the same rows.
    pub fn ls(&self) -> &LsAccumulator {
        &self.ls
    }

    /// `ZᵀWΦ` (`p x p`).
    pub fn ztwphi(&self) -> &DMatrix<f64> {
        &self.ztwphi
    }

    /// `ZᵀWy` (`p`).
    pub fn ztwy(&self) -> &DVector<f64> {
        &self.ztwy
    }

    /// `ZᵀWZ` (`p x p`).
    pub fn ztwz(&self) -> &DMatrix<f64> {
        &self.ztwz
    }

    /// `Σ w y²`.
    pub fn sum_wyy(&self) -> f64 {
        self.ls.sum_wyy()
    }
}

//! The joint-torque regressor matrix `Y` (`tau = Y theta`) as a type: its block storage and
//! dense views. Filled by [`crate::regressor`]'s recursion; held in [`crate::Data`], which
//! is why it lives below both.

use crate::params::{DRIVE_PARAMS, LINK_PARAMS, PARAMS_PER_JOINT};
use crate::types::{Lanes, VecN};

/// Joint-torque regressor of an `N`-joint chain, stored by blocks: `link[i][j]` is row
/// `i`'s 10 entries for link `j` (zero for `j < i`), `drive[i]` row `i`'s 4 entries for
/// joint `i`'s drive parameters (the other drive columns of row `i` are zero). `T` is
/// `f64`, or a pack of samples for the batch kernels (see [`crate::regressor::regressor_links`]).
#[derive(Debug, Clone, PartialEq)]
pub struct Regressor<const N: usize, T = f64> {
    /// Inertial blocks, `link[row][link]`.
    pub link: [[[T; LINK_PARAMS]; N]; N],
    /// Drive blocks `[sign(qd), qd, qdd, 1]` per row.
    pub drive: [[T; DRIVE_PARAMS]; N],
}

impl<const N: usize, T: Lanes> Regressor<N, T> {
    /// All zero, for any lane type.
    pub fn zeros() -> Self {
        let z = T::splat(0.0);
        Self { link: [[[z; LINK_PARAMS]; N]; N], drive: [[z; DRIVE_PARAMS]; N] }
    }
}

impl<const N: usize> Default for Regressor<N> {
    fn default() -> Self {
        Self::new()
    }
}

impl<const N: usize> Regressor<N> {
    /// All zero.
    pub const fn new() -> Self {
        Self { link: [[[0.0; LINK_PARAMS]; N]; N], drive: [[0.0; DRIVE_PARAMS]; N] }
    }

    /// Number of columns (`14 N`).
    pub const fn cols(&self) -> usize {
        PARAMS_PER_JOINT * N
    }

    /// Entry `(row, col)` of the dense `N x 14N` matrix.
    pub fn get(&self, row: usize, col: usize) -> f64 {
        if col < LINK_PARAMS * N {
            self.link[row][col / LINK_PARAMS][col % LINK_PARAMS]
        } else {
            let c = col - LINK_PARAMS * N;
            if c / DRIVE_PARAMS == row { self.drive[row][c % DRIVE_PARAMS] } else { 0.0 }
        }
    }

    /// Writes row `row` of the dense matrix into `out` (length `14 N`).
    #[inline]
    pub fn write_row(&self, row: usize, out: &mut [f64]) {
        let nl = LINK_PARAMS * N;
        for j in 0..N {
            out[LINK_PARAMS * j..LINK_PARAMS * (j + 1)].copy_from_slice(&self.link[row][j]);
        }
        out[nl..].fill(0.0);
        out[nl + DRIVE_PARAMS * row..nl + DRIVE_PARAMS * (row + 1)].copy_from_slice(&self.drive[row]);
    }

    /// Writes the dense `N x 14N` matrix in row-major order into `out` (length `14 N^2`).
    pub fn write_row_major(&self, out: &mut [f64]) {
        let p = PARAMS_PER_JOINT * N;
        for i in 0..N {
            self.write_row(i, &mut out[p * i..p * (i + 1)]);
        }
    }

    /// Writes only the inertial `N x 10N` part in row-major order (length `10 N^2`).
    pub fn write_rigid_row_major(&self, out: &mut [f64]) {
        let p = LINK_PARAMS * N;
        for i in 0..N {
            for j in 0..N {
                let o = p * i + LINK_PARAMS * j;
                out[o..o + LINK_PARAMS].copy_from_slice(&self.link[i][j]);
            }
        }
    }

    /// The dense matrix; `P` must be `14 N` (checked at compile time).
    pub fn to_matrix<const P: usize>(&self) -> nalgebra::SMatrix<f64, N, P> {
        const { assert!(P == PARAMS_PER_JOINT * N, "P must be 14 * N") };
        nalgebra::SMatrix::<f64, N, P>::from_fn(|r, c| self.get(r, c))
    }

    /// `Y theta` for a parameter slice of length `14 N`.
    pub fn mul(&self, theta: &[f64]) -> VecN<N> {
        let nl = LINK_PARAMS * N;
        let mut tau = VecN::<N>::zeros();
        for i in 0..N {
            let mut s = 0.0;
            for j in i..N {
                let th = &theta[LINK_PARAMS * j..LINK_PARAMS * (j + 1)];
                s += self.link[i][j].iter().zip(th).map(|(a, b)| a * b).sum::<f64>();
            }
            let th = &theta[nl + DRIVE_PARAMS * i..nl + DRIVE_PARAMS * (i + 1)];
            s += self.drive[i].iter().zip(th).map(|(a, b)| a * b).sum::<f64>();
            tau[i] = s;
        }
        tau
    }
}

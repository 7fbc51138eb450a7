//! The Fourier parametrisation of the excitation (Swevers et al. 1997): coefficients,
//! the per-harmonic basis on a time grid, and sampling a trajectory.

use ivdyn_core::trajectory::Fourier;

/// A sampled trajectory, row-major `T x N`.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Samples {
    /// Times (s).
    pub t: Vec<f64>,
    /// Positions.
    pub q: Vec<f64>,
    /// Velocities.
    pub qd: Vec<f64>,
    /// Accelerations.
    pub qdd: Vec<f64>,
}

/// Fourier coefficients of all joints (`a`, `b`: `n x h`, row-major), runtime-sized.
#[derive(Debug, Clone, PartialEq)]
pub struct Coeffs {
    /// Joints.
    pub n: usize,
    /// Harmonics.
    pub h: usize,
    /// Fundamental angular frequency (rad/s).
    pub omega: f64,
    /// Offsets.
    pub q0: Vec<f64>,
    /// Sine coefficients, `a[i * h + l]`.
    pub a: Vec<f64>,
    /// Cosine coefficients.
    pub b: Vec<f64>,
}

impl Coeffs {
    /// Joint `i`'s coefficients `[a_i; b_i]` (`2h`), in the layout of a [`Basis`] row.
    pub(super) fn joint(&self, i: usize) -> Vec<f64> {
        let h = self.h;
        (0..2 * h).map(|c| if c < h { self.a[i * h + c] } else { self.b[i * h + c - h] }).collect()
    }
}

/// Values of each harmonic's unit coefficient at the times of a grid: `q[k][c]`, with
/// `c < h` the sine coefficient `a_l` and `c >= h` the cosine coefficient `b_l`. A series
/// is the sum of its harmonics, and harmonic `l` is the one-harmonic [`Fourier`] of
/// frequency `l w`, so the basis is taken from `Fourier<1, 1>` (one implementation of the
/// series).
pub(super) struct Basis {
    /// Harmonics.
    pub(super) h: usize,
    /// Positions, `T x 2h`.
    pub(super) q: Vec<f64>,
    /// Velocities.
    pub(super) qd: Vec<f64>,
    /// Accelerations.
    pub(super) qdd: Vec<f64>,
}

impl Basis {
    /// The basis of `h` harmonics of `omega` at `times`.
    pub(super) fn new(omega: f64, h: usize, times: &[f64]) -> Basis {
        let (mut q, mut qd, mut qdd) =
            (vec![0.0; times.len() * 2 * h], vec![0.0; times.len() * 2 * h], vec![0.0; times.len() * 2 * h]);
        for (k, &t) in times.iter().enumerate() {
            for l in 0..h {
                for (c, (a, b)) in [(l, (1.0, 0.0)), (h + l, (0.0, 1.0))] {
                    let f = Fourier::<1, 1> { omega: (l + 1) as f64 * omega, q0: [0.0], a: [[a]], b: [[b]] };
                    let (x, v, acc) = f.eval(t);
                    q[k * 2 * h + c] = x[0];
                    qd[k * 2 * h + c] = v[0];
                    qdd[k * 2 * h + c] = acc[0];
                }
            }
        }
        Basis { h, q, qd, qdd }
    }
    /// Grid samples.
    pub(super) fn len(&self) -> usize {
        self.q.len() / (2 * self.h)
    }
    /// Sample `k`'s row (`2h` values) of `which` (`self.q`, `self.qd` or `self.qdd`).
    pub(super) fn row<'a>(&self, which: &'a [f64], k: usize) -> &'a [f64] {
        &which[k * 2 * self.h..(k + 1) * 2 * self.h]
    }
}

/// `a . b`.
pub(super) fn dot(a: &[f64], b: &[f64]) -> f64 {
    a.iter().zip(b).map(|(x, y)| x * y).sum()
}

/// Times per [`Basis`] in [`sample`]: the basis of a long log (simulate's hour at 1 kHz)
/// would take more memory than the samples themselves.
const SAMPLE_CHUNK: usize = 4096;

/// Samples `co` at `times` (through [`Basis`], i.e. `Fourier`).
pub fn sample(co: &Coeffs, times: &[f64]) -> Samples {
    let n = co.n;
    let mut s = Samples {
        t: times.to_vec(),
        q: vec![0.0; times.len() * n],
        qd: vec![0.0; times.len() * n],
        qdd: vec![0.0; times.len() * n],
    };
    let coef: Vec<Vec<f64>> = (0..n).map(|i| co.joint(i)).collect();
    for (c, chunk) in times.chunks(SAMPLE_CHUNK).enumerate() {
        let g = Basis::new(co.omega, co.h, chunk);
        for k in 0..chunk.len() {
            let row = (c * SAMPLE_CHUNK + k) * n;
            for (i, e) in coef.iter().enumerate() {
                s.q[row + i] = co.q0[i] + dot(g.row(&g.q, k), e);
                s.qd[row + i] = dot(g.row(&g.qd, k), e);
                s.qdd[row + i] = dot(g.row(&g.qdd, k), e);
            }
        }
    }
    s
}

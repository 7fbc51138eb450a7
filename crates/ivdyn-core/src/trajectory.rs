//! Finite Fourier series joint trajectories (Swevers et al., 1997), periodic with period
//! `2 pi / omega`: `q_i(t) = q0_i + sum_l a_il / (l w) sin(l w t) - b_il / (l w) cos(l w t)`.
//! Planned accelerations are exact, which makes them a free instrument.

use crate::types::VecN;
#[allow(unused_imports)] // needed without std (libm-backed trig), unused when std is unified in
use nalgebra::ComplexField;

/// `N` joints, `H` harmonics.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Fourier<const N: usize, const H: usize> {
    /// Fundamental angular frequency (rad/s).
    pub omega: f64,
    /// Offsets.
    pub q0: [f64; N],
    /// Sine coefficients `a_il` (rad/s, velocity amplitudes).
    pub a: [[f64; H]; N],
    /// Cosine coefficients `b_il`.
    pub b: [[f64; H]; N],
}

impl<const N: usize, const H: usize> Fourier<N, H> {
    /// Period (s).
    pub fn period(&self) -> f64 {
        core::f64::consts::TAU / self.omega
    }

    /// Position, velocity and acceleration at time `t`.
    pub fn eval(&self, t: f64) -> (VecN<N>, VecN<N>, VecN<N>) {
        let mut q = VecN::<N>::from_column_slice(&self.q0);
        let mut qd = VecN::<N>::zeros();
        let mut qdd = VecN::<N>::zeros();
        for l in 0..H {
            let lw = (l + 1) as f64 * self.omega;
            let (s, c) = (lw * t).sin_cos();
            for i in 0..N {
                let (a, b) = (self.a[i][l], self.b[i][l]);
                q[i] += (a * s - b * c) / lw;
                qd[i] += a * c + b * s;
                qdd[i] += lw * (-a * s + b * c);
            }
        }
        (q, qd, qdd)
    }

    /// RMS of each joint's acceleration over a period (closed form: sum of harmonic powers).
    pub fn qdd_rms(&self) -> VecN<N> {
        VecN::<N>::from_fn(|i, _| {
            let mut p = 0.0;
            for l in 0..H {
                let lw = (l + 1) as f64 * self.omega;
                p += 0.5 * lw * lw * (self.a[i][l] * self.a[i][l] + self.b[i][l] * self.b[i][l]);
            }
            p.sqrt()
        })
    }

    /// Scales joint `i`'s harmonics so that its acceleration RMS becomes `rms[i]`.
    pub fn scale_to_qdd_rms(&mut self, rms: &VecN<N>) {
        let cur = self.qdd_rms();
        for i in 0..N {
            if cur[i] > 0.0 {
                let k = rms[i] / cur[i];
                for l in 0..H {
                    self.a[i][l] *= k;
                    self.b[i][l] *= k;
                }
            }
        }
    }
}

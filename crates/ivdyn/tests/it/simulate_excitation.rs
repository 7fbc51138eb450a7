//! `simulate`'s built-in excitation (`app::fourier_trajectory`, sampled through the core's
//! Fourier series) against its documented form, evaluated here term by term:
//! `q_j(t) = q0_j + sum_l A_jl sin(2 pi l f0 t + phi_jl)` with `A_jl ~ U(0.3, 1) / l`
//! scaled to sum to the joint's amplitude and `phi_jl ~ U(0, 2 pi)` (the same draws of the
//! seeded generator), and `qd`, `qdd` its derivatives.

use ivdyn::Robot;
use ivdyn::app::{SimulateOptions, fourier_trajectory};
use ivdyn_core::rng::Rng;
use std::f64::consts::TAU;
use std::path::PathBuf;

#[test]
fn the_excitation_is_the_amplitude_phase_sum() {
    let p = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../fixtures/ur5.urdf");
    let robot = Robot::from_urdf(p, Some("base_link"), Some("tool0")).unwrap();
    let opts = SimulateOptions { seed: 7, duration_s: 12.0, rate_hz: 200.0, base_freq_hz: 0.2, ..Default::default() };
    let (t, q, qd, qdd) = fourier_trajectory(&robot, &opts);
    let (n, h) = (robot.dof(), opts.harmonics);
    assert_eq!(t.len(), 2400);
    let limits = ivdyn::with_model!(&robot.model, m => m.limits.to_vec());
    let mut rng = Rng::new(opts.seed);
    for j in 0..n {
        let (lo, hi) = (limits[j].lower, limits[j].upper);
        let finite = lo.is_finite() && hi.is_finite() && hi > lo;
        let q0 = if finite && hi - lo < 2.0 * TAU { 0.5 * (lo + hi) } else { 0.0 };
        let amp = if finite { opts.amplitude.min(0.4 * (hi - lo)) } else { opts.amplitude };
        let raw: Vec<(f64, f64)> =
            (0..h).map(|l| (rng.uniform(0.3, 1.0) / (l + 1) as f64, rng.uniform(0.0, TAU))).collect();
        let sum: f64 = raw.iter().map(|r| r.0).sum();
        for (k, &tk) in t.iter().enumerate() {
            let (mut x, mut v, mut a) = (q0, 0.0, 0.0);
            for (l, &(r, phi)) in raw.iter().enumerate() {
                let (c, w) = (r * amp / sum, TAU * opts.base_freq_hz * (l + 1) as f64);
                x += c * (w * tk + phi).sin();
                v += c * w * (w * tk + phi).cos();
                a -= c * w * w * (w * tk + phi).sin();
            }
            // a few roundings of terms below 1 (rad, rad/s, rad/s^2 at these frequencies)
            let i = k * n + j;
            assert!((q[i] - x).abs() < 1e-13, "q[{k}, {j}]: {} vs {x}", q[i]);
            assert!((qd[i] - v).abs() < 1e-13, "qd[{k}, {j}]: {} vs {v}", qd[i]);
            assert!((qdd[i] - a).abs() < 1e-12, "qdd[{k}, {j}]: {} vs {a}", qdd[i]);
        }
    }
}

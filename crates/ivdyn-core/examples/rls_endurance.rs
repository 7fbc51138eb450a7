//! Endurance run for issue 16 item 5: `ROWS` (default 1e8) RLS updates with forgetting
//! `lambda = 0.99` from `p0 = 1e4` (the filed defect: the covariance overflowed after
//! 69,707 rows), 8 parameters of which one is never excited and one is excited once every
//! 100,000 rows, row noise `sigma = 0.01` (`w = 1e4`), parameter 0 stepping by 1 every
//! 10^7 rows. Defaults otherwise (anti-windup cap `p0`, no outlier gate).
//!
//! `cargo run --release -p ivdyn-core --example rls_endurance [ROWS]`
//!
//! Prints the time, the extreme `d_j`, whether `P` is symmetric and Cholesky-factorable,
//! and the final error of the excited parameters; exits non-zero if any row failed or `P`
//! is not finite and positive definite.

use ivdyn_core::estim::Rls;
use ivdyn_core::rng::Rng;
use nalgebra::{Const, SVector};
use std::time::Instant;

const P: usize = 8;
type V = SVector<f64, P>;

fn main() {
    let rows: u64 = std::env::args().nth(1).map_or(100_000_000, |s| s.parse::<f64>().expect("ROWS") as u64);
    let mut rng = Rng::new(16);
    let mut truth = V::from_fn(|i, _| 0.5 + 0.1 * i as f64);
    let (sigma, w) = (0.01, 1e4);
    let mut rls = Rls::<Const<P>>::new(V::zeros(), 1e4);
    rls.forgetting = 0.99;
    let start = Instant::now();
    for k in 0..rows {
        if k > 0 && k % 10_000_000 == 0 {
            truth[0] += if (k / 10_000_000) % 2 == 1 { 1.0 } else { -1.0 };
        }
        let mut phi = V::from_fn(|_, _| rng.uniform(-1.0, 1.0));
        phi[P - 1] = 0.0; // never excited
        if k % 100_000 != 0 {
            phi[P - 2] = 0.0; // excited once every 100,000 rows
        }
        let y = phi.dot(&truth) + sigma * 3f64.sqrt() * rng.uniform(-1.0, 1.0);
        if let Err(e) = rls.update(&phi, y, w) {
            eprintln!("row {k}: {e}");
            std::process::exit(1);
        }
    }
    let secs = start.elapsed().as_secs_f64();
    let p = rls.covariance();
    let d = rls.d();
    let symmetric = (p - p.transpose()).norm() <= 1e-15 * p.norm();
    let spd = p.iter().all(|v| v.is_finite()) && p.cholesky().is_some();
    let err = (0..P - 2).map(|i| (rls.theta[i] - truth[i]).abs()).fold(0.0, f64::max);
    println!("rows {} in {secs:.1} s ({:.1} ns/row)", rls.count, 1e9 * secs / rows as f64);
    println!("d_j in [{:.3e}, {:.3e}], symmetric {symmetric}, Cholesky {spd}", d.min(), d.max());
    println!("max |theta_i - truth_i| over the always-excited parameters: {err:.2e}");
    println!("never-excited theta = {}, variance d = {:.6e}", rls.theta[P - 1], d[P - 1]);
    if !(spd && symmetric && d.iter().all(|&v| v > 0.0 && v.is_finite())) {
        std::process::exit(1);
    }
}

//! Times `ivdyn::batch::regressor_batch` (rigid part, `T x N x 10N`) from Rust on samples
//! written by `benches/python_regressor.py`, so the Python and Rust timings use the same
//! data in the same run.
//!
//!     cargo run --release -p ivdyn-py --example regressor_timing -- URDF BASE TIP SAMPLES.bin [REPEATS]
//!
//! `SAMPLES.bin`: little-endian f64, `q`, `qd`, `qdd` (each `T x N`, row-major) one after
//! the other. Prints `RUST_REGRESSOR T N threads min_s median_s checksum reused_min_s
//! reused_median_s`: first with a fresh output `Vec` per call, then into one reused buffer.

use std::time::Instant;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().collect();
    if args.len() < 5 {
        return Err("usage: regressor_timing URDF BASE TIP SAMPLES.bin [REPEATS]".into());
    }
    let robot = ivdyn::Robot::from_urdf(&args[1], Some(&args[2]), Some(&args[3]))?;
    let repeats: usize = args.get(5).map(|s| s.parse()).transpose()?.unwrap_or(5);
    let bytes = std::fs::read(&args[4])?;
    let all: Vec<f64> = bytes.chunks_exact(8).map(|b| f64::from_le_bytes(b.try_into().unwrap())).collect();
    let n = robot.dof();
    let t = all.len() / (3 * n);
    if all.len() != 3 * t * n {
        return Err(format!("{}: {} values is not 3 x T x {n}", args[4], all.len()).into());
    }
    let (q, rest) = all.split_at(t * n);
    let (qd, qdd) = rest.split_at(t * n);
    let len = t * n * 10 * n;
    let median = |mut v: Vec<f64>| -> (f64, f64) {
        v.sort_by(|a, b| a.total_cmp(b));
        (v[0], v[v.len() / 2])
    };
    // (1) a fresh Vec per call: the allocation and its page faults are part of the cost
    let mut fresh = Vec::new();
    let mut checksum = 0.0;
    for _ in 0..repeats {
        let t0 = Instant::now();
        let mut y = vec![0.0; len];
        ivdyn::batch::regressor_batch(&robot, q, qd, qdd, &mut y, true)?;
        fresh.push(t0.elapsed().as_secs_f64());
        checksum = y.iter().sum::<f64>();
    }
    // (2) one buffer, already touched, reused: the batch function alone
    let mut y = vec![1.0; len];
    let mut reused = Vec::new();
    for _ in 0..repeats {
        let t0 = Instant::now();
        ivdyn::batch::regressor_batch(&robot, q, qd, qdd, &mut y, true)?;
        reused.push(t0.elapsed().as_secs_f64());
    }
    let (f_min, f_med) = median(fresh);
    let (r_min, r_med) = median(reused);
    println!(
        "RUST_REGRESSOR {t} {n} {} {f_min:.6} {f_med:.6} {checksum:e} {r_min:.6} {r_med:.6}",
        ivdyn::batch::threads_for(t)
    );
    Ok(())
}

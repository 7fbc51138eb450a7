//! Writes a small MCAP log with ivdyn's writer, for the Python round-trip test
//! (python/tests_io/test_mcap_roundtrip.py) and as an example of the output API.
//!
//!     cargo run -p ivdyn --example write_log -- out.mcap [samples]
//!
//! Topics: /joint_states (position, velocity, effort), /ivdyn/predicted and
//! /ivdyn/residual (effort). Joint j at sample k: q = sin(0.01 k + j),
//! qd = cos(0.01 k + j), tau = 2 j + 0.001 k, predicted = 0.9 tau, residual = 0.1 tau;
//! stamps 1.7e18 ns + k ms.

use ivdyn::log::{JointLog, write_mcap};

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let mut args = std::env::args().skip(1);
    let out = args.next().ok_or("usage: write_log OUT.mcap [samples]")?;
    let t: usize = args.next().map(|s| s.parse()).transpose()?.unwrap_or(100);
    let names = ["shoulder_pan_joint", "shoulder_lift_joint", "elbow_joint"];
    let n = names.len();
    let at = |f: &dyn Fn(usize, usize) -> f64| -> Vec<f64> { (0..t * n).map(|i| f(i / n, i % n)).collect() };
    let tau = at(&|k, j| 2.0 * j as f64 + 0.001 * k as f64);
    let log = JointLog {
        joint_names: names.iter().map(|s| s.to_string()).collect(),
        t0_ns: 1_700_000_000_000_000_000,
        t: (0..t).map(|k| k as f64 * 1e-3).collect(),
        q: at(&|k, j| (0.01 * k as f64 + j as f64).sin()),
        qd: Some(at(&|k, j| (0.01 * k as f64 + j as f64).cos())),
        tau: Some(tau.clone()),
        u: None,
        current: None,
        truncated: false,
    };
    let pred: Vec<f64> = tau.iter().map(|v| 0.9 * v).collect();
    let res: Vec<f64> = tau.iter().map(|v| 0.1 * v).collect();
    let path = write_mcap(&out, &log, &[("/ivdyn/predicted", &pred), ("/ivdyn/residual", &res)])?;
    println!("{}", path.display());
    Ok(())
}

//! One dynamics kernel called in a loop, for instruction counts under callgrind
//! (load-independent, unlike times): `benches/callgrind_kernels.sh` runs it at two
//! iteration counts and prints the difference per call.
//!
//! Usage: `kernel_loop ROBOT KERNEL ITERS`, ROBOT in ur5 | paper | panda7, KERNEL in
//! rnea | regressor | mass_matrix | forward_dynamics | gravity.

use ivdyn_benches::{panda7, states, ur5};
use ivdyn_core::{Data, Model, forward_dynamics, gravity, mass_matrix, paper, regressor, rnea};
use std::hint::black_box;

fn run<const N: usize>(model: &Model<N>, kernel: &str, iters: usize) -> Result<f64, String> {
    let xs = states::<N>(1024);
    let mut data = Data::<N>::new();
    let taus: Vec<_> = xs.iter().map(|(q, qd, qdd)| *rnea(model, &mut data, q, qd, qdd)).collect();
    let mut sink = 0.0;
    for k in 0..iters {
        let i = k & 1023;
        let (q, qd, qdd) = &xs[i];
        sink += match kernel {
            "rnea" => black_box(rnea(model, &mut data, q, qd, qdd)[0]),
            "regressor" => black_box(regressor(model, &mut data, q, qd, qdd).link[0][0][0]),
            "mass_matrix" => black_box(mass_matrix(model, &mut data, q)[(0, 0)]),
            "forward_dynamics" => {
                black_box(forward_dynamics(model, &mut data, q, qd, &taus[i]).map(|x| x[0]).unwrap_or(0.0))
            }
            "gravity" => black_box(gravity(model, &mut data, q)[0]),
            other => return Err(format!("unknown kernel {other:?}")),
        };
    }
    Ok(sink)
}

fn main() -> Result<(), String> {
    let args: Vec<String> = std::env::args().collect();
    let [_, robot, kernel, iters] = args.as_slice() else {
        return Err("usage: kernel_loop ROBOT KERNEL ITERS".into());
    };
    let iters: usize = iters.parse().map_err(|e| format!("ITERS {iters:?}: {e}"))?;
    let sink = match robot.as_str() {
        "ur5" => run(&ur5(), kernel, iters)?,
        "paper" => run(&paper::robot(), kernel, iters)?,
        "panda7" => run(&panda7(), kernel, iters)?,
        other => return Err(format!("unknown robot {other:?}")),
    };
    black_box(sink);
    Ok(())
}

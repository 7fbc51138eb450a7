//! One dynamics kernel called in a loop, for instruction counts under callgrind
//! (load-independent, unlike times): `benches/callgrind_kernels.sh` runs it at two
//! iteration counts and prints the difference per call.
//!
//! Usage: `kernel_loop ROBOT KERNEL ITERS`, ROBOT in ur5 | paper | panda7, KERNEL in
//! rnea | regressor | mass_matrix | forward_dynamics | gravity, or (paper only) one
//! recursive terminal-link update at k = 5 (18 columns, rows of joints 5 and 6):
//! terminal_iv | terminal_iv_info | terminal_ls.

use ivdyn_benches::{panda7, states, ur5};
use ivdyn_core::estim::terminal::{Method, TerminalLink, TerminalSpec};
use ivdyn_core::estim::{Riv, RivInfo, Rls};
use ivdyn_core::{Data, Model, forward_dynamics, gravity, mass_matrix, paper, regressor, rnea};
use nalgebra::{Const, SVector};
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

/// The paper robot's 18 identifiable columns at k = 5 (`crates/ivdyn-core/tests/op_count.rs`).
const COLUMNS: [usize; 18] = [1, 4, 5, 7, 8, 9, 10, 11, 13, 14, 15, 16, 17, 19, 20, 21, 22, 23];

fn terminal(kernel: &str, iters: usize) -> Result<f64, String> {
    let z = SVector::<f64, 18>::zeros();
    let method = match kernel {
        "terminal_iv" => Method::Iv(Riv::new(z, 1e4)),
        "terminal_iv_info" => Method::IvInfo(RivInfo::new(z, 1e4)),
        "terminal_ls" => Method::Ls(Rls::new(z, 1e4)),
        other => return Err(format!("unknown kernel {other:?}")),
    };
    let (model, cols) = (paper::robot(), SVector::from(COLUMNS));
    let mut tl = TerminalLink::<6, Const<18>>::new(
        model.clone(),
        TerminalSpec::PAPER,
        cols,
        [0.0, 0.0, 0.0, 0.0, 0.01, 1.0],
        method,
    );
    let xs = states::<6>(1024);
    let mut data = Data::<6>::new();
    let taus: Vec<_> = xs.iter().map(|(q, qd, qdd)| *rnea(&model, &mut data, q, qd, qdd)).collect();
    for k in 0..iters {
        let i = k & 1023;
        let (q, qd, qdd) = &xs[i];
        tl.update(q, qd, qdd, &taus[i], &xs[(i + 1) & 1023].2).map_err(|e| e.to_string())?;
    }
    Ok(tl.theta()[0])
}

fn main() -> Result<(), String> {
    let args: Vec<String> = std::env::args().collect();
    let [_, robot, kernel, iters] = args.as_slice() else {
        return Err("usage: kernel_loop ROBOT KERNEL ITERS".into());
    };
    let iters: usize = iters.parse().map_err(|e| format!("ITERS {iters:?}: {e}"))?;
    let sink = match robot.as_str() {
        "paper" if kernel.starts_with("terminal") => terminal(kernel, iters)?,
        "ur5" => run(&ur5(), kernel, iters)?,
        "paper" => run(&paper::robot(), kernel, iters)?,
        "panda7" => run(&panda7(), kernel, iters)?,
        other => return Err(format!("unknown robot {other:?}")),
    };
    black_box(sink);
    Ok(())
}

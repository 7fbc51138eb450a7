//! Reproduces the paper's Fig. 5: trajectory tracking after a payload is grasped, under
//! (a) PD, (a') PD + nominal gravity, (b) computed torque with the nominal model,
//! (c) computed torque switched online to the IVM payload estimate, (d) computed torque
//! with the true parameters; on the paper's robot (250 g) and the Panda (2 kg).
//! Writes JSON for `examples/plot_control.py` and prints the tables of `docs/control.md`.
//!
//!     cargo run --release -p ivdyn --example control_fig5 -- [--out out/control] [--duration 10]
//!     .venv/bin/python examples/plot_control.py out/control docs/figures

use ivdyn_lab::control::{EstimatorKind, Experiment, Instrument, RunLog, Scheme};
use serde_json::json;
use std::path::{Path, PathBuf};

/// Settling allowance after the switch for the main table (s): with both closed-loop
/// poles at -20 rad/s an error decays to 2 % in 0.3 s.
const SETTLE: f64 = 0.5;

/// The value after `name` on the command line, or `default`.
fn arg<T: std::str::FromStr>(name: &str, default: T) -> T {
    let args: Vec<String> = std::env::args().collect();
    args.iter().position(|a| a == name).and_then(|i| args.get(i + 1)).and_then(|v| v.parse().ok()).unwrap_or(default)
}

/// Runs every scheme of Fig. 5 on `exp`, prints the tables of `docs/control.md` and writes
/// `out/<name>.json` for the plots.
fn run_all<const N: usize>(exp: &Experiment<N>, out: &Path) -> Result<(), Box<dyn std::error::Error>> {
    println!("\n## {} ({} joints), payload {} kg", exp.name, N, exp.payload.mass);
    println!("estimated columns (identifiable from all joints): {:?}", exp.column_names);
    let runs: Vec<RunLog> = Scheme::ALL.iter().map(|&s| exp.run(s)).collect::<Result<_, _>>()?;
    let c = &runs[3];
    let switch = c.switch_time.unwrap_or(exp.grasp_time);
    let truth = exp.truth_columns();
    let mass_b = exp.columns.iter().position(|&k| k == 0);
    print_final_estimate(exp, c, &truth, mass_b, switch);
    let settle = switch + SETTLE;
    let tables = tracking_tables::<N>(&runs, switch, settle);
    println!(
        "(c) mean RMS: before the grasp {:.3} mrad, grasp to switch {:.3} mrad, after switch + {SETTLE} s {:.3} mrad",
        1e3 * window_rms::<N>(c, 0.5, exp.grasp_time),
        1e3 * window_rms::<N>(c, exp.grasp_time, switch),
        1e3 * window_rms::<N>(c, settle, f64::INFINITY)
    );
    println!(
        "saturated steps {:?}; step time (controller + estimator, wall clock in the loop) {:.2} us",
        runs.iter().map(|r| r.saturated_steps).collect::<Vec<_>>(),
        c.step_us
    );
    print_estimator_variants(exp, &truth, mass_b)?;
    let js = experiment_json(exp, &runs, tables, &truth, mass_b, switch);
    std::fs::write(out.join(format!("{}.json", exp.name)), serde_json::to_string(&js)?)?;
    Ok(())
}

/// Prints the final estimate of scheme (c) (run `c`, switched at `switch`) against the
/// truth: the payload mass (entry `mass_b`) and when it settled within 5 %, then every
/// estimated entry.
fn print_final_estimate<const N: usize>(
    exp: &Experiment<N>,
    c: &RunLog,
    truth: &[f64],
    mass_b: Option<usize>,
    switch: f64,
) {
    let est = c.final_estimate();
    if let Some(b) = mass_b {
        println!(
            "payload mass: truth {:.4} kg, final estimate {:.4} kg ({:+.2} %), switch at t = {:.3} s ({:.3} s after the grasp)",
            truth[b],
            est[b],
            100.0 * (est[b] - truth[b]) / truth[b],
            switch,
            switch - exp.grasp_time
        );
        // first time the mass estimate stays within 5 % for good
        let within = c.estimates.iter().rposition(|e| ((e.theta[b] - truth[b]) / truth[b]).abs() > 0.05).map(|i| i + 1);
        if let Some(i) = within.filter(|&i| i < c.estimates.len()) {
            println!(
                "mass estimate within 5 % from t = {:.3} s on ({:.3} s after the grasp)",
                c.estimates[i].t,
                c.estimates[i].t - exp.grasp_time
            );
        }
    }
    println!("\nall estimated entries at the end (truth = the payload's parameters about the last link's origin):");
    for (i, name) in exp.column_names.iter().enumerate() {
        println!("  {name:<14} truth {:+.4e}  estimate {:+.4e}", truth[i], est[i]);
    }
}

/// Prints the per-joint tracking-error tables of every scheme from `settle` and from the
/// `switch` on, with the mean-RMS ratios the paper's comparison rests on; returns them
/// for the JSON.
fn tracking_tables<const N: usize>(runs: &[RunLog], switch: f64, settle: f64) -> Vec<serde_json::Value> {
    let mut tables = vec![];
    for (from, what) in [
        (settle, format!("from {SETTLE} s after the switch (t >= {settle:.3} s)")),
        (switch, format!("from the switch (t >= {switch:.3} s)")),
    ] {
        println!("\ntracking error {what}, per joint, RMS / peak in mrad:\n");
        let hdr: Vec<String> = (1..=N).map(|i| format!("j{i}")).collect();
        println!("| scheme | {} | mean RMS |", hdr.join(" | "));
        println!("|---|{}---|", "---|".repeat(N));
        let mut rms_mean = vec![];
        for r in runs {
            let (rms, pk) = r.rms_peak(from);
            let m = rms.iter().sum::<f64>() / N as f64;
            rms_mean.push(m);
            let cells: Vec<String> =
                rms.iter().zip(&pk).map(|(a, b)| format!("{:.3} / {:.2}", 1e3 * a, 1e3 * b)).collect();
            println!("| {} | {} | {:.3} |", r.scheme.label(), cells.join(" | "), 1e3 * m);
        }
        println!(
            "\nmean-RMS ratios: (a)/(c) = {:.1}, (a')/(c) = {:.1}, (b)/(c) = {:.1}, (c)/(d) = {:.2}",
            rms_mean[0] / rms_mean[3],
            rms_mean[1] / rms_mean[3],
            rms_mean[2] / rms_mean[3],
            rms_mean[3] / rms_mean[4],
        );
        tables.push(json!({"from": from, "rms_peak": runs.iter().map(|r| r.rms_peak(from)).collect::<Vec<_>>()}));
    }
    tables
}

/// RMS over joints and steps of the tracking error of `r` in `a <= t < b` (rad): scheme
/// (c) before the grasp, between grasp and switch, after the switch.
fn window_rms<const N: usize>(r: &RunLog, a: f64, b: f64) -> f64 {
    let v: Vec<f64> = r
        .t_all
        .iter()
        .zip(&r.err_all)
        .filter(|(t, _)| **t >= a && **t < b)
        .map(|(_, e)| e.iter().map(|x| x * x).sum::<f64>() / N as f64)
        .collect();
    (v.iter().sum::<f64>() / v.len().max(1) as f64).sqrt()
}

/// Prints scheme (c) with each instrument and with LS, on the same run: the mass estimate
/// at the end, the switch time, the tracking error after it.
fn print_estimator_variants<const N: usize>(
    exp: &Experiment<N>,
    truth: &[f64],
    mass_b: Option<usize>,
) -> Result<(), Box<dyn std::error::Error>> {
    println!("\nestimator variants (mass estimate at the end, switch time):");
    for (label, kind) in [
        ("IV, planned acceleration", EstimatorKind::Iv(Instrument::Planned)),
        ("IV, eq-35 model of u, delay 0", EstimatorKind::Iv(Instrument::Eq35 { delay: 0 })),
        ("IV, eq-35 model of u, delay 3", EstimatorKind::Iv(Instrument::Eq35 { delay: 3 })),
        ("LS", EstimatorKind::Ls),
    ] {
        let mut e = exp.clone();
        e.estimator = kind;
        let r = e.run(Scheme::CtEstimated)?;
        let (rms, _) = r.rms_peak(r.switch_time.unwrap_or(e.grasp_time));
        let fe = r.final_estimate();
        if let Some(b) = mass_b {
            println!(
                "  {label:<32} dm = {:.4} kg ({:+.2} %), switch {}, mean RMS after switch {:.3} mrad",
                fe[b],
                100.0 * (fe[b] - truth[b]) / truth[b],
                r.switch_time.map_or("never".to_string(), |t| format!("{:.3} s", t)),
                1e3 * rms.iter().sum::<f64>() / N as f64
            );
        }
    }
    Ok(())
}

/// The JSON of one experiment for `examples/plot_control.py`: every run (errors decimated
/// to the record rate), the tracking tables and the trace of scheme (c)'s estimator.
fn experiment_json<const N: usize>(
    exp: &Experiment<N>,
    runs: &[RunLog],
    tables: Vec<serde_json::Value>,
    truth: &[f64],
    mass_b: Option<usize>,
    switch: f64,
) -> serde_json::Value {
    let c = &runs[3];
    json!({
        "name": exp.name, "dof": N, "payload_mass": exp.payload.mass, "grasp_time": exp.grasp_time,
        "switch_time": c.switch_time, "tables": tables, "columns": exp.column_names, "truth": truth,
        "runs": runs.iter().map(|r| {
            // errors decimated to the record rate
            let e: Vec<&Vec<f64>> = r.err_all.iter().step_by(exp.record_every).collect();
            json!({"key": r.scheme.key(), "label": r.scheme.label(), "t": r.t, "q_des": r.q_des, "q": r.q,
                   "err": e, "tau": r.tau, "rms_peak_after_switch": r.rms_peak(switch)})
        }).collect::<Vec<_>>(),
        "estimates": {"t": c.estimates.iter().map(|e| e.t).collect::<Vec<_>>(),
                      "theta": c.estimates.iter().map(|e| e.theta.clone()).collect::<Vec<_>>(),
                      "mass_std": c.estimates.iter().map(|e| e.mass_std).collect::<Vec<_>>(),
                      "err_std": c.estimates.iter().map(|e| e.err_std).collect::<Vec<_>>(),
                      "mass_index": mass_b},
    })
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let out = PathBuf::from(arg("--out", "out/control".to_string()));
    let duration: f64 = arg("--duration", 10.0);
    std::fs::create_dir_all(&out)?;
    let mut paper = Experiment::paper()?;
    paper.duration = duration;
    paper.switch_error_tol = arg("--switch-tol", paper.switch_error_tol);
    run_all(&paper, &out)?;
    let root = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../..");
    let mut panda = Experiment::panda(root.join("fixtures/panda.urdf"))?;
    panda.duration = duration;
    panda.switch_error_tol = arg("--switch-tol", panda.switch_error_tol);
    run_all(&panda, &out)?;
    println!("\nwrote {}", out.display());
    Ok(())
}

//! Reproduces the paper's simulation (Figs 2 and 3) and a Monte Carlo study of the
//! estimators' bias and spread; writes JSON for `examples/plot_paper.py`.
//!
//!     cargo run --release -p ivdyn --example paper_reproduction -- [--seeds 20] [--n-max 1000000] [--out out/paper]
//!
//! See `docs/paper-reproduction.md` for the set-up and the results.

use indicatif::{ProgressBar, ProgressStyle};
use ivdyn_lab::repro::{Estimator, PaperSim, batch_estimates, recursive_traces};
use serde_json::json;
use std::path::{Path, PathBuf};
use std::sync::Mutex;

/// The value after `name` on the command line, or `default`.
fn arg<T: std::str::FromStr>(name: &str, default: T) -> T {
    let args: Vec<String> = std::env::args().collect();
    args.iter().position(|a| a == name).and_then(|i| args.get(i + 1)).and_then(|v| v.parse().ok()).unwrap_or(default)
}

/// About `per_decade` integers per decade from `lo` to `hi`, log-spaced, without repeats.
fn log_points(lo: usize, hi: usize, per_decade: usize) -> Vec<usize> {
    let mut v: Vec<usize> = (0..)
        .map(|k| (lo as f64 * 10f64.powf(k as f64 / per_decade as f64)).round() as usize)
        .take_while(|&n| n <= hi)
        .collect();
    v.dedup();
    v
}

/// One Monte Carlo run: seed, true base parameters, estimates per estimator, checkpoint
/// and base parameter.
type McRun = (u64, Vec<f64>, Vec<Vec<Vec<f64>>>);

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let seeds: u64 = arg("--seeds", 20);
    let n_max: usize = arg("--n-max", 1_000_000);
    let out = PathBuf::from(arg("--out", "out/paper".to_string()));
    std::fs::create_dir_all(&out)?;

    // --- recursive traces for the figures (seed 0) ---
    let sim = PaperSim::new(0)?;
    print_base(&sim);
    write_traces(&sim, n_max, &out)?;

    // --- Monte Carlo over seeds (nominal errors and noise both drawn per seed) ---
    let checkpoints: Vec<usize> =
        [2_000usize, 10_000, 100_000, 1_000_000].into_iter().filter(|&n| n <= n_max).collect();
    let results = monte_carlo(seeds, &checkpoints)?;
    std::fs::write(
        out.join("montecarlo.json"),
        serde_json::to_string(&json!({
            "names": sim.base.names, "checkpoints": checkpoints,
            "estimators": Estimator::ALL.iter().map(|e| e.label()).collect::<Vec<_>>(),
            "runs": results.iter().map(|(seed, truth, est)| json!({"seed": seed, "truth": truth, "estimates": est})).collect::<Vec<_>>(),
        }))?,
    )?;

    // --- table: error of the final estimates, mean and std over seeds ---
    print_error_tables(&sim, &results, &checkpoints);
    println!("\nwrote {}", out.display());
    Ok(())
}

/// Prints the base combinations of the k = 5 problem with their true values (seed 0), and
/// the columns that have no effect on joints 5-6 at all.
fn print_base(sim: &PaperSim) {
    println!("base combinations of the k = 5 problem ({} of {} unknowns):", sim.base.base_count(), sim.spec.cols(6));
    for (i, n) in sim.base.names.iter().enumerate() {
        println!("  [{i:2}] {n:<48} truth {:+.6e}", sim.truth_base[i]);
    }
    let all_names = ivdyn_lab::repro::terminal_names(&sim.spec, 6);
    println!(
        "no effect on joints 5-6 at all (zero columns): {:?}",
        sim.base.zero_columns.iter().map(|&c| all_names[c].as_str()).collect::<Vec<_>>()
    );
}

/// The recursive estimators' traces on seed 0 (Figs 2 and 3), up to 200 000 samples at
/// 20 points per decade, written to `out/traces.json`.
fn write_traces(sim: &PaperSim, n_max: usize, out: &Path) -> Result<(), Box<dyn std::error::Error>> {
    let n_fig = n_max.min(200_000);
    let record = log_points(100, n_fig, 20);
    eprintln!("recursive traces: {} samples x {} estimators", n_fig, Estimator::ALL.len());
    let traces = recursive_traces(sim, 0, &record, 1e4)?;
    std::fs::write(
        out.join("traces.json"),
        serde_json::to_string(&json!({
            "names": sim.base.names, "truth": sim.truth_base, "n": record,
            "estimators": Estimator::ALL.iter().map(|e| e.label()).collect::<Vec<_>>(),
            "estimates": traces,
        }))?,
    )?;
    Ok(())
}

/// The batch estimates at `checkpoints` for seeds `0..seeds`, one seed at a time per
/// thread (each seed draws its own nominal errors and noise, so the result does not
/// depend on the threads); sorted by seed.
fn monte_carlo(seeds: u64, checkpoints: &[usize]) -> Result<Vec<McRun>, Box<dyn std::error::Error>> {
    let bar = ProgressBar::new(seeds);
    bar.set_style(ProgressStyle::with_template(
        "monte carlo {bar:40} {pos}/{len} seeds [{elapsed_precise} / eta {eta}]",
    )?);
    let results = Mutex::new(Vec::new());
    let next = Mutex::new(0u64);
    std::thread::scope(|s| {
        for _ in 0..std::thread::available_parallelism().map(|n| n.get()).unwrap_or(1) {
            s.spawn(|| {
                loop {
                    let seed = {
                        let mut g = next.lock().unwrap();
                        if *g >= seeds {
                            break;
                        }
                        *g += 1;
                        *g - 1
                    };
                    let sim = PaperSim::new(seed).expect("set-up");
                    let est = batch_estimates(&sim, 1_000_000 + seed, checkpoints).expect("estimates");
                    results.lock().unwrap().push((seed, sim.truth_base.clone(), est));
                    bar.inc(1);
                }
            });
        }
    });
    bar.finish();
    let mut results = results.into_inner()?;
    results.sort_by_key(|r| r.0);
    Ok(results)
}

/// Prints, per checkpoint, the error of every estimator on the last link's and joint's
/// base combinations: mean and standard deviation over seeds.
fn print_error_tables(sim: &PaperSim, results: &[McRun], checkpoints: &[usize]) {
    println!("\nerror of the estimates over {} seeds, mean +- std: in % of |truth| where the truth is", results.len());
    println!("nonzero, else absolute (SI units):");
    for (ci, &n) in checkpoints.iter().enumerate() {
        println!("\nN = {n}");
        println!(
            "| combination | truth (seed 0) | {} |",
            Estimator::ALL.iter().map(|e| e.label()).collect::<Vec<_>>().join(" | ")
        );
        println!("|---|---|{}", "---|".repeat(Estimator::ALL.len()));
        for (b, name) in sim.base.names.iter().enumerate() {
            if !name.contains("link6") && !name.contains("joint6") {
                continue;
            }
            let cells: Vec<String> = (0..Estimator::ALL.len()).map(|k| error_cell(results, k, ci, b)).collect();
            println!("| {name} | {:.4e} | {} |", results[0].1[b], cells.join(" | "));
        }
    }
}

/// Mean +- std over seeds of estimator `k`'s error on base combination `b` at checkpoint
/// `ci`: relative (%) when the truth is nonzero for every seed, else absolute.
fn error_cell(results: &[McRun], k: usize, ci: usize, b: usize) -> String {
    let relative = results.iter().all(|(_, t, _)| t[b].abs() > 1e-9);
    let errs: Vec<f64> = results
        .iter()
        .map(|(_, t, e)| if relative { 100.0 * (e[k][ci][b] - t[b]) / t[b].abs() } else { e[k][ci][b] - t[b] })
        .collect();
    let m = errs.iter().sum::<f64>() / errs.len() as f64;
    let sd = (errs.iter().map(|x| (x - m).powi(2)).sum::<f64>() / (errs.len().max(2) - 1) as f64).sqrt();
    if relative { format!("{m:+.1} % +- {sd:.1}") } else { format!("{m:+.1e} +- {sd:.1e}") }
}

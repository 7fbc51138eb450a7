//! Identification on two real arms (docs/real-data.md): the Stäubli TX40 (motor side,
//! coupled wrist) and the KUKA LWR4+ (joint torques), read from the development data.
//!
//!     cargo run --release -p ivdyn --example real_data -- [DATA_ROOT] [--out DIR]
//!     .venv/bin/python examples/plot_real_data.py --in out/real --out docs/figures
//!
//! DATA_ROOT defaults to `../shared/data/real` next to the repository. Writes
//! `DIR/tx40.json`, `DIR/lwr.json` (the chosen settings: parameters, validation, series)
//! and `DIR/variants.json` (validation R² of the other settings tried, for the doc's
//! sensitivity table). Default DIR: `out/real`.

use std::path::PathBuf;

use ivdyn::io::real::{load_lwr_robot, load_lwr_run, load_tx40};
use ivdyn::realdata::{identify_lwr, identify_tx40, Estimator, LwrOptions, RealReport, Tx40Options};

fn main() {
    if let Err(e) = run() {
        eprintln!("error: {e}");
        std::process::exit(1);
    }
}

fn run() -> Result<(), Box<dyn std::error::Error>> {
    let mut root = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../../shared/data/real");
    let mut out = PathBuf::from("out/real");
    let mut args = std::env::args().skip(1);
    while let Some(a) = args.next() {
        match a.as_str() {
            "--out" => out = PathBuf::from(args.next().ok_or("--out needs a directory")?),
            "-h" | "--help" => {
                println!("usage: real_data [DATA_ROOT] [--out DIR]");
                return Ok(());
            }
            _ => root = PathBuf::from(a),
        }
    }
    std::fs::create_dir_all(&out)?;
    let summary = |r: &RealReport| {
        println!("{} ({}, {}): {}", r.dataset, r.method, r.split, r.preprocessing);
        println!("  rank {} of the base regressor, {} rows, cond {:.3e}", r.rank, r.rows, r.condition_number);
        println!("  {:<14} {:>8} {:>8} {:>9} {:>9}", "joint", "R2 val", "floor", "RMS val", "tau RMS");
        for i in 0..r.joints.len() {
            println!("  {:<14} {:>8.3} {:>8.2} {:>9.3} {:>9.3}", r.joints[i], r.validation.r2[i], r.floor_r2[i], r.validation.rms[i], r.validation.tau_rms[i]);
        }
    };
    let mut variants = vec![];

    let tx = load_tx40(&root)?;
    let rep = identify_tx40(&tx, &Tx40Options::default(), None)?;
    summary(&rep);
    std::fs::write(out.join("tx40.json"), serde_json::to_string_pretty(&rep)?)?;
    let tx_variants: Vec<(&str, Tx40Options)> = vec![
        ("WLS", Tx40Options { estimator: Estimator::Wls, ..Default::default() }),
        ("OLS, joint-side drive columns too", Tx40Options { joint_drive: true, ..Default::default() }),
        ("OLS, joint-side equations (K^T tau_m)", Tx40Options { fit_joint_side: true, ..Default::default() }),
        ("OLS, position filter 20 Hz", Tx40Options { cutoff_hz: 20.0, ..Default::default() }),
        ("OLS, position filter 200 Hz", Tx40Options { cutoff_hz: 200.0, ..Default::default() }),
        ("OLS, parallel filter 20 Hz (50 Hz rows)", Tx40Options { decimate_parallel: 10, ..Default::default() }),
        ("OLS, parallel filter 40 Hz (100 Hz rows)", Tx40Options { decimate_parallel: 5, ..Default::default() }),
    ];
    for (name, o) in tx_variants {
        let r = identify_tx40(&tx, &o, None)?;
        variants.push(serde_json::json!({"dataset": "tx40", "variant": name, "r2": r.validation.r2, "rms": r.validation.rms}));
    }

    let robot = load_lwr_robot(&root)?;
    let runs = (1..=3).map(|k| load_lwr_run(&root, k)).collect::<Result<Vec<_>, _>>()?;
    let rep = identify_lwr(&robot, &[&runs[0], &runs[2]], &runs[1], &LwrOptions::default(), None)?;
    summary(&rep);
    std::fs::write(out.join("lwr.json"), serde_json::to_string_pretty(&rep)?)?;
    let lwr_variants: Vec<(&str, LwrOptions)> = vec![
        ("OLS", LwrOptions { estimator: Estimator::Ols, ..Default::default() }),
        ("WLS, the data's velocities and accelerations", LwrOptions { matched_filter_hz: None, ..Default::default() }),
        ("OLS, the data's velocities and accelerations", LwrOptions { matched_filter_hz: None, estimator: Estimator::Ols, ..Default::default() }),
    ];
    for (name, o) in lwr_variants {
        let r = identify_lwr(&robot, &[&runs[0], &runs[2]], &runs[1], &o, None)?;
        variants.push(serde_json::json!({"dataset": "lwr", "variant": name, "r2": r.validation.r2, "rms": r.validation.rms}));
    }
    std::fs::write(out.join("variants.json"), serde_json::to_string_pretty(&variants)?)?;
    println!("wrote {}/tx40.json, lwr.json, variants.json", out.display());
    Ok(())
}

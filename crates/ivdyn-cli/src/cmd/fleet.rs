//! `ivdyn fleet`: the fleet driver is Python (`python/ivdyn/fleet`, on Ray, whose API is
//! Python's); this command runs it (`IVDYN_PYTHON`, else `python3`, `-m ivdyn.fleet`)
//! with the arguments as given, so the command line and `ivdyn.fleet` are one program.
//! An interpreter without ivdyn is a clear error, not a traceback.

use std::process::{Command, ExitCode};

use clap::Args;

use super::R;

#[derive(Args)]
#[command(disable_help_flag = true)]
pub struct FleetArgs {
    /// Arguments of `python -m ivdyn.fleet` (`ivdyn fleet --help` lists them): a manifest
    /// or --glob/--rule/--model, --out DIR, --engine ray|local, --address, --num-cpus, --fdr.
    #[arg(trailing_var_arg = true, allow_hyphen_values = true)]
    args: Vec<String>,
}

pub fn run(a: FleetArgs) -> R<ExitCode> {
    let python = std::env::var("IVDYN_PYTHON").unwrap_or_else(|_| "python3".into());
    let probe = Command::new(&python).args(["-c", "import ivdyn.fleet"]).output().map_err(|e| {
        format!(
            "fleet: cannot run the Python interpreter '{python}' ({e}); set IVDYN_PYTHON to one with ivdyn installed"
        )
    })?;
    if !probe.status.success() {
        return Err(format!(
            "fleet: '{python}' cannot import ivdyn.fleet (pip install 'ivdyn[fleet]', or set IVDYN_PYTHON): {}",
            String::from_utf8_lossy(&probe.stderr).lines().last().unwrap_or("")
        ));
    }
    let status = Command::new(&python)
        .args(["-m", "ivdyn.fleet"])
        .args(&a.args)
        .status()
        .map_err(|e| format!("fleet: cannot run '{python}': {e}"))?;
    Ok(match status.code() {
        Some(0) => ExitCode::SUCCESS,
        Some(c) => ExitCode::from(u8::try_from(c).unwrap_or(1)),
        None => ExitCode::from(1),
    })
}

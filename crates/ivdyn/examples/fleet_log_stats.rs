//! One log's fleet statistics (`app::fleet::log_stats`), timed, for the per-worker time
//! and memory of the fleet's map step (benches/README.md: run it under `/usr/bin/time -v`
//! for the peak resident memory; the simulation is a separate run, so that it is not
//! counted):
//!
//!     cargo run --release -p ivdyn --example fleet_log_stats -- simulate ur5-5min.mcap 300
//!     /usr/bin/time -v target/release/examples/fleet_log_stats stats ur5-5min.mcap
//!
//! `simulate OUT SECONDS`: a 1 kHz six-joint UR5 log (Fourier excitation, friction,
//! 0.1 N m torque noise) as MCAP. `stats LOG`: its statistics (`wls`, Coulomb friction as
//! `sign(qd)`), printing the seconds taken, the rows and the size of the bytes.

use ivdyn::Robot;
use ivdyn::app::identify::CoulombMode;
use ivdyn::app::{self, IdentifyOptions, LogInput, LogSource, Method, SimulateOptions, Trajectory};
use std::path::PathBuf;

fn ur5() -> Result<Robot, Box<dyn std::error::Error>> {
    let p = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../fixtures/ur5.urdf");
    Ok(Robot::from_urdf(p, Some("base_link"), Some("tool0"))?)
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let robot = ur5()?;
    match args.iter().map(String::as_str).collect::<Vec<_>>().as_slice() {
        ["simulate", out, seconds] => {
            let o = SimulateOptions {
                rate_hz: 1000.0,
                duration_s: seconds.parse()?,
                seed: 5,
                fc: Some(vec![2.0, 2.0, 1.5, 0.6, 0.6, 0.4]),
                fv: Some(vec![0.8, 0.8, 0.5, 0.2, 0.2, 0.1]),
                noise_tau: 0.1,
                ..Default::default()
            };
            let log = app::simulate(&robot, &Trajectory::Fourier, &o)?;
            ivdyn::log::write_mcap(PathBuf::from(out).as_path(), &log, &[])?;
            println!("{out}: {} samples", log.t.len());
        }
        ["stats", log] => {
            let opts = IdentifyOptions {
                method: Method::Wls,
                validation_fraction: 0.0,
                coulomb: CoulombMode::Sign,
                ..Default::default()
            };
            let t = std::time::Instant::now();
            let s =
                app::fleet::log_stats(&robot, &LogInput::File(log.into()), &LogSource::default(), log, &opts, true)?;
            let bytes = s.to_bytes()?;
            println!(
                "{log}: {:.2} s, {} rows per joint, {} bytes of statistics",
                t.elapsed().as_secs_f64(),
                s.samples,
                bytes.len()
            );
        }
        _ => return Err("usage: fleet_log_stats simulate OUT SECONDS | fleet_log_stats stats LOG".into()),
    }
    Ok(())
}

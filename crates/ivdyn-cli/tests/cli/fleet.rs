//! `ivdyn fleet` runs the Python driver: an interpreter that cannot be run, or that has
//! no ivdyn, is a clear error naming it and the way out (IVDYN_PYTHON).

use std::process::Command;

fn fleet_with(python: &str) -> (bool, String) {
    let o = Command::new(env!("CARGO_BIN_EXE_ivdyn"))
        .args(["fleet", "manifest.csv", "--out", "out"])
        .env("IVDYN_PYTHON", python)
        .output()
        .unwrap();
    (o.status.success(), String::from_utf8_lossy(&o.stderr).into_owned())
}

#[test]
fn fleet_names_an_interpreter_it_cannot_run() {
    let (ok, err) = fleet_with("/nonexistent/python3");
    assert!(!ok);
    assert!(
        err.contains("cannot run the Python interpreter '/nonexistent/python3'") && err.contains("IVDYN_PYTHON"),
        "{err}"
    );
}

#[test]
fn fleet_names_an_interpreter_without_ivdyn() {
    // `python3 -I` ignores the environment and user site: no ivdyn on its path here
    let dir = std::env::temp_dir().join("ivdyn-cli-fleet-nopy");
    std::fs::create_dir_all(&dir).unwrap();
    let shim = dir.join("python-without-ivdyn");
    std::fs::write(&shim, "#!/bin/sh\nexec python3 -I -c 'import sys; sys.path=[p for p in sys.path if \"site-packages\" not in p]; import ivdyn.fleet'\n")
        .unwrap();
    use std::os::unix::fs::PermissionsExt;
    std::fs::set_permissions(&shim, std::fs::Permissions::from_mode(0o755)).unwrap();
    let (ok, err) = fleet_with(shim.to_str().unwrap());
    assert!(!ok);
    assert!(err.contains("cannot import ivdyn.fleet") && err.contains("pip install 'ivdyn[fleet]'"), "{err}");
}

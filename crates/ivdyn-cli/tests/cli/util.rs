#![allow(dead_code)] // each module uses a part
use std::path::{Path, PathBuf};
use std::process::{Command, Output};

pub fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../..")
}

pub fn fixture(p: &str) -> String {
    root().join("fixtures").join(p).display().to_string()
}

pub fn ivdyn(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_ivdyn")).args(args).arg("--quiet").output().expect("run ivdyn")
}

pub use crate::scratch::Scratch;

/// A fresh, empty directory for one test, removed when it passes.
pub fn tmpdir(name: &str) -> Scratch {
    Scratch::new(&format!("ivdyn_cli_{name}"))
}

pub fn s(p: &Path) -> String {
    p.display().to_string()
}

pub fn ok(out: &Output) {
    assert!(
        out.status.success(),
        "ivdyn failed: {}\nstdout:\n{}\nstderr:\n{}",
        out.status,
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr)
    );
}

pub fn json(p: &Path) -> serde_json::Value {
    serde_json::from_str(&std::fs::read_to_string(p).unwrap()).unwrap()
}

pub fn files_in(d: &Path) -> Vec<String> {
    let mut v: Vec<String> =
        std::fs::read_dir(d).unwrap().map(|e| e.unwrap().file_name().to_string_lossy().to_string()).collect();
    v.sort();
    v
}

pub fn ur5_args() -> Vec<String> {
    vec!["--urdf".into(), fixture("ur5.urdf"), "--base".into(), "base_link".into(), "--tip".into(), "tool0".into()]
}

/// Runs `ivdyn` with owned arguments.
pub fn run(args: Vec<String>) -> Output {
    let a: Vec<&str> = args.iter().map(|s| s.as_str()).collect();
    ivdyn(&a)
}

/// `sub`, the UR5 fixture's `--urdf --base --tip`, then `rest`.
pub fn ur5_cmd(sub: &str, rest: &[&str]) -> Vec<String> {
    let mut v = vec![sub.to_string()];
    v.extend(ur5_args());
    v.extend(rest.iter().map(|s| s.to_string()));
    v
}

//! `ivdyn diagnose` suggests the next command (`next_command` of diagnosis.json, issue 15
//! item 3): run as printed, in a shell, it identifies the named effects and writes the URDF.

use std::process::Command;

use crate::util::{fixture, json, ok, run, s, tmpdir, ur5_cmd};

/// On the MuJoCo UR5 log with hidden Coulomb friction (fixtures/diagnose, truth in its
/// cases.json), copied to a path with a space so that the command must quote it.
#[test]
fn next_command_runs_as_printed() {
    let d = tmpdir("next_command");
    let log = d.join("run 1.mcap");
    std::fs::copy(fixture("diagnose/coulomb.mcap"), &log).unwrap();
    let out = d.join("diag");
    ok(&run(ur5_cmd("diagnose", &["--log", &s(&log), "--out", &s(&out), "--no-report"])));
    let dj = json(&out.join("diagnosis.json"));
    let cmd = dj["next_command"].as_str().expect("next_command in diagnosis.json").to_string();
    assert!(cmd.starts_with("ivdyn identify --urdf "), "{cmd}");
    for part in ["--base base_link", "--tip tool0", "--friction coulomb ", "--write-urdf identified.urdf"] {
        assert!(cmd.contains(part), "{part} not in {cmd}");
    }
    assert!(cmd.contains(&format!("--log '{}'", s(&log))), "the log's path quoted: {cmd}");

    // as a user would: `ivdyn` on the PATH, the command pasted into a shell
    let bin = std::path::Path::new(env!("CARGO_BIN_EXE_ivdyn")).parent().unwrap().to_path_buf();
    let path = format!("{}:{}", s(&bin), std::env::var("PATH").unwrap_or_default());
    let res = Command::new("sh").arg("-c").arg(&cmd).current_dir(&d).env("PATH", path).output().unwrap();
    ok(&res);
    let urdf = std::fs::read_to_string(d.join("identified.urdf")).expect("identified.urdf written");
    // the fixture's URDF has friction 0 everywhere; the truth (cases.json) has Coulomb
    // friction on these three joints, which the command was to identify
    for joint in ["shoulder_lift_joint", "elbow_joint", "wrist_1_joint"] {
        let fc = friction_of(&urdf, joint);
        assert!(fc > 0.0, "{joint}: friction {fc} in identified.urdf");
    }
}

/// The `friction` attribute of `joint`'s `<dynamics>` in a URDF text.
fn friction_of(urdf: &str, joint: &str) -> f64 {
    let at = urdf.find(&format!("<joint name=\"{joint}\"")).unwrap_or_else(|| panic!("no joint {joint}"));
    let rest = &urdf[at..urdf[at..].find("</joint>").map_or(urdf.len(), |e| at + e)];
    let k = rest.find("friction=\"").unwrap_or_else(|| panic!("{joint}: no friction attribute")) + 10;
    rest[k..k + rest[k..].find('"').unwrap()].parse().unwrap()
}

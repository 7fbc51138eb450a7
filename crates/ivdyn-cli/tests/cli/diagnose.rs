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

/// `--max-dictionary-gib`: under 8 MiB for the candidate columns the UR5 Coulomb log (1974
/// conditioned samples, ~6.1 kB of columns each) is diagnosed on two of its four blocks of
/// 500 samples, which the printed details say; a value under 1 MiB is refused, named.
#[test]
fn a_memory_cap_is_printed_with_the_samples_it_kept() {
    let d = tmpdir("max_dictionary");
    let log = fixture("diagnose/coulomb.mcap");
    let out = d.join("diag");
    let res = run(ur5_cmd(
        "diagnose",
        &["--log", &log, "--out", &s(&out), "--no-report", "--max-dictionary-gib", "0.0078125"],
    ));
    ok(&res);
    let text = String::from_utf8_lossy(&res.stdout);
    assert!(text.contains("log diagnosed on 1000 of its 1974 samples"), "{text}");
    let dj = json(&out.join("diagnosis.json"));
    assert_eq!(dj["effects"][0]["name"], "coulomb_friction");
    let bad = run(ur5_cmd("diagnose", &["--log", &log, "--out", &s(&d.join("bad")), "--max-dictionary-gib", "0"]));
    assert!(!bad.status.success());
    let err = String::from_utf8_lossy(&bad.stderr);
    assert!(err.contains("--max-dictionary-gib must be in [0.0009765625, 1024], got 0"), "{err}");
}

/// The `friction` attribute of `joint`'s `<dynamics>` in a URDF text.
fn friction_of(urdf: &str, joint: &str) -> f64 {
    let at = urdf.find(&format!("<joint name=\"{joint}\"")).unwrap_or_else(|| panic!("no joint {joint}"));
    let rest = &urdf[at..urdf[at..].find("</joint>").map_or(urdf.len(), |e| at + e)];
    let k = rest.find("friction=\"").unwrap_or_else(|| panic!("{joint}: no friction attribute")) + 10;
    rest[k..k + rest[k..].find('"').unwrap()].parse().unwrap()
}

//! Issue 16, hangs and memory: hostile inputs that used to overflow the stack, loop
//! forever or allocate gigabytes now end in an error naming what is wrong. Every input is
//! built here, small, so each test runs in well under a second when the limit holds.

use crate::scratch::ScratchFile;
use std::fmt::Write as _;
use std::path::Path;

use ivdyn::robot::urdf;

const FILE: &str = "hostile.urdf";

fn link(name: &str) -> String {
    format!(
        "<link name=\"{name}\"><inertial><mass value=\"1\"/><origin xyz=\"0 0 0.1\"/>\
         <inertia ixx=\"0.01\" iyy=\"0.01\" izz=\"0.01\" ixy=\"0\" ixz=\"0\" iyz=\"0\"/></inertial></link>\n"
    )
}

fn joint(name: &str, kind: &str, parent: &str, child: &str) -> String {
    format!(
        "<joint name=\"{name}\" type=\"{kind}\"><parent link=\"{parent}\"/><child link=\"{child}\"/>\
         <origin xyz=\"0 0 0.2\"/><axis xyz=\"0 0 1\"/><limit lower=\"-3\" upper=\"3\" effort=\"10\" velocity=\"2\"/></joint>\n"
    )
}

fn robot(body: &str) -> String {
    format!("<?xml version=\"1.0\"?>\n<robot name=\"hostile\">\n{body}</robot>\n")
}

fn load(text: &str, base: Option<&str>, tip: Option<&str>) -> String {
    match urdf::load_str(text, Path::new(FILE), base, tip) {
        Ok(r) => panic!("loaded a robot with {} joints from a hostile URDF", r.dof()),
        Err(e) => e.to_string(),
    }
}

/// world -> a -> b -> c, plus `c -> a`... `a` cannot have two parents, so the loop is
/// closed without a second parent: root `w`, a -> b -> c -> a with `a` not under `w`.
#[test]
fn urdf_loop_with_tip_inside_is_an_error_naming_the_links() {
    let mut body = String::new();
    for l in ["w", "a", "b", "c"] {
        body += &link(l);
    }
    body += &joint("j_wx", "revolute", "w", "x");
    body += &link("x");
    body += &joint("j_ab", "revolute", "a", "b");
    body += &joint("j_bc", "revolute", "b", "c");
    body += &joint("j_ca", "revolute", "c", "a");
    let text = robot(&body);
    for (base, tip) in [(None, Some("b")), (Some("a"), Some("c")), (Some("b"), None), (None, None)] {
        let msg = load(&text, base, tip);
        assert!(msg.contains(FILE), "{msg}");
        assert!(msg.contains("loop") && msg.contains("'a'") && msg.contains("'b'") && msg.contains("'c'"), "{msg}");
    }
}

#[test]
fn urdf_self_loop_is_an_error_naming_the_link() {
    // a side link looping on itself, then the root itself looping (no root left)
    let side = link("base") + &link("arm") + &link("tool") + &joint("j1", "revolute", "base", "arm");
    let side = side + &joint("j_self", "fixed", "tool", "tool");
    for (base, tip) in [(None, None), (None, Some("arm")), (Some("tool"), None), (None, Some("tool"))] {
        let msg = load(&robot(&side), base, tip);
        assert!(msg.contains("loop: 'tool' -> 'tool'"), "{msg}");
    }
    let root = link("base") + &link("arm") + &joint("j1", "revolute", "base", "arm");
    let root = root + &joint("j_self", "revolute", "base", "base");
    let msg = load(&robot(&root), None, None);
    assert!(msg.contains("loop: 'base' -> 'base'"), "{msg}");
}

/// A chain of 100,000 movable joints: more than the model's MAX_DOF, refused before any
/// deep walk (it used to overflow the stack in the default-tip search).
#[test]
fn urdf_long_chain_is_refused_without_overflow() {
    let n = 100_000;
    let mut body = String::with_capacity(n * 400);
    body += &link("l0");
    for k in 1..=n {
        let _ = writeln!(body, "<link name=\"l{k}\"/>");
        body += &joint(&format!("j{k}"), "revolute", &format!("l{}", k - 1), &format!("l{k}"));
    }
    let msg = load(&robot(&body), None, None);
    assert!(msg.contains("100000") && msg.contains("12"), "{msg}");
}

/// 30,000 nested elements used to overflow inside urdf-rs's XML parser; refused by the
/// depth pre-scan, naming the file.
#[test]
fn urdf_deep_xml_nesting_is_refused() {
    let depth = 30_000;
    let body = link("base") + &"<extra>".repeat(depth) + &"</extra>".repeat(depth);
    let msg = load(&robot(&body), None, None);
    assert!(msg.contains(FILE) && msg.contains("nest"), "{msg}");
}

/// Normal nesting (comments, CDATA, quoted `>` and `/>` in attributes) stays accepted.
#[test]
fn urdf_depth_scan_accepts_ordinary_files() {
    let body = link("base")
        + "<!-- a <comment> with <tags -->\n<![CDATA[ <not> <xml ]]>\n"
        + &link("arm").replace("<link name=\"arm\">", "<link name=\"arm\" note=\"a > b /> c\">")
        + &joint("j1", "revolute", "base", "arm");
    let r = urdf::load_str(&robot(&body), Path::new(FILE), None, None).unwrap();
    assert_eq!(r.dof(), 1);
}

// ---- logs: huge values, gaps, decimation, sample spacing -------------------------------

use ivdyn::Robot;
use ivdyn::app::stream::{self as st, Streamed};
use ivdyn::app::{self, IdentifyOptions, SimulateOptions, Trajectory};
use ivdyn::log::JointLog;

fn test_arm() -> Robot {
    Robot::from_urdf(concat!(env!("CARGO_MANIFEST_DIR"), "/../../fixtures/test_arm.urdf"), None, Some("tool")).unwrap()
}

/// 4 s at 250 Hz: small, but enough for identify and the diagnosis to run.
fn small_log(robot: &Robot) -> JointLog {
    let o = SimulateOptions { rate_hz: 250.0, duration_s: 4.0, seed: 3, noise_tau: 0.05, ..Default::default() };
    app::simulate(robot, &Trajectory::Fourier, &o).unwrap()
}

fn temp(name: &str) -> ScratchFile {
    ScratchFile::new("ivdyn-hostile", name)
}

/// One velocity of 1e300 used to hang `diagnose` in an SVD without an iteration limit;
/// refused while conditioning, naming the sample and the joint (identify too).
#[test]
fn huge_finite_value_is_refused_naming_sample_and_joint() {
    let robot = test_arm();
    let mut log = small_log(&robot);
    let n = robot.dof();
    log.qd.get_or_insert_with(|| vec![0.0; log.t.len() * n])[100 * n + 1] = 1e300;
    let joint = &robot.joint_names[1];
    let d = ivdyn::diagnose::diagnose(&robot, &log, &Default::default()).map(|_| ()).unwrap_err().to_string();
    assert!(d.contains("sample 100") && d.contains(joint.as_str()) && d.contains("qd"), "{d}");
    let i = app::identify(&robot, &log, &IdentifyOptions::default()).map(|_| ()).unwrap_err().to_string();
    assert!(i.contains("sample 100") && i.contains(joint.as_str()), "{i}");
    let mut log = small_log(&robot);
    log.q[7 * n] = -2e6;
    let i = app::identify(&robot, &log, &IdentifyOptions::default()).map(|_| ()).unwrap_err().to_string();
    assert!(i.contains("sample 7") && i.contains(" q "), "{i}");
}

/// The decompositions give up with an error instead of iterating forever.
#[test]
fn svd_of_non_finite_matrix_is_an_error() {
    let m = nalgebra::DMatrix::from_element(3, 3, f64::NAN);
    let e = ivdyn::linalg::svd(m, true, true, "test matrix").map(|_| ()).unwrap_err().to_string();
    assert!(e.contains("test matrix"), "{e}");
    let m = nalgebra::Matrix4::from_element(f64::INFINITY);
    assert!(ivdyn::linalg::sym_eigen(m, "pseudo-inertia").is_err());
}

/// Two samples 1e6 s apart at 1 ms would be resampled into 1e9 samples (8 GB): refused.
#[test]
fn resampling_across_a_gap_is_refused() {
    let t = [0.0, 1e-3, 2e-3, 1e6];
    let e = ivdyn::dsp::resample_uniform(&t, &[0.0; 4], 1, 1e-3, ivdyn::dsp::Interp::Linear).unwrap_err().to_string();
    assert!(e.contains("4 samples") && e.contains("gap"), "{e}");
    // a log with such a gap is cut into segments, not resampled across it
    let robot = test_arm();
    let mut log = small_log(&robot);
    let half = log.t.len() / 2;
    log.t.iter_mut().skip(half).for_each(|t| *t += 1e6);
    let _ = app::identify(&robot, &log, &IdentifyOptions::default());
}

/// `--decimate 1000000000` used to abort; the factor is bounded by the samples.
#[test]
fn absurd_decimation_is_refused_naming_the_option() {
    let robot = test_arm();
    let log = small_log(&robot);
    let opts = IdentifyOptions { decimate: 1_000_000_000, ..Default::default() };
    let e = app::identify(&robot, &log, &opts).map(|_| ()).unwrap_err().to_string();
    assert!(e.contains("decimate") && e.contains("1000000000"), "{e}"); // the streamed identify (an MCAP with a message count) checks it too
    let path = temp("decimate.mcap");
    ivdyn::log::write_mcap(&path, &log, &[]).unwrap();
    let read = ivdyn::log::ReadOptions::new(&robot.joint_names);
    let e = st::identify_mcap(&robot, &path, None, &read, &opts).map(|_| ()).unwrap_err().to_string();
    assert!(e.contains("decimate") && e.contains("1000000000"), "{e}");
}

/// Samples 1 ns apart in a streamed MCAP: a sample time no arm log has, refused before the
/// filters are designed for a 1 GHz rate.
#[test]
fn nanosecond_sample_spacing_is_refused_when_streaming() {
    let robot = test_arm();
    let mut log = small_log(&robot);
    log.t.iter_mut().enumerate().for_each(|(k, t)| *t = k as f64 * 1e-9);
    let path = temp("ns.mcap");
    ivdyn::log::write_mcap(&path, &log, &[]).unwrap();
    let read = ivdyn::log::ReadOptions::new(&robot.joint_names);
    match st::identify_mcap(&robot, &path, None, &read, &IdentifyOptions::default()) {
        Err(e) => assert!(e.to_string().contains("sample time"), "{e}"),
        Ok(Streamed::Unsupported(why)) => panic!("fell back to the in-memory path: {why}"),
        Ok(Streamed::Done(_)) => panic!("identified a 1 GHz log"),
    }
    let e = app::identify(&robot, &log, &IdentifyOptions::default()).map(|_| ()).unwrap_err().to_string();
    assert!(e.contains("sample time"), "{e}");
}

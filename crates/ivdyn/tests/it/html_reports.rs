//! The HTML reports of `identify` and `payload` (`--report`) on simulated UR5 logs: each
//! page is self-contained (no external `src`/`href`, no script), every image is a PNG of
//! its stated size, the per-joint and parameter tables carry exactly the JSON report's
//! numbers (their `data-v` attributes, parsed, against the JSON file, parsed), and an
//! unwritable report path is a clear error that leaves none of the command's files. The
//! plotted residual is checked against the JSON's RMS on a noise-free log.

use crate::scratch::Scratch;
use std::io::Cursor;
use std::path::{Path, PathBuf};

use base64::Engine as _;
use ivdyn::Robot;
use ivdyn::app::html::Series;
use ivdyn::app::{
    IdentifyJob, IdentifyOutputs, LogInput, LogSource, PayloadJob, SimulateOptions, Trajectory, identify_job,
    payload_job, simulate,
};
use ivdyn::log::JointLog;
use ivdyn::report::PayloadSpec;
use serde_json::Value;

fn ur5() -> Robot {
    let p = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../fixtures/ur5.urdf");
    Robot::from_urdf(p, Some("base_link"), Some("tool0")).unwrap()
}

fn tmpdir(name: &str) -> Scratch {
    Scratch::new(&format!("ivdyn_html_{name}"))
}

/// A 10 s, 500 Hz UR5 log with friction, torque noise `noise` (N m) and optionally a 2 kg payload.
fn log(robot: &Robot, seed: u64, noise: f64, payload: bool) -> JointLog {
    let opts = SimulateOptions {
        fc: Some(vec![2.0, 2.0, 1.5, 0.6, 0.6, 0.4]),
        fv: Some(vec![0.8, 0.8, 0.5, 0.2, 0.2, 0.1]),
        ..sim_opts(seed, noise, payload)
    };
    simulate(robot, &Trajectory::Fourier, &opts).unwrap()
}

/// 10 s at 500 Hz, no friction.
fn sim_opts(seed: u64, noise: f64, payload: bool) -> SimulateOptions {
    SimulateOptions {
        rate_hz: 500.0,
        duration_s: 10.0,
        seed,
        noise_tau: noise,
        payload: payload.then_some(PayloadSpec { mass: 2.0, com: [0.01, -0.02, 0.05], inertia: [0.0; 6] }),
        ..Default::default()
    }
}

/// Every `<img>` is a PNG data URI that decodes to its stated size; nothing else is loaded.
fn check_self_contained(html: &str) {
    assert!(html.starts_with("<!DOCTYPE html>") && html.trim_end().ends_with("</html>"));
    for bad in ["<script", "<link", "url(", "http://", "https://", "<iframe", "<object"] {
        assert!(!html.contains(bad), "the page must not contain {bad}");
    }
    let srcs: Vec<&str> = html.split("src=\"").skip(1).collect();
    assert!(!srcs.is_empty(), "no image");
    for s in &srcs {
        let b64 = s.strip_prefix("data:image/png;base64,").expect("every src is an embedded PNG");
        let b64 = &b64[..b64.find('"').unwrap()];
        let bytes = base64::engine::general_purpose::STANDARD.decode(b64).unwrap();
        let dec = png::Decoder::new(Cursor::new(bytes));
        let reader = dec.read_info().expect("decodes as PNG");
        let (w, h) = (reader.info().width, reader.info().height);
        let tag = &s[s.find('"').unwrap()..][..80];
        assert!(tag.contains(&format!("width=\"{w}\" height=\"{h}\"")), "stated size {tag} vs {w}x{h}");
    }
    for h in html.split("href=\"").skip(1) {
        assert!(h.starts_with('#'), "only links inside the page: {}", &h[..20.min(h.len())]);
    }
}

/// The `data-v` values of each row of the table `id` (rows without any are skipped).
fn table(html: &str, id: &str) -> Vec<Vec<f64>> {
    let start = html.find(&format!("<table id=\"{id}\">")).unwrap_or_else(|| panic!("no table {id}"));
    let body = &html[start..start + html[start..].find("</table>").unwrap()];
    body.split("<tr>")
        .map(|row| {
            row.split("data-v=\"")
                .skip(1)
                .map(|c| {
                    let v = &c[..c.find('"').unwrap()];
                    if v == "null" { f64::NAN } else { v.parse().unwrap() }
                })
                .collect::<Vec<f64>>()
        })
        .filter(|r| !r.is_empty())
        .collect()
}

fn num(v: &Value) -> f64 {
    v.as_f64().unwrap_or(f64::NAN)
}

/// `a == b`, NaN equal to NaN (null in JSON, "null" on the page).
fn same(a: f64, b: f64, what: &str) {
    assert!(a == b || (a.is_nan() && b.is_nan()), "{what}: page {a} vs JSON {b}");
}

fn identify_outputs(d: &Path, report: PathBuf) -> IdentifyOutputs {
    IdentifyOutputs { json: Some(d.join("identify.json")), report: Some(report), ..Default::default() }
}

fn identify_on(robot: &Robot, log: JointLog, outputs: IdentifyOutputs) -> Result<(), ivdyn::Error> {
    let job = IdentifyJob {
        log: LogInput::Arrays(log),
        also: vec![],
        validate: None,
        source: LogSource::default(),
        in_memory: false,
        stream: false,
        opts: Default::default(),
        outputs,
    };
    identify_job(robot, &job).map(|_| ())
}

#[test]
fn identify_report_matches_its_json() {
    let robot = ur5();
    let d = tmpdir("identify");
    identify_on(&robot, log(&robot, 1, 0.1, false), identify_outputs(&d, d.join("identify.html"))).unwrap();
    let html = std::fs::read_to_string(d.join("identify.html")).unwrap();
    let json: Value = serde_json::from_str(&std::fs::read_to_string(d.join("identify.json")).unwrap()).unwrap();
    check_self_contained(&html);
    let joints = json["joints"].as_array().unwrap();
    // 3 figures per joint
    assert_eq!(html.matches("<img ").count(), 3 * joints.len());
    let q = table(&html, "quality-table");
    assert_eq!(q.len(), joints.len());
    let (fit, val) = (&json["fit"], &json["validation"]);
    for (j, row) in q.iter().enumerate() {
        let nrmse = |p: &Value| num(&p["rms"][j]) / num(&p["tau_rms"][j]);
        let want = [
            num(&fit["rms"][j]),
            num(&fit["r2"][j]),
            nrmse(fit),
            num(&val["rms"][j]),
            num(&val["r2"][j]),
            nrmse(val),
            num(&fit["tau_rms"][j]),
        ];
        assert_eq!(row.len(), want.len());
        for (k, (a, b)) in row.iter().zip(want).enumerate() {
            same(*a, b, &format!("quality row {j} column {k}"));
        }
        assert!(html.contains(&format!("<td>{}</td>", joints[j].as_str().unwrap())));
    }
    let base = table(&html, "base-table");
    let jb = json["base"].as_array().unwrap();
    assert_eq!(base.len(), jb.len());
    for (row, b) in base.iter().zip(jb) {
        let want = [num(&b["value"]), num(&b["std"]), num(&b["rel_std_pct"]), num(&b["nominal"])];
        for (a, w) in row.iter().zip(want) {
            same(*a, w, b["name"].as_str().unwrap());
        }
    }
    // the physical verdict lists every link and joint, and the JSON's problems
    assert!(html.contains("id=\"physical-table\""));
    for v in json["physical"]["joints"].as_array().unwrap() {
        assert!(html.contains(v["name"].as_str().unwrap()));
    }
    let consistent = json["physical"]["consistent"].as_bool().unwrap();
    assert_eq!(html.contains("verdict clean"), consistent);
}

#[test]
fn payload_report_matches_its_json() {
    let robot = ur5();
    let d = tmpdir("payload");
    let job = PayloadJob {
        log: LogInput::Arrays(log(&robot, 2, 0.1, true)),
        before: Some(LogInput::Arrays(log(&robot, 1, 0.1, false))),
        source: LogSource::default(),
        opts: Default::default(),
        json: Some(d.join("payload.json")),
        mjcf: None,
        report: Some(d.join("payload.html")),
        urdf: None,
        torque_constant_prior: Default::default(),
    };
    payload_job(&robot, &job).unwrap();
    let html = std::fs::read_to_string(d.join("payload.html")).unwrap();
    let json: Value = serde_json::from_str(&std::fs::read_to_string(d.join("payload.json")).unwrap()).unwrap();
    check_self_contained(&html);
    let est = table(&html, "estimate-table");
    let mut want = vec![(num(&json["mass"]), num(&json["mass_std"]))];
    for k in 0..3 {
        want.push((num(&json["com"][k]), num(&json["com_std"][k])));
    }
    // the page lists the inertia in ivdyn's order, the JSON file in URDF's
    let urdf = |key: &str| ivdyn::core::inertia_from_urdf(std::array::from_fn(|k| num(&json[key][k])));
    for (v, s) in urdf("inertia").into_iter().zip(urdf("inertia_std")) {
        want.push((v, s));
    }
    assert_eq!(est.len(), want.len());
    for (k, (row, (v, s))) in est.iter().zip(want).enumerate() {
        same(row[0], v, &format!("estimate row {k} value"));
        same(row[1], s, &format!("estimate row {k} std"));
    }
    let q = table(&html, "quality-table");
    assert_eq!(q.len(), json["joints"].as_array().unwrap().len());
    for (j, row) in q.iter().enumerate() {
        let (b, a) = (num(&json["rms_before"][j]), num(&json["rms_after"][j]));
        same(row[0], b, "rms_before");
        same(row[1], a, "rms_after");
        same(row[2], 100.0 * (1.0 - a / b), "reduction");
    }
    same(table(&html, "physical-table")[0][0], num(&json["physical"]["mahalanobis2"]), "mahalanobis2");
}

#[test]
fn unwritable_report_leaves_no_file() {
    let robot = ur5();
    let d = tmpdir("unwritable");
    let bad = d.join("no/such/dir/identify.html");
    let e = identify_on(&robot, log(&robot, 3, 0.1, false), identify_outputs(&d, bad.clone())).unwrap_err();
    let msg = e.to_string();
    assert!(msg.contains("no/such/dir"), "the error names the report's path: {msg}");
    let left: Vec<_> = std::fs::read_dir(&d).unwrap().map(|e| e.unwrap().file_name()).collect();
    assert!(left.is_empty(), "neither the JSON nor a partial page (nor staging): {left:?}");
}

/// RMS of `x`.
fn rms(x: &[f64]) -> f64 {
    (x.iter().map(|v| v * v).sum::<f64>() / x.len() as f64).sqrt()
}

/// The plotted residual against the nominal model (the URDF) on a noise-free log with a
/// 2 kg payload is the payload's torque: its RMS per joint equals the JSON `rms_before`
/// (the same residual after the parallel filter, decimated, without the filter edges) up
/// to what the edges can change. The trajectory's harmonics are far below the filter's
/// cut-off, so the filter passes the residual unchanged; leaving out a share `e` of the
/// samples changes the mean square by at most `e (peak^2 / rms^2)` relatively, the RMS by
/// half that; decimating a signal this smooth changes its mean square by far less than 1 %,
/// the margin added.
#[test]
fn plotted_residual_is_the_json_residual() {
    let robot = ur5();
    let d = tmpdir("series");
    // no friction, which the URDF lacks: the residual is the payload's torque alone
    let after = simulate(&robot, &Trajectory::Fourier, &sim_opts(4, 0.0, true)).unwrap();
    let job = PayloadJob {
        log: LogInput::Arrays(after.clone()),
        before: None,
        source: LogSource::default(),
        opts: Default::default(),
        json: Some(d.join("p.json")),
        mjcf: None,
        report: None,
        urdf: None,
        torque_constant_prior: Default::default(),
    };
    let rep = payload_job(&robot, &job).unwrap().report;
    let s = Series::of(&[&robot], &after, &Default::default()).unwrap();
    // the measured series is the log's torque, sample for sample (uniform stamps: nothing resampled)
    assert_eq!(s.len(), after.t.len());
    assert_eq!(&s.measured, after.tau.as_ref().unwrap());
    let edge = (2.0 * 20.0f64.min(rep.samples as f64 / 100.0) / rep.samples as f64).max(2.0 / s.len() as f64);
    for j in 0..robot.dof() {
        let r = s.residual(0, j);
        let (plotted, peak) = (rms(&r), r.iter().fold(0.0f64, |m, v| m.max(v.abs())));
        let tol = 0.5 * edge * (peak / plotted).powi(2) + 0.01;
        let rel = (plotted / rep.rms_before[j] - 1.0).abs();
        assert!(rel <= tol, "joint {j}: plotted RMS {plotted} vs JSON {} ({rel:.4} > {tol:.4})", rep.rms_before[j]);
    }
}

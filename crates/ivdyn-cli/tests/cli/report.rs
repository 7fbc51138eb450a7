//! `identify --report` and `payload --report` from the command line: a self-contained page
//! (every image an embedded PNG, no external link) whose per-joint table holds the `--json`
//! report's numbers; a report path in a folder that does not exist fails, naming it, and
//! leaves none of the command's files.
use crate::util;
use util::*;

use std::path::Path;

/// The `data-v` numbers of the first row of table `id` after its header.
fn first_row(html: &str, id: &str) -> Vec<f64> {
    let at = html.find(&format!("<table id=\"{id}\">")).unwrap_or_else(|| panic!("no table {id}"));
    let row = html[at..].split("<tr>").nth(2).unwrap();
    row.split("data-v=\"").skip(1).map(|c| c[..c.find('"').unwrap()].parse().unwrap()).collect()
}

fn self_contained(html: &str) {
    assert!(html.starts_with("<!DOCTYPE html>"));
    assert!(!html.contains("<script") && !html.contains("http://") && !html.contains("https://"));
    let srcs = html.matches("src=\"").count();
    assert!(srcs > 0 && srcs == html.matches("src=\"data:image/png;base64,iVBORw0KGgo").count(), "PNG data URIs only");
}

fn page(p: &Path) -> String {
    std::fs::read_to_string(p).unwrap()
}

#[test]
fn identify_and_payload_reports() {
    let d = tmpdir("report");
    let p = |f: &str| s(&d.join(f));
    let log = fixture("logs/ur5_500hz.mcap");
    ok(&run(ur5_cmd("identify", &["--log", &log, "--json", &p("i.json"), "--report", &p("i.html")])));
    let (html, js) = (page(&d.join("i.html")), json(&d.join("i.json")));
    self_contained(&html);
    let row = first_row(&html, "quality-table");
    assert_eq!(row[0], js["fit"]["rms"][0].as_f64().unwrap());
    assert_eq!(row[1], js["fit"]["r2"][0].as_f64().unwrap());
    assert_eq!(row[3], js["validation"]["rms"][0].as_f64().unwrap());

    let after = p("after.mcap");
    let sim = [
        "--seed",
        "21",
        "--duration",
        "10",
        "--payload-mass",
        "2",
        "--payload-com",
        "0.01,-0.02,0.05",
        "--out",
        &after,
    ];
    ok(&run(ur5_cmd("simulate", &sim)));
    ok(&run(ur5_cmd("payload", &["--log", &after, "--json", &p("p.json"), "--report", &p("p.html")])));
    let (html, js) = (page(&d.join("p.html")), json(&d.join("p.json")));
    self_contained(&html);
    let mass = first_row(&html, "estimate-table");
    assert_eq!(mass[0], js["mass"].as_f64().unwrap());
    assert_eq!(mass[1], js["mass_std"].as_f64().unwrap());
    assert_eq!(first_row(&html, "quality-table")[0], js["rms_before"][0].as_f64().unwrap());
}

#[test]
fn unwritable_report_fails_leaving_nothing() {
    let d = tmpdir("report_fail");
    let log = fixture("logs/ur5_500hz.mcap");
    let (j, r) = (s(&d.join("i.json")), s(&d.join("no/i.html")));
    let out = run(ur5_cmd("identify", &["--log", &log, "--json", &j, "--report", &r]));
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(1), "{err}");
    assert!(err.contains("no/i.html"), "the error names the report: {err}");
    assert!(files_in(&d).is_empty(), "no JSON, no partial page, no staging folder: {:?}", files_in(&d));
}

//! `ivdyn identify --write-mjcf` and `ivdyn payload --write-mjcf`: the MJCF and its side file
//! are written with the parameter file's values; parameters that are not physically
//! consistent are refused naming the link, with none of the command's files written.
//! MuJoCo loads the file in python/tests_io/test_mjcf_export.py.
use crate::util;
use util::*;

/// Attribute `attr` (a number) of the first element of `xml` starting with `head`.
fn attr_of(xml: &str, head: &str, attr: &str) -> f64 {
    let start = xml.find(head).unwrap_or_else(|| panic!("no {head}"));
    let elem = &xml[start..start + xml[start..].find('>').unwrap()];
    let key = format!(" {attr}=\"");
    let v = &elem[elem.find(&key).unwrap_or_else(|| panic!("no {attr} in {elem}")) + key.len()..];
    v[..v.find('"').unwrap()].parse().unwrap()
}

#[test]
fn identify_writes_the_mjcf_with_the_parameter_files_values() {
    let d = tmpdir("mjcf_identify");
    let (xml, params) = (d.join("ur5.xml"), d.join("p.json"));
    let log = fixture("logs/ur5_500hz.mcap");
    let a = ur5_cmd(
        "identify",
        &["--log", &log, "--consistent", "--coulomb", "sign", "--write-mjcf", &s(&xml), "--out-params", &s(&params)],
    );
    ok(&run(a));
    assert_eq!(files_in(&d), ["p.json", "ur5.xml", "ur5.xml.json"]);
    let text = std::fs::read_to_string(&xml).unwrap();
    let p = json(&params);
    let joints: Vec<String> = serde_json::from_value(p["joints"].clone()).unwrap();
    let theta: Vec<f64> = serde_json::from_value(p["theta"].clone()).unwrap();
    let n = joints.len();
    let side = json(&d.join("ur5.xml.json"));
    for (j, name) in joints.iter().enumerate() {
        let drive = &theta[10 * n + 4 * j..10 * n + 4 * j + 4]; // fc, fv, ia, tau0
        let joint = format!("<joint name=\"{name}\"");
        assert_eq!(attr_of(&text, &joint, "frictionloss"), drive[0], "{name}");
        assert_eq!(attr_of(&text, &joint, "damping"), drive[1], "{name}");
        assert_eq!(attr_of(&text, &joint, "armature"), drive[2], "{name}");
        assert_eq!(side["tau0"][j].as_f64().unwrap(), drive[3], "{name}");
        // the body's mass is the link's first parameter
        let link = p["names"][10 * j].as_str().unwrap().trim_end_matches(".m");
        let start = text.find(&format!("<body name=\"{link}\"")).unwrap();
        assert_eq!(attr_of(&text[start..], "<inertial ", "mass"), theta[10 * j], "{link}");
    }
}

#[test]
fn inconsistent_parameters_are_refused_and_nothing_written() {
    let d = tmpdir("mjcf_refused");
    let p = |f: &str| s(&d.join(f));
    // the least-squares parameters of this log have a link that is not a body (see
    // cli/outputs.rs: the URDF write-back refuses its negative mass)
    let a = ur5_cmd(
        "identify",
        &["--log", &fixture("logs/ur5_500hz.mcap"), "--out-params", &p("p.json"), "--write-mjcf", &p("u.xml")],
    );
    let out = run(a);
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(1), "{err}");
    assert!(err.contains("MJCF export refused") && err.contains("link '") && err.contains("--consistent"), "{err}");
    assert!(files_in(&d).is_empty(), "{:?}", files_in(&d));
}

//! `ivdyn identify --friction ... --no-armature --no-offset`: the flags choose which drive
//! parameters are in the model, and that changes the fit the way physics says it must.
use crate::util;
use util::*;

/// Identifies `log` with `flags`; returns (base parameter names, drive_terms, worst
/// validation RMS, the parameter file).
fn identify(
    d: &std::path::Path,
    log: &std::path::Path,
    tag: &str,
    flags: &[&str],
) -> (Vec<String>, Vec<String>, f64, ivdyn::report::ParamsFile) {
    let (rep, par) = (d.join(format!("{tag}.json")), d.join(format!("{tag}.params.json")));
    let mut a =
        vec!["--log", log.to_str().unwrap(), "--json", rep.to_str().unwrap(), "--out-params", par.to_str().unwrap()];
    a.extend_from_slice(flags);
    ok(&run(ur5_cmd("identify", &a)));
    let r = json(&rep);
    let names = r["base"].as_array().unwrap().iter().map(|b| b["name"].as_str().unwrap().to_string()).collect();
    let terms = r["drive_terms"].as_array().unwrap().iter().map(|t| t.as_str().unwrap().to_string()).collect();
    let worst = r["validation"]["rms"].as_array().unwrap().iter().map(|v| v.as_f64().unwrap()).fold(0.0, f64::max);
    let pf = serde_json::from_value(r["params"].clone()).unwrap();
    (names, terms, worst, pf)
}

fn mentions(names: &[String], suffix: &str) -> bool {
    names.iter().any(|n| n.split(['+', '-', ' ', '*']).any(|t| t.ends_with(suffix)))
}

#[test]
fn friction_flags_choose_the_drive_parameters() {
    let d = tmpdir("friction");
    let (clean, rough) = (d.join("clean.mcap"), d.join("rough.mcap"));
    // the URDF has no friction: `clean` is rigid-body only; `rough` adds Coulomb and viscous
    ok(&run(ur5_cmd(
        "simulate",
        &["--noise", "0.05", "--duration", "12", "--seed", "8", "--out", clean.to_str().unwrap()],
    )));
    ok(&run(ur5_cmd(
        "simulate",
        &[
            "--noise",
            "0.05",
            "--duration",
            "12",
            "--seed",
            "8",
            "--fc",
            "2,2,1.5,0.6,0.6,0.4",
            "--fv",
            "0.8,0.8,0.5,0.2,0.2,0.1",
            "--out",
            rough.to_str().unwrap(),
        ],
    )));

    let rigid = ["--friction", "none", "--no-armature", "--no-offset"];
    let (names, terms, worst_clean_none, pf) = identify(&d, &clean, "clean_none", &rigid);
    assert!(terms.is_empty(), "{terms:?}");
    for sfx in [".fc", ".fv", ".ia", ".tau0"] {
        assert!(!mentions(&names, sfx), "{sfx} in {names:?}");
    }
    // parameters left out keep their nominal (URDF) values: zero friction
    for (n, v) in pf.names.iter().zip(&pf.theta) {
        if n.ends_with(".fc") || n.ends_with(".fv") || n.ends_with(".ia") || n.ends_with(".tau0") {
            assert_eq!(*v, 0.0, "{n}");
        }
    }
    // the rigid-body model is the true model of `clean`: residual at the filtered noise level
    assert!(worst_clean_none < 0.05, "{worst_clean_none}");

    let (names_all, terms_all, _, _) = identify(&d, &clean, "clean_all", &[]);
    assert_eq!(terms_all, ["fc", "fv", "ia", "tau0"]);
    assert!(mentions(&names_all, ".fc") && mentions(&names_all, ".fv"), "{names_all:?}");
    assert!(names_all.len() > names.len() + 6, "{} vs {}", names_all.len(), names.len());

    let (names_c, terms_c, _, _) = identify(&d, &clean, "clean_coulomb", &["--friction", "coulomb"]);
    assert_eq!(terms_c, ["fc", "ia", "tau0"]);
    assert!(mentions(&names_c, ".fc") && !mentions(&names_c, ".fv"), "{names_c:?}");

    // on the log with friction, leaving friction out of the model must show: a 2 N m
    // Coulomb term flips sign with the velocity and no rigid-body parameter can mimic it
    let (_, _, worst_rough_none, _) = identify(&d, &rough, "rough_none", &rigid);
    let (_, _, worst_rough_all, pf_all) = identify(&d, &rough, "rough_all", &[]);
    eprintln!(
        "validation worst rms: rough log, rigid model {worst_rough_none:.3} N m, with friction {worst_rough_all:.4} N m"
    );
    assert!(worst_rough_all < 0.05, "{worst_rough_all}");
    assert!(worst_rough_none > 0.3, "{worst_rough_none}");
    // and with friction in the model, shoulder_pan's Coulomb coefficient is found
    let k = pf_all.names.iter().position(|n| n == "shoulder_pan_joint.fc").unwrap();
    assert!((pf_all.theta[k] - 2.0).abs() < 0.05, "fc = {}", pf_all.theta[k]);

    // bad combinations are refused
    let out = run(ur5_cmd("identify", &["--log", clean.to_str().unwrap(), "--friction", "none,coulomb"]));
    assert!(!out.status.success());
    assert!(String::from_utf8_lossy(&out.stderr).contains("--friction none"));
    let _ = std::fs::remove_dir_all(&d);
}

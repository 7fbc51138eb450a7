//! The diagnosis outputs on a small hand-made `Diagnosis` (2 joints, 500 samples, one
//! step): `report.html` is self-contained (every image a PNG data URI of its stated size),
//! shows the verdict, the joint names and the numbers in the documented format;
//! `residuals.mcap` reads back with ivdyn's reader on every topic with the trace values.
//! Expected strings follow the format rule of `report::fmt_num` (3 significant digits,
//! docs/diagnose.md), written out by hand here.

use crate::scratch::Scratch;
use std::io::Cursor;

use base64::Engine as _;
use ivdyn::diagnose::report::{self, write_html, write_mcap_stamped};
use ivdyn::diagnose::{
    CandidateScore, DetectableJson, Diagnosis, DiagnosisJson, EffectJson, EffectKind, JointScore, LogInfo, Regimes,
    Step, Traces,
};
use ivdyn::log::mcap::list_topics;
use ivdyn::log::{ReadOptions, Source, for_each_sample};

const T: usize = 500;
const N: usize = 2;
/// A joint name with markup characters: the page must escape it.
const J1: &str = "wrist<1>";

fn regimes(rms: f64, rev: f64) -> Regimes {
    Regimes {
        rms,
        rms_reversal: rev,
        rms_high_acc: rms,
        rms_rest: rms,
        reversal_jump: 2.0 * rms,
        reversals: 3,
        corr_q: 0.1,
        corr_qd: 0.8,
        corr_qdd: -0.05,
        mean: 0.0,
    }
}

fn score(significant: bool, f: f64, p: f64, gain: f64) -> JointScore {
    let rejected_by = (!significant).then(|| format!("F test: F {f}, p {p} >= alpha 1e-3"));
    JointScore { f, p, heldout_gain: gain, effect_rms: 0.25, explained_rms: 0.25, significant, rejected_by }
}

/// Joint 0 `j_one`, joint 1 `wrist<1>`; q = sin(2 pi t + j), qd, qdd its derivatives;
/// the nominal model misses a Coulomb friction of 0.5 and 1.25 N m, which step 1 adds.
fn synthetic() -> Diagnosis {
    let joints = vec!["j_one".to_string(), J1.to_string()];
    let t: Vec<f64> = (0..T).map(|k| k as f64 * 1e-3).collect();
    let w = 2.0 * std::f64::consts::PI;
    let at = |f: &dyn Fn(f64, usize) -> f64| -> Vec<f64> { (0..T * N).map(|i| f(t[i / N], i % N)).collect() };
    let q = at(&|t, j| (w * t + j as f64).sin());
    let qd = at(&|t, j| w * (w * t + j as f64).cos());
    let qdd = at(&|t, j| -w * w * (w * t + j as f64).sin());
    let fc = [0.5, 1.25];
    // deterministic "noise": a fast pattern of +-0.01
    let noise = at(&|t, j| 0.01 * ((t * 1e3) as usize % 3) as f64 - 0.01 + 0.001 * j as f64);
    let rigid = at(&|t, j| 3.0 * (w * t + j as f64).sin() + 0.2 * j as f64);
    let tau: Vec<f64> = (0..T * N).map(|i| rigid[i] + fc[i % N] * qd[i].signum() + noise[i]).collect();
    let nominal = rigid.clone();
    let fin: Vec<f64> = (0..T * N).map(|i| rigid[i] + fc[i % N] * qd[i].signum()).collect();

    let mut params = serde_json::Map::new();
    params.insert("fc".into(), serde_json::json!([0.5, 1.25]));
    let cands = vec![
        CandidateScore {
            effect: EffectKind::Coulomb,
            per_joint: vec![score(true, 812.25, 3.2e-9, 0.873), score(true, 4321.0, 0.0, 0.95)],
            joints: vec![0, 1],
            score: 42.5,
            accepted: true,
            reason: "largest held-out gain".into(),
        },
        CandidateScore {
            effect: EffectKind::Viscous,
            per_joint: vec![score(false, 1.5, 0.22, -0.012), score(true, 50.0, 1e-6, 0.3)],
            joints: vec![1],
            score: 3.0,
            accepted: false,
            reason: "explains less than Coulomb friction".into(),
        },
    ];
    let final_cands = vec![CandidateScore {
        effect: EffectKind::Armature,
        per_joint: vec![score(false, 0.5, 0.48, 0.001), score(false, 1.1, 0.29, -0.002)],
        joints: vec![],
        score: 0.0,
        accepted: false,
        reason: "not significant on any joint".into(),
    }];
    Diagnosis {
        json: DiagnosisJson {
            effects: vec![EffectJson {
                name: "coulomb_friction".into(),
                joints: joints.clone(),
                parameters: params,
                parameters_std: serde_json::json!({"fc": [0.005, 0.0125]}).as_object().unwrap().clone(),
                rms_before: vec![0.512, 1.25],
                rms_after: vec![0.0225, 0.0478],
            }],
            baseline_rms: vec![0.512, 1.25],
            final_rms: vec![0.0225, 0.0478],
            joints: joints.clone(),
            nominal_refit: None,
            next_command: Some("ivdyn identify --urdf 'robots/my arm.urdf' --friction coulomb".into()),
            detectable: Some(DetectableJson {
                noise_std: 2.0,
                sigma: vec![0.015, 0.0478],
                torque_offset: vec![Some(0.04), None],
                asymmetric_coulomb_friction: vec![Some(0.08), Some(1.5)],
                joint_spring: vec![Some(0.2), Some(0.3)],
                torque_gain: vec![Some(0.01), Some(0.02)],
                armature: vec![Some(0.001), Some(0.002)],
            }),
        },
        steps: vec![Step {
            effect: EffectKind::Coulomb,
            joints: vec![0, 1],
            evidence: vec![
                "joint wrist<1> residual jumps by 2.5 N m at every velocity reversal: Coulomb friction".into(),
            ],
            candidates: cands,
            rms_before: vec![0.512, 1.25],
            rms_after: vec![0.0225, 0.0478],
        }],
        final_candidates: final_cands,
        noise_std: vec![0.015, 0.0478],
        regimes_before: vec![regimes(0.512, 0.7), regimes(1.25, 1.5)],
        regimes_after: vec![regimes(0.0225, f64::NAN), regimes(0.0478, 0.05)],
        verdict: "Missing: Coulomb friction on j_one, wrist<1>".into(),
        details: vec!["missing: Coulomb friction on j_one, wrist<1>".into()],
        traces: Traces { t, q, qd, qdd, tau, predicted: vec![nominal, fin] },
        info: LogInfo {
            file: "logs/run & test.mcap".into(),
            urdf: "robots/arm.urdf".into(),
            samples: T,
            duration: 0.499,
            rate: 1000.0,
            velocity_in_log: true,
            velocity: vec![],
            cutoff_hz: 20.0,
            align_samples: 0.0,
        },
    }
}

/// Text of the HTML between the first `<table id="{id}"` and its `</table>`, one string
/// per row with tags removed and cells separated by `|`.
fn table_rows(html: &str, id: &str) -> Vec<String> {
    let start = html.find(&format!("<table id=\"{id}\"")).unwrap_or_else(|| panic!("no table {id}"));
    let body = &html[start..start + html[start..].find("</table>").unwrap()];
    body.split("<tr")
        .skip(1)
        .map(|row| {
            let mut s = String::new();
            let mut in_tag = false;
            for c in row.chars() {
                match c {
                    '<' => {
                        in_tag = true;
                        // a new cell starts a new field
                        s.push('|');
                    }
                    '>' => in_tag = false,
                    c if !in_tag => s.push(c),
                    _ => {}
                }
            }
            s.split('|').map(|c| c.trim()).filter(|c| !c.is_empty()).collect::<Vec<_>>().join("|")
        })
        .collect()
}

/// The `src`, `width`, `height` of every `<img>`.
fn images(html: &str) -> Vec<(String, u32, u32)> {
    let attr = |tag: &str, name: &str| -> String {
        let k = tag.find(&format!(" {name}=\"")).unwrap_or_else(|| panic!("<img> without {name}")) + name.len() + 3;
        tag[k..k + tag[k..].find('"').unwrap()].to_string()
    };
    html.match_indices("<img")
        .map(|(i, _)| {
            let tag = &html[i..i + html[i..].find('>').unwrap()];
            (attr(tag, "src"), attr(tag, "width").parse().unwrap(), attr(tag, "height").parse().unwrap())
        })
        .collect()
}

#[test]
fn html_is_self_contained_and_complete() {
    let dir = tempdir("html");
    let d = synthetic();
    write_html(&d, &dir).unwrap();
    let html = std::fs::read_to_string(dir.join("report.html")).unwrap();
    assert!(html.starts_with("<!DOCTYPE html>"));

    // Nothing outside the file: no network, no external stylesheet/script/font.
    for bad in ["http://", "https://", "<script", "<link", "url(", "@import", "<iframe", "<object"] {
        assert!(!html.contains(bad), "report.html contains {bad}");
    }
    let srcs = html.matches("src=").count();
    let imgs = images(&html);
    assert_eq!(srcs, imgs.len(), "every src= belongs to an <img>");
    // the RMS bar chart + 3 figures per joint
    assert_eq!(imgs.len(), 1 + 3 * N);
    let nominal_blue = [31u8, 119, 180];
    for (src, w, h) in &imgs {
        let b64 = src.strip_prefix("data:image/png;base64,").expect("image is an inline PNG");
        let bytes = base64::engine::general_purpose::STANDARD.decode(b64).expect("valid base64");
        let mut reader = png::Decoder::new(Cursor::new(&bytes)).read_info().expect("valid PNG header");
        let info = reader.info();
        assert_eq!((info.width, info.height), (*w, *h), "stated size = PNG size");
        assert!(*w >= 800 && *h >= 300, "readable size, got {w}x{h}");
        let mut buf = vec![0; reader.output_buffer_size().unwrap()];
        let frame = reader.next_frame(&mut buf).expect("PNG decodes");
        assert_eq!(frame.color_type, png::ColorType::Rgb);
        let px = &buf[..frame.buffer_size()];
        // Every figure draws the nominal model (bars, lines or points in its colour;
        // points are blended at 35 % so look for exact pixels of lines/bars/legend swatches).
        assert!(px.chunks(3).any(|p| p == nominal_blue), "figure without the nominal model's colour");
        // and text/axes in black-ish
        assert!(px.chunks(3).filter(|p| p.iter().all(|&c| c < 60)).count() > 500, "figure without text");
    }

    // The verdict and every joint name, escaped.
    assert!(html.contains("Missing: Coulomb friction on j_one, wrist&lt;1&gt;"));
    assert!(html.contains("j_one") && html.contains("wrist&lt;1&gt;") && !html.contains("wrist<1>"));
    assert!(html.contains("logs/run &amp; test.mcap") && html.contains("robots/arm.urdf"));
    // the details under the headline, and each rejected row's rule with its numbers
    assert!(html.contains("<li>missing: Coulomb friction on j_one, wrist&lt;1&gt;</li>"));
    assert!(html.contains("<th>rejected by</th>") && html.contains("F test: F 1.1, p 0.29 &gt;= alpha 1e-3"));

    // RMS table: joint | nominal | after step 1 | final | noise | final/noise
    let rms = table_rows(&html, "rms-table");
    assert_eq!(rms.len(), 1 + N);
    assert!(rms[0].contains("N m"), "units in the header: {}", rms[0]);
    assert_eq!(rms[1], "j_one|0.512|0.0225|0.0225|0.0150|1.50");
    assert_eq!(rms[2], "wrist&lt;1&gt;|1.25|0.0478|0.0478|0.0478|1.00");

    // Parameters with units, evidence, candidate scores.
    assert!(html.contains("Coulomb friction level <span class=\"unit\">(N m)</span>"));
    // each value with twice its standard error, and the next command
    assert!(html.contains(">0.500 \u{b1} 0.0100<") && html.contains(">1.25 \u{b1} 0.0250<"));
    assert!(html.contains("\u{b1} 2 standard errors"));
    assert!(html.contains(
        "<p id=\"next-command\">Next command: <code>ivdyn identify --urdf &#39;robots/my arm.urdf&#39; --friction coulomb</code></p>"
    ));
    assert!(html.contains("residual jumps by 2.5 N m at every velocity reversal"));
    for s in [
        ">812<",
        ">3.20e-9<",
        "87.3\u{a0}%",
        "&lt; 1e-16",
        ">4321<",
        "-1.2\u{a0}%",
        ">0.220<",
        "largest held-out gain",
        "explains less than Coulomb friction",
        "not significant on any joint",
    ] {
        assert!(html.contains(s), "missing {s}");
    }

    // What the log can show: per joint, a dash where the motion shows none of it.
    let det = table_rows(&html, "detectable-table");
    assert_eq!(det.len(), 1 + N);
    assert_eq!(det[1], "j_one|0.0400|0.0800|0.200|0.0100|0.00100");
    assert_eq!(det[2], "wrist&lt;1&gt;|\u{2013}|1.50|0.300|0.0200|0.00200");

    // Regimes: NaN shown as a dash, correlations signed.
    let reg = table_rows(&html, "regimes-table");
    assert_eq!(reg.len(), 1 + 2 * N);
    assert_eq!(reg[2], "final|0.0225|\u{2013}|0.0225|0.0225|0.0450|3|+0.10|+0.80|-0.05|0");
}

/// The diagnosis of a log with nothing missing: no step, final = nominal.
fn clean() -> Diagnosis {
    let mut d = synthetic();
    d.json.effects.clear();
    d.steps.clear();
    d.traces.predicted.truncate(1);
    d.json.final_rms = d.json.baseline_rms.clone();
    d.regimes_after = d.regimes_before.clone();
    d.verdict = "Nothing significant missing".into();
    d
}

#[test]
fn clean_diagnosis_has_no_step() {
    let dir = tempdir("clean");
    let d = clean();
    write_html(&d, &dir).unwrap();
    let html = std::fs::read_to_string(dir.join("report.html")).unwrap();
    assert!(html.contains("verdict clean") && html.contains("Nothing significant missing"));
    assert!(html.contains("No effect was added"));
    assert_eq!(images(&html).len(), 1 + 3 * N);
    // joint | nominal | final | noise | final/noise
    let rms = table_rows(&html, "rms-table");
    assert_eq!(rms[1], "j_one|0.512|0.512|0.0150|34.1");
    write_mcap_stamped(&d, &d.json.joints, 0, &dir).unwrap();
    let topics = list_topics(dir.join("residuals.mcap")).unwrap();
    assert_eq!(topics.len(), 5, "no step topic: {topics:?}");
    assert!(topics.iter().all(|t| !t.0.contains("step")));
}

#[test]
fn payload_parameters_and_a_single_sample() {
    let dir = tempdir("payload");
    let mut d = synthetic();
    d.steps[0].effect = EffectKind::Payload;
    d.json.effects[0].name = "payload".into();
    d.json.effects[0].joints.clear();
    let p =
        serde_json::json!({"mass": 2.0, "com": [0.01, -0.02, 0.05], "inertia": [0.004, 0.0, 0.0, 0.004, 0.0, 0.002]});
    d.json.effects[0].parameters = p.as_object().unwrap().clone();
    write_html(&d, &dir).unwrap();
    let html = std::fs::read_to_string(dir.join("report.html")).unwrap();
    assert!(html.contains("Step 1: payload on the last link <span"));
    for s in [
        "mass <span class=\"unit\">(kg)</span>",
        ">2.00<",
        "[0.0100, -0.0200, 0.0500]",
        "[0.00400, 0, 0, 0.00400, 0, 0.00200]",
        "kg m\u{b2}",
    ] {
        assert!(html.contains(s), "missing {s}");
    }
    // one sample: still a page with every figure
    let mut d = synthetic();
    let tr = &mut d.traces;
    tr.t.truncate(1);
    for a in [&mut tr.q, &mut tr.qd, &mut tr.qdd, &mut tr.tau].into_iter().chain(tr.predicted.iter_mut()) {
        a.truncate(N);
    }
    write_html(&d, &dir).unwrap();
    let html = std::fs::read_to_string(dir.join("report.html")).unwrap();
    assert_eq!(images(&html).len(), 1 + 3 * N);
}

#[test]
fn bad_shapes_are_refused_and_leave_no_file() {
    let dir = tempdir("bad");
    let mut d = synthetic();
    d.traces.predicted[1].pop();
    let e = write_html(&d, &dir).unwrap_err().to_string();
    assert!(e.contains("traces.predicted[1]") && e.contains("1000") && e.contains("999"), "{e}");
    let e = write_mcap_stamped(&d, &d.json.joints.clone(), 0, &dir).unwrap_err().to_string();
    assert!(e.contains("traces.predicted[1]"), "{e}");
    let mut d = synthetic();
    d.steps.clear(); // one effect in the JSON, no step
    assert!(write_html(&d, &dir).unwrap_err().to_string().contains("traces.predicted"));
    let left: Vec<_> = std::fs::read_dir(&dir).unwrap().map(|e| e.unwrap().file_name()).collect();
    assert!(left.is_empty(), "files left after errors: {left:?}");
}

#[test]
fn mcap_reads_back_on_every_topic() {
    let dir = tempdir("mcap");
    let d = synthetic();
    let t0: i64 = 1_700_000_000_123_456_789;
    write_mcap_stamped(&d, &d.json.joints, t0, &dir).unwrap();
    let path = dir.join("residuals.mcap");
    let topics = list_topics(&path).unwrap();
    let expected = [
        "/ivdyn/measured",
        "/ivdyn/predicted/nominal",
        "/ivdyn/predicted/final",
        "/ivdyn/residual/nominal",
        "/ivdyn/residual/final",
        "/ivdyn/predicted/step1_coulomb_friction",
    ];
    assert_eq!(topics.len(), expected.len(), "{topics:?}");
    for (name, schema, count) in &topics {
        assert!(expected.contains(&name.as_str()), "unexpected topic {name}");
        assert_eq!(schema, "sensor_msgs/msg/JointState");
        assert_eq!(*count, T, "{name}");
    }
    assert_eq!(report::step_topic(1, EffectKind::Coulomb), "/ivdyn/predicted/step1_coulomb_friction");

    let tr = &d.traces;
    let stamp = |k: usize| t0 + (tr.t[k] * 1e9).round() as i64;
    let residual = |p: &[f64]| -> Vec<f64> { tr.tau.iter().zip(p).map(|(a, b)| a - b).collect() };
    // measured: q, qd, tau
    let log = ivdyn::log::read_mcap(&path, &ReadOptions::new(&d.json.joints).topic("/ivdyn/measured")).unwrap();
    assert_eq!(log.t0_ns, t0);
    assert_eq!(log.q, tr.q);
    assert_eq!(log.qd.as_deref(), Some(&tr.qd[..]));
    assert_eq!(log.tau.as_deref(), Some(&tr.tau[..]));
    // effort-only topics, read as the command topic next to /ivdyn/measured
    for (topic, want) in [
        ("/ivdyn/predicted/nominal", tr.predicted[0].clone()),
        ("/ivdyn/predicted/final", tr.predicted[1].clone()),
        ("/ivdyn/predicted/step1_coulomb_friction", tr.predicted[1].clone()),
        ("/ivdyn/residual/nominal", residual(&tr.predicted[0])),
        ("/ivdyn/residual/final", residual(&tr.predicted[1])),
    ] {
        let mut got = vec![];
        let mut stamps = vec![];
        for_each_sample(&path, &ReadOptions::new(&d.json.joints).topic("/ivdyn/measured").command_topic(topic), |s| {
            if s.source == Source::Command {
                assert!(s.q.is_none() && s.qd.is_none(), "{topic}: effort only");
                stamps.push(s.stamp_ns);
                got.extend_from_slice(s.tau.unwrap());
            }
            Ok(())
        })
        .unwrap();
        assert_eq!(got, want, "{topic}");
        assert_eq!(stamps, (0..T).map(stamp).collect::<Vec<_>>(), "{topic} stamps");
    }
    // a wrong joint list is refused
    let e = write_mcap_stamped(&d, &d.json.joints[..1], t0, &dir).unwrap_err().to_string();
    assert!(e.contains("joint names"), "{e}");
}

fn tempdir(tag: &str) -> Scratch {
    Scratch::new(&format!("ivdyn_diag_report_{tag}"))
}

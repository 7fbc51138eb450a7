//! The outputs a person reads: `report.html` (one self-contained page: inline CSS, PNG
//! plots embedded as base64 data URIs, no script, no external file) and `residuals.mcap`
//! (measured, predicted and residual torques as JointState topics, for a log viewer).
//! Topic names and the page's content are documented in `docs/diagnose.md` ("Outputs").
//!
//! * [`crate::report::plots`]: the figures (plotters into an RGB buffer, embedded font,
//!   PNG), shared with the identify and payload reports;
//! * [`html`]: the page text (its skeleton: [`crate::report::page`]).

mod html;

use std::path::Path;

pub use crate::report::page::{fmt_num, fmt_p, fmt_pct};

use super::{Diagnosis, EffectKind};
use crate::error::{Error, Result};
use crate::log::McapWriter;
use crate::output::OutputSet;
use crate::report::plots::{self, StateAxis, Trace, column, zoom_window};

/// File name of the page written by [`write_html`].
pub const HTML_FILE: &str = "report.html";
/// File name of the log written by [`write_mcap`].
pub const MCAP_FILE: &str = "residuals.mcap";

/// Unit and meaning of parameter `key` of effect `kind` in `diagnosis.json` (revolute
/// joints; for a prismatic joint read N for N m and m for rad). A key names one quantity
/// per effect: `k` is a spring's stiffness but a torque gain's ratio, `fc` and `vs` are
/// Stribeck's or smooth friction's (docs/diagnose.md, "Units of the parameters").
pub fn param_meta(kind: EffectKind, key: &str) -> (&'static str, &'static str) {
    use EffectKind::{SmoothCoulomb, TorqueGain};
    match (kind, key) {
        (TorqueGain, "k") => ("", "measured / true torque"),
        (SmoothCoulomb, "fc") => ("N m", "smooth Coulomb friction level"),
        (SmoothCoulomb, "vs") => ("rad/s", "velocity scale of tanh(qd / vs)"),
        (_, "fc") => ("N m", "Coulomb friction level"),
        (_, "fs") => ("N m", "Stribeck excess over Coulomb at rest"),
        (_, "vs") => ("rad/s", "Stribeck velocity"),
        (_, "fv") => ("N m s/rad", "viscous coefficient"),
        (_, "ia") => ("kg m\u{b2}", "armature (rotor) inertia"),
        (_, "tau0") => ("N m", "torque offset"),
        (_, "k") => ("N m/rad", "spring stiffness"),
        (_, "q0") => ("rad", "spring rest position"),
        (_, "fc_pos") => ("N m", "Coulomb friction level for qd > 0"),
        (_, "fc_neg") => ("N m", "Coulomb friction level for qd < 0"),
        (_, "mu") => ("", "friction per N m of the joint's load torque"),
        (_, "period") => ("rad", "ripple period in q"),
        (_, "a") => ("N m", "ripple sine amplitude"),
        (_, "b") => ("N m", "ripple cosine amplitude"),
        (_, "delay_s") => ("s", "torque-to-motion delay"),
        (_, "mass") => ("kg", "mass"),
        (_, "com") => ("m", "centre of mass [x, y, z] in the terminal link frame"),
        (_, "inertia") => ("kg m\u{b2}", "inertia about the COM [Ixx, Ixy, Ixz, Iyy, Iyz, Izz]"),
        _ => ("", ""),
    }
}

/// Sample count `T` and joint count `N` of a diagnosis whose arrays all agree; otherwise
/// an error naming the field.
fn check_shapes(d: &Diagnosis) -> Result<(usize, usize)> {
    let n = d.json.joints.len();
    let tr = &d.traces;
    let t = tr.t.len();
    let dim = |what: &str, expected: usize, got: usize| -> Result<()> {
        if expected == got {
            Ok(())
        } else {
            Err(Error::Dimension { what: format!("diagnosis {what}"), expected, got })
        }
    };
    if n == 0 {
        return Err(Error::Dimension { what: "diagnosis json.joints".into(), expected: 1, got: 0 });
    }
    if t == 0 {
        return Err(Error::Dimension { what: "diagnosis traces.t (samples)".into(), expected: 1, got: 0 });
    }
    for (what, a) in [("traces.q", &tr.q), ("traces.qd", &tr.qd), ("traces.qdd", &tr.qdd), ("traces.tau", &tr.tau)] {
        dim(what, t * n, a.len())?;
    }
    dim("traces.predicted (models: nominal + one per step)", d.steps.len() + 1, tr.predicted.len())?;
    for (i, p) in tr.predicted.iter().enumerate() {
        dim(&format!("traces.predicted[{i}]"), t * n, p.len())?;
    }
    dim("json.effects (one per step)", d.steps.len(), d.json.effects.len())?;
    for (what, a) in [
        ("json.baseline_rms", &d.json.baseline_rms),
        ("json.final_rms", &d.json.final_rms),
        ("noise_std", &d.noise_std),
    ] {
        dim(what, n, a.len())?;
    }
    dim("regimes_before", n, d.regimes_before.len())?;
    dim("regimes_after", n, d.regimes_after.len())?;
    for (i, s) in d.steps.iter().enumerate() {
        dim(&format!("steps[{i}].rms_after"), n, s.rms_after.len())?;
        for c in &s.candidates {
            dim(&format!("steps[{i}] candidate {} per_joint", c.effect.name()), n, c.per_joint.len())?;
        }
    }
    for c in &d.final_candidates {
        dim(&format!("final_candidates {} per_joint", c.effect.name()), n, c.per_joint.len())?;
    }
    Ok((t, n))
}

/// The error for a figure that cannot be drawn (the report file is what fails).
fn plot_error(dir: &Path, what: &str, msg: String) -> Error {
    Error::Io { file: dir.join(HTML_FILE), source: std::io::Error::other(format!("cannot draw {what}: {msg}")) }
}

/// Renders every figure.
fn figures(d: &Diagnosis, n: usize, dir: &Path) -> Result<html::Figures> {
    let tr = &d.traces;
    let k = d.steps.len();
    let joints = &d.json.joints;
    // RMS bars: nominal, then after each step.
    let mut bars = vec![("nominal model".to_string(), plots::step_color(0), d.json.baseline_rms.clone())];
    for (i, s) in d.steps.iter().enumerate() {
        bars.push((
            format!("after step {}: + {}", i + 1, s.effect.label()),
            plots::step_color(i + 1),
            s.rms_after.clone(),
        ));
    }
    let rms_bars = plots::rms_bars(joints, &bars, &d.noise_std).map_err(|e| plot_error(dir, "the RMS bar chart", e))?;

    let mut out = Vec::with_capacity(n);
    for (j, name) in joints.iter().enumerate() {
        let tau = column(&tr.tau, n, j);
        let pred: Vec<Vec<f64>> = tr.predicted.iter().map(|p| column(p, n, j)).collect();
        let res: Vec<Vec<f64>> = pred.iter().map(|p| tau.iter().zip(p).map(|(a, b)| a - b).collect()).collect();

        // Steps that did not touch this joint predict exactly what the step before did;
        // `last` is the model whose prediction is final on this joint (0: the nominal one).
        let changed: Vec<bool> = (0..=k).map(|i| i > 0 && pred[i] != pred[i - 1]).collect();
        let last = (0..=k).rev().find(|&i| changed[i]).unwrap_or(0);
        let (nominal_label, final_label) = match (k, last) {
            (0, _) => ("nominal model".to_string(), String::new()),
            (_, 0) => ("nominal model (= final model on this joint)".to_string(), String::new()),
            _ => ("nominal model".to_string(), format!("final model (+ {k} effect{})", if k == 1 { "" } else { "s" })),
        };

        let mut torque = vec![
            Trace { label: "measured".into(), color: plots::MEASURED, y: &tau, width: 1 },
            Trace { label: nominal_label.clone(), color: plots::NOMINAL, y: &pred[0], width: 2 },
        ];
        if last > 0 {
            torque.push(Trace { label: final_label.clone(), color: plots::step_color(last), y: &pred[last], width: 2 });
        }
        let zoom = zoom_window(&tr.t, &res[0]);
        let torque = plots::torque_vs_time(name, "whole log", &tr.t, &torque, zoom, "the nominal residual")
            .map_err(|e| plot_error(dir, &format!("the torque plot of joint '{name}'"), e))?;

        let residual: Vec<Trace> = (0..=k)
            .map(|i| Trace {
                label: match i {
                    0 => "nominal model".into(),
                    _ if !changed[i] => format!("after step {i} (no change on this joint)"),
                    _ => format!("after step {i}: + {}", d.steps[i - 1].effect.label()),
                },
                color: plots::step_color(i),
                y: &res[i],
                // unchanged: legend only, so the trace it would cover stays visible
                width: if i > 0 && !changed[i] {
                    0
                } else if i == last && last > 0 {
                    2
                } else {
                    1
                },
            })
            .collect();
        let residual = plots::residual_vs_time(name, &tr.t, &residual)
            .map_err(|e| plot_error(dir, &format!("the residual plot of joint '{name}'"), e))?;

        let (q, qd, qdd) = (column(&tr.q, n, j), column(&tr.qd, n, j), column(&tr.qdd, n, j));
        let axes = [
            StateAxis { desc: "velocity qd (rad/s)", x: &qd },
            StateAxis { desc: "acceleration qdd (rad/s\u{b2})", x: &qdd },
            StateAxis { desc: "position q (rad)", x: &q },
        ];
        let mut scatter = vec![Trace { label: nominal_label, color: plots::NOMINAL, y: &res[0], width: 1 }];
        if last > 0 {
            scatter.push(Trace { label: final_label, color: plots::step_color(last), y: &res[last], width: 1 });
        }
        let state = plots::residual_vs_state(name, &axes, &scatter)
            .map_err(|e| plot_error(dir, &format!("the residual-vs-state plot of joint '{name}'"), e))?;
        out.push(html::JointFigures { torque, residual, state });
    }
    Ok(html::Figures { rms_bars, joints: out })
}

/// Writes `report.html` into `dir` (created if missing): one self-contained page with
/// the verdict, the RMS table, each step's evidence, parameters and candidate scores, the
/// regimes table and the plots. The page is staged and put in place when complete
/// ([`crate::output`]), so an error leaves no partial file.
pub fn write_html(d: &Diagnosis, dir: &Path) -> Result<()> {
    let page = html_page(d, dir)?;
    let mut set = OutputSet::new();
    set.create_dir_all(dir)?;
    set.write_bytes(&dir.join(HTML_FILE), page.as_bytes())?;
    set.commit()
}

/// The text of [`write_html`]'s page (`dir`, where it is to go, names it in errors).
pub fn html_page(d: &Diagnosis, dir: &Path) -> Result<String> {
    let (_, n) = check_shapes(d)?;
    let figs = figures(d, n, dir)?;
    Ok(html::document(d, &figs))
}

/// Topic of the prediction after step `i` (1-based) that added `effect`:
/// `/ivdyn/predicted/step<i>_<effect name>`.
pub fn step_topic(i: usize, effect: super::EffectKind) -> String {
    format!("/ivdyn/predicted/step{i}_{}", effect.name())
}

/// Writes `residuals.mcap` into `dir` with stamps relative to the log's start (`t0 = 0`);
/// see [`write_mcap_stamped`] to keep the log's absolute stamps.
pub fn write_mcap(d: &Diagnosis, joints: &[String], dir: &Path) -> Result<()> {
    write_mcap_stamped(d, joints, 0, dir)
}

/// Writes `residuals.mcap` into `dir` (created if missing): JointState messages stamped
/// `t0_ns + t` (pass the log's `JointLog::t0_ns` to line them up with the input log) on
/// the topics
///
/// * `/ivdyn/measured` ([`crate::log::MEASURED_TOPIC`]): measured `q` (position), `qd` (velocity), `tau` (effort);
/// * `/ivdyn/predicted/nominal`, `/ivdyn/predicted/final`: predicted torque (effort);
/// * `/ivdyn/residual/nominal`, `/ivdyn/residual/final`: measured - predicted (effort);
/// * `/ivdyn/predicted/step<i>_<effect>` for each step `i` (1-based), e.g.
///   `/ivdyn/predicted/step1_coulomb_friction`.
///
/// With no step, `final` equals `nominal`. `joints` names the joints in the order of
/// every per-joint list. An error leaves no file (see [`McapWriter`]).
pub fn write_mcap_stamped(d: &Diagnosis, joints: &[String], t0_ns: i64, dir: &Path) -> Result<()> {
    let mut set = OutputSet::new();
    set.create_dir_all(dir)?;
    set.write(&dir.join(MCAP_FILE), |p| write_residuals(d, joints, t0_ns, p))?;
    set.commit()
}

/// The MCAP file of [`write_mcap_stamped`] at `path`.
pub fn write_residuals(d: &Diagnosis, joints: &[String], t0_ns: i64, path: &Path) -> Result<()> {
    let (t, n) = check_shapes(d)?;
    if joints.len() != n {
        return Err(Error::Dimension { what: "joint names for residuals.mcap".into(), expected: n, got: joints.len() });
    }
    let tr = &d.traces;
    let k = d.steps.len();
    let mut w = McapWriter::create(path)?;
    let meas = w.add_joint_state_topic(crate::log::MEASURED_TOPIC)?;
    let pred_nom = w.add_joint_state_topic("/ivdyn/predicted/nominal")?;
    let pred_fin = w.add_joint_state_topic("/ivdyn/predicted/final")?;
    let res_nom = w.add_joint_state_topic("/ivdyn/residual/nominal")?;
    let res_fin = w.add_joint_state_topic("/ivdyn/residual/final")?;
    let steps = d
        .steps
        .iter()
        .enumerate()
        .map(|(i, s)| w.add_joint_state_topic(&step_topic(i + 1, s.effect)))
        .collect::<Result<Vec<_>>>()?;
    let (nominal, last) = (&tr.predicted[0], &tr.predicted[k]);
    let mut res = vec![0.0; n];
    for s in 0..t {
        let row = s * n..(s + 1) * n;
        let stamp = t0_ns.saturating_add((tr.t[s] * 1e9).round() as i64);
        let tau = &tr.tau[row.clone()];
        w.write(meas, stamp, joints, &tr.q[row.clone()], &tr.qd[row.clone()], tau)?;
        for (id, rid, p) in [(pred_nom, res_nom, nominal), (pred_fin, res_fin, last)] {
            let p = &p[row.clone()];
            w.write(id, stamp, joints, &[], &[], p)?;
            for j in 0..n {
                res[j] = tau[j] - p[j];
            }
            w.write(rid, stamp, joints, &[], &[], &res)?;
        }
        for (i, id) in steps.iter().enumerate() {
            w.write(*id, stamp, joints, &[], &[], &tr.predicted[i + 1][row.clone()])?;
        }
    }
    w.finish()?;
    Ok(())
}

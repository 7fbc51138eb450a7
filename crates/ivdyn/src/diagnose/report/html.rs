//! The text of `report.html`: one self-contained page (inline CSS, images as
//! `data:image/png;base64` URIs, no script, no external file or network access).

use std::fmt::Write as _;

use serde_json::Value;

use crate::diagnose::{CandidateScore, Diagnosis, EffectJson, EffectKind, Regimes};
use crate::report::page::{self, esc, figure, file_name, fmt_num, fmt_p, fmt_pct, unit};
use crate::report::plots::Png;

use super::param_meta;

/// The figures of one joint.
pub(super) struct JointFigures {
    /// Measured vs predicted torque.
    pub torque: Png,
    /// Residual vs time.
    pub residual: Png,
    /// Residual vs position, velocity, acceleration.
    pub state: Png,
}

/// Every figure of the report.
pub(super) struct Figures {
    /// RMS per joint per step.
    pub rms_bars: Png,
    /// Per joint, in the log's joint order.
    pub joints: Vec<JointFigures>,
}

/// The whole page.
pub(super) fn document(d: &Diagnosis, figs: &Figures) -> String {
    let mut o = String::with_capacity(4 << 20);
    let joints = &d.json.joints;
    let k = d.steps.len();
    let title = format!("Model-gap diagnosis: {}", file_name(&d.info.urdf));
    page::open(&mut o, &title);
    header(&mut o, d, &title);
    let class = if k == 0 { "clean" } else { "found" };
    let _ = writeln!(o, "<div class=\"verdict {class}\" id=\"verdict\">{}</div>", esc(&d.verdict));
    if !d.details.is_empty() {
        o.push_str("<ul id=\"details\">\n");
        for line in &d.details {
            let _ = writeln!(o, "<li>{}</li>", esc(line));
        }
        o.push_str("</ul>\n");
    }
    if let Some(cmd) = &d.json.next_command {
        let _ = writeln!(o, "<p id=\"next-command\">Next command: <code>{}</code></p>", esc(cmd));
    }
    o.push_str(
        "<nav><a href=\"#rms\">RMS table</a><a href=\"#steps\">Steps</a><a href=\"#final\">Final check</a>\
<a href=\"#detectable\">What the log can show</a>\
         <a href=\"#regimes\">Where the residual is</a><a href=\"#plots\">Plots per joint</a></nav>\n",
    );
    o.push_str(
        "<p>The <b>residual</b> is the measured joint torque minus the torque the model predicts \
         for the logged motion. The diagnosis adds one effect at a time from a fixed vocabulary \
         (Coulomb, viscous and Stribeck friction, armature, payload, torque offset, joint spring), \
         each time choosing the candidate that explains most of the residual on a held-out part of \
         the log with a statistically significant F test, and stops when no candidate is significant. \
         When the model is complete, the residual RMS approaches the sensor noise.</p>\n",
    );
    rms_section(&mut o, d, figs);
    steps_section(&mut o, d);
    final_section(&mut o, d);
    detectable_section(&mut o, d);
    regimes_section(&mut o, d);
    plots_section(&mut o, d, figs, joints);
    page::close(&mut o, "diagnose");
    o
}

fn header(o: &mut String, d: &Diagnosis, title: &str) {
    let i = &d.info;
    let _ = writeln!(o, "<h1>{}</h1>", esc(title));
    let _ = writeln!(o, "<p class=\"sub\">Robot model (URDF): <code>{}</code></p>", esc(&i.urdf));
    let _ = writeln!(o, "<p class=\"sub\">Log: <code>{}</code></p>", esc(&i.file));
    let vel = if i.velocity_in_log { "taken from the log" } else { "not in the log: differentiated from positions" };
    let _ = writeln!(
        o,
        "<p class=\"sub\">{} samples over {} s at {} Hz; {} joints ({}); velocities {}.</p>",
        i.samples,
        fmt_num(i.duration),
        fmt_num(i.rate),
        d.json.joints.len(),
        esc(&d.json.joints.join(", ")),
        vel
    );
    let _ = writeln!(
        o,
        "<p class=\"sub\">Accelerations from a zero-phase low-pass at {} Hz (chosen from the data unless given), torque aligned to the motion by {} samples; the first and last samples (filter edges) are left out.</p>",
        fmt_num(i.cutoff_hz),
        fmt_num(i.align_samples)
    );
}

/// Column label of the model after step `i` (0 = nominal).
fn model_label(d: &Diagnosis, i: usize) -> String {
    if i == 0 { "nominal model".into() } else { format!("after step {i}: + {}", d.steps[i - 1].effect.label()) }
}

fn rms_section(o: &mut String, d: &Diagnosis, figs: &Figures) {
    let k = d.steps.len();
    o.push_str("<h2 id=\"rms\">RMS residual per joint</h2>\n");
    o.push_str(
        "<p>Root mean square of the residual over the whole log, for the nominal model and after each \
         step. The noise estimate comes from differences of the residual two samples apart; a final \
         RMS close to it means nothing structured is left.</p>\n",
    );
    o.push_str("<table id=\"rms-table\">\n<tr><th>joint</th>");
    for i in 0..=k {
        let _ = write!(o, "<th>{}{}</th>", esc(&model_label(d, i)), unit("N m"));
    }
    let _ = writeln!(
        o,
        "<th>final{}</th><th>noise std (estimate){}</th><th>final / noise</th></tr>",
        unit("N m"),
        unit("N m")
    );
    for (j, name) in d.json.joints.iter().enumerate() {
        let _ = write!(o, "<tr><td>{}</td>", esc(name));
        for i in 0..=k {
            let v = if i == 0 { d.json.baseline_rms[j] } else { d.steps[i - 1].rms_after[j] };
            let _ = write!(o, "<td class=\"n\">{}</td>", fmt_num(v));
        }
        let (f, s) = (d.json.final_rms[j], d.noise_std[j]);
        let ratio = if s > 0.0 { f / s } else { f64::NAN };
        let _ = writeln!(
            o,
            "<td class=\"n\"><b>{}</b></td><td class=\"n\">{}</td><td class=\"n\">{}</td></tr>",
            fmt_num(f),
            fmt_num(s),
            fmt_num(ratio)
        );
    }
    o.push_str("</table>\n");
    figure(
        o,
        &figs.rms_bars,
        "bar chart of the RMS residual per joint and step",
        "RMS residual per joint: one bar per model (nominal, then after each step); the black line is the sensor noise estimate.",
    );
}

fn steps_section(o: &mut String, d: &Diagnosis) {
    o.push_str("<h2 id=\"steps\">Steps: what was added, and why</h2>\n");
    if d.steps.is_empty() {
        o.push_str("<p>No effect was added: no candidate was significant on the nominal model (see the final check below).</p>\n");
        return;
    }
    for (i, (s, e)) in d.steps.iter().zip(&d.json.effects).enumerate() {
        let names: Vec<&str> = s.joints.iter().filter_map(|&j| d.json.joints.get(j).map(|s| s.as_str())).collect();
        // (the payload's label already says where it is)
        let on = if s.effect == EffectKind::Payload { String::new() } else { format!(" on {}", names.join(", ")) };
        let _ = writeln!(
            o,
            "<h3 id=\"step{}\">Step {}: {}{} <span class=\"unit\">(<code>{}</code>)</span></h3>",
            i + 1,
            i + 1,
            esc(s.effect.label()),
            esc(&on),
            s.effect.name()
        );
        o.push_str("<p><b>Evidence</b></p>\n<ul class=\"evidence\">\n");
        for ev in &s.evidence {
            let _ = writeln!(o, "<li>{}</li>", esc(ev));
        }
        o.push_str("</ul>\n<p><b>Identified parameters</b></p>\n");
        params_table(o, e, s.effect);
        let _ = writeln!(o, "<p><b>Candidates scored at step {}</b></p>", i + 1);
        candidates_table(o, d, &s.candidates);
    }
}

fn params_table(o: &mut String, e: &EffectJson, kind: EffectKind) {
    let per_joint = kind != EffectKind::Payload
        && !e.joints.is_empty()
        && e.parameters.values().all(|v| v.as_array().is_some_and(|a| a.len() == e.joints.len()));
    if per_joint {
        o.push_str("<table class=\"params\">\n<tr><th>joint</th>");
        for key in e.parameters.keys() {
            let (u, what) = param_meta(kind, key);
            let _ = write!(o, "<th><code>{}</code> {}{}</th>", esc(key), esc(what), unit(u));
        }
        o.push_str("</tr>\n");
        for (r, joint) in e.joints.iter().enumerate() {
            let _ = write!(o, "<tr><td>{}</td>", esc(joint));
            for (key, v) in &e.parameters {
                let s = e.parameters_std.get(key).and_then(|s| s.get(r));
                let _ = write!(o, "<td class=\"n\">{}</td>", value_text(&v[r], s));
            }
            o.push_str("</tr>\n");
        }
        o.push_str("</table>\n");
    } else {
        o.push_str("<table class=\"params\">\n<tr><th>parameter</th><th>value</th></tr>\n");
        for (key, v) in &e.parameters {
            let (u, what) = param_meta(kind, key);
            let _ = writeln!(
                o,
                "<tr><td><code>{}</code> {}{}</td><td class=\"n\">{}</td></tr>",
                esc(key),
                esc(what),
                unit(u),
                value_text(v, e.parameters_std.get(key))
            );
        }
        o.push_str("</table>\n");
    }
    if !e.parameters_std.is_empty() {
        o.push_str(
            "<p class=\"note\">Values \u{b1} 2 standard errors: the noise's, or the spread between \
             the log's two halves where larger, and with the nominal re-fit the change between \
             its neighbouring ridges (about 95 % when the residual is noise of the estimated \
             level; where the nominal inertials are off, a lower bound: on generated arms the \
             truth lay within them about 2 times in 3, docs/diagnose.md \u{201c}Uncertainty\u{201d}); \
             no \u{b1} where there is none (a shape chosen on a grid).</p>\n",
        );
    }
}

/// A JSON parameter value as text: numbers with [`fmt_num`], `\u{b1}` twice its standard
/// error `std` when there is one, lists in brackets.
fn value_text(v: &Value, std: Option<&Value>) -> String {
    match v {
        Value::Number(n) => {
            let x = n.as_f64().map(fmt_num).unwrap_or_else(|| esc(&n.to_string()));
            match std.and_then(Value::as_f64) {
                Some(s) => format!("{x} \u{b1} {}", fmt_num(2.0 * s)),
                None => x,
            }
        }
        Value::Array(a) => format!(
            "[{}]",
            a.iter().enumerate().map(|(i, x)| value_text(x, std.and_then(|s| s.get(i)))).collect::<Vec<_>>().join(", ")
        ),
        Value::Null => "\u{2013}".into(),
        other => esc(&other.to_string()),
    }
}

fn candidates_table(o: &mut String, d: &Diagnosis, cands: &[CandidateScore]) {
    let n = d.json.joints.len();
    o.push_str(
        "<table class=\"candidates\">\n<tr><th>candidate</th><th>joint</th><th>significant</th>\
         <th>held-out gain</th><th>effect RMS <span class=\"unit\">(N m)</span></th><th>F</th><th>p</th>\
         <th>rejected by</th><th>score</th><th>decision</th></tr>\n",
    );
    for c in cands {
        let class = if c.accepted { " class=\"accepted\"" } else { "" };
        let rows = c.per_joint.len().max(1);
        for (j, s) in c.per_joint.iter().enumerate() {
            let _ = write!(o, "<tr{class}>");
            if j == 0 {
                let _ = write!(
                    o,
                    "<td rowspan=\"{rows}\">{}<br><code>{}</code></td>",
                    esc(c.effect.label()),
                    c.effect.name()
                );
            }
            let joint = d.json.joints.get(j).map(|s| esc(s)).unwrap_or_else(|| format!("#{j}"));
            let sig = if s.significant { "<td class=\"sig\">yes</td>" } else { "<td class=\"dim\">no</td>" };
            let _ = write!(
                o,
                "<td>{joint}</td>{sig}<td class=\"n\">{}</td><td class=\"n\">{}</td><td class=\"n\">{}</td><td class=\"n\">{}</td><td>{}</td>",
                fmt_pct(s.heldout_gain),
                fmt_num(s.effect_rms),
                fmt_num(s.f),
                fmt_p(s.p),
                esc(s.rejected_by.as_deref().unwrap_or(""))
            );
            if j == 0 {
                let verdict = if c.accepted { "<b>added</b>: " } else { "not added: " };
                let _ = write!(
                    o,
                    "<td rowspan=\"{rows}\" class=\"n\">{}</td><td rowspan=\"{rows}\">{verdict}{}</td>",
                    fmt_num(c.score),
                    esc(&c.reason)
                );
            }
            o.push_str("</tr>\n");
        }
        if c.per_joint.is_empty() {
            let _ = writeln!(
                o,
                "<tr{class}><td>{}</td><td colspan=\"9\">{}</td></tr>",
                esc(c.effect.label()),
                esc(&c.reason)
            );
        }
    }
    o.push_str("</table>\n");
    let _ = writeln!(
        o,
        "<p class=\"note\">Per joint ({n} joints): <i>significant</i> = the F test of the candidate's \
         columns on the training part rejects \u{201c}no effect\u{201d}, and the fit also helps on the \
         held-out part; <i>held-out gain</i> = fraction of the held-out residual variance above the noise \
         that the fitted candidate removes (negative: it made the held-out part worse); <i>effect RMS</i> = \
         RMS of the torque the fitted candidate adds; <i>F</i>, <i>p</i> = the F statistic and its p-value; \
         <i>rejected by</i> = the rule that rejected it on the joint, with its numbers. The score ranks the candidates (0 when nothing is significant).</p>"
    );
}

fn final_section(o: &mut String, d: &Diagnosis) {
    o.push_str("<h2 id=\"final\">Final check: nothing else significant</h2>\n");
    if d.final_candidates.is_empty() {
        o.push_str("<p>No candidate scores were recorded for the final model.</p>\n");
        return;
    }
    let why = match d.final_candidates.iter().find(|c| c.reason == crate::diagnose::UNDONE) {
        Some(c) => format!(
            "the one added ({}) was removed again by the backward step (the rule on its rows), so the search stopped",
            c.effect.label()
        ),
        None => "none is significant, so the search stopped".into(),
    };
    let _ = writeln!(
        o,
        "<p>Every candidate scored on the residual of the final model ({}): {why}.</p>",
        esc(&model_label(d, d.steps.len()))
    );
    candidates_table(o, d, &d.final_candidates);
}

/// The smallest look-alike per joint the log can tell from the links' inertials
/// (`diagnosis.json`'s `detectable`).
fn detectable_section(o: &mut String, d: &Diagnosis) {
    let Some(det) = &d.json.detectable else { return };
    o.push_str("<h2 id=\"detectable\">What the log can show</h2>\n");
    let _ = writeln!(
        o,
        "<p>The smallest effect of each kind whose torque beyond what a change of the links' inertials \
         (before the terminal one) can make is {} noise standard deviations RMS on its joint: a smaller one \
         cannot be told from a CAD error of the links on this motion, whatever the diagnosis names; a wider \
         or longer motion lowers it. &ldquo;&ndash;&rdquo;: the motion shows none of it.</p>",
        fmt_num(det.noise_std)
    );
    o.push_str(
        "<table id=\"detectable-table\"><tr><th>joint</th><th>torque offset |tau0| (N m)</th><th>direction dependence |fc_pos - fc_neg| (N m)</th>\
         <th>spring |k| (N m/rad)</th><th>gain error |k - 1|</th><th>armature ia (kg m&sup2;)</th></tr>\n",
    );
    let cell = |v: &[Option<f64>], j: usize| v.get(j).copied().flatten().map_or("\u{2013}".to_string(), fmt_num);
    for (j, name) in d.json.joints.iter().enumerate() {
        let _ = writeln!(
            o,
            "<tr><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td></tr>",
            esc(name),
            cell(&det.torque_offset, j),
            cell(&det.asymmetric_coulomb_friction, j),
            cell(&det.joint_spring, j),
            cell(&det.torque_gain, j),
            cell(&det.armature, j)
        );
    }
    o.push_str("</table>\n");
}

fn regimes_section(o: &mut String, d: &Diagnosis) {
    o.push_str("<h2 id=\"regimes\">Where the residual is</h2>\n");
    o.push_str(
        "<p>RMS of the residual in three regimes (near velocity reversals, at high acceleration, \
         elsewhere), the mean jump of the residual across velocity reversals (about twice the Coulomb \
         friction level when that is missing), and the correlation of the residual with the joint's \
         own position, velocity and acceleration. Nominal model vs final model.</p>\n",
    );
    o.push_str("<table id=\"regimes-table\">\n<tr><th>joint</th><th>model</th>");
    for (h, u) in [
        ("RMS", "N m"),
        ("RMS at reversals", "N m"),
        ("RMS at high |qdd|", "N m"),
        ("RMS elsewhere", "N m"),
        ("jump at reversal", "N m"),
        ("reversals", ""),
        ("corr(r, q)", ""),
        ("corr(r, qd)", ""),
        ("corr(r, qdd)", ""),
        ("mean", "N m"),
    ] {
        let _ = write!(o, "<th>{}{}</th>", esc(h), unit(u));
    }
    o.push_str("</tr>\n");
    let final_label = if d.steps.is_empty() { "final (= nominal)" } else { "final" };
    for (j, name) in d.json.joints.iter().enumerate() {
        for (r, label, first) in [(&d.regimes_before[j], "nominal", true), (&d.regimes_after[j], final_label, false)] {
            o.push_str("<tr>");
            if first {
                let _ = write!(o, "<td rowspan=\"2\">{}</td>", esc(name));
            }
            let _ = writeln!(o, "<td>{label}</td>{}</tr>", regime_cells(r));
        }
    }
    o.push_str("</table>\n");
    o.push_str("<p class=\"note\">High |qdd| = the top 20 % of the joint's absolute acceleration; \u{2013} = not available (e.g. no velocity reversal in the log).</p>\n");
}

fn regime_cells(r: &Regimes) -> String {
    let mut s = String::new();
    for v in [r.rms, r.rms_reversal, r.rms_high_acc, r.rms_rest, r.reversal_jump] {
        let _ = write!(s, "<td class=\"n\">{}</td>", fmt_num(v));
    }
    let _ = write!(s, "<td class=\"n\">{}</td>", r.reversals);
    for v in [r.corr_q, r.corr_qd, r.corr_qdd] {
        let _ =
            write!(s, "<td class=\"n\">{}</td>", if v.is_finite() { format!("{v:+.2}") } else { "\u{2013}".into() });
    }
    let _ = write!(s, "<td class=\"n\">{}</td>", fmt_num(r.mean));
    s
}

fn plots_section(o: &mut String, d: &Diagnosis, figs: &Figures, joints: &[String]) {
    let k = d.steps.len();
    o.push_str("<h2 id=\"plots\">Plots per joint</h2>\n");
    o.push_str(
        "<p>Long logs are drawn as the minimum and maximum of each pixel column (time plots) and as a \
         random subsample of the samples (scatter plots).</p>\n",
    );
    let final_txt = if k == 0 {
        "no effect was added, so the final model is the nominal one".to_string()
    } else {
        format!("final model = nominal + the {k} effect(s) of the steps above")
    };
    for (j, (name, f)) in joints.iter().zip(&figs.joints).enumerate() {
        let _ = writeln!(o, "<h3 id=\"joint{j}\">{}</h3>", esc(name));
        figure(
            o,
            &f.torque,
            &format!("{name}: measured and predicted torque vs time"),
            &format!(
                "Measured torque and the torques predicted by the nominal and final models ({}); top: whole log, bottom: zoom.",
                esc(&final_txt)
            ),
        );
        figure(
            o,
            &f.residual,
            &format!("{name}: residual vs time"),
            "Residual of the nominal model and after each step. A residual that follows the motion means a missing effect; what remains at the end should look like noise.",
        );
        figure(
            o,
            &f.state,
            &format!("{name}: residual vs position, velocity, acceleration"),
            "Residual against the joint's own state: a step at zero velocity is Coulomb friction, a slope in velocity viscous friction, a slope in acceleration armature, a slope in position a spring, an offset a torque offset.",
        );
    }
}

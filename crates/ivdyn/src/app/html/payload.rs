//! The page of `ivdyn payload --report`.

use std::fmt::Write as _;
use std::path::Path;

use super::{ModelTraces, Series, joint_figures, joint_section, notes_list};
use crate::app::payload::{PayloadReport, RIGID_P_VALUE};
use crate::error::Result;
use crate::report::page::{self, esc, fmt_num, fmt_p, num_cell, unit};
use crate::report::plots;

/// Two-sided 95 % quantile of the standard normal: the intervals of the estimate table.
const Z95: f64 = 1.959_963_984_540_054;

/// What the payload page shows beyond the JSON report.
pub struct PayloadPage<'a> {
    /// The JSON report.
    pub report: &'a PayloadReport,
    /// The log after the grasp, and the one before it (if any).
    pub logs: Vec<String>,
    /// The log after the grasp, predicted by the nominal model (0) and by the nominal
    /// model with the reported payload (1).
    pub log: &'a Series,
}

/// The page's text (`file`, where it is to go, names it in errors).
pub fn payload_page(p: &PayloadPage<'_>, file: &Path) -> Result<String> {
    let r = p.report;
    let mut o = String::with_capacity(4 << 20);
    let title = format!("Payload on {}", r.link);
    page::open(&mut o, &title);
    header(&mut o, p, &title);
    let (class, verdict) = verdict(r);
    let _ = writeln!(o, "<div class=\"verdict {class}\" id=\"verdict\">{}</div>", esc(&verdict));
    o.push_str(
        "<nav><a href=\"#estimate\">Estimate</a><a href=\"#physical\">Physical validity</a>\
         <a href=\"#quality\">Fit quality</a><a href=\"#plots\">Plots per joint</a></nav>\n",
    );
    estimate_section(&mut o, r);
    physical_section(&mut o, r);
    quality_section(&mut o, r);
    notes_list(&mut o, "Notes", &r.notes);
    plots_section(&mut o, p, file)?;
    page::close(&mut o, "payload");
    Ok(o)
}

fn header(o: &mut String, p: &PayloadPage<'_>, title: &str) {
    let r = p.report;
    let _ = writeln!(o, "<h1>{}</h1>", esc(title));
    for (k, l) in p.logs.iter().enumerate() {
        let what = if k == 0 { "Log after the grasp" } else { "Log before the grasp" };
        let _ = writeln!(o, "<p class=\"sub\">{what}: <code>{}</code></p>", esc(l));
    }
    let dur = match (p.log.t.first(), p.log.t.last()) {
        (Some(a), Some(b)) => b - a,
        _ => 0.0,
    };
    let _ = writeln!(
        o,
        "<p class=\"sub\">{} samples fitted (filtered, decimated) from {} conditioned samples over {} s; \
         {} joints; residual taken against the {} model; the std cover: {}.</p>",
        r.samples,
        p.log.len(),
        fmt_num(dur),
        r.joints.len(),
        esc(&r.nominal),
        esc(&r.uncertainty_sources.join(", "))
    );
}

/// The verdict box's class and text.
fn verdict(r: &PayloadReport) -> (&'static str, String) {
    match (r.mass, r.mass_std, &r.physical) {
        (Some(m), Some(s), Some(ph)) => {
            let rigid = if ph.p_value < RIGID_P_VALUE {
                "but the data contradict a rigid payload"
            } else if ph.ls_possible {
                "a physically possible rigid body"
            } else {
                "the nearest physically possible rigid body to the least-squares fit"
            };
            let class = if ph.p_value < RIGID_P_VALUE { "found" } else { "clean" };
            (class, format!("Payload {} \u{b1} {} kg: {rigid}", fmt_num(m), fmt_num(s)))
        }
        _ => ("found", "The payload is not identifiable from this log".into()),
    }
}

fn estimate_section(o: &mut String, r: &PayloadReport) {
    o.push_str("<h2 id=\"estimate\">Estimate</h2>\n");
    let (Some(m), Some(c), Some(i), Some(ms), Some(cs), Some(is)) =
        (r.mass, r.com, r.inertia, r.mass_std, r.com_std, r.inertia_std)
    else {
        o.push_str(
            "<p>Not identifiable: these parameters are hidden in combinations the motion cannot separate.</p>\n",
        );
        o.push_str("<table id=\"hidden-table\">\n<tr><th>parameter</th><th>combined in</th></tr>\n");
        for h in &r.not_identifiable {
            let _ = writeln!(
                o,
                "<tr><td><code>{}</code></td><td><code>{}</code></td></tr>",
                esc(&h.parameter),
                esc(&h.combined_in)
            );
        }
        o.push_str("</table>\n");
        return;
    };
    let _ = writeln!(
        o,
        "<p>On link <code>{}</code>: centre of mass in the link frame, inertia about the centre of mass; \
         the 95 % interval is value \u{b1} {:.2} std (normal).</p>",
        esc(&r.link),
        Z95
    );
    o.push_str(
        "<table id=\"estimate-table\">\n<tr><th>parameter</th><th>value</th><th>std</th>\
         <th>95 % interval</th></tr>\n",
    );
    let mut rows = vec![("mass".to_string(), "kg", m, ms)];
    for (k, a) in ["x", "y", "z"].iter().enumerate() {
        rows.push((format!("com.{a}"), "m", c[k], cs[k]));
    }
    // the report's inertia is in ivdyn's order (the JSON file's is URDF's)
    for (k, a) in ivdyn_core::INERTIA_ORDER.iter().enumerate() {
        rows.push((format!("inertia.{a}"), "kg m\u{b2}", i[k], is[k]));
    }
    for (name, u, v, s) in rows {
        let _ = writeln!(
            o,
            "<tr><td><code>{}</code>{}</td>{}{}<td class=\"n\">{} to {}</td></tr>",
            esc(&name),
            unit(u),
            num_cell(v),
            num_cell(s),
            fmt_num(v - Z95 * s),
            fmt_num(v + Z95 * s)
        );
    }
    o.push_str("</table>\n");
}

fn physical_section(o: &mut String, r: &PayloadReport) {
    o.push_str("<h2 id=\"physical\">Physical validity</h2>\n");
    let Some(ph) = &r.physical else {
        o.push_str("<p>No estimate to check.</p>\n");
        return;
    };
    let ls = if ph.ls_possible {
        "The least-squares payload is a physically possible rigid body (positive mass, positive-definite \
         pseudo-inertia); it is the one reported."
            .to_string()
    } else {
        format!(
            "The least-squares payload is not a physically possible rigid body (least-squares mass {} kg, \
             smallest pseudo-inertia eigenvalue {}); the payload reported is the nearest possible one.",
            fmt_num(ph.ls_params[0]),
            fmt_num(ph.ls_violation.min_eig_pseudo_inertia)
        )
    };
    let _ = writeln!(o, "<p>{}</p>", esc(&ls));
    o.push_str("<table id=\"physical-table\">\n");
    let _ = writeln!(
        o,
        "<tr><th>squared Mahalanobis distance to the nearest rigid body</th>{}</tr>",
        num_cell(ph.mahalanobis2)
    );
    let _ = writeln!(o, "<tr><th>degrees of freedom (chi-square)</th><td class=\"n\">{}</td></tr>", ph.dof);
    let _ = writeln!(o, "<tr><th>p-value</th><td class=\"n\">{}</td></tr>", fmt_p(ph.p_value));
    let _ = writeln!(
        o,
        "<tr><th>constraints active</th><td>{}</td></tr>",
        if ph.constraints_active { "yes" } else { "no" }
    );
    o.push_str("</table>\n");
    let _ = writeln!(
        o,
        "<p class=\"note\">A p-value below {} means the data contradict a rigid payload fixed to the link.</p>",
        fmt_num(RIGID_P_VALUE)
    );
}

fn quality_section(o: &mut String, r: &PayloadReport) {
    o.push_str("<h2 id=\"quality\">Fit quality per joint</h2>\n");
    o.push_str(
        "<p>RMS of the residual (measured minus predicted torque) on the filtered, decimated data the \
         fit used: against the nominal model alone, and with the reported payload added.</p>\n",
    );
    let _ = writeln!(
        o,
        "<table id=\"quality-table\">\n<tr><th>joint</th><th>RMS without payload{}</th>\
         <th>RMS with payload{}</th><th>reduction <span class=\"unit\">(%)</span></th></tr>",
        unit("N m"),
        unit("N m")
    );
    for (j, name) in r.joints.iter().enumerate() {
        let (b, a) = (r.rms_before[j], r.rms_after[j]);
        let red = if b > 0.0 { 100.0 * (1.0 - a / b) } else { f64::NAN };
        let _ = writeln!(o, "<tr><td>{}</td>{}{}{}</tr>", esc(name), num_cell(b), num_cell(a), num_cell(red));
    }
    o.push_str("</table>\n");
}

fn plots_section(o: &mut String, p: &PayloadPage<'_>, file: &Path) -> Result<()> {
    o.push_str("<h2 id=\"plots\">Plots per joint</h2>\n");
    o.push_str(
        "<p>The conditioned log after the grasp (before the parallel filter: the residual includes the \
         sensor noise the fit filtered out). Long logs are drawn as the minimum and maximum of each pixel \
         column (time plots) and as a random subsample (scatter plots).</p>\n",
    );
    let with = plots::step_color(1);
    for (j, name) in p.report.joints.iter().enumerate() {
        let models = [
            ModelTraces {
                label: format!("{} model", p.report.nominal),
                color: plots::NOMINAL,
                residuals: vec![("without payload".into(), plots::NOMINAL, p.log.residual(0, j))],
            },
            ModelTraces {
                label: "with the payload".into(),
                color: with,
                residuals: vec![("with the payload".into(), with, p.log.residual(1, j))],
            },
        ];
        let f = joint_figures(file, name, j, (p.log, "log after the grasp"), p.log, &models)?;
        joint_section(
            o,
            j,
            name,
            &f,
            "Measured torque, the nominal model's prediction and the prediction with the reported payload; top: whole log, bottom: zoom.",
            "Residual without and with the payload: what the payload explains is the difference.",
        );
    }
    Ok(())
}

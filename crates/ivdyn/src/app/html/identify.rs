//! The page of `ivdyn identify --report`.

use std::fmt::Write as _;
use std::path::Path;

use super::{ModelTraces, Series, joint_figures, joint_section, masked, notes_list};
use crate::Robot;
use crate::app::identify::IdentifyReport;
use crate::error::Result;
use crate::report::Quality;
use crate::report::page::{self, esc, fmt_num, num_cell, unit};
use crate::report::plots;

/// What the identify page shows beyond the JSON report.
pub struct IdentifyPage<'a> {
    /// The robot (link names for the physical check).
    pub robot: &'a Robot,
    /// The JSON report.
    pub report: &'a IdentifyReport,
    /// The log files (or "arrays"), in the order given.
    pub logs: Vec<String>,
    /// The last log, predicted by the identified model.
    pub log: &'a Series,
    /// First held-out sample of `log` (its tail); `None` when nothing was held out of it.
    pub held_out_from: Option<usize>,
    /// The validation log, predicted by the identified model, when one was given.
    pub validation: Option<&'a Series>,
}

/// The page's text (`file`, where it is to go, names it in errors).
pub fn identify_page(p: &IdentifyPage<'_>, file: &Path) -> Result<String> {
    let r = p.report;
    let mut o = String::with_capacity(4 << 20);
    let title = format!("Identification: {}", r.params.robot);
    page::open(&mut o, &title);
    header(&mut o, p, &title);
    let (class, verdict) = if r.physical.consistent {
        ("clean", "The identified parameters are physically consistent".to_string())
    } else {
        let k = r.physical.links.len() + r.physical.joints.len();
        ("found", format!("The identified parameters are not physically consistent ({k} links or joints)"))
    };
    let _ = writeln!(o, "<div class=\"verdict {class}\" id=\"verdict\">{}</div>", esc(&verdict));
    o.push_str(
        "<nav><a href=\"#quality\">Fit quality</a><a href=\"#base\">Base parameters</a>\
         <a href=\"#physical\">Physical consistency</a><a href=\"#plots\">Plots per joint</a></nav>\n",
    );
    o.push_str("<h2 id=\"quality\">Fit quality per joint</h2>\n");
    o.push_str(
        "<p>On the filtered, decimated data the fit used: RMS of the residual (measured minus predicted \
         torque), R\u{b2} = 1 - SSE/SST, and NRMSE = RMS residual / RMS measured torque; on the fitted \
         samples and on the held-out ones (never fitted).</p>\n",
    );
    quality_table(&mut o, "quality-table", &r.joints, &r.fit, r.validation.as_ref());
    dwh_and_coulomb(&mut o, r);
    base_section(&mut o, r);
    physical_section(&mut o, p);
    notes_list(&mut o, "Notes", &r.notes);
    plots_section(&mut o, p, file)?;
    page::close(&mut o, "identify");
    Ok(o)
}

fn header(o: &mut String, p: &IdentifyPage<'_>, title: &str) {
    let r = p.report;
    let _ = writeln!(o, "<h1>{}</h1>", esc(title));
    for l in &p.logs {
        let _ = writeln!(o, "<p class=\"sub\">Log: <code>{}</code></p>", esc(l));
    }
    let dur = match (p.log.t.first(), p.log.t.last()) {
        (Some(a), Some(b)) => b - a,
        _ => 0.0,
    };
    let _ = writeln!(
        o,
        "<p class=\"sub\">Last log: {} samples over {} s; {} joints ({}).</p>",
        p.log.len(),
        fmt_num(dur),
        r.joints.len(),
        esc(&r.joints.join(", "))
    );
    let held =
        r.validation.as_ref().map(|v| format!(", {} held out ({})", v.samples, esc(&v.data))).unwrap_or_default();
    let _ = writeln!(
        o,
        "<p class=\"sub\">Method <code>{}</code>{}; fitted at {} Hz (decimation {}, zero-phase low-pass at {} Hz): \
         {} samples fitted{held}; {} rows, rank {}, condition number {}{}.</p>",
        esc(&r.method),
        r.instrument.as_ref().map(|i| format!(", instrument: {}", esc(i))).unwrap_or_default(),
        fmt_num(r.sample_rate_hz),
        r.decimation,
        fmt_num(r.filter_cutoff_hz),
        r.fit.samples,
        r.rows,
        r.rank,
        fmt_num(r.condition_number),
        if r.streamed { "; the log was streamed" } else { "" }
    );
}

/// The per-joint quality table (`id`): fit columns, then the held-out ones.
pub(super) fn quality_table(o: &mut String, id: &str, joints: &[String], fit: &Quality, val: Option<&Quality>) {
    let _ = write!(o, "<table id=\"{id}\">\n<tr><th>joint</th>");
    let mut parts = vec![("fit", fit)];
    if let Some(v) = val {
        parts.push(("held-out", v));
    }
    for (what, _) in &parts {
        let _ = write!(o, "<th>{what} RMS{}</th><th>{what} R\u{b2}</th><th>{what} NRMSE</th>", unit("N m"));
    }
    let _ = writeln!(o, "<th>measured RMS (fit){}</th></tr>", unit("N m"));
    for (j, name) in joints.iter().enumerate() {
        let _ = write!(o, "<tr><td>{}</td>", esc(name));
        for (_, q) in &parts {
            let nrmse = if q.tau_rms[j] > 0.0 { q.rms[j] / q.tau_rms[j] } else { f64::NAN };
            let _ = write!(o, "{}{}{}", num_cell(q.rms[j]), num_cell(q.r2[j]), num_cell(nrmse));
        }
        let _ = writeln!(o, "{}</tr>", num_cell(fit.tau_rms[j]));
    }
    o.push_str("</table>\n");
}

fn dwh_and_coulomb(o: &mut String, r: &IdentifyReport) {
    if let Some(d) = &r.dwh {
        let _ = writeln!(o, "<p><b>LS vs IV (Durbin-Wu-Hausman test):</b> {}</p>", esc(&d.verdict));
    }
    if r.coulomb.is_empty() {
        return;
    }
    o.push_str("<p><b>Coulomb friction shape per joint</b> (chosen on held-out rows):</p>\n");
    let _ = writeln!(
        o,
        "<table id=\"coulomb-table\">\n<tr><th>joint</th><th>shape</th><th>v_scale{}</th><th>asym</th></tr>",
        unit("rad/s")
    );
    for c in &r.coulomb {
        let _ = writeln!(
            o,
            "<tr><td>{}</td><td>{}</td>{}{}</tr>",
            esc(&c.joint),
            esc(&c.shape),
            num_cell(c.v_scale),
            num_cell(c.asym)
        );
    }
    o.push_str("</table>\n");
}

fn base_section(o: &mut String, r: &IdentifyReport) {
    o.push_str("<h2 id=\"base\">Base parameters</h2>\n");
    o.push_str(
        "<p>The identifiable combinations of the parameters (SI units), their estimate, its standard \
         deviation (from the fit's covariance), the relative standard deviation, and the nominal (URDF) \
         value of the same combination.</p>\n",
    );
    o.push_str(
        "<table id=\"base-table\">\n<tr><th>base parameter</th><th>value</th><th>std</th>\
         <th>relative std <span class=\"unit\">(%)</span></th><th>nominal</th></tr>\n",
    );
    for b in &r.base {
        let _ = writeln!(
            o,
            "<tr><td><code>{}</code></td>{}{}{}{}</tr>",
            esc(&b.name),
            num_cell(b.value),
            num_cell(b.std),
            num_cell(b.rel_std_pct),
            num_cell(b.nominal)
        );
    }
    o.push_str("</table>\n");
    if !r.unexcited.is_empty() {
        let _ = writeln!(
            o,
            "<p class=\"note\">Not excited by the data (left at their nominal values): {}.</p>",
            esc(&r.unexcited.join(", "))
        );
    }
}

fn physical_section(o: &mut String, p: &IdentifyPage<'_>) {
    let r = p.report;
    o.push_str("<h2 id=\"physical\">Physical consistency</h2>\n");
    o.push_str(
        "<p>The full parameters (nominal corrected in the identifiable directions) per link: positive \
         mass, inertia about the centre of mass positive definite with the triangle inequalities, \
         positive-definite pseudo-inertia; per joint: non-negative friction and armature.</p>\n",
    );
    o.push_str("<table id=\"physical-table\">\n<tr><th>link or joint</th><th>verdict</th></tr>\n");
    let rows = p
        .robot
        .link_names
        .iter()
        .map(|l| (l, &r.physical.links))
        .chain(r.joints.iter().map(|j| (j, &r.physical.joints)));
    for (name, found) in rows {
        let problems = found.iter().find(|v| &v.name == name).map(|v| v.problems.join("; "));
        let cell = match problems {
            Some(text) => format!("<td class=\"sig\" style=\"color: var(--warn)\">{}</td>", esc(&text)),
            None => "<td>consistent</td>".into(),
        };
        let _ = writeln!(o, "<tr><td>{}</td>{cell}</tr>", esc(name));
    }
    o.push_str("</table>\n");
    if let Some(c) = &r.consistent {
        o.push_str(
            "<p>A physically consistent fit was also made (<code>--consistent</code>); its quality on the \
             same data:</p>\n",
        );
        quality_table(o, "consistent-quality-table", &r.joints, &c.fit, c.validation.as_ref());
    }
}

fn plots_section(o: &mut String, p: &IdentifyPage<'_>, file: &Path) -> Result<()> {
    o.push_str("<h2 id=\"plots\">Plots per joint</h2>\n");
    o.push_str(
        "<p>The conditioned log (before the parallel filter: the residual includes the sensor noise the \
         fit filtered out), predicted by the identified model. Long logs are drawn as the minimum and \
         maximum of each pixel column (time plots) and as a random subsample (scatter plots).</p>\n",
    );
    let id = plots::step_color(1);
    let (shown, span, whole) = match (p.validation, p.held_out_from) {
        (Some(v), _) => (v.clone(), "validation log", v),
        (None, Some(k)) => (p.log.tail(k), "held-out tail", p.log),
        (None, None) => (p.log.clone(), "fitted log (nothing held out)", p.log),
    };
    let cut = if p.validation.is_some() { 0 } else { p.held_out_from.unwrap_or(whole.len()) };
    for (j, name) in p.report.joints.iter().enumerate() {
        let res = whole.residual(0, j);
        let mut parts = vec![];
        if cut > 0 {
            parts.push(("fitted part".to_string(), plots::NOMINAL, masked(&res, |k| k < cut)));
        }
        if cut < whole.len() {
            let what = if p.validation.is_some() { "validation log" } else { "held-out part" };
            parts.push((what.to_string(), id, masked(&res, |k| k >= cut)));
        }
        let models = [ModelTraces { label: "identified model".into(), color: id, residuals: parts }];
        let f = joint_figures(file, name, j, (&shown, span), whole, &models)?;
        joint_section(
            o,
            j,
            name,
            &f,
            &format!(
                "Measured torque and the identified model's prediction on the {span}; top: all of it, bottom: zoom."
            ),
            "Residual (measured - predicted by the identified model) over the plotted log, fitted and held-out parts.",
        );
    }
    Ok(())
}

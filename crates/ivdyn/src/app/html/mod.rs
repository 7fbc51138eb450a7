//! The HTML reports of `identify` and `payload` (`--report FILE.html`): one self-contained
//! page each, in the diagnosis report's style and built from the same parts
//! ([`crate::report::page`], the shared plots). Numbers in the tables are the JSON
//! report's; the plots show the conditioned log (before the parallel filter), predicted
//! by the models the JSON describes.

mod identify;
mod payload;

use std::path::Path;

pub use identify::{IdentifyPage, identify_page};
pub use payload::{PayloadPage, payload_page};

use crate::Robot;
use crate::error::{Error, Result};
use crate::log::JointLog;
use crate::prep::{self, ConditionOptions};
use crate::report::page::{esc, figure};
use crate::report::plots::{self, Png, StateAxis, Trace, column, zoom_window};

/// What a report plots of one log: the conditioned samples (as every fit sees them, before
/// the parallel filter) and the torque each model predicts there.
#[derive(Debug, Clone)]
pub struct Series {
    /// Joints.
    pub n: usize,
    /// Stamps (s from the log's start), `T`.
    pub t: Vec<f64>,
    /// Smoothed joint velocity, `T x n` row-major.
    pub qd: Vec<f64>,
    /// Measured torque, `T x n`.
    pub measured: Vec<f64>,
    /// Per model, `rnea(q, qd, qdd)` at the smoothed state, `T x n`.
    pub predicted: Vec<Vec<f64>>,
}

impl Series {
    /// Conditions `log` as the fits do (`condition`) and predicts its torque with each of
    /// `models`.
    pub fn of(models: &[&Robot], log: &JointLog, condition: &ConditionOptions) -> Result<Series> {
        let c = prep::condition(log, condition)?;
        let measured =
            c.tau.ok_or_else(|| Error::NoTorque { what: "log".into(), needed_by: "the HTML report".into() })?;
        let mut predicted = Vec::with_capacity(models.len());
        for m in models {
            let mut p = vec![0.0; c.d.q.len()];
            crate::batch::rnea_batch(m, &c.d.q, &c.d.qd, &c.d.qdd, &mut p)?;
            predicted.push(p);
        }
        Ok(Series { n: log.joint_names.len(), t: c.t, qd: c.d.qd, measured, predicted })
    }

    /// Samples.
    pub fn len(&self) -> usize {
        self.t.len()
    }

    /// Whether there is no sample.
    pub fn is_empty(&self) -> bool {
        self.t.is_empty()
    }

    /// Residual `measured - predicted[model]` of joint `j`, one value per sample.
    pub fn residual(&self, model: usize, j: usize) -> Vec<f64> {
        let (m, p) = (column(&self.measured, self.n, j), column(&self.predicted[model], self.n, j));
        m.iter().zip(&p).map(|(a, b)| a - b).collect()
    }

    /// The samples from `from` on.
    pub fn tail(&self, from: usize) -> Series {
        let from = from.min(self.len());
        let rows = |a: &[f64]| a[from * self.n..].to_vec();
        Series {
            n: self.n,
            t: self.t[from..].to_vec(),
            qd: rows(&self.qd),
            measured: rows(&self.measured),
            predicted: self.predicted.iter().map(|p| rows(p)).collect(),
        }
    }
}

/// `y` where `keep(k)` holds, NaN elsewhere: one trace per part of a log (the plots skip
/// non-finite values).
fn masked(y: &[f64], keep: impl Fn(usize) -> bool) -> Vec<f64> {
    y.iter().enumerate().map(|(k, &v)| if keep(k) { v } else { f64::NAN }).collect()
}

/// The figures of one joint.
struct JointFigures {
    torque: Png,
    residual: Png,
    velocity: Png,
}

/// The error for a figure that cannot be drawn (the report file is what fails).
fn plot_error(file: &Path, what: &str, msg: String) -> Error {
    Error::Io { file: file.to_path_buf(), source: std::io::Error::other(format!("cannot draw {what}: {msg}")) }
}

/// One model's traces for a joint's figures: the torque plot's label and colour, and the
/// residual traces (one per part of the log: label and values, NaN outside the part).
struct ModelTraces {
    label: String,
    color: plotters::style::RGBColor,
    residuals: Vec<(String, plotters::style::RGBColor, Vec<f64>)>,
}

/// Joint `j`'s figures: measured vs predicted torque over `shown` (`span` says which part of
/// the log, zoom where the last model's residual is largest); residual vs time and vs
/// velocity over `whole`, the traces of `models`.
fn joint_figures(
    file: &Path,
    name: &str,
    j: usize,
    (shown, span): (&Series, &str),
    whole: &Series,
    models: &[ModelTraces],
) -> Result<JointFigures> {
    let tau = column(&shown.measured, shown.n, j);
    let pred: Vec<Vec<f64>> = (0..models.len()).map(|k| column(&shown.predicted[k], shown.n, j)).collect();
    let mut torque = vec![Trace { label: "measured".into(), color: plots::MEASURED, y: &tau, width: 1 }];
    for (m, p) in models.iter().zip(&pred) {
        torque.push(Trace { label: m.label.clone(), color: m.color, y: p, width: 2 });
    }
    let last = shown.residual(models.len() - 1, j);
    let zoom = zoom_window(&shown.t, &last);
    let torque = plots::torque_vs_time(name, span, &shown.t, &torque, zoom, "the residual")
        .map_err(|e| plot_error(file, &format!("the torque plot of joint '{name}'"), e))?;
    let residual: Vec<Trace> = models
        .iter()
        .flat_map(|m| m.residuals.iter())
        .map(|(label, color, y)| Trace { label: label.clone(), color: *color, y, width: 1 })
        .collect();
    let residual_png = plots::residual_vs_time(name, &whole.t, &residual)
        .map_err(|e| plot_error(file, &format!("the residual plot of joint '{name}'"), e))?;
    let qd = column(&whole.qd, whole.n, j);
    let axes = [StateAxis { desc: "velocity qd (rad/s)", x: &qd }];
    let velocity = plots::residual_vs_state(name, &axes, &residual)
        .map_err(|e| plot_error(file, &format!("the residual-vs-velocity plot of joint '{name}'"), e))?;
    Ok(JointFigures { torque, residual: residual_png, velocity })
}

/// Writes one joint's section: its three figures with captions.
fn joint_section(o: &mut String, j: usize, name: &str, f: &JointFigures, torque_caption: &str, residual_caption: &str) {
    use std::fmt::Write as _;
    let _ = writeln!(o, "<h3 id=\"joint{j}\">{}</h3>", esc(name));
    figure(o, &f.torque, &format!("{name}: measured and predicted torque vs time"), torque_caption);
    figure(o, &f.residual, &format!("{name}: residual vs time"), residual_caption);
    figure(
        o,
        &f.velocity,
        &format!("{name}: residual vs velocity"),
        "Residual against the joint's velocity: a step at zero velocity is Coulomb friction the model lacks, \
         a slope viscous friction; what is left should be a band of noise around zero.",
    );
}

/// A bulleted list of `notes` (nothing when empty).
fn notes_list(o: &mut String, title: &str, notes: &[String]) {
    if notes.is_empty() {
        return;
    }
    o.push_str(&format!("<h2 id=\"notes\">{}</h2>\n<ul class=\"evidence\">\n", esc(title)));
    for n in notes {
        o.push_str(&format!("<li>{}</li>\n", esc(n)));
    }
    o.push_str("</ul>\n");
}

//! The report's figures: PNG images drawn with `plotters` into an RGB buffer, encoded with
//! `png`. Text uses DejaVu Sans embedded in the library (`assets/DejaVuSans.ttf`), so
//! nothing depends on system fonts or fontconfig (CI machines may have neither).
//!
//! Long logs are decimated for drawing only: time series keep the minimum and maximum of
//! every pixel column (the drawn envelope is exactly what all samples would draw), scatter
//! plots show a stratified random subsample of at most [`SCATTER_POINTS`] samples.

use std::sync::OnceLock;

use plotters::coord::Shift;
use plotters::prelude::*;
use plotters::style::text_anchor::{HPos, Pos, VPos};

use super::backend::Canvas;

/// Font family name the embedded font is registered under.
const FAMILY: &str = "sans-serif";

/// Pixel width of every figure: the page shows them unscaled (crisp at 100 % zoom).
pub(crate) const WIDTH: u32 = 1100;

/// Most points per scatter panel (per model).
pub(crate) const SCATTER_POINTS: usize = 4000;

/// Measured torque.
pub(crate) const MEASURED: RGBColor = RGBColor(40, 40, 40);
/// The nominal model.
pub(crate) const NOMINAL: RGBColor = RGBColor(31, 119, 180);
/// Models after step 1, 2, ... (the tab10 palette without its blue).
const STEPS: [RGBColor; 9] = [
    RGBColor(255, 127, 14),
    RGBColor(44, 160, 44),
    RGBColor(214, 39, 40),
    RGBColor(148, 103, 189),
    RGBColor(140, 86, 75),
    RGBColor(227, 119, 194),
    RGBColor(127, 127, 127),
    RGBColor(188, 189, 34),
    RGBColor(23, 190, 207),
];

/// Colour of the model after step `i` (1-based); step 0 is the nominal model.
pub(crate) fn step_color(i: usize) -> RGBColor {
    if i == 0 { NOMINAL } else { STEPS[(i - 1) % STEPS.len()] }
}

/// A PNG image.
#[derive(Debug, Clone)]
pub(crate) struct Png {
    /// Encoded bytes.
    pub bytes: Vec<u8>,
    /// Width in pixels.
    pub width: u32,
    /// Height in pixels.
    pub height: u32,
}

/// One line or point set of a figure.
pub(crate) struct Trace<'a> {
    /// Legend text.
    pub label: String,
    /// Colour.
    pub color: RGBColor,
    /// Values, one per sample.
    pub y: &'a [f64],
    /// Line width in pixels (0: in the legend only, not drawn).
    pub width: u32,
}

type Area<'a> = DrawingArea<Canvas<'a>, Shift>;
type DrawErr = Box<dyn std::error::Error>;

fn font(size: u32) -> TextStyle<'static> {
    (FAMILY, size).into_font().color(&BLACK)
}

/// Registers the embedded font once.
fn ensure_font() -> Result<(), String> {
    // plotters measures text with its registered font (layout), `Canvas` draws it.
    static OK: OnceLock<bool> = OnceLock::new();
    let ok = *OK
        .get_or_init(|| plotters::style::register_font(FAMILY, FontStyle::Normal, super::backend::FONT_BYTES).is_ok());
    if ok && super::backend::font().is_some() {
        Ok(())
    } else {
        Err("the embedded font (DejaVuSans.ttf) cannot be parsed".into())
    }
}

/// Draws into a white `width x height` RGB canvas and encodes it as PNG.
fn render(width: u32, height: u32, draw: impl FnOnce(&Area<'_>) -> Result<(), DrawErr>) -> Result<Png, String> {
    ensure_font()?;
    let mut buf = vec![255u8; width as usize * height as usize * 3];
    {
        let root = Canvas::with_buffer(&mut buf, (width, height)).into_drawing_area();
        draw(&root).map_err(|e| e.to_string())?;
        root.present().map_err(|e| e.to_string())?;
    }
    let mut bytes = Vec::new();
    {
        let mut enc = png::Encoder::new(&mut bytes, width, height);
        enc.set_color(png::ColorType::Rgb);
        enc.set_depth(png::BitDepth::Eight);
        // Balanced halves the page size against Fast (2.6 vs 5.7 MB for 6 joints, 60 s at
        // 1 kHz) for about 0.25 s more rendering in release.
        enc.set_compression(png::Compression::Balanced);
        let mut w = enc.write_header().map_err(|e| e.to_string())?;
        w.write_image_data(&buf).map_err(|e| e.to_string())?;
        w.finish().map_err(|e| e.to_string())?;
    }
    Ok(Png { bytes, width, height })
}

/// What a legend entry shows.
#[derive(Clone, Copy)]
pub(crate) enum Swatch {
    Line(u32),
    Dot,
    Bar,
}

/// A one-row legend drawn in its own strip (never over the data).
fn legend(area: &Area<'_>, items: &[(String, RGBColor, Swatch)]) -> Result<(), DrawErr> {
    let style = font(15);
    let (_, h) = area.dim_in_pixel();
    let yc = h as i32 / 2;
    let mut x = 70;
    for (label, color, swatch) in items {
        match swatch {
            Swatch::Line(w) => {
                area.draw(&PathElement::new(vec![(x, yc), (x + 28, yc)], color.stroke_width((*w).max(1) + 1)))?;
            }
            Swatch::Dot => area.draw(&Circle::new((x + 14, yc), 5, color.filled()))?,
            Swatch::Bar => area.draw(&Rectangle::new([(x + 4, yc - 7), (x + 24, yc + 7)], color.filled()))?,
        }
        x += 36;
        area.draw(&Text::new(label.clone(), (x, yc), style.pos(anchor(HPos::Left, VPos::Center))))?;
        let (tw, _) = area.estimate_text_size(label, &style)?;
        x += tw as i32 + 28;
    }
    Ok(())
}

fn anchor(h: HPos, v: VPos) -> Pos {
    Pos::new(h, v)
}

/// Tick label: the shortest decimal form (ticks are round numbers; this hides float noise
/// such as 0.30000000000000004).
fn tick(v: f64) -> String {
    if v.abs() < 1e-12 {
        return "0".into();
    }
    if v.abs() >= 1e5 || v.abs() < 1e-4 {
        return format!("{v:.1e}");
    }
    let s = format!("{v:.6}");
    let s = s.trim_end_matches('0').trim_end_matches('.');
    s.to_string()
}

/// `[lo, hi]` of the finite values of `ys`, padded by 5 % (a unit range if empty or flat).
fn y_range<'a>(ys: impl IntoIterator<Item = &'a [f64]>) -> (f64, f64) {
    let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
    for y in ys {
        for &v in y.iter().filter(|v| v.is_finite()) {
            lo = lo.min(v);
            hi = hi.max(v);
        }
    }
    if !lo.is_finite() {
        return (-1.0, 1.0);
    }
    let span = hi - lo;
    let pad =
        if span > 1e-12 * (1.0 + lo.abs().max(hi.abs())) { 0.05 * span } else { 0.5 * (1.0 + lo.abs()) * 1e-3 + 0.5 };
    (lo - pad, hi + pad)
}

/// Samples of `y(t)` with `t` in `[t0, t1]` reduced to the min and max of each of `cols`
/// equal time bins, in time order: a polyline through them covers exactly the pixels the
/// full series would.
pub(crate) fn envelope(t: &[f64], y: &[f64], t0: f64, t1: f64, cols: usize) -> Vec<(f64, f64)> {
    let lo = t.partition_point(|&x| x < t0);
    let hi = t.partition_point(|&x| x <= t1);
    let idx = lo..hi;
    if idx.len() <= 2 * cols || !(t1 > t0) {
        return idx.filter(|&k| y[k].is_finite()).map(|k| (t[k], y[k])).collect();
    }
    let mut out = Vec::with_capacity(2 * cols + 2);
    let bin_of = |x: f64| (((x - t0) / (t1 - t0) * cols as f64) as usize).min(cols - 1);
    let mut k = lo;
    while k < hi {
        let b = bin_of(t[k]);
        let (mut kmin, mut kmax) = (usize::MAX, usize::MAX);
        while k < hi && bin_of(t[k]) == b {
            if y[k].is_finite() {
                if kmin == usize::MAX || y[k] < y[kmin] {
                    kmin = k;
                }
                if kmax == usize::MAX || y[k] > y[kmax] {
                    kmax = k;
                }
            }
            k += 1;
        }
        if kmin == usize::MAX {
            continue;
        }
        let (a, b) = if kmin <= kmax { (kmin, kmax) } else { (kmax, kmin) };
        out.push((t[a], y[a]));
        if b != a {
            out.push((t[b], y[b]));
        }
    }
    out
}

/// At most `m` sample indices of `0..n`: one uniformly random index in each of `m` equal
/// strata (deterministic seed; random rather than strided so periodic trajectories do not alias).
pub(crate) fn subsample(n: usize, m: usize) -> Vec<usize> {
    if n <= m {
        return (0..n).collect();
    }
    let mut s: u64 = 0x9E37_79B9_7F4A_7C15;
    (0..m)
        .map(|i| {
            // xorshift64*
            s ^= s >> 12;
            s ^= s << 25;
            s ^= s >> 27;
            let u = (s.wrapping_mul(0x2545_F491_4F6C_DD1D) >> 11) as f64 / (1u64 << 53) as f64;
            (((i as f64 + u) * n as f64 / m as f64) as usize).min(n - 1)
        })
        .collect()
}

/// Column `j` of a row-major `T x n` array.
pub(crate) fn column(a: &[f64], n: usize, j: usize) -> Vec<f64> {
    a.iter().skip(j).step_by(n).copied().collect()
}

/// The time window (about a tenth of the log, 1 to 5 s) where the squared residual `r` is
/// largest; `None` when the log is too short for a zoom to show anything new.
pub(crate) fn zoom_window(t: &[f64], r: &[f64]) -> Option<(f64, f64)> {
    let (t0, t1) = (t[0], *t.last()?);
    let dur = t1 - t0;
    let w = (dur / 10.0).clamp(1.0, 5.0);
    if !(dur > 3.0 * w) {
        return None;
    }
    // Prefix sums of r^2 (non-finite values count as 0) for O(T) sliding windows.
    let mut cum = Vec::with_capacity(r.len() + 1);
    cum.push(0.0);
    for &v in r {
        cum.push(cum.last().unwrap() + if v.is_finite() { v * v } else { 0.0 });
    }
    let (mut best, mut best_k) = (f64::NEG_INFINITY, 0);
    let mut hi = 0;
    for k in 0..t.len() {
        if t[k] + w > t1 {
            break;
        }
        while hi < t.len() && t[hi] <= t[k] + w {
            hi += 1;
        }
        let s = cum[hi] - cum[k];
        if s > best {
            best = s;
            best_k = k;
        }
    }
    Some((t[best_k], t[best_k] + w))
}

/// One time-series panel: every trace against `t` over `[t0, t1]`.
fn time_panel(
    area: &Area<'_>,
    caption: &str,
    t: &[f64],
    (t0, t1): (f64, f64),
    traces: &[Trace<'_>],
    y_desc: &str,
) -> Result<(), DrawErr> {
    // a single sample still gets a (1 s wide) axis
    let t1 = if t1 > t0 { t1 } else { t0 + 1.0 };
    let lo = t.partition_point(|&x| x < t0);
    let hi = t.partition_point(|&x| x <= t1).max(lo);
    let (ylo, yhi) = y_range(traces.iter().map(|tr| &tr.y[lo..hi]));
    let mut chart = ChartBuilder::on(area)
        .caption(caption, font(17))
        .margin(8)
        .margin_right(20)
        .x_label_area_size(46)
        .y_label_area_size(78)
        .build_cartesian_2d(t0..t1, ylo..yhi)?;
    chart
        .configure_mesh()
        .x_desc("time (s)")
        .y_desc(y_desc)
        .label_style(font(14))
        .axis_desc_style(font(15))
        .light_line_style(RGBColor(238, 238, 238))
        .bold_line_style(RGBColor(205, 205, 205))
        .max_light_lines(1)
        .x_labels(12)
        .y_labels(7)
        .x_label_formatter(&|v| tick(*v))
        .y_label_formatter(&|v| tick(*v))
        .draw()?;
    let (px, py) = chart.plotting_area().dim_in_pixel();
    // One pixel in y, in data units.
    let dy = (yhi - ylo) / py.max(1) as f64;
    for tr in traces {
        let pts = envelope(t, tr.y, t0, t1, px.max(1) as usize);
        // Thick lines as 1-px polylines shifted by whole pixels: plotters' polygonised wide
        // strokes put long miter spikes at the sharp turns of an envelope or a friction jump.
        for k in 0..tr.width {
            let off = k as f64 * dy;
            chart.draw_series(LineSeries::new(pts.iter().map(|&(x, y)| (x, y + off)), tr.color.stroke_width(1)))?;
        }
    }
    Ok(())
}

/// Measured vs predicted torque of one joint over all of `t` (`span` says what that is,
/// e.g. "whole log"), and a zoom on `zoom` (where `largest`, e.g. "the nominal residual",
/// is largest).
pub(crate) fn torque_vs_time(
    joint: &str,
    span: &str,
    t: &[f64],
    traces: &[Trace<'_>],
    zoom: Option<(f64, f64)>,
    largest: &str,
) -> Result<Png, String> {
    let full = (t[0], *t.last().unwrap_or(&t[0]));
    let h_full = 330;
    let h_zoom = if zoom.is_some() { 290 } else { 0 };
    render(WIDTH, 40 + h_full + h_zoom, |root| {
        root.fill(&WHITE)?;
        let (top, rest) = root.split_vertically(40);
        let items: Vec<_> = traces.iter().map(|tr| (tr.label.clone(), tr.color, Swatch::Line(tr.width))).collect();
        legend(&top, &items)?;
        let (a, b) = rest.split_vertically(h_full);
        time_panel(&a, &format!("{joint}: measured and predicted torque, {span}"), t, full, traces, "torque (N m)")?;
        if let Some(z) = zoom {
            let cap = format!("{joint}: zoom on t = {:.1} to {:.1} s (where {largest} is largest)", z.0, z.1);
            time_panel(&b, &cap, t, z, traces, "torque (N m)")?;
        }
        Ok(())
    })
}

/// Residual (measured - predicted) of one joint vs time, one trace per model.
pub(crate) fn residual_vs_time(joint: &str, t: &[f64], traces: &[Trace<'_>]) -> Result<Png, String> {
    let full = (t[0], *t.last().unwrap_or(&t[0]));
    render(WIDTH, 40 + 330, |root| {
        root.fill(&WHITE)?;
        let (top, rest) = root.split_vertically(40);
        let items: Vec<_> = traces.iter().map(|tr| (tr.label.clone(), tr.color, Swatch::Line(tr.width))).collect();
        legend(&top, &items)?;
        time_panel(
            &rest,
            &format!("{joint}: residual = measured - predicted torque"),
            t,
            full,
            traces,
            "residual (N m)",
        )
    })
}

/// A state signal of one joint (x axis of a scatter panel).
pub(crate) struct StateAxis<'a> {
    /// Axis description with unit.
    pub desc: &'a str,
    /// Values, one per sample.
    pub x: &'a [f64],
}

/// Residual of one joint vs its position, velocity and acceleration (one panel each),
/// for each model in `traces` (e.g. nominal and final), on a common random subsample.
pub(crate) fn residual_vs_state(joint: &str, axes: &[StateAxis<'_>], traces: &[Trace<'_>]) -> Result<Png, String> {
    let n = axes.first().map(|a| a.x.len()).unwrap_or(0);
    let idx = subsample(n, SCATTER_POINTS);
    let (ylo, yhi) = y_range(traces.iter().map(|tr| tr.y));
    render(WIDTH, 40 + 380, |root| {
        root.fill(&WHITE)?;
        let (top, rest) = root.split_vertically(40);
        let mut items: Vec<_> = traces.iter().map(|tr| (tr.label.clone(), tr.color, Swatch::Dot)).collect();
        if let Some(last) = items.last_mut().filter(|_| idx.len() < n) {
            last.0 = format!("{} ({} of {n} samples shown)", last.0, idx.len());
        }
        legend(&top, &items)?;
        let panels = rest.split_evenly((1, axes.len().max(1)));
        for (k, (area, ax)) in panels.iter().zip(axes).enumerate() {
            let (xlo, xhi) = y_range([ax.x]);
            let cap = if k == 0 { format!("{joint}: residual vs state") } else { String::new() };
            let mut chart = ChartBuilder::on(area)
                .caption(cap, font(17))
                .margin(8)
                .margin_right(14)
                .x_label_area_size(46)
                .y_label_area_size(if k == 0 { 78 } else { 52 })
                .build_cartesian_2d(xlo..xhi, ylo..yhi)?;
            let mut mesh = chart.configure_mesh();
            mesh.x_desc(ax.desc)
                .label_style(font(14))
                .axis_desc_style(font(15))
                .light_line_style(RGBColor(238, 238, 238))
                .bold_line_style(RGBColor(205, 205, 205))
                .max_light_lines(1)
                .x_labels(6)
                .y_labels(7)
                .x_label_formatter(&|v| tick(*v))
                .y_label_formatter(&|v| tick(*v));
            if k == 0 {
                mesh.y_desc("residual (N m)");
            }
            mesh.draw()?;
            for tr in traces {
                let style = tr.color.mix(0.35).filled();
                let pts = idx.iter().filter(|&&i| ax.x[i].is_finite() && tr.y[i].is_finite());
                chart.draw_series(pts.map(|&i| Circle::new((ax.x[i], tr.y[i]), 2, style)))?;
            }
        }
        Ok(())
    })
}

/// RMS residual per joint (groups) and model (bars), with the noise estimate as a line.
pub(crate) fn rms_bars(joints: &[String], bars: &[(String, RGBColor, Vec<f64>)], noise: &[f64]) -> Result<Png, String> {
    let nj = joints.len();
    let ymax =
        bars.iter().flat_map(|b| b.2.iter()).chain(noise).copied().filter(|v| v.is_finite()).fold(0.0f64, f64::max);
    let ymax = if ymax > 0.0 { ymax * 1.1 } else { 1.0 };
    render(WIDTH, 40 + 400, |root| {
        root.fill(&WHITE)?;
        let (top, rest) = root.split_vertically(40);
        let mut items: Vec<_> = bars.iter().map(|b| (b.0.clone(), b.1, Swatch::Bar)).collect();
        items.push(("sensor noise std (estimate)".into(), BLACK, Swatch::Line(2)));
        legend(&top, &items)?;
        let mut chart = ChartBuilder::on(&rest)
            .caption("RMS residual per joint, before and after each step", font(17))
            .margin(8)
            .margin_right(20)
            .x_label_area_size(46)
            .y_label_area_size(78)
            .build_cartesian_2d(0f64..nj as f64, 0f64..ymax)?;
        chart
            .configure_mesh()
            .disable_x_mesh()
            .y_desc("RMS residual (N m)")
            .label_style(font(14))
            .axis_desc_style(font(15))
            .light_line_style(RGBColor(238, 238, 238))
            .bold_line_style(RGBColor(205, 205, 205))
            .max_light_lines(1)
            .x_labels(0)
            .y_labels(8)
            .y_label_formatter(&|v| tick(*v))
            .draw()?;
        // Joint names under the group centres (drawn on the root: absolute pixel coordinates).
        for (j, name) in joints.iter().enumerate() {
            let (px, py) = chart.backend_coord(&(j as f64 + 0.5, 0.0));
            root.draw(&Text::new(name.clone(), (px, py + 12), font(15).pos(anchor(HPos::Center, VPos::Top))))?;
        }
        let m = bars.len().max(1) as f64;
        let w = 0.8 / m;
        for (b, (_, color, v)) in bars.iter().enumerate() {
            let rects = v.iter().enumerate().filter(|(_, y)| y.is_finite()).map(|(j, &y)| {
                let x0 = j as f64 + 0.1 + b as f64 * w;
                Rectangle::new([(x0 + 0.1 * w, 0.0), (x0 + 0.9 * w, y)], color.filled())
            });
            chart.draw_series(rects)?;
        }
        let lines =
            noise.iter().enumerate().filter(|(_, y)| y.is_finite()).map(|(j, &y)| {
                PathElement::new(vec![(j as f64 + 0.06, y), (j as f64 + 0.94, y)], BLACK.stroke_width(2))
            });
        chart.draw_series(lines)?;
        Ok(())
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn envelope_keeps_extremes_in_time_order() {
        let t: Vec<f64> = (0..1000).map(|k| k as f64 * 1e-3).collect();
        let y: Vec<f64> = (0..1000)
            .map(|k| {
                if k == 501 {
                    5.0
                } else if k == 502 {
                    -4.0
                } else {
                    (k % 7) as f64 * 0.1
                }
            })
            .collect();
        let e = envelope(&t, &y, 0.0, 0.999, 10);
        assert!(e.len() <= 20);
        assert!(e.windows(2).all(|w| w[0].0 <= w[1].0), "time order");
        assert!(e.contains(&(t[501], 5.0)) && e.contains(&(t[502], -4.0)));
        // every bin without a spike spans exactly the 0..0.6 range of the saw-tooth
        assert!(e.iter().filter(|p| p.0 < 0.5).any(|p| p.1 == 0.0));
        assert!(e.iter().filter(|p| p.0 < 0.5).any(|p| (p.1 - 0.6).abs() < 1e-12));
    }

    #[test]
    fn subsample_is_sorted_unique_and_bounded() {
        let s = subsample(60_000, 4000);
        assert_eq!(s.len(), 4000);
        assert!(s.windows(2).all(|w| w[0] < w[1]));
        assert!(*s.last().unwrap() < 60_000);
        assert_eq!(subsample(10, 4000), (0..10).collect::<Vec<_>>());
    }

    #[test]
    fn ticks_are_short() {
        assert_eq!(tick(0.30000000000000004), "0.3");
        assert_eq!(tick(-2.0), "-2");
        assert_eq!(tick(1e-13), "0");
        assert_eq!(tick(12.5), "12.5");
    }
}

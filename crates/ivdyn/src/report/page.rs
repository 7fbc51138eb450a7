//! The page every report shares: the HTML skeleton (inline style sheet, no script, no
//! external file or network access), images as `data:image/png;base64` URIs, escaping
//! and the number formats (documented in `docs/diagnose.md` and `docs/cli.md`).

use std::fmt::Write as _;

use base64::Engine as _;

use super::plots::Png;

/// HTML-escapes text (element content and attribute values).
pub fn esc(s: &str) -> String {
    let mut out = String::with_capacity(s.len());
    for c in s.chars() {
        match c {
            '&' => out.push_str("&amp;"),
            '<' => out.push_str("&lt;"),
            '>' => out.push_str("&gt;"),
            '"' => out.push_str("&quot;"),
            '\'' => out.push_str("&#39;"),
            c => out.push(c),
        }
    }
    out
}

/// A number with 3 significant digits (`2.50`, `0.123`, `12.3`, `1235`), scientific
/// below 1e-3 or from 1e4 on (`1.23e-5`), `0` for zero and an en dash for NaN/inf
/// (not available).
pub fn fmt_num(x: f64) -> String {
    if !x.is_finite() {
        return "\u{2013}".into();
    }
    if x == 0.0 {
        return "0".into();
    }
    let a = x.abs();
    if !(1e-3..1e4).contains(&a) {
        return format!("{x:.2e}");
    }
    let decimals = (2 - a.log10().floor() as i32).max(0) as usize;
    format!("{x:.decimals$}")
}

/// A p-value: [`fmt_num`], or `< 1e-16` below what double precision resolves near 1.
pub fn fmt_p(p: f64) -> String {
    if p.is_finite() && p < 1e-16 { "&lt; 1e-16".into() } else { fmt_num(p) }
}

/// A fraction as a percentage: one decimal within +-1000 % (`87.3 %`), else
/// [`fmt_num`] of the percentage (`-3.77e7 %`, a gain relative to a near-zero excess).
pub fn fmt_pct(x: f64) -> String {
    let pct = 100.0 * x;
    if !pct.is_finite() {
        "\u{2013}".into()
    } else if pct.abs() < 0.05 {
        "0.0\u{a0}%".into() // not "-0.0 %"
    } else if pct.abs() < 1000.0 {
        format!("{pct:.1}\u{a0}%")
    } else {
        format!("{}\u{a0}%", fmt_num(pct))
    }
}

/// An `<img>` of `png` as a base64 data URI (nothing outside the page is loaded).
pub(crate) fn img(png: &Png, alt: &str) -> String {
    let b64 = base64::engine::general_purpose::STANDARD.encode(&png.bytes);
    format!(
        "<img src=\"data:image/png;base64,{b64}\" width=\"{}\" height=\"{}\" alt=\"{}\">",
        png.width,
        png.height,
        esc(alt)
    )
}

/// A `<figure>` of `png` with its caption (`caption` is HTML: escape text that needs it).
pub(crate) fn figure(out: &mut String, png: &Png, alt: &str, caption: &str) {
    let _ = writeln!(out, "<figure>{}<figcaption>{caption}</figcaption></figure>", img(png, alt));
}

/// The style sheet of every report page.
const CSS: &str = r#"
:root { --fg: #1d232b; --muted: #5b6675; --line: #d5dbe3; --head: #eef2f7; --ok: #1e7b34; --warn: #a35a00; }
* { box-sizing: border-box; }
body { font-family: "DejaVu Sans", "Segoe UI", system-ui, -apple-system, Helvetica, Arial, sans-serif;
       color: var(--fg); font-size: 16px; line-height: 1.45; margin: 0; background: #f7f8fa; }
main { max-width: 1180px; margin: 0 auto; padding: 24px 28px 60px; background: #fff; }
h1 { font-size: 30px; margin: 0 0 4px; }
h2 { font-size: 23px; margin: 38px 0 10px; padding-bottom: 4px; border-bottom: 2px solid var(--line); }
h3 { font-size: 19px; margin: 26px 0 8px; }
p, li { max-width: 60em; }
.sub { color: var(--muted); margin: 0 0 2px; }
.sub code { font-size: 14px; }
code { font-family: "DejaVu Sans Mono", Menlo, Consolas, monospace; font-size: 15px; }
.verdict { font-size: 28px; font-weight: bold; padding: 16px 22px; margin: 20px 0; border-radius: 6px;
           border-left: 10px solid; }
.verdict.clean { background: #eaf6ec; border-color: var(--ok); color: #124d20; }
.verdict.found { background: #fff4e5; border-color: var(--warn); color: #5e3400; }
nav { font-size: 15px; margin: 8px 0 0; }
nav a { margin-right: 14px; }
table { border-collapse: collapse; margin: 10px 0 14px; font-size: 15px; }
th, td { border: 1px solid var(--line); padding: 4px 10px; vertical-align: top; }
th { background: var(--head); text-align: left; font-weight: 600; }
table.candidates { font-size: 14px; }
table.candidates th, table.candidates td { padding: 2px 8px; }
#regimes-table th { min-width: 5.2em; }
td.n { text-align: right; font-variant-numeric: tabular-nums; white-space: nowrap; }
tr.accepted td { background: #eaf6ec; }
td.sig { font-weight: bold; color: var(--ok); }
td.dim { color: var(--muted); }
.unit { font-weight: normal; color: var(--muted); font-size: 13px; }
figure { margin: 14px 0 24px; }
figure img { display: block; max-width: 100%; height: auto; border: 1px solid var(--line); }
figcaption { color: var(--muted); font-size: 14px; margin-top: 4px; max-width: 75em; }
.evidence li { margin: 3px 0; }
.note { color: var(--muted); font-size: 14px; }
footer { margin-top: 40px; color: var(--muted); font-size: 13px; }
"#;

/// The last component of `path` (the whole of it when it has none).
pub fn file_name(path: &str) -> String {
    std::path::Path::new(path).file_name().map(|s| s.to_string_lossy().into_owned()).unwrap_or_else(|| path.to_string())
}

/// A table header's unit, `" (N m)"` in muted type; nothing for no unit.
pub fn unit(u: &str) -> String {
    if u.is_empty() { String::new() } else { format!(" <span class=\"unit\">({u})</span>") }
}

/// Starts a page titled `title`: everything up to and including `<main>`.
pub fn open(o: &mut String, title: &str) {
    let _ = writeln!(
        o,
        "<!DOCTYPE html>\n<html lang=\"en\">\n<head>\n<meta charset=\"utf-8\">\n\
         <meta name=\"viewport\" content=\"width=device-width, initial-scale=1\">\n\
         <title>{}</title>\n<style>{CSS}</style>\n</head>\n<body>\n<main>",
        esc(title)
    );
}

/// Ends a page written by `ivdyn <command>`: the footer (version, units), then `</html>`.
pub fn close(o: &mut String, command: &str) {
    let _ = writeln!(
        o,
        "<footer>Written by ivdyn {} (<code>ivdyn {}</code>). Units are for revolute joints; \
         for a prismatic joint read N for N m and m for rad.</footer>\n</main>\n</body>\n</html>",
        env!("CARGO_PKG_VERSION"),
        esc(command)
    );
}

/// A right-aligned number cell: `x` shown with [`fmt_num`], and exactly (shortest
/// round-trip form, as in the JSON report) in its `data-v` attribute, so a reader or a
/// test can take the full value off the page.
pub fn num_cell(x: f64) -> String {
    let v = if x.is_finite() { format!("{x:?}") } else { "null".into() };
    format!("<td class=\"n\" data-v=\"{v}\">{}</td>", fmt_num(x))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn numbers_have_three_significant_digits() {
        assert_eq!(fmt_num(2.5), "2.50");
        assert_eq!(fmt_num(0.1234), "0.123");
        assert_eq!(fmt_num(12.345), "12.3");
        assert_eq!(fmt_num(-3.21), "-3.21");
        assert_eq!(fmt_num(1234.4), "1234");
        assert_eq!(fmt_num(1.234e-5), "1.23e-5");
        assert_eq!(fmt_num(0.0), "0");
        assert_eq!(fmt_num(f64::NAN), "\u{2013}");
        assert_eq!(fmt_pct(0.873), "87.3\u{a0}%");
        assert_eq!(fmt_pct(-0.0001), "0.0\u{a0}%");
        assert_eq!(fmt_pct(-377092.817), "-3.77e7\u{a0}%");
    }

    #[test]
    fn escapes_markup() {
        assert_eq!(esc("a<b & \"c\""), "a&lt;b &amp; &quot;c&quot;");
    }
}

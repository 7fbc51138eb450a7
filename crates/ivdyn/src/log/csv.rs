//! CSV joint logs: one row per sample, a header row naming the columns.
//!
//! * `t`: time in seconds (non-decreasing);
//! * `<joint>.q` (required for every wanted joint), `<joint>.qd`, `<joint>.tau`,
//!   `<joint>.u`, `<joint>.i` (motor current, A) (optional; a field is read when every
//!   wanted joint has it, and a field that only some joints have is an error);
//! * any other column (other joints, other signals) is ignored;
//! * separator `,`; blank lines and lines starting with `#` are skipped; a comment
//!   `# t0_ns: <int>` sets [`JointLog::t0_ns`] (written by [`write_csv`]).
//!
//! Values are parsed with Rust's `f64` parser (`1e-3`, `-0.5`, `inf`, `NaN` are numbers,
//! the last two rejected as non-finite). Written values use the shortest representation
//! that parses back to the same `f64`, so a write/read round trip is exact.

use std::fs::File;
use std::io::{BufRead, BufReader, BufWriter, Write};
use std::path::Path;

use super::{JointLog, first_duplicate, name_list};
use crate::error::{Error, Result};

/// Column suffixes, in the order of [`JointLog`]'s arrays (`i`: [`JointLog::current`]).
const FIELDS: [&str; 5] = ["q", "qd", "tau", "u", "i"];

/// Reads a CSV joint log, returning the joints in the order of `joint_names`.
pub fn read_csv<S: AsRef<str>>(path: impl AsRef<Path>, joint_names: &[S]) -> Result<JointLog> {
    let path = path.as_ref();
    let file = File::open(path).map_err(|e| Error::Io { file: path.to_path_buf(), source: e })?;
    read_csv_from(BufReader::new(file), path, joint_names)
}

/// [`read_csv`] on any buffered byte source; `path` names it in error messages.
pub fn read_csv_from<S: AsRef<str>>(rd: impl BufRead, path: &Path, joint_names: &[S]) -> Result<JointLog> {
    let err = |msg: String| log_err(path, msg);
    let io = |e: std::io::Error| Error::Io { file: path.to_path_buf(), source: e };
    let want: Vec<String> = joint_names.iter().map(|s| s.as_ref().to_string()).collect();
    if want.is_empty() {
        return Err(err("no joint names given to match the log against".into()));
    }
    let mut header: Option<Header> = None;
    let mut log = JointLog { joint_names: want.clone(), ..Default::default() };
    let mut data: [Vec<f64>; 5] = Default::default();
    let (mut rd, mut buf, mut lineno) = (rd, Vec::new(), 0);
    while next_line(&mut rd, &mut buf).map_err(io)? {
        lineno += 1;
        if buf.len() > MAX_CSV_LINE {
            return Err(err(format!(
                "line {lineno} is longer than {MAX_CSV_LINE} bytes: not a joint log (a binary file?)"
            )));
        }
        let s = std::str::from_utf8(&buf).map_err(|e| err(format!("line {lineno} is not UTF-8 text: {e}")))?.trim();
        if s.is_empty() {
            continue;
        }
        if let Some(c) = s.strip_prefix('#') {
            if let Some(v) = c.trim().strip_prefix("t0_ns:") {
                log.t0_ns = v.trim().parse().map_err(|_| err(format!("line {lineno}: bad t0_ns '{}'", v.trim())))?;
            }
            continue;
        }
        let cells: Vec<&str> = s.split(',').map(str::trim).collect();
        match &header {
            None => header = Some(Header::parse(path, &cells, &want, lineno)?),
            Some(h) => h.read_row(path, &cells, lineno, &mut log.t, &mut data)?,
        }
    }
    let Some(header) = header.filter(|_| !log.t.is_empty()) else {
        return Err(err("no samples (a header row and at least one data row are needed)".into()));
    };
    let [q, qd, tau, u, current] = data;
    let cols = header.cols;
    log.q = q;
    log.qd = cols[1].is_some().then_some(qd);
    log.tau = cols[2].is_some().then_some(tau);
    log.u = cols[3].is_some().then_some(u);
    log.current = cols[4].is_some().then_some(current);
    Ok(log)
}

/// Longest CSV line read (bytes): a log's row is some tens of bytes per joint and field; a
/// longer "line" is not a joint log (a binary file, a file without newlines), and reading
/// it whole would allocate its length.
pub const MAX_CSV_LINE: usize = 1 << 20;

/// The next line of `rd` into `buf` (newline stripped), reading at most one byte more than
/// [`MAX_CSV_LINE`]; `false` at the end of the input.
fn next_line(rd: &mut impl BufRead, buf: &mut Vec<u8>) -> std::io::Result<bool> {
    buf.clear();
    let n = std::io::Read::take(&mut *rd, MAX_CSV_LINE as u64 + 1).read_until(b'\n', buf)?;
    while buf.last().is_some_and(|c| *c == b'\n' || *c == b'\r') {
        buf.pop();
    }
    Ok(n > 0)
}

/// A log error naming the file `path`.
fn log_err(path: &Path, msg: String) -> Error {
    Error::Log { file: path.to_path_buf(), msg }
}

/// The columns named by the header row.
struct Header {
    /// Column names (quotes stripped).
    names: Vec<String>,
    /// Wanted joints.
    want: Vec<String>,
    /// Column of `t`.
    tcol: usize,
    /// Per field of [`FIELDS`], the column of each wanted joint (`None`: the field is absent).
    cols: [Option<Vec<usize>>; 5],
}

impl Header {
    /// Finds `t` and each wanted joint's field columns in the header `cells` (line `lineno`):
    /// `q` must be there for every joint, another field for all joints or none.
    fn parse(path: &Path, cells: &[&str], want: &[String], lineno: usize) -> Result<Header> {
        let err = |msg: String| log_err(path, msg);
        let h: Vec<String> = cells.iter().map(|c| c.trim_matches('"').to_string()).collect();
        if let Some((name, a, b)) = first_duplicate(&h) {
            return Err(err(format!("line {lineno}: column '{name}' appears twice (columns {} and {})", a + 1, b + 1)));
        }
        let tcol = h.iter().position(|c| c == "t").ok_or_else(|| {
            err(format!("line {lineno}: no time column 't' in the header; columns are {}", name_list(&h)))
        })?;
        let mut cols: [Option<Vec<usize>>; 5] = Default::default();
        for (fi, f) in FIELDS.iter().enumerate() {
            let idx: Vec<Option<usize>> =
                want.iter().map(|j| h.iter().position(|c| *c == format!("{j}.{f}"))).collect();
            let missing: Vec<&str> =
                want.iter().zip(&idx).filter(|(_, i)| i.is_none()).map(|(j, _)| j.as_str()).collect();
            if missing.is_empty() {
                cols[fi] = Some(idx.into_iter().map(Option::unwrap).collect());
            } else if *f == "q" || missing.len() < want.len() {
                let have: Vec<&String> = h.iter().filter(|c| c.ends_with(&format!(".{f}"))).collect();
                return Err(err(format!(
                    "columns {} are missing (joints {}); the file has {}",
                    name_list(&missing.iter().map(|j| format!("{j}.{f}")).collect::<Vec<_>>()),
                    name_list(&missing),
                    name_list(&have)
                )));
            }
        }
        Ok(Header { names: h, want: want.to_vec(), tcol, cols })
    }

    /// Reads the data row `cells` (line `lineno`): the time (finite, non-decreasing) onto
    /// `t`, each present field's finite values onto `data`.
    fn read_row(
        &self,
        path: &Path,
        cells: &[&str],
        lineno: usize,
        t: &mut Vec<f64>,
        data: &mut [Vec<f64>; 5],
    ) -> Result<()> {
        let err = |msg: String| log_err(path, msg);
        let h = &self.names;
        let k = t.len();
        if cells.len() != h.len() {
            return Err(err(format!("line {lineno} (sample {k}): {} cells, the header has {}", cells.len(), h.len())));
        }
        let num = |c: usize| -> Result<f64> {
            cells[c].parse::<f64>().map_err(|_| {
                err(format!("line {lineno} (sample {k}): column '{}': '{}' is not a number", h[c], cells[c]))
            })
        };
        let tk = num(self.tcol)?;
        if !tk.is_finite() {
            return Err(err(format!("line {lineno} (sample {k}): time is {tk}")));
        }
        if let Some(&prev) = t.last()
            && tk < prev
        {
            return Err(err(format!(
                "line {lineno} (sample {k}): time goes back ({tk} s after {prev} s at sample {})",
                k - 1
            )));
        }
        t.push(tk);
        for (fi, f) in FIELDS.iter().enumerate() {
            let Some(ix) = &self.cols[fi] else { continue };
            for (j, &c) in ix.iter().enumerate() {
                let v = num(c)?;
                if !v.is_finite() {
                    return Err(err(format!("line {lineno} (sample {k}): joint '{}' {f} is {v}", self.want[j])));
                }
                data[fi].push(v);
            }
        }
        Ok(())
    }
}

/// Writes a joint log as CSV (columns `t`, then `<joint>.q` for every joint, then `.qd`,
/// `.tau`, `.u`, `.i` when present), with a `# t0_ns: ...` comment line first, all or
/// nothing ([`crate::output`]).
pub fn write_csv(path: impl AsRef<Path>, log: &JointLog) -> Result<()> {
    log.check_shapes()?;
    let arrays: Vec<(&str, &[f64])> = FIELDS
        .into_iter()
        .zip([Some(&log.q), log.qd.as_ref(), log.tau.as_ref(), log.u.as_ref(), log.current.as_ref()])
        .filter_map(|(f, a)| a.map(|a| (f, a.as_slice())))
        .collect();
    write_columns(path.as_ref(), log.t0_ns, &log.joint_names, &log.t, &arrays)
}

/// Writes CSV columns `t`, then `<joint>.<field>` for every joint of every `(field, T x N
/// array)` in order, shortest round-trip decimals, after a `# t0_ns: ...` comment line;
/// all or nothing ([`crate::output::write_atomic`]).
pub fn write_columns(path: &Path, t0_ns: i64, joints: &[String], t: &[f64], arrays: &[(&str, &[f64])]) -> Result<()> {
    let n = joints.len();
    for (f, a) in arrays {
        if a.len() != t.len() * n {
            return Err(Error::Dimension {
                what: format!("CSV column block {f}"),
                expected: t.len() * n,
                got: a.len(),
            });
        }
    }
    crate::output::write_atomic(path, |tmp| {
        let io = |e: std::io::Error| Error::Io { file: tmp.to_path_buf(), source: e };
        let mut w = BufWriter::new(File::create(tmp).map_err(io)?);
        writeln!(w, "# t0_ns: {t0_ns}").map_err(io)?;
        let mut head = vec!["t".to_string()];
        for (f, _) in arrays {
            head.extend(joints.iter().map(|j| format!("{j}.{f}")));
        }
        writeln!(w, "{}", head.join(",")).map_err(io)?;
        let mut line = String::new();
        for k in 0..t.len() {
            use std::fmt::Write as _;
            line.clear();
            let _ = write!(line, "{:?}", t[k]);
            for (_, a) in arrays {
                for v in &a[k * n..(k + 1) * n] {
                    let _ = write!(line, ",{v:?}");
                }
            }
            writeln!(w, "{line}").map_err(io)?;
        }
        w.into_inner().map_err(|e| io(e.into_error()))?.sync_all().map_err(io)
    })
}

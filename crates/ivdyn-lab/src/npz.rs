//! NumPy `.npy` arrays and `.npz` archives (what `np.save` / `np.savez` write), read
//! without Python.
//!
//! * `.npy` (format versions 1.0, 2.0, 3.0): magic `\x93NUMPY`, version, header length,
//!   then a Python-literal header `{'descr': '<f8', 'fortran_order': False, 'shape': (T, N), }`
//!   and the raw data. Little- and big-endian `f8`, `f4`, `i8`, `i4`, `u1` are read and
//!   converted to `f64` (`i8` beyond 2^53 would lose precision and is rejected).
//!   Fortran-ordered arrays are transposed into row-major order.
//! * `.npz`: a ZIP archive of `.npy` members. The central directory (ZIP64 sizes and
//!   offsets included) locates the members. Only **stored** members are read, which is
//!   what `np.savez` writes; `np.savez_compressed` deflates them, and that is reported as
//!   an error naming the member (re-save with `np.savez`).
//!
//! References: NEP 1 (the `.npy` format, numpy.lib.format); PKWARE APPNOTE.TXT 6.3
//! (sections 4.3.7 local header, 4.3.12 central directory, 4.3.16 end record, 4.5.3 ZIP64).

use std::collections::BTreeMap;
use std::path::Path;

use ivdyn::error::{Error, Result};

/// One array: `shape` and its values in row-major (C) order, converted to `f64`.
#[derive(Debug, Clone, PartialEq)]
pub struct NpyArray {
    /// Dimensions (empty for a scalar).
    pub shape: Vec<usize>,
    /// Values, row-major.
    pub data: Vec<f64>,
}

impl NpyArray {
    /// Rows and columns of a 1-D (`T` -> `T x 1`) or 2-D array; other ranks are errors.
    pub fn rows_cols(&self) -> Option<(usize, usize)> {
        match self.shape[..] {
            [t] => Some((t, 1)),
            [t, n] => Some((t, n)),
            _ => None,
        }
    }
}

fn err(file: &Path, msg: String) -> Error {
    Error::Log { file: file.to_path_buf(), msg }
}

fn u16_at(b: &[u8], i: usize) -> Option<u16> {
    Some(u16::from_le_bytes(b.get(i..i + 2)?.try_into().ok()?))
}
fn u32_at(b: &[u8], i: usize) -> Option<u32> {
    Some(u32::from_le_bytes(b.get(i..i + 4)?.try_into().ok()?))
}
fn u64_at(b: &[u8], i: usize) -> Option<u64> {
    Some(u64::from_le_bytes(b.get(i..i + 8)?.try_into().ok()?))
}

/// Reads a `.npy` file.
pub fn read_npy(path: impl AsRef<Path>) -> Result<NpyArray> {
    let path = path.as_ref();
    let bytes = std::fs::read(path).map_err(|e| Error::Io { file: path.to_path_buf(), source: e })?;
    parse_npy(&bytes).map_err(|m| err(path, m))
}

/// Reads every member of a `.npz` archive, keyed by name without the `.npy` suffix.
pub fn read_npz(path: impl AsRef<Path>) -> Result<BTreeMap<String, NpyArray>> {
    let path = path.as_ref();
    let bytes = std::fs::read(path).map_err(|e| Error::Io { file: path.to_path_buf(), source: e })?;
    let mut out = BTreeMap::new();
    for m in zip_members(&bytes).map_err(|m| err(path, m))? {
        if m.method != 0 {
            return Err(err(
                path,
                format!(
                    "member '{}' is compressed (ZIP method {}); only stored members are read: re-save the arrays with np.savez, not np.savez_compressed",
                    m.name, m.method
                ),
            ));
        }
        let data = bytes
            .get(m.data_start..m.data_start + m.size)
            .ok_or_else(|| err(path, format!("member '{}' runs past the end of the file (truncated?)", m.name)))?;
        let arr = parse_npy(data).map_err(|e| err(path, format!("member '{}': {e}", m.name)))?;
        let key = m.name.strip_suffix(".npy").unwrap_or(&m.name).to_string();
        out.insert(key, arr);
    }
    Ok(out)
}

/// A ZIP member: name, compression method, uncompressed size, where its data start.
struct Member {
    name: String,
    method: u16,
    size: usize,
    data_start: usize,
}

/// Lists the members from the central directory (APPNOTE 4.3.12, 4.3.16, 4.5.3).
fn zip_members(b: &[u8]) -> std::result::Result<Vec<Member>, String> {
    const EOCD: u32 = 0x0605_4b50;
    const EOCD64_LOC: u32 = 0x0706_4b50;
    const CEN: u32 = 0x0201_4b50;
    const LOC: u32 = 0x0403_4b50;
    if b.len() < 22 {
        return Err("not a ZIP (.npz) archive: too short".into());
    }
    // the end record is the last 22 bytes plus a comment of up to 65535 bytes
    let lo = b.len().saturating_sub(22 + 65535);
    let eocd = (lo..=b.len() - 22)
        .rev()
        .find(|&i| u32_at(b, i) == Some(EOCD))
        .ok_or("not a ZIP (.npz) archive: no end-of-central-directory record")?;
    let mut count = u16_at(b, eocd + 10).ok_or("truncated end record")? as u64;
    let mut cd_off = u32_at(b, eocd + 16).ok_or("truncated end record")? as u64;
    if (count == 0xFFFF || cd_off == 0xFFFF_FFFF) && eocd >= 20 && u32_at(b, eocd - 20) == Some(EOCD64_LOC) {
        let e64 = u64_at(b, eocd - 20 + 8).ok_or("truncated ZIP64 locator")? as usize;
        count = u64_at(b, e64 + 32).ok_or("truncated ZIP64 end record")?;
        cd_off = u64_at(b, e64 + 48).ok_or("truncated ZIP64 end record")?;
    }
    let mut out = vec![];
    let mut p = cd_off as usize;
    for k in 0..count {
        if u32_at(b, p) != Some(CEN) {
            return Err(format!("central directory entry {k} is damaged"));
        }
        let bad = || format!("central directory entry {k} is truncated");
        let method = u16_at(b, p + 10).ok_or_else(bad)?;
        let mut csize = u32_at(b, p + 20).ok_or_else(bad)? as u64;
        let mut usize_ = u32_at(b, p + 24).ok_or_else(bad)? as u64;
        let (nlen, xlen, clen) = (
            u16_at(b, p + 28).ok_or_else(bad)? as usize,
            u16_at(b, p + 30).ok_or_else(bad)? as usize,
            u16_at(b, p + 32).ok_or_else(bad)? as usize,
        );
        let mut local = u32_at(b, p + 42).ok_or_else(bad)? as u64;
        let name = String::from_utf8_lossy(b.get(p + 46..p + 46 + nlen).ok_or_else(bad)?).into_owned();
        // ZIP64 extra field (id 1): the 64-bit values of whichever fields are 0xFFFFFFFF, in order
        let extra = b.get(p + 46 + nlen..p + 46 + nlen + xlen).ok_or_else(bad)?;
        let mut x = 0;
        while x + 4 <= extra.len() {
            let (id, len) = (u16_at(extra, x).unwrap_or(0), u16_at(extra, x + 2).unwrap_or(0) as usize);
            if id == 1 {
                let mut f = x + 4;
                for v in [&mut usize_, &mut csize, &mut local] {
                    if *v == 0xFFFF_FFFF {
                        *v = u64_at(extra, f).ok_or_else(bad)?;
                        f += 8;
                    }
                }
            }
            x += 4 + len;
        }
        let lh = local as usize;
        if u32_at(b, lh) != Some(LOC) {
            return Err(format!("member '{name}': local header missing at offset {lh}"));
        }
        let data_start =
            lh + 30 + u16_at(b, lh + 26).ok_or_else(bad)? as usize + u16_at(b, lh + 28).ok_or_else(bad)? as usize;
        let size = if method == 0 { usize_ } else { csize };
        out.push(Member { name, method, size: size as usize, data_start });
        p += 46 + nlen + xlen + clen;
    }
    Ok(out)
}

/// Value of `'key': ...` in the npy header dict (up to the next `,` at depth 0 or `}`).
fn header_value<'a>(h: &'a str, key: &str) -> Option<&'a str> {
    let pat_a = format!("'{key}'");
    let pat_b = format!("\"{key}\"");
    let i = h.find(&pat_a).map(|i| i + pat_a.len()).or_else(|| h.find(&pat_b).map(|i| i + pat_b.len()))?;
    let rest = h[i..].trim_start().strip_prefix(':')?.trim_start();
    let mut depth = 0i32;
    for (k, c) in rest.char_indices() {
        match c {
            '(' | '[' => depth += 1,
            ')' | ']' => depth -= 1,
            ',' | '}' if depth == 0 => return Some(rest[..k].trim()),
            _ => {}
        }
    }
    Some(rest.trim())
}

/// Parses a whole `.npy` byte string (NEP 1).
fn parse_npy(b: &[u8]) -> std::result::Result<NpyArray, String> {
    if b.len() < 10 || &b[..6] != b"\x93NUMPY" {
        return Err("not a .npy array (no \\x93NUMPY magic)".into());
    }
    let (hlen, hstart) = match b[6] {
        1 => (u16_at(b, 8).ok_or("truncated header")? as usize, 10),
        2 | 3 => (u32_at(b, 8).ok_or("truncated header")? as usize, 12),
        v => return Err(format!(".npy format version {v} is not supported (1, 2, 3 are)")),
    };
    let header = std::str::from_utf8(b.get(hstart..hstart + hlen).ok_or("truncated header")?)
        .map_err(|_| "header is not text")?;
    let descr = header_value(header, "descr").ok_or("header has no 'descr'")?.trim_matches(|c| c == '\'' || c == '"');
    let fortran = match header_value(header, "fortran_order") {
        Some("True") => true,
        Some("False") | None => false,
        Some(v) => return Err(format!("fortran_order '{v}' is not True/False")),
    };
    let shape_s = header_value(header, "shape").ok_or("header has no 'shape'")?;
    let shape: Vec<usize> = shape_s
        .trim_matches(|c| c == '(' || c == ')')
        .split(',')
        .map(str::trim)
        .filter(|s| !s.is_empty())
        .map(|s| s.trim_end_matches('L').parse::<usize>().map_err(|_| format!("bad shape {shape_s}")))
        .collect::<std::result::Result<_, _>>()?;
    let count: usize = shape.iter().product();
    let (order, kind) = descr.split_at(1.min(descr.len()));
    let little = match order {
        "<" | "|" | "=" => true,
        ">" => false,
        _ => return Err(format!("dtype '{descr}' has no byte order")),
    };
    let width = match kind {
        "f8" | "i8" => 8,
        "f4" | "i4" => 4,
        "u1" | "b1" => 1,
        _ => return Err(format!("dtype '{descr}' is not supported (f8, f4, i8, i4, u1, b1 are)")),
    };
    let body = &b[hstart + hlen..];
    if body.len() < count * width {
        return Err(format!(
            "data truncated: shape {shape:?} of '{descr}' needs {} bytes, {} present",
            count * width,
            body.len()
        ));
    }
    let word = |k: usize| -> [u8; 8] {
        let mut w = [0u8; 8];
        let s = &body[k * width..(k + 1) * width];
        if little {
            w[..width].copy_from_slice(s);
        } else {
            for (i, v) in s.iter().rev().enumerate() {
                w[i] = *v;
            }
        }
        w
    };
    let mut data = Vec::with_capacity(count);
    for k in 0..count {
        let w = word(k);
        data.push(match kind {
            "f8" => f64::from_le_bytes(w),
            "f4" => f32::from_le_bytes(w[..4].try_into().expect("4 bytes")) as f64,
            "i8" => {
                let v = i64::from_le_bytes(w);
                if v.unsigned_abs() > 1 << 53 {
                    return Err(format!("element {k}: int64 {v} is not exactly representable as f64"));
                }
                v as f64
            }
            "i4" => i32::from_le_bytes(w[..4].try_into().expect("4 bytes")) as f64,
            _ => w[0] as f64,
        });
    }
    if fortran && shape.len() > 1 {
        data = fortran_to_c(&data, &shape);
    }
    Ok(NpyArray { shape, data })
}

/// Reorders column-major (Fortran) data of `shape` into row-major order.
fn fortran_to_c(data: &[f64], shape: &[usize]) -> Vec<f64> {
    let n = data.len();
    let mut out = vec![0.0; n];
    let mut idx = vec![0usize; shape.len()];
    for (c_pos, o) in out.iter_mut().enumerate() {
        // row-major index -> multi-index -> column-major position
        let mut r = c_pos;
        for d in (0..shape.len()).rev() {
            idx[d] = r % shape[d];
            r /= shape[d];
        }
        let (mut f_pos, mut stride) = (0, 1);
        for d in 0..shape.len() {
            f_pos += idx[d] * stride;
            stride *= shape[d];
        }
        *o = data[f_pos];
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    fn npy(descr: &str, fortran: bool, shape: &str, body: &[u8]) -> Vec<u8> {
        let mut h = format!(
            "{{'descr': '{descr}', 'fortran_order': {}, 'shape': {shape}, }}",
            if fortran { "True" } else { "False" }
        );
        while (10 + h.len() + 1) % 64 != 0 {
            h.push(' ');
        }
        h.push('\n');
        let mut b = b"\x93NUMPY\x01\x00".to_vec();
        b.extend((h.len() as u16).to_le_bytes());
        b.extend(h.as_bytes());
        b.extend(body);
        b
    }

    #[test]
    fn npy_orders_and_types() {
        let vals = [1.0f64, 2.0, 3.0, 4.0, 5.0, 6.0];
        let le: Vec<u8> = vals.iter().flat_map(|v| v.to_le_bytes()).collect();
        let a = parse_npy(&npy("<f8", false, "(2, 3)", &le)).unwrap();
        assert_eq!((a.shape.clone(), a.data.clone()), (vec![2, 3], vals.to_vec()));
        // the same bytes as a Fortran-ordered 3 x 2 array: columns [1 2 3], [4 5 6]
        let f = parse_npy(&npy("<f8", true, "(3, 2)", &le)).unwrap();
        assert_eq!(f.data, vec![1.0, 4.0, 2.0, 5.0, 3.0, 6.0]);
        let be: Vec<u8> = vals.iter().flat_map(|v| (*v as f32).to_be_bytes()).collect();
        assert_eq!(parse_npy(&npy(">f4", false, "(6,)", &be)).unwrap().data, vals.to_vec());
        let i: Vec<u8> = [-3i32, 7].iter().flat_map(|v| v.to_le_bytes()).collect();
        assert_eq!(parse_npy(&npy("<i4", false, "(2,)", &i)).unwrap().data, vec![-3.0, 7.0]);
        let e = parse_npy(&npy("<c16", false, "(1,)", &[0; 16])).unwrap_err();
        assert!(e.contains("'<c16' is not supported"), "{e}");
        let e = parse_npy(&npy("<f8", false, "(4,)", &le[..16])).unwrap_err();
        assert!(e.contains("needs 32 bytes, 16 present"), "{e}");
    }
}

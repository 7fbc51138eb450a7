//! Signal conditioning for identification logs: zero-phase low-pass filtering,
//! differentiation (Butterworth + central differences, or Savitzky-Golay), resampling of
//! uneven stamps, duplicate removal, decimation with a parallel anti-alias filter, and
//! outlier rejection (Hampel).
//!
//! Arrays are row-major `T x M` (`x[k * m + j]`: column `j` at sample `k`), columns are
//! processed independently. Every filter here is **linear**, so filtering the torque and
//! every column of the stacked regressor with the same [`Butterworth`] (or
//! [`Decimator`]) keeps `tau = Y theta` exact: `F(Y theta) = F(Y) theta` to rounding
//! (the "parallel filtering" of identification practice).
//!
//! Defaults (see `docs/logs.md`): a 4th-order Butterworth whose zero-phase (forward-
//! backward) response is -3 dB at **20 Hz** (capped at `0.2 fs` for slow logs). Robot
//! motion in identification runs (excitation trajectories of a few Hz, accelerations that
//! the drives can follow) lies below ~10 Hz, while the structural resonances of arms and
//! the encoder quantisation noise that differentiation amplifies lie above; a fixed
//! physical cut-off works the same at 500 Hz and at 5 kHz, where a cut-off tied to the
//! sample rate would let 10x more noise through at 5 kHz.

use crate::error::{Error, Result};

/// Default zero-phase cut-off frequency (Hz) for differentiation.
pub const DEFAULT_CUTOFF_HZ: f64 = 20.0;
/// Default Butterworth order (per pass; the forward-backward filter has twice the slope).
pub const DEFAULT_ORDER: usize = 4;

fn bad(msg: impl Into<String>) -> Error {
    Error::Signal { msg: msg.into() }
}

fn check_shape(x: &[f64], m: usize, what: &str) -> Result<usize> {
    if m == 0 || !x.len().is_multiple_of(m) {
        return Err(bad(format!("{what}: {} values is not a whole number of rows of {m} columns", x.len())));
    }
    Ok(x.len() / m)
}

/// The cut-off used by default at sample rate `fs`: 20 Hz, or `0.2 fs` if lower.
pub fn default_cutoff(fs: f64) -> f64 {
    DEFAULT_CUTOFF_HZ.min(0.2 * fs)
}

/// Lowest differentiation cut-off accepted, as a fraction of the sample rate. Below it the
/// bilinear design's coefficients round to an integrator (`1 + a1 + a2 = 0` at 1e-30 fs,
/// so the filter state is NaN), the edge transients span the whole log and the automatic
/// decimation factor `fs / (2.5 fc)` overflows; 1e-4 fs is 0.05 Hz at 500 Hz.
pub const MIN_CUTOFF_FRACTION: f64 = 1e-4;
/// Highest cut-off accepted, as a fraction of the sample rate: below the Nyquist frequency
/// `fs / 2` with room for the zero-phase design's raised single-pass cut-off (x1.116 for
/// order 4; at 0.45 fs its pre-warped frequency is past `fs / 2`).
pub const MAX_CUTOFF_FRACTION: f64 = 0.4;

/// The differentiation cut-off (Hz) for sample rate `fs`: `cutoff_hz`, or
/// [`default_cutoff`] when `None`, checked against `[1e-4 fs, 0.4 fs]`
/// ([`MIN_CUTOFF_FRACTION`], [`MAX_CUTOFF_FRACTION`]). The error names the option
/// (`--cutoff`, `cutoff` in Python) and the range at this log's rate; with the default
/// it points at the stamps, since only an absurd sample rate puts 20 Hz out of range.
pub fn resolve_cutoff(cutoff_hz: Option<f64>, fs: f64) -> Result<f64> {
    if !(fs.is_finite() && fs > 0.0) {
        return Err(bad(format!("sample rate {fs} Hz must be finite and positive (check the log's stamps)")));
    }
    let (lo, hi) = (MIN_CUTOFF_FRACTION * fs, MAX_CUTOFF_FRACTION * fs);
    let c = cutoff_hz.unwrap_or_else(|| default_cutoff(fs));
    if c.is_finite() && c >= lo && c <= hi {
        return Ok(c);
    }
    let (lo, hi, c, nyq, fs_s) = (num(lo), num(hi), num(c), num(0.5 * fs), num(fs));
    let range = format!("[{lo}, {hi}] Hz (1e-4 fs to 0.4 fs, below the Nyquist frequency {nyq} Hz)");
    Err(bad(match cutoff_hz {
        Some(_) => {
            format!("cutoff (--cutoff) {c} Hz is out of range at the log's sample rate {fs_s} Hz: allowed {range}")
        }
        None => format!(
            "the default cut-off {c} Hz is out of range at the log's sample rate {fs_s} Hz (sample spacing {} s): allowed {range}; check the log's stamps (units?) or give --cutoff",
            num(1.0 / fs)
        ),
    }))
}

/// `x` for a message: plain in the usual range, else in exponent form (1e-30, not 31 zeros).
fn num(x: f64) -> String {
    if x == 0.0 || (1e-3..1e6).contains(&x.abs()) {
        format!("{}", (x * 1e6).round() / 1e6)
    } else {
        // four significant digits: 9.999999999999956e24 reads as 1e25
        format!("{:e}", format!("{x:.3e}").parse::<f64>().unwrap_or(x))
    }
}

/// Median of the positive stamp differences (`None` if there are none).
pub fn median_dt(t: &[f64]) -> Option<f64> {
    let mut d: Vec<f64> = t.windows(2).map(|w| w[1] - w[0]).filter(|d| *d > 0.0).collect();
    if d.is_empty() {
        return None;
    }
    d.sort_by(f64::total_cmp);
    Some(d[d.len() / 2])
}

/// Rows `rows` of a `T x m` array.
pub fn take_rows(x: &[f64], m: usize, rows: &[usize]) -> Vec<f64> {
    let mut out = Vec::with_capacity(rows.len() * m);
    for &k in rows {
        out.extend_from_slice(&x[k * m..(k + 1) * m]);
    }
    out
}

// ---------------------------------------------------------------------------------------
// Butterworth low-pass, second-order sections, forward-backward filtering
// ---------------------------------------------------------------------------------------

/// A digital Butterworth low-pass as a cascade of second-order sections (bilinear
/// transform with pre-warping), for causal [`filter`](Self::filter) or zero-phase
/// [`filtfilt`](Self::filtfilt) use.
#[derive(Debug, Clone, PartialEq)]
pub struct Butterworth {
    /// Order of one pass.
    pub order: usize,
    /// The requested cut-off (Hz); see the constructors for which gain it marks.
    pub cutoff_hz: f64,
    /// Sample rate (Hz).
    pub fs: f64,
    /// Sections `[b0, b1, b2, a1, a2]` (`a0 = 1`).
    pub sections: Vec<[f64; 5]>,
    /// Samples of odd-symmetric extension added at each end by `filtfilt`
    /// (default `6 fs / cutoff`, at least 27; capped at `T - 1`).
    pub padlen: usize,
}

impl Butterworth {
    /// Single-pass design: gain `1/sqrt(2)` (-3 dB) at `cutoff_hz` for one pass, so -6 dB
    /// after [`filtfilt`](Self::filtfilt) (the convention of SciPy's `butter`).
    pub fn lowpass(order: usize, cutoff_hz: f64, fs: f64) -> Result<Self> {
        Self::design(order, cutoff_hz, fs, 1.0)
    }

    /// Zero-phase design: the forward-backward filter ([`filtfilt`](Self::filtfilt)) has
    /// gain `1/sqrt(2)` (-3 dB) at `cutoff_hz` (the single-pass cut-off is raised by
    /// `(sqrt 2 - 1)^(-1/(2 order))`, x1.116 for order 4). What the defaults use.
    pub fn zero_phase(order: usize, cutoff_hz: f64, fs: f64) -> Result<Self> {
        let scale = (std::f64::consts::SQRT_2 - 1.0).powf(-1.0 / (2.0 * order.max(1) as f64));
        Self::design(order, cutoff_hz, fs, scale)
    }

    /// The default differentiation filter at sample rate `fs`
    /// (`zero_phase(DEFAULT_ORDER, default_cutoff(fs), fs)`).
    pub fn default_for(fs: f64) -> Result<Self> {
        Self::zero_phase(DEFAULT_ORDER, default_cutoff(fs), fs)
    }

    fn design(order: usize, cutoff_hz: f64, fs: f64, scale: f64) -> Result<Self> {
        if !(1..=20).contains(&order) {
            return Err(bad(format!("Butterworth order {order} out of range 1..=20")));
        }
        if !(fs.is_finite() && fs > 0.0 && cutoff_hz.is_finite() && cutoff_hz > 0.0 && cutoff_hz < 0.5 * fs) {
            return Err(bad(format!("cut-off {cutoff_hz} Hz must be in (0, fs/2) for sample rate {fs} Hz")));
        }
        let k = (std::f64::consts::PI * cutoff_hz / fs).tan() * scale;
        let mut sections = vec![];
        for i in 0..order / 2 {
            let theta = (2 * i + 1) as f64 * std::f64::consts::PI / (2 * order) as f64;
            let q = 1.0 / (2.0 * theta.sin());
            let norm = 1.0 / (1.0 + k / q + k * k);
            let b0 = k * k * norm;
            sections.push([b0, 2.0 * b0, b0, 2.0 * (k * k - 1.0) * norm, (1.0 - k / q + k * k) * norm]);
        }
        if order % 2 == 1 {
            let b0 = k / (1.0 + k);
            sections.push([b0, b0, 0.0, (k - 1.0) / (k + 1.0), 0.0]);
        }
        let padlen = ((6.0 * fs / cutoff_hz).ceil() as usize).max(27);
        Ok(Butterworth { order, cutoff_hz, fs, sections, padlen })
    }

    /// Single-pass magnitude response at `f_hz` (square it for `filtfilt`).
    pub fn gain(&self, f_hz: f64) -> f64 {
        let w = 2.0 * std::f64::consts::PI * f_hz / self.fs;
        let (c1, s1, c2, s2) = (w.cos(), -w.sin(), (2.0 * w).cos(), -(2.0 * w).sin());
        let mut g = 1.0;
        for s in &self.sections {
            let (nr, ni) = (s[0] + s[1] * c1 + s[2] * c2, s[1] * s1 + s[2] * s2);
            let (dr, di) = (1.0 + s[3] * c1 + s[4] * c2, s[3] * s1 + s[4] * s2);
            g *= ((nr * nr + ni * ni) / (dr * dr + di * di)).sqrt();
        }
        g
    }

    /// Causal single pass, started in steady state at `x[0]` (no start-up transient on a
    /// constant signal).
    pub fn filter(&self, x: &[f64]) -> Vec<f64> {
        let mut y = x.to_vec();
        if let Some(&x0) = x.first() {
            let mut z = vec![0.0; 2 * self.sections.len()];
            self.steady_state(&mut z, &[x0]);
            self.run_rows(&mut z, &mut y, 1, false);
        }
        y
    }

    /// Zero-phase forward-backward filtering of one signal (gain squared, no phase lag).
    /// Ends: odd-symmetric extension by `padlen` samples (continues the local trend) and
    /// steady-state initial conditions, so a ramp or a constant passes unchanged.
    pub fn filtfilt(&self, x: &[f64]) -> Vec<f64> {
        self.filtfilt_columns(x, 1).expect("one column")
    }

    /// [`filtfilt`](Self::filtfilt) on every column of a row-major `T x m` array: apply it
    /// to the torque and to the stacked regressor alike. The passes sweep whole rows (the
    /// columns' recursions side by side, memory in order), each column's numbers bit for
    /// bit those of the column alone.
    pub fn filtfilt_columns(&self, x: &[f64], m: usize) -> Result<Vec<f64>> {
        let t = check_shape(x, m, "filtfilt_columns")?;
        if t < 2 {
            return Ok(x.to_vec());
        }
        let p = self.padlen.min(t - 1);
        let row = |k: usize| &x[k * m..(k + 1) * m];
        // odd-symmetric extensions: 2 x[0] - x[i] before, 2 x[T-1] - x[T-1-i] after
        let head: Vec<f64> = (1..=p).rev().flat_map(|i| row(0).iter().zip(row(i)).map(|(a, b)| 2.0 * a - b)).collect();
        let mut tail: Vec<f64> =
            (1..=p).flat_map(|i| row(t - 1).iter().zip(row(t - 1 - i)).map(|(a, b)| 2.0 * a - b)).collect();
        let mut y = x.to_vec();
        let mut z = vec![0.0; 2 * self.sections.len() * m];
        // forward over head, signal, tail; backward over tail and signal (the head's
        // backward outputs are not kept and cannot change the signal's)
        self.steady_state(&mut z, &head[..m]);
        self.run_rows(&mut z, &mut head.clone(), m, false);
        self.run_rows(&mut z, &mut y, m, false);
        self.run_rows(&mut z, &mut tail, m, false);
        self.steady_state(&mut z, &tail[(p - 1) * m..]);
        self.run_rows(&mut z, &mut tail, m, true);
        self.run_rows(&mut z, &mut y, m, true);
        Ok(y)
    }

    /// The states `z` (per section `[z1 (m), z2 (m)]`) of every section in steady state
    /// for the constant input `level` (`m` columns): a pass started there has no start-up
    /// transient.
    pub fn steady_state(&self, z: &mut [f64], level: &[f64]) {
        let m = level.len();
        let mut lv = level.to_vec();
        for (s, sec) in self.sections.iter().enumerate() {
            let [b0, b1, b2, a1, a2] = *sec;
            // the section's DC gain; its input level is the previous section's output level
            let g = (b0 + b1 + b2) / (1.0 + a1 + a2);
            let (z1, z2) = z[2 * s * m..2 * (s + 1) * m].split_at_mut(m);
            for j in 0..m {
                z2[j] = (b2 - a2 * g) * lv[j];
                z1[j] = (b1 - a1 * g) * lv[j] + z2[j];
                lv[j] *= g;
            }
        }
    }

    /// Every section over the rows of the row-major `x` (`m` columns) in place, first to
    /// last or (`reverse`) last to first, the states `z` carried (see
    /// [`steady_state`](Self::steady_state)). The inner loops run across a row's columns,
    /// which the compiler vectorises (AVX2 chosen at run time when the CPU has it; no fused
    /// multiply-add, so the numbers are the same on every CPU).
    pub fn run_rows(&self, z: &mut [f64], x: &mut [f64], m: usize, reverse: bool) {
        #[cfg(target_arch = "x86_64")]
        if std::is_x86_feature_detected!("avx2") {
            // SAFETY: the CPU supports AVX2 (checked just above); the function is the same
            // safe code compiled with it.
            unsafe { run_rows_avx2(&self.sections, z, x, m, reverse) };
            return;
        }
        run_rows_generic(&self.sections, z, x, m, reverse)
    }
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
unsafe fn run_rows_avx2(sections: &[[f64; 5]], z: &mut [f64], x: &mut [f64], m: usize, reverse: bool) {
    run_rows_generic(sections, z, x, m, reverse)
}

#[inline(always)]
fn run_rows_generic(sections: &[[f64; 5]], z: &mut [f64], x: &mut [f64], m: usize, reverse: bool) {
    let rows = x.len() / m;
    for r in 0..rows {
        let r = if reverse { rows - 1 - r } else { r };
        let row = &mut x[r * m..(r + 1) * m];
        for (s, sec) in sections.iter().enumerate() {
            let [b0, b1, b2, a1, a2] = *sec;
            let (z1, z2) = z[2 * s * m..2 * (s + 1) * m].split_at_mut(m);
            // transposed direct form II: y = b0 x + z1; z1' = b1 x - a1 y + z2; z2' = b2 x - a2 y
            for ((v, z1), z2) in row.iter_mut().zip(z1.iter_mut()).zip(z2.iter_mut()) {
                let x = *v;
                let out = b0 * x + *z1;
                *z1 = b1 * x - a1 * out + *z2;
                *z2 = b2 * x - a2 * out;
                *v = out;
            }
        }
    }
}

// ---------------------------------------------------------------------------------------
// Differentiation
// ---------------------------------------------------------------------------------------

/// First derivative of every column by central differences (second-order one-sided
/// differences at the ends), uniform sample time `dt`.
pub fn central_diff(x: &[f64], m: usize, dt: f64) -> Result<Vec<f64>> {
    let t = check_shape(x, m, "central_diff")?;
    let mut d = vec![0.0; x.len()];
    let at = |k: usize, j: usize| x[k * m + j];
    for j in 0..m {
        for k in 0..t {
            d[k * m + j] = match (t, k) {
                (1, _) => 0.0,
                (2, _) => (at(1, j) - at(0, j)) / dt,
                (_, 0) => (-3.0 * at(0, j) + 4.0 * at(1, j) - at(2, j)) / (2.0 * dt),
                (_, k) if k == t - 1 => (3.0 * at(k, j) - 4.0 * at(k - 1, j) + at(k - 2, j)) / (2.0 * dt),
                (_, k) => (at(k + 1, j) - at(k - 1, j)) / (2.0 * dt),
            };
        }
    }
    Ok(d)
}

/// Second derivative of every column: `(x[k+1] - 2 x[k] + x[k-1]) / dt^2` inside,
/// second-order one-sided four-point differences at the ends (needs `T >= 4`, else the
/// nearest inside value).
pub fn second_diff(x: &[f64], m: usize, dt: f64) -> Result<Vec<f64>> {
    let t = check_shape(x, m, "second_diff")?;
    let mut d = vec![0.0; x.len()];
    if t < 3 {
        return Ok(d);
    }
    let at = |k: usize, j: usize| x[k * m + j];
    let h2 = dt * dt;
    for j in 0..m {
        for k in 1..t - 1 {
            d[k * m + j] = (at(k + 1, j) - 2.0 * at(k, j) + at(k - 1, j)) / h2;
        }
        if t >= 4 {
            d[j] = (2.0 * at(0, j) - 5.0 * at(1, j) + 4.0 * at(2, j) - at(3, j)) / h2;
            let k = t - 1;
            d[k * m + j] = (2.0 * at(k, j) - 5.0 * at(k - 1, j) + 4.0 * at(k - 2, j) - at(k - 3, j)) / h2;
        } else {
            d[j] = d[m + j];
            d[(t - 1) * m + j] = d[(t - 2) * m + j];
        }
    }
    Ok(d)
}

/// Savitzky-Golay smoothing and differentiation: a least-squares polynomial of `order`
/// fitted over a sliding window of `window` (odd) samples. Exact for polynomials of
/// degree `<= order`, including at the ends (where the first/last full window's fit is
/// evaluated off-centre).
#[derive(Debug, Clone, PartialEq)]
pub struct SavitzkyGolay {
    /// Window length (odd).
    pub window: usize,
    /// Polynomial order (`< window`).
    pub order: usize,
    /// `(order+1) x window` least-squares solve matrix on positions `u = (i - h) / h`.
    g: Vec<f64>,
}

impl SavitzkyGolay {
    /// A filter with this window (odd, >= 3) and polynomial order (< window).
    pub fn new(window: usize, order: usize) -> Result<Self> {
        if window < 3 || window.is_multiple_of(2) || order >= window {
            return Err(bad(format!(
                "Savitzky-Golay window {window} must be odd and >= 3, and the order {order} below it"
            )));
        }
        let h = (window / 2) as f64;
        let p = order + 1;
        let a: Vec<f64> = (0..window)
            .flat_map(|i| {
                let u = (i as f64 - h) / h;
                (0..p).map(move |j| u.powi(j as i32))
            })
            .collect();
        // normal equations (A^T A) G = A^T, solved by Gauss-Jordan with partial pivoting
        let mut ata = vec![0.0; p * p];
        for r in 0..p {
            for c in 0..p {
                ata[r * p + c] = (0..window).map(|i| a[i * p + r] * a[i * p + c]).sum();
            }
        }
        let mut g: Vec<f64> = (0..p * window).map(|idx| a[(idx % window) * p + idx / window]).collect();
        for col in 0..p {
            let piv = (col..p).max_by(|&x, &y| ata[x * p + col].abs().total_cmp(&ata[y * p + col].abs())).unwrap();
            if ata[piv * p + col].abs() < 1e-300 {
                return Err(bad("Savitzky-Golay normal equations are singular"));
            }
            for c in 0..p {
                ata.swap(col * p + c, piv * p + c);
            }
            for c in 0..window {
                g.swap(col * window + c, piv * window + c);
            }
            let d = ata[col * p + col];
            for r in 0..p {
                if r == col {
                    continue;
                }
                let f = ata[r * p + col] / d;
                if f == 0.0 {
                    continue;
                }
                for c in 0..p {
                    ata[r * p + c] -= f * ata[col * p + c];
                }
                for c in 0..window {
                    g[r * window + c] -= f * g[col * window + c];
                }
            }
        }
        for r in 0..p {
            let d = ata[r * p + r];
            for c in 0..window {
                g[r * window + c] /= d;
            }
        }
        Ok(SavitzkyGolay { window, order, g })
    }

    /// A window giving roughly a -3 dB frequency of `cutoff_hz` at sample rate `fs` for
    /// this polynomial order (Schafer 2011: `f3dB ~ (order + 1) / (3.2 window - 4.6) fs`).
    pub fn for_cutoff(order: usize, cutoff_hz: f64, fs: f64) -> Result<Self> {
        let w = (((order + 1) as f64 * fs / cutoff_hz + 4.6) / 3.2).round() as usize;
        let w = (w.max(order + 2)) | 1;
        Self::new(w, order)
    }

    /// Weights for derivative `deriv` at window position `u0` (in units of the half width).
    fn weights(&self, deriv: usize, u0: f64, scale: f64) -> Vec<f64> {
        let mut w = vec![0.0; self.window];
        for j in deriv..=self.order {
            // d^deriv/du^deriv of u^j = j!/(j-deriv)! u^(j-deriv)
            let fall: f64 = ((j - deriv + 1)..=j).map(|v| v as f64).product();
            let c = fall * u0.powi((j - deriv) as i32) * scale;
            for (i, wi) in w.iter_mut().enumerate() {
                *wi += c * self.g[j * self.window + i];
            }
        }
        w
    }

    /// Derivative `deriv` (0 = smoothing) of every column of a `T x m` array with sample
    /// time `dt`. Needs `T >= window` and `deriv <= order`.
    pub fn apply(&self, x: &[f64], m: usize, deriv: usize, dt: f64) -> Result<Vec<f64>> {
        let t = check_shape(x, m, "savitzky_golay")?;
        if t < self.window {
            return Err(bad(format!("Savitzky-Golay window {} is longer than the {t} samples", self.window)));
        }
        if deriv > self.order {
            return Err(bad(format!("derivative {deriv} above the polynomial order {}", self.order)));
        }
        let h = self.window / 2;
        let scale = (1.0 / (h as f64 * dt)).powi(deriv as i32);
        let centre = self.weights(deriv, 0.0, scale);
        let mut out = vec![0.0; x.len()];
        let conv = |out: &mut [f64], k: usize, start: usize, w: &[f64]| {
            for j in 0..m {
                out[k * m + j] = w.iter().enumerate().map(|(i, wi)| wi * x[(start + i) * m + j]).sum();
            }
        };
        for k in h..t - h {
            conv(&mut out, k, k - h, &centre);
        }
        for k in 0..h {
            let w = self.weights(deriv, (k as f64 - h as f64) / h as f64, scale);
            conv(&mut out, k, 0, &w);
            let w = self.weights(deriv, (h - k) as f64 / h as f64, scale);
            conv(&mut out, t - 1 - k, t - self.window, &w);
        }
        Ok(out)
    }
}

/// How [`differentiate`] smooths and differentiates.
#[derive(Debug, Clone, PartialEq)]
pub enum DiffMethod {
    /// Zero-phase Butterworth low-pass of `q` ([`Butterworth::zero_phase`]: -3 dB at
    /// `cutoff_hz` after forward-backward filtering; `None` = [`default_cutoff`]), then
    /// central differences for `qd` and the three-point second difference for `qdd`.
    Butterworth {
        /// Order of one pass.
        order: usize,
        /// Zero-phase -3 dB frequency (Hz); `None` for the default.
        cutoff_hz: Option<f64>,
    },
    /// Savitzky-Golay fit: smoothing, first and second derivative from the same local
    /// polynomial.
    SavitzkyGolay {
        /// Window length (odd).
        window: usize,
        /// Polynomial order (>= 2 for qdd).
        order: usize,
    },
}

impl Default for DiffMethod {
    fn default() -> Self {
        DiffMethod::Butterworth { order: DEFAULT_ORDER, cutoff_hz: None }
    }
}

/// Filtered positions and their derivatives, `T x N` each.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Derivatives {
    /// Smoothed positions.
    pub q: Vec<f64>,
    /// Velocities.
    pub qd: Vec<f64>,
    /// Accelerations.
    pub qdd: Vec<f64>,
}

/// Smooths `q` (`T x n`, uniform sample time `dt`) and computes `qd`, `qdd`.
pub fn differentiate(q: &[f64], n: usize, dt: f64, method: &DiffMethod) -> Result<Derivatives> {
    check_shape(q, n, "differentiate")?;
    if !(dt.is_finite() && dt > 0.0) {
        return Err(bad(format!("sample time {dt} must be positive")));
    }
    if let Some(i) = q.iter().position(|v| !v.is_finite()) {
        return Err(bad(format!("sample {}, column {}: q is {}", i / n, i % n, q[i])));
    }
    match method {
        DiffMethod::Butterworth { order, cutoff_hz } => {
            let fs = 1.0 / dt;
            let f = Butterworth::zero_phase(*order, resolve_cutoff(*cutoff_hz, fs)?, fs)?;
            let qf = f.filtfilt_columns(q, n)?;
            let qd = central_diff(&qf, n, dt)?;
            let qdd = second_diff(&qf, n, dt)?;
            Ok(Derivatives { q: qf, qd, qdd })
        }
        DiffMethod::SavitzkyGolay { window, order } => {
            let sg = SavitzkyGolay::new(*window, *order)?;
            if *order < 2 {
                return Err(bad("Savitzky-Golay order must be >= 2 to give accelerations"));
            }
            Ok(Derivatives { q: sg.apply(q, n, 0, dt)?, qd: sg.apply(q, n, 1, dt)?, qdd: sg.apply(q, n, 2, dt)? })
        }
    }
}

// ---------------------------------------------------------------------------------------
// Duplicates and resampling
// ---------------------------------------------------------------------------------------

/// Result of [`dedup_stamps`].
#[derive(Debug, Clone, PartialEq)]
pub struct Dedup {
    /// Indices of the samples kept (the first of each run of equal stamps).
    pub keep: Vec<usize>,
    /// How many samples were dropped.
    pub dropped: usize,
}

/// Finds samples whose stamp equals the previous one. Decreasing stamps are an error.
pub fn dedup_stamps(t: &[f64]) -> Result<Dedup> {
    let mut keep = Vec::with_capacity(t.len());
    for k in 0..t.len() {
        if !t[k].is_finite() {
            return Err(bad(format!("sample {k}: time is {}", t[k])));
        }
        if k > 0 && t[k] < t[k - 1] {
            return Err(bad(format!("sample {k}: time goes back ({} s after {} s)", t[k], t[k - 1])));
        }
        if k == 0 || t[k] != t[k - 1] {
            keep.push(k);
        }
    }
    let dropped = t.len() - keep.len();
    Ok(Dedup { keep, dropped })
}

/// Interpolation for [`resample_uniform`].
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Interp {
    /// Piecewise linear (reproduces linear signals exactly; never overshoots).
    #[default]
    Linear,
    /// Cubic Hermite with three-point (parabolic) slopes: C1, local, reproduces
    /// quadratics exactly.
    Cubic,
}

/// [`resample_uniform`] makes at most `MAX_RESAMPLE_FACTOR x T + MAX_RESAMPLE_EXTRA`
/// samples from `T`; more is refused (a gap, or a step far below the sample time). 6: a
/// segment without gaps (no interval above 10 median intervals, half of them at most the
/// median) spans at most 5.5 T median intervals, so it is never refused.
pub const MAX_RESAMPLE_FACTOR: usize = 6;
/// See [`MAX_RESAMPLE_FACTOR`].
pub const MAX_RESAMPLE_EXTRA: usize = 1000;

/// Resamples a `T x m` array with strictly increasing stamps `t` onto the grid
/// `t[0] + k dt` (up to `t[T-1]`). Returns `(grid, values)`. Run [`dedup_stamps`] first
/// if stamps repeat.
pub fn resample_uniform(t: &[f64], x: &[f64], m: usize, dt: f64, interp: Interp) -> Result<(Vec<f64>, Vec<f64>)> {
    let n = check_shape(x, m, "resample_uniform")?;
    if n != t.len() {
        return Err(Error::Dimension {
            what: "resample_uniform: rows of x vs stamps".into(),
            expected: t.len(),
            got: n,
        });
    }
    if !(dt.is_finite() && dt > 0.0) {
        return Err(bad(format!("resampling step {dt} must be positive")));
    }
    if n == 0 {
        return Ok((vec![], vec![]));
    }
    for k in 1..n {
        if t[k] <= t[k - 1] || t[k].is_nan() {
            return Err(bad(format!(
                "sample {k}: stamps must increase strictly for resampling ({} s after {} s); drop duplicates first",
                t[k],
                t[k - 1]
            )));
        }
    }
    let span = t[n - 1] - t[0];
    let count = (span / dt + 1e-9).floor() + 1.0;
    // a gap in the stamps would be filled with span / dt samples (a 1e6 s gap at 1 ms:
    // gigabytes); a log is resampled near its own rate, never far above it
    let bound = MAX_RESAMPLE_FACTOR * n + MAX_RESAMPLE_EXTRA;
    if !(count <= bound as f64) {
        return Err(bad(format!(
            "resampling {n} samples over {span} s at {dt} s steps would make {count:.0} samples, more than {MAX_RESAMPLE_FACTOR} x the input + {MAX_RESAMPLE_EXTRA}: a gap in the stamps, or a step far below the sample time"
        )));
    }
    let count = count as usize;
    let grid: Vec<f64> = (0..count).map(|k| t[0] + k as f64 * dt).collect();
    // slopes for the cubic: per sample, per column
    let slopes = if interp == Interp::Cubic && n >= 3 {
        let mut s = vec![0.0; n * m];
        let h = |i: usize| t[i + 1] - t[i];
        let d = |i: usize, j: usize| (x[(i + 1) * m + j] - x[i * m + j]) / h(i);
        for j in 0..m {
            for i in 1..n - 1 {
                s[i * m + j] = (h(i) * d(i - 1, j) + h(i - 1) * d(i, j)) / (h(i - 1) + h(i));
            }
            let f2 = (d(1, j) - d(0, j)) / (h(0) + h(1));
            s[j] = d(0, j) - h(0) * f2;
            let f2 = (d(n - 2, j) - d(n - 3, j)) / (h(n - 3) + h(n - 2));
            s[(n - 1) * m + j] = d(n - 2, j) + h(n - 2) * f2;
        }
        Some(s)
    } else {
        None
    };
    let mut out = Vec::with_capacity(count * m);
    let mut i = 0;
    for &tg in &grid {
        while i + 2 < n && t[i + 1] <= tg {
            i += 1;
        }
        if n == 1 {
            out.extend_from_slice(&x[..m]);
            continue;
        }
        let hi = t[i + 1] - t[i];
        let s = ((tg - t[i]) / hi).clamp(0.0, 1.0);
        for j in 0..m {
            let (a, b) = (x[i * m + j], x[(i + 1) * m + j]);
            out.push(match &slopes {
                None => a + s * (b - a),
                Some(sl) => {
                    let (s2, s3) = (s * s, s * s * s);
                    (2.0 * s3 - 3.0 * s2 + 1.0) * a
                        + (s3 - 2.0 * s2 + s) * hi * sl[i * m + j]
                        + (-2.0 * s3 + 3.0 * s2) * b
                        + (s3 - s2) * hi * sl[(i + 1) * m + j]
                }
            });
        }
    }
    Ok((grid, out))
}

// ---------------------------------------------------------------------------------------
// Decimation with a parallel anti-alias filter
// ---------------------------------------------------------------------------------------

/// Decimation by an integer factor: a zero-phase anti-alias low-pass, then every
/// `factor`-th sample (from the first). Apply the SAME decimator to the torque and to
/// every column of the regressor (parallel filtering).
#[derive(Debug, Clone, PartialEq)]
pub struct Decimator {
    /// Keep one sample in `factor`.
    pub factor: usize,
    /// The anti-alias filter (at the input rate).
    pub filter: Butterworth,
}

impl Decimator {
    /// Default anti-alias filter: 8th-order Butterworth, zero-phase -3 dB at 80 % of the
    /// output Nyquist frequency (`0.4 fs / factor`); at the output Nyquist frequency the
    /// forward-backward gain is about -20 dB, at 2x the output Nyquist below -90 dB.
    pub fn new(factor: usize, fs: f64) -> Result<Self> {
        if factor == 0 {
            return Err(bad("decimation factor must be >= 1"));
        }
        let fc = 0.4 * fs / factor as f64;
        let filter = Butterworth::zero_phase(8, fc.min(0.45 * fs), fs)?;
        Ok(Decimator { factor, filter })
    }

    /// With a filter of your choice.
    pub fn with_filter(factor: usize, filter: Butterworth) -> Result<Self> {
        if factor == 0 {
            return Err(bad("decimation factor must be >= 1"));
        }
        Ok(Decimator { factor, filter })
    }

    /// Filters every column of a `T x m` array and keeps rows `0, factor, 2 factor, ...`.
    /// With `factor == 1` only the filter is applied.
    pub fn apply(&self, x: &[f64], m: usize) -> Result<Vec<f64>> {
        let t = check_shape(x, m, "decimate")?;
        let y = self.filter.filtfilt_columns(x, m)?;
        let rows: Vec<usize> = (0..t).step_by(self.factor).collect();
        Ok(take_rows(&y, m, &rows))
    }

    /// The stamps kept (no filtering).
    pub fn apply_t(&self, t: &[f64]) -> Vec<f64> {
        t.iter().step_by(self.factor).copied().collect()
    }
}

// ---------------------------------------------------------------------------------------
// Outliers
// ---------------------------------------------------------------------------------------

/// Options of the [`hampel`] filter.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct HampelOptions {
    /// Samples on each side of the window (default 5: 11 samples, 2.2 ms at 5 kHz,
    /// 22 ms at 500 Hz: shorter than any motion feature, longer than a glitch).
    pub half_window: usize,
    /// Threshold in robust standard deviations (`1.4826 * MAD`); default 3.
    pub n_sigma: f64,
    /// Floor on the robust standard deviation, so that a quantised signal whose window
    /// is constant does not flag every one-count step (default 0).
    pub min_sigma: f64,
}

impl Default for HampelOptions {
    fn default() -> Self {
        HampelOptions { half_window: 5, n_sigma: 3.0, min_sigma: 0.0 }
    }
}

/// What [`hampel`] replaced.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct OutlierReport {
    /// Replaced samples per column.
    pub per_column: Vec<usize>,
    /// Total replaced.
    pub total: usize,
    /// `(sample, column)` of the first 100 replaced values.
    pub first: Vec<(usize, usize)>,
}

/// Hampel filter on every column of a `T x m` array, in place: a sample farther than
/// `n_sigma` robust standard deviations from the median of its window is replaced by that
/// median. Non-finite values are always replaced.
pub fn hampel(x: &mut [f64], m: usize, opts: &HampelOptions) -> Result<OutlierReport> {
    let t = check_shape(x, m, "hampel")?;
    let h = opts.half_window;
    let mut rep = OutlierReport { per_column: vec![0; m], ..Default::default() };
    let mut win = Vec::with_capacity(2 * h + 1);
    let mut dev = Vec::with_capacity(2 * h + 1);
    let src = x.to_vec();
    for j in 0..m {
        for k in 0..t {
            let (a, b) = (k.saturating_sub(h), (k + h + 1).min(t));
            win.clear();
            win.extend((a..b).map(|i| src[i * m + j]).filter(|v| v.is_finite()));
            if win.is_empty() {
                continue;
            }
            win.sort_by(f64::total_cmp);
            let med = median_sorted(&win);
            dev.clear();
            dev.extend(win.iter().map(|v| (v - med).abs()));
            dev.sort_by(f64::total_cmp);
            let sigma = (1.4826 * median_sorted(&dev)).max(opts.min_sigma);
            let v = src[k * m + j];
            if !v.is_finite() || (v - med).abs() > opts.n_sigma * sigma {
                x[k * m + j] = med;
                rep.per_column[j] += 1;
                rep.total += 1;
                if rep.first.len() < 100 {
                    rep.first.push((k, j));
                }
            }
        }
    }
    rep.first.sort();
    Ok(rep)
}

fn median_sorted(v: &[f64]) -> f64 {
    let n = v.len();
    if n % 2 == 1 { v[n / 2] } else { 0.5 * (v[n / 2 - 1] + v[n / 2]) }
}

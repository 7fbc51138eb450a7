//! Zero-phase filtering of an endless multi-column stream, block by block, giving the
//! numbers of [`Butterworth::filtfilt`] on the whole signal.
//!
//! `filtfilt` runs the filter forward over the signal (extended at both ends by an
//! odd-symmetric copy of `padlen` samples), then backward over the result. In a stream:
//!
//! * the **forward** pass is causal: it runs once over the stream with its state carried
//!   from block to block, operation for operation as over the whole signal (the start
//!   extension is built from the first `padlen + 1` samples);
//! * the **backward** pass is anti-causal: the output of sample `k` depends on the forward
//!   output after `k`. A block of rows is finished once `look` more forward rows are known:
//!   the backward pass starts at the last of them from the steady state at its value (as
//!   `filtfilt` starts at the end of the signal) and the rows within `look` of that start
//!   are not emitted yet. The error of the start state decays like the filter's impulse
//!   response; `look` is where that response has fallen below `1e-13` of its peak, so
//!   emitted rows match the whole-signal result to ~1e-12 relative;
//! * at the end of the stream the end extension is built from the last `padlen + 1`
//!   samples and the last rows are finished exactly as `filtfilt` does.
//!
//! Rows can be decimated on output (keep global rows `0, f, 2f, ...`): the backward pass
//! still runs at the full rate, only the kept rows are handed out.
//!
//! Columns are independent; every inner loop runs across the columns of one row, which
//! the compiler vectorises (with AVX2 + FMA chosen at run time when the CPU has them).

use crate::dsp::Butterworth;

/// Relative level of the impulse response that sets the look-ahead of the backward pass.
const LOOK_TOL: f64 = 1e-13;

/// Streaming equivalent of [`Butterworth::filtfilt_columns`] (then keep every
/// `factor`-th row) on a row-major stream of `m` columns.
#[derive(Debug, Clone)]
pub struct StreamFiltfilt {
    filter: Butterworth,
    m: usize,
    pad: usize,
    look: usize,
    block: usize,
    factor: usize,
    /// Raw rows before the start (until `pad + 1` are known).
    head: Vec<f64>,
    started: bool,
    /// Forward state, per section `[z1 (m), z2 (m)]`.
    z: Vec<f64>,
    /// The last `pad + 1` raw rows, as a ring of rows (for the end extension).
    ring: Vec<f64>,
    ring_next: usize,
    /// Forward outputs of the rows not yet finished: global rows `first..first + rows`.
    buf: Vec<f64>,
    first: usize,
    /// Raw rows pushed.
    total: usize,
    finished: bool,
}

impl StreamFiltfilt {
    /// A stream filter of `m` columns keeping one row in `factor`; rows are finished in
    /// blocks of at least `block` rows (memory: about `(block + look) m` values).
    pub fn new(filter: &Butterworth, m: usize, factor: usize, block: usize) -> Self {
        let look = look_ahead(filter);
        let pad = filter.padlen;
        StreamFiltfilt {
            filter: filter.clone(),
            m,
            pad,
            look,
            block: block.max(look),
            factor: factor.max(1),
            head: Vec::new(),
            started: false,
            z: vec![0.0; 2 * filter.sections.len() * m],
            ring: vec![0.0; (pad + 1) * m],
            ring_next: 0,
            buf: Vec::new(),
            first: 0,
            total: 0,
            finished: false,
        }
    }

    /// Rows of look-ahead of the backward pass.
    pub fn look(&self) -> usize {
        self.look
    }

    /// Keep one row in `factor`.
    pub fn factor(&self) -> usize {
        self.factor
    }

    /// Raw rows pushed so far.
    pub fn rows_in(&self) -> usize {
        self.total
    }

    /// Pushes raw rows (`k x m`, row-major). Finished rows whose global index is a
    /// multiple of `factor` are handed to `out(global_index, row)` in order.
    pub fn push(&mut self, rows: &[f64], out: &mut impl FnMut(usize, &[f64])) {
        let m = self.m;
        debug_assert!(!self.finished && rows.len().is_multiple_of(m));
        // only the last `pad + 1` rows can be needed for the end extension
        let k = rows.len() / m;
        for row in rows[k.saturating_sub(self.pad + 1) * m..].chunks_exact(m) {
            self.remember(row);
        }
        let mut rest = rows;
        if !self.started {
            let need = (self.pad + 1 - self.head.len() / m).min(rest.len() / m);
            self.head.extend_from_slice(&rest[..need * m]);
            self.total += need;
            rest = &rest[need * m..];
            if self.head.len() / m < self.pad + 1 {
                return;
            }
            self.start();
        }
        let at = self.buf.len();
        self.buf.extend_from_slice(rest);
        self.total += rest.len() / m;
        self.filter.run_rows(&mut self.z, &mut self.buf[at..], m, false);
        if self.buf.len() / m >= self.block + self.look {
            self.flush(out);
        }
    }

    /// [`push`](Self::push) of `t` rows that `fill(k, dst)` appends to `dst` (row `k`, `m`
    /// values): the rows are built straight in the filter's buffer, without a copy.
    pub fn push_with(
        &mut self,
        t: usize,
        mut fill: impl FnMut(usize, &mut Vec<f64>),
        out: &mut impl FnMut(usize, &[f64]),
    ) {
        let m = self.m;
        if !self.started {
            let mut rows = Vec::with_capacity(t * m);
            for k in 0..t {
                fill(k, &mut rows);
            }
            return self.push(&rows, out);
        }
        let at = self.buf.len();
        for k in 0..t {
            fill(k, &mut self.buf);
        }
        debug_assert_eq!(self.buf.len(), at + t * m);
        // the ring of the last `pad + 1` raw rows, before the forward pass overwrites them
        let len = self.pad + 1;
        for r in t.saturating_sub(len)..t {
            let i = self.ring_next;
            self.ring[i * m..(i + 1) * m].copy_from_slice(&self.buf[at + r * m..at + (r + 1) * m]);
            self.ring_next = (i + 1) % len;
        }
        self.total += t;
        self.filter.run_rows(&mut self.z, &mut self.buf[at..], m, false);
        if self.buf.len() / m >= self.block + self.look {
            self.flush(out);
        }
    }

    /// Ends the stream: finishes every remaining row exactly as `filtfilt` on the whole
    /// signal does (for fewer than `padlen + 1` rows in all: `filtfilt` itself).
    pub fn finish(&mut self, out: &mut impl FnMut(usize, &[f64])) {
        if self.finished {
            return;
        }
        self.finished = true;
        let m = self.m;
        if !self.started {
            // a short signal: the whole-signal filter with its shorter extension
            if self.total == 0 {
                return;
            }
            let y = self.filter.filtfilt_columns(&self.head, m).expect("whole rows");
            for (g, row) in y.chunks_exact(m).enumerate() {
                if g.is_multiple_of(self.factor) {
                    out(g, row);
                }
            }
            return;
        }
        // end extension: 2 x[T-1] - x[T-1-i], i = 1..=pad
        let signal_rows = self.buf.len() / m;
        let last = self.ring_row(0).to_vec();
        for i in 1..=self.pad {
            let ext: Vec<f64> = last.iter().zip(self.ring_row(i)).map(|(l, x)| 2.0 * l - x).collect();
            let at = self.buf.len();
            self.buf.extend_from_slice(&ext);
            self.filter.run_rows(&mut self.z, &mut self.buf[at..], m, false);
        }
        let rows = self.buf.len() / m;
        backward(&self.filter, &mut self.buf, m, rows, rows - signal_rows);
        self.emit(signal_rows, out);
        self.buf.clear();
    }

    /// Stores a raw row in the ring of the last `pad + 1` rows.
    fn remember(&mut self, row: &[f64]) {
        let m = self.m;
        let i = self.ring_next;
        self.ring[i * m..(i + 1) * m].copy_from_slice(row);
        self.ring_next = (i + 1) % (self.pad + 1);
    }

    /// The raw row `back` rows before the last one.
    fn ring_row(&self, back: usize) -> &[f64] {
        let len = self.pad + 1;
        let i = (self.ring_next + 2 * len - 1 - back) % len;
        &self.ring[i * self.m..(i + 1) * self.m]
    }

    /// The first `pad + 1` rows are known: run the forward pass over the start extension
    /// `2 x[0] - x[i]` (`i = pad..1`, from the steady state at its first value), then
    /// over the head.
    fn start(&mut self) {
        let m = self.m;
        let x0 = self.head[..m].to_vec();
        let row = |i: usize| &self.head[i * m..(i + 1) * m];
        let mut ext: Vec<f64> = Vec::with_capacity(self.pad * m);
        for i in (1..=self.pad).rev() {
            ext.extend(x0.iter().zip(row(i)).map(|(a, b)| 2.0 * a - b));
        }
        self.filter.steady_state(&mut self.z, &ext[..m]);
        self.filter.run_rows(&mut self.z, &mut ext, m, false);
        self.buf = std::mem::take(&mut self.head);
        self.filter.run_rows(&mut self.z, &mut self.buf, m, false);
        self.started = true;
    }

    /// Finishes all buffered rows but the last `look` (kept as forward outputs).
    fn flush(&mut self, out: &mut impl FnMut(usize, &[f64])) {
        let m = self.m;
        let rows = self.buf.len() / m;
        let done = rows - self.look;
        backward(&self.filter, &mut self.buf, m, rows, self.look);
        self.emit(done, out);
        self.buf.copy_within(done * m.., 0);
        self.buf.truncate(self.look * m);
        self.first += done;
    }

    fn emit(&self, rows: usize, out: &mut impl FnMut(usize, &[f64])) {
        let m = self.m;
        let f = self.factor;
        let mut r = (f - self.first % f) % f;
        while r < rows {
            out(self.first + r, &self.buf[r * m..(r + 1) * m]);
            r += f;
        }
    }
}

/// Rows after which the single-pass impulse response stays below [`LOOK_TOL`] of its
/// peak (found by running the filter on an impulse), plus the padding length.
pub fn look_ahead(filter: &Butterworth) -> usize {
    let mut z = vec![0.0; 2 * filter.sections.len()];
    let (mut peak, mut last) = (0.0f64, 0usize);
    let limit = 1_000_000;
    let mut x = [1.0];
    for k in 0..limit {
        filter.run_rows(&mut z, &mut x, 1, false);
        let h = x[0].abs();
        peak = peak.max(h);
        if h > LOOK_TOL * peak {
            last = k;
        } else if k > last + 64 * (filter.order + 1) && k > 1000 {
            break;
        }
        x[0] = 0.0;
    }
    last + 1 + filter.order
}

/// The backward pass over the first `rows` rows of `buf`, from the last row down,
/// starting from the steady state at the last row's value. The last `skip` rows only
/// advance the state (they are left as they are); the others are overwritten with the
/// output.
fn backward(filter: &Butterworth, buf: &mut [f64], m: usize, rows: usize, skip: usize) {
    if rows == 0 {
        return;
    }
    let mut z = vec![0.0; 2 * filter.sections.len() * m];
    filter.steady_state(&mut z, &buf[(rows - 1) * m..rows * m]);
    let mut tail = buf[(rows - skip) * m..rows * m].to_vec();
    filter.run_rows(&mut z, &mut tail, m, true);
    filter.run_rows(&mut z, &mut buf[..(rows - skip) * m], m, true);
}

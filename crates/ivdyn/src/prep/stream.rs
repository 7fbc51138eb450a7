//! Streaming version of the Butterworth branch of [`crate::dsp::differentiate`]:
//! zero-phase smoothing of `q` ([`StreamFiltfilt`]), then central differences for `qd`
//! and the three-point second difference for `qdd`, with the same one-sided formulas at
//! the two ends (`dsp::central_diff`, `dsp::second_diff`).

use super::filtfilt::StreamFiltfilt;
use crate::dsp::Butterworth;

/// Conditioned rows handed out by [`StreamCondition`], appended in sample order.
#[derive(Debug, Clone, Default)]
pub struct CondRows {
    /// Smoothed positions.
    pub q: Vec<f64>,
    /// Velocities.
    pub qd: Vec<f64>,
    /// Accelerations.
    pub qdd: Vec<f64>,
}

impl CondRows {
    /// Empties the three arrays.
    pub fn clear(&mut self) {
        self.q.clear();
        self.qd.clear();
        self.qdd.clear();
    }
}

/// Smoothing and differentiation of a stream of `n` positions at sample time `dt`.
#[derive(Debug, Clone)]
pub struct StreamCondition {
    n: usize,
    dt: f64,
    filt: StreamFiltfilt,
    /// The last (up to) four smoothed rows.
    win: Vec<f64>,
    /// Smoothed rows received.
    seen: usize,
    scratch: Vec<f64>,
}

impl StreamCondition {
    /// `filter` is the differentiation filter at `1 / dt`.
    pub fn new(filter: &Butterworth, n: usize, dt: f64, block: usize) -> Self {
        StreamCondition {
            n,
            dt,
            filt: StreamFiltfilt::new(filter, n, 1, block),
            win: Vec::with_capacity(4 * n),
            seen: 0,
            scratch: vec![],
        }
    }

    /// Rows of delay between a position in and its conditioned row out (at most).
    pub fn delay(&self) -> usize {
        self.filt.look() + 2
    }

    /// Pushes raw positions (`k x n`); conditioned rows that are final are appended to `out`.
    pub fn push(&mut self, q: &[f64], out: &mut CondRows) {
        let mut smoothed = std::mem::take(&mut self.scratch);
        smoothed.clear();
        self.filt.push(q, &mut |_, row| smoothed.extend_from_slice(row));
        self.take(&smoothed, out);
        self.scratch = smoothed;
    }

    /// Ends the stream: the remaining rows, the last with the one-sided formulas.
    pub fn finish(&mut self, out: &mut CondRows) {
        let mut smoothed = vec![];
        self.filt.finish(&mut |_, row| smoothed.extend_from_slice(row));
        self.take(&smoothed, out);
        let (n, dt) = (self.n, self.dt);
        let rows = self.win.len() / n;
        if self.seen < 4 {
            // fewer than four samples: the whole-array formulas on what there is
            let qd = crate::dsp::central_diff(&self.win, n, dt).unwrap_or_default();
            let qdd = crate::dsp::second_diff(&self.win, n, dt).unwrap_or_default();
            out.q.extend_from_slice(&self.win);
            out.qd.extend_from_slice(&qd);
            out.qdd.extend_from_slice(&qdd);
            return;
        }
        let h2 = dt * dt;
        let x = |back: usize, j: usize| self.win[(rows - 1 - back) * n + j];
        for j in 0..n {
            out.q.push(x(0, j));
            out.qd.push((3.0 * x(0, j) - 4.0 * x(1, j) + x(2, j)) / (2.0 * dt));
        }
        for j in 0..n {
            out.qdd.push((2.0 * x(0, j) - 5.0 * x(1, j) + 4.0 * x(2, j) - x(3, j)) / h2);
        }
    }

    /// Takes smoothed rows in order; emits every row whose neighbours are known.
    fn take(&mut self, smoothed: &[f64], out: &mut CondRows) {
        let (n, dt) = (self.n, self.dt);
        let h2 = dt * dt;
        for row in smoothed.chunks_exact(n) {
            if self.win.len() == 4 * n {
                self.win.drain(..n);
            }
            self.win.extend_from_slice(row);
            let g = self.seen;
            self.seen += 1;
            let w = &self.win;
            let rows = w.len() / n;
            let x = |r: usize, j: usize| w[r * n + j];
            if g == 3 {
                // rows 0, 1, 2: the one-sided start, then central differences
                for j in 0..n {
                    out.q.push(x(0, j));
                    out.qd.push((-3.0 * x(0, j) + 4.0 * x(1, j) - x(2, j)) / (2.0 * dt));
                    out.qdd.push((2.0 * x(0, j) - 5.0 * x(1, j) + 4.0 * x(2, j) - x(3, j)) / h2);
                }
                for k in 1..3 {
                    for j in 0..n {
                        out.q.push(x(k, j));
                        out.qd.push((x(k + 1, j) - x(k - 1, j)) / (2.0 * dt));
                        out.qdd.push((x(k + 1, j) - 2.0 * x(k, j) + x(k - 1, j)) / h2);
                    }
                }
            } else if g > 3 {
                let k = rows - 2;
                for j in 0..n {
                    out.q.push(x(k, j));
                    out.qd.push((x(k + 1, j) - x(k - 1, j)) / (2.0 * dt));
                    out.qdd.push((x(k + 1, j) - 2.0 * x(k, j) + x(k - 1, j)) / h2);
                }
            }
        }
    }
}

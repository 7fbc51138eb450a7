//! Streaming version of the Butterworth branch of [`crate::dsp::differentiate`]:
//! zero-phase smoothing of `q` ([`StreamFiltfilt`]), then central differences for `qd`
//! and the three-point second difference for `qdd`, with the same one-sided formulas at
//! the two ends (`dsp::central_diff`, `dsp::second_diff`).
//!
//! On the joints that take the log's own velocity ([`StreamCondition::with_log_velocity`],
//! chosen by [`super::velocity::decide`]) the measured velocity goes through the same
//! zero-phase filter and `qdd` is its central difference: what
//! [`super::velocity::apply`] puts in place of the positions' derivatives in memory.

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
    /// Joints whose velocity is the log's (`None`: none; the smoothed rows are then `q`
    /// alone, else `[q | qd_log]`).
    log: Option<Vec<bool>>,
    /// The last (up to) four smoothed rows.
    win: Vec<f64>,
    /// Smoothed rows received.
    seen: usize,
    scratch: Vec<f64>,
    /// Raw rows `[q | qd_log]` of the last push.
    stacked: Vec<f64>,
}

impl StreamCondition {
    /// `filter` is the differentiation filter at `1 / dt`.
    pub fn new(filter: &Butterworth, n: usize, dt: f64, block: usize) -> Self {
        StreamCondition {
            n,
            dt,
            filt: StreamFiltfilt::new(filter, n, 1, block),
            log: None,
            win: Vec::with_capacity(4 * n),
            seen: 0,
            scratch: vec![],
            stacked: vec![],
        }
    }

    /// The same, with the log's velocity on the joints where `log[j]` (the filter then
    /// also smooths the measured velocities; they must be given to [`Self::push`]).
    pub fn with_log_velocity(filter: &Butterworth, n: usize, dt: f64, block: usize, log: Vec<bool>) -> Self {
        assert_eq!(log.len(), n, "one flag per joint");
        if !log.contains(&true) {
            return Self::new(filter, n, dt, block);
        }
        StreamCondition {
            filt: StreamFiltfilt::new(filter, 2 * n, 1, block),
            log: Some(log),
            win: Vec::with_capacity(8 * n),
            ..Self::new(filter, n, dt, block)
        }
    }

    /// Whether the log's velocity is taken on some joint (then [`Self::push`] needs it).
    pub fn needs_velocity(&self) -> bool {
        self.log.is_some()
    }

    /// Width of a smoothed row.
    fn width(&self) -> usize {
        if self.log.is_some() { 2 * self.n } else { self.n }
    }

    /// Rows of delay between a position in and its conditioned row out (at most).
    pub fn delay(&self) -> usize {
        self.filt.look() + 2
    }

    /// Pushes raw positions (`k x n`) and, when [`Self::needs_velocity`], the log's
    /// velocities of the same samples; conditioned rows that are final are appended to `out`.
    pub fn push(&mut self, q: &[f64], qd_log: Option<&[f64]>, out: &mut CondRows) {
        let n = self.n;
        let mut smoothed = std::mem::take(&mut self.scratch);
        smoothed.clear();
        if self.log.is_some() {
            let qd = qd_log.expect("the log's velocity is taken: push needs it");
            assert_eq!(qd.len(), q.len(), "one velocity per position");
            self.stacked.clear();
            for (q, qd) in q.chunks_exact(n).zip(qd.chunks_exact(n)) {
                self.stacked.extend_from_slice(q);
                self.stacked.extend_from_slice(qd);
            }
            self.filt.push(&self.stacked, &mut |_, row| smoothed.extend_from_slice(row));
        } else {
            self.filt.push(q, &mut |_, row| smoothed.extend_from_slice(row));
        }
        self.take(&smoothed, out);
        self.scratch = smoothed;
    }

    /// Ends the stream: the remaining rows, the last with the one-sided formulas.
    pub fn finish(&mut self, out: &mut CondRows) {
        let mut smoothed = vec![];
        self.filt.finish(&mut |_, row| smoothed.extend_from_slice(row));
        self.take(&smoothed, out);
        let (n, m, dt) = (self.n, self.width(), self.dt);
        let rows = self.win.len() / m;
        if rows == 0 {
            return;
        }
        if self.seen < 4 {
            // fewer than four samples: the whole-array formulas on what there is
            let col = |c: usize| -> Vec<f64> { self.win.chunks_exact(m).flat_map(|r| r[c..c + n].to_vec()).collect() };
            let q = col(0);
            let qd = crate::dsp::central_diff(&q, n, dt).unwrap_or_default();
            let qdd = crate::dsp::second_diff(&q, n, dt).unwrap_or_default();
            let (v, vd) = match &self.log {
                Some(_) => {
                    let v = col(n);
                    let vd = crate::dsp::central_diff(&v, n, dt).unwrap_or_default();
                    (v, vd)
                }
                None => (vec![], vec![]),
            };
            let log = |i: usize| self.log.as_ref().is_some_and(|l| l[i % n]);
            out.q.extend_from_slice(&q);
            out.qd.extend((0..qd.len()).map(|i| if log(i) { v[i] } else { qd[i] }));
            out.qdd.extend((0..qdd.len()).map(|i| if log(i) { vd[i] } else { qdd[i] }));
            return;
        }
        self.emit(rows - 1, At::End, out);
    }

    /// Takes smoothed rows in order; emits every row whose neighbours are known.
    fn take(&mut self, smoothed: &[f64], out: &mut CondRows) {
        let m = self.width();
        for row in smoothed.chunks_exact(m) {
            if self.win.len() == 4 * m {
                self.win.drain(..m);
            }
            self.win.extend_from_slice(row);
            let g = self.seen;
            self.seen += 1;
            if g == 3 {
                // rows 0, 1, 2: the one-sided start, then central differences
                self.emit(0, At::Start, out);
                self.emit(1, At::Inside, out);
                self.emit(2, At::Inside, out);
            } else if g > 3 {
                self.emit(2, At::Inside, out);
            }
        }
    }

    /// Conditioned row `k` of the window, with the difference formulas of its place.
    fn emit(&self, k: usize, at: At, out: &mut CondRows) {
        let (n, m, dt) = (self.n, self.width(), self.dt);
        let h2 = dt * dt;
        let x = |r: usize, c: usize| self.win[r * m + c];
        // first difference of column c at row k (qd of a position, qdd of a log velocity)
        let d1 = |c: usize| match at {
            At::Start => (-3.0 * x(k, c) + 4.0 * x(k + 1, c) - x(k + 2, c)) / (2.0 * dt),
            At::Inside => (x(k + 1, c) - x(k - 1, c)) / (2.0 * dt),
            At::End => (3.0 * x(k, c) - 4.0 * x(k - 1, c) + x(k - 2, c)) / (2.0 * dt),
        };
        // second difference (qdd of a position): three points inside, four at the ends
        let d2 = |c: usize| match at {
            At::Start => (2.0 * x(k, c) - 5.0 * x(k + 1, c) + 4.0 * x(k + 2, c) - x(k + 3, c)) / h2,
            At::Inside => (x(k + 1, c) - 2.0 * x(k, c) + x(k - 1, c)) / h2,
            At::End => (2.0 * x(k, c) - 5.0 * x(k - 1, c) + 4.0 * x(k - 2, c) - x(k - 3, c)) / h2,
        };
        let log = |j: usize| self.log.as_ref().is_some_and(|l| l[j]);
        out.q.extend((0..n).map(|j| x(k, j)));
        out.qd.extend((0..n).map(|j| if log(j) { x(k, n + j) } else { d1(j) }));
        out.qdd.extend((0..n).map(|j| if log(j) { d1(n + j) } else { d2(j) }));
    }
}

/// Where a conditioned row sits: its difference formulas.
#[derive(Debug, Clone, Copy)]
enum At {
    /// The first sample: one-sided forward differences.
    Start,
    /// Central differences.
    Inside,
    /// The last sample: one-sided backward differences.
    End,
}

//! Terminal-link estimation, paper eqs (38)-(54): the torque residual against the nominal
//! model is linear in the *changes* of the parameters of links `k..N` (eq 46),
//!
//! `dtau_i = tau_i(measured) - rnea_nominal_i(q, qd, qdd) = sum_{l=max(i,k)}^{N} Y_il dx_l`,
//!
//! for rows `i = k..N`, each weighted (the paper's `P`). In the standard parametrisation a
//! payload is the 10 inertial parameters added to the last link (plus its drive change).
//! Not every column is identifiable from those rows (on the paper's robot the payload
//! mass is invisible to joints 5 and 6): pass the indices of an identifiable (base)
//! column set, found numerically on the desktop (`ivdyn::ident::base`).
//!
//! [`TerminalLink::update`] computes only what those rows need
//! ([`super::terminal_rows`]: the regressor entries of the estimated columns, the nominal
//! torque of the rows used) and skips the products with the rows' structural zeros in the
//! estimator (row `i` does not see links inside `i`, nor other joints' drives);
//! [`TerminalLink::update_full`] is the same update from a full RNEA and full regressors,
//! kept as the reference it is tested against (`tests/terminal_update.rs`). The operation
//! count of `update` is measured in `tests/op_count.rs`.

use super::terminal_rows::{Needed, TerminalRows, terminal_rows};
use crate::data::Data;
use crate::error::Error;
use crate::estim::{Riv, RivInfo, Rls};
use crate::model::Model;
use crate::params::{DRIVE_PARAMS, LINK_PARAMS};
use crate::regressor::Regressor;
use crate::scalar::RealScalar;
use crate::types::VecN;
use crate::{regressor, rnea};
use nalgebra::allocator::Allocator;
use nalgebra::{DefaultAllocator, Dim, OVector, SVector};

/// Which unknowns: links (and joints) `k..N` (0-based `k`), with the selected drive
/// parameters of each of those joints, and which rows see them: joints `first_row..N`.
/// The paper uses `first_row = k` (eq 46); a payload's mass needs the inner joints' rows
/// (on the paper's robot it is invisible to joints 5 and 6), so `first_row` can be lower.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct TerminalSpec {
    /// First unknown link (0-based): the paper's `k - 1`.
    pub k: usize,
    /// Which of `[fc, fv, ia, tau0]` change with each unknown link's joint.
    pub drive: [bool; DRIVE_PARAMS],
    /// First row (joint, 0-based) used; `<= k`.
    pub first_row: usize,
}

impl TerminalSpec {
    /// The paper's simulation: links 5 and 6 (`k = 5`), each with `(F, d)` = `(fc, fv)`,
    /// rows of joints 5 and 6.
    pub const PAPER: TerminalSpec = TerminalSpec { k: 4, drive: [true, true, false, false], first_row: 4 };

    /// Unknowns `k..N` seen by rows `k..N` (the paper's eq 46).
    pub const fn new(k: usize, drive: [bool; DRIVE_PARAMS]) -> Self {
        TerminalSpec { k, drive, first_row: k }
    }

    /// A payload on the last link of an `n`-joint chain, seen by every joint's row,
    /// inertial parameters only.
    pub const fn payload(n: usize) -> Self {
        TerminalSpec { k: n - 1, drive: [false; DRIVE_PARAMS], first_row: 0 }
    }

    fn per_link(&self) -> usize {
        LINK_PARAMS + self.drive.iter().filter(|&&b| b).count()
    }

    /// Number of unknown columns for an `n`-joint chain.
    pub fn cols(&self, n: usize) -> usize {
        (n - self.k) * self.per_link()
    }

    /// Rows used: joints `first_row..n`.
    pub fn rows(&self, n: usize) -> core::ops::Range<usize> {
        self.first_row.min(self.k)..n
    }

    /// `(link, entry)` of column `c`: entry `< 10` is inertial, `10 + d` is drive param `d`.
    pub fn column(&self, c: usize) -> (usize, usize) {
        let per = self.per_link();
        let (l, e) = (self.k + c / per, c % per);
        if e < LINK_PARAMS {
            return (l, e);
        }
        let mut seen = 0;
        for d in 0..DRIVE_PARAMS {
            if self.drive[d] {
                if seen == e - LINK_PARAMS {
                    return (l, LINK_PARAMS + d);
                }
                seen += 1;
            }
        }
        unreachable!("column index within cols()")
    }

    /// Entry `(row, c)` of the terminal regressor, taken from the full regressor.
    #[inline]
    pub fn entry<const N: usize>(&self, y: &Regressor<N>, row: usize, c: usize) -> f64 {
        let (l, e) = self.column(c);
        if e < LINK_PARAMS {
            y.link[row][l][e]
        } else if l == row {
            y.drive[row][e - LINK_PARAMS]
        } else {
            0.0
        }
    }

    /// Index into the full `theta` (layout of [`crate::params`]) of column `c`.
    pub fn theta_index(&self, n: usize, c: usize) -> usize {
        let (l, e) = self.column(c);
        if e < LINK_PARAMS { LINK_PARAMS * l + e } else { LINK_PARAMS * n + DRIVE_PARAMS * l + (e - LINK_PARAMS) }
    }
}

/// Least squares or instrumental variables, row by row.
#[derive(Debug, Clone)]
pub enum Method<D: Dim, T: RealScalar = f64>
where
    DefaultAllocator: Allocator<D, D> + Allocator<D>,
{
    /// The paper's LSM (biased when the regressor holds noisy accelerations).
    Ls(Rls<D, T>),
    /// The paper's IVM, covariance form (forgetting, anti-windup, outlier gate).
    Iv(Riv<D, T>),
    /// The paper's IVM, information form: the same estimate in fewer operations (one
    /// estimate per sample, rank-one updates that skip a row's leading zeros); no
    /// forgetting ([`RivInfo`]).
    IvInfo(RivInfo<D, T>),
}

/// Online terminal-link estimator: nominal model, unknown set, identifiable columns,
/// row weights, and a recursive estimator over those columns. No allocation. `T` is the
/// scalar of the update ([`RealScalar`]: `f64` by default).
#[derive(Debug, Clone)]
pub struct TerminalLink<const N: usize, D: Dim, T: RealScalar = f64>
where
    DefaultAllocator: Allocator<D, D> + Allocator<D> + Allocator<D, nalgebra::U1>,
{
    /// Nominal model (the arm before the change).
    pub nominal: Model<N>,
    /// Unknown set.
    pub spec: TerminalSpec,
    /// Indices (into `0..spec.cols(N)`) of the estimated columns; length `D`.
    pub columns: OVector<usize, D>,
    /// Row weights per joint (only `k..N` used): the paper's `P = diag(0.01, 1)`.
    pub row_weight: [f64; N],
    /// The estimator.
    pub method: Method<D, T>,
    /// Rows of joints moving slower than this (rad/s or m/s) are skipped; 0 = use all.
    /// Near a velocity reversal the nominal Coulomb term `fc sign(qd)` does not describe the
    /// real friction (stiction, pre-sliding, a differentiated noisy velocity), and that
    /// error, correlated with the motion, would bias any estimator, IV included.
    pub min_speed: f64,
    /// Rows used so far.
    pub rows_used: u64,
    /// Rows skipped (slow joint) so far.
    pub rows_skipped: u64,
    data: Data<N>,
    data_z: Data<N>,
    rows: TerminalRows<N, T>,
    needed: Needed<N>,
    /// `(link, entry)` of each estimated column ([`TerminalSpec::column`]).
    col_map: OVector<(usize, usize), D>,
    support: OVector<bool, D>,
    /// Every column (the dense rows of [`TerminalLink::update_full`]).
    support_all: OVector<bool, D>,
    phi: OVector<T, D>,
    z: OVector<T, D>,
}

impl<const N: usize, D: Dim, T: RealScalar> TerminalLink<N, D, T>
where
    DefaultAllocator: Allocator<D, D> + Allocator<D> + Allocator<D, nalgebra::U1>,
{
    /// New estimator; `columns` selects identifiable columns of the terminal regressor.
    pub fn new(
        nominal: Model<N>,
        spec: TerminalSpec,
        columns: OVector<usize, D>,
        row_weight: [f64; N],
        method: Method<D, T>,
    ) -> Self {
        let (dim, _) = columns.shape_generic();
        let u1 = nalgebra::Const::<1>;
        Self {
            nominal,
            spec,
            columns,
            row_weight,
            method,
            min_speed: 0.0,
            rows_used: 0,
            rows_skipped: 0,
            data: Data::new(),
            data_z: Data::new(),
            rows: TerminalRows::new(),
            needed: Needed::NONE,
            col_map: OVector::from_element_generic(dim, u1, (0, 0)),
            support: OVector::from_element_generic(dim, u1, false),
            support_all: OVector::from_element_generic(dim, u1, true),
            phi: OVector::from_element_generic(dim, u1, T::zero()),
            z: OVector::from_element_generic(dim, u1, T::zero()),
        }
    }

    /// Current estimate of the selected parameter changes.
    pub fn theta(&self) -> &OVector<T, D> {
        match &self.method {
            Method::Ls(r) => &r.theta,
            Method::Iv(r) => &r.theta,
            Method::IvInfo(r) => &r.theta,
        }
    }

    /// One sample: measured `q, qd, qdd` and torque `tau`, and the instrumental
    /// acceleration `qdd_instr` (ignored by least squares). Eqs (41), (46), (52).
    /// Computes only what the rows need ([`super::terminal_rows`]) and skips the rows'
    /// structural zeros in the estimator; equal to [`Self::update_full`] up to rounding.
    pub fn update(
        &mut self,
        q: &SVector<T, N>,
        qd: &SVector<T, N>,
        qdd: &SVector<T, N>,
        tau: &SVector<T, N>,
        qdd_instr: &SVector<T, N>,
    ) -> Result<(), Error> {
        check_finite("tau", tau)?;
        check_finite("qdd", qdd)?;
        let iv = !matches!(self.method, Method::Ls(_));
        if iv {
            check_finite("qdd_instr", qdd_instr)?;
        }
        self.plan();
        let rows = self.spec.rows(N);
        terminal_rows(&self.nominal, &self.needed, &mut self.rows, q, qd, qdd, iv.then_some(qdd_instr));
        let (mut added, mut result) = (false, Ok(()));
        for row in rows {
            if self.min_speed > 0.0 && !(qd[row].abs() >= T::from_f64(self.min_speed)) {
                self.rows_skipped += 1;
                continue;
            }
            // the row's structural support: links outside row, and its own drive only, minus
            // the entries the model's structure makes zero
            for (b, &(l, e)) in self.col_map.iter().enumerate() {
                let on = l >= row && if e < LINK_PARAMS { self.rows.nz[row][l] & (1 << e) != 0 } else { l == row };
                self.support[b] = on;
                self.phi[b] = if on { entry(&self.rows.y, row, l, e) } else { T::zero() };
                if iv {
                    self.z[b] = if on { entry(&self.rows.y_z, row, l, e) } else { T::zero() };
                }
            }
            let dtau = tau[row] - self.rows.tau[row];
            let w = self.row_weight[row];
            result = match &mut self.method {
                Method::Ls(r) => r.update_sparse(&self.phi, &self.support, dtau, w),
                Method::Iv(r) => r.update_sparse(&self.phi, &self.z, &self.support, dtau, w),
                Method::IvInfo(r) => r.add_row_sparse(&self.phi, &self.z, &self.support, dtau, w),
            };
            if result.is_err() {
                break;
            }
            (added, self.rows_used) = (true, self.rows_used + 1);
        }
        self.finish_sample(added, result)
    }

    /// The information form estimates once per sample, after its rows (those added before
    /// a refused row count, as in the row-by-row forms).
    fn finish_sample(&mut self, added: bool, result: Result<(), Error>) -> Result<(), Error> {
        if let (true, Method::IvInfo(r)) = (added, &mut self.method) {
            r.estimate()?;
        }
        result
    }

    /// The column map and the regressor entries the rows need, from `spec` and `columns`
    /// (integer work only; they are public fields, so they are read at every update).
    fn plan(&mut self) {
        let rows = self.spec.rows(N);
        self.needed = Needed { first_row: rows.start, ..Needed::NONE };
        for (b, &c) in self.columns.iter().enumerate() {
            let (l, e) = self.spec.column(c);
            self.col_map[b] = (l, e);
            for row in rows.start..=l.min(N - 1) {
                if e < LINK_PARAMS {
                    self.needed.link[row][l] |= 1 << e;
                } else if row == l {
                    self.needed.drive[row][e - LINK_PARAMS] = true;
                }
            }
        }
    }

    /// The regressor at the last update's measured state: after [`Self::update`], only
    /// the entries of the estimated columns on the rows used are set.
    pub fn last_regressor(&self) -> &Regressor<N, T> {
        &self.rows.y
    }
}

/// Entry `(row, link l, entry e)` of a regressor (`e >= 10`: the row's drive entry).
#[inline(always)]
fn entry<const N: usize, T: RealScalar>(y: &Regressor<N, T>, row: usize, l: usize, e: usize) -> T {
    if e < LINK_PARAMS { y.link[row][l][e] } else { y.drive[row][e - LINK_PARAMS] }
}

/// [`crate::error::check_finite`] for any scalar.
fn check_finite<T: RealScalar, const N: usize>(what: &'static str, x: &SVector<T, N>) -> Result<(), Error> {
    match x.iter().position(|v| !v.is_finite()) {
        Some(index) => Err(Error::NonFinite { what, index }),
        None => Ok(()),
    }
}

impl<const N: usize, D: Dim> TerminalLink<N, D, f64>
where
    DefaultAllocator: Allocator<D, D> + Allocator<D> + Allocator<D, nalgebra::U1>,
{
    /// [`Self::update`] from the full dynamics: a full RNEA for the nominal torque and full
    /// regressors at the measured and instrumental accelerations, dense estimator rows
    /// (the implementation before issue 19). The reference the reduced update is tested
    /// against; it computes the same numbers up to rounding, at about three times the
    /// arithmetic. Afterwards [`Self::last_regressor`] is the full regressor.
    pub fn update_full(
        &mut self,
        q: &VecN<N>,
        qd: &VecN<N>,
        qdd: &VecN<N>,
        tau: &VecN<N>,
        qdd_instr: &VecN<N>,
    ) -> Result<(), Error> {
        crate::error::check_finite("tau", tau.as_slice())?;
        crate::error::check_finite("qdd", qdd.as_slice())?;
        let tau_nom = *rnea(&self.nominal, &mut self.data, q, qd, qdd);
        regressor(&self.nominal, &mut self.data, q, qd, qdd);
        self.rows.y = self.data.y.clone();
        let iv = !matches!(self.method, Method::Ls(_));
        if iv {
            crate::error::check_finite("qdd_instr", qdd_instr.as_slice())?;
            regressor(&self.nominal, &mut self.data_z, q, qd, qdd_instr);
        }
        let (mut added, mut result) = (false, Ok(()));
        self.support_all.fill(true);
        for row in self.spec.rows(N) {
            if self.min_speed > 0.0 && !(qd[row].abs() >= self.min_speed) {
                self.rows_skipped += 1;
                continue;
            }
            for (b, &c) in self.columns.iter().enumerate() {
                self.phi[b] = self.spec.entry(&self.data.y, row, c);
            }
            let dtau = tau[row] - tau_nom[row];
            let w = self.row_weight[row];
            if iv {
                for (b, &c) in self.columns.iter().enumerate() {
                    self.z[b] = self.spec.entry(&self.data_z.y, row, c);
                }
            }
            result = match &mut self.method {
                Method::Ls(r) => r.update(&self.phi, dtau, w),
                Method::Iv(r) => r.update(&self.phi, &self.z, dtau, w),
                Method::IvInfo(r) => r.add_row_sparse(&self.phi, &self.z, &self.support_all, dtau, w),
            };
            if result.is_err() {
                break;
            }
            (added, self.rows_used) = (true, self.rows_used + 1);
        }
        self.finish_sample(added, result)
    }
}

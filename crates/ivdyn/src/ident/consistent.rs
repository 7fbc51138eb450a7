//! Least squares with physical consistency enforced, on the compressed statistics of an
//! [`LsAccumulator`] (no second pass over the data).
//!
//! # Parametrisation
//! Each link's 4x4 pseudo-inertia is `J = U U^T` with the log-Cholesky factor
//! (Rucker & Wensing 2022, "Smooth parameterization of rigid-body inertia")
//!
//! ```text
//!           [ e^d1  s12   s13   t1 ]
//! U = e^a   [ 0     e^d2  s23   t2 ]
//!           [ 0     0     e^d3  t3 ]
//!           [ 0     0     0     1  ]
//! ```
//!
//! which maps `R^10` one-to-one onto the positive definite pseudo-inertias, i.e. onto the
//! physically consistent links ([`super::physical`]). Coulomb, viscous friction and
//! armature are squares (`fc = u^2`, ...: they may reach zero), the torque offset is free.
//!
//! # Cost
//! The LS fit is on base parameters `theta_b = P theta` ([`BaseParams::project`]), and the
//! accumulator holds `R`, `Q^T y` with `||W^(1/2) (y - Phi theta_b)||^2 = rss_min + ||R theta_b - Q^T y||^2`.
//! The consistent fit works on full parameters, which the data do not determine: the
//! directions of `theta` that do not change `R P theta` (unidentifiable, or not excited by
//! this log) are pulled toward the nominal (URDF) parameters with a small weight:
//!
//! ```text
//! min_x ||R P theta(x) - Q^T y||^2 + lambda ||N^T S^-1 (theta(x) - theta_nom)||^2
//! ```
//!
//! `N` is an orthonormal basis of the null space of `R P S` (singular values below
//! `1e-9` of the largest), `S` a diagonal of parameter scales (per link: nominal mass `m`,
//! `m L`, `m L^2` with `L` the link's nominal radius of gyration, at least 5 cm; drives:
//! 1 N m for `fc`, `tau0`, 1 N m s for `fv`, `m L^2` for `ia`), and
//! `lambda = REG_WEIGHT ||R P S||_F^2 / p` with [`REG_WEIGHT`] `= 1e-10`: a tie-breaker.
//! Identifiable directions are not regularised, so when consistent parameters fit the data
//! exactly the consistent fit finds them (a larger weight, 1e-6, was tried: it trades data
//! fit for closeness to the nominal model and LM then crawls along a narrow valley).
//! To stay strictly positive definite with room for rounding (the constrained optimum often
//! lies on the boundary: a mass distribution flattened to a plane or a line), each link is
//! `J = U U^T + MARGIN diag(m L^2, m L^2, m L^2, m)` in the nominal scales ([`MARGIN`] `= 1e-6`).
//! Solved by Levenberg-Marquardt (Marquardt's diagonal damping, numerical Jacobian of the
//! per-link map) by continuation in the weight: stages at `1e-4`, `1e-6`, `1e-8`, then
//! `REG_WEIGHT`, each warm-started from the last (started at the tiny final weight, LM
//! can drift along unidentifiable directions into the boundary and crawl there); the
//! last stage stops when the cost fell by less than `1e-8` of itself over 20
//! iterations (earlier ones at `1e-4`), starting from the LS full parameters projected onto the consistent set
//! (pseudo-inertia eigenvalues raised to [`START_FLOOR`] `= 1e-2` of the largest, negative
//! friction and armature set to ~0).

use nalgebra::{DMatrix, DVector, Matrix4};
use serde::Serialize;

use super::accum::LsAccumulator;
use super::base::BaseParams;
use crate::error::{Error, Result};
use crate::linalg::marquardt_step;
use crate::robot::physical::{PhysicalCheck, check_params, from_pseudo_inertia, pseudo_inertia};
use ivdyn_core::params::{FC, FV, IA, LINK_PARAMS, TAU0, drive_col, link_col};

/// Margin of positive definiteness, relative to the nominal scales (module docs).
pub const MARGIN: f64 = 1e-6;

/// Eigenvalue floor (relative to the largest) when the LS pseudo-inertia is projected onto
/// the consistent set for the start: well inside, since the log-Cholesky variables of an
/// eigenvalue near zero are far out on the exponential and move slowly.
pub const START_FLOOR: f64 = 1e-2;

/// Relative weight of the pull toward the nominal parameters on the unidentifiable directions.
pub const REG_WEIGHT: f64 = 1e-10;

/// Singular values of `R P S` below this fraction of the largest span the directions the
/// data do not see (module docs).
pub const NULL_TOL: f64 = 1e-9;

/// First weight of the continuation down to [`REG_WEIGHT`] (see [`fit_consistent`]).
pub const CONTINUATION_START: f64 = 1e-4;

/// Result of [`fit_consistent`].
#[derive(Debug, Clone, Serialize)]
pub struct ConsistentFit {
    /// Full parameters, physically consistent.
    pub theta: Vec<f64>,
    /// Their base parameters `P theta`.
    pub theta_base: Vec<f64>,
    /// The check of the unconstrained LS full parameters (what was wrong).
    pub ls_check: PhysicalCheck,
    /// The check of the consistent parameters (consistent unless the optimiser failed).
    pub check: PhysicalCheck,
    /// `sum w y^2` of the data (for relative residuals).
    pub sum_wyy: f64,
    /// What consistency cost and how the solver went (flattened into the JSON).
    #[serde(flatten)]
    pub cost: ConsistentCost,
}

/// The cost of consistency and the solver's figures, as the reports show them.
#[derive(Debug, Clone, Copy, Serialize)]
pub struct ConsistentCost {
    /// Weighted residual sum of squares of the LS fit.
    pub rss_ls: f64,
    /// Weighted residual sum of squares with the consistent parameters.
    pub rss: f64,
    /// `rss / rss_ls - 1`: relative degradation of the fit.
    pub rss_increase: f64,
    /// Levenberg-Marquardt iterations, all stages of the path kept.
    pub iterations: usize,
    /// Whether LM met its tolerance.
    pub converged: bool,
    /// Number of full-parameter directions the data do not see, pulled toward the nominal values.
    pub regularised_directions: usize,
}

/// The consistent fit inside an identification report (`ivdyn identify --consistent`).
#[derive(Debug, Clone, Serialize)]
pub struct ConsistentReport {
    /// The fit (parameters, checks, weighted RSS before and after).
    pub result: ConsistentFit,
    /// Per-joint quality of the consistent parameters on the fitted data.
    pub fit: crate::report::Quality,
    /// On the held-out tail (`null` with a separate validation log).
    pub validation: Option<crate::report::Quality>,
    /// The consistent full parameters, reloadable with `--params`.
    pub params: crate::report::ParamsFile,
}

/// Options of [`fit_consistent`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ConsistentOptions {
    /// Maximum LM iterations per continuation stage (four stages at the defaults).
    pub max_iter: usize,
    /// Stop when the cost decreased by less than this fraction over the last 20 iterations
    /// (or when no damping gives a decrease).
    pub tol: f64,
    /// [`REG_WEIGHT`].
    pub reg_weight: f64,
}

impl Default for ConsistentOptions {
    fn default() -> Self {
        ConsistentOptions { max_iter: 1000, tol: 1e-8, reg_weight: REG_WEIGHT }
    }
}

/// Log-Cholesky parameters `[a, d1, d2, d3, s12, s23, s13, t1, t2, t3]` to the 10 link
/// parameters (`J = U U^T`).
pub fn link_from_log_cholesky(x: &[f64]) -> [f64; LINK_PARAMS] {
    from_pseudo_inertia(&pseudo_of(x))
}

fn pseudo_of(x: &[f64]) -> Matrix4<f64> {
    let mut u = Matrix4::zeros();
    u[(0, 0)] = x[1].exp();
    u[(1, 1)] = x[2].exp();
    u[(2, 2)] = x[3].exp();
    u[(3, 3)] = 1.0;
    u[(0, 1)] = x[4];
    u[(1, 2)] = x[5];
    u[(0, 2)] = x[6];
    u[(0, 3)] = x[7];
    u[(1, 3)] = x[8];
    u[(2, 3)] = x[9];
    let u = u * x[0].exp();
    u * u.transpose()
}

/// `J = U U^T + margin`: the link parameters of `x` with the margin matrix added.
fn link_with_margin(x: &[f64], margin: &Matrix4<f64>) -> [f64; LINK_PARAMS] {
    from_pseudo_inertia(&(pseudo_of(x) + margin))
}

/// Log-Cholesky parameters of `J - margin`, projected (eigenvalues clipped at `1e-6` of the
/// largest) when that is not positive definite.
fn start_link(p: &[f64], margin: &Matrix4<f64>) -> Option<[f64; 10]> {
    let j = pseudo_inertia(p) - margin;
    log_cholesky_from_link(&from_pseudo_inertia(&j))
        .or_else(|| log_cholesky_from_link(&project_link(&from_pseudo_inertia(&j))?))
}

/// Inverse of [`link_from_log_cholesky`] for a positive definite pseudo-inertia: `None`
/// when `J` is not positive definite.
pub fn log_cholesky_from_link(p: &[f64]) -> Option<[f64; 10]> {
    let j = pseudo_inertia(p);
    // U U^T = J with U upper triangular: reverse the order, factor L L^T, reverse back.
    let rev = Matrix4::from_fn(|a, b| j[(3 - a, 3 - b)]);
    let l = rev.cholesky()?.l();
    let u = Matrix4::from_fn(|a, b| l[(3 - a, 3 - b)]);
    let s = u[(3, 3)];
    Some([
        s.ln(),
        (u[(0, 0)] / s).ln(),
        (u[(1, 1)] / s).ln(),
        (u[(2, 2)] / s).ln(),
        u[(0, 1)] / s,
        u[(1, 2)] / s,
        u[(0, 2)] / s,
        u[(0, 3)] / s,
        u[(1, 3)] / s,
        u[(2, 3)] / s,
    ])
}

/// The nearest (Frobenius) pseudo-inertia with eigenvalues `>= 1e-6 max eigenvalue`.
/// `None` when the decomposition does not converge (non-finite parameters).
fn project_link(p: &[f64]) -> Option<[f64; LINK_PARAMS]> {
    let e = crate::linalg::sym_eigen(pseudo_inertia(p), "pseudo-inertia").ok()?;
    let top = e.eigenvalues.max().max(1e-12);
    let clipped = e.eigenvalues.map(|l| l.max(START_FLOOR * top));
    let j = e.eigenvectors * Matrix4::from_diagonal(&clipped) * e.eigenvectors.transpose();
    Some(from_pseudo_inertia(&j))
}

/// The consistent parameters of `x` (layout: `10 n` log-Cholesky, then per joint `[u, v, w, tau0]`).
fn theta_of(x: &[f64], n: usize, margins: &[Matrix4<f64>]) -> Vec<f64> {
    let mut th = vec![0.0; 14 * n];
    for i in 0..n {
        th[link_col(i, 0)..link_col(i, LINK_PARAMS)]
            .copy_from_slice(&link_with_margin(&x[10 * i..10 * i + 10], &margins[i]));
    }
    for j in 0..n {
        let o = 10 * n + 4 * j;
        th[drive_col(n, j, FC)] = x[o] * x[o];
        th[drive_col(n, j, FV)] = x[o + 1] * x[o + 1];
        th[drive_col(n, j, IA)] = x[o + 2] * x[o + 2];
        th[drive_col(n, j, TAU0)] = x[o + 3];
    }
    th
}

/// `d theta / d x` (block diagonal: numerical per link, analytic for the drives).
fn jac_theta(x: &[f64], n: usize, margins: &[Matrix4<f64>]) -> DMatrix<f64> {
    let p = 14 * n;
    let mut jm = DMatrix::zeros(p, p);
    for i in 0..n {
        let xi = &x[10 * i..10 * i + 10];
        for k in 0..10 {
            let h = 1e-6;
            let (mut a, mut b) = (xi.to_vec(), xi.to_vec());
            a[k] += h;
            b[k] -= h;
            let (fa, fb) = (link_with_margin(&a, &margins[i]), link_with_margin(&b, &margins[i]));
            for r in 0..10 {
                jm[(link_col(i, r), 10 * i + k)] = (fa[r] - fb[r]) / (2.0 * h);
            }
        }
    }
    for j in 0..n {
        let o = 10 * n + 4 * j;
        jm[(drive_col(n, j, FC), o)] = 2.0 * x[o];
        jm[(drive_col(n, j, FV), o + 1)] = 2.0 * x[o + 1];
        jm[(drive_col(n, j, IA), o + 2)] = 2.0 * x[o + 2];
        jm[(drive_col(n, j, TAU0), o + 3)] = 1.0;
    }
    jm
}

/// Parameter scales `S` (module docs) from the nominal parameters.
pub(crate) fn scales(theta_nom: &[f64], n: usize) -> Vec<f64> {
    let masses: Vec<f64> = (0..n).map(|i| theta_nom[link_col(i, 0)]).collect();
    let pos: Vec<f64> = masses.iter().copied().filter(|m| *m > 0.0).collect();
    let mean = if pos.is_empty() { 1.0 } else { pos.iter().sum::<f64>() / pos.len() as f64 };
    let mut s = vec![1.0; 14 * n];
    for i in 0..n {
        let p = &theta_nom[link_col(i, 0)..link_col(i, LINK_PARAMS)];
        let m = if p[0] > 0.0 { p[0] } else { mean };
        let tr = p[4] + p[6] + p[9];
        let l = if p[0] > 0.0 && tr > 0.0 { (tr / (2.0 * p[0])).sqrt().max(0.05) } else { 0.05 };
        let sc = [m, m * l, m * l, m * l, m * l * l, m * l * l, m * l * l, m * l * l, m * l * l, m * l * l];
        s[link_col(i, 0)..link_col(i, LINK_PARAMS)].copy_from_slice(&sc);
        s[drive_col(n, i, IA)] = m * l * l;
    }
    s
}

fn bad(msg: String) -> Error {
    Error::Numerical { what: "consistent fit".into(), msg }
}

/// Fits physically consistent full parameters (module docs). `acc` holds the (weighted)
/// LS statistics of the base regressor of `base`; `theta_ls` is the LS estimate as full
/// parameters (e.g. [`BaseParams::apply`] on the nominal), `theta_nom` the nominal
/// parameters; `links`, `joints` name the `n` links and joints for the reports.
pub fn fit_consistent(
    acc: &LsAccumulator,
    base: &BaseParams,
    theta_ls: &[f64],
    theta_nom: &[f64],
    links: &[String],
    joints: &[String],
    opts: &ConsistentOptions,
) -> Result<ConsistentFit> {
    let n = joints.len();
    let p = 14 * n;
    check_inputs(acc, base, theta_ls, theta_nom, links, n)?;
    let r = acc.r();
    let qty = acc.qty();
    let rss_min = acc.rss();
    let a = &r * &base_map(base, p); // b x p
    let s = scales(theta_nom, n);
    let as_ = DMatrix::from_fn(base.base_count(), p, |i, j| a[(i, j)] * s[j]);
    let nt0 = null_rows(&as_, &s)?;

    // start: the LS full parameters projected onto the consistent set
    let ls_check = check_params(theta_ls, links, joints);
    let margins = margins(&s, n);
    let x = start_point(theta_ls, &s, &margins, links)?;

    // Levenberg-Marquardt (Marquardt's diagonal scaling) from two paths, keeping the one
    // that ends at the lower cost (both end on the same objective, at `reg_weight`):
    // - direct, at `reg_weight` only;
    // - by continuation in the weight: a strong pull toward the nominal parameters first,
    //   then weaker ones (x100 each) down to `reg_weight`, each warm-started from the last.
    // Direct, LM can wander along the unidentifiable directions into the boundary of the
    // consistent set (a link's pseudo-inertia near singular), where the log-Cholesky
    // variables run off to -inf and LM crawls: on exact UR5 data it stalled at a relative
    // RSS of 1.5e-9 (continuation: 1e-27). On the real arms' data the direct path ends
    // lower (continuation holds the parameters near the nominal ones it started from).
    let weights = continuation_weights(opts.reg_weight);
    let lm = Lm {
        a: &a,
        qty: &qty,
        nt0: &nt0,
        norm_as: as_.norm_squared() / p as f64,
        theta_nom,
        margins: &margins,
        n,
        opts,
    };
    let direct = lm.run(x.clone(), &weights[weights.len() - 1..]);
    let cont = lm.run(x, &weights);
    let end = if cont.cost < direct.cost { cont } else { direct };

    let rss_of =
        |t: &[f64]| -> Result<f64> { Ok(rss_min + (&r * DVector::from_vec(base.project(t)?) - &qty).norm_squared()) };
    let theta_base = base.project(&end.theta)?;
    let rss = rss_of(&end.theta)?;
    let rss_ls = rss_of(theta_ls)?;
    let check = check_params(&end.theta, links, joints);
    Ok(ConsistentFit {
        theta_base,
        ls_check,
        check,
        sum_wyy: acc.sum_wyy(),
        cost: ConsistentCost {
            rss_ls,
            rss,
            rss_increase: if rss_ls > 0.0 { rss / rss_ls - 1.0 } else { f64::NAN },
            iterations: end.iterations,
            converged: end.converged,
            regularised_directions: nt0.nrows(),
        },
        theta: end.theta,
    })
}

/// Checks that the accumulator, the base map and the parameter vectors agree on `n` joints
/// (`14 n` full parameters) and that the start and nominal parameters are finite.
fn check_inputs(
    acc: &LsAccumulator,
    base: &BaseParams,
    theta_ls: &[f64],
    theta_nom: &[f64],
    links: &[String],
    n: usize,
) -> Result<()> {
    let p = 14 * n;
    let b = base.base_count();
    if acc.p() != b || base.full_cols != p || theta_ls.len() != p || theta_nom.len() != p || links.len() != n {
        return Err(Error::Dimension {
            what: "consistent fit: accumulator / base / parameter sizes".into(),
            expected: p,
            got: theta_ls.len(),
        });
    }
    if let Some(i) = theta_ls.iter().chain(theta_nom).position(|v| !v.is_finite()) {
        return Err(bad(format!("parameter {} is not finite", i % p)));
    }
    Ok(())
}

/// `P` (`b x p`) with `theta_b = P theta`: the identity on the independent columns plus the
/// dependent columns' combinations ([`BaseParams::project`] as a matrix).
pub(crate) fn base_map(base: &BaseParams, p: usize) -> DMatrix<f64> {
    let mut pm = DMatrix::zeros(base.base_count(), p);
    for (row, &i) in base.independent.iter().enumerate() {
        pm[(row, i)] = 1.0;
        for (c, &d) in base.dependent.iter().enumerate() {
            pm[(row, d)] += base.k[(row, c)];
        }
    }
    pm
}

/// `N^T S^-1`: the rows that pull the directions the data do not see (singular values of
/// `A S = R P S` below [`NULL_TOL`] of the largest) toward the nominal parameters.
fn null_rows(as_: &DMatrix<f64>, s: &[f64]) -> Result<DMatrix<f64>> {
    let (b, p) = as_.shape();
    // null space of A S from its SVD (padded to p x p rows so that V^T is complete). Not
    // from the eigenvalues of (A S)^T (A S): squared, a 1e-9 singular-value ratio is 1e-18,
    // below the eigenvalues' rounding (~1e-16 of the largest), and which directions counted
    // as null then changed with the last bits of the data.
    let mut padded = DMatrix::zeros(p.max(b), p);
    padded.rows_mut(0, b).copy_from(as_);
    let svd = crate::linalg::svd(padded, false, true, "consistent fit: null space of the scaled regressor")?;
    let vt =
        svd.v_t.as_ref().ok_or_else(|| Error::internal("consistent fit: the SVD was asked for V^T and gave none"))?;
    let top = svd.singular_values.max().max(0.0);
    let null: Vec<usize> = (0..vt.nrows()).filter(|&k| !(svd.singular_values[k] > NULL_TOL * top)).collect();
    Ok(DMatrix::from_fn(null.len(), p, |r_, c| vt[(null[r_], c)] / s[c]))
}

/// Per link, the margin matrix `MARGIN diag(m L^2, m L^2, m L^2, m)` in the nominal scales:
/// strict positive definiteness with room for rounding (the constrained optimum often lies
/// on the boundary: a mass distribution flattened to a plane or a line).
fn margins(s: &[f64], n: usize) -> Vec<Matrix4<f64>> {
    (0..n)
        .map(|i| {
            let (m, ml2) = (s[link_col(i, 0)], s[link_col(i, 4)]);
            Matrix4::from_diagonal(&nalgebra::Vector4::new(ml2, ml2, ml2, m)) * MARGIN
        })
        .collect()
}

/// The LM start `x`: the LS full parameters projected onto the consistent set (links by
/// [`start_link`]; negative friction and armature raised to ~0 before the square root).
fn start_point(theta_ls: &[f64], s: &[f64], margins: &[Matrix4<f64>], links: &[String]) -> Result<Vec<f64>> {
    let n = links.len();
    let mut x = vec![0.0; 14 * n];
    for i in 0..n {
        let pl = &theta_ls[link_col(i, 0)..link_col(i, LINK_PARAMS)];
        let lc = start_link(pl, &margins[i])
            .ok_or_else(|| bad(format!("link '{}': cannot project onto a consistent inertia", links[i])))?;
        x[10 * i..10 * i + 10].copy_from_slice(&lc);
    }
    for j in 0..n {
        let o = 10 * n + 4 * j;
        for (k, col) in [FC, FV, IA].iter().enumerate() {
            let v = theta_ls[drive_col(n, j, *col)];
            let sc = if *col == IA { s[drive_col(n, j, IA)] } else { 1.0 };
            x[o + k] = v.max(1e-6 * sc).sqrt();
        }
        x[o + 3] = theta_ls[drive_col(n, j, TAU0)];
    }
    Ok(x)
}

/// The weights of the continuation path: [`CONTINUATION_START`], then x100 smaller each
/// stage, down to `reg_weight` (just `[reg_weight]` when it is not below the start).
fn continuation_weights(reg_weight: f64) -> Vec<f64> {
    let mut weights = vec![reg_weight];
    while weights.last().is_some_and(|w| *w < CONTINUATION_START) {
        let w = weights.last().map_or(CONTINUATION_START, |w| w * 100.0);
        weights.push(w.min(CONTINUATION_START));
    }
    weights.reverse();
    weights
}

/// The Levenberg-Marquardt problem of the module docs: residual `[A theta(x) - Q^T y;
/// sqrt(lambda) N^T S^-1 (theta(x) - theta_nom)]` over the log-Cholesky variables `x`.
struct Lm<'a> {
    /// `R P` (`b x p`).
    a: &'a DMatrix<f64>,
    /// `Q^T y` (`b`).
    qty: &'a DVector<f64>,
    /// `N^T S^-1` ([`null_rows`]).
    nt0: &'a DMatrix<f64>,
    /// `||R P S||_F^2 / p`: `lambda = weight * norm_as`.
    norm_as: f64,
    /// Nominal full parameters (the pull's target).
    theta_nom: &'a [f64],
    /// Per-link margin matrices ([`margins`]).
    margins: &'a [Matrix4<f64>],
    /// Joints.
    n: usize,
    /// Iteration limit and tolerance.
    opts: &'a ConsistentOptions,
}

/// Where an LM path ended.
struct LmEnd {
    /// Consistent full parameters `theta(x)`.
    theta: Vec<f64>,
    /// Final cost (at the last stage's weight).
    cost: f64,
    /// Iterations over all stages.
    iterations: usize,
    /// Whether the last stage met its stopping rule.
    converged: bool,
}

impl Lm<'_> {
    /// Runs the stages at `weights` in order, each warm-started from the last.
    fn run(&self, mut x: Vec<f64>, weights: &[f64]) -> LmEnd {
        let mut th = theta_of(&x, self.n, self.margins);
        let mut end = LmEnd { theta: vec![], cost: f64::INFINITY, iterations: 0, converged: false };
        for (stage, w) in weights.iter().enumerate() {
            let (cost, iterations, converged) = self.stage(&mut x, &mut th, *w, stage + 1 == weights.len());
            (end.cost, end.converged) = (cost, converged);
            end.iterations += iterations;
        }
        end.theta = th;
        end
    }

    /// One continuation stage at weight `w`: LM iterations until the cost stalls (the last
    /// stage at `opts.tol`, earlier ones only need to get close: at least `1e-4`), no
    /// damping gives a decrease, or `opts.max_iter`. Returns (cost, iterations, converged).
    fn stage(&self, x: &mut Vec<f64>, th: &mut Vec<f64>, w: f64, last: bool) -> (f64, usize, bool) {
        let nt = self.nt0 * (w * self.norm_as).sqrt(); // sqrt(lambda) N^T S^-1
        let mut rv = self.resid(&nt, th);
        let mut cost = rv.norm_squared();
        let mut mu = 1e-3;
        let mut history = vec![cost];
        let tol = if last { self.opts.tol } else { self.opts.tol.max(1e-4) };
        let (mut sit, mut converged) = (0, false);
        while sit < self.opts.max_iter {
            sit += 1;
            let jr = self.jacobian(&nt, x);
            let step = marquardt_step(x, &jr.tr_mul(&jr), &jr.tr_mul(&rv), &mut mu, cost, |xn| {
                let thn = theta_of(xn, self.n, self.margins);
                let rn = self.resid(&nt, &thn);
                let cn = rn.norm_squared();
                ((thn, rn), cn)
            });
            // no decrease possible at any damping: a (local) minimum to rounding
            converged = step.is_none();
            if let Some((xn, (thn, rn), cn)) = step {
                (*x, *th, rv, cost) = (xn, thn, rn, cn);
            }
            history.push(cost);
            let h = history.len();
            if h > 20 && history[h - 21] - cost <= tol * history[h - 21] {
                converged = true;
            }
            if converged {
                break;
            }
        }
        (cost, sit, converged)
    }

    /// Residual at `th` with the pull rows `nt`: `[A th - Q^T y; nt (th - theta_nom)]`.
    fn resid(&self, nt: &DMatrix<f64>, th: &[f64]) -> DVector<f64> {
        let (b, p) = self.a.shape();
        let thv = DVector::from_column_slice(th);
        let mut out = DVector::zeros(b + nt.nrows());
        out.rows_mut(0, b).copy_from(&(self.a * &thv - self.qty));
        let d = DVector::from_iterator(p, th.iter().zip(self.theta_nom).map(|(x, y)| x - y));
        out.rows_mut(b, nt.nrows()).copy_from(&(nt * d));
        out
    }

    /// Jacobian of the residual in `x`: `[A; nt] d theta / d x`.
    fn jacobian(&self, nt: &DMatrix<f64>, x: &[f64]) -> DMatrix<f64> {
        let (b, p) = self.a.shape();
        let a = self.a;
        DMatrix::from_fn(b + nt.nrows(), p, |i, j| if i < b { a[(i, j)] } else { nt[(i - b, j)] })
            * jac_theta(x, self.n, self.margins)
    }
}

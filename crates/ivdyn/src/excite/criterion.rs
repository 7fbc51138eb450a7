//! The criterion (`log cond` or `-log det` of the stacked base regressor, module docs of
//! [`super`]) on the variables `x`, and its gradient: finite differences of the regressor
//! in `(q, qd, qdd)` per sample, contracted with `dcrit/dPhi`, then chained through the
//! bound scaling. Also the scores reported for a sampled trajectory.

use nalgebra::{DMatrix, DVector};

use super::bounds::{Active, Box1, project_rest, scale_into};
use super::fourier::{Basis, Coeffs, Samples, dot};
use super::{Criterion, Scores};
use crate::Robot;
use crate::error::Result;
use crate::ident::{BaseParams, LsAccumulator};
use ivdyn_core::params::PARAMS_PER_JOINT;
use ivdyn_core::rng::Rng;

/// Step of the central differences in `q` (rad or m).
const HQ: f64 = 1e-6;
/// Step of the central differences in `qd` (exact for the quadratic velocity terms).
const HV: f64 = 1e-2;

/// The optimisation problem: robot, base columns, grids, bounds.
pub(super) struct Problem<'a> {
    /// The robot whose regressor is evaluated.
    pub(super) robot: &'a Robot,
    /// Base parameters: the regressor's independent columns.
    pub(super) base: &'a BaseParams,
    /// Joints.
    pub(super) n: usize,
    /// Harmonics.
    pub(super) h: usize,
    /// Fundamental angular frequency (rad/s).
    pub(super) omega: f64,
    /// Per-joint limits after the margin.
    pub(super) boxes: Vec<Box1>,
    /// Samples of the criterion.
    pub(super) crit_grid: Basis,
    /// Samples of the bound scaling.
    pub(super) bound_grid: Basis,
    /// The criterion minimised.
    pub(super) criterion: Criterion,
    /// base columns that are Coulomb columns (zero derivative in qd)
    pub(super) coulomb: Vec<bool>,
}

/// Per joint: scale, active bound, projected coefficients, `dq0/dz`.
type JointMap = (f64, Active, Vec<f64>, f64);

/// Result of one evaluation.
pub(super) struct Eval {
    /// Criterion value (to be minimised; infinite when `Phi` is rank deficient).
    pub(super) f: f64,
    /// Gradient in `x`, when asked for.
    pub(super) grad: Option<Vec<f64>>,
}

/// The regressor of every state of [`Problem::states`], row-major `(K x per x n) x p`,
/// read at base columns.
struct StackedRows<'a> {
    full: Vec<f64>,
    /// States per sample: 1, or `1 + 5 n` with the gradient's perturbations.
    per: usize,
    n: usize,
    p: usize,
    cols: &'a [usize],
}

impl StackedRows<'_> {
    /// Base column `c` of torque row `r` of state `s` of sample `k`.
    fn at(&self, k: usize, s: usize, r: usize, c: usize) -> f64 {
        self.full[((k * self.per + s) * self.n + r) * self.p + self.cols[c]]
    }
}

/// Eigen-decomposition of `Phi^T Phi`, with the indices of its extreme eigenvalues.
struct Spectrum {
    eig: nalgebra::SymmetricEigen<f64, nalgebra::Dyn>,
    imax: usize,
    imin: usize,
}

impl Spectrum {
    /// Decomposes `Phi^T Phi` and finds its largest and smallest eigenvalues (first index on ties).
    fn of(phi: &DMatrix<f64>) -> Result<Spectrum> {
        let eig = crate::linalg::sym_eigen(phi.tr_mul(phi), "excitation criterion: information matrix")?;
        let (mut imax, mut imin) = (0, 0);
        for j in 0..eig.eigenvalues.len() {
            if eig.eigenvalues[j] > eig.eigenvalues[imax] {
                imax = j;
            }
            if eig.eigenvalues[j] < eig.eigenvalues[imin] {
                imin = j;
            }
        }
        Ok(Spectrum { eig, imax, imin })
    }
}

impl<'a> Problem<'a> {
    /// Number of variables: per joint `z` and `2h` coefficients.
    pub(super) fn nvar(&self) -> usize {
        self.n * (1 + 2 * self.h)
    }

    /// Maps the variables `x = [z_i, c_i (2h)]_i` to coefficients (scaled into the bounds
    /// on `grid`), with per joint the scale, the active bound and the projected `c`.
    pub(super) fn realise(&self, x: &[f64], grid: &Basis) -> (Coeffs, Vec<JointMap>) {
        let (n, h) = (self.n, self.h);
        let mut co = Coeffs { n, h, omega: self.omega, q0: vec![0.0; n], a: vec![0.0; n * h], b: vec![0.0; n * h] };
        let mut info = Vec::with_capacity(n);
        for i in 0..n {
            let xi = &x[i * (1 + 2 * h)..(i + 1) * (1 + 2 * h)];
            let (q0, dq0) = self.boxes[i].offset(xi[0]);
            let mut pc = xi[1..].to_vec();
            project_rest(&mut pc, h);
            let (s, act) = scale_into(&pc, q0, &self.boxes[i], grid);
            let s = if s.is_finite() { s } else { 0.0 };
            co.q0[i] = q0;
            for l in 0..h {
                co.a[i * h + l] = s * pc[l];
                co.b[i * h + l] = s * pc[h + l];
            }
            info.push((s, act, pc, dq0));
        }
        (co, info)
    }

    /// Criterion (to be minimised) and optionally its gradient.
    pub(super) fn eval(&self, x: &[f64], want_grad: bool, sharpness: Option<f64>) -> Result<Eval> {
        let (co, info) = self.realise(x, &self.bound_grid);
        let rows = self.regressor_rows(&co, want_grad)?;
        let phi = self.phi(&rows);
        let sp = Spectrum::of(&phi)?;
        let (lmax, lmin) = (sp.eig.eigenvalues[sp.imax], sp.eig.eigenvalues[sp.imin]);
        if !(lmin > 0.0) {
            return Ok(Eval { f: f64::INFINITY, grad: None });
        }
        let (f, w) = self.criterion_of(&sp, lmax, lmin, phi.nrows(), sharpness);
        if !want_grad {
            return Ok(Eval { f, grad: None });
        }
        // d lambda_j = 2 v_j^T Phi^T dPhi v_j, so dF = <dPhi, Phi M> with M = 2 V diag(w) V^T
        let m = &sp.eig.eigenvectors
            * DMatrix::from_diagonal(&DVector::from_vec(w.iter().map(|x| 2.0 * x).collect()))
            * sp.eig.eigenvectors.transpose();
        let gm = &phi * m;
        let (ge, gq0) = self.state_gradient(&rows, &gm);
        Ok(Eval { f, grad: Some(self.chain_gradient(&info, &ge, &gq0)) })
    }

    /// The regressor at the criterion samples of `co`: per sample the state, then (with
    /// `want_grad`) `q +- HQ e_i`, `qd +- HV e_i`, `qdd + e_i` for every joint `i`.
    fn regressor_rows(&self, co: &Coeffs, want_grad: bool) -> Result<StackedRows<'a>> {
        let n = self.n;
        let kk = self.crit_grid.len();
        let per = if want_grad { 1 + 5 * n } else { 1 };
        let (q, qd, qdd) = self.states(co, per);
        let p = PARAMS_PER_JOINT * n;
        let mut full = vec![0.0; kk * per * n * p];
        crate::batch::regressor_batch(self.robot, &q, &qd, &qdd, &mut full, false)?;
        Ok(StackedRows { full, per, n, p, cols: &self.base.independent })
    }

    /// The `per` states of each criterion sample (see [`Self::regressor_rows`]), row-major
    /// `(K x per) x n` positions, velocities and accelerations.
    fn states(&self, co: &Coeffs, per: usize) -> (Vec<f64>, Vec<f64>, Vec<f64>) {
        let n = self.n;
        let g = &self.crit_grid;
        let kk = g.len();
        let (mut q, mut qd, mut qdd) = (vec![0.0; kk * per * n], vec![0.0; kk * per * n], vec![0.0; kk * per * n]);
        for k in 0..kk {
            let (mut q0, mut v0, mut a0) = (vec![0.0; n], vec![0.0; n], vec![0.0; n]);
            for i in 0..n {
                let e = co.joint(i);
                q0[i] = co.q0[i] + dot(g.row(&g.q, k), &e);
                v0[i] = dot(g.row(&g.qd, k), &e);
                a0[i] = dot(g.row(&g.qdd, k), &e);
            }
            for s in 0..per {
                let o = (k * per + s) * n;
                q[o..o + n].copy_from_slice(&q0);
                qd[o..o + n].copy_from_slice(&v0);
                qdd[o..o + n].copy_from_slice(&a0);
                if s == 0 {
                    continue;
                }
                let (kind, i) = ((s - 1) / n, (s - 1) % n);
                match kind {
                    0 => q[o + i] += HQ,
                    1 => q[o + i] -= HQ,
                    2 => qd[o + i] += HV,
                    3 => qd[o + i] -= HV,
                    _ => qdd[o + i] += 1.0,
                }
            }
        }
        (q, qd, qdd)
    }

    /// The stacked base regressor `Phi` (`K n x b`) at the unperturbed states.
    fn phi(&self, rows: &StackedRows) -> DMatrix<f64> {
        let (n, kk, b) = (self.n, self.crit_grid.len(), self.base.base_count());
        let mut phi = DMatrix::<f64>::zeros(kk * n, b);
        for k in 0..kk {
            for r in 0..n {
                for c in 0..b {
                    phi[(k * n + r, c)] = rows.at(k, 0, r, c);
                }
            }
        }
        phi
    }

    /// `f` as a function of the eigenvalues of `Phi^T Phi` (`rows` rows), and
    /// `w_j = df/dlambda_j`: `log cond`, its smooth surrogate of the given sharpness, or
    /// `-log det`.
    fn criterion_of(
        &self,
        sp: &Spectrum,
        lmax: f64,
        lmin: f64,
        rows: usize,
        sharpness: Option<f64>,
    ) -> (f64, Vec<f64>) {
        let lam = &sp.eig.eigenvalues;
        let b = lam.len();
        match (self.criterion, sharpness) {
            (Criterion::Cond, None) => {
                let mut w = vec![0.0; b];
                w[sp.imax] += 0.5 / lmax;
                w[sp.imin] -= 0.5 / lmin;
                (0.5 * (lmax / lmin).ln(), w)
            }
            (Criterion::Cond, Some(p)) => {
                // smooth upper bound of log cond: (log sum (l/lmax)^p + log sum (lmin/l)^p) / 2p
                // + log(lmax/lmin) / 2, which tends to log cond as p grows
                let up: Vec<f64> = lam.iter().map(|l| (l / lmax).powf(p)).collect();
                let dn: Vec<f64> = lam.iter().map(|l| (lmin / l).powf(p)).collect();
                let (su, sd) = (up.iter().sum::<f64>(), dn.iter().sum::<f64>());
                let f = 0.5 * (lmax / lmin).ln() + (su.ln() + sd.ln()) / (2.0 * p);
                let w = (0..b).map(|j| 0.5 * (up[j] / su - dn[j] / sd) / lam[j]).collect();
                (f, w)
            }
            (Criterion::Logdet, _) => {
                (-lam.iter().map(|l| (l / rows as f64).ln()).sum::<f64>(), lam.iter().map(|l| -1.0 / l).collect())
            }
        }
    }

    /// Gradient in the realised coefficients `e` (`n x 2h`) and offsets `q0` from `gm =
    /// dF/dPhi`: per sample and joint, the sensitivities to `q_i`, `qd_i`, `qdd_i` (finite
    /// differences of the regressor; Coulomb columns get none in `qd`) times the basis.
    fn state_gradient(&self, rows: &StackedRows, gm: &DMatrix<f64>) -> (Vec<f64>, Vec<f64>) {
        let (n, h, b) = (self.n, self.h, self.base.base_count());
        let g = &self.crit_grid;
        let mut ge = vec![0.0; n * 2 * h];
        let mut gq0 = vec![0.0; n];
        for k in 0..g.len() {
            for i in 0..n {
                let (mut sq, mut sv, mut sa) = (0.0, 0.0, 0.0);
                for r in 0..n {
                    for c in 0..b {
                        let w = gm[(k * n + r, c)];
                        let y0 = rows.at(k, 0, r, c);
                        sq += w * (rows.at(k, 1 + i, r, c) - rows.at(k, 1 + n + i, r, c)) / (2.0 * HQ);
                        if !self.coulomb[c] {
                            sv += w * (rows.at(k, 1 + 2 * n + i, r, c) - rows.at(k, 1 + 3 * n + i, r, c)) / (2.0 * HV);
                        }
                        sa += w * (rows.at(k, 1 + 4 * n + i, r, c) - y0);
                    }
                }
                gq0[i] += sq;
                let (bq, bv, ba) = (g.row(&g.q, k), g.row(&g.qd, k), g.row(&g.qdd, k));
                for c in 0..2 * h {
                    ge[i * 2 * h + c] += sq * bq[c] + sv * bv[c] + sa * ba[c];
                }
            }
        }
        (ge, gq0)
    }

    /// Chains the coefficient gradient through `e = s pc`, `s = s(pc, q0)` (envelope
    /// theorem at the active bound's sample), `q0 = q0(z)`, `pc = P c`.
    fn chain_gradient(&self, info: &[JointMap], ge: &[f64], gq0: &[f64]) -> Vec<f64> {
        let h = self.h;
        let mut grad = vec![0.0; self.nvar()];
        for i in 0..self.n {
            let (s, act, pc, dq0) = (&info[i].0, info[i].1, &info[i].2, info[i].3);
            let gei = &ge[i * 2 * h..(i + 1) * 2 * h];
            let gdotpc = dot(gei, pc);
            let mut gpc: Vec<f64> = gei.iter().map(|v| s * v).collect();
            let (row, coef, dsdq0) = self.active_derivative(act, *s, pc);
            for c in 0..2 * h {
                gpc[c] += gdotpc * coef * row[c];
            }
            project_rest(&mut gpc, h);
            let off = i * (1 + 2 * h);
            grad[off] = (gq0[i] + gdotpc * dsdq0) * dq0;
            grad[off + 1..off + 1 + 2 * h].copy_from_slice(&gpc);
        }
        grad
    }

    /// Derivatives of the scale `s` at the active bound: `ds/dpc = coef row` (the bound
    /// grid's row at the active sample) and `ds/dq0` (position bounds only).
    fn active_derivative(&self, act: Active, s: f64, pc: &[f64]) -> (&[f64], f64, f64) {
        let bg = &self.bound_grid;
        match act {
            Active::Vel(k, sg) => {
                let r = bg.row(&bg.qd, k);
                let pk = sg * dot(r, pc);
                (r, -s / pk * sg, 0.0)
            }
            Active::Acc(k, sg) => {
                let r = bg.row(&bg.qdd, k);
                let pk = sg * dot(r, pc);
                (r, -s / pk * sg, 0.0)
            }
            Active::Upper(k) => {
                let r = bg.row(&bg.q, k);
                let pk = dot(r, pc);
                (r, -s / pk, -1.0 / pk)
            }
            Active::Lower(k) => {
                let r = bg.row(&bg.q, k);
                let pk = -dot(r, pc);
                (r, s / pk, 1.0 / pk)
            }
        }
    }

    /// A random start: offsets `z ~ N(0, 1/4)` (finite ranges), coefficients `N(0, 1/l^2)`.
    pub(super) fn random_x(&self, rng: &mut Rng) -> Vec<f64> {
        let mut x = vec![0.0; self.nvar()];
        for i in 0..self.n {
            let off = i * (1 + 2 * self.h);
            x[off] = if self.boxes[i].finite_pos() { 0.5 * rng.normal() } else { 0.0 };
            for c in 0..2 * self.h {
                // higher harmonics smaller (a smooth trajectory), as a random excitation would be
                let l = (c % self.h + 1) as f64;
                x[off + 1 + c] = rng.normal() / l;
            }
        }
        x
    }

    /// Rescales each joint's `c` to unit norm (the map is invariant to it).
    pub(super) fn normalise(&self, x: &mut [f64]) {
        for i in 0..self.n {
            let off = i * (1 + 2 * self.h) + 1;
            let c = &mut x[off..off + 2 * self.h];
            let nrm = c.iter().map(|v| v * v).sum::<f64>().sqrt();
            if nrm > 0.0 {
                c.iter_mut().for_each(|v| *v /= nrm);
            }
        }
    }
}

/// Criterion values of a sampled trajectory on the base regressor: the condition number
/// from the triangular factor of the stacked rows (accumulated with [`LsAccumulator`], no
/// squaring of the condition number) and `log det(Phi^T Phi / rows)`.
pub fn scores(robot: &Robot, base: &BaseParams, s: &Samples) -> Result<Scores> {
    let n = robot.dof();
    let p = robot.num_params();
    let b = base.base_count();
    let t = s.t.len();
    let mut acc = LsAccumulator::new(b);
    const CHUNK: usize = 1024;
    let mut full = vec![];
    for st in (0..t).step_by(CHUNK) {
        let e = (st + CHUNK).min(t);
        full.resize((e - st) * n * p, 0.0);
        let r = st * n..e * n;
        crate::batch::regressor_batch(robot, &s.q[r.clone()], &s.qd[r.clone()], &s.qdd[r], &mut full, false)?;
        let rows = base.select_rows(&full, (e - st) * n)?;
        acc.add_rows(&rows, &vec![0.0; (e - st) * n], None)?;
    }
    let r = acc.r();
    let sv = r.singular_values();
    let (mx, mn) = sv.iter().fold((0.0f64, f64::INFINITY), |(a, c), &v| (a.max(v), c.min(v)));
    let rows = (t * n) as f64;
    let logdet = sv.iter().map(|v| (v * v / rows).ln()).sum();
    Ok(Scores { cond: mx / mn, logdet })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::excite::ExciteOptions;
    use crate::excite::bounds::joint_bounds;
    use crate::ident::robot_base_params;
    use ivdyn_core::params::{FC, drive_col};

    /// The analytic gradient matches central differences of the criterion.
    #[test]
    fn gradient_matches_finite_differences() {
        let robot = Robot::from_urdf(
            concat!(env!("CARGO_MANIFEST_DIR"), "/../../fixtures/ur5.urdf"),
            Some("base_link"),
            Some("tool0"),
        )
        .unwrap();
        let opts = ExciteOptions { harmonics: 3, opt_samples: 30, ..Default::default() };
        let (n, base) = (robot.dof(), robot_base_params(&robot, 200, 1).unwrap());
        for crit in [Criterion::Cond, Criterion::Logdet] {
            let bounds = joint_bounds(&robot, &opts).unwrap();
            let boxes = bounds
                .iter()
                .map(|b| Box1 { lower: b.lower, upper: b.upper, vel: b.velocity, acc: b.acceleration })
                .collect();
            let h = opts.harmonics;
            let omega = std::f64::consts::TAU * 0.1;
            let ct: Vec<f64> = (0..30).map(|k| 10.0 * (k as f64 + 0.5) / 30.0).collect();
            let bt: Vec<f64> = (0..=200).map(|k| 10.0 * k as f64 / 200.0).collect();
            let coulomb = base.independent.iter().map(|&c| (0..n).any(|j| drive_col(n, j, FC) == c)).collect();
            let pr = Problem {
                robot: &robot,
                base: &base,
                n,
                h,
                omega,
                boxes,
                crit_grid: Basis::new(omega, h, &ct),
                bound_grid: Basis::new(omega, h, &bt),
                criterion: crit,
                coulomb,
            };
            let mut rng = Rng::new(3);
            let x = pr.random_x(&mut rng);
            for sh in [None, Some(8.0)] {
                let g = pr.eval(&x, true, sh).unwrap().grad.unwrap();
                let mut worst: f64 = 0.0;
                let gn = g.iter().map(|v| v * v).sum::<f64>().sqrt();
                for j in 0..x.len() {
                    let eps = 1e-6;
                    let (mut xp, mut xm) = (x.clone(), x.clone());
                    xp[j] += eps;
                    xm[j] -= eps;
                    let fd = (pr.eval(&xp, false, sh).unwrap().f - pr.eval(&xm, false, sh).unwrap().f) / (2.0 * eps);
                    worst = worst.max((fd - g[j]).abs() / gn);
                }
                assert!(worst < 1e-5, "{crit:?} {sh:?}: gradient error {worst:e} relative to |g| = {gn:e}");
            }
        }
    }
}

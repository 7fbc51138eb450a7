//! The physically possible payload nearest to the least-squares one.
//!
//! # Physically possible
//! Ten parameters `theta = [m, h, I_o]` (mass, first moment `h = m c`, inertia about the
//! link origin) are a rigid body iff the 4x4 pseudo-inertia, the second moments of the
//! mass distribution `J = ∫ [x; 1] [x; 1]^T dm = [[tr(I_o)/2 1 - I_o, h], [h^T, m]]`,
//! is positive semi-definite (Wensing, Kim, Slotine 2017, "Linear matrix inequalities for
//! physically consistent inertial parameter identification"). That one condition holds
//! mass >= 0, the inertia about the COM positive semi-definite, and its principal moments
//! satisfying the triangle inequalities `I1 + I2 >= I3`.
//!
//! # Why the least-squares estimate is often not
//! A compact payload (a point mass, a rod) lies on the boundary of that set: its second
//! moments about the COM are zero in some directions. The noise of the fit then makes them
//! negative about half the time in each direction, and the estimate is not a body (the
//! issue's demo: Ixx = -0.002 kg m^2 for a point mass); with no payload at all, the mass
//! itself is negative half the time.
//!
//! # The consistent estimate
//! The payload that the data make most likely among the possible ones: with `theta_ls`
//! and its covariance `Sigma` (the fit's, first order),
//!
//! ```text
//! theta* = argmin (theta - theta_ls)^T Sigma^-1 (theta - theta_ls)   subject to  J(theta) = L L^T + E
//! ```
//!
//! for some `L` (any PSD `J - E`: a mass of ~0 and flat or line-like bodies are reachable),
//! with `E = MARGIN diag(M l^2, M l^2, M l^2, M)`, `M` the mass scale (the larger of
//! `|m_ls|` and its std), `l` = [`LENGTH`]: a margin far below the uncertainty that keeps
//! the inertia strictly positive definite, because MuJoCo refuses a principal moment of
//! exactly zero.
//!
//! `J` is linear in `theta`, so this is a convex quadratic over a convex cone (a small
//! semidefinite program): one minimum, which an interior-point method finds from any
//! strictly feasible start, with a bound on how far from the minimum it stops. That is
//! what [`project`] does (the log-det barrier, Newton's method along the central path,
//! started from the LS pseudo-inertia with its negative eigenvalues raised). The
//! factorised form `J = L L^T` with Levenberg-Marquardt on `L` was tried first: at the
//! usual answer, a point mass, `L` is singular, the Gauss-Newton model loses the curvature
//! that matters, and three starts on one problem stopped after 5000 iterations at
//! Mahalanobis distances 9.70, 8.89 and 9.24 (the barrier method: one answer, 7.07, in 40
//! Newton steps; 30 to 60 on 2000 simulated payloads).
//!
//! # The distance
//! The same minimum without the margin (`E = 0`) is `d2`, the squared Mahalanobis distance
//! from the LS estimate to the nearest rigid body. When the payload is rigid, its true parameters are possible, so `d2` is at
//! most their distance, which is chi-square with 10 degrees of freedom (Gaussian noise, the
//! covariance right): `P(chi2_10 > d2)` is a conservative p-value, and a small one says the
//! data contradict a rigid payload on the last link.

use nalgebra::{Matrix4, SMatrix, SVector, Vector4};
use serde::Serialize;

use super::stats::chi2_sf;
use crate::robot::physical::{from_pseudo_inertia, pseudo_inertia};

type V10 = SVector<f64, 10>;
type M10 = SMatrix<f64, 10, 10>;

/// Margin of positive definiteness of the consistent payload, relative to its scales
/// (module docs): far below any standard deviation, far above rounding.
pub const MARGIN: f64 = 1e-6;

/// Length scale of the margin (m): a typical payload radius.
pub const LENGTH: f64 = 0.05;

/// Where the central path stops: the cost (a squared Mahalanobis distance, chi-square
/// units) is then within this of its constrained minimum ([`Problem::central_path`]), and
/// the parameters within `sqrt(GAP)` = 0.001 std of the minimiser (the cost is a quadratic
/// with unit curvature in std units). Much further down the path (1e-9) the barrier's
/// Hessian becomes too ill-conditioned to solve: its curvature across a point mass's
/// vanishing moments grows as `1 / mu`.
const GAP: f64 = 1e-6;

/// How far ten parameters `[m, mcx, mcy, mcz, Ixx, Ixy, Iyy, Ixz, Iyz, Izz]` are from a
/// rigid body.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Violation {
    /// Whether they are a rigid body (pseudo-inertia positive semi-definite).
    pub possible: bool,
    /// Mass (kg): negative is impossible.
    pub mass: f64,
    /// Smallest eigenvalue of the pseudo-inertia `J` (kg m^2 for the second moments, kg for
    /// the mass; mixed units, as `J` is): negative is impossible.
    pub min_eig_pseudo_inertia: f64,
    /// Smallest principal moment of the inertia about the centre of mass (kg m^2); `None`
    /// when the mass is not positive (no centre of mass).
    pub min_principal_moment: Option<f64>,
    /// Worst triangle inequality `I1 + I2 - I3` of the principal moments about the centre of
    /// mass, `I3` the largest (kg m^2; twice the smallest second moment, negative is
    /// impossible); `None` when the mass is not positive.
    pub triangle_margin: Option<f64>,
}

/// The consistent estimate of [`project`].
#[derive(Debug, Clone, PartialEq)]
pub struct Projection {
    /// The consistent parameters `[m, mcx, mcy, mcz, Ixx, Ixy, Iyy, Ixz, Iyz, Izz]`.
    pub params: [f64; 10],
    /// Squared Mahalanobis distance from the LS estimate to the nearest rigid body (`J >= 0`,
    /// without the margin; 0 when the LS estimate is one).
    pub distance2: f64,
    /// Degrees of freedom of its chi-square bound (the identifiable parameters: 10).
    pub dof: usize,
    /// `P(chi2_dof > distance2)` (conservative, module docs).
    pub p_value: f64,
    /// Newton steps along the central paths (0 when the LS estimate was possible).
    pub iterations: usize,
}

/// The violations of `p` (see [`Violation`]).
pub fn violation(p: &[f64; 10]) -> Violation {
    // the eigenvalues of a non-finite matrix never converge; nothing is possible then
    if p.iter().any(|v| !v.is_finite()) {
        let nan = f64::NAN;
        return Violation {
            possible: false,
            mass: p[0],
            min_eig_pseudo_inertia: nan,
            min_principal_moment: None,
            triangle_margin: None,
        };
    }
    let min_eig = pseudo_inertia(p).symmetric_eigenvalues().min();
    let mut v = Violation {
        possible: min_eig >= 0.0,
        mass: p[0],
        min_eig_pseudo_inertia: min_eig,
        min_principal_moment: None,
        triangle_margin: None,
    };
    if p[0] > 0.0 {
        let mut eig: Vec<f64> = inertia_about_com(p).symmetric_eigenvalues().iter().copied().collect();
        eig.sort_by(|a, b| a.total_cmp(b));
        v.min_principal_moment = Some(eig[0]);
        v.triangle_margin = Some(eig[0] + eig[1] - eig[2]);
    }
    v
}

/// `I_c = I_o + m [c]x [c]x`, `c = h / m` (the parallel-axis theorem).
fn inertia_about_com(p: &[f64; 10]) -> nalgebra::Matrix3<f64> {
    let io = nalgebra::Matrix3::new(p[4], p[5], p[7], p[5], p[6], p[8], p[7], p[8], p[9]);
    let cx = (nalgebra::Vector3::new(p[1], p[2], p[3]) / p[0]).cross_matrix();
    io + p[0] * cx * cx
}

/// The consistent payload nearest to `theta_ls` in the metric of its covariance `cov`
/// (module docs). `theta_ls` must be finite and `cov` symmetric positive semi-definite.
///
/// Two projections: onto the rigid bodies (`J >= 0`) for the distance and its p-value, and
/// onto `J >= E` for the parameters. The margin is there for the simulators, not for the
/// statistics: on data whose std is below it (a noise-free simulation) it would otherwise
/// be all the distance.
pub fn project(theta_ls: &[f64; 10], cov: &M10) -> Projection {
    // outside the precondition the eigen-decompositions below would never converge: the
    // fit is returned as it is, at an undefined distance
    if theta_ls.iter().chain(cov.iter()).any(|v| !v.is_finite()) {
        return Projection { params: *theta_ls, distance2: f64::NAN, dof: 10, p_value: f64::NAN, iterations: 0 };
    }
    let (rigid, d0) = Problem::new(theta_ls, cov, 0.0).nearest();
    let (margin, d) = Problem::new(theta_ls, cov, MARGIN).nearest();
    let distance2 = rigid.map_or(0.0, |(_, cost)| cost);
    let params = margin.map_or(*theta_ls, |(theta, _)| theta);
    Projection { params, distance2, dof: 10, p_value: chi2_sf(distance2, 10.0), iterations: d0 + d }
}

/// The problem in scaled variables `z = D^-1 theta`, `D` the fit's std: `f(z) = (z -
/// z_ls)^T W (z - z_ls)`, `W = D Sigma^-1 D` (near a correlation matrix's inverse, well
/// scaled whatever the units), subject to `J(D z) - E` positive definite.
struct Problem {
    /// `D` (the std of the 10 parameters).
    d: V10,
    w: M10,
    z_ls: V10,
    /// `dJ / dz_k = D_k pseudo_inertia(e_k)` (`J` is linear in `theta`).
    basis: [Matrix4<f64>; 10],
    /// The margin `E` (module docs).
    margin: Matrix4<f64>,
}

impl Problem {
    /// The problem of `theta_ls`, `cov` with the margin `E` at `margin` times the scales.
    fn new(theta_ls: &[f64; 10], cov: &M10, margin: f64) -> Self {
        let cov = 0.5 * (cov + cov.transpose());
        let top = cov.diagonal().max().max(f64::MIN_POSITIVE);
        // a parameter whose variance rounds to zero is pinned down by the data: scale it as
        // if its std were 1e-8 of the largest (a huge weight, not an infinite one)
        let d = cov.diagonal().map(|v| v.max(1e-16 * top).sqrt());
        let corr = M10::from_fn(|a, b| cov[(a, b)] / (d[a] * d[b]));
        let e = corr.symmetric_eigen();
        let floor = 1e-14 * e.eigenvalues.max();
        let w = e.eigenvectors
            * M10::from_diagonal(&e.eigenvalues.map(|v| 1.0 / v.max(floor)))
            * e.eigenvectors.transpose();
        let basis = std::array::from_fn(|k| {
            let mut ek = [0.0; 10];
            ek[k] = d[k];
            pseudo_inertia(&ek)
        });
        let mass_scale = theta_ls[0].abs().max(d[0]).max(1e-12);
        let ml2 = mass_scale * LENGTH * LENGTH;
        let margin = Matrix4::from_diagonal(&Vector4::new(ml2, ml2, ml2, mass_scale)) * margin;
        let z_ls = V10::from_fn(|k, _| theta_ls[k] / d[k]);
        Problem { d, w, z_ls, basis, margin }
    }

    /// The nearest point of the set and its cost (`None` when `theta_ls` is strictly inside:
    /// nothing moves), and the Newton steps taken.
    fn nearest(&self) -> (Option<([f64; 10], f64)>, usize) {
        let Some(z0) = self.interior_start(&self.z_ls) else { return (None, 0) };
        let (z, steps) = self.central_path(z0);
        (Some((self.theta_of(&z).into(), self.cost(&z))), steps)
    }

    fn theta_of(&self, z: &V10) -> V10 {
        z.component_mul(&self.d)
    }

    /// `J(theta(z)) - E`.
    fn slack(&self, z: &V10) -> Matrix4<f64> {
        self.basis.iter().zip(z.iter()).fold(-self.margin, |acc, (a, zk)| acc + a * *zk)
    }

    /// The squared Mahalanobis distance `f(z)`.
    fn cost(&self, z: &V10) -> f64 {
        let dz = z - self.z_ls;
        dz.dot(&(self.w * dz))
    }

    /// `None` when `z` is strictly inside (the slack has a Cholesky factor); else the
    /// start of the barrier path: the slack's negative eigenvalues raised to 1e-3 of the
    /// largest (strictly inside, so the barrier is finite).
    fn interior_start(&self, z: &V10) -> Option<V10> {
        let s = self.slack(z);
        if s.cholesky().is_some() {
            return None;
        }
        let e = s.symmetric_eigen();
        let floor = 1e-3 * e.eigenvalues.abs().max();
        let clipped =
            e.eigenvectors * Matrix4::from_diagonal(&e.eigenvalues.map(|v| v.max(floor))) * e.eigenvectors.transpose();
        let theta = V10::from(from_pseudo_inertia(&(clipped + self.margin)));
        Some(theta.component_div(&self.d))
    }

    /// Follows the central path from the strictly feasible `z`: minimises `f(z) - mu log
    /// det(J - E)` by Newton's method for `mu` falling x10 from `max(1, f) / 4` until `4 mu
    /// < GAP`. The barrier minimiser's cost is within `4 mu` of the constrained minimum
    /// (the log-det barrier of the 4 x 4 cone has degree 4: Boyd & Vandenberghe 2004,
    /// sec. 11.6), so the end is within `GAP` of it. Returns `(z, Newton steps)`.
    fn central_path(&self, mut z: V10) -> (V10, usize) {
        let mut mu = self.cost(&z).max(1.0) / 4.0;
        let mut steps = 0;
        while 4.0 * mu >= GAP {
            mu /= 10.0;
            let (n, centred) = self.centre(&mut z, mu);
            steps += n;
            // rounding stopped Newton's method: `z` is still feasible and no worse; stop here
            if !centred {
                break;
            }
        }
        (z, steps)
    }

    /// Newton's method with backtracking on `f - mu log det(J - E)` from `z` (kept strictly
    /// feasible), until the Newton decrement `lambda^2 / 2` is below `1e-3 mu`. Returns
    /// the steps taken and whether it got there (in 100 steps, with a usable Newton step).
    fn centre(&self, z: &mut V10, mu: f64) -> (usize, bool) {
        for step in 1..=100 {
            let (grad, hess) = self.derivatives(z, mu);
            let dz = -newton_solve(&hess, &grad);
            let decrement = -grad.dot(&dz);
            if decrement / 2.0 < 1e-3 * mu {
                return (step, true);
            }
            let value = |z: &V10| -> Option<f64> {
                let chol = self.slack(z).cholesky()?;
                let log_det = 2.0 * chol.l().diagonal().iter().map(|v| v.ln()).sum::<f64>();
                Some(self.cost(z) - mu * log_det)
            };
            let f0 = value(z).unwrap_or(f64::INFINITY);
            let mut t = 1.0;
            // Armijo, inside the cone: halve until feasible and decreasing (at most 60 halvings)
            while t > 1e-18 && value(&(*z + t * dz)).is_none_or(|f| f > f0 - 0.25 * t * decrement) {
                t *= 0.5;
            }
            if t <= 1e-18 {
                return (step, false);
            }
            *z += t * dz;
        }
        (100, false)
    }

    /// Gradient and Hessian of `f - mu log det S`, `S = J - E`: `2 W (z - z_ls) - mu
    /// tr(S^-1 A_k)` and `2 W + mu tr(S^-1 A_a S^-1 A_b)`.
    fn derivatives(&self, z: &V10, mu: f64) -> (V10, M10) {
        // by the Cholesky factor: nalgebra's 4 x 4 `try_inverse` is the cofactor formula, which
        // loses every digit on a slack with eigenvalues 1e-3 and 1e-10 (a point mass's)
        let s_inv = self.slack(z).cholesky().map_or_else(Matrix4::zeros, |ch| ch.inverse());
        let ka: Vec<Matrix4<f64>> = self.basis.iter().map(|a| s_inv * a).collect();
        let grad = 2.0 * self.w * (z - self.z_ls) - mu * V10::from_fn(|k, _| ka[k].trace());
        let hess = 2.0 * self.w + mu * M10::from_fn(|a, b| (ka[a] * ka[b]).trace());
        (grad, hess)
    }
}

/// `H^-1 g` for the positive definite Newton matrix `H` by its Cholesky factor; should
/// rounding make `H` indefinite (its condition grows as `1 / mu` near a point mass), by its
/// eigen-decomposition with the eigenvalues below `1e-15` of the largest dropped.
fn newton_solve(hess: &M10, grad: &V10) -> V10 {
    if let Some(ch) = hess.cholesky() {
        return ch.solve(grad);
    }
    let e = hess.symmetric_eigen();
    let top = e.eigenvalues.max();
    let inv = e.eigenvalues.map(|v| if v > 1e-15 * top { 1.0 / v } else { 0.0 });
    e.eigenvectors * M10::from_diagonal(&inv) * e.eigenvectors.transpose() * grad
}

#[cfg(test)]
mod tests {
    use super::*;
    use ivdyn_core::rng::Rng;
    use nalgebra::{Matrix3, Vector3};

    /// A rigid body: `m` kg at `c`, principal moments `moments` about its COM, axes rotated by `rpy`.
    fn body(m: f64, c: [f64; 3], moments: [f64; 3], rpy: [f64; 3]) -> [f64; 10] {
        let li = ivdyn_core::LinkInertia::from_mass_com_inertia(
            m,
            &Vector3::from(c),
            &ivdyn_core::spatial::rpy_to_rot(rpy),
            &Matrix3::from_diagonal(&Vector3::from(moments)),
        );
        li.0
    }

    /// A random covariance with std from 1e-4 (mass) to 1e-3 (inertias) and correlations.
    fn covariance(rng: &mut Rng) -> M10 {
        let b = M10::from_fn(|_, _| rng.normal());
        let corr = b * b.transpose() / 10.0 + M10::identity();
        let s = V10::from_fn(|k, _| {
            if k == 0 {
                1e-4
            } else if k < 4 {
                3e-4
            } else {
                1e-3
            }
        });
        M10::from_diagonal(&s) * corr * M10::from_diagonal(&s)
    }

    /// `theta + cov^(1/2) z`, `z` standard normal.
    fn noisy(theta: &[f64; 10], cov: &M10, rng: &mut Rng) -> [f64; 10] {
        let l = cov.cholesky().unwrap().l();
        (V10::from(*theta) + l * V10::from_fn(|_, _| rng.normal())).into()
    }

    fn mahalanobis2(a: &[f64; 10], b: &[f64; 10], cov: &M10) -> f64 {
        let d = V10::from(*a) - V10::from(*b);
        (d.transpose() * cov.try_inverse().unwrap() * d)[0]
    }

    /// The KKT conditions of the convex problem in `J` (module docs), as a certificate that
    /// `proj` is the global minimum: with `g = 2 Sigma^-1 (theta* - theta_ls)` and `G` the
    /// gradient in `J` (`<G, dJ> = g . theta(dJ)`), `G` is positive semi-definite and
    /// orthogonal to `J* - E` (`<G, J* - E>` bounds the cost above its minimum). Returns
    /// `(min eig G / |G|, <G, J* - E>)`.
    fn kkt(theta_ls: &[f64; 10], cov: &M10, proj: &Projection) -> (f64, f64) {
        let pr = Problem::new(theta_ls, cov, MARGIN);
        let g = 2.0 * cov.try_inverse().unwrap() * (V10::from(proj.params) - V10::from(*theta_ls));
        let grad = Matrix4::from_fn(|i, j| {
            let mut e = Matrix4::zeros();
            e[(i, j)] = 1.0;
            g.dot(&V10::from(from_pseudo_inertia(&e)))
        });
        let jstar = pseudo_inertia(&proj.params) - pr.margin;
        let scale = grad.norm().max(1e-300);
        (grad.symmetric_eigenvalues().min() / scale, grad.dot(&jstar))
    }

    #[test]
    fn a_possible_estimate_is_kept() {
        let mut rng = Rng::new(3);
        let cov = covariance(&mut rng);
        let theta = body(2.0, [0.01, -0.02, 0.05], [4e-3, 5e-3, 3e-3], [0.2, -0.1, 0.3]);
        let pr = project(&theta, &cov);
        assert!(pr.distance2 < 1e-12, "{}", pr.distance2);
        for k in 0..10 {
            assert!((pr.params[k] - theta[k]).abs() < 1e-12, "{k}: {} vs {}", pr.params[k], theta[k]);
        }
        assert!(violation(&theta).possible);
    }

    /// Point masses and rods (on the boundary) plus noise: the LS estimate is mostly not a
    /// body; the projection always is, is the global minimum (KKT), is no farther from the LS
    /// estimate than the truth (which is possible), and, being a projection onto a convex set
    /// that holds the truth, no farther from the truth than the LS estimate.
    #[test]
    fn boundary_bodies_plus_noise_project_to_the_global_minimum() {
        let mut rng = Rng::new(11);
        let (mut violated, mut steps) = (0, 0);
        let trials = 40;
        for t in 0..trials {
            let cov = covariance(&mut rng);
            let truth = match t % 4 {
                0 => body(2.0, [0.01, -0.02, 0.05], [0.0; 3], [0.0; 3]),
                1 => body(1.0, [0.0, 0.03, 0.1], [0.0075, 0.0075, 0.0], [0.3, 0.2, -0.5]),
                2 => body(0.5, [0.02, 0.0, 0.02], [1e-3, 2e-3, 3e-3], [0.0; 3]),
                _ => [0.0; 10],
            };
            let ls = noisy(&truth, &cov, &mut rng);
            let pr = project(&ls, &cov);
            if !violation(&ls).possible {
                violated += 1;
            }
            let v = violation(&pr.params);
            assert!(v.possible && v.min_eig_pseudo_inertia > 0.0 && v.triangle_margin.unwrap() > 0.0, "{t}: {v:?}");
            if pr.params == ls {
                // possible already: kept as it is (the gradient is zero, no KKT to check)
                assert_eq!(pr.params, ls);
            } else {
                let (min_eig, compl) = kkt(&ls, &cov, &pr);
                // complementarity: the central path stops at 4 mu < GAP
                assert!(min_eig > -1e-9 && compl.abs() < 2.0 * GAP, "{t}: KKT min eig {min_eig:e}, compl {compl:e}");
            }
            // the zero body is outside the set by the margin E: compare with the body E instead
            let truth =
                if truth[0] == 0.0 { from_pseudo_inertia(&Problem::new(&ls, &cov, MARGIN).margin) } else { truth };
            let (d_truth, d_ls_truth) = (mahalanobis2(&truth, &ls, &cov), mahalanobis2(&pr.params, &truth, &cov));
            assert!(pr.distance2 <= d_truth + GAP, "{t}: {} > {d_truth}", pr.distance2);
            assert!(d_ls_truth <= d_truth + 2.0 * GAP.sqrt(), "{t}: {d_ls_truth} > {d_truth}");
            steps = steps.max(pr.iterations);
        }
        eprintln!("LS estimate not a body in {violated} of {trials} trials; at most {steps} Newton steps");
        // all four are within a few std of the boundary (the third's principal moments are
        // 1-3e-3 kg m^2, its inertia std 1e-3): the LS estimate is mostly not a body
        assert!(violated >= trials / 2, "{violated} of {trials}");
    }
}

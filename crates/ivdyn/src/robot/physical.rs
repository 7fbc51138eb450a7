//! Physical consistency of full parameter vectors, per link and per joint, in words.
//!
//! A link's 10 standard parameters `[m, h (= m c), I_o]` (inertia about the link origin)
//! describe a real body when (Wensing, Kim, Slotine 2017):
//!
//! * the mass is positive;
//! * the inertia about the centre of mass `I_c = I_o + m [c]x [c]x` is positive definite;
//! * its principal moments satisfy the triangle inequalities `I1 + I2 >= I3` (and
//!   permutations), i.e. the second moments of the mass distribution are non-negative;
//! * the 4x4 pseudo-inertia `J = [[Sigma, h], [h^T, m]]`, `Sigma = tr(I_o)/2 1 - I_o`, is
//!   positive definite (this single condition implies the three above; the others are
//!   reported because they say *what* is wrong).
//!
//! Drive parameters: Coulomb and viscous friction and armature must be `>= 0` (the
//! torque offset `tau0` has no sign).

use nalgebra::{Matrix3, Matrix4, Vector3};
use serde::Serialize;

use ivdyn_core::params::{FC, FV, IA, LINK_PARAMS, drive_col, link_col};

/// The violations found on one link or joint.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Violations {
    /// Link or joint name.
    pub name: String,
    /// What is wrong, one sentence each.
    pub problems: Vec<String>,
}

/// The check of a full parameter vector.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct PhysicalCheck {
    /// True when nothing is violated.
    pub consistent: bool,
    /// Links with violations (links without any are not listed).
    pub links: Vec<Violations>,
    /// Joints whose drive parameters are violated.
    pub joints: Vec<Violations>,
}

impl PhysicalCheck {
    /// All problems as `"<name>: <problem>"` lines.
    pub fn lines(&self) -> Vec<String> {
        self.links
            .iter()
            .chain(&self.joints)
            .flat_map(|v| v.problems.iter().map(move |p| format!("{}: {p}", v.name)))
            .collect()
    }
}

/// The 4x4 pseudo-inertia of `[m, mcx, mcy, mcz, Ixx, Ixy, Iyy, Ixz, Iyz, Izz]`.
pub fn pseudo_inertia(p: &[f64]) -> Matrix4<f64> {
    let io = inertia_origin(p);
    let sigma = Matrix3::identity() * (0.5 * io.trace()) - io;
    let mut j = Matrix4::zeros();
    j.fixed_view_mut::<3, 3>(0, 0).copy_from(&sigma);
    for a in 0..3 {
        j[(a, 3)] = p[1 + a];
        j[(3, a)] = p[1 + a];
    }
    j[(3, 3)] = p[0];
    j
}

/// The 10 parameters of a pseudo-inertia `J` (inverse of [`pseudo_inertia`]).
pub fn from_pseudo_inertia(j: &Matrix4<f64>) -> [f64; LINK_PARAMS] {
    let sigma = j.fixed_view::<3, 3>(0, 0).into_owned();
    let io = Matrix3::identity() * sigma.trace() - sigma;
    let s = |a: usize, b: usize| 0.5 * (io[(a, b)] + io[(b, a)]);
    let h = |a: usize| 0.5 * (j[(a, 3)] + j[(3, a)]);
    [j[(3, 3)], h(0), h(1), h(2), s(0, 0), s(0, 1), s(1, 1), s(0, 2), s(1, 2), s(2, 2)]
}

fn inertia_origin(p: &[f64]) -> Matrix3<f64> {
    Matrix3::new(p[4], p[5], p[7], p[5], p[6], p[8], p[7], p[8], p[9])
}

fn fmt3(v: &[f64]) -> String {
    v.iter().map(|x| format!("{x:.4e}")).collect::<Vec<_>>().join(", ")
}

/// Problems of one link's 10 parameters (empty when physically consistent).
pub fn check_link(p: &[f64]) -> Vec<String> {
    link_problems(p, 0.0)
}

/// Problems no body has, in one link's 10 parameters: a negative mass or principal
/// moment, or broken triangle inequalities, beyond rounding. A point mass or a massless
/// link (the limits of a rigid body, which URDFs hold) passes; [`check_link`] asks more.
pub fn check_link_limits(p: &[f64]) -> Vec<String> {
    if p.iter().take(LINK_PARAMS).all(|v| *v == 0.0) {
        return vec![];
    }
    // rounding of the inertia's eigenvalues: relative to the largest parameter
    let scale = p.iter().take(LINK_PARAMS).fold(0.0f64, |a, v| a.max(v.abs()));
    link_problems(p, -1e-9 * scale)
}

/// `check_link`'s tests with each "positive" read as "above `floor`" (0: strict).
fn link_problems(p: &[f64], floor: f64) -> Vec<String> {
    let mut out = vec![];
    if p.iter().take(LINK_PARAMS).any(|v| !v.is_finite()) {
        return vec!["parameters are not finite".into()];
    }
    let m = p[0];
    if !(m > 0.0) {
        out.push(format!("mass {m:.6e} kg is not positive"));
    } else {
        let c = Vector3::new(p[1], p[2], p[3]) / m;
        let cx = c.cross_matrix();
        let ic = inertia_origin(p) + m * cx * cx;
        let mut eig: Vec<f64> = ic.symmetric_eigenvalues().iter().copied().collect();
        eig.sort_by(|a, b| a.total_cmp(b));
        if !(eig[0] > floor) {
            out.push(format!(
                "inertia about the centre of mass is not positive definite (principal moments {})",
                fmt3(&eig)
            ));
        }
        if eig[0] + eig[1] - eig[2] < floor {
            out.push(format!(
                "principal moments {} violate the triangle inequality {:.4e} + {:.4e} >= {:.4e}",
                fmt3(&eig),
                eig[0],
                eig[1],
                eig[2]
            ));
        }
    }
    if floor == 0.0 {
        let jmin = pseudo_inertia(p).symmetric_eigenvalues().min();
        if !(jmin > 0.0) {
            out.push(format!("pseudo-inertia is not positive definite (smallest eigenvalue {jmin:.4e})"));
        }
    }
    out
}

/// Checks a full parameter vector `theta` (`14 n`, the layout of `ivdyn_core::params`);
/// `links` and `joints` name the `n` links and joints.
pub fn check_params(theta: &[f64], links: &[String], joints: &[String]) -> PhysicalCheck {
    let n = joints.len();
    let mut rep = PhysicalCheck { consistent: true, links: vec![], joints: vec![] };
    for (i, name) in links.iter().enumerate().take(n) {
        let p = &theta[link_col(i, 0)..link_col(i, LINK_PARAMS)];
        let problems = check_link(p);
        if !problems.is_empty() {
            rep.links.push(Violations { name: name.clone(), problems });
        }
    }
    for (j, name) in joints.iter().enumerate() {
        let mut problems = vec![];
        for (k, what, unit) in [
            (FC, "Coulomb friction fc", "N m"),
            (FV, "viscous friction fv", "N m s/rad"),
            (IA, "armature ia", "kg m^2"),
        ] {
            let v = theta[drive_col(n, j, k)];
            if !(v >= 0.0) {
                problems.push(format!("{what} {v:.6e} {unit} is negative"));
            }
        }
        if !problems.is_empty() {
            rep.joints.push(Violations { name: name.clone(), problems });
        }
    }
    rep.consistent = rep.links.is_empty() && rep.joints.is_empty();
    rep
}

/// [`check_params`] with the robot's link and joint names.
pub fn check_robot_params(robot: &super::Robot, theta: &[f64]) -> PhysicalCheck {
    check_params(theta, &robot.link_names, &robot.joint_names)
}

/// `Ok` when the parameters `theta` of `robot` are physically consistent, else the error
/// refusing to write them as `what` (a URDF, an MJCF), every link and joint named with its
/// problems: a simulator would reject or mis-simulate them (issue: physically invalid
/// inertials are never written).
pub fn refuse_inconsistent(robot: &super::Robot, theta: &[f64], what: &str) -> crate::error::Result<()> {
    let check = check_robot_params(robot, theta);
    if check.consistent {
        return Ok(());
    }
    let named = |kind: &'static str| move |v: &Violations| format!("{kind} '{}': {}", v.name, v.problems.join("; "));
    let lines: Vec<String> =
        check.links.iter().map(named("link")).chain(check.joints.iter().map(named("joint"))).collect();
    Err(refused(what, &lines))
}

/// The error refusing to write `what` for the problems `lines`.
pub fn refused(what: &str, lines: &[String]) -> crate::error::Error {
    crate::error::Error::PhysicallyInconsistent {
        what: format!("{what} export"),
        problems: format!(
            "not physically possible (a simulator would reject or mis-simulate it): {}. Identify with --consistent (consistent=True) for physically consistent parameters",
            lines.join("; ")
        ),
    }
}

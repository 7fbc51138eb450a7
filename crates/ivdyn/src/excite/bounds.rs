//! The joint limits, and the map of the free variables into them: each joint's harmonics
//! projected onto the rest constraints `qd(0) = qdd(0) = 0`, then scaled by the largest
//! factor that keeps the joint inside its (margin-shrunk) limits on a grid.

use serde::Serialize;

use super::fourier::{Basis, dot};
use super::{DEFAULT_VEL_LIMIT, ExciteOptions};
use crate::Robot;
use crate::error::{Error, Result};

/// The limits one joint is held to (before the margin).
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct JointBounds {
    /// Lower position limit (`null`/infinite: none).
    pub lower: f64,
    /// Upper position limit.
    pub upper: f64,
    /// Velocity limit.
    pub velocity: f64,
    /// Acceleration limit.
    pub acceleration: f64,
}

/// One value for every joint, or one per joint.
fn per_joint(what: &str, v: &[f64], n: usize) -> Result<Vec<f64>> {
    match v.len() {
        1 => Ok(vec![v[0]; n]),
        l if l == n => Ok(v.to_vec()),
        l => Err(Error::Dimension { what: format!("{what} (one value, or one per joint)"), expected: n, got: l }),
    }
}

/// The limits of `robot` with the options' overrides (before the margin).
pub fn joint_bounds(robot: &Robot, opts: &ExciteOptions) -> Result<Vec<JointBounds>> {
    let n = robot.dof();
    let lim = crate::with_model!(&robot.model, m => m.limits.to_vec());
    let acc = per_joint("acceleration limit", &opts.acc_limit, n)?;
    let vel = match &opts.vel_limit {
        Some(v) => per_joint("velocity limit", v, n)?,
        None => lim
            .iter()
            .map(|l| if l.velocity.is_finite() && l.velocity > 0.0 { l.velocity } else { DEFAULT_VEL_LIMIT })
            .collect(),
    };
    (0..n)
        .map(|i| {
            let ok = |v: f64| v > 0.0 && v.is_finite(); // false for NaN too
            if !ok(acc[i]) || !ok(vel[i]) {
                return Err(Error::JointLimits {
                    joint: robot.joint_names[i].clone(),
                    msg: format!(
                        "velocity and acceleration limits must be positive and finite for the excitation (got {} and {})",
                        vel[i], acc[i]
                    ),
                });
            }
            Ok(JointBounds { lower: lim[i].lower, upper: lim[i].upper, velocity: vel[i], acceleration: acc[i] })
        })
        .collect()
}

/// The limits shrunk by the safety margin (position ranges by `margin` of their width,
/// velocity and acceleration by `1 - margin`); an error when a position range is empty.
pub(super) fn margin_boxes(robot: &Robot, bounds: &[JointBounds], margin: f64) -> Result<Vec<Box1>> {
    let boxes: Vec<Box1> = bounds
        .iter()
        .map(|b| {
            let d = if b.lower.is_finite() && b.upper.is_finite() { margin * 0.5 * (b.upper - b.lower) } else { 0.0 };
            Box1 {
                lower: b.lower + d,
                upper: b.upper - d,
                vel: b.velocity * (1.0 - margin),
                acc: b.acceleration * (1.0 - margin),
            }
        })
        .collect();
    for (i, b) in boxes.iter().enumerate() {
        if b.finite_pos() && !(b.upper > b.lower) {
            return Err(Error::JointLimits {
                joint: robot.joint_names[i].clone(),
                msg: format!("empty position range after the safety margin {margin}"),
            });
        }
    }
    Ok(boxes)
}

/// Per-joint limits after the margin, as used by the scaling.
#[derive(Debug, Clone, Copy)]
pub(super) struct Box1 {
    /// Lower position limit.
    pub(super) lower: f64,
    /// Upper position limit.
    pub(super) upper: f64,
    /// Velocity limit.
    pub(super) vel: f64,
    /// Acceleration limit.
    pub(super) acc: f64,
}

impl Box1 {
    /// Whether both position limits are finite.
    pub(super) fn finite_pos(&self) -> bool {
        self.lower.is_finite() && self.upper.is_finite()
    }
    /// The offset `q0 = mid + half tanh(z)` (strictly inside a finite range; `z` itself
    /// otherwise) and `dq0/dz`.
    pub(super) fn offset(&self, z: f64) -> (f64, f64) {
        if self.finite_pos() {
            let (mid, half) = (0.5 * (self.lower + self.upper), 0.5 * (self.upper - self.lower));
            let th = z.tanh();
            (mid + half * th, half * (1.0 - th * th))
        } else {
            (z, 1.0)
        }
    }
}

/// Which bound limits a joint's scale, at which grid sample, with which sign.
#[derive(Debug, Clone, Copy)]
pub(super) enum Active {
    /// The velocity limit at a sample, with the sign of `qd` there.
    Vel(usize, f64),
    /// The acceleration limit at a sample, with the sign of `qdd` there.
    Acc(usize, f64),
    /// The upper position limit at a sample.
    Upper(usize),
    /// The lower position limit at a sample.
    Lower(usize),
}

/// `qd(0) = 0` and `qdd(0) = 0`: orthogonal projection of `c = [a; b]` onto
/// `sum a_l = 0`, `sum l b_l = 0` (symmetric, so it is its own adjoint in the gradient).
pub(super) fn project_rest(c: &mut [f64], h: usize) {
    let sa: f64 = c[..h].iter().sum::<f64>() / h as f64;
    c[..h].iter_mut().for_each(|v| *v -= sa);
    let w: Vec<f64> = (1..=h).map(|l| l as f64).collect();
    let ww: f64 = w.iter().map(|x| x * x).sum();
    let sb = dot(&c[h..], &w) / ww;
    c[h..].iter_mut().zip(&w).for_each(|(v, wl)| *v -= sb * wl);
}

/// Largest scale keeping `q0 + s pc` inside the box on `grid`; the active bound.
pub(super) fn scale_into(pc: &[f64], q0: f64, bx: &Box1, grid: &Basis) -> (f64, Active) {
    let (mut best, mut act) = (f64::INFINITY, Active::Vel(0, 1.0));
    let (mut pmax, mut kmax, mut pmin, mut kmin) = (f64::NEG_INFINITY, 0, f64::INFINITY, 0);
    let (mut vmax, mut kv, mut amax, mut ka) = (0.0f64, 0, 0.0f64, 0);
    for k in 0..grid.len() {
        let p = dot(grid.row(&grid.q, k), pc);
        if p > pmax {
            (pmax, kmax) = (p, k);
        }
        if p < pmin {
            (pmin, kmin) = (p, k);
        }
        let v = dot(grid.row(&grid.qd, k), pc).abs();
        if v > vmax {
            (vmax, kv) = (v, k);
        }
        let a = dot(grid.row(&grid.qdd, k), pc).abs();
        if a > amax {
            (amax, ka) = (a, k);
        }
    }
    let sgn = |x: f64| if x < 0.0 { -1.0 } else { 1.0 };
    if bx.vel.is_finite() && vmax > 0.0 && bx.vel / vmax < best {
        best = bx.vel / vmax;
        act = Active::Vel(kv, sgn(dot(grid.row(&grid.qd, kv), pc)));
    }
    if bx.acc.is_finite() && amax > 0.0 && bx.acc / amax < best {
        best = bx.acc / amax;
        act = Active::Acc(ka, sgn(dot(grid.row(&grid.qdd, ka), pc)));
    }
    if bx.finite_pos() {
        if pmax > 0.0 && (bx.upper - q0) / pmax < best {
            best = (bx.upper - q0) / pmax;
            act = Active::Upper(kmax);
        }
        if pmin < 0.0 && (q0 - bx.lower) / -pmin < best {
            best = (q0 - bx.lower) / -pmin;
            act = Active::Lower(kmin);
        }
    }
    (best, act)
}

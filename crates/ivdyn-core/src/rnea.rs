//! Recursive Newton-Euler inverse dynamics, paper eqs (2)-(8).

use crate::data::Data;
use crate::kinematics::{forward_pass, joint_transforms};
use crate::model::{JointKind, Model};
use crate::{Vec3, VecN};

/// Inverse dynamics `tau = M(q) qdd + C(q, qd) qd + g(q) + tau_drive(qd, qdd)`, with the
/// drive terms `fc sign(qd) + fv qd + ia qdd + tau0` of each joint. Returns
/// `&data.tau`.
pub fn rnea<'d, const N: usize>(
    model: &Model<N>,
    data: &'d mut Data<N>,
    q: &VecN<N>,
    qd: &VecN<N>,
    qdd: &VecN<N>,
) -> &'d VecN<N> {
    joint_transforms(model, &mut data.kin, q);
    forward_pass(model, &mut data.kin, qd, qdd);
    backward_pass(model, data);
    for i in 0..N {
        data.tau[i] += model.drive[i].torque(qd[i], qdd[i]);
    }
    &data.tau
}

/// Rigid-body inverse dynamics without the drive terms.
pub fn rnea_rigid<'d, const N: usize>(
    model: &Model<N>,
    data: &'d mut Data<N>,
    q: &VecN<N>,
    qd: &VecN<N>,
    qdd: &VecN<N>,
) -> &'d VecN<N> {
    joint_transforms(model, &mut data.kin, q);
    forward_pass(model, &mut data.kin, qd, qdd);
    backward_pass(model, data);
    &data.tau
}

/// Gravity torques `g(q)` (no drive terms, not even the offset).
pub fn gravity<'d, const N: usize>(
    model: &Model<N>,
    data: &'d mut Data<N>,
    q: &VecN<N>,
) -> &'d VecN<N> {
    let z = VecN::<N>::zeros();
    rnea_rigid(model, data, q, &z, &z)
}

/// Backward recursion, paper eqs (6)-(8): link forces from the kinematics in `data`.
#[inline]
pub(crate) fn backward_pass<const N: usize>(model: &Model<N>, data: &mut Data<N>) {
    let mut f_c = Vec3::zeros(); // force of the child on this link, in this link's coords
    let mut n_c = Vec3::zeros(); // moment of the child about this link's origin
    for i in (0..N).rev() {
        let p = &model.inertia[i];
        let (w, wd, acc) = (&data.kin.w[i], &data.kin.wd[i], &data.kin.acc[i]);
        let m = p.mass();
        let h = p.first_moment();
        let i_o = p.inertia_origin();
        // f_i = m acc + wd x h + w x (w x h) + R_{i+1} f_{i+1}                    (eq 6)
        let f = m * acc + wd.cross(&h) + w.cross(&w.cross(&h)) + f_c;
        // n_i = I_o wd + w x (I_o w) + h x acc + R_{i+1} n_{i+1} + p_{i+1} x (R_{i+1} f_{i+1}) (eq 7)
        let n = i_o * wd + w.cross(&(i_o * w)) + h.cross(acc) + n_c;
        data.f[i] = f;
        data.n[i] = n;
        let a = &model.joints[i].axis;
        // tau_i = axis . n_i (revolute) or axis . f_i (prismatic)                  (eq 8)
        data.tau[i] = match model.joints[i].kind {
            JointKind::Revolute => a.dot(&n),
            JointKind::Prismatic => a.dot(&f),
        };
        // express this link's force and moment in the parent's frame
        let r = &data.kin.rot[i];
        f_c = r * f;
        n_c = r * n + data.kin.pos[i].cross(&f_c);
    }
}

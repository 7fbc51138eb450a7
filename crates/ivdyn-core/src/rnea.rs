//! Recursive Newton-Euler inverse dynamics, paper eqs (2)-(8).

use crate::data::Data;
use crate::kinematics::{Kinematics, forward_pass, joint_transforms, splat3};
use crate::model::{JointKind, Model};
use crate::types::{Lanes, VecN};
use nalgebra::{SVector, Vector3};

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
pub fn gravity<'d, const N: usize>(model: &Model<N>, data: &'d mut Data<N>, q: &VecN<N>) -> &'d VecN<N> {
    let z = VecN::<N>::zeros();
    rnea_rigid(model, data, q, &z, &z)
}

/// Backward recursion, paper eqs (6)-(8): link forces from the kinematics in `data`.
#[inline]
pub(crate) fn backward_pass<const N: usize>(model: &Model<N>, data: &mut Data<N>) {
    backward_pass_in(model, &data.kin, &mut data.f, &mut data.n, &mut data.tau);
}

/// [`backward_pass`] for one sample or a pack of samples ([`Lanes`]): from the link
/// kinematics `kin` to the link forces `f`, moments `n` and the rigid-body joint torques
/// `tau` (no drive terms). Written once for both.
#[inline(always)]
pub fn backward_pass_in<T: Lanes, const N: usize>(
    model: &Model<N>,
    kin: &Kinematics<T, N>,
    f_out: &mut [Vector3<T>; N],
    n_out: &mut [Vector3<T>; N],
    tau: &mut SVector<T, N>,
) {
    let mut f_c = Vector3::<T>::zeros(); // force of the child on this link, in this link's coords
    let mut n_c = Vector3::<T>::zeros(); // moment of the child about this link's origin
    for i in (0..N).rev() {
        let p = &model.inertia[i];
        let (w, wd, acc) = (&kin.w[i], &kin.wd[i], &kin.acc[i]);
        let m = T::splat(p.mass());
        let h = splat3::<T>(&p.first_moment());
        let i_o = p.inertia_origin().map(T::splat);
        // f_i = m acc + wd x h + w x (w x h) + R_{i+1} f_{i+1}                    (eq 6)
        let f = acc * m + wd.cross(&h) + w.cross(&w.cross(&h)) + f_c;
        // n_i = I_o wd + w x (I_o w) + h x acc + R_{i+1} n_{i+1} + p_{i+1} x (R_{i+1} f_{i+1}) (eq 7)
        let n = i_o * wd + w.cross(&(i_o * w)) + h.cross(acc) + n_c;
        f_out[i] = f;
        n_out[i] = n;
        let a = splat3::<T>(&model.joints[i].axis);
        // tau_i = axis . n_i (revolute) or axis . f_i (prismatic)                  (eq 8)
        tau[i] = match model.joints[i].kind {
            JointKind::Revolute => a.dot(&n),
            JointKind::Prismatic => a.dot(&f),
        };
        // express this link's force and moment in the parent's frame; not for link 0,
        // whose parent is the base (a rotation and a cross product nobody reads)
        if i == 0 {
            break;
        }
        let r = &kin.rot[i];
        f_c = r * f;
        n_c = r * n + kin.pos[i].cross(&f_c);
    }
}

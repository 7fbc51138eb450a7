//! Kinetic and potential energy, for energy-balance checks and simulation monitoring.

use crate::data::Data;
use crate::kinematics::{forward_kinematics, joint_transforms};
use crate::model::{JointKind, Model};
use crate::types::{Vec3, VecN};

/// Kinetic energy `1/2 qd^T M(q) qd` computed from link velocities, including the
/// armature's `1/2 ia qd^2`.
pub fn kinetic_energy<const N: usize>(model: &Model<N>, data: &mut Data<N>, q: &VecN<N>, qd: &VecN<N>) -> f64 {
    joint_transforms(model, &mut data.kin, q);
    let mut w = Vec3::zeros();
    let mut v = Vec3::zeros();
    let mut ke = 0.0;
    for i in 0..N {
        let r = &data.kin.rot[i];
        let a = model.joints[i].axis;
        // velocity of the new origin: v + w x p, then rotate into link i
        v = r.tr_mul(&(v + w.cross(&data.kin.pos[i])));
        w = r.tr_mul(&w);
        match model.joints[i].kind {
            JointKind::Revolute => w += a * qd[i],
            JointKind::Prismatic => v += a * qd[i],
        }
        data.kin.w[i] = w;
        data.v[i] = v;
        let p = &model.inertia[i];
        // T = 1/2 (m v.v + 2 v.(w x h) + w.I_o w)
        ke +=
            0.5 * (p.mass() * v.dot(&v) + 2.0 * v.dot(&w.cross(&p.first_moment())) + w.dot(&(p.inertia_origin() * w)));
        ke += 0.5 * model.drive[i].ia * qd[i] * qd[i];
    }
    ke
}

/// Potential energy `-sum_i m_i g . c_i` (zero at the base origin).
pub fn potential_energy<const N: usize>(model: &Model<N>, data: &mut Data<N>, q: &VecN<N>) -> f64 {
    forward_kinematics(model, data, q);
    let mut pe = 0.0;
    for i in 0..N {
        let p = &model.inertia[i];
        // m c_world = R h + m o
        let mc = data.o_rot[i] * p.first_moment() + p.mass() * data.o_pos[i];
        pe -= model.gravity.dot(&mc);
    }
    pe
}

//! Joint-space mass matrix by the composite-rigid-body algorithm [RBDA, Table 6.2].

use crate::data::Data;
use crate::kinematics::joint_transforms;
use crate::model::{JointKind, Model};
use crate::spatial::Transform;
use crate::types::{MatN, Vec3, VecN};

/// Mass matrix `M(q)` including the armature `ia` on the diagonal. Returns `&data.m`.
pub fn mass_matrix<'d, const N: usize>(model: &Model<N>, data: &'d mut Data<N>, q: &VecN<N>) -> &'d MatN<N> {
    joint_transforms(model, &mut data.kin, q);
    // composite inertia, outermost first: IC_i = I_i + X_{i+1} IC_{i+1}
    for i in (0..N).rev() {
        let mut ic = model.inertia[i];
        if i + 1 < N {
            let x = Transform::new(data.kin.rot[i + 1], data.kin.pos[i + 1]);
            ic = ic.add(&data.ic[i + 1].transformed(&x));
        }
        data.ic[i] = ic;
    }
    for i in 0..N {
        let ic = &data.ic[i];
        let a = model.joints[i].axis;
        // F = IC_i S_i as (moment about origin i, force), both in link i's coords
        let (mut n, mut f) = match model.joints[i].kind {
            JointKind::Revolute => (ic.inertia_origin() * a, a.cross(&ic.first_moment())),
            JointKind::Prismatic => (ic.first_moment().cross(&a), ic.mass() * a),
        };
        data.m[(i, i)] = proj(model, i, &n, &f) + model.drive[i].ia;
        // carry F inward and project on each inner joint
        for j in (0..i).rev() {
            let r = &data.kin.rot[j + 1];
            f = r * f;
            n = r * n + data.kin.pos[j + 1].cross(&f);
            let mij = proj(model, j, &n, &f);
            data.m[(i, j)] = mij;
            data.m[(j, i)] = mij;
        }
    }
    &data.m
}

#[inline(always)]
fn proj<const N: usize>(model: &Model<N>, j: usize, n: &Vec3, f: &Vec3) -> f64 {
    match model.joints[j].kind {
        JointKind::Revolute => model.joints[j].axis.dot(n),
        JointKind::Prismatic => model.joints[j].axis.dot(f),
    }
}

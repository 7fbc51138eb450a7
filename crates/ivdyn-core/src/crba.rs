//! Joint-space mass matrix by the composite-rigid-body algorithm [RBDA, Table 6.2].
//!
//! Written in link frames with 3-vectors, like the RNEA. Each composite inertia is
//! carried to the parent by [`LinkInertia::transformed`]: the rotation `R I R^T` of a
//! symmetric tensor (upper triangle only) plus the parallel-axis terms of the translation.
//! Each column's wrench `IC_i S_i` is carried inward one link at a time (the force and the
//! moment rotated, `p x f` added to the moment) down to link 1; row 0 is projected from
//! link 1's frame, without a last step. For a revolute joint about a coordinate axis (the
//! usual case: DH and most URDF arms) `IC_i S_i` reads a column of the composite inertia
//! instead of multiplying it by the axis; the projections on the joints stay dot products
//! with the axis (a one-entry projection was slower: `benches/README.md`, issue 19 item 3).

use crate::data::Data;
use crate::inertia::LinkInertia;
use crate::kinematics::joint_transforms;
use crate::model::{JointKind, Model};
use crate::spatial::Transform;
use crate::types::{MatN, Vec3, VecN};

/// Mass matrix `M(q)` including the armature `ia` on the diagonal. Returns `&data.m`.
pub fn mass_matrix<'d, const N: usize>(model: &Model<N>, data: &'d mut Data<N>, q: &VecN<N>) -> &'d MatN<N> {
    joint_transforms(model, &mut data.kin, q);
    mass_matrix_at_transforms(model, data)
}

/// [`mass_matrix`] from the joint placements already in `data.kin` (`rot`, `pos` at the
/// wanted `q`): forward dynamics reuses those of its RNEA call.
pub(crate) fn mass_matrix_at_transforms<'d, const N: usize>(model: &Model<N>, data: &'d mut Data<N>) -> &'d MatN<N> {
    if N == 0 {
        return &data.m;
    }
    // composite inertia, outermost first: IC_i = I_i + X_{i+1} IC_{i+1}; IC_0 is not
    // formed, M_00 is projected from its parts below
    let mut ic = model.inertia[N - 1];
    for i in (1..N).rev() {
        data.ic[i] = ic;
        let x = Transform::new(data.kin.rot[i], data.kin.pos[i]);
        ic = model.inertia[i - 1].add(&ic.transformed(&x));
    }
    // Row 0 from link 1's frame: a_0 . (R_1 n + p_1 x R_1 f) = b_n . n + b_f . f with
    // b_n = R_1^T a_0, b_f = R_1^T (a_0 x p_1) (revolute; prismatic: b_n = 0, b_f = R_1^T a_0),
    // which saves the last inward step of every column.
    let a0 = model.joints[0].axis;
    let (b_n, b_f) = if N > 1 {
        let r1 = &data.kin.rot[1];
        match model.joints[0].kind {
            JointKind::Revolute => (r1.tr_mul(&a0), r1.tr_mul(&a0.cross(&data.kin.pos[1]))),
            JointKind::Prismatic => (Vec3::zeros(), r1.tr_mul(&a0)),
        }
    } else {
        (Vec3::zeros(), Vec3::zeros())
    };
    for i in (1..N).rev() {
        // F = IC_i S_i as (moment about origin i, force), both in link i's coords
        let (mut n, mut f) = Axis::of(&model.joints[i].axis, model.joints[i].kind).wrench(&data.ic[i]);
        data.m[(i, i)] = proj(model, i, &n, &f) + model.drive[i].ia;
        // carry F inward and project on each inner joint; M is symmetric
        for j in (1..i).rev() {
            let r = &data.kin.rot[j + 1];
            f = r * f;
            n = r * n + data.kin.pos[j + 1].cross(&f);
            let mij = proj(model, j, &n, &f);
            data.m[(i, j)] = mij;
            data.m[(j, i)] = mij;
        }
        let m0 = b_n.dot(&n) + b_f.dot(&f);
        data.m[(i, 0)] = m0;
        data.m[(0, i)] = m0;
    }
    data.ic[0] = ic;
    let (n, f) = Axis::of(&a0, model.joints[0].kind).wrench(&ic);
    data.m[(0, 0)] = proj(model, 0, &n, &f) + model.drive[0].ia;
    &data.m
}

#[inline(always)]
fn proj<const N: usize>(model: &Model<N>, j: usize, n: &Vec3, f: &Vec3) -> f64 {
    match model.joints[j].kind {
        JointKind::Revolute => model.joints[j].axis.dot(n),
        JointKind::Prismatic => model.joints[j].axis.dot(f),
    }
}

/// A joint's motion as the mass matrix uses it. For a revolute joint about `±e_k`, `I_o a` is a
/// signed column of `I_o` (the same values: the zero products add nothing), 9 products
/// fewer per column; `a x h` and the projections still multiply by the whole axis.
#[derive(Clone, Copy)]
enum Axis {
    /// Revolute (`true`) or prismatic joint along `sign * e_k`.
    Coord { k: usize, sign: f64, revolute: bool },
    /// Any other unit axis.
    General { a: Vec3, revolute: bool },
}

impl Axis {
    #[inline(always)]
    fn of(a: &Vec3, kind: JointKind) -> Self {
        let revolute = kind == JointKind::Revolute;
        let zeros = [a.x == 0.0, a.y == 0.0, a.z == 0.0];
        match zeros {
            [true, true, false] => Axis::Coord { k: 2, sign: a.z, revolute },
            [true, false, true] => Axis::Coord { k: 1, sign: a.y, revolute },
            [false, true, true] => Axis::Coord { k: 0, sign: a.x, revolute },
            _ => Axis::General { a: *a, revolute },
        }
    }

    /// `IC S` of a unit motion: revolute `(I_o a, a x h)`, prismatic `(h x a, m a)`.
    #[inline(always)]
    fn wrench(&self, ic: &LinkInertia) -> (Vec3, Vec3) {
        let (a, revolute) = match *self {
            Axis::Coord { k, sign, revolute } => {
                let mut a = Vec3::zeros();
                a[k] = sign;
                if revolute {
                    // I_o a is column k of I_o, signed
                    return (ic.inertia_origin().column(k) * sign, a.cross(&ic.first_moment()));
                }
                (a, revolute)
            }
            Axis::General { a, revolute } => (a, revolute),
        };
        if revolute {
            (ic.inertia_origin() * a, a.cross(&ic.first_moment()))
        } else {
            (ic.first_moment().cross(&a), ic.mass() * a)
        }
    }
}

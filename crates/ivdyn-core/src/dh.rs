//! Standard (distal) Denavit-Hartenberg tables, as in the paper's Table 1.
//!
//! `T_{i-1,i} = Rz(q_i + offset_i) Tz(d_i) Tx(a_i) Rx(alpha_i)`: joint `i` turns about
//! `z_{i-1}`. In this crate's convention link `i`'s frame is the *joint* frame
//! `i' = frame_{i-1} Rz(offset_i + q_i)` (origin on joint `i`'s axis, z along it), so
//! `x_tree[i] = X_{i-1} Rz(offset_i)` with `X_i = Tz(d_i) Tx(a_i) Rx(alpha_i)`, and DH frame
//! `i` is `i' X_i`. Inertial parameters given in DH frame `i` (as the paper's Table 2)
//! are moved into frame `i'` by [`inertia_from_dh_frame`].

use crate::inertia::LinkInertia;
use crate::model::{Joint, Model};
use crate::params::DriveParams;
use crate::spatial::{Transform, rot_x, rot_z};
use crate::types::{Mat3, Vec3};

/// One row of a standard DH table (SI units, radians).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DhRow {
    /// Link length along `x_i` (m).
    pub a: f64,
    /// Offset along `z_{i-1}` (m).
    pub d: f64,
    /// Twist about `x_i` (rad).
    pub alpha: f64,
    /// Joint angle offset: `theta_i = q_i + offset` (rad).
    pub offset: f64,
}

impl DhRow {
    /// `X_i = Tz(d) Tx(a) Rx(alpha)`: DH frame `i` in joint frame `i'`.
    pub fn placement(&self) -> Transform {
        Transform::new(rot_x(self.alpha), Vec3::new(self.a, 0.0, self.d))
    }
}

/// Revolute chain from a standard DH table; link parameters zero, tool frame = DH frame `N`.
pub fn model_from_dh<const N: usize>(rows: &[DhRow; N]) -> Model<N> {
    let joints = [Joint::revolute_z(); N];
    let mut x_tree = [Transform::IDENTITY; N];
    for i in 0..N {
        let off = Transform::new(rot_z(rows[i].offset), Vec3::zeros());
        x_tree[i] = if i == 0 { off } else { rows[i - 1].placement().compose(&off) };
    }
    // Unit z axes cannot fail the axis check.
    let mut model = Model::new(joints, x_tree).unwrap_or_else(|_| unreachable!());
    if N > 0 {
        model.tool = rows[N - 1].placement();
    }
    model
}

/// Moves link parameters given in DH frame `i` into the joint frame `i'` used by the model.
pub fn inertia_from_dh_frame(row: &DhRow, p: &LinkInertia) -> LinkInertia {
    p.transformed(&row.placement())
}

/// Moves link parameters from the joint frame `i'` into DH frame `i`.
pub fn inertia_to_dh_frame(row: &DhRow, p: &LinkInertia) -> LinkInertia {
    p.transformed(&row.placement().inverse())
}

/// The paper's per-link grouping `x^i = (alpha_i, beta_i, F_i, d_i)` (eqs 9-12), 11 numbers.
///
/// The OCR of eqs (9)-(10) is garbled; derived here from first principles: the torques
/// of a revolute chain depend on link `i` only through its first moment and inertia about
/// origin `i-1` (on joint `i`'s axis), with the mass `M_i = sum_{j>i} m_j` of the outer
/// links lumped at origin `i` (they act on link `i` through that point):
/// - `alpha_i = m_i (r_i + s_i) + M_i r_i`
/// - `Ibar_i = I_i + m_i ((r_i+s_i)^T (r_i+s_i) 1 - (r_i+s_i)(r_i+s_i)^T) + M_i (r_i^T r_i 1 - r_i r_i^T)`
/// - `beta_i = (Ibar_11, Ibar_22, Ibar_33, Ibar_12, Ibar_13, Ibar_23)`
///
/// in DH frame `i` coordinates, with `r_i` the origin of frame `i` seen from frame `i-1`
/// and `s_i` the centre of mass from origin `i`. Returns `[alpha (3), beta (6), F, d]`.
pub fn to_paper_grouping<const N: usize>(
    rows: &[DhRow; N],
    inertia: &[LinkInertia; N],
    drive: &[DriveParams; N],
) -> [[f64; 11]; N] {
    let mut out = [[0.0; 11]; N];
    let mut m_out = 0.0;
    for i in (0..N).rev() {
        let x = rows[i].placement();
        let r = x.trans; // origin i from origin i-1, joint-frame coords
        // about origin i-1 = the joint-frame origin: h, I_o as stored; add the lumped mass
        let alpha_j = inertia[i].first_moment() + m_out * r;
        let ibar_j = inertia[i].inertia_origin() + m_out * (r.dot(&r) * Mat3::identity() - r * r.transpose());
        // rotate into DH frame i coordinates
        let alpha = x.rot.tr_mul(&alpha_j);
        let ib = x.rot.transpose() * ibar_j * x.rot;
        out[i] = [
            alpha.x,
            alpha.y,
            alpha.z,
            ib[(0, 0)],
            ib[(1, 1)],
            ib[(2, 2)],
            ib[(0, 1)],
            ib[(0, 2)],
            ib[(1, 2)],
            drive[i].fc,
            drive[i].fv,
        ];
        m_out += inertia[i].mass();
    }
    out
}

/// Inverse of [`to_paper_grouping`] given the link masses (the grouping lumps them, so
/// they must be supplied): link parameters in the joint frames and drive parameters
/// (`fc = F`, `fv = d`, no armature or offset).
pub fn from_paper_grouping<const N: usize>(
    rows: &[DhRow; N],
    x: &[[f64; 11]; N],
    masses: &[f64; N],
) -> ([LinkInertia; N], [DriveParams; N]) {
    let mut inertia = [LinkInertia::ZERO; N];
    let mut drive = [DriveParams::ZERO; N];
    let mut m_out = 0.0;
    for i in (0..N).rev() {
        let pl = rows[i].placement();
        let r = pl.trans;
        let g = &x[i];
        let alpha = pl.rot * Vec3::new(g[0], g[1], g[2]);
        let ib = Mat3::new(g[3], g[6], g[7], g[6], g[4], g[8], g[7], g[8], g[5]);
        let ibar_j = pl.rot * ib * pl.rot.transpose();
        let h = alpha - m_out * r;
        let i_o = ibar_j - m_out * (r.dot(&r) * Mat3::identity() - r * r.transpose());
        inertia[i] = LinkInertia::from_parts(masses[i], &h, &i_o);
        drive[i] = DriveParams { fc: g[9], fv: g[10], ia: 0.0, tau0: 0.0, ..DriveParams::ZERO };
        m_out += masses[i];
    }
    (inertia, drive)
}

//! Link inertial parameters: the standard 10-vector and its conversions.

use crate::error::Error;
use crate::spatial::{Transform, skew};
use crate::types::{Mat3, Vec3};

/// Names of an inertia 6-vector's entries in ivdyn's order (the order of the 10-vector's
/// last six, Pinocchio's): every inertia 6-vector of the Rust and Python APIs uses it.
pub const INERTIA_ORDER: [&str; 6] = ["Ixx", "Ixy", "Iyy", "Ixz", "Iyz", "Izz"];

/// Names in URDF `<inertia>` attribute order, which URDF files and the JSON files that
/// follow them (`payload --json`, `diagnosis.json`, the URDF side file) keep.
pub const INERTIA_URDF_ORDER: [&str; 6] = ["Ixx", "Ixy", "Ixz", "Iyy", "Iyz", "Izz"];

/// `[Ixx, Ixy, Iyy, Ixz, Iyz, Izz]` (ivdyn) -> `[Ixx, Ixy, Ixz, Iyy, Iyz, Izz]` (URDF).
#[inline]
pub fn inertia_to_urdf(i: [f64; 6]) -> [f64; 6] {
    // the two orders differ by swapping Iyy and Ixz: the permutation is its own inverse
    [i[0], i[1], i[3], i[2], i[4], i[5]]
}

/// `[Ixx, Ixy, Ixz, Iyy, Iyz, Izz]` (URDF) -> `[Ixx, Ixy, Iyy, Ixz, Iyz, Izz]` (ivdyn).
#[inline]
pub fn inertia_from_urdf(u: [f64; 6]) -> [f64; 6] {
    inertia_to_urdf(u)
}

/// The symmetric 3x3 tensor of a 6-vector in ivdyn's order `[Ixx, Ixy, Iyy, Ixz, Iyz, Izz]`.
#[inline]
pub fn inertia_matrix(i: &[f64; 6]) -> Mat3 {
    Mat3::new(i[0], i[1], i[3], i[1], i[2], i[4], i[3], i[4], i[5])
}

/// The 6-vector `[Ixx, Ixy, Iyy, Ixz, Iyz, Izz]` of a (symmetric) 3x3 tensor.
#[inline]
pub fn inertia_vector(m: &Mat3) -> [f64; 6] {
    [m[(0, 0)], m[(0, 1)], m[(1, 1)], m[(0, 2)], m[(1, 2)], m[(2, 2)]]
}

/// The 10 standard inertial parameters of a rigid body about a frame origin, in that
/// frame's coordinates: `[m, m*cx, m*cy, m*cz, Ixx, Ixy, Iyy, Ixz, Iyz, Izz]`
/// (Pinocchio's order; the inertia is about the frame ORIGIN, not the centre of mass).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct LinkInertia(pub [f64; 10]);

impl LinkInertia {
    /// A massless body.
    pub const ZERO: LinkInertia = LinkInertia([0.0; 10]);

    /// Mass.
    #[inline]
    pub fn mass(&self) -> f64 {
        self.0[0]
    }

    /// First moment of mass `m c`.
    #[inline]
    pub fn first_moment(&self) -> Vec3 {
        Vec3::new(self.0[1], self.0[2], self.0[3])
    }

    /// Inertia tensor about the origin.
    #[inline]
    pub fn inertia_origin(&self) -> Mat3 {
        let p = &self.0;
        inertia_matrix(&[p[4], p[5], p[6], p[7], p[8], p[9]])
    }

    /// From mass, first moment and inertia about the origin (symmetrised).
    pub fn from_parts(m: f64, h: &Vec3, i_o: &Mat3) -> Self {
        let s = |a: usize, b: usize| 0.5 * (i_o[(a, b)] + i_o[(b, a)]);
        LinkInertia([m, h.x, h.y, h.z, s(0, 0), s(0, 1), s(1, 1), s(0, 2), s(1, 2), s(2, 2)])
    }

    /// URDF `<inertial>`: mass, centre of mass `com` and inertia `i_c` about the centre of
    /// mass, where `i_c` is given in a frame rotated by `rot` from the link frame
    /// (URDF `<origin rpy>` of the inertial). Parallel-axis theorem:
    /// `I_o = R I_c R^T - m [c]x [c]x`.
    pub fn from_mass_com_inertia(m: f64, com: &Vec3, rot: &Mat3, i_c: &Mat3) -> Self {
        let i_c_link = rot * i_c * rot.transpose();
        let cx = skew(com);
        let i_o = i_c_link - m * cx * cx;
        Self::from_parts(m, &(m * com), &i_o)
    }

    /// Mass, centre of mass and inertia about the centre of mass (link axes).
    /// Fails for a non-positive mass, for which the centre of mass is undefined.
    pub fn to_mass_com_inertia(&self, link: usize) -> Result<(f64, Vec3, Mat3), Error> {
        let m = self.mass();
        if !(m > 0.0) {
            return Err(Error::NonPhysicalInertia { link });
        }
        let c = self.first_moment() / m;
        let cx = skew(&c);
        Ok((m, c, self.inertia_origin() + m * cx * cx))
    }

    /// The same body described in the parent frame, given the body frame's placement `x`
    /// in the parent: `h' = R h + m p`,
    /// `I' = R I R^T - [p]x [R h]x - [R h]x [p]x - m [p]x [p]x`.
    #[inline(always)]
    pub fn transformed(&self, x: &Transform) -> Self {
        // with [a]x [b]x = b a^T - (a.b) 1 and u = R h + m p / 2:
        // I' = R I R^T + 2 (p.u) 1 - (u p^T + p u^T)
        // (the mass mixed into u saves the separate m p p^T term: 12 fewer products)
        let (r, p, m) = (&x.rot, &x.trans, self.mass());
        let rh = r * self.first_moment();
        let mp2 = p * (0.5 * m);
        let u = rh + mp2;
        let d = 2.0 * p.dot(&u);
        let i_r = rotate_symmetric(r, &self.inertia_origin());
        let e = |a: usize, b: usize| i_r[(a, b)] - (u[a] * p[b] + p[a] * u[b]);
        let h = u + mp2;
        LinkInertia([m, h.x, h.y, h.z, e(0, 0) + d, e(0, 1), e(1, 1) + d, e(0, 2), e(1, 2), e(2, 2) + d])
    }

    /// Sum of two bodies described in the same frame.
    pub fn add(&self, other: &LinkInertia) -> Self {
        let mut out = *self;
        for k in 0..10 {
            out.0[k] += other.0[k];
        }
        out
    }

    /// Physical realisability (density realisable by a point-mass distribution): the
    /// 4x4 pseudo-inertia `[[tr(I)/2 1 - I, h], [h^T, m]]` is positive semi-definite
    /// (Wensing et al. 2017). Returns the smallest eigenvalue-like margin test result.
    pub fn is_physically_consistent(&self, tol: f64) -> bool {
        let m = self.mass();
        if m <= tol {
            return false;
        }
        let i_o = self.inertia_origin();
        let sigma = 0.5 * i_o.trace() * Mat3::identity() - i_o;
        let h = self.first_moment();
        // Schur complement w.r.t. m: Sigma - h h^T / m must be PSD.
        let s = sigma - h * h.transpose() / m;
        let s = 0.5 * (s + s.transpose());
        // 3x3 PSD test via leading principal minors of s + tol I (Sylvester on PD).
        let s = s + tol * Mat3::identity();
        let d1 = s[(0, 0)];
        let d2 = s[(0, 0)] * s[(1, 1)] - s[(0, 1)] * s[(1, 0)];
        let d3 = s.determinant();
        d1 >= 0.0 && d2 >= 0.0 && d3 >= 0.0 && s[(1, 1)] >= 0.0 && s[(2, 2)] >= 0.0
    }
}

/// `R S R^T` for a symmetric `S`: the upper triangle of the product only (45 products
/// instead of 54), mirrored.
#[inline(always)]
pub fn rotate_symmetric(r: &Mat3, s: &Mat3) -> Mat3 {
    let a = r * s;
    let e = |i: usize, j: usize| a[(i, 0)] * r[(j, 0)] + a[(i, 1)] * r[(j, 1)] + a[(i, 2)] * r[(j, 2)];
    let (xy, xz, yz) = (e(0, 1), e(0, 2), e(1, 2));
    Mat3::new(e(0, 0), xy, xz, xy, e(1, 1), yz, xz, yz, e(2, 2))
}

//! Parameter layout and the drive parameters.
//!
//! The full parameter vector `theta` of an `N`-joint chain has `P = 14 N` entries:
//! `[link_1 (10), ..., link_N (10), drive_1 (4), ..., drive_N (4)]`. The first `10 N`
//! entries are the standard inertial parameters in Pinocchio's order (so a Pinocchio
//! regressor is the first `10 N` columns of ours), the drive blocks are
//! `[fc, fv, ia, tau0]`.

/// Inertial parameters per link.
pub const LINK_PARAMS: usize = 10;
/// Drive parameters per joint.
pub const DRIVE_PARAMS: usize = 4;
/// Parameters per joint (link + drive).
pub const PARAMS_PER_JOINT: usize = LINK_PARAMS + DRIVE_PARAMS;

/// Index of `m` in a link block.
pub const M: usize = 0;
/// Index of `m*cx` (first of three) in a link block.
pub const MC: usize = 1;
/// Index of `Ixx` in a link block.
pub const IXX: usize = 4;
/// Index of `Ixy` in a link block.
pub const IXY: usize = 5;
/// Index of `Iyy` in a link block.
pub const IYY: usize = 6;
/// Index of `Ixz` in a link block.
pub const IXZ: usize = 7;
/// Index of `Iyz` in a link block.
pub const IYZ: usize = 8;
/// Index of `Izz` in a link block.
pub const IZZ: usize = 9;

/// Index of `fc` (Coulomb) in a drive block.
pub const FC: usize = 0;
/// Index of `fv` (viscous) in a drive block.
pub const FV: usize = 1;
/// Index of `ia` (armature, rotor inertia reflected to the joint) in a drive block.
pub const IA: usize = 2;
/// Index of `tau0` (torque offset) in a drive block.
pub const TAU0: usize = 3;

/// Names of the link-block entries, for readable parameter names.
pub const LINK_PARAM_NAMES: [&str; LINK_PARAMS] =
    ["m", "m*cx", "m*cy", "m*cz", "Ixx", "Ixy", "Iyy", "Ixz", "Iyz", "Izz"];
/// Names of the drive-block entries.
pub const DRIVE_PARAM_NAMES: [&str; DRIVE_PARAMS] = ["fc", "fv", "ia", "tau0"];

/// Total parameter count for `n` joints.
pub const fn param_count(n: usize) -> usize {
    PARAMS_PER_JOINT * n
}

/// Column of link `link`'s entry `k` in `theta`.
pub const fn link_col(link: usize, k: usize) -> usize {
    LINK_PARAMS * link + k
}

/// Column of joint `joint`'s drive entry `k` in `theta` (for `n` joints).
pub const fn drive_col(n: usize, joint: usize, k: usize) -> usize {
    LINK_PARAMS * n + DRIVE_PARAMS * joint + k
}

/// Shape of a joint's Coulomb friction: a model constant, not part of `theta`, so the
/// torque stays linear in `fc`. The Coulomb term is `fc c(qd)` with
/// `c(v) = s(v) + asym |s(v)|`, where `s(v) = sign(v)` (`v_scale = 0`: paper eq 8) or the
/// smooth `s(v) = tanh(v / v_scale)` (a real drive's friction rises over a velocity band:
/// pre-sliding, lubrication, and a noisy velocity that dithers around zero at standstill).
/// `asym` makes it direction-dependent: `fc (1 + asym)` moving forward, `fc (1 - asym)`
/// backward.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct CoulombShape {
    /// Velocity scale of the smooth sign (rad/s, or m/s for prismatic); 0: exact sign.
    pub v_scale: f64,
    /// Direction asymmetry (`fc+ = fc (1 + asym)`, `fc- = fc (1 - asym)`).
    pub asym: f64,
}

impl CoulombShape {
    /// The paper's `sign(qd)`.
    pub const SIGN: CoulombShape = CoulombShape { v_scale: 0.0, asym: 0.0 };

    /// `c(qd)`, the Coulomb regressor entry. With the default shape it is exactly `sign(qd)`.
    #[inline]
    pub fn value(&self, qd: f64) -> f64 {
        // the paper's sign first, on its own: the shape is a model constant, so the branch
        // is predicted, whereas the two tests of `shaped` compiled to a select computing both
        // arms. The test is on the bit patterns (+0 in both fields): a load, an `or` and a
        // jump, where `== SIGN` took two float compares and four jumps; `-0` fields take
        // `shaped`, which gives the same `sign(qd)`
        if (self.v_scale.to_bits() | self.asym.to_bits()) == 0 {
            return sign(qd);
        }
        self.shaped(qd)
    }

    /// [`Self::value`] for a shape other than the paper's sign. Out of line: inlined, its
    /// operands were loaded on every call and rnea's drive loop was too large to unroll
    /// (callgrind, Panda RNEA: 47 instructions per call more).
    #[inline(never)]
    fn shaped(&self, qd: f64) -> f64 {
        // s(v) = tanh(v / v_s) or sign(v);  c = s + asym |s|
        let s = if self.v_scale > 0.0 { libm::tanh(qd / self.v_scale) } else { sign(qd) };
        if self.asym != 0.0 { s + self.asym * s.abs() } else { s }
    }

    /// Whether this is the exact sign of the paper.
    pub fn is_sign(&self) -> bool {
        *self == Self::SIGN
    }
}

/// Joint drive parameters: `tau_drive = fc c(qd) + fv qd + ia qdd + tau0`, with
/// `c = sign` unless [`DriveParams::coulomb`] says otherwise. The four coefficients are
/// `theta`'s drive block; the Coulomb shape is a model constant.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct DriveParams {
    /// Coulomb friction (N m, or N for prismatic).
    pub fc: f64,
    /// Viscous friction (N m s/rad).
    pub fv: f64,
    /// Armature: rotor inertia reflected through the gear (kg m^2).
    pub ia: f64,
    /// Constant torque offset (N m).
    pub tau0: f64,
    /// Shape of the Coulomb term (not in `theta`; default: `sign`).
    pub coulomb: CoulombShape,
}

impl DriveParams {
    /// All zero.
    pub const ZERO: DriveParams = DriveParams { fc: 0.0, fv: 0.0, ia: 0.0, tau0: 0.0, coulomb: CoulombShape::SIGN };

    /// From `[fc, fv, ia, tau0]` (Coulomb shape: `sign`).
    pub fn from_array(a: [f64; DRIVE_PARAMS]) -> Self {
        Self { fc: a[FC], fv: a[FV], ia: a[IA], tau0: a[TAU0], coulomb: CoulombShape::SIGN }
    }

    /// As `[fc, fv, ia, tau0]`.
    pub fn to_array(&self) -> [f64; DRIVE_PARAMS] {
        [self.fc, self.fv, self.ia, self.tau0]
    }

    /// The drive torque (paper eq 8's friction terms, plus armature and offset).
    #[inline]
    pub fn torque(&self, qd: f64, qdd: f64) -> f64 {
        self.fc * self.coulomb.value(qd) + self.fv * qd + self.ia * qdd + self.tau0
    }

    /// The drive regressor row `[c(qd), qd, qdd, 1]` of this joint's Coulomb shape.
    #[inline]
    pub fn regressor_row(&self, qd: f64, qdd: f64) -> [f64; DRIVE_PARAMS] {
        [self.coulomb.value(qd), qd, qdd, 1.0]
    }

    /// The drive regressor row of the paper's model, `[sign(qd), qd, qdd, 1]`.
    #[inline]
    pub fn regressor(qd: f64, qdd: f64) -> [f64; DRIVE_PARAMS] {
        [sign(qd), qd, qdd, 1.0]
    }
}

/// `sign(x)` with `sign(0) = 0` (the Coulomb model's convention).
#[inline]
pub fn sign(x: f64) -> f64 {
    // two compares, no branch: a joint velocity's sign changes at random from one sample
    // to the next, and a mispredicted branch costs more than the compares (same values:
    // exactly 1, -1 or +0, and 0 for NaN)
    (x > 0.0) as u8 as f64 - (x < 0.0) as u8 as f64
}

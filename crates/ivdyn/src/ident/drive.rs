//! Which drive (per-joint) parameters a fit estimates.

use ivdyn_core::params::LINK_PARAMS;
use serde::Serialize;

/// Which drive (per-joint) parameters [`identify`] estimates. The parameters left out
/// keep their nominal values (URDF or `--params`; zero unless set) and no base parameter
/// contains them. Default: all four.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
pub struct DriveTerms {
    /// Coulomb friction `fc` (torque `fc sign(qd)`).
    pub coulomb: bool,
    /// Viscous friction `fv` (torque `fv qd`).
    pub viscous: bool,
    /// Armature (rotor inertia reflected to the joint) `ia` (torque `ia qdd`).
    pub armature: bool,
    /// Constant torque offset `tau0`.
    pub offset: bool,
}

impl Default for DriveTerms {
    fn default() -> Self {
        DriveTerms { coulomb: true, viscous: true, armature: true, offset: true }
    }
}

impl DriveTerms {
    /// No drive parameter: the rigid-body model only.
    pub const NONE: DriveTerms = DriveTerms { coulomb: false, viscous: false, armature: false, offset: false };

    /// The per-joint parameter suffixes estimated (`fc`, `fv`, `ia`, `tau0`, in layout order).
    pub fn names(&self) -> Vec<String> {
        let on = [self.coulomb, self.viscous, self.armature, self.offset];
        ["fc", "fv", "ia", "tau0"].iter().zip(on).filter(|(_, o)| *o).map(|(s, _)| s.to_string()).collect()
    }

    /// Full-parameter indices left out for `n` joints (layout: `10 n` link parameters,
    /// then per joint `[fc, fv, ia, tau0]`).
    pub fn excluded_columns(&self, n: usize) -> Vec<usize> {
        let on = [self.coulomb, self.viscous, self.armature, self.offset];
        (0..n).flat_map(|j| (0..4).filter(move |&k| !on[k]).map(move |k| LINK_PARAMS * n + 4 * j + k)).collect()
    }
}

impl DriveTerms {
    /// The terms named by a user: friction terms `"coulomb"`, `"viscous"` or `"none"` (alone),
    /// armature and offset switched on or off.
    pub fn from_names(friction: &[&str], armature: bool, offset: bool) -> crate::error::Result<DriveTerms> {
        let bad = |msg: String| crate::error::Error::option("friction", msg);
        if let Some(f) = friction.iter().find(|f| !matches!(**f, "coulomb" | "viscous" | "none")) {
            return Err(bad(format!("must be 'none' or a list of 'coulomb', 'viscous', got '{f}'")));
        }
        if friction.contains(&"none") && friction.len() > 1 {
            return Err(bad("none cannot be combined with other terms".into()));
        }
        Ok(DriveTerms {
            coulomb: friction.contains(&"coulomb"),
            viscous: friction.contains(&"viscous"),
            armature,
            offset,
        })
    }
}

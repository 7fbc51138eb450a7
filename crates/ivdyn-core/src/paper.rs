//! The paper's six-joint robot: Table 1 (standard DH) and Table 2 (link parameters) in SI
//! units, as corrected in `shared/paper/NOTES.md`.

use crate::dh::{DhRow, inertia_from_dh_frame, model_from_dh};
use crate::inertia::LinkInertia;
use crate::model::Model;
use crate::params::DriveParams;
use crate::types::{Mat3, Vec3};
use core::f64::consts::FRAC_PI_2;

/// Table 1: `(a, d, alpha)`; all joints revolute with `theta_i = q_i`.
pub const DH: [DhRow; 6] = [
    DhRow { a: -0.011, d: 0.0, alpha: FRAC_PI_2, offset: 0.0 },
    DhRow { a: -0.08, d: 0.0, alpha: 0.0, offset: 0.0 },
    DhRow { a: -0.0886, d: 0.0, alpha: 0.0, offset: 0.0 },
    DhRow { a: 0.0, d: 0.0, alpha: FRAC_PI_2, offset: 0.0 },
    DhRow { a: 0.0, d: 0.103, alpha: FRAC_PI_2, offset: 0.0 },
    DhRow { a: 0.0, d: 0.0, alpha: 0.0, offset: 0.0 },
];

/// Table 2 row: mass (kg), centre of mass in DH frame `i` (m), principal inertia about
/// the centre of mass (kg m^2, diagonal), static (Coulomb) friction `F` (N m), viscous `d`.
#[derive(Debug, Clone, Copy)]
pub struct Table2Row {
    /// Mass (kg).
    pub m: f64,
    /// Centre of mass in DH frame i (m).
    pub s: [f64; 3],
    /// Diagonal of the inertia about the centre of mass (kg m^2).
    pub i_diag: [f64; 3],
    /// Coulomb friction (N m).
    pub f: f64,
    /// Viscous friction (N m s/rad).
    pub d: f64,
}

/// Table 2 in SI units.
pub const TABLE2: [Table2Row; 6] = [
    Table2Row { m: 0.800, s: [-0.04, -0.08, 0.0], i_diag: [0.010, 0.010, 0.010], f: 0.470, d: 0.0 },
    Table2Row { m: 0.100, s: [-0.04, 0.02, 0.0], i_diag: [0.005, 0.005, 0.005], f: 1.250, d: 0.0 },
    Table2Row { m: 0.350, s: [-0.07, 0.035, 0.0], i_diag: [0.005, 0.005, 0.005], f: 1.250, d: 0.0 },
    Table2Row { m: 0.200, s: [0.0, 0.0, 0.0], i_diag: [0.001, 0.001, 0.001], f: 0.450, d: 0.0 },
    Table2Row { m: 0.050, s: [-0.01, -0.03, 0.0], i_diag: [0.0005, 0.0005, 0.0005], f: 0.250, d: 0.0 },
    Table2Row { m: 0.020, s: [0.01, 0.01, 0.0], i_diag: [0.0001, 0.0001, 0.0001], f: 0.100, d: 0.0 },
];

impl Table2Row {
    /// The 10 standard parameters in DH frame `i` (about its origin).
    pub fn inertia_dh_frame(&self) -> LinkInertia {
        let d = self.i_diag;
        LinkInertia::from_mass_com_inertia(
            self.m,
            &Vec3::new(self.s[0], self.s[1], self.s[2]),
            &Mat3::identity(),
            &Mat3::from_diagonal(&Vec3::new(d[0], d[1], d[2])),
        )
    }
}

/// Link 6 after the simulated change (Figs 2-3), read literally as in `NOTES.md`: mass
/// 0.020 -> 0.080 kg, centre of mass (0.01, 0.01, 0) -> (0.04, 0.04, 0) m, inertia about
/// the centre of mass diag(1, 1, 1)e-4 -> diag(4, 3, 4)e-4 kg m^2, F 0.100 -> 0.250 N m.
pub const LINK6_AFTER_CHANGE: Table2Row =
    Table2Row { m: 0.080, s: [0.04, 0.04, 0.0], i_diag: [4e-4, 3e-4, 4e-4], f: 0.250, d: 0.0 };

/// The paper's kinematics with the link parameters of `table` (rows in DH frames).
pub fn robot_from_table(table: &[Table2Row; 6]) -> Model<6> {
    let mut model = model_from_dh(&DH);
    for i in 0..6 {
        model.inertia[i] = inertia_from_dh_frame(&DH[i], &table[i].inertia_dh_frame());
        model.drive[i] = DriveParams { fc: table[i].f, fv: table[i].d, ia: 0.0, tau0: 0.0, ..DriveParams::ZERO };
    }
    model
}

/// The paper's robot with Table 2 as its parameters (link parameters moved into the
/// joint frames, see [`crate::dh`]); gravity `(0, 0, -9.81)` in the base frame.
pub fn robot() -> Model<6> {
    robot_from_table(&TABLE2)
}

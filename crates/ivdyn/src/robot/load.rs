//! The one way a robot is loaded: URDF (base and tip), then a parameter file or, when
//! none is given, the side file a `--write-urdf` left beside the URDF.

use std::path::{Path, PathBuf};

use serde::{Deserialize, Serialize};

use super::Robot;
use super::urdf::{self, UrdfOptions};
use crate::error::{Error, Result};
use crate::report::{CoulombShapeFile, ParamsFile, PayloadSpec};
use ivdyn_core::CoulombShape;
use ivdyn_core::params::{IA, TAU0, drive_col};

/// Format marker of the side file.
pub const SIDE_FORMAT: &str = "ivdyn-urdf-side/1";

/// What URDF cannot hold, next to the written URDF (`OUT.urdf.json`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct SideFile {
    /// [`SIDE_FORMAT`].
    pub format: String,
    /// Robot name.
    pub robot: String,
    /// Base and tip links of the chain the parameters belong to.
    pub base_link: String,
    /// Tip link.
    pub tip_link: String,
    /// Movable joints, base to tip (order of the lists below).
    pub joints: Vec<String>,
    /// Armature (rotor inertia reflected to the joint), kg m^2.
    pub armature: Vec<f64>,
    /// Constant torque offsets, N m.
    pub tau0: Vec<f64>,
    /// Coulomb friction (also in the URDF `<dynamics friction>`), for reference.
    pub friction: Vec<f64>,
    /// Viscous friction (also in the URDF `<dynamics damping>`), for reference.
    pub damping: Vec<f64>,
    /// The payload written, if any.
    pub payload: Option<PayloadSpec>,
    /// Each joint's Coulomb-friction shape when some joint is not the exact sign (URDF's
    /// `<dynamics friction>` is the coefficient `fc` only).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub coulomb: Option<Vec<CoulombShapeFile>>,
    /// Remarks (where the parameters came from, links whose own share is not consistent).
    pub notes: Vec<String>,
}

/// The side file path of a URDF path: `OUT.urdf` -> `OUT.urdf.json`.
pub fn side_path(urdf: &Path) -> PathBuf {
    let mut s = urdf.as_os_str().to_owned();
    s.push(".json");
    PathBuf::from(s)
}

impl Robot {
    /// Applies an ivdyn URDF side file (armature and torque offsets, [`SideFile`]) to this
    /// robot, checking the format and the joint names.
    pub fn apply_side_file(&mut self, path: &Path) -> Result<()> {
        let text = std::fs::read_to_string(path).map_err(|e| Error::Io { file: path.to_path_buf(), source: e })?;
        let side: SideFile = serde_json::from_str(&text)
            .map_err(|e| Error::Log { file: path.to_path_buf(), msg: format!("not an ivdyn URDF side file: {e}") })?;
        if side.format != SIDE_FORMAT {
            return Err(Error::Log {
                file: path.to_path_buf(),
                msg: format!("format '{}', expected '{SIDE_FORMAT}'", side.format),
            });
        }
        if side.joints != self.joint_names || side.armature.len() != self.dof() || side.tau0.len() != self.dof() {
            return Err(Error::Log {
                file: path.to_path_buf(),
                msg: format!("side file for joints {:?}; this chain has {:?}", side.joints, self.joint_names),
            });
        }
        let n = self.dof();
        let mut th = self.params();
        for j in 0..n {
            th[drive_col(n, j, IA)] = side.armature[j];
            th[drive_col(n, j, TAU0)] = side.tau0[j];
        }
        self.set_params(&th)?;
        match &side.coulomb {
            Some(c) if c.len() != n => {
                Err(Error::Log { file: path.to_path_buf(), msg: format!("{} Coulomb shapes for {n} joints", c.len()) })
            }
            Some(c) => self.set_coulomb_shapes(
                &c.iter().map(|c| CoulombShape { v_scale: c.v_scale, asym: c.asym }).collect::<Vec<_>>(),
            ),
            None => Ok(()),
        }
    }

    /// Loads a URDF ([`crate::robot::urdf`]; `base` and `tip` pick the chain, and the
    /// bodies below a given tip are dropped) and, when
    /// `<path>.json` exists (written by `--write-urdf`), applies its ivdyn side file
    /// (armature, torque offsets): the one loading path of the library, the command line
    /// and Python.
    pub fn from_urdf(path: impl AsRef<Path>, base: Option<&str>, tip: Option<&str>) -> Result<Self> {
        Self::from_urdf_with(path, &UrdfOptions::new(base, tip))
    }

    /// [`Robot::from_urdf`] with all the loading options (e.g. fusing the bodies below
    /// the tip: [`UrdfOptions::fuse_beyond_tip`]).
    pub fn from_urdf_with(path: impl AsRef<Path>, opts: &UrdfOptions) -> Result<Self> {
        let path = path.as_ref();
        let mut r = urdf::load_with(path, opts)?;
        let side = side_path(path);
        if side.exists() {
            r.apply_side_file(&side)?;
        }
        Ok(r)
    }
}

/// The robot a command works on: [`Robot::from_urdf_with`], then, with `params`, a
/// parameter file (written by `identify --out-params`) replacing every parameter.
pub fn load(urdf: &Path, opts: &UrdfOptions, params: Option<&Path>) -> Result<Robot> {
    let mut robot = Robot::from_urdf_with(urdf, opts)?;
    if let Some(p) = params {
        let text = std::fs::read_to_string(p).map_err(|e| Error::Io { file: p.to_path_buf(), source: e })?;
        apply_params_json(&mut robot, &text, p)?;
    }
    Ok(robot)
}

/// Writes nothing; loads a [`ParamsFile`] into `robot`, checking joint and parameter names.
pub fn load_params(robot: &mut Robot, p: &ParamsFile) -> Result<()> {
    let names = robot.param_names();
    if p.names != names {
        return Err(Error::ParamsMismatch {
            robot: p.robot.clone(),
            file_joints: p.joints.clone(),
            joints: robot.joint_names.clone(),
        });
    }
    robot.set_params(&p.theta)?;
    robot.set_coulomb_shapes(&p.coulomb_shapes(robot.dof()))
}

/// Loads the parameter file `text` (JSON, [`ParamsFile`]; `name` names it in errors) into
/// `robot`.
pub fn apply_params_json(robot: &mut Robot, text: &str, name: &Path) -> Result<()> {
    let pf: ParamsFile = serde_json::from_str(text)
        .map_err(|e| Error::Log { file: name.to_path_buf(), msg: format!("not a parameter file: {e}") })?;
    load_params(robot, &pf).map_err(|e| Error::Log { file: name.to_path_buf(), msg: e.to_string() })
}

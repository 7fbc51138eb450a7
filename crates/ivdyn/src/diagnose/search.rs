//! The search: candidate effects, their columns, scoring, look-alike rules.

use super::Diagnosis;
use crate::error::Result;
use crate::io::JointLog;
use crate::Robot;

/// Options of [`diagnose`].
#[derive(Debug, Clone, Default)]
pub struct DiagnoseOptions {}

/// Diagnoses `log` against the nominal `robot`.
pub fn diagnose(_robot: &Robot, _log: &JointLog, _opts: &DiagnoseOptions) -> Result<Diagnosis> {
    todo!("diagnosis search")
}

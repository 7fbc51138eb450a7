//! `report.html` (self-contained, PNG plots embedded) and `residuals.mcap`.

use std::path::Path;

use super::Diagnosis;
use crate::error::Result;

/// Writes `report.html` into `dir`.
pub fn write_html(_d: &Diagnosis, _dir: &Path) -> Result<()> {
    todo!("report.html")
}

/// Writes `residuals.mcap` into `dir`.
pub fn write_mcap(_d: &Diagnosis, _joints: &[String], _dir: &Path) -> Result<()> {
    todo!("residuals.mcap")
}

//! The one place where Rust errors become Python exceptions.
//!
//! - `ValueError`: bad input (array lengths, NaN/inf, URDF content, unknown links, too many
//!   joints, invalid axes);
//! - `FileNotFoundError` / `OSError`: the URDF file cannot be read;
//! - `RuntimeError`: numerical failure (e.g. a mass matrix that is not positive definite).
//!
//! The message is always the Rust error's `Display` text.

use ivdyn::Error;
use ivdyn::core::Error as CoreError;
use pyo3::PyErr;
use pyo3::exceptions::{PyFileNotFoundError, PyOSError, PyRuntimeError, PyValueError};

fn core_is_input(e: &CoreError) -> bool {
    matches!(
        e,
        CoreError::NonFinite { .. }
            | CoreError::Dimension { .. }
            | CoreError::InvalidAxis { .. }
            | CoreError::NonPhysicalInertia { .. }
    )
}

/// `ivdyn::Error` -> Python exception.
pub fn to_py(e: Error) -> PyErr {
    let msg = e.to_string();
    // an error in a file is of its cause's kind
    let mut e = &e;
    while let Error::InFile { source, .. } = e {
        e = source;
    }
    match e {
        Error::Io { source, .. } if source.kind() == std::io::ErrorKind::NotFound => PyFileNotFoundError::new_err(msg),
        Error::Io { .. } => PyOSError::new_err(msg),
        Error::Core(c) if core_is_input(c) => PyValueError::new_err(msg),
        Error::Core(_) => PyRuntimeError::new_err(msg),
        Error::UrdfParse { .. }
        | Error::UnsupportedJoint { .. }
        | Error::MimicJoint { .. }
        | Error::UnknownLink { .. }
        | Error::Branching { .. }
        | Error::UrdfStructure { .. }
        | Error::BadJoint { .. }
        | Error::TooManyJoints { .. }
        | Error::Dimension { .. }
        | Error::Log { .. }
        | Error::Signal { .. }
        | Error::Option { .. } => PyValueError::new_err(msg),
        Error::Sample { source, .. } if core_is_input(source) => PyValueError::new_err(msg),
        _ => PyRuntimeError::new_err(msg),
    }
}

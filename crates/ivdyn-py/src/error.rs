//! The one place where Rust errors become Python exceptions.
//!
//! - `ValueError`: bad input (array lengths, NaN/inf, URDF content, unknown links, too many
//!   joints, invalid axes, estimator rows out of range or above the outlier gate);
//! - `FileNotFoundError` / `OSError`: the URDF file cannot be read;
//! - `RuntimeError`: numerical failure (e.g. a mass matrix that is not positive definite),
//!   refused write-backs, logs too short or with non-finite samples, joint limits the
//!   excitation cannot use, terminal-link settings (each kept from the former catch-all
//!   `Estimation` error, which raised `RuntimeError`), and internal errors.
//!
//! The message is always the Rust error's `Display` text.

use ivdyn::Error;
use ivdyn::core::Error as CoreError;
use pyo3::exceptions::{PyFileNotFoundError, PyOSError, PyRuntimeError, PyValueError};
use pyo3::{PyErr, PyResult};

fn core_is_input(e: &CoreError) -> bool {
    matches!(
        e,
        CoreError::NonFinite { .. }
            | CoreError::Dimension { .. }
            | CoreError::InvalidAxis { .. }
            | CoreError::NonPhysicalInertia { .. }
            | CoreError::RowOutOfRange { .. }
            | CoreError::Outlier { .. }
    )
}

/// `ivdyn::Error` -> Python exception.
pub fn to_py(e: Error) -> PyErr {
    let msg = e.to_string();
    // an error in a file or in a named step is of its cause's kind
    let mut e = &e;
    while let Error::InFile { source, .. } | Error::During { source, .. } = e {
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
        | Error::Option { .. }
        | Error::Stats { .. } => PyValueError::new_err(msg),
        Error::Sample { source, .. } if core_is_input(source) => PyValueError::new_err(msg),
        _ => PyRuntimeError::new_err(msg),
    }
}

/// A Rust panic caught at a binding's entry point -> `RuntimeError` with its message.
/// Left alone, pyo3 raises `PanicException`, a `BaseException` that `except Exception`
/// does not catch; a panic is a bug in ivdyn, but the caller's error handling should see it.
pub fn panic_to_py(payload: Box<dyn std::any::Any + Send>) -> PyErr {
    let what = payload
        .downcast_ref::<&str>()
        .map(|s| s.to_string())
        .or_else(|| payload.downcast_ref::<String>().cloned())
        .unwrap_or_else(|| "(no message)".into());
    PyRuntimeError::new_err(format!("internal error in ivdyn (please report): {what}"))
}

/// Runs `f`, turning a panic into [`panic_to_py`]'s `RuntimeError`.
pub fn no_panic<T>(f: impl FnOnce() -> PyResult<T>) -> PyResult<T> {
    std::panic::catch_unwind(std::panic::AssertUnwindSafe(f)).unwrap_or_else(|p| Err(panic_to_py(p)))
}

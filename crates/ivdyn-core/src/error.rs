//! The crate's error type: small, `Copy`, no strings (no allocation).

use core::fmt;

/// What went wrong, with the index that locates it.
#[derive(Debug, Clone, Copy, PartialEq)]
#[non_exhaustive]
pub enum Error {
    /// An input value is NaN or infinite. `what` names the argument, `index` the entry.
    NonFinite {
        /// Argument name (`"q"`, `"qd"`, `"qdd"`, `"tau"`, `"theta"`, ...).
        what: &'static str,
        /// Entry index within the argument.
        index: usize,
    },
    /// A slice argument has the wrong length.
    Dimension {
        /// Argument name.
        what: &'static str,
        /// Length required.
        expected: usize,
        /// Length given.
        got: usize,
    },
    /// The (armature-augmented) mass matrix is not positive definite at this state;
    /// `joint` is the pivot where the Cholesky factorisation failed.
    MassMatrixNotPositiveDefinite {
        /// Joint (row) index of the failing pivot.
        joint: usize,
    },
    /// A link's inertial parameters are not physically realisable for the requested
    /// operation (e.g. non-positive mass when a centre of mass is asked for).
    NonPhysicalInertia {
        /// Link index.
        link: usize,
    },
    /// A joint axis is not a unit vector.
    InvalidAxis {
        /// Joint index.
        joint: usize,
    },
    /// A recursive estimator update is degenerate (non-positive innovation variance,
    /// or a covariance that lost positive definiteness).
    DegenerateUpdate,
    /// A recursive-estimator row is finite but out of numerical range: its information
    /// ratio `w phi^T P phi` (the factor by which it would shrink the variance along
    /// `phi`) exceeds `1 / eps^2 ~ 2e31` or overflows. Accepting it would leave the
    /// covariance numerically singular along `phi` and the estimate stuck there.
    RowOutOfRange {
        /// `w phi^T P phi` (may be infinite).
        ratio: f64,
    },
    /// A recursive-estimator row's normalised innovation `|e| / sqrt(1/w + phi^T P phi)`
    /// exceeds the estimator's outlier gate; the row was not applied.
    Outlier {
        /// The row's normalised innovation.
        innovation: f64,
        /// The gate it exceeded.
        gate: f64,
    },
    /// A matrix that must be invertible is singular (to working precision).
    Singular,
}

impl fmt::Display for Error {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match *self {
            Error::NonFinite { what, index } => write!(f, "non-finite value in {what}[{index}]"),
            Error::Dimension { what, expected, got } => {
                write!(f, "{what} has length {got}, expected {expected}")
            }
            Error::MassMatrixNotPositiveDefinite { joint } => {
                write!(f, "mass matrix is not positive definite (pivot at joint {joint})")
            }
            Error::NonPhysicalInertia { link } => {
                write!(f, "link {link} inertial parameters are not physically realisable")
            }
            Error::InvalidAxis { joint } => write!(f, "joint {joint} axis is not a unit vector"),
            Error::DegenerateUpdate => write!(f, "degenerate recursive estimator update"),
            Error::RowOutOfRange { ratio } => write!(
                f,
                "row out of range: w * phi^T P phi = {ratio:e} exceeds 2e31 (an absurd phi or w, or p0 far too large); row not applied"
            ),
            Error::Outlier { innovation, gate } => write!(
                f,
                "outlier row: normalised innovation {innovation:.3e} exceeds outlier_gate {gate}; row not applied"
            ),
            Error::Singular => write!(f, "singular matrix"),
        }
    }
}

impl core::error::Error for Error {}

/// Checks that every entry of `x` is finite.
pub fn check_finite(what: &'static str, x: &[f64]) -> Result<(), Error> {
    match x.iter().position(|v| !v.is_finite()) {
        Some(index) => Err(Error::NonFinite { what, index }),
        None => Ok(()),
    }
}

//! The options of identify ([`super::identify`], the streamed identify, payload's before
//! model): the method, the conditioning, the Coulomb shape, the drive terms. Their own
//! module, below the identify pipeline and the preparation it shares with payload and the
//! fleet statistics, so that both can read them.

use serde::{Deserialize, Serialize};

use crate::error::{Error, Result};
use crate::ident::{self, DriveTerms};
use crate::log::JointLog;
use crate::prep::ConditionOptions;
use crate::progress::ProgressSink;

/// Estimation method of [`identify`].
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum Method {
    /// Ordinary least squares.
    Ols,
    /// Two-step weighted LS: OLS, then weights = 1 / (per-joint residual variance).
    Wls,
    /// Instrumental variables (weighted as WLS), the instrument the simulated identified
    /// model, iterated (module docs).
    Iv,
    /// IDIM-IV: the instrument is the regressor on a closed-loop simulation.
    IdimIv,
}

impl Method {
    /// The name used on the command line and in JSON.
    pub fn name(&self) -> &'static str {
        match self {
            Method::Ols => "ols",
            Method::Wls => "wls",
            Method::Iv => "iv",
            Method::IdimIv => "idim-iv",
        }
    }
}

/// How [`identify`] shapes each joint's Coulomb friction.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum CoulombMode {
    /// Chosen per joint by held-out validation: sign, smooth sign with a fitted velocity
    /// scale, and their direction-dependent variants ([`ident::coulomb`]).
    Auto,
    /// The paper's `fc sign(qd)` on every joint.
    Sign,
    /// The shapes the model has (e.g. from a parameter file), not chosen again.
    Model,
}

impl CoulombMode {
    /// From its name (`"auto"`, `"sign"`, `"model"`).
    pub fn from_name(s: &str) -> Result<Self> {
        match s {
            "auto" => Ok(CoulombMode::Auto),
            "sign" => Ok(CoulombMode::Sign),
            "model" => Ok(CoulombMode::Model),
            _ => Err(Error::option("coulomb", format!("must be 'auto', 'sign' or 'model', got '{s}'"))),
        }
    }
}

/// Options of [`identify`].
#[derive(Clone)]
pub struct IdentifyOptions {
    /// Estimation method (default WLS).
    pub method: Method,
    /// Conditioning (resampling, differentiation).
    pub condition: ConditionOptions,
    /// Decimation factor after the parallel filter (default 0: automatic, see
    /// [`auto_decimation`]; 1: filter only).
    pub decimate: usize,
    /// Fraction of the log (its tail) held out for validation when no validation log is
    /// given (default 0.25; 0 disables validation).
    pub validation_fraction: f64,
    /// A second log for validation (then the whole first log is used for the fit).
    pub validation_log: Option<JointLog>,
    /// Random states used to find the base parameters (default 200) and their seed.
    pub base_samples: usize,
    /// Seed of the base-parameter states.
    pub seed: u64,
    /// IDIM-IV iterations and relative tolerance.
    pub idim_max_iter: usize,
    /// IDIM-IV convergence tolerance on the relative change of the estimate.
    pub idim_tol: f64,
    /// Drive parameters to estimate (default: all of `fc, fv, ia, tau0`).
    pub drive: DriveTerms,
    /// Shape of the Coulomb friction (default: chosen per joint).
    pub coulomb: CoulombMode,
    /// Progress sink.
    pub progress: ProgressSink,
    /// Also fit physically consistent full parameters ([`ident::consistent`]).
    pub consistent: bool,
}

/// Most IDIM-IV iterations (each is a closed-loop simulation of the whole log).
pub const MAX_IDIM_ITER: usize = 1000;

impl IdentifyOptions {
    /// Rejects option values the fit cannot use (docs/reliability.md): a held-out share
    /// outside `[0, 0.9]`, base-parameter states outside `1..=MAX_BASE_SAMPLES`, IDIM-IV
    /// iterations outside `1..=MAX_IDIM_ITER` or a tolerance outside `(0, 1)`.
    pub fn check(&self) -> Result<()> {
        crate::limits::in_range("holdout", self.validation_fraction, 0.0, 0.9)?;
        crate::limits::count_in("base_samples", self.base_samples, 1, ident::base::MAX_BASE_SAMPLES)?;
        crate::limits::count_in("idim_max_iter", self.idim_max_iter, 1, MAX_IDIM_ITER)?;
        crate::limits::positive_up_to("idim_tol", self.idim_tol, 0.5)
    }
}

impl Default for IdentifyOptions {
    fn default() -> Self {
        IdentifyOptions {
            method: Method::Wls,
            condition: ConditionOptions::default(),
            decimate: 0,
            validation_fraction: 0.25,
            validation_log: None,
            base_samples: 200,
            seed: 1,
            idim_max_iter: 10,
            idim_tol: 1e-3,
            drive: DriveTerms::default(),
            coulomb: CoulombMode::Auto,
            progress: None,
            consistent: false,
        }
    }
}

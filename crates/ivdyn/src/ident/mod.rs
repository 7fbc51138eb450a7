//! Batch identification: streaming least squares and instrumental variables, base
//! parameters, uncertainty.
//!
//! Everything works on regressor rows given as row-major `&[f64]` (`m` rows x `p`
//! columns), measured outputs `y` and optional row weights `w` (inverse variances):
//!
//! - [`accum`]: [`LsAccumulator`] / [`IvAccumulator`], streaming, mergeable sufficient
//!   statistics (memory independent of the number of rows);
//! - [`fit`]: [`fit_ls`] / [`fit_iv`] and the [`FitReport`] (covariance, relative std,
//!   condition number, unexcited parameters, Durbin-Wu-Hausman test);
//! - [`base`]: [`BaseParams`], the identifiable parameter combinations found numerically,
//!   and [`robot_base_params`];
//! - [`stats`]: chi-square, F and normal distributions;
//! - [`coulomb`]: each joint's Coulomb-friction shape (sign, smooth, direction-dependent)
//!   chosen by held-out validation;
//! - [`consistent`]: the LS fit with physical consistency enforced (log-Cholesky
//!   parametrisation; the checks are [`crate::robot::physical`]);
//! - [`joint_acc`]: per-joint statistics from which OLS, two-step WLS, IV and per-joint
//!   quality follow without the data; [`drive`]: which drive terms are fitted;
//! - [`instrument`]: the tracking-simulation instrument; [`batch_fit`]: LS straight from
//!   states; [`arrays`]: fits and recursive estimators on plain arrays (Python's entry);
//! - [`transmission`]: motor-side regressors, gear ratios, drive gains; [`gains`]: the
//!   drive-gain fit (current as the output, honest identifiability);
//!
//! ```
//! use ivdyn::ident::{fit_ls, LsAccumulator};
//! // y = 2 x + 1 on three rows
//! let phi = [0.0, 1.0, 1.0, 1.0, 2.0, 1.0];
//! let y = [1.0, 3.0, 5.0];
//! let mut acc = LsAccumulator::new(2);
//! acc.add_rows(&phi, &y, None).unwrap();
//! let fit = fit_ls(&acc, &["a".into(), "b".into()]).unwrap();
//! assert!((fit.theta[0] - 2.0).abs() < 1e-12 && (fit.theta[1] - 1.0).abs() < 1e-12);
//! ```

pub mod accum;
pub mod arrays;
pub mod base;
pub mod batch_fit;
pub mod consistent;
pub mod coulomb;
pub mod drive;
pub mod fit;
pub mod gains;
pub mod idim;
pub mod instrument;
pub mod joint_acc;
pub mod payload;
pub mod payload_consistent;
pub mod stats;
pub mod transmission;
pub mod wls;

pub use accum::{IvAccumulator, LsAccumulator};
pub use base::{BaseParams, robot_base_params, robot_base_params_excluding};
pub use batch_fit::fit_ls_batch;
pub use drive::DriveTerms;
pub use fit::{DwhTest, FitReport, dwh_sandwich, dwh_test, dwh_var, fit_iv, fit_ls};
pub use idim::{Experiment, IdimIvResult, idim_iv};
pub use payload::{NotIdentifiable, PayloadEstimate, PhysicalFit, payload_from_fit};

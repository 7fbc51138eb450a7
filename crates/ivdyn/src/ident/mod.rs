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
//! - [`physical`]: physical-consistency checks per link and joint; [`consistent`]: the LS
//!   fit with consistency enforced (log-Cholesky parametrisation);
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
pub mod base;
pub mod consistent;
pub mod fit;
pub mod idim;
pub mod payload;
pub mod physical;
pub mod stats;

pub use accum::{IvAccumulator, LsAccumulator};
pub use base::{BaseParams, robot_base_params, robot_base_params_excluding};
pub use fit::{DwhTest, FitReport, dwh_test, fit_iv, fit_ls};
pub use idim::{idim_iv, Experiment, IdimIvResult};
pub use payload::{payload_from_fit, NotIdentifiable, PayloadEstimate};

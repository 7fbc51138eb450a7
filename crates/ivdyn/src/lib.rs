//! `ivdyn`: robot-arm dynamics identification on the desktop. The std side of the
//! project: URDF loading, runtime-sized robots (dispatching to the const-generic
//! `ivdyn-core`), and (as they land) log I/O, batch identification and diagnosis.
//!
//! ```no_run
//! let robot = ivdyn::Robot::from_urdf("ur5.urdf", None, Some("tool0")).unwrap();
//! let n = robot.dof();
//! let tau = robot.rnea(&vec![0.1; n], &vec![0.0; n], &vec![0.0; n]).unwrap();
//! println!("{:?} -> {tau:?}", robot.joint_names);
//! ```
#![warn(missing_docs)]
// `!(x > 0.0)` is deliberate throughout: it is true for NaN, which must be rejected too.
#![allow(clippy::neg_cmp_op_on_partial_ord)]

pub mod arrays;
pub mod batch;
pub mod control;
pub mod diagnose;
pub mod error;
pub mod excite;
pub mod ident;
pub mod io;
pub mod joint_acc;
pub mod pipeline;
pub mod realdata;
pub mod repro;
pub mod robot;
pub mod signal;
pub mod transmission;
pub mod stream;
pub mod urdf;
pub mod urdf_write;

pub use error::Error;
pub use ivdyn_core as core;
pub use robot::{DynModel, Robot, MAX_DOF};

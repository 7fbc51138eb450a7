//! `ivdyn`: robot-arm dynamics identification on the desktop. The std side of the
//! project: URDF loading, runtime-sized robots (dispatching to the const-generic
//! `ivdyn-core`), log I/O, signal conditioning, batch identification, excitation design,
//! the model-gap diagnosis, and the one orchestration ([`app`]) that the command line
//! (`crates/ivdyn-cli`) and the Python package (`crates/ivdyn-py`) both call.
//!
//! Layers, bottom to top; a module imports only from the layers below it
//! (`docs/architecture.md`):
//!
//! | layer | modules |
//! |---|---|
//! | shared types | [`error`], [`limits`] (option and size bounds), [`report`], [`progress`], [`output`] (atomic writes) |
//! | model | [`robot`] (URDF, the one loading path, write-back, physical checks) |
//! | signals | [`dsp`] (filters and derivatives on slices), then [`log`] (joint logs, readers, writers) |
//! | conditioning | [`prep`] (the one conditioning policy, and its streaming twin) |
//! | dynamics | [`batch`] (batched, multi-threaded, SIMD packs) |
//! | estimation | [`ident`] |
//! | uses | [`excite`], [`diagnose`], [`closed_loop`] |
//! | orchestration | [`app`] |
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

pub mod error;
pub mod limits;
pub mod output;
pub mod par;
pub mod progress;
pub mod report;

pub mod robot;

pub mod dsp;
pub mod linalg;
pub mod log;

pub mod prep;

pub mod batch;

pub mod ident;

pub mod closed_loop;
pub mod diagnose;
pub mod excite;

pub mod app;

pub use error::Error;
pub use ivdyn_core as core;
pub use robot::{DynModel, MAX_DOF, Robot};

/// The crate README's examples, compiled and run as doctests (they cannot rot).
#[cfg(doctest)]
#[doc = include_str!("../README.md")]
pub struct ReadmeDoctests;

/// The Rust examples of the repository's README and guides, run as doctests. Doctests
/// run in this crate's directory: `crates/ivdyn/fixtures` links the repository's
/// `fixtures/`, so the examples use the paths a reader in a clone types.
/// `python/tests/test_doc_snippets.py` checks every page with a Rust block is listed here.
#[cfg(doctest)]
pub mod doc_pages {
    #[doc = include_str!("../../../README.md")]
    pub struct Readme;
    #[doc = include_str!("../../../docs/logs.md")]
    pub struct Logs;
    #[doc = include_str!("../../../docs/control.md")]
    pub struct Control;
}

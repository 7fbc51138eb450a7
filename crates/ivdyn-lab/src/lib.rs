//! `ivdyn-lab` (not published): the research code around the `ivdyn` library, kept out of
//! what a user links against.
//!
//! * [`repro`]: the paper's simulation study (Figs 2 and 3, Monte Carlo);
//! * [`control`]: the computed-torque experiments of the paper's Fig. 5;
//! * [`realdata`] with the readers [`real`] and [`npz`]: identification on the real TX40
//!   and LWR4+ recordings (`docs/real-data.md`).
#![warn(missing_docs)]
#![allow(clippy::neg_cmp_op_on_partial_ord)]

pub mod control;
pub mod npz;
pub mod real;
pub mod realdata;
pub mod repro;

//! The command line's tests in one binary (one build, one link): each module runs the
//! `ivdyn` binary on fixtures or generated logs; `util` holds what they share (scratch
//! directories, `tests/scratch.rs`, are named per test and removed when it passes).

#[path = "../../../../tests/scratch.rs"]
mod scratch;
mod util;

mod bag;
mod common;
mod diagnose;
mod errors;
mod fleet;
mod friction;
mod gains;
mod mjcf;
mod out_mcap;
mod outputs;
mod payload;
mod report;
mod roundtrip;

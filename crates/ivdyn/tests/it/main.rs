//! ivdyn's integration tests in one binary: one build and one link instead of one per
//! file (`make test` time), the files' tests run together on the harness's threads. Each
//! module was a test binary of its own; they share nothing (scratch directories,
//! `tests/scratch.rs`, are named per test and removed when it passes). `tests/fixtures.rs`
//! and `tests/urdf_errors.rs` at the repository root belong here too.
//! `tests/io_stream.rs` stays a binary of its own: it measures the process's resident memory,
//! which the other tests' threads would add to.

mod base_names;
mod batch_recovery;
mod closed_loop;
mod consistent;
mod coulomb_shape;
mod diagnose_cases;
mod diagnose_constant;
mod diagnose_drives;
mod diagnose_exact_log;
mod diagnose_report;
mod diagnose_uncertainty;
mod diagnose_urdf_friction;
mod drive_gains;
mod dwh_level;
mod effort_current;
mod excite;
#[path = "../../../../tests/fixtures.rs"]
mod fixtures;
mod fleet_stats;
mod hostile_inputs;
mod hostile_limits;
mod html_reports;
mod ident_accum;
mod ident_base;
mod ident_fit;
mod ident_stats;
mod identify_effort_check;
mod idim_iv;
mod inertia_order;
mod io_bag;
mod io_csv;
mod io_mcap;
mod log_hygiene;
mod mjcf_write;
mod output;
mod payload;
mod payload_physical;
#[path = "../../../../tests/scratch.rs"]
mod scratch;
mod signal_conditioning;
mod simulate_excitation;
mod stream_identify;
mod transmission;
#[path = "../../../../tests/urdf_errors.rs"]
mod urdf_errors;
mod urdf_lenient;
mod urdf_tip;
mod urdf_write;

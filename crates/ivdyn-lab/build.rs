//! Empty on purpose: it makes `[build-dependencies]` (feature parity with ivdyn-py's build,
//! see Cargo.toml) part of the build.
fn main() {}

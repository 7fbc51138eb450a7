#![no_main]
// ivdyn_fuzz::db3 on libFuzzer's inputs (crates/ivdyn-fuzz/src/lib.rs)
libfuzzer_sys::fuzz_target!(|data: &[u8]| ivdyn_fuzz::db3(data));

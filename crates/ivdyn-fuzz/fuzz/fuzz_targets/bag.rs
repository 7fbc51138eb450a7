#![no_main]
// ivdyn_fuzz::bag on libFuzzer's inputs (crates/ivdyn-fuzz/src/lib.rs)
libfuzzer_sys::fuzz_target!(|data: &[u8]| ivdyn_fuzz::bag(data));

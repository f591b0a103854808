//! Fuzz target: `pumpcyl::fuzzing::record_mat` must never panic (see fuzz/README.md).
#![no_main]

libfuzzer_sys::fuzz_target!(|data: &[u8]| pumpcyl::fuzzing::record_mat(data));

//! Fuzz target: `pumpcyl::fuzzing::record_csv` must never panic (see fuzz/README.md).
#![no_main]

libfuzzer_sys::fuzz_target!(|data: &[u8]| pumpcyl::fuzzing::record_csv(data));

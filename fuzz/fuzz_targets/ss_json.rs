//! Fuzz target: `pumpcyl::fuzzing::ss_json` must never panic (see fuzz/README.md).
#![no_main]

libfuzzer_sys::fuzz_target!(|data: &[u8]| pumpcyl::fuzzing::ss_json(data));

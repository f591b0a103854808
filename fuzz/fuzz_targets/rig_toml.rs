//! Fuzz target: `pumpcyl::fuzzing::rig_toml` must never panic (see fuzz/README.md).
#![no_main]

libfuzzer_sys::fuzz_target!(|data: &[u8]| pumpcyl::fuzzing::rig_toml(data));

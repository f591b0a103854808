//! No code. This crate only names features of shared dependencies so that the test build and
//! the Python extension's build compile those dependencies once, with one feature set
//! (Cargo.toml; docs/architecture.md#build-times).

//! The FMU's shared library (crates/fmu, FMI 2.0 Co-Simulation for Linux x86-64), compiled by
//! this crate's build script and embedded, so the command line and the Python package write
//! self-contained FMUs (docs/fmu.md).

/// The shared library's bytes; empty on a host other than Linux x86-64.
pub const SHARED_LIBRARY: &[u8] = include_bytes!(concat!(env!("OUT_DIR"), "/pumpcyl.so"));

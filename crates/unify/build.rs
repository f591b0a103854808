//! Nothing to build: the crate exists for its build-dependency's features (Cargo.toml).
fn main() {}

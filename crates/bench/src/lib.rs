//! pumpcyl's criterion benchmarks live in `benches/`; run them with `cargo bench -p pumpcyl-bench`.

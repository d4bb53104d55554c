//! Benchmark (FOUNDATION STUB: being built).
fn main() {}

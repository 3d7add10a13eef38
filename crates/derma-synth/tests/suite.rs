//! The integration tests of derma-synth as one test binary (one build and link instead of one per
//! file; `cargo test -p derma-synth --test suite FILE::` runs one file's tests).

#[cfg(feature = "gpu")]
mod gpu;
mod robust_files;
mod synthesis;

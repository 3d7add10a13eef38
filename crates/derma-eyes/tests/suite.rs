//! The integration tests of derma-eyes as one test binary (one build and link instead of one per
//! file; `cargo test -p derma-eyes --test suite FILE::` runs one file's tests).

mod eyes;
mod robust_animate;
mod robust_files;

//! The integration tests of derma-photo as one test binary (one build and link instead of one per
//! file; `cargo test -p derma-photo --test suite FILE::` runs one file's tests).

mod ground_truth;
mod held_out;
mod robust_files;
mod robust_jobs;

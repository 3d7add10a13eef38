//! The integration tests of derma as one test binary (one build and link instead of one per
//! file; `cargo test -p derma --test suite FILE::` runs one file's tests).

mod batch_cli;
mod cli;
mod composition;
mod doc_commands;
mod eyes_cli;
mod head_frame_cli;
mod photo_cli;
mod precompute_cli;
mod render_cli;
mod rig_cli;
mod synth_cli;
mod tidy;
mod wrinkles;

#[allow(dead_code)] // each file uses some of the helpers
mod common;

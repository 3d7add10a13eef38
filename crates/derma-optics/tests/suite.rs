//! The integration tests of derma-optics as one test binary (one build and link instead of one per
//! file; `cargo test -p derma-optics --test suite FILE::` runs one file's tests).

mod furnace;
mod precompute;
mod robust_grid_dir;
mod robust_inputs;
mod validation;

//! The integration tests of derma-skin as one test binary (one build and link instead of one per
//! file; `cargo test -p derma-skin --test suite FILE::` runs one file's tests).

mod albedo_compare;
mod detail_regions;
mod fitted_head;
mod hair;
mod lake;
mod pipeline;
mod regional_color;
mod relief;
#[cfg(feature = "gpu")]
mod render;
mod robust_files;
mod robust_inputs;
mod streamed;

//! Faces from photographs, after Tarini, Yamauchi, Haber and Seidel 2002, "Texturing Faces":
//!
//! - [`resection`]: cameras from 2D–3D feature points (DLT + Levenberg–Marquardt), read by
//!   [`correspondences`] from JSON/CSV or MediaPipe's 468-point topology.
//! - [`unwrap`]: a single-chart, flip-free, stretch-minimising parameterisation with the paper's
//!   view-dependent weight (§3.1), over [`topology`]'s disc check.
//! - [`bake`]: resampling the photos into that texture (§3.2) with visibility by ray casting,
//!   [`gain`] compensation and [`blend`]'s multiresolution splines.
//! - [`iris`] and [`teeth`]: textures for the eye globes and teeth from single photos (§4).
//! - [`chromophores`]: melanin and hemoglobin maps from a baked texture through derma's skin
//!   colour LUT (beyond the paper), the maps `derma rig` animates.
//! - [`synthetic`]: ground truth — photos of the built-in head rendered from known cameras.

#![warn(missing_docs)]

pub mod bake;
pub mod blend;
pub mod camera;
pub mod chromophores;
pub mod correspondences;
pub mod delight;
pub mod error;
pub mod files;
pub mod gain;
pub mod iris;
pub mod light_model;
pub mod photo;
pub mod register;
pub mod resection;
pub mod synthetic;
pub mod teeth;
pub mod topology;
pub mod unwrap;

pub use camera::Camera;
pub use error::{PhotoError, Result};

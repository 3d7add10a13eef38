//! Core types shared by every derma crate.
//!
//! - [`map::Map`]: a planar `f32` image with a size, the unit every stage exchanges.
//! - [`rng::Philox`]: a counter-based random generator keyed by (seed, stream, index), so that a
//!   random draw never depends on thread order (and can be reproduced on a GPU).
//! - [`color`]: spectra on the 380–780 nm grid, the CIE 1931 observer, XYZ ↔ linear sRGB.
//! - [`image_io`]: PNG (8/16-bit) and OpenEXR reading and atomic writing; [`exr_writer`]: EXR
//!   files streamed from their rows, blocks compressed in parallel.
//! - [`mesh`]: triangle meshes and units; [`mesh_file`]: OBJ and glTF/GLB loading ([`gltf_scene`]:
//!   glTF as the web ships it; [`mesh_parts`]: which parts are the skin); [`head_mesh`]: a user's
//!   head mesh in derma's frame, and [`raster`]: UV-space rasterisation of a mesh
//!   into per-texel surface points.
//! - [`progress`]: the one way a long job reports (stages, units, steps, notes, timings).
//! - [`gpu`]: the one device choice ([`Device`]: auto, cpu, gpu), typed [`GpuError`]s and, with
//!   the `gpu` feature, the shared wgpu context.
//! - [`numerics`]: the one numerics module (small dense solves, Levenberg–Marquardt, NNLS;
//!   LU, Cholesky, QR, SVD, symmetric eigen and sparse Cholesky of its own).
//! - [`sh`]: order-2 spherical harmonics and shadowed irradiance transfer over a [`bvh`].
//! - [`atomic`], [`report`], [`memory`], [`dtab`], [`plot`]: atomic outputs that spare inputs,
//!   reports with hashes, memory checks, derma's table format, SVG plots.
//!
//! Data flow: every crate reads inputs through [`image_io`] and [`mesh`], draws its random
//! numbers from [`rng`], reports through [`progress`], runs on the [`Device`] of [`gpu`] and
//! writes through [`atomic`].

#![warn(missing_docs)]

pub mod atomic;
pub mod bvh;
mod cie_table;
pub mod color;
pub mod dtab;
pub mod error;
pub mod exr_writer;
pub mod gltf_scene;
pub mod gpu;
pub mod head_mesh;
pub mod image;
pub mod image_io;
pub mod map;
pub mod memory;
pub mod mesh;
pub mod mesh_file;
pub mod mesh_parts;
pub mod numerics;
pub mod plot;
pub mod progress;
pub mod pyramid;
pub mod raster;
pub mod report;
pub mod rng;
pub mod sh;
pub mod shard;

pub use error::{CoreError, Invalid, Result};
pub use gpu::{Device, GpuError};
pub use map::Map;
pub use progress::{Note, Progress, Silent, Unit};

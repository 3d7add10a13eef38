//! derma-export: derma where its users look (docs/render.md). The engine GLB of a texture set
//! on the built-in head or a user mesh, with loose maps under derma, Substance or Unreal names
//! ([`glb`]); the web viewer's export of a set and its rig as 16-bit PNGs ([`web`]); the
//! viewer's static server on localhost ([`serve`]); `derma skin` with its GLB ([`skin`]); and `derma render` from files, a rig frame's
//! colour included ([`files`]). It sits above the domain crates and the renderer, which it uses;
//! derma-batch runs the main job with its GLB through it.

#![warn(missing_docs)]

pub mod error;
pub mod files;
pub mod glb;
pub mod serve;
pub mod skin;
pub mod web;

pub use error::{ExportError, Result};

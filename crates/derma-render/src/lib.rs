//! derma-render: seeing derma's skin as users will, and the only code that draws. A wgpu
//! renderer (the `gpu` feature; headless; Mesa's lavapipe in CI, any Vulkan/Metal/DX12 GPU
//! otherwise) that draws a
//! head or a user mesh with
//! a derma texture set — diffuse light scattered by the separable screen-space subsurface
//! blur of Jimenez et al. 2015 with Burley's normalized diffusion per channel (driven by
//! `sss_color`/`sss_radius`, the match table's fitted profile), GGX specular with Smith
//! visibility from the roughness and specular maps, a shadowed three-light setup with a
//! hemisphere environment, and eyes with a refracting cornea — plus turntables and contact
//! sheets; its CPU renderer ([`frame`]: a G-buffer on the one rasteriser [`raster`], steps over it
//! and the one CPU shading [`shade`], over the microfacet terms [`brdf`] that the shaders share)
//! with the previews' materials ([`cpu`]) for drawing without a GPU;
//! the lacrimal lake ([`lake`]) and Burley's profile ([`burley`]) it draws. It depends on
//! derma-core and derma-head only; the crates above draw through it. Exporting (GLB, web, the
//! viewer's server) and rendering from files are derma-export's.

#![warn(missing_docs)]

pub mod brdf;
pub mod burley;
pub mod camera;
pub mod cpu;
pub mod draw;
pub mod error;
pub mod frame;
#[cfg(feature = "gpu")]
pub mod gpu_texture;
pub mod lake;
pub mod lighting;
pub mod material;
pub mod raster;
pub mod rendered;
#[cfg(feature = "gpu")]
pub mod renderer;
pub mod scene;
pub mod shade;
pub mod sheet;
pub mod sss;
pub mod wrinkles;

pub use camera::View;
pub use draw::{renderer, CpuRenderer, Draw};
pub use error::{RenderError, Result};
pub use lighting::{Lighting, Setup};
pub use material::SkinMaps;
pub use rendered::Rendered;
#[cfg(feature = "gpu")]
pub use renderer::Renderer;
pub use scene::Scene;

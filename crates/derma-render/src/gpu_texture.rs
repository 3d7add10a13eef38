//! What the renderer's pipelines need on derma-core's shared GPU context: sampled textures with
//! CPU-built mip chains, samplers, render targets, validated shader modules and texture
//! read-back ([`RenderGpu`], on [`Gpu`]). Only the renderer draws, so these live beside it.

use derma_core::gpu::{Gpu, GpuError};
use derma_core::Map;

/// A sampled texture's texel format as derma uploads it.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum TexelFormat {
    /// 8-bit colour, sRGB-encoded (decoded to linear by the sampler).
    Srgb8,
    /// 8-bit linear data (roughness, specular, masks).
    Linear8,
    /// 16-bit float linear data (normals, distances, anything needing more than 8 bits).
    Float16,
}

impl TexelFormat {
    fn wgpu(self) -> wgpu::TextureFormat {
        match self {
            TexelFormat::Srgb8 => wgpu::TextureFormat::Rgba8UnormSrgb,
            TexelFormat::Linear8 => wgpu::TextureFormat::Rgba8Unorm,
            TexelFormat::Float16 => wgpu::TextureFormat::Rgba16Float,
        }
    }
}

/// Number of mip levels of a `w`×`h` texture down to 1×1.
pub fn mip_levels(w: usize, h: usize) -> u32 {
    usize::BITS - w.max(h).max(1).leading_zeros()
}

/// The next mip level of a linear RGBA image (2×2 box filter; odd edges repeat their last
/// texel).
fn downsample(src: &[[f32; 4]], w: usize, h: usize) -> (Vec<[f32; 4]>, usize, usize) {
    let (nw, nh) = ((w / 2).max(1), (h / 2).max(1));
    let mut out = vec![[0.0f32; 4]; nw * nh];
    for y in 0..nh {
        for x in 0..nw {
            let mut acc = [0.0f32; 4];
            for (dx, dy) in [(0, 0), (1, 0), (0, 1), (1, 1)] {
                let sx = (2 * x + dx).min(w - 1);
                let sy = (2 * y + dy).min(h - 1);
                let p = src[sy * w + sx];
                for k in 0..4 {
                    acc[k] += 0.25 * p[k];
                }
            }
            out[y * nw + x] = acc;
        }
    }
    (out, nw, nh)
}

/// Linear RGBA texels of up to four maps (missing channels: 0, alpha 1).
pub fn rgba_of(maps: &[&Map]) -> (Vec<[f32; 4]>, usize, usize) {
    assert!(!maps.is_empty() && maps.len() <= 4, "1 to 4 channels");
    let (w, h) = (maps[0].width(), maps[0].height());
    let px = (0..w * h)
        .map(|i| {
            let mut p = [0.0, 0.0, 0.0, 1.0];
            for (k, m) in maps.iter().enumerate() {
                p[k] = m.data()[i];
            }
            p
        })
        .collect();
    (px, w, h)
}

fn encode(level: &[[f32; 4]], format: TexelFormat) -> Vec<u8> {
    let q = |v: f32| (v.clamp(0.0, 1.0) * 255.0 + 0.5) as u8;
    match format {
        TexelFormat::Srgb8 => level
            .iter()
            .flat_map(|p| {
                [
                    q(derma_core::color::srgb_encode(p[0])),
                    q(derma_core::color::srgb_encode(p[1])),
                    q(derma_core::color::srgb_encode(p[2])),
                    q(p[3]),
                ]
            })
            .collect(),
        TexelFormat::Linear8 => level.iter().flat_map(|p| p.map(q)).collect(),
        TexelFormat::Float16 => level
            .iter()
            .flat_map(|p| p.map(|v| half::f16::from_f32(v).to_bits()))
            .flat_map(u16::to_le_bytes)
            .collect(),
    }
}

/// The renderer's GPU resources, made on derma-core's context.
pub trait RenderGpu {
    /// A WGSL shader module, validated.
    fn shader_module(&self, label: &str, source: &str) -> Result<wgpu::ShaderModule, GpuError>;

    /// A sampled 2D texture of linear RGBA texels (`w`×`h`, row-major from the top) with a full
    /// mip chain built on the CPU (box filter in linear space), uploaded in `format`.
    fn texture(
        &self,
        label: &str,
        texels: &[[f32; 4]],
        w: usize,
        h: usize,
        format: TexelFormat,
    ) -> wgpu::Texture;

    /// A trilinear, 8× anisotropic sampler; `repeat` wraps (tileable maps), else clamps.
    fn sampler(&self, label: &str, repeat: bool) -> wgpu::Sampler;

    /// A render target (`w`×`h`, one level) that can also be sampled and copied out.
    fn render_target(
        &self,
        label: &str,
        w: u32,
        h: u32,
        format: wgpu::TextureFormat,
    ) -> wgpu::Texture;

    /// Reads a whole single-level texture with 4- or 8-byte texels back to the host, rows
    /// tightly packed (wgpu's 256-byte row alignment removed).
    fn read_texture(&self, tex: &wgpu::Texture) -> Result<Vec<u8>, GpuError>;
}

impl RenderGpu for Gpu {
    fn shader_module(&self, label: &str, source: &str) -> Result<wgpu::ShaderModule, GpuError> {
        self.validated(label, || {
            self.device
                .create_shader_module(wgpu::ShaderModuleDescriptor {
                    label: Some(label),
                    source: wgpu::ShaderSource::Wgsl(source.into()),
                })
        })
    }

    fn texture(
        &self,
        label: &str,
        texels: &[[f32; 4]],
        w: usize,
        h: usize,
        format: TexelFormat,
    ) -> wgpu::Texture {
        assert_eq!(texels.len(), w * h, "{label}: texel count");
        let levels = mip_levels(w, h);
        let tex = self.device.create_texture(&wgpu::TextureDescriptor {
            label: Some(label),
            size: wgpu::Extent3d {
                width: w as u32,
                height: h as u32,
                depth_or_array_layers: 1,
            },
            mip_level_count: levels,
            sample_count: 1,
            dimension: wgpu::TextureDimension::D2,
            format: format.wgpu(),
            usage: wgpu::TextureUsages::TEXTURE_BINDING | wgpu::TextureUsages::COPY_DST,
            view_formats: &[],
        });
        let bpp = if format == TexelFormat::Float16 { 8 } else { 4 };
        let mut level: std::borrow::Cow<[[f32; 4]]> = texels.into();
        let (mut lw, mut lh) = (w, h);
        for mip in 0..levels {
            self.queue.write_texture(
                wgpu::TexelCopyTextureInfo {
                    texture: &tex,
                    mip_level: mip,
                    origin: wgpu::Origin3d::ZERO,
                    aspect: wgpu::TextureAspect::All,
                },
                &encode(&level, format),
                wgpu::TexelCopyBufferLayout {
                    offset: 0,
                    bytes_per_row: Some((lw * bpp) as u32),
                    rows_per_image: Some(lh as u32),
                },
                wgpu::Extent3d {
                    width: lw as u32,
                    height: lh as u32,
                    depth_or_array_layers: 1,
                },
            );
            if mip + 1 < levels {
                let (next, nw, nh) = downsample(&level, lw, lh);
                level = next.into();
                (lw, lh) = (nw, nh);
            }
        }
        tex
    }

    fn sampler(&self, label: &str, repeat: bool) -> wgpu::Sampler {
        let mode = if repeat {
            wgpu::AddressMode::Repeat
        } else {
            wgpu::AddressMode::ClampToEdge
        };
        self.device.create_sampler(&wgpu::SamplerDescriptor {
            label: Some(label),
            address_mode_u: mode,
            address_mode_v: mode,
            address_mode_w: mode,
            mag_filter: wgpu::FilterMode::Linear,
            min_filter: wgpu::FilterMode::Linear,
            mipmap_filter: wgpu::MipmapFilterMode::Linear,
            anisotropy_clamp: 8,
            ..Default::default()
        })
    }

    fn render_target(
        &self,
        label: &str,
        w: u32,
        h: u32,
        format: wgpu::TextureFormat,
    ) -> wgpu::Texture {
        self.device.create_texture(&wgpu::TextureDescriptor {
            label: Some(label),
            size: wgpu::Extent3d {
                width: w,
                height: h,
                depth_or_array_layers: 1,
            },
            mip_level_count: 1,
            sample_count: 1,
            dimension: wgpu::TextureDimension::D2,
            format,
            usage: wgpu::TextureUsages::RENDER_ATTACHMENT
                | wgpu::TextureUsages::TEXTURE_BINDING
                | wgpu::TextureUsages::COPY_SRC,
            view_formats: &[],
        })
    }

    fn read_texture(&self, tex: &wgpu::Texture) -> Result<Vec<u8>, GpuError> {
        let (w, h) = (tex.width() as usize, tex.height() as usize);
        let bpp = tex.format().block_copy_size(None).expect("a colour format") as usize;
        let row = w * bpp;
        let padded = row.div_ceil(256) * 256;
        let staging = self.device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("texture read back"),
            size: (padded * h) as u64,
            usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        let mut enc = self.device.create_command_encoder(&Default::default());
        enc.copy_texture_to_buffer(
            tex.as_image_copy(),
            wgpu::TexelCopyBufferInfo {
                buffer: &staging,
                layout: wgpu::TexelCopyBufferLayout {
                    offset: 0,
                    bytes_per_row: Some(padded as u32),
                    rows_per_image: Some(h as u32),
                },
            },
            tex.size(),
        );
        self.queue.submit([enc.finish()]);
        let slice = staging.slice(..);
        slice.map_async(wgpu::MapMode::Read, |_| {});
        self.wait("reading a texture back")?;
        let data = slice.get_mapped_range().map_err(|e| GpuError::Device {
            during: "mapping a texture",
            detail: e.to_string(),
        })?;
        let mut out = Vec::with_capacity(row * h);
        for y in 0..h {
            out.extend_from_slice(&data[y * padded..y * padded + row]);
        }
        drop(data);
        staging.unmap();
        Ok(out)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn mip_chain_reaches_one_texel_and_box_filter_keeps_the_mean() {
        assert_eq!(mip_levels(1, 1), 1);
        assert_eq!(mip_levels(2048, 2048), 12);
        assert_eq!(mip_levels(5, 3), 3);
        let src: Vec<[f32; 4]> = (0..16).map(|i| [i as f32, 0.0, 1.0, 1.0]).collect();
        let (d, w, h) = downsample(&src, 4, 4);
        assert_eq!((w, h), (2, 2));
        let mean = |v: &[[f32; 4]]| v.iter().map(|p| p[0]).sum::<f32>() / v.len() as f32;
        assert!((mean(&d) - mean(&src)).abs() < 1e-6);
        // Top-left 2×2 block: 0, 1, 4, 5.
        assert_eq!(d[0][0], 2.5);
    }

    #[test]
    fn encoding_round_trips_within_its_precision() {
        let level = [[0.5, 0.2, 0.0, 1.0]];
        let s = encode(&level, TexelFormat::Srgb8);
        assert_eq!(
            s[0],
            (derma_core::color::srgb_encode(0.5) * 255.0 + 0.5) as u8
        );
        let f = encode(&level, TexelFormat::Float16);
        assert_eq!(f.len(), 8);
        assert_eq!(
            half::f16::from_bits(u16::from_le_bytes([f[2], f[3]])).to_f32(),
            half::f16::from_f32(0.2).to_f32()
        );
    }
}

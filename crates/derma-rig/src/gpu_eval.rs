//! Rig evaluation on the GPU (`rig.wgsl` on wgpu; Mesa's lavapipe in CI): the run-time form the
//! paper argues for (Jimenez et al. 2010 §6), with the same arithmetic as the CPU path in
//! `evaluate.rs`. Static inputs are uploaded once; a frame uploads only its weights.

use crate::basis::Rig;
use crate::error::{invalid, Result};
use derma_core::gpu::GpuCell;
use derma_core::Map;
use derma_shading::skin_color_lut::SkinColorLut;

use crate::rig_dir::SHADER;
const WORKGROUP: usize = 64;

#[repr(C)]
#[derive(Clone, Copy, bytemuck::Pod, bytemuck::Zeroable)]
struct Params {
    width: u32,
    height: u32,
    basis_width: u32,
    basis_height: u32,
    layers: u32,
    lut_n: u32,
    global_scale: f32,
    melanin_max: f32,
    blood_max: f32,
    has_skin: u32,
    pad: [u32; 2],
}

struct Pipelines {
    layout: wgpu::BindGroupLayout,
    /// Eq. 6's weighted sum at the basis resolution.
    combine: wgpu::ComputePipeline,
    /// Upsampling, H and the colour, per texel.
    main: wgpu::ComputePipeline,
}

/// The rig pipelines, compiled once per process.
static PIPELINES: GpuCell<Pipelines> = GpuCell::new();

fn pipelines() -> Result<(&'static derma_core::gpu::Gpu, &'static Pipelines)> {
    Ok(PIPELINES.get_or_init(|ctx| {
        // Binding 0 the parameters, 1–6 read-only inputs, 7–9 the outputs and the scratch.
        let (layout, [combine, main]) =
            ctx.entry_points("rig.wgsl", SHADER, 6, 3, ["combine", "main"])?;
        Ok(Pipelines {
            layout,
            combine,
            main,
        })
    })?)
}

/// A rig resident on the GPU.
pub struct GpuRig {
    size: (usize, usize),
    layers: usize,
    params: Params,
    params_buf: wgpu::Buffer,
    weights_buf: wgpu::Buffer,
    hemoglobin_buf: wgpu::Buffer,
    color_buf: wgpu::Buffer,
    bind: wgpu::BindGroup,
    /// Texels of the basis maps (threads of the `combine` dispatch).
    basis_texels: usize,
}

impl GpuRig {
    /// Uploads `rig`, `melanin` (full resolution) and `lut`.
    pub fn new(rig: &Rig, melanin: &Map, lut: &SkinColorLut) -> Result<Self> {
        let (ctx, pipes) = pipelines()?;
        let (w, h) = rig.size();
        rig.check_melanin(melanin)?;
        let (bw, bh) = rig.basis_size();
        let layers = rig.targets.len() + 1;
        let mut basis = Vec::with_capacity(layers * 2 * bw * bh);
        basis.extend_from_slice(rig.neutral_mean.data());
        basis.extend(std::iter::repeat_n(1.0f32, bw * bh));
        for t in &rig.targets {
            basis.extend_from_slice(t.bias.data());
            basis.extend_from_slice(t.scale.data());
        }
        let lut_data: Vec<f32> = lut.rgb.iter().flatten().copied().collect();
        // The largest buffers: the colour output (16 bytes a texel) and the basis.
        ctx.check_storage(
            format!("the rig's colour output at {w}×{h}"),
            (w * h * 16) as u64,
        )?;
        ctx.check_storage(
            format!("the rig's basis ({layers} layers of {bw}×{bh})"),
            (basis.len() * 4) as u64,
        )?;
        let d = &ctx.device;
        let init = |label, bytes: &[u8], usage| ctx.upload(label, bytes, usage);
        let read = wgpu::BufferUsages::STORAGE;
        let h0_buf = init("h0", bytemuck::cast_slice(rig.h0.data()), read);
        let mel_buf = init("melanin", bytemuck::cast_slice(melanin.data()), read);
        let basis_buf = init("basis", bytemuck::cast_slice(&basis), read);
        let lut_buf = init("lut", bytemuck::cast_slice(&lut_data), read);
        // The set's skin, 16 bytes a texel: its base colour's 8-bit sRGB codes (decoded in the
        // shader as derma_core::color::srgb_decode does), then d1 and d2 as six half floats
        // (relative error ≤ 2⁻¹¹: at most 5·10⁻⁵ of colour over the response's range).
        let pack = derma_core::gpu::pack2x16float;
        let skin: Vec<[u32; 4]> = match &rig.skin {
            Some(s) => (0..w * h)
                .map(|i| {
                    let (d1, d2) = s.at(i);
                    let [r, g, b] = s.base[i].map(u32::from);
                    [
                        r | (g << 8) | (b << 16),
                        pack(d1[0], d1[1]),
                        pack(d1[2], d2[0]),
                        pack(d2[1], d2[2]),
                    ]
                })
                .collect(),
            None => vec![[0; 4]],
        };
        if rig.skin.is_some() {
            ctx.check_storage(
                format!("the rig's skin response at {w}×{h}"),
                (w * h * 16) as u64,
            )?;
        }
        let skin_buf = init("skin", bytemuck::cast_slice(&skin), read);
        let weights_buf = init(
            "weights",
            bytemuck::cast_slice(&vec![0.0f32; layers]),
            read | wgpu::BufferUsages::COPY_DST,
        );
        let out = |label, bytes: u64| {
            d.create_buffer(&wgpu::BufferDescriptor {
                label: Some(label),
                size: bytes,
                usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC,
                mapped_at_creation: false,
            })
        };
        let hemoglobin_buf = out("hemoglobin", (w * h * 4) as u64);
        let color_buf = out("colour", (w * h * 16) as u64);
        let combined_buf = out("combined basis", (bw * bh * 8) as u64);
        let params = Params {
            width: w as u32,
            height: h as u32,
            basis_width: bw as u32,
            basis_height: bh as u32,
            layers: layers as u32,
            lut_n: lut.options.size as u32,
            global_scale: 1.0,
            melanin_max: lut.options.melanin_max as f32,
            blood_max: lut.options.blood_max as f32,
            has_skin: rig.skin.is_some() as u32,
            pad: [0; 2],
        };
        let params_buf = init(
            "params",
            bytemuck::bytes_of(&params),
            wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
        );
        let bind = ctx.bind_buffers(
            "rig",
            &pipes.layout,
            &[
                &params_buf,
                &weights_buf,
                &h0_buf,
                &mel_buf,
                &basis_buf,
                &lut_buf,
                &skin_buf,
                &hemoglobin_buf,
                &color_buf,
                &combined_buf,
            ],
        );
        Ok(Self {
            size: (w, h),
            layers,
            params,
            params_buf,
            weights_buf,
            hemoglobin_buf,
            color_buf,
            bind,
            basis_texels: bw * bh,
        })
    }

    /// Evaluates weights `w` (w_0 first) under global scale `g`: the hemoglobin map and the
    /// linear-sRGB colour maps.
    pub fn render(&self, w: &[f32], g: f32) -> Result<(Map, [Map; 3])> {
        let ctx = self.submit(w, g)?;
        let (fw, fh) = self.size;
        let hb: Vec<f32> = ctx.read_back(&self.hemoglobin_buf, fw * fh)?;
        let cb: Vec<[f32; 4]> = ctx.read_back(&self.color_buf, fw * fh)?;
        let rgb = Map::planes(fw, fh, |i| [cb[i][0], cb[i][1], cb[i][2]]);
        Ok((Map::from_vec(fw, fh, hb)?, rgb))
    }

    /// Seconds per frame as an engine runs the rig: `frames` frames of new weights (uploads
    /// and dispatches) submitted back to back and waited for once, nothing read back; after
    /// one warm-up frame. On a software adapter (lavapipe) this times the CPU's emulation.
    pub fn seconds_per_frame(&self, w: &[f32], g: f32, frames: usize) -> Result<f64> {
        let ctx = self.submit(w, g)?;
        ctx.wait("the warm-up frame")?;
        let frames = frames.max(1);
        let start = std::time::Instant::now();
        for k in 0..frames {
            // Weights that change each frame, as an animation's do.
            let wk: Vec<f32> = w
                .iter()
                .map(|&v| v * (1.0 + 0.01 * (k % 7) as f32))
                .collect();
            self.submit(&wk, g)?;
        }
        ctx.wait("the timed frames")?;
        Ok(start.elapsed().as_secs_f64() / frames as f64)
    }

    /// Uploads the frame's weights and scale and dispatches the shader (no waiting).
    fn submit(&self, w: &[f32], g: f32) -> Result<&'static derma_core::gpu::Gpu> {
        if w.len() != self.layers {
            return Err(invalid(
                "weights",
                format!(
                    "{} weights for {} layers (neutral + targets)",
                    w.len(),
                    self.layers
                ),
            ));
        }
        let (ctx, pipes) = pipelines()?;
        let params = Params {
            global_scale: g,
            ..self.params
        };
        ctx.queue
            .write_buffer(&self.params_buf, 0, bytemuck::bytes_of(&params));
        ctx.queue
            .write_buffer(&self.weights_buf, 0, bytemuck::cast_slice(w));
        let (fw, fh) = self.size;
        let (cx, cy) = derma_core::gpu::grid(self.basis_texels, WORKGROUP);
        let (gx, gy) = derma_core::gpu::grid(fw * fh, WORKGROUP);
        let mut enc = ctx.device.create_command_encoder(&Default::default());
        {
            let mut pass = enc.begin_compute_pass(&Default::default());
            pass.set_bind_group(0, &self.bind, &[]);
            // wgpu orders the two dispatches: `main` reads what `combine` wrote.
            pass.set_pipeline(&pipes.combine);
            pass.dispatch_workgroups(cx, cy, 1);
            pass.set_pipeline(&pipes.main);
            pass.dispatch_workgroups(gx, gy, 1);
        }
        ctx.queue.submit([enc.finish()]);
        Ok(ctx)
    }
}

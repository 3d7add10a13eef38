//! The texel-level coherent correction ([`crate::correction`]: Ashikhmin 2001 §3, in parallel
//! after Lefebvre & Hoppe 2005 §3.3–3.4) on the GPU, `correction.wgsl`: the same decisions.
//!
//! The canvas's codes and sources go up once; every subpass decides from the state before it and
//! then copies the chosen exemplar texels, on the GPU; only the final sources come back, and the
//! host copies the decided texels' values (exact copies of exemplar texels, as on the CPU).

use crate::canvas::{Canvas, NO_SOURCE};
use crate::error::Result;
use crate::exemplar::ExemplarSet;
use crate::guide::Guide;
use derma_core::gpu::{grid, Gpu, GpuCell};

/// The shader.
pub const SHADER: &str = include_str!("correction.wgsl");
const WORKGROUP: usize = 64;
/// Bit of a returned source exemplar that marks a texel the correction decided
/// (correction.wgsl's DECIDED).
const DECIDED: u32 = 1 << 31;

#[repr(C)]
#[derive(Clone, Copy, bytemuck::Pod, bytemuck::Zeroable)]
struct Params {
    width: u32,
    height: u32,
    channels: u32,
    wrap: u32,
    has_guide: u32,
    ox: u32,
    oy: u32,
    cols: u32,
    count: u32,
    pad: [u32; 3],
}

struct Pipelines {
    layout: wgpu::BindGroupLayout,
    decide: wgpu::ComputePipeline,
    apply: wgpu::ComputePipeline,
}

static PIPELINES: GpuCell<Pipelines> = GpuCell::new();

/// The correction's state on the GPU: the canvas's codes and sources and the buffers and
/// bindings of the subpasses.
pub(crate) struct GpuCorrection {
    ctx: &'static Gpu,
    pipes: &'static Pipelines,
    params: wgpu::Buffer,
    src: wgpu::Buffer,
    src_ex: wgpu::Buffer,
    group: wgpu::BindGroup,
    width: usize,
    height: usize,
    channels: usize,
    wrap: bool,
    guided: bool,
}

impl GpuCorrection {
    /// Uploads the canvas, the exemplars' codes and the guide's exemplar per texel; `None`
    /// when the canvas is larger than one storage binding of the adapter (the caller then
    /// corrects on the CPU).
    pub(crate) fn new(
        canvas: &Canvas,
        set: &ExemplarSet,
        guide: Option<&Guide>,
    ) -> Result<Option<Self>> {
        let (ctx, pipes) = PIPELINES.get_or_init(|ctx| {
            // Binding 0 uniform, 1–3 read-only storage, 4–7 read-write storage.
            let (layout, [decide, apply]) =
                ctx.entry_points("correction.wgsl", SHADER, 3, 4, ["decide", "apply"])?;
            Ok(Pipelines {
                layout,
                decide,
                apply,
            })
        })?;
        let (w, h, c) = (canvas.width, canvas.height, canvas.channels);
        let texels = w * h;
        let mut ex_info: Vec<u32> = Vec::with_capacity(set.exemplars.len() * 4);
        let mut ex_codes: Vec<u32> = Vec::new();
        for e in &set.exemplars {
            ex_info.extend_from_slice(&[
                e.width() as u32,
                e.height() as u32,
                ex_codes.len() as u32,
                0,
            ]);
            ex_codes.extend(e.codes.iter().map(|&v| v as u32));
        }
        let fits = |what: &str, bytes: usize| ctx.check_storage(what, bytes as u64).is_ok();
        if !fits("the canvas codes", texels * c * 4)
            || !fits("the exemplar codes", ex_codes.len() * 4)
        {
            return Ok(None);
        }
        let want: Vec<u32> = match guide {
            Some(g) => (0..texels)
                .map(|t| g.at(canvas, t % w, t / w) as u32)
                .collect(),
            None => vec![0],
        };
        let codes: Vec<u32> = canvas.codes.iter().map(|&v| v as u32).collect();
        let src_ex: Vec<u32> = canvas.src_exemplar.iter().map(|&e| e as u32).collect();
        let d = &ctx.device;
        use wgpu::BufferUsages as U;
        let init = |label, bytes: &[u8], usage| ctx.upload(label, bytes, usage);
        let params = d.create_buffer(&wgpu::BufferDescriptor {
            label: Some("correction params"),
            size: std::mem::size_of::<Params>() as u64,
            usage: U::UNIFORM | U::COPY_DST,
            mapped_at_creation: false,
        });
        let ex_info = init("exemplar info", bytemuck::cast_slice(&ex_info), U::STORAGE);
        let ex_codes = init(
            "exemplar codes",
            bytemuck::cast_slice(&ex_codes),
            U::STORAGE,
        );
        let want = init("wanted exemplars", bytemuck::cast_slice(&want), U::STORAGE);
        let codes = init("canvas codes", bytemuck::cast_slice(&codes), U::STORAGE);
        let src = init(
            "canvas sources",
            bytemuck::cast_slice(&canvas.src),
            U::STORAGE | U::COPY_SRC,
        );
        let src_ex = init(
            "canvas source exemplars",
            bytemuck::cast_slice(&src_ex),
            U::STORAGE | U::COPY_SRC,
        );
        // The most texels of one parity: (⌈w/2⌉ · ⌈h/2⌉).
        let choice = d.create_buffer(&wgpu::BufferDescriptor {
            label: Some("correction choices"),
            size: (w.div_ceil(2) * h.div_ceil(2) * 8) as u64,
            usage: U::STORAGE,
            mapped_at_creation: false,
        });
        let group = ctx.bind_buffers(
            "correction",
            &pipes.layout,
            &[
                &params, &ex_info, &ex_codes, &want, &codes, &src, &src_ex, &choice,
            ],
        );
        Ok(Some(Self {
            ctx,
            pipes,
            params,
            src,
            src_ex,
            group,
            width: w,
            height: h,
            channels: c,
            wrap: canvas.tile,
            guided: guide.is_some(),
        }))
    }

    /// One subpass: the texels of parity (ox, oy) decide from the state before it, then copy
    /// their choices.
    pub(crate) fn subpass(&self, ox: usize, oy: usize) -> Result<()> {
        let (ctx, pipes) = (self.ctx, self.pipes);
        let cols = (self.width - ox).div_ceil(2);
        let count = cols * (self.height - oy).div_ceil(2);
        let p = Params {
            width: self.width as u32,
            height: self.height as u32,
            channels: self.channels as u32,
            wrap: u32::from(self.wrap),
            has_guide: u32::from(self.guided),
            ox: ox as u32,
            oy: oy as u32,
            cols: cols as u32,
            count: count as u32,
            pad: [0; 3],
        };
        // The parameters are written before the submission that reads them.
        ctx.queue
            .write_buffer(&self.params, 0, bytemuck::bytes_of(&p));
        let dims = grid(count, WORKGROUP);
        let index = ctx.submit_passes(&self.group, &[(&pipes.decide, dims), (&pipes.apply, dims)]);
        ctx.wait_for(index, "correcting")?;
        Ok(())
    }

    /// Brings the sources back and makes every decided texel a copy of its exemplar texel
    /// (values, codes and source).
    pub(crate) fn finish(self, canvas: &mut Canvas, set: &ExemplarSet) -> Result<()> {
        let texels = self.width * self.height;
        let sources: Vec<u32> = self.ctx.read_back(&self.src, texels)?;
        let exemplars: Vec<u32> = self.ctx.read_back(&self.src_ex, texels)?;
        for (t, (&s, &e)) in sources.iter().zip(&exemplars).enumerate() {
            if e & DECIDED != 0 {
                debug_assert_ne!(s, NO_SOURCE);
                canvas.copy_texel(set, t, (e & 0xff) as usize, s as usize);
            }
        }
        Ok(())
    }
}

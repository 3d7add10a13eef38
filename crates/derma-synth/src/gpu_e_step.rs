//! The E-step of an optimisation pass (Shen et al. §3.3, after Kwatra et al. 2005 §3) in two bands
//! on the GPU, `e_step.wgsl`: every texel's value, source and codes, bit for bit as the CPU's.
//!
//! The host uploads the windows' matches, weights and costs (one word quadruple per window),
//! the cover lists and the exemplars' two bands; one dispatch blends all texels. Values, codes and sources
//! stay on the GPU (a `GpuCanvas`, which the optimiser's GPU path keeps), where the next pass
//! makes its coherent guesses (`guesses.wgsl`) and searches, until they are read back once after
//! the last pass (`gpu_optimize.rs`). Needs
//! 64-bit floats and integers (`SHADER_F64`, `SHADER_INT64`); without them, for a canvas
//! larger than the adapter binds, or for exemplars whose bands hold subnormal values, the caller
//! blends on the CPU.

use crate::canvas::Canvas;
use crate::e_step::{cover, Windows};
use crate::error::Result;
use crate::exemplar::{ExemplarSet, Quantizer};
use crate::resident::GpuCanvas;
use derma_core::gpu::{grid, Gpu, GpuCell};

/// The shader.
pub const SHADER: &str = include_str!("e_step.wgsl");
const WORKGROUP: usize = 64;

#[repr(C)]
#[derive(Clone, Copy, bytemuck::Pod, bytemuck::Zeroable)]
struct Params {
    width: u32,
    height: u32,
    channels: u32,
    cols: u32,
    count: u32,
    values_at: u32,
    pad: [u32; 2],
}

struct Pipelines {
    layout: wgpu::BindGroupLayout,
    blend: wgpu::ComputePipeline,
    quotients: wgpu::ComputePipeline,
}

static PIPELINES: GpuCell<Option<Pipelines>> = GpuCell::new();

/// The pipelines; `None` on a device without 64-bit floats and integers.
fn pipelines() -> Result<Option<(&'static Gpu, &'static Pipelines)>> {
    let (ctx, pipes) = PIPELINES.get_or_init(|ctx| {
        let needs = wgpu::Features::SHADER_F64 | wgpu::Features::SHADER_INT64;
        if !ctx.device.features().contains(needs) {
            return Ok(None);
        }
        // Binding 0 uniform, 1–5 read-only storage, 6–9 read-write storage.
        let (layout, [blend, quotients]) =
            ctx.entry_points("e_step.wgsl", SHADER, 5, 4, ["blend", "quotients"])?;
        Ok(Some(Pipelines {
            layout,
            blend,
            quotients,
        }))
    })?;
    Ok(pipes.as_ref().map(|p| (ctx, p)))
}

/// Runs `pipe` over `count` threads with `buffers` bound at 0, 1, 2, … and waits for it.
fn run(
    ctx: &Gpu,
    pipes: &Pipelines,
    pipe: &wgpu::ComputePipeline,
    buffers: &[wgpu::Buffer],
    count: usize,
    during: &'static str,
) -> Result<()> {
    let refs: Vec<&wgpu::Buffer> = buffers.iter().collect();
    let group = ctx.bind_buffers("e-step", &pipes.layout, &refs);
    let index = ctx.submit_passes(&group, &[(pipe, grid(count, WORKGROUP))]);
    ctx.wait_for(index, during)?;
    Ok(())
}

/// The cover lists of both axes in `e_step.wgsl`'s layout: column offsets, row offsets, then
/// the (window, offset) pairs.
fn cover_words(b: &Windows, canvas: &Canvas) -> Vec<u32> {
    let cx = cover(canvas.width, &b.xs, b.w, canvas.tile);
    let cy = cover(canvas.height, &b.ys, b.w, canvas.tile);
    let heads = cx.len() + cy.len() + 2;
    let pairs: usize = cx.iter().chain(&cy).map(Vec::len).sum();
    let mut words = Vec::with_capacity(heads + 2 * pairs);
    words.resize(heads, 0);
    let mut at = 0;
    for lists in [&cx, &cy] {
        for list in lists.iter() {
            words[at] = words.len() as u32;
            at += 1;
            words.extend(list.iter().flat_map(|&(k, d)| [k, d]));
        }
        words[at] = words.len() as u32;
        at += 1;
    }
    words
}

/// The exemplars' bands in `e_step.wgsl`'s layout: per exemplar its width and where its low
/// band starts, then the low bands (with the offset of the first), and the high bands.
fn band_words(set: &ExemplarSet, bands: &[(Vec<f32>, Vec<f32>)]) -> (Vec<u32>, usize, Vec<u32>) {
    let mut exemplars: Vec<u32> = Vec::new();
    let values_at = 2 * set.exemplars.len();
    let mut at = values_at;
    for e in &set.exemplars {
        exemplars.extend([e.width() as u32, at as u32]);
        at += e.texture.data.len();
    }
    for (low, _) in bands {
        exemplars.extend(low.iter().map(|v| v.to_bits()));
    }
    let high: Vec<u32> = bands
        .iter()
        .flat_map(|(_, high)| high.iter().map(|v| v.to_bits()))
        .collect();
    (exemplars, values_at, high)
}

/// Each window's match as `e_step.wgsl` reads it: exemplar, exemplar texel, weight (its bits)
/// and cost.
fn window_words(set: &ExemplarSet, b: &Windows) -> Vec<[u32; 4]> {
    b.placed
        .iter()
        .zip(&b.weights)
        .zip(&b.costs)
        .map(|((&(ex, mx, my), &wk), &cost)| {
            let ew = set.exemplars[ex].width();
            [ex as u32, (my * ew + mx) as u32, wk.to_bits(), cost]
        })
        .collect()
}

/// Blends `canvas` on the GPU from the exemplars' `bands` ((low, high) per exemplar) and
/// returns the result, kept there; `None` where this device cannot (the caller then blends on
/// the CPU). The host's canvas gives only its size here and is left as it was.
pub(crate) fn e_step(
    canvas: &Canvas,
    set: &ExemplarSet,
    b: &Windows,
    bands: &[(Vec<f32>, Vec<f32>)],
) -> Result<Option<GpuCanvas>> {
    let Some((ctx, pipes)) = pipelines()? else {
        return Ok(None);
    };
    // A GPU may flush subnormal f32s to zero where it widens them to f64 (Vulkan leaves the
    // default denormal mode to the implementation); bands holding any blend on the CPU.
    if bands
        .iter()
        .any(|(low, high)| low.iter().chain(high).any(|v| v.is_subnormal()))
    {
        tracing::debug!("E-step on the CPU: the exemplars' bands hold subnormal values");
        return Ok(None);
    }
    let prepared = std::time::Instant::now();
    let (w, h, c) = (canvas.width, canvas.height, canvas.channels);
    let texels = w * h;
    let (exemplars, values_at, high) = band_words(set, bands);
    let windows = window_words(set, b);
    let cover = cover_words(b, canvas);
    let fits = |what: &str, bytes: usize| ctx.check_storage(what, bytes as u64).is_ok();
    if !fits("the blended values", texels * c * 4)
        || !fits("the exemplars' low bands", exemplars.len() * 4)
        || !fits("the exemplars' high bands", high.len() * 4)
        || !fits("the windows", windows.len() * 16)
        || !fits("the cover lists", cover.len() * 4)
        || exemplars.len() > u32::MAX as usize
    {
        return Ok(None);
    }
    let bounds: Vec<u32> = (0..c).flat_map(|k| set.quantizer.boundaries(k)).collect();
    use wgpu::BufferUsages as U;
    let init = |label, bytes: &[u8], usage| ctx.upload(label, bytes, usage);
    let params = Params {
        width: w as u32,
        height: h as u32,
        channels: c as u32,
        cols: b.xs.len() as u32,
        count: texels as u32,
        values_at: values_at as u32,
        pad: [0; 2],
    };
    let out = |label, words: usize| {
        ctx.device.create_buffer(&wgpu::BufferDescriptor {
            label: Some(label),
            size: (words * 4) as u64,
            usage: U::STORAGE | U::COPY_SRC,
            mapped_at_creation: false,
        })
    };
    let buffers = [
        init("e-step params", bytemuck::bytes_of(&params), U::UNIFORM),
        init("e-step windows", bytemuck::cast_slice(&windows), U::STORAGE),
        init("e-step cover", bytemuck::cast_slice(&cover), U::STORAGE),
        init(
            "e-step exemplars",
            bytemuck::cast_slice(&exemplars),
            U::STORAGE,
        ),
        init("e-step high bands", bytemuck::cast_slice(&high), U::STORAGE),
        init(
            "e-step boundaries",
            bytemuck::cast_slice(&bounds),
            U::STORAGE,
        ),
        out("canvas values", texels * c),
        out("e-step sources", texels),
        out("e-step source exemplars", texels),
        out("canvas codes", texels * c),
    ];
    drop((exemplars, high, windows, cover));
    let started = std::time::Instant::now();
    run(ctx, pipes, &pipes.blend, &buffers, texels, "blending")?;
    let blended = started.elapsed();
    let [_, _, _, _, _, _, values, sources, source_exemplars, codes] = buffers;
    tracing::debug!(
        "E-step on the GPU, {w}×{h}: preparation and uploads {:.1} ms, blend {:.1} ms",
        (started - prepared).as_secs_f64() * 1e3,
        blended.as_secs_f64() * 1e3,
    );
    Ok(Some(GpuCanvas {
        ctx,
        values,
        codes,
        sources,
        source_exemplars,
        width: w,
        height: h,
        channels: c,
        wrap: canvas.tile,
    }))
}

/// `e_step.wgsl`'s quotient of each pair (a, b) as f32, as Rust's `(a / b) as f32` gives it, for
/// finite a and b > 0 (normal or zero), and the quotient's code in channel 0 of `quantizer`;
/// `None` on a device without 64-bit floats and integers. A check of the shader's arithmetic
/// for tests.
#[doc(hidden)]
pub fn gpu_quotients(
    pairs: &[(f64, f64)],
    quantizer: &Quantizer,
) -> Result<Option<Vec<(f32, u8)>>> {
    let Some((ctx, pipes)) = pipelines()? else {
        return Ok(None);
    };
    if pairs.is_empty() {
        return Ok(Some(Vec::new()));
    }
    let n = pairs.len();
    let words: Vec<[u32; 4]> = pairs
        .iter()
        .map(|&(a, b)| {
            let (a, b) = (a.to_bits(), b.to_bits());
            [a as u32, (a >> 32) as u32, b as u32, (b >> 32) as u32]
        })
        .collect();
    let params = Params {
        width: 1,
        height: 1,
        channels: 1,
        cols: 1,
        count: n as u32,
        values_at: 0,
        pad: [0; 2],
    };
    use wgpu::BufferUsages as U;
    let init = |label, bytes: &[u8], usage| ctx.upload(label, bytes, usage);
    let zero = [0u32; 4];
    let out = vec![0u32; n];
    let buffers = [
        init("quotient params", bytemuck::bytes_of(&params), U::UNIFORM),
        init("quotient pairs", bytemuck::cast_slice(&words), U::STORAGE),
        init("unused", bytemuck::cast_slice(&zero), U::STORAGE),
        init("unused", bytemuck::cast_slice(&zero), U::STORAGE),
        init("unused", bytemuck::cast_slice(&zero), U::STORAGE),
        init(
            "boundaries",
            bytemuck::cast_slice(&quantizer.boundaries(0)),
            U::STORAGE,
        ),
        init(
            "quotients",
            bytemuck::cast_slice(&out),
            U::STORAGE | U::COPY_SRC,
        ),
        init("unused", bytemuck::cast_slice(&zero), U::STORAGE),
        init("unused", bytemuck::cast_slice(&zero), U::STORAGE),
        init(
            "codes",
            bytemuck::cast_slice(&out),
            U::STORAGE | U::COPY_SRC,
        ),
    ];
    run(ctx, pipes, &pipes.quotients, &buffers, n, "dividing")?;
    let bits: Vec<u32> = ctx.read_back(&buffers[6], n)?;
    let codes: Vec<u32> = ctx.read_back(&buffers[9], n)?;
    Ok(Some(
        bits.into_iter()
            .zip(codes)
            .map(|(b, q)| (f32::from_bits(b), q as u8))
            .collect(),
    ))
}

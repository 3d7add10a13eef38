//! The GPU backend: `optics.wgsl` on wgpu (Vulkan, Metal, DX12; Mesa lavapipe in CI). Same
//! algorithm and random stream as the CPU path, in f32, with each photon's values tallied in
//! 64-bit fixed point, so that GPU results are bit-identical from run to run and under any
//! [`Kernel`] layout.

use crate::error::Result;
use crate::layer::{Bottom, Surface};
use crate::run::Run;
use crate::tally::Tally;
use crate::transport::{Incidence, Prepared};
use derma_core::gpu::{GpuCell, GpuError};
use derma_core::progress::Progress;

const SHADER: &str = include_str!("optics.wgsl");
const WORKGROUP: u32 = 64;
/// Floats per (wavelength, layer) in the kernel's layer table (`optics.wgsl`, `L`).
const LAYER_FLOATS: usize = 7;
/// Fixed-point scale of the tallies (2^24 units per photon weight).
const FIXED: f64 = 16_777_216.0;

/// How the kernel is laid out on the device. None of it changes the results (integer tallies
/// of per-photon values; each photon has its own random stream): tests compare layouts.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Kernel {
    /// The form of Philox's products.
    pub products: Products,
    /// Workgroups (of 64 threads) per dispatch for large runs.
    pub groups: u64,
    /// Photons per thread and dispatch for large runs.
    pub photons_per_thread: u64,
}

impl Kernel {
    /// The layout for this device: native products where it has 64-bit integers; on a
    /// hardware GPU 2^20 threads a dispatch, four times what a data-centre GPU keeps resident
    /// (an H200 holds 132 SMs × 2048 threads: NVIDIA H100 Tensor Core GPU Architecture
    /// whitepaper, 2022), 32 photons each; on a software adapter (lavapipe, which
    /// runs a workgroup per CPU thread) 2^12 threads of 8 photons, so that a dispatch takes
    /// under a second there and progress moves.
    pub fn for_device() -> std::result::Result<Self, GpuError> {
        let ctx = derma_core::gpu::context()?;
        let products = if ctx.device.features().contains(wgpu::Features::SHADER_INT64) {
            Products::Native64
        } else {
            Products::Halves
        };
        // 16384 × 32 measured fastest on an H200 (BENCHMARKS.md, "GPU figures on an H200").
        let (groups, photons_per_thread) = if ctx.hardware { (16384, 32) } else { (64, 8) };
        Ok(Self {
            products,
            groups,
            photons_per_thread,
        })
    }
}

/// How the kernel forms Philox's 32×32 → 64-bit products; both give the same bits.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Products {
    /// From 16-bit halves (any device).
    Halves,
    /// One 64-bit multiplication (devices with `SHADER_INT64`).
    Native64,
}

/// The native-product form of `mulhilo`, swapped in for the halves where the device allows.
const MULHILO_NATIVE: &str = "fn mulhilo(a: u32, b: u32) -> vec2<u32> {
    let p = u64(a) * u64(b);
    return vec2<u32>(u32(p & 0xfffffffflu), u32(p >> 32u));
}
";

/// The transport pipelines, compiled once per process (halves, native products).
static PIPELINES: [GpuCell<wgpu::ComputePipeline>; 2] = [GpuCell::new(), GpuCell::new()];

/// The kernel's source with the products of `products`.
fn shader(products: Products) -> String {
    match products {
        Products::Halves => SHADER.to_string(),
        Products::Native64 => {
            let a = SHADER.find("// mulhilo begin").expect("marker");
            let b = SHADER.find("// mulhilo end").expect("marker");
            format!("{}{MULHILO_NATIVE}{}", &SHADER[..a], &SHADER[b..])
        }
    }
}

fn pipeline(
    products: Products,
) -> std::result::Result<
    (
        &'static derma_core::gpu::Gpu,
        &'static wgpu::ComputePipeline,
    ),
    GpuError,
> {
    PIPELINES[products as usize].get_or_init(|ctx| {
        ctx.compute_pipeline(
            "the transport shader (optics.wgsl)",
            &shader(products),
            "main",
        )
    })
}

#[repr(C)]
#[derive(Clone, Copy, bytemuck::Pod, bytemuck::Zeroable)]
struct Params {
    seed_lo: u32,
    seed_hi: u32,
    offset_lo: u32,
    offset_hi: u32,
    count: u32,
    lanes: u32,
    n_lambda: u32,
    n_layers: u32,
    incidence: u32,
    surface: u32,
    sigma: f32,
    bottom: u32,
    bottom_value: f32,
    n_above: f32,
    brdf_ti: u32,
    brdf_to: u32,
    brdf_phi: u32,
    channels: u32,
    profile_bins: u32,
    profile_dmax: f32,
}

fn fixed_to_f64(lo: u32, hi: u32) -> f64 {
    (((hi as u64) << 32 | lo as u64) as i64) as f64 / FIXED
}

/// Runs `run` on the GPU; `progress` advances by the photons of each dispatch.
pub fn run_gpu(run: &Run, progress: &dyn Progress) -> Result<Tally> {
    run_gpu_with(run, progress, &Kernel::for_device()?)
}

/// [`run_gpu`] with the given kernel layout (the results are the same).
pub fn run_gpu_with(run: &Run, progress: &dyn Progress, kernel: &Kernel) -> Result<Tally> {
    run.validate()?;
    let (ctx, pipeline) = pipeline(kernel.products)?;
    let prepared: Vec<Prepared> = run.stacks.iter().map(Prepared::new).collect();
    let sizes = Sizes::new(run, &prepared);
    let grid = dispatch_grid(ctx, run, kernel, sizes.nl)?;
    let bufs = upload(ctx, pipeline, run, &prepared, &sizes);
    let base = base_params(run, &prepared[0], &sizes, grid.columns);
    dispatch_all(ctx, pipeline, &bufs, &base, run, &grid, progress)?;
    read_tally(ctx, run, &prepared, &sizes, &bufs)
}

/// The sizes of a run's tables on the GPU: wavelengths, layers, BRDF channels and bins,
/// profile bins and range, tally slots (two words each) and counters.
struct Sizes {
    nl: u32,
    n_layers: u32,
    channels: u32,
    bti: usize,
    bto: usize,
    bphi: usize,
    brdf_len: u32,
    pbins: usize,
    pdmax: f64,
    slots: u32,
    n_counts: u32,
}

impl Sizes {
    /// The sizes of `run`, prepared as `prepared`.
    fn new(run: &Run, prepared: &[Prepared]) -> Self {
        let nl = prepared.len() as u32;
        let n_layers = prepared[0].mut_.len() as u32;
        let channels = run.channels() as u32;
        let (bti, bto, bphi) = run
            .brdf
            .map_or((0, 0, 0), |b| (b.theta_in, b.theta_out, b.phi));
        let brdf_len = (bti * bto * bphi) as u32 * channels;
        let (pbins, pdmax) = run.profile.map_or((0, 1.0), |p| (p.bins, p.d_max_mm));
        let slots = 8 * nl + nl * n_layers + 1 + brdf_len + pbins as u32 * nl;
        let n_counts = nl + bti as u32;
        Self {
            nl,
            n_layers,
            channels,
            bti,
            bto,
            bphi,
            brdf_len,
            pbins,
            pdmax,
            slots,
            n_counts,
        }
    }
}

/// The kernel's layer table: per wavelength and layer, [`LAYER_FLOATS`] values in f32.
fn layer_table(prepared: &[Prepared], n_layers: usize) -> Vec<f32> {
    let mut layer_data = Vec::with_capacity(prepared.len() * n_layers * LAYER_FLOATS);
    for p in prepared {
        for l in 0..n_layers {
            layer_data.extend_from_slice(&[
                p.z[l] as f32,
                p.z[l + 1] as f32,
                p.mut_[l] as f32,
                p.mua_over_mut[l] as f32,
                p.inv_mut[l] as f32,
                p.g[l] as f32,
                p.n[l] as f32,
            ]);
        }
    }
    layer_data
}

/// The BRDF channel weights per wavelength in f32 (one channel of weight 1 where none given).
fn channel_table(run: &Run, nl: usize) -> Vec<f32> {
    if run.channel_weights.is_empty() {
        vec![1.0; nl]
    } else {
        run.channel_weights
            .iter()
            .flatten()
            .map(|&v| v as f32)
            .collect()
    }
}

/// How the photons are dispatched: workgroups per wavelength and photons per dispatch.
struct Grid {
    columns: u32,
    per_dispatch: u64,
}

/// The dispatch grid of `run` on this device under `kernel`; an error where its wavelengths
/// or photons per dispatch exceed the device's limits.
fn dispatch_grid(ctx: &derma_core::gpu::Gpu, run: &Run, kernel: &Kernel, nl: u32) -> Result<Grid> {
    // Workgroups: `columns` per wavelength. Large runs fill the device with the kernel's
    // workgroups and photons per thread and dispatch; small ones use fewer
    // (at least 4 photons a thread). Every dispatch but the last holds a multiple of nλ
    // photons, so each starts at a multiple of nλ. None of this changes the results.
    let max_groups = ctx.device.limits().max_compute_workgroups_per_dimension;
    if nl > max_groups {
        return Err(crate::error::OpticsError::Invalid(
            derma_core::Invalid::new(
                "wavelength samples on the GPU",
                format!("at most {max_groups} at once"),
                nl,
            ),
        ));
    }
    let full_columns = (kernel.groups / nl as u64).clamp(1, (max_groups / nl) as u64);
    let per_dispatch =
        full_columns * WORKGROUP as u64 * nl as u64 * kernel.photons_per_thread.max(1);
    if per_dispatch > u32::MAX as u64 {
        return Err(crate::error::OpticsError::Invalid(
            derma_core::Invalid::new(
                "photons per GPU dispatch",
                format!("at most {} (fewer groups or photons per thread)", u32::MAX),
                per_dispatch,
            ),
        ));
    }
    let columns = if run.photons >= per_dispatch {
        full_columns
    } else {
        run.photons
            .div_ceil(nl as u64 * WORKGROUP as u64 * 4)
            .clamp(1, full_columns)
    } as u32;
    Ok(Grid {
        columns,
        per_dispatch,
    })
}

/// The run's buffers on the GPU and their bind group.
struct Buffers {
    params: wgpu::Buffer,
    // Bound only; kept for the run's life, as the bind group's.
    _layers: wgpu::Buffer,
    _channels: wgpu::Buffer,
    acc: wgpu::Buffer,
    counts: wgpu::Buffer,
    bind: wgpu::BindGroup,
}

/// Uploads the layer table and channel weights, makes the zeroed tallies and counters and the
/// parameters' uniform, and binds them.
fn upload(
    ctx: &derma_core::gpu::Gpu,
    pipeline: &wgpu::ComputePipeline,
    run: &Run,
    prepared: &[Prepared],
    sizes: &Sizes,
) -> Buffers {
    let layer_data = layer_table(prepared, sizes.n_layers as usize);
    let chan = channel_table(run, sizes.nl as usize);
    let storage = |label, bytes: &[u8], usage| ctx.upload(label, bytes, usage);
    let layers_buf = storage(
        "layers",
        bytemuck::cast_slice(&layer_data),
        wgpu::BufferUsages::STORAGE,
    );
    let chan_buf = storage(
        "channels",
        bytemuck::cast_slice(&chan),
        wgpu::BufferUsages::STORAGE,
    );
    let rw = wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC;
    let acc_buf = storage(
        "tallies",
        bytemuck::cast_slice(&vec![0u32; 2 * sizes.slots as usize]),
        rw,
    );
    let counts_buf = storage(
        "counts",
        bytemuck::cast_slice(&vec![0u32; sizes.n_counts as usize]),
        rw,
    );

    // One uniform buffer and bind group for all dispatches; only the parameters change.
    let params_buf = ctx.device.create_buffer(&wgpu::BufferDescriptor {
        label: Some("params"),
        size: std::mem::size_of::<Params>() as u64,
        usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
        mapped_at_creation: false,
    });
    let layout = pipeline.get_bind_group_layout(0);
    let bind = ctx.bind_buffers(
        "optics",
        &layout,
        &[&params_buf, &layers_buf, &chan_buf, &acc_buf, &counts_buf],
    );
    Buffers {
        params: params_buf,
        _layers: layers_buf,
        _channels: chan_buf,
        acc: acc_buf,
        counts: counts_buf,
        bind,
    }
}

/// The kernel's parameters for `run` (its first stack prepared as `p0`), but for the
/// dispatch's photons (offset and count zero).
fn base_params(run: &Run, p0: &Prepared, sizes: &Sizes, columns: u32) -> Params {
    let (surface, sigma) = match p0.surface {
        Surface::Smooth => (0, 0.0),
        Surface::TrowbridgeReitz { sigma } => (1, sigma as f32),
        Surface::Smith { alpha } => (2, alpha as f32),
    };
    let (bottom, bottom_value) = match p0.bottom {
        Bottom::Medium { n } => (0, n as f32),
        Bottom::Lambertian { albedo } => (1, albedo as f32),
    };
    Params {
        seed_lo: run.seed as u32,
        seed_hi: (run.seed >> 32) as u32,
        offset_lo: 0,
        offset_hi: 0,
        count: 0,
        lanes: columns * WORKGROUP,
        n_lambda: sizes.nl,
        n_layers: sizes.n_layers,
        incidence: matches!(run.incidence, Incidence::ArcsinZenith) as u32,
        surface,
        sigma,
        bottom,
        bottom_value,
        n_above: p0.n_above as f32,
        brdf_ti: sizes.bti as u32,
        brdf_to: sizes.bto as u32,
        brdf_phi: sizes.bphi as u32,
        channels: sizes.channels,
        profile_bins: sizes.pbins as u32,
        profile_dmax: sizes.pdmax as f32,
    }
}

/// Traces all of `run`'s photons, `grid.per_dispatch` a dispatch with `base`'s parameters;
/// `progress` advances by each dispatch's photons as it finishes.
fn dispatch_all(
    ctx: &derma_core::gpu::Gpu,
    pipeline: &wgpu::ComputePipeline,
    bufs: &Buffers,
    base: &Params,
    run: &Run,
    grid: &Grid,
    progress: &dyn Progress,
) -> Result<()> {
    // Dispatches are queued back to back: the host waits for dispatch i − 1 (and reports its
    // photons) only after submitting dispatch i, so the device never idles between them.
    let mut offset = 0u64;
    let mut in_flight: Option<(wgpu::SubmissionIndex, u64)> = None;
    while offset < run.photons {
        let count = (run.photons - offset).min(grid.per_dispatch) as u32;
        let params = Params {
            offset_lo: offset as u32,
            offset_hi: (offset >> 32) as u32,
            count,
            ..*base
        };
        // Ordered after the previous dispatch by the queue, as wgpu guarantees.
        ctx.queue
            .write_buffer(&bufs.params, 0, bytemuck::bytes_of(&params));
        let mut enc = ctx.device.create_command_encoder(&Default::default());
        {
            let mut pass = enc.begin_compute_pass(&Default::default());
            pass.set_pipeline(pipeline);
            pass.set_bind_group(0, &bufs.bind, &[]);
            pass.dispatch_workgroups(grid.columns * base.n_lambda, 1, 1);
        }
        let index = ctx.queue.submit([enc.finish()]);
        if let Some((previous, photons)) = in_flight.replace((index, count as u64)) {
            ctx.wait_for(previous, "tracing photons")?;
            progress.advance(photons);
        }
        offset += count as u64;
    }
    if let Some((last, photons)) = in_flight {
        ctx.wait_for(last, "tracing photons")?;
        progress.advance(photons);
    }
    Ok(())
}

/// Reads the tallies and counters back into `run`'s [`Tally`].
fn read_tally(
    ctx: &derma_core::gpu::Gpu,
    run: &Run,
    prepared: &[Prepared],
    sizes: &Sizes,
    bufs: &Buffers,
) -> Result<Tally> {
    let (nl, n_layers) = (sizes.nl, sizes.n_layers);
    let acc: Vec<u32> = ctx.read_back(&bufs.acc, 2 * sizes.slots as usize)?;
    let counts: Vec<u32> = ctx.read_back(&bufs.counts, sizes.n_counts as usize)?;
    let val = |slot: u32| fixed_to_f64(acc[2 * slot as usize], acc[2 * slot as usize + 1]);

    let mut t = run.empty_tally();
    t.photons = run.photons;
    for l in 0..nl {
        t.per_lambda_count[l as usize] = counts[l as usize] as u64;
        for k in 0..4 {
            let s = val(l * 8 + k as u32);
            t.per_lambda[l as usize][k] = s;
            t.sum[k] += s;
            t.sum_sq[k] += val(l * 8 + 4 + k as u32);
        }
    }
    // Absorbed weight per wavelength and layer, split among the absorbers by the layer's
    // shares at that wavelength (what the CPU walk adds step by step).
    let abs0 = 8 * nl;
    for (l, p) in prepared.iter().enumerate() {
        for (li, a) in t.absorbed.iter_mut().enumerate() {
            let total = val(abs0 + l as u32 * n_layers + li as u32);
            for (v, share) in a.iter_mut().zip(&p.share[li]) {
                *v += total * share;
            }
        }
    }
    let roulette0 = abs0 + nl * n_layers;
    t.roulette = val(roulette0);
    let brdf0 = roulette0 + 1;
    for (i, v) in t.brdf.iter_mut().enumerate() {
        *v = val(brdf0 + i as u32);
    }
    for (i, v) in t.brdf_in.iter_mut().enumerate() {
        *v = counts[nl as usize + i] as u64;
    }
    let prof0 = brdf0 + sizes.brdf_len;
    for (i, v) in t.profile.iter_mut().enumerate() {
        *v = val(prof0 + i as u32);
    }
    Ok(t)
}

//! The distance fields on the GPU (WGSL, `sdf.wgsl`): jump flooding with its log₂ N passes
//! dispatched back to back without host round trips, and the refined backtracking search — the
//! CPU code in [`super::jfa`] and [`super::samplers`] is the reference; seeds are identical, and
//! distances agree to float rounding (the GPU's sin, cos and sqrt differ by ULPs).

use super::samplers::Sampler;
use super::{Field, GBuffer};
use crate::Result;
use derma_core::gpu::{Gpu, GpuCell};

const SHADER: &str = include_str!("sdf.wgsl");
const WORKGROUP: usize = 64;

#[repr(C)]
#[derive(Clone, Copy, bytemuck::Pod, bytemuck::Zeroable)]
struct Params {
    width: u32,
    height: u32,
    focal: f32,
    range: f32,
    step: u32,
    n: u32,
    steps: u32,
    refine: u32,
}

struct Pipelines {
    layout: wgpu::BindGroupLayout,
    init: wgpu::ComputePipeline,
    step: wgpu::ComputePipeline,
    distance: wgpu::ComputePipeline,
    backtrack: wgpu::ComputePipeline,
    equiangular: wgpu::ComputePipeline,
    exp_pass1: wgpu::ComputePipeline,
    exp_pass2: wgpu::ComputePipeline,
}

static PIPELINES: GpuCell<Pipelines> = GpuCell::new();

fn pipelines() -> Result<(&'static Gpu, &'static Pipelines)> {
    Ok(PIPELINES.get_or_init(|ctx| {
        // Binding 0 the parameters, 1–3 read-only inputs, 4–7 the fields and seeds.
        let (layout, [init, step, distance, backtrack, equiangular, exp_pass1, exp_pass2]) = ctx
            .entry_points(
                "sdf.wgsl",
                SHADER,
                3,
                4,
                [
                    "jfa_init",
                    "jfa_step",
                    "jfa_distance",
                    "backtrack",
                    "equiangular",
                    "exp_pass1",
                    "exp_pass2",
                ],
            )?;
        Ok(Pipelines {
            layout,
            init,
            step,
            distance,
            backtrack,
            equiangular,
            exp_pass1,
            exp_pass2,
        })
    })?)
}

/// A G-buffer resident on the GPU.
pub struct GpuFields {
    w: usize,
    h: usize,
    focal: f32,
    params: wgpu::Buffer,
    seeds: [wgpu::Buffer; 2],
    dist: wgpu::Buffer,
    acc: wgpu::Buffer,
    /// Bind groups reading seeds 0 → writing 1, and 1 → 0.
    binds: [wgpu::BindGroup; 2],
}

impl GpuFields {
    /// Uploads the mask and depth.
    pub fn new(g: &GBuffer) -> Result<GpuFields> {
        let (ctx, pl) = pipelines()?;
        let d = &ctx.device;
        let n = g.width * g.height;
        let mask: Vec<u32> = g.mask.iter().map(|&m| m as u32).collect();
        let init = |label, bytes: &[u8], usage| ctx.upload(label, bytes, usage);
        let st = wgpu::BufferUsages::STORAGE;
        let mask_buf = init("mask", bytemuck::cast_slice(&mask), st);
        let depth_buf = init("depth", bytemuck::cast_slice(&g.depth), st);
        let rw = |label| {
            d.create_buffer(&wgpu::BufferDescriptor {
                label: Some(label),
                size: (n * 4) as u64,
                usage: st | wgpu::BufferUsages::COPY_SRC,
                mapped_at_creation: false,
            })
        };
        let seeds = [rw("seeds a"), rw("seeds b")];
        let dist = rw("distance");
        let acc = rw("accesses");
        let offs = d.create_buffer(&wgpu::BufferDescriptor {
            label: Some("offsets"),
            size: (n * 8) as u64,
            usage: st,
            mapped_at_creation: false,
        });
        let params = d.create_buffer(&wgpu::BufferDescriptor {
            label: Some("sdf params"),
            size: std::mem::size_of::<Params>() as u64,
            usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        let bind = |a: usize, b: usize| {
            ctx.bind_buffers(
                "sdf",
                &pl.layout,
                &[
                    &params, &mask_buf, &depth_buf, &seeds[a], &seeds[b], &dist, &acc, &offs,
                ],
            )
        };
        let binds = [bind(0, 1), bind(1, 0)];
        Ok(GpuFields {
            w: g.width,
            h: g.height,
            focal: g.focal,
            params,
            seeds,
            dist,
            acc,
            binds,
        })
    }

    fn params(&self, step: u32, range: f32, s: Option<Sampler>) -> Params {
        let (n, steps, refine) = match s {
            Some(Sampler::Backtracking { n, steps, refine }) => (n, steps, refine),
            Some(Sampler::Equiangular { n }) => (n, 0, 0),
            Some(Sampler::Exponential { steps }) => (0, steps, 0),
            None => (0, 0, 0),
        };
        Params {
            width: self.w as u32,
            height: self.h as u32,
            focal: self.focal,
            range,
            step,
            n,
            steps,
            refine,
        }
    }

    fn read(&self, ctx: &Gpu, with_acc: bool) -> Result<Field> {
        let n = self.w * self.h;
        let distance: Vec<f32> = ctx
            .read_back::<f32>(&self.dist, n)?
            .into_iter()
            .map(|v| if v >= 1e30 { f32::INFINITY } else { v })
            .collect();
        let accesses = if with_acc {
            ctx.read_back::<u32>(&self.acc, n)?
        } else {
            vec![0; n]
        };
        Ok(Field { distance, accesses })
    }

    /// Jump flooding: init, log₂ N + 1 steps and the distances in one submission.
    pub fn jfa(&self) -> Result<(Field, Vec<u32>)> {
        let (ctx, _) = pipelines()?;
        let cur = self.submit_jfa(1)?;
        let n = self.w * self.h;
        let seeds = ctx.read_back::<u32>(&self.seeds[cur], n)?;
        let passes = self.jfa_steps().len() as u32;
        let mut f = self.read(ctx, false)?;
        f.accesses = vec![9 * passes + 2; n];
        Ok((f, seeds))
    }

    fn jfa_steps(&self) -> Vec<u32> {
        let mut steps = Vec::new();
        let mut k = self.w.max(self.h).next_power_of_two() / 2;
        while k >= 1 {
            steps.push(k as u32);
            k /= 2;
        }
        steps.push(1);
        steps
    }

    /// Mean milliseconds of one whole jump flooding on the device (all passes, no transfers):
    /// `repeats` floods submitted back to back, then one wait.
    pub fn time_jfa(&self, repeats: usize) -> Result<f64> {
        let (ctx, _) = pipelines()?;
        self.submit_jfa(1)?;
        ctx.wait("warming up jump flooding")?;
        let t = std::time::Instant::now();
        self.submit_jfa(repeats.max(1))?;
        ctx.wait("timing jump flooding")?;
        Ok(t.elapsed().as_secs_f64() * 1e3 / repeats.max(1) as f64)
    }

    /// Submits `repeats` whole floods; returns the seed buffer holding the result.
    fn submit_jfa(&self, repeats: usize) -> Result<usize> {
        let (ctx, pl) = pipelines()?;
        let n = self.w * self.h;
        let (gx, gy) = derma_core::gpu::grid(n, WORKGROUP);
        let steps = self.jfa_steps();
        // Each pass needs its own step in the uniform: a small buffer per pass copied in
        // before it (queue-ordered, so no host round trip between passes).
        let pass_params: Vec<wgpu::Buffer> = std::iter::once(0)
            .chain(steps.iter().copied())
            .chain(std::iter::once(0))
            .map(|k| {
                ctx.upload(
                    "sdf pass params",
                    bytemuck::bytes_of(&self.params(k, 0.0, None)),
                    wgpu::BufferUsages::COPY_SRC,
                )
            })
            .collect();
        let size = std::mem::size_of::<Params>() as u64;
        let mut enc = ctx.device.create_command_encoder(&Default::default());
        let mut cur = 0usize;
        for _ in 0..repeats {
            // Bind group c reads seeds[c] and writes seeds[1 − c]; init writes seeds[1].
            let run = |enc: &mut wgpu::CommandEncoder,
                       pipe: &wgpu::ComputePipeline,
                       c: usize,
                       p: &wgpu::Buffer| {
                enc.copy_buffer_to_buffer(p, 0, &self.params, 0, size);
                let mut pass = enc.begin_compute_pass(&Default::default());
                pass.set_pipeline(pipe);
                pass.set_bind_group(0, &self.binds[c], &[]);
                pass.dispatch_workgroups(gx, gy, 1);
            };
            run(&mut enc, &pl.init, 0, &pass_params[0]);
            cur = 1;
            for k in 0..steps.len() {
                run(&mut enc, &pl.step, cur, &pass_params[k + 1]);
                cur = 1 - cur;
            }
            run(&mut enc, &pl.distance, cur, &pass_params[steps.len() + 1]);
        }
        ctx.queue.submit([enc.finish()]);
        Ok(cur)
    }

    /// The passes of a sampler, in order.
    fn passes(pl: &Pipelines, s: Sampler) -> Vec<&wgpu::ComputePipeline> {
        match s {
            Sampler::Equiangular { .. } => vec![&pl.equiangular],
            Sampler::Exponential { .. } => vec![&pl.exp_pass1, &pl.exp_pass2],
            Sampler::Backtracking { .. } => vec![&pl.backtrack],
        }
    }

    fn submit_sampler(&self, ctx: &Gpu, pl: &Pipelines, s: Sampler, range: f32, repeats: usize) {
        ctx.queue.write_buffer(
            &self.params,
            0,
            bytemuck::bytes_of(&self.params(0, range, Some(s))),
        );
        let (gx, gy) = derma_core::gpu::grid(self.w * self.h, WORKGROUP);
        let mut enc = ctx.device.create_command_encoder(&Default::default());
        for _ in 0..repeats {
            for pipe in Self::passes(pl, s) {
                let mut pass = enc.begin_compute_pass(&Default::default());
                pass.set_pipeline(pipe);
                pass.set_bind_group(0, &self.binds[0], &[]);
                pass.dispatch_workgroups(gx, gy, 1);
            }
        }
        ctx.queue.submit([enc.finish()]);
    }

    /// A sampler's field, computed on the device.
    pub fn sampled(&self, s: Sampler, range: f32) -> Result<Field> {
        let (ctx, pl) = pipelines()?;
        self.submit_sampler(ctx, pl, s, range, 1);
        self.read(ctx, true)
    }

    /// Mean milliseconds of one sampler field on the device (no transfers).
    pub fn time_sampled(&self, s: Sampler, range: f32, repeats: usize) -> Result<f64> {
        let (ctx, pl) = pipelines()?;
        self.submit_sampler(ctx, pl, s, range, 1);
        ctx.wait("warming up the sampler")?;
        let t = std::time::Instant::now();
        self.submit_sampler(ctx, pl, s, range, repeats.max(1));
        ctx.wait("timing the sampler")?;
        Ok(t.elapsed().as_secs_f64() * 1e3 / repeats.max(1) as f64)
    }
}

//! The patch pass of [`crate::patch_pass`] (Shen et al. §3.2 in wavefronts, with the occurrence
//! penalty and the clash rounds) run on the GPU by the [`GpuMatcher`]: `patch_pass.wgsl`.
//!
//! The canvas's codes and sources, the occurrence counts and every wavefront's patches stay on
//! the GPU. Several wavefronts are recorded per submission, each with its rounds dispatched
//! indirectly (`patch_schedule.wgsl`), and only the state's head comes back between
//! submissions. The same integers as the CPU decide every step, so the sources are the CPU's.

use crate::canvas::NO_SOURCE;
use crate::error::Result;
use crate::exemplar::{Exemplar, ExemplarSet};
use crate::gpu::{
    gpu_error, info_stride, threads_per_query, GpuMatcher, Params, Resident, PATCH_SHADER,
    WORKGROUP,
};
use crate::matcher::PatchPlan;
use crate::search::MAX_GUESSES;
use derma_core::gpu::GpuCell;
use derma_core::progress::Progress;

/// The patch pass's pipelines: its kernels and the search's, on one layout (binding 0 uniform,
/// 1–2 read-only storage, 3–16 read-write storage).
struct PatchPipelines {
    layout: wgpu::BindGroupLayout,
    /// `schedule` (patch_schedule.wgsl) on its own layout: binding 0 uniform, 1 the state, 2
    /// the indirect arguments (which a dispatch may not also bind as storage).
    schedule_layout: wgpu::BindGroupLayout,
    schedule: wgpu::ComputePipeline,
    /// `advance`, `gather`, then per round: `penalty_rows`, `penalty_table`, `bar`,
    /// `prepare_round`, `screen`, `cost`, `min_cost`, `settle`, `choose`, `pick`, `finish`,
    /// `accept`, `paste`.
    steps: [wgpu::ComputePipeline; 15],
}

static PATCH_PIPELINES: GpuCell<Option<PatchPipelines>> = GpuCell::new();

/// The patch pass's pipelines; `None` on a device without 64-bit integers.
fn patch_pipelines() -> Result<(
    &'static derma_core::gpu::Gpu,
    &'static Option<PatchPipelines>,
)> {
    Ok(PATCH_PIPELINES.get_or_init(|ctx| {
        if !ctx.device.features().contains(wgpu::Features::SHADER_INT64) {
            return Ok(None);
        }
        let (layout, steps) = ctx.entry_points(
            "patch_pass.wgsl",
            PATCH_SHADER,
            2,
            14,
            [
                "advance",
                "gather",
                "penalty_rows",
                "penalty_table",
                "bar",
                "prepare_round",
                "screen",
                "cost",
                "min_cost",
                "settle",
                "choose",
                "pick",
                "finish",
                "accept",
                "paste",
            ],
        )?;
        let (schedule_layout, [schedule]) = ctx.entry_points(
            "patch_schedule.wgsl",
            include_str!("patch_schedule.wgsl"),
            0,
            2,
            ["schedule"],
        )?;
        Ok(Some(PatchPipelines {
            layout,
            schedule_layout,
            schedule,
            steps,
        }))
    })?)
}

/// Indirect-dispatch words of one round (three per dispatch; patch_schedule.wgsl's ROUND_ARGS).
const ROUND_ARGS: usize = 39;
/// Words of the patch pass's state before the per-patch statuses (patch_pass.wgsl).
const STATE_STATUS: usize = 11;
const STATE_MAX_ROUNDS: usize = 8;
/// Most rounds recorded per wavefront when the schedule adapts to the rounds wavefronts took.
const MAX_PATCH_ROUNDS: usize = 32;
const STATE_PENDING: usize = 1;
const STATE_WAVEFRONT: usize = 3;
const STATE_STALLED: usize = 4;

/// A wavefront with patches and whether two of them overlap.
type Front<'a> = (&'a Vec<[u32; 3]>, bool);

/// The patch pass's sizes: patch side, channels, candidate columns, candidates, exemplar
/// height, most patches of a wavefront and room for survivors.
struct Shape {
    n: usize,
    c: usize,
    cw: usize,
    candidates: usize,
    /// Threads per query of the searches: the positions, or the k-coherence candidates.
    threads: usize,
    ex_height: usize,
    nq_max: usize,
    capacity: usize,
}

/// The patch pass's buffers (patch_pass.wgsl's bindings, the schedule's indirect arguments
/// and the state's staging buffer).
struct PatchBuffers {
    params: wgpu::Buffer,
    source: wgpu::Buffer,
    penalty: wgpu::Buffer,
    windows: wgpu::Buffer,
    info: wgpu::Buffer,
    result: wgpu::Buffer,
    limits: wgpu::Buffer,
    survivors: wgpu::Buffer,
    costs: wgpu::Buffer,
    canvas: wgpu::Buffer,
    canvas_src: wgpu::Buffer,
    counts: wgpu::Buffer,
    plan: wgpu::Buffer,
    args: wgpu::Buffer,
    state: wgpu::Buffer,
    row_sums: wgpu::Buffer,
    staging: wgpu::Buffer,
}

/// What records the patch pass's submissions: its pipelines and bind groups, the round's
/// dispatches (pipeline, full workgroup counts) and the per-patch grid.
struct Recorder<'a> {
    ctx: &'a derma_core::gpu::Gpu,
    pipes: &'a PatchPipelines,
    bufs: &'a PatchBuffers,
    group: wgpu::BindGroup,
    schedule_group: wgpu::BindGroup,
    round: [(&'a wgpu::ComputePipeline, (u32, u32)); ROUND_ARGS / 3],
    per_query: (u32, u32),
}

impl GpuMatcher {
    /// The patch pass on the GPU (patch_pass.wgsl), one submission per wavefront; `None` where
    /// the device lacks 64-bit integers or the canvas exceeds one storage binding.
    pub(crate) fn patch_pass_resident(
        &self,
        set: &ExemplarSet,
        plan: &PatchPlan,
        progress: &dyn Progress,
    ) -> Result<Option<Vec<u32>>> {
        let (ctx, pipes) = patch_pipelines()?;
        let Some(pipes) = pipes else {
            return Ok(None);
        };
        let n = plan.n;
        let e = &set.exemplars[0];
        let c = e.channels();
        let (cw, ch) = e.candidates(n);
        let texels = plan.plane.width * plan.plane.height;
        let nq_max = plan.wavefronts.iter().map(Vec::len).max().unwrap_or(0);
        if nq_max == 0 {
            return Ok(Some(plan.sources.to_vec()));
        }
        let fits = |bytes: usize| ctx.check_storage("the patch pass", bytes as u64).is_ok();
        if !fits(texels * c * 4) || !fits(nq_max * n * n * c * 4) {
            return Ok(None);
        }
        let res = self.resident(set, 0, n, plan.coherence.map(|c| c.tables))?;
        let threads = threads_per_query(cw * ch, plan.coherence.map(|c| c.random));
        let shape = Shape {
            n,
            c,
            cw,
            candidates: cw * ch,
            threads,
            ex_height: e.height(),
            nq_max,
            capacity: self.survivor_room(nq_max, threads),
        };
        let fronts = fronts(plan);
        let bufs = PatchBuffers::new(ctx, plan, e, &shape, &fronts);
        let params = patch_params(e, &res, plan, &shape, fronts.len());
        let rec = Recorder::new(ctx, pipes, &bufs, &res, &params, &shape);
        let t0 = std::time::Instant::now();
        let (submissions, rounds) = self.run_wavefronts(&rec, &fronts, nq_max, progress)?;
        let sources: Vec<u32> = ctx.read_back(&bufs.canvas_src, texels)?;
        tracing::debug!(
            "GPU patch pass: {} wavefronts in {submissions} submissions ({} wavefronts of up to \
             {rounds} rounds each), {:.1} ms",
            fronts.len(),
            self.patch_wavefronts,
            t0.elapsed().as_secs_f64() * 1e3
        );
        Ok(Some(sources))
    }

    /// Runs the wavefronts, `patch_wavefronts` a submission, giving the last one started more
    /// rounds of its own until it settles; the submissions made and the rounds last recorded.
    fn run_wavefronts(
        &self,
        rec: &Recorder,
        fronts: &[Front],
        nq_max: usize,
        progress: &dyn Progress,
    ) -> Result<(usize, usize)> {
        let mut submissions = 0usize;
        let mut next = 0usize;
        let mut rounds = self.patch_rounds;
        while next < fronts.len() {
            let batch = self.patch_wavefronts.min(fronts.len() - next);
            let mut head = rec.submit(batch, rounds)?;
            submissions += 1;
            // The last wavefront started has not settled (it stopped the rest, or it was the
            // batch's last): more rounds for it alone.
            if head[STATE_PENDING] != 0 {
                rec.ctx.queue.write_buffer(
                    &rec.bufs.state,
                    (STATE_STALLED * 4) as u64,
                    bytemuck::bytes_of(&0u32),
                );
                // Each round accepts at least one patch, so this ends within nq_max rounds.
                for _ in 0..=nq_max {
                    if head[STATE_PENDING] == 0 {
                        break;
                    }
                    head = rec.submit(0, rounds)?;
                    submissions += 1;
                }
                if head[STATE_PENDING] != 0 {
                    return Err(gpu_error(format!(
                        "wavefront {} of the patch pass did not settle",
                        head[STATE_WAVEFRONT]
                    )));
                }
            }
            if self.patch_adaptive {
                rounds = rounds.max((head[STATE_MAX_ROUNDS] as usize).min(MAX_PATCH_ROUNDS));
            }
            let started = head[STATE_WAVEFRONT] as usize;
            let done: usize = fronts[next..=started].iter().map(|f| f.0.len()).sum();
            progress.advance(done as u64);
            next = started + 1;
        }
        Ok((submissions, rounds))
    }
}

/// The plan's wavefronts with patches, with their overlap flags.
fn fronts<'a>(plan: &'a PatchPlan) -> Vec<Front<'a>> {
    plan.wavefronts
        .iter()
        .zip(plan.overlaps.iter().copied())
        .filter(|(f, _)| !f.is_empty())
        .collect()
}

/// The plan's words on the GPU: per wavefront (first patch, patches, overlap), then the
/// patches.
fn plan_words(fronts: &[Front]) -> Vec<u32> {
    let mut plan_words: Vec<u32> = Vec::new();
    let mut first_patch = 0u32;
    for (f, overlap) in fronts {
        plan_words.extend_from_slice(&[first_patch, f.len() as u32, u32::from(*overlap)]);
        first_patch += f.len() as u32;
    }
    for (f, _) in fronts {
        plan_words.extend(f.iter().flatten());
    }
    plan_words
}

/// The occurrence counts of the exemplar's `texels` among the sources already on the canvas
/// (none at the start), and their total.
fn occurrences(sources: &[u32], texels: usize) -> (Vec<u32>, u32) {
    let mut counts = vec![0u32; texels];
    let mut total = 0u32;
    for &s in sources.iter().filter(|&&s| s != NO_SOURCE) {
        counts[s as usize] += 1;
        total += 1;
    }
    (counts, total)
}

/// The patch pass's parameters: the search's over the wavefront's patches, with the canvas,
/// the penalty's weight and cap, and the number of wavefronts.
fn patch_params(
    e: &Exemplar,
    res: &Resident,
    plan: &PatchPlan,
    shape: &Shape,
    fronts: usize,
) -> Params {
    let (n, nq_max) = (shape.n, shape.nq_max);
    let k16 = plan.weight16;
    Params {
        guarded: 1,
        canvas_w: plan.plane.width as u32,
        canvas_h: plan.plane.height as u32,
        k16_lo: k16 as u32,
        k16_hi: (k16 >> 32) as u32,
        cap: plan.cap,
        fronts: fronts as u32,
        ..Params::search(
            e,
            res,
            n,
            plan.tol,
            true,
            nq_max,
            shape.capacity,
            (n, nq_max * n),
            plan.coherence.map_or(0, |c| c.random),
        )
    }
}

impl PatchBuffers {
    /// The buffers of `plan`'s pass over exemplar `e`: the canvas's codes and sources, the
    /// occurrence counts, the plan and the state uploaded, the rest made empty.
    fn new(
        ctx: &derma_core::gpu::Gpu,
        plan: &PatchPlan,
        e: &Exemplar,
        shape: &Shape,
        fronts: &[Front],
    ) -> Self {
        let (n, c, nq_max, capacity) = (shape.n, shape.c, shape.nq_max, shape.capacity);
        let info_stride = info_stride(c);
        let stride = 3 + MAX_GUESSES;
        use wgpu::BufferUsages as U;
        let buffer = |label: &str, bytes: usize, usage: wgpu::BufferUsages| {
            ctx.device.create_buffer(&wgpu::BufferDescriptor {
                label: Some(label),
                size: bytes.max(4) as u64,
                usage,
                mapped_at_creation: false,
            })
        };
        let init = |label: &str, words: &[u32], usage: wgpu::BufferUsages| {
            ctx.upload(label, bytemuck::cast_slice(words), usage)
        };
        let codes: Vec<u32> = plan.plane.codes.iter().map(|&v| v as u32).collect();
        let (counts, total) = occurrences(plan.sources, e.width() * e.height());
        let rw = U::STORAGE | U::COPY_DST;
        let params = buffer(
            "patch params",
            std::mem::size_of::<Params>(),
            U::UNIFORM | U::COPY_DST,
        );
        let source = buffer("patch windows' codes", nq_max * n * n * c * 4, rw);
        let penalty = buffer("penalties", shape.candidates * 4, rw);
        let windows = buffer("patches", nq_max * stride * 4, rw);
        let info = buffer("patch info", nq_max * info_stride * 4, rw);
        let result = buffer("patch results", (nq_max * 2 + 1) * 4, rw);
        let limits = buffer("patch limits", nq_max * 4, rw);
        let survivors = buffer("patch survivors", capacity * 8, rw);
        let costs = buffer("patch costs", capacity * 4, rw);
        let canvas = init("canvas codes", &codes, rw);
        let canvas_src = init("canvas sources", plan.sources, rw | U::COPY_SRC);
        let counts = init("occurrence counts", &counts, rw);
        let plan = init("patch plan", &plan_words(fronts), rw);
        // The round's full workgroup counts (filled by `Recorder::new`), then the live ones
        // `schedule` writes before each round.
        let args = buffer("round arguments", ROUND_ARGS * 2 * 4, rw | U::INDIRECT);
        let mut state0 = vec![0u32; STATE_STATUS + 3 * nq_max];
        state0[0] = total;
        // No wavefront yet: `advance` starts wavefront 0 (the index wraps to it).
        state0[STATE_WAVEFRONT] = u32::MAX;
        let state = init("patch state", &state0, rw | U::COPY_SRC);
        let row_sums = buffer("row sums", shape.cw * shape.ex_height * 4, rw);
        let staging = buffer(
            "patch state read back",
            STATE_STATUS * 4,
            U::MAP_READ | U::COPY_DST,
        );
        Self {
            params,
            source,
            penalty,
            windows,
            info,
            result,
            limits,
            survivors,
            costs,
            canvas,
            canvas_src,
            counts,
            plan,
            args,
            state,
            row_sums,
            staging,
        }
    }
}

impl<'a> Recorder<'a> {
    /// Binds `bufs` (with the exemplar's `res`), writes `params` and the round's full
    /// workgroup counts.
    fn new(
        ctx: &'a derma_core::gpu::Gpu,
        pipes: &'a PatchPipelines,
        bufs: &'a PatchBuffers,
        res: &Resident,
        params: &Params,
        shape: &Shape,
    ) -> Self {
        let b = bufs;
        let group = ctx.bind_buffers(
            "patch pass",
            &pipes.layout,
            &[
                &b.params,
                &res.codes,
                &res.sums,
                &b.source,
                &b.penalty,
                &b.windows,
                &b.info,
                &b.result,
                &b.limits,
                &b.survivors,
                &b.costs,
                &b.canvas,
                &b.canvas_src,
                &b.counts,
                &b.state,
                &b.row_sums,
                &b.plan,
            ],
        );
        let q = &ctx.queue;
        q.write_buffer(&b.params, 0, bytemuck::bytes_of(params));
        let (round, per_query) = round_dispatches(pipes, shape);
        let full: Vec<u32> = round.iter().flat_map(|(_, d)| [d.0, d.1, 1]).collect();
        q.write_buffer(&b.args, 0, bytemuck::cast_slice(&full));
        let schedule_group = ctx.bind_buffers(
            "patch schedule",
            &pipes.schedule_layout,
            &[&b.params, &b.state, &b.args],
        );
        Self {
            ctx,
            pipes,
            bufs,
            group,
            schedule_group,
            round,
            per_query,
        }
    }

    /// Records `wavefronts` starts (each `advance`, `gather` and `rounds` rounds; none: only
    /// the rounds, continuing the current one), submits and reads the state's head back.
    fn submit(&self, wavefronts: usize, rounds: usize) -> Result<Vec<u32>> {
        let [advance, gather, ..] = &self.pipes.steps;
        let (group, args) = (&self.group, &self.bufs.args);
        let mut enc = self.ctx.device.create_command_encoder(&Default::default());
        {
            let mut pass = enc.begin_compute_pass(&Default::default());
            for _ in 0..wavefronts.max(1) {
                pass.set_bind_group(0, group, &[]);
                if wavefronts > 0 {
                    for (pipe, dims) in [(advance, (1, 1)), (gather, self.per_query)] {
                        pass.set_pipeline(pipe);
                        pass.dispatch_workgroups(dims.0, dims.1, 1);
                    }
                }
                for _ in 0..rounds {
                    // Nothing is dispatched for a settled wavefront or after a stop.
                    pass.set_pipeline(&self.pipes.schedule);
                    pass.set_bind_group(0, &self.schedule_group, &[]);
                    pass.dispatch_workgroups(1, 1, 1);
                    pass.set_bind_group(0, group, &[]);
                    for (k, &(pipe, _)) in self.round.iter().enumerate() {
                        pass.set_pipeline(pipe);
                        pass.dispatch_workgroups_indirect(args, ((ROUND_ARGS + 3 * k) * 4) as u64);
                    }
                }
            }
        }
        self.ctx.queue.submit([enc.finish()]);
        Ok(self
            .ctx
            .read_back_with(&self.bufs.state, &self.bufs.staging, STATE_STATUS)?)
    }
}

/// A round's dispatches, each with its full workgroup counts, and the per-patch grid.
#[allow(clippy::type_complexity)]
fn round_dispatches<'a>(
    pipes: &'a PatchPipelines,
    shape: &Shape,
) -> (
    [(&'a wgpu::ComputePipeline, (u32, u32)); ROUND_ARGS / 3],
    (u32, u32),
) {
    let [_, _, rows, table, bar, prepare_round, screen, cost, min_cost, settle, choose, pick, finish, accept, paste] =
        &pipes.steps;
    let (n, nq_max, candidates) = (shape.n, shape.nq_max, shape.candidates);
    let per_query = derma_core::gpu::grid(nq_max, WORKGROUP);
    let screen_dims = ((shape.threads.div_ceil(WORKGROUP)) as u32, nq_max as u32);
    let survivor_dims = derma_core::gpu::grid(shape.capacity, WORKGROUP);
    let round = [
        (
            rows,
            derma_core::gpu::grid(shape.cw * shape.ex_height, WORKGROUP),
        ),
        (table, derma_core::gpu::grid(candidates, WORKGROUP)),
        (bar, derma_core::gpu::grid(candidates, WORKGROUP)),
        (prepare_round, per_query),
        (screen, screen_dims),
        (cost, survivor_dims),
        (min_cost, screen_dims),
        (settle, per_query),
        (choose, survivor_dims),
        (pick, screen_dims),
        (finish, per_query),
        (accept, (1, 1)),
        (paste, derma_core::gpu::grid(nq_max * n * n, WORKGROUP)),
    ];
    (round, per_query)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_schedule_shader_knows_the_round_s_dispatches() {
        let wgsl = include_str!("patch_schedule.wgsl");
        let want = format!("const ROUND_ARGS: u32 = {ROUND_ARGS}u;");
        assert!(wgsl.contains(&want), "patch_schedule.wgsl lacks `{want}`");
        let want = format!("const STATE_STATUS: u32 = {STATE_STATUS}u;");
        assert!(
            PATCH_SHADER.contains(&want),
            "patch_pass.wgsl lacks `{want}`"
        );
    }
}

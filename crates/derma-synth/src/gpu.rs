//! The GPU backend of the best-match search (Shen et al. §3.4): `search.wgsl` on wgpu — one
//! thread per exemplar position and query, reduced with atomics — returning exactly what the
//! CPU search returns (the definition is in [`crate::search`]).
//!
//! Two sources of query windows: uploaded with each batch (`Matcher::best_matches`, the patch
//! pass's masked windows), or read from a copy of the canvas uploaded once per optimisation
//! pass (`Matcher::window_matches`), where the GPU also computes the quadrant sums and the
//! guesses' costs that the host computes for an uploaded window. The `Matcher` implementation
//! is `gpu_matcher.rs`; a whole patch pass on the GPU (`Matcher::patch_pass`) is in
//! `gpu_patch_pass.rs`.

use crate::coherence::{Coherence, SIMILAR};
use crate::error::{invalid, Result, SynthError};
use crate::exemplar::{Exemplar, ExemplarSet};
use crate::search::{
    initial_cost, known_block_sums, known_texels, Match, Query, Search, Tolerance, WindowQuery,
    MAX_GUESSES,
};
use bytemuck::Zeroable;
use derma_core::gpu::GpuCell;
use rayon::prelude::*;
use std::collections::HashMap;
use std::sync::{Arc, Mutex};

/// The shader.
pub const SHADER: &str = include_str!("search.wgsl");
/// The search with the patch pass's kernels (64-bit integers: devices with `SHADER_INT64`;
/// run by `gpu_patch_pass.rs`).
pub const PATCH_SHADER: &str = concat!(
    include_str!("search.wgsl"),
    include_str!("patch_pass.wgsl"),
    include_str!("guess_list.wgsl")
);
/// The coherent guesses of windows read from a canvas whose sources are on the GPU.
const GUESSES_SHADER: &str = concat!(
    include_str!("guesses.wgsl"),
    include_str!("guess_list.wgsl")
);
pub(crate) const WORKGROUP: usize = 64;

/// Rounds first recorded per wavefront (they grow to the most any wavefront has taken; one that
/// needs more gets them in a submission of its own).
pub(crate) const PATCH_ROUNDS: usize = 4;
/// Wavefronts recorded per submission of the patch pass (the first that does not settle in its
/// rounds stops the rest, which the next submission records again).
pub(crate) const PATCH_WAVEFRONTS: usize = 16;
/// Largest query upload per dispatch, in bytes.
pub(crate) const MAX_QUERY_BYTES: usize = 64 << 20;
/// Room for candidates that pass the bound in one compacted search (12 bytes each).
const MAX_SURVIVORS: usize = 32 << 20;

#[repr(C)]
#[derive(Clone, Copy, bytemuck::Pod, bytemuck::Zeroable)]
pub(crate) struct Params {
    pub(crate) ex_width: u32,
    pub(crate) channels: u32,
    pub(crate) w: u32,
    pub(crate) cand_w: u32,
    pub(crate) cand_h: u32,
    pub(crate) plane_w: u32,
    pub(crate) plane_len: u32,
    pub(crate) tol: u32,
    pub(crate) has_penalty: u32,
    pub(crate) info_stride: u32,
    pub(crate) n_queries: u32,
    pub(crate) capacity: u32,
    pub(crate) src_width: u32,
    pub(crate) src_height: u32,
    pub(crate) max_guesses: u32,
    pub(crate) guarded: u32,
    pub(crate) canvas_w: u32,
    pub(crate) canvas_h: u32,
    pub(crate) k16_lo: u32,
    pub(crate) k16_hi: u32,
    pub(crate) cap: u32,
    pub(crate) fronts: u32,
    pub(crate) sim_at: u32,
    pub(crate) sim_k: u32,
    pub(crate) n_random: u32,
    pub(crate) n_cand: u32,
    pub(crate) pad: [u32; 2],
}

impl Params {
    /// The search's parameters for `n_queries` windows of side `w` in exemplar `e` (its block
    /// sums in `res`), read from a source plane of `source` (width, height), with room for
    /// `capacity` survivors; the patch pass's fields zero.
    #[allow(clippy::too_many_arguments)]
    pub(crate) fn search(
        e: &Exemplar,
        res: &Resident,
        w: usize,
        tol: Tolerance,
        has_penalty: bool,
        n_queries: usize,
        capacity: usize,
        source: (usize, usize),
        random: usize,
    ) -> Self {
        let (cw, ch) = e.candidates(w);
        Self {
            ex_width: e.width() as u32,
            channels: e.channels() as u32,
            w: w as u32,
            cand_w: cw as u32,
            cand_h: ch as u32,
            plane_w: res.plane_w as u32,
            plane_len: res.plane_len as u32,
            tol: tol.0,
            has_penalty: u32::from(has_penalty),
            info_stride: info_stride(e.channels()) as u32,
            n_queries: n_queries as u32,
            capacity: capacity as u32,
            src_width: source.0 as u32,
            src_height: source.1 as u32,
            max_guesses: MAX_GUESSES as u32,
            ..Self::zeroed()
        }
        .over(res, random)
    }

    /// The search over each query's k-coherence candidates where `res` holds the similarity
    /// table, with `random` random ones; over every position where it does not.
    fn over(mut self, res: &Resident, random: usize) -> Self {
        if let Some(at) = res.sim_at {
            self.sim_at = at as u32;
            self.sim_k = SIMILAR as u32;
            self.n_random = random as u32;
            self.n_cand = candidates_per_query(random) as u32;
        }
        self
    }
}

/// Threads per query of the k-coherence search with `random` random candidates: the guess
/// slots, their similar positions and the random ones (search.wgsl, `position_of`).
pub(crate) fn candidates_per_query(random: usize) -> usize {
    MAX_GUESSES * (1 + SIMILAR) + random
}

/// Threads per query of a search over `positions` positions with `coherence` (the random
/// candidates' count) where it runs over k-coherence candidates.
pub(crate) fn threads_per_query(positions: usize, coherence: Option<usize>) -> usize {
    coherence.map_or(positions, candidates_per_query)
}

/// guesses.wgsl's parameters.
#[repr(C)]
#[derive(Clone, Copy, bytemuck::Pod, bytemuck::Zeroable)]
struct GuessParams {
    w: u32,
    n_queries: u32,
    stride: u32,
    exemplar: u32,
    ex_width: u32,
    cand_w: u32,
    cand_h: u32,
    canvas_w: u32,
    canvas_h: u32,
    wrap: u32,
    pad: [u32; 2],
}

impl GuessParams {
    /// For `n` windows of side `w` searched in exemplar `ex` (`e`), on a `width × height`
    /// canvas.
    fn new(
        e: &Exemplar,
        ex: usize,
        w: usize,
        n: usize,
        (width, height): (usize, usize),
        wrap: bool,
    ) -> Self {
        let (cw, ch) = e.candidates(w);
        Self {
            w: w as u32,
            n_queries: n as u32,
            stride: (3 + MAX_GUESSES) as u32,
            exemplar: ex as u32,
            ex_width: e.width() as u32,
            cand_w: cw as u32,
            cand_h: ch as u32,
            canvas_w: width as u32,
            canvas_h: height as u32,
            wrap: u32::from(wrap),
            pad: [0; 2],
        }
    }
}

/// Words of a query's `info` before its quadrant sums (search.wgsl's INFO_SUMS).
const INFO_HEAD: usize = 7;

/// Words of a query's `info` for `channels` channels: the head, then 4 quadrant sums each.
pub(crate) fn info_stride(channels: usize) -> usize {
    INFO_HEAD + 4 * channels
}
/// No guess / no answer (search.wgsl's NONE).
pub(crate) const NONE: u32 = u32::MAX;

/// Where a batch's query windows come from.
pub(crate) enum Windows<'a> {
    /// Uploaded with the batch, stacked one under the other.
    Uploaded(&'a [&'a Query]),
    /// Read from the plane kept on the GPU (`width × height` texels); the guesses made there
    /// from `sources` (sources, their exemplars) where given.
    Resident {
        plane: &'a wgpu::Buffer,
        width: usize,
        height: usize,
        wrap: bool,
        sources: Option<(&'a wgpu::Buffer, &'a wgpu::Buffer)>,
        queries: &'a [&'a WindowQuery],
    },
}

impl Windows<'_> {
    fn len(&self) -> usize {
        match self {
            Windows::Uploaded(q) => q.len(),
            Windows::Resident { queries, .. } => queries.len(),
        }
    }
}

pub(crate) fn gpu_error(detail: String) -> SynthError {
    invalid("GPU search", detail)
}

pub(crate) struct Pipelines {
    layout: wgpu::BindGroupLayout,
    guesses_layout: wgpu::BindGroupLayout,
    guesses: wgpu::ComputePipeline,
    prepare: wgpu::ComputePipeline,
    finish: wgpu::ComputePipeline,
    min_cost: wgpu::ComputePipeline,
    settle: wgpu::ComputePipeline,
    pick: wgpu::ComputePipeline,
    screen: wgpu::ComputePipeline,
    cost: wgpu::ComputePipeline,
    choose: wgpu::ComputePipeline,
}

/// The search pipelines, compiled once per process.
static PIPELINES: GpuCell<Pipelines> = GpuCell::new();

pub(crate) fn pipelines() -> Result<(&'static derma_core::gpu::Gpu, &'static Pipelines)> {
    Ok(PIPELINES.get_or_init(|ctx| {
        // One layout for all entry points: binding 0 uniform, 1–2 read-only storage,
        // 3–10 read-write storage.
        let (layout, [prepare, finish, min_cost, settle, pick, screen, cost, choose]) = ctx
            .entry_points(
                "search.wgsl",
                SHADER,
                2,
                8,
                [
                    "prepare", "finish", "min_cost", "settle", "pick", "screen", "cost", "choose",
                ],
            )?;
        // The coherent guesses of resident windows: binding 0 uniform, 1–2 read-only, 3
        // read-write.
        let (guesses_layout, [guesses]) =
            ctx.entry_points("guesses.wgsl", GUESSES_SHADER, 2, 1, ["guesses"])?;
        Ok(Pipelines {
            layout,
            guesses_layout,
            guesses,
            prepare,
            finish,
            min_cost,
            settle,
            pick,
            screen,
            cost,
            choose,
        })
    })?)
}

/// A buffer that is replaced by a larger one (the next power of two) when a batch needs more.
struct Growing {
    buf: wgpu::Buffer,
    size: u64,
    usage: wgpu::BufferUsages,
    label: &'static str,
}

impl Growing {
    fn new(d: &wgpu::Device, label: &'static str, usage: wgpu::BufferUsages) -> Self {
        let size = 256;
        Self {
            buf: d.create_buffer(&wgpu::BufferDescriptor {
                label: Some(label),
                size,
                usage,
                mapped_at_creation: false,
            }),
            size,
            usage,
            label,
        }
    }

    fn fit(&mut self, d: &wgpu::Device, bytes: u64) {
        if bytes > self.size {
            self.size = bytes.next_power_of_two();
            self.buf = d.create_buffer(&wgpu::BufferDescriptor {
                label: Some(self.label),
                size: self.size,
                usage: self.usage,
                mapped_at_creation: false,
            });
        }
    }
}

/// The per-batch buffers, kept between batches.
struct Scratch {
    params: wgpu::Buffer,
    qcodes: Growing,
    windows: Growing,
    info: Growing,
    penalty: Growing,
    result: Growing,
    limits: Growing,
    survivors: Growing,
    costs: Growing,
    staging: Growing,
}

impl Scratch {
    fn new(d: &wgpu::Device) -> Self {
        use wgpu::BufferUsages as U;
        let input = U::STORAGE | U::COPY_DST;
        Self {
            params: d.create_buffer(&wgpu::BufferDescriptor {
                label: Some("params"),
                size: std::mem::size_of::<Params>() as u64,
                usage: U::UNIFORM | U::COPY_DST,
                mapped_at_creation: false,
            }),
            qcodes: Growing::new(d, "query codes", input),
            windows: Growing::new(d, "query windows", input),
            info: Growing::new(d, "query info", input),
            penalty: Growing::new(d, "penalty", input),
            result: Growing::new(d, "result", input | U::COPY_SRC),
            limits: Growing::new(d, "limits", U::STORAGE),
            survivors: Growing::new(d, "survivors", U::STORAGE),
            costs: Growing::new(d, "costs", U::STORAGE),
            staging: Growing::new(d, "read back", U::MAP_READ | U::COPY_DST),
        }
    }
}

/// An exemplar's codes and block sums for one window side, resident on the GPU.
pub(crate) struct Resident {
    /// The exemplar's codes, then the similarity table where the search is k-coherent.
    pub(crate) codes: wgpu::Buffer,
    pub(crate) sums: wgpu::Buffer,
    pub(crate) plane_w: usize,
    pub(crate) plane_len: usize,
    /// Where the similarity table starts in `codes`, if it is there.
    pub(crate) sim_at: Option<usize>,
}

/// An upload's key: the exemplar's codes (address, length), the window side, and whether it
/// carries the similarity table.
type ResidentKey = (usize, usize, usize, bool);

/// The GPU matcher. Exemplar uploads are kept for the matcher's life, keyed by the exemplar's
/// codes (address and length) and the window side; one matcher is meant for one exemplar set.
pub struct GpuMatcher {
    resident: Mutex<HashMap<ResidentKey, Arc<Resident>>>,
    scratch: Mutex<Option<Scratch>>,
    pub(crate) name: String,
    max_survivors: usize,
    pub(crate) patch_rounds: usize,
    pub(crate) patch_wavefronts: usize,
    /// Whether the rounds recorded per wavefront grow to the most any wavefront has taken.
    pub(crate) patch_adaptive: bool,
}

impl GpuMatcher {
    /// Opens the GPU; the error says why none could be opened.
    pub fn new() -> Result<Self> {
        let (ctx, _) = pipelines()?;
        // The survivors (8 bytes each) must fit one storage binding of this adapter: lavapipe
        // binds 128 MiB, below MAX_SURVIVORS' 256 MiB (wgpu stopped the process on a 256²
        // exemplar there). Fewer survivors only send more batches down the uncompacted path,
        // which gives the same answer.
        let l = ctx.device.limits();
        let bindable = (l.max_storage_buffer_binding_size.min(l.max_buffer_size) / 8).max(1);
        // A power of two: the buffer grows to the next one of what it holds.
        let bindable = 1usize << bindable.ilog2();
        Ok(Self {
            resident: Mutex::new(HashMap::new()),
            scratch: Mutex::new(None),
            name: ctx.name.clone(),
            max_survivors: MAX_SURVIVORS.min(bindable),
            patch_rounds: PATCH_ROUNDS,
            patch_wavefronts: PATCH_WAVEFRONTS,
            patch_adaptive: true,
        })
    }

    /// As [`GpuMatcher::new`] with the patch pass recording `rounds` rounds per wavefront
    /// (fixed: by default they grow to the most any wavefront has taken) and `wavefronts`
    /// wavefronts per submission. Tests use few, so that wavefronts stop submissions and get
    /// more rounds; the sources are the same for any.
    pub fn with_patch_schedule(rounds: usize, wavefronts: usize) -> Result<Self> {
        Ok(Self {
            patch_rounds: rounds.max(1),
            patch_wavefronts: wavefronts.max(1),
            patch_adaptive: false,
            ..Self::new()?
        })
    }

    /// Room for survivors of the bound for `queries` queries of `candidates` positions each: a
    /// quarter of them, within what one binding of the adapter holds.
    pub(crate) fn survivor_room(&self, queries: usize, candidates: usize) -> usize {
        (queries * candidates / 4).clamp(self.max_survivors.min(1 << 16), self.max_survivors)
    }

    /// As [`GpuMatcher::new`] with room for at most `n` bound survivors per dispatch (tests
    /// use it to exercise the uncompacted fallback).
    pub fn with_survivor_room(n: usize) -> Result<Self> {
        Ok(Self {
            max_survivors: n.max(1),
            ..Self::new()?
        })
    }

    /// Exemplar `ex`'s upload for windows of side `w`, with the similarity table of
    /// `coherence` (for that side) where given.
    pub(crate) fn resident(
        &self,
        set: &ExemplarSet,
        ex: usize,
        w: usize,
        coherence: Option<&Coherence>,
    ) -> Result<Arc<Resident>> {
        let mut map = self
            .resident
            .lock()
            .map_err(|_| gpu_error("a previous search panicked".into()))?;
        let e = &set.exemplars[ex];
        let key = (
            e.codes.as_ptr() as usize,
            e.codes.len(),
            w,
            coherence.is_some(),
        );
        if let Some(r) = map.get(&key) {
            return Ok(r.clone());
        }
        let (ctx, _) = pipelines()?;
        let half = w / 2;
        let plane_w = e.width() + 1 - half;
        let plane_len = plane_w * (e.height() + 1 - half);
        let mut codes: Vec<u32> = e.codes.iter().map(|&v| v as u32).collect();
        let sim_at = coherence.map(|c| {
            let at = codes.len();
            codes.extend_from_slice(&c.tables[ex]);
            at
        });
        let sums: Vec<f32> = e.block_sums(half).into_iter().flatten().collect();
        let init = |label, bytes: &[u8]| ctx.upload(label, bytes, wgpu::BufferUsages::STORAGE);
        let r = Arc::new(Resident {
            codes: init("exemplar codes", bytemuck::cast_slice(&codes)),
            sums: init("exemplar block sums", bytemuck::cast_slice(&sums)),
            plane_w,
            plane_len,
            sim_at,
        });
        map.insert(key, r.clone());
        Ok(r)
    }

    /// One batch of queries of one exemplar: the compacted search, or the uncompacted one when
    /// more candidates survive the bound than there is room for.
    pub(crate) fn run(
        &self,
        set: &ExemplarSet,
        s: &Search,
        ex: usize,
        batch: Windows,
    ) -> Result<Vec<Match>> {
        let (ctx, pipes) = pipelines()?;
        let t0 = std::time::Instant::now();
        let w = s.w;
        let e = &set.exemplars[ex];
        let (cw, ch) = e.candidates(w);
        let res = self.resident(set, ex, w, s.coherence.map(|c| c.tables))?;
        let n = batch.len();
        let words = BatchWords::new(set, s, &batch, e.channels());
        let candidates = cw * ch;
        let random = s.coherence.map(|c| c.random);
        let threads = threads_per_query(candidates, random);
        let shape = BatchShape {
            n,
            info_stride: info_stride(e.channels()),
            threads,
            capacity: self.survivor_room(n, threads),
        };
        let penalty: &[u32] = s.penalty.map_or(&[0], |p| &p[ex]);
        let params = Params::search(
            e,
            &res,
            w,
            s.tol,
            s.penalty.is_some(),
            n,
            shape.capacity,
            words.source,
            random.unwrap_or(0),
        );
        let d = &ctx.device;
        // Buffers live as long as the matcher and grow when a batch needs more; one batch runs
        // at a time, holding them.
        let mut guard = self
            .scratch
            .lock()
            .map_err(|_| gpu_error("a previous search panicked".into()))?;
        let sc = guard.get_or_insert_with(|| Scratch::new(d));
        sc.fit_batch(d, &words, penalty, &shape);
        sc.upload_batch(&ctx.queue, &words, &params, penalty);
        let (source, prepare) = match &batch {
            Windows::Uploaded(_) => (&sc.qcodes.buf, None),
            Windows::Resident { plane, .. } => (*plane, Some(&pipes.prepare)),
        };
        let search = BatchSearch {
            ctx,
            pipes,
            prepare,
            sc,
            result: &words.result,
            shape,
        };
        search.guesses(&batch, e, ex, w);
        search.reset_results();
        let group = search.bind(&res, source);
        let t1 = std::time::Instant::now();
        let out = search.run(&group)?;
        let t2 = std::time::Instant::now();
        let out = matches(&out[..n * 2], candidates);
        tracing::debug!(
            "GPU search: {n} queries of side {w}: prepare {:.2} ms, GPU {:.2} ms, finish {:.2} ms",
            (t1 - t0).as_secs_f64() * 1e3,
            (t2 - t1).as_secs_f64() * 1e3,
            t2.elapsed().as_secs_f64() * 1e3
        );
        out
    }
}

/// One batch's sizes: queries, info words per query, threads per query (the positions, or the
/// k-coherence candidates) and room for the bound's survivors.
#[derive(Clone, Copy)]
struct BatchShape {
    n: usize,
    info_stride: usize,
    threads: usize,
    capacity: usize,
}

impl BatchShape {
    /// Where the survivor counter follows the per-query results, in bytes.
    fn counter_at(&self) -> u64 {
        (self.n * 2 * 4) as u64
    }
}

/// A batch's words for the GPU: the uploaded windows' codes, the resident windows' rows, the
/// queries' info, the first results with the survivor counter, and the source plane's size.
struct BatchWords {
    qcodes: Vec<u32>,
    windows: Vec<u32>,
    info: Vec<u32>,
    result: Vec<u32>,
    source: (usize, usize),
}

impl BatchWords {
    /// The queries' info and first results; for uploaded windows also their codes (256 where
    /// unknown), stacked, and the info's sums and guesses' cost, computed here; for resident
    /// windows their rows (origin, salt, guesses). The exemplar has `c` channels.
    fn new(set: &ExemplarSet, s: &Search, batch: &Windows, c: usize) -> Self {
        let mut words = match batch {
            Windows::Uploaded(queries) => uploaded_words(set, s, queries, c),
            Windows::Resident {
                width,
                height,
                queries,
                ..
            } => Self {
                qcodes: Vec::new(),
                windows: resident_rows(queries),
                info: Vec::with_capacity(queries.len() * info_stride(c)),
                result: Vec::with_capacity(queries.len() * 2 + 1),
                source: (*width, *height),
            },
        };
        // The survivor counter follows the per-query results (which `prepare` writes for
        // resident windows, as it writes their info).
        words.result.push(0);
        words
    }
}

/// [`BatchWords`] of uploaded windows: their codes (256 where unknown), stacked, and their info
/// (the fully known quadrants and their sums, as on the CPU) and first results; `c` channels.
fn uploaded_words(set: &ExemplarSet, s: &Search, queries: &[&Query], c: usize) -> BatchWords {
    let w = s.w;
    let half = w / 2;
    let n = queries.len();
    let prepared: Vec<(Vec<u32>, Vec<u32>, u32)> = queries
        .par_iter()
        .enumerate()
        .map(|(i, q)| {
            let known = |t: usize| q.mask.as_ref().is_none_or(|m| m[t] != 0);
            let codes: Vec<u32> = q
                .codes
                .iter()
                .enumerate()
                .map(|(i, &v)| if known(i / c) { v as u32 } else { 256 })
                .collect();
            // The fully known quadrants (bit q of the mask) and their sums, as on the CPU.
            let mut quad_mask = 0u32;
            let mut quad_sums = vec![0f32; 4 * c];
            for (ox, oy, sum) in known_block_sums(q, w, c, half) {
                let quad = usize::from(ox > 0) + 2 * usize::from(oy > 0);
                quad_mask |= 1 << quad;
                quad_sums[quad * c..(quad + 1) * c].copy_from_slice(&sum);
            }
            let first = initial_cost(set, s, q);
            let origin_y = (i * w) as u32;
            // Known, salt, quadrants, first cost, origin, flags (searched).
            let mut info = vec![known_texels(q, w), q.salt, quad_mask, first, 0, origin_y, 0];
            info.extend(quad_sums.iter().map(|v| v.to_bits()));
            (codes, info, first)
        })
        .collect();
    let mut qcodes: Vec<u32> = Vec::with_capacity(n * w * w * c);
    let mut info: Vec<u32> = Vec::with_capacity(n * info_stride(c));
    let mut result: Vec<u32> = Vec::with_capacity(n * 2 + 1);
    for (codes, inf, first) in prepared {
        qcodes.extend_from_slice(&codes);
        info.extend_from_slice(&inf);
        result.extend_from_slice(&[first, NONE]);
    }
    // The guesses, for the k-coherence search's candidates (rows as resident windows have).
    let rows: Vec<WindowQuery> = queries
        .iter()
        .enumerate()
        .map(|(i, q)| WindowQuery {
            exemplar: q.exemplar,
            x: 0,
            y: (i * w) as u32,
            guesses: q.guesses.clone(),
            salt: q.salt,
        })
        .collect();
    let windows = if s.coherence.is_some() {
        resident_rows(&rows.iter().collect::<Vec<_>>())
    } else {
        Vec::new()
    };
    BatchWords {
        qcodes,
        windows,
        info,
        result,
        source: (w, n * w),
    }
}

/// The rows of resident windows: origin, salt and guesses. Guesses left empty are made on the
/// GPU (`guesses`), over these NONEs; `prepare` writes the info and the first results from the
/// windows' origins, salts and guesses.
fn resident_rows(queries: &[&WindowQuery]) -> Vec<u32> {
    let stride = 3 + MAX_GUESSES;
    let mut windows = vec![NONE; queries.len() * stride];
    for (q, row) in queries.iter().zip(windows.chunks_exact_mut(stride)) {
        row[..3].copy_from_slice(&[q.x, q.y, q.salt]);
        row[3..3 + q.guesses.len()].copy_from_slice(&q.guesses);
    }
    windows
}

impl Scratch {
    /// Grows the buffers to hold the batch of `shape`, its `words` and `penalty`.
    fn fit_batch(
        &mut self,
        d: &wgpu::Device,
        words: &BatchWords,
        penalty: &[u32],
        shape: &BatchShape,
    ) {
        let (n, capacity, counter_at) = (shape.n, shape.capacity, shape.counter_at());
        let bytes = |v: &[u32]| std::mem::size_of_val(v).max(4) as u64;
        self.qcodes.fit(d, bytes(&words.qcodes));
        self.windows.fit(d, bytes(&words.windows));
        self.info.fit(d, (n * shape.info_stride * 4) as u64);
        self.penalty.fit(d, bytes(penalty));
        self.result.fit(d, counter_at + 4);
        self.limits.fit(d, (n * 4) as u64);
        self.survivors.fit(d, (capacity * 8) as u64);
        self.costs.fit(d, (capacity * 4) as u64);
        self.staging.fit(d, counter_at + 4);
    }

    /// Writes the batch's parameters, the words its source needs and the penalty.
    fn upload_batch(&self, q: &wgpu::Queue, words: &BatchWords, params: &Params, penalty: &[u32]) {
        q.write_buffer(&self.params, 0, bytemuck::bytes_of(params));
        // Only what this source needs goes up (`prepare` writes a resident batch's info).
        for (buf, words) in [
            (&self.qcodes, &words.qcodes),
            (&self.windows, &words.windows),
            (&self.info, &words.info),
        ] {
            if !words.is_empty() {
                q.write_buffer(&buf.buf, 0, bytemuck::cast_slice(words));
            }
        }
        q.write_buffer(&self.penalty.buf, 0, bytemuck::cast_slice(penalty));
    }
}

/// One batch's search on the GPU: the pipelines, `prepare` for resident windows, the kept
/// buffers, the first results and the batch's sizes.
struct BatchSearch<'a> {
    ctx: &'a derma_core::gpu::Gpu,
    pipes: &'a Pipelines,
    prepare: Option<&'a wgpu::ComputePipeline>,
    sc: &'a Scratch,
    result: &'a [u32],
    shape: BatchShape,
}

impl BatchSearch<'_> {
    /// The coherent guesses of resident windows from the sources kept on the GPU, where the
    /// batch has them (exemplar `e`, number `ex`, window side `w`), before `prepare` reads them.
    fn guesses(&self, batch: &Windows, e: &Exemplar, ex: usize, w: usize) {
        if let Windows::Resident {
            width,
            height,
            wrap,
            sources: Some((sources, source_exemplars)),
            ..
        } = batch
        {
            let gp = GuessParams::new(e, ex, w, batch.len(), (*width, *height), *wrap);
            make_guesses(
                self.ctx,
                self.pipes,
                &gp,
                (sources, source_exemplars),
                &self.sc.windows.buf,
            );
        }
    }

    /// Writes the first results (for resident windows only the survivor counter: `prepare`
    /// writes the rest).
    fn reset_results(&self) {
        let at = if self.prepare.is_some() {
            self.shape.counter_at()
        } else {
            0
        };
        self.ctx
            .queue
            .write_buffer(&self.sc.result.buf, at, bytemuck::cast_slice(self.result));
    }

    /// The search's bind group, the windows read from `source`.
    fn bind(&self, res: &Resident, source: &wgpu::Buffer) -> wgpu::BindGroup {
        let sc = self.sc;
        let buffers = [
            &sc.params,
            &res.codes,
            &res.sums,
            source,
            &sc.penalty.buf,
            &sc.windows.buf,
            &sc.info.buf,
            &sc.result.buf,
            &sc.limits.buf,
            &sc.survivors.buf,
            &sc.costs.buf,
        ];
        self.ctx
            .bind_buffers("search", &self.pipes.layout, &buffers)
    }

    /// The compacted search, or the uncompacted one where more candidates pass the bound than
    /// there is room for; the result words.
    fn run(&self, group: &wgpu::BindGroup) -> Result<Vec<u32>> {
        let pipes = self.pipes;
        let (n, capacity) = (self.shape.n, self.shape.capacity);
        let groups_x = self.shape.threads.div_ceil(WORKGROUP) as u32;
        let nq = n as u32;
        let per_query = derma_core::gpu::grid(n, WORKGROUP);
        let survivor_dims = derma_core::gpu::grid(capacity, WORKGROUP);
        let mut out = self.run_steps(
            group,
            &[
                (&pipes.screen, (groups_x, nq)),
                (&pipes.cost, survivor_dims),
                (&pipes.settle, per_query),
                (&pipes.choose, survivor_dims),
            ],
        )?;
        if out[n * 2] as usize > capacity {
            // More passed the bound than there was room for: the uncompacted search.
            tracing::debug!(
                "GPU search: {} candidates passed the bound, room for {capacity}; searching uncompacted",
                out[n * 2]
            );
            self.reset_results();
            out = self.run_steps(
                group,
                &[
                    (&pipes.min_cost, (groups_x, nq)),
                    (&pipes.settle, per_query),
                    (&pipes.pick, (groups_x, nq)),
                ],
            )?;
        }
        Ok(out)
    }

    /// Runs the steps (after `prepare` for resident windows, then `finish`) and reads the
    /// result words back through the kept staging buffer.
    fn run_steps(
        &self,
        group: &wgpu::BindGroup,
        steps: &[(&wgpu::ComputePipeline, (u32, u32))],
    ) -> Result<Vec<u32>> {
        let per_query = derma_core::gpu::grid(self.shape.n, WORKGROUP);
        let all: Vec<_> = self
            .prepare
            .map(|p| (p, per_query))
            .into_iter()
            .chain(steps.iter().copied())
            .chain([(&self.pipes.finish, per_query)])
            .collect();
        self.ctx.submit_passes(group, &all);
        let result_words = self.shape.n * 2 + 1;
        Ok(self
            .ctx
            .read_back_with(&self.sc.result.buf, &self.sc.staging.buf, result_words)?)
    }
}

/// The matches of the result words (cost, position) of each query; an error where a position
/// is not one of the `candidates`.
fn matches(words: &[u32], candidates: usize) -> Result<Vec<Match>> {
    words
        .chunks_exact(2)
        .map(|r| {
            let (cost, index) = (r[0], r[1]);
            if index as usize >= candidates {
                return Err(gpu_error(format!(
                    "the search returned position {index} of {candidates}"
                )));
            }
            Ok(Match { cost, index })
        })
        .collect()
}

/// Submits `guesses.wgsl` over the window rows in `windows` (x, y, salt, then the guesses it
/// writes), reading the canvas's sources and their exemplars.
fn make_guesses(
    ctx: &derma_core::gpu::Gpu,
    pipes: &Pipelines,
    gp: &GuessParams,
    (sources, source_exemplars): (&wgpu::Buffer, &wgpu::Buffer),
    windows: &wgpu::Buffer,
) {
    let params = ctx.upload(
        "guess params",
        bytemuck::bytes_of(gp),
        wgpu::BufferUsages::UNIFORM,
    );
    let group = ctx.bind_buffers(
        "guesses",
        &pipes.guesses_layout,
        &[&params, sources, source_exemplars, windows],
    );
    let dims = derma_core::gpu::grid(gp.n_queries as usize, WORKGROUP);
    ctx.submit_passes(&group, &[(&pipes.guesses, dims)]);
}

/// Runs `run` on the queries of each exemplar (`exemplar` of a query), in chunks of at most
/// `chunk`, and returns the answers in the queries' order.
pub(crate) fn by_exemplar<'q, Q>(
    set: &ExemplarSet,
    queries: &'q [Q],
    exemplar: impl Fn(&Q) -> u32,
    chunk: usize,
    mut run: impl FnMut(usize, &[&'q Q]) -> Result<Vec<Match>>,
) -> Result<Vec<Match>> {
    let mut out = vec![Match { cost: 0, index: 0 }; queries.len()];
    for ex in 0..set.exemplars.len() {
        let mine: Vec<usize> = (0..queries.len())
            .filter(|&i| exemplar(&queries[i]) as usize == ex)
            .collect();
        for part in mine.chunks(chunk) {
            let qs: Vec<&Q> = part.iter().map(|&i| &queries[i]).collect();
            for (&i, m) in part.iter().zip(run(ex, &qs)?) {
                out[i] = m;
            }
        }
    }
    Ok(out)
}

/// Most queries of one batch: a dimension of the screening grid (one row of workgroups per
/// query).
pub(crate) const MAX_BATCH_QUERIES: usize = 65_535;

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn guesses_made_from_sources_on_the_gpu_are_the_hosts() {
        // guesses.wgsl against Canvas::coherent_guess: texels without a source, sources in
        // another exemplar, continuations clamped at the candidates' edges, repeats, windows
        // wrapping on a torus.
        if derma_test_support::skip_without_gpu() {
            return;
        }
        use crate::canvas::{Canvas, NO_SOURCE};
        use crate::texture::Texture;
        let (ctx, pipes) = pipelines().unwrap();
        let rng = derma_core::rng::Philox::new(3, 9);
        let textures: Vec<Texture> = [(40, 30), (24, 24)]
            .iter()
            .map(|&(w, h)| Texture::new(w, h, 1, vec![0.5; w * h]).unwrap())
            .collect();
        let set = ExemplarSet::new(textures, 8).unwrap();
        for (tile, w) in [(false, 8), (true, 8), (true, 4), (false, 2)] {
            let mut canvas = Canvas::new(45, 37, 1, tile);
            for t in 0..45 * 37 {
                let r = rng.u32x4_sub(t as u64, w as u32);
                let ex = (r[0] % 2) as usize;
                canvas.src_exemplar[t] = ex as u8;
                let len = set.exemplars[ex].width() * set.exemplars[ex].height();
                // Neighbours often continue each other, so guesses repeat.
                canvas.src[t] = match r[1] % 4 {
                    0 => NO_SOURCE,
                    1 => (t % len) as u32,
                    _ => r[2] % len as u32,
                };
            }
            let probes = crate::optimize::probes(w);
            let (xs, ys) = crate::optimize::window_origins(&canvas, w);
            let origins: Vec<(usize, usize)> = ys
                .iter()
                .flat_map(|&y| xs.iter().map(move |&x| (x, y)))
                .collect();
            let stride = 3 + MAX_GUESSES;
            let mut rows = vec![NONE; origins.len() * stride];
            for (row, &(x, y)) in rows.chunks_exact_mut(stride).zip(&origins) {
                row[..3].copy_from_slice(&[x as u32, y as u32, 7]);
            }
            let init =
                |label, words: &[u32], usage| ctx.upload(label, bytemuck::cast_slice(words), usage);
            use wgpu::BufferUsages as U;
            let src = init("sources", &canvas.src, U::STORAGE);
            let src_ex: Vec<u32> = canvas.src_exemplar.iter().map(|&e| e as u32).collect();
            let src_ex = init("source exemplars", &src_ex, U::STORAGE);
            for ex in 0..2 {
                let windows = init("windows", &rows, U::STORAGE | U::COPY_SRC);
                let gp = GuessParams::new(&set.exemplars[ex], ex, w, origins.len(), (45, 37), tile);
                make_guesses(ctx, pipes, &gp, (&src, &src_ex), &windows);
                let got: Vec<u32> = ctx.read_back(&windows, rows.len()).unwrap();
                for (row, &(x, y)) in got.chunks_exact(stride).zip(&origins) {
                    let mut want = canvas.coherent_guess(&set, ex, x, y, w, &probes);
                    want.resize(MAX_GUESSES, NONE);
                    assert_eq!(
                        &row[3..],
                        &want[..],
                        "window ({x}, {y}), exemplar {ex}, side {w}, tile {tile}"
                    );
                }
            }
        }
    }

    #[test]
    fn the_survivor_buffer_fits_one_binding_of_the_adapter() {
        // wgpu stops the process on a binding beyond the adapter's limit (lavapipe: 128 MiB,
        // which MAX_SURVIVORS' 256 MiB once exceeded on a 256² exemplar).
        if derma_test_support::skip_without_gpu() {
            return;
        }
        let m = GpuMatcher::new().unwrap();
        let l = derma_core::gpu::context().unwrap().device.limits();
        let limit = l.max_storage_buffer_binding_size.min(l.max_buffer_size);
        // The buffer grows to the next power of two of the bytes it holds.
        let bytes = ((m.max_survivors * 8) as u64).next_power_of_two();
        assert!(bytes <= limit, "{bytes} bytes of survivors, limit {limit}");
    }
}

//! The GPU's [`Matcher`] (Shen et al. §3.4 on a device): batches of uploaded windows, windows
//! of a canvas uploaded once per pass, windows of the canvas the optimiser keeps on the GPU
//! (`resident.rs`) with their coherent guesses made there, and whole patch passes.

use crate::error::{invalid, Result};
use crate::exemplar::ExemplarSet;
use crate::gpu::{by_exemplar, pipelines, GpuMatcher, Windows, MAX_BATCH_QUERIES, MAX_QUERY_BYTES};
use crate::matcher::{gathered_window_matches, Matcher, PatchPlan};
use crate::resident::GpuCanvas;
use crate::search::{Match, Plane, Query, Search, WindowQuery, MAX_GUESSES};
use derma_core::progress::Progress;
use rayon::prelude::*;
use std::any::Any;

/// A canvas whose codes are on the GPU, as a batch's windows read them: the codes, the size,
/// whether it wraps, and the sources (sources, their exemplars) to make the coherent guesses
/// from, where the queries carry none.
#[derive(Clone, Copy)]
struct OnGpu<'a> {
    codes: &'a wgpu::Buffer,
    width: usize,
    height: usize,
    wrap: bool,
    sources: Option<(&'a wgpu::Buffer, &'a wgpu::Buffer)>,
}

impl GpuMatcher {
    /// The GPU's matcher behind `matcher`, if it is one: the optimisation passes then keep the
    /// canvas on the GPU and search it with [`GpuMatcher::kept_window_matches`].
    pub(crate) fn behind(matcher: &dyn Matcher) -> Option<&GpuMatcher> {
        let any: &dyn Any = matcher;
        any.downcast_ref()
    }

    /// The answer of each window query of the canvas the optimiser keeps on the GPU (`kept`):
    /// the answers [`Matcher::window_matches`] gives for the same canvas on the host. Queries
    /// without guesses (all or none) get the coherent guesses made there from `kept`'s sources.
    pub(crate) fn kept_window_matches(
        &self,
        set: &ExemplarSet,
        s: &Search,
        kept: &GpuCanvas,
        queries: &[WindowQuery],
        progress: &dyn Progress,
    ) -> Result<Vec<Match>> {
        let guess_here = unguessed(queries)?;
        let canvas = OnGpu {
            codes: &kept.codes,
            width: kept.width,
            height: kept.height,
            wrap: kept.wrap,
            sources: guess_here.then_some((&kept.sources, &kept.source_exemplars)),
        };
        self.on_gpu_matches(set, s, canvas, queries, progress)
    }

    /// The answers of window queries of `canvas`, exemplar by exemplar in batches.
    fn on_gpu_matches(
        &self,
        set: &ExemplarSet,
        s: &Search,
        canvas: OnGpu,
        queries: &[WindowQuery],
        progress: &dyn Progress,
    ) -> Result<Vec<Match>> {
        by_exemplar(
            set,
            queries,
            |q| q.exemplar,
            MAX_BATCH_QUERIES,
            |ex, qs| {
                let windows = Windows::Resident {
                    plane: canvas.codes,
                    width: canvas.width,
                    height: canvas.height,
                    wrap: canvas.wrap,
                    sources: canvas.sources,
                    queries: qs,
                };
                let answers = self.run(set, s, ex, windows)?;
                progress.advance(qs.len() as u64);
                Ok(answers)
            },
        )
    }
}

/// Whether the queries carry no guesses (to be made on the GPU); an error where some do and some
/// do not, or where one carries more than [`MAX_GUESSES`].
fn unguessed(queries: &[WindowQuery]) -> Result<bool> {
    let unguessed = queries.iter().filter(|q| q.guesses.is_empty()).count();
    if unguessed > 0 && unguessed < queries.len() {
        return Err(invalid(
            "window query",
            format!(
                "{unguessed} of {} windows without guesses (expected guesses for every window, \
                 or for none)",
                queries.len()
            ),
        ));
    }
    if let Some(q) = queries.iter().find(|q| q.guesses.len() > MAX_GUESSES) {
        return Err(invalid(
            "window query",
            format!(
                "{} guesses at ({}, {}) (at most {MAX_GUESSES})",
                q.guesses.len(),
                q.x,
                q.y
            ),
        ));
    }
    Ok(unguessed > 0)
}

impl Matcher for GpuMatcher {
    fn best_matches(&self, set: &ExemplarSet, s: &Search, queries: &[Query]) -> Result<Vec<Match>> {
        if let Some(q) = queries.iter().find(|q| q.guesses.len() > MAX_GUESSES) {
            return Err(invalid(
                "query",
                format!("{} guesses (at most {MAX_GUESSES})", q.guesses.len()),
            ));
        }
        let per_query = s.w * s.w * set.channels() * 4;
        let chunk = (MAX_QUERY_BYTES / per_query).clamp(1, MAX_BATCH_QUERIES);
        by_exemplar(
            set,
            queries,
            |q| q.exemplar,
            chunk,
            |ex, qs| self.run(set, s, ex, Windows::Uploaded(qs)),
        )
    }

    fn window_matches(
        &self,
        set: &ExemplarSet,
        s: &Search,
        plane: &Plane,
        queries: &[WindowQuery],
        progress: &dyn Progress,
    ) -> Result<Vec<Match>> {
        // The host's plane has no sources here to guess from: every window brings its guesses.
        if unguessed(queries)? {
            return Err(invalid(
                "window query",
                format!(
                    "{} windows without guesses (a search of the host's canvas needs them)",
                    queries.len()
                ),
            ));
        }
        let (ctx, _) = pipelines()?;
        // The canvas's codes, uploaded once for this pass.
        let bytes = (plane.codes.len() * 4) as u64;
        if let Err(e) = ctx.check_storage("the canvas", bytes) {
            // A plane this adapter cannot bind whole: its windows travel with the batches.
            tracing::debug!("GPU search: {e}; uploading the windows instead");
            return gathered_window_matches(self, set, s, plane, queries, progress);
        }
        let codes: Vec<u32> = plane.codes.par_iter().map(|&v| v as u32).collect();
        let uploaded = ctx.upload(
            "canvas codes",
            bytemuck::cast_slice(&codes),
            wgpu::BufferUsages::STORAGE,
        );
        let canvas = OnGpu {
            codes: &uploaded,
            width: plane.width,
            height: plane.height,
            wrap: plane.wrap,
            sources: None,
        };
        self.on_gpu_matches(set, s, canvas, queries, progress)
    }

    fn name(&self) -> String {
        format!("GPU ({})", self.name)
    }

    fn patch_pass(
        &self,
        set: &ExemplarSet,
        plan: &PatchPlan,
        progress: &dyn Progress,
    ) -> Result<Option<Vec<u32>>> {
        self.patch_pass_resident(set, plan, progress)
    }

    fn device(&self) -> derma_core::gpu::Device {
        derma_core::gpu::Device::Gpu
    }
}

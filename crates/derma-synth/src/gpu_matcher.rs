//! The GPU's [`Matcher`] (Shen et al. §3.4 on a device): batches of uploaded windows, windows
//! of a canvas kept on the GPU with their coherent guesses made there, and whole patch passes.

use crate::error::{invalid, Result};
use crate::exemplar::ExemplarSet;
use crate::gpu::{by_exemplar, pipelines, GpuMatcher, Windows, MAX_BATCH_QUERIES, MAX_QUERY_BYTES};
use crate::matcher::{gathered_window_matches, Matcher, PatchPlan};
use crate::search::{Match, Plane, Query, Search, WindowQuery, MAX_GUESSES};
use derma_core::progress::Progress;
use rayon::prelude::*;

impl Matcher for GpuMatcher {
    fn best_matches(&self, set: &ExemplarSet, s: &Search, queries: &[Query]) -> Result<Vec<Match>> {
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
        // No guesses at all: made here from the plane's sources on the GPU.
        let unguessed = queries.iter().filter(|q| q.guesses.is_empty()).count();
        let guess_here = unguessed > 0;
        if guess_here && (unguessed < queries.len() || plane.gpu.is_none()) {
            return Err(invalid(
                "window query",
                format!(
                    "{unguessed} of {} windows without guesses (expected guesses for every \
                     window, or for none where the plane's sources are on the GPU)",
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
        let (ctx, _) = pipelines()?;
        // The canvas's codes: kept here by the GPU's E-step, or uploaded once for this pass.
        let uploaded;
        let buf = match plane.gpu {
            Some(g) => g.codes,
            None => {
                let bytes = (plane.codes.len() * 4) as u64;
                if let Err(e) = ctx.check_storage("the canvas", bytes) {
                    // A plane this adapter cannot bind whole: its windows travel with the
                    // batches.
                    tracing::debug!("GPU search: {e}; uploading the windows instead");
                    return gathered_window_matches(self, set, s, plane, queries, progress);
                }
                let codes: Vec<u32> = plane.codes.par_iter().map(|&v| v as u32).collect();
                uploaded = ctx.upload(
                    "canvas codes",
                    bytemuck::cast_slice(&codes),
                    wgpu::BufferUsages::STORAGE,
                );
                &uploaded
            }
        };
        by_exemplar(
            set,
            queries,
            |q| q.exemplar,
            MAX_BATCH_QUERIES,
            |ex, qs| {
                let windows = Windows::Resident {
                    plane: buf,
                    width: plane.width,
                    height: plane.height,
                    wrap: plane.wrap,
                    sources: plane
                        .gpu
                        .filter(|_| guess_here)
                        .map(|g| (g.sources, g.source_exemplars)),
                    queries: qs,
                };
                let answers = self.run(set, s, ex, windows)?;
                progress.advance(qs.len() as u64);
                Ok(answers)
            },
        )
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

//! The synthesis canvas kept on the GPU between optimisation passes (Shen et al. §3.3 run on a
//! device): the buffers a GPU E-step leaves there and the GPU matcher searches, and their
//! read-back. Owned by the optimiser's GPU path (`gpu_optimize.rs`), beside the host's canvas,
//! which never refers to it.

use crate::canvas::Canvas;
use crate::error::Result;
use derma_core::gpu::Gpu;
use rayon::prelude::*;

/// A canvas as the GPU's E-step left it (one 32-bit word per value, code, source and source
/// exemplar), kept there for the next pass's guesses and search: newer than the host's canvas
/// it was blended for, until [`GpuCanvas::read_into`] brings it back.
pub(crate) struct GpuCanvas {
    /// The device that holds the buffers.
    pub ctx: &'static Gpu,
    /// The values, `width × height × channels`.
    pub values: wgpu::Buffer,
    /// The codes, one per value.
    pub codes: wgpu::Buffer,
    /// Source texel per texel (y · exemplar width + x, or `u32::MAX`).
    pub sources: wgpu::Buffer,
    /// Exemplar of the source per texel.
    pub source_exemplars: wgpu::Buffer,
    /// Texels per row.
    pub width: usize,
    /// Rows.
    pub height: usize,
    /// Values per texel.
    pub channels: usize,
    /// A torus (tileable output): windows continue across the edges.
    pub wrap: bool,
}

impl GpuCanvas {
    /// Copies everything back into the host's canvas (of the same size), making it current.
    pub(crate) fn read_into(self, canvas: &mut Canvas) -> Result<()> {
        let (n, c) = (self.width * self.height, self.channels);
        debug_assert_eq!((canvas.width, canvas.height), (self.width, self.height));
        let bits: Vec<u32> = self.ctx.read_back(&self.values, n * c)?;
        canvas
            .values
            .par_iter_mut()
            .zip(&bits)
            .for_each(|(v, &b)| *v = f32::from_bits(b));
        drop(bits);
        let words: Vec<u32> = self.ctx.read_back(&self.codes, n * c)?;
        canvas
            .codes
            .par_iter_mut()
            .zip(&words)
            .for_each(|(q, &w)| *q = w as u8);
        drop(words);
        canvas
            .src
            .copy_from_slice(&self.ctx.read_back::<u32>(&self.sources, n)?);
        let words: Vec<u32> = self.ctx.read_back(&self.source_exemplars, n)?;
        canvas
            .src_exemplar
            .par_iter_mut()
            .zip(&words)
            .for_each(|(e, &w)| *e = w as u8);
        Ok(())
    }
}

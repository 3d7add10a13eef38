//! The synthesis canvas kept on the GPU between optimisation passes (Shen et al. §3.3 run on a
//! device): the buffers a GPU E-step leaves there and a GPU matcher searches, and their read-back.

use crate::error::Result;
use derma_core::gpu::Gpu;
use rayon::prelude::*;

/// A [`crate::search::Plane`] kept on the GPU: its codes (one per 32-bit word) and, per texel, its source and
/// the source's exemplar, from which a GPU matcher makes the windows' coherent guesses.
#[derive(Clone, Copy, Debug)]
pub struct GpuPlane<'a> {
    /// The codes.
    pub codes: &'a wgpu::Buffer,
    /// Source texel per texel (y · exemplar width + x, or `u32::MAX`).
    pub sources: &'a wgpu::Buffer,
    /// Exemplar of the source per texel.
    pub source_exemplars: &'a wgpu::Buffer,
}

/// A canvas as the GPU's E-step left it (one 32-bit word per value, code, source and source
/// exemplar), kept there for the next pass's guesses and search.
pub(crate) struct Blended {
    pub ctx: &'static Gpu,
    pub values: wgpu::Buffer,
    pub codes: wgpu::Buffer,
    pub sources: wgpu::Buffer,
    pub source_exemplars: wgpu::Buffer,
    pub texels: usize,
    pub channels: usize,
}

impl Blended {
    /// The canvas as a search's plane.
    pub(crate) fn plane(&self) -> GpuPlane<'_> {
        GpuPlane {
            codes: &self.codes,
            sources: &self.sources,
            source_exemplars: &self.source_exemplars,
        }
    }

    /// Copies everything back into the host's canvas.
    pub(crate) fn read_into(
        self,
        values: &mut [f32],
        codes: &mut [u8],
        src: &mut [u32],
        src_exemplar: &mut [u8],
    ) -> Result<()> {
        let (n, c) = (self.texels, self.channels);
        let bits: Vec<u32> = self.ctx.read_back(&self.values, n * c)?;
        values
            .par_iter_mut()
            .zip(&bits)
            .for_each(|(v, &b)| *v = f32::from_bits(b));
        drop(bits);
        let words: Vec<u32> = self.ctx.read_back(&self.codes, n * c)?;
        codes
            .par_iter_mut()
            .zip(&words)
            .for_each(|(q, &w)| *q = w as u8);
        drop(words);
        src.copy_from_slice(&self.ctx.read_back::<u32>(&self.sources, n)?);
        let words: Vec<u32> = self.ctx.read_back(&self.source_exemplars, n)?;
        src_exemplar
            .par_iter_mut()
            .zip(&words)
            .for_each(|(e, &w)| *e = w as u8);
        Ok(())
    }
}

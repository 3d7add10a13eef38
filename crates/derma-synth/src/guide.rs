//! Region guidance (Shen et al. §3 extended to several exemplars): a map choosing, per output
//! texel, the exemplar its patches and windows are matched in (e.g. forehead, cheek, nose).

use crate::canvas::Canvas;
use crate::error::{invalid, Result};
use std::path::Path;

/// Region guidance: which exemplar each output texel draws from.
#[derive(Clone, Debug)]
pub struct Guide {
    /// Width of the guide map.
    pub width: usize,
    /// Height of the guide map.
    pub height: usize,
    /// Exemplar index per guide texel.
    pub exemplar: Vec<u8>,
}

impl Guide {
    /// A guide from a grey map: value v selects exemplar round(v · (count − 1)). The map is
    /// sampled at the nearest texel when its size differs from the output's.
    pub fn from_levels(width: usize, height: usize, levels: &[f32], count: usize) -> Self {
        let exemplar = levels
            .iter()
            .map(|&v| (v.clamp(0.0, 1.0) * (count - 1) as f32).round() as u8)
            .collect();
        Self {
            width,
            height,
            exemplar,
        }
    }

    /// The exemplar texel (x, y) of `canvas` draws from.
    pub(crate) fn at(&self, canvas: &Canvas, x: usize, y: usize) -> usize {
        let (x, y) = (x % canvas.width, y % canvas.height);
        let gx = (x * self.width / canvas.width).min(self.width - 1);
        let gy = (y * self.height / canvas.height).min(self.height - 1);
        self.exemplar[gy * self.width + gx] as usize
    }

    /// A guide from a grey image: level v selects exemplar round(v · (count − 1)).
    pub fn read(path: &Path, count: usize) -> Result<Self> {
        if count < 2 {
            return Err(invalid(
                "guide",
                "a guide chooses among exemplars: give at least two",
            ));
        }
        let g = derma_core::image_io::read_grey(path)?;
        let m = &g.channels[0];
        Ok(Guide::from_levels(m.width(), m.height(), m.data(), count))
    }
}

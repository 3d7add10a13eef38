//! The main job streamed: the bio maps painted (thesis §4.8.8's TexGen loop), converted and
//! encoded band by band of rows, so that only the band, the heights and the preview's maps are
//! whole-texture. Every file has the bits the whole path ([`crate::TextureSet::write`]) gives.
//!
//! What needs more than a band, and how it is had:
//! - The gutter between UV charts copies whole samples from each texel's dilation source,
//!   which may lie anywhere. The sources, and the texels their normals read, are painted first
//!   on their own ([`Painter::texels`]: a texel's sample does not depend on its row), with the
//!   sources' normal codes.
//! - Cavities and normals read the rows next to a texel: each band is painted with one row
//!   more on each side (wrapping on tileable patches).
//! - height.png is scaled by the heights' range: the heights are kept (4 bytes a texel) and it
//!   is written last. The statistics of report.json carry their blocks from band to band.

use crate::config::MaterialConfig;
use crate::features::BioSample;
use crate::paint::Painter;
use crate::report::Statistics;
use crate::surface::Surface;
use crate::texture_set::{
    convert_rows, normal_code, wrinkle_code, HeightRange, MapSinks, RenderMaps, Samples,
};
use derma_core::progress::{Progress, Silent, Unit};
use derma_core::Map;
use derma_shading::Appearance;
use rayon::prelude::*;
use std::path::Path;

/// Rows per band, before rounding to the preview's reduction: about 55 MB of samples at 8192
/// texels a row, and enough tasks of 8 rows for the cores.
const BAND_ROWS: usize = 128;

/// What the bands are made from.
pub(crate) struct Bands<'a> {
    pub painter: &'a Painter<'a>,
    pub surface: &'a Surface,
    /// The gutter's dilation sources (meshes only).
    pub dilation: Option<&'a [u32]>,
    pub appearance: &'a dyn Appearance,
    pub material: &'a MaterialConfig,
    /// Whether the preview keeps the subsurface maps (its GPU views draw them).
    pub keep_subsurface: bool,
}

/// What the streamed job leaves for the rest of the set's files.
pub(crate) struct Streamed {
    /// The map files written, in manifest order.
    pub files: Vec<&'static str>,
    pub height_range: HeightRange,
    pub statistics: Statistics,
    /// The render maps the preview draws, whole (no wrinkle normals).
    pub preview: RenderMaps,
    /// The contact sheet's bio channels ([`crate::preview::reduced_bio`]).
    pub reduced: [Map; 3],
}

/// Paints, converts and writes every map file of the set into `dir`, band by band.
pub(crate) fn write_bands(
    b: &Bands,
    dir: &Path,
    progress: &dyn Progress,
) -> crate::Result<Streamed> {
    let (w, h) = (b.surface.width, b.surface.height);
    progress.stage("paint the sources", 1, Unit::Steps);
    let gutter = b.dilation.map(|src| Gutter::paint(b, src));
    progress.stage("paint, convert and write", h as u64, Unit::Rows);
    let k = crate::preview::reduction(w, h);
    let rows = BAND_ROWS.div_ceil(k) * k;
    let mut state = State {
        sinks: None,
        statistics: Statistics::new(w * h),
        heights: Vec::with_capacity(w * h),
        preview: None,
        reduced: [Vec::new(), Vec::new(), Vec::new()],
    };
    // Each band is painted and converted while the last one is written, so the cores that
    // finish one side early help the other.
    let mut last: Option<(Band, RenderMaps)> = None;
    for a in (0..h).step_by(rows) {
        let (next, written) = rayon::join(
            || {
                let band = Band::paint(b, gutter.as_ref(), a..(a + rows).min(h));
                let maps = band.convert(b, gutter.as_ref());
                (band, maps)
            },
            || state.take_last(b, last.take(), dir, k, progress),
        );
        written?;
        last = Some(next);
    }
    state.take_last(b, last, dir, k, progress)?;
    state.finish(dir, (w, h), k)
}

/// The whole-texture state of the streamed job, filled band by band.
struct State {
    sinks: Option<MapSinks>,
    statistics: Statistics,
    heights: Vec<f32>,
    preview: Option<RenderMaps>,
    reduced: [Vec<f32>; 3],
}

impl State {
    /// [`Self::take`] of `band`, where there is one, advancing `progress` by its rows.
    fn take_last(
        &mut self,
        b: &Bands,
        band: Option<(Band, RenderMaps)>,
        dir: &Path,
        k: usize,
        progress: &dyn Progress,
    ) -> crate::Result<()> {
        if let Some((band, maps)) = band {
            self.take(b, &band, &maps, dir, k)?;
            progress.advance(maps.height as u64);
        }
        Ok(())
    }

    /// Writes a band's rows and keeps what the rest of the set needs of them.
    fn take(
        &mut self,
        b: &Bands,
        band: &Band,
        maps: &RenderMaps,
        dir: &Path,
        k: usize,
    ) -> crate::Result<()> {
        let (w, h) = (b.surface.width, b.surface.height);
        let a = band.start;
        let sinks = match &mut self.sinks {
            Some(s) => s,
            None => self
                .sinks
                .insert(MapSinks::create(dir, w, h, maps.subsurface.is_some())?),
        };
        sinks.push(band, maps, a)?;
        let texels = a * w..(a + maps.height) * w;
        self.statistics.add(b.surface, texels.clone(), |i| {
            crate::report::values(band.at(i), maps.base_color[i - a * w])
        });
        self.heights.extend(texels.map(|i| band.at(i).height_mm));
        let reduced = derma_core::map::box_reduced(w, maps.height, k, |i| {
            crate::preview::sheet_channels(band.at(a * w + i))
        });
        for (all, m) in self.reduced.iter_mut().zip(reduced) {
            all.extend_from_slice(m.data());
        }
        let preview = self.preview.get_or_insert_with(|| {
            RenderMaps::zeroed(w, h, b.keep_subsurface && maps.subsurface.is_some())
        });
        preview.copy_rows(maps, a);
        Ok(())
    }

    /// Ends the files, writes height.png from the heights kept, and hands over the rest.
    fn finish(self, dir: &Path, (w, h): (usize, usize), k: usize) -> crate::Result<Streamed> {
        let sinks = self.sinks.expect("at least one band");
        let mut files = sinks.finish()?;
        let heights = &self.heights;
        let height_range = crate::texture_set::range_of(heights);
        crate::texture_set::write_height_png(dir, (w, h), height_range, |i| heights[i])?;
        files.push(crate::outputs::HEIGHT_PNG);
        let (rw, rh) = (w / k, h / k);
        let reduced = self
            .reduced
            .map(|data| Map::from_vec(rw, rh, data).expect("the bands' reduced rows"));
        Ok(Streamed {
            files: crate::texture_set::in_manifest_order(&files),
            height_range,
            statistics: self.statistics,
            preview: self.preview.expect("at least one band"),
            reduced,
        })
    }
}

/// The gutter's dilation sources painted on their own: the sources and the texels their
/// normals read (sorted, with their samples), and each source's normal and wrinkle normal.
struct Gutter<'a> {
    src: &'a [u32],
    texels: Vec<u32>,
    samples: Vec<BioSample>,
    /// Per source (sorted): its normal.png code and wrinkle_normal.png code.
    codes: Vec<(u32, [u16; 3], Option<[u16; 3]>)>,
}

impl<'a> Gutter<'a> {
    /// Paints every texel the gutter copies from, and the texels whose heights their normals
    /// read (through their own sources where those lie in the gutter).
    fn paint(b: &Bands, src: &'a [u32]) -> Self {
        let (w, h) = (b.surface.width, b.surface.height);
        let wrap = b.surface.period().is_some();
        let mut marked = vec![0u64; src.len().div_ceil(64)];
        let mark = |m: &mut [u64], t: usize| m[t / 64] |= 1 << (t % 64);
        let list = |m: &[u64]| -> Vec<u32> {
            (0..src.len() as u32)
                .filter(|&t| m[t as usize / 64] >> (t % 64) & 1 == 1)
                .collect()
        };
        for (i, &s) in src.iter().enumerate() {
            if s as usize != i {
                mark(&mut marked, s as usize);
            }
        }
        let sources = list(&marked);
        for &s in &sources {
            let (x, y) = ((s as usize % w) as i64, (s as usize / w) as i64);
            for (dx, dy) in [(-1, 0), (1, 0), (0, -1), (0, 1)] {
                if let Some(j) = crate::normal_map::texel_at((w, h), x + dx, y + dy, wrap) {
                    mark(&mut marked, src[j] as usize);
                }
            }
        }
        let texels = list(&marked);
        let samples = b.painter.texels(&texels);
        let mut g = Gutter {
            src,
            texels,
            samples,
            codes: Vec::new(),
        };
        let codes = sources
            .par_iter()
            .map(|&s| {
                let i = s as usize;
                (
                    s,
                    normal_code(b.surface, &g, i),
                    wrinkle_code(b.surface, &g, i),
                )
            })
            .collect();
        g.codes = codes;
        g
    }

    /// The codes of source `s`.
    fn codes_of(&self, s: u32) -> ([u16; 3], Option<[u16; 3]>) {
        let k = self
            .codes
            .binary_search_by_key(&s, |c| c.0)
            .expect("a painted source");
        (self.codes[k].1, self.codes[k].2)
    }
}

impl Samples for Gutter<'_> {
    /// Texel `j`'s sample as the whole path has it after dilation (its source's).
    fn at(&self, j: usize) -> &BioSample {
        let s = self.src[j];
        let k = self.texels.binary_search(&s).expect("a painted texel");
        &self.samples[k]
    }
}

/// One band's samples (rows `start..end`), with the rows next to it, dilated: the row above
/// (where there is one), the band, the row below (where there is one).
struct Band {
    start: usize,
    end: usize,
    /// The texel index the first sample would have were the rows held consecutive (the row
    /// above the band's first; wrapping below zero on the first band of a tileable patch).
    base: usize,
    /// The rows above and below the band held, where they wrap around the image.
    above: Option<usize>,
    width: usize,
    texels: Vec<BioSample>,
}

impl Band {
    /// Paints rows `rows` and the row on each side (wrapping on tileable surfaces), and fills
    /// their gutter texels from `gutter`.
    fn paint(b: &Bands, gutter: Option<&Gutter>, rows: std::ops::Range<usize>) -> Self {
        let (w, h) = (b.surface.width, b.surface.height);
        let wrap = b.surface.period().is_some();
        let whole = rows.start == 0 && rows.end == h;
        let above = (!whole && (rows.start > 0 || wrap)).then(|| (rows.start + h - 1) % h);
        let below = (!whole && (rows.end < h || wrap)).then_some(rows.end % h);
        let mut texels = Vec::with_capacity((rows.len() + 2) * w);
        if let Some(y) = above {
            texels.extend(b.painter.rows(y..y + 1, &Silent));
        }
        texels.extend(b.painter.rows(rows.clone(), &Silent));
        if let Some(y) = below {
            texels.extend(b.painter.rows(y..y + 1, &Silent));
        }
        let first = above.unwrap_or(rows.start);
        if let Some(g) = gutter {
            texels.par_chunks_mut(w).enumerate().for_each(|(r, row)| {
                let y0 = (first + r) % h * w;
                for (x, t) in row.iter_mut().enumerate() {
                    if g.src[y0 + x] as usize != y0 + x {
                        *t = *g.at(y0 + x);
                    }
                }
            });
        }
        Band {
            start: rows.start,
            end: rows.end,
            base: (rows.start * w).wrapping_sub(if above.is_some() { w } else { 0 }),
            above,
            width: w,
            texels,
        }
    }

    /// The band's render maps, the gutter's normals from their sources'.
    fn convert(&self, b: &Bands, gutter: Option<&Gutter>) -> RenderMaps {
        let mut maps = convert_rows(
            self,
            self.start..self.end,
            b.surface,
            b.appearance,
            b.material,
        );
        let Some(g) = gutter else {
            return maps;
        };
        let w = self.width;
        let first = self.start * w;
        let mut extra = Vec::new();
        for (k, n) in maps.normal.iter_mut().enumerate() {
            let s = g.src[first + k];
            if s as usize != first + k {
                let (normal, wrinkle) = g.codes_of(s);
                *n = normal;
                if let Some(c) = wrinkle {
                    extra.push(((first + k) as u32, c));
                }
            }
        }
        maps.wrinkle_normal.extend(extra);
        maps.wrinkle_normal.sort_unstable_by_key(|e| e.0);
        maps
    }
}

impl Samples for Band {
    #[inline]
    fn at(&self, j: usize) -> &BioSample {
        let k = j.wrapping_sub(self.base);
        if k < self.texels.len() {
            return &self.texels[k];
        }
        // A row held out of order: the row above the first band, or below the last, of a
        // tileable patch.
        let (y, x) = (j / self.width, j % self.width);
        if Some(y) == self.above {
            &self.texels[x]
        } else {
            &self.texels[self.texels.len() - self.width + x]
        }
    }
}

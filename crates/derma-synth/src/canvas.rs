//! The texture being synthesised: values, their 8-bit codes for the search, and where each
//! texel was copied from (its source), on a plane or, for tileable output, a torus.

use crate::exemplar::ExemplarSet;
use crate::search::Plane;

/// No source yet: the texel still holds the white noise of §3.1.
pub const NO_SOURCE: u32 = u32::MAX;

pub(crate) struct Canvas {
    pub width: usize,
    pub height: usize,
    pub channels: usize,
    pub tile: bool,
    pub values: Vec<f32>,
    pub codes: Vec<u8>,
    /// Exemplar index of each texel's source.
    pub src_exemplar: Vec<u8>,
    /// Texel index (y · width + x) of the source in its exemplar, or [`NO_SOURCE`].
    pub src: Vec<u32>,
}

impl Canvas {
    pub fn new(width: usize, height: usize, channels: usize, tile: bool) -> Self {
        let n = width * height;
        Self {
            width,
            height,
            channels,
            tile,
            values: vec![0.0; n * channels],
            codes: vec![0; n * channels],
            src_exemplar: vec![0; n],
            src: vec![NO_SOURCE; n],
        }
    }

    /// Texel index of (px + dx, py + dy), wrapping on a torus.
    #[inline]
    pub fn at(&self, px: usize, py: usize, dx: usize, dy: usize) -> usize {
        let (mut x, mut y) = (px + dx, py + dy);
        if self.tile {
            x %= self.width;
            y %= self.height;
        }
        debug_assert!(x < self.width && y < self.height);
        y * self.width + x
    }

    /// Output texel (x + dx, y + dy), wrapping on a torus; `None` off a plane.
    #[inline]
    pub fn neighbour(&self, x: usize, y: usize, dx: isize, dy: isize) -> Option<usize> {
        let (w, h) = (self.width as isize, self.height as isize);
        let (mut nx, mut ny) = (x as isize + dx, y as isize + dy);
        if self.tile {
            nx = nx.rem_euclid(w);
            ny = ny.rem_euclid(h);
        } else if nx < 0 || ny < 0 || nx >= w || ny >= h {
            return None;
        }
        Some(ny as usize * self.width + nx as usize)
    }

    /// The codes as a [`Plane`] that search windows are read from.
    pub fn plane(&self) -> Plane<'_> {
        Plane {
            width: self.width,
            height: self.height,
            channels: self.channels,
            wrap: self.tile,
            codes: &self.codes,
        }
    }

    /// Starting guesses for the search of the window at (px, py) in exemplar `ex`: the
    /// positions that continue the sources of `probes` (offsets in the window) already drawn
    /// from that exemplar, clamped to the candidate range, without repeats; `[0]` when none is.
    pub fn coherent_guess(
        &self,
        set: &ExemplarSet,
        ex: usize,
        px: usize,
        py: usize,
        w: usize,
        probes: &[(usize, usize)],
    ) -> Vec<u32> {
        let e = &set.exemplars[ex];
        let (cw, ch) = e.candidates(w);
        let mut out = Vec::with_capacity(probes.len());
        for &(dx, dy) in probes {
            let t = self.at(px, py, dx, dy);
            if self.src[t] == NO_SOURCE || self.src_exemplar[t] as usize != ex {
                continue;
            }
            let (sx, sy) = (
                self.src[t] as usize % e.width(),
                self.src[t] as usize / e.width(),
            );
            let x = sx.saturating_sub(dx).min(cw - 1);
            let y = sy.saturating_sub(dy).min(ch - 1);
            let g = (y * cw + x) as u32;
            if !out.contains(&g) {
                out.push(g);
            }
        }
        if out.is_empty() {
            out.push(0);
        }
        out
    }

    /// Copies the exemplar window at candidate `index` over the window at (px, py).
    pub fn paste(
        &mut self,
        set: &ExemplarSet,
        ex: usize,
        index: u32,
        px: usize,
        py: usize,
        w: usize,
    ) {
        let ew = set.exemplars[ex].width();
        let cw = ew + 1 - w;
        let (mx, my) = (index as usize % cw, index as usize / cw);
        for dy in 0..w {
            for dx in 0..w {
                let t = self.at(px, py, dx, dy);
                self.copy_texel(set, t, ex, (my + dy) * ew + mx + dx);
            }
        }
    }

    /// Makes texel `t` a copy of texel `s` (y · width + x) of exemplar `ex`: its values, codes
    /// and source.
    #[inline]
    pub fn copy_texel(&mut self, set: &ExemplarSet, t: usize, ex: usize, s: usize) {
        let e = &set.exemplars[ex];
        let c = self.channels;
        self.values[t * c..(t + 1) * c].copy_from_slice(&e.texture.data[s * c..(s + 1) * c]);
        self.codes[t * c..(t + 1) * c].copy_from_slice(&e.codes[s * c..(s + 1) * c]);
        self.src[t] = s as u32;
        self.src_exemplar[t] = ex as u8;
    }
}

/// Window origins along an axis of `len` texels for windows of side `w` every `step`, starting
/// at `offset`: on a torus `offset, offset + step, …` until the axis is covered; on a plane the
/// same, kept inside, with a first window flush with the near edge and a last one flush with
/// the far edge where the steps do not land on them.
pub(crate) fn origins(len: usize, w: usize, step: usize, offset: usize, tile: bool) -> Vec<usize> {
    if tile {
        return (0..len.div_ceil(step))
            .map(|k| (offset + k * step) % len)
            .collect();
    }
    let mut v = Vec::new();
    if offset > 0 || len < w {
        v.push(0);
    }
    v.extend(
        (0..)
            .map(|k| offset + k * step)
            .take_while(|&p| p + w <= len),
    );
    if v.last().is_none_or(|&p| p + w < len) {
        v.push(len - w);
    }
    v
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn origins_cover_the_axis() {
        assert_eq!(origins(64, 16, 8, 0, false), vec![0, 8, 16, 24, 32, 40, 48]);
        assert_eq!(origins(60, 16, 8, 0, false), vec![0, 8, 16, 24, 32, 40, 44]);
        assert_eq!(
            origins(60, 16, 8, 0, true),
            vec![0, 8, 16, 24, 32, 40, 48, 56]
        );
        assert_eq!(origins(16, 16, 8, 0, false), vec![0]);
        assert_eq!(origins(40, 16, 8, 4, false), vec![0, 4, 12, 20, 24]);
        assert_eq!(origins(32, 16, 8, 4, true), vec![4, 12, 20, 28]);
    }
}

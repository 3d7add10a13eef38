//! Spatial index over features: a sparse uniform grid in 3D (thesis §4.8.8 suggests an R-tree;
//! `benches/index.rs` measures `rstar` against this grid, and the grid won — see BENCHMARKS.md).
//!
//! Each feature is inserted into every cell its bounding box overlaps, so a query is a single
//! cell look-up. Cells are keyed in a hash map; painting walks texels in scanline order, so
//! callers keep a [`GridCursor`] that skips the look-up while the cell does not change.

use glam::Vec3;
use std::collections::HashMap;
use std::hash::{BuildHasherDefault, Hasher};

/// Multiply-shift hasher for packed cell keys (keys are already well mixed by packing).
#[derive(Default)]
pub struct CellHasher(u64);

impl Hasher for CellHasher {
    fn finish(&self) -> u64 {
        self.0
    }
    fn write(&mut self, _: &[u8]) {
        unreachable!("only u64 keys")
    }
    fn write_u64(&mut self, k: u64) {
        self.0 = (k ^ (k >> 29)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
    }
}

type CellMap = HashMap<u64, (u32, u32), BuildHasherDefault<CellHasher>>;

/// A sparse uniform grid of feature indices.
pub struct Grid {
    inv_cell: f32,
    cells: CellMap,
    items: Vec<u32>,
    /// Bounds of every item together: points outside find nothing without a look-up (a kind
    /// confined to the brows or the beard is skipped over the rest of the head).
    lo: Vec3,
    hi: Vec3,
}

const BIAS: i64 = 1 << 20;

/// ⌊x⌋ without a libm call (targets without SSE4.1 lower `f32::floor` to `floorf`).
#[inline]
pub fn fast_floor(x: f32) -> i64 {
    let t = x as i64;
    t - ((x < t as f32) as i64)
}

#[inline]
fn key(ix: i64, iy: i64, iz: i64) -> u64 {
    (((ix + BIAS) as u64) & 0x1f_ffff)
        | ((((iy + BIAS) as u64) & 0x1f_ffff) << 21)
        | ((((iz + BIAS) as u64) & 0x1f_ffff) << 42)
}

impl Grid {
    /// Builds a grid with cells of `cell` mm from the bounding boxes of the features.
    pub fn build(cell: f32, bounds: impl Iterator<Item = (Vec3, Vec3)>) -> Grid {
        let inv = 1.0 / cell.max(1e-4);
        let mut pairs: Vec<(u64, u32)> = Vec::new();
        let (mut all_lo, mut all_hi) = (Vec3::INFINITY, Vec3::NEG_INFINITY);
        for (idx, (lo, hi)) in bounds.enumerate() {
            all_lo = all_lo.min(lo);
            all_hi = all_hi.max(hi);
            let (a, b) = ((lo * inv).floor(), (hi * inv).floor());
            for z in a.z as i64..=b.z as i64 {
                for y in a.y as i64..=b.y as i64 {
                    for x in a.x as i64..=b.x as i64 {
                        pairs.push((key(x, y, z), idx as u32));
                    }
                }
            }
        }
        // Sorting by (cell, feature) fixes the order of features within a cell, which fixes the
        // order in which they are applied: the result does not depend on threads.
        pairs.sort_unstable();
        let mut cells = CellMap::default();
        let mut items = Vec::with_capacity(pairs.len());
        let mut i = 0;
        while i < pairs.len() {
            let k = pairs[i].0;
            let start = items.len() as u32;
            while i < pairs.len() && pairs[i].0 == k {
                items.push(pairs[i].1);
                i += 1;
            }
            cells.insert(k, (start, items.len() as u32 - start));
        }
        Grid {
            inv_cell: inv,
            cells,
            items,
            lo: all_lo,
            hi: all_hi,
        }
    }

    #[inline]
    fn cell_of(&self, p: Vec3) -> [i64; 3] {
        let c = p * self.inv_cell;
        [fast_floor(c.x), fast_floor(c.y), fast_floor(c.z)]
    }

    #[inline]
    fn cell_key(&self, p: Vec3) -> u64 {
        let [x, y, z] = self.cell_of(p);
        key(x, y, z)
    }

    /// Features whose bounding boxes overlap the cell of `p`.
    #[inline]
    pub fn query(&self, p: Vec3) -> &[u32] {
        match self.cells.get(&self.cell_key(p)) {
            Some(&(s, n)) => &self.items[s as usize..(s + n) as usize],
            None => &[],
        }
    }

    /// Number of (cell, feature) entries.
    pub fn entries(&self) -> usize {
        self.items.len()
    }
}

/// Cells a [`GridCursor`] remembers besides the current one (direct-mapped by key): a row of
/// texels crosses the same cells as the row before it.
const RECENT: usize = 256;

/// Remembers the last cell looked up, so texels in the same cell skip the hash look-up, and
/// the cells met recently, so the next rows mostly skip it too.
pub struct GridCursor<'a> {
    grid: &'a Grid,
    last_key: u64,
    last: &'a [u32],
    /// Bounds of the last cell: while the point stays inside, nothing is recomputed.
    lo: Vec3,
    hi: Vec3,
    /// Recent cells: key and item range (key u64::MAX: empty).
    recent: Vec<(u64, u32, u32)>,
}

impl<'a> GridCursor<'a> {
    /// A cursor over `grid`.
    pub fn new(grid: &'a Grid) -> Self {
        Self {
            grid,
            last_key: u64::MAX,
            last: &[],
            lo: Vec3::INFINITY,
            hi: Vec3::NEG_INFINITY,
            recent: vec![(u64::MAX, 0, 0); RECENT],
        }
    }

    #[inline]
    /// The items whose bounds may contain `p` (those of its cell).
    pub fn query(&mut self, p: Vec3) -> &'a [u32] {
        if p.cmpge(self.lo).all() && p.cmplt(self.hi).all() {
            return self.last;
        }
        if p.cmplt(self.grid.lo).any() || p.cmpgt(self.grid.hi).any() {
            return &[];
        }
        let c = self.grid.cell_of(p);
        let cell = 1.0 / self.grid.inv_cell;
        self.lo = Vec3::new(c[0] as f32, c[1] as f32, c[2] as f32) * cell;
        self.hi = self.lo + Vec3::splat(cell);
        let k = key(c[0], c[1], c[2]);
        if k != self.last_key {
            self.last_key = k;
            let slot = (k.wrapping_mul(0x9e37_79b9_7f4a_7c15) >> 56) as usize % RECENT;
            let (s, n) = match self.recent[slot] {
                (key, s, n) if key == k => (s, n),
                _ => {
                    let (s, n) = self.grid.cells.get(&k).copied().unwrap_or((0, 0));
                    self.recent[slot] = (k, s, n);
                    (s, n)
                }
            };
            self.last = &self.grid.items[s as usize..(s + n) as usize];
        }
        self.last
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn query_finds_every_overlapping_box() {
        // Brute force against the grid for random boxes and points.
        let rng = derma_core::rng::Philox::new(5, 0);
        let boxes: Vec<(Vec3, Vec3)> = (0..500)
            .map(|i| {
                let u = rng.uniform4(i, 0);
                let c = Vec3::new(u[0], u[1], u[2]) * 50.0;
                let r = 0.2 + 3.0 * u[3];
                (c - Vec3::splat(r), c + Vec3::splat(r))
            })
            .collect();
        let g = Grid::build(2.0, boxes.iter().copied());
        let mut cur = GridCursor::new(&g);
        for i in 0..2000 {
            let u = rng.uniform4(10_000 + i, 0);
            let p = Vec3::new(u[0], u[1], u[2]) * 50.0;
            let found = g.query(p);
            assert_eq!(found, cur.query(p));
            for (k, (lo, hi)) in boxes.iter().enumerate() {
                let inside = p.cmpge(*lo).all() && p.cmple(*hi).all();
                if inside {
                    assert!(found.contains(&(k as u32)), "box {k} missed at {p}");
                }
            }
        }
    }
}

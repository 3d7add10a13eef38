//! Skin micro-relief: the network of furrows that divides the skin between features into small
//! plateaus (the "primary" and "secondary" lines of skin-replica studies; thesis §7.4 lists fine
//! surface detail as missing). Generated in 3D on the surface, so it is seamless across UV charts
//! and its sizes are millimetres whatever the texel density.
//!
//! Model: per octave, a Voronoi (Worley) partition of space with one jittered site per cell of
//! size `cell_mm`; the surface's plateaus are the cells, the furrows their borders. A texel at
//! distance d from the nearest border (the bisector of its two nearest sites) is lowered by
//! depth·(1 − (d/w)²)² for d < w (a rounded V of half-width w), and each plateau domes gently
//! towards its site. Furrows parallel to the skin's tension lines are the deep ones (Borges 1984,
//! relaxed skin tension lines): depth × (1 − anisotropy·(1 − cos²θ)), θ the angle between the
//! furrow and the tension direction. Octaves smaller than two texels are faded out and furrows
//! are never narrower than ¾ texel (their cross-section kept), so the relief is band-limited at
//! the output resolution: no aliasing at 1024², more detail as the size grows.

use glam::Vec3;

/// Parameters of the relief (config `[relief]`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ReliefParams {
    /// Plateau (cell) size of each octave, mm.
    pub cell_mm: [f32; 3],
    /// Furrow depth of each octave, mm.
    pub depth_mm: [f32; 3],
    /// Furrow half-width as a fraction of the octave's cell size.
    pub width_fraction: f32,
    /// Dome height of a plateau as a fraction of its octave's furrow depth.
    pub dome_fraction: f32,
    /// How much shallower furrows across the tension lines are (0 = isotropic, 1 = only parallel
    /// furrows).
    pub anisotropy: f32,
    /// Seed of the site jitter.
    pub seed: u32,
    /// Period (mm) in x and y of a tileable patch: each octave's cells are resized to fit a
    /// whole number of times and their sites repeat, so the relief tiles. `None` on meshes.
    pub period: Option<[f32; 2]>,
}

impl ReliefParams {
    /// An octave's cell size (mm, x y z) for nominal size `cell`, and the cells per period in x
    /// and y on a tileable patch: there the cells fit the period a whole number of times (cell
    /// sizes change by at most half a cell per period).
    #[inline]
    pub(crate) fn cells(&self, cell: f32) -> (Vec3, Option<[i32; 2]>) {
        match self.period {
            None => (Vec3::splat(cell), None),
            Some([px, py]) => {
                let (nx, ny) = ((px / cell).round().max(1.0), (py / cell).round().max(1.0));
                (
                    Vec3::new(px / nx, py / ny, cell),
                    Some([nx as i32, ny as i32]),
                )
            }
        }
    }

    /// The parameters of config `[relief]` with a jitter seed and a tiling period.
    pub fn from_config(
        c: &crate::config::ReliefConfig,
        seed: u32,
        period: Option<[f32; 2]>,
    ) -> Self {
        Self {
            cell_mm: c.cell_mm,
            depth_mm: c.depth_mm,
            width_fraction: c.width_fraction,
            dome_fraction: c.dome_fraction,
            anisotropy: c.anisotropy,
            seed,
            period,
        }
    }
}

/// A 32-bit integer hash (lowbias32, Chris Wellons' hash-prospector): cell coordinates and seed
/// → uniformly mixed bits. Pure, so the relief does not depend on evaluation order.
#[inline]
fn hash(mut x: u32) -> u32 {
    x ^= x >> 16;
    x = x.wrapping_mul(0x7feb_352d);
    x ^= x >> 15;
    x = x.wrapping_mul(0x846c_a68b);
    x ^= x >> 16;
    x
}

/// The jittered site of integer cell `c` (in cell units), octave `o`; with `wrap` cells (x, y)
/// the sites repeat with that period.
#[inline]
fn site_wrapped(c: [i32; 3], o: u32, seed: u32, wrap: Option<[i32; 2]>) -> Vec3 {
    match wrap {
        None => site(c, o, seed),
        Some([nx, ny]) => {
            let (wx, wy) = (c[0].rem_euclid(nx), c[1].rem_euclid(ny));
            site([wx, wy, c[2]], o, seed) + Vec3::new((c[0] - wx) as f32, (c[1] - wy) as f32, 0.0)
        }
    }
}

/// The jittered site of integer cell `c` (in cell units), octave `o`: one hash, three 10-bit
/// jitters.
#[inline]
fn site(c: [i32; 3], o: u32, seed: u32) -> Vec3 {
    let h = hash(
        (c[0] as u32).wrapping_mul(0x9e37_79b1)
            ^ (c[1] as u32).wrapping_mul(0x85eb_ca77)
            ^ (c[2] as u32).wrapping_mul(0xc2b2_ae3d)
            ^ seed.wrapping_mul(0x27d4_eb2f)
            ^ o.wrapping_mul(0x1656_67b1),
    );
    let u = |shift: u32| (((h >> shift) & 1023) as f32 + 0.5) / 1024.0;
    Vec3::new(c[0] as f32 + u(0), c[1] as f32 + u(10), c[2] as f32 + u(20))
}

/// The 3 × 3 × 3 block of sites around one cell of one octave, kept while consecutive texels
/// stay in that cell (texels are much smaller than cells, so most texels reuse them); when the
/// texel moves to a neighbouring cell, the sites the two blocks share are kept and only the
/// others computed. Sites are stored as coordinate columns (in [`NEIGHBOURS`] order, padded
/// to [`SLOTS_PADDED`] with a far site) for the distance loop.
#[derive(Clone, Copy, Debug)]
pub(crate) struct CellSites {
    base: [i32; 3],
    /// x, y and z of the sites.
    pub(crate) columns: [[f32; SLOTS_PADDED]; 3],
}

/// Slots of a block: the 27 sites and far padding, four rows of eight SIMD lanes.
pub(crate) const SLOTS_PADDED: usize = 32;

/// A coordinate no site has: the padding slot's distance is never among the smallest two.
const FAR: f32 = 1e18;

/// The 27 neighbour offsets, nearest classes first (own cell, faces, edges, corners): the
/// order of a block's slots, which decides between sites at exactly equal distances.
const NEIGHBOURS: [[i32; 3]; 27] = {
    let mut out = [[0i32; 3]; 27];
    let mut k = 0;
    let mut class: i32 = 0;
    while class <= 3 {
        let mut i: i32 = 0;
        while i < 27 {
            let d = [i % 3 - 1, (i / 3) % 3 - 1, i / 9 - 1];
            if d[0].abs() + d[1].abs() + d[2].abs() == class {
                out[k] = d;
                k += 1;
            }
            i += 1;
        }
        class += 1;
    }
    out
};

/// Slot of each offset (indexed (dz+1)·9 + (dy+1)·3 + dx+1): its place in [`NEIGHBOURS`].
const SLOTS: [usize; 27] = {
    let mut out = [0usize; 27];
    let mut k = 0;
    while k < 27 {
        let d = NEIGHBOURS[k];
        out[((d[2] + 1) * 9 + (d[1] + 1) * 3 + d[0] + 1) as usize] = k;
        k += 1;
    }
    out
};

/// Slot of neighbour offset `d` (each −1, 0 or 1) in a [`CellSites`] block.
#[inline]
fn slot(d: [i32; 3]) -> usize {
    SLOTS[((d[2] + 1) * 9 + (d[1] + 1) * 3 + d[0] + 1) as usize]
}

/// No slot: the site is not in the previous block.
const NONE: u8 = u8::MAX;

/// For a move of the block by neighbour offset `e` (indexed by `e`'s slot), the slot of the
/// previous block that holds each new slot's site, or [`NONE`].
const SHIFTS: [[u8; 27]; 27] = {
    let mut out = [[NONE; 27]; 27];
    let mut m = 0;
    while m < 27 {
        let e = NEIGHBOURS[m];
        let mut k = 0;
        while k < 27 {
            let d = NEIGHBOURS[k];
            let o = [e[0] + d[0], e[1] + d[1], e[2] + d[2]];
            if o[0].abs() <= 1 && o[1].abs() <= 1 && o[2].abs() <= 1 {
                out[m][k] = SLOTS[((o[2] + 1) * 9 + (o[1] + 1) * 3 + o[0] + 1) as usize] as u8;
            }
            k += 1;
        }
        m += 1;
    }
    out
};

/// Per-thread cache of the sites around the last cell of each octave (results do not depend on
/// it: a cache miss recomputes the same sites). Two blocks per octave: a new block is written
/// into the spare one while the sites it shares are read from the current one.
#[derive(Clone, Debug, Default)]
pub struct ReliefCache {
    octaves: [Blocks; 3],
}

/// The current and the spare block of one octave.
#[derive(Clone, Debug)]
struct Blocks {
    blocks: [CellSites; 2],
    current: usize,
    valid: bool,
}

impl Default for Blocks {
    fn default() -> Self {
        let empty = CellSites::far();
        Blocks {
            blocks: [empty; 2],
            current: 0,
            valid: false,
        }
    }
}

/// The block of sites around the cell of `q` (in cell units), octave `o`, from `cache`
/// (refilled, keeping the sites it shares with the previous block, when `q` left its cell).
#[inline]
pub(crate) fn block(
    q: Vec3,
    o: usize,
    seed: u32,
    wrap: Option<[i32; 2]>,
    cache: &mut ReliefCache,
) -> &CellSites {
    let base = q.floor();
    let b = [base.x as i32, base.y as i32, base.z as i32];
    let oct = &mut cache.octaves[o];
    if !(oct.valid && oct.blocks[oct.current].base == b) {
        let [first, second] = &mut oct.blocks;
        let (old, new) = if oct.current == 0 {
            (&*first, second)
        } else {
            (&*second, first)
        };
        // Sites shared with the previous block (a move to a neighbouring cell) are copied.
        let e = [b[0] - old.base[0], b[1] - old.base[1], b[2] - old.base[2]];
        let shift = (oct.valid && e.iter().all(|v| v.abs() <= 1)).then(|| &SHIFTS[slot(e)]);
        for (k, d) in NEIGHBOURS.iter().enumerate() {
            let s = match shift {
                Some(src) if src[k] != NONE => {
                    let j = src[k] as usize;
                    [old.columns[0][j], old.columns[1][j], old.columns[2][j]]
                }
                _ => site_wrapped(
                    [b[0] + d[0], b[1] + d[1], b[2] + d[2]],
                    o as u32,
                    seed,
                    wrap,
                )
                .to_array(),
            };
            (new.columns[0][k], new.columns[1][k], new.columns[2][k]) = (s[0], s[1], s[2]);
        }
        new.base = b;
        oct.current ^= 1;
        oct.valid = true;
    }
    &oct.blocks[oct.current]
}

impl CellSites {
    /// A block of far sites only (what an empty cache holds).
    pub(crate) fn far() -> Self {
        CellSites {
            base: [0; 3],
            columns: [[FAR; SLOTS_PADDED]; 3],
        }
    }

    /// Site `k` of the block.
    #[inline]
    pub(crate) fn site(&self, k: usize) -> Vec3 {
        Vec3::new(self.columns[0][k], self.columns[1][k], self.columns[2][k])
    }
}

/// The two nearest sites of `q` (in cell units) and their squared distances (of sites at
/// exactly equal distances, the first in [`NEIGHBOURS`] order).
#[inline]
fn nearest_two(
    q: Vec3,
    o: usize,
    seed: u32,
    wrap: Option<[i32; 2]>,
    cache: &mut ReliefCache,
) -> (Vec3, f32, Vec3, f32) {
    let cell = block(q, o, seed, wrap, cache);
    let (i1, d1, i2, d2) = two_smallest(&squared_distances(q, &cell.columns));
    (cell.site(i1), d1, cell.site(i2), d2)
}

/// Squared distances from `q` to the sites in `columns`, as `(s − q).length_squared()`
/// computes them: (dx² + dy²) + dz².
#[inline]
fn squared_distances(q: Vec3, columns: &[[f32; SLOTS_PADDED]; 3]) -> [f32; SLOTS_PADDED] {
    let mut d = [0.0f32; SLOTS_PADDED];
    for k in 0..SLOTS_PADDED {
        let (dx, dy, dz) = (
            columns[0][k] - q.x,
            columns[1][k] - q.y,
            columns[2][k] - q.z,
        );
        d[k] = (dx * dx + dy * dy) + dz * dz;
    }
    d
}

/// The smallest of `d` (four lanes of minima, then across them).
#[inline]
fn smallest(d: &[f32; SLOTS_PADDED]) -> f32 {
    let mut m = [f32::MAX; 4];
    for c in d.chunks_exact(4) {
        for l in 0..4 {
            m[l] = if c[l] < m[l] { c[l] } else { m[l] };
        }
    }
    let (a, b) = (m[0].min(m[1]), m[2].min(m[3]));
    a.min(b)
}

/// The smallest and second smallest of `d` with their indices (ties to the lower index).
#[inline]
fn two_smallest(d: &[f32; SLOTS_PADDED]) -> (usize, f32, usize, f32) {
    let d1 = smallest(d);
    let i1 = d.iter().position(|&v| v == d1).unwrap_or(0);
    // The second: the smallest of the others (an equal distance elsewhere included).
    let mut others = *d;
    others[i1] = f32::MAX;
    let d2 = smallest(&others);
    let i2 = (0..SLOTS_PADDED)
        .find(|&k| k != i1 && d[k] == d2)
        .unwrap_or(0);
    (i1, d1, i2, d2)
}

/// Weight of an octave of cell size `cell` at texel size `texel` (both mm): 0 below two texels,
/// 1 from four, smooth between.
#[inline]
pub fn octave_weight(cell: f32, texel: f32) -> f32 {
    let t = ((cell / texel.max(1e-6) - 2.0) / 2.0).clamp(0.0, 1.0);
    t * t * (3.0 - 2.0 * t)
}

/// Height (mm, ≤ dome) of the relief at surface point `p` with unit normal `n`, unit tension
/// direction `tension` (zero: isotropic), depth scale `scale` and texel size `texel_mm`.
pub fn height(
    prm: &ReliefParams,
    p: Vec3,
    n: Vec3,
    tension: Vec3,
    scale: f32,
    texel_mm: f32,
) -> f32 {
    height_cached(
        prm,
        p,
        n,
        tension,
        scale,
        texel_mm,
        &mut ReliefCache::default(),
    )
}

/// [`height`] reusing the sites of the previous call's cells (the same value, faster).
pub fn height_cached(
    prm: &ReliefParams,
    p: Vec3,
    n: Vec3,
    tension: Vec3,
    scale: f32,
    texel_mm: f32,
    cache: &mut ReliefCache,
) -> f32 {
    if scale <= 0.0 {
        return 0.0;
    }
    let mut h = 0.0f32;
    for (o, (&cell, &depth)) in prm.cell_mm.iter().zip(&prm.depth_mm).enumerate() {
        let w_oct = octave_weight(cell, texel_mm);
        if w_oct <= 0.0 || depth <= 0.0 {
            continue;
        }
        let (cell3, wrap) = prm.cells(cell);
        let q = p / cell3;
        let (s1, d1, s2, _) = nearest_two(q, o, prm.seed, wrap, cache);
        let sep = s2 - s1;
        let len = sep.length().max(1e-6);
        // Distance (mm) from p to the bisector plane of the two nearest sites (cells are cubes,
        // or nearly so on patches, so cell units scale by the mean cell size).
        let d_border = (sep.dot(0.5 * (s1 + s2) - q) / len).abs() * cell;
        // Furrow direction: in the tangent plane, across the separation of the two sites.
        let along = n.cross(sep).normalize_or_zero();
        let c = along.dot(tension);
        let orient = if tension == Vec3::ZERO {
            1.0
        } else {
            1.0 - prm.anisotropy * (1.0 - c * c)
        };
        let w_nom = prm.width_fraction * cell;
        let w = w_nom.max(0.75 * texel_mm);
        let furrow_depth = depth * orient * (w_nom / w);
        let furrow = if d_border < w {
            let t = d_border / w;
            -furrow_depth * (1.0 - t * t) * (1.0 - t * t)
        } else {
            0.0
        };
        // The plateau domes towards its site: highest at the site, level with the furrow rim.
        let r = (d1.sqrt() * cell / (0.5 * cell)).min(1.0);
        let dome = prm.dome_fraction * depth * (1.0 - r * r);
        h += w_oct * (furrow + dome);
    }
    h * scale
}

/// The relief the tests use: finer than the default, so small patches hold many cells.
#[cfg(test)]
pub(crate) fn test_params(period: Option<[f32; 2]>) -> ReliefParams {
    ReliefParams {
        cell_mm: [1.0, 0.4, 0.15],
        depth_mm: [0.03, 0.015, 0.006],
        width_fraction: 0.12,
        dome_fraction: 0.3,
        anisotropy: 0.6,
        seed: 7,
        period,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn prm() -> ReliefParams {
        test_params(None)
    }

    #[test]
    fn octaves_fade_below_two_texels() {
        assert_eq!(octave_weight(0.2, 0.1), 0.0);
        assert_eq!(octave_weight(0.4, 0.1), 1.0);
        assert!((octave_weight(0.3, 0.1) - 0.5).abs() < 1e-6);
        // With texels larger than every octave's cell, the surface is flat.
        let p = Vec3::new(1.3, 2.7, -0.4);
        assert_eq!(height(&prm(), p, Vec3::Z, Vec3::X, 1.0, 10.0), 0.0);
    }

    #[test]
    fn nearest_sites_are_the_true_nearest() {
        // Against brute force over a 5×5×5 neighbourhood.
        for k in 0..200 {
            let q = Vec3::new(
                k as f32 * 0.37,
                (k * 7 % 13) as f32 * 0.41,
                -(k as f32) * 0.23,
            );
            let (s1, d1, _, d2) = nearest_two(q, 0, 3, None, &mut ReliefCache::default());
            let b = q.floor();
            let mut all: Vec<f32> = Vec::new();
            for dz in -2..=2 {
                for dy in -2..=2 {
                    for dx in -2..=2 {
                        let c = [b.x as i32 + dx, b.y as i32 + dy, b.z as i32 + dz];
                        all.push((site(c, 0, 3) - q).length_squared());
                    }
                }
            }
            all.sort_by(f32::total_cmp);
            assert_eq!((d1, d2), (all[0], all[1]), "at {q}");
            assert!((s1 - q).length_squared() == d1);
        }
    }

    #[test]
    fn furrows_are_bounded_and_follow_the_tension_lines() {
        // Points over a flat skin (n = +Z) with tension along +X: the relief stays within the
        // octaves' depths and domes, reaches into the furrows, and its slopes across x-running
        // furrows (∂h/∂y) outweigh those across y-running ones (∂h/∂x).
        let p = prm();
        let (mut min, mut max) = (0.0f32, 0.0f32);
        let (mut gx, mut gy) = (0.0f64, 0.0f64);
        let e = 0.002;
        let at = |q: Vec3| height(&p, q, Vec3::Z, Vec3::X, 1.0, 0.01);
        for i in 0..40_000 {
            let q = Vec3::new((i % 200) as f32 * 0.031, (i / 200) as f32 * 0.029, 0.0);
            let h = at(q);
            min = min.min(h);
            max = max.max(h);
            gx += ((at(q + Vec3::X * e) - at(q - Vec3::X * e)) as f64).powi(2);
            gy += ((at(q + Vec3::Y * e) - at(q - Vec3::Y * e)) as f64).powi(2);
        }
        let total: f32 = p.depth_mm.iter().sum();
        assert!(min >= -total && min < -0.5 * p.depth_mm[0], "{min}");
        assert!(max <= p.dome_fraction * total + 1e-6, "{max}");
        assert!(gy > 1.5 * gx, "{gy} vs {gx}");
        // Isotropic when there is no tension direction.
        let mut g = [0.0f64; 2];
        for i in 0..40_000 {
            let q = Vec3::new((i % 200) as f32 * 0.031, (i / 200) as f32 * 0.029, 0.0);
            let f = |d: Vec3| height(&p, q + d * e, Vec3::Z, Vec3::ZERO, 1.0, 0.01) as f64;
            g[0] += (f(Vec3::X) - f(-Vec3::X)).powi(2);
            g[1] += (f(Vec3::Y) - f(-Vec3::Y)).powi(2);
        }
        assert!((g[0] / g[1] - 1.0).abs() < 0.15, "{g:?}");
    }

    #[test]
    fn a_periodic_relief_tiles() {
        let p = ReliefParams {
            period: Some([20.0, 30.0]),
            ..prm()
        };
        for k in 0..50 {
            let q = Vec3::new(k as f32 * 0.37 % 20.0, k as f32 * 0.61 % 30.0, 0.0);
            let h = |d: Vec3| height(&p, q + d, Vec3::Z, Vec3::X, 1.0, 0.01);
            let h0 = h(Vec3::ZERO);
            assert!((h0 - h(Vec3::new(20.0, 0.0, 0.0))).abs() < 1e-6);
            let far = h(Vec3::new(-20.0, 30.0, 0.0));
            assert!((h0 - far).abs() < 1e-5, "{h0} vs {far} at {q}");
        }
    }

    #[test]
    fn a_cached_walk_equals_fresh_evaluations() {
        // Steps small and large in every direction (cells left along one axis, diagonally,
        // or far): the kept and shifted sites give the same heights as a fresh cache.
        let rng = derma_core::rng::Philox::new(12, 0);
        let mut cache = ReliefCache::default();
        let mut p = Vec3::new(3.0, -2.0, 40.0);
        for k in 0..20_000u64 {
            let u = rng.uniform4(k, 0);
            let step = if k % 500 == 0 { 7.0 } else { 0.09 };
            p += (Vec3::new(u[0], u[1], u[2]) - 0.5) * step;
            let n = Vec3::new(0.3, 0.9, 0.1).normalize();
            let cached = height_cached(&prm(), p, n, Vec3::X, 1.0, 0.05, &mut cache);
            let fresh = height(&prm(), p, n, Vec3::X, 1.0, 0.05);
            assert_eq!(cached.to_bits(), fresh.to_bits(), "step {k} at {p}");
        }
    }

    #[test]
    fn the_relief_is_a_pure_function_of_the_point() {
        let p = Vec3::new(12.3, -4.5, 77.7);
        let a = height(&prm(), p, Vec3::Y, Vec3::X, 1.0, 0.05);
        let b = height(&prm(), p, Vec3::Y, Vec3::X, 1.0, 0.05);
        assert_eq!(a.to_bits(), b.to_bits());
        assert_ne!(
            a,
            height(
                &ReliefParams { seed: 8, ..prm() },
                p,
                Vec3::Y,
                Vec3::X,
                1.0,
                0.05
            )
        );
    }
}

//! k-coherence candidates (Tong et al. 2002; Zelinka & Garland's jump maps, Shen et al.'s
//! ref. [7]): a search that verifies exactly only a query's coherent guesses, the positions
//! most like each guess, and a few random ones, so its cost does not grow with the exemplar.
//!
//! Definition (both backends compute exactly this): for exemplar positions of windows of side
//! `w`, the similarity table holds, per position, [`SIMILAR`] other positions whose windows'
//! `b × b` block means (b = w/4, a 4 × 4 grid of blocks — w × w texels under 4 — as 8-bit
//! codes) lie nearest, none within [`near`] of
//! it, found by a deterministic PatchMatch (Barnes et al. 2009) over the exemplar
//! ([`similarity_table`]: integer distances, every iteration reading only the last one's
//! lists, so the table does not depend on the thread count). A query's candidates are its
//! guesses (clamped to the positions), the table's entries of each, and [`RANDOM`] positions
//! [`random_candidate`]`(salt, r)`. The search's rule (least cost, tolerance, least key) then
//! applies over them as over every position in the exhaustive search (`crate::search`).

use crate::exemplar::{Exemplar, ExemplarSet};
use crate::key::pick_key;
use rayon::prelude::*;

/// Positions per entry of the similarity table (k).
pub const SIMILAR: usize = 8;

/// Random positions among a query's candidates in the optimisation passes.
pub const RANDOM: usize = 8;

/// Random positions among a query's candidates in the patch pass, whose queries know only
/// their overlap: there the guesses' similar windows (alike as whole windows) say less.
pub const RANDOM_PATCH: usize = 256;

/// A search's k-coherence candidates: the tables, and how many random positions a query adds.
#[derive(Clone, Copy, Debug)]
pub struct Candidates<'a> {
    /// The similarity tables for the search's window side.
    pub tables: &'a Coherence,
    /// Random positions per query.
    pub random: usize,
}

/// PatchMatch iterations of [`similarity_table`].
const ITERATIONS: usize = 3;

/// Which positions a search verifies.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Scope {
    /// A query's k-coherence candidates (this module): the cost does not grow with the
    /// exemplar's area.
    #[default]
    Coherent,
    /// Every position of the exemplar (the exact best match of Shen et al.'s eq. 1).
    Exhaustive,
}

impl Scope {
    /// The scope named `name` ("coherent" or "exhaustive").
    pub fn parse(name: &str) -> Option<Self> {
        match name {
            "coherent" => Some(Self::Coherent),
            "exhaustive" => Some(Self::Exhaustive),
            _ => None,
        }
    }
}

/// The tables a synthesis made, by window side, each made once ([`Tables::of`]).
#[derive(Default)]
pub struct Tables {
    made: std::sync::Mutex<Vec<std::sync::Arc<Coherence>>>,
}

impl Tables {
    /// The tables of `set` for windows of side `w`, made on first use.
    pub fn of(&self, set: &ExemplarSet, w: usize) -> std::sync::Arc<Coherence> {
        let mut made = self.made.lock().unwrap_or_else(|p| p.into_inner());
        if let Some(c) = made.iter().find(|c| c.w == w) {
            return c.clone();
        }
        let started = std::time::Instant::now();
        let c = std::sync::Arc::new(Coherence::new(set, w));
        tracing::debug!(
            "k-coherence tables for {w}×{w} windows: {:.3} s",
            started.elapsed().as_secs_f64()
        );
        made.push(c.clone());
        c
    }
}

/// The similarity tables of a set's exemplars for windows of side `w`.
#[derive(Clone, Debug)]
pub struct Coherence {
    /// Window side.
    pub w: usize,
    /// Per exemplar: [`SIMILAR`] positions per position.
    pub tables: Vec<Vec<u32>>,
}

impl Coherence {
    /// The tables of every exemplar of `set`.
    pub fn new(set: &ExemplarSet, w: usize) -> Self {
        Self {
            w,
            tables: set
                .exemplars
                .iter()
                .map(|e| similarity_table(e, w))
                .collect(),
        }
    }

    /// The candidates of a query on exemplar `ex` (`positions` of them): `guesses` clamped,
    /// their similar positions and the random ones, into `out` (sorted, without repeats).
    pub fn candidates(
        &self,
        ex: usize,
        positions: usize,
        guesses: &[u32],
        salt: u32,
        random: usize,
        out: &mut Vec<u32>,
    ) {
        out.clear();
        let table = &self.tables[ex];
        for &g in guesses {
            let g = g.min(positions as u32 - 1);
            out.push(g);
            out.extend_from_slice(&table[g as usize * SIMILAR..][..SIMILAR]);
        }
        out.extend((0..random as u32).map(|r| random_candidate(salt, r, positions as u32)));
        out.sort_unstable();
        out.dedup();
    }
}

/// The `r`-th random candidate of a query with `salt`, among `positions` (search.wgsl has the
/// same function).
#[inline]
pub fn random_candidate(salt: u32, r: u32, positions: u32) -> u32 {
    pick_key(salt ^ 0x5bd1_e995, r) % positions
}

/// Whether positions `a` and `b` (columns `cw`) are too near to count as different places:
/// within a quarter window (at least 2 texels) each way.
#[inline]
pub fn near(a: u32, b: u32, cw: usize, w: usize) -> bool {
    let r = (w / 4).max(2) as i64;
    let (ax, ay) = ((a as usize % cw) as i64, (a as usize / cw) as i64);
    let (bx, by) = ((b as usize % cw) as i64, (b as usize / cw) as i64);
    (ax - bx).abs() < r && (ay - by).abs() < r
}

/// Every position's descriptor: the means (rounded down, as 8-bit codes) of its window's
/// g × g blocks of side b = w/4 (at least 1; g = 4, or w for windows under 4), per channel.
fn descriptors(e: &Exemplar, w: usize) -> (Vec<u8>, usize) {
    let (b, g) = ((w / 4).max(1), w.min(4));
    let sums = e.block_sums(b);
    let (cw, ch) = e.candidates(w);
    let pw = e.width() + 1 - b;
    let d = g * g * e.channels();
    let area = (b * b) as u32;
    let mut out = vec![0u8; cw * ch * d];
    out.par_chunks_mut(d).enumerate().for_each(|(p, v)| {
        let (x, y) = (p % cw, p / cw);
        let mut k = 0;
        for by in 0..g {
            for bx in 0..g {
                let at = (y + by * b) * pw + x + bx * b;
                for plane in &sums {
                    v[k] = (plane[at] as u32 / area) as u8;
                    k += 1;
                }
            }
        }
    });
    (out, d)
}

/// The similarity table of exemplar `e` for windows of side `w` (see the module comment):
/// [`SIMILAR`] positions per position, nearest first (ties to the lower position).
pub fn similarity_table(e: &Exemplar, w: usize) -> Vec<u32> {
    let (cw, ch) = e.candidates(w);
    let n = cw * ch;
    let (desc, d) = descriptors(e, w);
    // At most 16 · 4 channels · 255² < 2³²: exact in 32 bits.
    let dist = |a: u32, b: u32| -> u32 {
        let (p, q) = (&desc[a as usize * d..][..d], &desc[b as usize * d..][..d]);
        p.iter()
            .zip(q)
            .map(|(&x, &y)| {
                let t = x as i32 - y as i32;
                (t * t) as u32
            })
            .sum()
    };
    let knn = Knn {
        cw,
        ch,
        w,
        dist: &dist,
    };
    let mut lists: Vec<List> = (0..n as u32)
        .into_par_iter()
        .map_init(Vec::new, |tries, p| {
            tries.clear();
            tries.extend((0..4 * SIMILAR as u32).map(|j| pick_key(p, j) % n as u32));
            knn.keep(p, &[(u32::MAX, u32::MAX); SIMILAR], tries)
        })
        .collect();
    for it in 0..ITERATIONS as u32 {
        lists = (0..n as u32)
            .into_par_iter()
            .map_init(Vec::new, |tries, p| knn.improve(p, &lists, it, tries))
            .collect();
    }
    let mut table = vec![0u32; n * SIMILAR];
    for (p, l) in lists.iter().enumerate() {
        for j in 0..SIMILAR {
            // Too few other places (a tiny exemplar): the list repeats its nearest, or the
            // position itself.
            let e = if l[j].1 != u32::MAX { l[j] } else { l[0] };
            table[p * SIMILAR + j] = if e.1 != u32::MAX { e.1 } else { p as u32 };
        }
    }
    table
}

/// One PatchMatch step's inputs.
struct Knn<'a, D: Fn(u32, u32) -> u32 + Sync> {
    cw: usize,
    ch: usize,
    w: usize,
    dist: &'a D,
}

impl<D: Fn(u32, u32) -> u32 + Sync> Knn<'_, D> {
    /// Position `p`'s new list: its old one, its neighbours' entries shifted to it, and random
    /// searches around its best, at halving radii (`tries`: a buffer).
    fn improve(&self, p: u32, lists: &[List], it: u32, tries: &mut Vec<u32>) -> List {
        let (cw, ch) = (self.cw as i64, self.ch as i64);
        let (x, y) = (p as i64 % cw, p as i64 / cw);
        let at = |ex: i64, ey: i64| {
            (ex >= 0 && ey >= 0 && ex < cw && ey < ch).then(|| (ey * cw + ex) as u32)
        };
        tries.clear();
        for (dx, dy) in [(-1i64, 0i64), (1, 0), (0, -1), (0, 1)] {
            let Some(nb) = at(x + dx, y + dy) else {
                continue;
            };
            for &(_, e) in lists[nb as usize].iter().filter(|e| e.1 != u32::MAX) {
                tries.extend(at(e as i64 % cw - dx, e as i64 / cw - dy));
            }
        }
        let own = &lists[p as usize];
        let mut radius = cw.max(ch) / 2;
        let mut j = 0u32;
        while radius >= 1 {
            for &(_, e) in own.iter().take(2).filter(|e| e.1 != u32::MAX) {
                let h = pick_key(p ^ it.wrapping_mul(0x9e37_79b9), j);
                j += 1;
                let ox = (h & 0xffff) as i64 % (2 * radius + 1) - radius;
                let oy = (h >> 16) as i64 % (2 * radius + 1) - radius;
                tries.extend(at(e as i64 % cw + ox, e as i64 / cw + oy));
            }
            radius /= 2;
        }
        self.keep(p, own, tries)
    }

    /// The [`SIMILAR`] nearest of `old` and `tries` to `p` (none near it, no repeats),
    /// nearest first; entries not found yet are (MAX, MAX).
    fn keep(&self, p: u32, old: &List, tries: &mut [u32]) -> List {
        tries.sort_unstable();
        let mut best = *old;
        let mut last = u32::MAX;
        for &t in tries.iter() {
            if t == last {
                continue;
            }
            last = t;
            if near(p, t, self.cw, self.w) || old.iter().any(|e| e.1 == t) {
                continue;
            }
            let e = ((self.dist)(p, t), t);
            if e < best[SIMILAR - 1] {
                // Into the sorted list.
                let mut k = SIMILAR - 1;
                while k > 0 && e < best[k - 1] {
                    best[k] = best[k - 1];
                    k -= 1;
                }
                best[k] = e;
            }
        }
        best
    }
}

/// A position's list: (distance, position), nearest first.
type List = [(u32, u32); SIMILAR];

#[cfg(test)]
mod tests {
    use super::*;
    use crate::search::tests::noise_texture;

    #[test]
    fn a_repeated_tile_finds_its_copies() {
        // A 16-texel tile repeated 4 × 4 times: each window's nearest others are its copies
        // (distance 0), 16 texels apart.
        let tile = noise_texture(16, 16, 1, 7);
        let data: Vec<f32> = (0..64 * 64)
            .map(|i| tile.data[(i / 64 % 16) * 16 + i % 64 % 16])
            .collect();
        let t = crate::texture::Texture::new(64, 64, 1, data).unwrap();
        let set = ExemplarSet::new(vec![t], 8).unwrap();
        let e = &set.exemplars[0];
        let table = similarity_table(e, 8);
        let (cw, _) = e.candidates(8);
        let p = 20 * cw + 21;
        let first = table[p * SIMILAR] as usize;
        assert_eq!((first % cw % 16, first / cw % 16), (21 % 16, 20 % 16));
        assert_ne!(first, p);
    }

    #[test]
    fn windows_of_every_side_have_tables() {
        // Windows under 4 texels (a patch of 8 gives passes of 8, 4 and 2) and odd ones.
        let t = noise_texture(24, 24, 3, 11);
        let set = ExemplarSet::new(vec![t], 8).unwrap();
        for w in [1, 2, 3, 5, 6, 8, 12] {
            let table = similarity_table(&set.exemplars[0], w);
            let (cw, ch) = set.exemplars[0].candidates(w);
            assert_eq!(table.len(), cw * ch * SIMILAR, "side {w}");
            assert!(table.iter().all(|&p| (p as usize) < cw * ch), "side {w}");
        }
    }

    #[test]
    fn tables_do_not_depend_on_the_thread_count() {
        let t = noise_texture(48, 40, 3, 3);
        let set = ExemplarSet::new(vec![t], 8).unwrap();
        let one = rayon::ThreadPoolBuilder::new()
            .num_threads(1)
            .build()
            .unwrap();
        let a = one.install(|| similarity_table(&set.exemplars[0], 8));
        let b = similarity_table(&set.exemplars[0], 8);
        assert_eq!(a, b);
    }

    #[test]
    fn candidates_hold_the_guesses_their_similar_positions_and_the_random_ones() {
        let t = noise_texture(40, 40, 1, 5);
        let set = ExemplarSet::new(vec![t], 8).unwrap();
        let c = Coherence::new(&set, 8);
        let n = 33 * 33;
        let mut out = Vec::new();
        c.candidates(0, n, &[5, 5000], 77, RANDOM, &mut out);
        let last = n as u32 - 1;
        assert!(
            out.contains(&5) && out.contains(&last),
            "clamped guess kept: {out:?}"
        );
        for j in 0..SIMILAR {
            assert!(out.contains(&c.tables[0][5 * SIMILAR + j]));
        }
        for r in 0..RANDOM as u32 {
            assert!(out.contains(&random_candidate(77, r, n as u32)));
        }
        assert!(out.windows(2).all(|p| p[0] < p[1]));
    }
}

//! The best-match search of Shen et al. §3.2, eq. 1 and §3.4: the exemplar window with the
//! least L2 distance to a query window, over every position. Exact, so CPU and GPU agree.
//!
//! Definition (both backends compute exactly this): windows are `w × w` texels of 8-bit codes
//! (see [`crate::exemplar`]); the distance d is the integer sum of squared code differences
//! over the query's known texels (all, or those its mask marks) and all channels; with d* the least distance over all positions and
//! T = d* + ⌊d* · ε₁₆ / 2¹⁶⌋ (ε₁₆ = ε·2¹⁶, the tolerance), the answer is, among the positions
//! with d ≤ T, the one with the least key `pick_key(salt, index)`, index =
//! `y · (exemplar width − w + 1) + x`. The key is a bijection of the index for a given salt,
//! so the answer is unique; integers make every sum independent of summation order.
//! Optionally a per-candidate occurrence penalty is added to d first (see
//! [`crate::patch_pass`]): `penalty[index] · known texels`.
//! With ε = 0 this is the best match of eq. 1, ties broken at random; with ε > 0 it is image
//! quilting's choice among the near-best (Efros & Freeman 2001 §2.1, the paper's ref. [8]),
//! which keeps a deterministic best match from copying the same chain of patches over and over.
//!
//! The CPU search prunes without changing that answer (successive elimination, Li & Salari
//! 1995): the sums `S` of a window's fully known `w/2 × w/2` quadrants bound the distance from
//! below, Σ (S_e − S_q)² / (w/2)² ≤ distance (Cauchy–Schwarz on each quadrant), and a candidate
//! whose bound exceeds the limit of the best distance found so far cannot be chosen. The search starts from a coherent
//! guess (the continuation of the neighbouring texels' sources), which makes the bound tight.

use crate::error::Result;
use crate::exemplar::{Exemplar, ExemplarSet};
use rayon::prelude::*;

/// One search: a window of codes, the exemplar to search and a starting guess.
#[derive(Clone, Debug)]
pub struct Query {
    /// Index of the exemplar in the set.
    pub exemplar: u32,
    /// `w × w × channels` codes, rows from the top, channels interleaved.
    pub codes: Vec<u8>,
    /// Known texels (`w × w`, 1 = known) when not all are: the patch pass compares only the
    /// overlap with texels already synthesised (§3.2).
    pub mask: Option<Vec<u8>>,
    /// A candidate position index to start from (any valid index; it changes only the speed).
    pub guess: u32,
    /// Per-query salt of the random choice among the near-best (from the seed).
    pub salt: u32,
}

/// Tolerance ε of the choice among near-best matches, as ε·2¹⁶ (0 = best match only).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Tolerance(pub u32);

impl Tolerance {
    pub fn from_fraction(eps: f64) -> Self {
        Self((eps.clamp(0.0, 1.0) * 65536.0).round() as u32)
    }
    /// T = d + ⌊d·ε₁₆/2¹⁶⌋, saturating; split so it needs only 32-bit products, as on the GPU.
    #[inline]
    pub fn limit(self, d: u32) -> u32 {
        let e = self.0.min(65536);
        let hi = (d >> 16) * e;
        let lo = ((d & 0xffff) * e) >> 16;
        d.saturating_add(hi).saturating_add(lo)
    }
}

/// The random key of candidate `index` for a query's `salt`: an invertible 32-bit mix of
/// index + salt (xorshift–multiply rounds; each step is a bijection on u32).
#[inline]
pub fn pick_key(salt: u32, index: u32) -> u32 {
    let mut x = index.wrapping_add(salt);
    x ^= x >> 16;
    x = x.wrapping_mul(0x7feb_352d);
    x ^= x >> 15;
    x = x.wrapping_mul(0x846c_a68b);
    x ^= x >> 16;
    x
}

/// The index whose key is `key` (the inverse of [`pick_key`]; the GPU returns keys).
pub fn index_of_key(salt: u32, key: u32) -> u32 {
    let unshift = |mut x: u32, s: u32| {
        let mut y = x;
        let mut k = s;
        while k < 32 {
            x >>= s;
            y ^= x;
            k += s;
        }
        y
    };
    let mut x = unshift(key, 16);
    x = x.wrapping_mul(inverse_mod_2_32(0x846c_a68b));
    x = unshift(x, 15);
    x = x.wrapping_mul(inverse_mod_2_32(0x7feb_352d));
    x = unshift(x, 16);
    x.wrapping_sub(salt)
}

/// Multiplicative inverse of an odd number modulo 2³² (Newton's iteration).
const fn inverse_mod_2_32(a: u32) -> u32 {
    let mut x = a;
    let mut i = 0;
    while i < 5 {
        x = x.wrapping_mul(2u32.wrapping_sub(a.wrapping_mul(x)));
        i += 1;
    }
    x
}

/// The answer: position index and its distance.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Match {
    pub ssd: u32,
    pub index: u32,
}

/// Largest window the 32-bit cost can hold: w² · channels · 255² < 2³¹, leaving the other half
/// of the range to the occurrence penalty (capped at [`MAX_PENALTY_TOTAL`]).
pub fn window_fits(w: usize, channels: usize) -> bool {
    (w * w * channels) as u64 * 255 * 255 < (1u64 << 31)
}

/// Cap of penalty · known texels, so distance + penalty never overflows 32 bits.
pub const MAX_PENALTY_TOTAL: u32 = 1 << 31;

/// What every query of a batch shares.
#[derive(Clone, Copy, Debug)]
pub struct Search<'a> {
    /// Window side.
    pub w: usize,
    pub tol: Tolerance,
    /// Per exemplar, per candidate index: occurrence penalty per known texel, each at most
    /// `MAX_PENALTY_TOTAL / w²` (the patch pass's; `None` elsewhere).
    pub penalty: Option<&'a [Vec<u32>]>,
}

impl Search<'_> {
    /// The penalty of candidate `index` for a query with `known` known texels.
    #[inline]
    pub fn penalty_of(&self, exemplar: usize, index: usize, known: u32) -> u32 {
        self.penalty.map_or(0, |p| p[exemplar][index] * known)
    }
}

/// Number of known texels of a query.
pub fn known_texels(q: &Query, w: usize) -> u32 {
    q.mask.as_ref().map_or((w * w) as u32, |m| {
        m.iter().filter(|&&k| k != 0).count() as u32
    })
}

/// Runs searches; implemented on the CPU ([`CpuMatcher`]) and on the GPU (`gpu::GpuMatcher`).
pub trait Matcher: Sync {
    /// The answer of each query (all of window side `w`), in order.
    fn best_matches(&self, set: &ExemplarSet, s: &Search, queries: &[Query]) -> Result<Vec<Match>>;
    fn name(&self) -> String;
}

/// Distance between the query and the exemplar window at (x, y).
pub fn ssd_at(e: &Exemplar, w: usize, q: &Query, x: usize, y: usize) -> u32 {
    ssd_at_bounded(e, &Runs::of(q, w), &q.codes, x, y, u32::MAX)
}

/// The known texels of a query as runs (row, first column, length) of contiguous texels.
struct Runs {
    w: usize,
    runs: Vec<(usize, usize, usize)>,
}

impl Runs {
    fn of(q: &Query, w: usize) -> Self {
        let runs = match &q.mask {
            None => (0..w).map(|r| (r, 0, w)).collect(),
            Some(m) => {
                let mut v = Vec::new();
                for r in 0..w {
                    let row = &m[r * w..(r + 1) * w];
                    let mut x = 0;
                    while x < w {
                        if row[x] == 0 {
                            x += 1;
                            continue;
                        }
                        let start = x;
                        while x < w && row[x] != 0 {
                            x += 1;
                        }
                        v.push((r, start, x - start));
                    }
                }
                v
            }
        };
        Self { w, runs }
    }
}

/// As [`ssd_at`], but may stop early and return any value above `limit` once the partial sum
/// exceeds it.
#[inline]
fn ssd_at_bounded(e: &Exemplar, runs: &Runs, codes: &[u8], x: usize, y: usize, limit: u32) -> u32 {
    let c = e.channels();
    let ew = e.width();
    let w = runs.w;
    let mut total = 0u32;
    for &(r, start, len) in &runs.runs {
        let a = &e.codes[((y + r) * ew + x + start) * c..][..len * c];
        let b = &codes[(r * w + start) * c..][..len * c];
        total += row_ssd(a, b);
        if total > limit {
            return total;
        }
    }
    total
}

#[inline]
fn row_ssd(a: &[u8], b: &[u8]) -> u32 {
    a.iter()
        .zip(b)
        .map(|(&p, &q)| {
            let d = p as i32 - q as i32;
            (d * d) as u32
        })
        .sum()
}

/// Brute force over every position: the definition itself, for tests.
pub fn best_match_brute(set: &ExemplarSet, s: &Search, q: &Query) -> Match {
    let w = s.w;
    let e = &set.exemplars[q.exemplar as usize];
    let (cw, ch) = e.candidates(w);
    let known = known_texels(q, w);
    let all: Vec<(u32, u32)> = (0..ch)
        .flat_map(|y| (0..cw).map(move |x| (x, y)))
        .map(|(x, y)| {
            let index = y * cw + x;
            let pen = s.penalty_of(q.exemplar as usize, index, known);
            (ssd_at(e, w, q, x, y) + pen, index as u32)
        })
        .collect();
    let best = all.iter().map(|a| a.0).min().unwrap_or(u32::MAX);
    let limit = s.tol.limit(best);
    let (ssd, index) = all
        .into_iter()
        .filter(|a| a.0 <= limit)
        .min_by_key(|a| pick_key(q.salt, a.1))
        .expect("at least one candidate");
    Match { ssd, index }
}

/// The CPU backend: queries spread over all cores with rayon; each search prunes with the
/// quadrant-sum bound. Block sums are prepared once per (exemplar, window side).
pub struct CpuMatcher;

/// Quadrant block sums of each exemplar for one window side.
struct Prepared {
    half: usize,
    /// Per exemplar, per channel: sums over `half × half` blocks.
    sums: Vec<Vec<Vec<f32>>>,
}

impl Prepared {
    fn new(set: &ExemplarSet, w: usize) -> Self {
        let half = w / 2;
        Self {
            half,
            sums: set.exemplars.iter().map(|e| e.block_sums(half)).collect(),
        }
    }
}

impl Matcher for CpuMatcher {
    fn best_matches(&self, set: &ExemplarSet, s: &Search, queries: &[Query]) -> Result<Vec<Match>> {
        let prep = Prepared::new(set, s.w);
        Ok(queries
            .par_iter()
            .with_min_len(1)
            .map(|q| best_match_pruned(set, &prep, s, q))
            .collect())
    }
    fn name(&self) -> String {
        format!("CPU ({} threads)", rayon::current_num_threads())
    }
}

/// Exact search with the quadrant bound (see the module comment).
fn best_match_pruned(set: &ExemplarSet, prep: &Prepared, s: &Search, q: &Query) -> Match {
    let (w, tol) = (s.w, s.tol);
    let ex = q.exemplar as usize;
    let known = known_texels(q, w);
    let e = &set.exemplars[q.exemplar as usize];
    let c = e.channels();
    let (cw, ch) = e.candidates(w);
    let half = prep.half;
    if half == 0 {
        return best_match_brute(set, s, q);
    }
    let sums = &prep.sums[q.exemplar as usize];
    let plane_w = e.width() + 1 - half;

    // The sums of the query's fully known quadrants, as the same exact integers.
    let is_known = |dx: usize, dy: usize| q.mask.as_ref().is_none_or(|m| m[dy * w + dx] != 0);
    let mut quads: Vec<(usize, usize, Vec<f32>)> = Vec::with_capacity(4);
    for (ox, oy) in quadrants(half) {
        let all_known = (0..half).all(|dy| (0..half).all(|dx| is_known(ox + dx, oy + dy)));
        if !all_known {
            continue;
        }
        let mut sum = vec![0f32; c];
        for dy in 0..half {
            for dx in 0..half {
                let t = ((oy + dy) * w + ox + dx) * c;
                for (k, s) in sum.iter_mut().enumerate() {
                    *s += q.codes[t + k] as f32;
                }
            }
        }
        quads.push((ox, oy, sum));
    }
    let runs = Runs::of(q, w);

    let guess = (q.guess as usize).min(cw * ch - 1);
    let (gx, gy) = (guess % cw, guess / cw);
    // Candidates are kept while their distance is within the tolerance of the best so far;
    // as the best only falls, every candidate within the final limit is among them.
    let mut best =
        ssd_at_bounded(e, &runs, &q.codes, gx, gy, u32::MAX) + s.penalty_of(ex, guess, known);
    let mut kept: Vec<(u32, u32)> = vec![(best, guess as u32)];
    let mut limit = tol.limit(best);
    // Prune when bound · half² > threshold; the margin covers f32 rounding of ≤ 4·c squares
    // of exact integers (relative error ≤ 4c·2⁻²⁴ ≪ 2⁻¹⁶).
    let area = (half * half) as f64;
    let threshold = |limit: u32| (limit as f64 * area * (1.0 + 1.0 / 65536.0) + 1.0) as f32;
    let penalties = s.penalty.map(|p| &p[ex]);
    let mut acc = vec![0f32; cw];
    for y in 0..ch {
        acc.iter_mut().for_each(|a| *a = 0.0);
        for (ox, oy, sum) in &quads {
            let (ox, oy) = (*ox, *oy);
            for (k, &target) in sum.iter().enumerate() {
                let row = &sums[k][(y + oy) * plane_w + ox..][..cw];
                for (a, &s) in acc.iter_mut().zip(row) {
                    let d = s - target;
                    *a += d * d;
                }
            }
        }
        let mut bound_limit = threshold(limit);
        for (x, &bound) in acc.iter().enumerate() {
            let index = y * cw + x;
            let pen = penalties.map_or(0, |p| p[index] * known);
            if pen > limit {
                continue;
            }
            if pen == 0 {
                if bound > bound_limit {
                    continue;
                }
            } else if bound > threshold(limit - pen) {
                continue;
            }
            if index == guess {
                continue;
            }
            let ssd = ssd_at_bounded(e, &runs, &q.codes, x, y, limit - pen);
            if ssd > limit - pen {
                continue;
            }
            let cost = ssd + pen;
            kept.push((cost, index as u32));
            if cost < best {
                best = cost;
                limit = tol.limit(best);
                bound_limit = threshold(limit);
            }
        }
    }
    let (ssd, index) = kept
        .into_iter()
        .filter(|a| a.0 <= limit)
        .min_by_key(|a| pick_key(q.salt, a.1))
        .expect("the guess is always kept");
    Match { ssd, index }
}

/// Top-left corners of the four quadrants of a window of side 2·half.
fn quadrants(half: usize) -> [(usize, usize); 4] {
    [(0, 0), (half, 0), (0, half), (half, half)]
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::texture::Texture;
    use derma_core::rng::Philox;

    pub(crate) fn noise_texture(w: usize, h: usize, c: usize, seed: u64) -> Texture {
        let rng = Philox::new(seed, 0);
        // Smooth-ish noise: box-filtered white noise, so windows differ but bounds can bite.
        let raw: Vec<f32> = (0..w * h * c)
            .map(|i| rng.uniform4(i as u64, 0)[0])
            .collect();
        let data = (0..w * h * c)
            .map(|i| {
                let (k, t) = (i % c, i / c);
                let (x, y) = (t % w, t / w);
                let mut s = 0.0;
                for (dx, dy) in [(0, 0), (1, 0), (0, 1), (1, 1)] {
                    let (xx, yy) = ((x + dx).min(w - 1), (y + dy).min(h - 1));
                    s += raw[(yy * w + xx) * c + k];
                }
                s / 4.0
            })
            .collect();
        Texture::new(w, h, c, data).unwrap()
    }

    fn window(e: &Exemplar, w: usize, x: usize, y: usize) -> Vec<u8> {
        let c = e.channels();
        (0..w)
            .flat_map(|r| e.codes[((y + r) * e.width() + x) * c..][..w * c].to_vec())
            .collect()
    }

    #[test]
    fn pruned_search_equals_brute_force_whatever_the_guess() {
        let set = ExemplarSet::new(vec![noise_texture(48, 40, 3, 7)], 8).unwrap();
        let e = &set.exemplars[0];
        let w = 8;
        let (cw, ch) = e.candidates(w);
        let prep = Prepared::new(&set, w);
        let rng = Philox::new(3, 1);
        for i in 0..40u64 {
            let r = rng.u32x4(i);
            // Queries: exemplar windows with noise added, and pure noise.
            let (x, y) = (r[0] as usize % cw, r[1] as usize % ch);
            let mut codes = window(e, w, x, y);
            for (j, v) in codes.iter_mut().enumerate() {
                let n = rng.u32x4_sub(i, j as u32 + 1)[0] % (1 + i as u32 * 3);
                *v = v.saturating_add(n as u8);
            }
            let q = Query {
                exemplar: 0,
                codes,
                guess: r[2] % (cw * ch) as u32,
                salt: r[3],
                mask: None,
            };
            // Half the queries know only an L-shaped overlap plus a ragged extra column.
            let mut q = q;
            if i % 2 == 1 {
                q.mask = Some(
                    (0..w * w)
                        .map(|t| {
                            let (x, y) = (t % w, t / w);
                            u8::from(x < w / 2 || y < w / 2 || (x == w - 1 && y % 3 == 0))
                        })
                        .collect(),
                );
            }
            let pen: Vec<Vec<u32>> = vec![(0..cw * ch)
                .map(|k| ((k * 7919) % 13) as u32 * 40)
                .collect()];
            for tol in [
                Tolerance(0),
                Tolerance::from_fraction(0.1),
                Tolerance::from_fraction(0.5),
            ] {
                for penalty in [None, Some(&pen[..])] {
                    let s = Search { w, tol, penalty };
                    assert_eq!(
                        best_match_pruned(&set, &prep, &s, &q),
                        best_match_brute(&set, &s, &q)
                    );
                }
            }
        }
    }

    #[test]
    fn an_exact_window_is_found_at_distance_zero_and_ties_go_to_the_least_key() {
        // A constant exemplar: every window ties, so the least key over all 625 must win.
        let flat = Texture::new(32, 32, 1, vec![0.5; 1024]).unwrap();
        let set = ExemplarSet::new(vec![flat], 8).unwrap();
        let q = Query {
            exemplar: 0,
            codes: vec![3; 64],
            guess: 77,
            salt: 12345,
            mask: None,
        };
        let m = CpuMatcher
            .best_matches(
                &set,
                &Search {
                    w: 8,
                    tol: Tolerance(0),
                    penalty: None,
                },
                &[q],
            )
            .unwrap();
        let want = (0..625u32).min_by_key(|&i| pick_key(12345, i)).unwrap();
        assert_eq!(m[0].index, want);

        let set = ExemplarSet::new(vec![noise_texture(40, 40, 2, 1)], 8).unwrap();
        let e = &set.exemplars[0];
        let q = Query {
            exemplar: 0,
            codes: window(e, 8, 13, 21),
            guess: 0,
            salt: 9,
            mask: None,
        };
        let m = CpuMatcher
            .best_matches(
                &set,
                &Search {
                    w: 8,
                    tol: Tolerance(0),
                    penalty: None,
                },
                &[q],
            )
            .unwrap();
        assert_eq!(
            m[0],
            Match {
                ssd: 0,
                index: (21 * 33 + 13) as u32
            }
        );
    }

    #[test]
    fn keys_invert_and_the_tolerance_limit_is_exact() {
        for (salt, i) in [
            (0u32, 0u32),
            (7, 1),
            (0xdead_beef, 123_456),
            (u32::MAX, 65_000),
        ] {
            assert_eq!(index_of_key(salt, pick_key(salt, i)), i);
        }
        let t = Tolerance::from_fraction(0.1);
        for d in [0u32, 1, 9, 10, 65_535, 65_536, 1 << 30, u32::MAX] {
            let exact = d as u64 + (d as u64 * t.0 as u64 >> 16);
            assert_eq!(t.limit(d) as u64, exact.min(u32::MAX as u64), "d = {d}");
        }
    }

    #[test]
    fn window_limit_guards_the_32_bit_sum() {
        assert!(window_fits(64, 7));
        assert!(!window_fits(64, 9));
    }
}

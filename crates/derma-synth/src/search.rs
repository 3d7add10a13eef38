//! The best-match search of Shen et al. §3.2, eq. 1 and §3.4: the exemplar window with the
//! least L2 distance to a query window, over every position. Exact, so CPU and GPU agree.
//!
//! Definition (both backends compute exactly this): windows are `w × w` texels of 8-bit codes
//! (see [`crate::exemplar`]). The distance d is the integer sum of squared code differences
//! over the query's known texels (all, or those its mask marks) and all channels; where the
//! patch pass asks for it, an occurrence penalty `penalty[index] · known texels` is added
//! (see [`crate::patch_pass`]), giving the cost. With d* the least cost over all positions and
//! T = d* + ⌊d* · ε₁₆ / 2¹⁶⌋ (ε₁₆ = ε·2¹⁶, the tolerance), the answer is, among the positions
//! with cost ≤ T, the one with the least key `pick_key(salt, index)`, index =
//! `y · (exemplar width − w + 1) + x`. The key is a bijection of the index for a given salt,
//! so the answer is unique; integers make every sum independent of summation order.
//! With ε = 0 this is the best match of eq. 1, ties broken at random; with ε > 0 it is image
//! quilting's choice among the near-best (Efros & Freeman 2001 §2.1, the paper's ref. \[8\]),
//! which keeps a deterministic best match from copying the same chain of patches over and over.
//!
//! The CPU search prunes without changing that answer (successive elimination, Li & Salari
//! 1995): the sums `S` of a window's fully known `b × b` blocks bound the distance from below,
//! Σ (S_e − S_q)² / b² ≤ distance (Cauchy–Schwarz on each block). It bounds with the w/2
//! quadrants (16 candidates at a time, vectorised), then with w/4 blocks, then computes the
//! exact distance with early exit; a candidate whose bound exceeds the limit of the best cost
//! found so far cannot be chosen. It starts from coherent guesses (positions continuing the
//! neighbouring texels' sources), which make the first limit tight.

use crate::coherence::Candidates;
use crate::exemplar::{Exemplar, ExemplarSet};
pub use crate::key::{index_of_key, pick_key};
use rayon::prelude::*;

/// One search: a window of codes, the exemplar to search and starting guesses.
#[derive(Clone, Debug)]
pub struct Query {
    /// Index of the exemplar in the set.
    pub exemplar: u32,
    /// `w × w × channels` codes, rows from the top, channels interleaved.
    pub codes: Vec<u8>,
    /// Known texels (`w × w`, 1 = known) when not all are: the patch pass compares only the
    /// overlap with texels already synthesised (§3.2).
    pub mask: Option<Vec<u8>>,
    /// Candidate position indices to start from (any valid ones, at least one; they change
    /// only the speed: the lowest distance among them is the first limit).
    pub guesses: Vec<u32>,
    /// Per-query salt of the random choice among the near-best (from the seed).
    pub salt: u32,
}

/// Tolerance ε of the choice among near-best matches, as ε·2¹⁶ (0 = best match only).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Tolerance(pub u32);

impl Tolerance {
    /// The tolerance ε as a fraction of the best cost (image quilting's 0.1).
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

/// The answer: position index and its cost (distance plus any occurrence penalty).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Match {
    /// Distance plus occurrence penalty.
    pub cost: u32,
    /// Exemplar position, y · candidates_per_row + x.
    pub index: u32,
}

/// The threshold of the bound test `bound > limit · b²` in f32, with a margin that covers the
/// rounding of a sum of n squares of exact integers (relative error ≤ n · 2⁻²⁴): a bound has
/// at most 16 · channels terms, which [`window_fits`] keeps ≤ 33 024 (w ≥ 4), so the error is
/// ≤ 2⁻⁹ < 2⁻⁸, and a candidate is only ever skipped when its distance exceeds `limit`.
#[inline]
pub(crate) fn bound_limit(limit: u32, b: usize) -> f32 {
    (limit as f64 * (b * b) as f64 * (1.0 + 1.0 / 256.0) + 1.0) as f32
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
    /// Near-best tolerance of the choice.
    pub tol: Tolerance,
    /// Per exemplar, per candidate index: occurrence penalty per known texel, each at most
    /// `MAX_PENALTY_TOTAL / w²` (the patch pass's; `None` elsewhere).
    pub penalty: Option<&'a [Vec<u32>]>,
    /// The exemplar set's block sums for windows of side `w`, made once for many searches (the
    /// patch pass's rounds); `None`: the CPU makes them per call. The GPU keeps its own.
    pub prepared: Option<&'a Prepared<'a>>,
    /// Where given, the search runs over each query's k-coherence candidates (see
    /// [`crate::coherence`]) instead of every position: the same rule over fewer positions.
    pub coherence: Option<Candidates<'a>>,
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

/// A plane of codes that windows are read from (the canvas during the optimisation passes):
/// `width × height` texels, channels interleaved, wrapping at its edges when `wrap`.
#[derive(Clone, Copy, Debug)]
pub struct Plane<'a> {
    /// Texels per row.
    pub width: usize,
    /// Rows.
    pub height: usize,
    /// Codes per texel.
    pub channels: usize,
    /// A torus (tileable output): windows continue across the edges.
    pub wrap: bool,
    /// `width × height × channels` codes, rows from the top.
    pub codes: &'a [u8],
}

impl Plane<'_> {
    /// The codes of the `w × w` window at (x, y), rows from the top, channels interleaved.
    pub fn window(&self, x: usize, y: usize, w: usize) -> Vec<u8> {
        let c = self.channels;
        let mut out = Vec::with_capacity(w * w * c);
        for dy in 0..w {
            let row = if self.wrap {
                (y + dy) % self.height
            } else {
                y + dy
            };
            if x + w <= self.width {
                let t = row * self.width + x;
                out.extend_from_slice(&self.codes[t * c..(t + w) * c]);
            } else {
                for dx in 0..w {
                    let t = row * self.width + (x + dx) % self.width;
                    out.extend_from_slice(&self.codes[t * c..(t + 1) * c]);
                }
            }
        }
        out
    }
}

/// A search for the whole `w × w` window at (x, y) of a [`Plane`]: the optimisation passes'
/// M-step, whose windows are all known. The GPU reads them from a copy of the canvas on the
/// device (`gpu::GpuMatcher`), so no window travels on its own.
#[derive(Clone, Debug)]
pub struct WindowQuery {
    /// Index of the exemplar in the set.
    pub exemplar: u32,
    /// Column of the window's top-left texel.
    pub x: u32,
    /// Row of the window's top-left texel.
    pub y: u32,
    /// As [`Query::guesses`]: at least one, at most [`MAX_GUESSES`]; or none for a search that
    /// makes the coherent guesses itself from sources it keeps (the GPU's search of the canvas
    /// its optimisation passes keep there).
    pub guesses: Vec<u32>,
    /// As [`Query::salt`].
    pub salt: u32,
}

/// Most starting guesses of a [`WindowQuery`] (the optimisation pass probes five texels).
pub const MAX_GUESSES: usize = 5;

impl WindowQuery {
    /// The same search as a [`Query`] carrying its window's codes.
    pub fn query(&self, plane: &Plane, w: usize) -> Query {
        Query {
            exemplar: self.exemplar,
            codes: plane.window(self.x as usize, self.y as usize, w),
            mask: None,
            guesses: self.guesses.clone(),
            salt: self.salt,
        }
    }
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
/// exceeds it, checked every [`CHECK_EVERY`] runs (integers: the order of the sums does not
/// change the total).
#[inline(always)]
fn ssd_at_bounded(e: &Exemplar, runs: &Runs, codes: &[u8], x: usize, y: usize, limit: u32) -> u32 {
    let c = e.channels();
    let ew = e.width();
    let w = runs.w;
    let mut total = 0u32;
    for (i, &(r, start, len)) in runs.runs.iter().enumerate() {
        let a = &e.codes[((y + r) * ew + x + start) * c..][..len * c];
        let b = &codes[(r * w + start) * c..][..len * c];
        total += row_ssd(a, b);
        if i % CHECK_EVERY == CHECK_EVERY - 1 && total > limit {
            return total;
        }
    }
    total
}

/// Runs of known texels between the early-exit checks of [`ssd_at_bounded`].
const CHECK_EVERY: usize = 2;

/// The squared differences of two rows of codes, summed: differences in 16 bits and their
/// squares summed in 32, the reduction AVX2 runs as vpmaddwd (exact: a row of at most 2¹⁵
/// codes sums to below 2³¹).
#[inline(always)]
fn row_ssd(a: &[u8], b: &[u8]) -> u32 {
    a.iter()
        .zip(b)
        .map(|(&p, &q)| {
            let d = (p as i16 - q as i16) as i32;
            d * d
        })
        .sum::<i32>() as u32
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
    choose(q.salt, all, limit)
}

/// Among `(cost, index)` candidates, the one with cost ≤ `limit` and the least key.
fn choose(salt: u32, candidates: Vec<(u32, u32)>, limit: u32) -> Match {
    let (cost, index) = candidates
        .into_iter()
        .filter(|a| a.0 <= limit)
        .min_by_key(|a| pick_key(salt, a.1))
        .expect("at least one candidate within the limit");
    Match { cost, index }
}

/// A query's guesses, clamped to the candidate range and without repeats, with their costs.
fn guess_costs(e: &Exemplar, s: &Search, q: &Query, runs: &Runs) -> Vec<(u32, u32)> {
    let (cw, ch) = e.candidates(s.w);
    let known = known_texels(q, s.w);
    let mut guesses: Vec<usize> = q
        .guesses
        .iter()
        .map(|&g| (g as usize).min(cw * ch - 1))
        .collect();
    guesses.sort_unstable();
    guesses.dedup();
    guesses
        .into_iter()
        .map(|g| {
            let d = ssd_at_bounded(e, runs, &q.codes, g % cw, g / cw, u32::MAX);
            (d + s.penalty_of(q.exemplar as usize, g, known), g as u32)
        })
        .collect()
}

/// The least cost among a query's guesses: where both backends start (an upper bound of d*).
pub fn initial_cost(set: &ExemplarSet, s: &Search, q: &Query) -> u32 {
    let e = &set.exemplars[q.exemplar as usize];
    guess_costs(e, s, q, &Runs::of(q, s.w))
        .iter()
        .map(|g| g.0)
        .min()
        .unwrap_or(u32::MAX)
}

/// Candidates whose bounds are tested together (vectorised).
const CHUNK: usize = 16;

/// Quadrant block sums of each exemplar of a set for one window side, which the CPU search's
/// bounds read (see the module comment). It borrows the set: a search of another set makes its
/// own.
pub struct Prepared<'s> {
    set: &'s ExemplarSet,
    w: usize,
    half: usize,
    /// Per exemplar, per channel: sums over `half × half` blocks.
    sums: Vec<Vec<Vec<f32>>>,
    /// Side of the finer level of blocks (`half / 2`; 0 when there is none).
    fine: usize,
    /// Per exemplar, per channel: sums over `fine × fine` blocks.
    fine_sums: Vec<Vec<Vec<f32>>>,
}

impl std::fmt::Debug for Prepared<'_> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "Prepared {{ w: {} }}", self.w)
    }
}

impl<'s> Prepared<'s> {
    /// The block sums of `set`'s exemplars for windows of side `w`.
    pub fn new(set: &'s ExemplarSet, w: usize) -> Self {
        let half = w / 2;
        let fine = if half >= 2 { half / 2 } else { 0 };
        Self {
            set,
            w,
            half,
            sums: set.exemplars.iter().map(|e| e.block_sums(half)).collect(),
            fine,
            fine_sums: if fine > 0 {
                // Padded by a chunk, so the bound of every chunk reads 16 values (those past the
                // row's end are never used).
                set.exemplars
                    .iter()
                    .map(|e| {
                        let mut planes = e.block_sums(fine);
                        planes
                            .iter_mut()
                            .for_each(|p| p.resize(p.len() + CHUNK, 0.0));
                        planes
                    })
                    .collect()
            } else {
                Vec::new()
            },
        }
    }
}

/// The sums of the query's fully known `b × b` blocks (of a window of side `w` tiled by
/// them): (x offset, y offset, one sum per channel), as exact integers in f32.
pub(crate) fn known_block_sums(
    q: &Query,
    w: usize,
    c: usize,
    b: usize,
) -> Vec<(usize, usize, Vec<f32>)> {
    let is_known = |dx: usize, dy: usize| q.mask.as_ref().is_none_or(|m| m[dy * w + dx] != 0);
    let mut out = Vec::new();
    for oy in (0..w).step_by(b) {
        for ox in (0..w).step_by(b) {
            if !(0..b).all(|dy| (0..b).all(|dx| is_known(ox + dx, oy + dy))) {
                continue;
            }
            let mut sum = vec![0f32; c];
            for dy in 0..b {
                for dx in 0..b {
                    let t = ((oy + dy) * w + ox + dx) * c;
                    for (k, s) in sum.iter_mut().enumerate() {
                        *s += q.codes[t + k] as f32;
                    }
                }
            }
            out.push((ox, oy, sum));
        }
    }
    out
}

/// The CPU backend's answers to `queries`: spread over all cores with rayon; each search prunes
/// with the block-sum bounds, the exemplars' block sums those of the search or prepared once
/// per call.
pub(crate) fn best_matches_cpu(set: &ExemplarSet, s: &Search, queries: &[Query]) -> Vec<Match> {
    if let Some(c) = s.coherence {
        return queries
            .par_iter()
            .map_init(Vec::new, |cands, q| {
                best_match_coherent(set, s, c, q, cands)
            })
            .collect();
    }
    let own;
    let prep = match s.prepared {
        Some(p) if p.w == s.w && std::ptr::eq(p.set, set) => p,
        _ => {
            own = Prepared::new(set, s.w);
            &own
        }
    };
    let threads = rayon::current_num_threads();
    if queries.len() >= threads {
        return queries
            .par_iter()
            .with_min_len(1)
            .map(|q| best_match_pruned(set, prep, s, q))
            .collect();
    }
    // Fewer queries than threads (the patch pass's last searches of a wavefront): each
    // query's rows are split among the threads. Every part keeps all candidates within its
    // own limit, which is at least the whole search's, so the merged candidates hold every
    // one within the final limit and the answer is the same.
    queries
        .iter()
        .map(|q| {
            let (_, ch) = set.exemplars[q.exemplar as usize].candidates(s.w);
            let parts = (threads * 4).min(ch);
            let found: Vec<(Vec<(u32, u32)>, u32)> = (0..parts)
                .into_par_iter()
                .map(|p| scan_pruned(set, prep, s, q, p * ch / parts..(p + 1) * ch / parts))
                .collect();
            let best = found.iter().map(|f| f.1).min().unwrap_or(u32::MAX);
            let mut kept: Vec<(u32, u32)> = found.into_iter().flat_map(|f| f.0).collect();
            kept.sort_unstable_by_key(|k| k.1);
            kept.dedup();
            choose(q.salt, kept, s.tol.limit(best))
        })
        .collect()
}

/// The search over a query's k-coherence candidates ([`Coherence::candidates`], into `cands`):
/// each cost computed exactly, stopping early once it exceeds the tolerance of the least so far.
pub(crate) fn best_match_coherent(
    set: &ExemplarSet,
    s: &Search,
    c: Candidates,
    q: &Query,
    cands: &mut Vec<u32>,
) -> Match {
    let ex = q.exemplar as usize;
    let e = &set.exemplars[ex];
    let (cw, ch) = e.candidates(s.w);
    let (runs, known) = (Runs::of(q, s.w), known_texels(q, s.w));
    c.tables
        .candidates(ex, cw * ch, &q.guesses, q.salt, c.random, cands);
    let avx2 =
        cfg!(target_arch = "x86_64") && derma_core::numerics::lanes::Avx2::detect().is_some();
    let mut best = u32::MAX;
    let mut kept = Vec::with_capacity(cands.len());
    for &i in cands.iter() {
        let pen = s.penalty_of(ex, i as usize, known);
        let limit = s.tol.limit(best);
        if pen > limit {
            continue;
        }
        let (x, y) = (i as usize % cw, i as usize / cw);
        let d = if avx2 {
            ssd_bounded_on::<true>(e, &runs, &q.codes, x, y, limit - pen)
        } else {
            ssd_at_bounded(e, &runs, &q.codes, x, y, limit - pen)
        };
        if d <= limit - pen {
            kept.push((d + pen, i));
            best = best.min(d + pen);
        }
    }
    choose(q.salt, kept, s.tol.limit(best))
}

/// Brute force over a query's k-coherence candidates: the definition itself, for tests.
pub fn best_match_coherent_brute(set: &ExemplarSet, s: &Search, c: Candidates, q: &Query) -> Match {
    let e = &set.exemplars[q.exemplar as usize];
    let (cw, ch) = e.candidates(s.w);
    let known = known_texels(q, s.w);
    let mut cands = Vec::new();
    let ex = q.exemplar as usize;
    c.tables
        .candidates(ex, cw * ch, &q.guesses, q.salt, c.random, &mut cands);
    let all: Vec<(u32, u32)> = cands
        .iter()
        .map(|&i| {
            let pen = s.penalty_of(q.exemplar as usize, i as usize, known);
            (ssd_at(e, s.w, q, i as usize % cw, i as usize / cw) + pen, i)
        })
        .collect();
    let best = all.iter().map(|a| a.0).min().unwrap_or(u32::MAX);
    choose(q.salt, all, s.tol.limit(best))
}

/// Exact search with the block-sum bounds over every candidate, on one thread.
fn best_match_pruned(set: &ExemplarSet, prep: &Prepared, s: &Search, q: &Query) -> Match {
    let (_, ch) = set.exemplars[q.exemplar as usize].candidates(s.w);
    let (kept, best) = scan_pruned(set, prep, s, q, 0..ch);
    choose(q.salt, kept, s.tol.limit(best))
}

/// Exact search with the block-sum bounds (see the module comment) over the candidate rows
/// `rows`, starting from the query's guesses: every candidate whose cost is within the
/// tolerance of the least cost found (the guesses included), and that least cost. Compiled for
/// AVX2 + FMA where the processor has them (the bound loops vectorise 8 wide; the answer is
/// the same, as every decision that matters is made on exact integers).
fn scan_pruned(
    set: &ExemplarSet,
    prep: &Prepared,
    s: &Search,
    q: &Query,
    rows: std::ops::Range<usize>,
) -> (Vec<(u32, u32)>, u32) {
    #[cfg(target_arch = "x86_64")]
    if derma_core::numerics::lanes::Avx2::detect().is_some() {
        // SAFETY: the token proves the CPU has the features the function is compiled for.
        return unsafe { scan_pruned_avx2(set, prep, s, q, rows) };
    }
    scan_pruned_body::<false>(set, prep, s, q, rows)
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,fma")]
unsafe fn scan_pruned_avx2(
    set: &ExemplarSet,
    prep: &Prepared,
    s: &Search,
    q: &Query,
    rows: std::ops::Range<usize>,
) -> (Vec<(u32, u32)>, u32) {
    scan_pruned_body::<true>(set, prep, s, q, rows)
}

/// The exact distance of [`ssd_at_bounded`], on AVX2 where `AVX2` (only so instantiated inside
/// [`scan_pruned_avx2`], which runs after the processor was found to have it).
#[inline(always)]
fn ssd_bounded_on<const AVX2: bool>(
    e: &Exemplar,
    runs: &Runs,
    codes: &[u8],
    x: usize,
    y: usize,
    limit: u32,
) -> u32 {
    #[cfg(target_arch = "x86_64")]
    if AVX2 {
        // SAFETY: see the function's comment.
        return unsafe { ssd_at_bounded_avx2(e, runs, codes, (x, y), limit) };
    }
    ssd_at_bounded(e, runs, codes, x, y, limit)
}

/// [`ssd_at_bounded`] with the differences of 16 codes at a time in 16 bits, their squares
/// summed in pairs into eight 32-bit lanes (vpmaddwd: at most 2 · 255² a pair) and the lanes
/// added across only at the early-exit checks; the same integers.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
unsafe fn ssd_at_bounded_avx2(
    e: &Exemplar,
    runs: &Runs,
    codes: &[u8],
    (x, y): (usize, usize),
    limit: u32,
) -> u32 {
    use std::arch::x86_64::*;
    let c = e.channels();
    let (ew, w) = (e.width(), runs.w);
    let mut acc = _mm256_setzero_si256();
    let mut rest = 0u32;
    let total = |acc: __m256i, rest: u32| {
        let mut lanes = [0u32; 8];
        // SAFETY: `lanes` holds 32 bytes.
        unsafe { _mm256_storeu_si256(lanes.as_mut_ptr().cast(), acc) };
        lanes.iter().fold(rest, |s, &l| s.wrapping_add(l))
    };
    for (i, &(r, start, len)) in runs.runs.iter().enumerate() {
        let a = &e.codes[((y + r) * ew + x + start) * c..][..len * c];
        let b = &codes[(r * w + start) * c..][..len * c];
        let mut k = 0;
        while k + 16 <= a.len() {
            // SAFETY: k + 16 ≤ the length of both slices.
            let (va, vb) = unsafe {
                (
                    _mm_loadu_si128(a.as_ptr().add(k).cast()),
                    _mm_loadu_si128(b.as_ptr().add(k).cast()),
                )
            };
            let d = _mm256_sub_epi16(_mm256_cvtepu8_epi16(va), _mm256_cvtepu8_epi16(vb));
            acc = _mm256_add_epi32(acc, _mm256_madd_epi16(d, d));
            k += 16;
        }
        rest += row_ssd(&a[k..], &b[k..]);
        if i % CHECK_EVERY == CHECK_EVERY - 1 {
            let t = total(acc, rest);
            if t > limit {
                return t;
            }
        }
    }
    total(acc, rest)
}

#[inline(always)]
fn scan_pruned_body<const AVX2: bool>(
    set: &ExemplarSet,
    prep: &Prepared,
    s: &Search,
    q: &Query,
    rows: std::ops::Range<usize>,
) -> (Vec<(u32, u32)>, u32) {
    let (w, tol) = (s.w, s.tol);
    let ex = q.exemplar as usize;
    let known = known_texels(q, w);
    let e = &set.exemplars[ex];
    let c = e.channels();
    let (cw, _) = e.candidates(w);
    let half = prep.half;
    if half == 0 {
        let m = best_match_brute(set, s, q);
        return (vec![(m.cost, m.index)], m.cost);
    }
    let sums = &prep.sums[ex];
    let plane_w = e.width() + 1 - half;

    // The sums of the query's fully known quadrants, and of its fully known blocks at the
    // finer level: a finer partition gives a tighter bound (the bounds of a block's four
    // sub-blocks add up to at least its own), so it runs only where the coarse one passed.
    let quads = known_block_sums(q, w, c, half);
    let fine = prep.fine;
    let (fine_w, fine_at, fine_target) = if fine > 0 {
        let fine_w = e.width() + 1 - fine;
        let blocks = known_block_sums(q, w, c, fine);
        let at: Vec<usize> = blocks.iter().map(|(ox, oy, _)| oy * fine_w + ox).collect();
        let target: Vec<f32> = blocks.into_iter().flat_map(|b| b.2).collect();
        (fine_w, at, target)
    } else {
        (0, Vec::new(), Vec::new())
    };
    let fine_sums = prep.fine_sums.get(ex);
    let runs = Runs::of(q, w);

    // Candidates are kept while their cost is within the tolerance of the best so far; as
    // the best only falls, every candidate within the final limit is among them.
    let mut kept = guess_costs(e, s, q, &runs);
    let guesses: Vec<usize> = kept.iter().map(|g| g.1 as usize).collect();
    let mut best = kept.iter().map(|k| k.0).min().unwrap_or(u32::MAX);
    let mut limit = tol.limit(best);
    let mut coarse_limit = bound_limit(limit, half);
    let mut fine_limit = bound_limit(limit, fine);
    let penalties = s.penalty.map(|p| &p[ex]);
    let mut acc = vec![0f32; cw];
    for y in rows {
        acc.iter_mut().for_each(|a| *a = 0.0);
        for (ox, oy, sum) in &quads {
            for (k, &target) in sum.iter().enumerate() {
                let row = &sums[k][(y + oy) * plane_w + ox..][..cw];
                for (a, &s) in acc.iter_mut().zip(row) {
                    let d = s - target;
                    *a += d * d;
                }
            }
        }
        // Most candidates fail the coarse bound: test 16 at a time (vectorised) before
        // looking at any one. A penalty only raises a cost, so the shared limit is safe.
        for (chunk_no, chunk) in acc.chunks(CHUNK).enumerate() {
            if chunk
                .iter()
                .map(|&b| u32::from(b <= coarse_limit))
                .sum::<u32>()
                == 0
            {
                continue;
            }
            let x0 = chunk_no * CHUNK;
            // Where the patch pass bars windows most candidates may carry the cap: a chunk
            // none of whose coarse survivors could pay its penalty within the limit is done.
            if let Some(p) = penalties {
                let pens = &p[y * cw + x0..][..chunk.len()];
                if !chunk
                    .iter()
                    .zip(pens)
                    .any(|(&b, &pen)| b <= coarse_limit && pen * known <= limit)
                {
                    continue;
                }
            }
            // The finer bound of the whole chunk, vectorised the same way.
            // Always a whole chunk (the planes are padded), so the sums stay in registers.
            let mut fine_bound = [0f32; CHUNK];
            if let Some(fs) = fine_sums {
                let base = y * fine_w + x0;
                for (i, &at) in fine_at.iter().enumerate() {
                    for (k, plane) in fs.iter().enumerate() {
                        let t = fine_target[i * c + k];
                        let row: &[f32; CHUNK] =
                            plane[base + at..][..CHUNK].try_into().expect("a chunk");
                        for j in 0..CHUNK {
                            let d = row[j] - t;
                            fine_bound[j] += d * d;
                        }
                    }
                }
            }
            // The chunk's survivors of both bounds as bits, without a branch per candidate
            // (which bound passes is unpredictable); each is checked again below, as the
            // limits may fall within the chunk.
            let mut survivors = 0u32;
            for (j, (&b, &f)) in chunk.iter().zip(&fine_bound).enumerate() {
                survivors |= u32::from((b <= coarse_limit) & (f <= fine_limit)) << j;
            }
            while survivors != 0 {
                let j = survivors.trailing_zeros() as usize;
                survivors &= survivors - 1;
                let bound = chunk[j];
                if bound > coarse_limit || fine_bound[j] > fine_limit {
                    continue;
                }
                let x = x0 + j;
                let index = y * cw + x;
                let pen = penalties.map_or(0, |p| p[index] * known);
                let own_limit = if pen == 0 {
                    limit
                } else if pen > limit
                    || bound > bound_limit(limit - pen, half)
                    || fine_bound[j] > bound_limit(limit - pen, fine)
                {
                    continue;
                } else {
                    limit - pen
                };
                if guesses.contains(&index) {
                    continue;
                }
                let ssd = ssd_bounded_on::<AVX2>(e, &runs, &q.codes, x, y, own_limit);
                if ssd > own_limit {
                    continue;
                }
                let cost = ssd + pen;
                kept.push((cost, index as u32));
                if cost < best {
                    best = cost;
                    limit = tol.limit(best);
                    coarse_limit = bound_limit(limit, half);
                    fine_limit = bound_limit(limit, fine);
                }
            }
        }
    }
    (kept, best)
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;
    use crate::matcher::{CpuMatcher, Matcher};
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
    fn the_avx2_distance_is_the_definition() {
        // Rows of 8 to 96 codes (16 at a time, and the rest), with and without a mask, against
        // ssd_at; and the early exit returns more than the limit exactly when the distance is.
        let rng = Philox::new(3, 9);
        for (c, w) in [(1, 8), (3, 8), (3, 16), (2, 32), (3, 32), (4, 12)] {
            let set = ExemplarSet::new(vec![noise_texture(48, 40, c, 7 + c as u64)], 8).unwrap();
            let e = &set.exemplars[0];
            let (cw, ch) = e.candidates(w);
            for k in 0..24u64 {
                let mask = (k % 2 == 1).then(|| {
                    (0..w * w)
                        .map(|t| u8::from(rng.uniform4(k, t as u32)[0] < 0.6))
                        .collect::<Vec<u8>>()
                });
                let q = Query {
                    exemplar: 0,
                    codes: window(e, w, (k as usize * 5) % cw, (k as usize * 3) % ch),
                    mask,
                    guesses: vec![0],
                    salt: 0,
                };
                let runs = Runs::of(&q, w);
                let (x, y) = ((k as usize * 11) % cw, (k as usize * 7) % ch);
                let want = ssd_at(e, w, &q, x, y);
                assert_eq!(
                    ssd_bounded_on::<false>(e, &runs, &q.codes, x, y, u32::MAX),
                    want
                );
                if derma_core::numerics::lanes::Avx2::detect().is_none() {
                    continue;
                }
                assert_eq!(
                    ssd_bounded_on::<true>(e, &runs, &q.codes, x, y, u32::MAX),
                    want
                );
                for limit in [0, want / 2, want.saturating_sub(1), want] {
                    let got = ssd_bounded_on::<true>(e, &runs, &q.codes, x, y, limit);
                    assert_eq!(got > limit, want > limit, "c {c}, w {w}, limit {limit}");
                }
            }
        }
    }

    #[test]
    fn pruned_search_equals_brute_force_whatever_the_guess() {
        let set = ExemplarSet::new(vec![noise_texture(48, 40, 3, 7)], 8).unwrap();
        let e = &set.exemplars[0];
        let w = 8;
        let (cw, ch) = e.candidates(w);
        let prep = Prepared::new(&set, w);
        let rng = Philox::new(3, 1);
        let mut batch = Vec::new();
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
                guesses: vec![r[2] % (cw * ch) as u32, r[3] % (cw * ch) as u32],
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
                    let s = Search {
                        w,
                        tol,
                        penalty,
                        prepared: None,
                        coherence: None,
                    };
                    let want = best_match_brute(&set, &s, &q);
                    assert_eq!(best_match_pruned(&set, &prep, &s, &q), want);
                    // One query on a pool of three threads: its rows are split among them.
                    let pool = rayon::ThreadPoolBuilder::new()
                        .num_threads(3)
                        .build()
                        .unwrap();
                    let split = pool.install(|| {
                        CpuMatcher
                            .best_matches(&set, &s, std::slice::from_ref(&q))
                            .unwrap()
                    });
                    assert_eq!(split, vec![want]);
                    // The block sums made once for many searches give the same answer.
                    let shared = Search {
                        prepared: Some(&prep),
                        coherence: None,
                        ..s
                    };
                    let split = pool.install(|| {
                        CpuMatcher
                            .best_matches(&set, &shared, std::slice::from_ref(&q))
                            .unwrap()
                    });
                    assert_eq!(split, vec![want]);
                }
            }
            batch.push(q);
        }
        // Batches of several queries, on two threads.
        let s = Search {
            w,
            tol: Tolerance::from_fraction(0.1),
            penalty: None,
            prepared: None,
            coherence: None,
        };
        let want: Vec<Match> = batch
            .iter()
            .map(|q| best_match_brute(&set, &s, q))
            .collect();
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(2)
            .build()
            .unwrap();
        for n in [3, 7, 40] {
            let got = pool.install(|| CpuMatcher.best_matches(&set, &s, &batch[..n]).unwrap());
            assert_eq!(got, want[..n], "{n} queries");
        }
    }

    /// The CPU answer to one query of side 8, best match only.
    fn best_of(set: &ExemplarSet, q: Query) -> Vec<Match> {
        let s = Search {
            w: 8,
            tol: Tolerance(0),
            penalty: None,
            prepared: None,
            coherence: None,
        };
        CpuMatcher.best_matches(set, &s, &[q]).unwrap()
    }

    #[test]
    fn an_exact_window_is_found_at_distance_zero_and_ties_go_to_the_least_key() {
        // A constant exemplar: every window ties, so the least key over all 625 must win.
        let flat = Texture::new(32, 32, 1, vec![0.5; 1024]).unwrap();
        let set = ExemplarSet::new(vec![flat], 8).unwrap();
        let q = Query {
            exemplar: 0,
            codes: vec![3; 64],
            guesses: vec![77],
            salt: 12345,
            mask: None,
        };
        let m = best_of(&set, q);
        let want = (0..625u32).min_by_key(|&i| pick_key(12345, i)).unwrap();
        assert_eq!(m[0].index, want);

        let set = ExemplarSet::new(vec![noise_texture(40, 40, 2, 1)], 8).unwrap();
        let e = &set.exemplars[0];
        let q = Query {
            exemplar: 0,
            codes: window(e, 8, 13, 21),
            guesses: vec![0],
            salt: 9,
            mask: None,
        };
        let m = best_of(&set, q);
        assert_eq!(
            m[0],
            Match {
                cost: 0,
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
            let exact = d as u64 + ((d as u64 * t.0 as u64) >> 16);
            assert_eq!(t.limit(d) as u64, exact.min(u32::MAX as u64), "d = {d}");
        }
    }

    #[test]
    fn window_limit_guards_the_32_bit_sum() {
        assert!(window_fits(64, 7));
        assert!(!window_fits(64, 9));
    }
}

//! The patch pass of Shen et al. §3.1–3.2: white-noise initialisation, then N × N patches
//! every D = N/2 texels in scanline order, each replaced by its best match in the exemplar
//! over the overlap already synthesised.
//!
//! A deterministic best match drifts: continuing the previous patch walks the source towards an
//! exemplar edge, where the search keeps choosing the same few windows (a failure the
//! paper does not discuss). Two measures keep the exemplar in use as a whole: the choice among
//! near-best patches ([`crate::search::Tolerance`], image quilting's ε) and an occurrence
//! penalty after Kaspar et al. 2015 ("Self tuning texture optimization", §4.2): a candidate
//! whose window has been copied more than its share pays, per known texel,
//! λ · C · v̄ · max(0, O/(N² ō) − 1), where O is the number of output texels now drawn from its
//! N × N window, ō the mean number per exemplar texel, C the channels and v̄ the exemplars'
//! mean code variance (so λ = 1 charges one typical squared difference per unit of overuse).
//!
//! Patches run in anti-diagonal wavefronts, t = i + 2j (column i, row j): a patch overlaps
//! earlier ones only at (i−1, j), (i−1, j−1), (i, j−1) and (i+1, j−1), all of smaller t, so one
//! wavefront's searches are independent. They share the occurrence counts of the wavefronts
//! before, though, and patches in alike surroundings along a wavefront would pick the same
//! windows (bands along the wavefronts); so a patch whose match overlaps one accepted earlier
//! in its wavefront by more than half a patch each way is searched again with those windows
//! barred, which is what a scanline order with the penalty updated per patch would discourage
//! ([`crate::clash_rounds`]: the rounds, at a cost linear in the patches).
//! Where the output wraps (tileable) or the last patch is pulled in to the edge, the order is
//! simply wavefront by wavefront, and within one, scanline.

use crate::canvas::{origins, Canvas, NO_SOURCE};
use crate::clash_rounds::{ClashRounds, Window};
use crate::coherence::{Candidates, RANDOM_PATCH};
use crate::error::Result;
use crate::exemplar::ExemplarSet;
use crate::matcher::PatchPlan;
use crate::pass_context::PassContext;
use crate::search::{Prepared, Query, Search, Tolerance, MAX_GUESSES, MAX_PENALTY_TOTAL};
use derma_core::gpu::Device;
use derma_core::progress::Unit;
use derma_core::rng::Philox;

/// Philox stream of the initial noise (one stream per random decision, as every draw in derma).
const NOISE_STREAM: u32 = 0x5e_0001;
/// Philox stream of the salts of the near-best choice.
const PICK_STREAM: u32 = 0x5e_0002;

/// Fills the canvas with white Gaussian noise (§3.1), channel by channel with the mean and
/// standard deviation of the exemplars' codes, so the noise is in the exemplars' range.
pub(crate) fn initialise_noise(canvas: &mut Canvas, set: &ExemplarSet, seed: u64) {
    let c = canvas.channels;
    let stats = set.code_stats();
    let rng = Philox::new(seed, NOISE_STREAM);
    let q = &set.quantizer;
    for (i, code) in canvas.codes.iter_mut().enumerate() {
        let k = i % c;
        let (mu, var) = stats[k];
        let sigma = var.sqrt();
        let z = rng.normal2(i as u64, 0)[0] as f64;
        *code = (mu + sigma * z).round().clamp(0.0, 255.0) as u8;
        canvas.values[i] = q.dequantize(k, *code as f32);
    }
}

/// Which texels of the window at (px, py) are already synthesised: `None` when all are, and
/// also when none is — the first patch is matched against the noise over its whole window,
/// which makes it "completely random" (§3.2); every later one against its overlap alone.
fn known_mask(canvas: &Canvas, px: usize, py: usize, n: usize) -> Option<Vec<u8>> {
    let m: Vec<u8> = (0..n * n)
        .map(|t| u8::from(canvas.src[canvas.at(px, py, t % n, t / n)] != NO_SOURCE))
        .collect();
    let known = m.iter().filter(|&&k| k != 0).count();
    (known != 0 && known != n * n).then_some(m)
}

/// The patches of each wavefront t = i + 2j in scanline order: (x, y, index j·nx + i).
fn wavefronts(xs: &[usize], ys: &[usize]) -> Vec<Vec<(usize, usize, usize)>> {
    let (nx, ny) = (xs.len(), ys.len());
    (0..nx + 2 * ny - 2)
        .map(|t| {
            (0..ny)
                .filter_map(|j| {
                    t.checked_sub(2 * j)
                        .filter(|&i| i < nx)
                        .map(|i| (xs[i], ys[j], j * nx + i))
                })
                .collect()
        })
        .collect()
}

/// Whether two of the patches (x, y, ·) of side n share a texel of a `width × height` canvas
/// (wrapping on a torus).
fn overlapping(patches: &[(usize, usize, usize)], n: usize, width: usize, height: usize) -> bool {
    let near = |p: usize, q: usize, len: usize| {
        let d = (p + len - q) % len;
        d < n || len - d < n
    };
    patches.iter().enumerate().any(|(i, a)| {
        patches[i + 1..]
            .iter()
            .any(|b| near(a.0, b.0, width) && near(a.1, b.1, height))
    })
}

/// A wavefront's patches as the GPU's plan takes them: (x, y, salt).
fn salted(front: &[(usize, usize, usize)], rng: &Philox) -> Vec<[u32; 3]> {
    front
        .iter()
        .map(|&(x, y, k)| [x as u32, y as u32, rng.u32x4(k as u64)[0]])
        .collect()
}

/// Runs the patch pass with patches of side `n`.
pub(crate) fn patch_pass(
    canvas: &mut Canvas,
    ctx: &PassContext,
    n: usize,
    tol: Tolerance,
    occurrence: f64,
) -> Result<()> {
    let (set, guide, progress) = (ctx.set, ctx.guide, ctx.progress);
    let rng = Philox::new(ctx.seed, PICK_STREAM);
    let d = n / 2;
    let xs = origins(canvas.width, n, d, 0, canvas.tile);
    let ys = origins(canvas.height, n, d, 0, canvas.tile);
    let (nx, ny) = (xs.len(), ys.len());
    progress.stage("patch pass", (nx * ny) as u64, Unit::Windows);
    // Probes for the coherent guess: the known corners of a patch (top-left from the patch
    // above-left, left half from the previous patch, top half from the row above).
    let probes = [(0, 0), (0, d), (d, 0), (n - 1, 0)];
    let mut occ = Occurrence::new(set, n, occurrence);
    let fronts = wavefronts(&xs, &ys);
    let tables = ctx.coherence.map(|t| t.of(set, n));
    let candidates = tables.as_deref().map(|tables| Candidates {
        tables,
        random: RANDOM_PATCH,
    });
    // One exemplar on the GPU: the matcher may run the whole pass where it keeps the canvas.
    if set.exemplars.len() == 1 && ctx.matcher.device() == Device::Gpu {
        let plan = PatchPlan {
            n,
            tol,
            weight16: occ.weight16(),
            cap: penalty_cap(n),
            wavefronts: fronts.iter().map(|f| salted(f, &rng)).collect(),
            overlaps: fronts
                .iter()
                .map(|f| overlapping(f, n, canvas.width, canvas.height))
                .collect(),
            plane: canvas.plane(),
            sources: &canvas.src,
            coherence: candidates,
        };
        if let Some(sources) = ctx.matcher.patch_pass(set, &plan, progress)? {
            for (t, s) in sources.into_iter().enumerate() {
                if s != NO_SOURCE {
                    canvas.copy_texel(set, t, 0, s as usize);
                }
            }
            return Ok(());
        }
    }
    // The exemplars' block sums, once for every round's searches on the CPU.
    let prepared = (ctx.matcher.device() == Device::Cpu && ctx.coherence.is_none())
        .then(|| Prepared::new(set, n));
    for patches in fronts {
        if patches.is_empty() {
            continue;
        }
        let queries: Vec<Query> = patches
            .iter()
            .map(|&(px, py, k)| {
                let ex = guide.map_or(0, |g| g.at(canvas, px + d, py + d));
                Query {
                    exemplar: ex as u32,
                    codes: canvas.plane().window(px, py, n),
                    mask: known_mask(canvas, px, py, n),
                    guesses: canvas.coherent_guess(set, ex, px, py, n, &probes),
                    salt: rng.u32x4(k as u64)[0],
                }
            })
            .collect();
        // Searches of one wavefront are independent, but they share the occurrence counts of
        // the wavefronts before: left alone, patches in similar surroundings along a
        // wavefront pick the same windows and the output shows bands along the wavefronts.
        // So, in scanline order, a patch whose match overlaps (by more than half a patch each
        // way) a window accepted earlier in its wavefront is searched again, with the accepted
        // windows' neighbourhoods barred and the counts updated (see [`crate::clash_rounds`]).
        let mut rounds = ClashRounds::new(patches.len());
        while let Some(live) = rounds.next_live() {
            let (penalty, barring) = occ.penalties_excluding(rounds.accepted(), d);
            let search = Search {
                w: n,
                tol,
                penalty,
                prepared: prepared.as_ref(),
                coherence: candidates,
            };
            // A candidate left free joins the guesses: where the coherent ones are barred, it
            // gives the search a first limit below the cap (the answer is the same).
            let batch: Vec<Query> = live
                .iter()
                .map(|&k| {
                    let mut q = queries[k].clone();
                    if let Some(f) = barring.free[q.exemplar as usize] {
                        if q.guesses.len() < MAX_GUESSES && !q.guesses.contains(&f) {
                            q.guesses.push(f);
                        }
                    }
                    q
                })
                .collect();
            let matches = ctx.matcher.best_matches(set, &search, &batch)?;
            for (&k, m) in live.iter().zip(&matches) {
                let ex = queries[k].exemplar;
                let cw = set.exemplars[ex as usize].width() + 1 - n;
                let (mx, my) = (m.index as usize % cw, m.index as usize / cw);
                if rounds.offer(k, (ex, mx, my), d, barring.from[ex as usize]) {
                    let (px, py, _) = patches[k];
                    occ.remove(canvas, px, py, n);
                    canvas.paste(set, ex as usize, m.index, px, py, n);
                    occ.add(canvas, px, py, n);
                }
            }
        }
        progress.advance(patches.len() as u64);
    }
    Ok(())
}

/// The most a candidate pays per known texel for windows of side `n`: the cost of a whole
/// window's penalty stays within [`MAX_PENALTY_TOTAL`].
fn penalty_cap(n: usize) -> u32 {
    MAX_PENALTY_TOTAL / (n * n) as u32
}

/// The penalty per known texel of a window from which `o` output texels are drawn, in an
/// exemplar of `texels` texels of which `total` output texels are drawn, for windows of side `n`:
/// λ·C·v̄ · max(0, O/(N² ō) − 1) of the module comment in integers, so the GPU gives the same
/// bits: the ratio O/(N² ō) = o · texels / (n² · total) floored in 16.16 fixed point, times the
/// weight `k16` (λ·C·v̄ in 16.16), floored, at most `cap`. Exact in u64 while o · texels < 2⁶⁴
/// and n² · total < 2⁴⁸ (o ≤ total: canvases up to 2³⁴ texels, exemplars up to 2²⁴).
pub(crate) fn penalty(o: u64, texels: u64, n: usize, total: u64, k16: u64, cap: u32) -> u32 {
    let (a, d) = (o * texels, (n * n) as u64 * total);
    // ⌊a · 2¹⁶ / d⌋ without forming a · 2¹⁶.
    let ratio = ((a / d) << 16) + (((a % d) << 16) / d);
    let excess = ratio.saturating_sub(1 << 16);
    let pen = excess.saturating_mul(k16) >> 32;
    pen.min(cap as u64) as u32
}

/// Which of a wavefront's accepted windows bar candidates in a round, per exemplar.
struct Barring {
    /// The first accepted window in force (those before it are dropped: see
    /// [`Occurrence::penalties_excluding`]).
    from: Vec<usize>,
    /// A candidate no window in force bars, where some are barred (a guess for the searches).
    free: Vec<Option<u32>>,
}

/// How often each exemplar texel is the source of an output texel, and the penalties that
/// follow (see the module comment).
struct Occurrence {
    lambda: f64,
    n: usize,
    /// C · v̄: channels times the mean code variance per value.
    scale: f64,
    sizes: Vec<(usize, usize)>,
    count: Vec<Vec<u32>>,
    total: Vec<u64>,
    /// The penalties last made, per exemplar, per candidate (kept to be refilled each round).
    table: Vec<Vec<u32>>,
    /// Per exemplar, per candidate: 1 + the index of the last window taken that bars it, 0
    /// where none does (refilled each round).
    barred: Vec<Vec<u32>>,
    /// Room for one exemplar's summed-area table of counts.
    sat: Vec<u64>,
}

impl Occurrence {
    fn new(set: &ExemplarSet, n: usize, lambda: f64) -> Self {
        let var: f64 = set.code_stats().iter().map(|s| s.1).sum();
        let per_candidate = || -> Vec<Vec<u32>> {
            let size = |(cw, ch): (usize, usize)| cw * ch;
            (set.exemplars.iter())
                .map(|e| vec![0; size(e.candidates(n))])
                .collect()
        };
        Self {
            lambda,
            n,
            scale: var,
            sizes: set
                .exemplars
                .iter()
                .map(|e| (e.width(), e.height()))
                .collect(),
            count: set
                .exemplars
                .iter()
                .map(|e| vec![0; e.width() * e.height()])
                .collect(),
            total: vec![0; set.exemplars.len()],
            table: per_candidate(),
            barred: per_candidate(),
            sat: Vec::new(),
        }
    }

    fn remove(&mut self, canvas: &Canvas, px: usize, py: usize, n: usize) {
        for dy in 0..n {
            for dx in 0..n {
                let t = canvas.at(px, py, dx, dy);
                if canvas.src[t] != NO_SOURCE {
                    let ex = canvas.src_exemplar[t] as usize;
                    self.count[ex][canvas.src[t] as usize] -= 1;
                    self.total[ex] -= 1;
                }
            }
        }
    }

    fn add(&mut self, canvas: &Canvas, px: usize, py: usize, n: usize) {
        for dy in 0..n {
            for dx in 0..n {
                let t = canvas.at(px, py, dx, dy);
                let ex = canvas.src_exemplar[t] as usize;
                self.count[ex][canvas.src[t] as usize] += 1;
                self.total[ex] += 1;
            }
        }
    }

    /// The penalties per known texel of every candidate ([`Self::fill_penalties`]) with the
    /// windows of `taken` barred (`None` when there is nothing to charge), and per exemplar the
    /// first of `taken` still in force. A candidate within `d` texels (each way) of a window in
    /// force pays the cap. All are in force while the exemplar has a candidate none of them
    /// bars; past that, the oldest are dropped until one is free again: a small exemplar has
    /// room for only so many windows apart, and a wavefront's patches long accepted lie far
    /// along it. (Every candidate at the cap would leave the search nothing to prune and make
    /// its near-best choice a random one.)
    fn penalties_excluding(
        &mut self,
        taken: &[Window],
        d: usize,
    ) -> (Option<&[Vec<u32>]>, Barring) {
        let n = self.n;
        self.barred.iter_mut().for_each(|b| b.fill(0));
        for (a, &(ex, ax, ay)) in taken.iter().enumerate() {
            let (w, h) = self.sizes[ex as usize];
            let (cw, ch) = (w + 1 - n, h + 1 - n);
            for y in ay.saturating_sub(d - 1)..(ay + d).min(ch) {
                self.barred[ex as usize]
                    [y * cw + ax.saturating_sub(d - 1)..y * cw + (ax + d).min(cw)]
                    .fill(a as u32 + 1);
            }
        }
        // The first window in force: one past the oldest last-barring window of any candidate.
        let from: Vec<usize> = self
            .barred
            .iter()
            .map(|b| b.iter().copied().min().unwrap_or(0) as usize)
            .collect();
        let charged = |e: usize| self.barred[e].iter().any(|&l| l as usize > from[e]);
        let charged: Vec<bool> = (0..self.barred.len()).map(charged).collect();
        // The first candidate not barred (as patch_pass.wgsl's `bar` finds it): a guess, so
        // in the k-coherence search also a candidate with its similar positions.
        let free = (self.barred.iter().zip(&from))
            .map(|(b, &f)| b.iter().position(|&l| l as usize <= f).map(|i| i as u32))
            .collect();
        let barring = Barring { from, free };
        if self.lambda <= 0.0 && !charged.contains(&true) {
            return (None, barring);
        }
        self.fill_penalties();
        let cap = penalty_cap(n);
        for (e, table) in self
            .table
            .iter_mut()
            .enumerate()
            .filter(|&(e, _)| charged[e])
        {
            let from = barring.from[e];
            for (pen, _) in
                (table.iter_mut().zip(&self.barred[e])).filter(|(_, &l)| l as usize > from)
            {
                *pen = cap;
            }
        }
        (Some(&self.table), barring)
    }

    /// λ · C · v̄ in 16.16 fixed point, at most 2³² (the factor of [`penalty`]; 0 when λ = 0).
    fn weight16(&self) -> u64 {
        (self.lambda * self.scale * 65536.0)
            .round()
            .min(4_294_967_296.0) as u64
    }

    /// Per exemplar, per candidate, into `table`: the penalty per known texel (0 when λ = 0).
    fn fill_penalties(&mut self) {
        let n = self.n;
        let cap = penalty_cap(n);
        let k16 = self.weight16();
        for (e, &(w, h)) in self.sizes.iter().enumerate() {
            let (cw, ch) = (w + 1 - n, h + 1 - n);
            let (count, total, out) = (&self.count[e], self.total[e], &mut self.table[e]);
            if total == 0 || k16 == 0 {
                out.fill(0);
                continue;
            }
            // Summed-area table of the counts.
            let sat = &mut self.sat;
            sat.clear();
            sat.resize((w + 1) * (h + 1), 0);
            for y in 0..h {
                let mut row = 0u64;
                for x in 0..w {
                    row += count[y * w + x] as u64;
                    sat[(y + 1) * (w + 1) + x + 1] = sat[y * (w + 1) + x + 1] + row;
                }
            }
            for y in 0..ch {
                for x in 0..cw {
                    let o = sat[(y + n) * (w + 1) + x + n] + sat[y * (w + 1) + x]
                        - sat[y * (w + 1) + x + n]
                        - sat[(y + n) * (w + 1) + x];
                    out[y * cw + x] = penalty(o, (w * h) as u64, n, total, k16, cap);
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_integer_penalty_follows_the_formula() {
        // λ·C·v̄ · max(0, o/E − 1) with E = n²·total/texels, to within the fixed point's
        // rounding (one unit), zero up to the mean use and capped.
        let (texels, n) = (128 * 128u64, 32usize);
        for (scale, total) in [(3100.0f64, 40_000u64), (55.5, 9_000_000), (0.7, 1024)] {
            let k16 = (scale * 65536.0).round() as u64;
            let e = (n * n) as f64 * total as f64 / texels as f64;
            for o in [0u64, 1, e as u64, (e * 1.5) as u64, (e * 7.0) as u64, total] {
                let want = (scale * (o as f64 / e - 1.0).max(0.0)).floor();
                let got = penalty(o, texels, n, total, k16, u32::MAX) as f64;
                assert!(
                    (got - want.min(u32::MAX as f64)).abs() <= 1.0 + want * 1e-4,
                    "o {o}, total {total}: {got} vs {want}"
                );
            }
        }
        assert_eq!(penalty(10_000, texels, n, 1024, 1 << 40, 77), 77);
        assert_eq!(penalty(0, texels, n, 1024, 1 << 20, 77), 0);
    }

    #[test]
    fn windows_in_force_are_barred_and_the_oldest_drop_out_when_none_is_left() {
        // A 24² exemplar, 8² windows: 17² candidates; d = 4 bars 7² around each window taken.
        let tex = crate::search::tests::noise_texture(24, 24, 1, 3);
        let set = ExemplarSet::new(vec![tex], 8).unwrap();
        let (n, d, cw) = (8, 4, 17);
        let cap = penalty_cap(n);
        // Where candidate i lies: the block of the 3 × 3 grid of windows below that bars it.
        let block = |i: usize| {
            let at = |v: usize| [0..5, 5..12, 12..17].iter().position(|r| r.contains(&v));
            at(i / cw).unwrap() * 3 + at(i % cw).unwrap()
        };
        for lambda in [0.0, 1.0] {
            let mut occ = Occurrence::new(&set, n, lambda);
            let (p, b) = occ.penalties_excluding(&[], d);
            assert_eq!(
                (p.is_some(), b.from, b.free),
                (lambda > 0.0, vec![0], vec![Some(0)])
            );
            // One window at (8, 8): its 7² neighbours pay the cap, the rest nothing; the first
            // free candidate in scan order is a guess.
            let (p, b) = occ.penalties_excluding(&[(0, 8, 8)], d);
            assert_eq!((b.from.clone(), b.free.clone()), (vec![0], vec![Some(0)]));
            for (i, &v) in p.unwrap()[0].iter().enumerate() {
                let near = (i % cw).abs_diff(8) < d && (i / cw).abs_diff(8) < d;
                assert_eq!(v, if near { cap } else { 0 }, "candidate {i}");
            }
            // Nine windows 7 apart bar all 17² candidates, each candidate by one (block i by
            // window i): the first goes out of force, and its block comes free.
            let all: Vec<Window> = (0..3)
                .flat_map(|y| (0..3).map(move |x| (0, 1 + 7 * x, 1 + 7 * y)))
                .collect();
            let (p, b) = occ.penalties_excluding(&all, d);
            assert_eq!((b.from, b.free), (vec![1], vec![Some(0)]));
            for (i, &v) in p.unwrap()[0].iter().enumerate() {
                assert_eq!(v == cap, block(i) != 0, "candidate {i}, λ {lambda}");
            }
            // Window 0 again, last: now block 1 is the oldest, and comes free.
            let mut again = all.clone();
            again.push(all[0]);
            let (p, b) = occ.penalties_excluding(&again, d);
            assert_eq!(b.from, vec![2]);
            for (i, &v) in p.unwrap()[0].iter().enumerate() {
                assert_eq!(v == cap, block(i) != 1, "candidate {i}, λ {lambda}");
            }
            // The table is refilled each round: nothing taken, nothing barred.
            let (p, _) = occ.penalties_excluding(&[], d);
            assert!(p.is_none_or(|p| !p[0].contains(&cap)), "λ {lambda}");
        }
        // Fifty output texels drawn from exemplar texel (10, 10): the candidates whose window
        // holds it pay the formula's penalty for o = 50, the others none.
        let mut occ = Occurrence::new(&set, n, 1.0);
        occ.count[0][10 * 24 + 10] = 50;
        occ.total[0] = 50;
        let want = penalty(50, 24 * 24, n, 50, occ.weight16(), cap);
        assert!(want > 0);
        let (p, _) = occ.penalties_excluding(&[], d);
        let p = p.unwrap();
        for (i, &v) in p[0].iter().enumerate() {
            let holds = (3..=10).contains(&(i % cw)) && (3..=10).contains(&(i / cw));
            assert_eq!(v, if holds { want } else { 0 }, "candidate {i}");
        }
    }
}

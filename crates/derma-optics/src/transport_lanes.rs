//! Photons in SIMD lanes: [`crate::transport`]'s weighted walk (MCML's, Wang, Jacques & Zheng
//! 1995) for layered slabs under a normal pencil beam with smooth boundaries — what `derma optics
//! slab` and the validations run — eight photons at a time in f32 lanes
//! ([`derma_core::numerics::lanes`]: AVX2 where the CPU has it, the same operations on plain
//! f32s elsewhere, so the bits do not depend on the CPU).
//!
//! Each lane walks one photon; when it leaves or dies, its totals are booked and the lane takes
//! the next photon of the batch. Photon k draws its own Philox stream exactly as the scalar walk
//! and the GPU kernel do (photon index, stream, block), in the same order and for the same
//! decisions (step length, Fresnel test, Henyey–Greenstein cosine, azimuth, roulette), so the
//! three follow the same paths up to rounding. Directions and depths are f32 (x and y are not
//! tracked: totals need only depth); the weight is f32 but its bookkeeping is exact: each
//! absorption is booked as the f64 difference of the weights before and after it, roulette as
//! the difference it makes, and the specular reflection as 1 − the launched f32 weight, so
//! R + T + A balances the launched weight to f64 rounding as in the scalar walk.

use crate::fresnel::fresnel_unpolarised;
use crate::layer::{Bottom, Surface, N_ABSORBERS};
use crate::photon_rng::OPTICS_STREAM;
use crate::run::Run;
use crate::tally::{Tally, ABSORBED, R_DIFFUSE, R_SPECULAR, TRANSMITTED};
use crate::transport::{Incidence, Prepared, MAX_STEPS, ROULETTE_CHANCE, ROULETTE_WEIGHT};
use derma_core::numerics::lanes::philox4x32_10_lanes;
use derma_core::numerics::lanes::{IntLanes, Lanes, PortableF32};

/// Photons walked together.
pub const LANES: usize = 8;
/// Most layers the lane walk takes (their parameters are chosen per lane by selects).
pub use crate::MAX_LAYERS;

/// Whether `run` is one the lanes walk: one stack, smooth top, a clear medium below, a normal
/// pencil beam, totals only (no BRDF or profile), at most [`MAX_LAYERS`] layers.
pub fn eligible(run: &Run) -> bool {
    run.stacks.len() == 1
        && run.incidence == Incidence::Normal
        && run.brdf.is_none()
        && run.profile.is_none()
        && run.stacks[0].surface == Surface::Smooth
        && matches!(run.stacks[0].bottom, Bottom::Medium { .. })
        && run.stacks[0].layers.len() <= MAX_LAYERS
}

/// The slab's constants in f32, per layer (padded to [`MAX_LAYERS`]), in the forms the walk
/// uses.
struct Slab {
    layers: usize,
    /// Weight entering the first layer (1 − specular reflectance), f32.
    w0: f32,
    share: Vec<[f64; N_ABSORBERS]>,
    mut_: [f32; MAX_LAYERS],
    inv_mut: [f32; MAX_LAYERS],
    albedo_c: [f32; MAX_LAYERS],
    g: [f32; MAX_LAYERS],
    /// (1 − g²) and 1/(2g) of Henyey–Greenstein's inversion.
    hg_a: [f32; MAX_LAYERS],
    hg_b: [f32; MAX_LAYERS],
    /// Depths of the layer's top and bottom boundaries, mm.
    z_top: [f32; MAX_LAYERS],
    z_bot: [f32; MAX_LAYERS],
    /// Indices of the layer and of the media above and below it, and η = n/n' for both ways.
    n_here: [f32; MAX_LAYERS],
    n_up: [f32; MAX_LAYERS],
    n_down: [f32; MAX_LAYERS],
    eta_up: [f32; MAX_LAYERS],
    eta_down: [f32; MAX_LAYERS],
}

impl Slab {
    fn new(p: &Prepared) -> Self {
        let nl = p.mut_.len();
        // Boundary depths (layers + 1) and indices: `n[k + 1]` is layer k's, `n[0]` the medium
        // above, `n[layers + 1]` the one below.
        let mut z = [0.0f32; MAX_LAYERS + 1];
        let mut n = [1.0f32; MAX_LAYERS + 2];
        for k in 0..=nl {
            z[k] = p.z[k] as f32;
        }
        for k in 0..nl {
            n[k + 1] = p.n[k] as f32;
        }
        n[0] = p.n_above as f32;
        n[nl + 1] = match p.bottom {
            Bottom::Medium { n } => n as f32,
            Bottom::Lambertian { .. } => unreachable!("eligible() admits clear bottoms only"),
        };
        let per_layer = |f: &dyn Fn(usize) -> f32| -> [f32; MAX_LAYERS] {
            std::array::from_fn(|k| if k < nl { f(k) } else { 0.0 })
        };
        let g = per_layer(&|k| p.g[k] as f32);
        let below = |k: usize| n[(k + 2).min(MAX_LAYERS + 1)];
        Slab {
            layers: nl,
            // Normal incidence on a smooth top: the specular part is split off.
            w0: (1.0 - fresnel_unpolarised(1.0, p.n_above, p.n[0])) as f32,
            share: p.share.clone(),
            mut_: per_layer(&|k| p.mut_[k] as f32),
            inv_mut: per_layer(&|k| p.inv_mut[k] as f32),
            albedo_c: per_layer(&|k| p.mua_over_mut[k] as f32),
            g,
            hg_a: std::array::from_fn(|k| 1.0 - g[k] * g[k]),
            hg_b: std::array::from_fn(|k| if g[k] != 0.0 { 1.0 / (2.0 * g[k]) } else { 0.0 }),
            z_top: std::array::from_fn(|k| z[k]),
            z_bot: std::array::from_fn(|k| z[k + 1]),
            n_here: std::array::from_fn(|k| n[k + 1]),
            n_up: std::array::from_fn(|k| n[k]),
            n_down: std::array::from_fn(below),
            eta_up: std::array::from_fn(|k| n[k + 1] / n[k]),
            eta_down: std::array::from_fn(|k| n[k + 1] / below(k)),
        }
    }
}

/// Tallies photons `range` of `run` (eligible, see [`eligible`]) in lanes: AVX2 where the CPU
/// has it, plain f32s otherwise, with the same result.
pub fn trace_range_lanes(run: &Run, prepared: &Prepared, range: std::ops::Range<u64>) -> Tally {
    trace_range_on(run, prepared, range, true)
}

/// [`trace_range_lanes`], on AVX2 only where `simd` allows it (the portable lanes otherwise:
/// the tests compare the two).
pub fn trace_range_on(
    run: &Run,
    prepared: &Prepared,
    range: std::ops::Range<u64>,
    simd: bool,
) -> Tally {
    let slab = Slab::new(prepared);
    #[cfg(target_arch = "x86_64")]
    if simd {
        if let Some(t) = derma_core::numerics::lanes::Avx2::detect() {
            // SAFETY: the token proves the CPU has AVX2 and FMA.
            return unsafe { walk_avx2(t, run, &slab, range) };
        }
    }
    walk_slab::<PortableF32>((), run, &slab, range)
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,fma")]
unsafe fn walk_avx2(
    t: derma_core::numerics::lanes::Avx2,
    run: &Run,
    slab: &Slab,
    range: std::ops::Range<u64>,
) -> Tally {
    walk_slab::<derma_core::numerics::lanes::Avx2F32>(t, run, slab, range)
}

/// [`walk`] with its layer count fixed at compile time where the slab has a single layer.
#[inline(always)]
fn walk_slab<L: Lanes>(t: L::Token, run: &Run, slab: &Slab, range: std::ops::Range<u64>) -> Tally {
    if slab.layers == 1 {
        walk::<L, true>(t, run, slab, range)
    } else {
        walk::<L, false>(t, run, slab, range)
    }
}

/// Per-photon sums of one lane, in f64. Absorption is booked per stay in a layer: the weight
/// on entering it (or since the last roulette) less the weight on leaving it, which is the sum
/// of the stay's absorptions exactly (each is a difference of f32 weights, exact in f64, and
/// they telescope), without per-interaction work.
#[derive(Clone, Copy, Default)]
struct Book {
    r_diffuse: f64,
    transmitted: f64,
    absorbed: [f64; MAX_LAYERS],
    roulette: f64,
    /// Weight when the current stay began.
    w_entry: f32,
}

/// Chooses each lane's value of `table` by its layer index.
#[inline(always)]
fn pick<L: Lanes>(layer: L::I, table: &[f32], n: usize) -> L {
    let t = layer.to_f32_bits().token();
    let mut v = L::splat(t, table[0]);
    for (k, &x) in table.iter().enumerate().take(n).skip(1) {
        v = layer.eq(L::I::splat(t, k as i32)).select(L::splat(t, x), v);
    }
    v
}

/// Unpolarised Fresnel reflectance at incidence cosine `cos_i` from index `n1` into `n2`, η =
/// n1/n2 (lanes; [`fresnel_unpolarised`]'s formula): ½(r_s² + r_p²), 1 beyond the critical
/// angle. Also returns cos θt.
#[inline(always)]
fn fresnel<L: Lanes>(cos_i: L, n1: L, n2: L, eta: L) -> (L, L) {
    let one = cos_i.splat_as(1.0);
    let zero = cos_i.splat_as(0.0);
    let c = cos_i.clamp(0.0, 1.0);
    let sin_t = eta.mul(one.sub(c.mul(c)).max(zero).sqrt());
    let total = sin_t.ge(one);
    let cos_t = one.sub(sin_t.mul(sin_t)).max(zero).sqrt();
    let (a, b) = (n1.mul(c), n2.mul(cos_t));
    let rs = a.sub(b).div(a.add(b));
    let (a, b) = (n1.mul(cos_t), n2.mul(c));
    let rp = a.sub(b).div(a.add(b));
    let f = cos_i.splat_as(0.5).mul(rs.mul(rs).add(rp.mul(rp)));
    (total.select(one, f), cos_t)
}

/// The lanes' random streams: two blocks of four words per lane and the next word's place.
struct Streams<L: Lanes> {
    words: [L::I; 8],
    pos: L::I,
    ctr: [L::I; 4],
    key: [u32; 2],
}

impl<L: Lanes> Streams<L> {
    /// Makes sure every lane has at least four unread words (a block moves down and the next
    /// is drawn where fewer remain).
    #[inline(always)]
    fn refill(&mut self, t: L::Token) {
        for _ in 0..2 {
            let need = self.pos.to_f32().ge(L::splat(t, 4.0));
            if need.mask_bits() == 0 {
                return;
            }
            let fresh = philox4x32_10_lanes(self.ctr, self.key);
            for k in 0..4 {
                let (lo, hi) = (self.words[k].to_f32_bits(), self.words[k + 4].to_f32_bits());
                self.words[k] = need.select(hi, lo).to_bits();
                self.words[k + 4] = need.select(fresh[k].to_f32_bits(), hi).to_bits();
            }
            let four = L::I::splat(t, 4);
            self.pos = need
                .select(self.pos.sub(four).to_f32_bits(), self.pos.to_f32_bits())
                .to_bits();
            let one = L::I::splat(t, 1);
            self.ctr[3] = need
                .select(
                    self.ctr[3].add(one).to_f32_bits(),
                    self.ctr[3].to_f32_bits(),
                )
                .to_bits();
        }
    }

    /// The next uniform draw in [0, 1) (24 bits, as [`crate::photon_rng::PhotonRng::uniform`])
    /// of the lanes in `mask`; other lanes' streams do not advance. `last` bounds the lanes'
    /// place in their words: the k-th draw of a step after [`Self::refill`] is at most k + 2.
    #[inline(always)]
    fn uniform(&mut self, t: L::Token, mask: L, last: usize) -> L {
        let mut w = self.words[0].to_f32_bits();
        for k in 1..=last.min(7) {
            w = self
                .pos
                .eq(L::I::splat(t, k as i32))
                .select(self.words[k].to_f32_bits(), w);
        }
        let one = L::I::splat(t, 1);
        self.pos = mask
            .select(self.pos.add(one).to_f32_bits(), self.pos.to_f32_bits())
            .to_bits();
        w.to_bits()
            .shr::<8>()
            .to_f32()
            .mul(L::splat(t, 1.0 / 16_777_216.0))
    }
}

/// The lanes' photons: direction, depth, optical path left to the next interaction, weight,
/// layer and steps taken; the lanes' random streams and the next photon to launch. (Their
/// sums, [`Book`]s, are kept apart: `book` borrows them, which would keep this in memory.)
struct Photons<L: Lanes> {
    alive: L,
    ux: L,
    uy: L,
    uz: L,
    z: L,
    s_left: L,
    w: L,
    layer: L::I,
    steps: L,
    rng: Streams<L>,
    next: u64,
}

/// Where one step takes each lane: its layer's μt, its direction's sense, the boundary ahead,
/// and whether the step reaches that boundary (`hit`) or ends inside the layer (`inside`).
struct Reach<L: Lanes> {
    mu_t: L,
    up: L,
    down: L,
    z_b: L,
    abs_uz: L,
    hit: L,
    inside: L,
}

/// What one step did, for the booking: lanes escaping through the top or the bottom, crossing
/// into the next layer, winning or losing the roulette; the weights before the step and after
/// its absorption (before any roulette); and the lanes with something to book.
struct Events<L: Lanes> {
    escapes_top: L,
    escapes_bottom: L,
    crosses: L,
    survives: L,
    killed: L,
    w_before: L,
    w_absorbed: L,
    bits: u32,
}

/// Lanes whose bit is set in `bits` (all ones), the others zero.
#[inline(always)]
fn lane_mask<L: Lanes>(t: L::Token, bits: u32) -> L {
    L::from_array(
        t,
        std::array::from_fn(|l| f32::from_bits(if bits >> l & 1 == 1 { u32::MAX } else { 0 })),
    )
}

/// The walk, generic over the lanes; `ONE` is a single layer (every [`pick`] is then one
/// constant, held out of the loop).
#[inline(always)]
fn walk<L: Lanes, const ONE: bool>(
    t: L::Token,
    run: &Run,
    slab: &Slab,
    range: std::ops::Range<u64>,
) -> Tally {
    let mut tally = run.empty_tally();
    let nl = if ONE { 1 } else { slab.layers };
    let mut books = [Book::default(); LANES];
    let mut p = Photons::<L>::new(t, run.seed, range.start);
    loop {
        p.launch(t, slab, &mut books, range.end);
        if p.alive.mask_bits() == 0 {
            break;
        }
        p.rng.refill(t);
        p.draw_step_length(t);
        let reach = p.reach(t, slab, nl);
        let mut events = Events::new(t, p.w);
        // Boundary: hop to it, then reflect or cross (only when a lane got there).
        if reach.hit.mask_bits() != 0 {
            p.cross_boundary(t, slab, nl, &reach, &mut events);
        }
        // Interaction: hop inside the layer, absorb, scatter, roulette.
        if reach.inside.mask_bits() != 0 {
            p.interact(t, slab, nl, reach.inside, &mut events);
        }
        events.bits |= p.count_step(t);
        let done = p.book_events(&mut books, &events);
        p.change_layer(t, reach.up, events.crosses);
        p.retire(t, &mut tally, slab, &books, done);
    }
    tally
}

impl<L: Lanes> Events<L> {
    /// Nothing happened yet, at weight `w`.
    #[inline(always)]
    fn new(t: L::Token, w: L) -> Self {
        let zero = L::splat(t, 0.0);
        Self {
            escapes_top: zero,
            escapes_bottom: zero,
            crosses: zero,
            survives: zero,
            killed: zero,
            w_before: w,
            w_absorbed: w,
            bits: 0,
        }
    }
}

impl<L: Lanes> Photons<L> {
    /// Empty lanes, with the streams keyed by `seed`; the first photon is `first`.
    #[inline(always)]
    fn new(t: L::Token, seed: u64, first: u64) -> Self {
        let isplat = |v: i32| L::I::splat(t, v);
        let (zero, one) = (L::splat(t, 0.0), L::splat(t, 1.0));
        Self {
            alive: zero,
            ux: zero,
            uy: zero,
            uz: one,
            z: zero,
            s_left: zero,
            w: zero,
            layer: isplat(0),
            steps: zero,
            rng: Streams::<L> {
                words: [isplat(0); 8],
                pos: isplat(8),
                ctr: [
                    isplat(0),
                    isplat(0),
                    isplat(OPTICS_STREAM as i32),
                    isplat(0),
                ],
                key: [seed as u32, (seed >> 32) as u32],
            },
            next: first,
        }
    }

    /// Launches photons into empty lanes, in lane order, while any below `end` remain; their
    /// `books` start afresh.
    #[inline(always)]
    fn launch(&mut self, t: L::Token, slab: &Slab, books: &mut [Book; LANES], end: u64) {
        let empty = !self.alive.mask_bits() & 0xff;
        if empty == 0 || self.next >= end {
            return;
        }
        let (zero, one) = (L::splat(t, 0.0), L::splat(t, 1.0));
        let rng = &mut self.rng;
        let mut launched = 0u32;
        let (mut lo, mut hi) = (rng.ctr[0].to_array(), rng.ctr[1].to_array());
        let mut blk = rng.ctr[3].to_array();
        let mut pos = rng.pos.to_array();
        for l in 0..LANES {
            if empty >> l & 1 == 1 && self.next < end {
                books[l] = Book {
                    w_entry: slab.w0,
                    ..Book::default()
                };
                let next = self.next;
                (lo[l], hi[l]) = (next as u32 as i32, (next >> 32) as u32 as i32);
                (blk[l], pos[l]) = (0, 8);
                launched |= 1 << l;
                self.next += 1;
            }
        }
        rng.ctr[0] = L::I::from_array(t, lo);
        rng.ctr[1] = L::I::from_array(t, hi);
        rng.ctr[3] = L::I::from_array(t, blk);
        rng.pos = L::I::from_array(t, pos);
        let m = lane_mask::<L>(t, launched);
        self.ux = m.select(zero, self.ux);
        self.uy = m.select(zero, self.uy);
        self.uz = m.select(one, self.uz);
        self.z = m.select(zero, self.z);
        self.s_left = m.select(zero, self.s_left);
        self.w = m.select(L::splat(t, slab.w0), self.w);
        self.layer = m.select(zero, self.layer.to_f32_bits()).to_bits();
        self.steps = m.select(zero, self.steps);
        self.alive = self.alive.or(m);
    }

    /// Draws a step length (in optical depths) where the last one was used up.
    #[inline(always)]
    fn draw_step_length(&mut self, t: L::Token) {
        let (zero, one) = (L::splat(t, 0.0), L::splat(t, 1.0));
        let fresh = self.alive.and(self.s_left.le(zero));
        let xi = self.rng.uniform(t, fresh, 3);
        self.s_left = fresh.select(zero.sub(one.sub(xi).ln()), self.s_left);
    }

    /// Whether the step reaches the boundary ahead (never when moving parallel to it).
    #[inline(always)]
    fn reach(&self, t: L::Token, slab: &Slab, nl: usize) -> Reach<L> {
        let zero = L::splat(t, 0.0);
        let (layer, uz, z) = (self.layer, self.uz, self.z);
        let mu_t = pick::<L>(layer, &slab.mut_, nl);
        let down = uz.gt(zero);
        let up = uz.lt(zero);
        let z_b = up.select(
            pick::<L>(layer, &slab.z_top, nl),
            pick::<L>(layer, &slab.z_bot, nl),
        );
        // μt·(z_b − z)/u_z ≤ s compared without the division (both sides times |u_z|; the
        // gap is signed: a depth rounded past the boundary counts as reached); the distance
        // itself is needed only where a lane reaches the boundary.
        let abs_uz = zero.sub(uz).max(uz);
        let gap = up.select(z.sub(z_b), z_b.sub(z));
        let hit = self
            .alive
            .and(up.or(down))
            .and(mu_t.mul(gap).le(self.s_left.mul(abs_uz)));
        // (`a.and_not(b)` is b and not a.)
        let inside = hit.and_not(self.alive);
        Reach {
            mu_t,
            up,
            down,
            z_b,
            abs_uz,
            hit,
            inside,
        }
    }

    /// Moves the lanes that reach a boundary onto it, then reflects them or lets them cross
    /// (Fresnel), into the next layer or out of the slab; `ev` gets the escapes and crossings.
    #[inline(always)]
    fn cross_boundary(
        &mut self,
        t: L::Token,
        slab: &Slab,
        nl: usize,
        r: &Reach<L>,
        ev: &mut Events<L>,
    ) {
        let (zero, one) = (L::splat(t, 0.0), L::splat(t, 1.0));
        let isplat = |v: i32| L::I::splat(t, v);
        let (layer, up, down, hit) = (self.layer, r.up, r.down, r.hit);
        let is_top = up.and(layer.eq(isplat(0)));
        let is_bottom = down.and(layer.eq(isplat(nl as i32 - 1)));
        let n1 = pick::<L>(layer, &slab.n_here, nl);
        let n2 = up.select(
            pick::<L>(layer, &slab.n_up, nl),
            pick::<L>(layer, &slab.n_down, nl),
        );
        let eta = up.select(
            pick::<L>(layer, &slab.eta_up, nl),
            pick::<L>(layer, &slab.eta_down, nl),
        );
        let outer = is_top.or(is_bottom);
        // Internal boundaries between equal indices are crossed without a Fresnel draw.
        let crosses_free = outer.and_not(hit).and(n1.eq(n2));
        let tested = crosses_free.and_not(hit);
        let xi_f = self.rng.uniform(t, tested, 4);
        // The hop to the boundary, along the incident direction.
        let dist = r.z_b.sub(self.z).div(self.uz);
        let cos_i = r.abs_uz;
        let (f, cos_t) = fresnel(cos_i, n1, n2, eta);
        let reflect = tested.and(xi_f.lt(f));
        let refract = reflect.and_not(tested);
        // Refracted: u' = η u + (η cosθi − cosθt) m, m = (0, 0, ±1) facing the incident
        // side; through the top, normalised as the scalar walk does.
        let (ux, uy, uz) = (self.ux, self.uy, self.uz);
        let k = eta.mul(cos_i).sub(cos_t);
        let side = up.select(one, zero.sub(one));
        let (rx, ry, rz) = (eta.mul(ux), eta.mul(uy), eta.mul(uz).add(k.mul(side)));
        let inv_len = one.div(rx.mul(rx).add(ry.mul(ry)).add(rz.mul(rz)).sqrt());
        let rx = is_top.select(rx.mul(inv_len), rx);
        let ry = is_top.select(ry.mul(inv_len), ry);
        let rz = is_top.select(rz.mul(inv_len), rz);
        ev.escapes_top = refract.and(is_top);
        ev.escapes_bottom = refract.and(is_bottom);
        ev.crosses = outer.and_not(refract).or(crosses_free);
        ev.bits |= ev
            .escapes_top
            .or(ev.escapes_bottom)
            .or(ev.crosses)
            .mask_bits();
        self.ux = refract.select(rx, ux);
        self.uy = refract.select(ry, uy);
        self.uz = refract.select(rz, reflect.select(zero.sub(uz), uz));
        self.s_left = hit.select(self.s_left.sub(r.mu_t.mul(dist)), self.s_left);
        self.z = hit.select(r.z_b, self.z);
    }

    /// Moves the lanes `inside` their layer to the interaction, absorbs, scatters
    /// (Henyey–Greenstein) and plays the roulette below the threshold weight; `ev` gets the
    /// weights and the roulette's outcome.
    #[inline(always)]
    fn interact(&mut self, t: L::Token, slab: &Slab, nl: usize, inside: L, ev: &mut Events<L>) {
        let splat = |v: f32| L::splat(t, v);
        let (zero, one) = (splat(0.0), splat(1.0));
        let layer = self.layer;
        let d = self.s_left.mul(pick::<L>(layer, &slab.inv_mut, nl));
        self.z = inside.select(self.uz.mul_add(d, self.z), self.z);
        self.s_left = inside.select(zero, self.s_left);
        let w = self.w;
        let a = pick::<L>(layer, &slab.albedo_c, nl);
        let w_abs = w.sub(w.mul(a));
        let g = pick::<L>(layer, &slab.g, nl);
        let xi_g = self.rng.uniform(t, inside, 4);
        let xi_p = self.rng.uniform(t, inside, 5);
        // Henyey–Greenstein (MCML eq. 3.28); isotropic for |g| < 10⁻⁶.
        let tt = pick::<L>(layer, &slab.hg_a, nl).div(one.sub(g).add(splat(2.0).mul(g).mul(xi_g)));
        let ct_hg = one
            .add(g.mul(g))
            .sub(tt.mul(tt))
            .mul(pick::<L>(layer, &slab.hg_b, nl))
            .clamp(-1.0, 1.0);
        let iso = zero.sub(g).max(g).lt(splat(1e-6));
        let ct = iso.select(splat(2.0).mul(xi_g).sub(one), ct_hg);
        let (sp, cp) = xi_p.sincos_turns();
        // Spin (MCML eq. 3.30).
        let (ux, uy, uz) = (self.ux, self.uy, self.uz);
        let st = one.sub(ct.mul(ct)).max(zero).sqrt();
        let vertical = zero.sub(uz).max(uz).gt(splat(0.99999));
        let sign_z = uz.lt(zero).select(zero.sub(one), one);
        let temp = one.sub(uz.mul(uz)).sqrt();
        let q = st.div(temp);
        let uzcp = uz.mul(cp);
        let sx = q.mul_add(ux.mul_add(uzcp, zero.sub(uy.mul(sp))), ux.mul(ct));
        let sy = q.mul_add(uy.mul_add(uzcp, ux.mul(sp)), uy.mul(ct));
        let sz = uz.mul_add(ct, zero.sub(st.mul(cp).mul(temp)));
        self.ux = inside.select(vertical.select(st.mul(cp), sx), ux);
        self.uy = inside.select(vertical.select(st.mul(sp), sy), uy);
        self.uz = inside.select(vertical.select(ct.mul(sign_z), sz), uz);
        // Roulette below the threshold weight.
        let low = inside.and(w_abs.lt(splat(ROULETTE_WEIGHT as f32)));
        self.w = inside.select(w_abs, w);
        ev.w_absorbed = self.w;
        if low.mask_bits() != 0 {
            let xi_r = self.rng.uniform(t, low, 6);
            ev.survives = low.and(xi_r.lt(splat(ROULETTE_CHANCE as f32)));
            ev.killed = ev.survives.and_not(low);
            self.w = ev
                .survives
                .select(self.w.div(splat(ROULETTE_CHANCE as f32)), self.w);
            ev.bits |= low.mask_bits();
        }
    }

    /// Counts the step; the lanes trapped beyond [`MAX_STEPS`], which are abandoned (never in
    /// practice).
    #[inline(always)]
    fn count_step(&mut self, t: L::Token) -> u32 {
        self.steps = self
            .alive
            .select(self.steps.add(L::splat(t, 1.0)), self.steps);
        self.alive
            .and(self.steps.gt(L::splat(t, MAX_STEPS as f32)))
            .mask_bits()
    }

    /// Books the lanes' events into `books` in f64 (each ends the stay in the layer); the
    /// lanes whose photon ended.
    #[inline(always)]
    fn book_events(&self, books: &mut [Book; LANES], ev: &Events<L>) -> u32 {
        let mut done = 0u32;
        if ev.bits == 0 {
            return done;
        }
        let (wb, wm, wn) = (
            ev.w_before.to_array(),
            ev.w_absorbed.to_array(),
            self.w.to_array(),
        );
        let lay = self.layer.to_array();
        let (et, eb, cr) = (
            ev.escapes_top.mask_bits(),
            ev.escapes_bottom.mask_bits(),
            ev.crosses.mask_bits(),
        );
        let (sv, kl) = (ev.survives.mask_bits(), ev.killed.mask_bits());
        let mut bits = ev.bits;
        while bits != 0 {
            let l = bits.trailing_zeros() as usize;
            bits &= bits - 1;
            let b = &mut books[l];
            let here = lay[l] as usize;
            // Each event ends the stay in the layer at some weight `end`.
            let (end, ended) = if et >> l & 1 == 1 {
                b.r_diffuse += wb[l] as f64;
                (wb[l], true)
            } else if eb >> l & 1 == 1 {
                b.transmitted += wb[l] as f64;
                (wb[l], true)
            } else if cr >> l & 1 == 1 {
                // Into the next layer (`layer` still holds the one it leaves).
                (wb[l], false)
            } else if sv >> l & 1 == 1 {
                // Roulette won: the weight ×10 is created.
                b.roulette += wn[l] as f64 - wm[l] as f64;
                (wm[l], false)
            } else if kl >> l & 1 == 1 {
                b.roulette -= wm[l] as f64;
                (wm[l], true)
            } else {
                // Trapped beyond MAX_STEPS: abandoned.
                b.roulette -= wn[l] as f64;
                (wn[l], true)
            };
            b.absorbed[here] += b.w_entry as f64 - end as f64;
            b.w_entry = wn[l];
            if ended {
                done |= 1 << l;
            }
        }
        done
    }

    /// Moves the lanes that `crosses` into the layer above (`up`) or below.
    #[inline(always)]
    fn change_layer(&mut self, t: L::Token, up: L, crosses: L) {
        let isplat = |v: i32| L::I::splat(t, v);
        let layer = self.layer;
        self.layer = crosses
            .select(
                up.select(
                    layer.sub(isplat(1)).to_f32_bits(),
                    layer.add(isplat(1)).to_f32_bits(),
                ),
                layer.to_f32_bits(),
            )
            .to_bits();
    }

    /// Books the photons of the lanes in `done` into `tally` and empties their lanes.
    #[inline(always)]
    fn retire(
        &mut self,
        t: L::Token,
        tally: &mut Tally,
        slab: &Slab,
        books: &[Book; LANES],
        done: u32,
    ) {
        if done == 0 {
            return;
        }
        let mut bits = done;
        while bits != 0 {
            let l = bits.trailing_zeros() as usize;
            bits &= bits - 1;
            book(tally, slab, &books[l]);
        }
        self.alive = lane_mask::<L>(t, done).and_not(self.alive);
    }
}

/// Adds one photon's totals to `t`.
fn book(t: &mut Tally, slab: &Slab, b: &Book) {
    debug_assert!(b.absorbed[slab.layers..].iter().all(|&a| a == 0.0));
    let absorbed: f64 = b.absorbed[..slab.layers].iter().sum();
    let mut out = [0.0f64; 4];
    out[R_SPECULAR] = 1.0 - slab.w0 as f64;
    out[R_DIFFUSE] = b.r_diffuse;
    out[TRANSMITTED] = b.transmitted;
    out[ABSORBED] = absorbed;
    for (k, a) in b.absorbed[..slab.layers].iter().enumerate() {
        for c in 0..N_ABSORBERS {
            t.absorbed[k][c] += a * slab.share[k][c];
        }
    }
    t.roulette += b.roulette;
    t.photons += 1;
    t.per_lambda_count[0] += 1;
    for k in 0..4 {
        t.sum[k] += out[k];
        t.sum_sq[k] += out[k] * out[k];
        t.per_lambda[0][k] += out[k];
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::slab::{parse_layer, slab_stack};

    fn run(layers: &[&str], photons: u64) -> Run {
        let ls = layers.iter().map(|l| parse_layer(l).unwrap()).collect();
        Run::totals(slab_stack(ls, 1.0, 1.33), photons, 11)
    }

    #[test]
    fn avx2_and_portable_lanes_tally_the_same_bits() {
        // Two layers of different indices (every boundary case: top, internal, bottom).
        let r = run(&["0.1,10,400,0.85,1.4", "0.6,1,200,0.8,1.37"], 4000);
        assert!(eligible(&r));
        let p = Prepared::new(&r.stacks[0]);
        let a = trace_range_on(&r, &p, 0..4000, true);
        let b = trace_range_on(&r, &p, 0..4000, false);
        assert_eq!(a, b);
        assert_eq!(a.photons, 4000);
    }

    #[test]
    fn lanes_follow_the_scalar_walk_photon_by_photon() {
        // The same random numbers drive the same decisions: the totals of a few thousand
        // photons differ from the f64 walk's by rounding only (here far below the noise, 10⁻³).
        let r = run(&["0.5,2,150,0.8,1.4", "0.5,0.5,100,0.9,1.4"], 3000);
        let p = Prepared::new(&r.stacks[0]);
        let lanes = trace_range_on(&r, &p, 0..3000, true);
        let scalar = crate::cpu::trace_range(&r, std::slice::from_ref(&p), 0..3000);
        for k in 0..4 {
            let d = (lanes.sum[k] - scalar.sum[k]).abs() / 3000.0;
            assert!(d < 2e-4, "total {k}: {} vs {}", lanes.sum[k], scalar.sum[k]);
        }
        assert!(lanes.bookkeeping_error().abs() <= 1e-12 * lanes.weight_total());
    }
}

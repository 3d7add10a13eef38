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
    let splat = |v: f32| L::splat(t, v);
    let isplat = |v: i32| L::I::splat(t, v);
    let (zero, one) = (splat(0.0), splat(1.0));
    let lane_mask = |bits: u32| {
        L::from_array(
            t,
            std::array::from_fn(|l| f32::from_bits(if bits >> l & 1 == 1 { u32::MAX } else { 0 })),
        )
    };

    // Lane state.
    let mut books = [Book::default(); LANES];
    let mut alive = zero;
    let (mut ux, mut uy, mut uz) = (zero, zero, one);
    let (mut z, mut s_left, mut w) = (zero, zero, zero);
    let mut layer = isplat(0);
    let mut steps = zero;
    let mut rng = Streams::<L> {
        words: [isplat(0); 8],
        pos: isplat(8),
        ctr: [
            isplat(0),
            isplat(0),
            isplat(OPTICS_STREAM as i32),
            isplat(0),
        ],
        key: [run.seed as u32, (run.seed >> 32) as u32],
    };
    let mut next = range.start;

    loop {
        // Launch photons into empty lanes, in lane order.
        let empty = !alive.mask_bits() & 0xff;
        if empty != 0 && next < range.end {
            let mut launched = 0u32;
            let (mut lo, mut hi) = (rng.ctr[0].to_array(), rng.ctr[1].to_array());
            let mut blk = rng.ctr[3].to_array();
            let mut pos = rng.pos.to_array();
            for l in 0..LANES {
                if empty >> l & 1 == 1 && next < range.end {
                    books[l] = Book {
                        w_entry: slab.w0,
                        ..Book::default()
                    };
                    (lo[l], hi[l]) = (next as u32 as i32, (next >> 32) as u32 as i32);
                    (blk[l], pos[l]) = (0, 8);
                    launched |= 1 << l;
                    next += 1;
                }
            }
            rng.ctr[0] = L::I::from_array(t, lo);
            rng.ctr[1] = L::I::from_array(t, hi);
            rng.ctr[3] = L::I::from_array(t, blk);
            rng.pos = L::I::from_array(t, pos);
            let m = lane_mask(launched);
            ux = m.select(zero, ux);
            uy = m.select(zero, uy);
            uz = m.select(one, uz);
            z = m.select(zero, z);
            s_left = m.select(zero, s_left);
            w = m.select(splat(slab.w0), w);
            layer = m.select(zero, layer.to_f32_bits()).to_bits();
            steps = m.select(zero, steps);
            alive = alive.or(m);
        }
        if alive.mask_bits() == 0 {
            break;
        }
        rng.refill(t);

        // Step length where the last one was used up.
        let fresh = alive.and(s_left.le(zero));
        let xi = rng.uniform(t, fresh, 3);
        s_left = fresh.select(zero.sub(one.sub(xi).ln()), s_left);

        // Does the step reach the boundary ahead (never when moving parallel to it)?
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
        let hit = alive
            .and(up.or(down))
            .and(mu_t.mul(gap).le(s_left.mul(abs_uz)));
        // (`a.and_not(b)` is b and not a.)
        let inside = hit.and_not(alive);
        let (hm, im) = (hit.mask_bits(), inside.mask_bits());
        let mut events = 0u32; // lanes with something to book
        let (mut escapes_top, mut escapes_bottom, mut crosses) = (zero, zero, zero);

        // Boundary: hop to it, then reflect or cross (only when a lane got there).
        if hm != 0 {
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
            let xi_f = rng.uniform(t, tested, 4);
            // The hop to the boundary, along the incident direction.
            let dist = z_b.sub(z).div(uz);
            let cos_i = abs_uz;
            let (f, cos_t) = fresnel(cos_i, n1, n2, eta);
            let reflect = tested.and(xi_f.lt(f));
            let refract = reflect.and_not(tested);
            // Refracted: u' = η u + (η cosθi − cosθt) m, m = (0, 0, ±1) facing the incident
            // side; through the top, normalised as the scalar walk does.
            let k = eta.mul(cos_i).sub(cos_t);
            let side = up.select(one, zero.sub(one));
            let (rx, ry, rz) = (eta.mul(ux), eta.mul(uy), eta.mul(uz).add(k.mul(side)));
            let inv_len = one.div(rx.mul(rx).add(ry.mul(ry)).add(rz.mul(rz)).sqrt());
            let rx = is_top.select(rx.mul(inv_len), rx);
            let ry = is_top.select(ry.mul(inv_len), ry);
            let rz = is_top.select(rz.mul(inv_len), rz);
            escapes_top = refract.and(is_top);
            escapes_bottom = refract.and(is_bottom);
            crosses = outer.and_not(refract).or(crosses_free);
            events |= escapes_top.or(escapes_bottom).or(crosses).mask_bits();
            ux = refract.select(rx, ux);
            uy = refract.select(ry, uy);
            uz = refract.select(rz, reflect.select(zero.sub(uz), uz));
            s_left = hit.select(s_left.sub(mu_t.mul(dist)), s_left);
            z = hit.select(z_b, z);
        }

        // Interaction: hop inside the layer, absorb, scatter, roulette.
        let (mut survives, mut killed) = (zero, zero);
        // Weights before the step and after its absorption (before any roulette).
        let w_before = w;
        let mut w_absorbed = w;
        if im != 0 {
            let d = s_left.mul(pick::<L>(layer, &slab.inv_mut, nl));
            z = inside.select(uz.mul_add(d, z), z);
            s_left = inside.select(zero, s_left);
            let a = pick::<L>(layer, &slab.albedo_c, nl);
            let w_abs = w.sub(w.mul(a));
            let g = pick::<L>(layer, &slab.g, nl);
            let xi_g = rng.uniform(t, inside, 4);
            let xi_p = rng.uniform(t, inside, 5);
            // Henyey–Greenstein (MCML eq. 3.28); isotropic for |g| < 10⁻⁶.
            let tt =
                pick::<L>(layer, &slab.hg_a, nl).div(one.sub(g).add(splat(2.0).mul(g).mul(xi_g)));
            let ct_hg = one
                .add(g.mul(g))
                .sub(tt.mul(tt))
                .mul(pick::<L>(layer, &slab.hg_b, nl))
                .clamp(-1.0, 1.0);
            let iso = zero.sub(g).max(g).lt(splat(1e-6));
            let ct = iso.select(splat(2.0).mul(xi_g).sub(one), ct_hg);
            let (sp, cp) = xi_p.sincos_turns();
            // Spin (MCML eq. 3.30).
            let st = one.sub(ct.mul(ct)).max(zero).sqrt();
            let vertical = zero.sub(uz).max(uz).gt(splat(0.99999));
            let sign_z = uz.lt(zero).select(zero.sub(one), one);
            let temp = one.sub(uz.mul(uz)).sqrt();
            let q = st.div(temp);
            let uzcp = uz.mul(cp);
            let sx = q.mul_add(ux.mul_add(uzcp, zero.sub(uy.mul(sp))), ux.mul(ct));
            let sy = q.mul_add(uy.mul_add(uzcp, ux.mul(sp)), uy.mul(ct));
            let sz = uz.mul_add(ct, zero.sub(st.mul(cp).mul(temp)));
            ux = inside.select(vertical.select(st.mul(cp), sx), ux);
            uy = inside.select(vertical.select(st.mul(sp), sy), uy);
            uz = inside.select(vertical.select(ct.mul(sign_z), sz), uz);
            // Roulette below the threshold weight.
            let low = inside.and(w_abs.lt(splat(ROULETTE_WEIGHT as f32)));
            w = inside.select(w_abs, w);
            w_absorbed = w;
            if low.mask_bits() != 0 {
                let xi_r = rng.uniform(t, low, 6);
                survives = low.and(xi_r.lt(splat(ROULETTE_CHANCE as f32)));
                killed = survives.and_not(low);
                w = survives.select(w.div(splat(ROULETTE_CHANCE as f32)), w);
                events |= low.mask_bits();
            }
        }

        steps = alive.select(steps.add(one), steps);
        // Photons trapped beyond MAX_STEPS are abandoned (never in practice).
        let trapped = alive.and(steps.gt(splat(MAX_STEPS as f32))).mask_bits();
        events |= trapped;

        // Book the lanes' events, in f64.
        let mut done = 0u32;
        if events != 0 {
            let (wb, wm, wn) = (w_before.to_array(), w_absorbed.to_array(), w.to_array());
            let lay = layer.to_array();
            let (et, eb, cr) = (
                escapes_top.mask_bits(),
                escapes_bottom.mask_bits(),
                crosses.mask_bits(),
            );
            let (sv, kl) = (survives.mask_bits(), killed.mask_bits());
            let mut bits = events;
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
        }
        layer = crosses
            .select(
                up.select(
                    layer.sub(isplat(1)).to_f32_bits(),
                    layer.add(isplat(1)).to_f32_bits(),
                ),
                layer.to_f32_bits(),
            )
            .to_bits();
        // Book the photons that ended.
        if done != 0 {
            let mut bits = done;
            while bits != 0 {
                let l = bits.trailing_zeros() as usize;
                bits &= bits - 1;
                book(&mut tally, slab, &books[l]);
            }
            alive = lane_mask(done).and_not(alive);
        }
    }
    tally
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

//! The micro-relief of many texels, eight at a time (issue 39: paint vectorised across texels):
//! the same model and IEEE operations as [`super::relief::height_cached`], in SIMD lanes.
//!
//! Each texel's two nearest sites are found with the block's 32 slots in four rows of eight
//! lanes (distances, least, and the first slot holding it by a lane mask); the furrow and dome
//! arithmetic then runs across eight texels at once. Every lane performs the scalar code's
//! operations in its order (no fused multiply–adds; negation as a product with −1, absolute
//! value by clearing the sign bit; `max` and `min` with the operands placed so a NaN gives what
//! `f32::max` and `f32::min` give), so the heights are bit-identical to
//! [`super::relief::height_cached`]'s on every path — a test compares them, non-finite points
//! included.

use super::relief::{block, octave_weight, CellSites, ReliefCache, ReliefParams, SLOTS_PADDED};
use derma_core::numerics::lanes::Lanes;
use glam::Vec3;

/// Texels per group: eight f32 lanes.
const LANES: usize = 8;

/// One texel's inputs to the relief, as [`super::relief::height_cached`] takes them.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct ReliefTexel {
    /// Point on the surface (mm).
    pub p: Vec3,
    /// Unit surface normal.
    pub n: Vec3,
    /// Unit tension direction in the tangent plane (zero: isotropic).
    pub tension: Vec3,
    /// Depth scale (≤ 0: no relief).
    pub scale: f32,
    /// Texel size (mm).
    pub texel_mm: f32,
}

/// `out[k]` = [`super::relief::height_cached`] of `texels[k]`, in SIMD lanes where the CPU has
/// AVX2 (texel by texel otherwise); the same bits either way.
pub fn heights(
    prm: &ReliefParams,
    texels: &[ReliefTexel],
    out: &mut [f32],
    cache: &mut ReliefCache,
) {
    assert_eq!(texels.len(), out.len(), "one height per texel");
    #[cfg(target_arch = "x86_64")]
    if let Some(t) = derma_core::numerics::lanes::Avx2::detect() {
        // SAFETY: the token proves the CPU has AVX2 and FMA.
        unsafe { heights_avx2(t, prm, texels, out, cache) };
        return;
    }
    for (o, x) in out.iter_mut().zip(texels) {
        *o = super::relief::height_cached(prm, x.p, x.n, x.tension, x.scale, x.texel_mm, cache);
    }
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,fma")]
unsafe fn heights_avx2(
    t: derma_core::numerics::lanes::Avx2,
    prm: &ReliefParams,
    texels: &[ReliefTexel],
    out: &mut [f32],
    cache: &mut ReliefCache,
) {
    heights_on::<derma_core::numerics::lanes::Avx2F32>(t, prm, texels, out, cache);
}

/// [`heights`] on lanes `L` (groups of eight; the last padded with its last texel).
#[inline(always)]
pub(crate) fn heights_on<L: Lanes>(
    t: L::Token,
    prm: &ReliefParams,
    texels: &[ReliefTexel],
    out: &mut [f32],
    cache: &mut ReliefCache,
) {
    for (group, o) in texels.chunks(LANES).zip(out.chunks_mut(LANES)) {
        let g: [ReliefTexel; LANES] = std::array::from_fn(|l| group[l.min(group.len() - 1)]);
        let h = group_heights::<L>(t, prm, &g, cache).to_array();
        o.copy_from_slice(&h[..group.len()]);
    }
}

/// The relief of eight texels.
#[inline(always)]
fn group_heights<L: Lanes>(
    t: L::Token,
    prm: &ReliefParams,
    g: &[ReliefTexel; LANES],
    cache: &mut ReliefCache,
) -> L {
    let splat = |v: f32| L::splat(t, v);
    let (nx, ny, nz) = (
        lanes::<L>(t, g, |x| x.n.x),
        lanes::<L>(t, g, |x| x.n.y),
        lanes::<L>(t, g, |x| x.n.z),
    );
    let (tx, ty, tz) = (
        lanes::<L>(t, g, |x| x.tension.x),
        lanes::<L>(t, g, |x| x.tension.y),
        lanes::<L>(t, g, |x| x.tension.z),
    );
    let zero = splat(0.0);
    let isotropic = tx.eq(zero).and(ty.eq(zero)).and(tz.eq(zero));
    let texel = lanes::<L>(t, g, |x| x.texel_mm);
    let scale = lanes::<L>(t, g, |x| x.scale);
    let mut h = zero;
    for (o, (&cell, &depth)) in prm.cell_mm.iter().zip(&prm.depth_mm).enumerate() {
        if depth <= 0.0 {
            continue;
        }
        let w_oct: [f32; LANES] = std::array::from_fn(|l| octave_weight(cell, g[l].texel_mm));
        // Lanes the scalar code skips: a faded octave, or no relief at all.
        let skipped: [bool; LANES] = std::array::from_fn(|l| w_oct[l] <= 0.0 || g[l].scale <= 0.0);
        if skipped.iter().all(|&s| s) {
            continue;
        }
        let (cell3, wrap) = prm.cells(cell);
        let mut q = [[0.0f32; LANES]; 3];
        let mut s1 = [[0.0f32; LANES]; 3];
        let mut s2 = [[1.0f32; LANES]; 3];
        let mut d1 = [0.0f32; LANES];
        for l in 0..LANES {
            if skipped[l] {
                continue;
            }
            let ql = g[l].p / cell3;
            let sites = block(ql, o, prm.seed, wrap, cache);
            let (i1, dist1, i2) = nearest_two_on::<L>(t, ql, sites);
            let (a, b) = (sites.site(i1), sites.site(i2));
            for c in 0..3 {
                q[c][l] = ql[c];
                s1[c][l] = a[c];
                s2[c][l] = b[c];
            }
            d1[l] = dist1;
        }
        let v = |a: [f32; LANES]| L::from_array(t, a);
        let (qx, qy, qz) = (v(q[0]), v(q[1]), v(q[2]));
        let (ax, ay, az) = (v(s1[0]), v(s1[1]), v(s1[2]));
        let (bx, by, bz) = (v(s2[0]), v(s2[1]), v(s2[2]));
        // sep = s2 − s1; len = |sep| (at least 1e-6).
        let (sx, sy, sz) = (bx.sub(ax), by.sub(ay), bz.sub(az));
        let len = dot(sx, sy, sz, sx, sy, sz).sqrt().max(splat(1e-6));
        // Distance to the bisector: |sep · (½(s1 + s2) − q)| / len · cell.
        let half = splat(0.5);
        let (mx, my, mz) = (
            half.mul(ax.add(bx)).sub(qx),
            half.mul(ay.add(by)).sub(qy),
            half.mul(az.add(bz)).sub(qz),
        );
        let d_border = abs(dot(sx, sy, sz, mx, my, mz).div(len)).mul(splat(cell));
        // along = normalize_or_zero(n × sep); c = along · tension.
        let (cx, cy, cz) = (
            ny.mul(sz).sub(sy.mul(nz)),
            nz.mul(sx).sub(sz.mul(nx)),
            nx.mul(sy).sub(sx.mul(ny)),
        );
        let rcp = splat(1.0).div(dot(cx, cy, cz, cx, cy, cz).sqrt());
        let normal = rcp.gt(zero).and(rcp.lt(splat(f32::INFINITY)));
        let (ux, uy, uz) = (
            normal.select(cx.mul(rcp), zero),
            normal.select(cy.mul(rcp), zero),
            normal.select(cz.mul(rcp), zero),
        );
        let c = dot(ux, uy, uz, tx, ty, tz);
        let one = splat(1.0);
        let orient = isotropic.select(one, one.sub(splat(prm.anisotropy).mul(one.sub(c.mul(c)))));
        let w_nom = prm.width_fraction * cell;
        // f32::max(w_nom, 0.75·texel): the lanes' max gives its second operand on a NaN.
        let w = splat(0.75).mul(texel).max(splat(w_nom));
        let furrow_depth = splat(depth).mul(orient).mul(splat(w_nom).div(w));
        let tt = d_border.div(w);
        let rim = one.sub(tt.mul(tt));
        let furrow = d_border
            .lt(w)
            .select(splat(-1.0).mul(furrow_depth).mul(rim).mul(rim), zero);
        // The plateau's dome: r = min(√d1 · cell / (½ cell), 1).
        let r = v(d1)
            .sqrt()
            .mul(splat(cell))
            .div(splat(0.5 * cell))
            .min(one);
        let dome = splat(prm.dome_fraction * depth).mul(one.sub(r.mul(r)));
        let add = v(w_oct).mul(furrow.add(dome));
        let skip = L::from_array(
            t,
            std::array::from_fn(|l| {
                if skipped[l] {
                    f32::from_bits(u32::MAX)
                } else {
                    0.0
                }
            }),
        );
        h = skip.select(h, h.add(add));
    }
    scale.le(zero).select(zero, h.mul(scale))
}

/// One input of the eight texels, as lanes.
#[inline(always)]
fn lanes<L: Lanes>(t: L::Token, g: &[ReliefTexel; LANES], f: impl Fn(&ReliefTexel) -> f32) -> L {
    L::from_array(t, std::array::from_fn(|l| f(&g[l])))
}

/// `a · b` as glam computes it: (ax·bx + ay·by) + az·bz.
#[inline(always)]
fn dot<L: Lanes>(ax: L, ay: L, az: L, bx: L, by: L, bz: L) -> L {
    ax.mul(bx).add(ay.mul(by)).add(az.mul(bz))
}

/// |x| (the sign bit cleared, as `f32::abs`).
#[inline(always)]
fn abs<L: Lanes>(x: L) -> L {
    x.and(x.splat_as(f32::from_bits(0x7fff_ffff)))
}

/// The slot of the nearest site of `q` in `sites`, its squared distance, and the slot of the
/// second nearest (ties to the lower slot, as the scalar search breaks them).
#[inline(always)]
fn nearest_two_on<L: Lanes>(t: L::Token, q: Vec3, sites: &CellSites) -> (usize, f32, usize) {
    let (qx, qy, qz) = (L::splat(t, q.x), L::splat(t, q.y), L::splat(t, q.z));
    let row = |c: usize, j: usize| {
        L::from_array(
            t,
            sites.columns[c][j * LANES..(j + 1) * LANES]
                .try_into()
                .expect("eight slots"),
        )
    };
    let d: [L; SLOTS_PADDED / LANES] = std::array::from_fn(|j| {
        let (dx, dy, dz) = (row(0, j).sub(qx), row(1, j).sub(qy), row(2, j).sub(qz));
        dx.mul(dx).add(dy.mul(dy)).add(dz.mul(dz))
    });
    let least = |d: &[L; SLOTS_PADDED / LANES]| {
        let m = d[0].min(d[1]).min(d[2].min(d[3])).to_array();
        m.iter().fold(f32::MAX, |a, &b| if b < a { b } else { a })
    };
    let slots_of = |v: f32| {
        let v = L::splat(t, v);
        d.iter().enumerate().fold(0u32, |bits, (j, r)| {
            bits | (r.eq(v).mask_bits() << (LANES * j))
        })
    };
    // The first slot in `bits` (slot 0 when none: no distance is a number, as the scalar
    // search falls back).
    let first = |bits: u32| {
        if bits == 0 {
            0
        } else {
            bits.trailing_zeros() as usize
        }
    };
    let d1 = least(&d);
    let i1 = first(slots_of(d1));
    // The second: the least of the other slots (an equal distance elsewhere included).
    let others: [L; SLOTS_PADDED / LANES] = std::array::from_fn(|j| {
        let slot = L::from_array(t, std::array::from_fn(|l| (j * LANES + l) as f32));
        slot.eq(L::splat(t, i1 as f32))
            .select(L::splat(t, f32::MAX), d[j])
    });
    let d2 = least(&others);
    let i2 = first(slots_of(d2) & !(1u32 << i1));
    (i1, d1, i2)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::features::relief::{height_cached, test_params as prm};
    use derma_core::numerics::lanes::PortableF32;

    /// Texels along a wandering curve, with every case the scalar code branches on: faded
    /// octaves (large texels), no relief (scale ≤ 0), no tension, steps within and across cells,
    /// a run of eight that skips every octave, and points and a texel size that are not numbers.
    fn texels() -> Vec<ReliefTexel> {
        let rng = derma_core::rng::Philox::new(5, 1);
        let mut p = Vec3::new(3.0, -2.0, 40.0);
        (0..4001u64)
            .map(|k| {
                let u = rng.uniform4(k, 0);
                let v = rng.uniform4(k, 1);
                p += (Vec3::new(u[0], u[1], u[2]) - 0.5) * if k % 97 == 0 { 5.0 } else { 0.07 };
                let n = (Vec3::new(v[0], v[1], v[2]) - 0.5).normalize_or(Vec3::Z);
                let tension = if k % 5 == 0 {
                    Vec3::ZERO
                } else {
                    n.any_orthonormal_vector()
                };
                ReliefTexel {
                    p,
                    n,
                    tension,
                    scale: if k % 13 == 0 { 0.0 } else { 0.5 + u[3] },
                    texel_mm: [0.01, 0.05, 0.14, 0.3, 2.0][(k % 5) as usize] * (0.8 + 0.4 * v[3]),
                }
            })
            .chain((0..8).map(|k| ReliefTexel {
                p: Vec3::new(k as f32, 1.0, 2.0),
                n: Vec3::Z,
                tension: Vec3::X,
                scale: 1.0,
                texel_mm: 10.0,
            }))
            .chain(
                [
                    Vec3::new(f32::NAN, 1.0, 2.0),
                    Vec3::new(f32::INFINITY, 1.0, 2.0),
                    Vec3::new(1.0, f32::NEG_INFINITY, 2.0),
                ]
                .map(|p| ReliefTexel {
                    p,
                    n: Vec3::Z,
                    tension: Vec3::X,
                    scale: 1.0,
                    texel_mm: 0.05,
                }),
            )
            .chain(std::iter::once(ReliefTexel {
                p: Vec3::new(0.3, 0.2, 0.1),
                n: Vec3::Z,
                tension: Vec3::X,
                scale: 1.0,
                texel_mm: f32::NAN,
            }))
            .collect()
    }

    fn scalar(prm: &ReliefParams, texels: &[ReliefTexel]) -> Vec<u32> {
        let mut cache = ReliefCache::default();
        texels
            .iter()
            .map(|x| {
                height_cached(prm, x.p, x.n, x.tension, x.scale, x.texel_mm, &mut cache).to_bits()
            })
            .collect()
    }

    #[test]
    fn the_lanes_give_the_scalar_bits() {
        let shallow = ReliefParams {
            depth_mm: [0.03, 0.0, 0.006],
            ..prm(None)
        };
        for prm in [prm(None), prm(Some([20.0, 30.0])), shallow] {
            let period = prm.period;
            let texels = texels();
            let want = scalar(&prm, &texels);
            assert!(want.iter().filter(|&&b| f32::from_bits(b) != 0.0).count() > 2000);
            // Portable lanes (every CPU) and the dispatched path (AVX2 here where present).
            let mut out = vec![0.0f32; texels.len()];
            heights_on::<PortableF32>((), &prm, &texels, &mut out, &mut ReliefCache::default());
            let got: Vec<u32> = out.iter().map(|v| v.to_bits()).collect();
            assert_eq!(got, want, "portable lanes, period {period:?}");
            heights(&prm, &texels, &mut out, &mut ReliefCache::default());
            let got: Vec<u32> = out.iter().map(|v| v.to_bits()).collect();
            assert_eq!(got, want, "dispatched lanes, period {period:?}");
        }
    }

    #[test]
    fn ties_go_to_the_lower_slot() {
        // Two sites at exactly the same distance: the nearest is the lower slot, the second the
        // other one, as the scalar search picks them.
        let mut sites = CellSites::far();
        for k in 0..27 {
            sites.columns[0][k] = 10.0 + k as f32;
            sites.columns[1][k] = 0.0;
            sites.columns[2][k] = 0.0;
        }
        sites.columns[0][4] = 1.0;
        sites.columns[0][9] = -1.0;
        let (i1, d1, i2) = nearest_two_on::<PortableF32>((), Vec3::ZERO, &sites);
        assert_eq!((i1, d1, i2), (4, 1.0, 9));
        sites.columns[0][2] = 0.5;
        assert_eq!(
            nearest_two_on::<PortableF32>((), Vec3::ZERO, &sites),
            (2, 0.25, 4)
        );
    }
}

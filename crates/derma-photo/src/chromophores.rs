//! Melanin and hemoglobin maps from a baked photo texture (beyond Tarini et al. 2002; as
//! Jimenez et al. 2010 §3 turn acquired colour into chromophores): each texel's colour is
//! matched in CIELAB to a table over (∛C_m, ∛C_hd) in the form of eq. 7 — the one `derma skin`
//! paints with (`derma_skin::measured::inversion_lut`), or the skin-colour LUT — over its
//! continuous domain, clamped to the gamut with the residual ΔE*ab kept.

use crate::error::{PhotoError, Result};
use crate::photo::RgbImage;
use derma_core::color::{linear_srgb_to_xyz, xyz_to_lab};
use derma_core::Map;
use derma_shading::skin_color_lut::SkinColorLut;
use rayon::prelude::*;
use serde::Serialize;

/// Chromophore maps of a texture.
pub struct Chromophores {
    /// Melanosome volume fraction C_m per texel.
    pub melanin: Map,
    /// Dermal blood volume fraction C_hd per texel (the rig's hemoglobin).
    pub hemoglobin: Map,
    /// ΔE*ab between the texel's colour and the LUT's colour of the result.
    pub residual: Map,
    /// Per texel in [0, 1]: the share of the result its own colour decides, the rest coming from
    /// its neighbours (σ / (σ + √λ), σ the colour's weaker sensitivity to the chromophores).
    pub confidence: Map,
    /// Summary.
    pub report: ChromophoreReport,
}

/// A summary of an inversion.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct ChromophoreReport {
    /// The exposure factor the texture was divided by before matching.
    pub exposure: f64,
    /// Median ΔE*ab over the texels inverted.
    pub median_delta_e: f64,
    /// 95th percentile ΔE*ab.
    pub p95_delta_e: f64,
    /// Share of texels whose best match lies on the gamut's edge (clamped).
    pub clamped_share: f64,
    /// Texels the statistics cover (the mask's).
    pub texels: usize,
    /// Share of neighbouring texel pairs (both covered) whose melanin differs by more than 0.05.
    pub flips: f64,
}

/// ΔE*ab within which a continuation from the left neighbour's answer is kept without a search
/// (authored: below the photos' 8-bit steps of about 0.3–0.5 ΔE, see [`SMOOTHNESS`]).
const CONTINUE_DE: f64 = 0.5;

/// The largest residual ΔE*ab a full search lends the continuations after it (out of the gamut,
/// beyond it they search again).
const ANCHOR_MAX: f64 = 2.0;

/// Nodes of [`LabTable`] per LUT cell and side.
const LAB_REFINE: usize = 8;

/// The LUT resampled in Lab for matching: Lab of the LUT's bilinear colour on a grid
/// [`LAB_REFINE`]× finer than the LUT, interpolated bilinearly (within 0.001 ΔE of converting
/// every lookup; see the tests), so a colour and its Jacobian over (u, v) ∈ [0, 1]² cost one
/// cell's four nodes instead of three cube roots per evaluation and finite differences.
struct LabTable {
    n: usize,
    lab: Vec<[f64; 3]>,
}

fn lab_of(rgb: [f64; 3]) -> [f64; 3] {
    xyz_to_lab(linear_srgb_to_xyz(rgb.map(|v| v.max(0.0))))
}

impl LabTable {
    fn new(lut: &SkinColorLut) -> Self {
        let n = (lut.options.size - 1) * LAB_REFINE + 1;
        let at = |i: usize| i as f64 / (n - 1) as f64;
        let lab = (0..n * n)
            .into_par_iter()
            .map(|k| lab_of(lut.lookup_uv(at(k % n), at(k / n))))
            .collect();
        Self { n, lab }
    }

    /// The cell of (u, v) (clamped to the box) and the position inside it.
    fn cell(&self, u: f64, v: f64) -> (usize, f64, f64) {
        let m = (self.n - 1) as f64;
        let (x, y) = (u.clamp(0.0, 1.0) * m, v.clamp(0.0, 1.0) * m);
        let (i, j) = ((x as usize).min(self.n - 2), (y as usize).min(self.n - 2));
        (j * self.n + i, x - i as f64, y - j as f64)
    }

    /// Lab at (u, v).
    fn lab(&self, u: f64, v: f64) -> [f64; 3] {
        let (k, fx, fy) = self.cell(u, v);
        let (a, b, c, d) = (
            self.lab[k],
            self.lab[k + 1],
            self.lab[k + self.n],
            self.lab[k + self.n + 1],
        );
        std::array::from_fn(|q| {
            let top = a[q] + (b[q] - a[q]) * fx;
            let bot = c[q] + (d[q] - c[q]) * fx;
            top + (bot - top) * fy
        })
    }

    /// Lab at (u, v) with its derivatives along u and v.
    fn lab_jacobian(&self, u: f64, v: f64) -> ([f64; 3], [f64; 3], [f64; 3]) {
        let (k, fx, fy) = self.cell(u, v);
        let m = (self.n - 1) as f64;
        let (a, b, c, d) = (
            self.lab[k],
            self.lab[k + 1],
            self.lab[k + self.n],
            self.lab[k + self.n + 1],
        );
        let mut l = [0.0; 3];
        let (mut ju, mut jv) = ([0.0; 3], [0.0; 3]);
        for q in 0..3 {
            let top = a[q] + (b[q] - a[q]) * fx;
            let bot = c[q] + (d[q] - c[q]) * fx;
            l[q] = top + (bot - top) * fy;
            ju[q] = ((b[q] - a[q]) * (1.0 - fy) + (d[q] - c[q]) * fy) * m;
            jv[q] = (bot - top) * m;
        }
        (l, ju, jv)
    }
}

fn dist2(a: [f64; 3], b: [f64; 3]) -> f64 {
    (0..3).map(|k| (a[k] - b[k]).powi(2)).sum()
}

/// (u, v, ΔE, clamped) of the LUT colour closest in Lab to `target`: a search over a 17 × 17
/// grid, then damped Gauss–Newton steps in the box [0, 1]² from the three best grid points (the
/// table is nearly flat in blood where blood saturates the colour; one start can stall there).
fn invert_one(t: &LabTable, target: [f64; 3], coarse: &Coarse) -> (f64, f64, f64, bool) {
    // The three best grid points in one pass (ties to the lower (u, v), as a sort would).
    let key = |a: &(f64, f64, f64)| (a.2, a.0, a.1);
    let less = |a: &(f64, f64, f64), b: &(f64, f64, f64)| {
        let (ka, kb) = (key(a), key(b));
        ka.0.total_cmp(&kb.0)
            .then(ka.1.total_cmp(&kb.1))
            .then(ka.2.total_cmp(&kb.2))
            .is_lt()
    };
    let mut d = [0.0f64; COARSE * COARSE];
    for (k, d) in d.iter_mut().enumerate() {
        *d = (coarse.lab[0][k] - target[0]).powi(2)
            + (coarse.lab[1][k] - target[1]).powi(2)
            + (coarse.lab[2][k] - target[2]).powi(2);
    }
    let mut starts = [(0.0, 0.0, f64::INFINITY); 3];
    for (k, d) in d.iter().enumerate() {
        if *d > starts[2].2 {
            continue;
        }
        let c = (Coarse::at(k % COARSE), Coarse::at(k / COARSE), *d);
        if less(&c, &starts[2]) {
            starts[2] = c;
            if less(&starts[2], &starts[1]) {
                starts.swap(1, 2);
                if less(&starts[1], &starts[0]) {
                    starts.swap(0, 1);
                }
            }
        }
    }
    let mut best = (0.0, 0.0, f64::INFINITY);
    for &(u0, v0, _) in &starts {
        let r = refine(t, target, u0, v0);
        if r.2 < best.2 {
            best = r;
        }
        // The other starts only matter where the first one stalled on the box's edge (the
        // table is flat in blood where blood saturates): elsewhere the minimum is unique.
        let on_edge =
            best.0 <= 1e-6 || best.1 <= 1e-6 || best.0 >= 1.0 - 1e-6 || best.1 >= 1.0 - 1e-6;
        if best.2 < 0.01 || !on_edge {
            break;
        }
    }
    let (u, v, cur) = best;
    let edge = 1e-6;
    let clamped = u <= edge || v <= edge || u >= 1.0 - edge || v >= 1.0 - edge;
    (u, v, cur.sqrt(), clamped)
}

/// Damped Gauss–Newton from (u, v): (u, v, squared ΔE).
fn refine(t: &LabTable, target: [f64; 3], mut u: f64, mut v: f64) -> (f64, f64, f64) {
    // Each trial point is evaluated with its Jacobian, which the next iteration starts from.
    let (mut l0, mut ju, mut jv) = t.lab_jacobian(u, v);
    let mut cur = dist2(l0, target);
    let mut lambda = 1e-3;
    for _ in 0..20 {
        let r: [f64; 3] = std::array::from_fn(|k| l0[k] - target[k]);
        let (a11, a12, a22) = (
            ju.iter().map(|x| x * x).sum::<f64>(),
            ju.iter().zip(&jv).map(|(a, b)| a * b).sum::<f64>(),
            jv.iter().map(|x| x * x).sum::<f64>(),
        );
        let (g1, g2) = (
            ju.iter().zip(&r).map(|(a, b)| a * b).sum::<f64>(),
            jv.iter().zip(&r).map(|(a, b)| a * b).sum::<f64>(),
        );
        let mut improved = false;
        for _ in 0..8 {
            let (d11, d22) = (a11 * (1.0 + lambda) + 1e-12, a22 * (1.0 + lambda) + 1e-12);
            let det = d11 * d22 - a12 * a12;
            if det.abs() < 1e-300 {
                lambda *= 10.0;
                continue;
            }
            let du = -(d22 * g1 - a12 * g2) / det;
            let dv = -(-a12 * g1 + d11 * g2) / det;
            let (nu, nv) = ((u + du).clamp(0.0, 1.0), (v + dv).clamp(0.0, 1.0));
            let (nl, nju, njv) = t.lab_jacobian(nu, nv);
            let c = dist2(nl, target);
            if c < cur {
                (l0, ju, jv) = (nl, nju, njv);
                let step = (nu - u).abs() + (nv - v).abs();
                let gain = cur - c;
                u = nu;
                v = nv;
                cur = c;
                lambda = (lambda * 0.3).max(1e-9);
                // Stop once a step no longer changes ΔE² by 10⁻⁴ (ΔE by ~0.01).
                improved = step > 1e-9 && gain > 1e-4;
                break;
            }
            lambda *= 10.0;
        }
        if !improved {
            break;
        }
    }
    (u, v, cur)
}

/// Nodes per side of [`Coarse`].
const COARSE: usize = 17;

/// The starting grid of [`invert_one`]: Lab at COARSE × COARSE points of the box, one array per
/// coordinate (so that the distances to a target are computed several at a time).
struct Coarse {
    lab: [Vec<f64>; 3],
}

impl Coarse {
    fn new(t: &LabTable) -> Self {
        let mut lab = [const { Vec::new() }; 3];
        for k in 0..COARSE * COARSE {
            let l = t.lab(Self::at(k % COARSE), Self::at(k / COARSE));
            for q in 0..3 {
                lab[q].push(l[q]);
            }
        }
        Self { lab }
    }

    /// The coordinate of grid line i.
    fn at(i: usize) -> f64 {
        i as f64 / (COARSE - 1) as f64
    }
}

/// The exposure factor that best explains a texture as LUT colours: the mean ΔE*ab of the best
/// 90 % of a sample of texels is minimised over factors 0.25–4 (golden-section search in log
/// space).
pub fn fit_exposure(lut: &SkinColorLut, texels: &[[f32; 3]]) -> f64 {
    let t = LabTable::new(lut);
    let coarse = Coarse::new(&t);
    let step = (texels.len() / 2000).max(1);
    let sample: Vec<[f32; 3]> = texels.iter().step_by(step).copied().collect();
    let cost = |log_e: f64| -> f64 {
        let e = log_e.exp();
        let mut d: Vec<f64> = sample
            .par_iter()
            .map(|c| invert_one(&t, lab_of(c.map(|x| x as f64 / e)), &coarse).2)
            .collect();
        d.sort_by(f64::total_cmp);
        // The mean of the best 90 %: robust to outliers (hair, shadows) yet sensitive to the
        // whole distribution, unlike the median.
        let k = (d.len() * 9 / 10).max(1);
        d[..k].iter().sum::<f64>() / k as f64
    };
    let (mut a, mut b) = (0.25f64.ln(), 4.0f64.ln());
    let g = (5f64.sqrt() - 1.0) / 2.0;
    let (mut x1, mut x2) = (b - g * (b - a), a + g * (b - a));
    let (mut f1, mut f2) = (cost(x1), cost(x2));
    for _ in 0..30 {
        if f1 < f2 {
            b = x2;
            x2 = x1;
            f2 = f1;
            x1 = b - g * (b - a);
            f1 = cost(x1);
        } else {
            a = x1;
            x1 = x2;
            f1 = f2;
            x2 = a + g * (b - a);
            f2 = cost(x2);
        }
        if b - a < 1e-3 {
            break;
        }
    }
    (0.5 * (a + b)).exp()
}

/// λ of the spatial prior: the cost of a unit step of (∛C_m, ∛C_hd) between neighbours, in
/// ΔE*ab² (a step of 0.01, about 0.0036 in melanin at C_m = 0.06, costs as much as 1 ΔE² of
/// colour). Authored: at 2500 the photos' 8-bit steps (~0.3–0.5 ΔE) still showed as contour
/// bands in a 2048² hemoglobin map; at 10 000 they are gone while the melanin keeps its 1–2 mm
/// freckles (the colour pins melanin ~10× harder than blood).
pub const SMOOTHNESS: f64 = 10_000.0;
/// Jacobi sweeps of the spatial prior at each level of its coarse-to-fine cascade.
pub const SWEEPS: usize = 12;

/// JᵀJ of Lab over (u, v) at (u, v): [a11, a12, a22].
fn normal_matrix(t: &LabTable, u: f64, v: f64) -> [f32; 3] {
    let (_, ju, jv) = t.lab_jacobian(u, v);
    let d = |a: &[f64; 3], b: &[f64; 3]| a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
    [d(&ju, &ju) as f32, d(&ju, &jv) as f32, d(&jv, &jv) as f32]
}

/// The smaller singular value of J from JᵀJ = [a11, a12, a22] (ΔE per unit of (u, v)).
fn weaker_sensitivity(h: [f32; 3]) -> f32 {
    let (p, q, r) = (h[0], h[1], h[2]);
    (0.5 * (p + r - ((p - r).powi(2) + 4.0 * q * q).sqrt()))
        .max(0.0)
        .sqrt()
}

/// The spatial prior (beyond the per-texel fit; as a Gaussian Markov random field): minimises
/// Σ (x − x̂)ᵀ H (x − x̂) + λ Σ_neighbours |x_i − x_j|² over x = (∛C_m, ∛C_hd), x̂ the texel's own
/// best match and H its JᵀJ (the colour's quadratic cost around it): where the colour pins a
/// chromophore (melanin, mostly) the texel keeps it; where it hardly does (blood under much
/// melanin) the neighbours decide, so no texel jumps between explanations its colour cannot
/// tell apart. Solved coarse to fine (a multigrid cascade): each coarser level sums its 2 × 2
/// children's data terms (H and H x̂; λ is unchanged, the membrane energy being scale-free in
/// 2D), is relaxed by [`SWEEPS`] Jacobi sweeps over the 4-neighbourhood from the coarser answer,
/// and hands its answer down; so the prior reaches across a whole 2048² map in a few sweeps per
/// level.
fn smooth(res: &mut [Texel], w: usize, h: usize, lambda: f64, sweeps: usize) {
    let lambda = lambda as f32;
    // Level 0: the texels' own data terms.
    let mut levels: Vec<Level> = vec![Level {
        w,
        h,
        hm: res.par_iter().map(|r| r.h).collect(),
        b: res
            .par_iter()
            .map(|r| {
                let [a, b, c] = r.h;
                [a * r.uv[0] + b * r.uv[1], b * r.uv[0] + c * r.uv[1]]
            })
            .collect(),
        x: res.par_iter().map(|r| r.uv).collect(),
    }];
    while levels.last().is_some_and(|l| l.w.min(l.h) > 8) {
        let f = levels.last().expect("a level");
        let (cw, ch) = (f.w.div_ceil(2), f.h.div_ceil(2));
        // Each coarse texel sums its children row by row (the order a raster pass would).
        let mut c = Level {
            w: cw,
            h: ch,
            hm: vec![[0.0; 3]; cw * ch],
            b: vec![[0.0; 2]; cw * ch],
            x: vec![[0.0; 2]; cw * ch],
        };
        c.hm.par_chunks_mut(cw)
            .zip(c.b.par_chunks_mut(cw))
            .zip(c.x.par_chunks_mut(cw))
            .enumerate()
            .for_each(|(cy, ((hm, b), xs))| {
                let mut n = vec![0.0f32; cw];
                for y in 2 * cy..(2 * cy + 2).min(f.h) {
                    for x in 0..f.w {
                        let (i, j) = (y * f.w + x, x / 2);
                        for k in 0..3 {
                            hm[j][k] += f.hm[i][k];
                        }
                        for k in 0..2 {
                            b[j][k] += f.b[i][k];
                            xs[j][k] += f.x[i][k];
                        }
                        n[j] += 1.0;
                    }
                }
                for (x, n) in xs.iter_mut().zip(&n) {
                    *x = x.map(|v| v / n);
                }
            });
        levels.push(c);
    }
    // Coarse to fine.
    for l in (0..levels.len()).rev() {
        if l + 1 < levels.len() {
            let (fine, coarse) = levels.split_at_mut(l + 1);
            let (f, c) = (&mut fine[l], &coarse[0]);
            let fw = f.w;
            f.x.par_chunks_mut(fw).enumerate().for_each(|(y, row)| {
                for (x, v) in row.iter_mut().enumerate() {
                    *v = c.x[(y / 2) * c.w + x / 2];
                }
            });
        }
        levels[l].relax(lambda, sweeps);
    }
    for (r, x) in res.iter_mut().zip(&levels[0].x) {
        r.uv = *x;
    }
}

/// One level of [`smooth`]'s cascade: per texel, the data term's matrix H ([a11, a12, a22]) and
/// vector H x̂, and the current answer.
struct Level {
    w: usize,
    h: usize,
    hm: Vec<[f32; 3]>,
    b: Vec<[f32; 2]>,
    x: Vec<[f32; 2]>,
}

impl Level {
    /// Jacobi sweeps: x_i = (H + nλ)⁻¹ (H x̂ + λ Σ_j x_j) over the n neighbours in the image.
    fn relax(&mut self, lambda: f32, sweeps: usize) {
        let (w, h) = (self.w, self.h);
        let mut next = self.x.clone();
        for _ in 0..sweeps {
            let cur = &self.x;
            next.par_chunks_mut(w).enumerate().for_each(|(y, row)| {
                let up = (y > 0).then(|| &cur[(y - 1) * w..y * w]);
                let down = (y + 1 < h).then(|| &cur[(y + 1) * w..(y + 2) * w]);
                let mid = &cur[y * w..(y + 1) * w];
                let (hm, b) = (&self.hm[y * w..(y + 1) * w], &self.b[y * w..(y + 1) * w]);
                let vertical = up.is_some() as u8 + down.is_some() as u8;
                for (x, out) in row.iter_mut().enumerate() {
                    let mut sum = [0.0f32; 2];
                    // The sum in the order left, right, up, down.
                    let mut add = |q: [f32; 2]| {
                        sum[0] += q[0];
                        sum[1] += q[1];
                    };
                    if x > 0 {
                        add(mid[x - 1]);
                    }
                    if x + 1 < w {
                        add(mid[x + 1]);
                    }
                    if let Some(up) = up {
                        add(up[x]);
                    }
                    if let Some(down) = down {
                        add(down[x]);
                    }
                    let n = ((x > 0) as u8 + (x + 1 < w) as u8 + vertical) as f32;
                    let [a, bb, c] = hm[x];
                    let (m11, m12, m22) = (a + n * lambda, bb, c + n * lambda);
                    let rhs = [b[x][0] + lambda * sum[0], b[x][1] + lambda * sum[1]];
                    let det = m11 * m22 - m12 * m12;
                    *out = if det.abs() > 1e-12 {
                        [
                            ((m22 * rhs[0] - m12 * rhs[1]) / det).clamp(0.0, 1.0),
                            ((m11 * rhs[1] - m12 * rhs[0]) / det).clamp(0.0, 1.0),
                        ]
                    } else {
                        mid[x]
                    };
                }
            });
            std::mem::swap(&mut self.x, &mut next);
        }
    }
}

/// Share of 4-neighbour pairs of used texels whose melanin differs by more than 0.05.
fn flip_share(res: &[Texel], w: usize, h: usize) -> f64 {
    let (pairs, flips) = (0..h)
        .into_par_iter()
        .map(|y| {
            let (mut pairs, mut flips) = (0usize, 0usize);
            for x in 0..w {
                let i = y * w + x;
                if !res[i].used {
                    continue;
                }
                for j in [(x + 1 < w).then_some(i + 1), (y + 1 < h).then_some(i + w)]
                    .into_iter()
                    .flatten()
                {
                    if res[j].used {
                        pairs += 1;
                        flips += ((res[i].melanin - res[j].melanin).abs() > 0.05) as usize;
                    }
                }
            }
            (pairs, flips)
        })
        .reduce(|| (0, 0), |a, b| (a.0 + b.0, a.1 + b.1));
    flips as f64 / pairs.max(1) as f64
}

/// One texel's inversion.
#[derive(Clone, Copy)]
struct Texel {
    melanin: f32,
    hemoglobin: f32,
    delta_e: f32,
    clamped: bool,
    used: bool,
    /// (∛ melanin, ∛ blood) in the LUT's unit square, and JᵀJ of Lab there (ΔE² per unit²).
    uv: [f32; 2],
    h: [f32; 3],
}

/// Inverts the LUT for every texel after dividing the texture by `exposure`; the report's
/// statistics cover the texels where `mask` holds (all when `None`) — e.g. those coloured from
/// photos, not interpolated or in the gutter — while every texel gets its maps, so they can
/// drive a whole UV layout (`derma skin`'s `baseline.melanin_map`).
pub fn invert(
    lut: &SkinColorLut,
    texture: &RgbImage,
    mask: Option<&[bool]>,
    exposure: f64,
) -> Result<Chromophores> {
    invert_with(lut, texture, mask, exposure, SMOOTHNESS)
}

/// [`invert`] with the spatial prior's weight λ (0: each texel alone).
pub fn invert_with(
    lut: &SkinColorLut,
    texture: &RgbImage,
    mask: Option<&[bool]>,
    exposure: f64,
    smoothness: f64,
) -> Result<Chromophores> {
    if !(exposure > 0.0 && exposure.is_finite()) {
        return Err(PhotoError::Invalid(derma_core::Invalid::new(
            "exposure",
            "a positive number",
            exposure,
        )));
    }
    let n = texture.width * texture.height;
    if let Some(m) = mask {
        if m.len() != n {
            return Err(PhotoError::Invalid(derma_core::Invalid::new(
                "mask",
                format!(
                    "{n} texels (one per texel of the {}×{} texture)",
                    texture.width, texture.height
                ),
                format!("{} texels", m.len()),
            )));
        }
    }
    let t = LabTable::new(lut);
    let coarse = Coarse::new(&t);
    let o = &lut.options;
    // Rows in parallel; a texel with exactly its left neighbour's colour (a texture's dilated
    // gutter, flat regions) reuses its result — the same answer, computed once.
    let w = texture.width;
    let mut res: Vec<Texel> = Vec::with_capacity(n);
    res.resize(
        n,
        Texel {
            melanin: 0.0,
            hemoglobin: 0.0,
            delta_e: 0.0,
            clamped: false,
            used: false,
            uv: [0.0; 2],
            h: [0.0; 3],
        },
    );
    res.par_chunks_mut(w).enumerate().for_each(|(y, row)| {
        // ΔE of the row's last full search, while the continuations after it stay out of the
        // gamut; at most ANCHOR_MAX.
        let mut anchor = 0.0f64;
        for x in 0..w {
            let i = y * w + x;
            let used = mask.is_none_or(|m| m[i]);
            if x > 0 && texture.data[i] == texture.data[i - 1] {
                row[x] = Texel { used, ..row[x - 1] };
                continue;
            }
            let c = texture.data[i].map(|x| x as f64 / exposure);
            let target = lab_of(c);
            // Continuation: start from the left neighbour's answer; keep it when it lands inside
            // the box and explains the colour within ΔE 0.5, or within ΔE 0.5 of the last full
            // search's residual while the colours stay out of the gamut (neighbouring skin is
            // alike, and this keeps neighbours on the same branch of a curve of nearly one
            // colour, also where no colour matches within 0.5); else search. A colour matched
            // within 0.5 resets the allowance, so one poor match does not loosen a whole row.
            let from_left = (x > 0 && !row[x - 1].clamped).then(|| {
                let [u0, v0] = row[x - 1].uv;
                refine(&t, target, u0 as f64, v0 as f64)
            });
            let inside = |u: f64, v: f64| u > 1e-6 && v > 1e-6 && u < 1.0 - 1e-6 && v < 1.0 - 1e-6;
            let (u, v, de, clamped) = match from_left {
                Some((u, v, d2)) if d2.sqrt() < CONTINUE_DE + anchor && inside(u, v) => {
                    if d2 < CONTINUE_DE * CONTINUE_DE {
                        anchor = 0.0;
                    }
                    (u, v, d2.sqrt(), false)
                }
                _ => {
                    let found = invert_one(&t, target, &coarse);
                    anchor = if found.2 < CONTINUE_DE {
                        0.0
                    } else {
                        found.2.min(ANCHOR_MAX)
                    };
                    found
                }
            };
            row[x] = Texel {
                melanin: (u.powi(3) * o.melanin_max) as f32,
                hemoglobin: (v.powi(3) * o.blood_max) as f32,
                delta_e: de as f32,
                clamped,
                used,
                uv: [u as f32, v as f32],
                h: normal_matrix(&t, u, v),
            };
        }
    });
    let h = texture.height;
    if smoothness > 0.0 {
        smooth(&mut res, w, h, smoothness, SWEEPS);
    }
    // The maps and the residual at the smoothed result.
    res.par_iter_mut().enumerate().for_each(|(i, r)| {
        let (u, v) = (r.uv[0] as f64, r.uv[1] as f64);
        r.melanin = (u.powi(3) * o.melanin_max) as f32;
        r.hemoglobin = (v.powi(3) * o.blood_max) as f32;
        let target = lab_of(texture.data[i].map(|x| x as f64 / exposure));
        r.delta_e = dist2(t.lab(u, v), target).sqrt() as f32;
    });
    let mut de: Vec<f64> = res
        .par_iter()
        .filter(|r| r.used)
        .map(|r| r.delta_e as f64)
        .collect();
    let clamped = res.par_iter().filter(|r| r.used && r.clamped).count();
    // The k-th smallest, as a sort would place it (without sorting millions).
    let mut pct = |p: f64| {
        if de.is_empty() {
            return 0.0;
        }
        let k = ((de.len() as f64 - 1.0) * p).round() as usize;
        *de.select_nth_unstable_by(k, f64::total_cmp).1
    };
    let (median, p95) = (pct(0.5), pct(0.95));
    let report = ChromophoreReport {
        exposure,
        median_delta_e: median,
        p95_delta_e: p95,
        clamped_share: clamped as f64 / de.len().max(1) as f64,
        texels: de.len(),
        flips: flip_share(&res, w, h),
    };
    let map = |f: fn(&Texel) -> f32| {
        Map::from_vec(
            texture.width,
            texture.height,
            res.par_iter().map(f).collect(),
        )
    };
    Ok(Chromophores {
        melanin: map(|r| r.melanin)?,
        hemoglobin: map(|r| r.hemoglobin)?,
        residual: map(|r| r.delta_e)?,
        confidence: Map::from_vec(
            texture.width,
            texture.height,
            res.par_iter()
                .map(|r| {
                    let smin = weaker_sensitivity(r.h);
                    smin / (smin + (smoothness as f32).sqrt()).max(1e-12)
                })
                .collect(),
        )?,
        report,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_lab_table_matches_converting_every_lookup() {
        // Between its nodes the table interpolates Lab; converting the LUT's own bilinear colour
        // at every point is the reference. Its analytic Jacobian matches central differences.
        let lut = SkinColorLut::builtin();
        let t = LabTable::new(&lut);
        let mut worst = 0.0f64;
        for j in 0..=97 {
            for i in 0..=97 {
                let (u, v) = (i as f64 / 97.0, j as f64 / 97.0);
                worst = worst.max(dist2(t.lab(u, v), lab_of(lut.lookup_uv(u, v))).sqrt());
            }
        }
        assert!(worst < 0.001, "ΔE {worst}");
        assert!(worst > 0.0, "the table should interpolate Lab, not convert");
        let (u, v, h) = (0.4137, 0.2911, 1e-6);
        let (_, ju, jv) = t.lab_jacobian(u, v);
        for k in 0..3 {
            let du = (t.lab(u + h, v)[k] - t.lab(u - h, v)[k]) / (2.0 * h);
            let dv = (t.lab(u, v + h)[k] - t.lab(u, v - h)[k]) / (2.0 * h);
            assert!((ju[k] - du).abs() < 1e-5 * (1.0 + du.abs()), "{ju:?} {du}");
            assert!((jv[k] - dv).abs() < 1e-5 * (1.0 + dv.abs()), "{jv:?} {dv}");
        }
    }

    #[test]
    fn lut_colours_invert_to_their_chromophores() {
        let lut = SkinColorLut::builtin();
        let cases = [
            (0.02, 0.01),
            (0.08, 0.05),
            (0.2, 0.12),
            (0.4, 0.03),
            (0.05, 0.25),
        ];
        let tex = RgbImage {
            width: cases.len(),
            height: 1,
            data: cases
                .iter()
                .map(|&(m, h)| lut.lookup(m, h).map(|v| v as f32))
                .collect(),
        };
        // Each texel alone (no spatial prior: the five colours are unrelated).
        let c = invert_with(&lut, &tex, None, 1.0, 0.0).unwrap();
        let de = |a: [f64; 3], b: [f64; 3]| {
            let (a, b) = (lab_of(a), lab_of(b));
            ((a[0] - b[0]).powi(2) + (a[1] - b[1]).powi(2) + (a[2] - b[2]).powi(2)).sqrt()
        };
        for (i, &(m, h)) in cases.iter().enumerate() {
            let (gm, gh) = (c.melanin.data()[i] as f64, c.hemoglobin.data()[i] as f64);
            // The colour of what was found is the colour that was given.
            let found = de(lut.lookup(gm, gh), lut.lookup(m, h));
            assert!(found < 0.1, "({m}, {h}) → ({gm}, {gh}): ΔE {found}");
            assert!(c.residual.data()[i] < 0.5, "ΔE {}", c.residual.data()[i]);
            // The chromophores, as far as the colour tells them apart: in Lab the LUT moves by
            // at least σ_min per unit of relative change in (melanin, hemoglobin) (σ_min, the
            // smaller singular value of its Jacobian there), so a colour found within ΔE δ
            // puts them within δ / σ_min. Under much melanin blood hardly shows, and the two
            // trade against each other along a curve of nearly one colour.
            let base = lab_of(lut.lookup(m, h));
            let col = |dm: f64, dh: f64| {
                let l = lab_of(lut.lookup(m * (1.0 + dm), h * (1.0 + dh)));
                [0, 1, 2].map(|k| (l[k] - base[k]) / 0.01)
            };
            let (jm, jh) = (col(0.01, 0.0), col(0.0, 0.01));
            let dot = |a: [f64; 3], b: [f64; 3]| a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
            let (p, q, r) = (dot(jm, jm), dot(jm, jh), dot(jh, jh));
            let sigma_min = (0.5 * (p + r - ((p - r).powi(2) + 4.0 * q * q).sqrt())).sqrt();
            let err = ((gm / m - 1.0).powi(2) + (gh / h - 1.0).powi(2)).sqrt();
            let bound = (found + 0.02) / sigma_min + 0.005;
            assert!(
                err <= bound,
                "({m}, {h}) → ({gm}, {gh}): relative error {err:.4} above {bound:.4} (σ_min {sigma_min:.2})"
            );
        }
        assert!(c.report.median_delta_e < 0.5);
    }

    #[test]
    fn the_spatial_prior_stops_flips_and_keeps_the_mean() {
        // A patch of one skin colour (C_m 0.15, C_hd 0.06: blood weakly visible under the
        // melanin) with 8-bit-like noise: alone, texels scatter along the curve of nearly one
        // colour; with the prior they stay together, around the truth.
        let lut = SkinColorLut::builtin();
        let (m, h) = (0.15, 0.06);
        let base = lut.lookup(m, h);
        let rng = derma_core::rng::Philox::new(5, 0);
        let n = 48;
        let tex = RgbImage::from_fn(n, n, |i| {
            let g = rng.normal2(i as u64, 0);
            let g2 = rng.normal2(i as u64, 1);
            let noise = [g[0], g[1], g2[0]];
            std::array::from_fn(|k| (base[k] as f32) * (1.0 + 0.012 * noise[k]))
        });
        let spread = |c: &Chromophores| {
            let d = c.hemoglobin.data();
            let mean = d.iter().map(|v| *v as f64).sum::<f64>() / d.len() as f64;
            let sd =
                (d.iter().map(|v| (*v as f64 - mean).powi(2)).sum::<f64>() / d.len() as f64).sqrt();
            (mean, sd)
        };
        let alone = invert_with(&lut, &tex, None, 1.0, 0.0).unwrap();
        let prior = invert(&lut, &tex, None, 1.0).unwrap();
        let (ma, sa) = spread(&alone);
        let (mp, sp) = spread(&prior);
        assert!(
            sp < 0.3 * sa,
            "hemoglobin spread {sp} with the prior, {sa} alone"
        );
        // Noise through the cube root biases both; the prior less (0.067 against 0.074 alone when
        // this was written).
        assert!(
            (mp / h - 1.0).abs() < 0.15 && (mp / h - 1.0).abs() <= (ma / h - 1.0).abs(),
            "hemoglobin mean {mp} (alone {ma})"
        );
        let mm = prior.melanin.data().iter().map(|v| *v as f64).sum::<f64>() / (n * n) as f64;
        assert!((mm / m - 1.0).abs() < 0.05, "melanin mean {mm}");
        assert!(prior.report.flips <= alone.report.flips);
        assert!(prior.report.flips < 0.005, "{:?}", prior.report);
        // Confidence: in (0, 1), lower for this blood-under-melanin colour than for pale skin.
        let pale = invert(
            &lut,
            &RgbImage::filled(4, 4, lut.lookup(0.02, 0.06).map(|v| v as f32)),
            None,
            1.0,
        )
        .unwrap();
        let (cp, cd) = (pale.confidence.data()[5], prior.confidence.data()[100]);
        assert!(
            cd > 0.0 && cd < cp && cp < 1.0,
            "confidence {cd} (dark) vs {cp} (pale)"
        );
    }

    #[test]
    fn a_colour_outside_the_gamut_is_clamped_with_its_residual() {
        let lut = SkinColorLut::builtin();
        // Saturated blue: no skin has it.
        let tex = RgbImage::filled(1, 1, [0.05, 0.1, 0.6]);
        let c = invert(&lut, &tex, None, 1.0).unwrap();
        assert!(c.residual.data()[0] > 20.0, "ΔE {}", c.residual.data()[0]);
        assert_eq!(c.report.clamped_share, 1.0);
        assert!(c.melanin.data()[0].is_finite() && c.hemoglobin.data()[0].is_finite());
    }

    #[test]
    fn the_exposure_of_a_scaled_texture_is_found() {
        let lut = SkinColorLut::builtin();
        let texels: Vec<[f32; 3]> = (0..200)
            .map(|i| {
                let (m, h) = (
                    0.02 + 0.1 * (i % 10) as f64 / 10.0,
                    0.01 + 0.08 * (i / 10) as f64 / 20.0,
                );
                lut.lookup(m, h).map(|v| (v * 1.6) as f32)
            })
            .collect();
        let e = fit_exposure(&lut, &texels);
        assert!((e / 1.6 - 1.0).abs() < 0.05, "exposure {e}");
    }
}

//! The Monte Carlo appearance: bio parameters → base colour and subsurface parameters through a
//! model-match table (thesis §4.8.6, mmd), interpolated in the grid's cells (∛ along melanin and
//! blood). This is the texture-set path, so the table is compiled to a compact f32 form for 16-megapixel maps.

use crate::appearance::{Appearance, BioTexel, Subsurface};
use crate::error::{Result, ShadingError};
use crate::match_table::MatchTable;
use crate::model_kind::ModelKind;
use derma_core::numerics::fastmath::{cbrt_f32, exp_f32};
use std::path::Path;

/// Values kept per node: base colour (3), subsurface colour (3), scatter distance (3), padded
/// to 12 so each node is three 4-lane vectors.
const N: usize = 12;
/// The colours (the first six values) are kept as logarithms and interpolated geometrically:
/// a reflectance falls off as e^(−absorbance) (Beer–Lambert) and the epidermis' absorbance is
/// melanin × thickness, a product multilinear interpolation reproduces exactly in the
/// logarithm but not in the value itself. Measured on the committed table: ΔE*ab at 24
/// off-node points 2.41 → 1.57 (docs/matching.md). Scatter distances stay linear.
const LOG_VALUES: usize = 6;
/// Floor before the logarithm (a reflectance below it is black for any 16-bit map).
const LOG_FLOOR: f32 = 1e-6;
const MAX_AXES: usize = 6;
/// Most nodes per axis the compiled form takes.
const MAX_NODES: usize = 16;

/// The committed default table (see docs/matching.md for the command that rebuilds it).
pub const BUILTIN_TABLE: &[u8] = include_bytes!("../data/match-table.dtab");

/// Where the base colour comes from.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum BaseColor {
    /// kd of the fitted glTF GGX model: what a glTF/Unreal/Unity metallic-roughness material
    /// needs to reproduce the simulated BRDF's diffuse part.
    GgxFit,
    /// The Monte Carlo diffuse reflectance under diffuse light.
    DiffuseAlbedo,
}

/// How values between nodes are found.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Interpolation {
    /// Multilinear in the surrounding hypercube (thesis §4.8.6, after Wagner): 2^d reads.
    Multilinear,
    /// Kuhn-simplex interpolation in the same cell (Kasson, Nin, Plouffe & Hafner 1995): d + 1
    /// reads; equal to multilinear at nodes and along cell edges, piecewise linear inside.
    /// The texture-set default: about half the time of multilinear (BENCHMARKS.md).
    Simplex,
}

/// An [`Appearance`] backed by a match table.
pub struct TableAppearance {
    /// How values are interpolated between nodes.
    pub interpolation: Interpolation,
    /// Axes with ≥ 2 nodes, in fixed arrays for the inner loop: how many, their BioTexel
    /// field, node positions (padded with +∞), reciprocal node spacings and node strides.
    d: usize,
    field: [usize; MAX_AXES],
    nodes: [[f32; MAX_NODES]; MAX_AXES],
    inv_step: [[f32; MAX_NODES]; MAX_AXES],
    n_nodes: [usize; MAX_AXES],
    stride: [usize; MAX_AXES],
    /// Active axes interpolated in ∛x (`match_table::interpolates_in_cube_root`).
    cube_root: [bool; MAX_AXES],
    /// Node offset of each corner of the sub-cube spanned by active axes 1.. (bit k−1 of the
    /// index: upper node on active axis k); axis 0 is folded in while gathering.
    corner: Vec<usize>,
    values: Vec<[f32; N]>,
    /// Where the base colour comes from.
    pub base: BaseColor,
    /// The table's surface fit ([`crate::surface_fit`]), when it has one.
    specular: Option<crate::appearance::SurfaceSpecular>,
    /// The largest relative RMS of the table's subsurface (Burley) fit over its nodes: how far
    /// the colours it gives may be from the transport they were fitted to.
    pub subsurface_rms: f64,
}

/// The subsurface fit's relative RMS above which a match table's colours are not trusted
/// without a warning: the built-in table's worst node is 0.107 (test below).
pub const TRUSTED_RMS: f64 = 0.15;

impl TableAppearance {
    /// Compiles `table` with the Monte Carlo diffuse albedo as base colour (the meaning the
    /// [`Appearance`] trait and the analytic model give it).
    pub fn new(table: &MatchTable) -> Result<Self> {
        Self::with_base(table, BaseColor::DiffuseAlbedo)
    }

    /// Compiles `table` with the chosen base colour.
    pub fn with_base(table: &MatchTable, base: BaseColor) -> Result<Self> {
        let h = &table.dtab.header;
        // Each value read is an RGB triple: a table whose value is shorter is refused by name,
        // not read past its row.
        let need = |name: &str| {
            let (o, n) = h.offset(name).ok_or_else(|| {
                ShadingError::Invalid(derma_core::Invalid::new(
                    format!("value '{name}' of the match table"),
                    "a value every derma match table has (make one with `derma match fit`)",
                    "none",
                ))
            })?;
            if n < 3 {
                return Err(ShadingError::Invalid(derma_core::Invalid::new(
                    format!("value '{name}' of the match table"),
                    "at least 3 floats (red, green, blue)",
                    format!("{n}"),
                )));
            }
            Ok((o, n))
        };
        let (ob, _) = match base {
            BaseColor::GgxFit => need(ModelKind::Ggx.name())?,
            BaseColor::DiffuseAlbedo => need("albedo")?,
        };
        let (oc, _) = need("burley.albedo")?;
        let (or, _) = need("burley.mfp_mm")?;
        let stride = h.stride();
        let values = (0..h.nodes())
            .map(|n| {
                let row = &table.dtab.data[n * stride..(n + 1) * stride];
                let mut v = [0.0; N];
                v[0..3].copy_from_slice(&row[ob..ob + 3]);
                v[3..6].copy_from_slice(&row[oc..oc + 3]);
                v[6..9].copy_from_slice(&row[or..or + 3]);
                for x in &mut v[..LOG_VALUES] {
                    *x = x.max(LOG_FLOOR).ln();
                }
                v
            })
            .collect();
        let strides = table.strides();
        let mut active = Vec::new();
        for (field, name) in crate::match_table::BIO_AXES.iter().enumerate() {
            let k = h
                .axes
                .iter()
                .position(|a| a.name == *name)
                .expect("checked");
            let a = &h.axes[k];
            if a.values.len() > MAX_NODES {
                return Err(ShadingError::Invalid(derma_core::Invalid::new(
                    format!("nodes of match table axis '{name}'"),
                    format!("at most {MAX_NODES}"),
                    a.values.len(),
                )));
            }
            if a.values.len() >= 2 {
                let cube_root = crate::match_table::interpolates_in_cube_root(name);
                let v = if cube_root {
                    a.values.iter().map(|x| x.cbrt()).collect()
                } else {
                    a.values.clone()
                };
                active.push((field, v, strides[k], cube_root));
            }
        }
        let d = active.len();
        let mut field = [0; MAX_AXES];
        let mut nodes = [[f32::INFINITY; MAX_NODES]; MAX_AXES];
        let mut inv_step = [[0.0; MAX_NODES]; MAX_AXES];
        let mut n_nodes = [1; MAX_AXES];
        let mut stride = [0; MAX_AXES];
        let mut cube_root = [false; MAX_AXES];
        for (k, (f, v, st, c)) in active.iter().enumerate() {
            field[k] = *f;
            cube_root[k] = *c;
            n_nodes[k] = v.len();
            stride[k] = *st;
            for (i, &x) in v.iter().enumerate() {
                nodes[k][i] = x as f32;
                if i + 1 < v.len() {
                    inv_step[k][i] = (1.0 / (v[i + 1] - x)) as f32;
                }
            }
        }
        let corner = (0..1usize << d.saturating_sub(1))
            .map(|m| {
                active
                    .iter()
                    .skip(1)
                    .enumerate()
                    .filter(|(k, _)| m >> k & 1 == 1)
                    .map(|(_, a)| a.2)
                    .sum()
            })
            .collect();
        Ok(Self {
            interpolation: Interpolation::Simplex,
            d,
            field,
            nodes,
            inv_step,
            n_nodes,
            stride,
            cube_root,
            corner,
            values,
            base,
            specular: table.surface_fit().map(|f| f.specular()),
            subsurface_rms: table.worst_rms("burley").unwrap_or(0.0),
        })
    }

    /// The committed default table.
    pub fn builtin() -> Self {
        let dtab =
            derma_core::dtab::Dtab::from_bytes(BUILTIN_TABLE, Path::new("<built-in match table>"))
                .expect("the built-in match table is valid");
        let t = MatchTable::new(dtab, Path::new("<built-in match table>"))
            .expect("the built-in match table is a match table");
        Self::new(&t).expect("the built-in match table has the values")
    }

    /// Reads a match table (.dtab from `derma match fit`).
    pub fn read(path: &Path) -> Result<Self> {
        Self::new(&MatchTable::read(path)?)
    }

    /// The nine values at `bio` (base colour, subsurface colour, scatter distance; 3 padding).
    #[inline]
    pub fn lookup(&self, bio: &BioTexel) -> [f32; N] {
        self.lookup_with(bio, self.interpolation)
    }

    /// The values at `bio` with the given interpolation.
    #[inline]
    pub fn lookup_with(&self, bio: &BioTexel, interpolation: Interpolation) -> [f32; N] {
        let mut v = self.interpolate(bio, interpolation);
        for x in &mut v[..LOG_VALUES] {
            *x = exp_f32(*x);
        }
        v
    }

    /// The stored values at `bio` (colours as logarithms), interpolated.
    #[inline]
    fn interpolate(&self, bio: &BioTexel, interpolation: Interpolation) -> [f32; N] {
        let f = bio.to_array();
        let d = self.d;
        let mut base = 0usize;
        let mut t = [0.0f32; MAX_AXES];
        for k in 0..d {
            let nodes = &self.nodes[k];
            let n = self.n_nodes[k];
            // Branch-free interval search: count the inner nodes at or below x (node
            // coordinates are ∛ of the values on cube-root axes).
            let x = f[self.field[k]];
            // (∛ of 0 comes out tiny and positive: below the first node, clamped to it.)
            // Negative and NaN inputs fall to the first node: `max` and `min` take the number
            // (as the SIMD lanes of `lookup_batch` do).
            let x = if self.cube_root[k] {
                cbrt_f32(x.max(0.0))
            } else {
                x
            };
            let x = x.max(nodes[0]).min(nodes[n - 1]);
            let above = nodes[1..].iter().map(|&v| (v <= x) as usize).sum::<usize>();
            let i = above.min(n - 2);
            t[k] = ((x - nodes[i]) * self.inv_step[k][i]).clamp(0.0, 1.0);
            base += i * self.stride[k];
        }
        if d == 0 {
            return self.values[base];
        }
        if interpolation == Interpolation::Simplex {
            // Kuhn simplex: walk from the lower corner along axes in decreasing fraction.
            // Axes by decreasing fraction, ranked without data-dependent branches.
            let mut order = [0usize; MAX_AXES];
            for k in 0..d {
                let mut rank = 0;
                for j in 0..d {
                    rank += ((t[j] > t[k]) | ((t[j] == t[k]) & (j < k))) as usize;
                }
                order[rank] = k;
            }
            let mut idx = base;
            let mut out = as_lanes(&self.values[idx]);
            let w0 = 1.0 - t[order[0]];
            for g in &mut out {
                for v in g.iter_mut() {
                    *v *= w0;
                }
            }
            for j in 0..d {
                idx += self.stride[order[j]];
                let w = t[order[j]] - if j + 1 < d { t[order[j + 1]] } else { 0.0 };
                let v = as_lanes(&self.values[idx]);
                for g in 0..3 {
                    for l in 0..4 {
                        out[g][l] += w * v[g][l];
                    }
                }
            }
            return std::array::from_fn(|j| out[j / 4][j % 4]);
        }
        // Multilinear interpolation as repeated linear interpolation: lerp along axis 0 while
        // gathering the 2^d corners, then halve along the highest remaining axis. Values are
        // handled as three 4-lane groups so the compiler emits packed SIMD arithmetic.
        let mut buf = [[[0.0f32; 4]; 3]; 1 << (MAX_AXES - 1)];
        let mut n = 1usize << (d - 1);
        let (s0, t0) = (self.stride[0], t[0]);
        for (b, &off) in buf[..n].iter_mut().zip(&self.corner) {
            let lo = as_lanes(&self.values[base + off]);
            let hi = as_lanes(&self.values[base + off + s0]);
            for g in 0..3 {
                b[g] = lerp4(lo[g], hi[g], t0);
            }
        }
        for k in (1..d).rev() {
            n /= 2;
            let w = t[k];
            let (lo, hi) = buf.split_at_mut(n);
            for (a, b) in lo.iter_mut().zip(&hi[..n]) {
                for g in 0..3 {
                    a[g] = lerp4(a[g], b[g], w);
                }
            }
        }
        let b = &buf[0];
        std::array::from_fn(|j| b[j / 4][j % 4])
    }
}

/// Texels interpolated together by [`TableAppearance::lookup_batch`]: eight f32 lanes fill an
/// AVX2 register.
pub const LANES: usize = 8;

impl TableAppearance {
    /// [`Self::lookup`] of many texels (simplex interpolation), eight at a time: the cell search,
    /// the fractions' ranking, the weights, ∛ and e^x run across texels in SIMD lanes
    /// ([`derma_core::numerics::lanes`], where the CPU has AVX2; texel by texel otherwise). The
    /// lanes perform [`Self::lookup`]'s IEEE operations in the same order, so the values are
    /// identical on every path.
    pub fn lookup_batch(&self, bio: &[BioTexel], out: &mut [[f32; N]]) {
        assert_eq!(bio.len(), out.len(), "one output per texel");
        #[cfg(target_arch = "x86_64")]
        if self.interpolation == Interpolation::Simplex && self.d > 0 {
            if let Some(t) = derma_core::numerics::lanes::Avx2::detect() {
                // SAFETY: the token proves the CPU has AVX2 and FMA.
                unsafe { self.lookup_batch_avx2(t, bio, out) };
                return;
            }
        }
        for (o, b) in out.iter_mut().zip(bio) {
            *o = self.lookup(b);
        }
    }

    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2,fma")]
    unsafe fn lookup_batch_avx2(
        &self,
        tok: derma_core::numerics::lanes::Avx2,
        bio: &[BioTexel],
        out: &mut [[f32; N]],
    ) {
        for (b, o) in bio.chunks(LANES).zip(out.chunks_mut(LANES)) {
            if b.len() == LANES {
                self.simplex_avx2(tok, b.try_into().expect("a full block"), o);
            } else {
                // The last, partial block: padded with its first texel.
                let block: [BioTexel; LANES] = std::array::from_fn(|l| b[l.min(b.len() - 1)]);
                let mut res = [[0.0f32; N]; LANES];
                self.simplex_avx2(tok, &block, &mut res);
                o.copy_from_slice(&res[..b.len()]);
            }
        }
    }

    /// Kuhn-simplex interpolation and e^x of the colours for one block of eight texels: the
    /// operations of [`Self::interpolate`] and [`Self::lookup_with`], lane by lane.
    #[cfg(target_arch = "x86_64")]
    #[inline(always)]
    fn simplex_avx2(
        &self,
        tok: derma_core::numerics::lanes::Avx2,
        bio: &[BioTexel; LANES],
        out: &mut [[f32; N]],
    ) {
        use derma_core::numerics::lanes::{Avx2F32 as F32x8, Avx2I32 as I32x8, IntLanes, Lanes};
        let d = self.d;
        let splat = |v: f32| F32x8::splat(tok, v);
        let mut base = I32x8::splat(tok, 0);
        let mut t = [splat(0.0); MAX_AXES];
        for k in 0..d {
            let (nodes, inv_step, n) = (&self.nodes[k], &self.inv_step[k], self.n_nodes[k]);
            let f = self.field[k];
            let x = F32x8::from_array(tok, std::array::from_fn(|l| bio[l].to_array()[f]));
            let x = if self.cube_root[k] {
                x.max(splat(0.0)).cbrt()
            } else {
                x
            };
            let x = x.max(splat(nodes[0])).min(splat(nodes[n - 1]));
            // The cell: the inner nodes at or below x, counted (a set mask is −1).
            let (mut lo, mut inv, mut i) =
                (splat(nodes[0]), splat(inv_step[0]), I32x8::splat(tok, 0));
            for j in 1..n - 1 {
                let ge = x.ge(splat(nodes[j]));
                lo = ge.select(splat(nodes[j]), lo);
                inv = ge.select(splat(inv_step[j]), inv);
                i = i.sub(ge.to_bits());
            }
            t[k] = x.sub(lo).mul(inv).clamp(0.0, 1.0);
            base = base.add(i.mul(I32x8::splat(tok, self.stride[k] as i32)));
        }
        // Ranks of the fractions, largest first, ties to the lower axis: axis j outranks k
        // when t_j > t_k, or t_j = t_k and j < k.
        let mut rank = [[0i32; LANES]; MAX_AXES];
        for k in 0..d {
            let mut r = I32x8::splat(tok, 0);
            for j in 0..d {
                let above = match j.cmp(&k) {
                    std::cmp::Ordering::Less => t[j].ge(t[k]),
                    std::cmp::Ordering::Greater => t[j].gt(t[k]),
                    std::cmp::Ordering::Equal => continue,
                };
                r = r.sub(above.to_bits());
            }
            rank[k] = r.to_array();
        }
        let ts: [[f32; LANES]; MAX_AXES] = std::array::from_fn(|k| t[k].to_array());
        let base = base.to_array();
        for l in 0..LANES {
            let mut order = [0usize; MAX_AXES];
            for k in 0..d {
                order[rank[k][l] as usize] = k;
            }
            let mut idx = base[l] as usize;
            let row = |idx: usize| {
                let v = &self.values[idx];
                let (a, b): ([f32; 8], [f32; 8]) = (
                    v[..8].try_into().expect("8 values"),
                    v[4..].try_into().expect("8 values"),
                );
                (F32x8::from_array(tok, a), F32x8::from_array(tok, b))
            };
            let (v0, v1) = row(idx);
            let w0 = splat(1.0 - ts[order[0]][l]);
            let (mut a, mut b) = (v0.mul(w0), v1.mul(w0));
            for j in 0..d {
                idx += self.stride[order[j]];
                let w = ts[order[j]][l] - if j + 1 < d { ts[order[j + 1]][l] } else { 0.0 };
                let (va, vb) = row(idx);
                let w = splat(w);
                a = a.add(w.mul(va));
                b = b.add(w.mul(vb));
            }
            // The second half starts at value 4.
            let (a, b) = (a.to_array(), b.to_array());
            out[l] = std::array::from_fn(|j| if j < 8 { a[j] } else { b[j - 4] });
        }
        // The colours back from logarithms, each value across the block's lanes.
        for c in 0..LOG_VALUES {
            let e = F32x8::from_array(tok, std::array::from_fn(|l| out[l][c]))
                .exp()
                .to_array();
            for l in 0..LANES {
                out[l][c] = e[l];
            }
        }
    }
}

#[inline(always)]
fn as_lanes(v: &[f32; N]) -> [[f32; 4]; 3] {
    [
        [v[0], v[1], v[2], v[3]],
        [v[4], v[5], v[6], v[7]],
        [v[8], v[9], v[10], v[11]],
    ]
}

#[inline(always)]
fn lerp4(a: [f32; 4], b: [f32; 4], t: f32) -> [f32; 4] {
    [
        a[0] + t * (b[0] - a[0]),
        a[1] + t * (b[1] - a[1]),
        a[2] + t * (b[2] - a[2]),
        a[3] + t * (b[3] - a[3]),
    ]
}

impl Appearance for TableAppearance {
    fn name(&self) -> &'static str {
        "match-table"
    }
    fn albedo(&self, bio: &BioTexel) -> [f32; 3] {
        let v = self.lookup(bio);
        [v[0], v[1], v[2]]
    }
    fn subsurface(&self, bio: &BioTexel) -> Option<Subsurface> {
        self.shade(bio).1
    }
    fn specular(&self) -> Option<crate::appearance::SurfaceSpecular> {
        self.specular
    }
    fn shade(&self, bio: &BioTexel) -> ([f32; 3], Option<Subsurface>) {
        shade_of(&self.lookup(bio))
    }
    fn shade_batch(&self, bio: &[BioTexel], out: &mut [([f32; 3], Option<Subsurface>)]) {
        let mut v = [[0.0f32; N]; 64];
        for (b, o) in bio.chunks(64).zip(out.chunks_mut(64)) {
            let v = &mut v[..b.len()];
            self.lookup_batch(b, v);
            for (o, v) in o.iter_mut().zip(v.iter()) {
                *o = shade_of(v);
            }
        }
    }
}

/// A looked-up node row as base colour and subsurface parameters.
#[inline]
fn shade_of(v: &[f32; N]) -> ([f32; 3], Option<Subsurface>) {
    (
        [v[0], v[1], v[2]],
        Some(Subsurface {
            color: [v[3], v[4], v[5]],
            radius_mm: [v[6], v[7], v[8]],
        }),
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The built-in table is trusted (no warning on the default run); a table whose fit missed
    /// is not (the warning derma skin gives with such a --table).
    #[test]
    fn the_builtin_tables_fit_is_trusted_and_a_poor_one_is_not() {
        let t = TableAppearance::builtin();
        println!(
            "built-in subsurface relative RMS, worst node: {:.4}",
            t.subsurface_rms
        );
        assert!(t.subsurface_rms > 0.0 && t.subsurface_rms < TRUSTED_RMS);
        let mut table = builtin_table();
        let (o, _) = table.dtab.header.offset("burley.rms").unwrap();
        let s = table.dtab.header.stride();
        table.dtab.data[3 * s + o] = 0.74;
        assert_eq!(
            TableAppearance::new(&table).unwrap().subsurface_rms,
            0.74f32 as f64
        );
    }

    fn builtin_table() -> MatchTable {
        let dtab = derma_core::dtab::Dtab::from_bytes(BUILTIN_TABLE, Path::new("builtin")).unwrap();
        MatchTable::new(dtab, Path::new("builtin")).unwrap()
    }

    fn texel(p: &[f64]) -> BioTexel {
        BioTexel::from_array(std::array::from_fn(|k| p[k] as f32))
    }

    #[test]
    fn compiled_lookup_matches_the_table() {
        let mt = builtin_table();
        let ta = TableAppearance::new(&mt).unwrap();
        let axes: Vec<Vec<f64>> = mt
            .dtab
            .header
            .axes
            .iter()
            .map(|a| a.values.clone())
            .collect();
        let rng = derma_core::rng::Philox::new(9, 0);
        for k in 0..200u64 {
            let u = rng.uniform4(k, 0);
            let v = rng.uniform4(k, 1);
            let r = [u[0], u[1], u[2], u[3], v[0], v[1]];
            // Every 4th point sits on a node (exactness), the rest anywhere in the cell.
            let p: Vec<f64> = axes
                .iter()
                .zip(r)
                .map(|(a, r)| {
                    let x = r as f64 * (a.len() - 1) as f64;
                    let x = if k % 4 == 0 { x.round() } else { x };
                    let i = (x.floor() as usize).min(a.len().saturating_sub(2));
                    if a.len() == 1 {
                        a[0]
                    } else {
                        a[i] + (a[i + 1] - a[i]) * (x - i as f64)
                    }
                })
                .collect();
            let bio = texel(&p);
            let want = mt.value_at_geometric(&mt.coords(&bio), "albedo").unwrap();
            let sss = mt.value_at(&mt.coords(&bio), "burley.mfp_mm").unwrap();
            let ml = ta.lookup_with(&bio, Interpolation::Multilinear);
            let sx = ta.lookup_with(&bio, Interpolation::Simplex);
            for c in 0..3 {
                assert!((ml[c] as f64 - want[c]).abs() < 1e-5, "{p:?}");
                assert!((ml[6 + c] as f64 - sss[c]).abs() < 1e-4 * sss[c].max(1.0));
                if k % 4 == 0 {
                    assert!((sx[c] as f64 - want[c]).abs() < 1e-5, "node {p:?}");
                }
                // Inside cells simplex and multilinear differ by little on this table.
                assert!((sx[c] - ml[c]).abs() < 0.02, "{p:?}: {sx:?} vs {ml:?}");
            }
        }
    }

    #[test]
    fn batches_equal_single_lookups_bit_for_bit() {
        // Texels across and beyond the table's ranges (clamped), 203 of them: full blocks and a
        // partial one (on a CPU without AVX2 both sides are the scalar path).
        let ta = TableAppearance::builtin();
        let rng = derma_core::rng::Philox::new(3, 0);
        let bio = (0..203u64)
            .map(|i| {
                let (u, v) = (rng.uniform4(i, 0), rng.uniform4(i, 1));
                BioTexel {
                    melanin: 0.45 * u[0] * u[0] - 0.01,
                    pheomelanin: 1.2 * u[1] - 0.1,
                    blood: 0.12 * u[2],
                    oxygenation: u[3],
                    stratum_corneum_um: 5.0 + 20.0 * v[0],
                    epidermis_um: 30.0 + 100.0 * v[1],
                }
            })
            .collect::<Vec<_>>();
        // NaN inputs fall to the first node on both paths.
        let mut bio = bio;
        bio[5].blood = f32::NAN;
        bio[6].pheomelanin = f32::NAN;
        let mut fast = vec![[0.0f32; N]; bio.len()];
        ta.lookup_batch(&bio, &mut fast);
        for (k, b) in bio.iter().enumerate() {
            let one = ta.lookup(b).map(f32::to_bits);
            assert_eq!(fast[k].map(f32::to_bits), one, "texel {k}: {b:?}");
        }
    }

    #[test]
    fn colours_interpolate_geometrically_in_cube_root_melanin() {
        // Between two melanin nodes, every other axis on a node: the base colour is the
        // weighted geometric mean of the nodes' colours, with the weight linear in ∛melanin.
        let mt = builtin_table();
        let ta = TableAppearance::new(&mt).unwrap();
        let h = &mt.dtab.header;
        let mel = h.axes.iter().position(|a| a.name == "melanin").unwrap();
        let nodes = h.axes[mel].values.clone();
        let mut p: Vec<f64> = h.axes.iter().map(|a| a.values[0]).collect();
        let (lo, hi) = (nodes[3], nodes[4]);
        let at = |x: f64, p: &mut Vec<f64>| {
            p[mel] = x;
            let v = ta.lookup(&texel(p));
            [v[0] as f64, v[1] as f64, v[2] as f64]
        };
        let (a, b) = (at(lo, &mut p), at(hi, &mut p));
        for t in [0.25, 0.5, 0.8] {
            let x = (lo.cbrt() + t * (hi.cbrt() - lo.cbrt())).powi(3);
            let v = at(x, &mut p);
            for c in 0..3 {
                let want = a[c].powf(1.0 - t) * b[c].powf(t);
                assert!(
                    (v[c] - want).abs() < 1e-5 * want,
                    "t {t} c {c}: {v:?} vs {want}"
                );
                // Strictly below the straight line in x (the old interpolation's overestimate).
                let xt = (x - lo) / (hi - lo);
                assert!(v[c] < a[c] * (1.0 - xt) + b[c] * xt);
            }
        }
    }
}

//! A single-chart parameterisation of a disc over [0, 1]² that minimises texture stretch with
//! Tarini et al. 2002's view-dependent weight (§3.1, after Sander et al. 2001's L² stretch).
//!
//! The start is the least-squares conformal map (Lévy et al. 2002) when it is flip-free, else
//! Tutte's embedding (positive harmonic weights, boundary on a circle; Floater 2003). Then the
//! symmetric Dirichlet energy (Smith & Schaefer 2015), a barrier against flips whose minimum is
//! the isometry, is lowered by Accelerated Quadratic Proxy steps (Kovalsky et al. 2016: the
//! Laplacian, factorised once, as the proxy Hessian; Nesterov extrapolation), each cut to the
//! largest flip-free step (Smith & Schaefer 2015 §3.2) and backtracked to sufficient decrease.
//!
//! The weight. §3.1 sets ω(T) = 1/(⟨N(T), V⟩ + k) and says the face grows in texture space and
//! the back of the head shrinks. For a conformal texture scale σ, Sander's stretch is 1/σ; the
//! minimiser of Σ ω A′ σ⁻² at a fixed texture area Σ A′ σ² is σ ∝ ω^¼ (Lagrange). That grows
//! the face only when ⟨N, V⟩ → −1 on it, so V here is the direction of view *onto* the face
//! (derma's heads face +Z: V = −Z), and each triangle's target scale is ω^¼.

use crate::error::{PhotoError, Result};
use crate::topology::Topology;
use derma_core::mesh::TriMesh;
use derma_core::numerics::sparse::SparseCholesky;
use glam::{DVec2, DVec3, Vec2, Vec3};
use rayon::prelude::*;
use serde::Serialize;

/// Settings of [`unwrap`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct UnwrapOptions {
    /// Direction of view onto the face (V of §3.1); `None` = view-independent (ω = 1).
    pub view: Option<Vec3>,
    /// k of ω = 1/(⟨N, V⟩ + k), in [1.01, 2] (§3.1).
    pub k: f32,
    /// Most local/global iterations.
    pub iterations: usize,
    /// Stop when ten iterations together lower the energy by less than ten times this fraction.
    pub tolerance: f64,
    /// Empty border around the chart, as a fraction of the square (room for dilation and mips).
    pub margin: f32,
}

impl Default for UnwrapOptions {
    fn default() -> Self {
        Self {
            view: None,
            k: 1.2,
            iterations: 1000,
            tolerance: 1e-5,
            margin: 0.01,
        }
    }
}

impl UnwrapOptions {
    /// Checks k.
    pub fn check(&self) -> Result<()> {
        if !(1.01..=2.0).contains(&self.k) {
            return Err(PhotoError::Invalid(derma_core::Invalid::new(
                "unwrap k",
                "1.01–2 (Tarini et al. 2002 §3.1)",
                self.k,
            )));
        }
        if !(0.0..0.25).contains(&self.margin) {
            return Err(PhotoError::Invalid(derma_core::Invalid::new(
                "unwrap margin",
                "0–0.25 of the square",
                self.margin,
            )));
        }
        if let Some(v) = self.view {
            if !v.is_finite() || v.length() < 1e-6 {
                return Err(PhotoError::Invalid(derma_core::Invalid::new(
                    "unwrap view direction",
                    "a vector such as 0,0,-1 (or none for a view-independent layout)",
                    format!("({}, {}, {}), which has no direction", v.x, v.y, v.z),
                )));
            }
        }
        Ok(())
    }
}

/// Stretch of a parameterisation (Sander et al. 2001 §3), normalised so that 1 is isometric up
/// to one global scale.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct Stretch {
    /// L² stretch over the mesh (area-weighted RMS of the per-triangle L²), ≥ 1.
    pub l2: f64,
    /// L^∞ stretch: the largest singular value of any triangle's texture→surface map.
    pub linf: f64,
    /// The L² stretch with §3.1's weight ω (equals `l2` without a view).
    pub weighted_l2: f64,
    /// Triangles with zero or negative texture area.
    pub flipped: usize,
}

/// An unwrapped mesh.
pub struct Unwrap {
    /// The welded mesh with its new UVs in [0, 1]² and recomputed normals.
    pub mesh: TriMesh,
    /// Stretch of the result.
    pub stretch: Stretch,
    /// Stretch of the Tutte start.
    pub tutte_stretch: Stretch,
    /// Local/global iterations run.
    pub iterations: usize,
}

/// Per-triangle geometry in its own 2D frame.
#[derive(Clone, Copy)]
struct Frame {
    /// Gradient operator: ∇f = g · (f₀, f₁, f₂), rows x and y.
    g: [[f64; 3]; 2],
    /// Area (normalised mesh).
    area: f64,
    /// Energy weight c = ω A.
    c: f64,
    /// Target scale s = ω^¼ (normalised).
    s: f64,
    /// ω.
    omega: f64,
}

fn frame(p: [DVec3; 3]) -> ([[f64; 3]; 2], f64) {
    let e1 = p[1] - p[0];
    let e2 = p[2] - p[0];
    let x1 = e1.length();
    let n = e1.cross(e2);
    let x2x = e2.dot(e1) / x1;
    let x2y = n.length() / x1;
    let det = x1 * x2y;
    // ∇f = E⁻ᵀ (f₁ − f₀, f₂ − f₀) with E = [[x₁, x₂ₓ], [0, x₂ᵧ]].
    let gx = [-x2y / det, x2y / det, 0.0];
    let gy = [(x2x - x1) / det, -x2x / det, x1 / det];
    ([gx, gy], 0.5 * det)
}

/// J = [[∂u/∂x, ∂u/∂y], [∂v/∂x, ∂v/∂y]] of a triangle under `uv`.
fn jacobian(f: &Frame, uv: [DVec2; 3]) -> [[f64; 2]; 2] {
    let d = |row: usize, c: usize| {
        f.g[row][0] * uv[0][c] + f.g[row][1] * uv[1][c] + f.g[row][2] * uv[2][c]
    };
    [[d(0, 0), d(1, 0)], [d(0, 1), d(1, 1)]]
}

/// The texture→surface stretch (Γ², γ² sum and Γ) of a triangle with surface→texture Jacobian
/// J: the inverse map's singular values are 1/σᵢ of J's.
fn triangle_stretch(j: [[f64; 2]; 2]) -> Option<(f64, f64)> {
    let det = j[0][0] * j[1][1] - j[0][1] * j[1][0];
    if det <= 0.0 {
        return None;
    }
    // Singular values of J: σ₁² + σ₂² = ‖J‖²_F, σ₁σ₂ = det.
    let f2 = j[0][0].powi(2) + j[0][1].powi(2) + j[1][0].powi(2) + j[1][1].powi(2);
    let disc = ((f2 * f2 - 4.0 * det * det).max(0.0)).sqrt();
    let s_max2 = 0.5 * (f2 + disc);
    let s_min2 = (0.5 * (f2 - disc)).max(det * det / s_max2);
    // Of the inverse: 1/σ₂² + 1/σ₁² and max 1/σ₂.
    Some((1.0 / s_min2 + 1.0 / s_max2, (1.0 / s_min2).sqrt()))
}

fn measure(frames: &[Frame], tris: &[[u32; 3]], uv: &[DVec2]) -> Stretch {
    let (mut sum, mut wsum, mut area3, mut warea, mut area2, mut linf) =
        (0.0, 0.0, 0.0, 0.0, 0.0, 0.0f64);
    let mut flipped = 0;
    for (f, t) in frames.iter().zip(tris) {
        let c = t.map(|i| uv[i as usize]);
        let j = jacobian(f, c);
        let det = j[0][0] * j[1][1] - j[0][1] * j[1][0];
        area3 += f.area;
        warea += f.omega * f.area;
        match triangle_stretch(j) {
            Some((s2, smax)) => {
                sum += 0.5 * s2 * f.area;
                wsum += 0.5 * s2 * f.area * f.omega;
                linf = linf.max(smax);
                area2 += det * f.area;
            }
            None => flipped += 1,
        }
    }
    // Normalise by the global scale: √(texture area / surface area).
    let norm = (area2 / area3).sqrt();
    Stretch {
        l2: (sum / area3).sqrt() * norm,
        linf: linf * norm,
        weighted_l2: (wsum / warea).sqrt() * norm,
        flipped,
    }
}

/// Triangles per partial sum: the energies are summed per fixed chunk and the chunks in order,
/// the same sum at any thread count.
const CHUNK: usize = 2048;

/// The symmetric Dirichlet energy Σ c (‖J/s‖² + ‖(J/s)⁻¹‖²) (Smith & Schaefer 2015 eq. 2 with
/// §3.1's per-triangle target scale s), infinite when a triangle flips, and its gradient per
/// vertex (gathered per vertex over its triangles, so both cores work and the order is fixed).
struct Energy<'a> {
    frames: &'a [Frame],
    tris: &'a [[u32; 3]],
    /// Each vertex's (triangle, corner) pairs: `incident[start[v]..start[v + 1]]`.
    start: Vec<u32>,
    incident: Vec<(u32, u8)>,
    /// ∂E/∂uv of every triangle's three corners, reused between gradients.
    corners: Vec<[DVec2; 3]>,
}

/// One triangle's Jacobian J with det J, ‖J‖², its target scale² and its energy.
struct Term {
    j: [[f64; 2]; 2],
    det: f64,
    n2: f64,
    s2: f64,
    energy: f64,
}

/// One triangle's [`Term`], or `None` when it is flipped.
fn sd_term(f: &Frame, t: &[u32; 3], uv: &[DVec2]) -> Option<Term> {
    let j = jacobian(f, t.map(|i| uv[i as usize]));
    let det = j[0][0] * j[1][1] - j[0][1] * j[1][0];
    if det <= 0.0 {
        return None;
    }
    let n2 = j[0][0].powi(2) + j[0][1].powi(2) + j[1][0].powi(2) + j[1][1].powi(2);
    let s2 = f.s * f.s;
    Some(Term {
        j,
        det,
        n2,
        s2,
        energy: f.c * (n2 / s2 + s2 * n2 / (det * det)),
    })
}

impl<'a> Energy<'a> {
    fn new(frames: &'a [Frame], tris: &'a [[u32; 3]], vertices: usize) -> Self {
        let mut start = vec![0u32; vertices + 1];
        for t in tris {
            for &v in t {
                start[v as usize + 1] += 1;
            }
        }
        for v in 0..vertices {
            start[v + 1] += start[v];
        }
        let mut fill = start.clone();
        let mut incident = vec![(0u32, 0u8); 3 * tris.len()];
        for (i, t) in tris.iter().enumerate() {
            for (corner, &v) in t.iter().enumerate() {
                incident[fill[v as usize] as usize] = (i as u32, corner as u8);
                fill[v as usize] += 1;
            }
        }
        Self {
            frames,
            tris,
            start,
            incident,
            corners: vec![[DVec2::ZERO; 3]; tris.len()],
        }
    }

    /// E(uv).
    fn value(&self, uv: &[DVec2]) -> f64 {
        let partial: Vec<f64> = self
            .frames
            .par_chunks(CHUNK)
            .zip(self.tris.par_chunks(CHUNK))
            .map(|(fs, ts)| {
                fs.iter()
                    .zip(ts)
                    .map(|(f, t)| sd_term(f, t, uv).map_or(f64::INFINITY, |x| x.energy))
                    .sum::<f64>()
            })
            .collect();
        partial.iter().sum()
    }

    /// E(uv), with ∇E written to `grad` when E is finite.
    fn gradient(&mut self, uv: &[DVec2], grad: &mut [DVec2]) -> f64 {
        let partial: Vec<f64> = self
            .corners
            .par_chunks_mut(CHUNK)
            .zip(self.frames.par_chunks(CHUNK))
            .zip(self.tris.par_chunks(CHUNK))
            .map(|((cs, fs), ts)| {
                let mut sum = 0.0;
                for ((corner, f), t) in cs.iter_mut().zip(fs).zip(ts) {
                    let Some(Term {
                        j,
                        det,
                        n2,
                        s2,
                        energy: e,
                    }) = sd_term(f, t, uv)
                    else {
                        return f64::INFINITY;
                    };
                    // ∂/∂J: 2J/s² + s² (2J/det² − 2‖J‖² cof(J)/det³); ∂J/∂uv_k = g_k.
                    let cof = [[j[1][1], -j[1][0]], [-j[0][1], j[0][0]]];
                    let a = 2.0 / s2 + 2.0 * s2 / (det * det);
                    let b = 2.0 * s2 * n2 / (det * det * det);
                    let dj: [[f64; 2]; 2] = std::array::from_fn(|r| {
                        std::array::from_fn(|c| f.c * (a * j[r][c] - b * cof[r][c]))
                    });
                    *corner = std::array::from_fn(|k| {
                        DVec2::new(
                            dj[0][0] * f.g[0][k] + dj[0][1] * f.g[1][k],
                            dj[1][0] * f.g[0][k] + dj[1][1] * f.g[1][k],
                        )
                    });
                    sum += e;
                }
                sum
            })
            .collect();
        let energy: f64 = partial.iter().sum();
        if energy.is_finite() {
            let corners = &self.corners;
            grad.par_iter_mut().enumerate().for_each(|(v, g)| {
                let (a, b) = (self.start[v] as usize, self.start[v + 1] as usize);
                *g = self.incident[a..b]
                    .iter()
                    .fold(DVec2::ZERO, |acc, &(t, k)| {
                        acc + corners[t as usize][k as usize]
                    });
            });
        }
        energy
    }
}

/// Largest step α ∈ (0, 1] along `d` from `uv` that keeps every triangle's signed area positive
/// (times 0.9, Smith & Schaefer 2015 §3.2).
fn max_flip_free_step(tris: &[[u32; 3]], uv: &[DVec2], d: &[DVec2]) -> f64 {
    let alpha = tris
        .par_iter()
        .map(|t| {
            let [a, b, c] = t.map(|i| uv[i as usize]);
            let [da, db, dc] = t.map(|i| d[i as usize]);
            // 2·area(α) = cross(b−a + α(db−da), c−a + α(dc−da)) = A + Bα + Cα².
            let (e1, e2, f1, f2) = (b - a, c - a, db - da, dc - da);
            let aa = e1.perp_dot(e2);
            let bb = e1.perp_dot(f2) + f1.perp_dot(e2);
            let cc = f1.perp_dot(f2);
            smallest_positive_root(aa, bb, cc)
        })
        .reduce(|| f64::INFINITY, f64::min);
    (0.9 * alpha).min(1.0)
}

fn smallest_positive_root(a: f64, b: f64, c: f64) -> f64 {
    // With a > 0 (an unflipped triangle), b ≥ 0 and c ≥ 0 keep the area growing: no root.
    if a > 0.0 && b >= 0.0 && c >= 0.0 {
        return f64::INFINITY;
    }
    let scale = a.abs().max(b.abs()).max(c.abs());
    if c.abs() <= 1e-12 * scale {
        if b < 0.0 {
            return -a / b;
        }
        return f64::INFINITY;
    }
    let disc = b * b - 4.0 * a * c;
    if disc < 0.0 {
        return f64::INFINITY;
    }
    let q = -0.5 * (b + b.signum() * disc.sqrt());
    let roots = [q / c, if q != 0.0 { a / q } else { f64::INFINITY }];
    roots
        .into_iter()
        .filter(|r| *r > 0.0)
        .fold(f64::INFINITY, f64::min)
}

/// Tutte's embedding: boundary on the unit circle by arc length, each interior vertex at the
/// weighted mean of its neighbours (one sparse solve per coordinate).
fn tutte(topo: &Topology, p: &[DVec3]) -> Result<Vec<DVec2>> {
    let n = p.len();
    let boundary = &topo.boundary_loops[0];
    let mut uv = vec![DVec2::ZERO; n];
    let mut is_b = vec![false; n];
    let len: Vec<f64> = (0..boundary.len())
        .map(|i| {
            (p[boundary[(i + 1) % boundary.len()] as usize] - p[boundary[i] as usize]).length()
        })
        .collect();
    let total: f64 = len.iter().sum();
    let mut s = 0.0;
    for (i, &v) in boundary.iter().enumerate() {
        let a = std::f64::consts::TAU * s / total;
        // Reversed so that the embedding keeps the triangles' counter-clockwise orientation.
        uv[v as usize] = DVec2::new(a.cos(), -a.sin());
        is_b[v as usize] = true;
        s += len[i];
    }
    let mut index = vec![usize::MAX; n];
    let mut m = 0;
    for v in 0..n {
        if !is_b[v] {
            index[v] = m;
            m += 1;
        }
    }
    // Harmonic weights (cot α + cot β)/2 clamped positive: symmetric and positive, so the
    // embedding with a convex boundary is flip-free (Floater 2003), yet close to harmonic.
    let mut weights: std::collections::HashMap<(u32, u32), f64> = std::collections::HashMap::new();
    for t in &topo.triangles {
        for k in 0..3 {
            let (o, a, b) = (t[k], t[(k + 1) % 3], t[(k + 2) % 3]);
            let (ea, eb) = (p[a as usize] - p[o as usize], p[b as usize] - p[o as usize]);
            let cot = ea.dot(eb) / ea.cross(eb).length().max(1e-300);
            *weights.entry((a.min(b), a.max(b))).or_insert(0.0) += 0.5 * cot;
        }
    }
    let mut entries = Vec::with_capacity(7 * m);
    let mut diag = vec![0.0; m];
    let (mut bu, mut bv) = (vec![0.0; m], vec![0.0; m]);
    let mut edges: Vec<((u32, u32), f64)> = weights.into_iter().collect();
    edges.sort_unstable_by_key(|e| e.0);
    for ((a, b), w) in edges {
        let w = w.max(1e-3);
        for (x, y) in [(a, b), (b, a)] {
            if is_b[x as usize] {
                continue;
            }
            let i = index[x as usize];
            diag[i] += w;
            if is_b[y as usize] {
                bu[i] += w * uv[y as usize].x;
                bv[i] += w * uv[y as usize].y;
            } else if index[y as usize] < i {
                entries.push((i, index[y as usize], -w));
            }
        }
    }
    entries.extend(diag.iter().enumerate().map(|(i, d)| (i, i, *d)));
    if m > 0 {
        let chol = SparseCholesky::new(m, &entries)?;
        let (xu, xv) = rayon::join(|| chol.solve(&bu), || chol.solve(&bv));
        let (xu, xv) = (xu?, xv?);
        for v in 0..n {
            if !is_b[v] {
                uv[v] = DVec2::new(xu[index[v]], xv[index[v]]);
            }
        }
    }
    // Orientation: the embedding must keep the triangles counter-clockwise.
    if signed_areas(&topo.triangles, &uv).sum::<f64>() < 0.0 {
        for q in &mut uv {
            q.y = -q.y;
        }
    }
    Ok(uv)
}

/// Twice the signed texture area of each triangle (positive: counter-clockwise).
fn signed_areas<'a>(tris: &'a [[u32; 3]], uv: &'a [DVec2]) -> impl Iterator<Item = f64> + 'a {
    tris.iter().map(|t| {
        let [a, b, c] = t.map(|i| uv[i as usize]);
        (b - a).perp_dot(c - a)
    })
}

/// The least-squares conformal map (Lévy et al. 2002) as solved, with the two boundary vertices
/// farthest apart pinned (its orientation unchecked: [`lscm`] checks it).
fn conformal_map(topo: &Topology, p: &[DVec3], frames: &[Frame]) -> Result<Vec<DVec2>> {
    let n = p.len();
    let boundary = &topo.boundary_loops[0];
    // Pins: a boundary vertex and the boundary vertex farthest from it, at their 3D distance.
    let farthest_from = |v: usize| -> usize {
        *boundary
            .iter()
            .max_by(|x, y| {
                (p[**x as usize] - p[v])
                    .length()
                    .total_cmp(&(p[**y as usize] - p[v]).length())
            })
            .expect("a boundary") as usize
    };
    let b = farthest_from(boundary[0] as usize);
    let a = farthest_from(b);
    let pin = [
        (a, DVec2::ZERO),
        (b, DVec2::new((p[b] - p[a]).length(), 0.0)),
    ];
    let mut index = vec![usize::MAX; n];
    let mut m = 0;
    for v in 0..n {
        if v != a && v != b {
            index[v] = m;
            m += 1;
        }
    }
    // The conformal energy Σ A (|∇u|² + |∇v|²) − 2·(texture area) (Lévy et al. 2002 §3; the
    // residuals ∂u/∂x − ∂v/∂y, ∂u/∂y + ∂v/∂x squared and summed): the cotangent Laplacian on u
    // and on v, and the area's boundary sum Σ u_i v_j − u_j v_i over boundary edges i → j (in
    // the triangles' winding) coupling them. Unknown 2i is u, 2i + 1 is v; pinned vertices move
    // to the right-hand side.
    let mut entries = Vec::with_capacity(9 * topo.triangles.len() + 2 * boundary.len());
    let mut rhs = vec![0.0; 2 * m];
    let mut add = |(v1, c1): (usize, usize), (v2, c2): (usize, usize), x: f64| {
        let i = index[v1];
        if i == usize::MAX {
            return;
        }
        let row = 2 * i + c1;
        match index[v2] {
            usize::MAX => {
                let q = pin.iter().find(|(pv, _)| *pv == v2).expect("pinned").1;
                rhs[row] -= x * q[c2];
            }
            j if row >= 2 * j + c2 => entries.push((row, 2 * j + c2, x)),
            _ => {}
        }
    };
    for (f, t) in frames.iter().zip(&topo.triangles) {
        for a in 0..3 {
            for b in 0..3 {
                let x = f.area * (f.g[0][a] * f.g[0][b] + f.g[1][a] * f.g[1][b]);
                let (va, vb) = (t[a] as usize, t[b] as usize);
                add((va, 0), (vb, 0), x);
                add((va, 1), (vb, 1), x);
            }
        }
    }
    for k in 0..boundary.len() {
        let (i, j) = (
            boundary[k] as usize,
            boundary[(k + 1) % boundary.len()] as usize,
        );
        add((i, 0), (j, 1), -0.5);
        add((j, 1), (i, 0), -0.5);
        add((j, 0), (i, 1), 0.5);
        add((i, 1), (j, 0), 0.5);
    }
    let chol = SparseCholesky::new(2 * m, &entries)?;
    let x = chol.solve(&rhs)?;
    let mut uv = vec![DVec2::ZERO; n];
    for v in 0..n {
        uv[v] = match index[v] {
            usize::MAX => pin.iter().find(|(pv, _)| *pv == v).expect("pinned").1,
            i => DVec2::new(x[2 * i], x[2 * i + 1]),
        };
    }
    Ok(uv)
}

/// Least-squares conformal map (Lévy et al. 2002): free boundary, the two boundary vertices
/// farthest apart pinned; `None` when it flips a triangle (then Tutte's embedding starts).
fn lscm(topo: &Topology, p: &[DVec3], frames: &[Frame]) -> Result<Option<Vec<DVec2>>> {
    let uv = conformal_map(topo, p, frames)?;
    let positive = signed_areas(&topo.triangles, &uv)
        .filter(|s| *s > 0.0)
        .count();
    if positive == topo.triangles.len() {
        return Ok(Some(uv));
    }
    if positive == 0 {
        // Mirrored: flip v.
        return Ok(Some(
            uv.into_iter().map(|q| DVec2::new(q.x, -q.y)).collect(),
        ));
    }
    Ok(None)
}

/// Unwraps a disc-topology mesh into one chart over [0, 1]². Errors name the number of
/// boundary loops when the mesh is not a disc.
pub fn unwrap(mesh: &TriMesh, opts: &UnwrapOptions) -> Result<Unwrap> {
    opts.check()?;
    let topo = Topology::new(mesh)?;
    topo.check_disc()?;
    // Normalise scale: total area 1.
    let area: f64 = topo
        .triangles
        .iter()
        .map(|t| {
            let [a, b, c] = t.map(|i| topo.positions[i as usize].as_dvec3());
            0.5 * (b - a).cross(c - a).length()
        })
        .sum();
    if !(area > 0.0) {
        return Err(PhotoError::Mesh("the surface has zero area".into()));
    }
    let s = 1.0 / area.sqrt();
    let p: Vec<DVec3> = topo.positions.iter().map(|v| v.as_dvec3() * s).collect();
    let view = opts.view.map(|v| v.as_dvec3().normalize_or_zero());
    let mut frames: Vec<Frame> = topo
        .triangles
        .iter()
        .map(|t| {
            let q = t.map(|i| p[i as usize]);
            let (g, area) = frame(q);
            let omega = match view {
                Some(v) => {
                    let n = (q[1] - q[0]).cross(q[2] - q[0]).normalize_or_zero();
                    1.0 / (n.dot(v) + opts.k as f64)
                }
                None => 1.0,
            };
            Frame {
                g,
                area,
                c: 0.0,
                s: omega.powf(0.25),
                omega,
            }
        })
        .collect();
    if let Some(i) = frames.iter().position(|f| !(f.area > 1e-14)) {
        return Err(PhotoError::Mesh(format!(
            "triangle {i} has zero area; remove degenerate triangles first"
        )));
    }
    // Normalise: mean ω 1 over the area, and the target scales keep the total area.
    let wa: f64 = frames.iter().map(|f| f.omega * f.area).sum();
    let sa: f64 = frames.iter().map(|f| f.s * f.s * f.area).sum();
    for f in &mut frames {
        f.c = f.omega * f.area / wa;
        f.s /= sa.sqrt();
    }
    // The conformal start on one core; Tutte's embedding (the fallback, and the reported
    // start) and the proxy's factorisation on the other.
    let n = p.len();
    let (conformal, rest) = rayon::join(
        || lscm(&topo, &p, &frames),
        || -> Result<_> {
            let tutte_uv = tutte(&topo, &p)?;
            // The global matrix K = Σ c GᵀG, vertex 0 pinned.
            let mut entries = Vec::with_capacity(6 * topo.triangles.len());
            for (f, t) in frames.iter().zip(&topo.triangles) {
                for a in 0..3 {
                    for b in 0..3 {
                        let (va, vb) = (t[a] as usize, t[b] as usize);
                        if va == 0 || vb == 0 || va < vb {
                            continue;
                        }
                        let k = f.c * (f.g[0][a] * f.g[0][b] + f.g[1][a] * f.g[1][b]);
                        entries.push((va - 1, vb - 1, k));
                    }
                }
            }
            Ok((tutte_uv, SparseCholesky::new(n - 1, &entries)?))
        },
    );
    let (tutte_uv, chol) = rest?;
    let tutte_stretch = measure(&frames, &topo.triangles, &tutte_uv);
    // Start from the conformal map when it is flip-free (much nearer the optimum), else Tutte.
    let mut uv = conformal?.unwrap_or(tutte_uv);
    let mut iterations = 0;
    let mut sd = Energy::new(&frames, &topo.triangles, n);
    let mut energy = sd.value(&uv);
    let mut prev = uv.clone();
    let mut history: Vec<f64> = vec![energy];
    let mut last_alpha = 1.0f64;
    // Buffers reused by every iteration.
    let (mut ext, mut trial, mut grad) = (uv.clone(), uv.clone(), vec![DVec2::ZERO; n]);
    let mut d = vec![DVec2::ZERO; n];
    let mut x = vec![[0.0f64; 2]; n - 1];
    for it in 0..opts.iterations {
        iterations += 1;
        // Nesterov-style extrapolation (Kovalsky et al. 2016 §4), kept only when it lowers the
        // energy without a flip.
        let theta = (1.0 - (2.0f64).sqrt() / (it as f64 + 2.0).sqrt()).clamp(0.0, 0.9);
        ext.par_iter_mut()
            .zip(&uv)
            .zip(&prev)
            .for_each(|((e, u), p)| *e = *u + theta * (*u - *p));
        let mut ext_energy = sd.value(&ext);
        if !(ext_energy.is_finite() && ext_energy <= energy) {
            ext.copy_from_slice(&uv);
            ext_energy = energy;
        }
        sd.gradient(&ext, &mut grad);
        // Direction: the Laplacian proxy's Newton step, −K⁻¹∇E, vertex 0 fixed.
        for (x, g) in x.iter_mut().zip(&grad[1..]) {
            *x = [-g.x, -g.y];
        }
        chol.solve_pairs(&mut x)?;
        d[0] = DVec2::ZERO;
        for (d, x) in d[1..].iter_mut().zip(&x) {
            *d = DVec2::from_array(*x);
        }
        let slope: f64 = grad.iter().zip(&d).map(|(g, d)| g.dot(*d)).sum();
        // Backtracking on the true energy (Armijo) from the largest flip-free step, or twice
        // the last accepted step when that is shorter (the proxy's step length is steady).
        let mut alpha = max_flip_free_step(&topo.triangles, &ext, &d).min(2.0 * last_alpha);
        let mut accepted = None;
        for _ in 0..30 {
            trial
                .par_iter_mut()
                .zip(&ext)
                .zip(&d)
                .for_each(|((t, u), d)| *t = *u + alpha * *d);
            let e = sd.value(&trial);
            if e.is_finite() && e <= ext_energy + 1e-4 * alpha * slope {
                accepted = Some(e);
                break;
            }
            alpha *= 0.5;
        }
        let Some(e) = accepted else { break };
        last_alpha = alpha;
        // uv ← trial, prev ← the old uv; the old prev becomes the next trial buffer.
        std::mem::swap(&mut prev, &mut uv);
        std::mem::swap(&mut uv, &mut trial);
        energy = e;
        history.push(e);
        // Converged when ten iterations together lowered the energy by less than 10 × tolerance.
        if history.len() > 10 && history[history.len() - 11] - e < 10.0 * opts.tolerance * e {
            break;
        }
    }
    let stretch = measure(&frames, &topo.triangles, &uv);
    let uv = fit_to_square(&uv, &p, view, opts.margin);
    let mut out = TriMesh {
        positions: topo.positions.clone(),
        normals: Vec::new(),
        uvs: uv
            .iter()
            .map(|q| Vec2::new(q.x as f32, q.y as f32))
            .collect(),
        triangles: topo.triangles.clone(),
    };
    out.compute_normals();
    Ok(Unwrap {
        mesh: out,
        stretch,
        tutte_stretch,
        iterations,
    })
}

/// Turns the chart upright (the best rotation onto the surface's projection along the view, or
/// onto its x–y plane) and scales it into [margin, 1 − margin]² keeping its aspect.
fn fit_to_square(uv: &[DVec2], p: &[DVec3], view: Option<DVec3>, margin: f32) -> Vec<DVec2> {
    let v = view.unwrap_or(DVec3::NEG_Z);
    let up = if v.y.abs() > 0.9 { DVec3::Z } else { DVec3::Y };
    // Image axes of a camera looking along v: right = v × up… seen from the front, so that the
    // head's right appears on the image's left as in a photo.
    let right = v.cross(up).normalize();
    let up = right.cross(v).normalize();
    let target: Vec<DVec2> = p
        .iter()
        .map(|q| DVec2::new(q.dot(right), q.dot(up)))
        .collect();
    let n = uv.len() as f64;
    let (cu, ct) = (
        uv.iter().sum::<DVec2>() / n,
        target.iter().sum::<DVec2>() / n,
    );
    // 2D Procrustes rotation: θ = atan2(Σ a×b, Σ a·b).
    let (mut sdot, mut scross) = (0.0, 0.0);
    for (a, b) in uv.iter().zip(&target) {
        let (a, b) = (*a - cu, *b - ct);
        sdot += a.dot(b);
        scross += a.perp_dot(b);
    }
    let rot = DVec2::from_angle(scross.atan2(sdot));
    let r: Vec<DVec2> = uv.iter().map(|q| rot.rotate(*q - cu)).collect();
    let (lo, hi) = r.iter().fold(
        (DVec2::splat(f64::INFINITY), DVec2::splat(f64::NEG_INFINITY)),
        |(lo, hi), q| (lo.min(*q), hi.max(*q)),
    );
    let m = margin as f64;
    let scale = (1.0 - 2.0 * m) / (hi - lo).max_element();
    let offset = DVec2::splat(0.5) - 0.5 * (hi + lo) * scale;
    r.iter().map(|q| *q * scale + offset).collect()
}

/// The stretch of a mesh's existing UVs (for comparing layouts from other tools).
pub fn stretch_of(mesh: &TriMesh, view: Option<Vec3>, k: f32) -> Result<Stretch> {
    if mesh.uvs.len() != mesh.positions.len() {
        return Err(PhotoError::Mesh("the mesh has no UVs to measure".into()));
    }
    let p: Vec<DVec3> = mesh.positions.iter().map(|v| v.as_dvec3()).collect();
    let view = view.map(|v| v.as_dvec3().normalize_or_zero());
    let frames: Vec<Frame> = mesh
        .triangles
        .iter()
        .map(|t| {
            let q = t.map(|i| p[i as usize]);
            let (g, area) = frame(q);
            let omega = view.map_or(1.0, |v| {
                1.0 / ((q[1] - q[0]).cross(q[2] - q[0]).normalize_or_zero().dot(v) + k as f64)
            });
            Frame {
                g,
                area,
                c: 0.0,
                s: 1.0,
                omega,
            }
        })
        .collect();
    let uv: Vec<DVec2> = mesh.uvs.iter().map(|q| q.as_dvec2()).collect();
    Ok(measure(&frames, &mesh.triangles, &uv))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_view_without_direction_is_refused() {
        for v in [Vec3::ZERO, Vec3::new(f32::NAN, 0.0, -1.0)] {
            let o = UnwrapOptions {
                view: Some(v),
                ..Default::default()
            };
            let e = o.check().unwrap_err().to_string();
            assert!(e.contains("view direction") && e.contains("0,0,-1"), "{e}");
        }
        assert!(UnwrapOptions::default().check().is_ok());
    }
    use crate::topology::grid_mesh;

    #[test]
    fn a_flat_square_unwraps_isometrically() {
        let m = grid_mesh(12, |_, _| 0.0);
        let u = unwrap(&m, &UnwrapOptions::default()).unwrap();
        assert_eq!(u.stretch.flipped, 0);
        assert!(u.stretch.l2 < 1.0005, "{:?}", u.stretch);
        // Tutte's circle distorts the square; the iterations undo it.
        assert!(u.tutte_stretch.l2 > 1.02, "{:?}", u.tutte_stretch);
        for q in &u.mesh.uvs {
            assert!(q.x >= 0.0 && q.y >= 0.0 && q.x <= 1.0 && q.y <= 1.0);
        }
    }

    #[test]
    fn the_conformal_start_of_a_flat_patch_is_a_similarity() {
        // A planar, irregular patch (a jittered grid, squeezed): its least-squares conformal map
        // is the patch itself up to rotation, scale and translation (Lévy et al. 2002), so every
        // triangle's Jacobian is the same multiple of a rotation, and no triangle flips.
        let mut m = grid_mesh(10, |_, _| 0.0);
        for (i, p) in m.positions.iter_mut().enumerate() {
            let j = ((i * 37) % 11) as f32 / 11.0 - 0.5;
            *p = Vec3::new(1.7 * p.x + 0.02 * j, p.y - 0.015 * j, 0.0);
        }
        let topo = Topology::new(&m).unwrap();
        let p: Vec<DVec3> = topo.positions.iter().map(|v| v.as_dvec3()).collect();
        let frames: Vec<Frame> = topo
            .triangles
            .iter()
            .map(|t| {
                let (g, area) = frame(t.map(|i| p[i as usize]));
                Frame {
                    g,
                    area,
                    c: area,
                    s: 1.0,
                    omega: 1.0,
                }
            })
            .collect();
        // As solved, before `lscm` could mirror it: a wrong sign of the area term would give
        // the mirror image (every triangle flipped), which `lscm` would quietly turn back.
        let uv = conformal_map(&topo, &p, &frames).unwrap();
        assert!(signed_areas(&topo.triangles, &uv).all(|a| a > 0.0));
        let mut scales = Vec::new();
        for (f, t) in frames.iter().zip(&topo.triangles) {
            // Frames differ per triangle by a rotation, so compare J's conformal invariants:
            // a similarity has J = [[a, −b], [b, a]] (up to the frame's reflection).
            let j = jacobian(f, t.map(|i| uv[i as usize]));
            let (a, b) = (j[0][0] - j[1][1], j[0][1] + j[1][0]);
            assert!(a.abs() + b.abs() < 1e-9, "{j:?}");
            scales.push((j[0][0] * j[1][1] - j[0][1] * j[1][0]).sqrt());
        }
        let (lo, hi) = scales
            .iter()
            .fold((f64::MAX, 0.0f64), |(l, h), s| (l.min(*s), h.max(*s)));
        assert!(hi - lo < 1e-9 * hi, "{lo} {hi}");
    }

    #[test]
    fn stretch_of_a_known_affine_map() {
        // u = 2x, v = y on a unit right triangle: J = diag(2, 1); the texture→surface map has
        // singular values ½ and 1: L² = √((¼ + 1)/2), normalised by √(texture/surface area) = √2.
        let mut m = TriMesh {
            positions: vec![Vec3::ZERO, Vec3::X, Vec3::Y],
            uvs: vec![Vec2::ZERO, Vec2::new(2.0, 0.0), Vec2::Y],
            triangles: vec![[0, 1, 2]],
            normals: vec![],
        };
        m.compute_normals();
        let s = stretch_of(&m, None, 1.2).unwrap();
        assert!(
            (s.l2 - (0.625f64).sqrt() * 2f64.sqrt()).abs() < 1e-9,
            "{s:?}"
        );
        assert!((s.linf - 2f64.sqrt()).abs() < 1e-9);
    }

    #[test]
    fn a_curved_patch_never_flips_and_beats_tutte() {
        // A saddle with strong curvature.
        let m = grid_mesh(30, |x, y| 0.8 * (x - 0.5) * (y - 0.5) * 4.0);
        let u = unwrap(&m, &UnwrapOptions::default()).unwrap();
        assert_eq!(u.stretch.flipped, 0);
        assert!(u.stretch.l2 < u.tutte_stretch.l2);
        assert!(u.stretch.l2 < 1.02, "{:?}", u.stretch);
    }

    #[test]
    fn the_view_weight_gives_facing_triangles_more_texture() {
        // A half cylinder, axis along y, bulging toward +z: a face seen from +z (V = −Z).
        let m = grid_mesh(40, |_, _| 0.0);
        let mut m2 = m.clone();
        for p in &mut m2.positions {
            let a = (p.x - 0.5) * std::f32::consts::PI * 0.95;
            *p = Vec3::new(a.sin() * 0.5, p.y, a.cos() * 0.5);
        }
        m2.compute_normals();
        let plain = unwrap(&m2, &UnwrapOptions::default()).unwrap();
        let viewed = unwrap(
            &m2,
            &UnwrapOptions {
                view: Some(Vec3::NEG_Z),
                k: 1.05,
                ..Default::default()
            },
        )
        .unwrap();
        assert_eq!(viewed.stretch.flipped, 0);
        // Texture area of the frontal strip (|x| < 0.15) relative to the whole.
        let frontal = |u: &Unwrap| {
            let (mut f, mut all) = (0.0, 0.0);
            for t in &u.mesh.triangles {
                let [a, b, c] = t.map(|i| u.mesh.uvs[i as usize]);
                let ar = 0.5 * (b - a).perp_dot(c - a).abs();
                let centre = (u.mesh.positions[t[0] as usize]
                    + u.mesh.positions[t[1] as usize]
                    + u.mesh.positions[t[2] as usize])
                    / 3.0;
                all += ar;
                if centre.x.abs() < 0.15 {
                    f += ar;
                }
            }
            f / all
        };
        assert!(
            frontal(&viewed) > 1.15 * frontal(&plain),
            "{} vs {}",
            frontal(&viewed),
            frontal(&plain)
        );
        assert!(viewed.stretch.weighted_l2 < viewed.stretch.l2);
    }

    #[test]
    fn the_layout_is_the_same_at_any_thread_count() {
        let m = grid_mesh(24, |x, y| {
            0.6 * (x - 0.5) * (y - 0.5) * 4.0 + 0.2 * (3.0 * x).sin()
        });
        let opts = UnwrapOptions {
            view: Some(Vec3::NEG_Z),
            ..Default::default()
        };
        let one = rayon::ThreadPoolBuilder::new()
            .num_threads(1)
            .build()
            .unwrap();
        let a = one.install(|| unwrap(&m, &opts).unwrap());
        let b = unwrap(&m, &opts).unwrap();
        assert_eq!(a.mesh.uvs, b.mesh.uvs);
        assert_eq!(a.iterations, b.iterations);
    }

    #[test]
    fn a_mesh_with_a_hole_is_refused_with_its_loop_count() {
        let mut m = grid_mesh(8, |_, _| 0.0);
        let mid = 2 * (4 * 8 + 4);
        m.triangles.drain(mid..mid + 2);
        let e = unwrap(&m, &UnwrapOptions::default())
            .err()
            .unwrap()
            .to_string();
        assert!(e.contains("2 boundary loops"), "{e}");
    }
}

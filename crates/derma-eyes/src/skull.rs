//! The skull map T and skull normal map Υ (thesis §3.9, eqs. 3.15–3.16): textures over the
//! modelling camera's 2D coordinates holding the 3D position and normal of the skin surface the
//! region slides on, so a vertex's 3D position follows from its reduced coordinates ũ⁺. The eye
//! openings, where the neutral skin does not cover the camera, are closed by a smooth (harmonic)
//! surface, as the thesis closes the sockets of its skull.

use derma_core::mesh::TriMesh;
use derma_core::numerics::SparseCholesky;
use glam::{Vec2, Vec3};

/// Texel size (mm): 0.5 mm, a third of the head's 1.5 mm edges (the map stays in cache).
pub const TEXEL_MM: f32 = 0.5;

/// T and Υ over a rectangle of the modelling camera.
#[derive(Clone, Debug)]
pub struct SkullMap {
    /// Lower-left corner of the covered rectangle (mm).
    pub origin: Vec2,
    /// Texels across and down.
    pub width: usize,
    /// Texels down.
    pub height: usize,
    /// Position then normal per texel (6 floats).
    pub texels: Vec<[f32; 6]>,
}

impl SkullMap {
    /// Rasterises the front-most surface of `mesh`'s triangles (those `keep` accepts) over the
    /// rectangle `lo`–`hi` (mm), then fills uncovered texels harmonically from their borders.
    pub fn new(
        mesh: &TriMesh,
        keep: impl Fn(usize) -> bool,
        lo: Vec2,
        hi: Vec2,
    ) -> crate::Result<SkullMap> {
        Self::layered(&[(mesh, &keep)], lo, hi)
    }

    /// As [`SkullMap::new`] over several layers: each later layer covers only the texels the
    /// earlier ones left empty (the rest pose first, then the closed lids).
    pub fn layered(
        layers: &[(&TriMesh, &dyn Fn(usize) -> bool)],
        lo: Vec2,
        hi: Vec2,
    ) -> crate::Result<SkullMap> {
        let width = ((hi.x - lo.x) / TEXEL_MM).ceil() as usize + 1;
        let height = ((hi.y - lo.y) / TEXEL_MM).ceil() as usize + 1;
        let mut depth = vec![f32::MIN; width * height];
        let mut texels = vec![[0.0f32; 6]; width * height];
        for (mesh, keep) in layers {
            let before: Vec<bool> = depth.iter().map(|d| *d > f32::MIN).collect();
            for (ti, t) in mesh.triangles.iter().enumerate() {
                if !keep(ti) {
                    continue;
                }
                let p = t.map(|i| mesh.positions[i as usize]);
                let n = t.map(|i| mesh.normals[i as usize]);
                let q = p.map(|v| (v.truncate() - lo) / TEXEL_MM);
                let area = (q[1] - q[0]).perp_dot(q[2] - q[0]);
                if area.abs() < 1e-12 {
                    continue;
                }
                let bmin = q[0].min(q[1]).min(q[2]).floor().max(Vec2::ZERO);
                let bmax = q[0]
                    .max(q[1])
                    .max(q[2])
                    .ceil()
                    .min(Vec2::new(width as f32 - 1.0, height as f32 - 1.0));
                for y in bmin.y as usize..=bmax.y.max(0.0) as usize {
                    for x in bmin.x as usize..=bmax.x.max(0.0) as usize {
                        let i = y * width + x;
                        if before[i] {
                            continue;
                        }
                        let s = Vec2::new(x as f32, y as f32);
                        let w1 = (q[2] - q[1]).perp_dot(s - q[1]) / area;
                        let w2 = (q[0] - q[2]).perp_dot(s - q[2]) / area;
                        let w3 = 1.0 - w1 - w2;
                        if w1 < -1e-5 || w2 < -1e-5 || w3 < -1e-5 {
                            continue;
                        }
                        let pos = p[0] * w1 + p[1] * w2 + p[2] * w3;
                        if pos.z > depth[i] {
                            depth[i] = pos.z;
                            let nn = (n[0] * w1 + n[1] * w2 + n[2] * w3).normalize_or(Vec3::Z);
                            texels[i] = [pos.x, pos.y, pos.z, nn.x, nn.y, nn.z];
                        }
                    }
                }
            }
        }
        let covered: Vec<bool> = depth.iter().map(|d| *d > f32::MIN).collect();
        harmonic_fill(&mut texels, &covered, width, height)?;
        // Unit normals at every texel (the fill interpolates them linearly).
        for t in texels.iter_mut() {
            let n = Vec3::new(t[3], t[4], t[5]).normalize_or(Vec3::Z);
            t[3..6].copy_from_slice(&n.to_array());
        }
        Ok(SkullMap {
            origin: lo,
            width,
            height,
            texels,
        })
    }

    /// Bilinear T(ũ) and Υ(ũ) (the normal unnormalised).
    #[inline]
    pub fn sample(&self, u: Vec2) -> (Vec3, Vec3) {
        let f = (u - self.origin) * (1.0 / TEXEL_MM);
        let fx = f.x.clamp(0.0, (self.width - 1) as f32 - 1e-3);
        let fy = f.y.clamp(0.0, (self.height - 1) as f32 - 1e-3);
        let (x0, y0) = (fx as usize, fy as usize);
        let (tx, ty) = (fx - x0 as f32, fy - y0 as f32);
        let i = y0 * self.width + x0;
        let (a, b, c, d) = (
            &self.texels[i],
            &self.texels[i + 1],
            &self.texels[i + self.width],
            &self.texels[i + self.width + 1],
        );
        let mut o = [0.0f32; 6];
        for k in 0..6 {
            let top = a[k] + (b[k] - a[k]) * tx;
            let bot = c[k] + (d[k] - c[k]) * tx;
            o[k] = top + (bot - top) * ty;
        }
        (Vec3::new(o[0], o[1], o[2]), Vec3::new(o[3], o[4], o[5]))
    }
}

/// Solves Laplace's equation on the uncovered texels with the covered ones as boundary values
/// (sparse Cholesky on the 5-point Laplacian; texels on the rectangle's border use the
/// neighbours they have).
fn harmonic_fill(t: &mut [[f32; 6]], covered: &[bool], w: usize, h: usize) -> crate::Result<()> {
    let holes: Vec<usize> = (0..w * h).filter(|&i| !covered[i]).collect();
    if holes.is_empty() {
        return Ok(());
    }
    if holes.len() == w * h {
        return Err(crate::EyesError::Invalid(
            "the skull map covers no skin".into(),
        ));
    }
    let mut index = vec![u32::MAX; w * h];
    for (k, &i) in holes.iter().enumerate() {
        index[i] = k as u32;
    }
    let mut entries = Vec::new();
    let mut rhs = vec![vec![0.0f64; holes.len()]; 6];
    for (k, &i) in holes.iter().enumerate() {
        let (x, y) = (i % w, i / w);
        let mut nb = Vec::with_capacity(4);
        if x > 0 {
            nb.push(i - 1);
        }
        if x + 1 < w {
            nb.push(i + 1);
        }
        if y > 0 {
            nb.push(i - w);
        }
        if y + 1 < h {
            nb.push(i + w);
        }
        // A tiny diagonal term keeps components without any covered neighbour solvable.
        entries.push((k, k, nb.len() as f64 + 1e-9));
        for j in nb {
            if covered[j] {
                for c in 0..6 {
                    rhs[c][k] += t[j][c] as f64;
                }
            } else if (index[j] as usize) < k {
                entries.push((k, index[j] as usize, -1.0));
            }
        }
    }
    let chol = SparseCholesky::new(holes.len(), &entries)?;
    let refs: Vec<&[f64]> = rhs.iter().map(|v| v.as_slice()).collect();
    let sol = chol.solve_many(&refs)?;
    for (k, &i) in holes.iter().enumerate() {
        for c in 0..6 {
            t[i][c] = sol[c][k] as f32;
        }
    }
    Ok(())
}

//! Height → tangent-space normal map (OpenGL convention: +Y is +v, "up" in the texture). The
//! height gradient is taken on the surface, not in UV: with the UV Jacobian (∂P/∂u, ∂P/∂v) the
//! surface gradient g satisfies g·∂P/∂u = ∂h/∂u and g·∂P/∂v = ∂h/∂v; the displaced surface has
//! normal N − g (first order in the slope), expressed in the texel's MikkTSpace frame (T, B, N).

use crate::surface::Surface;
use derma_core::Map;
use glam::Vec3;
use rayon::prelude::*;

/// Tangent-space normals (x, y, z in [−1, 1]) of the displacement `height` (mm) over `surface`;
/// texels off the surface get +Z.
pub fn normals_from_height(surface: &Surface, height: &Map) -> [Map; 3] {
    let (w, h) = (surface.width, surface.height);
    let hd = height.data();
    let mut out = vec![[0.0f32, 0.0, 1.0]; w * h];
    out.par_chunks_mut(w).enumerate().for_each(|(y, row)| {
        for (x, o) in row.iter_mut().enumerate() {
            if surface.covered(y * w + x) {
                *o = tangent_normal(surface, |j| hd[j], x, y);
            }
        }
    });
    let ch = |k: usize| Map::from_fn(w, h, |i| out[i][k]);
    [ch(0), ch(1), ch(2)]
}

/// The index of texel (`x`, `y`) of a `w` × `h` map: across the edges when `wrap`, else `None`
/// outside.
#[inline]
pub fn texel_at((w, h): (usize, usize), x: i64, y: i64, wrap: bool) -> Option<usize> {
    let (x, y) = if wrap {
        (x.rem_euclid(w as i64), y.rem_euclid(h as i64))
    } else if x < 0 || y < 0 || x >= w as i64 || y >= h as i64 {
        return None;
    } else {
        (x, y)
    };
    Some(y as usize * w + x as usize)
}

/// The tangent-space normal of covered texel (`x`, `y`) from the heights (mm) of its
/// neighbours on the surface, `height(j)` giving texel `j`'s.
#[inline]
pub fn tangent_normal(
    surface: &Surface,
    height: impl Fn(usize) -> f32,
    x: usize,
    y: usize,
) -> [f32; 3] {
    let (w, h) = (surface.width, surface.height);
    let wrap = surface.period().is_some();
    let i = y * w + x;
    let at = |xx: i64, yy: i64| -> Option<f32> {
        let j = texel_at((w, h), xx, yy, wrap)?;
        surface.covered(j).then(|| height(j))
    };
    let c = height(i);
    let (xi, yi) = (x as i64, y as i64);
    // Central differences where both neighbours are on the surface, else one-sided.
    let diff = |a: Option<f32>, b: Option<f32>| match (a, b) {
        (Some(a), Some(b)) => 0.5 * (b - a),
        (None, Some(b)) => b - c,
        (Some(a), None) => c - a,
        (None, None) => 0.0,
    };
    let dh_dx = diff(at(xi - 1, yi), at(xi + 1, yi)); // per texel, +x = +u
    let dh_dy = diff(at(xi, yi - 1), at(xi, yi + 1)); // per texel, +y = −v
    let hu = dh_dx * w as f32;
    let hv = -dh_dy * h as f32;
    let f = surface.frame(i);
    let (a, b, cc) = (f.dpdu.dot(f.dpdu), f.dpdu.dot(f.dpdv), f.dpdv.dot(f.dpdv));
    let det = a * cc - b * b;
    let g = if det.abs() > 1e-20 {
        f.dpdu * ((cc * hu - b * hv) / det) + f.dpdv * ((a * hv - b * hu) / det)
    } else {
        Vec3::ZERO
    };
    let n = (f.n - g).normalize_or(f.n);
    [n.dot(f.t), n.dot(f.b), n.dot(f.n)]
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn slope_gives_the_analytic_normal() {
        // h = 0.1·x (mm) on a 10 mm patch: normal ∝ (−0.1, 0, 1); a ramp in v tilts +y the other way.
        let s = Surface::patch(32, 32, [10.0, 10.0], false);
        let mut hmap = Map::filled(32, 32, 0.0);
        let mut vmap = Map::filled(32, 32, 0.0);
        for i in 0..32 * 32 {
            let p = s.position(i);
            hmap.data_mut()[i] = 0.1 * p.x;
            vmap.data_mut()[i] = 0.1 * p.y;
        }
        let n = normals_from_height(&s, &hmap);
        let e = Vec3::new(-0.1, 0.0, 1.0).normalize();
        for i in [0usize, 100, 555, 1023] {
            assert!(
                (n[0].data()[i] - e.x).abs() < 1e-4
                    && n[1].data()[i].abs() < 1e-5
                    && (n[2].data()[i] - e.z).abs() < 1e-4
            );
        }
        let n = normals_from_height(&s, &vmap);
        // Height rising with v (up the texture): the normal leans to −y (OpenGL +Y up).
        assert!((n[1].data()[500] + e.z * 0.1 / (1.0f32 + 0.01).sqrt() / e.z).abs() < 1e-3);
        assert!(n[1].data()[500] < 0.0);
    }
}

//! A bounding-volume hierarchy over a triangle mesh for ray casting (nearest hit and any hit)
//! and closest-point queries: axis-aligned boxes split at the median centroid of the longest
//! axis, Möller–Trumbore ray tests, Ericson's closest point on a triangle (Real-Time Collision
//! Detection, 2005, §5.1.5).

use glam::Vec3;

/// Triangles per leaf at most.
const LEAF_SIZE: usize = 4;

#[derive(Clone, Copy, Debug)]
struct Node {
    lo: Vec3,
    hi: Vec3,
    /// Leaf: first triangle in `order`; inner: index of the right child (the left is next).
    start: u32,
    /// Triangles in a leaf; 0 for an inner node.
    count: u32,
}

/// A ray's nearest intersection with the mesh.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Hit {
    /// Triangle index.
    pub triangle: u32,
    /// Distance along the (unit or not) direction: the hit is at origin + t·dir.
    pub t: f32,
    /// Barycentric weights of corners 1 and 2.
    pub bary: [f32; 2],
}

/// A static BVH over triangles given by positions and index triples.
pub struct Bvh {
    nodes: Vec<Node>,
    order: Vec<u32>,
    tris: Vec<[Vec3; 3]>,
}

impl Bvh {
    /// Builds the hierarchy (median split of centroids on the longest axis of their bounds).
    pub fn new(positions: &[Vec3], triangles: &[[u32; 3]]) -> Bvh {
        let tris: Vec<[Vec3; 3]> = triangles
            .iter()
            .map(|t| t.map(|i| positions[i as usize]))
            .collect();
        let centroids: Vec<Vec3> = tris.iter().map(|t| (t[0] + t[1] + t[2]) / 3.0).collect();
        let mut order: Vec<u32> = (0..tris.len() as u32).collect();
        let mut nodes = Vec::with_capacity(2 * tris.len() / LEAF_SIZE + 1);
        if !tris.is_empty() {
            build(&tris, &centroids, &mut order, 0, &mut nodes);
        }
        Bvh { nodes, order, tris }
    }

    /// The nearest hit of the ray origin + t·dir with t in (t_min, t_max).
    pub fn nearest(&self, origin: Vec3, dir: Vec3, t_min: f32, t_max: f32) -> Option<Hit> {
        self.traverse(origin, dir, t_min, t_max, false)
    }

    /// Whether anything lies on the ray for t in (t_min, t_max).
    pub fn occluded(&self, origin: Vec3, dir: Vec3, t_min: f32, t_max: f32) -> bool {
        self.traverse(origin, dir, t_min, t_max, true).is_some()
    }

    /// The point of the mesh closest to `p` within `max_dist` (None if nothing is that close).
    pub fn closest(&self, p: Vec3, max_dist: f32) -> Option<Closest> {
        if self.nodes.is_empty() {
            return None;
        }
        let mut best: Option<Closest> = None;
        let mut limit2 = max_dist * max_dist;
        let mut stack = [0u32; 64];
        let mut sp = 1;
        while sp > 0 {
            sp -= 1;
            let idx = stack[sp];
            let node = self.nodes[idx as usize];
            let q = p.clamp(node.lo, node.hi);
            if (q - p).length_squared() > limit2 {
                continue;
            }
            if node.count > 0 {
                for k in node.start..node.start + node.count {
                    let ti = self.order[k as usize];
                    let (point, bary) = closest_on_triangle(p, &self.tris[ti as usize]);
                    let d2 = (point - p).length_squared();
                    if d2 <= limit2 {
                        limit2 = d2;
                        best = Some(Closest {
                            triangle: ti,
                            point,
                            bary,
                            distance: d2.sqrt(),
                        });
                    }
                }
            } else {
                // Visit the nearer child first so the limit shrinks early.
                let (l, r) = (idx + 1, node.start);
                let dl = box_distance2(p, &self.nodes[l as usize]);
                let dr = box_distance2(p, &self.nodes[r as usize]);
                let (first, second) = if dl <= dr { (l, r) } else { (r, l) };
                stack[sp] = second;
                stack[sp + 1] = first;
                sp += 2;
            }
        }
        best
    }

    fn traverse(&self, o: Vec3, d: Vec3, t_min: f32, t_max: f32, any: bool) -> Option<Hit> {
        if self.nodes.is_empty() {
            return None;
        }
        let inv = Vec3::ONE / d;
        let mut best: Option<Hit> = None;
        let mut limit = t_max;
        let mut stack = [0u32; 64];
        let mut sp = 1;
        while sp > 0 {
            sp -= 1;
            let idx = stack[sp];
            let node = self.nodes[idx as usize];
            if !slab(o, inv, node.lo, node.hi, t_min, limit) {
                continue;
            }
            if node.count > 0 {
                for k in node.start..node.start + node.count {
                    let ti = self.order[k as usize];
                    if let Some((t, b)) = intersect(o, d, &self.tris[ti as usize]) {
                        if t > t_min && t < limit {
                            limit = t;
                            best = Some(Hit {
                                triangle: ti,
                                t,
                                bary: b,
                            });
                            if any {
                                return best;
                            }
                        }
                    }
                }
            } else {
                // The left child is stored right after its parent, the right one at `start`.
                stack[sp] = node.start;
                stack[sp + 1] = idx + 1;
                sp += 2;
            }
        }
        best
    }
}

/// The closest point of a mesh to a query point.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Closest {
    /// Triangle index.
    pub triangle: u32,
    /// The closest point.
    pub point: Vec3,
    /// Barycentric weights of corners 1 and 2.
    pub bary: [f32; 2],
    /// Its distance to the query.
    pub distance: f32,
}

fn box_distance2(p: Vec3, n: &Node) -> f32 {
    (p.clamp(n.lo, n.hi) - p).length_squared()
}

/// The closest point of triangle `t` to `p` and its barycentric weights of corners 1 and 2,
/// by Voronoi regions (Ericson 2005, §5.1.5).
pub fn closest_on_triangle(p: Vec3, t: &[Vec3; 3]) -> (Vec3, [f32; 2]) {
    let [a, b, c] = *t;
    let (ab, ac, ap) = (b - a, c - a, p - a);
    let (d1, d2) = (ab.dot(ap), ac.dot(ap));
    if d1 <= 0.0 && d2 <= 0.0 {
        return (a, [0.0, 0.0]);
    }
    let bp = p - b;
    let (d3, d4) = (ab.dot(bp), ac.dot(bp));
    if d3 >= 0.0 && d4 <= d3 {
        return (b, [1.0, 0.0]);
    }
    let vc = d1 * d4 - d3 * d2;
    if vc <= 0.0 && d1 >= 0.0 && d3 <= 0.0 {
        let v = d1 / (d1 - d3);
        return (a + v * ab, [v, 0.0]);
    }
    let cp = p - c;
    let (d5, d6) = (ab.dot(cp), ac.dot(cp));
    if d6 >= 0.0 && d5 <= d6 {
        return (c, [0.0, 1.0]);
    }
    let vb = d5 * d2 - d1 * d6;
    if vb <= 0.0 && d2 >= 0.0 && d6 <= 0.0 {
        let w = d2 / (d2 - d6);
        return (a + w * ac, [0.0, w]);
    }
    let va = d3 * d6 - d5 * d4;
    if va <= 0.0 && (d4 - d3) >= 0.0 && (d5 - d6) >= 0.0 {
        let w = (d4 - d3) / ((d4 - d3) + (d5 - d6));
        return (b + w * (c - b), [1.0 - w, w]);
    }
    let denom = 1.0 / (va + vb + vc);
    let (v, w) = (vb * denom, vc * denom);
    if !(v.is_finite() && w.is_finite()) {
        // A degenerate triangle: its corners' closest.
        let best = [a, b, c]
            .into_iter()
            .enumerate()
            .min_by(|x, y| {
                (x.1 - p)
                    .length_squared()
                    .total_cmp(&(y.1 - p).length_squared())
            })
            .map(|(i, _)| i)
            .unwrap_or(0);
        return ([a, b, c][best], [[0.0, 0.0], [1.0, 0.0], [0.0, 1.0]][best]);
    }
    (a + ab * v + ac * w, [v, w])
}

fn build(
    tris: &[[Vec3; 3]],
    centroids: &[Vec3],
    order: &mut [u32],
    offset: usize,
    nodes: &mut Vec<Node>,
) -> u32 {
    let (mut lo, mut hi) = (Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY));
    let (mut clo, mut chi) = (lo, hi);
    for &i in order.iter() {
        for p in tris[i as usize] {
            lo = lo.min(p);
            hi = hi.max(p);
        }
        clo = clo.min(centroids[i as usize]);
        chi = chi.max(centroids[i as usize]);
    }
    let me = nodes.len() as u32;
    nodes.push(Node {
        lo,
        hi,
        start: offset as u32,
        count: order.len() as u32,
    });
    let ext = chi - clo;
    if order.len() <= LEAF_SIZE || ext.max_element() <= 0.0 {
        return me;
    }
    let axis = if ext.x >= ext.y && ext.x >= ext.z {
        0
    } else if ext.y >= ext.z {
        1
    } else {
        2
    };
    let mid = order.len() / 2;
    order.select_nth_unstable_by(mid, |a, b| {
        centroids[*a as usize][axis].total_cmp(&centroids[*b as usize][axis])
    });
    let (left, right) = order.split_at_mut(mid);
    build(tris, centroids, left, offset, nodes);
    let r = build(tris, centroids, right, offset + mid, nodes);
    nodes[me as usize].start = r;
    nodes[me as usize].count = 0;
    me
}

fn slab(o: Vec3, inv: Vec3, lo: Vec3, hi: Vec3, t_min: f32, t_max: f32) -> bool {
    let t0 = (lo - o) * inv;
    let t1 = (hi - o) * inv;
    let near = t0.min(t1).max_element().max(t_min);
    let far = t0.max(t1).min_element().min(t_max);
    near <= far
}

/// Möller–Trumbore: (t, [b1, b2]) of the ray's hit with the triangle's plane inside it.
fn intersect(o: Vec3, d: Vec3, t: &[Vec3; 3]) -> Option<(f32, [f32; 2])> {
    let e1 = t[1] - t[0];
    let e2 = t[2] - t[0];
    let p = d.cross(e2);
    let det = e1.dot(p);
    if det.abs() < 1e-20 {
        return None;
    }
    let inv = 1.0 / det;
    let s = o - t[0];
    let u = s.dot(p) * inv;
    if !(0.0..=1.0).contains(&u) {
        return None;
    }
    let q = s.cross(e1);
    let v = d.dot(q) * inv;
    if v < 0.0 || u + v > 1.0 {
        return None;
    }
    Some((e2.dot(q) * inv, [u, v]))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::rng::Philox;

    /// A brute-force nearest hit to check the hierarchy against.
    fn brute(tris: &[[Vec3; 3]], o: Vec3, d: Vec3) -> Option<(u32, f32)> {
        let mut best: Option<(u32, f32)> = None;
        for (i, t) in tris.iter().enumerate() {
            if let Some((tt, _)) = intersect(o, d, t) {
                if tt > 0.0 && best.is_none_or(|b| tt < b.1) {
                    best = Some((i as u32, tt));
                }
            }
        }
        best
    }

    #[test]
    fn nearest_hits_match_brute_force_on_random_triangles() {
        let rng = Philox::new(7, 0);
        let u = |index: u64, sub: u32| rng.uniform4(index, sub);
        let mut positions = Vec::new();
        let mut triangles = Vec::new();
        for i in 0..300u64 {
            let c = u(i, 0);
            let c = Vec3::new(c[0], c[1], c[2]);
            for k in 0..3u32 {
                let j = u(i, 1 + k);
                positions.push(c + 0.2 * (Vec3::new(j[0], j[1], j[2]) - 0.5));
            }
            let b = 3 * i as u32;
            triangles.push([b, b + 1, b + 2]);
        }
        let bvh = Bvh::new(&positions, &triangles);
        let tris: Vec<[Vec3; 3]> = triangles
            .iter()
            .map(|t| t.map(|i| positions[i as usize]))
            .collect();
        let mut hits = 0;
        for r in 0..500u64 {
            let a = u(1000 + r, 0);
            let o = Vec3::new(a[0], a[1], -1.0);
            let d = (Vec3::new(a[2], a[3], 2.0) - o).normalize();
            let got = bvh
                .nearest(o, d, 0.0, f32::INFINITY)
                .map(|h| (h.triangle, h.t));
            assert_eq!(got, brute(&tris, o, d), "ray {r}");
            assert_eq!(bvh.occluded(o, d, 0.0, f32::INFINITY), got.is_some());
            hits += got.is_some() as usize;
        }
        assert!(hits > 100, "too few rays hit ({hits}) to test anything");
    }

    #[test]
    fn a_hit_beyond_the_limit_does_not_count() {
        let p = [Vec3::ZERO, Vec3::X, Vec3::Y];
        let bvh = Bvh::new(&p, &[[0, 1, 2]]);
        let o = Vec3::new(0.2, 0.2, 1.0);
        let h = bvh.nearest(o, -Vec3::Z, 0.0, 2.0).unwrap();
        assert!((h.t - 1.0).abs() < 1e-6 && (h.bary[0] - 0.2).abs() < 1e-6);
        assert!(!bvh.occluded(o, -Vec3::Z, 0.0, 0.999));
        assert!(bvh.occluded(o, -Vec3::Z, 0.0, 1.001));
    }

    #[test]
    fn closest_points_match_brute_force_on_random_triangles() {
        let rng = Philox::new(11, 0);
        let mut k = 0u64;
        let mut r = || {
            k += 1;
            rng.uniform4(k, 0)[0] * 20.0 - 10.0
        };
        let mut positions = Vec::new();
        let mut triangles = Vec::new();
        for i in 0..200u32 {
            for _ in 0..3 {
                positions.push(Vec3::new(r(), r(), r()));
            }
            triangles.push([3 * i, 3 * i + 1, 3 * i + 2]);
        }
        let bvh = Bvh::new(&positions, &triangles);
        let tris: Vec<[Vec3; 3]> = triangles
            .iter()
            .map(|t| t.map(|i| positions[i as usize]))
            .collect();
        for _ in 0..300 {
            let p = Vec3::new(r(), r(), r()) * 1.5;
            let c = bvh.closest(p, f32::INFINITY).expect("a mesh is somewhere");
            // Brute force on a fine barycentric grid bounds the exact answer from above.
            let mut brute = f32::INFINITY;
            for t in &tris {
                let (q, _) = closest_on_triangle(p, t);
                brute = brute.min((q - p).length());
                for a in 0..=10 {
                    for b in 0..=(10 - a) {
                        let (u, v) = (a as f32 / 10.0, b as f32 / 10.0);
                        let q = t[0] + u * (t[1] - t[0]) + v * (t[2] - t[0]);
                        assert!((q - p).length() >= c.distance - 1e-3);
                    }
                }
            }
            assert!((c.distance - brute).abs() < 1e-4);
            let t = tris[c.triangle as usize];
            let q = t[0] + c.bary[0] * (t[1] - t[0]) + c.bary[1] * (t[2] - t[0]);
            assert!((q - c.point).length() < 1e-3);
            // Beyond the limit nothing is found.
            assert!(bvh.closest(p, c.distance * 0.99).is_none() || c.distance == 0.0);
        }
    }
}

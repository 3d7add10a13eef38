//! Spatial index: the sparse uniform grid derma uses against an R-tree (`rstar`), on the
//! workload of the main job: 170 000 follicle discs on a head-sized sphere, queried at texel
//! points in scanline-like order. `cargo bench -p derma-skin --bench index`.

use criterion::{criterion_group, criterion_main, Criterion};
use derma_core::rng::Philox;
use derma_skin::index::{Grid, GridCursor};
use glam::Vec3;
use rstar::{RTree, RTreeObject, AABB};

struct Disc {
    lo: [f32; 3],
    hi: [f32; 3],
}

impl RTreeObject for Disc {
    type Envelope = AABB<[f32; 3]>;
    fn envelope(&self) -> Self::Envelope {
        AABB::from_corners(self.lo, self.hi)
    }
}

fn sphere_point(u: f32, v: f32) -> Vec3 {
    let th = u * std::f32::consts::TAU;
    let z = 2.0 * v - 1.0;
    let r = (1.0 - z * z).sqrt();
    Vec3::new(r * th.cos(), r * th.sin(), z) * 100.0
}

fn bench(c: &mut Criterion) {
    let rng = Philox::new(1, 0);
    let reach = 0.3f32;
    let centres: Vec<Vec3> = (0..170_000)
        .map(|i| {
            let u = rng.uniform4(i, 0);
            sphere_point(u[0], u[1])
        })
        .collect();
    let bounds: Vec<(Vec3, Vec3)> = centres
        .iter()
        .map(|&c| (c - Vec3::splat(reach), c + Vec3::splat(reach)))
        .collect();
    // Queries: a scanline sweep over (θ, z), as texels of a lat-long chart are visited.
    let n = 512;
    let queries: Vec<Vec3> = (0..n * n)
        .map(|i| sphere_point((i % n) as f32 / n as f32, (i / n) as f32 / n as f32))
        .collect();

    let mut g = c.benchmark_group("index");
    g.sample_size(10);
    g.measurement_time(std::time::Duration::from_secs(4));
    g.bench_function("build/grid", |b| {
        b.iter(|| Grid::build(2.0 * reach, bounds.iter().copied()))
    });
    g.bench_function("build/rstar", |b| {
        b.iter(|| {
            RTree::bulk_load(
                bounds
                    .iter()
                    .map(|(l, h)| Disc {
                        lo: l.to_array(),
                        hi: h.to_array(),
                    })
                    .collect(),
            )
        })
    });
    let grid = Grid::build(2.0 * reach, bounds.iter().copied());
    let tree = RTree::bulk_load(
        bounds
            .iter()
            .map(|(l, h)| Disc {
                lo: l.to_array(),
                hi: h.to_array(),
            })
            .collect(),
    );
    g.bench_function("query_262k/grid_cursor", |b| {
        b.iter(|| {
            let mut cur = GridCursor::new(&grid);
            queries.iter().map(|&q| cur.query(q).len()).sum::<usize>()
        })
    });
    g.bench_function("query_262k/rstar", |b| {
        b.iter(|| {
            queries
                .iter()
                .map(|q| {
                    tree.locate_in_envelope_intersecting(&AABB::from_point(q.to_array()))
                        .count()
                })
                .sum::<usize>()
        })
    });
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);

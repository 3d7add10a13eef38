//! The paint stage of the main job alone (issue 15's largest stage): the built-in head's bio
//! maps painted at 4096² (`DERMA_BENCH_SIZE` to change) from the surface, fields and features of
//! one generation, on all cores; and the micro-relief's height along a scanline of texels, the
//! stage's largest part.
//!
//! cargo bench -p derma-skin --bench paint

use criterion::{criterion_group, criterion_main, Criterion};
use derma_skin::features::relief::{height_cached, ReliefCache, ReliefParams};
use derma_skin::features::relief_lanes::{heights, ReliefTexel};
use derma_skin::{SkinConfig, SkinGenerator};
use glam::Vec3;

fn bench(c: &mut Criterion) {
    let size: u32 = std::env::var("DERMA_BENCH_SIZE")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(4096);
    let cfg = SkinConfig {
        size,
        ..SkinConfig::default()
    };
    let set = SkinGenerator::new(cfg.clone())
        .run()
        .expect("the built-in head");
    let mut g = c.benchmark_group("paint");
    g.sample_size(10);
    g.bench_function(format!("head_{size}"), |b| {
        b.iter(|| {
            derma_skin::paint::paint(
                &cfg,
                &set.surface,
                &set.fields,
                &set.features,
                &derma_core::progress::Silent,
            )
            .unwrap()
        })
    });
    // 100 000 texels 0.14 mm apart along a curved scanline (the texel pitch of the head at
    // 4096²), the default relief's three octaves.
    let r = &cfg.relief;
    let prm = ReliefParams::from_config(r, 7, None);
    let points: Vec<(Vec3, Vec3)> = (0..100_000)
        .map(|k| {
            let a = k as f32 * 0.14 / 90.0;
            let n = Vec3::new(a.cos(), 0.2 * (k / 2000) as f32 / 50.0, a.sin()).normalize();
            (n * 90.0 + Vec3::Y * (k / 2000) as f32 * 0.14, n)
        })
        .collect();
    g.bench_function("relief_100k_texels", |b| {
        b.iter(|| {
            let mut cache = ReliefCache::default();
            points
                .iter()
                .map(|(p, n)| height_cached(&prm, *p, *n, Vec3::X, 1.0, 0.14, &mut cache))
                .sum::<f32>()
        })
    });
    let texels: Vec<ReliefTexel> = points
        .iter()
        .map(|&(p, n)| ReliefTexel {
            p,
            n,
            tension: Vec3::X,
            scale: 1.0,
            texel_mm: 0.14,
        })
        .collect();
    let mut out = vec![0.0f32; texels.len()];
    g.bench_function("relief_lanes_100k_texels", |b| {
        b.iter(|| {
            heights(&prm, &texels, &mut out, &mut ReliefCache::default());
            out.iter().sum::<f32>()
        })
    });
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);

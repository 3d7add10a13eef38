//! Bio → render lookup for a 4096² texture set (16.8 M texels) on all cores: the built-in match
//! table (simplex and multilinear; base colour + subsurface colour + scatter distance) against the analytic
//! model's simplex LUT (base colour only), texel by texel and in batches of eight (SIMD lanes).
//! Goal (issues 4 and 15): table lookup < 0.5 s on 2 cores.
//!
//! cargo bench -p derma-shading --bench table_lookup

use criterion::{criterion_group, criterion_main, Criterion};
use derma_core::rng::Philox;
use derma_shading::table_appearance::Interpolation;
use derma_shading::{Appearance, BioTexel, SpectralKubelkaMunk, TableAppearance};
use rayon::prelude::*;

const SIDE: usize = 4096;

/// Texels spread over the default skin ranges (derma-skin's baseline, lips and moles).
fn texels() -> Vec<BioTexel> {
    let rng = Philox::new(5, 0);
    (0..SIDE * SIDE)
        .into_par_iter()
        .map(|i| {
            let u = rng.uniform4(i as u64, 0);
            BioTexel {
                melanin: 0.01 + 0.3 * u[0] * u[0],
                pheomelanin: 0.3 + 0.3 * u[1],
                blood: 0.01 + 0.07 * u[2],
                oxygenation: 0.6 + 0.3 * u[3],
                stratum_corneum_um: 10.0 + 10.0 * u[0],
                epidermis_um: 50.0 + 50.0 * u[1],
            }
        })
        .collect()
}

fn bench(c: &mut Criterion) {
    let tex = texels();
    let table = TableAppearance::builtin();
    let analytic = SpectralKubelkaMunk::default();
    let mut out = vec![[0.0f32; 12]; tex.len()];
    let mut g = c.benchmark_group("lookup_4096x4096");
    g.sample_size(10);
    for (name, interp) in [
        ("match_table_simplex", Interpolation::Simplex),
        ("match_table_multilinear", Interpolation::Multilinear),
    ] {
        g.bench_function(name, |b| {
            b.iter(|| {
                out.par_chunks_mut(SIDE)
                    .zip(tex.par_chunks(SIDE))
                    .for_each(|(o, t)| {
                        for (o, t) in o.iter_mut().zip(t) {
                            *o = table.lookup_with(t, interp);
                        }
                    })
            })
        });
    }
    // The texture-set path: rows looked up eight texels at a time (SIMD lanes).
    g.bench_function("match_table_simplex_batch", |b| {
        b.iter(|| {
            out.par_chunks_mut(SIDE)
                .zip(tex.par_chunks(SIDE))
                .for_each(|(o, t)| table.lookup_batch(t, o))
        })
    });
    g.bench_function("memory_baseline", |b| {
        b.iter(|| {
            out.par_chunks_mut(SIDE)
                .zip(tex.par_chunks(SIDE))
                .for_each(|(o, t)| {
                    for (o, t) in o.iter_mut().zip(t) {
                        o[0] = t.melanin;
                        o[1] = t.blood;
                    }
                })
        })
    });
    g.bench_function("analytic_km_albedo", |b| {
        b.iter(|| {
            out.par_chunks_mut(SIDE)
                .zip(tex.par_chunks(SIDE))
                .for_each(|(o, t)| {
                    for (o, t) in o.iter_mut().zip(t) {
                        let a = analytic.albedo(t);
                        o[0] = a[0];
                        o[1] = a[1];
                        o[2] = a[2];
                    }
                })
        })
    });
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);

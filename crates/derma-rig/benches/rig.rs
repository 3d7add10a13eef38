//! Rig benchmarks (BENCHMARKS.md, "Dynamic facial colour"): building the basis for 4096² maps
//! with 8 targets at several radii, one 2048² colour frame with 8 targets (real-time path and
//! exact path), full-resolution local statistics against the exact O(r) disk, and the GPU frame
//! (`rig.wgsl`) at 2048² and 4096² with 8 targets — frames submitted back to back with new
//! weights, nothing read back, as an engine runs it (skipped where no GPU adapter opens; on
//! Mesa's lavapipe it times the CPU's emulation).
//!
//!     cargo bench -p derma-rig --bench rig
//!     cargo bench -p derma-rig --features gpu --bench rig -- gpu_frame   (the GPU frame alone,
//!                                                  without and with a set's skin; gpu feature)

use criterion::{criterion_group, criterion_main, BenchmarkId, Criterion};
use derma_core::Map;
use derma_rig::evaluate::{color, hemoglobin, FramePlan};
use derma_rig::local_stats::{local_stats, local_stats_exact};
use derma_rig::{BasisOptions, Rig, TargetSource, TargetSpec};
use derma_shading::skin_color_lut::SkinColorLut;
use std::time::Duration;

/// A hemoglobin-like map: hash noise around a smooth pattern (volume fraction ~0.012).
fn blood(w: usize, seed: u32) -> Map {
    let v = (0..w * w)
        .map(|i| {
            let mut x = (i as u32).wrapping_mul(0x9E37_79B9) ^ seed.wrapping_mul(0x85EB_CA6B);
            x ^= x >> 15;
            x = x.wrapping_mul(0x2C1B_3C6D);
            x ^= x >> 12;
            let n = (x >> 8) as f32 / (1u32 << 24) as f32;
            let (u, v) = ((i % w) as f32 / w as f32, (i / w) as f32 / w as f32);
            0.012
                * (1.0
                    + 0.3 * (std::f32::consts::TAU * u).sin() * (std::f32::consts::PI * v).sin()
                    + 0.2 * seed as f32 / 8.0)
                * (0.6 + 0.8 * n)
        })
        .collect();
    Map::from_vec(w, w, v).unwrap()
}

fn rig_of(neutral: &Map, targets: &[Map], r: f64, melanin: Option<Map>) -> Rig {
    let specs: Vec<TargetSpec> = targets
        .iter()
        .enumerate()
        .map(|(i, m)| TargetSpec {
            name: format!("t{i}"),
            source: TargetSource::Map(m),
            global_scale: None,
        })
        .collect();
    Rig::build(neutral, None, melanin, &specs, &BasisOptions::new(r)).unwrap()
}

/// The frame benchmarks' rig: `w`², 8 targets, r = 32, with a melanin ramp.
fn frame_rig(w: usize) -> (Rig, Map) {
    let neutral = blood(w, 0);
    let targets: Vec<Map> = (1..=8).map(|s| blood(w, s)).collect();
    let melanin = Map::from_vec(
        w,
        w,
        (0..w * w)
            .map(|i| 0.01 + 0.05 * (i % w) as f32 / w as f32)
            .collect(),
    )
    .unwrap();
    let rig = rig_of(&neutral, &targets, 32.0, Some(melanin.clone()));
    (rig, melanin)
}

fn build(c: &mut Criterion) {
    let w = 4096;
    let neutral = blood(w, 0);
    let targets: Vec<Map> = (1..=8).map(|s| blood(w, s)).collect();
    let mut g = c.benchmark_group("rig_build_4096_8_targets");
    g.sample_size(10).measurement_time(Duration::from_secs(20));
    for r in [16.0, 64.0, 256.0, 1024.0] {
        g.bench_with_input(BenchmarkId::from_parameter(r), &r, |b, &r| {
            b.iter(|| rig_of(&neutral, &targets, r, None))
        });
    }
    g.finish();
}

fn frame(c: &mut Criterion) {
    let w = 2048;
    let (rig, melanin) = frame_rig(w);
    let lut = SkinColorLut::builtin();
    let weights = vec![0.2, 0.1, 0.1, 0.1, 0.1, 0.1, 0.1, 0.1, 0.1];
    let mut plan = FramePlan::new(&rig, &melanin, &lut).unwrap();
    let mut out = vec![0u32; w * w];
    let mut g = c.benchmark_group("rig_frame_2048_8_targets");
    g.sample_size(30);
    g.bench_function("realtime_rgba8", |b| {
        b.iter(|| plan.render(&rig, &weights, 1.1, &mut out).unwrap())
    });
    g.sample_size(10);
    g.bench_function("exact_hemoglobin", |b| {
        b.iter(|| hemoglobin(&rig, &weights, 1.1).unwrap())
    });
    g.bench_function("exact_hemoglobin_and_color", |b| {
        b.iter(|| color(&hemoglobin(&rig, &weights, 1.1).unwrap(), &melanin, &lut).unwrap())
    });
    g.finish();
}

fn stats(c: &mut Criterion) {
    let map = blood(1024, 3);
    let mut g = c.benchmark_group("local_stats_1024");
    g.sample_size(10);
    for r in [8.0, 32.0, 128.0, 512.0] {
        g.bench_with_input(BenchmarkId::new("pyramid", r), &r, |b, &r| {
            b.iter(|| local_stats(&map, None, r).unwrap())
        });
        g.bench_with_input(BenchmarkId::new("exact", r), &r, |b, &r| {
            b.iter(|| local_stats_exact(&map, None, r).unwrap())
        });
    }
    g.finish();
}

#[cfg(feature = "gpu")]
fn gpu_frame(c: &mut Criterion) {
    let lut = SkinColorLut::builtin();
    let weights = vec![0.2, 0.1, 0.1, 0.1, 0.1, 0.1, 0.1, 0.1, 0.1];
    let mut g = c.benchmark_group("rig_gpu_frame_8_targets");
    g.sample_size(20);
    for w in [2048usize, 4096] {
        let (mut rig, melanin) = frame_rig(w);
        // Without and with a texture set's skin (the composition's three extra reads a texel).
        for with_skin in [false, true] {
            if with_skin {
                let ramp = |k: f32| Map::from_fn(w, w, |i| k * (i % 7) as f32);
                let skin = derma_rig::skin_response::SkinResponse::from_parts(
                    (0..w * w).map(|i| [(i % 251) as u8, 120, 90]).collect(),
                    [ramp(-0.01), ramp(-0.02), ramp(-0.015)],
                    [ramp(0.001), ramp(0.002), ramp(0.001)],
                    "bench",
                )
                .unwrap();
                rig.skin = Some(skin);
            }
            let gpu = match derma_rig::gpu_eval::GpuRig::new(&rig, &melanin, &lut) {
                Ok(gpu) => gpu,
                Err(e) => {
                    eprintln!("rig_gpu_frame skipped: {e}");
                    return;
                }
            };
            let id = if with_skin {
                format!("{w}_with_skin")
            } else {
                w.to_string()
            };
            g.bench_function(BenchmarkId::from_parameter(id), |b| {
                b.iter_custom(|iters| {
                    let s = gpu
                        .seconds_per_frame(&weights, 1.1, iters as usize)
                        .unwrap();
                    Duration::from_secs_f64(s * iters as f64)
                })
            });
        }
    }
    g.finish();
}

#[cfg(feature = "gpu")]
criterion_group!(benches, build, frame, stats, gpu_frame);
#[cfg(not(feature = "gpu"))]
criterion_group!(benches, build, frame, stats);
criterion_main!(benches);

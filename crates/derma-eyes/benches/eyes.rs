//! Eye-region benchmarks (BENCHMARKS.md, "Eye region"): one model frame on one core — the
//! per-vertex linear model ũ⁺ = Ũ e alone and the whole frame (contact, depth and globe
//! sliding included) over the built-in head's region — and the exact distance transform at
//! 1920 × 1080.
//!
//!     cargo bench -p derma-eyes --bench eyes

use criterion::{criterion_group, criterion_main, Criterion};
use derma_eyes::evaluate::{Evaluator, Frame};
use derma_eyes::rigdata::Rig;
use derma_eyes::*;
use glam::Vec2;
use std::time::Duration;

fn frames(c: &mut Criterion) {
    let head = derma_head::Head::builtin();
    let rig = Rig::new(head).unwrap();
    let m = EyeModel::fit(&rig.samples(300, 1), Components::default()).unwrap();
    let ev = Evaluator::new(&m, &rig.region, head, sliding::THICKNESS).unwrap();
    let mut g = ev.neutral.clone();
    g.eyes = [Fick {
        h: 12.0,
        v: -20.0,
        t: 0.0,
    }; 2];
    g.lids = [0, 1].map(|e| m.baseline_aperture(e, 12.0, -20.0, 0.6));
    let n = ev.optimised.len();
    let mut grp = c.benchmark_group(format!("eye frame ({n} vertices, one core)"));
    grp.measurement_time(Duration::from_secs(4));
    let mut u = vec![Vec2::ZERO; n];
    grp.bench_function("model: e = W g, u = U e", |b| {
        b.iter(|| {
            let e = ev.optimised.coefficients(&g);
            ev.optimised.evaluate(&e, &mut u);
        })
    });
    let mut f = Frame::default();
    grp.bench_function("whole frame (contact, depth, sliding)", |b| {
        b.iter(|| ev.frame(&g, &mut f))
    });
    grp.finish();
    let scene = sdf::scene::head_close_up(head, 1920, 1080);
    let mut grp = c.benchmark_group("distance fields 1920x1080");
    grp.sample_size(20);
    grp.bench_function("exact EDT", |b| b.iter(|| sdf::exact::field(&scene.g)));
    grp.bench_function("backtracking 6x8, 3 refinements", |b| {
        b.iter(|| sdf::samplers::field(&scene.g, sdf::table::DEFAULT, sdf::table::RANGE_MM))
    });
    grp.finish();
}

criterion_group!(benches, frames);
criterion_main!(benches);

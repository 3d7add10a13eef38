//! Photon throughput per core (issue 15's goal: ≥ 2·10⁶ photons/s per core on the 1-layer
//! slab): one thread walking 100 000 photons of MCML's anchor slabs — in AVX2 lanes, in portable
//! lanes, and one at a time in f64 (the walk the skin specimen uses).
//!
//! `cargo bench -p derma-optics --bench photons`

use criterion::{criterion_group, criterion_main, Criterion, Throughput};
use derma_optics::cpu::trace_range;
use derma_optics::run::Run;
use derma_optics::slab::{parse_layer, slab_stack};
use derma_optics::transport::Prepared;
use derma_optics::transport_lanes::trace_range_on;

const PHOTONS: u64 = 100_000;

fn bench(c: &mut Criterion) {
    for (name, layers) in [
        ("one_layer", vec!["1,1,100,0.9,1.4"]),
        ("van_de_hulst", vec!["0.2,10,90,0.75,1"]),
        ("two_layer", vec!["0.1,10,400,0.85,1.4", "1,1,200,0.8,1.4"]),
    ] {
        let ls = layers.iter().map(|l| parse_layer(l).unwrap()).collect();
        let run = Run::totals(slab_stack(ls, 1.0, 1.0), PHOTONS, 1);
        let p = Prepared::new(&run.stacks[0]);
        let mut g = c.benchmark_group(format!("photons_{name}"));
        g.sample_size(10);
        g.throughput(Throughput::Elements(PHOTONS));
        g.bench_function("lanes_simd", |b| {
            b.iter(|| trace_range_on(&run, &p, 0..PHOTONS, true))
        });
        g.bench_function("lanes_portable", |b| {
            b.iter(|| trace_range_on(&run, &p, 0..PHOTONS, false))
        });
        g.bench_function("scalar_f64", |b| {
            b.iter(|| trace_range(&run, std::slice::from_ref(&p), 0..PHOTONS))
        });
        g.finish();
    }
}

criterion_group!(benches, bench);
criterion_main!(benches);

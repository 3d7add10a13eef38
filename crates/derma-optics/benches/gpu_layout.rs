//! GPU photon throughput by kernel layout (issue 16): the 1-layer slab at 10⁷ photons under
//! several workgroup counts and photons per thread, with Philox's products native and from
//! halves — the figures to choose `Kernel::for_device`'s layout by on a given GPU. Every layout
//! gives the same tallies (tested), so only the time differs. Skipped where no GPU adapter
//! opens; on Mesa's lavapipe it times the CPU's emulation (use `PHOTONS=…` to shrink the run).
//!
//! `cargo bench -p derma-optics --bench gpu_layout`

use criterion::{criterion_group, criterion_main, BenchmarkId, Criterion, Throughput};
use derma_core::progress::Silent;
use derma_optics::gpu::{run_gpu_with, Kernel, Products};
use derma_optics::run::Run;
use derma_optics::slab::{parse_layer, slab_stack};

fn bench(c: &mut Criterion) {
    let device = match Kernel::for_device() {
        Ok(k) => k,
        Err(e) => {
            eprintln!("gpu_layout skipped: {e}");
            return;
        }
    };
    let photons: u64 = std::env::var("PHOTONS")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(10_000_000);
    let layer = parse_layer("1,1,100,0.9,1.4").unwrap();
    let run = Run::totals(slab_stack(vec![layer], 1.0, 1.0), photons, 1);
    let mut g = c.benchmark_group("gpu_photons_one_layer");
    g.sample_size(10);
    g.throughput(Throughput::Elements(photons));
    let mut layouts = Vec::new();
    for groups in [1024u64, 4096, 16384] {
        for photons_per_thread in [8u64, 32] {
            layouts.push(Kernel {
                groups,
                photons_per_thread,
                ..device
            });
        }
    }
    if device.products == Products::Native64 {
        layouts.push(Kernel {
            products: Products::Halves,
            ..device
        });
    }
    for k in layouts {
        let id = format!(
            "{:?}_groups{}_ppt{}",
            k.products, k.groups, k.photons_per_thread
        );
        g.bench_function(BenchmarkId::from_parameter(id), |b| {
            b.iter(|| run_gpu_with(&run, &Silent, &k).unwrap())
        });
    }
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);

//! The lane primitives the photon walk and the look-up spend their time in, per eight lanes:
//! Philox4x32-10 (scalar ×8, portable lanes, AVX2 lanes), ln and sin/cos of turns.
//!
//! `cargo bench -p derma-core --bench lanes`

use criterion::{black_box, criterion_group, criterion_main, Criterion};
use derma_core::numerics::lanes::philox4x32_10_lanes;
use derma_core::numerics::lanes::{IntLanes, Lanes, PortableF32, PortableI32};
use derma_core::rng::philox4x32_10;

fn bench(c: &mut Criterion) {
    let mut g = c.benchmark_group("lanes");
    let key = [1234u32, 5678];
    g.bench_function("philox_scalar_x8", |b| {
        b.iter(|| {
            let mut acc = 0u32;
            for l in 0..8u32 {
                acc ^= philox4x32_10(black_box([l, 0, 0x4f50, 3]), key)[0];
            }
            acc
        })
    });
    let ctr = || {
        [
            PortableI32(std::array::from_fn(|l| l as i32)),
            PortableI32::splat((), 0),
            PortableI32::splat((), 0x4f50),
            PortableI32::splat((), 3),
        ]
    };
    g.bench_function("philox_portable", |b| {
        b.iter(|| philox4x32_10_lanes(black_box(ctr()), key)[0].to_array()[0])
    });
    #[cfg(target_arch = "x86_64")]
    if let Some(t) = derma_core::numerics::lanes::Avx2::detect() {
        // The lanes run inside functions compiled for AVX2, as in the kernels.
        use derma_core::numerics::lanes::{Avx2, Avx2F32, Avx2I32};
        #[target_feature(enable = "avx2,fma")]
        unsafe fn philox(t: Avx2, key: [u32; 2]) -> i32 {
            let ctr = [
                Avx2I32::from_array(t, std::array::from_fn(|l| l as i32)),
                Avx2I32::splat(t, 0),
                Avx2I32::splat(t, 0x4f50),
                Avx2I32::splat(t, 3),
            ];
            philox4x32_10_lanes(black_box(ctr), key)[0].to_array()[0]
        }
        #[target_feature(enable = "avx2,fma")]
        unsafe fn ln(t: Avx2) -> f32 {
            let x = Avx2F32::from_array(t, black_box([0.1, 0.3, 0.5, 0.7, 0.9, 0.2, 0.4, 0.6]));
            x.ln().to_array()[0]
        }
        #[target_feature(enable = "avx2,fma")]
        unsafe fn sincos(t: Avx2) -> f32 {
            let x = Avx2F32::from_array(t, black_box([0.1, 0.3, 0.5, 0.7, 0.9, 0.2, 0.4, 0.6]));
            x.sincos_turns().0.to_array()[0]
        }
        // SAFETY (the three): the token proves AVX2 and FMA.
        g.bench_function("philox_avx2", |b| b.iter(|| unsafe { philox(t, key) }));
        g.bench_function("ln_avx2", |b| b.iter(|| unsafe { ln(t) }));
        g.bench_function("sincos_avx2", |b| b.iter(|| unsafe { sincos(t) }));
    }
    let x = PortableF32([0.1, 0.3, 0.5, 0.7, 0.9, 0.2, 0.4, 0.6]);
    g.bench_function("ln_portable", |b| {
        b.iter(|| black_box(x).ln().to_array()[0])
    });
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);

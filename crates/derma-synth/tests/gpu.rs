//! The GPU search returns exactly the CPU search's answers, and so a seed gives the same
//! texture on either (Shen et al. §3.4 run on both backends). Runs on Mesa's lavapipe in CI.

use derma_core::progress::Silent;
use derma_core::rng::Philox;
use derma_synth::coherence::{Candidates, Coherence};
use derma_synth::search::best_match_coherent_brute;
use derma_synth::{
    synthesize, CpuMatcher, ExemplarSet, GpuMatcher, Guide, Matcher, Plane, Query, Search,
    SynthOptions, Texture, Tolerance, WindowQuery,
};
use derma_test_support::skip_without_gpu;

fn exemplar(w: usize, h: usize, c: usize, seed: u64) -> Texture {
    let rng = Philox::new(seed, 0);
    let data = (0..w * h * c)
        .map(|i| {
            let (t, k) = (i / c, i % c);
            let (x, y) = ((t % w) as f32, (t / w) as f32);
            0.5 + 0.3 * ((x * 0.31 + k as f32).sin() * (y * 0.17).cos())
                + 0.2 * rng.uniform4(i as u64, 0)[0]
        })
        .collect();
    Texture::new(w, h, c, data).unwrap()
}

#[test]
fn gpu_search_equals_cpu_search() {
    // Skip only without an adapter; a shader that does not compile must fail.
    if skip_without_gpu() {
        return;
    }
    let gpu = GpuMatcher::new().unwrap();
    let set = ExemplarSet::new(vec![exemplar(40, 36, 3, 1), exemplar(34, 40, 3, 2)], 8).unwrap();
    let rng = Philox::new(9, 1);
    let w = 8;
    let queries: Vec<Query> = (0..24u64)
        .map(|i| {
            let r = rng.u32x4(i);
            let ex = (i % 2) as u32;
            let codes = (0..w * w * 3)
                .map(|j| (rng.u32x4_sub(i, j as u32 + 1)[0] % 256) as u8)
                .collect();
            let mask = (i % 3 == 0).then(|| {
                (0..w * w)
                    .map(|t| u8::from(t % w < w / 2 || t / w < w / 2))
                    .collect()
            });
            Query {
                exemplar: ex,
                codes,
                mask,
                guesses: vec![r[0] % 500, r[1] % 700],
                salt: r[2],
            }
        })
        .collect();
    let pen: Vec<Vec<u32>> = set
        .exemplars
        .iter()
        .map(|e| {
            let (cw, ch) = e.candidates(w);
            (0..cw * ch)
                .map(|k| ((k * 7919) % 11) as u32 * 50)
                .collect()
        })
        .collect();
    // Room for only 100 survivors forces the uncompacted fallback.
    let cramped = GpuMatcher::with_survivor_room(100).unwrap();
    // Over every position, and over the k-coherence candidates (with many random ones, so the
    // survivors overflow the cramped room there too).
    let tables = Coherence::new(&set, w);
    let scopes = [
        None,
        Some(Candidates {
            tables: &tables,
            random: 64,
        }),
    ];
    for coherence in scopes {
        for tol in [Tolerance(0), Tolerance::from_fraction(0.1)] {
            for penalty in [None, Some(&pen[..])] {
                let s = Search {
                    w,
                    tol,
                    penalty,
                    prepared: None,
                    coherence,
                };
                let what = format!(
                    "tolerance {tol:?}, penalty {}, coherent {}",
                    penalty.is_some(),
                    coherence.is_some()
                );
                let a = CpuMatcher.best_matches(&set, &s, &queries).unwrap();
                let b = gpu.best_matches(&set, &s, &queries).unwrap();
                assert_eq!(a, b, "{what}");
                let c = cramped.best_matches(&set, &s, &queries).unwrap();
                assert_eq!(a, c, "uncompacted, {what}");
                if let Some(c) = coherence {
                    for (q, m) in queries.iter().zip(&a) {
                        assert_eq!(*m, best_match_coherent_brute(&set, &s, c, q), "{what}");
                    }
                }
            }
        }
    }
}

/// A texture's values as bits: "identical" includes the sign of zero.
fn bits(t: &Texture) -> Vec<u32> {
    t.data.iter().map(|v| v.to_bits()).collect()
}

#[test]
fn a_seed_gives_the_same_texture_on_cpu_and_gpu() {
    // Skip only without an adapter; a shader that does not compile must fail.
    if skip_without_gpu() {
        return;
    }
    // One exemplar: the patch pass runs on the GPU (patch_pass.wgsl) where the device has
    // 64-bit integers (lavapipe has them). Sizes off the patch grid pull the last patches in
    // to the edge (a plane) or wrap them over the first (a torus), so patches of a wavefront
    // overlap; λ = 0 charges only the windows accepted earlier in a wavefront.
    let gpu = GpuMatcher::new().unwrap();
    let tight = GpuMatcher::with_patch_schedule(1, 3).unwrap();
    let set = ExemplarSet::new(vec![exemplar(48, 48, 2, 5)], 16).unwrap();
    // The smallest exemplar for 16² patches, 32², has 17² candidates; one accepted window bars
    // up to 15² of them, and four windows can bar all: the 160 × 144 output's wavefronts (up to
    // ten patches) run out of windows apart, so the oldest drop out of force and later rounds
    // search four patches at a time (breaking either rule in the shader fails this test).
    let small = ExemplarSet::new(vec![exemplar(32, 32, 1, 9)], 16).unwrap();
    // Without the correction, the E-step's two-band blend is the output (the correction makes
    // every texel an exemplar copy again).
    for (set, tile, width, height, occurrence, correction) in [
        (&set, false, 80, 64, 1.0, 1),
        (&set, true, 80, 64, 1.0, 0),
        (&set, false, 70, 58, 1.0, 0),
        (&set, true, 70, 58, 0.0, 1),
        (&small, false, 160, 144, 1.0, 0),
        (&small, true, 64, 64, 0.0, 1),
    ] {
        let opts = SynthOptions {
            width,
            height,
            patch: 16,
            seed: 42,
            tile,
            occurrence,
            correction,
            // The self-adaptive skip where it acts (off by default).
            settle: if width >= 160 {
                derma_synth::settle::EXHAUSTIVE_FACTOR
            } else {
                0.0
            },
            ..Default::default()
        };
        let none = Silent;
        let a = synthesize(set, &opts, None, &CpuMatcher, &none).unwrap();
        let b = synthesize(set, &opts, None, &gpu, &none).unwrap();
        assert_eq!(
            bits(&a.texture),
            bits(&b.texture),
            "tile {tile}, {width}×{height}, λ {occurrence}"
        );
        assert_eq!(a.source, b.source);
        assert_eq!(a.source_exemplar, b.source_exemplar);
        // The self-adaptive skip acted the same way on both.
        assert_eq!(a.passes, b.passes);
        if width >= 160 {
            assert!(
                a.passes.iter().any(|p| p.searched < p.windows),
                "{:?}",
                a.passes
            );
        }
        // One round per wavefront, three wavefronts a submission: most wavefronts stop their
        // submission and get more rounds; the texture is the same.
        let c = synthesize(set, &opts, None, &tight, &none).unwrap();
        assert_eq!(
            a.texture, c.texture,
            "one round a wavefront, {width}×{height}"
        );
    }
}

#[test]
fn windows_of_the_canvas_kept_on_the_gpu_get_the_cpu_answers() {
    // The optimisation passes' searches read their windows from a plane the GPU keeps: windows
    // at any origin, across the wrap of a torus, in two exemplars, with up to five guesses.
    if skip_without_gpu() {
        return;
    }
    let gpu = GpuMatcher::new().unwrap();
    let set = ExemplarSet::new(vec![exemplar(40, 36, 3, 1), exemplar(34, 40, 3, 2)], 8).unwrap();
    let (pw, ph) = (37, 29);
    let rng = Philox::new(4, 2);
    let codes: Vec<u8> = (0..pw * ph * 3)
        .map(|i| (rng.u32x4(i as u64)[0] % 256) as u8)
        .collect();
    for wrap in [false, true] {
        let plane = Plane {
            width: pw,
            height: ph,
            channels: 3,
            wrap,
            codes: &codes,
        };
        for w in [4, 8] {
            let (xs, ys) = if wrap {
                (pw, ph)
            } else {
                (pw + 1 - w, ph + 1 - w)
            };
            let queries: Vec<WindowQuery> = (0..60u64)
                .map(|i| {
                    let r = rng.u32x4_sub(i, 7 + w as u32);
                    WindowQuery {
                        exemplar: (i % 2) as u32,
                        x: r[0] % xs as u32,
                        y: r[1] % ys as u32,
                        guesses: (0..1 + i as u32 % 5).map(|g| r[2] % 900 + g * 31).collect(),
                        salt: r[3],
                    }
                })
                .collect();
            let tables = Coherence::new(&set, w);
            let coherent = Some(Candidates {
                tables: &tables,
                random: 8,
            });
            for (tol, coherence) in [
                (Tolerance(0), None),
                (Tolerance::from_fraction(0.1), None),
                (Tolerance(0), coherent),
                (Tolerance::from_fraction(0.1), coherent),
            ] {
                let s = Search {
                    w,
                    tol,
                    penalty: None,
                    prepared: None,
                    coherence,
                };
                let a = CpuMatcher
                    .window_matches(&set, &s, &plane, &queries, &Silent)
                    .unwrap();
                let b = gpu
                    .window_matches(&set, &s, &plane, &queries, &Silent)
                    .unwrap();
                let what = format!(
                    "wrap {wrap}, side {w}, tolerance {tol:?}, coherent {}",
                    coherence.is_some()
                );
                assert_eq!(a, b, "{what}");
                // The same answers as the windows gathered and uploaded.
                let gathered: Vec<Query> = queries.iter().map(|q| q.query(&plane, w)).collect();
                assert_eq!(a, gpu.best_matches(&set, &s, &gathered).unwrap(), "{what}");
            }
        }
    }
}

#[test]
fn a_guided_tileable_synthesis_is_the_same_on_cpu_and_gpu() {
    // Two exemplars chosen by a guide, wrapping: the correction's proposals keep to the guide's
    // exemplar and cross the wrap, on the GPU as on the CPU.
    if skip_without_gpu() {
        return;
    }
    let gpu = GpuMatcher::new().unwrap();
    let set = ExemplarSet::new(vec![exemplar(40, 40, 1, 3), exemplar(36, 44, 1, 4)], 16).unwrap();
    let levels: Vec<f32> = (0..16 * 16).map(|t| ((t % 16) / 8) as f32).collect();
    let guide = Guide::from_levels(16, 16, &levels, 2);
    // Without the correction the E-step's blend is the output: both exemplars' bands on the GPU.
    for correction in [0, 1, 2] {
        let opts = SynthOptions {
            width: 64,
            height: 48,
            patch: 16,
            seed: 3,
            tile: true,
            correction,
            ..Default::default()
        };
        let a = synthesize(&set, &opts, Some(&guide), &CpuMatcher, &Silent).unwrap();
        let b = synthesize(&set, &opts, Some(&guide), &gpu, &Silent).unwrap();
        assert_eq!(a.texture, b.texture, "{correction} correction passes");
        assert_eq!(a.source, b.source);
        assert_eq!(a.source_exemplar, b.source_exemplar);
        assert!(a.source_exemplar.contains(&0) && a.source_exemplar.contains(&1));
    }
}

/// The f64 pairs whose f32 quotients the GPU E-step's long division must get right: random
/// weighted sums over random weight sums, exact ties of the f32 rounding, quotients that the
/// f64 rounding turns into ties (double rounding), subnormal and overflowing f32 results.
fn quotient_pairs() -> Vec<(f64, f64)> {
    let rng = Philox::new(11, 3);
    let mut pairs = Vec::new();
    for i in 0..20_000u64 {
        let u = rng.uniform4(i, 0);
        let r = rng.u32x4(i);
        let b = (0..1 + r[0] % 16)
            .map(|k| rng.uniform4(i, k + 1)[0] as f64 * 1000.0 + 1e-3)
            .sum::<f64>();
        let a = (u[1] as f64 - 0.3) * b * 2f64.powi(r[1] as i32 % 9 - 4);
        pairs.push((a, b));
        // Small integers: exact quotients, many at a tie of either rounding.
        pairs.push((((r[2] % 2001) as f64 - 1000.0), (1 + r[3] % 97) as f64));
        // An odd 25-bit integer times a power of two: exactly halfway between two f32s.
        let m = ((r[2] | 1 << 24) & ((1 << 25) - 1)) | 1;
        pairs.push((m as f64 * 2f64.powi(r[3] as i32 % 60 - 30), 1.0));
        // Just off that tie, in f64: f64 rounding keeps it off, or lands on it.
        let t = m as f64;
        pairs.push((t * (1.0 + 2f64.powi(-52)), 1.0));
        pairs.push((t, 1.0 + 2f64.powi(-52)));
        pairs.push((t * 3.0 + 1.0, 3.0));
        // Within an f64 ulp above an f32 tie T: (b·T + k·ulp) / b = T + (k/b) ulp, whose f64
        // rounding (k/b just above a half: the sticky bit decides) makes it T or T + 1 ulp,
        // and so the f32 rounding down (to even) or up.
        let tie = m as f64 * 2f64.powi(-24);
        for b in [3.0, 5.0, 7.0, 9.0, 11.0, 13.0] {
            for k in 1..b as i32 {
                pairs.push((b * tie + k as f64 * 2f64.powi(-52), b));
            }
        }
    }
    for e in [-160, -150, -149, -140, -127, -126, -125, 127, 128] {
        for m in [
            1.0,
            1.5,
            1.999_999_9,
            0.75,
            1.0 + 2f64.powi(-24),
            1.0 - 2f64.powi(-25),
        ] {
            pairs.push((m * 2f64.powi(e), 1.0));
            pairs.push((-m * 2f64.powi(e) * 3.0, 3.0));
        }
    }
    pairs.push((0.0, 5.0));
    pairs.push((-0.0, 5.0));
    pairs.push((f32::MAX as f64, 1.0));
    pairs.push((f32::MAX as f64 * (1.0 + 2f64.powi(-25)), 1.0));
    pairs
}

#[test]
fn the_gpu_divides_and_rounds_like_rust() {
    // The E-step's quotient (acc / Σω) as f32 — f64 division then rounding to f32, both to
    // nearest even — formed by integer long division in e_step.wgsl, since Vulkan's f64
    // division may be 2.5 ulp off.
    if skip_without_gpu() {
        return;
    }
    // Codes too (the quantiser's boundaries compared as integer keys), at every boundary and
    // a key either side of it.
    let q = derma_synth::Quantizer {
        lo: vec![-0.37],
        hi: vec![1.91],
    };
    let mut pairs = quotient_pairs();
    for &t in &q.boundaries(0)[1..] {
        for key in [t - 1, t, t + 1] {
            pairs.push((derma_synth::exemplar::from_order_key(key) as f64, 1.0));
        }
    }
    let Some(got) = derma_synth::gpu_e_step::gpu_quotients(&pairs, &q).unwrap() else {
        let f = derma_core::gpu::context().unwrap().device.features();
        assert!(
            !f.contains(wgpu::Features::SHADER_F64 | wgpu::Features::SHADER_INT64),
            "the device has 64-bit floats and integers but the E-step did not run"
        );
        eprintln!("no 64-bit floats on this adapter: the E-step blends on the CPU");
        return;
    };
    let mut wrong = 0;
    for (&(a, b), &(g, code)) in pairs.iter().zip(&got) {
        let want = (a / b) as f32;
        if want.to_bits() != g.to_bits() || code != q.quantize(0, want) {
            if wrong < 10 {
                eprintln!(
                    "{a:e} / {b:e}: want {want:e} ({:#x}, code {}), got {g:e} ({:#x}, code {code})",
                    want.to_bits(),
                    q.quantize(0, want),
                    g.to_bits()
                );
            }
            wrong += 1;
        }
    }
    assert_eq!(
        wrong,
        0,
        "{wrong} of {} quotients or codes differ",
        pairs.len()
    );
}

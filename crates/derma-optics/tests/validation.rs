//! The transport against independent references: adding-doubling (iadpython, values generated
//! by scripts/iad_reference.py), van de Hulst's table and MCML's published results, exact
//! conservation, reciprocity, determinism, CPU/GPU agreement and the shape of skin spectra.

use derma_core::progress::Silent;
use derma_optics::cpu::run_cpu;
use derma_optics::layer::{Bottom, Layer, Stack, Surface};
use derma_optics::run::Run;
use derma_optics::simulate::{skin_result, skin_run, SkinSimConfig};
use derma_optics::slab::{parse_layer, slab_stack, SlabResult};
use derma_optics::tally::{BrdfBins, Tally};
use derma_optics::transport::Incidence;
use derma_optics::{BioTexel, Device};

fn slab(run: &Run) -> SlabResult {
    let t = run_cpu(run, &Silent).unwrap();
    SlabResult::from_tally(&t, 1.0, "cpu")
}

fn layers(spec: &[&str]) -> Vec<Layer> {
    spec.iter().map(|l| parse_layer(l).unwrap()).collect()
}

/// Checks an MC estimate against a reference: within `k` standard errors and `abs` absolute.
fn close(what: &str, mc: f64, se: f64, reference: f64, abs: f64) {
    let d = (mc - reference).abs();
    assert!(
        d <= 3.0 * se && d <= abs,
        "{what}: Monte Carlo {mc:.5} ± {se:.5} vs reference {reference:.5} (|Δ| = {d:.5})"
    );
}

#[test]
fn adding_doubling_cases() {
    let text = include_str!("data/iad_cases.json");
    let data: serde_json::Value = serde_json::from_str(text).unwrap();
    let cases = data["cases"].as_array().unwrap();
    assert!(cases.len() >= 12);
    for c in cases {
        let name = c["name"].as_str().unwrap();
        let mut ls: Vec<Layer> = c["layers"]
            .as_array()
            .unwrap()
            .iter()
            .map(|l| {
                let f = |k: &str| l[k].as_f64().unwrap();
                Layer::plain(
                    f("d_mm"),
                    f("mua_per_cm") / 10.0,
                    f("mus_per_cm") / 10.0,
                    f("g"),
                    f("n"),
                )
            })
            .collect();
        // iadpython's n_above/n_below are glass slides with air beyond: clear layers here.
        let na = c["n_above"].as_f64().unwrap();
        let nb = c["n_below"].as_f64().unwrap();
        if na != 1.0 {
            ls.insert(0, Layer::plain(1.0, 0.0, 0.0, 0.0, na));
        }
        if nb != 1.0 {
            ls.push(Layer::plain(1.0, 0.0, 0.0, 0.0, nb));
        }
        let r = slab(&Run::totals(slab_stack(ls, 1.0, 1.0), 400_000, 7));
        let se_r = (r.stderr.r_specular.powi(2) + r.stderr.r_diffuse.powi(2)).sqrt();
        close(
            &format!("{name}: R"),
            r.r_specular + r.r_diffuse,
            se_r,
            c["r_total"].as_f64().unwrap(),
            0.002,
        );
        close(
            &format!("{name}: T"),
            r.t_total,
            r.stderr.t_total,
            c["t_total"].as_f64().unwrap(),
            0.002,
        );
    }
}

#[test]
fn van_de_hulst_table_35_and_mcml() {
    // van de Hulst 1980, table 35, as used in MCML's paper (Wang, Jacques & Zheng 1995, §4.1):
    // μa 10 /cm, μs 90 /cm, g 0.75, d 0.02 cm, n 1: Rd 0.09739, Tt 0.66096.
    let r = slab(&Run::totals(
        slab_stack(layers(&["0.2,10,90,0.75,1"]), 1.0, 1.0),
        1_000_000,
        3,
    ));
    close(
        "van de Hulst Rd",
        r.r_diffuse,
        r.stderr.r_diffuse,
        0.09739,
        0.002,
    );
    close(
        "van de Hulst Tt",
        r.t_total,
        r.stderr.t_total,
        0.66096,
        0.002,
    );
    assert_eq!(r.r_specular, 0.0);
    // MCML's own result for that case (Wang et al. 1995, quoted with its error in
    // SKIN-OPTICS-REFERENCES): Rd 0.09721, Tt 0.66109 — agreement within the combined errors.
    assert!(
        (r.r_diffuse - 0.09721).abs()
            < 4.0 * (r.stderr.r_diffuse.powi(2) + 0.0003f64.powi(2)).sqrt()
    );
    assert!(
        (r.t_total - 0.66109).abs() < 4.0 * (r.stderr.t_total.powi(2) + 0.0003f64.powi(2)).sqrt()
    );
}

#[test]
fn semi_infinite_media() {
    // Adding-doubling (iadpython 0.5.3) for semi-infinite media, SKIN-OPTICS-REFERENCES:
    // albedo 0.9, g 0, n 1.5: R 0.2601; albedo 0.99, g 0.9, n 1.4: R 0.2790 (specular included).
    for (spec, reference) in [("1000,10,90,0,1.5", 0.2601), ("1000,1,99,0.9,1.4", 0.2790)] {
        let r = slab(&Run::totals(
            slab_stack(layers(&[spec]), 1.0, 1.0),
            300_000,
            5,
        ));
        let se = (r.stderr.r_specular.powi(2) + r.stderr.r_diffuse.powi(2)).sqrt();
        close(spec, r.r_specular + r.r_diffuse, se, reference, 0.003);
        assert!(r.t_total < 1e-6);
    }
}

fn skin_tally(bio: &BioTexel, photons: u64) -> (Run, Tally) {
    let cfg = SkinSimConfig {
        photons,
        ..SkinSimConfig::default()
    };
    let run = skin_run(bio, &cfg);
    let t = run_cpu(&run, &Silent).unwrap();
    (run, t)
}

#[test]
fn energy_bookkeeping_is_exact() {
    // R + T + A equals the launched weight (photons + roulette's net) to rounding, for slabs of
    // every kind and the skin specimen; roulette's net is zero within noise.
    let runs = vec![
        Run::totals(
            slab_stack(layers(&["1,1,100,0.9,1.4"]), 1.0, 1.0),
            50_000,
            1,
        ),
        Run::totals(
            slab_stack(
                layers(&["0.1,10,400,0.85,1.4", "1,1,200,0.8,1.33"]),
                1.2,
                1.5,
            ),
            50_000,
            2,
        ),
        skin_run(
            &BioTexel::FAIR,
            &SkinSimConfig {
                photons: 41_000,
                ..SkinSimConfig::default()
            },
        ),
    ];
    for run in runs {
        let t = run_cpu(&run, &Silent).unwrap();
        assert!(
            t.bookkeeping_error().abs() <= 1e-9 * t.weight_total(),
            "bookkeeping error {}",
            t.bookkeeping_error()
        );
        let absorbed: f64 = t.absorbed.iter().flatten().sum();
        assert!(
            (absorbed - t.sum[3]).abs() <= 1e-9 * t.weight_total(),
            "per-layer absorption sums to A"
        );
        assert!(t.roulette.abs() < 0.01 * t.photons as f64);
    }
}

#[test]
fn lossless_index_matched_specimen_returns_everything() {
    let run = Run::totals(
        slab_stack(layers(&["0.5,0,100,0.8,1", "0.5,0,50,0,1"]), 1.0, 1.0),
        50_000,
        9,
    );
    let r = slab(&run);
    assert_eq!(r.absorbed, 0.0);
    assert!((r.r_specular + r.r_diffuse + r.t_total - 1.0).abs() < 1e-12);
}

#[test]
fn results_do_not_depend_on_thread_count() {
    let run = skin_run(
        &BioTexel::FAIR,
        &SkinSimConfig {
            photons: 20_000,
            ..SkinSimConfig::default()
        },
    );
    let one = rayon::ThreadPoolBuilder::new()
        .num_threads(1)
        .build()
        .unwrap();
    let two = rayon::ThreadPoolBuilder::new()
        .num_threads(2)
        .build()
        .unwrap();
    let a = one.install(|| run_cpu(&run, &Silent).unwrap());
    let b = two.install(|| run_cpu(&run, &Silent).unwrap());
    assert_eq!(a, b);
    let c = run_cpu(
        &Run {
            seed: 2,
            ..run.clone()
        },
        &Silent,
    )
    .unwrap();
    assert_ne!(a.sum, c.sum, "another seed gives another sample");
}

#[test]
#[ignore = "slow: scripts/test_slow.sh"]
fn sampled_brdf_is_reciprocal() {
    // A smooth-surfaced scattering slab over a grey diffuse floor: f(θa → θb) = f(θb → θa).
    // Compared after summing over azimuth bins (Σ_φ f is reciprocal too), per zenith pair.
    let stack = Stack {
        layers: vec![Layer::plain(0.3, 0.2, 10.0, 0.6, 1.3)],
        n_above: 1.0,
        bottom: Bottom::Lambertian { albedo: 0.6 },
        surface: Surface::Smooth,
    };
    let bins = BrdfBins {
        theta_in: 6,
        theta_out: 6,
        phi: 4,
    };
    let run = Run {
        stacks: vec![stack],
        photons: 3_000_000,
        seed: 11,
        incidence: Incidence::ArcsinZenith,
        brdf: Some(bins),
        profile: None,
        channel_weights: Vec::new(),
    };
    let t = run_cpu(&run, &Silent).unwrap();
    let f = |ti: usize, to: usize| -> f64 {
        (0..bins.phi)
            .map(|p| t.brdf[bins.index(ti, to, p)])
            .sum::<f64>()
            / (t.brdf_in[ti] as f64 * bins.projected_solid_angle(to))
    };
    let mut worst: f64 = 0.0;
    for a in 0..5 {
        for b in a + 1..5 {
            let (x, y) = (f(a, b), f(b, a));
            worst = worst.max(((x - y) / (0.5 * (x + y))).abs());
        }
    }
    assert!(worst < 0.05, "worst relative asymmetry {worst:.3}");
}

#[cfg(feature = "gpu")]
#[test]
fn cpu_and_gpu_agree() {
    if derma_test_support::skip_without_gpu() {
        return;
    }
    let run = Run::totals(
        slab_stack(layers(&["1,1,100,0.9,1.4"]), 1.0, 1.0),
        100_000,
        4,
    );
    let c = slab(&run);
    let tg = derma_optics::gpu::run_gpu(&run, &Silent).unwrap();
    let g = SlabResult::from_tally(&tg, 1.0, "gpu");
    // Same photons, same random streams: f32 paths track the f64 ones, so the two agree far
    // better than two independent samples; the test still only asks for statistical agreement.
    for (what, a, b, se) in [
        ("Rd", c.r_diffuse, g.r_diffuse, c.stderr.r_diffuse),
        ("T", c.t_total, g.t_total, c.stderr.t_total),
        ("A", c.absorbed, g.absorbed, c.stderr.absorbed),
    ] {
        assert!(
            (a - b).abs() < 3.0 * se * 2f64.sqrt(),
            "{what}: cpu {a} gpu {b} ± {se}"
        );
    }
    assert!((c.r_specular - g.r_specular).abs() < 1e-6);
    assert!(
        g.bookkeeping_error.abs() < 1e-5,
        "GPU books balance to f32 precision"
    );
    // The GPU is deterministic too (integer tallies).
    assert_eq!(tg, derma_optics::gpu::run_gpu(&run, &Silent).unwrap());
    // And the skin specimen (micro-facet surface, white hypodermis) agrees in colour.
    let cfg = SkinSimConfig {
        photons: 41_000,
        ..SkinSimConfig::default()
    };
    let sr = skin_run(&BioTexel::FAIR, &cfg);
    let a = skin_result(
        &BioTexel::FAIR,
        &cfg,
        &run_cpu(&sr, &Silent).unwrap(),
        Device::Cpu,
        1.0,
    );
    let b = skin_result(
        &BioTexel::FAIR,
        &cfg,
        &derma_optics::gpu::run_gpu(&sr, &Silent).unwrap(),
        Device::Gpu,
        1.0,
    );
    for c in 0..3 {
        assert!(
            (a.linear_srgb[c] - b.linear_srgb[c]).abs() < 0.01,
            "{:?} vs {:?}",
            a.linear_srgb,
            b.linear_srgb
        );
    }
}

#[cfg(feature = "gpu")]
#[test]
fn gpu_results_do_not_depend_on_the_kernel_layout() {
    if derma_test_support::skip_without_gpu() {
        return;
    }
    use derma_optics::gpu::{run_gpu_with, Kernel, Products};
    let device = Kernel::for_device().unwrap();
    // Many workgroups with one photon a thread against few with many, and Philox's products
    // from 16-bit halves against the device's own (native 64-bit where it has them): the
    // tallies are sums of per-photon integers, so they must agree to the bit.
    let layouts = [
        Kernel {
            products: Products::Halves,
            groups: 3,
            photons_per_thread: 1,
        },
        Kernel {
            groups: 4096,
            photons_per_thread: 32,
            ..device
        },
    ];
    // Three wavelengths over two layers with a floor, oblique incidence, BRDF and profile bins
    // (every kind of tally), and the skin specimen (micro-facet surface, six layers).
    let stack = |mua: f64| Stack {
        layers: vec![
            Layer::plain(0.1, mua, 20.0, 0.8, 1.4),
            Layer::plain(0.4, 0.5 * mua, 8.0, 0.7, 1.37),
        ],
        n_above: 1.0,
        bottom: Bottom::Lambertian { albedo: 0.5 },
        surface: Surface::Smooth,
    };
    let slab = Run {
        stacks: vec![stack(0.3), stack(1.0), stack(3.0)],
        photons: 6_001,
        seed: 5,
        incidence: Incidence::ArcsinZenith,
        brdf: Some(BrdfBins {
            theta_in: 3,
            theta_out: 4,
            phi: 2,
        }),
        profile: Some(derma_optics::tally::ProfileBins {
            bins: 8,
            d_max_mm: 2.0,
        }),
        channel_weights: Vec::new(),
    };
    let cfg = SkinSimConfig {
        photons: 3_000,
        ..SkinSimConfig::default()
    };
    let skin = skin_run(&BioTexel::FAIR, &cfg);
    for run in [&slab, &skin] {
        let a = run_gpu_with(run, &Silent, &layouts[0]).unwrap();
        let b = run_gpu_with(run, &Silent, &layouts[1]).unwrap();
        assert_eq!(a, b, "{:?} against {:?}", layouts[0], layouts[1]);
        assert_eq!(a.photons, run.photons);
        assert_eq!(a.per_lambda_count.iter().sum::<u64>(), run.photons);
    }
}

#[test]
#[ignore = "slow: scripts/test_slow.sh"]
fn skin_spectra_have_the_known_shape() {
    // Fair, medium and dark epidermis over a well-perfused dermis. Features (not bytes): the
    // hemoglobin Soret dip near 420 nm and Q-band dips near 542 and 577 nm with the 560 nm hump
    // between them; reflectance rising towards the red; darker skin reflects less.
    let mut prev: Option<Vec<f64>> = None;
    for melanin in [0.02f32, 0.1, 0.35] {
        let bio = BioTexel {
            melanin,
            blood: 0.03,
            ..BioTexel::FAIR
        };
        let (run, t) = skin_tally(&bio, 820_000);
        let cfg = SkinSimConfig {
            photons: run.photons,
            ..SkinSimConfig::default()
        };
        let r = skin_result(&bio, &cfg, &t, Device::Cpu, 1.0).r_diffuse;
        let at = |nm: usize| r[(nm - 380) / 10];
        assert!(
            at(700) > at(600) && at(600) > at(500),
            "rising to red, melanin {melanin}: {r:?}"
        );
        if melanin < 0.05 {
            // Darker epidermis absorbs the violet more than blood does; the dip is a fair-skin feature.
            assert!(
                at(420) < at(450) && at(420) < at(390).max(at(400)),
                "Soret dip, melanin {melanin}"
            );
        }
        if melanin < 0.3 {
            // The 560 nm hump stands above the line through the 540 and 580 nm dips (in dark
            // skin, melanin flattens the Q bands away, as in measured spectra).
            assert!(
                at(560) > 0.5 * (at(540) + at(580)) && at(540) < at(560),
                "Q bands, melanin {melanin}"
            );
        }
        if melanin < 0.05 {
            assert!(at(540) < at(520), "542 nm dip below the 520 nm shoulder");
        }
        if let Some(p) = &prev {
            for nm in (450..=700).step_by(50) {
                assert!(
                    at(nm) < p[(nm - 380) / 10],
                    "more melanin reflects less at {nm} nm"
                );
            }
        }
        prev = Some(r);
    }
}

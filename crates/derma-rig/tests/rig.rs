//! The rig against the paper (Jimenez et al. 2010): eq. 3 exactness, one-hot weights reproduce a
//! target's local statistics, appearance transfer, global histogram matching against
//! scikit-image, the σ_n → 0 guard, save/load, the real-time frame path and determinism.

use derma_core::Map;
use derma_rig::evaluate::{color, hemoglobin, unpack_rgba8, FramePlan};
use derma_rig::local_stats::{local_stats, local_stats_exact};
use derma_rig::weights::{resolve, Normalization, WeightSpec};
use derma_rig::{BasisOptions, Rig, TargetSource, TargetSpec, TransferMode};
use derma_shading::skin_color_lut::SkinColorLut;

/// Texel noise from an integer hash, uniform in [0, 1).
fn hash(i: usize, seed: u32) -> f32 {
    let mut x = (i as u32).wrapping_mul(0x9E37_79B9) ^ seed.wrapping_mul(0x85EB_CA6B);
    x ^= x >> 15;
    x = x.wrapping_mul(0x2C1B_3C6D);
    x ^= x >> 12;
    x = x.wrapping_mul(0x297A_2D39);
    x ^= x >> 15;
    (x >> 8) as f32 / (1u32 << 24) as f32
}

/// A hemoglobin-like map: a smooth perfusion pattern times vascular texture (noise smoothed over
/// a few texels), around `base` (volume fraction).
fn blood_map(w: usize, h: usize, seed: u32, base: f32) -> Map {
    blood_map_with(w, h, seed, base, 0.3, 0.8)
}

/// `low`: amplitude of the smooth pattern; `texture`: amplitude of the vascular texture.
fn blood_map_with(w: usize, h: usize, seed: u32, base: f32, low: f32, texture: f32) -> Map {
    let raw: Vec<f32> = (0..w * h).map(|i| hash(i, seed)).collect();
    let smooth = |x: usize, y: usize| {
        let mut s = 0.0;
        for dy in 0..3 {
            for dx in 0..3 {
                s += raw[((y + dy) % h) * w + (x + dx) % w];
            }
        }
        s / 9.0
    };
    let v = (0..w * h)
        .map(|i| {
            let (x, y) = (i % w, i / w);
            let low = 1.0
                + low
                    * (x as f32 * std::f32::consts::TAU / w as f32).sin()
                    * (y as f32 * std::f32::consts::PI / h as f32).sin();
            base * low * (1.0 - 0.5 * texture + texture * smooth(x, y))
        })
        .collect();
    Map::from_vec(w, h, v).unwrap()
}

fn opts(r: f64, basis: usize) -> BasisOptions {
    BasisOptions {
        radius: r,
        basis_size: (basis, basis),
        sigma_floor: derma_rig::basis::DEFAULT_SIGMA_FLOOR,
    }
}

/// A rig of `neutral` with one map target.
fn single_target_rig(neutral: &Map, name: &str, target: &Map, o: BasisOptions) -> Rig {
    let spec = TargetSpec {
        name: name.into(),
        source: TargetSource::Map(target),
        global_scale: None,
    };
    Rig::build(neutral, None, None, &[spec], &o).unwrap()
}

fn one_hot(rig: &Rig, name: &str) -> Vec<f32> {
    let names: Vec<&str> = rig.targets.iter().map(|t| t.name.as_str()).collect();
    let spec: WeightSpec = format!("{name}=1").parse().unwrap();
    resolve(&names, &spec, Normalization::default()).unwrap()
}

fn max_abs_diff(a: &Map, b: &Map) -> f32 {
    a.data()
        .iter()
        .zip(b.data())
        .map(|(x, y)| (x - y).abs())
        .fold(0.0, f32::max)
}

#[test]
fn eq3_affine_target_is_reproduced_exactly_and_neutral_pose_is_the_neutral() {
    let n = blood_map(128, 128, 1, 0.02);
    let affine =
        Map::from_vec(128, 128, n.data().iter().map(|v| 1.6 * v + 0.004).collect()).unwrap();
    let rig = single_target_rig(&n, "flush", &affine, opts(12.0, 32));
    let h = hemoglobin(&rig, &one_hot(&rig, "flush"), 1.0).unwrap();
    // Eq. 3: μ_i = 1.6 μ_n + 0.004 and σ_i = 1.6 σ_n everywhere, so H = 1.6 H_n + 0.004 exactly
    // (to float rounding), whatever the upsampling of the basis.
    let err = max_abs_diff(&h, &affine);
    assert!(err < 2e-6, "affine target error {err}");
    let h = hemoglobin(&rig, &[1.0, 0.0], 1.0).unwrap();
    assert!(max_abs_diff(&h, &n) < 1e-7, "neutral pose");
    // Half way: the affine blend of the two (eq. 6 is linear in the weights).
    let h = hemoglobin(&rig, &[0.5, 0.5], 1.0).unwrap();
    let want = Map::from_vec(128, 128, n.data().iter().map(|v| 1.3 * v + 0.002).collect()).unwrap();
    assert!(max_abs_diff(&h, &want) < 2e-6);
    // The global scale multiplies the whole map.
    let h = hemoglobin(&rig, &[1.0, 0.0], 1.27).unwrap();
    assert!((h.data()[77] - 1.27 * n.data()[77]).abs() < 1e-7);
}

#[test]
fn one_hot_weights_reproduce_the_targets_local_statistics() {
    // Eq. 1–3 hold where the local statistics vary slowly over the disk: strong vascular
    // texture, perfusion changes over several radii.
    let (w, r) = (256, 8.0);
    let n = blood_map_with(w, w, 2, 0.015, 0.0, 1.6);
    let other = blood_map_with(w, w, 3, 0.015, 0.0, 1.6);
    let t = Map::from_vec(
        w,
        w,
        (0..w * w)
            .map(|i| {
                let (x, y) = ((i % w) as f32 / w as f32, (i / w) as f32 / w as f32);
                let gain = 1.0 + 0.4 * (-((x - 0.3).powi(2) + (y - 0.5).powi(2)) / 0.12).exp()
                    - 0.3 * (-((y - 0.8).powi(2)) / 0.06).exp();
                gain * (0.5 * n.data()[i] + 0.5 * other.data()[i])
            })
            .collect(),
    )
    .unwrap();
    let rig = single_target_rig(&n, "t", &t, opts(r, 64));
    let h = hemoglobin(&rig, &one_hot(&rig, "t"), 1.0).unwrap();
    let got = local_stats_exact(&h, None, r).unwrap();
    let want = local_stats_exact(&t, None, r).unwrap();
    // Compare away from the border (edge clipping differs between the maps' spans).
    let (mut em, mut es, mut sd) = (0.0f64, 0.0f64, 0.0f64);
    let mut count = 0.0;
    for y in 24..w - 24 {
        for x in 24..w - 24 {
            em += (got.mean.get(x, y) - want.mean.get(x, y)).abs() as f64;
            es += (got.sigma.get(x, y) - want.sigma.get(x, y)).abs() as f64;
            sd += want.sigma.get(x, y) as f64;
            count += 1.0;
        }
    }
    let (em, es, sd) = (em / count, es / count, sd / count);
    // The change the target makes to the local mean (the quantity the rig must carry).
    let ns = local_stats_exact(&n, None, r).unwrap();
    let change = ns
        .mean
        .data()
        .iter()
        .zip(want.mean.data())
        .map(|(a, b)| (a - b).abs() as f64)
        .sum::<f64>()
        / (w * w) as f64;
    // What remains is second order: the stored μ_i is itself a disk average, and the local mean
    // of the result averages it again (curvature of the mean on the scale of r).
    assert!(
        em < 0.1 * change,
        "mean off by {em}; the target changes it by {change}"
    );
    assert!(es < 0.05 * sd, "σ off by {es} (σ {sd})");
}

/// High-pass: the map minus its local mean.
fn high_pass(m: &Map, r: f64) -> Vec<f32> {
    let s = local_stats(m, None, r).unwrap();
    m.data()
        .iter()
        .zip(s.mean.data())
        .map(|(a, b)| a - b)
        .collect()
}

fn correlation(a: &[f32], b: &[f32]) -> f64 {
    let n = a.len() as f64;
    let (ma, mb) = (
        a.iter().map(|&v| v as f64).sum::<f64>() / n,
        b.iter().map(|&v| v as f64).sum::<f64>() / n,
    );
    let (mut sab, mut saa, mut sbb) = (0.0, 0.0, 0.0);
    for (&x, &y) in a.iter().zip(b) {
        let (x, y) = (x as f64 - ma, y as f64 - mb);
        sab += x * y;
        saa += x * x;
        sbb += y * y;
    }
    sab / (saa * sbb).sqrt()
}

#[test]
fn transfer_keeps_the_new_characters_fine_structure_and_takes_the_targets_statistics() {
    let (w, r) = (256, 16.0);
    let a = blood_map(w, w, 10, 0.015);
    let target = blood_map(w, w, 11, 0.03);
    let b = blood_map(w, w, 12, 0.01);
    let rig = single_target_rig(&a, "t", &target, opts(r, 64));
    let moved = rig
        .transfer(&b, None, None, TransferMode::Absolute, 0.05)
        .unwrap();
    // The neutral pose of the transferred rig is character B.
    assert!(max_abs_diff(&hemoglobin(&moved, &[1.0, 0.0], 1.0).unwrap(), &b) < 1e-7);
    let h = hemoglobin(&moved, &one_hot(&moved, "t"), 1.0).unwrap();
    let (hp_h, hp_a, hp_b) = (high_pass(&h, r), high_pass(&a, r), high_pass(&b, r));
    let (cb, ca) = (correlation(&hp_h, &hp_b), correlation(&hp_h, &hp_a));
    assert!(cb > 0.97, "fine structure of B kept: correlation {cb}");
    assert!(ca.abs() < 0.1, "no fine structure of A: correlation {ca}");
    let got = local_stats_exact(&h, None, r).unwrap();
    let want = local_stats_exact(&target, None, r).unwrap();
    let m_err = got
        .mean
        .data()
        .iter()
        .zip(want.mean.data())
        .map(|(p, q)| (p - q).abs())
        .sum::<f32>()
        / (w * w) as f32;
    let s_err = got
        .sigma
        .data()
        .iter()
        .zip(want.sigma.data())
        .map(|(p, q)| (p - q).abs())
        .sum::<f32>()
        / (w * w) as f32;
    let sd = want.sigma.stats(None).mean as f32;
    assert!(
        m_err < 0.08 * sd && s_err < 0.08 * sd,
        "stats off: mean {m_err}, σ {s_err}, σ {sd}"
    );
    // Relative transfer keeps B's own level and applies the target's change: B is 2/3 of A's
    // level and the target twice A's, so the result sits near 2·B's level.
    let rel = rig
        .transfer(&b, None, None, TransferMode::Relative, 0.05)
        .unwrap();
    let hr = hemoglobin(&rel, &one_hot(&rel, "t"), 1.0).unwrap();
    let ratio = hr.stats(None).mean / b.stats(None).mean;
    assert!((ratio - 2.0).abs() < 0.1, "relative transfer ratio {ratio}");
}

#[derive(serde::Deserialize)]
struct Reference {
    width: usize,
    height: usize,
    neutral: Vec<f32>,
    target: Vec<f32>,
    matched: Vec<f64>,
}

#[test]
fn whole_map_radius_agrees_with_skimage_match_histograms() {
    let path = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/tests/data/histmatch_reference.json"
    );
    let r: Reference = serde_json::from_str(&std::fs::read_to_string(path).unwrap()).unwrap();
    let n = Map::from_vec(r.width, r.height, r.neutral).unwrap();
    let t = Map::from_vec(r.width, r.height, r.target).unwrap();
    let rig = single_target_rig(&n, "t", &t, opts(1000.0, 16));
    let h = hemoglobin(&rig, &one_hot(&rig, "t"), 1.0).unwrap();
    let sd_t = {
        let m = t.data().iter().map(|&v| v as f64).sum::<f64>() / t.data().len() as f64;
        (t.data()
            .iter()
            .map(|&v| (v as f64 - m).powi(2))
            .sum::<f64>()
            / t.data().len() as f64)
            .sqrt()
    };
    let diffs: Vec<f64> = h
        .data()
        .iter()
        .zip(&r.matched)
        .map(|(a, b)| (*a as f64 - b).abs())
        .collect();
    let rms = (diffs.iter().map(|d| d * d).sum::<f64>() / diffs.len() as f64).sqrt();
    let max = diffs.iter().cloned().fold(0.0, f64::max);
    println!(
        "vs scikit-image: RMS {:.4} σ_target, max {:.4} σ_target",
        rms / sd_t,
        max / sd_t
    );
    // Gaussian matching equals exact CDF matching up to the sampling noise of the quantiles.
    assert!(rms < 0.05 * sd_t, "RMS {rms} vs σ_target {sd_t}");
    assert!(max < 0.6 * sd_t, "max {max} vs σ_target {sd_t}");
    // Ranks are kept (both are monotone maps of the source).
    let mut order: Vec<usize> = (0..diffs.len()).collect();
    order.sort_by(|&i, &j| r.matched[i].partial_cmp(&r.matched[j]).unwrap());
    assert!(order
        .windows(2)
        .all(|p| h.data()[p[0]] <= h.data()[p[1]] + 1e-9));
}

#[test]
fn flat_neutral_regions_do_not_spike() {
    let w = 128;
    let mut n = blood_map(w, w, 20, 0.02);
    // The left half painted flat, with 8-bit-like quantisation noise of one level.
    for y in 0..w {
        for x in 0..w / 2 {
            n.set(
                x,
                y,
                0.02 + if (x + y) % 7 == 0 {
                    0.32 / 255.0 * 0.01
                } else {
                    0.0
                },
            );
        }
    }
    let t = blood_map(w, w, 21, 0.03);
    let rig = single_target_rig(&n, "t", &t, opts(8.0, 32));
    let h = hemoglobin(&rig, &one_hot(&rig, "t"), 1.0).unwrap();
    assert!(h.data().iter().all(|v| v.is_finite()));
    let ts = local_stats_exact(&t, None, 8.0).unwrap();
    // Deep inside the flat half, H stays within a fraction of the target's σ of its mean.
    for y in 16..w - 16 {
        for x in 4..w / 2 - 16 {
            let dev = (h.get(x, y) - ts.mean.get(x, y)).abs();
            assert!(dev < 0.5 * ts.sigma.get(x, y) + 2e-4, "({x},{y}): {dev}");
        }
    }
    // Without the guard the same texels would have been scaled by σ_i/σ_n ≫ 1.
    let raw_ratio = rig.targets[0].sigma.get(4, 16) / rig.neutral_sigma.get(4, 16).max(1e-12);
    assert!(
        raw_ratio > 100.0,
        "the test needs a flat region: {raw_ratio}"
    );
}

#[test]
fn save_load_round_trip_and_frame_path_matches_the_exact_color() {
    let w = 128;
    let n = blood_map(w, w, 30, 0.012);
    let mel = Map::from_vec(
        w,
        w,
        (0..w * w)
            .map(|i| 0.005 + 0.1 * (i % w) as f32 / w as f32)
            .collect(),
    )
    .unwrap();
    let rig = Rig::build(
        &n,
        None,
        Some(mel.clone()),
        &[
            TargetSpec {
                name: "happiness".into(),
                source: TargetSource::Builtin(derma_rig::expression::find("happiness").unwrap()),
                global_scale: None,
            },
            TargetSpec {
                name: "anger".into(),
                source: TargetSource::Builtin(derma_rig::expression::find("anger").unwrap()),
                global_scale: None,
            },
        ],
        &opts(6.0, 32),
    )
    .unwrap();
    assert_eq!(rig.targets[1].global_scale, 1.27);
    let lut = SkinColorLut::builtin();
    let dir = std::env::temp_dir().join(format!("derma-rig-rt-{}", std::process::id()));
    derma_rig::rig_dir::save(&rig, &lut, &dir).unwrap();
    let (back, lut_back, json) = derma_rig::rig_dir::load(&dir).unwrap();
    assert_eq!(back, rig);
    assert_eq!(lut_back.rgb, lut.rgb);
    assert_eq!(json.targets.len(), 2);
    std::fs::remove_dir_all(&dir).unwrap();

    let wts = vec![0.3, 0.5, 0.2];
    let h = hemoglobin(&rig, &wts, 1.1).unwrap();
    let c = color(&h, &mel, &lut).unwrap();
    let mut plan = FramePlan::new(&rig, &mel, &lut).unwrap();
    let mut frame = vec![0u32; w * w];
    plan.render(&rig, &wts, 1.1, &mut frame).unwrap();
    let f = unpack_rgba8(&frame, w, w);
    let mut worst = 0.0f32;
    for k in 0..3 {
        for (a, b) in f[k].data().iter().zip(c[k].data()) {
            let want = derma_core::color::srgb_encode(*b);
            worst = worst.max((a - want).abs() * 255.0);
        }
    }
    println!("frame path vs exact colour: worst {worst} levels");
    assert!(
        worst <= 2.0,
        "frame path differs from the exact colour by {worst} levels"
    );
}

#[test]
fn deterministic_across_thread_counts() {
    let w = 128;
    let n = blood_map(w, w, 40, 0.012);
    let t = blood_map(w, w, 41, 0.02);
    let run = |threads: usize| {
        rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap()
            .install(|| {
                let rig = single_target_rig(&n, "t", &t, opts(40.0, 32));
                hemoglobin(&rig, &[0.4, 0.6], 1.0).unwrap()
            })
    };
    assert_eq!(run(1).data(), run(3).data());
}

#[cfg(feature = "gpu")]
#[test]
fn gpu_shader_agrees_with_the_cpu_path() {
    if derma_test_support::skip_without_gpu() {
        return;
    }
    // Non-square, non-power-of-two ratio between map and basis, several targets, a partial
    // blend with a global scale: every branch of the shader's upsampling and lookup.
    let (w, h) = (96, 64);
    let n = Map::from_vec(w, h, blood_map(96, 96, 50, 0.012).data()[..w * h].to_vec()).unwrap();
    let t1 = Map::from_vec(w, h, n.data().iter().map(|v| 1.4 * v + 0.002).collect()).unwrap();
    let mel = Map::from_vec(
        w,
        h,
        (0..w * h)
            .map(|i| 0.003 + 0.2 * (i % w) as f32 / w as f32)
            .collect(),
    )
    .unwrap();
    let specs = [
        TargetSpec {
            name: "t1".into(),
            source: TargetSource::Map(&t1),
            global_scale: None,
        },
        TargetSpec {
            name: "fear".into(),
            source: TargetSource::Builtin(derma_rig::expression::find("fear").unwrap()),
            global_scale: None,
        },
    ];
    let o = BasisOptions {
        radius: 5.0,
        basis_size: (24, 16),
        sigma_floor: 0.05,
    };
    let rig = Rig::build(&n, None, Some(mel.clone()), &specs, &o).unwrap();
    let lut = SkinColorLut::builtin();
    let gpu = derma_rig::gpu_eval::GpuRig::new(&rig, &mel, &lut).unwrap();
    for (wts, g) in [(vec![1.0, 0.0, 0.0], 1.0), (vec![0.2, 0.5, 0.3], 1.17)] {
        let (hg, cg) = gpu.render(&wts, g).unwrap();
        let hc = hemoglobin(&rig, &wts, g).unwrap();
        let cc = color(&hc, &mel, &lut).unwrap();
        let dh = max_abs_diff(&hg, &hc);
        assert!(dh < 1e-6, "hemoglobin differs by {dh}");
        for k in 0..3 {
            let dc = max_abs_diff(&cg[k], &cc[k]);
            assert!(dc < 2e-4, "colour channel {k} differs by {dc}");
        }
    }
    // Timed frames (other weights, nothing read back) leave the rig as it was: the next
    // render is the same as before them, to the bit.
    let before = gpu.render(&[0.2, 0.5, 0.3], 1.17).unwrap();
    let s = gpu.seconds_per_frame(&[0.9, 0.1, 0.4], 0.8, 3).unwrap();
    assert!(s.is_finite() && s > 0.0, "seconds per frame {s}");
    assert_eq!(gpu.render(&[0.2, 0.5, 0.3], 1.17).unwrap(), before);
    assert!(gpu.seconds_per_frame(&[1.0, 0.0], 1.0, 1).is_err());
}

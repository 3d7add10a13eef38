//! The eye-region model, drivers and distance fields against the thesis, the literature and
//! exact references.

use derma_eyes::blink::{self, Activity};
use derma_eyes::rigdata::Rig;
use derma_eyes::sdf::{self, material, samplers::Sampler, GBuffer};
use derma_eyes::*;
use std::sync::OnceLock;

fn rig() -> &'static Rig {
    static R: OnceLock<Rig> = OnceLock::new();
    R.get_or_init(|| Rig::new(derma_head::Head::builtin()).unwrap())
}

fn model() -> &'static (tracked::Tracked, EyeModel) {
    static M: OnceLock<(tracked::Tracked, EyeModel)> = OnceLock::new();
    M.get_or_init(|| {
        let t = rig().samples(300, 1);
        let m = EyeModel::fit(&t, Components::default()).unwrap();
        (t, m)
    })
}

#[test]
fn the_region_has_four_lid_margins_and_a_capture_like_sample_of_a_thousand_vertices() {
    let sampled = region::EyeRegion::of_head_sampled(
        derma_head::Head::builtin(),
        Some(region::TRACK_SPACING),
    )
    .unwrap();
    assert!(
        (500..1500).contains(&sampled.tracked),
        "{}",
        sampled.tracked
    );
    let r = &rig().region;
    // The rig tracks every skin vertex it moves; only the lids' inner surfaces are extrapolated.
    assert!((0..r.len()).all(|i| (i < r.tracked) != r.inner[i]));
    assert_eq!(sampled.len(), r.len());
    for e in 0..2 {
        for l in 0..2 {
            assert!(r.margins[e][l].len() > 20);
        }
        // Upper and lower lids share their canthi.
        assert_eq!(r.margins[e][0][0], r.margins[e][1][0]);
        assert_eq!(r.margins[e][0].last(), r.margins[e][1].last());
    }
}

#[test]
fn the_trained_model_reproduces_held_out_frames() {
    let (_, m) = model();
    // Fresh poses (another seed) the model never saw.
    let held = rig().samples(60, 99);
    let mut sum = 0.0f64;
    let mut n = 0usize;
    for f in &held.frames {
        let g = m.gaze_of(&held, f);
        let (_, u) = m.predict(&g);
        for (a, b) in u.iter().zip(&f.vertices) {
            sum += (*a - *b).length_squared() as f64;
            n += 1;
        }
    }
    let rms = (sum / n as f64).sqrt();
    // Stated bound: 0.25 mm RMS over the tracked vertices (the rig's look units clamp, which a
    // linear model cannot follow exactly).
    assert!(rms < 0.25, "held-out RMS {rms} mm");
}

#[test]
#[ignore = "slow: scripts/test_slow.sh"]
fn one_more_component_never_increases_training_error() {
    let (t, _) = model();
    let mut last = (f64::MAX, f64::MAX);
    for k in 1..=8 {
        let e = model::training_error(t, k).unwrap();
        assert!(
            e.0 <= last.0 * (1.0 + 1e-6) && e.1 <= last.1 * (1.0 + 1e-6),
            "k {k}: {e:?} after {last:?}"
        );
        last = e;
    }
    let cv = model::cross_validate(t, Components { lids: 8, skin: 6 }, 5).unwrap();
    // Fig. 3.7's shape: the held-out error falls steeply over the first components.
    assert!(
        cv.skin[3] < 0.1 * cv.skin[0] && cv.lids[4] < 0.5 * cv.lids[0],
        "{cv:?}"
    );
}

#[test]
fn the_optimised_form_equals_the_two_stage_model() {
    let (t, m) = model();
    let opt = m.optimised(&[]);
    let mut u = vec![glam::Vec2::ZERO; opt.len()];
    for f in t.frames.iter().step_by(37) {
        let g = m.gaze_of(t, f);
        let (_, want) = m.predict(&g);
        opt.evaluate(&opt.coefficients(&g), &mut u);
        for (a, b) in u.iter().zip(&want) {
            assert!((*a - *b).length() < 1e-3, "{a} {b}");
        }
    }
}

#[test]
fn the_baseline_aperture_lands_in_read_et_al_ranges() {
    let (_, m) = model();
    // Read et al. 2006: 9.7 ± 1.2 mm in primary gaze, 6.4 ± 1.1 mm at 40° downgaze.
    for e in 0..2 {
        let primary = m.baseline_opening_mm(e, 0.0, 0.0);
        let down = m.baseline_opening_mm(e, 0.0, -40.0);
        assert!((primary - 9.7).abs() <= 1.2, "primary {primary}");
        assert!((down - 6.4).abs() <= 1.1, "40° down {down}");
        // Closing factor 0 closes the eye.
        let closed = m.denormalise_lids(e, m.baseline_aperture(e, 0.0, 0.0, 0.0));
        assert!((closed[0] - closed[1]) < 0.5);
    }
}

#[test]
fn skin_never_penetrates_the_globe_after_sliding() {
    no_skin_inside_the_globes(derma_head::Head::builtin(), &rig().region, &model().1);
}

/// Over the neutral frame, a blink, and gaze ±30° with the lids following, no skin vertex
/// outside the lids' sliding band lies inside its globe.
fn no_skin_inside_the_globes(head: &derma_head::Head, region: &region::EyeRegion, m: &EyeModel) {
    let ev = evaluate::Evaluator::new(m, region, head, sliding::THICKNESS).unwrap();
    let mut f = evaluate::Frame::default();
    // The neutral frame is the rest mesh.
    ev.frame(&ev.neutral, &mut f);
    let worst = f
        .positions
        .iter()
        .zip(&region.rest)
        .map(|(a, b)| (*a - *b).length())
        .fold(0.0f32, f32::max);
    assert!(worst < 1e-3, "{worst}");
    for (h, v, c) in [
        (0.0, -35.0, 1.0),
        (25.0, 10.0, 1.0),
        (-20.0, -10.0, 0.0),
        (10.0, 20.0, 0.5),
        (30.0, 0.0, 1.0),
        (-30.0, 0.0, 1.0),
        (0.0, 30.0, 1.0),
        (0.0, -30.0, 1.0),
        (0.0, 0.0, 0.0),
    ] {
        let mut g = ev.neutral.clone();
        g.eyes = [Fick { h, v, t: 0.0 }; 2];
        g.lids = [0, 1].map(|e| m.baseline_aperture(e, h, v, c));
        ev.frame(&g, &mut f);
        let rot = g.eyes.map(|a| a.rotation());
        for (i, p) in f.positions.iter().enumerate() {
            let e = ev.slider.eye[i] as usize;
            let r = rot[e].inverse() * (*p - ev.slider.centres[e]);
            let d = ev.slider.maps[e].sample(r.normalize());
            let outside = match ev.slider.modes[i] {
                sliding::Mode::Surface { .. } => true,
                sliding::Mode::Offset { delta0, t, .. } => delta0 + t >= 0.0,
            };
            if outside {
                assert!(
                    r.length() >= d - 1e-3,
                    "vertex {i} at {} inside the globe ({d}) at ({h}, {v}, {c})",
                    r.length()
                );
            }
        }
    }
}

#[test]
#[ignore = "slow: scripts/test_slow.sh"]
fn a_fitted_heads_lids_slide_over_its_own_globes() {
    // A scan: the built-in head's outer skin made wider, shorter and deeper, bent, and moved
    // (a head of other proportions), fitted; its rig trains its own model.
    let head = derma_head::Head::builtin();
    let chart = derma_head::asset::parse().meta.charts["skin"];
    let inside = |uv: glam::Vec2| {
        uv.x >= chart[0] && uv.x <= chart[2] && uv.y >= chart[1] && uv.y <= chart[3]
    };
    let mut scan = head.skin.clone();
    scan.triangles
        .retain(|t| t.iter().all(|&i| inside(head.skin.uvs[i as usize])));
    for p in &mut scan.positions {
        *p = glam::Vec3::new(1.08 * p.x, 0.95 * p.y + 0.0006 * p.x * p.x, 1.04 * p.z)
            + glam::Vec3::new(3.0, -12.0, 20.0);
    }
    let fitted = derma_head::fit::fit(
        scan.clone(),
        &derma_head::fit::FitOptions::default(),
        &derma_core::progress::Silent,
    )
    .unwrap();
    assert_eq!(fitted.report.flipped, 0);
    let fitted = fitted.head();
    let rig = Rig::new(&fitted).unwrap();
    let m = EyeModel::fit(&rig.samples(300, 1), Components::default()).unwrap();
    no_skin_inside_the_globes(&fitted, &rig.region, &m);
    // The scan's own vertices, carried through the fit's B map, stay outside the globes too,
    // and its lids close over a blink.
    let skin = surface::Skin::user(&fitted, scan, std::path::Path::new("scan")).unwrap();
    let (flipped, crossing) = blink_faults(&fitted, &rig.region, &m, &skin);
    println!("fitted head: {flipped} triangles turned over, margins cross by {crossing} mm");
    assert_blinks_clean(flipped, crossing);
    let ev = evaluate::Evaluator::new(&m, &rig.region, &fitted, sliding::THICKNESS).unwrap();
    let all: Vec<u32> = (0..skin.mesh().positions.len() as u32).collect();
    let mut f = evaluate::Frame::default();
    let mut deepest = f32::NEG_INFINITY;
    let mut moved = 0.0f32;
    for (h, v, c) in [
        (0.0, 0.0, 0.0),
        (0.0, 0.0, 1.0),
        (30.0, 0.0, 0.0),
        (-30.0, 0.0, 0.0),
        (0.0, 30.0, 0.0),
        (0.0, -30.0, 0.0),
        (30.0, 0.0, 1.0),
        (0.0, -30.0, 1.0),
    ] {
        let mut g = ev.neutral.clone();
        g.eyes = [Fick { h, v, t: 0.0 }; 2];
        g.lids = [0, 1].map(|e| m.baseline_aperture(e, h, v, c));
        ev.frame(&g, &mut f);
        let (pos, _) = skin.frame(&rig.region, &f, &all);
        let rot = g.eyes.map(|a| a.rotation());
        for (p, q) in pos.iter().zip(&skin.mesh().positions) {
            moved = moved.max((*p - *q).length());
            for e in 0..2 {
                let r = rot[e].inverse() * (*p - ev.slider.centres[e]);
                if r.length() < 20.0 {
                    let d = ev.slider.maps[e].sample(r.normalize());
                    deepest = deepest.max(d - r.length());
                }
            }
        }
    }
    assert!(moved > 5.0, "the scan's lids barely move: {moved} mm");
    assert!(deepest < 0.05, "a scan vertex {deepest} mm inside a globe");
    // The globes moved with the head and grew with it.
    assert!((fitted.eyes[0].centre - head.eyes[0].centre).length() > 10.0);
    assert!(fitted.eyes[0].radius > head.eyes[0].radius);
}

#[test]
fn blink_intervals_and_amplitudes_follow_their_distributions() {
    let b = blink::schedule(3600.0 * 4.0, Activity::Watching, 7);
    assert!(b.len() > 1000, "{}", b.len());
    let (mu, sd) = (blink::FREQUENCY_HZ.0 as f64, blink::FREQUENCY_HZ.1 as f64);
    let (lo, hi) = (
        blink::FREQ_RANGE.0 as f64 * mu,
        blink::FREQ_RANGE.1 as f64 * mu,
    );
    // Frequencies pause_scale / pause (the pause starts where the previous blink ended) follow
    // table 3.1's truncated normal.
    let scale = blink::pause_scale(Activity::Watching) as f64;
    let mut freq: Vec<f64> = b
        .windows(2)
        .map(|w| scale / (w[1].start - w[0].start - w[0].down * (1.0 + blink::UP_OVER_DOWN)) as f64)
        .collect();
    let n = freq.len() as f64;
    let ks = blink::ks_statistic(&mut freq, |x| blink::truncated_cdf(x, mu, sd, lo, hi));
    // 1 % critical value of the one-sample KS test: 1.63 / √n.
    assert!(ks < 1.63 / n.sqrt(), "frequency KS {ks}");
    let mut amp: Vec<f64> = b.iter().map(|x| x.amplitude as f64).collect();
    let (am, asd) = (blink::AMPLITUDE_DEG.0 as f64, blink::AMPLITUDE_DEG.1 as f64);
    let ks = blink::ks_statistic(&mut amp, |x| blink::truncated_cdf(x, am, asd, -1e9, 1e9));
    assert!(ks < 1.63 / (amp.len() as f64).sqrt(), "amplitude KS {ks}");
    // Closing 40–47 % faster than opening; a mean blink's down phase is 66 ms.
    for x in &b {
        let ratio = x.up / x.down;
        assert!((1.40..=1.47).contains(&ratio));
    }
    let mean_down = b.iter().map(|x| x.down).sum::<f32>() / b.len() as f32;
    assert!((mean_down - 0.066).abs() < 0.002, "{mean_down}");
    // Rates per activity: the table's and Bentivoglio et al.'s means, within 7 % over an hour
    // (a count of 270–1560 blinks whose pauses spread as widely as their mean).
    for (a, per_min) in [
        (Activity::Rest, 17.0),
        (Activity::Conversation, 26.0),
        (Activity::Reading, 4.5),
        (Activity::Watching, 60.0 * blink::FREQUENCY_HZ.0),
    ] {
        let n = blink::schedule(3600.0, a, 3).len() as f32 / 60.0;
        assert!((n - per_min).abs() < 0.07 * per_min, "{a:?}: {n}/min");
    }
}

#[test]
fn idle_saccade_magnitudes_are_exponential() {
    let f = idle::schedule(3.0 * 3600.0, 5);
    let mut mags: Vec<f64> = f
        .windows(2)
        .filter(|w| !w[1].mutual || !w[0].mutual)
        .map(|w| w[0].gaze.amplitude_to(w[1].gaze) as f64)
        .filter(|&a| a > 1.0)
        .collect();
    assert!(mags.len() > 500);
    let mean = mags.iter().sum::<f64>() / mags.len() as f64;
    // Shifts between away fixations add two exponential draws, so the mean lies between one
    // and two scales; most are small, few exceed 20°.
    assert!(mean > 4.0 && mean < 14.0, "{mean}");
    mags.sort_by(f64::total_cmp);
    assert!(mags[mags.len() / 2] < mean);
}

/// A G-buffer of a flat plane (constant depth) with skin where `skin` says and eye elsewhere.
fn flat(w: usize, h: usize, skin: impl Fn(usize, usize) -> bool) -> GBuffer {
    GBuffer {
        width: w,
        height: h,
        mask: (0..w * h)
            .map(|i| {
                if skin(i % w, i / w) {
                    material::SKIN
                } else {
                    material::EYE
                }
            })
            .collect(),
        depth: vec![100.0; w * h],
        focal: 1000.0,
    }
}

#[test]
fn distance_fields_equal_the_exact_transform_on_simple_shapes() {
    // An eye opening: skin outside a disc of radius 50 px and left of x = 70, far enough from the
    // image border that every search stays inside the image (screen space knows nothing beyond
    // it); the exact transform against the analytic distance.
    let (w, h) = (220, 180);
    let inside =
        |x: usize, y: usize| ((x as f32 - 110.0).powi(2) + (y as f32 - 90.0).powi(2)).sqrt() < 50.0;
    let g = flat(w, h, |x, y| !inside(x, y) || x < 70);
    let exact = sdf::exact::field(&g);
    for y in 0..h {
        for x in 0..w {
            let i = y * w + x;
            if g.mask[i] == material::EYE {
                // Analytic distance to the nearest skin pixel centre is within a pixel of this.
                let disc = (50.0 - ((x as f32 - 110.0).powi(2) + (y as f32 - 90.0).powi(2)).sqrt())
                    .max(0.0);
                let plane = x as f32 - 69.0;
                let d_px = exact.distance[i] * g.px_per_mm(i);
                assert!(
                    (d_px - disc.min(plane)).abs() <= 1.0,
                    "({x}, {y}): {d_px} vs {}",
                    disc.min(plane)
                );
            }
        }
    }
    // JFA+1 equals the exact transform here.
    let j = sdf::jfa::field(&g);
    assert!(sdf::error_percent(&j.distance, &exact.distance, 3.0) < 1e-3);
    // The samplers within their stated resolution over pixels within range Λ = 2 mm (20 px):
    // the refined search within 0.5 % of Λ (the angular error of its finest directions), the
    // thesis' 8 × 8 search within its ±22.5° direction spacing (≤ 8 % overestimate, ~4 % mean).
    let range = 2.0;
    for (s, tol) in [
        (sdf::table::DEFAULT, 0.5),
        (
            Sampler::Backtracking {
                n: 8,
                steps: 8,
                refine: 0,
            },
            5.0,
        ),
        (Sampler::Equiangular { n: 64 }, 12.0),
    ] {
        let f = sdf::samplers::field(&g, s, range);
        let e = sdf::error_percent(&f.distance, &exact.distance, range);
        assert!(e < tol, "{}: {e}%", s.name());
        // Never closer than the truth by more than a pixel (samples find real skin).
        for (a, b) in f.distance.iter().zip(&exact.distance) {
            if a.is_finite() {
                // Distances between texel centres: never below the exact transform.
                assert!(*a >= b - 1e-4, "{} {a} < {b}", s.name());
            }
        }
    }
}

#[test]
fn the_saliency_map_finds_the_odd_one_out() {
    use derma_core::Map;
    // Grey noise-free field with one red square: the first target is on it.
    let (w, h) = (256, 192);
    let mk = |f: &dyn Fn(usize, usize) -> f32| {
        Map::from_vec(w, h, (0..w * h).map(|i| f(i % w, i / w)).collect()).unwrap()
    };
    let red = |x: usize, y: usize| (170..190).contains(&x) && (50..70).contains(&y);
    let rgb = [
        mk(&|x, y| if red(x, y) { 0.9 } else { 0.4 }),
        mk(&|x, y| if red(x, y) { 0.1 } else { 0.4 }),
        mk(&|_, _| 0.4),
    ];
    let s = saliency::saliency(&rgb);
    let t = saliency::targets(&s, 3, 0.1);
    assert!(
        (t[0].x - 180.0 / 256.0).abs() < 0.06 && (t[0].y - 60.0 / 192.0).abs() < 0.08,
        "{t:?}"
    );
}

#[cfg(feature = "gpu")]
#[test]
fn gpu_fields_equal_the_cpu_reference() {
    if derma_test_support::skip_without_gpu() {
        return;
    }
    let head = derma_head::Head::builtin();
    let scene = sdf::scene::head_close_up(head, 640, 360);
    let g = &scene.g;
    let gpu = sdf::gpu::GpuFields::new(g).unwrap();
    // Jump flooding: integer seeds, identical to the CPU's.
    let (jg, seeds) = gpu.jfa().unwrap();
    assert_eq!(seeds, sdf::jfa::flood(g));
    let jc = sdf::jfa::field(g);
    for (a, b) in jg.distance.iter().zip(&jc.distance) {
        assert!(a == b || (a - b).abs() <= 1e-5 * b.abs(), "{a} {b}");
    }
    // The three samplers: the same searches; the GPU's sin/cos/sqrt differ by ULPs, which can
    // move a sample across a texel edge on a rare pixel.
    let range = sdf::table::RANGE_MM;
    let exact = sdf::exact::field(g);
    for s in [
        sdf::table::DEFAULT,
        Sampler::Equiangular { n: 64 },
        Sampler::Exponential { steps: 8 },
    ] {
        let c = sdf::samplers::field(g, s, range);
        let d = gpu.sampled(s, range).unwrap();
        let (mut same, mut n) = (0usize, 0usize);
        for i in 0..c.distance.len() {
            if g.mask[i] == material::EYE {
                n += 1;
                let (a, b) = (c.distance[i], d.distance[i]);
                if a == b || (a - b).abs() < 1e-4 {
                    same += 1;
                }
            }
        }
        assert!(
            same as f64 >= 0.999 * n as f64,
            "{}: {same} of {n} globe pixels agree",
            s.name()
        );
        let (ec, eg) = (
            sdf::error_percent(&c.distance, &exact.distance, range),
            sdf::error_percent(&d.distance, &exact.distance, range),
        );
        assert!((ec - eg).abs() < 0.02, "{}: CPU {ec}% GPU {eg}%", s.name());
    }
}

/// Over a full blink (closing factor 1 → 0) in primary gaze: the most skin triangles at once
/// turned over against every pose of the rig's own blink (its face units, what the model learnt:
/// a crease's triangles turn as the fold forms, legitimately, and the model may form it a little
/// earlier or later than the rig), and the deepest crossing (mm) of the upper lid margin below
/// the lower one, here and looking down and aside.
fn blink_faults(
    head: &derma_head::Head,
    region: &region::EyeRegion,
    m: &EyeModel,
    skin: &surface::Skin,
) -> (usize, f32) {
    let ev = evaluate::Evaluator::new(m, region, head, sliding::THICKNESS).unwrap();
    let mesh = skin.mesh();
    let all: Vec<u32> = (0..mesh.positions.len() as u32).collect();
    let face = |p: &[glam::Vec3], t: &[u32; 3]| {
        let [a, b, c] = t.map(|i| p[i as usize]);
        (b - a).cross(c - a)
    };
    let rig_blink: Vec<Vec<glam::Vec3>> = (0..=20)
        .map(|k| {
            let w = k as f32 / 20.0;
            skin.posed(&[("eyeBlinkLeft", w), ("eyeBlinkRight", w)])
        })
        .collect();
    // The outer skin: the sockets' charts (conjunctiva, the lids' backs) are hidden.
    let outer = |t: &&[u32; 3]| {
        mesh.uvs.is_empty()
            || !t
                .iter()
                .all(|&i| head.regions.in_socket(mesh.uvs[i as usize]))
    };
    let (mut flipped, mut crossing) = (0usize, 0.0f32);
    let mut f = evaluate::Frame::default();
    for (h, v) in [(0.0, 0.0), (0.0, -30.0), (25.0, 0.0)] {
        for k in 0..=20 {
            let w = k as f32 / 20.0;
            let mut g = ev.neutral.clone();
            g.eyes = [Fick { h, v, t: 0.0 }; 2];
            g.lids = [0, 1].map(|e| m.baseline_aperture(e, h, v, 1.0 - w));
            ev.frame(&g, &mut f);
            if (h, v) == (0.0, 0.0) {
                let (pos, _) = skin.frame(region, &f, &all);
                let turned = mesh
                    .triangles
                    .iter()
                    .filter(outer)
                    .filter(|t| {
                        let n = face(&pos, t);
                        rig_blink.iter().all(|r| face(r, t).dot(n) <= 0.0)
                    })
                    .count();
                flipped = flipped.max(turned);
            }
            for e in 0..2 {
                let chain = |l: usize| -> Vec<glam::Vec2> {
                    region.margins[e][l]
                        .iter()
                        .map(|&i| lids::project(f.positions[i as usize]))
                        .collect()
                };
                let (upper, lower) = (chain(0), chain(1));
                for p in &upper[1..upper.len() - 1] {
                    if let Some(y) = contact::height_at(&lower, p.x) {
                        crossing = crossing.max(y - p.y);
                    }
                }
            }
        }
    }
    (flipped, crossing)
}

/// A blink's faults within bounds: at full closure a few sub-millimetre triangles of the outer
/// canthus, compressed to slivers, may turn (10 on the built-in head, 11 on the fitted one),
/// nothing else does (the thesis's skull-map lift turned 1635 over against the rig at the same
/// weight); the upper margin may sit a hair below the lower where the globes push the closed
/// lids (the rig's own blink crosses by 1.26 mm).
fn assert_blinks_clean(flipped: usize, crossing: f32) {
    assert!(
        flipped <= 16,
        "{flipped} triangles turned over during a blink"
    );
    assert!(
        crossing <= 0.25,
        "the upper margin crosses the lower by {crossing} mm"
    );
}

#[test]
fn a_blink_closes_the_lids_cleanly() {
    let head = derma_head::Head::builtin();
    let skin = surface::Skin::of_head(head);
    let (flipped, crossing) = blink_faults(head, &rig().region, &model().1, &skin);
    println!("built-in head: {flipped} triangles turned over, margins cross by {crossing} mm");
    assert_blinks_clean(flipped, crossing);
}

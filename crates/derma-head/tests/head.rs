//! The built-in head against anatomy and its own data: sizes, the eyes in their sockets, the
//! landmarks in their regions, the face units and the exported files.

use derma_core::raster::UvRaster;
use derma_head::{regions, Head, REGIONS};
use glam::{Vec2, Vec3};

fn region_at(head: &Head, p: Vec3) -> regions::Weights {
    // The nearest skin vertex; where it lies on a UV seam (several vertices at one place, e.g.
    // between the lips' skin chart and the mouth cavity's), the largest weight of each region.
    let m = &head.skin;
    let d = |i: usize| (m.positions[i] - p).length();
    let i = (0..m.positions.len())
        .min_by(|&a, &b| d(a).total_cmp(&d(b)))
        .unwrap();
    let mut out = [0.0f32; REGIONS.len()];
    for j in (0..m.positions.len()).filter(|&j| (m.positions[j] - m.positions[i]).length() < 1e-3) {
        let w = head.regions.weights(m.positions[j], m.uvs[j]);
        for k in 0..out.len() {
            out[k] = out[k].max(w[k]);
        }
    }
    out
}

fn w(weights: &regions::Weights, name: &str) -> f32 {
    weights[regions::index(name).unwrap()]
}

#[test]
fn skin_is_a_head_sized_subdivided_surface_with_one_clean_uv_layout() {
    let head = Head::builtin();
    let m = &head.skin;
    println!(
        "skin: {} vertices, {} triangles",
        m.positions.len(),
        m.triangles.len()
    );
    assert!(m.triangles.len() > 100_000);
    let (lo, hi) = m.bounds();
    let size = hi - lo;
    // Head breadth (eu–eu ~150 mm with the ears ~180) and height with the neck (~240 mm).
    assert!((150.0..200.0).contains(&size.x), "{size}");
    assert!((200.0..280.0).contains(&size.y), "{size}");
    assert!(m
        .uvs
        .iter()
        .all(|t| (0.0..=1.0).contains(&t.x) && (0.0..=1.0).contains(&t.y)));
    let r = UvRaster::new(m, 512, 512);
    assert_eq!(r.overlapping_triangles, 0, "UV charts overlap");
    assert!(r.coverage() > 0.3, "{}", r.coverage());
    // Head and neck surface of an adult: roughly 1000–1600 cm² (the cavities add a little).
    let area = m.area() / 100.0;
    assert!((1000.0..1700.0).contains(&area), "{area} cm²");
}

#[test]
fn eye_globes_sit_in_the_sockets_and_match_the_landmarks() {
    let head = Head::builtin();
    for (eye, side) in head.eyes.iter().zip(["left", "right"]) {
        let inside = head
            .skin
            .positions
            .iter()
            .filter(|p| (**p - eye.centre).length() < eye.radius)
            .count();
        assert_eq!(inside, 0, "{side}: skin vertices inside the globe");
        let lm = &head.landmarks;
        assert_eq!(lm.get(&format!("eye_centre_{side}")), eye.centre);
        // The centre lies between the canthi, behind the lid margins, and the palpebral fissure
        // is 25–35 mm wide (Farkas 1994: en–ex ≈ 30 mm).
        let ci = lm.get(&format!("canthus_inner_{side}"));
        let co = lm.get(&format!("canthus_outer_{side}"));
        let width = (co - ci).length();
        assert!((25.0..35.0).contains(&width), "{side}: fissure {width} mm");
        let mid = 0.5 * (ci + co);
        assert!((mid.x - eye.centre.x).abs() < 3.0 && (mid.y - eye.centre.y).abs() < 4.0);
        let up = lm.get(&format!("lid_upper_{side}"));
        assert!(
            up.z > eye.centre.z + 0.5 * eye.radius,
            "{side}: lid not in front of the eye"
        );
        assert!((10.0..13.0).contains(&eye.radius));
        // The interpupillary distance of adults is 55–70 mm.
    }
    let ipd = (head.eyes[0].centre - head.eyes[1].centre).length();
    assert!((55.0..70.0).contains(&ipd), "{ipd}");
}

#[test]
fn landmarks_fall_in_their_regions() {
    let head = Head::builtin();
    let lm = &head.landmarks;
    let cases = [
        ("nose_tip", "nose"),
        ("chin", "chin"),
        ("ear_left", "ears"),
        ("ear_right", "ears"),
        ("lid_upper_left", "eyelids"),
        ("lid_lower_right", "eyelids"),
    ];
    for (point, region) in cases {
        let r = region_at(head, lm.get(point));
        assert!(w(&r, region) > 0.8, "{point} not in {region}: {r:?}");
    }
    // The mouth corners are where the vermilion ends: on its border.
    for side in ["left", "right"] {
        let r = region_at(head, lm.get(&format!("mouth_corner_{side}")));
        assert!((0.3..=1.0).contains(&w(&r, "lips")), "{side} corner: {r:?}");
    }
    // Scalp: 20 mm above the hairline on the midline is scalp, 15 mm below is forehead.
    let h = lm.get("hairline");
    let near = |p: Vec3| {
        let m = &head.skin;
        *m.positions
            .iter()
            .filter(|q| q.z > 0.0)
            .min_by(|a, b| {
                (Vec2::new(a.x, a.y) - Vec2::new(p.x, p.y))
                    .length()
                    .total_cmp(&(Vec2::new(b.x, b.y) - Vec2::new(p.x, p.y)).length())
            })
            .unwrap()
    };
    let above = region_at(head, near(h + Vec3::Y * 20.0));
    let below = region_at(head, near(h - Vec3::Y * 15.0));
    assert!(w(&above, "scalp") > 0.9, "{above:?}");
    assert!(
        w(&below, "forehead") > 0.9 && w(&below, "scalp") < 0.1,
        "{below:?}"
    );
    // The cheeks are redder regions' home: a point 45 mm out and 30 mm down is cheek.
    let cheek = region_at(head, near(Vec3::new(45.0, -30.0, 0.0)));
    assert!(w(&cheek, "cheeks") > 0.5, "{cheek:?}");
}

#[test]
fn region_masks_cover_the_layout_and_the_face_is_mostly_face() {
    let head = Head::builtin();
    let masks = head.region_masks(256);
    assert_eq!(masks.len(), REGIONS.len());
    for (name, m) in &masks {
        let mean = m.data().iter().sum::<f32>() / m.data().len() as f32;
        assert!(mean > 0.0005, "{name} is empty");
        assert!(m.data().iter().all(|v| (0.0..=1.0).contains(v)), "{name}");
    }
}

#[test]
fn face_units_are_the_52_arkit_shapes_and_move_what_they_name() {
    let head = Head::builtin();
    let units = head.face_units();
    assert_eq!(units.len(), 52);
    let get = |n: &str| units.iter().find(|u| u.name == n).unwrap();
    // A blink closes the left eye: the upper lid margin comes down to about the lower one.
    let lm = &head.landmarks;
    let posed = head.posed_skin(&[("eyeBlinkLeft", 1.0)]);
    let up = lm.get("lid_upper_left");
    let low = lm.get("lid_lower_left");
    let i = derma_test_support::nearest(&head.skin.positions, up).unwrap();
    let closed = posed.positions[i];
    assert!(
        (closed.y - low.y).abs() < 0.4 * (up.y - low.y),
        "{closed} vs lower lid {low}"
    );
    // It does not touch the right eye.
    let blink = &get("eyeBlinkLeft").skin;
    let max_on = |f: &dyn Fn(f32) -> bool| {
        blink
            .iter()
            .filter(|(v, _)| f(head.skin.positions[*v as usize].x))
            .map(|(_, d)| d.length())
            .fold(0.0f32, f32::max)
    };
    let (left, right) = (max_on(&|x| x > 0.0), max_on(&|x| x < -5.0));
    // (The Face Units pack's blinks are not strictly one-sided: eyeBlinkLeft moves the right
    // lids too, by about half as much.)
    assert!(
        right < 0.6 * left,
        "a left blink moves the right side by {right} mm ({left})"
    );
    // jawOpen moves the lower teeth and the chin down; not the upper teeth.
    let jaw = get("jawOpen");
    let k = head
        .parts
        .iter()
        .position(|p| p.name == "teeth_lower")
        .unwrap();
    let u = head
        .parts
        .iter()
        .position(|p| p.name == "teeth_upper")
        .unwrap();
    assert!(jaw
        .parts
        .iter()
        .any(|(p, o)| *p == k && o.iter().any(|(_, d)| d.y < -5.0)));
    assert!(!jaw
        .parts
        .iter()
        .any(|(p, o)| *p == u && o.iter().any(|(_, d)| d.length() > 1.0)));
}

#[test]
fn glb_and_obj_export_load_back_with_named_parts_and_targets() {
    let head = Head::builtin();
    let dir = derma_test_support::scratch_dir("head-export");
    derma_head::export::write_glb(head, &dir.join("head.glb")).unwrap();
    derma_head::export::write_obj(head, &dir.join("head.obj"), &dir.join("head_parts.obj"))
        .unwrap();
    let (doc, buffers, _) = gltf::import(dir.join("head.glb")).unwrap();
    let names: Vec<String> = doc
        .meshes()
        .map(|m| m.name().unwrap_or("").to_string())
        .collect();
    for want in [
        "skin",
        "eye_left",
        "eye_right",
        "eyelashes_left",
        "teeth_upper",
        "teeth_lower",
        "tongue",
    ] {
        assert!(
            names.iter().any(|n| n == want),
            "{want} missing from {names:?}"
        );
    }
    let skin = doc.meshes().find(|m| m.name() == Some("skin")).unwrap();
    let prim = skin.primitives().next().unwrap();
    let reader = prim.reader(|b| Some(&buffers[b.index()]));
    let targets: Vec<_> = reader.read_morph_targets().collect();
    assert_eq!(targets.len(), 52);
    let n = reader.read_positions().unwrap().count();
    assert_eq!(n, head.skin.positions.len());
    // The sparse targets decode to the library's offsets (metres in the file).
    let unit = head
        .face_units()
        .iter()
        .position(|u| u.name == "jawOpen")
        .unwrap();
    let offs: Vec<[f32; 3]> = targets[unit].0.clone().unwrap().collect();
    for &(v, d) in head.face_units()[unit].skin.iter().take(50) {
        let got = Vec3::from(offs[v as usize]) * 1000.0;
        assert!((got - d).length() < 1e-3);
    }
    let extras = skin.extras().as_ref().unwrap().get();
    assert!(extras.contains("eyeBlinkLeft") && extras.contains("tongueOut"));
    let skin = derma_core::mesh::TriMesh::load(&dir.join("head.obj")).unwrap();
    assert_eq!(skin.triangles.len(), head.skin.triangles.len());
    let parts = std::fs::read_to_string(dir.join("head_parts.obj")).unwrap();
    assert!(
        parts.contains("o eye_left") && parts.contains("o tongue") && !parts.contains("o skin")
    );
}

//! The fit against ground truth it was not tuned on (seed 5; the schedule was set on seeds 1–2),
//! through the files a user gives (a cm OBJ without UVs), and what it refuses.

use crate::truth;

use derma_core::head_mesh::HeadUnit;
use derma_core::mesh::TriMesh;
use derma_core::mesh_parts::PartChoice;
use derma_core::progress::Silent;
use derma_head::fit::job::{FitJob, LandmarkSource};
use derma_head::fit::{self, store, Alignment, FitError, FitOptions};
use derma_test_support::scratch_dir;
use glam::Vec3;

#[test]
#[ignore = "slow: scripts/test_slow.sh"]
fn a_warped_remeshed_head_in_centimetres_is_fitted_within_a_millimetre() {
    let case = truth::case(5, 10.0, 60.0);
    let dir = scratch_dir("fit-truth");
    let obj = dir.join("scan.obj");
    case.scan_cm.write_obj(&obj).unwrap();
    let out = dir.join("fitted");
    let report = FitJob {
        mesh: obj.clone(),
        unit: HeadUnit::Auto,
        part: PartChoice::Auto,
        axes: None,
        landmarks: LandmarkSource::Auto,
        out: out.clone(),
    }
    .run(&Silent)
    .expect("the fit");
    let fitted = store::read(&out).unwrap();
    let m = case.measure(&fitted);
    // Issue 36's figures: RMS ≤ 1 mm and 95th percentile ≤ 2 mm on the face, landmarks ≤ 2 mm,
    // the fitted skin on the scan (median ≤ 0.2 mm), no triangle turned over.
    assert!(m.rms <= 1.0, "face RMS {} mm", m.rms);
    assert!(m.p95 <= 2.0, "face p95 {} mm", m.p95);
    assert!(m.landmark_max <= 2.0, "landmarks {} mm", m.landmark_max);
    assert!(report.median_mm <= 0.2, "median {}", report.median_mm);
    assert_eq!(report.flipped, 0);
    assert!(report.projected);
    // The automatic alignment found the mouth corners on the scan (its open lips' border)
    // within a millimetre, and most eye corners; the fit put each opening's corner where the
    // scan has it.
    assert!(report.detected.len() >= 4, "{:?}", report.detected);
    // The canthi are found on the skin's opening: the outer 1.3–2.0 mm and the inner about
    // 5.4 mm from derma's landmarks, which sit inside the socket (docs/head.md).
    for (n, p) in &report.detected {
        let off = (Vec3::from(*p) - case.landmarks.points[n]).length();
        let limit = match n.as_str() {
            "mouth_corner_left" | "mouth_corner_right" => 1.0,
            "canthus_outer_left" | "canthus_outer_right" => 2.5,
            _ => 6.5,
        };
        assert!(off < limit, "{n} detected {off} mm off");
    }
    for (n, gap) in &report.corner_gap_mm {
        assert!(*gap < 1.5, "{n}: the fit's corner {gap} mm from the scan's");
    }

    // The directory reads back as a head: same fine skin, landmarks on it, in the scan's mm.
    let head = derma_head::fitted::open(&out).unwrap();
    let lm = &head.landmarks;
    let asset = derma_head::asset::parse();
    let tip = fitted.fine[asset.meta.landmarks["nose_tip"] as usize];
    assert!((lm.get("nose_tip") - tip).length() < 1e-4);
    // The landmarks file is in the scan's units (cm).
    let text = std::fs::read_to_string(out.join("landmarks.json")).unwrap();
    let cm = derma_head::Landmarks::from_json(&text, 10.0).unwrap();
    assert!((cm.get("nose_tip") - tip).length() < 1e-3);

    // A smile moves the user's mouth corners up and out (head frame: the scan's, turned a few
    // degrees).
    let up = fitted.similarity.rotation * Vec3::Y;
    let smile = head.posed_skin(&[("mouthSmileLeft", 1.0)]);
    let v = asset.meta.landmarks["mouth_corner_left"] as usize;
    let i = head
        .skin
        .positions
        .iter()
        .position(|p| (*p - fitted.fine[v]).length() < 1e-5)
        .expect("the landmark's vertex");
    let lift = (smile.positions[i] - head.skin.positions[i]).dot(up);
    assert!(
        lift > 1.0,
        "the smile lifts the left mouth corner {lift} mm"
    );

    // Every fine skin vertex lies outside both globes at rest.
    for e in &head.eyes {
        for p in &head.skin.positions {
            assert!((*p - e.centre).length() > e.radius - 0.05);
        }
    }

    // The correspondences: one record per fitted skin vertex and per scan vertex, most found.
    let t2s = store::decode(&std::fs::read(out.join("template_to_scan.bin")).unwrap()).unwrap();
    let s2t = store::decode(&std::fs::read(out.join("scan_to_template.bin")).unwrap()).unwrap();
    assert_eq!(t2s.len(), head.skin.positions.len());
    assert_eq!(s2t.len(), case.scan.positions.len());
    let found = s2t.iter().filter(|c| c.is_some()).count() as f32 / s2t.len() as f32;
    assert!(found > 0.95, "{found}");
    // The scan was not touched.
    assert!(obj.exists());
}

/// A UV sphere of radius `r` (mm), outward.
fn sphere(r: f32) -> TriMesh {
    let mut m = TriMesh::default();
    let (nu, nv) = (48u32, 24u32);
    for j in 0..=nv {
        for i in 0..nu {
            let (t, p) = (
                std::f32::consts::PI * j as f32 / nv as f32,
                std::f32::consts::TAU * i as f32 / nu as f32,
            );
            m.positions
                .push(r * Vec3::new(t.sin() * p.cos(), t.cos(), t.sin() * p.sin()));
        }
    }
    for j in 0..nv {
        for i in 0..nu {
            let a = j * nu + i;
            let b = j * nu + (i + 1) % nu;
            let (c, d) = (a + nu, b + nu);
            m.triangles.push([a, b, d]);
            m.triangles.push([a, d, c]);
        }
    }
    m.compute_normals();
    m
}

#[test]
#[ignore = "slow: scripts/test_slow.sh"]
fn what_is_no_face_or_cannot_fit_is_refused_by_name() {
    let fail = |scan: TriMesh, opts: &FitOptions| match fit::fit(scan, opts, &Silent) {
        Err(e) => e,
        Ok(_) => panic!("a fit that should fail succeeded"),
    };
    // A sphere is no face: at no orientation, size or place.
    let e = fit::auto_alignment(&sphere(100.0)).expect_err("no face");
    assert!(
        matches!(e, FitError::Scan(_)) && e.to_string().contains("no face found"),
        "{e}"
    );
    // A head whose triangles face inward.
    let case = truth::case(6, 5.0, 60.0);
    let mut inward = case.scan.clone();
    for t in &mut inward.triangles {
        t.swap(1, 2);
    }
    let e = fit::auto_alignment(&inward).expect_err("inward");
    assert!(e.to_string().contains("face inward"), "{e}");
    // Placed by hand, the fit refuses it too.
    let auto = fit::auto_alignment(&case.scan).expect("the head's face");
    let placed = FitOptions {
        alignment: auto.clone(),
        ..FitOptions::default()
    };
    let mut inward = case.scan.clone();
    for t in &mut inward.triangles {
        t.swap(1, 2);
    }
    let e = fail(inward, &placed);
    assert!(e.to_string().contains("face inward"), "{e}");
    // A landmark far from the surface is named.
    let mut lm = case.landmarks.clone();
    *lm.points.get_mut("nose_tip").unwrap() += Vec3::new(0.0, 0.0, 40.0);
    let opts = FitOptions {
        alignment: Alignment::Landmarks(lm),
        ..FitOptions::default()
    };
    let e = fail(case.scan.clone(), &opts);
    assert!(
        e.to_string().contains("nose_tip") && e.to_string().contains("from the scan's surface"),
        "{e}"
    );
    // A fit that cannot reach the scan says so with its residual.
    let opts = FitOptions {
        alignment: auto,
        stiffness: vec![1000.0],
        iterations: 1,
        max_residual_mm: 1e-4,
        ..FitOptions::default()
    };
    let e = fail(case.scan.clone(), &opts);
    assert!(
        matches!(e, FitError::NoConvergence { rms_mm, .. } if rms_mm > 1e-4),
        "{e}"
    );
    assert!(e.to_string().contains("did not converge"));
}

#[test]
fn bad_files_are_errors_that_name_them_and_leave_nothing_behind() {
    let dir = scratch_dir("fit-bad");
    // Non-finite coordinates.
    let nan = dir.join("nan.obj");
    std::fs::write(&nan, "v 0 0 0\nv 1 0 nan\nv 0 1 0\nf 1 2 3\n").unwrap();
    let job = |mesh: &std::path::Path, out: &str| FitJob {
        mesh: mesh.to_path_buf(),
        unit: HeadUnit::Auto,
        part: PartChoice::Auto,
        axes: None,
        landmarks: LandmarkSource::Auto,
        out: dir.join(out),
    };
    let e = job(&nan, "a").run(&Silent).unwrap_err().to_string();
    assert!(e.contains("nan.obj") && e.contains("NaN"), "{e}");
    // A box: no face; the output directory gets no head.json.
    let cube = dir.join("box.obj");
    let mut text = String::new();
    for z in [-100, 100] {
        for y in [-120, 120] {
            for x in [-80, 80] {
                text.push_str(&format!("v {x} {y} {z}\n"));
            }
        }
    }
    for f in [
        [1, 3, 4, 2],
        [5, 6, 8, 7],
        [1, 2, 6, 5],
        [3, 7, 8, 4],
        [1, 5, 7, 3],
        [2, 4, 8, 6],
    ] {
        text.push_str(&format!(
            "f {} {} {}\nf {} {} {}\n",
            f[0], f[1], f[2], f[0], f[2], f[3]
        ));
    }
    std::fs::write(&cube, text).unwrap();
    let e = job(&cube, "b").run(&Silent).unwrap_err().to_string();
    assert!(e.contains("box.obj") && e.contains("no face found"), "{e}");
    assert!(!dir.join("b").join("head.json").exists());
    // An output directory that is the scan's own folder, overwriting it: refused before work.
    let e = FitJob {
        mesh: dir.join("head.json"),
        unit: HeadUnit::Auto,
        part: PartChoice::Auto,
        axes: None,
        landmarks: LandmarkSource::Auto,
        out: dir.clone(),
    };
    std::fs::write(dir.join("head.json"), "{}").unwrap();
    assert!(e.run(&Silent).is_err());
    // A directory that is no fitted head.
    let e = derma_head::fitted::open(&dir.join("a"))
        .err()
        .expect("no head")
        .to_string();
    assert!(e.contains("head.json"), "{e}");
}

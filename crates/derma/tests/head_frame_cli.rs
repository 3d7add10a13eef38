//! The fit is the frame: `derma head fit` finds a scan's unit and axes from its face, and every
//! command given the fitted head reads the scan in that frame — a unit that agrees changes
//! nothing, one that contradicts it is refused by name; a file of several parts is read by its
//! skin, or by the part named. On MediaPipe's canonical face (../shared/data: a face mask in cm,
//! not made by derma).

use crate::common;

use common::{run, s, tmp};
use std::path::Path;

/// The canonical face turned to +Z up, facing −Y, in a unit of 420 mm (cm ÷ 42): no unit and no
/// axis of derma's convention.
fn turned_and_rescaled(src: &Path, dst: &Path) {
    let text = std::fs::read_to_string(src).unwrap();
    let out: String = text
        .lines()
        .map(|l| match l.strip_prefix("v ") {
            Some(rest) => {
                let v: Vec<f32> = rest
                    .split_whitespace()
                    .map(|t| t.parse().unwrap())
                    .collect();
                // File (x, y, z) of a +Y-up, +Z-facing face → (x, −z, y): +Z up, facing −Y.
                format!("v {} {} {}\n", v[0] / 42.0, -v[2] / 42.0, v[1] / 42.0)
            }
            None => format!("{l}\n"),
        })
        .collect();
    std::fs::write(dst, out).unwrap();
}

fn json(p: &Path) -> serde_json::Value {
    serde_json::from_slice(&std::fs::read(p).unwrap()).unwrap()
}

#[test]
#[ignore = "slow: scripts/test_slow.sh"]
fn every_command_reads_the_scan_in_the_frame_its_fit_found() {
    let Some(face) = derma_test_support::shared_data("canonical_face_model.obj") else {
        return;
    };
    let d = tmp("frame", "unit");
    let fit = d.join("fit");
    let (ok, _, err) = run(&[
        "head",
        "fit",
        "--mesh",
        s(&face),
        "--unit",
        "cm",
        "--out",
        s(&fit),
    ]);
    assert!(ok, "{err}");
    // With the fitted head, no unit and the fit's unit paint the same files.
    let paint = |out: &str, extra: &[&str]| {
        let o = d.join(out);
        let mut args = vec![
            "skin",
            "--size",
            "128",
            "--mesh",
            s(&face),
            "--head",
            s(&fit),
            "--out",
            s(&o),
        ];
        args.extend_from_slice(extra);
        let r = run(&args);
        (r, o)
    };
    let ((ok, _, err), a) = paint("a", &[]);
    assert!(ok, "{err}");
    let ((ok, _, err), b) = paint("b", &["--unit", "cm"]);
    assert!(ok, "{err}");
    for f in [
        "base_color.png",
        "normal.png",
        "height.exr",
        "melanin.exr",
        "hemoglobin.exr",
    ] {
        assert_eq!(
            std::fs::read(a.join(f)).unwrap(),
            std::fs::read(b.join(f)).unwrap(),
            "{f} differs with the unit given"
        );
    }
    assert_eq!(
        json(&a.join("report.json"))["inputs"]["mesh"]["mm_per_unit"],
        10.0
    );
    // A unit that contradicts the fit is refused, naming both; nothing is painted.
    let ((ok, _, err), c) = paint("c", &["--unit", "mm"]);
    assert!(!ok);
    assert!(
        err.contains("10 mm per unit") && err.contains("mm"),
        "{err}"
    );
    assert!(!c.join("base_color.png").exists());
    // So is a part the fit did not read.
    let ((ok, _, err), _) = paint("d", &["--node", "eye_left"]);
    assert!(!ok && err.contains("eye_left"), "{err}");
    let _ = std::fs::remove_dir_all(&d);
}

#[test]
#[ignore = "slow: scripts/test_slow.sh"]
fn a_scan_in_no_unit_and_turned_is_fitted_and_painted_in_its_frame() {
    let Some(face) = derma_test_support::shared_data("canonical_face_model.obj") else {
        return;
    };
    let d = tmp("frame", "turned");
    let turned = d.join("turned.obj");
    turned_and_rescaled(&face, &turned);
    let fit = d.join("fit");
    let (ok, out, err) = run(&["head", "fit", "--mesh", s(&turned), "--out", s(&fit)]);
    assert!(ok, "{err}");
    assert!(out.contains("+Z up, facing −Y"), "{out}");
    let head = json(&fit.join("head.json"));
    let frame = &head["frame"];
    let k = frame["mm_per_unit"].as_f64().unwrap();
    // 420 mm per unit, found from the face's size: within the ±15 % adults' faces vary.
    assert!((k / 420.0 - 1.0).abs() < 0.15, "{k}");
    assert!(frame["unit"].is_null(), "{frame}");
    // Landmarks are written in the file's own coordinates: the nose tip is the most forward
    // point along −Y.
    let lm = json(&fit.join("landmarks.json"));
    let nose_y = lm["nose_tip"][1].as_f64().unwrap();
    let min_y = std::fs::read_to_string(&turned)
        .unwrap()
        .lines()
        .filter_map(|l| l.strip_prefix("v "))
        .map(|r| r.split_whitespace().nth(1).unwrap().parse::<f64>().unwrap())
        .fold(f64::INFINITY, f64::min);
    assert!((nose_y - min_y).abs() * k < 3.0, "{nose_y} {min_y}");
    // The skin is painted on the turned scan in the fit's frame, as the report says.
    let o = d.join("skin");
    let (ok, _, err) = run(&[
        "skin",
        "--size",
        "128",
        "--mesh",
        s(&turned),
        "--head",
        s(&fit),
        "--out",
        s(&o),
    ]);
    assert!(ok, "{err}");
    let mesh = &json(&o.join("report.json"))["inputs"]["mesh"];
    assert_eq!(mesh["axes"], "+Z up, facing −Y", "{mesh}");
    assert!((mesh["mm_per_unit"].as_f64().unwrap() - k).abs() < 1e-3 * k);
    // Its own landmarks go through the same frame (turned, not only scaled: read upright they
    // would face the wrong way and be refused).
    let (ok, _, err) = run(&[
        "skin",
        "--size",
        "128",
        "--mesh",
        s(&turned),
        "--head",
        s(&fit),
        "--landmarks",
        "mediapipe",
        "--out",
        s(&d.join("skin_lm")),
    ]);
    assert!(ok, "{err}");
    let _ = std::fs::remove_dir_all(&d);
}

#[test]
fn a_file_of_several_parts_is_read_by_its_skin_or_the_part_named() {
    let d = tmp("frame", "parts");
    let tpl = d.join("tpl");
    assert!(run(&["skin", "--export-template", s(&tpl)]).0);
    let glb = tpl.join("head.glb");
    // The template's GLB holds the skin, eyes, lashes, teeth and tongue: the skin is painted
    // (in metres, 232 mm tall), not every node into one UV space.
    let a = d.join("a");
    let (ok, _, err) = run(&["skin", "--size", "128", "--mesh", s(&glb), "--out", s(&a)]);
    assert!(ok, "{err}");
    let r = json(&a.join("report.json"));
    assert_eq!(r["inputs"]["mesh"]["unit"], "m");
    let skin_cm2 = r["surface_area_cm2"].as_f64().unwrap();
    assert!(
        (1300.0..1600.0).contains(&skin_cm2),
        "{skin_cm2} cm² is not the skin alone"
    );
    // A part named: the left eye (its globe, 11.8 mm in radius: 17.5 cm²).
    let b = d.join("b");
    let (ok, _, err) = run(&[
        "skin",
        "--size",
        "128",
        "--mesh",
        s(&glb),
        "--node",
        "eye_left",
        "--unit",
        "m",
        "--out",
        s(&b),
    ]);
    assert!(ok, "{err}");
    let r = json(&b.join("report.json"));
    assert_eq!(r["inputs"]["mesh"]["part"], "eye_left");
    let eye_cm2 = r["surface_area_cm2"].as_f64().unwrap();
    assert!((15.0..20.0).contains(&eye_cm2), "{eye_cm2}");
    // A name the file does not hold is an error listing what it holds.
    let (ok, _, err) = run(&[
        "skin",
        "--size",
        "128",
        "--mesh",
        s(&glb),
        "--node",
        "face",
        "--out",
        s(&d.join("c")),
    ]);
    assert!(
        !ok && err.contains("'face'") && err.contains("'tongue'"),
        "{err}"
    );
    let _ = std::fs::remove_dir_all(&d);
}

#[test]
fn axes_that_contradict_the_landmarks_are_refused() {
    let Some(face) = derma_test_support::shared_data("canonical_face_model.obj") else {
        return;
    };
    let d = tmp("frame", "axes");
    let (ok, _, err) = run(&[
        "head",
        "fit",
        "--mesh",
        s(&face),
        "--landmarks",
        "mediapipe",
        "--axes",
        "+Z,-Y",
        "--out",
        s(&d.join("fit")),
    ]);
    assert!(
        !ok && err.contains("+Y up, facing +Z") && err.contains("+Z up, facing −Y"),
        "{err}"
    );
    assert!(!d.join("fit/head.json").exists());
    let _ = std::fs::remove_dir_all(&d);
}

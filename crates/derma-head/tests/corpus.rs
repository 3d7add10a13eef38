//! The fit on real meshes derma did not make (`scripts/corpus.py`: photogrammetry heads and
//! busts, a FACS face, MediaPipe's face mask, a full-length statue), each fitted with no flags
//! — its unit, axes and skin found — against landmarks placed by hand
//! (`tests/data/corpus_landmarks.json`, `scripts/landmark_views.py`: corners on a front view,
//! midline points on a profile, each error measured in its view's plane). Goals (issue 59): no
//! triangle turned over; landmark error median ≤ 3 mm, none over 6 mm.
//!
//!   python3 scripts/corpus.py fetch
//!   cargo test --release -p derma-head --test suite corpus:: -- --ignored --nocapture
//!
//! MediaPipe's face (from ../shared/data) runs in the test command.

use derma_core::head_mesh::HeadUnit;
use derma_core::progress::Silent;
use derma_head::fit::job::{FitJob, LandmarkSource};
use derma_head::fit::{store, FitReport};
use glam::Vec3;
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::time::Instant;

/// Hand-placed landmarks: mesh → name → point in the file's own coordinates.
fn hand_placed() -> BTreeMap<String, BTreeMap<String, [f32; 3]>> {
    #[derive(serde::Deserialize)]
    struct Entry {
        points: BTreeMap<String, [f32; 3]>,
    }
    let p = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/corpus_landmarks.json");
    let all: BTreeMap<String, Entry> = serde_json::from_slice(&std::fs::read(p).unwrap()).unwrap();
    all.into_iter().map(|(k, e)| (k, e.points)).collect()
}

/// How one fit went.
struct Outcome {
    report: FitReport,
    seconds: f64,
    /// Per hand-placed landmark, its distance (mm) from the fitted head's.
    errors: Vec<(String, f32)>,
    /// Per eye, the height (mm) of the upper lid's middle over the lower lid's under the fitted
    /// head's own eyeBlink at full weight (0: the margins meet).
    blink_gap: [f32; 2],
}

/// [`Outcome::blink_gap`] of a fitted head.
fn blink_gaps(head: &derma_head::Head) -> [f32; 2] {
    ["left", "right"].map(|side| {
        let side_cap = if side == "left" { "Left" } else { "Right" };
        let posed = head.posed_skin(&[(&format!("eyeBlink{side_cap}"), 1.0)]);
        let (up, low) = (
            head.landmarks.get(&format!("lid_upper_{side}")),
            head.landmarks.get(&format!("lid_lower_{side}")),
        );
        let i = derma_test_support::nearest(&head.skin.positions, up).unwrap();
        posed.positions[i].y - low.y
    })
}

/// The landmark error as the hand placement read it: the canthi and mouth corners were read
/// off a front view, so their error is measured in the face's frontal plane (its depth inside
/// an opening is no annotation's); the midline points were read off a profile, so theirs is
/// measured in the midsagittal plane. `rot` turns derma's frame into the fitted face's own
/// (its placement's rotation), so a turned face is measured on its own planes.
fn read_off(name: &str, fitted: Vec3, hand: Vec3, rot: glam::Mat3) -> f32 {
    let d = rot.transpose() * (fitted - hand);
    let on_profile = ["nose_tip", "subnasale", "chin", "glabella"].contains(&name);
    if on_profile {
        glam::Vec2::new(d.y, d.z).length()
    } else {
        glam::Vec2::new(d.x, d.y).length()
    }
}

/// Fits `mesh` with no flags into `out` and measures it against `points`.
fn fit(mesh: &Path, out: &Path, points: &BTreeMap<String, [f32; 3]>) -> Outcome {
    let clock = Instant::now();
    let report = FitJob {
        mesh: mesh.to_path_buf(),
        unit: HeadUnit::Auto,
        part: Default::default(),
        axes: None,
        landmarks: LandmarkSource::Auto,
        out: out.to_path_buf(),
    }
    .run(&Silent)
    .unwrap_or_else(|e| panic!("{}: {e}", mesh.display()));
    let seconds = clock.elapsed().as_secs_f64();
    let frame = store::frame(out).unwrap();
    let head = derma_head::fitted::open(out).unwrap();
    let rot = store::read(out).unwrap().similarity.rotation;
    // The eye and mouth corners as the skin's openings show them (derma's canthi lie inside the
    // socket); the midline points as derma's landmarks.
    let corner = |n: &str| {
        report
            .opening_corners
            .iter()
            .find(|c| c.0 == n)
            .map(|c| Vec3::from(c.1))
    };
    let errors = points
        .iter()
        .map(|(n, p)| {
            let hand = frame.point(Vec3::from(*p));
            let fitted = corner(n).unwrap_or_else(|| head.landmarks.get(n));
            (n.clone(), read_off(n, fitted, hand, rot))
        })
        .collect();
    Outcome {
        report,
        seconds,
        errors,
        blink_gap: blink_gaps(head),
    }
}

/// The median (NaN for a mesh with no hand-placed landmarks).
fn median(v: &mut [f32]) -> f32 {
    v.sort_by(f32::total_cmp);
    v.get(v.len() / 2).copied().unwrap_or(f32::NAN)
}

/// One markdown row of docs/head.md's corpus table.
fn row(name: &str, o: &Outcome) -> String {
    let f = o.report.frame.as_ref().expect("a frame");
    let mut e = judged(o);
    let worst = o
        .errors
        .iter()
        .filter(|e| e.0 != "glabella")
        .max_by(|a, b| a.1.total_cmp(&b.1))
        .map(|w| format!("{:.1} ({})", w.1, w.0.replace('_', " ")))
        .unwrap_or_default();
    let glabella = o
        .errors
        .iter()
        .find(|e| e.0 == "glabella")
        .map_or(0.0, |g| g.1);
    format!(
        "| {name} | {} · {} | {:.1} s | {:.2} / {:.3} | {} | {} of 6 | {:.1} | {worst} | {glabella:.1} | {:+.1} / {:+.1} |",
        f.axes,
        f.unit
            .clone()
            .unwrap_or_else(|| format!("{:.1} mm/unit", f.mm_per_unit)),
        o.seconds,
        o.report.rms_mm,
        o.report.median_mm,
        o.report.flipped,
        o.report.detected.len(),
        median(&mut e),
        o.blink_gap[0],
        o.blink_gap[1]
    )
}

/// The landmarks whose definition derma's template shares with the hand placement: its
/// glabella is the most prominent midline point up to 30 mm above the eyes, which on its flat
/// brow is that band's top, 4–11 mm above the brow ridge the hand placed (reported, not
/// judged).
fn judged(o: &Outcome) -> Vec<f32> {
    o.errors
        .iter()
        .filter(|e| e.0 != "glabella")
        .map(|e| e.1)
        .collect()
}

/// Whether a fit meets issue 59's goals: nothing turned over, landmarks median ≤ 3 mm and none
/// over 6 mm.
fn meets_goals(o: &Outcome) -> bool {
    let mut e = judged(o);
    o.report.flipped == 0 && median(&mut e) <= 3.0 && e.iter().all(|&x| x <= 6.0)
}

/// What every corpus fit holds: nothing turned over; the carried blink closes each eye (its
/// upper lid's middle within 1 mm of the lower lid's); landmarks median ≤ `median_mm`, none
/// over `max_mm` (where landmarks were hand-placed: not on the scan added for its photographed
/// albedo, `jon`).
fn check(name: &str, o: &Outcome, median_mm: f32, max_mm: f32) {
    let mut e = judged(o);
    assert_eq!(o.report.flipped, 0, "{name}: triangles turned over");
    assert!(
        o.blink_gap.iter().all(|g| g.abs() <= 1.0),
        "{name}: the blink leaves the lids {:?} mm apart",
        o.blink_gap
    );
    if e.is_empty() {
        return;
    }
    let m = median(&mut e);
    assert!(
        m <= median_mm,
        "{name}: landmark median {m} mm {:?}",
        o.errors
    );
    assert!(
        e.iter().all(|&x| x <= max_mm),
        "{name}: a landmark over {max_mm} mm {:?}",
        o.errors
    );
}

#[test]
#[ignore = "slow: scripts/test_slow.sh"]
fn mediapipes_face_is_fitted_with_no_flags() {
    let Some(face) = derma_test_support::shared_data("canonical_face_model.obj") else {
        return;
    };
    let out = derma_test_support::scratch_dir("corpus-mediapipe");
    let o = fit(&face, &out.join("fit"), &hand_placed()["mediapipe"]);
    let f = o.report.frame.as_ref().unwrap();
    assert_eq!(f.unit.as_deref(), Some("cm"));
    assert_eq!(f.axes, "+Y up, facing +Z");
    println!("{}", row("mediapipe", &o));
    // Issue 59's goals, met here.
    check("mediapipe", &o, 3.0, 6.0);
    let _ = std::fs::remove_dir_all(&out);
}

fn corpus_dir() -> PathBuf {
    std::env::var_os("DERMA_CORPUS")
        .map(PathBuf::from)
        .unwrap_or_else(|| Path::new(env!("CARGO_MANIFEST_DIR")).join("../../target/corpus"))
}

#[test]
#[ignore = "needs the corpus: python3 scripts/corpus.py fetch"]
fn the_corpus_is_fitted_with_no_flags() {
    #[derive(serde::Deserialize)]
    struct Mesh {
        name: String,
        mesh: String,
        held_out: bool,
    }
    let dir = corpus_dir();
    let list: Vec<Mesh> = serde_json::from_slice(
        &std::fs::read(dir.join("corpus.json"))
            .expect("the corpus (python3 scripts/corpus.py fetch)"),
    )
    .unwrap();
    let hand = hand_placed();
    let out = derma_test_support::scratch_dir("corpus");
    println!("| mesh | found | time | RMS / median (mm) | flipped | corners | landmarks median (mm) | worst (mm) | glabella (mm) | blink gap L / R (mm) |");
    println!("|---|---|---:|---:|---:|---:|---:|---|---:|---:|");
    let mut failures = Vec::new();
    for m in &list {
        let points = hand.get(&m.name).cloned().unwrap_or_default();
        let o = fit(&dir.join(&m.mesh), &out.join(&m.name), &points);
        let name = if m.held_out {
            format!("{} (held out)", m.name)
        } else {
            m.name.clone()
        };
        println!("{}", row(&name, &o));
        println!(
            "  goals {}; {}",
            if o.errors.is_empty() {
                "not judged (no hand-placed landmarks)"
            } else if meets_goals(&o) {
                "met"
            } else {
                "missed"
            },
            o.errors
                .iter()
                .map(|(n, e)| format!("{n} {e:.1}"))
                .collect::<Vec<_>>()
                .join(", ")
        );
        // What holds on every mesh (the goals are reported, docs/head.md).
        if let Err(e) = std::panic::catch_unwind(|| check(&m.name, &o, 5.0, 15.0)) {
            failures.push(format!("{}: {e:?}", m.name));
        }
    }
    let _ = std::fs::remove_dir_all(&out);
    assert!(failures.is_empty(), "{failures:#?}");
}

//! The fit against ground truth: the built-in head's skin retriangulated, its vertices slid
//! along the surface, warped by a smooth random deformation, rotated, moved and written in
//! centimetres; fitted, and every fitted vertex compared with where its template vertex went.
//!
//!   cargo run --release -p derma-head --example fit_truth -- SEED PEAK_MM [LANDMARKS]
//!
//! Environment: SIGMA (warp width, mm; 60), SPLITS (split the scan's triangles into four N
//! times), WRITE (also write the scan there, cm OBJ), STIFFNESS and ITERATIONS (the schedule),
//! LM (print each landmark's error).

use derma_core::progress::Silent;
use derma_head::fit::{self, Alignment, FitOptions};
use std::time::Instant;

#[path = "../tests/support/truth.rs"]
#[allow(dead_code)]
mod truth;

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let seed: u64 = args.get(1).and_then(|s| s.parse().ok()).unwrap_or(1);
    let peak: f32 = args.get(2).and_then(|s| s.parse().ok()).unwrap_or(10.0);
    let with_landmarks = args.get(3).is_some_and(|s| s == "landmarks");
    let env = |k: &str| std::env::var(k).ok().and_then(|s| s.parse::<f32>().ok());
    let case = truth::case_split(
        seed,
        peak,
        env("SIGMA").unwrap_or(60.0),
        env("SPLITS").unwrap_or(0.0) as usize,
    );
    if let Ok(path) = std::env::var("WRITE") {
        case.scan_cm
            .write_obj(std::path::Path::new(&path))
            .expect("writing the scan");
    }
    let opts = FitOptions {
        alignment: if with_landmarks {
            Alignment::Landmarks(case.landmarks.clone())
        } else {
            fit::auto_alignment(&case.scan).expect("a face")
        },
        ..FitOptions::default()
    };
    let mut opts = opts;
    if let Ok(s) = std::env::var("STIFFNESS") {
        opts.stiffness = s.split(',').map(|x| x.parse().unwrap()).collect();
    }
    if let Ok(s) = std::env::var("ITERATIONS") {
        opts.iterations = s.parse().unwrap();
    }
    let t0 = Instant::now();
    let fitted = fit::fit(case.scan.clone(), &opts, &Silent).expect("fit");
    let secs = t0.elapsed().as_secs_f64();
    let m = case.measure(&fitted);
    for (n, p) in &fitted.report.detected {
        let truth = case.landmarks.points[n];
        let gap = fitted.report.corner_gap_mm.iter().find(|g| &g.0 == n);
        println!(
            "detected {n}: {:.2} mm from the landmark, {} from the fit's corner",
            (glam::Vec3::from(*p) - truth).length(),
            gap.map_or("no corner".into(), |g| format!("{:.2} mm", g.1))
        );
    }
    if std::env::var("LM").is_ok() {
        let asset = derma_head::asset::parse();
        for n in case.landmarks.points.keys() {
            let v = asset.meta.landmarks[n] as usize;
            println!("{n}: {:.2} mm", (fitted.fine[v] - case.truth[v]).length());
        }
    }
    println!(
        "seed {seed} peak {peak} mm{}: {} scan vertices, {secs:.2} s; face RMS {:.3} mm, p95 {:.3} mm, max {:.3} mm; landmarks max {:.3} mm; surface median {:.3} mm; flipped {}; report {:?}",
        if with_landmarks { " (landmarks)" } else { "" },
        case.scan.positions.len(),
        m.rms, m.p95, m.max, m.landmark_max, fitted.report.median_mm, fitted.report.flipped, fitted.report
    );
}

//! The fit against ground truth: the built-in head's skin retriangulated, its vertices slid
//! along the surface, warped by a smooth random deformation, rotated, moved and written in
//! centimetres; fitted, and every fitted vertex compared with where its template vertex went.
//!
//!   cargo run --release -p derma-head --example fit_truth -- SEED PEAK_MM [LANDMARKS]

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
            Alignment::Auto
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
    if std::env::var("WHERE").is_ok() {
        let tpl = derma_head::fit::template::Template::of(&derma_head::asset::parse());
        let p = &tpl.level2.positions;
        for q in &tpl.level2.quads {
            let [a, b, c, d] = q.map(|c| c.0 as usize);
            for t in [[a, b, c], [a, c, d]] {
                let n = |x: &[glam::Vec3]| (x[t[1]] - x[t[0]]).cross(x[t[2]] - x[t[0]]);
                let (n0, n1) = (n(&case.truth), n(&fitted.fine));
                if n0.dot(n1) <= 0.0 {
                    println!("flip at {:?} outer {}", p[t[0]], tpl.outer2[t[0]]);
                }
            }
        }
    }
    if std::env::var("LM").is_ok() {
        let asset = derma_head::asset::parse();
        for n in case.landmarks.points.keys() {
            let v = asset.meta.landmarks[n] as usize;
            println!("{n}: {:.2} mm", (fitted.fine[v] - case.truth[v]).length());
        }
    }
    if std::env::var("BINS").is_ok() {
        let p2 = &derma_head::Head::builtin();
        let tpl = derma_head::fit::template::Template::of(&derma_head::asset::parse());
        let _ = p2;
        let mut bins = std::collections::BTreeMap::new();
        for &i in &case.face {
            let p = tpl.level2.positions[i];
            let key = (((p.y + 200.0) / 25.0) as i32, (p.x.abs() / 20.0) as i32);
            let e = (fitted.fine[i] - case.truth[i]).length();
            let b = bins.entry(key).or_insert((0.0f32, 0usize));
            b.0 += e * e;
            b.1 += 1;
        }
        for ((y, x), (s, n)) in bins {
            println!(
                "y {:>4}..{:>4} |x| {:>3}..{:>3}: rms {:.2} ({n})",
                y * 25 - 200,
                y * 25 - 175,
                x * 20,
                x * 20 + 20,
                (s / n as f32).sqrt()
            );
        }
    }
    println!(
        "seed {seed} peak {peak} mm{}: {} scan vertices, {secs:.2} s; face RMS {:.3} mm, p95 {:.3} mm, max {:.3} mm; landmarks max {:.3} mm; surface median {:.3} mm; flipped {}; report {:?}",
        if with_landmarks { " (landmarks)" } else { "" },
        case.scan.positions.len(),
        m.rms, m.p95, m.max, m.landmark_max, fitted.report.median_mm, fitted.report.flipped, fitted.report
    );
}

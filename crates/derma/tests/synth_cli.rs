//! End-to-end tests of `derma synth`: joint channels with files beside the output, the same
//! seed giving the same bytes, a guide, and the errors users meet.

use crate::common;

use common::s;
use derma_core::image_io::{read_rgb, write_png16, write_png8};
use derma_core::Map;
use std::path::{Path, PathBuf};

fn tmp(tag: &str) -> PathBuf {
    common::tmp("synthcli", tag)
}

/// `derma synth ARGS --quiet`.
fn run(args: &[&str]) -> (bool, String, String) {
    common::run(&[&["synth"], args].concat())
}

/// A grey "relief" and a registered colour image of the same bumps.
fn exemplars(dir: &Path, n: usize, level: f32) -> (PathBuf, PathBuf) {
    let v = |i: usize| {
        let (x, y) = ((i % n) as f32, (i / n) as f32);
        level + 0.15 * (x * 0.6).sin() * (y * 0.45).cos() + 0.05 * ((x + 2.0 * y) * 1.3).sin()
    };
    let h = Map::from_vec(n, n, (0..n * n).map(v).collect()).unwrap();
    let c = |k: f32| Map::from_vec(n, n, (0..n * n).map(|i| k * v(i)).collect()).unwrap();
    let (hp, cp) = (
        dir.join(format!("h{level}.png")),
        dir.join(format!("c{level}.png")),
    );
    write_png16(&hp, &[&h]).unwrap();
    write_png8(&cp, &[&c(1.0), &c(0.8), &c(0.7)]).unwrap();
    (hp, cp)
}

#[test]
fn joint_channels_are_written_beside_the_output_and_a_seed_repeats_bytes() {
    let d = tmp("joint");
    let (h, c) = exemplars(&d, 72, 0.5);
    let out = d.join("o.png");
    let chan = format!("color={}", s(&c));
    let args = [
        "--exemplar",
        s(&h),
        "--exemplar-channels",
        &chan,
        "--size",
        "100x80",
        "--patch",
        "16",
        "--seed",
        "3",
        "--tile",
        "--out",
        s(&out),
    ];
    let (ok, _, err) = run(&args);
    assert!(ok, "{err}");
    let grey = read_rgb(&out).unwrap();
    let color = read_rgb(&d.join("o_color.png")).unwrap();
    assert_eq!(
        (grey.channels[0].width(), grey.channels[0].height()),
        (100, 80)
    );
    assert!(color.is_color);
    // Registered: the colour is (within 8-bit rounding) 0.8 × the relief in green.
    let (hv, gv) = (grey.channels[0].data(), color.channels[1].data());
    let worst = hv
        .iter()
        .zip(gv)
        .map(|(a, b)| (0.8 * a - b).abs())
        .fold(0f32, f32::max);
    assert!(worst < 0.02, "channels drifted apart by {worst}");
    let first = std::fs::read(&out).unwrap();
    let (ok, _, err) = run(&args);
    assert!(ok, "{err}");
    assert_eq!(first, std::fs::read(&out).unwrap(), "same seed, same bytes");
    let _ = std::fs::remove_dir_all(&d);
}

#[test]
fn a_guide_chooses_the_exemplar_and_metrics_are_printed() {
    let d = tmp("guide");
    let (dark, _) = exemplars(&d, 64, 0.25);
    let (light, _) = exemplars(&d, 64, 0.75);
    let (w, h) = (96, 48);
    let guide = Map::from_vec(
        w,
        h,
        (0..w * h)
            .map(|i| if i % w < w / 2 { 0.0 } else { 1.0 })
            .collect(),
    )
    .unwrap();
    let g = d.join("guide.png");
    write_png16(&g, &[&guide]).unwrap();
    let out = d.join("g.exr");
    let (ok, stdout, err) = run(&[
        "--exemplar",
        s(&dark),
        "--exemplar",
        s(&light),
        "--guide",
        s(&g),
        "--size",
        "96x48",
        "--patch",
        "16",
        "--out",
        s(&out),
        "--metrics",
    ]);
    assert!(ok, "{err}");
    assert!(
        stdout.contains("\"patch_swd\"") && stdout.contains("\"stages\""),
        "{stdout}"
    );
    let m = &read_rgb(&out).unwrap().channels[0];
    let mean = |x0: usize, x1: usize| {
        let mut acc = 0.0;
        for y in 0..h {
            for x in x0..x1 {
                acc += m.get(x, y) as f64;
            }
        }
        acc / ((x1 - x0) * h) as f64
    };
    assert!(
        mean(0, 24) < 0.4 && mean(72, 96) > 0.6,
        "{} {}",
        mean(0, 24),
        mean(72, 96)
    );
    let _ = std::fs::remove_dir_all(&d);
}

#[test]
fn errors_name_the_file_or_value() {
    let d = tmp("errors");
    let (h, _) = exemplars(&d, 40, 0.5);
    let out = d.join("o.png");
    let (ok, _, err) = run(&["--exemplar", s(&h), "--size", "64", "--out", s(&out)]);
    assert!(
        !ok && err.contains("40×40") && err.contains("smaller patch"),
        "{err}"
    );
    let (ok, _, err) = run(&["--exemplar", s(&h), "--patch", "16", "--out", s(&h)]);
    assert!(!ok && err.contains("never writes over its inputs"), "{err}");
    let (ok, _, err) = run(&[
        "--exemplar",
        s(&h),
        "--patch",
        "16",
        "--out",
        s(&d.join("o.tif")),
    ]);
    assert!(!ok && err.contains(".png or .exr"), "{err}");
    let (ok, _, err) = run(&["--exemplar", s(&d.join("missing.png")), "--out", s(&out)]);
    assert!(!ok && err.contains("missing.png"), "{err}");
    let (ok, _, err) = run(&[
        "--exemplar",
        s(&h),
        "--guide",
        s(&h),
        "--patch",
        "16",
        "--out",
        s(&out),
    ]);
    assert!(!ok && err.contains("at least two exemplars"), "{err}");
    let _ = std::fs::remove_dir_all(&d);
}

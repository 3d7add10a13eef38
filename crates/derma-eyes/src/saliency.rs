//! Visual saliency (Itti, Koch & Niebur 1998, "A model of saliency-based visual attention"):
//! intensity, red–green and blue–yellow opponency and orientation features on a dyadic Gaussian
//! pyramid, centre–surround differences (c ∈ {2, 3, 4}, s = c + {3, 4}), the normalisation
//! operator N(·), conspicuity maps summed at scale 4, and a winner-take-all scan with inhibition
//! of return that yields gaze targets (thesis §3.10: gaze driven by salient points of a video).

use derma_core::image::Grey;
use derma_core::pyramid::{gaussian_pyramid, BINOMIAL};
use derma_core::Map;
use glam::Vec2;

/// The dyadic Gaussian pyramid of Itti et al. 1998 (`levels` levels, level 0 is `m`): derma-core's
/// REDUCE with the binomial kernel [1 4 6 4 1]/16.
fn pyramid(m: &Map, levels: usize) -> Vec<Map> {
    let grey = Grey::from_fn(m.width(), m.height(), |i| [m.data()[i]]);
    gaussian_pyramid(grey, levels, &BINOMIAL)
        .iter()
        .map(|l| {
            let [p] = l.to_planes();
            p
        })
        .collect()
}

/// |c ⊖ s| resampled to `w` × `h`.
fn across(c: &Map, s: &Map, w: usize, h: usize) -> Map {
    let (c, s) = (c.resized(w, h), s.resized(w, h));
    c.zip_map(&s, |a, b| (a - b).abs())
}

/// N(·): scale to [0, 1], then multiply by (1 − m̄)² where m̄ is the mean of the other local
/// maxima (Itti et al. 1998, §2).
pub fn normalise(m: &Map) -> Map {
    let max = m.data().iter().copied().fold(0.0f32, f32::max);
    if max <= 0.0 {
        return m.clone();
    }
    let (w, h) = (m.width(), m.height());
    let v: Vec<f32> = m.data().iter().map(|x| x / max).collect();
    let mut sum = 0.0;
    let mut n = 0;
    for y in 1..h.saturating_sub(1) {
        for x in 1..w.saturating_sub(1) {
            let c = v[y * w + x];
            let is_max = [(0, 1), (2, 1), (1, 0), (1, 2)]
                .iter()
                .all(|(dx, dy)| c >= v[(y + dy - 1) * w + x + dx - 1]);
            if is_max && c < 1.0 && c > 0.05 {
                sum += c;
                n += 1;
            }
        }
    }
    let mbar = if n > 0 { sum / n as f32 } else { 0.0 };
    let f = (1.0 - mbar) * (1.0 - mbar);
    Map::from_fn(w, h, |i| v[i] * f)
}

/// The saliency map of a linear RGB image, at pyramid scale 4 (1/16 of the input).
pub fn saliency(rgb: &[Map; 3]) -> Map {
    let (w, h) = (rgb[0].width(), rgb[0].height());
    let n = w * h;
    let (r, g, b) = (rgb[0].data(), rgb[1].data(), rgb[2].data());
    let i: Vec<f32> = (0..n).map(|k| (r[k] + g[k] + b[k]) / 3.0).collect();
    let imax = i.iter().copied().fold(0.0f32, f32::max);
    // Hue channels only where the intensity exceeds a tenth of its maximum (Itti et al. 1998).
    let chan = |f: &dyn Fn(usize) -> f32| -> Map {
        Map::from_fn(w, h, |k| if i[k] > 0.1 * imax { f(k) / i[k] } else { 0.0 })
    };
    let rr = chan(&|k| (r[k] - (g[k] + b[k]) / 2.0).max(0.0));
    let gg = chan(&|k| (g[k] - (r[k] + b[k]) / 2.0).max(0.0));
    let bb = chan(&|k| (b[k] - (r[k] + g[k]) / 2.0).max(0.0));
    let yy = chan(&|k| ((r[k] + g[k]) / 2.0 - (r[k] - g[k]).abs() / 2.0 - b[k]).max(0.0));
    let levels = 9;
    let ip = pyramid(&Map::from_fn(w, h, |k| i[k]), levels);
    // Opponent channels per level: R − G and B − Y.
    let opponent = |a: &Map, b: &Map| -> Vec<Map> {
        pyramid(a, levels)
            .iter()
            .zip(pyramid(b, levels))
            .map(|(a, b)| a.zip_map(&b, |x, y| x - y))
            .collect()
    };
    let rg = opponent(&rr, &gg);
    let by = opponent(&bb, &yy);
    // Orientation: oriented first-derivative energy at 0°, 45°, 90°, 135° per level (a
    // steerable stand-in for the paper's Gabor filters).
    let orient: Vec<Vec<Map>> = (0..4)
        .map(|o| {
            let th = o as f32 * std::f32::consts::FRAC_PI_4;
            let (c, s) = (th.cos(), th.sin());
            ip.iter()
                .map(|m| {
                    let (mw, mh) = (m.width(), m.height());
                    let at = |x: isize, y: isize| {
                        m.get(
                            x.clamp(0, mw as isize - 1) as usize,
                            y.clamp(0, mh as isize - 1) as usize,
                        )
                    };
                    Map::from_fn(mw, mh, |k| {
                        let (x, y) = ((k % mw) as isize, (k / mw) as isize);
                        let gx = 0.5 * (at(x + 1, y) - at(x - 1, y));
                        let gy = 0.5 * (at(x, y + 1) - at(x, y - 1));
                        (c * gx + s * gy).abs()
                    })
                })
                .collect()
        })
        .collect();
    let (sw, sh) = (ip[4].width(), ip[4].height());
    let feature = |p: &[Map]| -> Map {
        let mut acc = Map::filled(sw, sh, 0.0);
        for c in 2..=4 {
            for d in [3, 4] {
                let s = c + d;
                if s < p.len() {
                    let m = normalise(&across(&p[c], &p[s], sw, sh));
                    acc.data_mut()
                        .iter_mut()
                        .zip(m.data())
                        .for_each(|(a, v)| *a += v);
                }
            }
        }
        acc
    };
    let ci = normalise(&feature(&ip));
    let cc = {
        let a = feature(&rg);
        let b = feature(&by);
        normalise(&a.zip_map(&b, |x, y| x + y))
    };
    let co = {
        let mut acc = Map::filled(sw, sh, 0.0);
        for o in &orient {
            let m = normalise(&feature(o));
            acc.data_mut()
                .iter_mut()
                .zip(m.data())
                .for_each(|(a, v)| *a += v);
        }
        normalise(&acc)
    };
    Map::from_fn(sw, sh, |k| {
        (ci.data()[k] + cc.data()[k] + co.data()[k]) / 3.0
    })
}

/// The `n` most salient points (image fractions in [0, 1]², y down) by winner-take-all with
/// inhibition of return over a disc of `radius` (fraction of the image width).
pub fn targets(s: &Map, n: usize, radius: f32) -> Vec<Vec2> {
    let (w, h) = (s.width(), s.height());
    let mut m = s.data().to_vec();
    let r = (radius * w as f32).max(1.0);
    let mut out = Vec::new();
    for _ in 0..n {
        let (k, v) = m
            .iter()
            .enumerate()
            .fold((0, f32::MIN), |b, (i, &v)| if v > b.1 { (i, v) } else { b });
        if v <= 0.0 {
            break;
        }
        let (x, y) = ((k % w) as f32, (k / w) as f32);
        out.push(Vec2::new((x + 0.5) / w as f32, (y + 0.5) / h as f32));
        for (i, val) in m.iter_mut().enumerate() {
            let (px, py) = ((i % w) as f32, (i / w) as f32);
            if (px - x).hypot(py - y) <= r {
                *val = 0.0;
            }
        }
    }
    out
}

//! A teeth texture from one photo (Tarini et al. 2002 §4.2): voids and gums found by the largest
//! jumps in histograms of colour distances (to black, to red), the six front teeth's colour
//! equalised in six vertical stripes, and the result composited as a billboard into a generic
//! texture of `derma-head`'s teeth, fading out at the canines.

use crate::error::{PhotoError, Result};
use crate::photo::RgbImage;
use derma_core::color::luminance;
use derma_core::mesh::TriMesh;
use derma_core::raster::UvRaster;
use serde::Serialize;

/// What a photo pixel is.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Label {
    /// A tooth.
    Tooth,
    /// Gums, lips or skin (red-ish).
    Gum,
    /// A void (the dark mouth behind and between teeth): transparent.
    Void,
}

/// Settings of [`teeth_texture`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TeethOptions {
    /// Texture size (texels, square; the teeth use its lower part, as their UVs do).
    pub size: usize,
    /// Luminance the teeth are equalised to (linear; §4.2's "predefined value"): 0.55, a
    /// tooth's albedo in linear light is about 0.5–0.6 (authored: lightness L* ≈ 75–80, the range
    /// of common tooth shade guides, is a linear luminance of 0.48–0.57).
    pub target_luminance: f32,
    /// Half-width of the photographed front teeth on the model (mm): up to the canines.
    pub canine_x_mm: f32,
    /// Gum colour, linear RGB (authored: a pink of L* ≈ 55, a* ≈ 25, the look of healthy
    /// attached gingiva; §4.2 only says "some standard gums color").
    pub gum: [f32; 3],
}

impl Default for TeethOptions {
    fn default() -> Self {
        Self {
            size: 1024,
            target_luminance: 0.55,
            canine_x_mm: 17.0,
            gum: [0.42, 0.16, 0.16],
        }
    }
}

/// A summary.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct TeethReport {
    /// Colour distance below which a pixel is a void.
    pub void_threshold: f32,
    /// Chromatic distance to red below which a pixel is gum.
    pub gum_threshold: f32,
    /// Shares of tooth, gum and void pixels.
    pub shares: [f64; 3],
    /// The equalisation target (linear RGB).
    pub target: [f32; 3],
    /// Stripe averages before equalisation.
    pub stripes_before: Vec<[f32; 3]>,
    /// Bounding box of the teeth in the photo (x0, y0, x1, y1).
    pub bbox: [usize; 4],
    /// Row of the gap between upper and lower teeth.
    pub gap_row: usize,
}

/// A teeth texture: RGBA (alpha 0 on voids) in the teeth meshes' UVs.
pub struct TeethTexture {
    /// Linear RGB.
    pub rgb: RgbImage,
    /// Alpha per texel.
    pub alpha: Vec<f32>,
    /// The equalised photo (linear RGB) and its labels.
    pub equalised: RgbImage,
    /// Pixel labels.
    pub labels: Vec<Label>,
    /// The summary.
    pub report: TeethReport,
}

/// The threshold at the biggest jump of the distances: sorted, the largest step between
/// neighbours (the empty stretch of the histogram between the near-target class and the rest),
/// looked for between the 1st and 90th percentiles, the threshold in its middle.
pub fn biggest_jump_threshold(d: &[f32]) -> f32 {
    let mut s: Vec<f32> = d.iter().copied().filter(|v| v.is_finite()).collect();
    if s.len() < 2 {
        return 0.0;
    }
    s.sort_by(f32::total_cmp);
    let (a, b) = (
        s.len() / 100,
        (s.len() * 9 / 10).max(s.len() / 100 + 1).min(s.len() - 1),
    );
    let mut best = (f32::NEG_INFINITY, a);
    for i in a..b {
        let gap = s[i + 1] - s[i];
        if gap > best.0 {
            best = (gap, i);
        }
    }
    0.5 * (s[best.1] + s[best.1 + 1])
}

/// A pixel too red to be a tooth whatever the histogram says: red chromaticity above 0.45
/// (authored, between the synthetic smile's teeth at 0.37 and its gums and lips at 0.60–0.65).
fn too_red(d_red: f32) -> bool {
    // d_red < 0.62 ⇔ roughly r/(r+g+b) > 0.45 for skin-like g ≈ b.
    d_red < 0.62
}

fn chroma(c: [f32; 3]) -> [f32; 3] {
    let s = (c[0] + c[1] + c[2]).max(1e-6);
    c.map(|v| v / s)
}

/// Labels each pixel (§4.2).
pub fn label(img: &RgbImage) -> (Vec<Label>, f32, f32) {
    let d_black: Vec<f32> = img
        .data
        .iter()
        .map(|c| (c[0] * c[0] + c[1] * c[1] + c[2] * c[2]).sqrt())
        .collect();
    let void_t = biggest_jump_threshold(&d_black);
    let d_red: Vec<f32> = img
        .data
        .iter()
        .map(|c| {
            let q = chroma(*c);
            ((q[0] - 1.0).powi(2) + q[1].powi(2) + q[2].powi(2)).sqrt()
        })
        .collect();
    // Gum threshold among the non-void pixels only.
    let nonvoid: Vec<f32> = d_red
        .iter()
        .zip(&d_black)
        .filter(|(_, b)| **b >= void_t)
        .map(|(r, _)| *r)
        .collect();
    let gum_t = biggest_jump_threshold(&nonvoid);
    let labels = d_black
        .iter()
        .zip(&d_red)
        .map(|(&b, &r)| {
            if b < void_t {
                Label::Void
            } else if r < gum_t || too_red(r) {
                Label::Gum
            } else {
                Label::Tooth
            }
        })
        .collect();
    (labels, void_t, gum_t)
}

/// How much brighter (median luminance) the pixels taken for teeth must be than the rest (gum,
/// lips, the mouth's dark interior) for a photo to be taken for one of teeth: enamel is the
/// brightest thing in a smile; on skin or a texture the classes differ little. Authored: a
/// real skin crop (shared/data) measured 1.22 and a derma base colour 1.06, both refused; the
/// synthetic smiles of the tests pass; no real smile photo was measured.
pub const MIN_TEETH_CONTRAST: f32 = 1.5;

/// Refuses a photo whose "tooth" pixels are not brighter than the rest (not a photo of teeth).
fn check_teeth(img: &RgbImage, labels: &[Label]) -> Result<()> {
    let median = |want: bool| {
        let mut v: Vec<f32> = img
            .data
            .iter()
            .zip(labels)
            .filter(|(_, l)| (**l == Label::Tooth) == want)
            .map(|(c, _)| 0.2126 * c[0] + 0.7152 * c[1] + 0.0722 * c[2])
            .collect();
        v.sort_by(f32::total_cmp);
        v.get(v.len() / 2).copied().unwrap_or(0.0)
    };
    let contrast = median(true) / median(false).max(1e-4);
    if contrast < MIN_TEETH_CONTRAST {
        return Err(PhotoError::Invalid(derma_core::Invalid::new(
            "teeth photo",
            format!(
                "a photo of a smile, cropped to the mouth (teeth against gums and the mouth: at least {MIN_TEETH_CONTRAST}× as bright as the rest)"
            ),
            format!(
                "no teeth found: the pixels taken for teeth are {contrast:.2}× as bright as the rest"
            ),
        )));
    }
    Ok(())
}

/// Runs §4.2 on a photo of the subject's teeth (linear RGB), mapping the result onto the teeth
/// meshes `upper` and `lower` (derma-head's, or any with the same convention: mm, +Y up, +Z
/// forward, front teeth at x ≈ 0).
pub fn teeth_texture(
    img: &RgbImage,
    upper: &TriMesh,
    lower: &TriMesh,
    opts: &TeethOptions,
) -> Result<TeethTexture> {
    if img.width < 24 || img.height < 12 {
        return Err(PhotoError::Invalid(derma_core::Invalid::new(
            "teeth photo",
            "at least 24×12 pixels",
            format!("{}×{} pixels", img.width, img.height),
        )));
    }
    let (labels, void_t, gum_t) = label(img);
    let (w, h) = (img.width, img.height);
    let teeth: Vec<usize> = (0..w * h).filter(|&i| labels[i] == Label::Tooth).collect();
    if teeth.len() < 50 {
        return Err(PhotoError::Invalid(derma_core::Invalid::new(
            "teeth photo",
            "a photo of teeth (at least 50 tooth pixels)",
            format!(
                "only {} tooth pixels (thresholds: void {void_t:.3}, gum {gum_t:.3})",
                teeth.len()
            ),
        )));
    }
    check_teeth(img, &labels)?;
    let b = teeth_box(&teeth, &labels, w, h);
    let target = target_colour(img, &teeth, opts.target_luminance);
    let stripes = stripe_means(img, &teeth, &b, target);
    let eq = equalise(img, &labels, &b, &stripes, target, opts.gum);
    // Composite: the generic texture (target colour, shaded toward the back of the arch), the
    // photo's front teeth mapped orthographically onto the front of each arch.
    let size = opts.size;
    let mut rgb = RgbImage::filled(size, size, target);
    let mut alpha = vec![1.0f32; size * size];
    let front = Front {
        eq: &eq,
        labels: &labels,
        b: &b,
    };
    for (mesh, is_upper) in [(upper, true), (lower, false)] {
        composite(mesh, is_upper, &front, target, opts, (&mut rgb, &mut alpha))?;
    }
    let n = (w * h) as f64;
    let count = |l: Label| labels.iter().filter(|x| **x == l).count() as f64 / n;
    Ok(TeethTexture {
        rgb,
        alpha,
        equalised: eq,
        report: TeethReport {
            void_threshold: void_t,
            gum_threshold: gum_t,
            shares: [count(Label::Tooth), count(Label::Gum), count(Label::Void)],
            target,
            stripes_before: stripes,
            bbox: [b.x0, b.y0, b.x1, b.y1],
            gap_row: b.gap_row,
        },
        labels,
    })
}

/// Where the teeth are in the photo: their bounding box (pixels, inclusive) and the row of the
/// gap between upper and lower teeth.
struct TeethBox {
    x0: usize,
    y0: usize,
    x1: usize,
    y1: usize,
    gap_row: usize,
}

impl TeethBox {
    /// The width of each of the six stripes over the box (pixels).
    fn stripe_w(&self) -> f32 {
        (self.x1 - self.x0 + 1) as f32 / 6.0
    }
}

/// The box of the tooth pixels `teeth` (indices into a `w` × `h` photo) and the gap: the row
/// inside the box with the fewest tooth pixels in its middle half.
fn teeth_box(teeth: &[usize], labels: &[Label], w: usize, h: usize) -> TeethBox {
    let (mut x0, mut y0, mut x1, mut y1) = (w, h, 0, 0);
    for &i in teeth {
        let (x, y) = (i % w, i / w);
        x0 = x0.min(x);
        x1 = x1.max(x);
        y0 = y0.min(y);
        y1 = y1.max(y);
    }
    // The gap: the row inside the box with the fewest tooth pixels in its middle half.
    let mid = (x0 + 3 * (x1 - x0) / 8)..(x0 + 5 * (x1 - x0) / 8 + 1);
    let gap_row = (y0 + (y1 - y0) / 4..=y0 + 3 * (y1 - y0) / 4)
        .min_by_key(|&y| {
            (
                mid.clone()
                    .filter(|&x| labels[y * w + x] == Label::Tooth)
                    .count(),
                (y as i64 - ((y0 + y1) / 2) as i64).abs(),
            )
        })
        .unwrap_or((y0 + y1) / 2);
    TeethBox {
        x0,
        y0,
        x1,
        y1,
        gap_row,
    }
}

/// The equalisation target: the teeth's mean colour with its luminance set to `target_luminance`.
fn target_colour(img: &RgbImage, teeth: &[usize], target_luminance: f32) -> [f32; 3] {
    let mut mean = [0.0f32; 3];
    for &i in teeth {
        for k in 0..3 {
            mean[k] += img.data[i][k] / teeth.len() as f32;
        }
    }
    let s = target_luminance / luminance(mean).max(1e-6);
    mean.map(|v| v * s)
}

/// The teeth's mean colour in each of six stripes over the box (the target where a stripe
/// holds no tooth pixel).
fn stripe_means(img: &RgbImage, teeth: &[usize], b: &TeethBox, target: [f32; 3]) -> Vec<[f32; 3]> {
    let (w, stripe_w) = (img.width, b.stripe_w());
    let mut stripes = vec![[0.0f32; 3]; 6];
    let mut counts = [0usize; 6];
    for &i in teeth {
        let k = (((i % w - b.x0) as f32 / stripe_w) as usize).min(5);
        for c in 0..3 {
            stripes[k][c] += img.data[i][c];
        }
        counts[k] += 1;
    }
    for k in 0..6 {
        if counts[k] > 0 {
            stripes[k] = stripes[k].map(|v| v / counts[k] as f32);
        } else {
            stripes[k] = target;
        }
    }
    stripes
}

/// The equalised photo: each tooth pixel corrected by (target − stripe mean), interpolated
/// linearly between stripe centres column by column; gums set to `gum`, voids to blue.
fn equalise(
    img: &RgbImage,
    labels: &[Label],
    b: &TeethBox,
    stripes: &[[f32; 3]],
    target: [f32; 3],
    gum: [f32; 3],
) -> RgbImage {
    let (w, x0, stripe_w) = (img.width, b.x0, b.stripe_w());
    let correction = |x: usize| -> [f32; 3] {
        let f = ((x as f32 - x0 as f32) / stripe_w - 0.5).clamp(0.0, 5.0);
        let (k, t) = ((f as usize).min(4), f - (f as usize).min(4) as f32);
        std::array::from_fn(|c| {
            (target[c] - stripes[k][c]) * (1.0 - t) + (target[c] - stripes[k + 1][c]) * t
        })
    };
    let mut eq = img.clone();
    for (i, p) in eq.data.iter_mut().enumerate() {
        match labels[i] {
            Label::Tooth => {
                let corr = correction(i % w);
                for c in 0..3 {
                    p[c] = (p[c] + corr[c]).max(0.0);
                }
            }
            Label::Gum => *p = gum,
            Label::Void => *p = [0.0, 0.0, 1.0],
        }
    }
    eq
}

/// The photo's front teeth as composited: the equalised photo, its labels and the teeth's box.
struct Front<'a> {
    eq: &'a RgbImage,
    labels: &'a [Label],
    b: &'a TeethBox,
}

impl Front<'_> {
    /// Per photo column, how many rows from the gap row outward (up for the upper arch, down
    /// for the lower) the teeth and the voids between them run before the lips or gums (two
    /// gum rows in a row end it: one is a speck of the labelling).
    fn visible_runs(&self, is_upper: bool) -> Vec<usize> {
        let (w, h, g) = (self.eq.width, self.eq.height, self.b.gap_row);
        let row = |n: usize| {
            if is_upper {
                g.checked_sub(n)
            } else {
                Some(g + n)
            }
        };
        let gum = |x: usize, n: usize| match row(n) {
            Some(y) if y < h => self.labels[y * w + x] == Label::Gum,
            _ => true,
        };
        (0..w)
            .map(|x| {
                let mut n = 0;
                while !(gum(x, n + 1) && gum(x, n + 2)) {
                    n += 1;
                }
                n
            })
            .collect()
    }
}

/// Rows of teeth a photo column must show for the arch to take it (fewer: the lips cover that
/// arch there, and the generic texture is drawn).
const MIN_RUN: usize = 3;

/// The photo pixel (column, row) that a point of an arch's front shows: `across` ∈ [0, 1] over
/// the teeth's box, `from_edge_mm` from the incisal edge toward the gum line. The rows keep the
/// photo's own scale (`px_per_mm`, from the box's width over the front teeth), so the teeth keep
/// their proportions; past the column's `runs` (where the lips hid the rest of the tooth) the
/// row 2 px inside the visible end continues it — §4.2: the teeth are expanded into what the
/// lips covered. `None` where the column shows none of this arch's teeth.
fn photo_pixel(
    b: &TeethBox,
    runs: &[usize],
    is_upper: bool,
    across: f32,
    from_edge_mm: f32,
    px_per_mm: f32,
) -> Option<(usize, usize)> {
    let x = (b.x0 as f32 + across * (b.x1 - b.x0) as f32).round() as usize;
    let x = x.min(runs.len() - 1);
    if runs[x] < MIN_RUN {
        return None;
    }
    let reach = (runs[x] - 2) as f32;
    let off = (from_edge_mm * px_per_mm).min(reach).round() as usize;
    let y = if is_upper {
        b.gap_row.saturating_sub(off)
    } else {
        b.gap_row + off
    };
    Some((x, y))
}

/// One arch composited into the texture (`rgb`, `alpha`): the generic colour (`target`, shaded
/// toward the back of the arch), the photo's front teeth mapped orthographically onto its front
/// and faded out at the canines; voids transparent.
fn composite(
    mesh: &TriMesh,
    is_upper: bool,
    front: &Front,
    target: [f32; 3],
    opts: &TeethOptions,
    (rgb, alpha): (&mut RgbImage, &mut [f32]),
) -> Result<()> {
    if mesh.uvs.len() != mesh.positions.len() {
        return Err(PhotoError::Mesh("a teeth mesh has no UVs".into()));
    }
    let (size, b) = (opts.size, front.b);
    let (w, h) = (front.eq.width, front.eq.height);
    let (lo, hi) = mesh.bounds();
    let raster = UvRaster::new(mesh, size, size);
    let runs = front.visible_runs(is_upper);
    let px_per_mm = (b.x1 - b.x0) as f32 / (2.0 * (opts.canine_x_mm + 2.0));
    // Front teeth's vertical extent: incisal edge to the gum line (the arch's other end).
    for i in 0..size * size {
        if !raster.covered(i) {
            continue;
        }
        let p = raster.position(mesh, i);
        let depth = ((hi.z - p.z) / (hi.z - lo.z).max(1e-6)).clamp(0.0, 1.0);
        let generic = target.map(|v| v * (1.0 - 0.45 * depth));
        let xf = p.x.abs();
        let wf = 1.0 - smooth(opts.canine_x_mm - 2.0, opts.canine_x_mm + 2.0, xf);
        let mut c = generic;
        let mut a = 1.0;
        if wf > 0.0 && p.z > hi.z - 12.0 {
            // Photo coordinates: x across the box, y from the gap (incisal edges) outward.
            let u = (p.x / (opts.canine_x_mm + 2.0) * 0.5 + 0.5).clamp(0.0, 1.0);
            let edge = if is_upper { lo.y } else { hi.y };
            let at = photo_pixel(b, &runs, is_upper, u, (p.y - edge).abs(), px_per_mm);
            let (pc, pa) = match at.map(|(px, py)| py.min(h - 1) * w + px.min(w - 1)) {
                Some(j) if front.labels[j] == Label::Void => (generic, 0.0),
                Some(j) if front.labels[j] == Label::Tooth => (front.eq.data[j], 1.0),
                _ => (generic, 1.0),
            };
            c = std::array::from_fn(|k| pc[k] * wf + generic[k] * (1.0 - wf));
            a = pa * wf + (1.0 - wf);
        }
        rgb.data[i] = c;
        alpha[i] = a;
    }
    Ok(())
}

fn smooth(a: f32, b: f32, x: f32) -> f32 {
    let t = ((x - a) / (b - a)).clamp(0.0, 1.0);
    t * t * (3.0 - 2.0 * t)
}

/// A synthetic smile for tests and examples: a dark mouth, gums, six upper and six lower teeth
/// with dark gaps between them, lips around, lit unevenly (brighter on the left). Returns the
/// image and the true label of each pixel.
pub fn synthetic_smile(width: usize, height: usize) -> (RgbImage, Vec<Label>) {
    let mut data = vec![[0.0f32; 3]; width * height];
    let mut labels = vec![Label::Void; width * height];
    let (cx, cy) = (width as f32 / 2.0, height as f32 / 2.0);
    for y in 0..height {
        for x in 0..width {
            let (fx, fy) = (
                (x as f32 + 0.5 - cx) / (0.45 * width as f32),
                (y as f32 + 0.5 - cy) / (0.4 * height as f32),
            );
            let light = 1.25 - 0.5 * (x as f32 / width as f32);
            let r = fx * fx + fy * fy;
            let (c, l) = if r > 1.0 {
                ([0.45, 0.12, 0.12], Label::Gum) // lips
            } else if fy.abs() < 0.06 {
                ([0.015, 0.01, 0.01], Label::Void) // the gap
            } else if fy.abs() > 0.75 {
                ([0.4, 0.13, 0.14], Label::Gum) // gums
            } else {
                let tooth = ((fx + 1.0) * 6.0).fract();
                if !(0.06..=0.94).contains(&tooth) || fx.abs() > 0.95 {
                    ([0.02, 0.015, 0.015], Label::Void)
                } else {
                    ([0.62, 0.58, 0.48], Label::Tooth)
                }
            };
            data[y * width + x] = c.map(|v| v * light);
            labels[y * width + x] = l;
        }
    }
    (
        RgbImage {
            width,
            height,
            data,
        },
        labels,
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_teeth_keep_the_photos_scale_and_continue_under_the_lips() {
        let b = TeethBox {
            x0: 10,
            y0: 5,
            x1: 110,
            y1: 75,
            gap_row: 40,
        };
        // Column 60's upper tooth shows for 12 rows above the gap before the lip, the lower
        // for 30.
        let mut runs = vec![30usize; 120];
        runs[60] = 12;
        // 3 px a millimetre: 2 mm from the incisal edge is 6 rows from the gap, either arch.
        assert_eq!(photo_pixel(&b, &runs, true, 0.5, 2.0, 3.0), Some((60, 34)));
        assert_eq!(
            photo_pixel(&b, &[30; 120], false, 0.5, 2.0, 3.0),
            Some((60, 46))
        );
        // 8 mm up (24 rows) is under the lip: the row 2 px inside the visible end continues
        // the tooth, where stretching the visible 12 rows over the crown would have drawn the
        // whole tooth twice as tall.
        assert_eq!(photo_pixel(&b, &runs, true, 0.5, 8.0, 3.0), Some((60, 30)));
        // Where the whole crown shows, it is read at scale.
        assert_eq!(photo_pixel(&b, &runs, true, 0.2, 8.0, 3.0), Some((30, 16)));
        // A column where the lips cover the arch: the generic texture.
        runs[40] = 2;
        assert_eq!(photo_pixel(&b, &runs, true, 0.3, 1.0, 3.0), None);
    }

    #[test]
    fn the_visible_runs_end_at_the_lips() {
        let (img, _) = synthetic_smile(240, 120);
        let (labels, _, _) = label(&img);
        let teeth: Vec<usize> = (0..labels.len())
            .filter(|&i| labels[i] == Label::Tooth)
            .collect();
        let b = teeth_box(&teeth, &labels, 240, 120);
        let eq = img.clone();
        let front = Front {
            eq: &eq,
            labels: &labels,
            b: &b,
        };
        let (up, down) = (front.visible_runs(true), front.visible_runs(false));
        // Mid-mouth the teeth run to the gums (fy 0.75 of the 0.4-height ellipse: 36 rows from
        // the centre); toward the corners the lips' ellipse cuts them shorter.
        assert!(
            (30..=40).contains(&up[120]) && (30..=40).contains(&down[120]),
            "{} {}",
            up[120],
            down[120]
        );
        assert!(
            up[30] < up[120] && down[30] < down[120],
            "{} {}",
            up[30],
            down[30]
        );
    }

    #[test]
    fn labels_match_the_synthetic_smile() {
        let (img, truth) = synthetic_smile(240, 120);
        let (l, _, _) = label(&img);
        let agree = l.iter().zip(&truth).filter(|(a, b)| a == b).count() as f64 / l.len() as f64;
        assert!(agree > 0.97, "agreement {agree}");
    }

    #[test]
    fn equalisation_evens_out_the_stripes() {
        let (img, _) = synthetic_smile(240, 120);
        let head = derma_head::Head::builtin();
        let (u, lo) = (
            &head.part("teeth_upper").unwrap().mesh,
            &head.part("teeth_lower").unwrap().mesh,
        );
        let t = teeth_texture(
            &img,
            u,
            lo,
            &TeethOptions {
                size: 256,
                ..Default::default()
            },
        )
        .unwrap();
        // Before: the left stripe is much brighter than the right (uneven light).
        let sb = &t.report.stripes_before;
        assert!(luminance(sb[0]) > 1.3 * luminance(sb[5]));
        // After: every stripe's mean tooth luminance is within 5 % of the target.
        let (x0, x1) = (t.report.bbox[0], t.report.bbox[2]);
        let sw = (x1 - x0 + 1) as f32 / 6.0;
        for k in 0..6 {
            let px: Vec<[f32; 3]> = (0..img.width * img.height)
                .filter(|&i| {
                    t.labels[i] == Label::Tooth
                        && (((i % img.width - x0) as f32 / sw) as usize).min(5) == k
                })
                .map(|i| t.equalised.data[i])
                .collect();
            let m: f32 = px.iter().map(|c| luminance(*c)).sum::<f32>() / px.len() as f32;
            assert!((m / 0.55 - 1.0).abs() < 0.05, "stripe {k}: {m}");
        }
        // Voids became transparent somewhere on the front teeth, and the rest is opaque.
        assert!(t.alpha.iter().any(|a| *a < 0.5));
        assert!(t.alpha.iter().filter(|a| **a >= 0.99).count() > t.alpha.len() / 2);
    }

    #[test]
    fn a_photo_without_teeth_is_refused() {
        let img = RgbImage::filled(64, 32, [0.4, 0.12, 0.12]);
        let head = derma_head::Head::builtin();
        let (u, lo) = (
            &head.part("teeth_upper").unwrap().mesh,
            &head.part("teeth_lower").unwrap().mesh,
        );
        let e = teeth_texture(&img, u, lo, &TeethOptions::default())
            .err()
            .unwrap()
            .to_string();
        assert!(e.contains("tooth pixels"), "{e}");
    }
}

//! The two bands the E-step treats apart: each exemplar's low band (a box mean) and high band
//! (the rest), after Burt & Adelson's multiresolution spline (ACM TOG 2(4), 1983, §2–3).
//!
//! Burt & Adelson join two images without a visible seam or a blurred one by blending each band
//! over a transition as wide as its wavelength: low frequencies over a wide one, fine detail
//! over a narrow one. The E-step (`crate::optimize`) does the same with two bands: it blends the
//! low band of the overlapping windows' matches, whose transitions then span the windows'
//! overlap, and takes the high band from one window, so the grain is never averaged.

/// Radius ρ of the low band's box for windows of side `w`: ⌊w/4⌋, at least 1, so the box
/// (2ρ + 1 texels a side, w/2 + 1 for the passes' sides, cut off at the exemplar's edges) spans
/// the windows' overlap of w/2. Shading broader than the overlap is blended
/// across it; detail that fits inside it comes whole from one window.
pub(crate) fn radius(w: usize) -> usize {
    (w / 4).max(1)
}

/// The low band of a `width × height` texture of `c` interleaved channels: each texel the mean
/// of the texels of the (2ρ + 1)² box around it that lie inside (summed in f64 in a fixed
/// order, so the bits do not depend on anything but the input).
pub(crate) fn low_band(
    data: &[f32],
    width: usize,
    height: usize,
    c: usize,
    rho: usize,
) -> Vec<f32> {
    // Each box summed directly (exemplars are small), not by running totals, whose rounding
    // would depend on the position.
    let mut out = vec![0f32; data.len()];
    for y in 0..height {
        let (y0, y1) = (y.saturating_sub(rho), (y + rho).min(height - 1));
        for x in 0..width {
            let (x0, x1) = (x.saturating_sub(rho), (x + rho).min(width - 1));
            let n = ((y1 - y0 + 1) * (x1 - x0 + 1)) as f64;
            for k in 0..c {
                let mut s = 0f64;
                for yy in y0..=y1 {
                    for xx in x0..=x1 {
                        s += data[(yy * width + xx) * c + k] as f64;
                    }
                }
                out[(y * width + x) * c + k] = (s / n) as f32;
            }
        }
    }
    out
}

/// Both bands of every exemplar of a set for windows of side `w`: (low, high) per exemplar, with
/// high = value − low in f32.
pub(crate) fn bands(set: &crate::exemplar::ExemplarSet, w: usize) -> Vec<(Vec<f32>, Vec<f32>)> {
    let rho = radius(w);
    set.exemplars
        .iter()
        .map(|e| {
            let t = &e.texture;
            let low = low_band(&t.data, t.width, t.height, t.channels, rho);
            let high = t.data.iter().zip(&low).map(|(v, l)| v - l).collect();
            (low, high)
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_low_band_is_the_box_mean_inside_the_texture() {
        // 4 × 3, two channels: channel 0 = x + 10 y, channel 1 = 1.
        let (w, h) = (4, 3);
        let data: Vec<f32> = (0..w * h)
            .flat_map(|t| [(t % w + 10 * (t / w)) as f32, 1.0])
            .collect();
        let low = low_band(&data, w, h, 2, 1);
        // Corner (0, 0): the box holds x ∈ {0, 1}, y ∈ {0, 1}: mean of 0, 1, 10, 11.
        assert_eq!(low[0], 5.5);
        // Interior (1, 1): the full 3 × 3 box, mean of a linear ramp = its centre value.
        assert_eq!(low[(w + 1) * 2], 11.0);
        // Edge (3, 2): x ∈ {2, 3}, y ∈ {1, 2}: mean of 12, 13, 22, 23.
        assert_eq!(low[(2 * w + 3) * 2], 17.5);
        assert!(low.iter().skip(1).step_by(2).all(|&v| v == 1.0));
        assert_eq!(radius(32), 8);
        assert_eq!(radius(8), 2);
        assert_eq!(radius(2), 1);
    }
}

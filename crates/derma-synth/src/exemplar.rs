//! Exemplars as the search sees them: each channel quantised to 8 bits over the exemplar set's
//! range, so the L2 distance of Shen et al. §3.2, eq. 1 is an exact integer on CPU and GPU alike.

use crate::error::{invalid, Result};
use crate::texture::Texture;

/// Per-channel affine map from the exemplar set's values to 0..=255 (and back). One quantiser
/// serves every exemplar of a set, so distances between regions drawn from different exemplars
/// stay comparable.
#[derive(Clone, Debug, PartialEq)]
pub struct Quantizer {
    /// Value of code 0 per channel.
    pub lo: Vec<f32>,
    /// Value of code 255 per channel.
    pub hi: Vec<f32>,
}

impl Quantizer {
    /// The range of each channel over all textures.
    pub fn fit(textures: &[&Texture]) -> Self {
        let c = textures[0].channels;
        let mut lo = vec![f32::INFINITY; c];
        let mut hi = vec![f32::NEG_INFINITY; c];
        for t in textures {
            for px in t.data.chunks_exact(c) {
                for k in 0..c {
                    lo[k] = lo[k].min(px[k]);
                    hi[k] = hi[k].max(px[k]);
                }
            }
        }
        Self { lo, hi }
    }

    #[inline]
    /// Code of value `v` of channel `k`.
    pub fn quantize(&self, k: usize, v: f32) -> u8 {
        let span = self.hi[k] - self.lo[k];
        if span <= 0.0 {
            return 0;
        }
        ((v - self.lo[k]) / span * 255.0).round().clamp(0.0, 255.0) as u8
    }

    #[inline]
    /// Value of (fractional) code `q` of channel `k`.
    pub fn dequantize(&self, k: usize, q: f32) -> f32 {
        self.lo[k] + q / 255.0 * (self.hi[k] - self.lo[k])
    }

    /// The code boundaries of channel `k` as [`order_key`]s: entry `j` (1 ≤ j ≤ 255) is the key
    /// of the least value whose code is at least `j` (`u32::MAX` where no value reaches it), so
    /// a value's code is the number of boundaries at or below its key. How the GPU reproduces
    /// [`Quantizer::quantize`] bit for bit with integer comparisons alone (its division is not
    /// correctly rounded). Entry 0 is unused.
    pub fn boundaries(&self, k: usize) -> [u32; 256] {
        // `quantize` is monotone in v (each step of it is), so each boundary is found by
        // bisection over the keys of the finite values.
        let (lo_key, hi_key) = (order_key(f32::MIN), order_key(f32::MAX));
        let mut out = [u32::MAX; 256];
        for (j, b) in out.iter_mut().enumerate().skip(1) {
            if self.quantize(k, f32::MAX) < j as u8 {
                continue;
            }
            let (mut a, mut z) = (lo_key, hi_key);
            while a < z {
                let mid = a + (z - a) / 2;
                if self.quantize(k, from_order_key(mid)) >= j as u8 {
                    z = mid;
                } else {
                    a = mid + 1;
                }
            }
            *b = a;
        }
        out
    }

    /// Codes of interleaved texels `data` into `out`.
    pub fn quantize_all(&self, data: &[f32], out: &mut [u8]) {
        let c = self.lo.len();
        for (i, (o, &v)) in out.iter_mut().zip(data).enumerate() {
            *o = self.quantize(i % c, v);
        }
    }
}

/// A key of `v` whose unsigned order is the order of the values (−0 just below +0): the bits
/// with the sign flipped for positive values and all bits flipped for negative ones.
pub fn order_key(v: f32) -> u32 {
    let b = v.to_bits();
    if b >> 31 == 1 {
        !b
    } else {
        b | 1 << 31
    }
}

/// The value of an [`order_key`].
pub fn from_order_key(key: u32) -> f32 {
    f32::from_bits(if key >> 31 == 1 {
        key & !(1 << 31)
    } else {
        !key
    })
}

/// One exemplar: its values (copied into the output) and their 8-bit codes (searched).
#[derive(Clone, Debug)]
pub struct Exemplar {
    /// The values.
    pub texture: Texture,
    /// 8-bit codes of the values, interleaved like them.
    pub codes: Vec<u8>,
}

impl Exemplar {
    /// Width in texels.
    pub fn width(&self) -> usize {
        self.texture.width
    }
    /// Height in texels.
    pub fn height(&self) -> usize {
        self.texture.height
    }
    /// Channels per texel.
    pub fn channels(&self) -> usize {
        self.texture.channels
    }

    /// Candidate window positions for a window of side `w`: (columns, rows).
    pub fn candidates(&self, w: usize) -> (usize, usize) {
        (self.width() + 1 - w, self.height() + 1 - w)
    }

    /// Sums of each channel's codes over every `b × b` block: plane `c` holds
    /// `(width − b + 1) × (height − b + 1)` values (exact integers in f32 for b ≤ 256).
    pub fn block_sums(&self, b: usize) -> Vec<Vec<f32>> {
        let (w, h, c) = (self.width(), self.height(), self.channels());
        let (pw, ph) = (w + 1 - b, h + 1 - b);
        (0..c)
            .map(|k| {
                // Horizontal running sums, then vertical ones, in integers.
                let mut horiz = vec![0u32; pw * h];
                for y in 0..h {
                    let row = &self.codes[y * w * c..(y + 1) * w * c];
                    let mut s: u32 = (0..b).map(|x| row[x * c + k] as u32).sum();
                    horiz[y * pw] = s;
                    for x in 1..pw {
                        s = s + row[(x + b - 1) * c + k] as u32 - row[(x - 1) * c + k] as u32;
                        horiz[y * pw + x] = s;
                    }
                }
                let mut out = vec![0f32; pw * ph];
                for x in 0..pw {
                    let mut s: u32 = (0..b).map(|y| horiz[y * pw + x]).sum();
                    out[x] = s as f32;
                    for y in 1..ph {
                        s = s + horiz[(y + b - 1) * pw + x] - horiz[(y - 1) * pw + x];
                        out[y * pw + x] = s as f32;
                    }
                }
                out
            })
            .collect()
    }
}

/// The exemplars one synthesis draws from (one, or several chosen by a guide), sharing a
/// channel layout and a quantiser.
#[derive(Clone, Debug)]
pub struct ExemplarSet {
    /// The exemplars.
    pub exemplars: Vec<Exemplar>,
    /// The quantiser they share.
    pub quantizer: Quantizer,
}

impl ExemplarSet {
    /// Checks the exemplars agree in channels, hold finite values and are large enough for
    /// patches of side `patch` (see [`ExemplarSet::check_patch`]).
    pub fn new(textures: Vec<Texture>, patch: usize) -> Result<Self> {
        let first = textures
            .first()
            .ok_or_else(|| invalid("exemplars", "none given"))?;
        let c = first.channels;
        for (i, t) in textures.iter().enumerate() {
            if t.channels != c {
                return Err(invalid(
                    format!("exemplar {}", i + 1),
                    format!("has {} channels, the first has {c}", t.channels),
                ));
            }
            check_size(i, t.width, t.height, patch)?;
            if let Some(j) = t.data.iter().position(|v| !v.is_finite()) {
                return Err(invalid(
                    format!("exemplar {}", i + 1),
                    format!(
                        "texel ({}, {}) holds a non-finite value",
                        (j / c) % t.width,
                        (j / c) / t.width
                    ),
                ));
            }
        }
        let quantizer = Quantizer::fit(&textures.iter().collect::<Vec<_>>());
        let exemplars = textures
            .into_iter()
            .map(|texture| {
                let mut codes = vec![0u8; texture.data.len()];
                quantizer.quantize_all(&texture.data, &mut codes);
                Exemplar { texture, codes }
            })
            .collect();
        Ok(Self {
            exemplars,
            quantizer,
        })
    }

    /// Channels per texel (the same for every exemplar).
    pub fn channels(&self) -> usize {
        self.exemplars[0].channels()
    }

    /// Mean and variance of each channel's codes over all exemplars.
    pub fn code_stats(&self) -> Vec<(f64, f64)> {
        let c = self.channels();
        let mut sum = vec![0f64; c];
        let mut sq = vec![0f64; c];
        let mut n = 0f64;
        for e in &self.exemplars {
            for px in e.codes.chunks_exact(c) {
                for k in 0..c {
                    sum[k] += px[k] as f64;
                    sq[k] += (px[k] as f64).powi(2);
                }
            }
            n += (e.width() * e.height()) as f64;
        }
        (0..c)
            .map(|k| {
                let mean = sum[k] / n;
                (mean, (sq[k] / n - mean * mean).max(0.0))
            })
            .collect()
    }

    /// Checks every exemplar is large enough for patches of side `patch`.
    pub fn check_patch(&self, patch: usize) -> Result<()> {
        for (i, e) in self.exemplars.iter().enumerate() {
            check_size(i, e.width(), e.height(), patch)?;
        }
        Ok(())
    }
}

/// Exemplar `i` (0-based) must be at least twice the patch on each side, so the search has a
/// real choice: (side − patch + 1)² ≥ (patch + 1)² candidate positions.
fn check_size(i: usize, width: usize, height: usize, patch: usize) -> Result<()> {
    if width < 2 * patch || height < 2 * patch {
        return Err(invalid(
            format!("exemplar {}", i + 1),
            format!(
                "is {width}×{height}, too small for {patch}×{patch} patches: it must be at least \
                 {0}×{0} (or choose a smaller patch)",
                2 * patch
            ),
        ));
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn ramp(w: usize, h: usize, c: usize) -> Texture {
        let data = (0..w * h * c)
            .map(|i| ((i * 37) % 101) as f32 / 100.0)
            .collect();
        Texture::new(w, h, c, data).unwrap()
    }

    #[test]
    fn block_sums_match_direct_sums() {
        let set = ExemplarSet::new(vec![ramp(20, 17, 2)], 4).unwrap();
        let e = &set.exemplars[0];
        let b = 3;
        let sums = e.block_sums(b);
        let pw = 20 + 1 - b;
        for (k, plane) in sums.iter().enumerate() {
            for (y, x) in [(0, 0), (5, 7), (14, 17)] {
                let direct: u32 = (0..b)
                    .flat_map(|dy| (0..b).map(move |dx| (dx, dy)))
                    .map(|(dx, dy)| e.codes[((y + dy) * 20 + x + dx) * 2 + k] as u32)
                    .sum();
                assert_eq!(plane[y * pw + x], direct as f32);
            }
        }
    }

    #[test]
    fn order_keys_sort_like_the_values() {
        let vals = [
            f32::MIN,
            -1.0,
            -1e-38,
            -1e-45,
            -0.0,
            0.0,
            1e-45,
            1e-38,
            0.5,
            1.0,
            f32::MAX,
        ];
        for pair in vals.windows(2) {
            assert!(order_key(pair[0]) < order_key(pair[1]), "{pair:?}");
        }
        for v in vals {
            assert_eq!(from_order_key(order_key(v)).to_bits(), v.to_bits());
        }
    }

    #[test]
    fn boundaries_give_the_codes_of_quantize() {
        // Counting the boundaries at or below a value's key is how the GPU's E-step codes its
        // averages; it must agree with `quantize` everywhere, at the boundaries above all.
        let q = Quantizer {
            lo: vec![-0.37, 0.0, 2.0],
            hi: vec![1.91, 1.0, 2.0],
        };
        let rng = derma_core::rng::Philox::new(7, 1);
        for k in 0..3 {
            let b = q.boundaries(k);
            let code = |v: f32| b[1..].iter().filter(|&&t| t <= order_key(v)).count();
            let mut probes: Vec<f32> = (0..20_000u64)
                .map(|i| {
                    let u = rng.u32x4(i);
                    q.lo[0] - 1.0 + (u[0] as f32 / u32::MAX as f32) * 4.0
                })
                .collect();
            for &t in b.iter().skip(1).filter(|&&t| t != u32::MAX) {
                let v = from_order_key(t);
                probes.extend([v, from_order_key(t - 1), from_order_key(t + 1)]);
            }
            probes.extend([f32::MIN, f32::MAX, -0.0, 0.0, 255.0, -255.0]);
            for v in probes {
                assert_eq!(
                    code(v),
                    q.quantize(k, v) as usize,
                    "channel {k}, value {v:e}"
                );
            }
        }
        // A channel of one value: every code 0, no boundary reached.
        assert!(q.boundaries(2)[1..].iter().all(|&t| t == u32::MAX));
    }

    #[test]
    fn quantiser_spans_the_set_and_inverts() {
        let set = ExemplarSet::new(vec![ramp(16, 16, 1)], 8).unwrap();
        let q = &set.quantizer;
        assert_eq!(q.quantize(0, q.lo[0]), 0);
        assert_eq!(q.quantize(0, q.hi[0]), 255);
        let v = 0.37;
        assert!((q.dequantize(0, q.quantize(0, v) as f32) - v).abs() <= 0.5 / 255.0 + 1e-6);
    }

    #[test]
    fn too_small_or_mismatched_exemplars_are_named() {
        let e = ExemplarSet::new(vec![ramp(30, 40, 1)], 16).unwrap_err();
        assert!(
            e.to_string().contains("30×40") && e.to_string().contains("32×32"),
            "{e}"
        );
        let e = ExemplarSet::new(vec![ramp(40, 40, 1), ramp(40, 40, 3)], 16).unwrap_err();
        assert!(e.to_string().contains("exemplar 2"), "{e}");
    }
}

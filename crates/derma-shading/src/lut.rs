//! Regular-grid lookup tables with simplex (Kuhn) interpolation: D+1 table reads per lookup
//! instead of 2^D for multilinear (Kasson, Nin, Plouffe & Hafner 1995, "Performing color space
//! conversions with three-dimensional linear interpolation", J. Electronic Imaging 4).

/// How an axis maps its parameter to grid coordinates.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum AxisScale {
    /// Nodes evenly spaced in the parameter.
    Linear,
    /// Grid uniform in ∛x, dense where colour changes fastest (as Jimenez et al. 2010 §6 do for
    /// melanin and hemoglobin).
    Cbrt,
}

/// ∛x for x ≥ 0 without a libm call: an exponent-halving bit estimate refined by three Newton
/// steps (relative error < 1e-6 over [1e-12, 1e6]; tested against `f32::cbrt`).
#[inline]
pub fn fast_cbrt(x: f32) -> f32 {
    if x <= 0.0 {
        return 0.0;
    }
    // Bit-level estimate: divide the exponent by 3 (Kahan's magic constant for f32).
    let mut y = f32::from_bits(x.to_bits() / 3 + 709_921_077);
    for _ in 0..3 {
        y = y - (y * y * y - x) / (3.0 * y * y);
    }
    y
}

/// One axis of a table: `n` nodes from `min` to `max`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Axis {
    /// Value of the first node.
    pub min: f32,
    /// Value of the last node.
    pub max: f32,
    /// Number of nodes.
    pub n: usize,
    /// How the nodes are spaced.
    pub scale: AxisScale,
}

impl Axis {
    /// `n` nodes evenly spaced from `min` to `max`.
    pub const fn linear(min: f32, max: f32, n: usize) -> Self {
        Self {
            min,
            max,
            n,
            scale: AxisScale::Linear,
        }
    }

    /// `n` nodes evenly spaced in ∛x from `min` to `max`.
    pub const fn cbrt(min: f32, max: f32, n: usize) -> Self {
        Self {
            min,
            max,
            n,
            scale: AxisScale::Cbrt,
        }
    }

    fn warp(&self, x: f32) -> f32 {
        match self.scale {
            AxisScale::Linear => x,
            AxisScale::Cbrt => fast_cbrt(x),
        }
    }
    /// Parameter value at node `i`.
    pub fn node(&self, i: usize) -> f32 {
        let (a, b) = (self.warp(self.min), self.warp(self.max));
        let t = a + (b - a) * i as f32 / (self.n - 1) as f32;
        match self.scale {
            AxisScale::Linear => t,
            AxisScale::Cbrt => t * t * t,
        }
    }
    /// Continuous grid coordinate of `x`, clamped to the axis.
    fn coord(&self, x: f32) -> f32 {
        let (a, b) = (self.warp(self.min), self.warp(self.max));
        let t = (self.warp(x.clamp(self.min, self.max)) - a) / (b - a);
        t * (self.n - 1) as f32
    }
}

/// A D-dimensional table of RGB values.
#[derive(Clone, Debug)]
pub struct GridLut<const D: usize> {
    axes: [Axis; D],
    strides: [usize; D],
    values: Vec<[f32; 3]>,
}

impl<const D: usize> GridLut<D> {
    /// Builds the table by evaluating `f` at every node (in parallel; node order is fixed, so the
    /// table is identical for any thread count).
    pub fn build(axes: [Axis; D], f: impl Fn([f32; D]) -> [f32; 3] + Sync) -> Self {
        use rayon::prelude::*;
        let mut strides = [1usize; D];
        for k in (0..D.saturating_sub(1)).rev() {
            strides[k] = strides[k + 1] * axes[k + 1].n;
        }
        let total = strides[0] * axes[0].n;
        let values = (0..total)
            .into_par_iter()
            .map(|flat| {
                let p: [f32; D] =
                    std::array::from_fn(|k| axes[k].node((flat / strides[k]) % axes[k].n));
                f(p)
            })
            .collect();
        Self {
            axes,
            strides,
            values,
        }
    }

    /// The table's axes.
    pub fn axes(&self) -> &[Axis; D] {
        &self.axes
    }

    /// Simplex-interpolated value at `p` (clamped to the table's range).
    #[inline]
    pub fn lookup(&self, p: [f32; D]) -> [f32; 3] {
        let mut base = 0usize;
        let mut frac = [(0.0f32, 0usize); D];
        for k in 0..D {
            let a = &self.axes[k];
            let c = a.coord(p[k]);
            let i = (c.floor() as usize).min(a.n - 2);
            base += i * self.strides[k];
            frac[k] = (c - i as f32, k);
        }
        // Sort dimensions by decreasing fractional part (insertion sort; D is small).
        for i in 1..D {
            let mut j = i;
            while j > 0 && frac[j - 1].0 < frac[j].0 {
                frac.swap(j - 1, j);
                j -= 1;
            }
        }
        let mut idx = base;
        let v0 = self.values[idx];
        let w0 = 1.0 - frac[0].0;
        let mut out = [v0[0] * w0, v0[1] * w0, v0[2] * w0];
        for j in 0..D {
            idx += self.strides[frac[j].1];
            let w = frac[j].0 - if j + 1 < D { frac[j + 1].0 } else { 0.0 };
            let v = self.values[idx];
            out[0] += v[0] * w;
            out[1] += v[1] * w;
            out[2] += v[2] * w;
        }
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn axes() -> [Axis; 3] {
        [
            Axis::linear(0.0, 1.0, 5),
            Axis::cbrt(0.0, 0.5, 4),
            Axis::linear(-1.0, 1.0, 3),
        ]
    }

    #[test]
    fn exact_at_nodes_and_for_affine_functions() {
        let ax = axes();
        let f = |p: [f32; 3]| [p[0] * 2.0 + p[2], p[1].cbrt(), 1.0 - p[0]];
        let lut = GridLut::build(ax, f);
        for i in 0..5 {
            for j in 0..4 {
                for k in 0..3 {
                    let p = [ax[0].node(i), ax[1].node(j), ax[2].node(k)];
                    let (a, b) = (lut.lookup(p), f(p));
                    for c in 0..3 {
                        assert!((a[c] - b[c]).abs() < 1e-5, "{p:?}");
                    }
                }
            }
        }
        // Affine in the warped coordinates → reproduced everywhere.
        for &p in &[
            [0.13f32, 0.071, 0.37],
            [0.99, 0.49, -0.99],
            [0.5, 0.0001, 0.0],
        ] {
            let (a, b) = (lut.lookup(p), f(p));
            for c in 0..3 {
                assert!((a[c] - b[c]).abs() < 1e-4, "{p:?}: {a:?} vs {b:?}");
            }
        }
    }

    #[test]
    fn fast_cbrt_matches_libm() {
        let mut x = 1e-12f32;
        while x < 1e6 {
            let (a, b) = (fast_cbrt(x), x.cbrt());
            assert!(((a - b) / b).abs() < 1e-6, "{x}: {a} vs {b}");
            x *= 1.37;
        }
        assert_eq!(fast_cbrt(0.0), 0.0);
    }

    #[test]
    fn clamps_outside_the_range() {
        let lut = GridLut::build(axes(), |p| [p[0], 0.0, 0.0]);
        assert!((lut.lookup([7.0, 0.1, 0.0])[0] - 1.0).abs() < 1e-6);
        assert!(lut.lookup([-3.0, 0.1, 0.0])[0].abs() < 1e-6);
    }
}

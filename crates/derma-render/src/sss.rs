//! The separable subsurface blur's kernel (Jimenez et al. 2015, "Separable subsurface
//! scattering", §3): Burley's normalized diffusion per channel, applied along x then along y
//! with the profile's marginal as the 1D kernel, the tap weights integrated from its CDF.

use crate::burley;

/// Taps on each side of the centre.
pub const TAPS: u32 = 12;
/// The kernel's reach in units of the widest channel's shape d: 24 d holds all but e⁻⁸ of the
/// slow lobe of Burley's profile (e^{−r/(3d)}).
pub const U_RANGE: f32 = 24.0;
/// Nodes of the cumulative marginal table (linearly interpolated by the shader).
pub const TABLE_NODES: usize = 1024;
/// Where the table ends (units of d); beyond it F = ½.
pub const TABLE_U_MAX: f64 = 48.0;

/// The one-sided cumulative marginal F(u) of Burley's profile (d = 1) the blur integrates its
/// weights from, as the shader's storage buffer.
pub fn cdf_table() -> Vec<f32> {
    burley::marginal_cdf_table(TABLE_NODES, TABLE_U_MAX)
        .into_iter()
        .map(|v| v as f32)
        .collect()
}

/// Tap k's offset (units of the widest channel's d): quadratic spacing, dense at the centre
/// where narrow channels (blue) keep most of their weight.
pub fn tap_u(k: f32) -> f32 {
    let t = k / TAPS as f32;
    U_RANGE * 0.5 * t * t
}

/// F(u) from `table` (as the shader reads it).
fn cdf_at(table: &[f32], u: f32) -> f32 {
    let n = table.len();
    let x = u / TABLE_U_MAX as f32 * (n - 1) as f32;
    if x >= (n - 1) as f32 {
        return 0.5;
    }
    let i = x.floor() as usize;
    let f = x - i as f32;
    table[i] * (1.0 - f) + table[i + 1] * f
}

/// The weights of taps 0 (centre), 1, …, [`TAPS`] on one side for a channel whose d is
/// `ratio` × the widest channel's (the shader's computation, for tests and CPU checks). The
/// centre counts once, every other tap twice (both sides).
pub fn weights(table: &[f32], ratio: f32) -> Vec<f32> {
    let inv = 1.0 / ratio;
    let mut w = vec![2.0 * cdf_at(table, 0.5 * tap_u(1.0) * inv)];
    for k in 1..=TAPS {
        let lo = 0.5 * (tap_u(k as f32 - 1.0) + tap_u(k as f32));
        let hi = if k < TAPS {
            0.5 * (tap_u(k as f32) + tap_u(k as f32 + 1.0))
        } else {
            1e9
        };
        w.push(cdf_at(table, hi * inv) - cdf_at(table, lo * inv));
    }
    w
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_channel_keeps_its_energy_and_narrow_channels_stay_sharp() {
        let t = cdf_table();
        for ratio in [1.0, 0.5, 0.2, 0.05] {
            let w = weights(&t, ratio);
            let total = w[0] + 2.0 * w[1..].iter().sum::<f32>();
            assert!((total - 1.0).abs() < 1e-5, "ratio {ratio}: {total}");
            assert!(w.iter().all(|&x| x >= 0.0));
        }
        // The narrower a channel's profile, the more weight its centre tap keeps: a fifth of
        // the widest d keeps over three times as much (0.214 against 0.063), a twentieth
        // nearly half of all.
        let centre: Vec<f32> = [1.0, 0.5, 0.2, 0.05].map(|r| weights(&t, r)[0]).to_vec();
        assert!(centre.windows(2).all(|w| w[0] < w[1]), "{centre:?}");
        assert!(centre[2] > 3.0 * centre[0], "{centre:?}");
        assert!(centre[3] > 0.45, "{centre:?}");
    }

    #[test]
    fn tap_weights_follow_burleys_marginal() {
        // Between taps 3 and 4 the weight is ∫ m over the bin: compare with the closed form.
        let t = cdf_table();
        let w = weights(&t, 1.0);
        let (lo, hi) = (
            0.5 * (tap_u(3.0) + tap_u(4.0)),
            0.5 * (tap_u(4.0) + tap_u(5.0)),
        );
        let n = 20_000;
        let h = (hi - lo) as f64 / n as f64;
        let exact: f64 = (0..n)
            .map(|i| burley::marginal(lo as f64 + (i as f64 + 0.5) * h, 1.0) * h)
            .sum();
        assert!(
            ((w[4] as f64 - exact) / exact).abs() < 1e-3,
            "{} vs {exact}",
            w[4]
        );
    }
}

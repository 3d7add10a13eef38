//! Saccades on the main sequence (thesis §3.9, after Bahill et al. 1975 and Harwood et al. 1999):
//! duration D = 2.2 A + 21 ms (Carpenter 1988), peak velocity 473 (1 − e^(−A/7.8)) °/s (the
//! saturating main sequence of the issue), and an asymmetric velocity profile whose acceleration
//! phase shrinks from half the duration for small saccades to about a third for large ones
//! (Harwood et al. 1999 rule out the symmetric minimum-jerk profile).

/// Duration (s) of a saccade of amplitude `a` (°): Carpenter 1988, "Movements of the Eyes".
pub fn duration(a: f32) -> f32 {
    (2.2 * a + 21.0) * 1e-3
}

/// Peak velocity (°/s) of a saccade of amplitude `a` (°).
pub fn peak_velocity(a: f32) -> f32 {
    473.0 * (1.0 - (-a / 7.8).exp())
}

/// Fraction of the duration spent accelerating: ½ for small saccades, → ⅓ for large ones
/// (authored interpolation with a 15° scale between Harwood et al.'s two regimes).
pub fn acceleration_fraction(a: f32) -> f32 {
    0.5 - (1.0 / 6.0) * (1.0 - (-a / 15.0).exp())
}

/// A velocity profile v(τ) ∝ τ^(p s) (1 − τ)^((1 − p) s) on τ ∈ [0, 1]: peak at τ = p, with the
/// sharpness s solved so that peak × duration / amplitude equals the main sequence's ratio.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Profile {
    /// Amplitude (°).
    pub amplitude: f32,
    /// Duration (s).
    pub duration: f32,
    a: f64,
    b: f64,
    norm: f64,
    /// Cumulative position table at 64 steps for fast evaluation.
    cdf: [f32; 65],
}

fn beta_shape_peak(a: f64, b: f64) -> (f64, f64) {
    // ∫ τ^a (1 − τ)^b dτ by Simpson's rule (2048 panels) and the density's peak.
    let f = |t: f64| t.powf(a) * (1.0 - t).powf(b);
    let integral = derma_core::numerics::simpson(f, 0.0, 1.0, 2048);
    let p = a / (a + b);
    (integral, f(p) / integral)
}

impl Profile {
    /// The profile of a saccade of amplitude `amp` (°).
    pub fn new(amp: f32) -> Profile {
        let amp = amp.max(0.05);
        let d = duration(amp);
        let ratio = (peak_velocity(amp) * d / amp) as f64;
        let p = acceleration_fraction(amp) as f64;
        // The peak ratio grows with s; bisect s in [0.05, 40].
        let (mut lo, mut hi) = (0.05f64, 40.0f64);
        for _ in 0..60 {
            let m = 0.5 * (lo + hi);
            if beta_shape_peak(p * m, (1.0 - p) * m).1 < ratio {
                lo = m;
            } else {
                hi = m;
            }
        }
        let s = 0.5 * (lo + hi);
        let (a, b) = (p * s, (1.0 - p) * s);
        let (norm, _) = beta_shape_peak(a, b);
        let mut cdf = [0.0f32; 65];
        let mut acc = 0.0f64;
        let sub = 32;
        for k in 0..64 {
            for j in 0..sub {
                let t = (k * sub + j) as f64 / (64 * sub) as f64 + 0.5 / (64 * sub) as f64;
                acc += t.powf(a) * (1.0 - t).powf(b) / norm / (64 * sub) as f64;
            }
            cdf[k + 1] = acc as f32;
        }
        let last = cdf[64];
        cdf.iter_mut().for_each(|c| *c /= last);
        Profile {
            amplitude: amp,
            duration: d,
            a,
            b,
            norm,
            cdf,
        }
    }

    /// Velocity (°/s) at time `t` (s) from the start.
    pub fn velocity(&self, t: f32) -> f32 {
        let tau = (t / self.duration) as f64;
        if !(0.0..=1.0).contains(&tau) {
            return 0.0;
        }
        (tau.powf(self.a) * (1.0 - tau).powf(self.b) / self.norm) as f32 * self.amplitude
            / self.duration
    }

    /// Fraction of the amplitude covered at time `t` (s).
    pub fn progress(&self, t: f32) -> f32 {
        let f = (t / self.duration).clamp(0.0, 1.0) * 64.0;
        let i = (f as usize).min(63);
        let r = f - i as f32;
        self.cdf[i] + (self.cdf[i + 1] - self.cdf[i]) * r
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn profiles_follow_the_main_sequence_and_skew_for_large_saccades() {
        for amp in [2.0f32, 5.0, 10.0, 15.0, 30.0, 40.0] {
            let p = Profile::new(amp);
            let n = 4000;
            let dt = p.duration / n as f32;
            let mut area = 0.0;
            let mut peak = (0.0f32, 0.0f32);
            for i in 0..n {
                let t = (i as f32 + 0.5) * dt;
                let v = p.velocity(t);
                area += v * dt;
                if v > peak.0 {
                    peak = (v, t);
                }
            }
            assert!((area - amp).abs() < 0.01 * amp, "{amp}: area {area}");
            assert!(
                (peak.0 - peak_velocity(amp)).abs() < 0.02 * peak_velocity(amp),
                "{amp}: peak {}",
                peak.0
            );
            assert!((p.duration - (2.2 * amp + 21.0) * 1e-3).abs() < 1e-6);
            let frac = peak.1 / p.duration;
            assert!(
                (frac - acceleration_fraction(amp)).abs() < 0.02,
                "{amp}: {frac}"
            );
            assert!((p.progress(p.duration) - 1.0).abs() < 1e-5 && p.progress(0.0) == 0.0);
        }
        // Large saccades accelerate for about a third of their duration.
        assert!(acceleration_fraction(40.0) < 0.36);
    }
}

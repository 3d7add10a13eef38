//! Stochastic spontaneous blinks (thesis §3.9, table 3.1): blink frequency and amplitude drawn
//! from normal distributions, phase durations from the amplitude (Evinger et al. 1991) with the
//! closing phase faster than the opening one (Sforza et al. 2008), each phase on the
//! minimum-jerk profile (Flash & Hogan 1985).

use derma_core::rng::Philox;
use serde::{Deserialize, Serialize};

/// Table 3.1: blink frequency while watching, mean and σ (Hz), after Ishimaru et al. 2014.
pub const FREQUENCY_HZ: (f32, f32) = (0.1339, 0.1605);
/// Table 3.1: blink amplitude (° of upper-lid rotation), mean and σ, after Trutoiu et al. 2011
/// and Evinger et al. 1991.
pub const AMPLITUDE_DEG: (f32, f32) = (34.5895, 3.805);
/// Down-phase duration (ms) of a spontaneous blink of mean amplitude (Evinger et al. 1991,
/// Invest Ophthalmol Vis Sci 32:387): ≈ 66 ms.
pub const DOWN_PHASE_MS: f32 = 66.0;
/// Closing is 40–47 % faster than opening (Sforza et al. 2008, Ophthal Plast Reconstr Surg 24):
/// the up phase lasts 1.435 times the down phase (the midpoint).
pub const UP_OVER_DOWN: f32 = 1.435;

/// What the character is doing; sets the mean blink rate (Bentivoglio et al. 1997, Mov Disord
/// 12:1028: 17 blinks/min at rest, 26 in conversation, 4.5 reading), or table 3.1's watching rate.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Activity {
    /// At rest: 17 /min.
    #[default]
    Rest,
    /// In conversation: 26 /min.
    Conversation,
    /// Reading: 4.5 /min.
    Reading,
    /// Watching a video (table 3.1): 0.1339 Hz ≈ 8 /min.
    Watching,
}

impl Activity {
    /// Mean blink frequency (Hz).
    pub fn rate_hz(self) -> f32 {
        match self {
            Activity::Rest => 17.0 / 60.0,
            Activity::Conversation => 26.0 / 60.0,
            Activity::Reading => 4.5 / 60.0,
            Activity::Watching => FREQUENCY_HZ.0,
        }
    }

    /// Parses a name.
    pub fn parse(s: &str) -> Option<Activity> {
        [
            Activity::Rest,
            Activity::Conversation,
            Activity::Reading,
            Activity::Watching,
        ]
        .into_iter()
        .find(|a| format!("{a:?}").eq_ignore_ascii_case(s))
    }
}

/// One blink.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Blink {
    /// Start time (s).
    pub start: f32,
    /// Amplitude (° of upper-lid rotation).
    pub amplitude: f32,
    /// Down-phase duration (s).
    pub down: f32,
    /// Up-phase duration (s).
    pub up: f32,
}

/// The frequency distribution's truncation: the thesis' normal has σ > μ, so draws are kept in
/// [μ/5, 3μ] (at most one blink every 0.4 s at rest, at least one per 18 s).
pub const FREQ_RANGE: (f32, f32) = (0.2, 3.0);

fn normal(rng: &Philox, i: u64, sub: u32) -> f32 {
    rng.normal2(i, sub)[0]
}

/// Minimum-jerk position profile s(τ) = 10τ³ − 15τ⁴ + 6τ⁵ on [0, 1].
pub fn min_jerk(t: f32) -> f32 {
    let t = t.clamp(0.0, 1.0);
    t * t * t * (10.0 + t * (-15.0 + 6.0 * t))
}

impl Blink {
    /// Lid closure in [0, 1] at time `t` (0 before and after, 1 at the end of the down phase).
    pub fn closure(&self, t: f32, full_amplitude: f32) -> f32 {
        let peak = (self.amplitude / full_amplitude).min(1.0);
        let dt = t - self.start;
        if dt <= 0.0 || dt >= self.down + self.up {
            0.0
        } else if dt < self.down {
            peak * min_jerk(dt / self.down)
        } else {
            peak * (1.0 - min_jerk((dt - self.down) / self.up))
        }
    }
}

/// The factor on the drawn pauses 1/f that makes blinks come at the activity's mean rate: a
/// pause of 1/f with f ~ N(μ, σ) truncated to [`FREQ_RANGE`] lasts E[1/f] = 1.083/μ on average
/// (σ > μ in table 3.1), and each blink adds its own duration, so unscaled the blinks came 13 %
/// further apart than the table's mean period 1/μ (4.2 s against 3.5 s at rest). The factor
/// (1/μ − mean blink duration) / E[1/f] keeps the drawn distribution's shape and sets its mean.
pub fn pause_scale(activity: Activity) -> f32 {
    let (mu, cv) = (1.0f64, (FREQUENCY_HZ.1 / FREQUENCY_HZ.0) as f64);
    let (lo, hi) = (FREQ_RANGE.0 as f64, FREQ_RANGE.1 as f64);
    // E[1/f]·μ by Simpson's rule over the truncated density (1024 panels).
    let density = |x: f64| (-0.5 * ((x - mu) / cv).powi(2)).exp();
    let simpson = |g: &dyn Fn(f64) -> f64| derma_core::numerics::simpson(g, lo, hi, 1024);
    let (inv, mass) = (simpson(&|x| density(x) / x), simpson(&density));
    let rate = activity.rate_hz() as f64;
    let mean_pause = inv / mass / rate;
    let blink = DOWN_PHASE_MS as f64 * 1e-3 * (1.0 + UP_OVER_DOWN as f64);
    ((1.0 / rate - blink) / mean_pause) as f32
}

/// Spontaneous blinks over `seconds`: pauses [`pause_scale`]/f with f ~ N(rate, rate·σ/μ)
/// truncated to [`FREQ_RANGE`] × rate, amplitudes ~ N(table 3.1), down phase ∝ amplitude
/// (66 ms at the mean), up phase [`UP_OVER_DOWN`] times longer.
pub fn schedule(seconds: f32, activity: Activity, seed: u64) -> Vec<Blink> {
    let rng = Philox::new(seed, 0xB11E);
    let rate = activity.rate_hz();
    let cv = FREQUENCY_HZ.1 / FREQUENCY_HZ.0;
    let scale = pause_scale(activity);
    let mut out = Vec::new();
    let mut t = 0.0f32;
    for i in 0u64.. {
        let f = truncated(
            &rng,
            i,
            rate,
            rate * cv,
            FREQ_RANGE.0 * rate,
            FREQ_RANGE.1 * rate,
        );
        t += scale / f;
        if t >= seconds {
            break;
        }
        let a = (AMPLITUDE_DEG.0 + AMPLITUDE_DEG.1 * normal(&rng, i, 7)).max(1.0);
        let down = DOWN_PHASE_MS * 1e-3 * a / AMPLITUDE_DEG.0;
        out.push(Blink {
            start: t,
            amplitude: a,
            down,
            up: UP_OVER_DOWN * down,
        });
        t += down * (1.0 + UP_OVER_DOWN);
    }
    out
}

/// A draw of N(μ, σ) kept within [lo, hi] by rejection (sub-streams per attempt).
fn truncated(rng: &Philox, i: u64, mu: f32, sigma: f32, lo: f32, hi: f32) -> f32 {
    for k in 0..64 {
        let x = mu + sigma * normal(rng, i, 100 + k);
        if (lo..=hi).contains(&x) {
            return x;
        }
    }
    mu
}

/// CDF of N(μ, σ) truncated to [lo, hi] at x (for tests of the generator).
pub fn truncated_cdf(x: f64, mu: f64, sigma: f64, lo: f64, hi: f64) -> f64 {
    let phi = |v: f64| 0.5 * (1.0 + erf((v - mu) / (sigma * std::f64::consts::SQRT_2)));
    ((phi(x.clamp(lo, hi)) - phi(lo)) / (phi(hi) - phi(lo))).clamp(0.0, 1.0)
}

/// The error function (Abramowitz & Stegun 7.1.26, |error| < 1.5e-7).
pub fn erf(x: f64) -> f64 {
    let t = 1.0 / (1.0 + 0.327_591_1 * x.abs());
    let y = 1.0
        - (((((1.061_405_429 * t - 1.453_152_027) * t) + 1.421_413_741) * t - 0.284_496_736) * t
            + 0.254_829_592)
            * t
            * (-x * x).exp();
    if x >= 0.0 {
        y
    } else {
        -y
    }
}

/// The Kolmogorov–Smirnov statistic of `sample` against `cdf`.
pub fn ks_statistic(sample: &mut [f64], cdf: impl Fn(f64) -> f64) -> f64 {
    sample.sort_by(f64::total_cmp);
    let n = sample.len() as f64;
    sample
        .iter()
        .enumerate()
        .map(|(i, &x)| {
            let f = cdf(x);
            (f - i as f64 / n).abs().max(((i + 1) as f64 / n - f).abs())
        })
        .fold(0.0, f64::max)
}

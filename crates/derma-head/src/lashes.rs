//! Eyelash strands on MakeHuman's lash cards: each lash a tapering fibre from the lid margin
//! along the card, longest at the middle of the lid and fanning out towards the corners, as
//! coverage over the cards' UVs (the lashes' colour is the hair's: derma-skin writes it).
//!
//! The cards' layout (read from the built-in asset): u runs along the lid margin over
//! [0, 0.838], mirrored between the eyes (so the fan is symmetric about the lid's middle); the
//! upper card's lashes rise from v ≈ 0.09 to 0.33, the lower card's fall from v ≈ 0.92 to 0.70.
//! Counts and sizes: the textbook 100–150 upper and 50–75 lower lashes per lid (e.g. Wolff's
//! Anatomy of the Eye and Orbit, which gives upper lashes 8–12 mm and lower 6–8 mm long); the
//! cards are shorter than that (about 10 and 7 mm), so the lashes here reach at most about
//! 9.6 mm (upper) and 6.6 mm (lower) mid-lid, about 4 and 3 mm at the corners; a shaft of about
//! 0.12 mm at the root (authored, the order of terminal hair); the card spans about 32 mm
//! along u and 10 mm along v, 0.025 UV per mm.

use derma_core::rng::Philox;
use derma_core::Map;
use glam::Vec2;
use std::sync::OnceLock;

/// UV units per millimetre on the cards (both directions, to the layout's precision).
const UV_PER_MM: f32 = 0.025;
/// The lid margin's extent along u.
const U_RANGE: (f32, f32) = (0.02, 0.82);
/// Lashes per lid: upper and lower (within the textbook ranges).
const COUNTS: [usize; 2] = [150, 75];
/// Root and tip v of the upper and lower cards.
const CARDS: [(f32, f32); 2] = [(0.09, 0.33), (0.92, 0.70)];
/// Longest lash as a share of its card's root-to-tip span, upper and lower (authored so the
/// upper lashes reach about 10 mm and the lower 6 mm).
const REACH: [f32; 2] = [1.0, 0.75];
/// Shaft half-width at the root (mm): a 0.12 mm shaft.
const HALF_WIDTH_MM: f32 = 0.06;
/// Random stream of the lashes' draws (fixed: the built-in cards carry one set of lashes).
const STREAM: u32 = 1;
/// Bins along u and v for finding the lashes near a point.
const BINS: usize = 32;

/// One lash: a quadratic Bézier in the card's UVs from `root` through `ctrl` to `tip`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Lash {
    /// Root on the lid margin.
    pub root: Vec2,
    /// Control point (the curl).
    pub ctrl: Vec2,
    /// Tip.
    pub tip: Vec2,
    /// Half-width at the root (UV); it tapers linearly to zero at the tip.
    pub half_width: f32,
}

impl Lash {
    fn at(&self, t: f32) -> Vec2 {
        let s = 1.0 - t;
        self.root * (s * s) + self.ctrl * (2.0 * s * t) + self.tip * (t * t)
    }

    /// Coverage of the lash at `uv`, antialiased over `aa` UV units: 1 inside the tapering
    /// shaft, falling to 0 over `aa` at its edge; a shaft narrower than `aa` is widened to it
    /// with its coverage scaled by the ratio, so its area is kept and thin tips fade.
    fn coverage(&self, uv: Vec2, aa: f32) -> f32 {
        const STEPS: usize = 12;
        let mut best = 0.0f32;
        let mut prev = self.root;
        for k in 1..=STEPS {
            let t = k as f32 / STEPS as f32;
            let next = self.at(t);
            let ab = next - prev;
            let s = ((uv - prev).dot(ab) / ab.length_squared().max(1e-12)).clamp(0.0, 1.0);
            let d = uv.distance(prev + ab * s);
            let tt = (k as f32 - 1.0 + s) / STEPS as f32;
            let hw = self.half_width * (1.0 - tt);
            let hw_eff = hw.max(0.5 * aa);
            let c = (0.5 - (d - hw_eff) / aa).clamp(0.0, 1.0) * (hw / hw_eff);
            best = best.max(c);
            prev = next;
        }
        best
    }

    fn bounds(&self) -> (Vec2, Vec2) {
        let lo = self.root.min(self.ctrl).min(self.tip) - Vec2::splat(self.half_width);
        let hi = self.root.max(self.ctrl).max(self.tip) + Vec2::splat(self.half_width);
        (lo, hi)
    }
}

struct Lashes {
    lashes: Vec<Lash>,
    bins: Vec<Vec<u32>>,
}

/// Every lash of the built-in cards (both cards; the same for both eyes), deterministic.
pub fn lashes() -> &'static [Lash] {
    &all().lashes
}

fn all() -> &'static Lashes {
    static ALL: OnceLock<Lashes> = OnceLock::new();
    ALL.get_or_init(|| {
        let rng = Philox::new(0x1a5e5, STREAM);
        let mut lashes = Vec::new();
        let (u0, u1) = U_RANGE;
        let mid = 0.5 * (u0 + u1);
        for (card, &n) in COUNTS.iter().enumerate() {
            let (v_root, v_tip) = CARDS[card];
            let up = (v_tip - v_root).signum();
            let span = (v_tip - v_root).abs();
            for i in 0..n {
                let r = rng.uniform4(((card as u64) << 32) | i as u64, 0);
                // Evenly along the margin with jitter; longest mid-lid, shorter at the corners.
                let u = u0 + (u1 - u0) * (i as f32 + r[0]) / n as f32;
                let x = (u - mid) / (0.5 * (u1 - u0));
                let length =
                    span * REACH[card] * (0.55 + 0.45 * (1.0 - x * x)) * (0.8 + 0.2 * r[1]);
                // Fanning out to the corners, and curling: the control point pulled sideways.
                let fan = 0.35 * x * length;
                let curl = (r[2] - 0.5) * 0.25 * length;
                let root = Vec2::new(u, v_root);
                let tip = Vec2::new(u + fan, v_root + up * length);
                let ctrl = Vec2::new(u + 0.3 * fan + curl, v_root + up * 0.5 * length);
                let hw = HALF_WIDTH_MM
                    * UV_PER_MM
                    * (0.8 + 0.4 * r[3])
                    * if card == 0 { 1.0 } else { 0.8 };
                lashes.push(Lash {
                    root,
                    ctrl,
                    tip,
                    half_width: hw,
                });
            }
        }
        let mut bins = vec![Vec::new(); BINS * BINS];
        for (k, l) in lashes.iter().enumerate() {
            let (lo, hi) = l.bounds();
            // The antialiasing reaches ½ texel beyond the shaft: 2/512 covers maps of 128² up.
            let pad = 2.0 / 512.0;
            for by in bin(lo.y - pad)..=bin(hi.y + pad) {
                for bx in bin(lo.x - pad)..=bin(hi.x + pad) {
                    bins[by * BINS + bx].push(k as u32);
                }
            }
        }
        Lashes { lashes, bins }
    })
}

/// The bin along one axis of a UV coordinate.
fn bin(v: f32) -> usize {
    ((v * BINS as f32).floor() as i64).clamp(0, BINS as i64 - 1) as usize
}

/// Coverage of the lash cards at `uv`, antialiased over `aa` UV units: the union of every lash
/// there (1 − Π(1 − cᵢ)).
pub fn coverage_aa(uv: Vec2, aa: f32) -> f32 {
    let a = all();
    let mut clear = 1.0;
    for &k in &a.bins[bin(uv.y) * BINS + bin(uv.x)] {
        clear *= 1.0 - a.lashes[k as usize].coverage(uv, aa);
    }
    1.0 - clear
}

/// Coverage of the lash cards at `uv`, antialiased over a 512² map's texel.
pub fn coverage(uv: Vec2) -> f32 {
    coverage_aa(uv, 1.0 / 512.0)
}

/// The coverage as an `n`×`n` map (row 0 at v = 1), antialiased over its texels.
pub fn coverage_map(n: usize) -> Map {
    Map::from_par_fn(n, n, |i| {
        let uv = Vec2::new(
            ((i % n) as f32 + 0.5) / n as f32,
            1.0 - ((i / n) as f32 + 0.5) / n as f32,
        );
        coverage_aa(uv, 1.0 / n as f32)
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn lashes_rise_from_the_margins_within_their_cards() {
        let l = lashes();
        assert_eq!(l.len(), COUNTS[0] + COUNTS[1]);
        for (k, lash) in l.iter().enumerate() {
            let (v_root, v_tip) = CARDS[usize::from(k >= COUNTS[0])];
            assert_eq!(lash.root.y, v_root);
            let (lo, hi) = (v_root.min(v_tip), v_root.max(v_tip));
            assert!((lo..=hi).contains(&lash.tip.y), "{lash:?}");
            // 0.1 mm shafts: a few thousandths of the card.
            assert!(lash.half_width > 0.0005 && lash.half_width < 0.002);
        }
    }

    #[test]
    fn coverage_is_dense_at_the_roots_and_sparse_at_the_tips() {
        let m = coverage_map(512);
        let row_mean = |v: f32| {
            let y = ((1.0 - v) * 512.0) as usize;
            (40..400).map(|x| m.get(x, y)).sum::<f32>() / 360.0
        };
        let (root, mid, tip, off) = (
            row_mean(0.095),
            row_mean(0.2),
            row_mean(0.32),
            row_mean(0.5),
        );
        assert!(root > 0.4 && root > mid && mid > tip, "{root} {mid} {tip}");
        assert_eq!(off, 0.0);
        // Single strands: the mid-card row alternates between lash and gap.
        assert!(mid > 0.05 && mid < 0.7, "{mid}");
        // The point query and the map agree.
        assert!(
            (coverage(Vec2::new(0.4, 0.1)) - coverage_aa(Vec2::new(0.4, 0.1), 1.0 / 512.0)).abs()
                < 1e-6
        );
    }
}

//! Lid contact: the upper lid margin never passes below the lower one. The EyeMove thesis models
//! the margins as curves (§3.5) and leaves their contact to the data; a linear model of a rig
//! whose closed lids overlap (the Face Units pack's blink crosses by 1.3 mm) passes it on. Per
//! frame, in the modelling camera, each upper-margin vertex's shortfall below the lower margin
//! (interpolated along the lid) lifts the upper lid, by a weight that falls off with a vertex's
//! rest distance from its upper margin (a Gaussian of 3 mm, authored: the strip above the margin
//! compresses without turning over for shortfalls up to 3.5 mm).

use crate::region::EyeRegion;
use glam::Vec2;

/// Width (mm) of the lift's Gaussian falloff above the upper margin.
pub const FALLOFF_MM: f32 = 3.0;
/// Beyond this rest distance (mm) from the upper margin a vertex is not lifted.
pub const REACH_MM: f32 = 9.0;

/// The contact of a region's lids.
#[derive(Clone, Debug)]
pub struct Contact {
    /// Per eye, the upper and lower margin chains (model vertices, inner → outer canthus).
    pub margins: [[Vec<u32>; 2]; 2],
    /// Per model vertex: its eye and the share of its upper margin's lift it takes (0: none —
    /// the lower lid, the canthi and everything farther than [`REACH_MM`]).
    pub lift: Vec<(u8, f32)>,
}

impl Contact {
    /// The contact of `region`'s lids (rest distances from its margins decide the lifts).
    pub fn new(region: &EyeRegion) -> Contact {
        let nearest = |i: usize, chain: &[u32]| {
            chain
                .iter()
                .map(|&j| region.rest[i].distance(region.rest[j as usize]))
                .fold(f32::INFINITY, f32::min)
        };
        let lift = (0..region.len())
            .map(|i| {
                let e = region.eye[i];
                let [upper, lower] = &region.margins[e as usize];
                let (du, dl) = (nearest(i, upper), nearest(i, lower));
                let w = if du < dl && du <= REACH_MM {
                    (-(du / FALLOFF_MM).powi(2)).exp()
                } else {
                    0.0
                };
                (e, w)
            })
            .collect();
        Contact {
            margins: region.margins.clone(),
            lift,
        }
    }

    /// Lifts the upper lids of the model coordinates `u` (modelling camera, mm) so that their
    /// margins are nowhere below the lower ones.
    pub fn apply(&self, u: &mut [Vec2]) {
        for e in 0..2 {
            let chain = |l: usize| -> Vec<Vec2> {
                self.margins[e][l].iter().map(|&i| u[i as usize]).collect()
            };
            let (upper, lower) = (chain(0), chain(1));
            // The shortfall of each upper-margin point (the shared canthi have none).
            let shortfall: Vec<Vec2> = upper
                .iter()
                .enumerate()
                .map(|(k, p)| {
                    let inner = k > 0 && k + 1 < upper.len();
                    let below = height_at(&lower, p.x).map_or(0.0, |y| (y - p.y).max(0.0));
                    Vec2::new(p.x, if inner { below } else { 0.0 })
                })
                .collect();
            if shortfall.iter().all(|s| s.y == 0.0) {
                continue;
            }
            for (i, ui) in u.iter_mut().enumerate() {
                let (eye, w) = self.lift[i];
                if eye as usize == e && w > 0.0 {
                    ui.y += w * height_at(&shortfall, ui.x).unwrap_or(0.0);
                }
            }
        }
    }
}

/// The polyline's height at `x` (linear between its points; None outside it). The chain may
/// run either way along x.
pub fn height_at(chain: &[Vec2], x: f32) -> Option<f32> {
    chain.windows(2).find_map(|w| {
        let (a, b) = (w[0], w[1]);
        let (lo, hi) = (a.x.min(b.x), a.x.max(b.x));
        (x >= lo && x <= hi && hi > lo).then(|| a.y + (b.y - a.y) * (x - a.x) / (b.x - a.x))
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn heights_interpolate_either_way_along_the_chain() {
        let c = [
            Vec2::new(0.0, 0.0),
            Vec2::new(2.0, 1.0),
            Vec2::new(4.0, 0.0),
        ];
        assert_eq!(height_at(&c, 1.0), Some(0.5));
        assert_eq!(height_at(&c, 3.0), Some(0.5));
        let r: Vec<Vec2> = c.iter().rev().copied().collect();
        assert_eq!(height_at(&r, 1.0), Some(0.5));
        assert_eq!(height_at(&c, 5.0), None);
    }
}

//! The generalised gaze vector g of the eye-region model (thesis §3.3): per eye the Fick angles
//! (horizontal, vertical, torsion) and the two lid displacements, then optional action units.
//!
//! Fick (1854) coordinates are a sequence of rotations about head-fixed then carried axes: first
//! horizontal (about the head's vertical axis), then vertical (about the carried horizontal axis),
//! last torsion (about the line of sight). derma's head looks down +Z with +Y up and +X the head's
//! left, so h > 0 turns the eye towards +X and v > 0 turns it up.

use glam::{Quat, Vec3};
use serde::{Deserialize, Serialize};

/// Inputs per eye in g: three Fick angles and two lid displacements.
pub const PER_EYE: usize = 5;
/// Inputs of both eyes (g₁…g₁₀).
pub const EYE_INPUTS: usize = 2 * PER_EYE;

/// Fick angles of one eye, degrees.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Fick {
    /// Horizontal rotation (°), positive towards the head's +X (the subject's left).
    pub h: f32,
    /// Vertical rotation (°), positive up.
    pub v: f32,
    /// Torsion about the line of sight (°).
    #[serde(default)]
    pub t: f32,
}

impl Fick {
    /// Primary position: looking straight ahead.
    pub const PRIMARY: Fick = Fick {
        h: 0.0,
        v: 0.0,
        t: 0.0,
    };

    /// The eye's rotation from primary position: R = R_Y(h) · R_X(−v) · R_Z(t) (intrinsic
    /// horizontal, then vertical, then torsion: Fick's gimbal).
    pub fn rotation(self) -> Quat {
        Quat::from_rotation_y(self.h.to_radians())
            * Quat::from_rotation_x(-self.v.to_radians())
            * Quat::from_rotation_z(self.t.to_radians())
    }

    /// The line of sight (unit, head coordinates).
    pub fn direction(self) -> Vec3 {
        let (h, v) = (self.h.to_radians(), self.v.to_radians());
        Vec3::new(h.sin() * v.cos(), v.sin(), h.cos() * v.cos())
    }

    /// The Fick angles (no torsion) that point the line of sight along `d` (any length > 0).
    pub fn towards(d: Vec3) -> Fick {
        let d = d.normalize_or(Vec3::Z);
        Fick {
            h: d.x.atan2(d.z).to_degrees(),
            v: d.y.clamp(-1.0, 1.0).asin().to_degrees(),
            t: 0.0,
        }
    }

    /// Angular amplitude (°) of the shift from `self` to `other` (great-circle angle between
    /// the two lines of sight).
    pub fn amplitude_to(self, other: Fick) -> f32 {
        self.direction()
            .dot(other.direction())
            .clamp(-1.0, 1.0)
            .acos()
            .to_degrees()
    }
}

/// Both eyes' Fick angles pointing at a target (head coordinates, mm): vergence follows from
/// the two globe centres.
pub fn verge(centres: [Vec3; 2], target: Vec3) -> [Fick; 2] {
    centres.map(|c| Fick::towards(target - c))
}

/// The normalised generalised gaze vector g̃ (§3.7): gaze per eye and normalised lid openings
/// (0 closed, 1 the widest opening seen in training), then action units in [0, 1].
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Gaze {
    /// Fick angles of the left (+X) and right eye.
    pub eyes: [Fick; 2],
    /// Normalised (upper, lower) lid openings per eye, g̃[4,5] and g̃[9,10].
    pub lids: [[f32; 2]; 2],
    /// Action-unit strengths g̃₁₁… in the model's unit order.
    pub units: Vec<f32>,
}

impl Gaze {
    /// g̃ as a row of inputs: (h, v, t, upper, lower) per eye, then the units.
    pub fn inputs(&self) -> Vec<f64> {
        let mut g = Vec::with_capacity(EYE_INPUTS + self.units.len());
        for (e, l) in self.eyes.iter().zip(&self.lids) {
            g.extend([e.h, e.v, e.t, l[0], l[1]].map(f64::from));
        }
        g.extend(self.units.iter().map(|&u| u as f64));
        g
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn fick_rotation_carries_the_optical_axis_to_the_direction() {
        for (h, v) in [
            (0.0, 0.0),
            (20.0, 0.0),
            (0.0, -30.0),
            (-35.0, 25.0),
            (10.0, 40.0),
        ] {
            let f = Fick { h, v, t: 0.0 };
            let a = f.rotation() * Vec3::Z;
            assert!(
                (a - f.direction()).length() < 1e-5,
                "{h} {v}: {a} {}",
                f.direction()
            );
            let back = Fick::towards(a);
            assert!((back.h - h).abs() < 1e-3 && (back.v - v).abs() < 1e-3);
        }
        // Positive angles look towards +X and up.
        assert!(
            Fick {
                h: 10.0,
                v: 0.0,
                t: 0.0
            }
            .direction()
            .x > 0.0
        );
        assert!(
            Fick {
                h: 0.0,
                v: 10.0,
                t: 0.0
            }
            .direction()
            .y > 0.0
        );
    }

    #[test]
    fn torsion_turns_about_the_line_of_sight_only() {
        let f = Fick {
            h: 15.0,
            v: 10.0,
            t: 0.0,
        };
        let g = Fick { t: 12.0, ..f };
        assert!((f.rotation() * Vec3::Z - g.rotation() * Vec3::Z).length() < 1e-6);
        let x = (g.rotation() * Vec3::X).dot(f.rotation() * Vec3::X);
        assert!((x - 12f32.to_radians().cos()).abs() < 1e-5);
    }

    #[test]
    fn vergence_turns_both_eyes_in_for_a_near_target() {
        let c = [Vec3::new(31.0, 0.0, 66.0), Vec3::new(-31.0, 0.0, 66.0)];
        let [l, r] = verge(c, Vec3::new(0.0, 0.0, 366.0));
        // Left eye (+X) turns towards −X, the right eye towards +X, by atan(31/300).
        let want = (31.0f32 / 300.0).atan().to_degrees();
        assert!((l.h + want).abs() < 1e-3 && (r.h - want).abs() < 1e-3);
        assert!((l.amplitude_to(r) - 2.0 * want).abs() < 1e-2);
    }
}

//! Lighting setups: three directional lights in camera space (the key casts the shadow) and a
//! hemisphere environment (sky above, ground below) for ambient light and reflections.
//! The setups are authored like a portrait photographer's, not measured.

use glam::Vec3;

/// One directional light: unit direction towards it in camera space (x right, y up, z towards
/// the viewer) and its irradiance at normal incidence (linear RGB).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Light {
    /// Towards the light, camera space.
    pub dir: Vec3,
    /// Linear RGB irradiance.
    pub irradiance: Vec3,
}

/// A lighting setup.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Lighting {
    /// Key (shadow-casting), fill and rim.
    pub lights: [Light; 3],
    /// Sky radiance (linear RGB), above the horizon.
    pub sky: Vec3,
    /// Ground radiance, below it.
    pub ground: Vec3,
    /// Exposure multiplier before tone mapping.
    pub exposure: f32,
}

fn light(dir: [f32; 3], irradiance: [f32; 3]) -> Light {
    Light {
        dir: Vec3::from(dir).normalize(),
        irradiance: Vec3::from(irradiance),
    }
}

/// The setups `derma render --lighting` offers.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Setup {
    /// Three-point portrait lighting: a warm key above left, a cool fill right, a rim behind.
    Studio,
    /// One soft daylight window to the side, a dim bounce opposite and a bright sky: the
    /// light that shows subsurface scattering at the shadow edge.
    Window,
}

impl Setup {
    /// Every setup, in `--help` order.
    pub const ALL: [Setup; 2] = [Setup::Studio, Setup::Window];

    /// Its name on the command line.
    pub fn name(self) -> &'static str {
        match self {
            Setup::Studio => "studio",
            Setup::Window => "window",
        }
    }

    /// The lights and environment.
    pub fn lighting(self) -> Lighting {
        match self {
            Setup::Studio => Lighting {
                lights: [
                    light([-0.55, 0.55, 0.63], [3.0, 2.85, 2.6]),
                    light([0.8, 0.1, 0.6], [0.55, 0.6, 0.7]),
                    light([0.45, 0.5, -0.75], [1.6, 1.6, 1.7]),
                ],
                sky: Vec3::new(0.06, 0.065, 0.075),
                ground: Vec3::new(0.025, 0.022, 0.02),
                exposure: 1.0,
            },
            Setup::Window => Lighting {
                lights: [
                    light([-0.85, 0.3, 0.45], [4.0, 4.1, 4.3]),
                    light([0.9, -0.1, 0.4], [0.1, 0.09, 0.08]),
                    light([0.0, 1.0, 0.0], [0.0, 0.0, 0.0]),
                ],
                sky: Vec3::new(0.05, 0.06, 0.075),
                ground: Vec3::new(0.02, 0.018, 0.016),
                exposure: 1.1,
            },
        }
    }
}

impl std::str::FromStr for Setup {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        Setup::ALL
            .into_iter()
            .find(|x| x.name().eq_ignore_ascii_case(s.trim()))
            .ok_or_else(|| format!("lighting '{s}': expected studio or window"))
    }
}

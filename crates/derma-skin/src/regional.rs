//! Regional biology and the person: blood volume, oxygenation, melanin and epidermal thickness
//! vary over a face by region, and skin tone (ITA°), sex and age set the rest. Region gains
//! multiply the baseline skin of thesis §5.3.1 before features are painted.
//!
//! Directions of the regional differences come from the literature cited per row of [`GAINS`];
//! their magnitudes are authored so that the default head's colour statistics land in the
//! ranges measured on real faces (see docs/head.md and the `regional_color` tests).

use derma_head::regions::{self, Weights};
use serde::{Deserialize, Serialize};

/// Names of the regional biology maps (fields), in [`gains`]' order.
pub const CHANNELS: [&str; 4] = [
    "regional_blood",
    "regional_melanin",
    "regional_oxygenation",
    "regional_epidermis",
];

/// Largest regional gain an 8- or 16-bit image can hold: a PNG regional field's value v in
/// [0, 1] reads as the gain 8·v (so 0.125 is 1, no change). Authored: room above the largest
/// gain of [`GAINS`] (5.5, the nose). EXR fields hold the values
/// themselves; `--export-template` writes EXR.
pub const PNG_GAIN_SCALE: f32 = 8.0;

/// The value a regional field `name` stored as an 8/16-bit image encodes by `v` in [0, 1]:
/// gains (blood, melanin, epidermis) `PNG_GAIN_SCALE`·v, the oxygenation shift v − ½.
/// `None` for fields that are not regional.
pub fn decode_png(name: &str, v: f32) -> Option<f32> {
    match name {
        "regional_oxygenation" => Some(v - 0.5),
        n if CHANNELS.contains(&n) => Some(PNG_GAIN_SCALE * v),
        _ => None,
    }
}

/// The values where no region changes anything: gains 1, oxygenation shift 0.
pub const NEUTRAL: [f32; 4] = [1.0, 1.0, 0.0, 1.0];

/// Regional change: blood ×, melanin ×, oxygenation + (fraction), epidermis ×.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Gain {
    /// Region name (derma-head's [`regions::REGIONS`]).
    pub region: &'static str,
    /// Factor on the blood volume fraction.
    pub blood: f32,
    /// Factor on the melanin volume fraction.
    pub melanin: f32,
    /// Added to the oxygen saturation.
    pub oxygenation: f32,
    /// Factor on the epidermal thickness.
    pub epidermis: f32,
}

const fn g(
    region: &'static str,
    blood: f32,
    melanin: f32,
    oxygenation: f32,
    epidermis: f32,
) -> Gain {
    Gain {
        region,
        blood,
        melanin,
        oxygenation,
        epidermis,
    }
}

/// The regional table.
pub const GAINS: [Gain; 12] = [
    // Cheeks, nose, forehead and chin carry more superficial blood than the neck: the neutral
    // hemoglobin maps of Jimenez et al. 2010 (fig. 4) are darkest (most blood) over the cheeks,
    // nose and around the mouth; facial erythema is highest on the cheeks and nose. Where the
    // flow is higher the tissue extracts a smaller fraction of the oxygen (Fick's principle), so
    // the well-perfused regions also carry more oxygenated blood: +0.12–0.2 saturation.
    // Magnitudes are authored against measured facial colour (the test regional_color): the
    // excess over 1 was cut to 0.6× when the optics' surface became the Smith microsurface;
    // when the baseline blood was lowered to 0.3–2 % (so facial a* and b* land near measured
    // faces), cheeks and nose were raised to 5 and 5.5 so their diffuse erythema still stands
    // out (coarse a* σ ≥ 2.5 on light skin, as a fair face scan's 3.0). Beside two
    // photographed albedos (docs/skin.md, "Beside a real face") the rest of the face was far
    // paler than theirs — chin 7.8 against 15, neck 6 against 14, lids 9 against 15–17, where
    // their cheeks lead the chin by 1.6 a* and the forehead by 2.6–3.3 — so forehead, chin,
    // upper lip, ears, lids and neck were raised towards the cheeks (forehead 2.56 → 3.2, the
    // others to 4, the neck 0.9 → 2.5; tuned on the Lee Perry-Smith scan, checked on the other).
    g("cheeks", 5.0, 1.0, 0.2, 1.0),
    g("nose", 5.5, 1.0, 0.2, 1.0),
    g("forehead", 3.2, 1.0, 0.12, 1.0),
    g("chin", 4.0, 1.0, 0.0, 1.0),
    g("upper_lip", 4.0, 1.0, 0.0, 1.0),
    // The auricle is thin and well perfused and reads redder than the scalp around it (as in
    // the reference head scan of the issue this follows).
    g("ears", 4.0, 1.0, 0.15, 1.0),
    // Periorbital skin: darker and bluish — venous blood of the orbicularis plexus seen through
    // thin skin, and more melanin (Freitag & Cestari 2007, "What causes dark circles under the
    // eyes?", J Cosmet Dermatol 6:211–215).
    g("periorbital", 4.0, 1.25, -0.4, 0.85),
    // Eyelid skin is the thinnest of the face (Ha et al. 2005, Plast Reconstr Surg 115:1769).
    g("eyelids", 4.0, 1.3, -0.2, 0.6),
    // The lip vermilion: the lips feature sets its blood (thesis §5.3.6); its capillary loops
    // lie close under a thin epidermis and carry well-oxygenated blood.
    g("lips", 1.0, 1.0, 0.2, 1.0),
    // The neck is paler than the face.
    g("neck", 2.5, 0.95, 0.0, 1.0),
    g("scalp", 1.0, 1.0, 0.0, 1.0),
    g("eyebrows", 1.2, 1.0, 0.0, 1.0),
];

/// Regional biology at a point with region weights `w`: 1 + Σ wᵣ (gainᵣ − 1) per channel.
pub fn gains(w: &Weights) -> [f32; 4] {
    let mut out = NEUTRAL;
    for r in &GAINS {
        let k = w[regions::index(r.region).expect("a region of derma-head")];
        out[0] += k * (r.blood - 1.0);
        out[1] += k * (r.melanin - 1.0);
        out[2] += k * r.oxygenation;
        out[3] += k * (r.epidermis - 1.0);
    }
    out[0] = out[0].max(0.1);
    out[1] = out[1].max(0.1);
    out[3] = out[3].max(0.2);
    out
}

/// Sex, for the beard area.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Sex {
    /// Terminal beard follicles on the beard area.
    Male,
    /// Vellus hair only.
    Female,
}

impl Sex {
    /// Its name, as configs and reports write it ("male", "female").
    pub fn name(self) -> &'static str {
        match self {
            Sex::Male => "male",
            Sex::Female => "female",
        }
    }

    /// Parses a name.
    pub fn parse(s: &str) -> Option<Sex> {
        [Sex::Male, Sex::Female].into_iter().find(|x| x.name() == s)
    }
}

/// The person the skin belongs to (`[person]`).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct Person {
    /// Skin tone as the individual typology angle of the cheeks and forehead (°).
    pub ita_deg: f32,
    /// Set the baseline melanin so the cheeks and forehead come out at `ita_deg`.
    pub calibrate_melanin: bool,
    /// Sex.
    pub sex: Sex,
    /// Age (years): wrinkle count and depth, lentigines.
    pub age_years: f32,
}

impl Default for Person {
    fn default() -> Self {
        Preset::Light.person(Sex::Male, 35.0)
    }
}

/// The six ITA° skin-colour categories of Chardon et al. 1991 (Int J Cosmet Sci 13:191–208):
/// very light > 55°, light 41–55°, intermediate 28–41°, tan 10–28°, brown −30–10°, dark < −30°.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Preset {
    /// ITA > 55°.
    VeryLight,
    /// 41–55°.
    Light,
    /// 28–41°.
    Intermediate,
    /// 10–28°.
    Tan,
    /// −30–10°.
    Brown,
    /// < −30°.
    Dark,
}

impl Preset {
    /// All presets, lightest first.
    pub const ALL: [Preset; 6] = [
        Preset::VeryLight,
        Preset::Light,
        Preset::Intermediate,
        Preset::Tan,
        Preset::Brown,
        Preset::Dark,
    ];

    /// Its command-line name.
    pub fn name(self) -> &'static str {
        match self {
            Preset::VeryLight => "very-light",
            Preset::Light => "light",
            Preset::Intermediate => "intermediate",
            Preset::Tan => "tan",
            Preset::Brown => "brown",
            Preset::Dark => "dark",
        }
    }

    /// Parses a command-line name.
    pub fn parse(s: &str) -> Option<Preset> {
        Preset::ALL.into_iter().find(|p| p.name() == s)
    }

    /// The ITA° band (Chardon et al. 1991); the open ends closed at ±70°.
    pub fn band(self) -> (f32, f32) {
        match self {
            Preset::VeryLight => (55.0, 70.0),
            Preset::Light => (41.0, 55.0),
            Preset::Intermediate => (28.0, 41.0),
            Preset::Tan => (10.0, 28.0),
            Preset::Brown => (-30.0, 10.0),
            Preset::Dark => (-70.0, -30.0),
        }
    }

    /// The ITA° this preset aims at: the middle of its band, the open ends closed at ±70° (very
    /// light 62.5°), except dark at −40°: the nearer of the two dark facial clusters measured by
    /// Wee et al. 2009 (ITA −39.9° and −57.8°; crates/derma-skin/data/facial-colour-groups.toml),
    /// where the Monte Carlo skin's colour is also compared with a measured mean.
    pub fn target_ita_deg(self) -> f32 {
        match self {
            Preset::Dark => -40.0,
            _ => {
                let (lo, hi) = self.band();
                0.5 * (lo + hi)
            }
        }
    }

    /// The person of this preset, aiming at [`Preset::target_ita_deg`].
    pub fn person(self, sex: Sex, age_years: f32) -> Person {
        Person {
            ita_deg: self.target_ita_deg(),
            calibrate_melanin: true,
            sex,
            age_years,
        }
    }
}

/// Individual typology angle (°) of a CIELAB colour: atan((L* − 50) / b*) (Chardon et al. 1991),
/// computed as atan2 so that it stays monotonic where b* ≤ 0 (the same value for every b* > 0,
/// which skin always has).
pub fn ita_deg(lab: [f64; 3]) -> f64 {
    (lab[0] - 50.0).atan2(lab[2]).to_degrees()
}

/// Wrinkle count and depth factor for an age: 1 at 40, rising linearly from 0.2 at ≤ 20 to 2.2
/// at ≥ 70 (authored; wrinkles deepen and multiply with age, e.g. Lemperle et al. 2001's
/// wrinkle severity grades rise steadily with age).
pub fn age_factor(age_years: f32) -> f32 {
    (0.2 + (age_years - 20.0) * 0.04).clamp(0.2, 2.2)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ita_follows_chardon() {
        // L* = 50 is 0° whatever b*; L* 60, b* 10 is 45°.
        assert!((ita_deg([50.0, 10.0, 15.0])).abs() < 1e-9);
        assert!((ita_deg([60.0, 10.0, 10.0]) - 45.0).abs() < 1e-9);
        for p in Preset::ALL {
            let (lo, hi) = p.band();
            let t = p.person(Sex::Female, 30.0).ita_deg;
            assert!(lo < t && t < hi, "{}", p.name());
        }
    }

    #[test]
    fn regional_gains_are_neutral_outside_regions_and_blend_inside() {
        let none = [0.0; regions::REGIONS.len()];
        assert_eq!(gains(&none), NEUTRAL);
        let mut w = none;
        w[regions::index("cheeks").unwrap()] = 0.5;
        let c = gains(&w);
        let cheeks = GAINS.iter().find(|g| g.region == "cheeks").unwrap();
        assert!(cheeks.blood > 1.5, "cheeks carry more blood");
        assert!((c[0] - (1.0 + 0.5 * (cheeks.blood - 1.0))).abs() < 1e-6);
        assert!((c[2] - 0.5 * cheeks.oxygenation).abs() < 1e-6);
    }
}

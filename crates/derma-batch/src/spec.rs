//! A batch's spec and its draws (docs/batch.md): the distributions of skin tone, sex, age, mesh
//! and size, checked as read, and identity i's person and seed from Philox(seed, i) alone.

use crate::error::{BatchError, Result};
use derma_core::rng::Philox;
use derma_skin::regional::{Preset, Sex};
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;
use std::path::Path;

/// The batch's own Philox stream ("batc"): identity i's draws are `Philox(seed, STREAM)` at
/// index i, so they do not depend on the shards or the order identities run in.
pub const STREAM: u32 = 0x6261_7463;

/// The spec as written (`derma batch SPEC.toml`); paths relative to the spec's directory.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct BatchSpec {
    /// How many identities (0 … count − 1).
    pub count: usize,
    /// The batch's seed: every identity's draws and its own skin seed come from it.
    #[serde(default = "default_seed")]
    pub seed: u64,
    /// Texture size in texels (square), every identity: one size (the set's files in the
    /// identity's directory) or a list (`size = [512, 2048]`: the identity painted at each, the
    /// same person and seed, into `NNNNNN/512/`, `NNNNNN/2048/`).
    #[serde(default = "default_size")]
    pub size: Sizes,
    /// Skin tones drawn uniformly from these presets (Chardon et al. 1991's ITA° categories:
    /// very-light, light, intermediate, tan, brown, dark), each at its target ITA°; default all
    /// six. Not with `ita_deg`.
    #[serde(default)]
    pub presets: Vec<String>,
    /// Skin tone as ITA° drawn uniformly in [min, max] instead of presets.
    #[serde(default)]
    pub ita_deg: Option<[f32; 2]>,
    /// Probability that an identity is male (beard follicles), in [0, 1].
    #[serde(default = "default_male")]
    pub male: f32,
    /// Age in years drawn uniformly in [min, max] (wrinkles, lentigines), to 0.1 year.
    #[serde(default = "default_ages")]
    pub age_years: [f32; 2],
    /// Meshes with UVs (OBJ, glTF, GLB), one drawn uniformly per identity; empty: the
    /// built-in head (or `heads`).
    #[serde(default)]
    pub meshes: Vec<String>,
    /// Fitted heads (`derma head fit` directories), one drawn uniformly per identity, each
    /// painted on its template skin. Not with `meshes`.
    #[serde(default)]
    pub heads: Vec<String>,
    /// A skin configuration (TOML, `derma skin --print-config`) for every other key; its size,
    /// seed and person are replaced by the batch's.
    #[serde(default)]
    pub config: Option<String>,
    /// The bio → render conversion: "table" (the Monte Carlo match table) or "analytic".
    #[serde(default)]
    pub appearance: Appearance,
    /// Also head.glb beside each set (the head it was painted on, PBR material).
    #[serde(default)]
    pub glb: bool,
    /// The set's files to keep (names as written: base_color.png, normal.png, melanin.exr, …;
    /// docs/skin.md); empty: all of them. report.json is always kept (the manifest's timings),
    /// head.glb whenever `glb` is on. features.json alone is about 19 MB on the built-in head
    /// whatever the size, so a batch for training data usually names its maps.
    #[serde(default)]
    pub outputs: Vec<String>,
}

fn default_seed() -> u64 {
    1
}
fn default_size() -> Sizes {
    Sizes::One(1024)
}

fn default_male() -> f32 {
    0.5
}
fn default_ages() -> [f32; 2] {
    [20.0, 70.0]
}

/// The bio → render conversion of every identity.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Appearance {
    /// The built-in Monte Carlo match table (`derma skin`'s default).
    #[default]
    Table,
    /// The spectral Kubelka–Munk model.
    Analytic,
}

/// One texture size, or several (each in a directory of its own).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(untagged)]
pub enum Sizes {
    /// Every identity at this size, its files in its directory.
    One(u32),
    /// Every identity at each size, in `NNNNNN/SIZE/`.
    Each(Vec<u32>),
}

impl Sizes {
    /// The sizes, with the subdirectory each set goes into ("" for a single size).
    pub fn dirs(&self) -> Vec<(u32, String)> {
        match self {
            Sizes::One(n) => vec![(*n, String::new())],
            Sizes::Each(v) => v.iter().map(|n| (*n, n.to_string())).collect(),
        }
    }
}

/// What identity i is: its draws and the files it became.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Identity {
    /// Its index, 0 … count − 1.
    pub index: usize,
    /// Its directory under the batch's output.
    pub dir: String,
    /// The skin's seed (below 2⁵³).
    pub seed: u64,
    /// The preset drawn (None when ITA° was drawn from a range).
    pub preset: Option<String>,
    /// The person painted: ITA°, sex, age.
    pub ita_deg: f32,
    /// "male" or "female".
    pub sex: Sex,
    /// Years.
    pub age_years: f32,
    /// The mesh, as the spec names it.
    pub mesh: Option<String>,
    /// The fitted head, as the spec names it.
    pub head: Option<String>,
    /// Texture size, or sizes (each set in its own subdirectory).
    pub size: Sizes,
    /// SHA-256 of every file but report.json, by name.
    pub files: BTreeMap<String, String>,
}

impl BatchSpec {
    /// Parses a spec; `origin` names it in errors.
    pub fn parse(text: &str, origin: &str) -> Result<Self> {
        let spec: BatchSpec = toml::from_str(text).map_err(|e| {
            derma_core::Invalid::new(
                format!("batch spec '{origin}'"),
                "a valid batch spec (TOML)",
                e.to_string().trim(),
            )
        })?;
        spec.validate(origin)?;
        Ok(spec)
    }

    /// Reads a spec file and resolves its relative paths against its directory.
    pub fn read(path: &Path) -> Result<Self> {
        let text = std::fs::read_to_string(path).map_err(|e| {
            BatchError::from(derma_core::CoreError::Format {
                path: path.to_path_buf(),
                message: format!("cannot read the batch spec ({e})"),
            })
        })?;
        let mut spec = Self::parse(&text, &path.display().to_string())?;
        // Resolved from the spec's real place, so a rerun that spells its path otherwise
        // (relative, absolute, through a link) stores the same spec.
        let real = std::fs::canonicalize(path).map_err(|e| {
            BatchError::from(derma_core::CoreError::Format {
                path: path.to_path_buf(),
                message: format!("cannot resolve ({e})"),
            })
        })?;
        let dir = real.parent().unwrap_or(Path::new(""));
        let resolve = |p: &mut String| {
            if !Path::new(p.as_str()).is_absolute() {
                *p = dir.join(&*p).display().to_string();
            }
        };
        spec.meshes.iter_mut().for_each(resolve);
        spec.heads.iter_mut().for_each(resolve);
        spec.config.iter_mut().for_each(resolve);
        // Every input is there before the first identity is painted.
        let named = (spec.meshes.iter().map(|p| ("meshes", p)))
            .chain(spec.heads.iter().map(|p| ("heads", p)))
            .chain(spec.config.iter().map(|p| ("config", p)));
        for (key, p) in named {
            if !Path::new(p).exists() {
                return Err(BatchError::from(derma_core::CoreError::Format {
                    path: path.to_path_buf(),
                    message: format!("{key}: '{p}' does not exist"),
                }));
            }
        }
        Ok(spec)
    }

    fn validate(&self, origin: &str) -> Result<()> {
        let bad = |key: &str, expected: &str, got: &str| -> Result<()> {
            Err(
                derma_core::Invalid::new(format!("{key} in batch spec '{origin}'"), expected, got)
                    .into(),
            )
        };
        if self.count == 0 {
            return bad("count", "at least one identity", "0");
        }
        let sizes = self.size.dirs();
        if sizes.is_empty() {
            return bad("size", "a size or a list of sizes", "an empty list");
        }
        for (n, _) in &sizes {
            if !(16..=16384).contains(n) {
                return bad("size", "16 … 16384 texels", &format!("{n} texels"));
            }
        }
        if sizes
            .iter()
            .enumerate()
            .any(|(i, a)| sizes[..i].iter().any(|b| b.0 == a.0))
        {
            return bad("size", "each size once", "a size listed twice");
        }
        for p in &self.presets {
            if Preset::parse(p).is_none() {
                let all = Preset::ALL.map(|p| p.name()).join(", ");
                return bad("presets", &format!("one of {all}"), &format!("'{p}'"));
            }
        }
        if let Some([lo, hi]) = self.ita_deg {
            if !self.presets.is_empty() {
                return bad("ita_deg", "either presets or ita_deg", "both");
            }
            if !(lo.is_finite() && hi.is_finite() && lo <= hi && lo >= -90.0 && hi <= 90.0) {
                return bad(
                    "ita_deg",
                    "[min, max] with −90 ≤ min ≤ max ≤ 90",
                    &format!("[{lo}, {hi}]"),
                );
            }
        }
        if !(0.0..=1.0).contains(&self.male) {
            return bad("male", "a probability in [0, 1]", &self.male.to_string());
        }
        let [a0, a1] = self.age_years;
        if !(a0.is_finite() && a1.is_finite() && 0.0 <= a0 && a0 <= a1 && a1 <= 120.0) {
            return bad(
                "age_years",
                "[min, max] with 0 ≤ min ≤ max ≤ 120",
                &format!("[{a0}, {a1}]"),
            );
        }
        if !self.meshes.is_empty() && !self.heads.is_empty() {
            return bad("heads", "either meshes or heads", "both");
        }
        for f in &self.outputs {
            if derma_skin::outputs::output(f).is_none() {
                let all: Vec<&str> = derma_skin::outputs::OUTPUTS
                    .iter()
                    .map(|o| o.file)
                    .collect();
                return bad(
                    "outputs",
                    &format!("one of {}", all.join(", ")),
                    &format!("'{f}'"),
                );
            }
        }
        Ok(())
    }

    /// Identity i's draws (its files empty): four uniforms of `Philox(seed, STREAM)` at index i
    /// for tone, sex, age and mesh, and a second draw for its skin seed.
    pub fn identity(&self, i: usize) -> Identity {
        let rng = Philox::new(self.seed, STREAM);
        let [u_tone, u_sex, u_age, u_mesh] = rng.uniform4(i as u64, 0);
        let pick = |u: f32, n: usize| ((u * n as f32) as usize).min(n - 1);
        let w = rng.u32x4_sub(i as u64, 1);
        // 53 bits: exact as a JSON number in every reader (Python, JavaScript) and in TOML.
        let seed = (u64::from(w[0]) << 21) | u64::from(w[1] >> 11);
        let sex = if u_sex < self.male {
            Sex::Male
        } else {
            Sex::Female
        };
        let [a0, a1] = self.age_years;
        let age_years = ((a0 + u_age * (a1 - a0)) * 10.0).round() / 10.0;
        let (preset, ita_deg) = match self.ita_deg {
            Some([lo, hi]) => (None, lo + u_tone * (hi - lo)),
            None => {
                let names: Vec<&str> = if self.presets.is_empty() {
                    Preset::ALL.iter().map(|p| p.name()).collect()
                } else {
                    self.presets.iter().map(String::as_str).collect()
                };
                let p = Preset::parse(names[pick(u_tone, names.len())]).expect("validated");
                (Some(p.name().to_string()), p.target_ita_deg())
            }
        };
        let choose =
            |list: &[String]| (!list.is_empty()).then(|| list[pick(u_mesh, list.len())].clone());
        Identity {
            index: i,
            dir: dir_name(i, self.count),
            seed,
            preset,
            ita_deg,
            sex,
            age_years,
            mesh: choose(&self.meshes),
            head: choose(&self.heads),
            size: self.size.clone(),
            files: BTreeMap::new(),
        }
    }
}

/// Identity i's directory name: its index, zero-padded to the count's digits (at least 6).
pub fn dir_name(i: usize, count: usize) -> String {
    let digits = count.saturating_sub(1).to_string().len().max(6);
    format!("{i:0digits$}")
}

#[cfg(test)]
mod tests {
    use super::*;

    fn spec(extra: &str) -> BatchSpec {
        BatchSpec::parse(&format!("count = 6000\nseed = 4\n{extra}"), "test").unwrap()
    }

    #[test]
    fn draws_follow_the_spec_s_distributions() {
        let all = spec("male = 0.3\nage_years = [30.0, 40.0]");
        let ids: Vec<Identity> = (0..all.count).map(|i| all.identity(i)).collect();
        // Presets uniform: each of six within four standard deviations of 1000.
        let sd = (6000.0f64 * (1.0 / 6.0) * (5.0 / 6.0)).sqrt();
        for p in Preset::ALL {
            let n = ids
                .iter()
                .filter(|d| d.preset.as_deref() == Some(p.name()))
                .count();
            assert!((n as f64 - 1000.0).abs() < 4.0 * sd, "{}: {n}", p.name());
            assert!(ids
                .iter()
                .filter(|d| d.preset.as_deref() == Some(p.name()))
                .all(|d| d.ita_deg == p.target_ita_deg()));
        }
        let male = ids.iter().filter(|d| d.sex == Sex::Male).count() as f64;
        let sd = (6000.0f64 * 0.3 * 0.7).sqrt();
        assert!((male - 1800.0).abs() < 4.0 * sd, "{male}");
        assert!(ids
            .iter()
            .all(|d| (30.0..=40.0).contains(&d.age_years) && (d.age_years * 10.0).fract() == 0.0));
        let mean_age = ids.iter().map(|d| d.age_years as f64).sum::<f64>() / 6000.0;
        assert!((mean_age - 35.0).abs() < 0.2, "{mean_age}");
        // Every identity its own seed.
        let seeds: std::collections::BTreeSet<u64> = ids.iter().map(|d| d.seed).collect();
        assert_eq!(seeds.len(), 6000);
        assert!(seeds.iter().all(|&s| s < 1 << 53));
    }

    #[test]
    fn ranges_lists_and_the_ends_of_probability() {
        let s = spec("ita_deg = [-20.0, 10.0]\nmale = 0.0\nmeshes = [\"a.obj\", \"b.obj\"]");
        let ids: Vec<Identity> = (0..s.count).map(|i| s.identity(i)).collect();
        assert!(ids.iter().all(|d| d.preset.is_none()
            && (-20.0..=10.0).contains(&d.ita_deg)
            && d.sex == Sex::Female
            && d.head.is_none()));
        let a = ids
            .iter()
            .filter(|d| d.mesh.as_deref() == Some("a.obj"))
            .count();
        assert!((2800..3200).contains(&a), "{a}");
        let s = spec("presets = [\"tan\", \"dark\"]\nmale = 1.0");
        assert!((0..100).all(|i| {
            let d = s.identity(i);
            d.sex == Sex::Male && ["tan", "dark"].contains(&d.preset.as_deref().unwrap())
        }));
    }

    #[test]
    fn an_identity_depends_on_its_index_and_the_seed_alone() {
        let small = BatchSpec::parse("count = 8\nseed = 9", "t").unwrap();
        let large = BatchSpec::parse("count = 8000000\nseed = 9", "t").unwrap();
        let other = BatchSpec::parse("count = 8\nseed = 10", "t").unwrap();
        for i in 0..8 {
            let (a, b) = (small.identity(i), large.identity(i));
            assert_eq!(
                (a.seed, a.preset, a.age_years),
                (b.seed, b.preset, b.age_years)
            );
            assert_eq!(
                (a.dir.as_str(), b.dir.as_str()),
                (&*format!("{i:06}"), &*format!("{i:07}"))
            );
            assert_ne!(a.seed, other.identity(i).seed);
        }
    }

    #[test]
    fn a_spec_round_trips_through_the_batch_directory_s_copy() {
        for extra in [
            "ita_deg = [0.0, 30.0]\nglb = true\nappearance = \"analytic\"",
            "size = [256, 1024]\noutputs = [\"normal.png\"]",
        ] {
            let s = spec(extra);
            let text = toml::to_string(&s).unwrap();
            assert_eq!(BatchSpec::parse(&text, "copy").unwrap(), s, "{text}");
        }
    }
}

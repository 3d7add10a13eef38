//! The skin-colour lookup table of Jimenez et al. 2010 (§6, eq. 7, fig. 9): RGB over
//! u = ∛C_m (melanin) and v = ∛C_hd (dermal hemoglobin), with a 61 % eumelanin blend and
//! epidermal hemoglobin C_he = 0.25 C_hd, each entry the total diffuse reflectance of the
//! optics crate's Monte Carlo skin under diffuse light.
//!
//! Every entry uses the same photon seed (common random numbers), so the table is smooth in
//! its parameters: neighbouring entries share their random paths and differ only by physics.

use crate::error::{Result, ShadingError};
use derma_core::color::{reflectance_to_linear_srgb, Spectrum};
use derma_core::dtab::{Dtab, DtabAxis, DtabHeader, DtabValue};
use derma_core::gpu::Device;
use derma_core::progress::{Progress, Silent, Unit};
use derma_optics::run::Run;
use derma_optics::specimen::skin_stacks_with_epidermal_blood;
use derma_optics::tally::R_DIFFUSE;
use derma_optics::transport::Incidence;
use derma_optics::yellow_pigments::YellowPigments;
use derma_optics::BioTexel;

/// The committed table (see [`SkinColorLut::builtin`]).
pub const BUILTIN_LUT: &[u8] = include_bytes!("../data/skin-color-lut.dtab");

/// Settings of the LUT.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LutOptions {
    /// Entries per axis.
    pub size: usize,
    /// Photons per entry.
    pub photons: u64,
    /// Seed of the simulations.
    pub seed: u64,
    /// Eumelanin share of melanin, β_m = 0.61 (Jimenez et al. 2010, fig. 9).
    pub eumelanin: f64,
    /// C_he / C_hd = 0.25 (Jimenez et al. 2010, §6).
    pub epidermal_ratio: f64,
    /// Top of the melanin axis, C_m ≤ 0.5 (Jimenez et al. 2010, table 1).
    pub melanin_max: f64,
    /// Top of the dermal hemoglobin axis, C_hd ≤ 0.32 (Jimenez et al. 2010, table 1).
    pub blood_max: f64,
    /// The rest of the specimen: BioSpec's fair defaults ([`BioTexel::FAIR`]).
    pub oxygenation: f64,
    /// Stratum corneum thickness, µm.
    pub stratum_corneum_um: f64,
    /// Epidermis thickness, µm.
    pub epidermis_um: f64,
    /// β-carotene and bilirubin (BioSpec's baselines; none in tables made before them).
    pub yellow: YellowPigments,
}

impl Default for LutOptions {
    /// 32 × 32 entries of 2·10⁴ photons: about 1 % colour noise per entry (41 wavelengths,
    /// ~500 photons each) and a couple of minutes on two cores.
    fn default() -> Self {
        Self {
            size: 32,
            photons: 20_000,
            seed: 1,
            eumelanin: 0.61,
            epidermal_ratio: 0.25,
            melanin_max: 0.5,
            blood_max: 0.32,
            oxygenation: BioTexel::FAIR.oxygenation as f64,
            stratum_corneum_um: BioTexel::FAIR.stratum_corneum_um as f64,
            epidermis_um: BioTexel::FAIR.epidermis_um as f64,
            yellow: YellowPigments::BIOSPEC,
        }
    }
}

/// The table: `rgb[v * size + u]`, linear sRGB under D65.
#[derive(Clone, Debug, PartialEq)]
pub struct SkinColorLut {
    /// How the table was made (and its axis tops).
    pub options: LutOptions,
    /// Entries `rgb[v × size + u]`, linear sRGB under D65.
    pub rgb: Vec<[f32; 3]>,
}

/// Total diffuse reflectance (linear sRGB) of skin with melanin `c_m` and dermal blood `c_hd`.
pub fn entry_color(opts: &LutOptions, c_m: f64, c_hd: f64, device: Device) -> Result<[f64; 3]> {
    let bio = BioTexel {
        melanin: c_m as f32,
        pheomelanin: (1.0 - opts.eumelanin) as f32,
        blood: c_hd as f32,
        oxygenation: opts.oxygenation as f32,
        stratum_corneum_um: opts.stratum_corneum_um as f32,
        epidermis_um: opts.epidermis_um as f32,
    };
    let run = Run {
        stacks: skin_stacks_with_epidermal_blood(&bio, &opts.yellow, opts.epidermal_ratio * c_hd),
        photons: opts.photons,
        seed: opts.seed,
        incidence: Incidence::ArcsinZenith,
        brdf: None,
        profile: None,
        channel_weights: Vec::new(),
    };
    let (t, _) = derma_optics::backend::run_on(&run, device, &Silent)?;
    let r: Spectrum =
        std::array::from_fn(|i| t.per_lambda[i][R_DIFFUSE] / t.per_lambda_count[i].max(1) as f64);
    Ok(reflectance_to_linear_srgb(&r))
}

impl SkinColorLut {
    /// Node value of axis position `i` for an axis topping at `max`: (i/(n−1) · ∛max)³.
    pub fn node(&self, i: usize, max: f64) -> f64 {
        let u = i as f64 / (self.options.size - 1) as f64 * max.cbrt();
        u * u * u
    }

    /// Simulates every entry (one stage, advancing by entries).
    pub fn build(opts: LutOptions, device: Device, progress: &dyn Progress) -> Result<Self> {
        if opts.size < 2 {
            return Err(ShadingError::Invalid(derma_core::Invalid::new(
                "LUT size",
                "at least 2",
                opts.size,
            )));
        }
        if opts.photons == 0 {
            return Err(ShadingError::Invalid(derma_core::Invalid::new(
                "photons per LUT entry",
                "at least 1",
                opts.photons,
            )));
        }
        for (name, v) in [
            ("eumelanin", opts.eumelanin),
            ("epidermal ratio", opts.epidermal_ratio),
            ("melanin max", opts.melanin_max),
            ("blood max", opts.blood_max),
        ] {
            if !(0.0..=1.0).contains(&v) {
                return Err(ShadingError::Invalid(derma_core::Invalid::new(
                    name,
                    "a value in [0, 1]",
                    v,
                )));
            }
        }
        let device = device.resolve().map_err(derma_optics::OpticsError::from)?;
        progress.stage(
            "skin-color LUT",
            (opts.size * opts.size) as u64,
            Unit::Entries,
        );
        let mut lut = Self {
            options: opts,
            rgb: Vec::with_capacity(opts.size * opts.size),
        };
        for v in 0..opts.size {
            for u in 0..opts.size {
                let c = entry_color(
                    &opts,
                    lut.node(u, opts.melanin_max),
                    lut.node(v, opts.blood_max),
                    device,
                )?;
                lut.rgb.push(c.map(|x| x as f32));
                progress.advance(1);
            }
        }
        Ok(lut)
    }

    /// The table of an [`Appearance`](crate::appearance::Appearance) over melanin C_m and
    /// dermal blood C_hd (nodes as [`SkinColorLut::build`]'s, `size`² of them up to the
    /// maxima), every other parameter held at `at`'s (its melanin and blood ignored; no
    /// epidermal blood): the colour model a skin set paints with, for an inversion
    /// (`derma photo chromophores`) whose maps that set then paints back to the same colour.
    pub fn from_appearance(
        appearance: &dyn crate::appearance::Appearance,
        at: &BioTexel,
        size: usize,
        melanin_max: f64,
        blood_max: f64,
    ) -> Self {
        let options = LutOptions {
            size: size.max(2),
            photons: 0,
            seed: 0,
            eumelanin: 1.0 - at.pheomelanin as f64,
            epidermal_ratio: 0.0,
            melanin_max,
            blood_max,
            oxygenation: at.oxygenation as f64,
            stratum_corneum_um: at.stratum_corneum_um as f64,
            epidermis_um: at.epidermis_um as f64,
            yellow: YellowPigments::BIOSPEC,
        };
        let mut lut = Self {
            options,
            rgb: Vec::with_capacity(options.size * options.size),
        };
        for v in 0..options.size {
            for u in 0..options.size {
                let bio = BioTexel {
                    melanin: lut.node(u, melanin_max) as f32,
                    blood: lut.node(v, blood_max) as f32,
                    ..*at
                };
                lut.rgb.push(appearance.albedo(&bio));
            }
        }
        lut
    }

    /// Jimenez et al. 2010 eq. 7, normalised to [0, 1]: (∛C_m / ∛C_m,max, ∛C_hd / ∛C_hd,max).
    pub fn uv(&self, c_m: f64, c_hd: f64) -> (f64, f64) {
        (
            (c_m.max(0.0) / self.options.melanin_max).cbrt().min(1.0),
            (c_hd.max(0.0) / self.options.blood_max).cbrt().min(1.0),
        )
    }

    /// Bilinear lookup, as a GPU samples the texture.
    pub fn lookup(&self, c_m: f64, c_hd: f64) -> [f64; 3] {
        let (u, v) = self.uv(c_m, c_hd);
        self.lookup_uv(u, v)
    }

    /// Bilinear lookup at the table's own coordinates (u, v) = (∛(C_m / max), ∛(C_hd / max)) in
    /// [0, 1]² (clamped): what an inversion searching that square calls.
    pub fn lookup_uv(&self, u: f64, v: f64) -> [f64; 3] {
        let n = self.options.size;
        let (u, v) = (u.clamp(0.0, 1.0), v.clamp(0.0, 1.0));
        let (x, y) = (u * (n - 1) as f64, v * (n - 1) as f64);
        let (i, j) = ((x as usize).min(n - 2), (y as usize).min(n - 2));
        let (fx, fy) = (x - i as f64, y - j as f64);
        let at = |a: usize, b: usize| self.rgb[b * n + a];
        std::array::from_fn(|c| {
            let top = at(i, j)[c] as f64 * (1.0 - fx) + at(i + 1, j)[c] as f64 * fx;
            let bot = at(i, j + 1)[c] as f64 * (1.0 - fx) + at(i + 1, j + 1)[c] as f64 * fx;
            top * (1.0 - fy) + bot * fy
        })
    }

    /// As a `.dtab` over (∛C_hd, ∛C_m), value "linear_srgb".
    pub fn to_dtab(&self) -> Dtab {
        let n = self.options.size;
        let ax = |name: &str, max: f64| DtabAxis {
            name: name.into(),
            values: (0..n)
                .map(|i| i as f64 / (n - 1) as f64 * max.cbrt())
                .collect(),
        };
        let o = &self.options;
        Dtab {
            header: DtabHeader {
                axes: vec![
                    ax("blood_cbrt", o.blood_max),
                    ax("melanin_cbrt", o.melanin_max),
                ],
                values: vec![DtabValue {
                    name: "linear_srgb".into(),
                    len: 3,
                }],
                meta: serde_json::json!({
                    "kind": "derma skin colour LUT",
                    "source": "Jimenez et al. 2010 §6 eq. 7: u = cbrt(C_m), v = cbrt(C_hd); total diffuse reflectance of derma's Monte Carlo skin under diffuse light",
                    "eumelanin_blend": o.eumelanin,
                    "epidermal_hemoglobin_ratio": o.epidermal_ratio,
                    "melanin_max": o.melanin_max,
                    "blood_max": o.blood_max,
                    "oxygenation": o.oxygenation,
                    "stratum_corneum_um": o.stratum_corneum_um,
                    "epidermis_um": o.epidermis_um,
                    "yellow_pigments": o.yellow,
                    "photons_per_entry": o.photons,
                    "seed": o.seed,
                    "png": "u (melanin) along x, v (hemoglobin) along y from the top; sRGB-encoded 16-bit",
                }),
            },
            data: self.rgb.iter().flatten().copied().collect(),
        }
    }

    /// Reads a table written by [`Self::to_dtab`]; `what` names it in errors.
    pub fn from_dtab(t: &Dtab, what: &str) -> Result<Self> {
        let bad = |part: &str, expected: &str, got: String| {
            ShadingError::Invalid(derma_core::Invalid::new(
                format!("{part} of skin-colour LUT '{what}'"),
                expected,
                got,
            ))
        };
        let axes = &t.header.axes;
        if axes.len() != 2 || axes[0].name != "blood_cbrt" || axes[1].name != "melanin_cbrt" {
            return Err(bad(
                "axes",
                "blood_cbrt, melanin_cbrt",
                format!(
                    "{:?}",
                    axes.iter().map(|a| a.name.as_str()).collect::<Vec<_>>()
                ),
            ));
        }
        let n = axes[0].values.len();
        if n < 2 || axes[1].values.len() != n || t.header.offset("linear_srgb") != Some((0, 3)) {
            let values = t
                .header
                .values
                .iter()
                .map(|v| format!("{}[{}]", v.name, v.len))
                .collect::<Vec<_>>();
            return Err(bad(
                "layout",
                "a square table of at least 2×2 linear_srgb triples",
                format!(
                    "{n}×{} nodes of {}",
                    axes[1].values.len(),
                    values.join(", ")
                ),
            ));
        }
        // The axis stores cube roots: undo, rounded to 12 decimals (0.5, not 0.5000000000000001).
        let top = |a: &derma_core::dtab::DtabAxis| (a.values[n - 1].powi(3) * 1e12).round() / 1e12;
        let meta = &t.header.meta;
        let num = |k: &str, default: f64| meta.get(k).and_then(|v| v.as_f64()).unwrap_or(default);
        let d = LutOptions::default();
        let options = LutOptions {
            size: n,
            photons: meta
                .get("photons_per_entry")
                .and_then(|v| v.as_u64())
                .unwrap_or(d.photons),
            seed: meta.get("seed").and_then(|v| v.as_u64()).unwrap_or(d.seed),
            eumelanin: num("eumelanin_blend", d.eumelanin),
            epidermal_ratio: num("epidermal_hemoglobin_ratio", d.epidermal_ratio),
            melanin_max: top(&axes[1]),
            blood_max: top(&axes[0]),
            oxygenation: num("oxygenation", d.oxygenation),
            stratum_corneum_um: num("stratum_corneum_um", d.stratum_corneum_um),
            epidermis_um: num("epidermis_um", d.epidermis_um),
            yellow: match meta.get("yellow_pigments") {
                None => YellowPigments::NONE,
                Some(v) => serde_json::from_value(v.clone()).map_err(|e| {
                    bad(
                        "meta.yellow_pigments",
                        "yellow pigment concentrations",
                        e.to_string(),
                    )
                })?,
            },
        };
        if !(options.melanin_max > 0.0 && options.blood_max > 0.0) {
            return Err(bad(
                "axis tops",
                "positive values",
                format!(
                    "melanin {}, blood {}",
                    options.melanin_max, options.blood_max
                ),
            ));
        }
        let rgb = t
            .data
            .chunks_exact(3)
            .map(|c| [c[0], c[1], c[2]])
            .collect::<Vec<_>>();
        if rgb.len() != n * n || rgb.iter().flatten().any(|v| !v.is_finite()) {
            let not_finite = rgb
                .iter()
                .filter(|c| c.iter().any(|v| !v.is_finite()))
                .count();
            return Err(bad(
                "payload",
                &format!("{} finite triples ({n}²)", n * n),
                format!("{} triples, {not_finite} of them not finite", rgb.len()),
            ));
        }
        Ok(Self { options, rgb })
    }

    /// The committed 32 × 32 table (`data/skin-color-lut.dtab`, built by `derma match lut`;
    /// see docs/matching.md), so the rig and the main job need no precompute.
    pub fn builtin() -> Self {
        let t = Dtab::from_bytes(BUILTIN_LUT, std::path::Path::new("skin-color-lut.dtab"))
            .expect("the committed LUT parses (tested)");
        Self::from_dtab(&t, "builtin").expect("the committed LUT is valid (tested)")
    }

    /// Writes the table by `path`'s extension: `.dtab` (linear, with its JSON sidecar) or
    /// `.png` (16-bit, sRGB-encoded, u along x and v down, for engines and viewers).
    pub fn write(&self, path: &std::path::Path) -> Result<()> {
        match path.extension().and_then(|e| e.to_str()) {
            Some("dtab") => Ok(self.to_dtab().write(path)?),
            Some("png") => {
                let ch = self.channels().map(|mut m| {
                    m.data_mut()
                        .iter_mut()
                        .for_each(|v| *v = derma_core::color::srgb_encode(v.clamp(0.0, 1.0)));
                    m
                });
                Ok(derma_core::image_io::write_png16(
                    path,
                    &[&ch[0], &ch[1], &ch[2]],
                )?)
            }
            _ => Err(ShadingError::Invalid(derma_core::Invalid::new(
                format!("skin-color LUT file '{}'", path.display()),
                "a .png or .dtab file name",
                path.extension().map_or("no extension".to_string(), |e| {
                    format!("'.{}'", e.to_string_lossy())
                }),
            ))),
        }
    }

    /// The table as images: three channels of `size × size`, linear.
    pub fn channels(&self) -> [derma_core::Map; 3] {
        let n = self.options.size;
        derma_core::Map::planes(n, n, |i| self.rgb[i])
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn small() -> SkinColorLut {
        let o = LutOptions {
            size: 4,
            photons: 6000,
            ..Default::default()
        };
        SkinColorLut::build(o, Device::Cpu, &Silent).unwrap()
    }

    #[test]
    fn monotonic_in_melanin_and_blood_reddens() {
        let lut = small();
        let n = lut.options.size;
        for v in 0..n {
            for u in 1..n {
                let (a, b) = (lut.rgb[v * n + u - 1], lut.rgb[v * n + u]);
                for c in 0..3 {
                    assert!(b[c] < a[c], "row {v}, u {u}, channel {c}: {a:?} → {b:?}");
                }
            }
        }
        // More hemoglobin at low melanin: green drops more than red (skin reddens).
        let (a, b) = (lut.rgb[0], lut.rgb[(n - 1) * n]);
        assert!(b[1] / a[1] < b[0] / a[0], "{a:?} {b:?}");
        // Pale skin is bright, dark skin is dark.
        assert!(
            lut.rgb[0][0] > 0.4 && lut.rgb[n - 1][0] < 0.2,
            "{:?}",
            lut.rgb
        );
        // Lookup at nodes returns the node; the cube-root axis puts C_m = 0.5·(1/3)³ at u = 1/3.
        let c = lut.lookup(lut.node(1, 0.5), 0.0);
        assert!((c[0] - lut.rgb[1][0] as f64).abs() < 1e-6);
        let (u, _) = lut.uv(0.5 / 27.0, 0.0);
        assert!((u - 1.0 / 3.0).abs() < 1e-12);
    }

    #[test]
    fn dtab_round_trip_and_builtin() {
        let lut = small();
        let back = SkinColorLut::from_dtab(&lut.to_dtab(), "test").unwrap();
        assert_eq!(back.rgb, lut.rgb);
        assert!((back.options.blood_max - 0.32).abs() < 1e-12);
        assert!((back.options.melanin_max - 0.5).abs() < 1e-12);
        let b = SkinColorLut::builtin();
        assert_eq!(b.options.size, 32);
        assert!((b.options.eumelanin - 0.61).abs() < 1e-12);
        // Fair skin (C_m 0.02, C_hd 0.012): a light, red-leaning colour.
        let c = b.lookup(0.02, 0.012);
        assert!(c[0] > c[1] && c[1] > c[2] && c[0] > 0.3, "{c:?}");
        let mut t = lut.to_dtab();
        t.header.axes.swap(0, 1);
        assert!(SkinColorLut::from_dtab(&t, "swapped").is_err());
    }

    #[test]
    fn deterministic() {
        let o = LutOptions {
            size: 2,
            photons: 2000,
            ..Default::default()
        };
        let a = SkinColorLut::build(o, Device::Cpu, &Silent).unwrap();
        let b = SkinColorLut::build(o, Device::Cpu, &Silent).unwrap();
        assert_eq!(a, b);
    }
}

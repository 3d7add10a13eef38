//! The rig on disk, in the form an engine evaluates at run time (Jimenez et al. 2010 §6): the
//! full-resolution mean-free neutral `h0.exr`, low-resolution scale/bias textures per target,
//! the skin-colour LUT, and `rig.json` describing them. `rig.json` is written last, so a
//! directory with a `rig.json` holds a complete rig; every file is written atomically.

use crate::basis::{check_name, Rig, Target};
use crate::error::{Result, RigError};
use crate::skin_response::SkinResponse;
use derma_core::dtab::Dtab;
use derma_core::image_io::{read_exr_channels, write_exr, write_png16, ExrPrecision};
use derma_core::Map;
use derma_optics::bio::names;
use derma_shading::skin_color_lut::SkinColorLut;
use serde::{Deserialize, Serialize};
use std::path::Path;

/// The rig's shader (the GPU frame runs it), written into every rig directory as `rig.wgsl` for
/// engines, in every build.
pub const SHADER: &str = include_str!("rig.wgsl");

/// The `format` of rig.json.
pub const FORMAT: &str = "derma-rig";
/// The `version` of rig.json this code reads and writes.
pub const VERSION: u32 = 1;

/// `rig.json`.
#[derive(Clone, Debug, Serialize, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct RigJson {
    /// Always [`FORMAT`].
    pub format: String,
    /// Always [`VERSION`].
    pub version: u32,
    /// The evaluation, as a formula an engine can implement.
    pub model: String,
    /// Units of the maps.
    pub units: String,
    /// Full-resolution map size [w, h].
    pub map_size: [usize; 2],
    /// Basis texture size [w, h].
    pub basis_size: [usize; 2],
    /// Disk radius r of the local statistics, texels.
    pub radius_texels: f64,
    /// σ floor ε (absolute).
    pub sigma_floor: f32,
    /// The rig's files.
    pub files: Files,
    /// The skin-colour LUT's layout.
    pub lut: LutJson,
    /// The targets, in weight order.
    pub targets: Vec<TargetJson>,
}

#[derive(Clone, Debug, Serialize, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
/// The files of a rig directory, relative to it.
pub struct Files {
    /// Full resolution, channel `h0`: H_0 = H_n − μ_n (float).
    pub h0: String,
    /// Basis resolution, channels `bias` (μ_n) and `sigma` (σ_n).
    pub neutral: String,
    /// Full resolution, channel `melanin` (C_m), when the rig has one.
    pub melanin: Option<String>,
    /// The LUT as derma's table, as linear float RGB, and as a 16-bit sRGB PNG.
    pub lut_dtab: String,
    /// See `lut_dtab`.
    pub lut_exr: String,
    /// See `lut_dtab`.
    pub lut_png: String,
    /// The run-time evaluation as a WGSL compute shader (the one derma's GPU path runs).
    pub shader: String,
    /// The texture set's skin, when the rig was built from a set.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub skin: Option<SkinFiles>,
}

#[derive(Clone, Debug, Serialize, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
/// The files of a rig built from a texture set ([`crate::skin_response`]).
pub struct SkinFiles {
    /// The set's base colour, 8-bit sRGB (a copy of its base_color.png).
    pub base_color: String,
    /// Full resolution, channels `d1.R`, `d1.G`, `d1.B`, `d2.R`, `d2.G`, `d2.B` (float).
    pub response: String,
    /// The appearance that made the set and its response.
    pub appearance: String,
    /// How a frame's colour is formed from them.
    pub formula: String,
}

/// [`SkinFiles::formula`].
pub const SKIN_FORMULA: &str = "colour (linear sRGB) = srgb_decode(base_color) + d1*x + d2*x^2, \
x = cbrt(H) - cbrt(Hn), Hn = H evaluated with w0 = 1 and g = 1 (the neutral); replaces the LUT colour";

/// Channel names of the response file, d1 then d2.
pub const RESPONSE_CHANNELS: [&str; 6] = ["d1.R", "d1.G", "d1.B", "d2.R", "d2.G", "d2.B"];

#[derive(Clone, Debug, Serialize, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
/// The skin-colour LUT as rig.json describes it.
pub struct LutJson {
    /// Entries per axis.
    pub size: usize,
    /// Top of the melanin axis (volume fraction).
    pub melanin_max: f64,
    /// Top of the dermal blood axis (volume fraction).
    pub blood_max: f64,
    /// How the image is laid out.
    pub layout: String,
}

#[derive(Clone, Debug, Serialize, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
/// One target as rig.json lists it.
pub struct TargetJson {
    /// Its name (a weight name).
    pub name: String,
    /// Basis resolution, channels `scale`, `bias` and `sigma` (σ_i, for transfer).
    pub file: String,
    /// Global hemoglobin scale suggested at full weight.
    pub global_scale: f32,
    /// "map" or "builtin:NAME".
    pub source: String,
}

const MODEL: &str = "Jimenez et al. 2010 eq. 6: H = g * (w0*bias0 + sum_i w_i*bias_i + h0 * (w0 + sum_i w_i*scale_i)), \
w0 = 1 - sum_i w_i, bias0 = neutral.bias, basis textures sampled bilinearly (clamp to edge); \
colour = LUT(u = cbrt(C_m / melanin_max), v = cbrt(H / blood_max)) sampled bilinearly (eq. 7)";

fn lut_json(lut: &SkinColorLut) -> LutJson {
    LutJson {
        size: lut.options.size,
        melanin_max: lut.options.melanin_max,
        blood_max: lut.options.blood_max,
        layout: "u (melanin, cube-root axis) along x from the left, v (dermal blood, cube-root axis) along y from the top; texel centres at the nodes".into(),
    }
}

/// Writes `rig` (and the LUT it is evaluated with) into `dir`.
pub fn save(rig: &Rig, lut: &SkinColorLut, dir: &Path) -> Result<RigJson> {
    derma_core::atomic::ensure_writable_dir(dir)?;
    derma_core::atomic::ensure_writable_dir(&dir.join("targets"))?;
    write_exr(&dir.join("h0.exr"), &[("h0", &rig.h0)], ExrPrecision::F32)?;
    write_exr(
        &dir.join("neutral.exr"),
        &[("bias", &rig.neutral_mean), ("sigma", &rig.neutral_sigma)],
        ExrPrecision::F32,
    )?;
    if let Some(m) = &rig.melanin {
        write_exr(
            &dir.join("melanin.exr"),
            &[(names::MELANIN, m)],
            ExrPrecision::F32,
        )?;
    }
    let mut targets = Vec::new();
    for t in &rig.targets {
        let file = format!("targets/{}.exr", t.name);
        write_exr(
            &dir.join(&file),
            &[("bias", &t.bias), ("scale", &t.scale), ("sigma", &t.sigma)],
            ExrPrecision::F32,
        )?;
        targets.push(TargetJson {
            name: t.name.clone(),
            file,
            global_scale: t.global_scale,
            source: t.source.clone(),
        });
    }
    lut.to_dtab().write(&dir.join("skin_color_lut.dtab"))?;
    let [r, g, b] = lut.channels();
    write_exr(
        &dir.join("skin_color_lut.exr"),
        &[("R", &r), ("G", &g), ("B", &b)],
        ExrPrecision::F32,
    )?;
    let enc = |m: &Map| m.map(derma_core::color::srgb_encode);
    write_png16(
        &dir.join("skin_color_lut.png"),
        &[&enc(&r), &enc(&g), &enc(&b)],
    )?;
    derma_core::atomic::write_bytes(&dir.join("rig.wgsl"), SHADER.as_bytes())?;
    let skin = match &rig.skin {
        Some(s) => Some(save_skin(s, dir)?),
        None => None,
    };
    let (w, h) = rig.size();
    let (bw, bh) = rig.basis_size();
    let json = RigJson {
        format: FORMAT.into(),
        version: VERSION,
        model: MODEL.into(),
        units: "hemoglobin: dermal blood volume fraction C_hd; melanin: epidermal melanosome volume fraction C_m; radius in texels of the full-resolution maps".into(),
        map_size: [w, h],
        basis_size: [bw, bh],
        radius_texels: rig.radius,
        sigma_floor: rig.sigma_floor,
        files: Files {
            h0: "h0.exr".into(),
            neutral: "neutral.exr".into(),
            melanin: rig.melanin.as_ref().map(|_| "melanin.exr".into()),
            lut_dtab: "skin_color_lut.dtab".into(),
            lut_exr: "skin_color_lut.exr".into(),
            lut_png: "skin_color_lut.png".into(),
            shader: "rig.wgsl".into(),
            skin,
        },
        lut: lut_json(lut),
        targets,
    };
    derma_core::report::write_json(
        &dir.join("rig.json"),
        &json,
        derma_core::report::JsonFormat::DATA_PRETTY,
    )?;
    Ok(json)
}

fn save_skin(s: &SkinResponse, dir: &Path) -> Result<SkinFiles> {
    let (w, h) = s.size();
    let codes = Map::planes(w, h, |i| s.base[i].map(|c| c as f32 / 255.0));
    derma_core::image_io::write_png8(
        &dir.join("base_color.png"),
        &[&codes[0], &codes[1], &codes[2]],
    )?;
    let planes: Vec<(&str, &Map)> = RESPONSE_CHANNELS
        .iter()
        .zip(s.d1.iter().chain(&s.d2))
        .map(|(n, m)| (*n, m))
        .collect();
    write_exr(&dir.join("skin_response.exr"), &planes, ExrPrecision::F32)?;
    Ok(SkinFiles {
        base_color: "base_color.png".into(),
        response: "skin_response.exr".into(),
        appearance: s.appearance.clone(),
        formula: SKIN_FORMULA.into(),
    })
}

fn load_skin(dir: &Path, f: &SkinFiles, full: (usize, usize)) -> Result<SkinResponse> {
    let bp = dir.join(&f.base_color);
    let img = derma_core::image_io::read_rgb(&bp)?;
    let m = &img.channels;
    if (m[0].width(), m[0].height()) != full {
        return Err(RigError::File {
            path: bp,
            detail: format!(
                "is {}×{}; rig.json says {}×{}",
                m[0].width(),
                m[0].height(),
                full.0,
                full.1
            ),
        });
    }
    let code = |v: f32| (v * 255.0).round().clamp(0.0, 255.0) as u8;
    let base = (0..full.0 * full.1)
        .map(|i| std::array::from_fn(|c| code(m[c].data()[i])))
        .collect();
    let rp = dir.join(&f.response);
    let c = read_exr_channels(&rp)?;
    let p: Vec<Map> = RESPONSE_CHANNELS
        .iter()
        .map(|n| channel(&rp, &c, n, full))
        .collect::<Result<_>>()?;
    let [a, b, cc, d, e, g]: [Map; 6] = p.try_into().expect("six channels");
    SkinResponse::from_parts(base, [a, b, cc], [d, e, g], &f.appearance)
}

fn channel(path: &Path, chans: &[(String, Map)], name: &str, size: (usize, usize)) -> Result<Map> {
    let m = chans
        .iter()
        .find(|(n, _)| n == name)
        .map(|(_, m)| m.clone())
        .ok_or_else(|| RigError::File {
            path: path.to_path_buf(),
            detail: format!(
                "no channel '{name}'; found {:?}",
                chans.iter().map(|c| c.0.as_str()).collect::<Vec<_>>()
            ),
        })?;
    if (m.width(), m.height()) != size {
        return Err(RigError::File {
            path: path.to_path_buf(),
            detail: format!(
                "channel '{name}' is {}×{}; rig.json says {}×{}",
                m.width(),
                m.height(),
                size.0,
                size.1
            ),
        });
    }
    Ok(m)
}

/// Reads a rig directory written by [`save`]: the rig and its LUT.
pub fn load(dir: &Path) -> Result<(Rig, SkinColorLut, RigJson)> {
    let jp = dir.join("rig.json");
    let text = std::fs::read_to_string(&jp).map_err(|e| RigError::File {
        path: jp.clone(),
        detail: format!(
            "cannot read ({e}); is '{}' a rig directory from `derma rig build`?",
            dir.display()
        ),
    })?;
    let json: RigJson = serde_json::from_str(&text).map_err(|e| RigError::File {
        path: jp.clone(),
        detail: e.to_string(),
    })?;
    if json.format != FORMAT || json.version != VERSION {
        return Err(RigError::File {
            path: jp,
            detail: format!(
                "format '{}' version {}; expected '{FORMAT}' version {VERSION}",
                json.format, json.version
            ),
        });
    }
    let full = (json.map_size[0], json.map_size[1]);
    let basis = (json.basis_size[0], json.basis_size[1]);
    let read = |file: &str| -> Result<(std::path::PathBuf, Vec<(String, Map)>)> {
        let p = dir.join(file);
        let c = read_exr_channels(&p)?;
        Ok((p, c))
    };
    let (p, c) = read(&json.files.h0)?;
    let h0 = channel(&p, &c, "h0", full)?;
    let (p, c) = read(&json.files.neutral)?;
    let neutral_mean = channel(&p, &c, "bias", basis)?;
    let neutral_sigma = channel(&p, &c, "sigma", basis)?;
    let melanin = match &json.files.melanin {
        Some(f) => {
            let (p, c) = read(f)?;
            Some(channel(&p, &c, names::MELANIN, full)?)
        }
        None => None,
    };
    let mut targets = Vec::new();
    for t in &json.targets {
        check_name(&t.name)?;
        let (p, c) = read(&t.file)?;
        targets.push(Target {
            name: t.name.clone(),
            bias: channel(&p, &c, "bias", basis)?,
            scale: channel(&p, &c, "scale", basis)?,
            sigma: channel(&p, &c, "sigma", basis)?,
            global_scale: t.global_scale,
            source: t.source.clone(),
        });
    }
    let skin = match &json.files.skin {
        Some(f) => Some(load_skin(dir, f, full)?),
        None => None,
    };
    let lp = dir.join(&json.files.lut_dtab);
    let lut = SkinColorLut::from_dtab(&Dtab::read(&lp)?, &lp.display().to_string())?;
    let rig = Rig {
        radius: json.radius_texels,
        h0,
        neutral_mean,
        neutral_sigma,
        sigma_floor: json.sigma_floor,
        targets,
        melanin,
        skin,
    };
    Ok((rig, lut, json))
}

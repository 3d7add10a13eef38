//! `derma.skin`: the main job (docs/skin.md) from Python — the person, size, seed and mesh as
//! arguments, the texture set's maps back as arrays in their files' encodings, a set written on request.

use crate::array::Array;
use crate::errors::message;
use crate::progress::Callback;
use derma_shading::BioTexel;
use derma_skin::features::BioSample;
use derma_skin::regional::{Preset, Sex};
use derma_skin::{AppearanceChoice, SkinConfig, SkinGenerator, TextureSet};
use pyo3::prelude::*;
use pyo3::types::PyDict;
use std::path::PathBuf;

/// What the Python call asked for, as derma-skin's generator takes it: the wrapper's keyword
/// arguments as one dict (every key present), None where the config's value stands. A value
/// of the wrong type or sign is a `DermaError` naming the argument ([`crate::errors::item`]).
pub struct Request {
    size: Option<u32>,
    seed: Option<u64>,
    preset: Option<String>,
    ita_deg: Option<f32>,
    sex: Option<String>,
    age: Option<f32>,
    mesh: Option<PathBuf>,
    head: Option<PathBuf>,
    fields: Option<PathBuf>,
    config: Option<PathBuf>,
    /// "table" (default) or "analytic".
    appearance: Option<String>,
    threads: Option<usize>,
    /// "auto" (default), "cpu" or "gpu".
    device: Option<String>,
}

impl<'py> FromPyObject<'_, 'py> for Request {
    type Error = PyErr;

    fn extract(d: pyo3::Borrowed<'_, 'py, PyAny>) -> PyResult<Self> {
        use crate::errors::item;
        let d = d.cast::<PyDict>()?;
        Ok(Self {
            size: item(&d, "size", "a whole number of texels in [16, 16384]")?,
            seed: item(&d, "seed", "a whole number ≥ 0")?,
            preset: item(&d, "preset", "a preset's name")?,
            ita_deg: item(&d, "ita_deg", "a number (degrees)")?,
            sex: item(&d, "sex", "'male' or 'female'")?,
            age: item(&d, "age", "a number of years")?,
            mesh: item(&d, "mesh", "a path")?,
            head: item(&d, "head", "a path")?,
            fields: item(&d, "fields", "a path")?,
            config: item(&d, "config", "a path")?,
            appearance: item(&d, "appearance", "'table' or 'analytic'")?,
            threads: item(&d, "threads", "a whole number ≥ 1")?,
            device: item(&d, "device", "'auto', 'cpu' or 'gpu'")?,
        })
    }
}

impl Request {
    /// The generator, with `derma skin`'s precedence: the config, then each argument given.
    fn generator<'a>(&self, progress: &'a Callback) -> PyResult<SkinGenerator<'a>> {
        let mut g = match &self.config {
            Some(p) => SkinGenerator::from_config_file(p).map_err(crate::errors::error)?,
            None => SkinGenerator::new(SkinConfig::default()),
        };
        let cfg = g.config_mut();
        if let Some(s) = self.size {
            if !(16..=16384).contains(&s) {
                return Err(crate::errors::invalid(
                    "size",
                    format!("{s}: expected a whole number of texels in [16, 16384]"),
                ));
            }
            cfg.size = s;
        }
        if let Some(s) = self.seed {
            cfg.seed = s;
        }
        if let Some(s) = &self.sex {
            cfg.person.sex = Sex::parse(s).ok_or_else(|| {
                crate::errors::invalid("sex", format!("'{s}': expected 'male' or 'female'"))
            })?;
        }
        if let Some(a) = self.age {
            cfg.person.age_years = a;
        }
        match (&self.preset, self.ita_deg) {
            (Some(_), Some(_)) => {
                return Err(crate::errors::invalid(
                    "ita_deg",
                    "give preset or ita_deg, not both",
                ))
            }
            (Some(p), None) => {
                let preset = Preset::parse(p).ok_or_else(|| {
                    let all = Preset::ALL.map(|p| p.name()).join(", ");
                    crate::errors::invalid("preset", format!("'{p}': expected one of {all}"))
                })?;
                cfg.person = preset.person(cfg.person.sex, cfg.person.age_years);
            }
            (None, Some(ita)) => {
                cfg.person.ita_deg = ita;
                cfg.person.calibrate_melanin = true;
            }
            (None, None) => {}
        }
        let appearance = match self.appearance.as_deref().unwrap_or("table") {
            "table" => AppearanceChoice::Default,
            "analytic" => AppearanceChoice::Analytic,
            a => {
                return Err(crate::errors::invalid(
                    "appearance",
                    format!("'{a}': expected 'table' or 'analytic'"),
                ))
            }
        };
        g = g
            .appearance(appearance)
            .device(crate::errors::device(
                self.device.as_deref().unwrap_or("auto"),
            )?)
            .progress(progress);
        if let Some(m) = &self.mesh {
            g = g.mesh(m);
        }
        if let Some(h) = &self.head {
            g = g.head(h);
        }
        if let Some(f) = &self.fields {
            g = g.fields(f);
        }
        if let Some(n) = self.threads {
            g = g.threads(n);
        }
        Ok(g)
    }
}

/// The fields of a [`BioSample`] in memory order: the samples are viewed as (h, w, 13) float32.
const SAMPLE_CHANNELS: [&str; 13] = [
    "melanin",
    "pheomelanin",
    "blood",
    "oxygenation",
    "stratum_corneum_um",
    "epidermis_um",
    "height_mm",
    "extra.R",
    "extra.G",
    "extra.B",
    "extra.A",
    "lips",
    "furrow_mm",
];

// The view is only right if a sample is exactly these thirteen f32 in this order (both structs
// are `repr(C)`); a change to either struct fails the build here.
const _: () = {
    use std::mem::{offset_of, size_of};
    assert!(size_of::<BioSample>() == 13 * 4);
    assert!(offset_of!(BioSample, tissue) == 0);
    assert!(offset_of!(BioTexel, melanin) == 0);
    assert!(offset_of!(BioTexel, pheomelanin) == 4);
    assert!(offset_of!(BioTexel, blood) == 8);
    assert!(offset_of!(BioTexel, oxygenation) == 12);
    assert!(offset_of!(BioTexel, stratum_corneum_um) == 16);
    assert!(offset_of!(BioTexel, epidermis_um) == 20);
    assert!(offset_of!(BioSample, height_mm) == 24);
    assert!(offset_of!(BioSample, extra) == 28);
    assert!(offset_of!(BioSample, lips) == 44);
    assert!(offset_of!(BioSample, furrow_mm) == 48);
};

/// The set's maps as arrays, rows from the top of the texture (v = 1) as the files store them.
fn maps(mut set: TextureSet) -> Vec<(&'static str, Array)> {
    let (w, h) = (set.render.width, set.render.height);
    let r = &mut set.render;
    let mut out = vec![
        (
            "base_color",
            Array::new::<u8, _>(std::mem::take(&mut r.base_color), &[h, w, 3]),
        ),
        (
            "normal",
            Array::new::<u16, _>(std::mem::take(&mut r.normal), &[h, w, 3]),
        ),
        (
            "roughness",
            Array::new::<u8, _>(std::mem::take(&mut r.roughness), &[h, w]),
        ),
        (
            "specular",
            Array::new::<u8, _>(std::mem::take(&mut r.specular), &[h, w]),
        ),
    ];
    if let Some(ss) = r.subsurface.take() {
        out.push(("sss_color", Array::new::<u8, _>(ss.color, &[h, w, 3])));
        out.push(("sss_radius", Array::new::<u16, _>(ss.radius, &[h, w, 3])));
    }
    let texels = std::mem::take(&mut set.bio.texels);
    out.push((
        "bio",
        Array::new::<f32, _>(texels, &[h, w, SAMPLE_CHANNELS.len()]),
    ));
    out
}

/// Paints a texture set (derma-skin's generator; docs/python.md has the arguments and the
/// arrays' encodings) from `request` (the package's keyword arguments), writes it into `out`
/// when given, and returns its maps and report.
#[pyfunction]
#[pyo3(signature = (request, *, out=None, glb=false, progress=None))]
pub fn skin<'py>(
    py: Python<'py>,
    request: Request,
    out: Option<PathBuf>,
    glb: bool,
    progress: Option<Py<PyAny>>,
) -> PyResult<Bound<'py, PyDict>> {
    let callback = Callback::new(progress);
    let generator = request.generator(&callback)?;
    let made = py.detach(
        || -> Result<(TextureSet, Option<Vec<&'static str>>), String> {
            match &out {
                Some(dir) => {
                    let o = derma_export::skin::run_in_memory(&generator, dir, glb, &callback)
                        .map_err(|e| message(&e))?;
                    Ok((o.set, Some(o.written.files)))
                }
                None => {
                    let size = generator.config().size as usize;
                    generator
                        .config()
                        .validate("the options")
                        .and_then(|()| derma_skin::generate::check_memory(size))
                        .and_then(|()| generator.run())
                        .map(|set| (set, None))
                        .map_err(|e| message(&e))
                }
            }
        },
    );
    drop(generator);
    let notes = callback.finish()?;
    let (set, files) = made.map_err(crate::errors::DermaError::new_err)?;
    let d = PyDict::new(py);
    let info = PyDict::new(py);
    info.set_item("size", set.config.size)?;
    info.set_item("seed", set.config.seed)?;
    info.set_item("appearance", set.appearance)?;
    info.set_item("features", set.features.total())?;
    info.set_item("ita_deg", set.config.person.ita_deg)?;
    info.set_item("sex", set.config.person.sex.name())?;
    info.set_item("age_years", set.config.person.age_years)?;
    info.set_item("bio_channels", SAMPLE_CHANNELS.to_vec())?;
    info.set_item("notes", notes)?;
    info.set_item("files", files)?;
    for (name, a) in maps(set) {
        d.set_item(name, Bound::new(py, a)?)?;
    }
    d.set_item("info", info)?;
    Ok(d)
}

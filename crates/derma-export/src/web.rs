//! The web viewer's files (`derma export web`): the GLB, and the rig in a form a browser can
//! read — three.js' EXRLoader only takes channels named R, G, B, A or Y, so the rig's maps go
//! out as 16-bit PNGs (values mapped to their range, stated in `manifest.json`) with the
//! skin-colour LUT, for the viewer to evaluate Jimenez et al. 2010 eqs. 6–7 in a shader.

use crate::error::{ExportError, Result};
use derma_core::image_io::write_png16;
use derma_core::Map;
use serde_json::json;
use std::path::Path;

/// The manifest's `format`.
pub const FORMAT: &str = "derma-web";
/// Its `version` (2: the rig carries the set's skin, [`derma_rig::skin_response`]).
pub const VERSION: u32 = 2;

/// What was written.
#[derive(Clone, Debug)]
pub struct WebReport {
    /// Rig targets exported (0 without a rig).
    pub targets: usize,
}

/// (min, max) of several maps, widened so the range is never empty.
fn range(maps: &[&Map]) -> (f32, f32) {
    let (lo, hi) = maps
        .iter()
        .flat_map(|m| m.data().iter().copied())
        .fold((f32::MAX, f32::MIN), |(a, b), v| (a.min(v), b.max(v)));
    if hi > lo {
        (lo, hi)
    } else {
        (lo, lo + 1.0)
    }
}

fn normalise(m: &Map, (lo, hi): (f32, f32)) -> Map {
    m.map(|x| (x - lo) / (hi - lo))
}

/// Tiles laid side by side.
fn atlas(tiles: &[Map]) -> Map {
    let (w, h) = (tiles[0].width(), tiles[0].height());
    let mut out = Map::filled(w * tiles.len(), h, 0.0);
    for (i, t) in tiles.iter().enumerate() {
        for y in 0..h {
            for x in 0..w {
                out.set(i * w + x, y, t.get(x, y));
            }
        }
    }
    out
}

/// A point deep inside each region of the built-in head, as UV with v up: the centre of the
/// cell of a coarse grid (the mask area-averaged to 32²) that the region fills most, the first
/// such cell on ties. The viewer labels them and the browser test probes them.
fn region_points(head: &derma_head::Head, n: usize) -> serde_json::Value {
    const CELLS: usize = 32;
    let mut out = serde_json::Map::new();
    for (name, m) in head.region_masks(n) {
        let coarse = m.resized(CELLS, CELLS);
        let (i, _) = coarse
            .data()
            .iter()
            .enumerate()
            .fold(
                (0, f32::MIN),
                |(bi, bv), (i, &v)| if v > bv { (i, v) } else { (bi, bv) },
            );
        let (x, y) = (i % CELLS, i / CELLS);
        out.insert(
            name.to_string(),
            json!([
                (x as f32 + 0.5) / CELLS as f32,
                1.0 - (y as f32 + 0.5) / CELLS as f32
            ]),
        );
    }
    serde_json::Value::Object(out)
}

/// Checks that `dir` holds a web export (its `manifest.json` with this format), naming what is
/// wrong otherwise — a texture set's own manifest.json is not one.
pub fn check_export(dir: &Path) -> Result<()> {
    let path = dir.join("manifest.json");
    let bad = |detail: String| {
        ExportError::from(derma_core::CoreError::Format {
            path: path.clone(),
            message: format!("{detail}; expected a directory from `derma export web`"),
        })
    };
    let bytes = std::fs::read(&path).map_err(|e| bad(format!("cannot read it ({e})")))?;
    let v: serde_json::Value =
        serde_json::from_slice(&bytes).map_err(|e| bad(format!("not JSON ({e})")))?;
    match v.get("format").and_then(|f| f.as_str()) {
        Some(FORMAT) => Ok(()),
        Some(other) => Err(bad(format!("format '{other}', not '{FORMAT}'"))),
        None => Err(bad("no \"format\" field".into())),
    }
}

/// Writes the set's expression-wrinkle maps for the viewer (`wrinkles/normal.png`, 16-bit as
/// the set's; `wrinkles/masks_K.png`, three regions to a 16-bit RGB image) and returns their
/// manifest entry: the files, the regions with their face-unit drivers and the blend; null
/// where the set has none.
fn write_wrinkles(textures: &Path, out: &Path) -> Result<serde_json::Value> {
    let Some(wm) = derma_render::wrinkles::WrinkleMaps::from_dir(textures)? else {
        return Ok(serde_json::Value::Null);
    };
    let wd = out.join("wrinkles");
    derma_core::atomic::ensure_writable_dir(&wd)?;
    let n = &wm.normal;
    write_png16(&wd.join("normal.png"), &[&n[0], &n[1], &n[2]])?;
    let mut images = Vec::new();
    for (k, ([r, g, b], names)) in crate::glb::wrinkle_mask_images(&wm).iter().enumerate() {
        let file = format!("wrinkles/masks_{k}.png");
        write_png16(&out.join(&file), &[r, g, b])?;
        images.push(json!({"file": file, "channels": names}));
    }
    Ok(json!({
        "normal": {"file": "wrinkles/normal.png", "encoding": "n·½+½, as normal.png"},
        "masks": images,
        "regions": crate::glb::wrinkle_regions_json(),
        "formula": derma_head::wrinkle_regions::FORMULA,
    }))
}

/// Length (s) and rate of the idle eye motion the viewer plays (`eyes/motion.bin`): 900 s holds
/// about 230 blinks at rest.
const MOTION_SECONDS: f32 = 900.0;
/// See [`MOTION_SECONDS`].
const MOTION_FPS: f32 = 60.0;

/// Writes the head's eye-region model for the viewer's live evaluation (`eyes/model.bin`, the
/// arrays of [`derma_eyes::live::pack`]) and returns its manifest entry (the header, with the
/// file): trained on the head's rig as `derma render --gaze` trains it.
fn write_eyes(
    head: &derma_head::Head,
    skin_origin: &[u32],
    out: &Path,
) -> Result<serde_json::Value> {
    let model = derma_eyes::still::StillModel::new(head).map_err(|e| {
        derma_core::Invalid::new("the eye-region model", "one trained on the head's rig", e)
    })?;
    let (mut header, bin) = derma_eyes::live::pack(&model, head, skin_origin);
    let dir = out.join("eyes");
    derma_core::atomic::ensure_writable_dir(&dir)?;
    derma_core::atomic::write_bytes(&dir.join("model.bin"), &bin)?;
    header["file"] = json!("eyes/model.bin");
    // The lacrimal lake's constants, from their one home (derma-render's lake.rs).
    {
        use derma_render::lake;
        header["lake"] = json!({
            "meniscus_mm": lake::MENISCUS_MM,
            "range_mm": lake::RANGE_MM,
            "attenuation_per_mm": lake::ATTENUATION,
            "f0": lake::F0,
            "roughness": lake::ROUGHNESS,
            "max_search_px": lake::MAX_SEARCH_PX,
        });
    }
    // The idle eyes the viewer plays when left alone: table 3.1's blinks at rest and idle
    // saccades on the main sequence, long enough for 200 blinks.
    let (seconds, fps) = (MOTION_SECONDS, MOTION_FPS);
    let track = model.idle_track(head, seconds, fps, derma_eyes::blink::Activity::Rest, 1);
    let bytes: Vec<u8> = track
        .iter()
        .flatten()
        .flat_map(|v| v.to_le_bytes())
        .collect();
    derma_core::atomic::write_bytes(&dir.join("motion.bin"), &bytes)?;
    header["motion"] = json!({
        "file": "eyes/motion.bin",
        "fps": fps,
        "seconds": seconds,
        "activity": "rest",
        "blinks_per_minute": 60.0 * derma_eyes::blink::Activity::Rest.rate_hz(),
        "frame": ["gaze h (°, + the subject's left)", "gaze v (°, + up)", "lid closure (0 open, 1 shut)"],
        "encoding": "little-endian f32, three per frame",
    });
    Ok(header)
}

/// Textures for the head's parts, from `derma photo`.
#[derive(Clone, Copy, Debug, Default)]
pub struct PartTextures<'a> {
    /// An eye texture for the globes (`derma photo iris`).
    pub iris: Option<&'a Path>,
    /// A teeth texture for the teeth (`derma photo teeth`).
    pub teeth: Option<&'a Path>,
}

/// Writes `out/head.glb` (the built-in head with the set, its globes with `iris` or the built-in
/// eye, its teeth with `teeth` or their flat colour) and, with a rig, `out/rig/*.png` and
/// `out/manifest.json`.
pub fn export(
    textures: &Path,
    rig_dir: Option<&Path>,
    head: Option<&Path>,
    parts: PartTextures<'_>,
    out: &Path,
) -> Result<WebReport> {
    derma_core::atomic::ensure_writable_dir(out)?;
    let glb = crate::glb::export(
        &crate::glb::GlbOptions {
            textures: textures.to_path_buf(),
            mesh: None,
            unit: derma_core::head_mesh::HeadUnit::Auto,
            part: Default::default(),
            head: head.map(Path::to_path_buf),
            out: out.join("head.glb"),
            maps: None,
            // The viewer reads its own 16-bit copies (wrinkles/).
            wrinkles: false,
            iris: parts.iris.map(Path::to_path_buf),
            teeth: parts.teeth.map(Path::to_path_buf),
            volume: false,
            // three.js sorts blended materials: the viewer's lashes and brows blend.
            hair_mask: false,
        },
        &derma_core::progress::Silent,
    )?;
    // The head the GLB was built on, read once for the regions and the eye model.
    let model_head = derma_head::fitted::or_builtin(head)?;
    let mut manifest = json!({
        "format": FORMAT,
        "version": VERSION,
        "glb": "head.glb",
        "skin_mesh": "skin",
        "regions": region_points(model_head, 256),
        "rig": null,
    });
    manifest["expression_units"] = crate::glb::expression_units();
    manifest["wrinkles"] = write_wrinkles(textures, out)?;
    manifest["eyes"] = write_eyes(model_head, &glb.skin_origin, out)?;
    let mut targets = 0;
    if let Some(dir) = rig_dir {
        let (rig, lut, rj) = derma_rig::rig_dir::load(dir)?;
        let melanin = rig.melanin.as_ref().ok_or_else(|| {
            ExportError::from(derma_core::CoreError::Format {
                path: dir.to_path_buf(),
                message: "the rig has no melanin map; build the rig with one".into(),
            })
        })?;
        let skin = crate::files::skin_of(
            &rig,
            dir,
            &derma_render::material::SkinMaps::from_dir(textures)?.base_color,
        )?;
        let rd = out.join("rig");
        derma_core::atomic::ensure_writable_dir(&rd)?;
        let h0r = range(&[&rig.h0]);
        write_png16(&rd.join("h0.png"), &[&normalise(&rig.h0, h0r)])?;
        let mr = range(&[melanin]);
        write_png16(&rd.join("melanin.png"), &[&normalise(melanin, mr)])?;
        // Basis atlas: tile 0 the neutral (bias μ₀, scale 1), then each target (bias, scale).
        let ones = Map::filled(rig.neutral_mean.width(), rig.neutral_mean.height(), 1.0);
        let biases: Vec<&Map> = std::iter::once(&rig.neutral_mean)
            .chain(rig.targets.iter().map(|t| &t.bias))
            .collect();
        let scales: Vec<&Map> = std::iter::once(&ones)
            .chain(rig.targets.iter().map(|t| &t.scale))
            .collect();
        let (br, sr) = (range(&biases), range(&scales));
        let b_atlas = atlas(&biases.iter().map(|m| normalise(m, br)).collect::<Vec<_>>());
        let s_atlas = atlas(&scales.iter().map(|m| normalise(m, sr)).collect::<Vec<_>>());
        let zero = Map::filled(b_atlas.width(), b_atlas.height(), 0.0);
        write_png16(&rd.join("basis.png"), &[&b_atlas, &s_atlas, &zero])?;
        // The LUT: linear RGB, 16-bit, rows along the blood axis from the top (rig.json's layout).
        let [r, g, b] = lut.channels();
        let lr = range(&[&r, &g, &b]);
        write_png16(
            &rd.join("lut.png"),
            &[&normalise(&r, lr), &normalise(&g, lr), &normalise(&b, lr)],
        )?;
        // The set's skin: its base colour decoded to linear (16-bit, which encodes back to the
        // set's 8-bit codes exactly) and the response (d1, d2).
        let (w, h) = skin.size();
        let base = Map::planes(w, h, |i| skin.base[i].map(derma_core::color::srgb8_decode));
        write_png16(&rd.join("base.png"), &[&base[0], &base[1], &base[2]])?;
        let d1r = range(&[&skin.d1[0], &skin.d1[1], &skin.d1[2]]);
        let d2r = range(&[&skin.d2[0], &skin.d2[1], &skin.d2[2]]);
        let norm3 = |m: &[Map; 3], r| m.each_ref().map(|p| normalise(p, r));
        let (n1, n2) = (norm3(&skin.d1, d1r), norm3(&skin.d2, d2r));
        write_png16(&rd.join("d1.png"), &[&n1[0], &n1[1], &n1[2]])?;
        write_png16(&rd.join("d2.png"), &[&n2[0], &n2[1], &n2[2]])?;
        targets = rig.targets.len();
        manifest["rig"] = json!({
            "model": rj.model,
            "map_size": rj.map_size,
            "basis_size": rj.basis_size,
            "h0": {"file": "rig/h0.png", "range": [h0r.0, h0r.1]},
            "melanin": {"file": "rig/melanin.png", "range": [mr.0, mr.1]},
            "basis": {"file": "rig/basis.png", "tiles": targets + 1,
                "bias_range": [br.0, br.1], "scale_range": [sr.0, sr.1],
                "layout": "tile 0 the neutral, tile i target i-1, side by side; R bias, G scale"},
            "lut": {"file": "rig/lut.png", "range": [lr.0, lr.1], "size": rj.lut.size,
                "melanin_max": rj.lut.melanin_max, "blood_max": rj.lut.blood_max, "layout": rj.lut.layout},
            "targets": rig.targets.iter().map(|t| json!({"name": t.name, "global_scale": t.global_scale})).collect::<Vec<_>>(),
            "skin": {"base": {"file": "rig/base.png", "range": [0.0, 1.0]}, "appearance": skin.appearance,
                "d1": {"file": "rig/d1.png", "range": [d1r.0, d1r.1]},
                "d2": {"file": "rig/d2.png", "range": [d2r.0, d2r.1]},
                "formula": derma_rig::rig_dir::SKIN_FORMULA},
            "encoding": "16-bit PNG, value = range[0] + (range[1] - range[0]) × sample; rows top first (v = 1 at the top)",
        });
    }
    derma_core::report::write_json(
        &out.join("manifest.json"),
        &manifest,
        derma_core::report::JsonFormat::DATA_PRETTY,
    )?;
    Ok(WebReport { targets })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn only_a_web_export_passes_the_check() {
        let d = derma_test_support::scratch_dir("web-check");
        let m = d.join("manifest.json");
        let err = check_export(&d).unwrap_err().to_string();
        assert!(
            err.contains("manifest.json") && err.contains("cannot read"),
            "{err}"
        );
        // A texture set's manifest (another format) is named as such.
        std::fs::write(&m, r#"{"format": "derma-texture-set"}"#).unwrap();
        let err = check_export(&d).unwrap_err().to_string();
        assert!(
            err.contains("'derma-texture-set'") && err.contains("export web"),
            "{err}"
        );
        std::fs::write(&m, "{").unwrap();
        assert!(check_export(&d)
            .unwrap_err()
            .to_string()
            .contains("not JSON"));
        std::fs::write(
            &m,
            format!(r#"{{"format": "{FORMAT}", "version": {VERSION}}}"#),
        )
        .unwrap();
        check_export(&d).unwrap();
    }
}

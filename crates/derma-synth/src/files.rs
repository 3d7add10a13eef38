//! Exemplars and results as files: images (PNG or EXR) loaded as textures with registered
//! channels (albedo with its height and normal maps, synthesised jointly), and each channel
//! group of a result written to its own file beside the main output.

use crate::error::{invalid, Result};
use crate::texture::Texture;
use derma_core::image_io::{read_rgb, write_exr, write_png16, write_png8, ExrPrecision};
use derma_core::Map;
use std::path::{Path, PathBuf};

/// One named group of an exemplar's channels: the main image (`name` None) or a registered
/// channel such as `height`.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct ChannelGroup {
    /// None for the main image, else the name given on the command line.
    pub name: Option<String>,
    /// 3 for a colour image, 1 for a grey one.
    pub channels: usize,
}

/// Exemplars loaded from files, all with the same channel layout.
pub struct ExemplarFiles {
    /// One texture per exemplar, its groups' channels side by side.
    pub textures: Vec<Texture>,
    /// The channel layout shared by every exemplar.
    pub groups: Vec<ChannelGroup>,
    /// Every file read (to keep outputs from overwriting them).
    pub inputs: Vec<PathBuf>,
}

/// An image as its channels: a colour image gives three, a grey one one.
pub fn load_channels(path: &Path) -> Result<Vec<Map>> {
    let img = read_rgb(path)?;
    Ok(if img.is_color {
        img.channels
    } else {
        img.channels.into_iter().take(1).collect()
    })
}

/// Loads exemplar images, each with its registered channels (`registered[i]` for image i, as
/// (name, file); empty for none), into textures of one layout.
pub fn load_exemplars(
    images: &[PathBuf],
    registered: &[Vec<(String, PathBuf)>],
) -> Result<ExemplarFiles> {
    if !registered.is_empty() && registered.len() != images.len() {
        return Err(invalid(
            "registered channels",
            format!(
                "given for {} exemplars of {}; give them once per exemplar",
                registered.len(),
                images.len()
            ),
        ));
    }
    let mut textures = Vec::new();
    let mut layout: Option<Vec<ChannelGroup>> = None;
    let mut inputs = Vec::new();
    for (i, path) in images.iter().enumerate() {
        let mut maps = load_channels(path)?;
        inputs.push(path.clone());
        let mut groups = vec![ChannelGroup {
            name: None,
            channels: maps.len(),
        }];
        for (name, file) in registered.get(i).into_iter().flatten() {
            let extra = load_channels(file)?;
            inputs.push(file.clone());
            if (extra[0].width(), extra[0].height()) != (maps[0].width(), maps[0].height()) {
                return Err(invalid(
                    format!("exemplar channel '{name}' ('{}')", file.display()),
                    format!(
                        "it is {}×{}, but '{}' is {}×{}: registered channels must have the exemplar's size",
                        extra[0].width(),
                        extra[0].height(),
                        path.display(),
                        maps[0].width(),
                        maps[0].height()
                    ),
                ));
            }
            groups.push(ChannelGroup {
                name: Some(name.clone()),
                channels: extra.len(),
            });
            maps.extend(extra);
        }
        match &layout {
            None => layout = Some(groups),
            Some(l) if *l != groups => {
                return Err(invalid(
                    format!("exemplar '{}'", path.display()),
                    "it has another channel layout than the first; all exemplars need the same channels",
                ))
            }
            Some(_) => {}
        }
        textures.push(Texture::from_maps(&maps.iter().collect::<Vec<_>>())?);
    }
    Ok(ExemplarFiles {
        textures,
        groups: layout.unwrap_or_default(),
        inputs,
    })
}

/// Where each group of a result goes: the main group to `out`, group NAME to `stem_NAME.ext`
/// beside it. `out` must end in `.png` or `.exr`.
pub fn output_paths(out: &Path, groups: &[ChannelGroup]) -> Result<Vec<PathBuf>> {
    let ext = out
        .extension()
        .and_then(|e| e.to_str())
        .map(str::to_ascii_lowercase);
    if !matches!(ext.as_deref(), Some("png" | "exr")) {
        return Err(invalid(
            format!("output '{}'", out.display()),
            "expected a .png or .exr file name",
        ));
    }
    Ok(groups
        .iter()
        .map(|g| match &g.name {
            None => out.to_path_buf(),
            Some(n) => {
                let stem = out.file_stem().and_then(|s| s.to_str()).unwrap_or("synth");
                let ext = out.extension().and_then(|s| s.to_str()).unwrap_or("png");
                out.with_file_name(format!("{stem}_{n}.{ext}"))
            }
        })
        .collect())
}

/// Writes one group of maps: EXR as float (R, G, B or Y), PNG colour as 8-bit (values as
/// stored, no transfer applied) and PNG grey as 16-bit so heights keep their precision.
pub fn write_group(path: &Path, maps: &[Map]) -> Result<()> {
    let refs: Vec<&Map> = maps.iter().collect();
    let ext = path
        .extension()
        .and_then(|e| e.to_str())
        .map(str::to_ascii_lowercase);
    match ext.as_deref() {
        Some("exr") => {
            let names: &[&str] = if maps.len() == 3 {
                &["R", "G", "B"]
            } else {
                &["Y"]
            };
            let ch: Vec<(&str, &Map)> = names.iter().copied().zip(refs).collect();
            write_exr(path, &ch, ExrPrecision::F32)?
        }
        Some("png") if maps.len() == 3 => write_png8(path, &refs)?,
        Some("png") => write_png16(path, &refs)?,
        _ => {
            return Err(invalid(
                format!("output '{}'", path.display()),
                "expected a .png or .exr file name",
            ))
        }
    }
    Ok(())
}

/// Writes each group of `texture`'s channels to its path (from [`output_paths`]).
pub fn write_outputs(paths: &[PathBuf], groups: &[ChannelGroup], texture: &Texture) -> Result<()> {
    let mut k = 0;
    for (g, path) in groups.iter().zip(paths) {
        let maps: Vec<Map> = (k..k + g.channels).map(|c| texture.channel(c)).collect();
        k += g.channels;
        write_group(path, &maps)?;
    }
    Ok(())
}

//! `derma skin` from configuration to files: the texture set derma-skin paints and writes, and
//! on request its engine GLB on the head it was painted on (docs/skin.md, docs/render.md).

use crate::glb::{self, GlbOptions, GlbReport};
use crate::Result;
use derma_core::atomic::StagedDir;
use derma_core::head_mesh::{HeadUnit, MeshFrame};
use derma_core::mesh_parts::PartChoice;
use derma_core::progress::Progress;
use derma_skin::outputs::GLB;
use derma_skin::{SkinGenerator, TextureSet, Written};
use std::path::Path;

/// What [`run`] made and wrote.
pub struct SkinOutput {
    /// The texture set in memory (its maps, features, configuration and log).
    pub set: TextureSet,
    /// The files written into the output directory.
    pub written: Written,
    /// `head.glb`, when asked for.
    pub glb: Option<GlbReport>,
}

/// Checks the output directory, generates the set, writes it into `out` and, with `glb`, writes
/// `out/head.glb`: the built-in head with its parts, or the set's own mesh in the unit it was
/// painted in.
pub fn run(
    generator: &SkinGenerator,
    out: &Path,
    glb: bool,
    progress: &dyn Progress,
) -> Result<SkinOutput> {
    generator.check_output(out)?;
    let set = generator.run()?;
    // Written beside `out` and swapped in whole: a killed rerun never leaves a mix of two sets.
    let staged = StagedDir::begin(out, &derma_skin::outputs::owned)?;
    let dir = staged.path();
    let written = set.write(dir, progress)?;
    let (unit, part) = painted_read(set.mesh_scale.as_ref(), set.inputs.head.is_some());
    let glb = glb
        .then(|| {
            glb::export(
                &GlbOptions {
                    textures: dir.to_path_buf(),
                    mesh: set.inputs.mesh.clone(),
                    unit,
                    part: part.clone(),
                    head: set.inputs.head.clone(),
                    out: dir.join(GLB),
                    maps: None,
                    wrinkles: true,
                    iris: None,
                    teeth: None,
                    volume: false,
                    hair_mask: false,
                },
                progress,
            )
        })
        .transpose()?;
    let glb = match glb {
        Some(mut report) => {
            derma_skin::manifest::add_file(
                dir,
                GLB,
                "the head (or mesh) with this set as glTF PBR materials (derma export glb)",
            )?;
            report.path = out.join(GLB);
            Some(report)
        }
        None => None,
    };
    staged.commit()?;
    Ok(SkinOutput { set, written, glb })
}

/// How a user mesh was read when the set was painted: its length unit when one was found,
/// fitted to a head's size when none was (through a fitted head, its frame decides), and its
/// part; the loader's own choice for the built-in head.
fn painted_read(frame: Option<&MeshFrame>, fitted: bool) -> (HeadUnit, PartChoice) {
    match frame {
        _ if fitted => (HeadUnit::Auto, PartChoice::Auto),
        Some(f) => (
            f.unit.map_or(HeadUnit::Fit, HeadUnit::Length),
            f.part_choice(),
        ),
        None => (HeadUnit::Auto, PartChoice::Auto),
    }
}

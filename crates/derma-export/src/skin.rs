//! `derma skin` from configuration to files: the texture set derma-skin paints and writes, and
//! on request its engine GLB on the head it was painted on (docs/skin.md, docs/render.md).

use crate::glb::{self, GlbOptions, GlbReport};
use crate::Result;
use derma_core::atomic::StagedDir;
use derma_core::head_mesh::{HeadUnit, MeshFrame};
use derma_core::mesh_parts::PartChoice;
use derma_core::progress::Progress;
use derma_skin::generate::SetSummary;
use derma_skin::outputs::GLB;
use derma_skin::report::InputFiles;
use derma_skin::{SkinGenerator, TextureSet, Written};
use std::path::Path;

/// What [`run`] (or [`run_in_memory`]) made and wrote.
pub struct SkinOutput<S = SetSummary> {
    /// What the set was (its features, configuration, inputs and albedo comparison; with
    /// [`run_in_memory`], the whole [`TextureSet`] with its maps).
    pub set: S,
    /// The files written into the output directory.
    pub written: Written,
    /// `head.glb`, when asked for.
    pub glb: Option<GlbReport>,
}

/// Checks the output directory, generates the set, writes it into `out` and, with `glb`, writes
/// `out/head.glb`: the built-in head with its parts, or the set's own mesh in the unit it was
/// painted in. The set is streamed to its files band by band ([`SkinGenerator::write_to`]).
pub fn run(
    generator: &SkinGenerator,
    out: &Path,
    glb: bool,
    progress: &dyn Progress,
) -> Result<SkinOutput> {
    staged(generator, out, glb, progress, |dir| generator.write_to(dir))
}

/// [`run`], keeping the whole set in memory (the same files): for callers that want its maps.
pub fn run_in_memory(
    generator: &SkinGenerator,
    out: &Path,
    glb: bool,
    progress: &dyn Progress,
) -> Result<SkinOutput<TextureSet>> {
    staged(generator, out, glb, progress, |dir| {
        let set = generator.run()?;
        let written = set.write(dir, progress)?;
        Ok((set, written))
    })
}

/// What [`staged`] needs of a set to export its GLB.
pub trait Painted {
    /// How a user mesh was read, and the files read.
    fn read(&self) -> (Option<&MeshFrame>, &InputFiles);
}

impl Painted for SetSummary {
    fn read(&self) -> (Option<&MeshFrame>, &InputFiles) {
        (self.mesh_scale.as_ref(), &self.inputs)
    }
}

impl Painted for TextureSet {
    fn read(&self) -> (Option<&MeshFrame>, &InputFiles) {
        (self.mesh_scale.as_ref(), &self.inputs)
    }
}

/// Writes a set with `write` into a directory beside `out`, adds its GLB, and swaps it in.
fn staged<S: Painted>(
    generator: &SkinGenerator,
    out: &Path,
    glb: bool,
    progress: &dyn Progress,
    write: impl FnOnce(&Path) -> derma_skin::Result<(S, Written)>,
) -> Result<SkinOutput<S>> {
    generator.check_output(out)?;
    // Written beside `out` and swapped in whole: a killed rerun never leaves a mix of two sets.
    let staged = StagedDir::begin(out, &derma_skin::outputs::owned)?;
    let dir = staged.path();
    let (set, written) = write(dir)?;
    let (frame, inputs) = set.read();
    let (unit, part) = painted_read(frame, inputs.head.is_some());
    let glb = glb
        .then(|| {
            glb::export(
                &GlbOptions {
                    textures: dir.to_path_buf(),
                    mesh: inputs.mesh.clone(),
                    unit,
                    part: part.clone(),
                    head: inputs.head.clone(),
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

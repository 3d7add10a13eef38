//! A rig from files, as `derma rig build` and `derma rig transfer` make one: a character's maps
//! (neutral hemoglobin, melanin, mask), target maps and built-in library entries are read,
//! checked against the output directory (no input is ever overwritten), built (Jimenez et al.
//! 2010 eq. 4–5) or transferred (§5), and saved as a rig directory.

use crate::basis::{BasisOptions, Rig, TargetSource, TargetSpec, TransferMode};
use crate::error::{invalid, Result};
use crate::expression;
use crate::maps::{read_map, read_optional, Quantity};
use crate::rig_dir::{self, RigJson};
use crate::skin_response::{appearance_of_set, SkinResponse};
use crate::RigError;
use derma_core::progress::Progress;
use derma_core::Map;
use derma_shading::skin_color_lut::{LutOptions, SkinColorLut};
use std::path::{Path, PathBuf};

/// A character's maps on disk.
#[derive(Clone, Debug, Default)]
pub struct CharacterFiles {
    /// Neutral hemoglobin map H_n.
    pub neutral: PathBuf,
    /// Melanin map C_m, for colour output.
    pub melanin: Option<PathBuf>,
    /// Skin mask (> 0 = skin): texels outside are left out of the statistics.
    pub mask: Option<PathBuf>,
    /// The texture set the maps are (`derma skin`'s directory): frames then keep its skin
    /// ([`crate::skin_response`]).
    pub set: Option<SetFiles>,
}

/// A texture set a rig is built on.
#[derive(Clone, Debug, Default)]
pub struct SetFiles {
    /// The set's directory.
    pub dir: PathBuf,
    /// The match table it was made with, when not the built-in one.
    pub table: Option<PathBuf>,
}

impl CharacterFiles {
    /// The character of the texture set in `set.dir`: its hemoglobin and melanin maps, and its
    /// skin for the frames' colour.
    pub fn of_set(set: SetFiles, mask: Option<PathBuf>) -> Self {
        use crate::skin_response::files;
        Self {
            neutral: set.dir.join(files::HEMOGLOBIN),
            melanin: Some(set.dir.join(files::MELANIN)),
            mask,
            set: Some(set),
        }
    }

    /// Every file, to keep outputs away from them.
    pub fn paths(&self) -> Vec<&Path> {
        let mut v: Vec<&Path> = vec![&self.neutral];
        v.extend(self.melanin.as_deref());
        v.extend(self.mask.as_deref());
        if let Some(s) = &self.set {
            v.push(&s.dir);
            v.extend(s.table.as_deref());
        }
        v
    }

    /// The set's skin response, when the character is a set; checked against the rig's size.
    fn skin(&self, rig: &Rig) -> Result<Option<SkinResponse>> {
        let Some(s) = &self.set else {
            return Ok(None);
        };
        let appearance = appearance_of_set(&s.dir, s.table.as_deref())?;
        let r = SkinResponse::of_set(&s.dir, &*appearance)?;
        if r.size() != rig.size() {
            return Err(RigError::File {
                path: s.dir.clone(),
                detail: format!(
                    "its base colour is {}×{}; its hemoglobin map {}×{}",
                    r.size().0,
                    r.size().1,
                    rig.size().0,
                    rig.size().1
                ),
            });
        }
        Ok(Some(r))
    }

    /// (neutral, melanin, mask), PNGs scaled by `lut`'s axis tops.
    pub fn read(
        &self,
        lut: &LutOptions,
        progress: &dyn Progress,
    ) -> Result<(Map, Option<Map>, Option<Map>)> {
        Ok((
            read_map(&self.neutral, Quantity::Hemoglobin, lut, progress)?,
            read_optional(self.melanin.as_deref(), Quantity::Melanin, lut, progress)?,
            read_optional(self.mask.as_deref(), Quantity::Mask, lut, progress)?,
        ))
    }
}

/// What a rig is built from.
#[derive(Clone, Debug, Default)]
pub struct BuildFiles {
    /// The character.
    pub character: CharacterFiles,
    /// Measured or painted target hemoglobin maps, aligned with the neutral: (name, file).
    pub targets: Vec<(String, PathBuf)>,
    /// Built-in library entries by name, or "all" (placed on the built-in head's UV layout, or
    /// on `on_mesh`).
    pub builtin: Vec<String>,
    /// Suggested global hemoglobin scale of targets at full weight: (name, scale).
    pub globals: Vec<(String, f32)>,
    /// A skin-colour LUT (.dtab); `None` for the built-in one.
    pub lut: Option<PathBuf>,
    /// The maps are on a user's own mesh and UVs: the built-in entries are placed on it
    /// through the head fitted to it; `None`: the built-in head's UV layout (also a fitted
    /// head's template).
    pub on_mesh: Option<OnMesh>,
}

/// A user's mesh and the head fitted to it (`derma head fit`).
#[derive(Clone, Debug)]
pub struct OnMesh {
    /// The fitted head directory.
    pub head: PathBuf,
    /// The mesh (with its UVs) the maps were painted on.
    pub mesh: PathBuf,
}

impl OnMesh {
    /// The mesh in mm and the fitted head's regions; refused when most of the mesh lies off
    /// the fitted head (another mesh, or another unit).
    pub fn load(&self) -> Result<(derma_core::mesh::TriMesh, derma_head::Regions)> {
        use derma_head::fit::onto::{Carry, MIN_SHARE, REACH_MM};
        let head = derma_head::fitted::open(&self.head)?;
        let mesh = derma_head::fitted::load_scan(
            &self.head,
            &self.mesh,
            derma_core::head_mesh::HeadUnit::Auto,
            &Default::default(),
            &derma_core::Silent,
        )?;
        let share = Carry::new(head, &mesh).share();
        if share < MIN_SHARE {
            return Err(crate::RigError::File {
                path: self.mesh.clone(),
                detail: format!(
                    "only {:.0} % of its vertices lie within {REACH_MM} mm of the head fitted in '{}'; is it the mesh that head was fitted to, read in the same unit?",
                    100.0 * share,
                    self.head.display()
                ),
            });
        }
        let regions = derma_head::Regions::new(head.landmarks.clone(), Vec::new(), Vec::new());
        Ok((mesh, regions))
    }
}

/// The built-in skin-colour LUT, or the one at `path`.
pub fn load_lut(path: Option<&Path>) -> Result<SkinColorLut> {
    match path {
        None => Ok(SkinColorLut::builtin()),
        Some(p) => {
            let t = derma_core::dtab::Dtab::read(p)?;
            Ok(SkinColorLut::from_dtab(&t, &p.display().to_string())?)
        }
    }
}

/// Fails before any work when the rig directory `out` would hold an input.
pub fn check_out(out: &Path, inputs: &[&Path]) -> Result<()> {
    derma_core::atomic::ensure_writable_dir(out)?;
    derma_core::atomic::check_inputs_spared(&[out.to_path_buf()], inputs)?;
    Ok(())
}

/// Builds a rig from `files` with `opts` and saves it into `out`.
pub fn build(
    files: &BuildFiles,
    opts: &BasisOptions,
    out: &Path,
    progress: &dyn Progress,
) -> Result<(Rig, RigJson)> {
    let mut inputs = files.character.paths();
    inputs.extend(files.targets.iter().map(|(_, p)| p.as_path()));
    check_out(out, &inputs)?;
    let lut = load_lut(files.lut.as_deref())?;
    let (neutral, melanin, mask) = files.character.read(&lut.options, progress)?;
    let maps: Vec<(String, Map)> = files
        .targets
        .iter()
        .map(|(n, p)| {
            Ok((
                n.clone(),
                read_map(p, Quantity::Hemoglobin, &lut.options, progress)?,
            ))
        })
        .collect::<Result<_>>()?;
    let global = |name: &str| files.globals.iter().find(|(n, _)| n == name).map(|g| g.1);
    let mut specs: Vec<TargetSpec> = maps
        .iter()
        .map(|(n, m)| TargetSpec {
            name: n.clone(),
            source: TargetSource::Map(m),
            global_scale: global(n),
        })
        .collect();
    for e in expression::select(&files.builtin)? {
        specs.push(TargetSpec {
            name: e.name.into(),
            source: TargetSource::Builtin(e),
            global_scale: global(e.name),
        });
    }
    if let Some((n, _)) = files
        .globals
        .iter()
        .find(|(n, _)| !specs.iter().any(|s| &s.name == n))
    {
        return Err(invalid(
            "global scale",
            format!("'{n}': no target of that name"),
        ));
    }
    if specs.is_empty() {
        return Err(invalid(
            "rig",
            "no targets: give target maps (NAME=FILE) and/or built-in library entries",
        ));
    }
    let on_mesh = match &files.on_mesh {
        Some(m) => Some(m.load()?),
        None => None,
    };
    let placement = match &on_mesh {
        Some((mesh, regions)) => expression::Placement::Mesh { mesh, regions },
        None => expression::Placement::Builtin,
    };
    let mut rig = Rig::build_placed(&neutral, mask.as_ref(), melanin, &specs, opts, &placement)?;
    rig.skin = files.character.skin(&rig)?;
    let json = rig_dir::save(&rig, &lut, out)?;
    Ok((rig, json))
}

/// Transfers the rig in `rig_dir` onto `character` (Jimenez et al. 2010 §5) and saves the
/// result into `out`.
pub fn transfer(
    rig_dir: &Path,
    character: &CharacterFiles,
    mode: TransferMode,
    sigma_floor: f32,
    out: &Path,
    progress: &dyn Progress,
) -> Result<Rig> {
    let mut inputs = character.paths();
    inputs.push(rig_dir);
    check_out(out, &inputs)?;
    let (rig, lut, _) = rig_dir::load(rig_dir)?;
    let (neutral, melanin, mask) = character.read(&lut.options, progress)?;
    let mut moved = rig.transfer(&neutral, mask.as_ref(), melanin, mode, sigma_floor)?;
    moved.skin = character.skin(&moved)?;
    rig_dir::save(&moved, &lut, out)?;
    Ok(moved)
}

//! The precompute grid (thesis Precalculate, §4.8.6): the skin simulation over a grid of bio
//! parameters, as independent shards that resume where they stopped, merged into a `.dtab`.
//!
//! A run directory holds `grid.toml` (the grid it was started with; a different grid is refused)
//! and one `entries/NNNNNN.json` per finished grid node, written atomically. Shard k of n owns
//! the nodes i with i mod n = k − 1, so shards are separate processes (a Slurm array or a
//! Kubernetes indexed Job) that can share a directory or use their own; `merge` reads any number
//! of directories and writes the table in node order.

use crate::bio::BioTexel;
use crate::error::{OpticsError, Result};
use crate::simulate::{simulate_skin, SkinResult, SkinSimConfig};
use crate::specimen::SurfaceModel;
use crate::tally::{BrdfBins, ProfileBins};
use crate::yellow_pigments::YellowPigments;
use derma_core::dtab::{Dtab, DtabAxis, DtabHeader, DtabValue};
use derma_core::gpu::Device;
use derma_core::progress::{Folded, Note, Progress, Unit};
use serde::{Deserialize, Serialize};
use std::path::{Path, PathBuf};

/// Names of the grid axes, in table order (the bio parameters of thesis §5.2).
pub const AXES: [&str; 6] = BioTexel::NAMES;

#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
/// The node values of each bio parameter (thesis §5.2), each strictly increasing.
pub struct GridAxes {
    /// Melanosome volume fraction of the epidermis.
    pub melanin: Vec<f64>,
    /// Pheomelanin share of the melanin.
    pub pheomelanin: Vec<f64>,
    /// Whole-blood volume fraction of the dermis.
    pub blood: Vec<f64>,
    /// Oxygenated share of the hemoglobin.
    pub oxygenation: Vec<f64>,
    /// Stratum corneum thickness, µm.
    pub stratum_corneum_um: Vec<f64>,
    /// Living epidermis thickness, µm.
    pub epidermis_um: Vec<f64>,
}

#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
/// A precompute grid: the nodes over the bio parameters and what to simulate at each.
pub struct Grid {
    /// Photons per node.
    pub photons: u64,
    /// Base seed (each node derives its own, see [`Grid::config`]).
    pub seed: u64,
    /// BRDF bins [θi, θo, Δφ].
    #[serde(default = "default_brdf")]
    pub brdf: [usize; 3],
    #[serde(default = "default_profile_bins")]
    /// Rings of the radial profile.
    pub profile_bins: usize,
    #[serde(default = "default_dmax")]
    /// Outer radius of the radial profile, mm.
    pub profile_d_max_mm: f64,
    /// The skin surface's model: `smith` (default) or `thesis`.
    #[serde(default)]
    pub surface: SurfaceModel,
    /// β-carotene and bilirubin concentrations (`[yellow_pigments]`). Absent: none, as every
    /// grid written before they were modelled was simulated; give the section for BioSpec's.
    #[serde(default = "YellowPigments::none", rename = "yellow_pigments")]
    pub yellow: YellowPigments,
    /// The axes.
    pub axes: GridAxes,
}

fn default_brdf() -> [usize; 3] {
    let b = SkinSimConfig::default().brdf;
    [b.theta_in, b.theta_out, b.phi]
}
fn default_profile_bins() -> usize {
    SkinSimConfig::default().profile.bins
}
fn default_dmax() -> f64 {
    SkinSimConfig::default().profile.d_max_mm
}

/// The default grid: 4 nodes on each of the 6 axes (4096 entries), 10⁶ photons each. Nodes span
/// Jimenez et al. 2010 table 1 (melanin ≤ 0.5; dermal blood ≤ 0.32 — the top node 0.2 because
/// BioSpec's dermis holds 0.2–5 % blood), venous to arterial oxygenation, and facial layer
/// thicknesses (stratum corneum 5–50 µm; epidermis 20–200 µm, Sandby-Møller et al. 2003).
pub const DEFAULT_GRID: &str = r#"# derma optics precompute grid: 4^6 = 4096 entries x 10^6 photons.
photons = 1000000
seed = 1
brdf = [9, 9, 12]
profile_bins = 64
profile_d_max_mm = 8.0

# BioSpec's baselines (derma-optics yellow_pigments.rs), g/L.
[yellow_pigments]
carotene_epidermis_g_per_l = 0.00021
carotene_dermis_g_per_l = 0.00007
bilirubin_blood_g_per_l = 0.05

[axes]
melanin = [0.002, 0.05, 0.2, 0.5]
pheomelanin = [0.0, 0.3, 0.6, 1.0]
blood = [0.002, 0.02, 0.08, 0.2]
oxygenation = [0.5, 0.7, 0.85, 1.0]
stratum_corneum_um = [5.0, 15.0, 30.0, 50.0]
epidermis_um = [20.0, 60.0, 120.0, 200.0]
"#;

impl Grid {
    /// Parses a grid from TOML; `origin` names it in errors (unknown keys, ranges, order).
    pub fn parse(text: &str, origin: &Path) -> Result<Self> {
        let g: Grid = toml::from_str(text).map_err(|e| {
            crate::OpticsError::from(derma_core::CoreError::Format {
                path: origin.to_path_buf(),
                message: e.to_string(),
            })
        })?;
        g.validate(origin)?;
        Ok(g)
    }

    /// The grid `spec` names: `default` (the built-in grid) or a TOML file.
    pub fn load(spec: &str) -> Result<Self> {
        if spec == "default" {
            return Ok(Self::default_grid());
        }
        let p = Path::new(spec);
        let text = std::fs::read_to_string(p).map_err(|e| OpticsError::Io {
            path: p.to_path_buf(),
            source: e,
        })?;
        Self::parse(&text, p)
    }

    /// The built-in grid ([`DEFAULT_GRID`]).
    pub fn default_grid() -> Self {
        Self::parse(DEFAULT_GRID, Path::new("<built-in default grid>"))
            .expect("the built-in grid parses")
    }

    /// The six axes in [`AXES`] order.
    pub fn axes(&self) -> [&Vec<f64>; 6] {
        let a = &self.axes;
        [
            &a.melanin,
            &a.pheomelanin,
            &a.blood,
            &a.oxygenation,
            &a.stratum_corneum_um,
            &a.epidermis_um,
        ]
    }

    fn validate(&self, origin: &Path) -> Result<()> {
        let bad = |m: String| {
            crate::OpticsError::from(derma_core::CoreError::Format {
                path: origin.to_path_buf(),
                message: m,
            })
        };
        if self.photons == 0 {
            return Err(bad("photons must be at least 1".into()));
        }
        let ranges = [
            (0.0, 1.0),
            (0.0, 1.0),
            (0.0, 1.0),
            (0.0, 1.0),
            (0.1, 1000.0),
            (1.0, 2000.0),
        ];
        for ((name, values), (lo, hi)) in AXES.iter().zip(self.axes()).zip(ranges) {
            if values.is_empty() {
                return Err(bad(format!("axes.{name} needs at least one value")));
            }
            for w in values.windows(2) {
                if !(w[1] > w[0]) {
                    return Err(bad(format!("axes.{name} must be strictly increasing")));
                }
            }
            for v in values {
                if !(v.is_finite() && *v >= lo && *v <= hi) {
                    return Err(bad(format!("axes.{name}: {v} outside [{lo}, {hi}]")));
                }
            }
        }
        if self.brdf.contains(&0)
            || self.profile_bins == 0
            || !(self.profile_d_max_mm > 0.0 && self.profile_d_max_mm.is_finite())
        {
            return Err(bad(
                "brdf bins, profile_bins and profile_d_max_mm must be positive".into(),
            ));
        }
        if self.brdf.iter().any(|&b| b > crate::tally::MAX_BRDF_BINS)
            || self.profile_bins > crate::tally::MAX_PROFILE_BINS
        {
            return Err(bad(format!(
                "brdf {:?} and profile_bins {}: at most {} bins per BRDF angle and {} rings",
                self.brdf,
                self.profile_bins,
                crate::tally::MAX_BRDF_BINS,
                crate::tally::MAX_PROFILE_BINS
            )));
        }
        self.yellow
            .validate()
            .map_err(|e| bad(format!("[yellow_pigments]: {e}")))?;
        Ok(())
    }

    /// Number of nodes (the product of the axes' lengths).
    pub fn len(&self) -> usize {
        self.axes().iter().map(|a| a.len()).product()
    }

    /// True when an axis is empty.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// Bio parameters of node `i` (first axis slowest).
    pub fn node(&self, i: usize) -> BioTexel {
        let axes = self.axes();
        let mut rest = i;
        let mut v = [0.0; 6];
        for k in (0..6).rev() {
            let n = axes[k].len();
            v[k] = axes[k][rest % n];
            rest /= n;
        }
        BioTexel::from_array(v.map(|x| x as f32))
    }

    /// The BRDF bins of every node.
    pub fn brdf_bins(&self) -> BrdfBins {
        BrdfBins {
            theta_in: self.brdf[0],
            theta_out: self.brdf[1],
            phi: self.brdf[2],
        }
    }

    /// Simulation settings of node `i`: its own seed so entries are independent of sharding.
    pub fn config(&self, i: usize) -> SkinSimConfig {
        SkinSimConfig {
            photons: self.photons,
            seed: self.seed.wrapping_mul(0x9E37_79B9_7F4A_7C15) ^ i as u64,
            brdf: self.brdf_bins(),
            profile: ProfileBins {
                bins: self.profile_bins,
                d_max_mm: self.profile_d_max_mm,
            },
            surface: self.surface,
            yellow: self.yellow,
        }
    }
}

/// A shard of the grid's nodes: derma-core's one split of work over a cluster job.
pub use derma_core::shard::Shard;

fn entry_path(dir: &Path, i: usize) -> PathBuf {
    dir.join("entries").join(format!("{i:06}.json"))
}

/// Prepares `dir` for `grid`: writes `grid.toml`, or checks that the one there is the same.
pub fn prepare_dir(dir: &Path, grid: &Grid) -> Result<()> {
    derma_core::atomic::ensure_writable_dir(&dir.join("entries"))?;
    let path = dir.join("grid.toml");
    let text = toml::to_string(grid).map_err(|e| {
        OpticsError::Invalid(derma_core::Invalid::new(
            format!("grid for '{}'", path.display()),
            "a grid that can be written as TOML",
            e,
        ))
    })?;
    if path.exists() {
        let old = std::fs::read_to_string(&path).map_err(|e| OpticsError::Io {
            path: path.clone(),
            source: e,
        })?;
        let old_grid = Grid::parse(&old, &path)?;
        if &old_grid != grid {
            return Err(crate::OpticsError::from(derma_core::CoreError::Format {
                path,
                message:
                    "this directory was started with a different grid; use a new output directory \
                          or the same grid"
                        .into(),
            }));
        }
        return Ok(());
    }
    derma_core::atomic::write_bytes(&path, text.as_bytes())?;
    Ok(())
}

/// Node indices of `shard` that `dir` does not hold yet.
pub fn pending(dir: &Path, grid: &Grid, shard: Shard) -> Vec<usize> {
    (0..grid.len())
        .filter(|&i| shard.owns(i) && !entry_path(dir, i).exists())
        .collect()
}

/// Simulates node `i` and writes its entry atomically.
pub fn compute_entry(
    dir: &Path,
    grid: &Grid,
    i: usize,
    device: Device,
    progress: &dyn Progress,
) -> Result<SkinResult> {
    let r = simulate_skin(&grid.node(i), &grid.config(i), device, progress)?;
    // Exact: a resumed run merges these numbers as they were computed.
    derma_core::report::write_json(
        &entry_path(dir, i),
        &r,
        derma_core::report::JsonFormat::DATA,
    )?;
    Ok(r)
}

/// What [`run_shard`] did.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ShardRun {
    /// Grid nodes the shard owns.
    pub owned: usize,
    /// Of those, entries already in the directory (kept, not recomputed).
    pub already_done: usize,
    /// Entries computed by this run.
    pub computed: usize,
    /// The device they ran on.
    pub device: Device,
}

/// Runs shard `shard` of `grid` into `dir`: computes every owned node not there yet, one
/// entry file each, so an interrupted run resumes where it stopped. Notes what it will do,
/// then reports one stage of all the photons to simulate.
pub fn run_shard(
    dir: &Path,
    grid: &Grid,
    shard: Shard,
    device: Device,
    progress: &dyn Progress,
) -> Result<ShardRun> {
    prepare_dir(dir, grid)?;
    let owned = (0..grid.len()).filter(|&i| shard.owns(i)).count();
    let todo = pending(dir, grid, shard);
    let device = device.resolve()?;
    progress.note(Note::info(format!(
        "grid: {} entries × {} photons; shard {}/{} owns {owned}, {} already done, {} to go, on {device}",
        grid.len(),
        grid.photons,
        shard.k,
        shard.n,
        owned - todo.len(),
        todo.len(),
    )));
    progress.stage(
        "precompute",
        todo.len() as u64 * grid.photons,
        Unit::Photons,
    );
    for &i in &todo {
        compute_entry(dir, grid, i, device, &Folded(progress)).map_err(|e| match e {
            OpticsError::Invalid(mut inv) => {
                inv.what = format!("{} in grid entry {i}", inv.what);
                OpticsError::Invalid(inv)
            }
            other => other,
        })?;
    }
    Ok(ShardRun {
        owned,
        already_done: owned - todo.len(),
        computed: todo.len(),
        device,
    })
}

fn read_entry(path: &Path) -> Result<SkinResult> {
    let bytes = std::fs::read(path).map_err(|e| OpticsError::Io {
        path: path.to_path_buf(),
        source: e,
    })?;
    serde_json::from_slice(&bytes).map_err(|e| {
        crate::OpticsError::from(derma_core::CoreError::Format {
            path: path.to_path_buf(),
            message: format!("not a precompute entry: {e}"),
        })
    })
}

/// Values stored per node, in order.
pub fn value_layout(grid: &Grid) -> Vec<DtabValue> {
    let b = grid.brdf[0] * grid.brdf[1] * grid.brdf[2];
    let v = |name: &str, len| DtabValue {
        name: name.into(),
        len,
    };
    vec![
        v("linear_srgb", 3),
        v("r_diffuse", derma_core::color::N_WAVELENGTHS),
        v("r_specular", derma_core::color::N_WAVELENGTHS),
        v("brdf_rgb", 3 * b),
        v("profile_rgb", 3 * grid.profile_bins),
        v("absorbed", 4 * crate::layer::N_ABSORBERS),
    ]
}

/// Joins the entries of `dirs` (all started with the same grid) into one table.
pub fn merge(dirs: &[PathBuf]) -> Result<Dtab> {
    let first = dirs.first().ok_or_else(|| {
        OpticsError::Invalid(derma_core::Invalid::new(
            "directories to merge",
            "at least one",
            "none",
        ))
    })?;
    let gp = first.join("grid.toml");
    let text = std::fs::read_to_string(&gp).map_err(|e| OpticsError::Io {
        path: gp.clone(),
        source: e,
    })?;
    let grid = Grid::parse(&text, &gp)?;
    for d in &dirs[1..] {
        let p = d.join("grid.toml");
        let t = std::fs::read_to_string(&p).map_err(|e| OpticsError::Io {
            path: p.clone(),
            source: e,
        })?;
        if Grid::parse(&t, &p)? != grid {
            return Err(crate::OpticsError::from(derma_core::CoreError::Format {
                path: p,
                message: format!("grid differs from {}", gp.display()),
            }));
        }
    }
    let layout = value_layout(&grid);
    let stride: usize = layout.iter().map(|v| v.len).sum();
    let mut data = Vec::with_capacity(grid.len() * stride);
    let mut missing = Vec::new();
    let mut photons_total = 0u64;
    for i in 0..grid.len() {
        let Some(path) = dirs.iter().map(|d| entry_path(d, i)).find(|p| p.exists()) else {
            missing.push(i);
            continue;
        };
        let r = read_entry(&path)?;
        if r.config != grid.config(i) || r.bio != grid.node(i) {
            return Err(crate::OpticsError::from(derma_core::CoreError::Format {
                path,
                message: format!(
                    "entry {i} was simulated with other settings than {}'s node {i} (another grid, or a run before the grid's yellow pigments or surface changed); run it again",
                    gp.display()
                ),
            }));
        }
        photons_total += r.config.photons;
        data.extend(r.linear_srgb.iter().map(|&v| v as f32));
        data.extend(r.r_diffuse.iter().map(|&v| v as f32));
        data.extend(r.r_specular.iter().map(|&v| v as f32));
        data.extend(r.brdf_rgb.iter().flatten().map(|&v| v as f32));
        data.extend(r.profile_rgb.iter().flatten().map(|&v| v as f32));
        data.extend(r.absorbed.iter().flatten().map(|&v| v as f32));
    }
    if !missing.is_empty() {
        let show: Vec<String> = missing.iter().take(10).map(|i| i.to_string()).collect();
        return Err(OpticsError::Invalid(derma_core::Invalid::new(
            "precompute entries",
            format!(
                "all {} entries of the grid (run the remaining shards first)",
                grid.len()
            ),
            format!(
                "{} of {} missing (first: {})",
                missing.len(),
                grid.len(),
                show.join(", ")
            ),
        )));
    }
    let axes = AXES
        .iter()
        .zip(grid.axes())
        .map(|(n, v)| DtabAxis {
            name: n.to_string(),
            values: v.clone(),
        })
        .collect();
    Ok(Dtab {
        header: DtabHeader {
            axes,
            values: layout,
            meta: serde_json::json!({
                "kind": "derma optics precompute",
                "grid": grid,
                "photons_total": photons_total,
                "wavelengths_nm": "380..780 step 10",
                "brdf": "sr^-1, linear sRGB under D65, [theta_in][theta_out][dphi] bins of the grid",
                "profile_rgb": "mm^-2 per photon, rings of profile_d_max_mm/profile_bins",
                "absorbed": "fraction per [layer][absorber]: layers SC, epidermis, papillary, reticular; absorbers eumelanin, pheomelanin, oxyhemoglobin, deoxyhemoglobin, baseline (with the grid's beta-carotene and bilirubin)",
            }),
        },
        data,
    })
}

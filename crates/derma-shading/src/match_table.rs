//! The model-match table (thesis §4.8.6, ModelMatch): for every node of a precompute grid, the
//! fitted parameters of each render model, the subsurface fits and the diffuse colour, as a
//! `.dtab`; values between nodes by multilinear interpolation in the surrounding hypercube
//! (thesis cites Wagner for interpolation in a hypercube), in ∛ along melanin and blood.

use crate::brdf_fit::{fit_brdf, FitGeometry, FitOptions, Weighting};
use crate::error::{Result, ShadingError};
use crate::model_kind::ModelKind;
use crate::render_model::{n_params, param_names};
use crate::surface_fit::SurfaceFit;
use crate::{burley, sum_of_gaussians};
use derma_core::dtab::{Dtab, DtabHeader, DtabValue};
use derma_core::progress::{Progress, Unit};
use derma_optics::precompute::Grid;
use derma_optics::tally::ProfileBins;
use rayon::prelude::*;
use std::path::Path;

/// The precompute grid's axes in [`derma_optics::BioTexel`] order.
pub const BIO_AXES: [&str; 6] = derma_optics::precompute::AXES;

/// What to fit.
#[derive(Clone, Debug)]
pub struct MatchOptions {
    /// Render BRDF models to fit.
    pub models: Vec<ModelKind>,
    /// How BRDF bins count in the residual.
    pub weighting: Weighting,
    /// Annealing and polish settings.
    pub fit: FitOptions,
    /// Gaussians in the sum-of-Gaussians profile fit (d'Eon et al. use 6 for skin).
    pub gaussians: usize,
    /// BRDF bins beyond this zenith (degrees) are left out of the fit.
    pub max_zenith_deg: f64,
}

impl Default for MatchOptions {
    fn default() -> Self {
        Self {
            models: ModelKind::ALL.to_vec(),
            weighting: Weighting::Cosine,
            fit: FitOptions::default(),
            gaussians: 6,
            max_zenith_deg: crate::brdf_fit::DEFAULT_MAX_ZENITH_DEG,
        }
    }
}

/// Residual statistics of one fitted quantity over the grid (relative RMS).
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct ResidualSummary {
    /// The model or profile ("ggx", "burley", "sog").
    pub name: String,
    /// Mean over the nodes.
    pub mean: f64,
    /// Median over the nodes.
    pub median: f64,
    /// 90th percentile over the nodes.
    pub p90: f64,
    /// Largest over the nodes.
    pub max: f64,
    /// Node with the largest residual.
    pub worst_node: usize,
}

impl ResidualSummary {
    fn new(name: &str, v: &[f64]) -> Self {
        let mut s = v.to_vec();
        s.sort_by(f64::total_cmp);
        let q = |f: f64| s[((s.len() - 1) as f64 * f).round() as usize];
        let worst = v
            .iter()
            .enumerate()
            .max_by(|a, b| a.1.total_cmp(b.1))
            .map_or(0, |x| x.0);
        Self {
            name: name.into(),
            mean: v.iter().sum::<f64>() / v.len().max(1) as f64,
            median: q(0.5),
            p90: q(0.9),
            max: q(1.0),
            worst_node: worst,
        }
    }
}

/// The precompute table's bins (from its metadata).
pub fn precompute_grid(pre: &Dtab) -> Result<Grid> {
    serde_json::from_value(pre.header.meta["grid"].clone()).map_err(|e| {
        ShadingError::Invalid(derma_core::Invalid::new(
            "precompute table",
            "a derma optics precompute table (make one with `derma optics merge`)",
            format!("a table whose meta.grid is unreadable ({e})"),
        ))
    })
}

fn slice<'a>(pre: &'a Dtab, node: usize, name: &str) -> Result<&'a [f32]> {
    let (o, l) = pre.header.offset(name).ok_or_else(|| {
        ShadingError::Invalid(derma_core::Invalid::new(
            format!("value '{name}' of the precompute table"),
            "a value every derma optics precompute table has (make one with `derma optics merge`)",
            "none",
        ))
    })?;
    let s = pre.header.stride();
    Ok(&pre.data[node * s + o..node * s + o + l])
}

/// The layout of a match table's node vector.
pub fn value_layout(opts: &MatchOptions) -> Vec<DtabValue> {
    let v = |name: String, len| DtabValue { name, len };
    let mut out = vec![v("albedo".into(), 3)];
    for m in &opts.models {
        out.push(v(m.name().into(), n_params(m.model())));
        out.push(v(format!("{}.rms", m.name()), 1));
    }
    for n in ["albedo", "d_mm", "mfp_mm"] {
        out.push(v(format!("burley.{n}"), 3));
    }
    out.push(v("burley.rms".into(), 1));
    out.push(v("sog.variance_mm2".into(), opts.gaussians));
    out.push(v("sog.weights".into(), 3 * opts.gaussians));
    out.push(v("sog.rms".into(), 1));
    out
}

/// Fits every node of precompute table `pre` (one stage, advancing by entries).
pub fn fit_table(
    pre: &Dtab,
    opts: &MatchOptions,
    progress: &dyn Progress,
) -> Result<(Dtab, Vec<ResidualSummary>)> {
    let grid = precompute_grid(pre)?;
    let bins = grid.brdf_bins();
    let pbins = ProfileBins {
        bins: grid.profile_bins,
        d_max_mm: grid.profile_d_max_mm,
    };
    let geom = FitGeometry::with_cutoff(bins, opts.weighting, opts.max_zenith_deg);
    let nodes = pre.header.nodes();
    // Check the values are there before spending minutes.
    for name in ["linear_srgb", "brdf_rgb", "profile_rgb"] {
        slice(pre, 0, name)?;
    }
    progress.stage("fit", nodes as u64, Unit::Entries);
    let rows: Vec<Vec<f32>> = (0..nodes)
        .into_par_iter()
        .map(|node| -> Result<Vec<f32>> {
            let row = fit_node(pre, node, &geom, &pbins, opts)?;
            progress.advance(1);
            Ok(row)
        })
        .collect::<Result<_>>()?;
    let surface = crate::surface_fit::fit_surface(
        grid.surface,
        bins,
        opts.weighting,
        opts.max_zenith_deg,
        grid.seed,
        progress,
    )?;
    let layout = value_layout(opts);
    let mut header = DtabHeader {
        axes: pre.header.axes.clone(),
        values: layout,
        meta: serde_json::Value::Null,
    };
    let mut summaries = Vec::new();
    for name in opts
        .models
        .iter()
        .map(|m| m.name().to_string())
        .chain(["burley".into(), "sog".into()])
    {
        let (o, _) = header.offset(&format!("{name}.rms")).expect("layout");
        let v: Vec<f64> = rows.iter().map(|r| r[o] as f64).collect();
        summaries.push(ResidualSummary::new(&name, &v));
    }
    let models: serde_json::Map<String, serde_json::Value> = opts
        .models
        .iter()
        .map(|m| {
            (
                m.name().to_string(),
                serde_json::json!(param_names(m.model())),
            )
        })
        .collect();
    header.meta = serde_json::json!({
        "kind": "derma match table",
        "models": models,
        "weighting": opts.weighting.name(),
        "max_zenith_deg": opts.max_zenith_deg,
        "anneal_steps": opts.fit.schedule.steps,
        "seed": opts.fit.seed,
        "precompute": pre.header.meta,
        "albedo": "Monte Carlo diffuse reflectance under diffuse light, linear sRGB (D65)",
        "rms": "relative weighted RMS of the fit (BRDF: over bins and channels; profiles: r-weighted)",
        "burley": "Burley 2015 normalized diffusion per channel: albedo A, shape d (mm), mean free path l = d s(A) (Christensen & Burley 2015)",
        "sog": "d'Eon et al. 2007 sum of Gaussians: variances (mm^2), weights [gaussian][rgb]",
        "residuals": summaries,
        "surface_specular_doc": SURFACE_DOC,
    });
    header.meta[crate::surface_fit::META_KEY] = serde_json::to_value(&surface).expect("plain");
    let data = rows.into_iter().flatten().collect();
    Ok((Dtab { header, data }, summaries))
}

/// What the surface fit in a match table's metadata is.
const SURFACE_DOC: &str = "glTF GGX (roughness, F0) fitted to the light the skin's surface reflects without entering (derma-optics surface_reflection); the specular and roughness maps' source";

/// Adds (or replaces) the surface's specular fit in match table `table`: the surface of its
/// precompute grid, fitted with the table's weighting and zenith cutoff. For tables fitted before
/// the surface fit was part of `fit_table`.
pub fn add_surface_fit(table: &mut MatchTable, progress: &dyn Progress) -> Result<SurfaceFit> {
    let meta = &table.dtab.header.meta;
    let grid: Grid = serde_json::from_value(meta["precompute"]["grid"].clone()).map_err(|e| {
        ShadingError::Invalid(derma_core::Invalid::new(
            "meta.precompute.grid of the match table",
            "the precompute grid the table was fitted to",
            format!("none readable ({e})"),
        ))
    })?;
    let weighting = match meta["weighting"].as_str() {
        Some("uniform") => Weighting::Uniform,
        Some("cosine") | None => Weighting::Cosine,
        Some(other) => {
            return Err(ShadingError::Invalid(derma_core::Invalid::new(
                "meta.weighting of the match table",
                "'cosine' or 'uniform'",
                format!("'{other}'"),
            )))
        }
    };
    let max_zenith = meta["max_zenith_deg"]
        .as_f64()
        .unwrap_or(crate::brdf_fit::DEFAULT_MAX_ZENITH_DEG);
    let bins = grid.brdf_bins();
    let fit = crate::surface_fit::fit_surface(
        grid.surface,
        bins,
        weighting,
        max_zenith,
        grid.seed,
        progress,
    )?;
    let meta = &mut table.dtab.header.meta;
    meta["surface_specular_doc"] = serde_json::json!(SURFACE_DOC);
    meta[crate::surface_fit::META_KEY] = serde_json::to_value(&fit).expect("plain");
    Ok(fit)
}

fn fit_node(
    pre: &Dtab,
    node: usize,
    geom: &FitGeometry,
    pbins: &ProfileBins,
    opts: &MatchOptions,
) -> Result<Vec<f32>> {
    let albedo = slice(pre, node, "linear_srgb")?;
    let brdf: Vec<[f64; 3]> = slice(pre, node, "brdf_rgb")?
        .chunks_exact(3)
        .map(|c| [c[0] as f64, c[1] as f64, c[2] as f64])
        .collect();
    let profile: Vec<[f64; 3]> = slice(pre, node, "profile_rgb")?
        .chunks_exact(3)
        .map(|c| [c[0] as f64, c[1] as f64, c[2] as f64])
        .collect();
    if brdf.len() != geom.len() || profile.len() != pbins.bins {
        return Err(ShadingError::Invalid(derma_core::Invalid::new(
            format!("BRDF and profile lengths of precompute node {node}"),
            format!(
                "the grid's bins ({} BRDF bins and {} profile bins)",
                geom.len(),
                pbins.bins
            ),
            format!("{} and {}", brdf.len(), profile.len()),
        )));
    }
    let mut row: Vec<f32> = albedo.to_vec();
    for m in &opts.models {
        // One annealing stream per (node, model kind): a model fitted alone or with others
        // gives the same parameters.
        let kind = ModelKind::ALL
            .iter()
            .position(|k| k == m)
            .expect("a known model");
        let stream = (node * ModelKind::ALL.len() + kind) as u32;
        let f = fit_brdf(m.model(), geom, &brdf, &opts.fit, stream);
        row.extend(f.params.iter().map(|&v| v as f32));
        row.push(f.relative_rms as f32);
    }
    let fits: Vec<burley::BurleyFit> = (0..3)
        .map(|c| {
            let d: Vec<f64> = profile.iter().map(|p| p[c]).collect();
            burley::fit(pbins, &d, opts.fit.lm)
        })
        .collect();
    row.extend(fits.iter().map(|f| f.albedo as f32));
    row.extend(fits.iter().map(|f| f.d_mm as f32));
    row.extend(fits.iter().map(|f| f.mfp_mm as f32));
    row.push(fits.iter().map(|f| f.relative_rms).fold(0.0, f64::max) as f32);
    let sog = sum_of_gaussians::fit(pbins, &profile, opts.gaussians, opts.fit.lm);
    let mut v = sog.variances_mm2.clone();
    let mut w = sog.weights.clone();
    // Pad when fewer Gaussians were usable (never in practice: fit keeps k).
    v.resize(opts.gaussians, 0.0);
    w.resize(opts.gaussians, [0.0; 3]);
    row.extend(v.iter().map(|&x| x as f32));
    row.extend(w.iter().flatten().map(|&x| x as f32));
    row.push(sog.relative_rms as f32);
    Ok(row)
}

/// Whether values are interpolated in ∛x along the axis named `axis` rather than in x:
/// melanin and blood, whose absorption makes the skin's colour fall off steeply at small
/// fractions and flatten at large ones (Beer–Lambert: e^(−μa·path)), so that a straight line
/// between nodes in x overestimates the albedo in the gap (at melanin 0.33 between nodes 0.2 and
/// 0.5, by ΔE*ab ≈ 8 on the committed table). ∛ is the coordinate Jimenez et al. 2010 §6
/// (eq. 7) chose for the same two chromophores in their skin-colour table.
pub fn interpolates_in_cube_root(axis: &str) -> bool {
    axis == derma_optics::bio::names::MELANIN || axis == derma_optics::bio::names::BLOOD
}

/// Multilinear interpolation over a grid with arbitrary (increasing) node positions per axis:
/// the 2^d corners of the hypercube around a point and their weights (products of the 1-D
/// linear weights, linear in x or, on axes flagged so, in ∛x); axes with a single node are
/// constant.
#[derive(Clone, Debug)]
pub struct Hypercube {
    /// Node coordinates per axis (∛ of the node values on cube-root axes).
    axes: Vec<Vec<f64>>,
    cube_root: Vec<bool>,
    strides: Vec<usize>,
}

impl Hypercube {
    /// A grid over `axes` (node values per axis, first axis slowest), linear along every axis.
    pub fn new(axes: Vec<Vec<f64>>) -> Self {
        let flat = vec![false; axes.len()];
        Self::with_cube_root(axes, flat)
    }

    /// A grid over `axes`, interpolating in ∛x along the axes where `cube_root` is set.
    pub fn with_cube_root(axes: Vec<Vec<f64>>, cube_root: Vec<bool>) -> Self {
        assert_eq!(axes.len(), cube_root.len(), "one flag per axis");
        let mut strides = vec![1; axes.len()];
        for k in (0..axes.len().saturating_sub(1)).rev() {
            strides[k] = strides[k + 1] * axes[k + 1].len();
        }
        let axes = axes
            .into_iter()
            .zip(&cube_root)
            .map(|(a, &c)| {
                if c {
                    a.iter().map(|v| v.cbrt()).collect()
                } else {
                    a
                }
            })
            .collect();
        Self {
            axes,
            cube_root,
            strides,
        }
    }

    /// Interval index and weight of the upper node along axis k (clamped to the axis).
    fn locate(&self, k: usize, x: f64) -> (usize, f64) {
        let x = if self.cube_root[k] { x.cbrt() } else { x };
        let a = &self.axes[k];
        if a.len() < 2 || x <= a[0] {
            return (0, 0.0);
        }
        if x >= a[a.len() - 1] {
            return (a.len() - 2, 1.0);
        }
        let i = a.partition_point(|&v| v <= x) - 1;
        (i, (x - a[i]) / (a[i + 1] - a[i]))
    }

    /// Calls `f(node, weight)` for every corner with non-zero weight.
    pub fn corners(&self, p: &[f64], f: &mut dyn FnMut(usize, f64)) {
        let d = self.axes.len();
        let mut base = 0;
        let mut t = vec![0.0; d];
        for k in 0..d {
            let (i, w) = self.locate(k, p[k]);
            base += i * self.strides[k];
            t[k] = w;
        }
        for mask in 0..(1usize << d) {
            let mut w = 1.0;
            let mut idx = base;
            for k in 0..d {
                if mask >> k & 1 == 1 {
                    w *= t[k];
                    idx += self.strides[k];
                } else {
                    w *= 1.0 - t[k];
                }
            }
            if w != 0.0 {
                f(idx, w);
            }
        }
    }
}

/// A match table read from disk or built in.
pub struct MatchTable {
    /// The table's contents.
    pub dtab: Dtab,
    cube: Hypercube,
    /// For each bio axis, its index in the table's axes.
    bio_axis: [usize; 6],
}

impl MatchTable {
    /// Checks `dtab` is a match table (its axes are bio parameters, its values fitted models); `origin` names it in errors.
    pub fn new(dtab: Dtab, origin: &Path) -> Result<Self> {
        let bad = |m: String| {
            crate::ShadingError::from(derma_core::CoreError::Format {
                path: origin.to_path_buf(),
                message: m,
            })
        };
        if dtab.header.meta["kind"] != "derma match table" {
            return Err(bad(
                "not a derma match table (make one with `derma match fit`)".into(),
            ));
        }
        let mut bio_axis = [0; 6];
        for (k, name) in BIO_AXES.iter().enumerate() {
            bio_axis[k] = dtab
                .header
                .axes
                .iter()
                .position(|a| a.name == *name)
                .ok_or_else(|| bad(format!("missing axis '{name}'")))?;
        }
        let cube = Hypercube::with_cube_root(
            dtab.header.axes.iter().map(|a| a.values.clone()).collect(),
            dtab.header
                .axes
                .iter()
                .map(|a| interpolates_in_cube_root(&a.name))
                .collect(),
        );
        Ok(Self {
            dtab,
            cube,
            bio_axis,
        })
    }

    /// Reads and checks the match table at `path`.
    pub fn read(path: &Path) -> Result<Self> {
        Self::new(Dtab::read(path)?, path)
    }

    /// The surface's specular fit, where the table has one (tables fitted before it was part of
    /// the fit have none: [`add_surface_fit`] adds it).
    pub fn surface_fit(&self) -> Option<SurfaceFit> {
        serde_json::from_value(self.dtab.header.meta[crate::surface_fit::META_KEY].clone()).ok()
    }

    /// The largest `NAME.rms` (relative RMS of fit NAME) over the table's nodes; `None` where
    /// the table has no such value.
    pub fn worst_rms(&self, name: &str) -> Option<f64> {
        let (o, _) = self.dtab.header.offset(&format!("{name}.rms"))?;
        let s = self.dtab.header.stride();
        Some(
            self.dtab
                .data
                .chunks(s)
                .map(|r| r[o] as f64)
                .fold(0.0, f64::max),
        )
    }

    /// Table coordinates of a texel.
    pub fn coords(&self, bio: &derma_optics::BioTexel) -> Vec<f64> {
        let v = bio.to_array();
        let mut p = vec![0.0; self.dtab.header.axes.len()];
        for k in 0..6 {
            p[self.bio_axis[k]] = v[k] as f64;
        }
        p
    }

    /// Interpolated value `name` at table coordinates `p`.
    pub fn value_at(&self, p: &[f64], name: &str) -> Option<Vec<f64>> {
        self.weighted_sum(p, name, |v| v)
    }

    /// Value `name` at `p` interpolated geometrically (multilinear in the logarithm), as the
    /// table appearance interpolates colours; `None` if the table has no such value. Values
    /// must be positive.
    pub fn value_at_geometric(&self, p: &[f64], name: &str) -> Option<Vec<f64>> {
        let out = self.weighted_sum(p, name, f64::ln)?;
        Some(out.into_iter().map(f64::exp).collect())
    }

    /// Σ over the corners around `p` of weight × `f(value)`, per component of `name`.
    fn weighted_sum(&self, p: &[f64], name: &str, f: impl Fn(f64) -> f64) -> Option<Vec<f64>> {
        let (o, l) = self.dtab.header.offset(name)?;
        let s = self.dtab.header.stride();
        let mut out = vec![0.0; l];
        self.cube.corners(p, &mut |node, w| {
            for (j, v) in out.iter_mut().enumerate() {
                *v += w * f(self.dtab.data[node * s + o + j] as f64);
            }
        });
        Some(out)
    }

    /// Node stride of each table axis (first axis slowest).
    pub fn strides(&self) -> &[usize] {
        &self.cube.strides
    }

    /// Names of the models fitted in this table.
    pub fn models(&self) -> Vec<ModelKind> {
        ModelKind::ALL
            .into_iter()
            .filter(|m| self.dtab.header.offset(m.name()).is_some())
            .collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_committed_surface_fit_is_what_the_table_makes_again() {
        // The committed table's surface fit, redone from its own metadata (grid surface, bins,
        // seed, weighting): the same values, so the maps' source is rebuildable.
        let read = || {
            let d =
                Dtab::from_bytes(crate::table_appearance::BUILTIN_TABLE, Path::new("t")).unwrap();
            MatchTable::new(d, Path::new("t")).unwrap()
        };
        let committed = read().surface_fit().expect("a surface fit");
        let mut t = read();
        t.dtab.header.meta[crate::surface_fit::META_KEY] = serde_json::Value::Null;
        assert!(t.surface_fit().is_none());
        let again = add_surface_fit(&mut t, &derma_core::progress::Silent).unwrap();
        assert_eq!(again, committed);
        assert_eq!(t.surface_fit(), Some(committed));
    }

    #[test]
    fn multilinear_is_exact_at_nodes_and_linear_along_edges() {
        let axes = vec![vec![0.0, 1.0, 3.0], vec![5.0], vec![-1.0, 0.0, 2.0, 4.0]];
        let cube = Hypercube::new(axes.clone());
        // f = node index as value: exact at nodes.
        let f = |i: usize, j: usize| (i * 4 + j) as f64 * 1.7 + ((i * 7 + j * 3) % 5) as f64;
        let value = |p: &[f64]| {
            let mut v = 0.0;
            cube.corners(p, &mut |n, w| v += w * f(n / 4, n % 4));
            v
        };
        for i in 0..3 {
            for j in 0..4 {
                let v = value(&[axes[0][i], 5.0, axes[2][j]]);
                assert!((v - f(i, j)).abs() < 1e-12);
            }
        }
        // Along an edge: linear between its end nodes.
        for t in [0.1, 0.37, 0.9] {
            let x = 1.0 + 2.0 * t;
            let v = value(&[x, 5.0, 2.0]);
            let want = f(1, 2) * (1.0 - t) + f(2, 2) * t;
            assert!((v - want).abs() < 1e-12, "{v} vs {want}");
        }
        // Weights sum to one inside, and outside the range the value clamps.
        let mut s = 0.0;
        cube.corners(&[0.3, 7.0, 2.9], &mut |_, w| s += w);
        assert!((s - 1.0).abs() < 1e-12);
        assert!((value(&[-9.0, 5.0, -9.0]) - f(0, 0)).abs() < 1e-12);
        assert!((value(&[9.0, 5.0, 9.0]) - f(2, 3)).abs() < 1e-12);
    }

    #[test]
    fn cube_root_axes_interpolate_linearly_in_the_cube_root() {
        let cube = Hypercube::with_cube_root(
            vec![vec![0.008, 0.125, 1.0], vec![0.0, 1.0]],
            vec![true, false],
        );
        let weights = |p: &[f64]| {
            let mut w = vec![0.0; 6];
            cube.corners(p, &mut |n, x| w[n] += x);
            w
        };
        // ∛: 0.2, 0.5, 1.0; 0.343 = 0.7³ lies 2/5 of the way from 0.5 to 1.0.
        let w = weights(&[0.343, 0.0]);
        assert!(
            (w[2] - 0.6).abs() < 1e-12 && (w[4] - 0.4).abs() < 1e-12,
            "{w:?}"
        );
        // Nodes stay exact; the linear axis stays linear.
        let w = weights(&[0.125, 0.25]);
        assert!(
            (w[2] - 0.75).abs() < 1e-12 && (w[3] - 0.25).abs() < 1e-12,
            "{w:?}"
        );
        assert!(interpolates_in_cube_root("melanin") && interpolates_in_cube_root("blood"));
        assert!(!interpolates_in_cube_root("epidermis_um"));
    }
}

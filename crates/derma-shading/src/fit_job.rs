//! `derma match fit` as one library call (model matching, docs/matching.md): a precompute table
//! is read, every entry fitted, the match table, its residual CSV and the optional plots written.

use crate::error::{Result, ShadingError};
use crate::match_report;
use crate::match_table::{self, MatchOptions, MatchTable, ResidualSummary};
use derma_core::dtab::Dtab;
use derma_core::progress::Progress;
use std::path::PathBuf;
use std::time::Instant;

/// What `derma match fit` asks for.
#[derive(Clone, Debug)]
pub struct FitJob {
    /// The precompute table (`.dtab` from `derma optics merge`).
    pub grid: PathBuf,
    /// The match table to write (a `.json` sidecar and a `.residuals.csv` go beside it).
    pub out: PathBuf,
    /// Models, weighting, annealing, profile fits.
    pub options: MatchOptions,
    /// A folder for SVG plots of fitted against simulated BRDFs and profiles.
    pub plots: Option<PathBuf>,
    /// Nodes to plot; empty: fair, medium and dark melanin with the other axes mid-range.
    pub plot_nodes: Vec<usize>,
}

/// What a [`FitJob`] made.
pub struct FitReport {
    /// Entries of the grid fitted.
    pub entries: usize,
    /// Wall-clock seconds of the fits.
    pub seconds: f64,
    /// Relative RMS residuals over the grid, per model and profile.
    pub summary: Vec<ResidualSummary>,
    /// The per-entry residual CSV.
    pub residuals: PathBuf,
    /// How many plots were written, where.
    pub plots: Option<(usize, PathBuf)>,
}

/// Runs `job`, advancing `progress` per fitted entry.
pub fn run(job: &FitJob, progress: &dyn Progress) -> Result<FitReport> {
    let residuals = job.out.with_extension("residuals.csv");
    let mut outputs = vec![job.out.clone(), residuals.clone()];
    outputs.extend(job.plots.clone());
    derma_core::atomic::check_inputs_spared(&outputs, &[job.grid.as_path()])?;
    let z = job.options.max_zenith_deg;
    if !(z > 0.0 && z <= 90.0) {
        return Err(ShadingError::Invalid(derma_core::Invalid::new(
            "max zenith",
            "degrees in (0, 90]",
            format!("{z}°"),
        )));
    }
    let pre = Dtab::read(&job.grid)?;
    let t0 = Instant::now();
    let (table, summary) = match_table::fit_table(&pre, &job.options, progress)?;
    let seconds = t0.elapsed().as_secs_f64();
    table.write(&job.out)?;
    derma_core::atomic::write_bytes(
        &residuals,
        match_report::residual_csv(&table, &job.options).as_bytes(),
    )?;
    let plots = match &job.plots {
        Some(dir) => {
            let mt = MatchTable::new(table, &job.out)?;
            let nodes = if job.plot_nodes.is_empty() {
                match_report::default_plot_nodes(&pre)
            } else {
                job.plot_nodes.clone()
            };
            Some((
                match_report::write_plots(&pre, &mt, &job.options, &nodes, dir)?,
                dir.clone(),
            ))
        }
        None => None,
    };
    Ok(FitReport {
        entries: pre.header.nodes(),
        seconds,
        summary,
        residuals,
        plots,
    })
}

/// `derma match surface`: match table `table` with the surface's specular fit added (or redone,
/// [`match_table::add_surface_fit`]), written to `out`; `table` itself is left as it is.
pub fn add_surface(
    table: &std::path::Path,
    out: &std::path::Path,
    progress: &dyn Progress,
) -> Result<crate::surface_fit::SurfaceFit> {
    derma_core::atomic::check_inputs_spared(&[out.to_path_buf()], &[table])?;
    let mut t = MatchTable::read(table)?;
    let fit = match_table::add_surface_fit(&mut t, progress)?;
    t.dtab.write(out)?;
    Ok(fit)
}

//! Which appearance reproduces the Monte Carlo skin's colour better between grid nodes: the
//! built-in match table (multilinear over 360 simulated entries) or the analytic spectral
//! Kubelka–Munk model? Simulates skin at points off the table's nodes and prints CIELAB ΔE*ab
//! of each appearance's base colour against the simulation's diffuse albedo. With `nodes` the
//! points are the table's own grid nodes, simulated with fresh seeds: what remains there is the
//! photon noise of table and check, so the off-node excess is the interpolation's.
//!
//! A fourth argument names another match table (.dtab) to check instead of the built-in one.
//! Points off the nodes are uniform in ∛melanin and ∛blood and in the other axes over the
//! table's ranges (stratum corneum 10–20 µm, what derma-skin paints).
//!
//! cargo run --release -p derma-shading --example 02_appearance_check [points] [photons] [nodes] [table]

use derma_core::color::{linear_srgb_to_xyz, xyz_to_lab};
use derma_core::gpu::Device;
use derma_core::progress::Silent;
use derma_core::rng::Philox;
use derma_optics::precompute::Grid;
use derma_optics::simulate::{simulate_skin, SkinSimConfig};
use derma_shading::{Appearance, BioTexel, SpectralKubelkaMunk, TableAppearance};

fn delta_e(a: [f64; 3], b: [f64; 3]) -> f64 {
    let (la, lb) = (
        xyz_to_lab(linear_srgb_to_xyz(a)),
        xyz_to_lab(linear_srgb_to_xyz(b)),
    );
    ((la[0] - lb[0]).powi(2) + (la[1] - lb[1]).powi(2) + (la[2] - lb[2]).powi(2)).sqrt()
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().collect();
    let points: u64 = args.get(1).map_or(Ok(12), |s| s.parse())?;
    let photons: u64 = args.get(2).map_or(Ok(400_000), |s| s.parse())?;
    let at_nodes = match args.get(3).map(String::as_str) {
        None | Some("off") => false,
        Some("nodes") => true,
        Some(other) => {
            return Err(format!("third argument {other:?}: expected off or nodes").into())
        }
    };
    // The grid the built-in table was fitted on (its nodes; `nodes` checks the built-in table).
    let grid = Grid::parse(
        include_str!("../data/match-grid.toml"),
        std::path::Path::new("match-grid.toml"),
    )?;
    let table = match args.get(4) {
        Some(path) => TableAppearance::read(std::path::Path::new(path))?,
        None => TableAppearance::builtin(),
    };
    let analytic = SpectralKubelkaMunk::default();
    let rng = Philox::new(2026, 7);
    println!(
        "{:>7} {:>6} {:>6} {:>5} {:>4} {:>5}   {:>22}   {:>8} {:>8}",
        "melanin", "pheo", "blood", "oxy", "sc", "epi", "Monte Carlo albedo", "ΔE table", "ΔE KM"
    );
    let (mut st, mut sa) = (0.0, 0.0);
    let (m, b) = (&grid.axes.melanin, &grid.axes.blood);
    for k in 0..points {
        // Uniform in the table's (cube-root) melanin and blood ranges, off the nodes.
        let u = rng.uniform4(k, 0).map(|x| x as f64);
        let v = rng.uniform4(k, 1).map(|x| x as f64);
        let cb = |lo: f64, hi: f64, t: f64| (lo.cbrt() + (hi.cbrt() - lo.cbrt()) * t).powi(3);
        let bio = if at_nodes {
            grid.node((u[0] * grid.len() as f64) as usize % grid.len())
        } else {
            BioTexel {
                melanin: cb(m[0], m[m.len() - 1], u[0]) as f32,
                pheomelanin: u[1] as f32,
                blood: cb(b[0], b[b.len() - 1], u[2]) as f32,
                oxygenation: (0.55 + 0.4 * u[3]) as f32,
                stratum_corneum_um: (10.0 + 10.0 * v[1]) as f32,
                epidermis_um: (40.0 + 60.0 * v[0]) as f32,
            }
        };
        let cfg = SkinSimConfig {
            photons,
            seed: 100 + k,
            ..SkinSimConfig::default()
        };
        let mc = simulate_skin(&bio, &cfg, Device::Cpu, &Silent)?.linear_srgb;
        let t = table.albedo(&bio).map(|x| x as f64);
        let a = analytic.albedo(&bio).map(|x| x as f64);
        let (et, ea) = (delta_e(t, mc), delta_e(a, mc));
        st += et;
        sa += ea;
        println!(
            "{:>7.4} {:>6.3} {:>6.4} {:>5.2} {:>4.0} {:>5.0}   ({:.4}, {:.4}, {:.4})   {:>8.2} {:>8.2}",
            bio.melanin,
            bio.pheomelanin,
            bio.blood,
            bio.oxygenation,
            bio.stratum_corneum_um,
            bio.epidermis_um,
            mc[0],
            mc[1],
            mc[2],
            et,
            ea
        );
    }
    println!(
        "mean ΔE*ab over {points} {} points: table {:.2}, analytic {:.2}",
        if at_nodes { "node" } else { "off-node" },
        st / points as f64,
        sa / points as f64
    );
    Ok(())
}

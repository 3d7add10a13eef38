//! Shards, resume and merge of the precompute grid.

use derma_core::progress::Silent;
use derma_optics::precompute::{self, Grid, Shard};
use derma_optics::simulate::SkinSimConfig;
use derma_optics::yellow_pigments::YellowPigments;
use derma_optics::Device;
use std::path::{Path, PathBuf};

const GRID: &str = r#"
photons = 2050
seed = 3
brdf = [3, 3, 2]
profile_bins = 8
profile_d_max_mm = 4.0
[axes]
melanin = [0.02, 0.2]
pheomelanin = [0.3]
blood = [0.01, 0.05]
oxygenation = [0.75]
stratum_corneum_um = [10.0]
epidermis_um = [80.0]
"#;

fn tmp(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("derma-precompute-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    d
}

fn fill(dir: &Path, grid: &Grid, shard: Shard) -> usize {
    precompute::prepare_dir(dir, grid).unwrap();
    let todo = precompute::pending(dir, grid, shard);
    for &i in &todo {
        precompute::compute_entry(dir, grid, i, Device::Cpu, &Silent).unwrap();
    }
    todo.len()
}

#[test]
fn shards_merge_to_the_same_table_and_resume_skips_finished_entries() {
    let grid = Grid::parse(GRID, std::path::Path::new("test.toml")).unwrap();
    assert_eq!(grid.len(), 4);
    let whole = tmp("whole");
    assert_eq!(fill(&whole, &grid, Shard::parse("1/1").unwrap()), 4);
    // Resume: nothing left, and finished entries are not rewritten.
    let entry = whole.join("entries/000002.json");
    let before = std::fs::metadata(&entry).unwrap().modified().unwrap();
    assert_eq!(fill(&whole, &grid, Shard::parse("1/1").unwrap()), 0);
    assert_eq!(
        std::fs::metadata(&entry).unwrap().modified().unwrap(),
        before
    );

    let (a, b) = (tmp("a"), tmp("b"));
    assert_eq!(fill(&a, &grid, Shard::parse("1/2").unwrap()), 2);
    assert_eq!(fill(&b, &grid, Shard::parse("2/2").unwrap()), 2);
    let t1 = precompute::merge(std::slice::from_ref(&whole)).unwrap();
    let t2 = precompute::merge(&[b.clone(), a.clone()]).unwrap();
    assert_eq!(
        t1.to_bytes(),
        t2.to_bytes(),
        "sharding does not change the table"
    );
    assert_eq!(t1.header.nodes(), 4);
    // More melanin → darker: node 0 (melanin 0.02) vs node 2 (0.2), same blood.
    let (o, _) = t1.header.offset("linear_srgb").unwrap();
    let s = t1.header.stride();
    assert!(t1.data[2 * s + o + 1] < t1.data[o + 1]);

    // A missing shard is a clear error; a different grid in the same directory is refused.
    let e = precompute::merge(std::slice::from_ref(&a))
        .unwrap_err()
        .to_string();
    assert!(e.contains("2 of 4 missing"), "{e}");
    let other = Grid {
        photons: 999,
        ..grid.clone()
    };
    let e = precompute::prepare_dir(&a, &other).unwrap_err().to_string();
    assert!(e.contains("different grid"), "{e}");
    assert!(
        Shard::parse("3/2").is_err() && Shard::parse("0/2").is_err() && Shard::parse("x").is_err()
    );
    for d in [whole, a, b] {
        let _ = std::fs::remove_dir_all(d);
    }
}

#[test]
fn default_grid_is_4_to_the_6() {
    let g = Grid::default_grid();
    assert_eq!(g.len(), 4096);
    assert_eq!(g.photons, 1_000_000);
    let last = g.node(4095);
    assert_eq!((last.melanin, last.epidermis_um), (0.5, 200.0));
    assert_eq!(g.yellow, YellowPigments::BIOSPEC);
    assert_eq!(g.config(7).yellow, YellowPigments::BIOSPEC);
}

#[test]
fn files_from_before_the_yellow_pigments_read_as_without_them() {
    // A grid (or a run directory's grid.toml) without [yellow_pigments] was simulated without
    // them: resuming or merging it must not pass for a grid with them.
    let old = Grid::parse(GRID, Path::new("old.toml")).unwrap();
    assert_eq!(old.yellow, YellowPigments::NONE);
    let with = format!("{GRID}\n[yellow_pigments]\ncarotene_epidermis_g_per_l = 0.00021\ncarotene_dermis_g_per_l = 0.00007\nbilirubin_blood_g_per_l = 0.05\n");
    let new = Grid::parse(&with, Path::new("new.toml")).unwrap();
    assert_eq!(new.yellow, YellowPigments::BIOSPEC);
    assert_ne!(old, new);
    // The same for a simulation's settings (entries and result.json files).
    let mut v = serde_json::to_value(SkinSimConfig::default()).unwrap();
    v.as_object_mut().unwrap().remove("yellow");
    let back: SkinSimConfig = serde_json::from_value(v).unwrap();
    assert_eq!(back.yellow, YellowPigments::NONE);
    // Negative concentrations are refused, naming the section.
    let bad = with.replace("= 0.05", "= -1");
    let e = Grid::parse(&bad, Path::new("bad.toml"))
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("bad.toml") && e.contains("yellow_pigments"),
        "{e}"
    );
}

//! A precompute directory's grid never panics its reader (docs/optics.md, resumable runs):
//! `grid.toml` truncated, with a byte changed or of arbitrary text makes
//! `precompute::prepare_dir` refuse the directory, or accept it only when it holds the same
//! grid.

use derma_optics::precompute::{self, Grid};
use derma_test_support::damaged;
use proptest::prelude::*;
use std::path::{Path, PathBuf};

const GRID: &str = "photons = 200\nseed = 1\nbrdf = [2, 2, 2]\nprofile_bins = 4\n[axes]\nmelanin = [0.05, 0.2]\npheomelanin = [0.3]\nblood = [0.02]\noxygenation = [0.7]\nstratum_corneum_um = [15.0]\nepidermis_um = [60.0]\n";

fn scratch(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("derma-robust-grid-dir-{}", std::process::id()));
    let p = d.join(name);
    let _ = std::fs::remove_dir_all(&p);
    std::fs::create_dir_all(&p).unwrap();
    p
}

fn grid() -> Grid {
    Grid::parse(GRID, Path::new("grid.toml")).unwrap()
}

/// The bytes of `grid.toml` as `prepare_dir` writes it.
fn written() -> Vec<u8> {
    let dir = scratch("written");
    precompute::prepare_dir(&dir, &grid()).unwrap();
    std::fs::read(dir.join("grid.toml")).unwrap()
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(derma_test_support::proptest_cases(48)))]

    #[test]
    fn a_damaged_grid_file_is_refused_or_the_same_grid(cut in 0.0f64..1.0, at in 0.0f64..1.0, flip in 1u8..=255) {
        let dir = scratch("damaged");
        let bytes = damaged(&written(), cut, at, flip);
        std::fs::write(dir.join("grid.toml"), &bytes).unwrap();
        let same = std::str::from_utf8(&bytes)
            .ok()
            .and_then(|t| Grid::parse(t, Path::new("grid.toml")).ok())
            .is_some_and(|g| g == grid());
        prop_assert_eq!(precompute::prepare_dir(&dir, &grid()).is_ok(), same);
    }

    #[test]
    fn an_arbitrary_grid_file_is_refused(text in "\\PC{0,200}") {
        let dir = scratch("arbitrary");
        std::fs::write(dir.join("grid.toml"), &text).unwrap();
        prop_assert!(precompute::prepare_dir(&dir, &grid()).is_err());
    }
}

#[test]
fn a_directory_is_prepared_once_and_resumed_with_its_grid() {
    let dir = scratch("valid");
    precompute::prepare_dir(&dir, &grid()).unwrap();
    precompute::prepare_dir(&dir, &grid()).unwrap();
    let other = Grid::parse(&GRID.replace("seed = 1", "seed = 2"), Path::new("g")).unwrap();
    assert!(precompute::prepare_dir(&dir, &other).is_err());
}

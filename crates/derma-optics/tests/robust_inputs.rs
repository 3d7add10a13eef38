//! The optics' parsers never panic or ask for absurd memory: grid TOML (arbitrary text, and
//! known keys with arbitrary values), slab layers, shards, and precompute entries damaged on
//! disk all give an error (or a valid result).

use derma_core::gpu::Device;
use derma_core::progress::Silent;
use derma_optics::precompute::{self, Grid, Shard};
use derma_optics::slab::parse_layer;
use proptest::prelude::*;
use std::path::Path;

const GRID: &str = "photons = 200\nseed = 1\nbrdf = [2, 2, 2]\nprofile_bins = 4\n[axes]\nmelanin = [0.05]\npheomelanin = [0.3]\nblood = [0.02]\noxygenation = [0.7]\nstratum_corneum_um = [15.0]\nepidermis_um = [60.0]\n";

proptest! {
    #![proptest_config(ProptestConfig::with_cases(derma_test_support::proptest_cases(48)))]

    #[test]
    fn arbitrary_text_is_not_a_panic(text in "\\PC{0,200}") {
        let _ = Grid::parse(&text, Path::new("fuzz.toml"));
        let _ = parse_layer(&text);
        let _ = Shard::parse(&text);
    }

    #[test]
    fn grid_values_are_checked(
        line in 0usize..4,
        value in prop_oneof![
            any::<i64>().prop_map(|v| v.to_string()),
            any::<f64>().prop_map(|v| format!("{v:?}")),
            Just("[0, 0, 0]".to_string()),
            Just("[100000, 100000, 100000]".to_string()),
            Just("[4294967295, 1, 1]".to_string()),
        ],
    ) {
        let key = ["photons", "brdf", "profile_bins", "profile_d_max_mm"][line];
        let text = GRID
            .lines()
            .filter(|l| !l.starts_with(key))
            .map(|l| if l == "[axes]" { format!("{key} = {value}\n[axes]") } else { l.to_string() })
            .collect::<Vec<_>>()
            .join("\n");
        if let Ok(g) = Grid::parse(&text, Path::new("fuzz.toml")) {
            // An accepted grid describes tallies of a sane size.
            prop_assert!(g.brdf.iter().all(|&b| b <= derma_optics::tally::MAX_BRDF_BINS), "{text}");
            prop_assert!(g.profile_bins <= 1 << 16, "{text}");
        }
    }

    #[test]
    fn damaged_entries_make_merge_fail_not_panic(cut in 0.0f64..1.0, at in 0.0f64..1.0, flip in 1u8..=255) {
        let dir = std::env::temp_dir().join(format!("derma-robust-optics-{}", std::process::id()));
        let grid = Grid::parse(GRID, Path::new("grid")).unwrap();
        let entry = dir.join("entries").join("000000.json");
        if !entry.exists() {
            precompute::run_shard(&dir, &grid, Shard::parse("1/1").unwrap(), Device::Cpu, &Silent).unwrap();
            std::fs::copy(&entry, dir.join("good.json")).unwrap();
        }
        let good = std::fs::read(dir.join("good.json")).unwrap();
        std::fs::write(&entry, derma_test_support::damaged(&good, cut, at, flip)).unwrap();
        let _ = precompute::merge(std::slice::from_ref(&dir));
    }
}

//! The match table's readers never panic on bad files (docs/optics.md's table, `derma match
//! fit`'s output): the built-in table truncated or with a byte changed is an error, and a valid
//! `.dtab` of any axes, values and kind is a match table only when it is one —
//! `MatchTable::read` and `TableAppearance::read`.

use derma_core::dtab::{Dtab, DtabAxis, DtabHeader, DtabValue};
use derma_shading::match_table::{MatchTable, BIO_AXES};
use derma_shading::table_appearance::{TableAppearance, BUILTIN_TABLE};
use derma_test_support::damaged;
use proptest::prelude::*;
use std::path::PathBuf;

fn scratch(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("derma-robust-shading-{}", std::process::id()));
    std::fs::create_dir_all(&d).unwrap();
    d.join(name)
}

/// The values a match table's appearance reads (each three floats or more: shorter ones are
/// not generated, as `TableAppearance::with_base` reads three of each without checking).
const VALUES: [&str; 4] = ["albedo", "burley.albedo", "burley.mfp_mm", "ggx.rms"];

proptest! {
    #![proptest_config(ProptestConfig::with_cases(derma_test_support::proptest_cases(32)))]

    #[test]
    fn a_damaged_table_is_an_error(cut in 0.0f64..1.0, at in 0.0f64..1.0, flip in 1u8..=255) {
        let p = scratch("damaged.dtab");
        std::fs::write(&p, damaged(BUILTIN_TABLE, cut, at, flip)).unwrap();
        prop_assert!(MatchTable::read(&p).is_err());
        prop_assert!(TableAppearance::read(&p).is_err());
    }

    #[test]
    fn arbitrary_bytes_are_not_a_table(bytes in proptest::collection::vec(any::<u8>(), 0..400)) {
        let p = scratch("arbitrary.dtab");
        std::fs::write(&p, &bytes).unwrap();
        prop_assert!(MatchTable::read(&p).is_err());
        prop_assert!(TableAppearance::read(&p).is_err());
    }

    #[test]
    fn a_table_of_any_axes_and_values_is_a_match_table_only_when_it_is_one(
        axes in proptest::collection::vec(proptest::bool::weighted(0.9), 6),
        values in proptest::collection::vec((proptest::bool::weighted(0.9), 1usize..5), 4),
        kind in prop_oneof![Just("derma match table"), Just("derma skin-colour LUT"), Just("")],
        fill in -1.0f32..2.0,
    ) {
        let header = DtabHeader {
            axes: BIO_AXES
                .iter()
                .zip(&axes)
                .filter(|(_, keep)| **keep)
                .map(|(name, _)| DtabAxis { name: name.to_string(), values: vec![0.0, 1.0] })
                .collect(),
            values: VALUES
                .iter()
                .zip(&values)
                .filter(|(_, (keep, _))| *keep)
                .map(|(name, (_, len))| DtabValue { name: name.to_string(), len: *len })
                .collect(),
            meta: serde_json::json!({ "kind": kind }),
        };
        let data = vec![fill; header.nodes() * header.stride()];
        let p = scratch("any.dtab");
        std::fs::write(&p, Dtab { header, data }.to_bytes()).unwrap();
        let is_one = kind == "derma match table" && axes.iter().all(|a| *a);
        prop_assert_eq!(MatchTable::read(&p).is_ok(), is_one);
        let appearance = TableAppearance::read(&p);
        prop_assert!(appearance.is_err() || is_one);
    }
}

#[test]
fn the_built_in_table_reads_from_a_file() {
    let p = scratch("builtin.dtab");
    std::fs::write(&p, BUILTIN_TABLE).unwrap();
    assert!(MatchTable::read(&p).is_ok());
    assert!(TableAppearance::read(&p).is_ok());
}

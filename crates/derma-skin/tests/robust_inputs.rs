//! The skin's parsers never panic or overflow on bad input: TOML configs (arbitrary text, and
//! known keys with arbitrary values), field expressions (arbitrary text, deep nesting, very
//! long), and field files of arbitrary bytes.

use derma_core::progress::Silent;
use derma_core::Map;
use derma_skin::config::SkinConfig;
use derma_skin::field::FieldSet;
use proptest::prelude::*;

fn fields() -> FieldSet {
    let mut f = FieldSet::default();
    f.scalars.insert("face".into(), Map::filled(4, 4, 0.5));
    f.scalars.insert("eyes".into(), Map::filled(8, 2, 0.25));
    f
}

/// Keys of the config with a value slot, as `[section]\nkey = VALUE`.
const KEYS: [(&str, &str); 8] = [
    ("", "size"),
    ("", "seed"),
    ("mole", "radius_sigma_mm"),
    ("freckle", "power"),
    ("baseline", "phi"),
    ("material", "specular_f0"),
    ("detail", "tile_size"),
    ("surface", "patch_size_mm"),
];

proptest! {
    #![proptest_config(ProptestConfig::with_cases(derma_test_support::proptest_cases(64)))]

    #[test]
    fn arbitrary_text_is_not_a_panic(text in "\\PC{0,200}") {
        let _ = SkinConfig::from_toml(&text, "fuzz.toml");
        let _ = fields().define("x", &text);
    }

    #[test]
    fn known_keys_with_any_value_give_an_error_or_a_valid_config(
        k in 0..KEYS.len(),
        value in prop_oneof![
            any::<f64>().prop_map(|v| format!("{v:?}")),
            any::<i64>().prop_map(|v| v.to_string()),
            Just("nan".to_string()),
            Just("inf".to_string()),
            Just("-inf".to_string()),
            Just("\"text\"".to_string()),
            Just("[1.0, -2.0]".to_string()),
            Just("{ min = 1.0, max = 0.0 }".to_string()),
        ],
    ) {
        let (section, key) = KEYS[k];
        let text = if section.is_empty() {
            format!("{key} = {value}\n")
        } else {
            format!("[{section}]\n{key} = {value}\n")
        };
        match SkinConfig::from_toml(&text, "fuzz.toml") {
            Ok(cfg) => prop_assert!(cfg.validate("again").is_ok()),
            Err(e) => prop_assert!(e.to_string().contains("fuzz.toml"), "{e}"),
        }
    }

    #[test]
    fn expressions_over_known_fields_give_an_error_or_a_field_in_range(
        expr in "[a-z()+*/,. 0-9-]{0,40}",
    ) {
        let mut f = fields();
        if f.define("x", &expr).is_ok() {
            let m = f.scalar("x").unwrap();
            prop_assert!(m.data().iter().all(|v| (0.0..=1.0).contains(v)), "{expr}");
        }
    }

    #[test]
    fn field_files_of_arbitrary_bytes_are_errors(bytes in proptest::collection::vec(any::<u8>(), 0..256)) {
        let d = std::env::temp_dir().join(format!("derma-robust-skin-{}", std::process::id()));
        std::fs::create_dir_all(&d).unwrap();
        for name in ["moles.png", "moles.exr", "wrinkle_vectors.png"] {
            let p = d.join(name);
            std::fs::write(&p, &bytes).unwrap();
            let stem = name.split('.').next().unwrap();
            prop_assert!(fields().load_file(stem, &p, &Silent).is_err());
        }
    }
}

#[test]
fn deep_and_long_expressions_are_refused_not_overflowed() {
    for expr in [
        "(".repeat(100_000),
        format!("{}face{}", "(".repeat(10_000), ")".repeat(10_000)),
        "-".repeat(100_000) + "face",
        format!("face{}", "+face".repeat(50_000)),
        format!("{}face{}", "min(face, ".repeat(1000), ")".repeat(1000)),
    ] {
        let e = fields().define("x", &expr).unwrap_err().to_string();
        assert!(
            e.contains("nested") || e.contains("characters"),
            "{}: {e}",
            &expr[..20]
        );
    }
    // Nesting within the limit works.
    let mut f = fields();
    f.define("x", &format!("{}face{}", "(".repeat(30), ")".repeat(30)))
        .unwrap();
    assert!((f.scalar("x").unwrap().data()[0] - 0.5).abs() < 1e-6);
}

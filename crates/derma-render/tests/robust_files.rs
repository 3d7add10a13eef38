//! The renderer's reader never panics on bad files (docs/render.md's inputs): a texture set
//! with a damaged map gives an error, or maps of one size.

use derma_core::image_io::write_png8;
use derma_core::Map;
use derma_render::material::SkinMaps;
use derma_test_support::{damaged, scratch_dir};
use proptest::prelude::*;
use std::path::PathBuf;
use std::sync::OnceLock;

const MAPS: [&str; 4] = [
    "base_color.png",
    "normal.png",
    "roughness.png",
    "specular.png",
];

/// A valid 8 × 8 texture set (the four maps the renderer needs), written once.
fn texture_set() -> &'static PathBuf {
    static DIR: OnceLock<PathBuf> = OnceLock::new();
    DIR.get_or_init(|| {
        let d = scratch_dir("robust-render-set");
        let m = |v: f32| Map::from_vec(8, 8, vec![v; 64]).unwrap();
        let (a, b, c) = (m(0.6), m(0.5), m(1.0));
        write_png8(&d.join(MAPS[0]), &[&a, &b, &b]).unwrap();
        write_png8(&d.join(MAPS[1]), &[&b, &b, &c]).unwrap();
        write_png8(&d.join(MAPS[2]), &[&b]).unwrap();
        write_png8(&d.join(MAPS[3]), &[&b]).unwrap();
        d
    })
}

#[test]
fn the_valid_set_reads() {
    SkinMaps::from_dir(texture_set()).unwrap();
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(derma_test_support::proptest_cases(48)))]

    #[test]
    fn a_set_with_a_damaged_map_is_an_error_or_maps(
        which in 0usize..4, cut in 0.0f64..1.0, at in 0.0f64..1.0, flip in 1u8..=255,
    ) {
        let src = texture_set();
        let d = scratch_dir("robust-render-damaged");
        for f in MAPS {
            std::fs::copy(src.join(f), d.join(f)).unwrap();
        }
        let bytes = damaged(&std::fs::read(src.join(MAPS[which])).unwrap(), cut, at, flip);
        std::fs::write(d.join(MAPS[which]), bytes).unwrap();
        let _ = SkinMaps::from_dir(&d);
    }
}

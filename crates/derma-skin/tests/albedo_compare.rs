//! derma_skin::albedo_compare on a real set: a set beside its own base colour differs by
//! nothing, beside a redder "photo" by that redness.

use derma_core::image_io::LoadedImage;
use derma_core::map::Map;
use derma_skin::albedo_compare::{compare, REGIONS};
use derma_skin::{SkinConfig, SkinGenerator, TextureSet};

/// The built-in head's base colour as a "photograph" of itself, optionally with its red
/// raised by `red` (as an 8-bit sRGB image read back).
fn photo_of(set: &TextureSet, red: f32) -> LoadedImage {
    let s = &set.surface;
    let ch = |k: usize| {
        Map::from_fn(s.width, s.height, |i| {
            let v = set.render.base_color[i][k] as f32 / 255.0;
            if k == 0 {
                (v + red).min(1.0)
            } else {
                v
            }
        })
    };
    LoadedImage {
        channels: vec![ch(0), ch(1), ch(2)],
        is_color: true,
        alpha: None,
    }
}

#[test]
fn a_set_beside_itself_differs_by_nothing_and_a_redder_photo_by_its_redness() {
    let cfg = SkinConfig {
        size: 128,
        ..SkinConfig::default()
    };
    let set = SkinGenerator::new(cfg).threads(2).run().unwrap();
    let same = compare(set.painted(), &photo_of(&set, 0.0), "self").unwrap();
    assert_eq!(same.regions.len(), REGIONS.len());
    for r in &same.regions {
        assert!(r.delta_e < 1e-6, "{}: {}", r.region, r.delta_e);
        assert!((r.photo.a_spread - r.derma.a_spread).abs() < 1e-9);
        assert!(r.texels > 0);
    }
    assert!(same.photo_cheek_ita_deg > 30.0 && same.photo_cheek_ita_deg < 60.0);
    let red = compare(set.painted(), &photo_of(&set, 0.05), "redder").unwrap();
    for r in &red.regions {
        // More red: a* up, ΔE the size of that shift.
        let da = r.photo.lab[1] - r.derma.lab[1];
        assert!(
            da > 2.0 && r.delta_e >= da,
            "{}: Δa* {da}, ΔE {}",
            r.region,
            r.delta_e
        );
    }
    assert!(red.median_delta_e > 2.0);
}

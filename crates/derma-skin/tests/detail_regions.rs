//! `[detail] regions`: one exemplar per region (Graham et al. 2013), blended by the region's
//! mask — the detail lands inside the region and nowhere else.

use derma_core::Map;
use derma_skin::{SkinConfig, SkinGenerator};

#[test]
#[ignore = "slow: scripts/test_slow.sh"]
fn a_region_exemplar_changes_only_its_region() {
    let dir = derma_test_support::scratch_dir("detail-regions");
    let n = 64;
    let bumps = Map::from_vec(
        n,
        n,
        (0..n * n)
            .map(|i| {
                let (x, y) = ((i % n) as f32, (i / n) as f32);
                0.5 + 0.3 * (x * 0.9).sin() * (y * 0.7).cos() + 0.1 * ((x + 2.0 * y) * 0.4).sin()
            })
            .collect(),
    )
    .unwrap();
    let ex = dir.join("cheek.png");
    derma_core::image_io::write_png16(&ex, &[&bumps]).unwrap();
    let base = SkinConfig {
        size: 128,
        scatter_resolution: 256,
        ..SkinConfig::default()
    };
    let mut with = base.clone();
    with.detail
        .regions
        .insert("cheeks".into(), ex.display().to_string());
    with.detail.tile_size = 64;
    with.detail.patch = 16;
    with.detail.height_mm = 0.05;
    let run = |c: &SkinConfig| SkinGenerator::new(c.clone()).threads(2).run().unwrap();
    let (a, b) = (run(&base), run(&with));
    let cheeks = a.fields.scalar("cheeks").unwrap();
    let s = &a.surface;
    let (mut inside, mut outside_changed, mut outside) = (0.0f64, 0usize, 0usize);
    for i in 0..s.len() {
        if !s.covered(i) {
            continue;
        }
        let uv = s.uv(i);
        let m = cheeks.sample_uv(uv.x, uv.y, false);
        let d = (b.bio.texels[i].height_mm - a.bio.texels[i].height_mm).abs() as f64;
        if m > 0.9 {
            inside += d;
        } else if m == 0.0 {
            outside += 1;
            if d > 0.0 {
                outside_changed += 1;
            }
        }
    }
    assert!(inside > 0.0, "no detail on the cheeks");
    assert!(outside > 1000);
    assert_eq!(outside_changed, 0, "detail outside the cheeks");
    // An unknown region is a clear error naming it.
    let mut bad = with.clone();
    bad.detail
        .regions
        .insert("elbow".into(), ex.display().to_string());
    let e = SkinGenerator::new(bad).run().err().unwrap().to_string();
    assert!(e.contains("elbow"), "{e}");
}

//! The main job on a fitted head (`derma head fit`): its template painted without landmarks, and
//! the scan it was fitted to painted with the regions the fit gives, against the built-in head's
//! regional colour.

use derma_core::head_mesh::HeadUnit;
use derma_core::progress::Silent;
use derma_head::fit::job::{FitJob, LandmarkSource};
use derma_skin::color_stats::region_colors;
use derma_skin::{SkinConfig, SkinGenerator};
use glam::{Vec2, Vec3};

const REGIONS: [&str; 4] = ["cheeks", "forehead", "neck", "periorbital"];

#[test]
#[ignore = "slow: scripts/test_slow.sh"]
fn a_fitted_head_and_its_scan_get_the_built_in_heads_regional_colour() {
    // A user's mesh with UVs: the built-in head's outer skin, wider, shorter, deeper and moved,
    // in centimetres.
    let head = derma_head::Head::builtin();
    let chart = derma_head::asset::parse().meta.charts["skin"];
    let inside =
        |uv: Vec2| uv.x >= chart[0] && uv.x <= chart[2] && uv.y >= chart[1] && uv.y <= chart[3];
    let mut scan = head.skin.clone();
    scan.triangles
        .retain(|t| t.iter().all(|&i| inside(head.skin.uvs[i as usize])));
    for p in &mut scan.positions {
        *p = (Vec3::new(1.07 * p.x, 0.96 * p.y + 0.0005 * p.x * p.x, 1.03 * p.z)
            + Vec3::new(-4.0, 25.0, -10.0))
            / 10.0;
    }
    let dir = derma_test_support::scratch_dir("skin-fitted");
    let obj = dir.join("scan.obj");
    scan.write_obj(&obj).unwrap();
    let fitted = dir.join("fitted");
    FitJob {
        mesh: obj.clone(),
        unit: HeadUnit::Auto,
        part: Default::default(),
        axes: None,
        landmarks: LandmarkSource::Auto,
        out: fitted.clone(),
    }
    .run(&Silent)
    .unwrap();

    let cfg = SkinConfig {
        size: 256,
        ..SkinConfig::default()
    };
    let colours = |g: SkinGenerator| {
        let set = g.threads(2).run().unwrap();
        region_colors(&set, &REGIONS).unwrap()
    };
    let builtin = colours(SkinGenerator::new(cfg.clone()));
    let template = colours(SkinGenerator::new(cfg.clone()).head(&fitted));
    let on_scan = colours(SkinGenerator::new(cfg).mesh(&obj).head(&fitted));
    for (name, got) in [("fitted template", &template), ("scan", &on_scan)] {
        for (b, g) in builtin.iter().zip(got) {
            let de = (0..3)
                .map(|k| (b.lab[k] - g.lab[k]).powi(2))
                .sum::<f64>()
                .sqrt();
            assert!(
                de < 2.5 && g.texels > 300,
                "{name}, {}: {:?} against the built-in head's {:?} (ΔE {de:.2})",
                b.region,
                g.lab,
                b.lab
            );
        }
        // Cheeks and forehead redder than the neck, as on the built-in head.
        assert!(
            got[0].lab[1] > got[2].lab[1] && got[1].lab[1] > got[2].lab[1],
            "{name}"
        );
    }
}

//! The built-in expression library placed on a user's mesh in its own UV layout, through the
//! head fitted to it: each texel gets the gains of the built-in head's corresponding point.

use derma_rig::expression::{self, Placement};
use glam::{Vec2, Vec3};

#[test]
#[ignore = "slow: scripts/test_slow.sh"]
fn the_library_lands_on_a_users_own_uvs_where_it_lands_on_the_built_in_head() {
    // A user's mesh: the built-in head's outer skin, wider, shorter, deeper, bent and moved, with
    // UVs of its own (a cylindrical projection, nothing like derma's layout). Vertex i is the
    // built-in skin's vertex i, so every texel's true point on the built-in head is known.
    let head = derma_head::Head::builtin();
    let chart = derma_head::asset::parse().meta.charts["skin"];
    let inside =
        |uv: Vec2| uv.x >= chart[0] && uv.x <= chart[2] && uv.y >= chart[1] && uv.y <= chart[3];
    let mut truth = head.skin.clone();
    truth
        .triangles
        .retain(|t| t.iter().all(|&i| inside(head.skin.uvs[i as usize])));
    // Front half only: a cylindrical projection is one-to-one there.
    truth
        .triangles
        .retain(|t| t.iter().all(|&i| head.skin.positions[i as usize].z > 20.0));
    let (lo, hi) = truth.bounds();
    truth.uvs = truth
        .positions
        .iter()
        .map(|p| {
            Vec2::new(
                0.5 + p.x.atan2(p.z - 20.0) / std::f32::consts::PI,
                (p.y - lo.y) / (hi.y - lo.y),
            )
        })
        .collect();
    let mut scan = truth.clone();
    for p in &mut scan.positions {
        *p = Vec3::new(1.08 * p.x, 0.95 * p.y + 0.0006 * p.x * p.x, 1.04 * p.z)
            + Vec3::new(3.0, -12.0, 20.0);
    }
    let fitted = derma_head::fit::fit(
        scan.clone(),
        &derma_head::fit::FitOptions::default(),
        &derma_core::progress::Silent,
    )
    .unwrap()
    .head();
    let regions = derma_head::Regions::new(fitted.landmarks.clone(), Vec::new(), Vec::new());
    let placement = Placement::Mesh {
        mesh: &scan,
        regions: &regions,
    };
    let (w, h) = (128, 128);
    let on_scan = placement.points(w, h);
    let raster = derma_core::raster::UvRaster::new(&truth, w, h);
    let mut n = 0;
    for e in &expression::LIBRARY {
        let (gm, _) = expression::gain_maps(e, &on_scan, placement.regions(), w, h);
        let (mut worst, mut sum, mut moved) = (0.0f32, 0.0f32, 0);
        for (i, p) in on_scan.iter().enumerate() {
            if p.is_none() {
                continue;
            }
            let want = e.gains_at(raster.position(&truth, i)).0;
            let got = gm.data()[i];
            worst = worst.max((got - want).abs());
            sum += (got - want).abs();
            moved += usize::from((want - 1.0).abs() > 0.05);
            n += 1;
        }
        let mean = sum / on_scan.iter().flatten().count() as f32;
        assert!(moved > 200, "{}: {moved} texels change", e.name);
        assert!(
            mean < 0.005 && worst < 0.06,
            "{}: gains off the built-in head's by {mean:.4} on average, {worst:.3} at worst",
            e.name
        );
    }
    assert!(n > 8 * 5000, "{n}");
}

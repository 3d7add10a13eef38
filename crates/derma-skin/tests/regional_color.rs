//! The default complexion against measurements, per skin-tone preset, on features of the maps
//! (not bytes): ITA° of cheeks and forehead in the preset's band (Chardon et al. 1991), b* in the
//! range measured on faces, the colour against a published group mean where there is one
//! (data/facial-colour-groups.toml), the calibrated melanin against Jacques' classes, facial a*
//! within the range measured on real faces, forehead and cheeks redder than the neck, and coarse
//! colour variation over the face.

use derma_skin::color_stats::{coarse_std, region_colors};
use derma_skin::regional::{Preset, Sex};
use derma_skin::{SkinConfig, SkinGenerator};
use serde::Deserialize;

/// Facial a* (cheek and forehead means) measured on real faces: between about 9 and 18 across
/// the four groups of Xiao et al. 2017 (Skin Res Technol 23:21–29; Caucasian, Chinese, Kurdish,
/// Thai); a fair man's head-scan albedo measures 14.5. The band is a deliberately wide envelope.
const FACE_A_STAR: (f64, f64) = (8.0, 20.0);

/// Facial b* measured by spectrophotometer: roughly 12–19 across groups (lowest in Caucasian
/// skin; Xiao et al. 2017; Korean adults 17.1 over 12 sites, Han et al. 2006).
const FACE_B_STAR_MIN: f64 = 12.0;

#[derive(Deserialize)]
struct Groups {
    group: Vec<Group>,
}

#[derive(Deserialize)]
struct Group {
    preset: String,
    group: String,
    site: String,
    lab: [f64; 3],
    source: String,
}

fn delta_e(a: [f64; 3], b: [f64; 3]) -> f64 {
    (0..3).map(|k| (a[k] - b[k]).powi(2)).sum::<f64>().sqrt()
}

/// Melanosome volume fraction of the epidermis by class (Jacques 1998, OMLC "Skin optics"
/// summary): light-skinned adults 1.3–6.3 %, moderately pigmented 11–16 %, darkly pigmented
/// 18–43 %. Chardon's categories are mapped onto the three: very light to intermediate are
/// light-skinned, brown moderately and dark darkly pigmented; tan (ITA 10–28°) falls between
/// Jacques' light and moderate classes and is held to the span of the two. Very light is the
/// exception, measured and documented (docs/head.md): the Monte Carlo skin reaches its ITA°
/// (≥ 60°) only with melanin well below 1.3 %, between the table's nodes 0.002 and 0.013.
fn jacques_range(p: Preset) -> (f32, f32) {
    match p {
        Preset::VeryLight => (0.002, 0.013),
        Preset::Light | Preset::Intermediate => (0.013, 0.063),
        Preset::Tan => (0.013, 0.16),
        Preset::Brown => (0.11, 0.16),
        Preset::Dark => (0.18, 0.43),
    }
}

#[test]
#[ignore = "slow: scripts/test_slow.sh"]
fn every_preset_lands_in_its_ita_band_with_real_face_colour() {
    let groups: Groups = toml::from_str(include_str!("../data/facial-colour-groups.toml")).unwrap();
    let appearance = derma_shading::TableAppearance::builtin();
    for p in Preset::ALL {
        let cfg = SkinConfig {
            size: 256,
            person: p.person(Sex::Male, 35.0),
            ..SkinConfig::default()
        };
        let (_, melanin) = derma_skin::calibration::apply_person(&cfg, &appearance, true).unwrap();
        let melanin = melanin.expect("the presets calibrate melanin");
        let set = SkinGenerator::new(cfg).threads(2).run().unwrap();
        let c = region_colors(&set, &["cheeks", "forehead", "neck", "periorbital"]).unwrap();
        let (cheeks, forehead, neck, orbit) = (&c[0], &c[1], &c[2], &c[3]);
        // Periorbital skin darker than the forehead, and on light skin bluer (venous blood
        // through thin skin); on darker skin dark circles are mostly pigment, brown rather
        // than blue (Freitag & Cestari 2007).
        assert!(
            orbit.lab[0] < forehead.lab[0],
            "{}: periorbital {:?} vs forehead {:?}",
            p.name(),
            orbit.lab,
            forehead.lab
        );
        if matches!(p, Preset::VeryLight | Preset::Light) {
            assert!(
                orbit.lab[2] < forehead.lab[2],
                "{}: periorbital b* {:.1} not below the forehead's {:.1}",
                p.name(),
                orbit.lab[2],
                forehead.lab[2]
            );
        }
        assert!(cheeks.texels > 500 && forehead.texels > 500 && neck.texels > 500);
        // Cheeks and forehead together (texel-weighted) in the band.
        let n = (cheeks.texels + forehead.texels) as f64;
        let mean: [f64; 3] = [0, 1, 2].map(|k| {
            (cheeks.lab[k] * cheeks.texels as f64 + forehead.lab[k] * forehead.texels as f64) / n
        });
        let ita = derma_skin::regional::ita_deg(mean);
        let (lo, hi) = p.band();
        let sd = coarse_std(&set, "face", 5.0).unwrap();
        println!(
            "| {} | {melanin:.4} | {:.1} | {:.1} | {:.1} | {ita:.1} | {:.2} | {:.1} |",
            p.name(),
            mean[0],
            mean[1],
            mean[2],
            sd[1],
            neck.lab[1]
        );
        assert!(
            (lo as f64..=hi as f64).contains(&ita),
            "{}: ITA {ita:.1}° outside {lo}…{hi}",
            p.name()
        );
        // b* = (L* − 50) / tan ITA°: at very light's ITA ≥ 60°, b* ≥ 12 needs L* ≥ 70.8, lighter
        // than its cheeks are; there the floor is what its own L* and ITA° allow, less 0.5.
        let b_min = match p {
            Preset::VeryLight => (mean[0] - 50.0) / 60f64.to_radians().tan() - 0.5,
            _ => FACE_B_STAR_MIN,
        };
        assert!(
            mean[2] >= b_min,
            "{}: b* {:.1} below {b_min:.1}",
            p.name(),
            mean[2]
        );
        if p == Preset::VeryLight {
            assert!(ita >= 60.0, "very-light: ITA {ita:.1}° below 60°");
        }
        let (mlo, mhi) = jacques_range(p);
        assert!(
            (mlo..=mhi).contains(&melanin),
            "{}: melanin {melanin:.4} outside Jacques' {mlo}–{mhi}",
            p.name()
        );
        for g in groups.group.iter().filter(|g| g.preset == p.name()) {
            println!(
                "  {}: ΔE*ab {:.1} from {} ({}) {:?}",
                p.name(),
                delta_e(mean, g.lab),
                g.group,
                g.site,
                g.lab
            );
        }
        if p == Preset::Intermediate {
            // The Korean mean of Han et al. 2006 (12 sites, face and body), the group mean
            // nearest to cheeks and forehead at this tone (Yun et al. 2010's mixes in three body
            // sites of five and is printed above): its lightness and yellowness, while a* is held
            // to the face's own site, the cheek's 11.9 (the same study's reddest site) — the
            // body sites pale the 12-site a* (9.6) below a face's, as two photographed faces
            // show (docs/skin.md, "Beside a real face").
            let han = groups
                .group
                .iter()
                .find(|g| g.source.starts_with("Han K"))
                .expect("Han et al. 2006 in the data file")
                .lab;
            const HAN_CHEEK_A: f64 = 11.9;
            let de = ((mean[0] - han[0]).powi(2) + (mean[2] - han[2]).powi(2)).sqrt();
            assert!(
                de <= 3.0,
                "intermediate: ΔE*ab {de:.1} in L* and b* from {han:?}"
            );
            assert!(
                (mean[1] - HAN_CHEEK_A).abs() <= 2.0,
                "intermediate: a* {:.1} against Han's cheek {HAN_CHEEK_A}",
                mean[1]
            );
        }
        for r in [cheeks, forehead] {
            assert!(
                (FACE_A_STAR.0..=FACE_A_STAR.1).contains(&r.lab[1]),
                "{} {}: a* {:.1}",
                p.name(),
                r.region,
                r.lab[1]
            );
            // Redder than the neck by half an a* unit at least: on dark skin melanin hides most
            // of the blood's difference (measured here: about 1).
            assert!(
                r.lab[1] > neck.lab[1] + 0.5,
                "{} {} (a* {:.1}) not redder than the neck ({:.1})",
                p.name(),
                r.region,
                r.lab[1],
                neck.lab[1]
            );
        }
        // Coarse variation over the face: the reference scan of a fair man measures a* σ 3.0;
        // the light presets (the scan's skin) must reach 2.5. Melanin masks the blood's
        // contrast, so darker presets vary less (see docs/head.md).
        let need = match p {
            Preset::VeryLight | Preset::Light => 2.5,
            Preset::Intermediate | Preset::Tan => 1.5,
            Preset::Brown => 1.0,
            Preset::Dark => 0.6,
        };
        assert!(
            sd[1] >= need,
            "{}: coarse a* σ {:.2} < {need}",
            p.name(),
            sd[1]
        );
    }
}

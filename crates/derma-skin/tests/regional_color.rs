//! The default complexion against measurements, per skin-tone preset, on features of the maps
//! (not bytes): ITA° of cheeks and forehead in the preset's band (Chardon et al. 1991), facial
//! a* within the range measured on real faces, forehead and cheeks redder than the neck, and
//! coarse colour variation over the face.

use derma_skin::color_stats::{coarse_std, region_colors};
use derma_skin::regional::{Preset, Sex};
use derma_skin::{SkinConfig, SkinGenerator};

/// Facial a* (cheek and forehead means) measured on real faces: between about 9 and 18 across
/// the four groups of Xiao et al. 2017 (Skin Res Technol 23:21–29; Caucasian, Chinese, Kurdish,
/// Thai); a fair man's head-scan albedo measures 14.5. The band is a deliberately wide envelope.
const FACE_A_STAR: (f64, f64) = (8.0, 20.0);

#[test]
fn every_preset_lands_in_its_ita_band_with_real_face_redness() {
    for p in Preset::ALL {
        let cfg = SkinConfig {
            size: 256,
            person: p.person(Sex::Male, 35.0),
            ..SkinConfig::default()
        };
        let set = SkinGenerator::new(cfg).threads(2).run().unwrap();
        let c = region_colors(&set, &["cheeks", "forehead", "neck", "periorbital"]).unwrap();
        let (cheeks, forehead, neck, orbit) = (&c[0], &c[1], &c[2], &c[3]);
        // Periorbital skin darker and bluer than the forehead (Freitag & Cestari 2007).
        assert!(
            orbit.lab[0] < forehead.lab[0] && orbit.lab[2] < forehead.lab[2],
            "{}: periorbital {:?} vs forehead {:?}",
            p.name(),
            orbit.lab,
            forehead.lab
        );
        assert!(cheeks.texels > 500 && forehead.texels > 500 && neck.texels > 500);
        // Cheeks and forehead together (texel-weighted) in the band.
        let n = (cheeks.texels + forehead.texels) as f64;
        let mean: [f64; 3] = [0, 1, 2].map(|k| {
            (cheeks.lab[k] * cheeks.texels as f64 + forehead.lab[k] * forehead.texels as f64) / n
        });
        let ita = derma_skin::regional::ita_deg(mean);
        let (lo, hi) = p.band();
        println!(
            "{}: cheeks+forehead L* {:.1} a* {:.1} b* {:.1} ITA {ita:.1}°; neck a* {:.1}",
            p.name(),
            mean[0],
            mean[1],
            mean[2],
            neck.lab[1]
        );
        assert!(
            (lo as f64..=hi as f64).contains(&ita),
            "{}: ITA {ita:.1}° outside {lo}…{hi}",
            p.name()
        );
        for r in [cheeks, forehead] {
            assert!(
                (FACE_A_STAR.0..=FACE_A_STAR.1).contains(&r.lab[1]),
                "{} {}: a* {:.1}",
                p.name(),
                r.region,
                r.lab[1]
            );
            assert!(
                r.lab[1] > neck.lab[1] + 1.0,
                "{} {} (a* {:.1}) not redder than the neck ({:.1})",
                p.name(),
                r.region,
                r.lab[1],
                neck.lab[1]
            );
        }
        // Coarse variation over the face: the reference scan of a fair man measures a* σ 3.0.
        // Melanin masks the blood's contrast, so darker presets vary less (see docs/head.md);
        // the light presets (the scan's skin) must reach 2.
        let sd = coarse_std(&set, "face", 5.0).unwrap();
        println!(
            "{}: coarse σ L* {:.2} a* {:.2} b* {:.2}",
            p.name(),
            sd[0],
            sd[1],
            sd[2]
        );
        let need = match p {
            Preset::VeryLight | Preset::Light => 2.0,
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

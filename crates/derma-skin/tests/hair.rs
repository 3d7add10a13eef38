//! Hair from the follicles (docs/skin.md, "Hair"): every strand starts at a follicle of its
//! kind, brows cover the eyebrow region and not the forehead, stubble grows on a man's beard and
//! on no woman's, the hair takes its melanins' colour, and hair_coverage.png is written.

use derma_core::color::srgb8_decode;
use derma_shading::hair::HairMelanin;
use derma_skin::features::follicle::Follicle;
use derma_skin::features::strand::Strand;
use derma_skin::regional::{Preset, Sex};
use derma_skin::{SkinConfig, SkinGenerator, TextureSet};

fn set(preset: Preset, sex: Sex, edit: impl FnOnce(&mut SkinConfig)) -> TextureSet {
    let mut cfg = SkinConfig {
        size: 512,
        person: preset.person(sex, 35.0),
        ..SkinConfig::default()
    };
    edit(&mut cfg);
    SkinGenerator::new(cfg).threads(2).run().unwrap()
}

/// Mean hair coverage over the texels where the field `region` exceeds 0.7.
fn coverage_in(s: &TextureSet, region: &str) -> f64 {
    let f = s.fields.scalar(region).unwrap();
    let (mut sum, mut n) = (0.0, 0usize);
    for i in 0..s.surface.len() {
        let uv = s.surface.uv(i);
        if s.surface.covered(i) && f.sample_uv(uv.x, uv.y, false) > 0.7 {
            sum += s.bio.texels[i].extra[3] as f64;
            n += 1;
        }
    }
    sum / n.max(1) as f64
}

#[test]
fn every_strand_grows_from_a_follicle_of_its_kind() {
    let s = set(Preset::Light, Sex::Male, |_| {});
    let roots = |kind: &str| -> Vec<[u32; 3]> {
        let mut v: Vec<[u32; 3]> = s
            .features
            .get::<Follicle>(kind)
            .unwrap()
            .originals()
            .iter()
            .map(|f| f.center.to_array().map(f32::to_bits))
            .collect();
        v.sort_unstable();
        v
    };
    for (strands, follicles) in [("brow_hair", "eyebrow"), ("stubble", "follicle")] {
        let at = roots(follicles);
        let grown = s.features.get::<Strand>(strands).unwrap().originals();
        assert!(grown.len() > 50, "{strands}: {}", grown.len());
        for st in grown {
            let r = st.curve.p[0].to_array().map(f32::to_bits);
            assert!(
                at.binary_search(&r).is_ok(),
                "{strands} root {:?} is no {follicles}",
                st.curve.p[0]
            );
        }
    }
    // Every eyebrow follicle grows a hair; only a share of the follicle field's are beard ones.
    assert_eq!(
        s.features
            .get::<Strand>("brow_hair")
            .unwrap()
            .originals()
            .len(),
        roots("eyebrow").len()
    );
    assert!(
        s.features
            .get::<Strand>("stubble")
            .unwrap()
            .originals()
            .len()
            < roots("follicle").len() / 4
    );
}

#[test]
#[ignore = "slow: scripts/test_slow.sh"]
fn brows_and_stubble_cover_their_regions_only() {
    let man = set(Preset::Light, Sex::Male, |_| {});
    let woman = set(Preset::Light, Sex::Female, |_| {});
    let (brows, forehead) = (coverage_in(&man, "eyebrows"), coverage_in(&man, "forehead"));
    assert!(
        brows > 0.3 && forehead < 0.05,
        "brows {brows:.3}, forehead {forehead:.3}"
    );
    let (beard_m, beard_f) = (coverage_in(&man, "chin"), coverage_in(&woman, "chin"));
    assert!(
        beard_m > 0.1 && beard_f < 0.02,
        "chin: man {beard_m:.3}, woman {beard_f:.3}"
    );
    assert_eq!(
        woman
            .features
            .get::<Strand>("stubble")
            .unwrap()
            .originals()
            .len(),
        0
    );
    // A clean-shaven man: no stubble.
    let shaven = set(Preset::Light, Sex::Male, |c| c.hair.stubble_length_mm = 0.0);
    assert!(coverage_in(&shaven, "chin") < 0.02);
}

#[test]
#[ignore = "slow: scripts/test_slow.sh"]
fn hair_takes_the_colour_of_its_melanins() {
    // Every hair (stalks, brows, stubble) has the one colour of the hair's melanins, composited
    // over the skin by its coverage: the extra colour is that colour wherever there is hair, and
    // the base colour is darker where the hair covers more of a texel.
    let hair = |s: &TextureSet| -> [f32; 3] {
        let mut colours = s
            .bio
            .texels
            .iter()
            .filter(|t| t.extra[3] > 0.01)
            .map(|t| [t.extra[0], t.extra[1], t.extra[2]]);
        let first = colours.next().expect("hair somewhere");
        for c in colours {
            for k in 0..3 {
                assert!(
                    (c[k] - first[k]).abs() <= 1e-5 * first[k].max(1e-3),
                    "{c:?} vs {first:?}"
                );
            }
        }
        first
    };
    for (preset, eumelanin) in [(Preset::VeryLight, 0.5), (Preset::Dark, 8.0)] {
        let s = set(preset, Sex::Female, |_| {});
        let want = HairMelanin {
            eumelanin,
            pheomelanin: 0.15,
        }
        .color();
        let got = hair(&s);
        for k in 0..3 {
            assert!(
                (got[k] - want[k]).abs() < 1e-5,
                "{}: {got:?} vs {want:?}",
                preset.name()
            );
        }
        // Brow texels: the more hair, the nearer the base colour is to the hair's.
        let lum = |c: [u8; 3]| c.map(srgb8_decode).iter().sum::<f32>();
        let brow: Vec<(f32, f32)> = s
            .render
            .base_color
            .iter()
            .zip(&s.bio.texels)
            .filter(|(_, t)| t.extra[3] > 0.01)
            .map(|(c, t)| (t.extra[3], lum(*c)))
            .collect();
        let mean_lum = |lo: f32, hi: f32| {
            let v: Vec<f32> = brow
                .iter()
                .filter(|(a, _)| (lo..hi).contains(a))
                .map(|p| p.1)
                .collect();
            v.iter().sum::<f32>() / v.len().max(1) as f32
        };
        assert!(
            mean_lum(0.5, 1.01) < mean_lum(0.01, 0.1),
            "{}",
            preset.name()
        );
    }
    // Set by hand: red hair.
    let red = set(Preset::Light, Sex::Female, |c| {
        c.hair.melanin_from_skin = false;
        c.hair.eumelanin = 0.3;
        c.hair.pheomelanin = 3.0;
    });
    let c = hair(&red);
    assert!(c[0] > 2.0 * c[1], "{c:?}");
}

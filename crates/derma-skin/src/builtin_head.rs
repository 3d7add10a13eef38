//! The default fields on derma's built-in head (`derma-head`): feature probability fields,
//! wrinkle vector fields and the regional biology maps, all built from the head's named regions
//! and landmarks and rasterised on its UV layout.
//!
//! Feature fields follow thesis §5.3 (cysts, moles, freckles, follicles, wrinkles) on the real
//! regions; pores follow the regional follicle densities of Pagnoni et al. 1994; the wrinkle
//! families (forehead, glabellar, crow's feet, nasolabial, under-eye) follow the face's
//! expression lines. The regional biology is in [`crate::regional`].

use crate::field::FieldSet;
use crate::regional::{self, Person};
use derma_core::mesh::TriMesh;
use derma_core::raster::{apply_dilation, dilation_sources, UvRaster};
use derma_core::Map;
use derma_head::{region, regions, wrinkle_regions, Head, Regions, REGIONS};
use glam::{Vec2, Vec3};

/// Resolution of the generated fields.
pub const FIELD_RESOLUTION: usize = 1024;

/// Peak densities (1/cm² where the field is 1) that reproduce the thesis' counts (§5.3) on the
/// built-in head with its default fields: density = count / ∫ field dA. The integrals are
/// recomputed by the test `default_densities_reproduce_thesis_counts`.
pub struct Densities {
    /// Cysts.
    pub cyst: f32,
    /// Moles.
    pub mole: f32,
    /// Freckles.
    pub freckle: f32,
    /// Wrinkle start points.
    pub wrinkle: f32,
    /// Scalp follicles.
    pub follicle: f32,
    /// Eyebrow follicles.
    pub eyebrow: f32,
}

/// Counts the densities are derived from: thesis §5.3 (cysts 5000, moles 700, freckles 3000,
/// follicles 170 000 on the scalp); eyebrows ≈ 250 hairs per brow; 40 wrinkles (authored).
pub const THESIS_COUNTS: [(&str, f32); 6] = [
    ("cysts", 5000.0),
    ("moles", 700.0),
    ("freckles", 3000.0),
    ("wrinkles", 40.0),
    ("scalp", 170_000.0),
    ("eyebrows", 500.0),
];

/// Field integrals on the built-in head (cm², printed by the test): cysts 461.98, moles 784.60,
/// freckles 105.39, wrinkles 99.050, scalp 531.29 (without the beard), eyebrows 6.139. The wrinkle
/// count is for age 40 (`regional::age_factor` = 1).
pub const DEFAULT_DENSITY: Densities = Densities {
    cyst: 10.823,
    mole: 0.89218,
    freckle: 28.465,
    wrinkle: 0.40383,
    follicle: 319.98,
    eyebrow: 81.444,
};

/// Beard follicles relative to the scalp follicles' peak density: in men the follicle field is
/// scalp + 0.17 · beard, about 57 terminal hairs/cm² on the beard area at the default scalp
/// density — an authored figure of the order of the beard densities reported in grooming and
/// hair-transplant practice (tens per cm², several times below the scalp's); women keep vellus
/// hair, which is not painted.
pub const BEARD_TO_SCALP: f32 = 0.17;

#[inline]
fn smoothstep(a: f32, b: f32, x: f32) -> f32 {
    let t = ((x - a) / (b - a)).clamp(0.0, 1.0);
    t * t * (3.0 - 2.0 * t)
}

/// The built-in head's skin mesh (mm).
pub fn head_mesh() -> TriMesh {
    Head::builtin().skin.clone()
}

/// Names of the feature fields, in the order [`feature_values`] returns them.
pub const FIELD_NAMES: [&str; 10] = [
    "scalp", "eyebrows", "eyes", "lips", "face", "freckles", "moles", "cysts", "pores", "wrinkles",
];

/// Distance from `p` to the segment a–b in the xy plane, and the unit direction of the segment.
fn segment(p: Vec2, a: Vec2, b: Vec2) -> (f32, Vec2) {
    let ab = b - a;
    let t = ((p - a).dot(ab) / ab.length_squared()).clamp(0.0, 1.0);
    ((p - (a + t * ab)).length(), ab.normalize())
}

/// Feature fields and the wrinkle direction (a 3D direction in the skin, and a length in [0, 1])
/// at one surface point with region weights `w`.
fn feature_values(
    r: &Regions,
    w: &regions::Weights,
    p: Vec3,
    person: &Person,
) -> ([f32; 10], Vec3, f32) {
    let g = |i: usize| w[i];
    let skin = 1.0 - g(region!("mouth_interior")).max(g(region!("eye_sockets")));
    let scalp = g(region!("scalp"));
    let beard = if person.sex == regional::Sex::Male {
        BEARD_TO_SCALP * g(region!("beard"))
    } else {
        0.0
    };
    let eyebrows = g(region!("eyebrows"));
    let eyes = (g(region!("eyelids")) + g(region!("eye_sockets"))).min(1.0);
    let lips = g(region!("lips"));
    let face = g(region!("face"));
    // Freckles: where the sun falls — cheeks, nose, forehead (thesis §5.3.5).
    let freckles = (g(region!("cheeks"))
        + 0.9 * g(region!("nose"))
        + 0.35 * g(region!("forehead"))
        + 0.3 * g(region!("upper_lip"))
        - lips
        - eyebrows)
        .clamp(0.0, 1.0);
    let moles = (skin * (1.0 - 0.7 * scalp) - lips).clamp(0.0, 1.0);
    let cysts = (face * (1.0 - eyes) * (1.0 - lips)).clamp(0.0, 1.0);
    // Pores: facial follicle density is highest on the nose, then cheeks and chin, lower on the
    // forehead and the rest of the face (Pagnoni et al. 1994, Br J Dermatol 131:862, cyanoacrylate
    // biopsies by region); relative weights authored in that order.
    let pores = (g(region!("nose"))
        + 0.75 * g(region!("cheeks"))
        + 0.6 * g(region!("chin"))
        + 0.55 * g(region!("forehead"))
        + 0.35
            * (face
                - g(region!("nose"))
                - g(region!("cheeks"))
                - g(region!("chin"))
                - g(region!("forehead")))
            .max(0.0)
        - eyes
        - lips
        - eyebrows)
        .clamp(0.0, 1.0);
    // Wrinkle families and their directions.
    let eye_l = r.side(1.0).eye;
    let s = if p.x >= 0.0 { 1.0 } else { -1.0 };
    let this = r.side(p.x);
    let (eye, co, mc) = (this.eye, this.canthus_outer, this.mouth_corner);
    let sn = r.subnasale();
    let q = Vec2::new(p.x, p.y);
    let mut best = (0.0f32, Vec3::ZERO, 0.0f32);
    let mut consider = |weight: f32, dir: Vec3, len: f32| {
        if weight > best.0 {
            best = (weight, dir, len);
        }
    };
    // Forehead lines: horizontal, across the middle of the forehead.
    consider(
        g(region!("forehead")) * smoothstep(eye_l.y + 28.0, eye_l.y + 36.0, p.y),
        Vec3::X,
        0.9,
    );
    // Glabellar lines: vertical between the brows.
    let glab = face
        * smoothstep(9.0, 5.0, p.x.abs())
        * smoothstep(eye.y + 8.0, eye.y + 14.0, p.y)
        * smoothstep(eye.y + 32.0, eye.y + 26.0, p.y);
    consider(glab, Vec3::Y, 0.35);
    // Crow's feet: radiating from the outer canthus, 5–18 mm lateral of it.
    let dc = Vec2::new(p.x - co.x, p.y - co.y);
    let crow =
        face * (1.0 - eyes) * smoothstep(20.0, 12.0, dc.length()) * smoothstep(0.0, 4.0, dc.x * s);
    let radial = dc.normalize_or(Vec2::X);
    consider(crow, Vec3::new(radial.x, radial.y, 0.0), 0.3);
    // Nasolabial folds: from beside the nasal ala to 8 mm beyond the mouth corner.
    let a = Vec2::new(s * 20.0, sn.y + 6.0);
    let b = Vec2::new(mc.x + s * 8.0, mc.y - 10.0);
    let (d, along) = segment(q, a, b);
    consider(
        face * (1.0 - lips) * smoothstep(5.0, 2.0, d),
        Vec3::new(along.x, along.y, 0.0),
        0.8,
    );
    // Under-eye lines: a band 9–14 mm below the eye centre across the lower lid.
    let under = face
        * smoothstep(eye.y - 16.0, eye.y - 12.0, p.y)
        * smoothstep(eye.y - 8.0, eye.y - 11.0, p.y)
        * smoothstep(16.0, 10.0, (p.x - eye.x).abs());
    consider(under, Vec3::X, 0.35);
    let wrinkles = best.0 * (1.0 - lips);
    (
        [
            (scalp + beard).clamp(0.0, 1.0),
            eyebrows,
            eyes,
            lips,
            face,
            freckles,
            moles,
            cysts,
            pores,
            wrinkles,
        ]
        .map(|v| v.clamp(0.0, 1.0)),
        best.1,
        best.2,
    )
}

/// Per-texel values: feature fields, wrinkle vector (UV direction encoded, length), regional
/// biology, region weights.
struct Texel {
    f: [f32; 10],
    wv: [f32; 3],
    /// Relief depth scale and the tension-line direction (UV, encoded like `wv`).
    relief: f32,
    tv: [f32; 3],
    /// The hair's growth direction (UV, encoded like `wv`).
    hv: [f32; 3],
    bio: [f32; regional::CHANNELS.len()],
    regions: regions::Weights,
    /// Masks of the regions of expression wrinkles (derma_head::wrinkle_regions).
    wrinkle: [f32; wrinkle_regions::COUNT],
}

/// The field name of expression-wrinkle region `name`'s mask (`wrinkle_mask_forehead_left`…).
pub fn wrinkle_mask_field(name: &str) -> String {
    format!("wrinkle_mask_{name}")
}

/// The direction hair grows at `p` (head coordinates, mm; +x the head's left, +y up): along the
/// brows, medial hairs point up and slightly out, the body sweeps outwards and a little up, the
/// tail points out and down, and the rows above the brow's crest angle down while those below
/// angle up, so they meet along it (the herringbone of a brow; angles authored after the
/// brow-grooming literature's "flow" diagrams). Elsewhere hair points down (beard and
/// moustache, sideburns). Returns the direction and a length factor: the brow's medial hairs
/// are short and upright, about half the length of the body's (authored).
fn hair_direction(r: &Regions, p: Vec3) -> (Vec3, f32) {
    let this = r.side(p.x);
    let s = if p.x >= 0.0 { 1.0 } else { -1.0 };
    let (eye, ci, co) = (this.eye, this.canthus_inner, this.canthus_outer);
    // The brow's parameter, as derma-head's eyebrow region: −1 medial to 1 at the tail.
    let (b0, b1) = (ci.x.abs() - 3.0, co.x.abs() + 10.0);
    let t = (2.0 * (p.x.abs() - b0) / (b1 - b0) - 1.0).clamp(-1.5, 1.5);
    let brow_y = eye.y + 18.0 + 4.0 * (1.0 - ((t - 0.2) / 1.2).powi(2)).max(0.0);
    let brow_h = 5.0 - 2.5 * (0.5 * (t + 1.0)).clamp(0.0, 1.0);
    let near_brow = smoothstep(eye.y + 8.0, eye.y + 12.0, p.y);
    if near_brow <= 0.0 {
        // Beard: down, the moustache fanning out from the philtrum.
        let fan = 0.35
            * smoothstep(4.0, 20.0, p.x.abs())
            * smoothstep(-10.0, 5.0, p.y - this.mouth_corner.y);
        return (Vec3::new(s * fan, -1.0, 0.0).normalize(), 1.0);
    }
    // Angle above the outward horizontal, by position along the brow (degrees, authored).
    const ALONG: [(f32, f32); 5] = [
        (-1.0, 80.0),
        (-0.5, 60.0),
        (0.0, 25.0),
        (0.5, 5.0),
        (1.0, -20.0),
    ];
    let tt = t.clamp(-1.0, 1.0);
    let k = ALONG.windows(2).position(|w| tt <= w[1].0).unwrap_or(3);
    let ((ta, aa), (tb, ab)) = (ALONG[k], ALONG[k + 1]);
    let along = aa + (ab - aa) * (tt - ta) / (tb - ta);
    // Rows above the crest angle down and below it up (±25° at the brow's edge).
    let row = -25.0 * ((p.y - brow_y) / brow_h).clamp(-1.0, 1.0);
    let a = (along + row).to_radians();
    let brow = Vec3::new(s * a.cos(), a.sin(), 0.0);
    let down = Vec3::new(0.0, -1.0, 0.0);
    let length = 0.5 + 0.5 * smoothstep(-1.0, -0.2, t);
    (
        (brow * near_brow + down * (1.0 - near_brow)).normalize_or(brow),
        1.0 + (length - 1.0) * near_brow,
    )
}

/// The vector fields the built-in head makes.
pub const VECTOR_FIELDS: [&str; 3] = ["wrinkle_vectors", "tension_vectors", "hair_vectors"];

/// Every field name the built-in head's defaults hold ([`fields_on`]'s keys): the feature
/// fields, the region masks, the regional biology, the expression-wrinkle masks, the relief
/// and the vector fields.
pub fn field_names() -> std::collections::BTreeSet<String> {
    FIELD_NAMES
        .iter()
        .chain(REGIONS.iter())
        .chain(regional::CHANNELS.iter())
        .chain(VECTOR_FIELDS.iter())
        .map(|n| n.to_string())
        .chain(
            wrinkle_regions::REGIONS
                .iter()
                .map(|r| wrinkle_mask_field(r.name)),
        )
        .chain(["relief".to_string()])
        .collect()
}

/// The UV layout fingerprint ([`TriMesh::uv_layout`]) of the built-in head's skin, which
/// every fitted head and every copy of `--export-template`'s mesh shares.
pub fn template_layout() -> &'static derma_core::mesh::UvLayout {
    static LAYOUT: std::sync::OnceLock<derma_core::mesh::UvLayout> = std::sync::OnceLock::new();
    LAYOUT.get_or_init(|| Head::builtin().skin.uv_layout())
}

/// The default fields of the built-in head for `person`: feature fields ([`FIELD_NAMES`]), the
/// wrinkle vector field, every region mask (by region name, where it does not clash with a
/// feature field) and the regional biology maps ([`regional::CHANNELS`]); rasterised at
/// [`FIELD_RESOLUTION`] on `mesh` (the built-in skin) and dilated into the gutter.
pub fn default_fields(mesh: &TriMesh, person: &Person) -> FieldSet {
    fields_on(mesh, &Head::builtin().regions, person)
}

/// The default fields of any mesh whose landmarks define `regions`.
pub fn fields_on(mesh: &TriMesh, regions: &Regions, person: &Person) -> FieldSet {
    let raster = FieldRaster::new(mesh, regions, person);
    let scalars = scalar_getters();
    let vectors = vector_getters();
    let gets: Vec<&Get> = scalars
        .values()
        .chain(vectors.iter().flat_map(|(_, g)| g.iter()))
        .collect();
    let planes = field_planes(&raster, &gets);
    let mut set = dilated_set(planes, &raster.covered, &scalars, &vectors);
    hold_at_file_precision(&mut set);
    set
}

/// What every texel of [`fields_on`] reads: the mesh rasterised at [`FIELD_RESOLUTION`], its
/// regions, the person and the smoothed regional biology per vertex.
struct FieldRaster<'a> {
    mesh: &'a TriMesh,
    regions: &'a Regions,
    person: &'a Person,
    raster: UvRaster,
    covered: Vec<bool>,
    gains: Vec<[f32; 4]>,
}

impl<'a> FieldRaster<'a> {
    /// `mesh` rasterised, with its regional biology smoothed over the surface.
    fn new(mesh: &'a TriMesh, regions: &'a Regions, person: &'a Person) -> Self {
        let n = FIELD_RESOLUTION;
        let raster = UvRaster::new(mesh, n, n);
        let covered: Vec<bool> = (0..n * n).map(|i| raster.covered(i)).collect();
        let gains = smoothed_gains(mesh, regions, BIO_SMOOTHING_MM);
        Self {
            mesh,
            regions,
            person,
            raster,
            covered,
            gains,
        }
    }

    /// The texture coordinate of texel `i`'s centre.
    fn uv_of(&self, i: usize) -> Vec2 {
        let n = FIELD_RESOLUTION;
        Vec2::new(
            ((i % n) as f32 + 0.5) / n as f32,
            1.0 - ((i / n) as f32 + 0.5) / n as f32,
        )
    }

    /// Texel `i`'s values (neutral where no triangle covers it).
    fn texel(&self, i: usize) -> Texel {
        if !self.covered[i] {
            return Texel {
                f: [0.0; 10],
                wv: [0.5, 0.5, 0.0],
                relief: 0.0,
                tv: [0.5, 0.5, 0.0],
                hv: [0.5, 0.5, 0.0],
                bio: regional::NEUTRAL,
                regions: [0.0; REGIONS.len()],
                wrinkle: [0.0; wrinkle_regions::COUNT],
            };
        }
        let regions = self.regions;
        let p = self.raster.position(self.mesh, i);
        let w = regions.weights(p, self.uv_of(i));
        let (f, dir3, len) = feature_values(regions, &w, p, self.person);
        let frame = self.uv_frame(i);
        let wv = frame.to_uv(dir3, len);
        // Tension lines: relaxed skin tension lines run with the expression lines (Borges
        // 1984) — the wrinkle families' directions where they are, horizontal elsewhere (as
        // RSTLs run on the forehead, temples and neck).
        let tension = if f[9] > 0.05 && len > 0.0 {
            dir3
        } else {
            Vec3::X
        };
        let tv = frame.to_uv(tension, 1.0);
        let (hair_dir, hair_len) = hair_direction(regions, p);
        let hv = frame.to_uv(hair_dir, hair_len);
        let relief = relief_depth(&w);
        let bio = self.bio(i);
        Texel {
            f,
            wv,
            relief,
            tv,
            hv,
            bio,
            regions: w,
            // By position, as the furrows are painted (a fold's furrow reaches the texels of
            // the mouth's or the eye sockets' charts that lie beside it in space).
            wrinkle: wrinkle_regions::masks(regions, p),
        }
    }

    /// The 3D-to-UV frame of texel `i`: its Jacobian by central differences of the rasterised
    /// positions (zero across a chart's edge).
    fn uv_frame(&self, i: usize) -> UvFrame {
        let n = FIELD_RESOLUTION;
        let (x, y) = (i % n, i / n);
        let at = |xx: usize, yy: usize| {
            let j = yy * n + xx;
            self.covered[j].then(|| self.raster.position(self.mesh, j))
        };
        let du = match (at((x + 1).min(n - 1), y), at(x.saturating_sub(1), y)) {
            (Some(a), Some(b)) => (a - b) * (n as f32 / 2.0),
            _ => Vec3::ZERO,
        };
        let dv = match (at(x, y.saturating_sub(1)), at(x, (y + 1).min(n - 1))) {
            (Some(a), Some(b)) => (a - b) * (n as f32 / 2.0),
            _ => Vec3::ZERO,
        };
        let (a11, a12, a22) = (du.dot(du), du.dot(dv), dv.dot(dv));
        UvFrame {
            du,
            dv,
            a11,
            a12,
            a22,
            det: a11 * a22 - a12 * a12,
        }
    }

    /// The regional biology at texel `i`, interpolated from its triangle's corners.
    fn bio(&self, i: usize) -> [f32; 4] {
        let (gains, raster) = (&self.gains, &self.raster);
        let t = self.mesh.triangles[raster.triangle[i] as usize];
        let [b1, b2] = raster.bary[i];
        [0, 1, 2, 3].map(|c| {
            gains[t[0] as usize][c] * (1.0 - b1 - b2)
                + gains[t[1] as usize][c] * b1
                + gains[t[2] as usize][c] * b2
        })
    }
}

/// A texel's Jacobian of position by UV, with the normal equations' terms, for carrying 3D
/// directions into UV.
struct UvFrame {
    du: Vec3,
    dv: Vec3,
    a11: f32,
    a12: f32,
    a22: f32,
    det: f32,
}

impl UvFrame {
    /// The 3D direction `dir3` in UV coordinates (least squares on the Jacobian), encoded as
    /// d·½ + ½ with the length `len`; none where the length or the Jacobian vanishes.
    fn to_uv(&self, dir3: Vec3, len: f32) -> [f32; 3] {
        let (du, dv, a11, a12, a22) = (self.du, self.dv, self.a11, self.a12, self.a22);
        if len > 0.0 && self.det > 1e-9 {
            let (b1, b2) = (du.dot(dir3), dv.dot(dir3));
            let d = Vec2::new(a22 * b1 - a12 * b2, a11 * b2 - a12 * b1).normalize_or_zero();
            [0.5 + 0.5 * d.x, 0.5 + 0.5 * d.y, len]
        } else {
            [0.5, 0.5, 0.0]
        }
    }
}

/// Relief depth by region (authored): coarser on the nose, finest on the eyelids, none on the
/// lip vermilion (its own vertical folds are not modelled).
fn relief_depth(w: &regions::Weights) -> f32 {
    let g = |i: usize| w[i];
    let skin = 1.0 - g(region!("mouth_interior")).max(g(region!("eye_sockets")));
    (skin
        * (1.0 - g(region!("lips")))
        * (1.0 + 0.3 * g(region!("nose"))
            - 0.5 * g(region!("eyelids"))
            - 0.2 * g(region!("scalp"))
            - 0.2 * g(region!("ears"))))
    .clamp(0.0, 1.5)
}

/// A field's value in a texel.
type Get = Box<dyn Fn(&Texel) -> f32 + Sync>;

/// The scalar fields, by name, with their value in a texel.
type ScalarGetters = std::collections::BTreeMap<String, Get>;

/// The vector fields, by name, with their components' values in a texel.
type VectorGetters = [(&'static str, [Get; 3]); 3];

/// Each scalar field with its value in a texel, named as the set names them: a later insertion
/// of a name replaces an earlier one; the regions' weights only fill names not taken.
fn scalar_getters() -> ScalarGetters {
    let mut scalars = ScalarGetters::new();
    for (k, name) in FIELD_NAMES.iter().enumerate() {
        scalars.insert((*name).into(), Box::new(move |v| v.f[k]));
    }
    for (k, name) in REGIONS.iter().enumerate() {
        scalars
            .entry((*name).into())
            .or_insert_with(|| Box::new(move |v| v.regions[k]));
    }
    for (k, name) in regional::CHANNELS.iter().enumerate() {
        scalars.insert((*name).into(), Box::new(move |v| v.bio[k]));
    }
    for (k, r) in wrinkle_regions::REGIONS.iter().enumerate() {
        scalars.insert(wrinkle_mask_field(r.name), Box::new(move |v| v.wrinkle[k]));
    }
    scalars.insert("relief".into(), Box::new(|v| v.relief));
    scalars
}

/// The vector fields ([`VECTOR_FIELDS`]) with their components' values in a texel.
fn vector_getters() -> VectorGetters {
    let xyz = |f: fn(&Texel) -> &[f32; 3]| -> [Get; 3] {
        std::array::from_fn(|c| -> Get { Box::new(move |v| f(v)[c]) })
    };
    [
        (VECTOR_FIELDS[0], xyz(|v| &v.wv)),
        (VECTOR_FIELDS[1], xyz(|v| &v.tv)),
        (VECTOR_FIELDS[2], xyz(|v| &v.hv)),
    ]
}

/// One plane per getter of `gets`: each texel's values, made a band of rows at a time and
/// spread into the planes, so only a band is ever held as structs (6.5 MB, not 200 MB at
/// FIELD_RESOLUTION²).
fn field_planes(raster: &FieldRaster, gets: &[&Get]) -> Vec<Vec<f32>> {
    use rayon::prelude::*;
    let n = FIELD_RESOLUTION;
    let mut planes: Vec<Vec<f32>> = gets.iter().map(|_| vec![0.0f32; n * n]).collect();
    let mut band: Vec<Texel> = Vec::with_capacity(FIELD_BAND_ROWS * n);
    for lo in (0..n).step_by(FIELD_BAND_ROWS) {
        let texels = lo * n..(lo + FIELD_BAND_ROWS).min(n) * n;
        texels
            .clone()
            .into_par_iter()
            .map(|i| raster.texel(i))
            .collect_into_vec(&mut band);
        planes.par_iter_mut().zip(gets).for_each(|(plane, get)| {
            for (o, v) in plane[texels.clone()].iter_mut().zip(&band) {
                *o = get(v);
            }
        });
    }
    planes
}

/// The planes dilated into the gutter (from the `covered` texels) and named: the scalars',
/// then the vectors' components, in the getters' order.
fn dilated_set(
    planes: Vec<Vec<f32>>,
    covered: &[bool],
    scalars: &ScalarGetters,
    vectors: &VectorGetters,
) -> FieldSet {
    use rayon::prelude::*;
    let n = FIELD_RESOLUTION;
    let src = dilation_sources(covered, n, n);
    let maps: Vec<Map> = planes
        .into_par_iter()
        .map(|mut plane| {
            if let Some(src) = &src {
                apply_dilation(&mut plane, src);
            }
            Map::from_vec(n, n, plane).expect("a field of FIELD_RESOLUTION²")
        })
        .collect();
    let mut next = maps.into_iter();
    let mut set = FieldSet::default();
    for name in scalars.keys() {
        set.scalars
            .insert(name.clone(), next.next().expect("one map per field"));
    }
    for (name, _) in vectors {
        let mut take = || next.next().expect("one map per field");
        set.vectors.insert((*name).into(), [take(), take(), take()]);
    }
    set
}

/// Holds the fields at the precision of the files [`export`] writes them to — 16-bit PNG, the
/// regional biology float EXR — so a template read back through `--fields` is these fields
/// exactly; and marks them built-in ([`FieldSet::origins`]).
fn hold_at_file_precision(set: &mut FieldSet) {
    use rayon::prelude::*;
    let q = |m: &mut Map| {
        m.data_mut().par_iter_mut().for_each(|v| {
            *v = derma_core::image_io::dequantize16(derma_core::image_io::quantize16(*v))
        });
    };
    for (name, m) in set.scalars.iter_mut() {
        if !regional::CHANNELS.contains(&name.as_str()) {
            q(m);
        }
    }
    set.vectors.values_mut().flatten().for_each(q);
    set.origins = set
        .scalars
        .keys()
        .chain(set.vectors.keys())
        .map(|n| (n.clone(), "built-in".to_string()))
        .collect();
}

/// Rows of the built-in head's fields made at a time ([`fields_on`]).
const FIELD_BAND_ROWS: usize = 32;

/// Smoothing of the regional biology over the surface (mm): no anatomical boundary is sharp in
/// blood or pigment; facial hemoglobin maps vary smoothly on the scale of a centimetre
/// (Jimenez et al. 2010, fig. 4).
pub const BIO_SMOOTHING_MM: f32 = 8.0;

/// Regional biology per vertex of `mesh`, diffused over the surface to a Gaussian of about
/// `sigma_mm`: vertices at one position (UV seams) are welded, then uniform Laplacian smoothing
/// x ← (x + Σ neighbours) / (1 + degree) runs N = (7/3)(σ/ē)² times (ē the mean edge length; each
/// step adds about (3/7) ē² of variance per axis on a triangulated quad grid).
fn smoothed_gains(mesh: &TriMesh, regions: &Regions, sigma_mm: f32) -> Vec<[f32; 4]> {
    use std::collections::HashMap;
    let key = |p: Vec3| (p * 1e3).round().as_ivec3().to_array();
    let mut weld: HashMap<[i32; 3], u32> = HashMap::new();
    let id: Vec<u32> = mesh
        .positions
        .iter()
        .map(|p| {
            let n = weld.len() as u32;
            *weld.entry(key(*p)).or_insert(n)
        })
        .collect();
    let n = weld.len();
    let mut value = vec![[0.0f32; 4]; n];
    let mut seen = vec![false; n];
    for (v, &w) in id.iter().enumerate() {
        if !seen[w as usize] {
            seen[w as usize] = true;
            let r = regions.weights(mesh.positions[v], mesh.uvs[v]);
            value[w as usize] = regional::gains(&r);
        }
    }
    let mut nbrs: Vec<Vec<u32>> = vec![Vec::new(); n];
    let (mut edge_sum, mut edges) = (0.0f64, 0usize);
    for t in &mesh.triangles {
        for k in 0..3 {
            let (a, b) = (t[k] as usize, t[(k + 1) % 3] as usize);
            let (wa, wb) = (id[a], id[b]);
            if wa != wb && !nbrs[wa as usize].contains(&wb) {
                nbrs[wa as usize].push(wb);
                nbrs[wb as usize].push(wa);
                edge_sum += (mesh.positions[a] - mesh.positions[b]).length() as f64;
                edges += 1;
            }
        }
    }
    let e = (edge_sum / edges.max(1) as f64) as f32;
    let steps = ((7.0 / 3.0) * (sigma_mm / e).powi(2)).ceil() as usize;
    let mut next = value.clone();
    for _ in 0..steps {
        for i in 0..n {
            let mut acc = value[i];
            for &j in &nbrs[i] {
                for c in 0..4 {
                    acc[c] += value[j as usize][c];
                }
            }
            let k = 1.0 / (1 + nbrs[i].len()) as f32;
            next[i] = acc.map(|x| x * k);
        }
        std::mem::swap(&mut value, &mut next);
    }
    id.iter().map(|&w| value[w as usize]).collect()
}

/// Writes the built-in head for artists to start from: `head.obj` (the skin, mm), `head_parts.obj`
/// (eyes, lashes, teeth, tongue as named objects), `head.glb` (metres, every part a named node,
/// the 52 face units as morph targets) and every default field: 16-bit PNG (`NAME.png`, the
/// `*_vectors` as RGB), the regional biology as float EXR (`regional_*.exr`) — the layout
/// `--fields` reads (docs/skin.md, "The template's fields").
pub fn export(dir: &std::path::Path, person: &Person) -> crate::Result<Vec<String>> {
    derma_core::atomic::ensure_writable_dir(dir)?;
    let head = Head::builtin();
    derma_head::export::write_obj(head, &dir.join("head.obj"), &dir.join("head_parts.obj"))
        .map_err(crate::SkinError::from_head)?;
    derma_head::export::write_glb(head, &dir.join("head.glb"))
        .map_err(crate::SkinError::from_head)?;
    let fields = default_fields(&head.skin, person);
    let mut written = vec![
        "head.obj".to_string(),
        "head_parts.obj".to_string(),
        "head.glb".to_string(),
    ];
    for (name, m) in &fields.scalars {
        // Regional gains and shifts are not probabilities: written as their own values (EXR,
        // float32), which round-trip exactly; everything else as 16-bit greyscale in [0, 1].
        let file = if regional::CHANNELS.contains(&name.as_str()) {
            let file = format!("{name}.exr");
            derma_core::image_io::write_exr(
                &dir.join(&file),
                &[("Y", m)],
                derma_core::image_io::ExrPrecision::F32,
            )?;
            file
        } else {
            let file = format!("{name}.png");
            derma_core::image_io::write_png16(&dir.join(&file), &[m])?;
            file
        };
        written.push(file);
    }
    for (name, [r, g, b]) in &fields.vectors {
        derma_core::image_io::write_png16(&dir.join(format!("{name}.png")), &[r, g, b])?;
        written.push(format!("{name}.png"));
    }
    Ok(written)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// ∫ field dA (cm²) of each default field on the head at the default scatter resolution
    /// (for a woman: the scalp field without the beard, whose follicles come on top in men).
    fn field_areas() -> Vec<(&'static str, f64)> {
        let m = head_mesh();
        let person = Person {
            sex: regional::Sex::Female,
            ..Person::default()
        };
        let fields = default_fields(&m, &person);
        let tangents = crate::surface::mikktspace_tangents(&m);
        let s = crate::surface::Surface::mesh(&m, &tangents, 1024, 1024);
        THESIS_COUNTS
            .iter()
            .map(|(name, _)| {
                let f = &fields.scalars[*name];
                let sm = crate::scatter::Sampler::new(&s, |i| {
                    let uv = s.uv(i);
                    f.sample_uv(uv.x, uv.y, false).clamp(0.0, 1.0)
                });
                (*name, sm.weighted_area_mm2() / 100.0)
            })
            .collect()
    }

    #[test]
    fn default_densities_reproduce_thesis_counts() {
        let d = &DEFAULT_DENSITY;
        let dens = [d.cyst, d.mole, d.freckle, d.wrinkle, d.follicle, d.eyebrow];
        let mut ok = true;
        for (((name, area), (_, count)), density) in
            field_areas().into_iter().zip(THESIS_COUNTS).zip(dens)
        {
            println!(
                "{name}: area {area:.3} cm², density for {count} = {:.5}",
                count as f64 / area
            );
            let got = density as f64 * area;
            ok &= (got - count as f64).abs() <= 0.01 * count as f64;
        }
        assert!(ok, "densities out of date (see the printed values)");
    }
}

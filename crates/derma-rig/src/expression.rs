//! The built-in expression library: the six basic emotions (Ekman 1972) plus exercise and
//! alcohol, as regional changes of the local hemoglobin statistics on derma's built-in head.
//!
//! These are AUTHORED APPROXIMATIONS of the observations in Jimenez et al. 2010 (§3.1, figures
//! 1, 2, 5, 10–13), not measurements: the paper publishes its maps only as figures. Each region
//! is an anisotropic Gaussian in canonical face coordinates (mm; eyes at y = 21, mouth line at
//! y = −46; `derma_head::Regions::face_coords` maps any head there through its landmarks), mirrored for paired regions, with a gain on the local mean (perfusion) and on the
//! local standard deviation (contrast of the vascular pattern). Gains combine multiplicatively
//! (in log space), so overlapping regions stay positive and smooth.

use derma_core::mesh::TriMesh;
use derma_core::Map;
use derma_head::{Head, Regions};
use glam::Vec3;

/// One region of change.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Region {
    /// Centre (x, y) in canonical face millimetres ([`derma_head::Regions::face_coords`]); `x`
    /// is mirrored when `paired`.
    pub centre: (f32, f32),
    /// Standard deviations of the Gaussian along x and y (mm).
    pub size: (f32, f32),
    /// Mirrored across the face's midline (a pair of regions).
    pub paired: bool,
    /// Factor on the local mean hemoglobin at the centre.
    pub mean_gain: f32,
    /// Factor on the local standard deviation at the centre.
    pub sigma_gain: f32,
}

/// Whether an entry follows geometry (an expression, driven by the blend-shape weights) or is a
/// global physiological state with its own rig parameter (Jimenez et al. 2010 §5).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Kind {
    /// Follows geometry: driven by the blend-shape weights.
    Expression,
    /// A physiological state of the whole face with its own rig parameter.
    Global,
}

/// A library entry.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Expression {
    /// Its name in the library.
    pub name: &'static str,
    /// Expression or global state.
    pub kind: Kind,
    /// Suggested global hemoglobin scale at full weight (§7: anger ×1.27, fear ×0.81; 1 for the
    /// rest); `derma rig eval --global-scale auto` blends these by weight.
    pub global_scale: f32,
    /// Gain on the local mean over the whole face (global states), before the regions.
    pub face_gain: f32,
    /// The regions of local change.
    pub regions: &'static [Region],
    /// Face units (ARKit names, weights at full expression) that pose the head for it: the
    /// Action Units of EMFACS prototypes (Ekman & Friesen, Facial Action Coding System, 1978;
    /// Friesen & Ekman 1983) — happiness AU6+12, sadness AU1+4+15, anger AU4+5+7+23, fear
    /// AU1+2+4+5+20+26, surprise AU1+2+5B+26, disgust AU9+15+16 — each mapped to the unit that
    /// moves the same region (authored). Empty for the global states.
    pub face_units: &'static [(&'static str, f32)],
    /// What the entry encodes and which observation it follows.
    pub notes: &'static str,
}

const fn r(
    centre: (f32, f32),
    size: (f32, f32),
    paired: bool,
    mean_gain: f32,
    sigma_gain: f32,
) -> Region {
    Region {
        centre,
        size,
        paired,
        mean_gain,
        sigma_gain,
    }
}

/// The library, in a fixed order (the order of `derma rig library`).
pub const LIBRARY: [Expression; 8] = [
    Expression {
        name: "happiness",
        kind: Kind::Expression,
        global_scale: 1.0,
        face_gain: 1.0,
        regions: &[
            // Cheekbones raised and bulging: perfusion rises over them during a smile (§3.1,
            // observation 2).
            r((40.0, 4.0), (13.0, 11.0), true, 1.35, 1.2),
            // Compressed skin drains (observation 2): crow's feet, lower lids, nasolabial folds.
            r((50.0, 18.0), (6.0, 5.0), true, 0.8, 0.85),
            r((22.0, -28.0), (4.0, 12.0), true, 0.8, 0.85),
            // Lips stretched over the teeth.
            r((0.0, -46.0), (18.0, 6.0), false, 0.9, 0.9),
        ],
        face_units: &[("mouthSmileLeft", 1.0), ("mouthSmileRight", 1.0), ("cheekSquintLeft", 0.7), ("cheekSquintRight", 0.7)],
        notes: "smile: cheekbone perfusion up, crow's feet, nasolabial folds and stretched lips drained (Jimenez et al. 2010 §3.1 obs. 2, fig. 1 'sad smile')",
    },
    Expression {
        name: "sadness",
        kind: Kind::Expression,
        global_scale: 1.0,
        face_gain: 1.0,
        regions: &[
            // Inner brows raised: the central forehead bunches and drains.
            r((12.0, 50.0), (9.0, 7.0), true, 0.85, 0.9),
            // Mentalis raises the chin boss: compressed, drained.
            r((0.0, -68.0), (11.0, 7.0), false, 0.8, 0.85),
            // Reddening around the eyes and nose tip.
            r((22.0, 14.0), (8.0, 6.0), true, 1.15, 1.1),
            r((0.0, -6.0), (7.0, 7.0), false, 1.12, 1.05),
        ],
        face_units: &[("browInnerUp", 0.8), ("browDownLeft", 0.3), ("browDownRight", 0.3), ("mouthFrownLeft", 0.8), ("mouthFrownRight", 0.8)],
        notes: "inner brows up and chin boss compressed (drained); eyes and nose tip redder (authored after fig. 12)",
    },
    Expression {
        name: "anger",
        kind: Kind::Expression,
        global_scale: 1.27,
        face_gain: 1.0,
        regions: &[
            // Brows lowered and drawn together: the glabella is compressed.
            r((0.0, 34.0), (7.0, 7.0), false, 0.8, 0.85),
            // Lips pressed together.
            r((0.0, -46.0), (18.0, 6.0), false, 0.75, 0.8),
            // Forehead above the knitted brows and the nostril wings flush.
            r((0.0, 54.0), (26.0, 8.0), false, 1.12, 1.1),
            r((11.0, -10.0), (5.0, 5.0), true, 1.15, 1.1),
        ],
        face_units: &[("browDownLeft", 1.0), ("browDownRight", 1.0), ("eyeWideLeft", 0.3), ("eyeWideRight", 0.3), ("eyeSquintLeft", 0.5), ("eyeSquintRight", 0.5), ("mouthPressLeft", 0.8), ("mouthPressRight", 0.8)],
        notes: "glabella and pressed lips drained, forehead and nostrils flushed; global blushing ×1.27 (Jimenez et al. 2010 §7, fig. 1)",
    },
    Expression {
        name: "fear",
        kind: Kind::Expression,
        global_scale: 0.81,
        face_gain: 1.0,
        regions: &[
            // Brows raised and drawn together: horizontal forehead compression.
            r((0.0, 56.0), (24.0, 7.0), false, 0.85, 0.9),
            // Lips stretched sideways.
            r((0.0, -46.0), (20.0, 6.0), false, 0.85, 0.85),
            // Upper lids raised: stretched, drained.
            r((32.0, 27.0), (9.0, 4.0), true, 0.88, 0.9),
        ],
        face_units: &[("browInnerUp", 1.0), ("browOuterUpLeft", 0.6), ("browOuterUpRight", 0.6), ("eyeWideLeft", 0.8), ("eyeWideRight", 0.8), ("mouthStretchLeft", 0.7), ("mouthStretchRight", 0.7), ("jawOpen", 0.2)],
        notes: "forehead, stretched lips and upper lids drained; global pallor ×0.81 (Jimenez et al. 2010 §7, fig. 1)",
    },
    Expression {
        name: "surprise",
        kind: Kind::Expression,
        global_scale: 1.0,
        face_gain: 1.0,
        regions: &[
            // Brows raised high: the whole forehead folds and drains in bands.
            r((0.0, 56.0), (36.0, 8.0), false, 0.82, 0.88),
            // Upper lids stretched open.
            r((32.0, 27.0), (10.0, 4.0), true, 0.85, 0.9),
            // Jaw dropped: lips and chin stretched.
            r((0.0, -46.0), (18.0, 7.0), false, 0.85, 0.9),
            r((0.0, -72.0), (12.0, 8.0), false, 0.9, 0.95),
        ],
        face_units: &[("browInnerUp", 1.0), ("browOuterUpLeft", 1.0), ("browOuterUpRight", 1.0), ("eyeWideLeft", 0.6), ("eyeWideRight", 0.6), ("jawOpen", 0.5)],
        notes: "raised brows fold and drain the forehead, open lids and dropped jaw stretch (drain) lids, lips and chin (fig. 11)",
    },
    Expression {
        name: "disgust",
        kind: Kind::Expression,
        global_scale: 1.0,
        face_gain: 1.0,
        regions: &[
            // Nose wrinkler: the sides of the nasal bridge compress.
            r((10.0, 14.0), (5.0, 7.0), true, 0.75, 0.8),
            // Upper lip raised and everted: the philtrum area fills.
            r((0.0, -30.0), (12.0, 6.0), false, 1.18, 1.1),
            // Cheeks pushed up.
            r((36.0, 0.0), (11.0, 10.0), true, 1.2, 1.1),
        ],
        face_units: &[("noseSneerLeft", 1.0), ("noseSneerRight", 1.0), ("mouthUpperUpLeft", 0.6), ("mouthUpperUpRight", 0.6), ("mouthFrownLeft", 0.4), ("mouthFrownRight", 0.4)],
        notes: "nasal bridge compressed (drained), raised upper lip and cheeks flushed (Jimenez et al. 2010 fig. 1, 13)",
    },
    Expression {
        name: "exercise",
        kind: Kind::Global,
        global_scale: 1.0,
        face_gain: 1.12,
        regions: &[
            // After exertion the lateral cheeks and the forehead flush most.
            r((44.0, -6.0), (16.0, 16.0), true, 1.4, 1.15),
            r((0.0, 56.0), (34.0, 10.0), false, 1.22, 1.1),
            r((0.0, -74.0), (12.0, 8.0), false, 1.12, 1.05),
        ],
        face_units: &[],
        notes: "global state: the whole face +12 %, lateral cheeks and forehead most (authored after fig. 5 top and fig. 10; obs. 5: a spatial pattern of its own)",
    },
    Expression {
        name: "alcohol",
        kind: Kind::Global,
        global_scale: 1.0,
        face_gain: 1.08,
        regions: &[
            // Alcohol flushing concentrates centrally: nose, medial cheeks, around the eyes.
            r((0.0, -4.0), (8.0, 12.0), false, 1.35, 1.15),
            r((26.0, -6.0), (10.0, 10.0), true, 1.3, 1.15),
            r((24.0, 20.0), (9.0, 5.0), true, 1.12, 1.05),
        ],
        face_units: &[],
        notes: "global state: the whole face +8 %, nose and medial cheeks most, a pattern distinct from exercise (authored after fig. 5 top and fig. 10; obs. 5)",
    },
];

/// The library entry called `name`.
/// The entries `names` selects: each by name, or every entry for "all"; an unknown name is an
/// error listing the library.
pub fn select(names: &[String]) -> crate::Result<Vec<&'static Expression>> {
    if names.iter().any(|n| n == "all") {
        return Ok(LIBRARY.iter().collect());
    }
    names
        .iter()
        .filter(|n| !n.is_empty())
        .map(|n| {
            find(n).ok_or_else(|| {
                crate::error::invalid(
                    "built-in expression",
                    format!(
                        "'{n}' is not in the library ({})",
                        LIBRARY
                            .iter()
                            .map(|e| e.name)
                            .collect::<Vec<_>>()
                            .join(", ")
                    ),
                )
            })
        })
        .collect()
}

/// The library entry named `name`.
pub fn find(name: &str) -> Option<&'static Expression> {
    LIBRARY.iter().find(|e| e.name == name)
}

impl Expression {
    /// (mean gain, σ gain) at point `p` of the built-in head.
    pub fn gains_at(&self, p: Vec3) -> (f32, f32) {
        self.gains_on(p, &Head::builtin().regions)
    }

    /// (mean gain, σ gain) at point `p` of a head whose regions are `regions`.
    pub fn gains_on(&self, p: Vec3, regions: &Regions) -> (f32, f32) {
        let (x, y, front) = regions.face_coords(p);
        if front <= 0.0 {
            return (1.0, 1.0);
        }
        let (mut lm, mut ls) = (self.face_gain.ln(), 0.0f32);
        for reg in self.regions {
            let g = |cx: f32| {
                (-0.5
                    * (((x - cx) / reg.size.0).powi(2) + ((y - reg.centre.1) / reg.size.1).powi(2)))
                .exp()
            };
            let w = if reg.paired {
                g(reg.centre.0).max(g(-reg.centre.0))
            } else {
                g(reg.centre.0)
            };
            lm += w * reg.mean_gain.ln();
            ls += w * reg.sigma_gain.ln();
        }
        ((front * lm).exp(), (front * ls).exp())
    }
}

/// The face units posing expression weights `weights` (by library name): Σ_e w_e · units_e
/// per unit, at most 1, in the order units first appear; names outside the library pose
/// nothing.
pub fn face_units<'a>(
    weights: impl IntoIterator<Item = (&'a str, f32)>,
) -> Vec<(&'static str, f32)> {
    let mut out: Vec<(&'static str, f32)> = Vec::new();
    for (name, w) in weights {
        for (u, k) in find(name).map_or(&[][..], |e| e.face_units) {
            add_unit(&mut out, u, w * k);
        }
    }
    out
}

/// Adds weight `w` of face unit `u` to `units`: a unit already there sums, at most 1.
pub fn add_unit<'a>(units: &mut Vec<(&'a str, f32)>, u: &'a str, w: f32) {
    match units.iter_mut().find(|(n, _)| *n == u) {
        Some(e) => e.1 = (e.1 + w).min(1.0),
        None => units.push((u, w.min(1.0))),
    }
}

/// Where the library's regions land: on the built-in head's UV layout (which a fitted head's
/// template shares), or on a user's mesh in its own UV layout, through the landmarks of the
/// head fitted to it.
pub enum Placement<'a> {
    /// The built-in head's UV layout.
    Builtin,
    /// A user's mesh (mm, in the frame its head was fitted in) and that head's regions.
    Mesh {
        /// The mesh, with its own UVs.
        mesh: &'a TriMesh,
        /// The fitted head's regions (its landmarks in the mesh's frame).
        regions: &'a Regions,
    },
}

impl Placement<'_> {
    /// Surface points on a `w × h` UV grid (texel centres), `None` outside the charts.
    pub fn points(&self, w: usize, h: usize) -> Vec<Option<Vec3>> {
        let mesh = match self {
            Placement::Builtin => &Head::builtin().skin,
            Placement::Mesh { mesh, .. } => *mesh,
        };
        let raster = derma_core::raster::UvRaster::new(mesh, w, h);
        (0..w * h)
            .map(|i| raster.covered(i).then(|| raster.position(mesh, i)))
            .collect()
    }

    /// The regions that give the points their face coordinates.
    pub fn regions(&self) -> &Regions {
        match self {
            Placement::Builtin => &Head::builtin().regions,
            Placement::Mesh { regions, .. } => regions,
        }
    }
}

/// Gain maps (mean, σ) of `e` on a `w × h` grid, from `points` ([`Placement::points`]) and the
/// placement's `regions`; 1 outside the charts.
pub fn gain_maps(
    e: &Expression,
    points: &[Option<Vec3>],
    regions: &Regions,
    w: usize,
    h: usize,
) -> (Map, Map) {
    let (gm, gs): (Vec<f32>, Vec<f32>) = points
        .iter()
        .map(|p| p.map_or((1.0, 1.0), |p| e.gains_on(p, regions)))
        .unzip();
    (Map::from_fn(w, h, |i| gm[i]), Map::from_fn(w, h, |i| gs[i]))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The skin point of the built-in head nearest canonical face coordinates (x, y).
    fn face(x: f32, y: f32) -> Vec3 {
        let head = Head::builtin();
        let d = |p: &Vec3| {
            let (fx, fy, front) = head.regions.face_coords(*p);
            (fx - x).powi(2) + (fy - y).powi(2) + if front < 0.99 { 1e6 } else { 0.0 }
        };
        *head
            .skin
            .positions
            .iter()
            .min_by(|a, b| d(a).total_cmp(&d(b)))
            .unwrap()
    }

    #[test]
    fn library_follows_the_papers_observations() {
        assert_eq!(LIBRARY.len(), 8);
        let names: Vec<_> = LIBRARY.iter().map(|e| e.name).collect();
        for n in [
            "happiness",
            "sadness",
            "anger",
            "fear",
            "surprise",
            "disgust",
            "exercise",
            "alcohol",
        ] {
            assert!(names.contains(&n), "{n}");
        }
        // §7: anger ×1.27, fear ×0.81.
        assert_eq!(find("anger").unwrap().global_scale, 1.27);
        assert_eq!(find("fear").unwrap().global_scale, 0.81);
        // Obs. 2: a smile raises perfusion over the cheekbones and drains compressed skin.
        let smile = find("happiness").unwrap();
        assert!(smile.gains_at(face(40.0, 4.0)).0 > 1.25);
        assert!(smile.gains_at(face(-40.0, 4.0)).0 > 1.25, "mirrored");
        assert!(smile.gains_at(face(22.0, -28.0)).0 < 0.9);
        // Behind the face nothing changes.
        assert_eq!(smile.gains_at(Vec3::new(0.0, 0.0, -100.0)), (1.0, 1.0));
        // Obs. 5: the two global states have different spatial patterns.
        let (ex, al) = (find("exercise").unwrap(), find("alcohol").unwrap());
        let lateral = face(46.0, -6.0);
        let nose = face(0.0, -4.0);
        assert!(ex.gains_at(lateral).0 > ex.gains_at(nose).0);
        assert!(al.gains_at(nose).0 > al.gains_at(lateral).0);
    }

    #[test]
    fn expressions_pose_the_heads_face_units() {
        let head = Head::builtin();
        for e in &LIBRARY {
            assert_eq!(
                e.face_units.is_empty(),
                e.kind == Kind::Global,
                "{}",
                e.name
            );
            for (u, k) in e.face_units {
                assert!(
                    head.face_units().iter().any(|t| t.name == *u),
                    "{}: {u}",
                    e.name
                );
                assert!(*k > 0.0 && *k <= 1.0);
            }
        }
        let u = face_units([("happiness", 0.5), ("surprise", 1.0)]);
        assert_eq!(u[0], ("mouthSmileLeft", 0.5));
        assert!(u.contains(&("cheekSquintLeft", 0.35)));
        assert!(u.contains(&("browInnerUp", 1.0)));
        // Two expressions that share a unit add up to at most 1.
        let u = face_units([("fear", 1.0), ("surprise", 1.0)]);
        assert!(u.contains(&("browInnerUp", 1.0)) && u.contains(&("jawOpen", 0.7)));
        assert!(face_units([("exercise", 1.0), ("nonsense", 1.0)]).is_empty());
    }

    #[test]
    fn gain_maps_cover_the_face_of_the_head() {
        let (w, h) = (64, 64);
        let pts = Placement::Builtin.points(w, h);
        let (gm, _) = gain_maps(
            find("happiness").unwrap(),
            &pts,
            Placement::Builtin.regions(),
            w,
            h,
        );
        let st = gm.stats(None);
        assert!(st.max > 1.2 && st.min < 0.92, "{st:?}");
    }
}

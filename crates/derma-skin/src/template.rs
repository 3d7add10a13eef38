//! The built-in head template: a parametric adult head (mm, +Y up, face towards +Z) with a single
//! UV chart — u is the longitude with the seam at the back of the head, v the polar angle —
//! and its default probability and vector fields, all generated here.
//!
//! The shape is an ellipsoid with the proportions of an adult head (breadth 152, height 224,
//! depth 192 mm; close to median adult head breadth and length in anthropometric surveys such as
//! ANSUR II) plus facial relief (nose, brow ridge, eye sockets, cheekbones, lips, chin) as smooth
//! bumps: a neutral stand-in for a sculpted head, good enough to place and show features on.

use crate::field::FieldSet;
use derma_core::mesh::TriMesh;
use derma_core::raster::{apply_dilation, dilation_sources, UvRaster};
use derma_core::Map;
use glam::{Vec2, Vec3};
use std::f32::consts::{PI, TAU};

/// Longitude segments and polar segments of the template mesh.
const SEG_U: usize = 256;
const SEG_V: usize = 160;
/// Polar angle at the open bottom of the neck.
const PHI_MAX: f32 = 0.82 * PI;
/// Resolution of the generated fields.
pub const FIELD_RESOLUTION: usize = 1024;

/// Peak densities (1/cm² where the field is 1) that reproduce the thesis' counts (§5.3) on the
/// template with its default fields: density = count / ∫ field dA. The integrals are recomputed
/// by the test `default_densities_reproduce_thesis_counts`.
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

/// Field integrals on the template (cm²): cysts 296.36, moles 666.93, freckles 87.229, wrinkles
/// 23.305, scalp 504.08, eyebrows 6.367.
pub const DEFAULT_DENSITY: Densities = Densities {
    cyst: 16.871,
    mole: 1.0496,
    freckle: 34.392,
    wrinkle: 1.7164,
    follicle: 337.25,
    eyebrow: 78.534,
};

#[inline]
fn smoothstep(a: f32, b: f32, x: f32) -> f32 {
    let t = ((x - a) / (b - a)).clamp(0.0, 1.0);
    t * t * (3.0 - 2.0 * t)
}

#[inline]
fn gauss(x: f32, y: f32, cx: f32, cy: f32, sx: f32, sy: f32) -> f32 {
    (-0.5 * (((x - cx) / sx).powi(2) + ((y - cy) / sy).powi(2))).exp()
}

/// Unit direction of longitude θ (0 = back) and polar angle φ (0 = top).
fn direction(theta: f32, phi: f32) -> Vec3 {
    Vec3::new(
        -phi.sin() * theta.sin(),
        phi.cos(),
        -phi.sin() * theta.cos(),
    )
}

/// Radius of the head along `d` before facial relief: an ellipsoid that narrows into a neck.
fn base_radius(d: Vec3) -> f32 {
    let (ax, ay) = (76.0, 112.0);
    let az = if d.z > 0.0 { 92.0 } else { 100.0 };
    let r = 1.0 / ((d.x / ax).powi(2) + (d.y / ay).powi(2) + (d.z / az).powi(2)).sqrt();
    // Neck: below y ≈ −60 mm blend towards a 55 mm cylinder-like radius.
    let y = r * d.y;
    let neck = 55.0 / (1.0 - d.y * d.y).sqrt().max(0.2);
    let t = smoothstep(-55.0, -95.0, y);
    r + (neck.min(r) - r) * t
}

/// Facial relief (mm, outwards) at face coordinates (x, y) of a front-facing point.
fn relief(x: f32, y: f32) -> f32 {
    // Nose: a ridge from the bridge (y 25) to the tip (y −8), then the base to y −16.
    let nose_h = if y > -8.0 {
        8.0 + 14.0 * smoothstep(25.0, -8.0, y)
    } else {
        22.0 * smoothstep(-18.0, -8.0, y)
    };
    let nose_w = 6.0 + 6.0 * smoothstep(25.0, -12.0, y);
    let nose = if y < 30.0 {
        nose_h * (-0.5 * (x / nose_w).powi(2)).exp() * smoothstep(32.0, 24.0, y).max(0.0)
    } else {
        0.0
    };
    let sockets =
        -10.0 * (gauss(x, y, 32.0, 22.0, 13.0, 10.0) + gauss(x, y, -32.0, 22.0, 13.0, 10.0));
    let lids = 7.0 * (gauss(x, y, 32.0, 21.0, 9.0, 6.0) + gauss(x, y, -32.0, 21.0, 9.0, 6.0));
    let brow = 5.0 * gauss(x, y, 0.0, 38.0, 40.0, 6.0);
    let cheeks = 6.0 * (gauss(x, y, 42.0, 0.0, 14.0, 14.0) + gauss(x, y, -42.0, 0.0, 14.0, 14.0));
    let lips = 7.0 * gauss(x, y, 0.0, -46.0, 20.0, 9.0) - 2.5 * gauss(x, y, 0.0, -46.0, 18.0, 1.2);
    let chin = 6.0 * gauss(x, y, 0.0, -76.0, 13.0, 10.0);
    nose + sockets + lids + brow + cheeks + lips + chin
}

/// Point of the template at (θ, φ).
fn point(theta: f32, phi: f32) -> Vec3 {
    let d = direction(theta, phi);
    let r = base_radius(d);
    let p = d * r;
    let front = smoothstep(0.25, 0.6, d.z);
    d * (r + front * relief(p.x, p.y))
}

/// The template mesh in millimetres.
pub fn head_mesh() -> TriMesh {
    let mut m = TriMesh::default();
    for j in 0..=SEG_V {
        let v = j as f32 / SEG_V as f32;
        let phi = v * PHI_MAX;
        for i in 0..=SEG_U {
            let u = i as f32 / SEG_U as f32;
            let theta = (u * TAU) % TAU;
            m.positions.push(point(theta, phi));
            m.uvs.push(Vec2::new(u, 1.0 - v));
            // Normal by central differences of the parametric surface (periodic in θ, so both
            // sides of the seam get the same normal).
            let (dt, dp) = (1e-3, 1e-3);
            let n = if phi < 1e-4 {
                Vec3::Y
            } else {
                let pt = point(theta + dt, phi) - point(theta - dt, phi);
                let pp = point(theta, phi + dp) - point(theta, (phi - dp).max(0.0));
                pt.cross(pp).normalize_or(Vec3::Y)
            };
            m.normals.push(
                if n.dot(m.positions.last().copied().unwrap_or(Vec3::Y)) < 0.0 {
                    -n
                } else {
                    n
                },
            );
        }
    }
    let row = SEG_U as u32 + 1;
    for j in 0..SEG_V as u32 {
        for i in 0..SEG_U as u32 {
            let (a, b, c, d) = (
                j * row + i,
                j * row + i + 1,
                (j + 1) * row + i,
                (j + 1) * row + i + 1,
            );
            // Counter-clockwise seen from outside.
            if j > 0 {
                m.triangles.push([a, b, c]);
            }
            m.triangles.push([b, d, c]);
        }
    }
    m
}

/// Face coordinates of a template point: x (mm, the head's left positive), y (mm, up; eyes at
/// 21, mouth line at −46, chin at −76) and frontness in [0, 1] (1 on the face, 0 behind it).
pub fn face_coords(p: Vec3) -> (f32, f32, f32) {
    let d = p.normalize_or(Vec3::Y);
    (p.x, p.y, smoothstep(0.15, 0.45, d.z))
}

/// Names of the template's scalar fields, in the order [`field_values`] returns them.
pub const FIELD_NAMES: [&str; 10] = [
    "scalp", "eyebrows", "eyes", "lips", "face", "freckles", "moles", "cysts", "pores", "wrinkles",
];

/// Values of every default scalar field at point `p` of the template, and the wrinkle vector
/// (encoded R, G, B).
fn field_values(p: Vec3) -> ([f32; 10], [f32; 3]) {
    let (x, y, front) = face_coords(p);
    let d = p.normalize_or(Vec3::Y);
    // Hairline height by longitude: 68 mm at the forehead, 20 mm at the temples, −55 mm at the nape.
    let c = d.z / (d.x * d.x + d.z * d.z).sqrt().max(1e-6);
    let hair_y = 20.0 + 48.0 * c.max(0.0) - 75.0 * (-c).max(0.0);
    let scalp = smoothstep(hair_y - 3.0, hair_y + 5.0, y);
    let brow_arch = |sx: f32| 40.0 + 4.0 * (1.0 - ((x - sx) / 24.0).powi(2)).max(0.0);
    let brow = |sx: f32| {
        let ex = ((x - sx) / 24.0).abs();
        let ey = ((y - brow_arch(sx)) / 5.0).abs();
        smoothstep(1.0, 0.8, (ex * ex + ey * ey).sqrt())
            * (1.0 - 0.5 * smoothstep(0.0, 1.0, (x.abs() - 20.0) / 30.0))
    };
    let eyebrows = front * brow(33.0).max(brow(-33.0));
    let eye = |sx: f32| {
        smoothstep(
            1.1,
            0.8,
            (((x - sx) / 17.0).powi(2) + ((y - 21.0) / 9.0).powi(2)).sqrt(),
        )
    };
    let eyes = front * eye(32.0).max(eye(-32.0));
    // Lips: a superellipse around the mouth line (y = −46), the upper lip 8 mm tall with a
    // cupid's bow dip at the centre, the lower lip 10 mm and fuller; corners at |x| = 25 mm.
    let lip_h = if y > -46.0 {
        8.0 - 1.5 * (-(x / 4.0).powi(2)).exp() + 1.5 * (-((x.abs() - 7.0) / 4.0).powi(2)).exp()
    } else {
        10.0
    };
    let lip_r = (((y + 46.0) / lip_h).powi(2) + (x.abs() / 25.0).powf(2.5)).sqrt();
    let lips = front * smoothstep(1.0, 0.8, lip_r);
    let face = front * (1.0 - scalp) * smoothstep(-100.0, -88.0, y);
    let freckles =
        (face * gauss(x, y, 0.0, 5.0, 40.0, 30.0) - eyes - lips - eyebrows).clamp(0.0, 1.0);
    let moles = (1.0 - 0.7 * scalp - lips).clamp(0.0, 1.0);
    let cysts = (face * (1.0 - eyes) * (1.0 - lips)).clamp(0.0, 1.0);
    let pores = (face * (0.4 + 0.6 * gauss(x, y, 0.0, 0.0, 30.0, 25.0)) - eyes - lips - eyebrows)
        .clamp(0.0, 1.0);
    let forehead = face
        * smoothstep(44.0, 50.0, y)
        * smoothstep(66.0, 58.0, y)
        * smoothstep(48.0, 36.0, x.abs());
    let crow = |sx: f32| smoothstep(14.0, 6.0, ((x - sx).powi(2) + (y - 21.0).powi(2)).sqrt());
    let crows = face * crow(50.0).max(crow(-50.0)) * (1.0 - eyes);
    let wrinkles = forehead.max(crows);
    // Wrinkle vectors: horizontal on the forehead, radiating from the outer eye corners.
    let (mut dx, mut dy, mut len) = (0.0f32, 0.0f32, 0.0f32);
    if forehead > 0.0 {
        (dx, dy, len) = (1.0, 0.0, 0.9);
    }
    if crows > forehead {
        let sx = if x > 0.0 { 42.0 } else { -42.0 };
        let v = Vec2::new(x - sx, y - 21.0).normalize_or(Vec2::X);
        (dx, dy, len) = (v.x, v.y, 0.3);
    }
    (
        [
            scalp, eyebrows, eyes, lips, face, freckles, moles, cysts, pores, wrinkles,
        ]
        .map(|v| v.clamp(0.0, 1.0)),
        [0.5 + 0.5 * dx, 0.5 + 0.5 * dy, len],
    )
}

/// The scalar fields (in [`FIELD_NAMES`] order) and the wrinkle vector at one texel.
type FieldTexel = ([f32; 10], [f32; 3]);

/// The template's default fields, rasterised at [`FIELD_RESOLUTION`] and dilated into the gutter.
pub fn default_fields(mesh: &TriMesh) -> FieldSet {
    let n = FIELD_RESOLUTION;
    let raster = UvRaster::new(mesh, n, n);
    let covered: Vec<bool> = (0..n * n).map(|i| raster.covered(i)).collect();
    let values: Vec<FieldTexel> = {
        use rayon::prelude::*;
        (0..n * n)
            .into_par_iter()
            .map(|i| {
                if covered[i] {
                    field_values(raster.position[i])
                } else {
                    ([0.0; 10], [0.5, 0.5, 0.0])
                }
            })
            .collect()
    };
    let src = dilation_sources(&covered, n, n);
    let mk = |f: &dyn Fn(&FieldTexel) -> f32| {
        let mut m = Map::from_vec(n, n, values.iter().map(f).collect()).expect("size");
        if let Some(src) = &src {
            apply_dilation(m.data_mut(), src);
        }
        m
    };
    let mut set = FieldSet::default();
    for (k, name) in FIELD_NAMES.iter().enumerate() {
        set.scalars.insert((*name).into(), mk(&|v| v.0[k]));
    }
    set.vectors.insert(
        "wrinkle_vectors".into(),
        [mk(&|v| v.1[0]), mk(&|v| v.1[1]), mk(&|v| v.1[2])],
    );
    set
}

/// Writes the template for artists to start from: `head.obj` (mm) and every default field as a
/// 16-bit PNG (`NAME.png`, and `wrinkle_vectors.png` as RGB) — the layout `--fields` reads.
pub fn export(dir: &std::path::Path) -> crate::Result<Vec<String>> {
    derma_core::atomic::ensure_writable_dir(dir)?;
    let mesh = head_mesh();
    mesh.write_obj(&dir.join("head.obj"))?;
    let fields = default_fields(&mesh);
    let mut written = vec!["head.obj".to_string()];
    for (name, m) in &fields.scalars {
        derma_core::image_io::write_png16(&dir.join(format!("{name}.png")), &[m])?;
        written.push(format!("{name}.png"));
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

    #[test]
    fn template_is_a_head_sized_closed_chart() {
        let m = head_mesh();
        let (lo, hi) = m.bounds();
        let size = hi - lo;
        assert!(
            (140.0..170.0).contains(&size.x) && (180.0..230.0).contains(&size.z),
            "{size}"
        );
        // UVs in the unit square, no overlaps, most of the square covered.
        let r = UvRaster::new(&m, 256, 256);
        assert_eq!(r.overlapping_triangles, 0);
        assert!(r.coverage() > 0.95, "{}", r.coverage());
        // Surface area of an adult head and neck: 900–1600 cm².
        let a = m.area() / 100.0;
        assert!((900.0..1600.0).contains(&a), "{a} cm²");
    }

    /// ∫ field dA (cm²) of each default field on the template at the default scatter resolution.
    fn field_areas() -> Vec<(&'static str, f64)> {
        let m = head_mesh();
        let fields = default_fields(&m);
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
        for (((name, area), (_, count)), density) in
            field_areas().into_iter().zip(THESIS_COUNTS).zip(dens)
        {
            println!(
                "{name}: area {area:.3} cm², density for {count} = {:.5}",
                count as f64 / area
            );
            let got = density as f64 * area;
            assert!(
                (got - count as f64).abs() <= 0.01 * count as f64,
                "{name}: {got} vs {count}"
            );
        }
    }

    #[test]
    fn fields_are_where_the_face_is() {
        let nose_tip = point(PI, 0.5 * PI + 0.05);
        let (f, _) = field_values(nose_tip);
        assert!(f[4] > 0.9, "face at the nose tip");
        let top = point(PI, 0.15);
        assert!(field_values(top).0[0] > 0.99, "scalp on the crown");
        let mouth = Vec3::new(0.0, -46.0, 100.0);
        assert!(field_values(mouth).0[3] > 0.9, "lips at the mouth");
        assert!(
            field_values(Vec3::new(0.0, -46.0, -100.0)).0[3] == 0.0,
            "no lips at the back"
        );
    }
}

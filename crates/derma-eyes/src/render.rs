//! Looking at the result: the eye region rendered by derma-render's CPU renderer (skin,
//! lashes riding on the lid margins, globes with the open cornea over the iris disc) frame by
//! frame, written as PNG frames, an animated PNG and a contact strip.

use crate::evaluate;
use crate::globe::Globe;
use crate::region::EyeRegion;
use crate::surface::Skin;
use derma_core::mesh::TriMesh;
use derma_core::Map;
use derma_head::Head;
use derma_render::cpu::{self as preview, FlatMaterial, Prop};
use glam::{Quat, Vec2, Vec3};

/// Linear skin colour of the preview (a light-intermediate complexion, authored).
const SKIN_RGB: [f32; 3] = [0.56, 0.36, 0.28];

/// The eye band of the head, cropped for framing, with what each frame moves.
pub struct Stage<'a> {
    head: &'a Head,
    region: &'a EyeRegion,
    skin: &'a Skin<'a>,
    crop: TriMesh,
    /// Vertex of `skin` of each crop vertex.
    source: Vec<u32>,
    tangents: Vec<[f32; 4]>,
    /// The lash parts riding on the lid margins.
    lashes: Vec<crate::still::LashAnchors>,
    globes: [(TriMesh, TriMesh); 2],
    /// Eyeball texture (linear RGB on the head's eye UVs); the default eye when `None`.
    eye: Option<[Map; 3]>,
}

impl<'a> Stage<'a> {
    /// The stage of `head`'s eye band (60 mm either side, 28 mm below to 34 mm above the eyes)
    /// with `skin` (the head's own or a user's mesh following it), the globes textured with
    /// `eye` (linear RGB on the head's eye UVs) or the default eye.
    pub fn new(
        head: &'a Head,
        region: &'a EyeRegion,
        skin: &'a Skin<'a>,
        eye: Option<[Map; 3]>,
    ) -> Stage<'a> {
        // Centred between the globes (a fitted head need not be centred on x = 0).
        let mid = 0.5 * (head.eyes[0].centre + head.eyes[1].centre);
        let (cx, cy) = (mid.x, mid.y);
        let zmin = mid.z - 20.0;
        let keep =
            |p: Vec3| (p.x - cx).abs() < 60.0 && p.y > cy - 28.0 && p.y < cy + 34.0 && p.z > zmin;
        let mesh = skin.mesh();
        let mut index = vec![u32::MAX; mesh.positions.len()];
        let mut crop = TriMesh::default();
        let mut source = Vec::new();
        for t in &mesh.triangles {
            if !t.iter().all(|&i| keep(mesh.positions[i as usize])) {
                continue;
            }
            let tri = t.map(|i| {
                if index[i as usize] == u32::MAX {
                    index[i as usize] = crop.positions.len() as u32;
                    crop.positions.push(mesh.positions[i as usize]);
                    crop.normals
                        .push(mesh.normals.get(i as usize).copied().unwrap_or(Vec3::Z));
                    crop.uvs
                        .push(mesh.uvs.get(i as usize).copied().unwrap_or(Vec2::ZERO));
                    source.push(i);
                }
                index[i as usize]
            });
            crop.triangles.push(tri);
        }
        let tangents = derma_core::mesh::mikktspace_tangents(&crop);
        let lashes = crate::still::lash_anchors(head, region);
        let globes = [0, 1].map(|e| {
            let g = Globe::of(&head.eyes[e]);
            (g.shell(false), g.iris())
        });
        Stage {
            head,
            region,
            skin,
            crop,
            source,
            tangents,
            lashes,
            globes,
            eye,
        }
    }

    /// Renders one frame `size` px wide (linear RGB; the height from the band's 104 × 50 mm
    /// aspect).
    pub fn render(&self, f: &evaluate::Frame, rot: [Quat; 2], size: usize) -> [Map; 3] {
        let mut mesh = self.crop.clone();
        (mesh.positions, mesh.normals) = self.skin.frame(self.region, f, &self.source);
        let lashes: Vec<TriMesh> = self
            .lashes
            .iter()
            .map(|l| l.moved(&self.region.rest, &f.positions))
            .collect();
        let globes: Vec<TriMesh> = (0..2)
            .flat_map(|e| {
                let c = self.head.eyes[e].centre;
                [&self.globes[e].0, &self.globes[e].1].map(|m| {
                    let mut m = m.clone();
                    for p in m.positions.iter_mut() {
                        *p = c + rot[e] * *p;
                    }
                    for n in m.normals.iter_mut() {
                        *n = rot[e] * *n;
                    }
                    m
                })
            })
            .collect();
        static DEFAULT_EYE: fn(Vec2) -> Vec3 = derma_head::eye::default_albedo;
        let textured = |uv: Vec2| -> Vec3 {
            let t = self.eye.as_ref().expect("textured only with a texture");
            Vec3::from(t.each_ref().map(|m| m.sample_uv(uv.x, uv.y, false)))
        };
        let eye_albedo: &(dyn Fn(Vec2) -> Vec3 + Sync) = if self.eye.is_some() {
            &textured
        } else {
            &DEFAULT_EYE
        };
        static LASHES: fn(Vec2) -> Vec3 = |_| Vec3::new(0.02, 0.015, 0.012);
        static LASH_COVERAGE: fn(Vec2) -> f32 = derma_head::lashes::coverage;
        // Sclera under the tear film: glossy. The iris disc sits behind the (open) cornea, whose
        // highlight a flat disc cannot show: matte, or a flat disc mirrors the key light whole.
        let mut props: Vec<Prop> = globes
            .iter()
            .enumerate()
            .map(|(k, m)| {
                let iris = k % 2 == 1;
                Prop {
                    mesh: m,
                    albedo: eye_albedo,
                    roughness: if iris { 0.7 } else { 0.08 },
                    f0: if iris { 0.02 } else { 0.025 },
                    coverage: None,
                    kind: derma_render::material::MATERIAL_EYE,
                }
            })
            .collect();
        for m in &lashes {
            props.push(Prop {
                mesh: m,
                albedo: &LASHES,
                roughness: 0.6,
                f0: 0.04,
                coverage: Some(&LASH_COVERAGE),
                kind: derma_render::material::MATERIAL_OTHER,
            });
        }
        // The band is 120 × 62 mm, framed at 92 % of the render's width: keep its inner
        // 104 × 50 mm (the crop's ragged triangle edges stay outside), so render large enough
        // that this inner part is `size` px wide.
        let (w_mm, h_mm) = (104.0f32, 50.0f32);
        let full = ((size as f32 * 120.0 / (0.92 * w_mm)).ceil() as usize).max(size);
        let material = FlatMaterial::new(0.5, 0.35);
        let colour = preview::uniform_color(SKIN_RGB);
        let img = preview::render_lit(
            &mesh,
            &self.tangents,
            &material.textures(&colour),
            &props,
            0.0,
            full,
            &derma_render::Setup::Studio.lighting(),
        );
        let span = 0.92 * full as f32 / 120.0; // px per mm
        let (cw, ch) = (size, ((h_mm / w_mm * size as f32).round() as usize).max(1));
        let (x0, y0) = ((full - cw) / 2, (full - ch) / 2 + (2.0 * span) as usize);
        img.map(|m| m.crop(x0, y0, cw, ch))
    }
}

/// 8-bit sRGB bytes of a linear RGB image.
pub fn srgb8(img: &[Map; 3]) -> Vec<u8> {
    let n = img[0].width() * img[0].height();
    (0..n)
        .flat_map(|i| {
            img.iter().map(move |m| {
                (derma_core::color::srgb_encode(m.data()[i].clamp(0.0, 1.0)) * 255.0).round() as u8
            })
        })
        .collect()
}

//! The texture set for engines: a glTF 2.0 binary with the head (or a user mesh) and its parts
//! as named meshes, MikkTSpace tangents, the face units as morph targets, and the skin as a
//! metallic-roughness material with KHR_materials_specular (F0 from the specular map),
//! KHR_materials_diffuse_transmission and, on request, KHR_materials_volume (attenuation from
//! the mean free paths of `sss_radius`); plus the maps as loose files under engine naming conventions.

use crate::error::{ExportError, Result};
use derma_core::image_io::png8_bytes;
use derma_core::mesh::{mikktspace_tangents, split_by_tangent, TriMesh};
use derma_core::Map;
use derma_head::export::Glb;
use derma_render::material::{default_eye_texture, SkinMaps};
use glam::Vec3;
use serde_json::{json, Value};
use std::path::{Path, PathBuf};

/// Tangent-space normal convention of loose normal maps (the GLB's own is always glTF's,
/// OpenGL +Y, as the glTF 2.0 specification requires).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum NormalConvention {
    /// +Y up (green up): glTF, Blender, Unity, three.js.
    #[default]
    OpenGl,
    /// −Y (green down): Unreal, Direct3D tools.
    DirectX,
}

/// How loose maps are named.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum MapNames {
    /// derma's own names (base_color.png, normal.png, …).
    #[default]
    Derma,
    /// Substance Painter's export preset names (head_BaseColor.png, head_Normal.png, …).
    Substance,
    /// Unreal / MetaHuman-style texture asset names (T_Head_BC.png, T_Head_N.png, …).
    Unreal,
}

impl MapNames {
    /// The file name of map `key` (base_color, normal, roughness, specular, height,
    /// sss_color, sss_radius, orm).
    pub fn file(self, key: &str) -> String {
        match self {
            MapNames::Derma => format!("{key}.png"),
            MapNames::Substance => {
                let s = match key {
                    "base_color" => "BaseColor",
                    "normal" => "Normal",
                    "roughness" => "Roughness",
                    "specular" => "Specular",
                    "height" => "Height",
                    "sss_color" => "SubsurfaceColor",
                    "sss_radius" => "SubsurfaceRadius",
                    _ => "OcclusionRoughnessMetallic",
                };
                format!("head_{s}.png")
            }
            MapNames::Unreal => {
                let s = match key {
                    "base_color" => "BC",
                    "normal" => "N",
                    "roughness" => "R",
                    "specular" => "S",
                    "height" => "H",
                    "sss_color" => "SSS",
                    "sss_radius" => "SSSR",
                    _ => "ORM",
                };
                format!("T_Head_{s}.png")
            }
        }
    }
}

/// What to export.
pub struct GlbOptions {
    /// The texture set (`derma skin --out DIR`).
    pub textures: PathBuf,
    /// A user mesh, read in `unit` (derma-core's one head-mesh loader); `None`: the built-in
    /// head with eyes, lashes, teeth and tongue.
    pub mesh: Option<PathBuf>,
    /// The user mesh's unit: as `derma skin` read it (its `surface.unit`), or `Auto` (with a
    /// fitted head, the fit's).
    pub unit: derma_core::head_mesh::HeadUnit,
    /// The part of the user mesh's file: as `derma skin` read it, or `Auto`.
    pub part: derma_core::mesh_parts::PartChoice,
    /// A fitted head directory (`derma head fit`) instead of the built-in head.
    pub head: Option<PathBuf>,
    /// The GLB to write.
    pub out: PathBuf,
    /// Loose maps to write beside (directory), with their naming and normal convention.
    pub maps: Option<(PathBuf, MapNames, NormalConvention)>,
    /// Carry the set's expression-wrinkle maps (where it has them) as extra textures, named in
    /// the skin material's `extras.derma_wrinkles` with the weight table.
    pub wrinkles: bool,
    /// An eye texture on the head's eye UVs (`derma photo iris`'s eye.png or eye.exr); default:
    /// the built-in eye.
    pub iris: Option<PathBuf>,
    /// A teeth texture on the head's teeth UVs (`derma photo teeth`'s teeth.png or .exr);
    /// default: the teeth's flat colour.
    pub teeth: Option<PathBuf>,
    /// Also KHR_materials_volume on the skin (attenuation from `sss_radius`). Off by default:
    /// glTF gives a volume no effect without KHR_materials_transmission, which skin has none
    /// of, while Blender's importer turns it into a volume absorption that darkens the head's
    /// bounding box in Eevee.
    pub volume: bool,
    /// The hair cards (lashes, brows) alpha-tested (`alphaMode: MASK`, cutoff ½) for engines
    /// that sort no transparency; by default they are blended (`BLEND`), so a lash thinner than
    /// a pixel fades instead of breaking into dots.
    pub hair_mask: bool,
}

/// A hair card material's alpha mode: blended, or alpha-tested at ½ with `mask`.
fn hair_alpha(material: &mut Value, mask: bool) {
    if mask {
        material["alphaMode"] = json!("MASK");
        material["alphaCutoff"] = json!(0.5);
    } else {
        material["alphaMode"] = json!("BLEND");
    }
}

/// The rig library's expressions that pose the face, each as its (face unit, weight) table:
/// {"happiness": {"mouthSmileLeft": 1.0, …}, …} (the GLB's skin node, the viewer's manifest).
pub fn expression_units() -> Value {
    Value::Object(
        derma_rig::expression::LIBRARY
            .iter()
            .filter(|e| !e.face_units.is_empty())
            .map(|e| (e.name.to_string(), unit_table(e.face_units)))
            .collect(),
    )
}

/// A (face unit, weight) table as a JSON object.
pub fn unit_table(t: &[(&str, f32)]) -> serde_json::Value {
    serde_json::Value::Object(t.iter().map(|(u, k)| (u.to_string(), json!(k))).collect())
}

/// The wrinkle masks packed three regions to an RGB image (no alpha: browsers and engine
/// importers premultiply it, which would wipe the other channels where it is 0), in
/// [`derma_head::wrinkle_regions::REGIONS`] order, the last image padded with zeros; with each
/// image's region names.
pub fn wrinkle_mask_images(
    wm: &derma_render::wrinkles::WrinkleMaps,
) -> Vec<([Map; 3], Vec<&'static str>)> {
    let (w, h) = (wm.masks[0].width(), wm.masks[0].height());
    wm.masks
        .chunks(3)
        .zip(derma_head::wrinkle_regions::REGIONS.chunks(3))
        .map(|(m, r)| {
            let ch = std::array::from_fn(|c| {
                m.get(c).cloned().unwrap_or_else(|| Map::filled(w, h, 0.0))
            });
            (ch, r.iter().map(|r| r.name).collect())
        })
        .collect()
}

/// The wrinkle regions with their face-unit drivers, as the GLB's and the web export's JSON.
pub fn wrinkle_regions_json() -> Value {
    json!(derma_head::wrinkle_regions::REGIONS
        .iter()
        .map(|r| json!({"name": r.name, "drivers": unit_table(r.drivers)}))
        .collect::<Vec<_>>())
}

/// What was written.
#[derive(Debug, Clone, serde::Serialize)]
pub struct GlbReport {
    /// The GLB.
    pub path: PathBuf,
    /// Its size (bytes).
    pub bytes: usize,
    /// Meshes by name.
    pub meshes: Vec<String>,
    /// Morph targets on the skin.
    pub morph_targets: usize,
    /// Extensions used.
    pub extensions: Vec<String>,
    /// Loose maps written.
    pub maps: Vec<PathBuf>,
    /// Per vertex of the GLB's skin mesh, the source mesh's vertex it copies (the exporter splits
    /// vertices where mirrored UVs flip the tangent).
    pub skin_origin: Vec<u32>,
}

fn srgb_encoded(m: &[Map; 3]) -> [Map; 3] {
    m.clone().map(|mut c| {
        c.data_mut()
            .iter_mut()
            .for_each(|v| *v = derma_core::color::srgb_encode(*v));
        c
    })
}

/// The subsurface summary the volume and transmission extensions carry: mean linear sss
/// colour and mean mean-free path per channel (mm) over the texture.
fn subsurface_means(s: &SkinMaps) -> Option<([f32; 3], [f32; 3])> {
    let (c, r) = s.subsurface.as_ref()?;
    let mean = |m: &Map| m.data().iter().sum::<f32>() / m.data().len() as f32;
    Some((
        [mean(&c[0]), mean(&c[1]), mean(&c[2])],
        [mean(&r[0]), mean(&r[1]), mean(&r[2])],
    ))
}

/// KHR_materials_volume's attenuation from mean free paths ℓ_c (mm): Beer–Lambert with
/// extinction 1/ℓ_c, the colour left after the longest path (glTF: attenuationColor is the
/// transmittance at attenuationDistance, in metres).
pub fn attenuation(mfp_mm: [f32; 3]) -> ([f32; 3], f32) {
    let d = mfp_mm.iter().cloned().fold(0.0f32, f32::max).max(1e-3);
    (
        mfp_mm.map(|l| (-d / l.max(1e-4)).exp()),
        d * derma_head::export::M_PER_MM,
    )
}

fn tangent_accessor(g: &mut Glb, t: &[[f32; 4]]) -> usize {
    let bytes: Vec<u8> = t.iter().flatten().flat_map(|v| v.to_le_bytes()).collect();
    let view = g.view(&bytes, Some(34962));
    g.accessor(json!({"bufferView": view, "componentType": 5126, "count": t.len(), "type": "VEC4"}))
}

/// Loads a user mesh in derma's frame through derma-core's one head-mesh loader, with `derma
/// skin`'s rules: the unit that makes it head-sized, else a fit to a nominal head; the skin
/// among its parts. `progress` is told how it was read.
pub fn load_mesh_mm(path: &Path, progress: &dyn derma_core::progress::Progress) -> Result<TriMesh> {
    use derma_core::head_mesh::HeadUnit;
    load_mesh_in(path, HeadUnit::Auto, &Default::default(), progress)
}

/// As [`load_mesh_mm`], the mesh read in `unit`, its part `part`.
pub fn load_mesh_in(
    path: &Path,
    unit: derma_core::head_mesh::HeadUnit,
    part: &derma_core::mesh_parts::PartChoice,
    progress: &dyn derma_core::progress::Progress,
) -> Result<TriMesh> {
    let how = derma_core::head_mesh::HeadRead {
        unit,
        part: part.clone(),
        fitted: None,
    };
    Ok(derma_core::head_mesh::load_head_mesh(path, &how, progress)?.0)
}

/// Writes the GLB (and the loose maps when asked); `progress` hears how a user mesh was read.
pub fn export(o: &GlbOptions, progress: &dyn derma_core::progress::Progress) -> Result<GlbReport> {
    let skin = SkinMaps::from_dir(&o.textures)?;
    let head = derma_head::fitted::or_builtin(o.head.as_deref())?;
    let mut s = Scene::default();
    let ext_used = add_skin_material(o, &skin, &mut s)?;
    if o.wrinkles {
        add_wrinkle_extras(o, &mut s)?;
    }
    let skin_mesh = read_skin_mesh(o, head, progress)?;
    let corner = mikktspace_tangents(&skin_mesh);
    let (split, tangents, origin) = split_by_tangent(&skin_mesh, &corner);
    // Morph targets follow the split vertices: the head's, or on a user mesh with a fitted
    // head, carried over through the fit's correspondence.
    let carried;
    let units = match (&o.mesh, &o.head) {
        (None, _) => head.face_units(),
        (Some(p), Some(_)) => {
            carried = carried_units(head, &skin_mesh, p)?;
            &carried[..]
        }
        (Some(_), None) => &[],
    };
    let skin_part = SplitSkin {
        mesh: &split,
        tangents: &tangents,
        origin: &origin,
        source_vertices: skin_mesh.positions.len(),
    };
    add_skin_mesh(&mut s, &skin_part, units);
    refuse_teeth_on_user_mesh(o)?;
    if o.mesh.is_none() {
        let textures = add_part_textures(o, &mut s)?;
        add_parts(&mut s, head, units, &textures);
        add_brows(&mut s, &skin, head, units, o.hair_mask)?;
    }
    let (bytes, names) = s.finish(&ext_used);
    derma_core::atomic::write_bytes(&o.out, &bytes)?;
    let mut maps = Vec::new();
    if let Some((dir, naming, conv)) = &o.maps {
        maps = write_maps(&o.textures, &skin, dir, *naming, *conv)?;
    }
    Ok(GlbReport {
        path: o.out.clone(),
        bytes: bytes.len(),
        meshes: names,
        morph_targets: units.len(),
        extensions: ext_used,
        maps,
        skin_origin: origin,
    })
}

/// The GLB as it is built: its buffer and the glTF arrays that point into it, with the meshes'
/// names for the report.
#[derive(Default)]
struct Scene {
    g: Glb,
    images: Vec<Value>,
    materials: Vec<Value>,
    meshes: Vec<Value>,
    names: Vec<String>,
}

impl Scene {
    /// Adds `png` as image `name` (texture `i` samples image `i`); returns its index.
    fn image(&mut self, name: &str, png: &[u8]) -> usize {
        let v = self.g.view(png, None);
        self.images
            .push(json!({"bufferView": v, "mimeType": "image/png", "name": name}));
        self.images.len() - 1
    }

    /// The GLB's bytes (a node per mesh, one scene) and the meshes' names.
    fn finish(self, ext_used: &[String]) -> (Vec<u8>, Vec<String>) {
        let Scene {
            mut g,
            images,
            materials,
            meshes,
            names,
        } = self;
        // The skin's node names the rig library's expressions by the face units they pose, for
        // tools that drive morph targets from expressions (Blender's importer makes node extras
        // custom properties; blender/derma_skin builds drivers from them).
        let expressions = expression_units();
        let nodes: Vec<Value> = meshes
            .iter()
            .enumerate()
            .map(|(i, m)| {
                let mut n = json!({"name": m["name"], "mesh": i});
                if m["name"] == "skin" && m["extras"]["targetNames"].is_array() {
                    n["extras"] = json!({"derma_expressions": expressions});
                }
                n
            })
            .collect();
        let n_images = images.len();
        let mut doc = json!({
            "asset": {"version": "2.0", "generator": "derma export glb",
                "copyright": "MakeHuman base mesh and Face Units by the MakeHuman community and Mika Suominen, CC0 1.0; textures: derma"},
            "extensionsUsed": ext_used,
            "scene": 0,
            "scenes": [{"name": "derma", "nodes": (0..nodes.len()).collect::<Vec<_>>()}],
            "nodes": nodes,
            "meshes": meshes,
            "materials": materials,
            "images": images,
            "samplers": [{"magFilter": 9729, "minFilter": 9987, "wrapS": 33071, "wrapT": 33071}],
            "textures": (0..n_images).map(|i| json!({"source": i, "sampler": 0})).collect::<Vec<_>>(),
        });
        doc["buffers"] = json!([{"byteLength": 0}]);
        doc["bufferViews"] = json!(g.views);
        doc["accessors"] = json!(g.accessors);
        while !g.bin.len().is_multiple_of(4) {
            g.bin.push(0);
        }
        doc["buffers"] = json!([{"byteLength": g.bin.len()}]);
        (g.finish(&doc), names)
    }
}

/// The bytes of file `f` of the texture set in `dir`.
fn read_set_file(dir: &Path, f: &str) -> Result<Vec<u8>> {
    let p = dir.join(f);
    std::fs::read(&p).map_err(|e| {
        ExportError::from(derma_core::CoreError::Format {
            path: p,
            message: format!("cannot read ({e})"),
        })
    })
}

/// The skin's textures and its material (material 0); returns the extensions it uses.
fn add_skin_material(o: &GlbOptions, skin: &SkinMaps, s: &mut Scene) -> Result<Vec<String>> {
    // Textures: base colour and normal as written by `derma skin`; roughness (G), metal (B = 0)
    // and the specular level (A, KHR_materials_specular reads alpha) packed in one.
    let (w, h) = skin.size();
    let ones = Map::filled(w, h, 1.0);
    let zeros = Map::filled(w, h, 0.0);
    let orm = png8_bytes(
        "orm_specular",
        &[&ones, &skin.roughness, &zeros, &skin.specular],
    )?;
    let t_base = s.image(
        "base_color",
        &read_set_file(&o.textures, derma_skin::outputs::BASE_COLOR)?,
    );
    let t_norm = s.image(
        "normal",
        &read_set_file(&o.textures, derma_skin::outputs::NORMAL)?,
    );
    let t_orm = s.image("orm_specular", &orm);
    let (exts, ext_used) = skin_extensions(skin, o.volume, t_orm);
    s.materials.push(json!({
        "name": "skin",
        "pbrMetallicRoughness": {
            "baseColorTexture": {"index": t_base},
            "metallicFactor": 0.0,
            "roughnessFactor": 1.0,
            "metallicRoughnessTexture": {"index": t_orm}
        },
        "normalTexture": {"index": t_norm},
        "extensions": exts
    }));
    Ok(ext_used)
}

/// The skin material's extensions (specular from texture `t_orm`; diffuse transmission and, when
/// `volume`, a volume from the set's subsurface maps) and their names.
fn skin_extensions(skin: &SkinMaps, volume: bool, t_orm: usize) -> (Value, Vec<String>) {
    let mut ext_used = vec!["KHR_materials_specular".to_string()];
    // F0 = 0.04 (ior 1.5) × specularColorFactor × specular: 2 × s gives F0 = 0.08 s, the
    // specular map's meaning (F0 / 0.08).
    let mut exts = json!({
        "KHR_materials_specular": {
            "specularFactor": 1.0,
            "specularTexture": {"index": t_orm},
            "specularColorFactor": [2.0, 2.0, 2.0]
        }
    });
    if let Some((color, mfp)) = subsurface_means(skin) {
        let (att, dist) = attenuation(mfp);
        // Diffuse transmission: light scattered inside that leaves through the back of thin
        // parts (ears, nostrils); a quarter of the subsurface light, tinted by Burley's albedo.
        exts["KHR_materials_diffuse_transmission"] = json!({
            "diffuseTransmissionFactor": 0.25,
            "diffuseTransmissionColorFactor": color
        });
        ext_used.push("KHR_materials_diffuse_transmission".into());
        if volume {
            exts["KHR_materials_volume"] = json!({
                "thicknessFactor": 0.01,
                "attenuationDistance": dist,
                "attenuationColor": att
            });
            ext_used.push("KHR_materials_volume".into());
        }
    }
    (exts, ext_used)
}

/// The set's expression-wrinkle maps (where it has them) as textures, named in the skin
/// material's `extras.derma_wrinkles` with the weight table.
fn add_wrinkle_extras(o: &GlbOptions, s: &mut Scene) -> Result<()> {
    let Some(wm) = derma_render::wrinkles::WrinkleMaps::from_dir(&o.textures)? else {
        return Ok(());
    };
    let t_wn = s.image(
        "wrinkle_normal",
        &read_set_file(&o.textures, derma_skin::outputs::WRINKLE_NORMAL)?,
    );
    let mut masks = Vec::new();
    for (k, ([r, gr, b], names)) in wrinkle_mask_images(&wm).iter().enumerate() {
        let name = format!("wrinkle_masks_{k}");
        let t = s.image(&name, &png8_bytes(&name, &[r, gr, b])?);
        masks.push(json!({"index": t, "channels": names}));
    }
    s.materials[0]["extras"] = json!({"derma_wrinkles": {
        "normalTexture": {"index": t_wn, "encoding": "n·½+½ as normalTexture, every furrow at full activation"},
        "maskTextures": masks,
        "regions": wrinkle_regions_json(),
        "formula": derma_head::wrinkle_regions::FORMULA,
        "units": "the mesh's morph target weights by name (the 52 face units)"
    }});
    Ok(())
}

/// The skin mesh: the user's (through a fitted head, read in the frame the fit found, as
/// render, eyes and rig do), or the head's own.
fn read_skin_mesh(
    o: &GlbOptions,
    head: &derma_head::Head,
    progress: &dyn derma_core::progress::Progress,
) -> Result<TriMesh> {
    Ok(match (&o.mesh, o.head.as_deref()) {
        (Some(p), Some(dir)) => derma_head::fitted::load_scan(dir, p, o.unit, &o.part, progress)?,
        (Some(p), None) => load_mesh_in(p, o.unit, &o.part, progress)?,
        (None, _) => head.skin.clone(),
    })
}

/// The skin mesh split where mirrored UVs flip the tangent.
struct SplitSkin<'a> {
    /// The split mesh.
    mesh: &'a TriMesh,
    /// Its tangents (xyz, handedness).
    tangents: &'a [[f32; 4]],
    /// Per split vertex, the source mesh's vertex it copies.
    origin: &'a [u32],
    /// Vertices of the source mesh.
    source_vertices: usize,
}

/// The skin's mesh (material 0) with its tangents and `units` as morph targets, moved onto the
/// split vertices.
fn add_skin_mesh(s: &mut Scene, skin: &SplitSkin, units: &[derma_head::MorphTarget]) {
    let mut copies: Vec<Vec<u32>> = vec![Vec::new(); skin.source_vertices];
    for (i, &v) in skin.origin.iter().enumerate() {
        copies[v as usize].push(i as u32);
    }
    let remapped: Vec<(String, Vec<(u32, Vec3)>)> = units
        .iter()
        .map(|u| {
            let mut offs: Vec<(u32, Vec3)> = u
                .skin
                .iter()
                .flat_map(|(v, d)| copies[*v as usize].iter().map(move |&i| (i, *d)))
                .collect();
            offs.sort_by_key(|o| o.0);
            (u.name.clone(), offs)
        })
        .collect();
    let targets: Vec<(&str, &[(u32, Vec3)])> = remapped
        .iter()
        .map(|(n, o)| (n.as_str(), o.as_slice()))
        .collect();
    let mut m = s.g.mesh("skin", skin.mesh, &targets);
    let ta = tangent_accessor(&mut s.g, skin.tangents);
    m["primitives"][0]["attributes"]["TANGENT"] = json!(ta);
    m["primitives"][0]["material"] = json!(0);
    s.meshes.push(m);
    s.names.push("skin".to_string());
}

/// Refuses a teeth texture with a user mesh (it has no teeth to carry it).
fn refuse_teeth_on_user_mesh(o: &GlbOptions) -> Result<()> {
    if o.mesh.is_some() && o.teeth.is_some() {
        return Err(derma_core::Invalid::new(
            format!(
                "teeth texture '{}'",
                o.teeth
                    .as_ref()
                    .map(|p| p.display().to_string())
                    .unwrap_or_default()
            ),
            "the head's teeth to go on",
            "a user mesh, which has none",
        )
        .into());
    }
    Ok(())
}

/// Image indices of the parts' textures.
struct PartTextures {
    /// The teeth's, when given, and whether it has alpha (voids).
    teeth: Option<(usize, bool)>,
    /// The eye globes'.
    eye: usize,
    /// The lash cards'.
    lashes: usize,
    /// The hair cards alpha-tested, not blended ([`GlbOptions::hair_mask`]).
    hair_mask: bool,
}

/// The parts' textures: the teeth (when given), the eye (given or built in) and the lash cards.
fn add_part_textures(o: &GlbOptions, s: &mut Scene) -> Result<PartTextures> {
    // The teeth's colour, and its alpha where the texture has one (the voids between teeth).
    let teeth = match &o.teeth {
        Some(p) => {
            let t = derma_render::material::read_albedo(p)?;
            let rgb = srgb_encoded(&t.rgb);
            let mut maps = vec![&rgb[0], &rgb[1], &rgb[2]];
            maps.extend(t.alpha.as_ref());
            let image = s.image("teeth", &png8_bytes("teeth", &maps)?);
            Some((image, t.alpha.is_some()))
        }
        None => None,
    };
    let eye = srgb_encoded(&match &o.iris {
        Some(p) => derma_eyes::files::load_eye_texture(p)?,
        None => default_eye_texture(512),
    });
    let eye = s.image("eye", &png8_bytes("eye", &[&eye[0], &eye[1], &eye[2]])?);
    // The set's lash cards (the hair's colour, lashes as alpha), or near-black lashes.
    let lashes_png = o.textures.join(derma_render::material::files::LASHES);
    let lash_bytes = if lashes_png.is_file() {
        std::fs::read(&lashes_png).map_err(|e| derma_core::CoreError::Read {
            path: lashes_png.clone(),
            source: e,
        })?
    } else {
        let lash = derma_head::lashes::coverage_map(512);
        let black = Map::filled(512, 512, 0.02f32.powf(1.0 / 2.2));
        png8_bytes("eyelashes", &[&black, &black, &black, &lash])?
    };
    let lashes = s.image("eyelashes", &lash_bytes);
    Ok(PartTextures {
        teeth,
        eye,
        lashes,
        hair_mask: o.hair_mask,
    })
}

/// The head's parts as meshes, each with its own material and moved by `units`.
fn add_parts(
    s: &mut Scene,
    head: &derma_head::Head,
    units: &[derma_head::MorphTarget],
    textures: &PartTextures,
) {
    for (k, part) in head.parts.iter().enumerate() {
        s.materials.push(part_material(part, textures));
        let mut t = derma_head::export::part_targets(units, k);
        // The globes dilate and constrict their pupils by morph (docs/eyes.md).
        let pupil: Vec<(&str, Vec<(u32, glam::Vec3)>)> = match part.name.as_str() {
            "eye_left" | "eye_right" => {
                let c = head.eyes[usize::from(part.name == "eye_right")].centre;
                derma_head::eye::PUPIL_MORPHS_MM
                    .iter()
                    .map(|(n, d)| (*n, derma_head::eye::pupil_offsets(&part.mesh, c, *d)))
                    .collect()
            }
            _ => Vec::new(),
        };
        t.extend(pupil.iter().map(|(n, o)| (*n, o.as_slice())));
        let mut pm = s.g.mesh(&part.name, &part.mesh, &t);
        pm["primitives"][0]["material"] = json!(s.materials.len() - 1);
        s.meshes.push(pm);
        s.names.push(part.name.clone());
    }
}

/// A part's material: the eye texture on the globes, blended (or alpha-tested) lash cards, the teeth
/// texture where given, else the part's flat colour.
fn part_material(part: &derma_head::Part, textures: &PartTextures) -> Value {
    let prop = derma_head::Look::of(&part.name);
    if part.name.starts_with("eye_") {
        json!({"name": part.name, "pbrMetallicRoughness": {"baseColorTexture": {"index": textures.eye},
            "metallicFactor": 0.0, "roughnessFactor": prop.roughness}})
    } else if prop.coverage.is_some() {
        let mut m = json!({"name": part.name, "doubleSided": true,
            "pbrMetallicRoughness": {"baseColorTexture": {"index": textures.lashes},
            "metallicFactor": 0.0, "roughnessFactor": prop.roughness}});
        hair_alpha(&mut m, textures.hair_mask);
        m
    } else if let (Some((t, voids)), true) = (textures.teeth, part.name.starts_with("teeth")) {
        let mut m = json!({"name": part.name, "pbrMetallicRoughness": {"baseColorTexture": {"index": t},
            "metallicFactor": 0.0, "roughnessFactor": prop.roughness}});
        if voids {
            // The voids between teeth cut out, as the renderers test them.
            m["alphaMode"] = json!("MASK");
            m["alphaCutoff"] = json!(0.5);
        }
        m
    } else {
        let a = (prop.albedo)(glam::Vec2::splat(0.5));
        json!({"name": part.name, "pbrMetallicRoughness": {"baseColorFactor": [a.x, a.y, a.z, 1.0],
            "metallicFactor": 0.0, "roughnessFactor": prop.roughness}})
    }
}

/// The brows as a card over the skin (blended, or alpha-tested with `hair_mask`), moved by
/// `units`, where the set carries their hair.
fn add_brows(
    s: &mut Scene,
    skin: &SkinMaps,
    head: &derma_head::Head,
    units: &[derma_head::MorphTarget],
    hair_mask: bool,
) -> Result<()> {
    // (The set as `export` read it: its hair coverage and the hair's colour from lashes.png.)
    let (Some(coverage), Some(hair)) = (&skin.hair, skin.lash_color) else {
        return Ok(());
    };
    let (w, h) = (coverage.width(), coverage.height());
    let rgb = hair.map(|c| Map::filled(w, h, derma_core::color::srgb_encode(c)));
    let t_brows = s.image(
        "eyebrows",
        &png8_bytes("eyebrows", &[&rgb[0], &rgb[1], &rgb[2], coverage])?,
    );
    let look = derma_head::Look::of("eyebrows");
    let mut m = json!({"name": "eyebrows",
        "pbrMetallicRoughness": {"baseColorTexture": {"index": t_brows},
        "metallicFactor": 0.0, "roughnessFactor": look.roughness}});
    hair_alpha(&mut m, hair_mask);
    s.materials.push(m);
    let cards = derma_head::brows::BrowCards::of(head, &head.skin);
    let offsets = brow_offsets(&cards, units);
    let targets: Vec<(&str, &[(u32, glam::Vec3)])> = units
        .iter()
        .zip(&offsets)
        .map(|(u, o)| (u.name.as_str(), o.as_slice()))
        .collect();
    let mut bm = s.g.mesh("eyebrows", &cards.mesh, &targets);
    bm["primitives"][0]["material"] = json!(s.materials.len() - 1);
    s.meshes.push(bm);
    s.names.push("eyebrows".to_string());
    Ok(())
}

/// The skin's face units carried to the brow cards' vertices (one weight array drives both),
/// per unit in increasing card-vertex order.
fn brow_offsets(
    cards: &derma_head::brows::BrowCards,
    units: &[derma_head::MorphTarget],
) -> Vec<Vec<(u32, glam::Vec3)>> {
    let mut card_of = std::collections::HashMap::new();
    for (c, &v) in cards.source.iter().enumerate() {
        card_of.insert(v, c as u32);
    }
    units
        .iter()
        .map(|u| {
            let mut o: Vec<(u32, glam::Vec3)> = u
                .skin
                .iter()
                .filter_map(|(v, d)| card_of.get(v).map(|&c| (c, *d)))
                .collect();
            o.sort_unstable_by_key(|&(c, _)| c); // glTF's sparse indices increase
            o
        })
        .collect()
}

/// Writes the loose maps under `naming` (normal in `conv`; the packed ORM as engines import it).
pub fn write_maps(
    src: &Path,
    skin: &SkinMaps,
    dir: &Path,
    naming: MapNames,
    conv: NormalConvention,
) -> Result<Vec<PathBuf>> {
    derma_core::atomic::ensure_writable_dir(dir)?;
    let mut out = Vec::new();
    let copy = |key: &str, file: &str, out: &mut Vec<PathBuf>| -> Result<()> {
        let from = src.join(file);
        if from.is_file() {
            let bytes = std::fs::read(&from).map_err(|e| {
                ExportError::from(derma_core::CoreError::Format {
                    path: from.clone(),
                    message: e.to_string(),
                })
            })?;
            let to = dir.join(naming.file(key));
            derma_core::atomic::write_bytes(&to, &bytes)?;
            out.push(to);
        }
        Ok(())
    };
    copy("base_color", derma_skin::outputs::BASE_COLOR, &mut out)?;
    copy("roughness", derma_skin::outputs::ROUGHNESS, &mut out)?;
    copy("specular", derma_skin::outputs::SPECULAR, &mut out)?;
    copy("height", derma_skin::outputs::HEIGHT_PNG, &mut out)?;
    copy("sss_color", derma_skin::outputs::SSS_COLOR, &mut out)?;
    copy("sss_radius", derma_skin::outputs::SSS_RADIUS, &mut out)?;
    let to = dir.join(naming.file("normal"));
    match conv {
        NormalConvention::OpenGl => copy("normal", derma_skin::outputs::NORMAL, &mut out)?,
        NormalConvention::DirectX => {
            let mut g = skin.normal[1].clone();
            g.data_mut().iter_mut().for_each(|v| *v = 1.0 - *v);
            derma_core::image_io::write_png16(&to, &[&skin.normal[0], &g, &skin.normal[2]])?;
            out.push(to);
        }
    }
    let (w, h) = skin.size();
    let ones = Map::filled(w, h, 1.0);
    let zeros = Map::filled(w, h, 0.0);
    let orm = dir.join(naming.file("orm"));
    derma_core::image_io::write_png8(&orm, &[&ones, &skin.roughness, &zeros])?;
    out.push(orm);
    Ok(out)
}

/// A fitted head's face units carried onto the user mesh at `path` (read as `mesh`), refused
/// when most of it lies off the fitted skin.
pub fn carried_units(
    head: &derma_head::Head,
    mesh: &derma_core::mesh::TriMesh,
    path: &std::path::Path,
) -> Result<Vec<derma_head::MorphTarget>> {
    let (units, share) = derma_head::fit::onto::face_units(head, mesh);
    check_share(share, path)?;
    Ok(units)
}

/// Refuses a user mesh at `path` of which only `share` lies near the fitted head.
pub fn check_share(share: f32, path: &std::path::Path) -> Result<()> {
    if share < derma_head::fit::onto::MIN_SHARE {
        return Err(ExportError::from(derma_core::CoreError::Format {
            path: path.to_path_buf(),
            message: format!(
                "only {:.0} % of its vertices lie within {} mm of the fitted head; is it the mesh the head was fitted to, read in the same unit?",
                100.0 * share,
                derma_head::fit::onto::REACH_MM
            ),
        }));
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn attenuation_is_beer_lambert_over_the_longest_mean_free_path() {
        let (c, d) = attenuation([4.0, 2.0, 1.0]);
        assert!((d - 0.004).abs() < 1e-9);
        assert!((c[0] - (-1.0f32).exp()).abs() < 1e-6);
        assert!((c[1] - (-2.0f32).exp()).abs() < 1e-6);
        assert!((c[2] - (-4.0f32).exp()).abs() < 1e-6);
    }

    #[test]
    fn map_names_follow_each_convention() {
        assert_eq!(MapNames::Derma.file("base_color"), "base_color.png");
        assert_eq!(MapNames::Substance.file("normal"), "head_Normal.png");
        assert_eq!(MapNames::Unreal.file("orm"), "T_Head_ORM.png");
    }
}

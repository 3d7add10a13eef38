//! The animated head for engines and DCC tools: a glTF 2.0 binary with the built-in head, the
//! eye-region motion as morph targets (the mean displacement plus principal components of the
//! baked frames, as the thesis reduces skin motion to a few components) whose weights are
//! animated, eyelashes riding on their lid margins, and the globes (sclera, transparent cornea,
//! textured iris) as nodes whose rotation is animated.

use crate::globe::Globe;
use crate::pca::Pca;
use derma_head::export::{Glb, M_PER_MM};
use derma_head::Head;
use glam::{Quat, Vec2, Vec3};
use serde_json::{json, Value};
use std::path::Path;

/// Motion components kept as morph targets (besides the mean).
pub const COMPONENTS: usize = 12;

/// A baked animation: frame times, region-vertex positions per frame (evaluated when asked: a
/// long clip's frames are never all held) and globe rotations.
pub struct Baked<'a> {
    /// Frame times (s).
    pub times: Vec<f32>,
    /// Model-vertex positions (mm) of frame i.
    pub positions: &'a (dyn Fn(usize) -> Vec<Vec3> + Sync),
    /// Globe rotations per frame.
    pub rotations: Vec<[Quat; 2]>,
}

/// What the export measured.
#[derive(Clone, Debug, serde::Serialize)]
pub struct Report {
    /// Morph targets written (mean + components).
    pub targets: usize,
    /// RMS (mm) of the morph-target reconstruction over all frames and region vertices.
    pub rms_mm: f32,
    /// Largest reconstruction error (mm).
    pub max_mm: f32,
    /// File size (bytes).
    pub bytes: usize,
}

/// The eye globes' texture as PNG bytes: `texture` (linear RGB on the globe's UVs) or the
/// default iris, sampled at texel centres and sRGB-encoded.
fn eye_texture_png(size: usize, texture: Option<&[derma_core::Map; 3]>) -> crate::Result<Vec<u8>> {
    let srgb = derma_core::Map::planes(size, size, |i| {
        // glTF's texture origin is the top-left: v = 1 − row.
        let uv = Vec2::new(
            ((i % size) as f32 + 0.5) / size as f32,
            1.0 - ((i / size) as f32 + 0.5) / size as f32,
        );
        let c = match texture {
            Some(t) => Vec3::from(t.each_ref().map(|m| m.sample_uv(uv.x, uv.y, false))),
            None => derma_head::eye::default_albedo(uv),
        };
        c.to_array()
            .map(|v| derma_core::color::srgb_encode(v.clamp(0.0, 1.0)))
    });
    Ok(derma_core::image_io::png8_bytes(
        "the eye texture",
        &[&srgb[0], &srgb[1], &srgb[2]],
    )?)
}

/// The lash cards' texture as PNG bytes: the lashes' colour ([`derma_head::Look`]) in RGB and
/// their coverage ([`derma_head::lashes::coverage`]) in alpha, for alpha testing.
fn lash_texture_png(size: usize) -> crate::Result<Vec<u8>> {
    let look = derma_head::Look::of("eyelashes");
    let rgb = (look.albedo)(Vec2::splat(0.5))
        .to_array()
        .map(|v| derma_core::Map::filled(size, size, derma_core::color::srgb_encode(v)));
    let alpha = derma_head::lashes::coverage_map(size);
    Ok(derma_core::image_io::png8_bytes(
        "the lash texture",
        &[&rgb[0], &rgb[1], &rgb[2], &alpha],
    )?)
}

/// Writes `path`: the head with `baked` motion on the eye region (`region` maps skin vertices to
/// model vertices) carried onto `skin` (the head's own or a user's mesh), the globes textured with `eye` (linear RGB on the head's eye UVs) or the
/// default eye.
pub fn write(
    head: &Head,
    region: &crate::region::EyeRegion,
    skin: &crate::surface::Skin,
    baked: &Baked,
    eye: Option<&[derma_core::Map; 3]>,
    path: &Path,
) -> crate::Result<Report> {
    check_frames(baked)?;
    let motion = reduce_motion(region, baked)?;
    let names: Vec<String> = std::iter::once("eyeRegionMean".to_string())
        .chain((1..motion.targets.len()).map(|c| format!("eyeRegionPC{c}")))
        .collect();
    let mut s = Scene::default();
    let morph_nodes = add_skin_and_parts(&mut s, head, region, skin, &names, &motion.targets);
    let eye_nodes = add_globes(&mut s, head);
    // Animation: weights of the morph nodes, rotations of the eye nodes.
    let nodes = AnimatedNodes {
        morph: &morph_nodes,
        eyes: &eye_nodes,
        targets: names.len(),
    };
    let animation = animation(&mut s.g, baked, &motion.weights, &nodes);
    let out = s.finish(animation, eye)?;
    derma_core::atomic::write_bytes(path, &out)?;
    Ok(Report {
        targets: names.len(),
        rms_mm: motion.rms_mm,
        max_mm: motion.max_mm as f32,
        bytes: out.len(),
    })
}

/// Refuses a clip without frames or without a rotation pair per frame.
fn check_frames(baked: &Baked) -> crate::Result<()> {
    let nf = baked.times.len();
    if nf == 0 || baked.rotations.len() != nf {
        return Err(derma_core::Invalid::new(
            "the animation's frames",
            "at least one, with one rotation pair each",
            format!("{nf} times and {} rotations", baked.rotations.len()),
        )
        .into());
    }
    Ok(())
}

/// The clip's motion as morph targets: per frame the weights (in [0, 1]) of the targets (model-
/// vertex vectors, the mean first), and how well they reconstruct every frame.
struct Motion {
    /// Per frame, the weights of the targets after the mean.
    weights: Vec<Vec<f64>>,
    /// The targets, flattened per model vertex (mm).
    targets: Vec<Vec<f64>>,
    /// RMS reconstruction error (mm).
    rms_mm: f32,
    /// Largest reconstruction error (mm).
    max_mm: f64,
}

/// Frame `i`'s displacements of the model vertices from rest (mm), flattened.
fn displacement_row(region: &crate::region::EyeRegion, baked: &Baked, i: usize) -> Vec<f64> {
    (baked.positions)(i)
        .iter()
        .zip(&region.rest)
        .flat_map(|(a, b)| (*a - *b).to_array())
        .map(f64::from)
        .collect()
}

/// The clip's displacements reduced to the mean and principal components, every frame
/// projected and its reconstruction error measured.
fn reduce_motion(region: &crate::region::EyeRegion, baked: &Baked) -> crate::Result<Motion> {
    use rayon::prelude::*;
    let nf = baked.times.len();
    let nm = region.len();
    // Displacements per frame, flattened (made when needed: a long clip's rows would not fit),
    // and their principal components fitted on at most FIT_FRAMES frames spread evenly over the
    // clip, so the fit costs the same for any length; every frame is then projected.
    let fit_rows: Vec<Vec<f64>> = fit_sample(nf)
        .into_par_iter()
        .map(|i| displacement_row(region, baked, i))
        .collect();
    let pca = if fit_rows.len() >= 2 {
        Pca::fit(&fit_rows, COMPONENTS)?
    } else {
        Pca {
            mean: fit_rows[0].clone(),
            components: Vec::new(),
            variances: Vec::new(),
            total_variance: 0.0,
        }
    };
    // A clip fitted on every frame projects the rows it already holds; a longer one makes
    // each row again.
    let held = (fit_rows.len() == nf).then_some(fit_rows);
    let per_frame = project_frames(&pca, held.as_deref(), region, baked);
    let (mut se, mut worst) = (0.0f64, 0.0f64);
    let mut weights: Vec<Vec<f64>> = Vec::with_capacity(nf);
    for (w, s, m) in per_frame {
        se += s;
        worst = worst.max(m);
        weights.push(w);
    }
    let rms = (se / (nf * nm) as f64).sqrt() as f32;
    // glTF's morph weights belong in [0, 1] (Blender's importer clamps them to ±10 and mishandles
    // larger ones): each component's weights w ∈ [lo, hi] over the clip become (w − lo)/(hi − lo)
    // on the target scaled by hi − lo, and lo × the component moves into the mean target
    // (weight 1). The same offsets at every frame, exactly.
    let (weights, targets) = unit_weights(&pca.mean, &pca.components, &weights);
    Ok(Motion {
        weights,
        targets,
        rms_mm: rms,
        max_mm: worst,
    })
}

/// Every frame's weights on `pca` with its squared reconstruction error and its largest one
/// (rows from `held` when it holds them all, else made again).
fn project_frames(
    pca: &Pca,
    held: Option<&[Vec<f64>]>,
    region: &crate::region::EyeRegion,
    baked: &Baked,
) -> Vec<(Vec<f64>, f64, f64)> {
    use rayon::prelude::*;
    // Every frame projected and its reconstruction error measured, in parallel; the sums are
    // taken in frame order (the same bits at any thread count).
    (0..baked.times.len())
        .into_par_iter()
        .map(|i| {
            let made;
            let r: &[f64] = match held {
                Some(rows) => &rows[i],
                None => {
                    made = displacement_row(region, baked, i);
                    &made
                }
            };
            let w = pca.project(r, pca.len());
            let back = pca.reconstruct(&w);
            let (mut se, mut worst) = (0.0f64, 0.0f64);
            for c in r.chunks_exact(3).zip(back.chunks_exact(3)) {
                let e = ((c.0[0] - c.1[0]).powi(2)
                    + (c.0[1] - c.1[1]).powi(2)
                    + (c.0[2] - c.1[2]).powi(2))
                .sqrt();
                se += e * e;
                worst = worst.max(e);
            }
            (w, se, worst)
        })
        .collect()
}

/// The vertex offsets of model-vertex `targets` on a lash card `mesh`: each vertex follows its
/// nearest lid-margin vertex.
fn lash_offsets(
    region: &crate::region::EyeRegion,
    targets: &[Vec<f64>],
    mesh: &derma_core::mesh::TriMesh,
) -> Vec<Vec<(u32, Vec3)>> {
    let margin: Vec<u32> = region.margins.iter().flatten().flatten().copied().collect();
    let near: Vec<usize> = mesh
        .positions
        .iter()
        .map(|p| {
            margin
                .iter()
                .map(|&m| m as usize)
                .min_by(|&a, &b| {
                    (region.rest[a] - *p)
                        .length_squared()
                        .total_cmp(&(region.rest[b] - *p).length_squared())
                })
                .expect("margins")
        })
        .collect();
    targets
        .iter()
        .map(|v| {
            near.iter()
                .enumerate()
                .map(|(i, &m)| {
                    (
                        i as u32,
                        Vec3::new(v[3 * m] as f32, v[3 * m + 1] as f32, v[3 * m + 2] as f32),
                    )
                })
                .collect()
        })
        .collect()
}

/// Morph targets by `names` from their per-vertex offsets.
fn as_targets<'a>(
    names: &'a [String],
    offs: &'a [Vec<(u32, Vec3)>],
) -> Vec<(&'a str, &'a [(u32, Vec3)])> {
    names
        .iter()
        .zip(offs)
        .map(|(n, o)| (n.as_str(), o.as_slice()))
        .collect()
}

/// The GLB as it is built: its buffer, meshes and nodes.
#[derive(Default)]
struct Scene {
    g: Glb,
    meshes: Vec<Value>,
    nodes: Vec<Value>,
}

impl Scene {
    /// Adds `m` as mesh `name` with morph `targets` and `material`, and a node for it; returns
    /// the node.
    fn add(
        &mut self,
        name: &str,
        m: &derma_core::mesh::TriMesh,
        targets: &[(&str, &[(u32, Vec3)])],
        material: usize,
    ) -> usize {
        let mut mesh = self.g.mesh(name, m, targets);
        mesh["primitives"][0]["material"] = json!(material);
        self.meshes.push(mesh);
        self.nodes
            .push(json!({"name": name, "mesh": self.meshes.len() - 1}));
        self.nodes.len() - 1
    }

    /// The GLB's bytes: the meshes, nodes and `animation`, with the eye texture (`eye` or the
    /// default) and the lash texture.
    fn finish(
        self,
        animation: (Vec<Value>, Vec<Value>),
        eye: Option<&[derma_core::Map; 3]>,
    ) -> crate::Result<Vec<u8>> {
        let Scene {
            mut g,
            meshes,
            nodes,
        } = self;
        let (samplers, channels) = animation;
        let png = eye_texture_png(512, eye)?;
        let iv = g.view(&png, None);
        let lv = g.view(&lash_texture_png(256)?, None);
        let roots: Vec<usize> = (0..nodes.len())
            .filter(|i| {
                !nodes.iter().any(|n| {
                    n["children"]
                        .as_array()
                        .is_some_and(|c| c.iter().any(|x| x.as_u64() == Some(*i as u64)))
                })
            })
            .collect();
        let doc = json!({
            "asset": {"version": "2.0", "generator": "derma eyes",
                "copyright": "MakeHuman base mesh and Face Units by the MakeHuman community and Mika Suominen, CC0 1.0"},
            "scene": 0,
            "scenes": [{"name": "derma eye region", "nodes": roots}],
            "nodes": nodes,
            "meshes": meshes,
            "materials": materials(),
            "images": [{"bufferView": iv, "mimeType": "image/png", "name": "eye"},
                       {"bufferView": lv, "mimeType": "image/png", "name": "eyelashes"}],
            "samplers": [{"magFilter": 9729, "minFilter": 9987, "wrapS": 33071, "wrapT": 33071}],
            "textures": [{"source": 0, "sampler": 0}, {"source": 1, "sampler": 0}],
            "animations": [{"name": "eyes", "samplers": samplers, "channels": channels}],
            "buffers": [{"byteLength": 0}],
            "bufferViews": [],
            "accessors": [],
        });
        let mut doc = doc;
        doc["bufferViews"] = json!(g.views);
        doc["accessors"] = json!(g.accessors);
        while !g.bin.len().is_multiple_of(4) {
            g.bin.push(0);
        }
        doc["buffers"] = json!([{"byteLength": g.bin.len()}]);
        Ok(g.finish(&doc))
    }
}

/// The materials: skin (0), eye (1), cornea (2), lashes (3) and mouth (4).
fn materials() -> Value {
    json!([
        {"name": "skin", "pbrMetallicRoughness": {"baseColorFactor": [0.56, 0.36, 0.28, 1.0], "metallicFactor": 0.0, "roughnessFactor": 0.55}},
        {"name": "eye", "pbrMetallicRoughness": {"baseColorTexture": {"index": 0}, "metallicFactor": 0.0, "roughnessFactor": 0.3}},
        {"name": "cornea", "alphaMode": "BLEND", "pbrMetallicRoughness": {"baseColorFactor": [1.0, 1.0, 1.0, 0.06], "metallicFactor": 0.0, "roughnessFactor": 0.02}},
        // The lash cards: blended by the head's lash coverage (texture 1), as the head's own GLB
        // blends them.
        {"name": "lashes", "alphaMode": "BLEND", "doubleSided": true,
         "pbrMetallicRoughness": {"baseColorTexture": {"index": 1}, "metallicFactor": 0.0, "roughnessFactor": 0.6}},
        {"name": "mouth", "pbrMetallicRoughness": {"baseColorFactor": [0.62, 0.56, 0.45, 1.0], "metallicFactor": 0.0, "roughnessFactor": 0.35}}
    ])
}

/// The skin (material 0) with the motion `targets` named `names`, and the head's parts but the
/// globes: lashes (3) riding on their lid margins, the rest (4) still; returns the morph nodes.
fn add_skin_and_parts(
    s: &mut Scene,
    head: &Head,
    region: &crate::region::EyeRegion,
    skin: &crate::surface::Skin,
    names: &[String],
    targets: &[Vec<f64>],
) -> Vec<usize> {
    // Per model vertex, a target vector → offsets of the skin's vertices (every UV copy of the
    // head's skin, or the user's mesh through the fit's B map).
    let to_skin = |v: &[f64]| -> Vec<(u32, Vec3)> {
        skin.offsets(region, |m| {
            Vec3::new(v[3 * m] as f32, v[3 * m + 1] as f32, v[3 * m + 2] as f32)
        })
    };
    let skin_offs: Vec<Vec<(u32, Vec3)>> = targets.iter().map(|v| to_skin(v)).collect();
    let mut morph_nodes = vec![s.add("skin", skin.mesh(), &as_targets(names, &skin_offs), 0)];
    for p in &head.parts {
        if p.name.starts_with("eye_") {
            continue;
        }
        if p.name.starts_with("eyelashes") {
            // Lashes follow their nearest lid-margin vertex.
            let offs = lash_offsets(region, targets, &p.mesh);
            morph_nodes.push(s.add(&p.name, &p.mesh, &as_targets(names, &offs), 3));
        } else {
            s.add(&p.name, &p.mesh, &[], 4);
        }
    }
    morph_nodes
}

/// The globes: per eye a node at its centre holding the sclera, iris and cornea; returns the
/// eye nodes.
fn add_globes(s: &mut Scene, head: &Head) -> Vec<usize> {
    let mut eye_nodes = Vec::new();
    for (e, side) in ["left", "right"].iter().enumerate() {
        let globe = Globe::of(&head.eyes[e]);
        let c = head.eyes[e].centre * M_PER_MM;
        let sclera = s.add(&format!("sclera_{side}"), &globe.shell(false), &[], 1);
        let iris = s.add(&format!("iris_{side}"), &globe.iris(), &[], 1);
        let cornea = s.add(
            &format!("cornea_{side}"),
            &globe.shell(true).cornea_cap(&globe),
            &[],
            2,
        );
        s.nodes.push(json!({"name": format!("eye_{side}"), "translation": c.to_array(), "children": [sclera, iris, cornea]}));
        eye_nodes.push(s.nodes.len() - 1);
    }
    eye_nodes
}

/// The nodes an animation drives.
struct AnimatedNodes<'a> {
    /// Nodes whose morph weights it animates.
    morph: &'a [usize],
    /// Eye nodes (left, right) whose rotation it animates.
    eyes: &'a [usize],
    /// Morph targets per morph node (the mean, at weight 1, and the components).
    targets: usize,
}

/// The animation's samplers and channels: the morph `weights` of the morph nodes and the
/// globes' rotations, over the frame times.
fn animation(
    g: &mut Glb,
    baked: &Baked,
    weights: &[Vec<f64>],
    nodes: &AnimatedNodes,
) -> (Vec<Value>, Vec<Value>) {
    let nf = baked.times.len();
    let tb: Vec<u8> = baked.times.iter().flat_map(|t| t.to_le_bytes()).collect();
    let tv = g.view(&tb, None);
    let t_min = baked.times.first().copied().unwrap_or(0.0);
    let t_max = baked.times.last().copied().unwrap_or(0.0);
    let time_acc = g.accessor(json!({"bufferView": tv, "componentType": 5126, "count": nf, "type": "SCALAR", "min": [t_min], "max": [t_max]}));
    let wb: Vec<u8> = weights
        .iter()
        .flat_map(|w| std::iter::once(1.0f32).chain(w.iter().map(|&x| x as f32)))
        .flat_map(f32::to_le_bytes)
        .collect();
    let wv = g.view(&wb, None);
    let w_acc = g.accessor(json!({"bufferView": wv, "componentType": 5126, "count": nf * nodes.targets, "type": "SCALAR"}));
    let mut samplers = vec![json!({"input": time_acc, "output": w_acc, "interpolation": "LINEAR"})];
    let mut channels: Vec<Value> = nodes
        .morph
        .iter()
        .map(|&n| json!({"sampler": 0, "target": {"node": n, "path": "weights"}}))
        .collect();
    for (e, &n) in nodes.eyes.iter().enumerate() {
        let qb: Vec<u8> = baked
            .rotations
            .iter()
            .flat_map(|r| r[e].to_array())
            .flat_map(f32::to_le_bytes)
            .collect();
        let qv = g.view(&qb, None);
        let q_acc = g.accessor(
            json!({"bufferView": qv, "componentType": 5126, "count": nf, "type": "VEC4"}),
        );
        samplers.push(json!({"input": time_acc, "output": q_acc, "interpolation": "LINEAR"}));
        channels.push(
            json!({"sampler": samplers.len() - 1, "target": {"node": n, "path": "rotation"}}),
        );
    }
    (samplers, channels)
}

/// The cornea cap of a shell mesh (triangles in front of the limbus).
trait CorneaCap {
    fn cornea_cap(self, g: &Globe) -> derma_core::mesh::TriMesh;
}

impl CorneaCap for derma_core::mesh::TriMesh {
    fn cornea_cap(mut self, g: &Globe) -> derma_core::mesh::TriMesh {
        let zl = g.radius * g.limbus_angle().cos() - 1e-4;
        self.triangles
            .retain(|t| t.iter().all(|&i| self.positions[i as usize].z >= zl));
        self
    }
}
/// Most frames the morph targets are fitted to, spread evenly over the clip, so the fit's cost no
/// longer grows with the clip (it was O(frames² · vertices)). A clip under 8.5 s at 30 fps is
/// fitted on every frame; a longer one samples every (frames / 256)-th, which can step over a
/// blink (about 0.16 s in derma: a 66 ms down phase and an up phase 1.435× as long, blink.rs).
/// Every frame is still projected, and the reconstruction error over all of them is the fit RMS
/// the command reports.
pub const FIT_FRAMES: usize = 256;

/// The frames of an `n`-frame clip the morph targets are fitted to: all of them up to
/// [`FIT_FRAMES`], else [`FIT_FRAMES`] evenly spaced from the first to the last.
pub fn fit_sample(n: usize) -> Vec<usize> {
    if n <= FIT_FRAMES {
        (0..n).collect()
    } else {
        (0..FIT_FRAMES)
            .map(|j| j * (n - 1) / (FIT_FRAMES - 1))
            .collect()
    }
}

/// Per-frame `weights` of `components` over a `mean` rewritten so every weight lies in [0, 1]:
/// returns the new weights and the targets (the mean first, weight 1 at every frame).
fn unit_weights(
    mean: &[f64],
    components: &[Vec<f64>],
    weights: &[Vec<f64>],
) -> (Vec<Vec<f64>>, Vec<Vec<f64>>) {
    let mut base = mean.to_vec();
    let mut targets = Vec::with_capacity(components.len() + 1);
    let mut ranges = Vec::with_capacity(components.len());
    for (c, comp) in components.iter().enumerate() {
        let (lo, hi) = weights
            .iter()
            .map(|w| w[c])
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), x| {
                (a.min(x), b.max(x))
            });
        let span = hi - lo;
        for (b, v) in base.iter_mut().zip(comp) {
            *b += lo * v;
        }
        targets.push(comp.iter().map(|v| v * span).collect::<Vec<f64>>());
        ranges.push((lo, span));
    }
    let unit = weights
        .iter()
        .map(|w| {
            w.iter()
                .zip(&ranges)
                .map(|(&x, &(lo, span))| {
                    if span > 0.0 {
                        ((x - lo) / span).clamp(0.0, 1.0)
                    } else {
                        0.0
                    }
                })
                .collect()
        })
        .collect();
    let mut all = vec![base];
    all.extend(targets);
    (unit, all)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_fit_sample_is_every_frame_or_an_even_spread_from_first_to_last() {
        assert_eq!(fit_sample(3), vec![0, 1, 2]);
        assert_eq!(fit_sample(FIT_FRAMES).len(), FIT_FRAMES);
        let s = fit_sample(3600);
        assert_eq!((s.len(), s[0], s[FIT_FRAMES - 1]), (FIT_FRAMES, 0, 3599));
        assert!(s.windows(2).all(|w| w[1] > w[0] && w[1] - w[0] <= 15));
    }

    #[test]
    fn unit_weights_keep_every_frame_and_stay_in_zero_one() {
        // Two components over three coordinates, weights from −29 to 12 (the range a saccade
        // reached before).
        let mean = vec![1.0, -2.0, 0.5];
        let comps = vec![vec![0.3, 0.1, -0.2], vec![-0.05, 0.4, 0.25]];
        let weights = vec![vec![-29.0, 3.0], vec![12.0, 3.0], vec![0.5, 3.0]];
        let (unit, targets) = unit_weights(&mean, &comps, &weights);
        for (w, u) in weights.iter().zip(&unit) {
            assert!(u.iter().all(|x| (0.0..=1.0).contains(x)), "{u:?}");
            for j in 0..3 {
                let before = mean[j] + w[0] * comps[0][j] + w[1] * comps[1][j];
                let after = targets[0][j] + u[0] * targets[1][j] + u[1] * targets[2][j];
                assert!((before - after).abs() < 1e-12, "{before} vs {after}");
            }
        }
        // A component constant over the clip folds into the mean with weight 0.
        assert!(unit.iter().all(|u| u[1] == 0.0));
    }
}

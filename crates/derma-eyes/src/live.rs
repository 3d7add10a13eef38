//! The bound eye-region model as data for a real-time evaluator (thesis §3.9, fig. 3.14 and
//! Algorithm 1): W, the per-vertex Ũ, the lids' contact weights, the depth and normal bases, the
//! rest offsets, the globes' radial maps and each vertex's sliding mode, packed as a JSON header
//! and little-endian arrays, so the web viewer (or an engine's vertex shader) evaluates
//! ẽ = W g̃, ũ⁺ = Ũ e, the contact, the depth and globe sliding per frame exactly as
//! [`crate::evaluate::Evaluator::frame`] does. Check poses with
//! the evaluator's own output travel with the data, so a port can test itself against it.

use crate::evaluate::{Frame, RADIAL_MAP_SIZE};
use crate::sliding::Mode;
use crate::still::{EyePose, StillModel, FIXATION_MM};
use serde_json::{json, Value};

/// Format tag of the header.
pub const FORMAT: &str = "derma-eye-model";
/// Version of the layout.
pub const VERSION: u32 = 2;

/// Little-endian arrays and their header entries (byte offset, count, components).
#[derive(Default)]
struct Blob {
    bin: Vec<u8>,
    arrays: serde_json::Map<String, Value>,
}

impl Blob {
    /// Appends `words` (4 bytes each, little-endian) as array `name` of `ty`.
    fn words(
        &mut self,
        name: &str,
        ty: &str,
        components: usize,
        words: impl Iterator<Item = [u8; 4]>,
    ) {
        let offset = self.bin.len();
        self.bin.extend(words.flatten());
        let count = (self.bin.len() - offset) / 4 / components;
        self.arrays.insert(
            name.into(),
            json!({"type": ty, "offset": offset, "count": count, "components": components}),
        );
    }

    fn f32s(&mut self, name: &str, components: usize, data: impl IntoIterator<Item = f32>) {
        self.words(
            name,
            "f32",
            components,
            data.into_iter().map(f32::to_le_bytes),
        );
    }

    fn u32s(&mut self, name: &str, components: usize, data: impl IntoIterator<Item = u32>) {
        self.words(
            name,
            "u32",
            components,
            data.into_iter().map(u32::to_le_bytes),
        );
    }
}

/// A check pose: input and the evaluator's model-vertex positions (mm) at `vertices`.
fn check(
    m: &StillModel,
    head: &derma_head::Head,
    pose: EyePose,
    units: &[(&str, f32)],
    vertices: &[u32],
) -> Value {
    let g = m.gaze(head, pose, units);
    let mut f = Frame::default();
    m.evaluator.frame(&g, &mut f);
    json!({
        "gaze": [pose.gaze.0, pose.gaze.1],
        "closure": pose.closure,
        "units": units.iter().map(|(n, w)| (n.to_string(), json!(w))).collect::<serde_json::Map<_, _>>(),
        "positions": vertices.iter().map(|&v| f.positions[v as usize].to_array()).collect::<Vec<_>>(),
    })
}

/// The model bound to `head` as (header, arrays). `skin_origin`: per vertex of the mesh the
/// evaluator writes to, the head skin vertex it copies (an exporter's order, which may split the
/// head's vertices); the arrays list the pairs (that vertex, model vertex) of the region. Lash
/// parts are listed with their model anchor per vertex.
pub fn pack(m: &StillModel, head: &derma_head::Head, skin_origin: &[u32]) -> (Value, Vec<u8>) {
    let ev = &m.evaluator;
    let opt = &ev.optimised;
    let n = opt.len();
    let mut b = Blob::default();
    add_model_arrays(&mut b, m);
    add_slide_arrays(&mut b, &ev.slider, n);
    let skin_vertices = skin_vertex_pairs(&m.rig.region.skin_to_model, skin_origin);
    b.u32s(
        "skin_vertices",
        2,
        skin_vertices.iter().flat_map(|&(a, b)| [a, b]),
    );
    let mut lashes = Vec::new();
    for l in &m.lashes {
        b.u32s(&format!("lash_{}", l.name), 1, l.near.iter().copied());
        lashes.push(json!({"name": l.name, "anchors": format!("lash_{}", l.name)}));
    }
    // Check vertices: the middle of each lid margin of each eye.
    let region = &m.rig.region;
    let probes: Vec<u32> = region
        .margins
        .iter()
        .flatten()
        .map(|c| c[c.len() / 2])
        .collect();
    let checks = check_poses(m, head, &probes);
    let header = json!({
        "format": FORMAT,
        "version": VERSION,
        "units_mm": true,
        "vertices": n,
        "k": opt.k,
        "inputs": "g̃ = (h, v, t, upper, lower) per eye (left, right; Fick degrees, normalised lid openings), then the units",
        "units": m.model.units,
        "region_units": crate::region::REGION_UNITS,
        "w": linear(&opt.w),
        "baseline": {
            "features": "[h, |h|, max(v, 0), min(v, 0)]",
            "rows": [linear(&m.model.baseline[0]), linear(&m.model.baseline[1])],
            "closure": "per eye c = max(closure, eyeBlink unit), w = eyeWide unit; (upper, lower) = b + w (1 − c)(1 − b), b = (rows · [features, 1]) × (1 − c)",
        },
        "fixation_mm": FIXATION_MM,
        "centres": [head.eyes[0].centre.to_array(), head.eyes[1].centre.to_array()],
        "depth": {"k": ev.depth.k,
            "layout": "per vertex z then n_x, n_y, n_z, each its value at e = 0 then k coefficient columns; position (ũ⁺, z) + offset, normal normalise(n + normal_offset)"},
        "contact": {"layout": "lift: per vertex the share of its upper margin's shortfall below the lower margin (linear along x in the modelling camera; none at the canthi) added to ũ⁺.y"},
        "radial": {"size": RADIAL_MAP_SIZE, "reach": ev.slider.reach,
            "layout": "per eye size² texels, octahedral coordinates of the globe-frame direction, texel centres at (i + ½)/size, bilinear"},
        "lashes": lashes,
        "margins": region.margins,
        "checks": {"vertices": probes, "poses": checks},
        "arrays": b.arrays,
    });
    (header, b.bin)
}

/// The pairs (vertex of the mesh written to, model vertex) of the region, from each vertex's
/// head skin vertex (`skin_origin`) and each skin vertex's model vertex (`to_model`).
fn skin_vertex_pairs(to_model: &[u32], skin_origin: &[u32]) -> Vec<(u32, u32)> {
    skin_origin
        .iter()
        .enumerate()
        .filter_map(|(i, &v)| {
            let mv = *to_model.get(v as usize)?;
            (mv != u32::MAX).then_some((i as u32, mv))
        })
        .collect()
}

/// The per-vertex arrays of the evaluator: the bases, the contact's lift, the rest offsets,
/// the rest positions and normals, and each vertex's eye.
fn add_model_arrays(b: &mut Blob, m: &StillModel) {
    let ev = &m.evaluator;
    let opt = &ev.optimised;
    b.f32s("basis", 2 * (opt.k + 1), opt.basis.iter().copied());
    b.f32s(
        "depth",
        4 * (ev.depth.k + 1),
        ev.depth.basis.iter().copied(),
    );
    b.f32s("lift", 1, ev.contact.lift.iter().map(|&(_, w)| w));
    b.f32s("offset", 3, ev.offset.iter().flat_map(|v| v.to_array()));
    b.f32s(
        "normal_offset",
        3,
        ev.normal_offset.iter().flat_map(|v| v.to_array()),
    );
    b.f32s(
        "rest",
        3,
        m.rig.region.rest.iter().flat_map(|v| v.to_array()),
    );
    b.f32s(
        "rest_normals",
        3,
        ev.rest_normals.iter().flat_map(|v| v.to_array()),
    );
    b.u32s("eye", 1, ev.slider.eye.iter().map(|&e| e as u32));
}

/// The globe sliding of each of the `n` vertices and the globes' radial maps.
fn add_slide_arrays(b: &mut Blob, slider: &crate::sliding::Slider, n: usize) {
    // Sliding per vertex: [kind (0 surface, 1 offset, -1 never reaches a globe), t, δ₀, τ̂₀].
    let mut near = vec![false; n];
    for &i in &slider.near {
        near[i as usize] = true;
    }
    b.f32s(
        "slide",
        6,
        slider
            .modes
            .iter()
            .zip(&near)
            .flat_map(|(mode, &reach)| match *mode {
                _ if !reach => [-1.0, 0.0, 0.0, 0.0, 0.0, 0.0],
                Mode::Surface { t } => [0.0, t, 0.0, 0.0, 0.0, 0.0],
                Mode::Offset { delta0, t, tau0 } => [1.0, t, delta0, tau0.x, tau0.y, tau0.z],
            }),
    );
    b.f32s(
        "radial",
        1,
        slider.maps.iter().flat_map(|r| r.radius.iter().copied()),
    );
}

/// A linear map's weights as rows of f32.
fn linear(l: &crate::regression::Linear) -> Value {
    json!(l
        .w
        .iter()
        .map(|r| r.iter().map(|&x| x as f32).collect::<Vec<_>>())
        .collect::<Vec<_>>())
}

/// The check poses (rest, downgaze, wide, squinting, closed) with the evaluator's positions of
/// the `probes`.
fn check_poses(m: &StillModel, head: &derma_head::Head, probes: &[u32]) -> Vec<Value> {
    [
        (EyePose::REST, vec![]),
        (
            EyePose {
                gaze: (0.0, -20.0),
                closure: 0.0,
            },
            vec![],
        ),
        (
            EyePose {
                gaze: (15.0, 10.0),
                closure: 0.0,
            },
            vec![("eyeWideLeft", 0.5), ("eyeWideRight", 0.3)],
        ),
        (
            EyePose {
                gaze: (-10.0, 0.0),
                closure: 0.6,
            },
            vec![("eyeSquintLeft", 0.8), ("eyeSquintRight", 0.8)],
        ),
        // Closed: the lids' contact acts.
        (
            EyePose {
                gaze: (0.0, 0.0),
                closure: 1.0,
            },
            vec![],
        ),
    ]
    .iter()
    .map(|(p, u)| check(m, head, *p, u, probes))
    .collect::<Vec<_>>()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_arrays_hold_every_vertex_and_the_checks_move_the_lids() {
        let head = derma_head::Head::builtin();
        let m = StillModel::new(head).unwrap();
        let origin: Vec<u32> = (0..head.skin.positions.len() as u32).collect();
        let (h, bin) = pack(&m, head, &origin);
        let n = h["vertices"].as_u64().unwrap() as usize;
        assert!(n > 100);
        let mut end = 0;
        let mut arrays: Vec<(&String, &Value)> = h["arrays"].as_object().unwrap().iter().collect();
        arrays.sort_by_key(|(_, a)| a["offset"].as_u64());
        for (name, a) in arrays {
            let (off, count, comps) = (
                a["offset"].as_u64().unwrap() as usize,
                a["count"].as_u64().unwrap() as usize,
                a["components"].as_u64().unwrap() as usize,
            );
            assert_eq!(off, end, "{name} follows the previous array");
            end = off + 4 * count * comps;
            if [
                "basis",
                "depth",
                "lift",
                "offset",
                "normal_offset",
                "rest",
                "eye",
                "slide",
            ]
            .contains(&name.as_str())
            {
                assert_eq!(count, n, "{name}");
            }
        }
        assert_eq!(end, bin.len());
        // Every model vertex on the skin is listed once.
        let on_skin = m
            .rig
            .region
            .skin_to_model
            .iter()
            .filter(|&&k| k != u32::MAX)
            .count();
        assert_eq!(
            h["arrays"]["skin_vertices"]["count"].as_u64().unwrap() as usize,
            on_skin
        );
        assert_eq!(
            h["arrays"]["depth"]["components"].as_u64().unwrap(),
            4 * (h["depth"]["k"].as_u64().unwrap() + 1)
        );
        // The checks: downgaze lowers both upper lids (probe 0: left upper, 2: right upper).
        let y = |pose: usize, probe: usize| {
            h["checks"]["poses"][pose]["positions"][probe][1]
                .as_f64()
                .unwrap()
        };
        assert!(y(1, 0) < y(0, 0) - 0.8 && y(1, 2) < y(0, 2) - 0.8);
        // The rest check is the rest mesh.
        let rest = m.rig.region.rest[h["checks"]["vertices"][0].as_u64().unwrap() as usize];
        assert!((y(0, 0) - rest.y as f64).abs() < 0.1);
    }
}

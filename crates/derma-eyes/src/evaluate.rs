//! Per-frame synthesis (thesis §3.9, fig. 3.14 and Algorithm 1): g̃ → e = W g̃ → ũ⁺ = Ũ e →
//! 3D positions from the skull map T and normals from Υ → globe sliding. Everything a frame
//! needs is precomputed here, so a frame is a few multiply-adds and two texture look-ups per
//! vertex.

use crate::gaze::Gaze;
use crate::globe::{Globe, RadialMap};
use crate::model::{EyeModel, Optimised, MAX_COEF};
use crate::region::EyeRegion;
use crate::skull::SkullMap;
use crate::sliding::Slider;
use glam::{Vec2, Vec3};

/// Travel (mm, in the modelling camera) over which a vertex's rest offset from the skull map
/// fades (authored: about the depth of the upper-lid crease).
pub const UNFOLD_MM: f32 = 1.0;

/// Texels per side of each globe's radial map (0.2 mm arc per texel on a 12 mm globe).
pub const RADIAL_MAP_SIZE: usize = 128;

/// A model bound to a head region, ready to evaluate frames.
pub struct Evaluator {
    /// The optimised model over every region vertex (tracked, then extrapolated).
    pub optimised: Optimised,
    /// T and Υ.
    pub skull: SkullMap,
    /// Globe sliding.
    pub slider: Slider,
    /// The globes (own frame).
    pub globes: [Globe; 2],
    /// Per vertex: rest position minus T(ũ⁺ at the neutral input), so the neutral frame is the
    /// rest mesh exactly (vertices hidden in folds keep their depth).
    pub(crate) offset: Vec<Vec3>,
    /// Per vertex: ũ⁺ at the neutral input.
    pub(crate) u0: Vec<Vec2>,
    /// Per vertex: the rest normal minus Υ(ũ⁺ neutral).
    pub(crate) normal_offset: Vec<Vec3>,
    /// Rest normals.
    pub(crate) rest_normals: Vec<Vec3>,
    /// The neutral input.
    pub neutral: Gaze,
}

/// Reusable per-frame buffers.
#[derive(Default)]
pub struct Frame {
    /// Reduced coordinates ũ⁺.
    pub u: Vec<Vec2>,
    /// Positions (head space, mm).
    pub positions: Vec<Vec3>,
    /// Normals.
    pub normals: Vec<Vec3>,
}

impl Evaluator {
    /// Binds `model` to `region` of `head` (whose tracked vertices it was trained on).
    pub fn new(
        model: &EyeModel,
        region: &EyeRegion,
        head: &derma_head::Head,
        thickness: f32,
    ) -> crate::Result<Evaluator> {
        if model.vertices != region.tracked {
            return Err(crate::EyesError::Invalid(format!(
                "the model was trained on {} tracked vertices, the head's eye region has {}",
                model.vertices, region.tracked
            )));
        }
        // Extrapolation sources: tracked vertices and the lid control points at rest.
        let mut sources: Vec<Vec3> = region.rest[..region.tracked].to_vec();
        let mut source_eye: Vec<u8> = region.eye[..region.tracked].to_vec();
        for e in 0..2 {
            for l in 0..2 {
                let chain: Vec<Vec3> = region.margins[e][l]
                    .iter()
                    .map(|&i| region.rest[i as usize])
                    .collect();
                let flat: Vec<Vec2> = chain.iter().map(|p| crate::lids::project(*p)).collect();
                for (s, t) in crate::lids::resample_params(&flat, model.lid_points) {
                    sources.push(chain[s].lerp(chain[s + 1], t));
                    source_eye.push(e as u8);
                }
            }
        }
        // Untracked skin follows tracked vertices and lid points; the lids' inner surfaces and
        // the conjunctiva (socket charts) follow the lid curves alone — their nearest tracked
        // skin lies across the lid, on the surface that does not move with them.
        let nt = region.tracked;
        let lid_only: Vec<u8> = source_eye
            .iter()
            .enumerate()
            .map(|(j, &e)| if j >= nt { e } else { u8::MAX })
            .collect();
        let (skin_i, inner_i): (Vec<usize>, Vec<usize>) =
            (nt..region.len()).partition(|&i| !region.inner[i]);
        let pick = |idx: &[usize]| -> (Vec<Vec3>, Vec<u8>) {
            (
                idx.iter().map(|&i| region.rest[i]).collect(),
                idx.iter().map(|&i| region.eye[i]).collect(),
            )
        };
        let (sp, se) = pick(&skin_i);
        let (ip, ie) = pick(&inner_i);
        let skin_rows = crate::transfer::extrapolation(&sources, &source_eye, &sp, &se);
        let inner_rows = crate::transfer::extrapolation(&sources, &lid_only, &ip, &ie);
        let mut rows = vec![Vec::new(); region.len() - nt];
        for (i, r) in skin_i.iter().zip(skin_rows) {
            rows[i - nt] = r;
        }
        for (i, r) in inner_i.iter().zip(inner_rows) {
            rows[i - nt] = r;
        }
        let optimised = model.optimised(&rows);
        let (lo, hi) = region.rest.iter().fold(
            (Vec2::splat(f32::MAX), Vec2::splat(f32::MIN)),
            |(a, b), p| (a.min(p.truncate()), b.max(p.truncate())),
        );
        let margin = Vec2::splat(6.0);
        let skin = &head.skin;
        // The face's front surface: skin-chart triangles in front of the globe centres (the
        // camera would otherwise see the inside of the back of the head through the openings).
        let front = head.eyes[0].centre.z.min(head.eyes[1].centre.z) - 8.0;
        let keep = |t: usize| {
            let tri = skin.triangles[t];
            !tri.iter()
                .any(|&i| head.regions.in_socket(skin.uvs[i as usize]))
                && tri.iter().all(|&i| skin.positions[i as usize].z > front)
        };
        // The head's own closed lids close the openings (its blink pose).
        let mut closed = head.posed_skin(&[("eyeBlinkLeft", 1.0), ("eyeBlinkRight", 1.0)]);
        closed.compute_normals();
        let keep_closed = |t: usize| {
            let tri = closed.triangles[t];
            !tri.iter()
                .any(|&i| head.regions.in_socket(closed.uvs[i as usize]))
                && tri.iter().all(|&i| closed.positions[i as usize].z > front)
        };
        let skull = SkullMap::layered(
            &[(skin, &keep), (&closed, &keep_closed)],
            lo - margin,
            hi + margin,
        )?;
        let globes = [Globe::of(&head.eyes[0]), Globe::of(&head.eyes[1])];
        let maps = globes.map(|g| RadialMap::from_mesh(&g.shell(true), RADIAL_MAP_SIZE));
        let centres = [head.eyes[0].centre, head.eyes[1].centre];
        let slider = Slider::new(
            centres,
            maps,
            &region.rest,
            &region.eye,
            &region.inner,
            thickness,
        );
        let neutral = Gaze {
            eyes: Default::default(),
            lids: [0, 1].map(|e| model.baseline_aperture(e, 0.0, 0.0, 1.0)),
            units: vec![0.0; model.units.len()],
        };
        let e = optimised.coefficients(&neutral);
        let mut u = vec![Vec2::ZERO; optimised.len()];
        optimised.evaluate(&e, &mut u);
        let mut offset = Vec::with_capacity(u.len());
        let mut normal_offset = Vec::with_capacity(u.len());
        for (i, ui) in u.iter().enumerate() {
            let (p, n) = skull.sample(*ui);
            offset.push(region.rest[i] - p);
            normal_offset.push(region.rest_normals[i] - n);
        }
        Ok(Evaluator {
            optimised,
            skull,
            slider,
            globes,
            offset,
            u0: u,
            normal_offset,
            rest_normals: region.rest_normals.clone(),
            neutral,
        })
    }

    /// Evaluates one frame into `f` (buffers reused).
    pub fn frame(&self, g: &Gaze, f: &mut Frame) {
        let e: [f32; MAX_COEF] = self.optimised.coefficients(g);
        self.frame_from(&e, g, f)
    }

    /// As [`Evaluator::frame`] from precomputed coefficients e (what a vertex shader receives).
    pub fn frame_from(&self, e: &[f32; MAX_COEF], g: &Gaze, f: &mut Frame) {
        let n = self.optimised.len();
        f.u.resize(n, Vec2::ZERO);
        f.positions.resize(n, Vec3::ZERO);
        f.normals.resize(n, Vec3::ZERO);
        self.optimised.evaluate(e, &mut f.u);
        for i in 0..n {
            let (p, nn) = self.skull.sample(f.u[i]);
            // Skin hidden in a fold at rest (the upper lid under its crease) unfolds onto the
            // visible surface as it slides away: its rest offset fades over UNFOLD_MM of travel.
            // (1 − (travel / UNFOLD_MM)²)⁺: no square root per vertex.
            let travel2 = (f.u[i] - self.u0[i]).length_squared();
            let keep = (1.0 - travel2 * (1.0 / (UNFOLD_MM * UNFOLD_MM))).max(0.0);
            f.positions[i] = p + self.offset[i] * keep;
            // The rest normal turned as the skull normal turns (to first order: the skull normal
            // plus the rest normal's difference from it, cheaper than a rotation per vertex and
            // exact at rest); the difference fades with the offset, so unfolded skin takes the
            // surface's normal. The map's normals are unit at its texels.
            let n = if keep > 0.0 {
                nn + self.normal_offset[i] * keep
            } else {
                nn
            };
            f.normals[i] = n * n.length_recip();
        }
        let rot = g.eyes.map(|a| a.rotation());
        self.slider
            .apply(rot, &mut f.positions, &mut f.normals, &self.rest_normals);
    }
}

//! Per-frame synthesis (thesis §3.9, fig. 3.14 and Algorithm 1): g̃ → e = W g̃ → ũ⁺ = Ũ e →
//! the lids' contact ([`crate::contact`]) → depth and normals linear in e ([`crate::depth`], in
//! place of the thesis's skull map) → globe sliding. Everything a frame needs is precomputed
//! here, so a frame is a few multiply-adds per vertex and one radial-map look-up near a globe.

use crate::gaze::Gaze;
use crate::globe::{Globe, RadialMap};
use crate::model::{EyeModel, Optimised, MAX_COEF};
use crate::region::EyeRegion;
use crate::sliding::Slider;
use glam::{Vec2, Vec3};

/// Texels per side of each globe's radial map (0.2 mm arc per texel on a 12 mm globe).
pub const RADIAL_MAP_SIZE: usize = 128;

/// A model bound to a head region, ready to evaluate frames.
pub struct Evaluator {
    /// The optimised model over every region vertex (tracked, then extrapolated).
    pub optimised: Optimised,
    /// Depth and normals from the coefficients.
    pub depth: crate::depth::DepthModel,
    /// Globe sliding.
    pub slider: Slider,
    /// The globes (own frame).
    pub globes: [Globe; 2],
    /// Per vertex: the rest position minus the model's at the neutral input (its fit's residual
    /// there, held constant), so the neutral frame is the rest mesh exactly.
    pub(crate) offset: Vec<Vec3>,
    /// Per vertex: the rest normal minus the model's at the neutral input.
    pub(crate) normal_offset: Vec<Vec3>,
    /// Rest normals.
    pub(crate) rest_normals: Vec<Vec3>,
    /// The lids' contact (the upper margin kept above the lower).
    pub(crate) contact: crate::contact::Contact,
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
            return Err(derma_core::Invalid::new(
                "the tracked vertices the model was trained on",
                format!("the {} of the head's eye region", region.tracked),
                model.vertices,
            )
            .into());
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
        let rig = crate::rigdata::Rig::with_region(head, region.clone());
        let depth = crate::depth::DepthModel::fit(model, &optimised, &rig)?;
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
        let n = optimised.len();
        let mut u = vec![Vec2::ZERO; n];
        optimised.evaluate(&e, &mut u);
        let (mut p, mut nn) = (vec![Vec3::ZERO; n], vec![Vec3::ZERO; n]);
        depth.evaluate(&e, &u, &mut p, &mut nn);
        let offset = (0..n).map(|i| region.rest[i] - p[i]).collect();
        let normal_offset = (0..n).map(|i| region.rest_normals[i] - nn[i]).collect();
        Ok(Evaluator {
            optimised,
            depth,
            slider,
            globes,
            offset,
            normal_offset,
            rest_normals: region.rest_normals.clone(),
            contact: crate::contact::Contact::new(region),
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
        self.contact.apply(&mut f.u);
        self.depth
            .evaluate(e, &f.u, &mut f.positions, &mut f.normals);
        for i in 0..n {
            f.positions[i] += self.offset[i];
            let nn = f.normals[i] + self.normal_offset[i];
            f.normals[i] = nn * nn.length_recip();
        }
        let rot = g.eyes.map(|a| a.rotation());
        self.slider
            .apply(rot, &mut f.positions, &mut f.normals, &self.rest_normals);
    }
}

//! De-lighting: each photo's lighting — soft light as SH bands 0–1 through each vertex's shadowed
//! transfer (Ramamoorthi & Hanrahan 2001; Sloan et al. 2002) plus one key light with its hard
//! shadows, per channel so that exposure and white balance are in it — and its vignetting,
//! estimated with one shared albedo per vertex on the known mesh: photo = albedo × shading, so the
//! bake can divide the shading out. The lights come from the photos' ratios (the albedo cancels)
//! as a generalized eigenproblem; highlights are masked and residuals reweighted (Cauchy) so
//! highlights and hard shadows do not bend the fit. Last, the model itself is chosen
//! ([`crate::light_model`]): each candidate's lights are fitted on four fifths of the vertices
//! and scored on the rest, and the simplest that explains the held-out photos best is kept.

use crate::light_model::{self, Basis, Key, Model, PARAMS};
use derma_core::numerics::dense::{smallest_generalized_eigenpair, solve, Matrix};
use derma_core::numerics::robust::mad_sigma;
use derma_core::sh::SH9;
use glam::Vec3;
use rayon::prelude::*;
use serde::Serialize;
use std::borrow::Cow;

/// One observation of a vertex in a photo.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Sample {
    /// The photo.
    pub photo: usize,
    /// Its linear RGB there.
    pub colour: [f32; 3],
    /// Squared distance from the image centre, 1 at the corner (for vignetting).
    pub r2: f32,
    /// Unit direction from the vertex toward the camera.
    pub view: Vec3,
}

/// A sample's weight against highlights of a key light toward `l`: 0 where the half vector lies
/// within 15° of the normal, rising to 1 at 25°. Skin's sheen (GGX roughness 0.3–0.45, Weyrich
/// et al. 2006) falls to a tenth of its peak within about 10° of the mirror direction, so the
/// samples left carry almost none of it; the rest of the skin's surface reflection is weak
/// beside its diffuse light.
pub fn highlight_weight(n: Vec3, view: Vec3, l: Vec3) -> f32 {
    let h = (view + l).normalize_or(n);
    let angle = n.dot(h).clamp(-1.0, 1.0).acos().to_degrees();
    ((angle - 15.0) / 10.0).clamp(0.0, 1.0)
}

/// Settings of [`estimate`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DelightOptions {
    /// Alternations of lighting, vignetting and albedo.
    pub iterations: usize,
    /// Reweight residuals (IRLS) after this many alternations; `usize::MAX` for plain least
    /// squares.
    pub robust_after: usize,
    /// Estimate each photo's vignetting (1 − v r²).
    pub vignetting: bool,
    /// The lighting model to use; `None` lets the photos choose ([`Model::candidates`], by
    /// held-out misfit).
    pub model: Option<Model>,
}

impl Default for DelightOptions {
    fn default() -> Self {
        Self {
            iterations: 10,
            robust_after: 1,
            vignetting: true,
            model: None,
        }
    }
}

/// SH coefficients of the soft light while the keys are searched for: bands 0 and 1 (an ambient
/// sky with a gradient). Band 2 can let the lighting trade a smooth albedo change against the
/// shape of the shading (on a convex face, position and normal go together); it is one of the
/// candidates the held-out misfit decides on ([`Model::candidates`]), not a start.
pub const SOFT: usize = 4;

/// The lighting of each photo.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Lighting {
    /// The model the photos chose (the one with the least held-out misfit, the simplest of
    /// those within 2 % of it).
    pub model: Model,
    /// Its name, e.g. "SH 0–1 (occluded) + soft key".
    pub model_name: String,
    /// Every candidate's held-out misfit (RMS log-ratio residual between photos on the fifth
    /// of the vertices its lights were not fitted on), simplest first; empty where the model
    /// was given.
    pub candidates: Vec<Candidate>,
    /// Why the lighting was kept (exposure and white balance only) although de-lighting was
    /// asked for: no model explained the photos well enough; `None` otherwise.
    pub fallback: Option<String>,
    /// Per photo and channel: the model's coefficients ([`Basis::len`] of them, zero beyond):
    /// the soft light's (SH irradiance: sky, fill, bounce; or the one constant), then the key
    /// light's irradiance; all with exposure and white balance.
    pub coefficients: Vec<[[f32; PARAMS]; 3]>,
    /// Per photo: the direction toward its key light (world); `None` where soft light alone
    /// explains the photo as well.
    pub key_direction: Vec<Option<[f32; 3]>>,
    /// Per photo: vignetting v of 1 − v r².
    pub vignetting: Vec<f32>,
    /// Per photo and channel: the gain that undoes its mean shading; the geometric mean over
    /// photos is 1 in every channel (the overall colour of the light is not recoverable, so the
    /// light is taken as neutral on average: no colour cast).
    pub gains: Vec<[f32; 3]>,
    /// RMS relative residual over the observations weighted ½ or more after the fit.
    pub rms_relative: f64,
    /// Share of observations weighted below ½ (highlights, hard shadows).
    pub outlier_share: f64,
}

impl Lighting {
    /// Photo k's vignetting factor at squared radius r2 (≥ 0.2 inside the image: v ≤ 0.8,
    /// r² ≤ 1).
    pub fn vignette(&self, k: usize, r2: f32) -> f32 {
        1.0 - self.vignetting[k] * r2
    }
}

/// One candidate model's score.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Candidate {
    /// Its name.
    pub model: String,
    /// RMS log-ratio residual between photos on the held-out vertices.
    pub held_out_misfit: f64,
}

/// What the lighting sees of the mesh, per vertex: its unit normal, its shadowed SH transfer
/// ([`derma_core::sh::shadowed_transfer`]) and whether a direction from it is unoccluded.
pub struct Surface<'a> {
    /// Unit normals.
    pub normals: &'a [Vec3],
    /// SH transfer with visibility.
    pub transfer: &'a [[f32; SH9]],
    /// Whether vertex v sees the direction d (no part of the mesh in the way).
    pub open: &'a (dyn Fn(usize, Vec3) -> bool + Sync),
}

/// The result of [`estimate`].
pub struct Delit {
    /// The lighting.
    pub lighting: Lighting,
    /// Per vertex: the shared albedo (the scale of [`Lighting::gains`]).
    pub albedo: Vec<[f32; 3]>,
    /// Per vertex and sample (as given): the robust weight in (0, 1].
    pub weights: Vec<Vec<f32>>,
    /// Per photo and vertex: the key's term (max(⟨n, l⟩, 0) × its visibility, as the model's
    /// key says); all zero without a key.
    pub key_terms: Vec<Vec<f32>>,
    transfer: Vec<[f32; SH9]>,
}

impl Delit {
    /// Photo k's shading at every vertex (irradiance × exposure × white balance), without
    /// vignetting.
    pub fn shadings(&self, k: usize) -> Vec<[f32; 3]> {
        let basis = basis_of(&self.lighting.model, &self.transfer, &self.key_terms);
        let coef = &self.lighting.coefficients[k];
        (0..self.transfer.len())
            .into_par_iter()
            .map(|v| std::array::from_fn(|c| basis.shade(v, k, &coef[c])))
            .collect()
    }
}

/// A model's basis over the given transfer and keys' terms.
fn basis_of<'a>(model: &Model, transfer: &'a [[f32; SH9]], keys: &'a [Vec<f32>]) -> Basis<'a> {
    Basis {
        transfer,
        soft: model.soft,
        keys: (model.key != Key::None).then(|| keys.iter().map(|k| k.as_slice()).collect()),
    }
}

/// The misfit ([`Problem::lights`], a mean squared relative error between photos) of the sky's
/// occlusion alone below which no other term is fitted. Authored between what the synthetic sets
/// measure: 0.003 under an even sky (8-bit quantisation, sky visibility from 8² rays), 0.2 with a
/// directional key.
pub const DC_MISFIT: f64 = 0.02;

/// The smallest shading a division trusts, as a share of the photo's mean: below it (the back of
/// a hard shadow, SH ringing) the shading is clamped and the sample's weight falls.
pub const MIN_SHADING: f32 = 0.05;

/// Photo k's shading at vertex v in channel c, from the basis and the coefficients.
fn shader<'a>(
    basis: &'a Basis<'a>,
    coef: &'a [[[f32; PARAMS]; 3]],
) -> impl Fn(usize, usize, usize) -> f32 + Sync + 'a {
    move |k, v, c| basis.shade(v, k, &coef[k][c])
}

/// Per vertex: max(⟨n, l⟩, 0) × visibility of l (vertices in `only`, or all).
fn key_term(surface: &Surface, l: Vec3, only: Option<&[usize]>) -> Vec<f32> {
    let at = |v: usize| {
        let c = surface.normals[v].dot(l);
        if c > 0.0 && (surface.open)(v, l) {
            c
        } else {
            0.0
        }
    };
    match only {
        None => (0..surface.normals.len()).into_par_iter().map(at).collect(),
        Some(vs) => {
            let mut out = vec![0.0; surface.normals.len()];
            let vals: Vec<f32> = vs.par_iter().map(|&v| at(v)).collect();
            for (&v, x) in vs.iter().zip(vals) {
                out[v] = x;
            }
            out
        }
    }
}

/// One chunk's share of [`Problem::lights`]: its two normal matrices, samples per photo and rows.
type Normals = (Vec<f64>, Vec<f64>, Vec<usize>, usize);

/// Vertices per partial sum of [`Problem::lights`].
const LIGHT_CHUNK: usize = 256;

/// A sample's weight: vertex, then the sample's place in the vertex's list.
type Weight<'a> = dyn Fn(usize, usize) -> f32 + Sync + 'a;

/// What the light solve reads.
struct Problem<'a> {
    surface: &'a Surface<'a>,
    samples: &'a [Vec<Sample>],
    photos: usize,
}

impl Problem<'_> {
    /// Vertex v's rows of [`Problem::lights`] added to its normal matrices; returns how many.
    #[allow(clippy::too_many_arguments)]
    fn accumulate(
        &self,
        v: usize,
        basis: &Basis,
        vig: &[f32],
        weight: &Weight,
        colour: &(dyn Fn(&Sample) -> f32 + Sync),
        m: &mut [f64],
        nrm: &mut [f64],
    ) -> usize {
        let p = basis.len();
        let dim = p * self.photos;
        let mut rows = 0;
        let s = &self.samples[v];
        let phi: Vec<[f32; PARAMS]> = s.iter().map(|x| basis.at(v, x.photo)).collect();
        // The colours with vignetting divided out.
        let val: Vec<f64> = s
            .iter()
            .map(|x| colour(x) as f64 / (1.0 - vig[x.photo] * x.r2) as f64)
            .collect();
        for a in 0..s.len() {
            let ja = s[a].photo * p;
            let wa = weight(v, a) as f64;
            for i in 0..p {
                for j in 0..p {
                    nrm[(ja + i) * dim + ja + j] += wa * (phi[a][i] * phi[a][j]) as f64;
                }
            }
            for b in a + 1..s.len() {
                let jb = s[b].photo * p;
                let sum = val[a] + val[b];
                if sum <= 0.0 {
                    continue;
                }
                let w = wa * weight(v, b) as f64 / (sum * sum);
                rows += 1;
                // r = [block a: I_b φ_a, block b: −I_a φ_b].
                let ra: [f64; PARAMS] = std::array::from_fn(|i| val[b] * phi[a][i] as f64);
                let rb: [f64; PARAMS] = std::array::from_fn(|i| -val[a] * phi[b][i] as f64);
                for i in 0..p {
                    for j in 0..p {
                        m[(ja + i) * dim + ja + j] += w * ra[i] * ra[j];
                        m[(jb + i) * dim + jb + j] += w * rb[i] * rb[j];
                        m[(ja + i) * dim + jb + j] += w * ra[i] * rb[j];
                        m[(jb + i) * dim + ja + j] += w * rb[i] * ra[j];
                    }
                }
            }
        }
        rows
    }

    /// Every photo's light coefficients at once, without the albedo: where photos j and k see
    /// vertex v, I_k S_j − I_j S_k = 0 (the albedo cancels), linear in the coefficients; the
    /// least-squares solution with mean squared shading fixed is the smallest generalized
    /// eigenvector. Rows are weighted by the samples' robust weights over (I_j + I_k)² (relative
    /// errors). Per channel (`colour` maps a sample to the value solved for), over `vertices`.
    /// Returns the coefficients per photo and the eigenvalue (the weighted misfit).
    fn lights(
        &self,
        vertices: &[usize],
        basis: &Basis,
        vig: &[f32],
        weight: &Weight,
        colour: &(dyn Fn(&Sample) -> f32 + Sync),
    ) -> Option<(Vec<[f32; PARAMS]>, f64)> {
        let p = basis.len();
        let dim = p * self.photos;
        // The normal matrices summed per fixed chunk of vertices, the chunks in order (the same
        // sums at any thread count).
        let partial: Vec<Normals> = vertices
            .par_chunks(LIGHT_CHUNK)
            .map(|chunk| {
                let mut m = vec![0.0f64; dim * dim];
                let mut nrm = vec![0.0f64; dim * dim];
                let mut count = vec![0usize; self.photos];
                let mut rows = 0usize;
                for &v in chunk {
                    rows += self.accumulate(v, basis, vig, weight, colour, &mut m, &mut nrm);
                    for x in &self.samples[v] {
                        count[x.photo] += 1;
                    }
                }
                (m, nrm, count, rows)
            })
            .collect();
        let mut m = vec![0.0f64; dim * dim];
        let mut nrm = vec![0.0f64; dim * dim];
        let mut count = vec![0usize; self.photos];
        let mut rows = 0usize;
        for (pm, pn, pc, pr) in partial {
            m.iter_mut().zip(&pm).for_each(|(a, b)| *a += b);
            nrm.iter_mut().zip(&pn).for_each(|(a, b)| *a += b);
            count.iter_mut().zip(&pc).for_each(|(a, b)| *a += b);
            rows += pr;
        }
        // Mean squared shading per photo.
        for k in 0..self.photos {
            let n = count[k].max(1) as f64;
            for i in 0..p {
                for j in 0..p {
                    nrm[(k * p + i) * dim + k * p + j] /= n;
                }
            }
        }
        // A ridge of 10⁻⁶ of the mean diagonal on both sides: a coefficient no vertex feeds (a
        // key not yet placed, a key lighting nothing) gets the typical quotient instead of 0/0.
        let (tm, tn) = (
            (0..dim).map(|i| m[i * dim + i]).sum::<f64>() / dim as f64,
            (0..dim).map(|i| nrm[i * dim + i]).sum::<f64>() / dim as f64,
        );
        // And a prior toward ambient light: 10⁻³ more on every coefficient but the constant.
        // Where the photos' ratios cannot tell shading shapes apart (the same light in every
        // view) the data leave the shape free; the prior then picks the sky's occlusion alone.
        for i in 0..dim {
            let prior = if i % p == 0 { 0.0 } else { 1e-4 };
            m[i * dim + i] += (1e-6 + prior) * tm;
            nrm[i * dim + i] += 1e-6 * tn;
        }
        let a = Matrix::from_fn(dim, dim, |i, j| m[i * dim + j]);
        let b = Matrix::from_fn(dim, dim, |i, j| nrm[i * dim + j]);
        let (lambda, x) = smallest_generalized_eigenpair(&a, &b).ok()?;
        // As a mean squared relative error per pair: each row is about (e / 2)·S with mean
        // squared shading 1 / photos.
        let lambda = lambda * 4.0 * self.photos as f64 / rows.max(1) as f64;
        // The sign that makes the soft light's mean positive.
        let sign = if x.chunks(p).map(|c| c[0]).sum::<f64>() < 0.0 {
            -1.0
        } else {
            1.0
        };
        let coef = x
            .chunks(p)
            .map(|c| std::array::from_fn(|i| if i < p { (sign * c[i]) as f32 } else { 0.0 }))
            .collect();
        Some((coef, lambda))
    }
}

impl Problem<'_> {
    /// Every photo's vignetting at once, given the lights: Gauss–Newton steps on the residual
    /// of [`Problem::lights`], Ĩ_b S_a − Ĩ_a S_b with Ĩ = I / (1 − v r²), over the channels.
    fn vignetting(
        &self,
        vertices: &[usize],
        basis: &Basis,
        coef: &[[[f32; PARAMS]; 3]],
        weight: &Weight,
        start: &[f32],
    ) -> Vec<f32> {
        let k = self.photos;
        let mut vig: Vec<f64> = start.iter().map(|v| *v as f64).collect();
        for _ in 0..2 {
            let mut m = vec![0.0f64; k * k];
            let mut g = vec![0.0f64; k];
            for &v in vertices {
                let s = &self.samples[v];
                let f: Vec<f64> = s.iter().map(|x| 1.0 - vig[x.photo] * x.r2 as f64).collect();
                for c in 0..3 {
                    let sh: Vec<f64> = s
                        .iter()
                        .map(|x| basis.shade(v, x.photo, &coef[x.photo][c]) as f64)
                        .collect();
                    let val: Vec<f64> = s
                        .iter()
                        .zip(&f)
                        .map(|(x, f)| x.colour[c] as f64 / f)
                        .collect();
                    for a in 0..s.len() {
                        for b in a + 1..s.len() {
                            if val[a] + val[b] <= 0.0 {
                                continue;
                            }
                            let w =
                                (weight(v, a) * weight(v, b)) as f64 / (val[a] + val[b]).powi(2);
                            let r0 = val[b] * sh[a] - val[a] * sh[b];
                            let (pa, pb) = (s[a].photo, s[b].photo);
                            // dĨ/dv = I r² / f².
                            let db = sh[a] * val[b] * s[b].r2 as f64 / f[b];
                            let da = -sh[b] * val[a] * s[a].r2 as f64 / f[a];
                            m[pa * k + pa] += w * da * da;
                            m[pb * k + pb] += w * db * db;
                            m[pa * k + pb] += w * da * db;
                            m[pb * k + pa] += w * da * db;
                            g[pa] -= w * da * r0;
                            g[pb] -= w * db * r0;
                        }
                    }
                }
            }
            let tr = (0..k).map(|i| m[i * k + i]).sum::<f64>() / k as f64;
            for i in 0..k {
                m[i * k + i] += 1e-6 * tr.max(1e-30);
            }
            let Some(step) = solve(&m, &g, k) else {
                break;
            };
            for i in 0..k {
                vig[i] = (vig[i] + step[i]).clamp(0.0, 0.8);
            }
        }
        vig.iter().map(|v| *v as f32).collect()
    }
}

/// The key direction of photo k that best explains the photos, or `None` when no key light
/// lowers the misfit by 3 % over soft light alone (or that misfit is below 1 % RMS already): from `start` (or, when coarse, the best of 64
/// directions over the sphere, a Fibonacci lattice: a key can come from anywhere), a compass
/// search on the sphere with steps halving from `step_deg` to 0.5°, on the channels' sum over
/// the subsample `sub` (shadows recast and highlights masked for each candidate), the other
/// photos' keys held. `weight` is the robust weight, `lit` the other photos' highlight masks.
#[allow(clippy::too_many_arguments)]
fn search_key(
    prob: &Problem,
    sub: &[usize],
    k: usize,
    start: Option<Vec3>,
    step_deg: f32,
    keys: &[Vec<f32>],
    vig: &[f32],
    weight: &Weight,
) -> Option<Vec3> {
    let sum = |x: &Sample| x.colour.iter().sum::<f32>();
    let normals = prob.surface.normals;
    let cost = |d: Option<Vec3>| {
        let term = match d {
            Some(d) => key_term(prob.surface, d, Some(sub)),
            None => vec![0.0; normals.len()],
        };
        let mut ks: Vec<&[f32]> = keys.iter().map(|x| x.as_slice()).collect();
        ks[k] = &term;
        let w = |v: usize, a: usize| {
            let x = &prob.samples[v][a];
            match d {
                Some(d) if x.photo == k => weight(v, a) * highlight_weight(normals[v], x.view, d),
                _ => weight(v, a),
            }
        };
        let basis = Basis {
            transfer: prob.surface.transfer,
            soft: SOFT,
            keys: Some(ks),
        };
        prob.lights(sub, &basis, vig, &w, &sum)
            .map_or(f64::INFINITY, |r| r.1)
    };
    // Candidates are scored in parallel and taken in their order (the first of equal costs).
    let take = |best: &mut (Vec3, f64), candidates: &[Vec3]| {
        let costs: Vec<f64> = candidates.par_iter().map(|d| cost(Some(*d))).collect();
        for (d, c) in candidates.iter().zip(costs) {
            if c < best.1 {
                *best = (*d, c);
            }
        }
    };
    let (soft, mut best) = rayon::join(
        || cost(None),
        || match start {
            Some(d) => (d, cost(Some(d))),
            None => (Vec3::Z, f64::INFINITY),
        },
    );
    if step_deg > 4.0 {
        let g = std::f32::consts::PI * (3.0 - 5f32.sqrt());
        let lattice: Vec<Vec3> = (0..64)
            .map(|i| {
                let z = 1.0 - 2.0 * (i as f32 + 0.5) / 64.0;
                let r = (1.0 - z * z).sqrt();
                Vec3::new(r * (g * i as f32).cos(), r * (g * i as f32).sin(), z)
            })
            .collect();
        take(&mut best, &lattice);
    }
    // A compass search: each neighbour at the current step in turn, moving at once to any
    // better one; the step halves when none is.
    let mut step = step_deg.to_radians();
    while step > 0.4f32.to_radians() {
        let (a, b) = best.0.any_orthonormal_pair();
        let mut moved = false;
        for t in [a, -a, b, -b] {
            let d = (best.0 * step.cos() + t * step.sin()).normalize();
            let c = cost(Some(d));
            if c < best.1 {
                best = (d, c);
                moved = true;
            }
        }
        if !moved {
            step *= 0.5;
        }
    }
    // A key must explain a misfit above 1 % RMS and lower it by 3 %.
    (soft > 1e-4 && best.1 < 0.97 * soft).then_some(best.0)
}

/// Estimates each photo's lighting and one albedo per vertex from `samples` (per vertex, its
/// observations): the lights from the photos' ratios ([`Problem::lights`]), first soft light
/// alone, then with a key light per photo whose direction starts at the soft light's dominant
/// direction and is refined by a compass search, with its hard shadows from `surface.open`;
/// then vignetting, albedo and robust weights in turn.
pub fn estimate(
    surface: &Surface,
    samples: &[Vec<Sample>],
    photos: usize,
    opts: &DelightOptions,
) -> Delit {
    estimate_from(surface, samples, photos, opts, None)
}

/// [`estimate`] warm-started from key directions found before (per photo; `None` where no key
/// was found): those keys are placed at once (skipping the coarse searches) and then go through
/// the fine compass search, which keeps them only where they still lower the misfit by 3 %; the
/// others are searched for from scratch (after the cameras were registered, the lighting moves
/// little). With fewer than 6 iterations there is no fine search, and a warm key stays unchecked.
pub fn estimate_from(
    surface: &Surface,
    samples: &[Vec<Sample>],
    photos: usize,
    opts: &DelightOptions,
    warm: Option<&[Option<Vec3>]>,
) -> Delit {
    assert_eq!(surface.transfer.len(), samples.len());
    let prob = Problem {
        surface,
        samples,
        photos,
    };
    let split = Split::new(samples);
    let start = fit_start(&prob, &split, opts, warm);
    let choice = match opts.model {
        // Without held-out vertices (a mesh of a handful) there is nothing to choose by.
        Some(m) => given(surface, &start, m),
        None if split.held.is_empty() => given(surface, &start, Model::START),
        None => choose_model(&prob, &split, &start),
    };
    finish(&prob, &split, opts, start, choice)
}

/// The vertices the lights are solved from.
struct Split {
    /// An even subsample of ≤ 6000 vertices seen twice or more (only those tie the photos'
    /// lights together; the lights have a few dozen unknowns).
    sub: Vec<usize>,
    /// ≤ 1500 of them for the key search (a few hundred solves).
    search: Vec<usize>,
    /// Four fifths of `sub`, the candidates' lights are fitted on …
    fit: Vec<usize>,
    /// … and the other fifth (every fifth vertex), where they are scored.
    held: Vec<usize>,
}

impl Split {
    fn new(samples: &[Vec<Sample>]) -> Split {
        let shared: Vec<usize> = (0..samples.len())
            .filter(|&v| samples[v].len() >= 2)
            .collect();
        let stride = (shared.len() / 6000).max(1);
        let sub: Vec<usize> = shared.iter().step_by(stride).copied().collect();
        let search = sub
            .iter()
            .step_by((sub.len() / 1500).max(1))
            .copied()
            .collect();
        let (held, fit) = sub
            .iter()
            .enumerate()
            .partition::<Vec<_>, _>(|(i, _)| i % 5 == 2);
        Split {
            search,
            fit: fit.into_iter().map(|(_, v)| *v).collect(),
            held: held.into_iter().map(|(_, v)| *v).collect(),
            sub,
        }
    }
}

/// The lighting as the start model ([`Model::START`]) finds it: soft light, then a hard key
/// per photo, vignetting and robust weights.
struct Start {
    coef: Vec<[[f32; PARAMS]; 3]>,
    vig: Vec<f32>,
    dirs: Vec<Option<Vec3>>,
    /// Per photo: the hard key's term per vertex.
    keys: Vec<Vec<f32>>,
    robust: Vec<Vec<f32>>,
    /// Per sample: the highlight mask of its photo's key.
    lit: Vec<Vec<f32>>,
}

/// One round of every photo's lights (per channel, in parallel) and then their vignetting.
fn lights_and_vignetting(
    prob: &Problem,
    vertices: &[usize],
    basis: &Basis,
    w: &Weight,
    opts: &DelightOptions,
    coef: &mut [[[f32; PARAMS]; 3]],
    vig: &mut Vec<f32>,
) {
    let per_channel: Vec<Option<Vec<[f32; PARAMS]>>> = (0..3)
        .into_par_iter()
        .map(|c| {
            prob.lights(vertices, basis, vig, w, &|x| x.colour[c])
                .map(|r| r.0)
        })
        .collect();
    for (c, r) in per_channel.into_iter().enumerate() {
        if let Some(r) = r {
            for k in 0..prob.photos {
                coef[k][c] = r[k];
            }
        }
    }
    if opts.vignetting {
        *vig = prob.vignetting(vertices, basis, coef, w, vig);
    }
}

/// The start model's alternations: the lights from the photos' ratios, first soft light alone,
/// then with a key light per photo whose direction starts at the soft light's dominant
/// direction (or at `warm`'s) and is refined by a compass search, with its hard shadows; then
/// vignetting and robust weights in turn.
fn fit_start(
    prob: &Problem,
    split: &Split,
    opts: &DelightOptions,
    warm: Option<&[Option<Vec3>]>,
) -> Start {
    let (surface, samples, photos) = (prob.surface, prob.samples, prob.photos);
    let transfer = surface.transfer;
    let nv = samples.len();
    let (sub, search) = (&split.sub, &split.search);
    let mut robust: Vec<Vec<f32>> = samples.iter().map(|s| vec![1.0; s.len()]).collect();
    let mut coef = vec![[[0.0f32; PARAMS]; 3]; photos];
    let mut vig = vec![0.0f32; photos];
    let mut keys: Vec<Vec<f32>> = vec![vec![0.0; nv]; photos];
    let mut dirs: Vec<Option<Vec3>> = vec![None; photos];
    // Per sample: the highlight mask of its photo's key.
    let masks = |dirs: &[Option<Vec3>]| -> Vec<Vec<f32>> {
        samples
            .par_iter()
            .enumerate()
            .map(|(v, s)| {
                s.iter()
                    .map(|x| {
                        dirs[x.photo]
                            .map_or(1.0, |d| highlight_weight(surface.normals[v], x.view, d))
                    })
                    .collect()
            })
            .collect()
    };
    let mut lit = masks(&dirs);
    let soft = 2.min(opts.iterations);
    // The sky's occlusion alone (an even light), or the soft light and then the keys.
    let mut even = false;
    for it in 0..opts.iterations {
        if it == 1 {
            // Model selection: where the sky's occlusion alone explains the photos (an even
            // light, a light tent), more terms would only fit noise, and the photos' ratios
            // cannot fix their shape: stay with it.
            let w = |v: usize, a: usize| robust[v][a];
            let sum = |x: &Sample| x.colour.iter().sum::<f32>();
            let sky = Basis {
                transfer,
                soft: 1,
                keys: None,
            };
            if let Some((_, misfit)) = prob.lights(sub, &sky, &vig, &w, &sum) {
                even = misfit <= DC_MISFIT;
            }
        }
        let with_key = it >= soft && !even;
        if with_key && (it == soft || it == soft + 1 || it == soft + 3) {
            // The key light of each photo in turn (coarse first, then finer once the
            // vignetting and weights have settled).
            for k in 0..photos {
                let w = |v: usize, a: usize| robust[v][a] * lit[v][a];
                let known = warm.and_then(|w| w.get(k).copied().flatten());
                let d = match known {
                    // A key found before: placed at the first pass, refined at the fine one.
                    Some(d) if it == soft => Some(d),
                    Some(_) if it == soft + 1 => dirs[k],
                    _ => {
                        // Coarse twice (the second time with every other key in place), then
                        // fine.
                        let step = if it <= soft + 1 { 8.0 } else { 2.0 };
                        search_key(prob, search, k, dirs[k], step, &keys, &vig, &w)
                    }
                };
                dirs[k] = d;
                keys[k] = match d {
                    Some(d) => key_term(surface, d, None),
                    None => vec![0.0; nv],
                };
                lit = masks(&dirs);
            }
        }
        let w = |v: usize, a: usize| robust[v][a] * lit[v][a];
        let basis = Basis {
            transfer,
            soft: if even { 1 } else { SOFT },
            keys: with_key.then(|| keys.iter().map(|k| k.as_slice()).collect()),
        };
        // Lights and vignetting in turn, without the albedo.
        for _ in 0..3 {
            lights_and_vignetting(prob, sub, &basis, &w, opts, &mut coef, &mut vig);
        }
        if it + 1 >= opts.robust_after && it + 1 < opts.iterations {
            let shade = shader(&basis, &coef);
            let mean_shade = mean_shading(samples, &shade, photos);
            robust = reweight(samples, &w, &shade, &vig, &mean_shade);
        }
    }
    Start {
        coef,
        vig,
        dirs,
        keys,
        robust,
        lit,
    }
}

/// A model, its candidates' scores, its transfer and keys' terms, and why the lighting was kept.
type Choice = (
    Model,
    Vec<Candidate>,
    Vec<[f32; SH9]>,
    Vec<Vec<f32>>,
    Option<String>,
);

/// The largest RMS relative residual of the trusted samples ([`Lighting::rms_relative`]) at which
/// the de-lighting is trusted; above it the lighting is kept. Tuned on three of
/// `bench/photo_light.sh`'s Cycles sets (docs/photo.md; the environment and sky sets held out):
/// where de-lighting paid (the Lambert set, +1.8–2.8 dB) the fit left 0.040; where it cost 3–6 dB
/// (an area and a point key through skin) 0.15–0.23. The held-out ratio misfit that chooses the
/// model does not separate these (0.61 of the lighting kept's on the Lambert set, 0.63 on the
/// point key's): it counts the texture's edges under the cameras' error, which every model
/// shares.
pub const MAX_RELATIVE_MISFIT: f64 = 0.08;

/// The transfer a model's soft light goes through: the shadowed one (borrowed), or the open one.
fn transfer_of<'a>(surface: &Surface<'a>, model: &Model) -> Cow<'a, [[f32; SH9]]> {
    if model.occlusion || model.soft == 0 {
        Cow::Borrowed(surface.transfer)
    } else {
        Cow::Owned(light_model::open_transfers(surface.normals))
    }
}

/// A given model, with its transfer and keys' terms (no scores).
fn given(surface: &Surface, start: &Start, model: Model) -> Choice {
    let keys = model_keys(surface, &start.dirs, &start.keys, model.key, None);
    (
        model,
        Vec::new(),
        transfer_of(surface, &model).into_owned(),
        keys,
        None,
    )
}

/// Which model the photos choose: every candidate's lights fitted on [`Split::fit`] (with the
/// start's vignetting, robust weights and key directions) and scored on [`Split::held`]; the
/// simplest within 2 % of the least misfit wins.
fn choose_model(prob: &Problem, split: &Split, start: &Start) -> Choice {
    let surface = prob.surface;
    let found = start.dirs.iter().any(|d| d.is_some());
    let w_fit = |v: usize, a: usize| start.robust[v][a] * start.lit[v][a];
    let w_held = |v: usize, a: usize| start.lit[v][a];
    let mut scored: Vec<(Model, f64)> = Vec::new();
    for model in Model::candidates() {
        if model.key != Key::None && !found {
            continue;
        }
        let transfer = transfer_of(surface, &model);
        let keys = model_keys(
            surface,
            &start.dirs,
            &start.keys,
            model.key,
            Some(&split.sub),
        );
        let basis = basis_of(&model, &transfer, &keys);
        let mut coef = vec![[[0.0f32; PARAMS]; 3]; prob.photos];
        let mut vig = start.vig.clone();
        let fixed = DelightOptions {
            vignetting: false,
            ..Default::default()
        };
        lights_and_vignetting(
            prob, &split.fit, &basis, &w_fit, &fixed, &mut coef, &mut vig,
        );
        let misfit = held_out_misfit(prob, &split.held, &basis, &coef, &start.vig, &w_held);
        scored.push((model, misfit));
    }
    let least = scored.iter().map(|s| s.1).fold(f64::INFINITY, f64::min);
    let model = scored
        .iter()
        .find(|s| s.1 <= 1.02 * least)
        .map_or(Model::START, |s| s.0);
    let transfer = transfer_of(surface, &model).into_owned();
    let keys = model_keys(surface, &start.dirs, &start.keys, model.key, None);
    let candidates = scored
        .iter()
        .map(|(m, e)| Candidate {
            model: m.name(),
            held_out_misfit: *e,
        })
        .collect();
    (model, candidates, transfer, keys, None)
}

/// Per photo: the key's term per vertex for a model's kind of key (all zero without a key or
/// where the photo has none); the hard key's terms are the start's. `only`: the vertices that
/// need a term (the others 0), or all.
fn model_keys(
    surface: &Surface,
    dirs: &[Option<Vec3>],
    hard: &[Vec<f32>],
    key: Key,
    only: Option<&[usize]>,
) -> Vec<Vec<f32>> {
    let nv = surface.normals.len();
    match key {
        Key::Hard => hard.to_vec(),
        Key::None => vec![vec![0.0; nv]; dirs.len()],
        _ => dirs
            .iter()
            .map(|d| match d {
                None => vec![0.0; nv],
                Some(l) => {
                    let disc = light_model::disc_directions(
                        *l,
                        light_model::SOFT_KEY_DEG,
                        light_model::SOFT_KEY_RAYS,
                    );
                    let at = |v: usize| {
                        let open = |d: Vec3| (surface.open)(v, d);
                        light_model::key_at(key, surface.normals[v], *l, &disc, &open)
                    };
                    match only {
                        None => (0..nv).into_par_iter().map(at).collect(),
                        Some(vs) => {
                            let mut out = vec![0.0; nv];
                            let vals: Vec<f32> = vs.par_iter().map(|&v| at(v)).collect();
                            for (&v, x) in vs.iter().zip(vals) {
                                out[v] = x;
                            }
                            out
                        }
                    }
                }
            })
            .collect(),
    }
}

/// The misfit of lights `coef` between the photos at `vertices`: the RMS over sample pairs and
/// channels of ln(I_a / I_b) − ln(S_a / S_b) (vignetting divided out; S floored at
/// [`MIN_SHADING`] of its photo's mean), each squared residual capped at 1 (a factor e: a
/// shadow the model misplaces counts, but does not swamp the rest), weighted.
fn held_out_misfit(
    prob: &Problem,
    vertices: &[usize],
    basis: &Basis,
    coef: &[[[f32; PARAMS]; 3]],
    vig: &[f32],
    weight: &Weight,
) -> f64 {
    let shade = shader(basis, coef);
    // Each photo's mean shading over the scored vertices (the floor every candidate shares).
    let mean = mean_shading_at(prob.samples, vertices.iter().copied(), &shade, prob.photos);
    let parts: Vec<(f64, f64)> = vertices
        .par_iter()
        .map(|&v| {
            let s = &prob.samples[v];
            let (mut num, mut den) = (0.0f64, 0.0f64);
            for c in 0..3 {
                let log: Vec<(f64, f64)> = s
                    .iter()
                    .map(|x| {
                        let i = x.colour[c] as f64 / (1.0 - vig[x.photo] * x.r2) as f64;
                        let sh = shade(x.photo, v, c).max(MIN_SHADING * mean[x.photo][c]);
                        (i.max(1e-4).ln(), (sh as f64).max(1e-12).ln())
                    })
                    .collect();
                for a in 0..s.len() {
                    for b in a + 1..s.len() {
                        let w = (weight(v, a) * weight(v, b)) as f64;
                        let e = (log[a].0 - log[b].0) - (log[a].1 - log[b].1);
                        num += w * (e * e).min(1.0);
                        den += w;
                    }
                }
            }
            (num, den)
        })
        .collect();
    let (num, den) = parts
        .iter()
        .fold((0.0, 0.0), |(a, b), (x, y)| (a + x, b + y));
    if den > 0.0 {
        (num / den).sqrt()
    } else {
        f64::INFINITY
    }
}

/// The chosen model's lights and vignetting on all of [`Split::sub`], the albedo, one more
/// round of robust weights and the albedo again; then the normalisation and the report.
fn finish(
    prob: &Problem,
    split: &Split,
    opts: &DelightOptions,
    start: Start,
    choice: Choice,
) -> Delit {
    let (model, candidates, transfer, keys, fallback) = choice;
    let (samples, photos) = (prob.samples, prob.photos);
    let Start {
        mut coef,
        mut vig,
        dirs,
        mut robust,
        lit,
        ..
    } = start;
    let basis = basis_of(&model, &transfer, &keys);
    let w = |v: usize, a: usize| robust[v][a] * lit[v][a];
    // The start's lights are the start model's already; another model's are solved afresh.
    if model != Model::START {
        coef = vec![[[0.0f32; PARAMS]; 3]; photos];
        for _ in 0..3 {
            lights_and_vignetting(prob, &split.sub, &basis, &w, opts, &mut coef, &mut vig);
        }
    }
    let mut albedo = {
        let shade = shader(&basis, &coef);
        let mean_shade = mean_shading(samples, &shade, photos);
        if opts.iterations > opts.robust_after {
            robust = reweight(samples, &w, &shade, &vig, &mean_shade);
        }
        let w = |v: usize, a: usize| robust[v][a] * lit[v][a];
        solve_albedo(samples, &w, &shade, &vig, &mean_shade)
    };
    let weights: Vec<Vec<f32>> = robust
        .iter()
        .zip(&lit)
        .map(|(r, l)| r.iter().zip(l).map(|(a, b)| a * b).collect())
        .collect();
    let gains = normalise(samples, &basis, &mut coef, &mut albedo, photos);
    let (rms_relative, outlier_share) =
        fit_quality(samples, &basis, &coef, &albedo, &vig, &weights);
    drop(basis);
    let fallback = fallback.or_else(|| {
        if model == Model::KEPT {
            return Some("no lighting model explained the held-out photos better than their exposure and white balance alone".into());
        }
        (rms_relative > MAX_RELATIVE_MISFIT).then(|| {
            format!(
                "the lighting model {} leaves the photos a relative misfit of {rms_relative:.3} (trusted up to {MAX_RELATIVE_MISFIT})",
                model.name()
            )
        })
    });
    let lighting = Lighting {
        model,
        model_name: model.name(),
        candidates,
        fallback,
        coefficients: coef,
        // A model without a key has none to report (the start's stay out of it).
        key_direction: dirs
            .iter()
            .map(|d| d.filter(|_| model.key != Key::None).map(|d| d.to_array()))
            .collect(),
        vignetting: vig,
        gains,
        rms_relative,
        outlier_share,
    };
    Delit {
        lighting,
        albedo,
        weights,
        key_terms: keys,
        transfer,
    }
}

/// Normalises the lights so that per channel the geometric mean over photos of their mean
/// shading is 1 (the albedo scaled to match); returns each photo's gain (that mean over its
/// mean shading).
fn normalise(
    samples: &[Vec<Sample>],
    basis: &Basis,
    coef: &mut [[[f32; PARAMS]; 3]],
    albedo: &mut [[f32; 3]],
    photos: usize,
) -> Vec<[f32; 3]> {
    let mean_shade = mean_shading(samples, &shader(basis, coef), photos);
    let mut gains = vec![[1.0f32; 3]; photos];
    for c in 0..3 {
        let logs: Vec<f64> = (0..photos)
            .filter(|&k| mean_shade[k][c] > 0.0)
            .map(|k| (mean_shade[k][c] as f64).ln())
            .collect();
        let g = if logs.is_empty() {
            1.0
        } else {
            (logs.iter().sum::<f64>() / logs.len() as f64).exp() as f32
        };
        for k in 0..photos {
            for l in coef[k][c].iter_mut() {
                *l /= g;
            }
            gains[k][c] = if mean_shade[k][c] > 0.0 {
                g / mean_shade[k][c]
            } else {
                1.0
            };
        }
        for a in albedo.iter_mut() {
            a[c] *= g;
        }
    }
    gains
}

/// The RMS relative residual over the observations weighted ½ or more, and the share of those
/// weighted below.
fn fit_quality(
    samples: &[Vec<Sample>],
    basis: &Basis,
    coef: &[[[f32; PARAMS]; 3]],
    albedo: &[[f32; 3]],
    vig: &[f32],
    weights: &[Vec<f32>],
) -> (f64, f64) {
    let shade = shader(basis, coef);
    let mean_shade = mean_shading(samples, &shade, coef.len());
    let (mut se, mut n, mut low) = (0.0f64, 0usize, 0usize);
    for (v, s) in samples.iter().enumerate() {
        for (x, w) in s.iter().zip(&weights[v]) {
            if *w >= 0.5 {
                let e = relative_residual(x, v, &albedo[v], &shade, vig[x.photo], &mean_shade);
                se += e * e;
                n += 1;
            } else {
                low += 1;
            }
        }
    }
    (
        (se / n.max(1) as f64).sqrt(),
        low as f64 / (n + low).max(1) as f64,
    )
}

/// Albedo per vertex: A = Σ w I S / Σ w S² over its samples (S with vignetting, floored at
/// [`MIN_SHADING`] of the photo's mean).
fn solve_albedo(
    samples: &[Vec<Sample>],
    weight: &Weight,
    shade: &(dyn Fn(usize, usize, usize) -> f32 + Sync),
    vig: &[f32],
    mean_shade: &[[f32; 3]],
) -> Vec<[f32; 3]> {
    (0..samples.len())
        .into_par_iter()
        .map(|v| {
            std::array::from_fn(|c| {
                let (mut num, mut den) = (0.0f64, 0.0f64);
                for (a, x) in samples[v].iter().enumerate() {
                    let w = &weight(v, a);
                    let floor = MIN_SHADING * mean_shade[x.photo][c];
                    let sh = (shade(x.photo, v, c).max(floor) * (1.0 - vig[x.photo] * x.r2)) as f64;
                    num += *w as f64 * x.colour[c] as f64 * sh;
                    den += *w as f64 * sh * sh;
                }
                if den > 0.0 {
                    (num / den) as f32
                } else {
                    0.0
                }
            })
        })
        .collect()
}

/// Per photo and channel: the mean shading over the vertices it sees.
fn mean_shading(
    samples: &[Vec<Sample>],
    shade: &(dyn Fn(usize, usize, usize) -> f32 + Sync),
    photos: usize,
) -> Vec<[f32; 3]> {
    mean_shading_at(samples, 0..samples.len(), shade, photos)
}

/// [`mean_shading`] over the given vertices only.
fn mean_shading_at(
    samples: &[Vec<Sample>],
    vertices: impl Iterator<Item = usize>,
    shade: &(dyn Fn(usize, usize, usize) -> f32 + Sync),
    photos: usize,
) -> Vec<[f32; 3]> {
    let mut sum = vec![[0.0f64; 3]; photos];
    let mut n = vec![0usize; photos];
    for v in vertices {
        for x in &samples[v] {
            for c in 0..3 {
                sum[x.photo][c] += shade(x.photo, v, c) as f64;
            }
            n[x.photo] += 1;
        }
    }
    sum.iter()
        .zip(&n)
        .map(|(s, &n)| s.map(|v| (v / n.max(1) as f64).max(0.0) as f32))
        .collect()
}

/// The relative residual of one observation, over the channels' sum: I / (A·S) − 1 (S floored
/// at [`MIN_SHADING`] of the photo's mean).
fn relative_residual(
    x: &Sample,
    v: usize,
    albedo: &[f32; 3],
    shade: &(dyn Fn(usize, usize, usize) -> f32 + Sync),
    vig: f32,
    mean_shade: &[[f32; 3]],
) -> f64 {
    let model: f64 = (0..3)
        .map(|c| {
            let s = shade(x.photo, v, c).max(MIN_SHADING * mean_shade[x.photo][c]);
            (albedo[c] * s * (1.0 - vig * x.r2)) as f64
        })
        .sum();
    let seen: f64 = x.colour.iter().map(|v| *v as f64).sum();
    if model > 1e-6 {
        seen / model - 1.0
    } else {
        1.0
    }
}

/// Robust weights from leave-one-out residuals: each observation against the albedo the
/// vertex's other observations give (with a single observation there is nothing to compare, so
/// weight 1), e = I / (A₋ S) − 1 over the channels' sum. Cauchy weights 1 / (1 + (e / cσ)²), σ
/// from the residuals' median absolute deviation (×1.4826, a normal's σ, floor 1 %), c = 2 for
/// brighter than expected and 6 for darker: highlights only add light, while the darker misfits
/// (shadow detail finer than the mesh) are milder and should still count.
fn reweight(
    samples: &[Vec<Sample>],
    weight: &Weight,
    shade: &(dyn Fn(usize, usize, usize) -> f32 + Sync),
    vig: &[f32],
    mean_shade: &[[f32; 3]],
) -> Vec<Vec<f32>> {
    let res: Vec<Vec<f64>> = samples
        .par_iter()
        .enumerate()
        .map(|(v, s)| {
            if s.len() < 2 {
                return vec![0.0; s.len()];
            }
            let sh: Vec<[f64; 3]> = s
                .iter()
                .map(|x| {
                    std::array::from_fn(|c| {
                        (shade(x.photo, v, c).max(MIN_SHADING * mean_shade[x.photo][c])
                            * (1.0 - vig[x.photo] * x.r2)) as f64
                    })
                })
                .collect();
            (0..s.len())
                .map(|a| {
                    let (mut model, mut seen) = (0.0f64, 0.0f64);
                    for c in 0..3 {
                        let (mut num, mut den) = (0.0f64, 0.0f64);
                        for b in (0..s.len()).filter(|&b| b != a) {
                            let w = weight(v, b) as f64;
                            num += w * s[b].colour[c] as f64 * sh[b][c];
                            den += w * sh[b][c] * sh[b][c];
                        }
                        let albedo = if den > 0.0 { num / den } else { 0.0 };
                        model += albedo * sh[a][c];
                        seen += s[a].colour[c] as f64;
                    }
                    if model > 1e-6 {
                        seen / model - 1.0
                    } else {
                        1.0
                    }
                })
                .collect()
        })
        .collect();
    let mut abs: Vec<f64> = res
        .iter()
        .filter(|r| r.len() >= 2)
        .flat_map(|r| r.iter().map(|e| e.abs()))
        .collect();
    let sigma = mad_sigma(&mut abs).map_or(0.01, |s| s.max(0.01));
    res.iter()
        .map(|r| {
            r.iter()
                .map(|e| {
                    let c = if *e > 0.0 { 2.0 } else { 6.0 };
                    (1.0 / (1.0 + (e / (c * sigma)).powi(2))) as f32
                })
                .collect()
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use derma_core::sh::open_transfer;

    /// Vertices on the front half of a sphere with a varied albedo, photographed under three
    /// lights (ambient + directional, coloured) with exposure and vignetting.
    type Scene = (Vec<Vec3>, Vec<[f32; SH9]>, Vec<Vec<Sample>>, Vec<[f32; 3]>);

    fn scene(highlights: bool) -> Scene {
        let g = std::f32::consts::PI * (3.0 - 5f32.sqrt());
        let n = 3000;
        let normals: Vec<Vec3> = (0..n)
            .map(|i| {
                let z = 1.0 - (i as f32 + 0.5) / n as f32;
                let r = (1.0 - z * z).sqrt();
                Vec3::new(r * (g * i as f32).cos(), r * (g * i as f32).sin(), z)
            })
            .collect();
        let albedo: Vec<[f32; 3]> = normals
            .iter()
            .enumerate()
            .map(|(i, n)| {
                let s = ((i * 7919) % 100) as f32 / 100.0;
                [0.4 + 0.2 * s, 0.25 + 0.1 * n.x, 0.2 + 0.05 * s]
            })
            .collect();
        let lights = [
            (
                Vec3::new(0.5, 0.3, 1.0),
                0.8,
                0.3,
                [1.0, 1.0, 1.0],
                1.0,
                0.2,
            ),
            (
                Vec3::new(-0.7, 0.2, 0.6),
                1.0,
                0.2,
                [1.1, 1.0, 0.9],
                0.7,
                0.3,
            ),
            (
                Vec3::new(0.1, -0.8, 0.5),
                0.6,
                0.4,
                [0.9, 1.0, 1.1],
                1.3,
                0.1,
            ),
        ];
        let transfer: Vec<[f32; SH9]> = normals.iter().map(|n| open_transfer(*n)).collect();
        let samples = normals
            .iter()
            .enumerate()
            .map(|(v, n)| {
                lights
                    .iter()
                    .enumerate()
                    .map(|(k, (l, key, amb, wb, exp, vig))| {
                        let r2 = ((v * 31 + k * 17) % 97) as f32 / 97.0;
                        let e = key * n.dot(l.normalize()).max(0.0) + amb;
                        let spot = highlights && (v + k * 5) % 50 == 0;
                        let colour = std::array::from_fn(|c| {
                            let d = albedo[v][c] * e + if spot { 0.5 } else { 0.0 };
                            d * wb[c] * exp * (1.0 - vig * r2)
                        });
                        Sample {
                            photo: k,
                            colour,
                            r2,
                            view: Vec3::Z,
                        }
                    })
                    .collect()
            })
            .collect();
        (normals, transfer, samples, albedo)
    }

    fn run(sc: &Scene, opts: &DelightOptions) -> Delit {
        // A convex sphere: nothing shadows anything.
        let surface = Surface {
            normals: &sc.0,
            transfer: &sc.1,
            open: &|_, _| true,
        };
        estimate(&surface, &sc.2, 3, opts)
    }

    /// Worst relative albedo error per channel after the one per-channel scale that best fits.
    fn albedo_error(got: &[[f32; 3]], truth: &[[f32; 3]]) -> f64 {
        let mut worst = 0.0f64;
        for c in 0..3 {
            let s: f64 = got
                .iter()
                .zip(truth)
                .map(|(g, t)| (g[c] / t[c]) as f64)
                .sum::<f64>()
                / got.len() as f64;
            let mut e: Vec<f64> = got
                .iter()
                .zip(truth)
                .map(|(g, t)| ((g[c] / t[c]) as f64 / s - 1.0).abs())
                .collect();
            e.sort_by(f64::total_cmp);
            worst = worst.max(e[e.len() * 99 / 100]);
        }
        worst
    }

    #[test]
    fn albedo_is_recovered_under_three_coloured_lights() {
        let sc = scene(false);
        let truth = &sc.3;
        let d = run(&sc, &DelightOptions::default());
        let e = albedo_error(&d.albedo, truth);
        // Order-2 SH represents a clamped cosine plus ambient to a few per cent.
        assert!(e < 0.06, "99th percentile albedo error {e}");
        // Vignetting found.
        for (k, want) in [0.2f32, 0.3, 0.1].iter().enumerate() {
            let v = d.lighting.vignetting[k];
            assert!(
                (v - want).abs() < 0.04,
                "photo {k}: vignetting {v} vs {want}"
            );
        }
        // Gains undo exposure × white balance up to one scale per channel, geometric mean 1.
        for c in 0..3 {
            let p: f32 = (0..3).map(|k| d.lighting.gains[k][c]).product();
            assert!((p.ln()).abs() < 1e-3, "channel {c}: product of gains {p}");
        }
    }

    #[test]
    fn highlights_are_weighted_out() {
        let sc = scene(true);
        let truth = &sc.3;
        let plain = run(
            &sc,
            &DelightOptions {
                robust_after: usize::MAX,
                ..Default::default()
            },
        );
        let robust = run(&sc, &DelightOptions::default());
        let (ep, er) = (
            albedo_error(&plain.albedo, truth),
            albedo_error(&robust.albedo, truth),
        );
        assert!(er < 0.06 && er < 0.5 * ep, "robust {er} vs plain {ep}");
        // The highlighted observations are the ones weighted down.
        let (mut spots, mut low) = (0, 0);
        for (v, w) in robust.weights.iter().enumerate() {
            for (k, w) in w.iter().enumerate() {
                if (v + k * 5) % 50 == 0 {
                    spots += 1;
                    low += (*w < 0.5) as usize;
                }
            }
        }
        assert!(
            low * 10 >= spots * 9,
            "{low} of {spots} highlights weighted down"
        );
    }
}

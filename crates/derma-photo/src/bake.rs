//! Texture resampling from calibrated photos (Tarini et al. 2002 §3.2): vertex-to-photo binding
//! with visibility by ray casting and a silhouette test; per-texel blending weighted by ⟨N, Vᵢ⟩;
//! the paper's three triangle cases; the one-ring colour fill (80/60/40/20 %) so no region stays
//! empty; gains solved globally first; then the multiresolution spline with shrunk masks.

use crate::blend::{default_levels, multiband_with, Plane};
use crate::camera::{Camera, Prepared};
use crate::delight::{
    estimate, estimate_from, DelightOptions, Delit, Lighting, Sample, Surface, MIN_SHADING,
};
use crate::error::{PhotoError, Result};
use crate::gain::Overlaps;
use crate::photo::{Photo, RgbImage};
use crate::register::{luminance_pyramid, register, RegisterOptions, Registration};
use crate::topology::Topology;
use derma_core::bvh::Bvh;
use derma_core::image::{Grey, Image};
use derma_core::mesh::TriMesh;
use derma_core::progress::{Note, Progress, Unit};
use derma_core::raster::{dilation_sources, UvRaster, NO_TRIANGLE};
use glam::Vec3;
use rayon::prelude::*;
use serde::Serialize;

/// The most photos one bake takes (one bit each per vertex).
pub const MAX_PHOTOS: usize = 32;
/// [`Baked::source`] of a texel coloured by interpolating vertex colours (cases 2 and 3).
pub const SOURCE_INTERPOLATED: u8 = 254;
/// [`Baked::source`] of a texel outside the chart.
pub const SOURCE_NONE: u8 = 255;

/// Settings of [`bake`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BakeOptions {
    /// Texture width and height in texels.
    pub size: usize,
    /// Take each photo's lighting out before blending ([`crate::delight`]); `None` keeps it.
    pub delight: Option<DelightOptions>,
    /// Rays per vertex (this number squared) for the mesh's shadowed SH transfer.
    pub transfer_side: usize,
    /// Render each photo's recovered shading in its own frame ([`Baked::shading`]).
    pub shading_images: bool,
    /// Solve per-photo gains and white balance before blending (Brown & Lowe 2007), normalised
    /// per channel to a geometric mean of 1; with de-lighting the gains come from the lighting.
    pub gain_compensation: bool,
    /// Blend with multiresolution splines (Burt & Adelson 1983); else the weighted mean.
    pub multiband: bool,
    /// Pyramid levels (`None`: down to about 8 texels).
    pub levels: Option<usize>,
    /// ⟨N, V⟩ below which a photo's weight is 0 and above which its smooth ramp is done:
    /// a smooth falloff instead of a hard angle cut.
    pub falloff: [f32; 2],
    /// Ray offset for the visibility test, as a fraction of the mesh's extent.
    pub ray_offset: f32,
    /// Refine the cameras photometrically on the de-lit photos ([`crate::register`]; with
    /// de-lighting only); `None` takes them as given.
    pub register: Option<RegisterOptions>,
    /// Refuse instead of warning: a lighting no model explains, a registration beyond the
    /// clicks' reach, gains far from 1 ([`BakeReport::warnings`]) become an error.
    pub strict: bool,
}

impl Default for BakeOptions {
    fn default() -> Self {
        Self {
            size: 2048,
            delight: Some(DelightOptions::default()),
            transfer_side: 8,
            shading_images: false,
            gain_compensation: true,
            multiband: true,
            levels: None,
            // cos 84° and cos 60°.
            falloff: [0.1, 0.5],
            ray_offset: 1e-3,
            register: Some(RegisterOptions::default()),
            strict: false,
        }
    }
}

/// What happened to each photo.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct PhotoReport {
    /// The photo.
    pub name: String,
    /// Gain per channel applied before blending.
    pub gain: [f32; 3],
    /// Vertices bound to it.
    pub bound_vertices: usize,
    /// Share of the chart's texels where it is the best view.
    pub best_share: f64,
}

/// A summary of a bake.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct BakeReport {
    /// Per photo.
    pub photos: Vec<PhotoReport>,
    /// Triangles in the paper's cases 1 (a common photo), 2 (all bound, none common) and 3
    /// (an unbound vertex).
    pub triangle_cases: [usize; 3],
    /// Vertices bound to no photo, coloured by the one-ring fill.
    pub unbound_vertices: usize,
    /// Share of the chart's texels coloured from photos directly (case 1).
    pub photo_coverage: f64,
    /// Each photo's lighting as de-lighting found it (`None` when the lighting was kept).
    pub lighting: Option<Lighting>,
    /// Each photo's photometric registration (empty when the cameras were taken as given).
    pub registration: Vec<Registration>,
    /// Wall-clock seconds of the stages: binding, gains and de-lighting, resampling, spline
    /// blending.
    pub seconds: [f64; 3],
    /// What the bake fell back from, naming the photo and the figure: a lighting no model
    /// explained (kept instead), a registration beyond the clicks' reach (the calibrated
    /// cameras kept), gains far from 1 (the lighting kept).
    pub warnings: Vec<String>,
}

/// A baked texture.
pub struct Baked {
    /// Linear RGB, row 0 at v = 1: the albedo (in the scale of mean gain 1) when de-lit, else
    /// the photos' colour.
    pub texture: RgbImage,
    /// Per photo with [`BakeOptions::shading_images`] and de-lighting: the shading taken out
    /// (irradiance × exposure × white balance × vignetting) in the photo's frame, 0 off the mesh.
    pub shading: Vec<RgbImage>,
    /// Per texel: the best photo's index, [`SOURCE_INTERPOLATED`] or [`SOURCE_NONE`].
    pub source: Vec<u8>,
    /// The summary.
    pub report: BakeReport,
}

fn smoothstep(a: f32, b: f32, x: f32) -> f32 {
    let t = ((x - a) / (b - a)).clamp(0.0, 1.0);
    t * t * (3.0 - 2.0 * t)
}

/// A photo's weight at a surface point with unit normal `n`: ⟨N, V⟩ with a smooth falloff at
/// grazing angles and at the image border (2 % of its size).
fn weight(cam: &Prepared, p: Vec3, n: Vec3, falloff: [f32; 2]) -> Option<(f32, glam::DVec2)> {
    let v = (cam.centre - p.as_dvec3()).normalize();
    let cos = n.as_dvec3().dot(v) as f32;
    if cos <= falloff[0] {
        return None;
    }
    let px = cam.project(p.as_dvec3())?;
    if !cam.camera.in_image(px) {
        return None;
    }
    let (w, h) = (cam.camera.width as f64, cam.camera.height as f64);
    let edge = px.x.min(px.y).min(w - px.x).min(h - px.y) as f32;
    let border = smoothstep(0.0, 0.02 * w.max(h) as f32, edge);
    let wgt = cos * smoothstep(falloff[0], falloff[1], cos) * border;
    (wgt > 0.0).then_some((wgt, px))
}

/// A mesh vertex seen from a photo: its pixel and ⟨N, V⟩.
type Corner = ([f32; 2], f32);

/// The weight of a texel at pixel `px` whose surface has ⟨N, V⟩ = `cos`: as [`weight`].
fn texel_weight(cam: &crate::Camera, px: [f32; 2], cos: f32, falloff: [f32; 2]) -> Option<f32> {
    if cos <= falloff[0] {
        return None;
    }
    let (w, h) = (cam.width as f32, cam.height as f32);
    let edge = px[0].min(px[1]).min(w - px[0]).min(h - px[1]);
    if edge <= 0.0 {
        return None;
    }
    let wgt =
        cos * smoothstep(falloff[0], falloff[1], cos) * smoothstep(0.0, 0.02 * w.max(h), edge);
    (wgt > 0.0).then_some(wgt)
}

/// Squared distance of pixel `px` from the image centre, 1 at the corner (vignetting's r²).
fn radius2(cam: &crate::Camera, px: [f32; 2]) -> f32 {
    let (w, h) = (cam.width as f32, cam.height as f32);
    ((px[0] - w / 2.0).powi(2) + (px[1] - h / 2.0).powi(2)) / ((w * w + h * h) / 4.0)
}

/// Photo `i`'s sample of the point `p` (normal `n`) through `cam`, with its view weight; `None`
/// where the photo does not see it ([`weight`]).
fn sample_at(
    cam: &Prepared,
    photo: &Photo,
    i: usize,
    p: Vec3,
    n: Vec3,
    falloff: [f32; 2],
) -> Option<(Sample, f32)> {
    let (w, px) = weight(cam, p, n, falloff)?;
    let sample = Sample {
        photo: i,
        colour: photo.image.sample(px),
        r2: radius2(&cam.camera, [px.x as f32, px.y as f32]),
        view: (cam.centre - p.as_dvec3()).normalize().as_vec3(),
    };
    Some((sample, w))
}

/// Photo k's shading (per welded vertex, `shade`) times its vignetting, drawn in its own frame
/// by derma-render's rasteriser; 0 off the mesh.
fn shading_image(
    topo: &Topology,
    shade: &[[f32; 3]],
    cam: &crate::Camera,
    lighting: &Lighting,
    k: usize,
) -> RgbImage {
    let welded = TriMesh {
        positions: topo.positions.clone(),
        triangles: topo.triangles.clone(),
        ..Default::default()
    };
    let shade: Vec<Vec3> = shade.iter().map(|s| Vec3::from(*s)).collect();
    let w = cam.width as usize;
    let hits = cam.rasterise(&welded);
    let data = hits
        .par_iter()
        .enumerate()
        .map(|(i, hit)| match hit {
            Some(hit) => {
                let s = hit.interpolate(&welded, &shade);
                let px = [(i % w) as f32 + 0.5, (i / w) as f32 + 0.5];
                (s * lighting.vignette(k, radius2(cam, px))).to_array()
            }
            None => [0.0; 3],
        })
        .collect();
    RgbImage {
        width: w,
        height: cam.height as usize,
        data,
    }
}

/// Smoothing passes of [`level_views`]: about 4–5 rings of the mesh, 5–10 mm on a face.
pub const LEVEL_PASSES: usize = 24;

/// Seam levelling: each photo's de-lit colour at its vertices against the shared albedo, the ratio
/// smoothed over the mesh ([`LEVEL_PASSES`] passes of one-ring averaging: its low frequencies
/// only) and folded into that photo's shading, so that neighbouring regions from different
/// photos agree in level while each keeps its own detail. Each view's shading error (a shadow
/// edge a little off, a light the model does not hold) is its own, and would otherwise show as
/// a seam where the best view changes.
fn level_views(
    neighbours: &[Vec<u32>],
    samples: &[Vec<Sample>],
    albedo: &[[f32; 3]],
    weight: &[Vec<f32>],
    shade: Vec<Vec<[f32; 3]>>,
    vignette: impl Fn(usize, f32) -> f32 + Sync,
) -> Vec<Vec<[f32; 3]>> {
    let nv = samples.len();
    shade
        .into_par_iter()
        .enumerate()
        .map(|(k, mut sh)| {
            // The ratio albedo / de-lit colour where the photo sees the vertex and trusts it.
            let mut cur: Vec<Option<[f32; 3]>> = (0..nv)
                .map(|v| {
                    let x = samples[v].iter().find(|x| x.photo == k)?;
                    if weight[k][v] < 0.25 {
                        return None;
                    }
                    let f = vignette(k, x.r2);
                    let r: [f32; 3] = std::array::from_fn(|c| {
                        let unlit = x.colour[c] / (sh[v][c] * f);
                        if unlit > 1e-4 {
                            (albedo[v][c] / unlit).clamp(0.5, 2.0)
                        } else {
                            1.0
                        }
                    });
                    Some(r)
                })
                .collect();
            for _ in 0..LEVEL_PASSES {
                cur = (0..nv)
                    .map(|v| {
                        let (mut sum, mut n) = ([0.0f32; 3], 0usize);
                        for &u in std::iter::once(&(v as u32)).chain(&neighbours[v]) {
                            if let Some(r) = cur[u as usize] {
                                for c in 0..3 {
                                    sum[c] += r[c];
                                }
                                n += 1;
                            }
                        }
                        (n > 0).then(|| sum.map(|s| s / n as f32))
                    })
                    .collect();
            }
            for (s, r) in sh.iter_mut().zip(&cur) {
                if let Some(r) = r {
                    for c in 0..3 {
                        s[c] /= r[c];
                    }
                }
            }
            sh
        })
        .collect()
}

/// Gains of a de-lit photo outside this factor of 1 (either way) are far from 1: authored, three
/// stops of exposure or a white balance no camera makes; a lighting fit that needs them has
/// gone wrong.
pub const FAR_GAIN: f32 = 3.0;

/// The checks of the fits that could otherwise go wrong silently, each a warning naming the
/// photo and the figure: a registration refused for moving a camera beyond
/// [`RegisterOptions::max_shift_px`]; a lighting no model explained (the de-lighting already
/// kept the lighting); gains beyond [`FAR_GAIN`] (the lighting then kept: its fallback set).
fn check_fits(
    registration: &[Registration],
    delit: &mut Option<crate::delight::Delit>,
    photos: &[Photo],
    opts: &BakeOptions,
) -> Vec<String> {
    let mut warnings = Vec::new();
    if let (Some(r), false) = (opts.register, registration.iter().all(|g| g.kept)) {
        let worst = registration
            .iter()
            .enumerate()
            .max_by(|a, b| a.1.shift_px.total_cmp(&b.1.shift_px));
        if let Some((k, g)) = worst.filter(|(_, g)| g.shift_px > r.max_shift_px) {
            warnings.push(format!(
                "registration refused: photo '{}' would move {:.1} px, beyond the {:.1} px its clicks allow; the cameras are kept as calibrated",
                photos[k].name, g.shift_px, r.max_shift_px
            ));
        }
    }
    let Some(d) = delit.as_mut() else {
        return warnings;
    };
    if let Some(why) = &d.lighting.fallback {
        warnings.push(format!(
            "de-lighting: {why}; the lighting is kept (each photo's exposure and white balance only)"
        ));
        return warnings;
    }
    let far: Vec<String> = d
        .lighting
        .gains
        .iter()
        .zip(photos)
        .filter(|(g, _)| g.iter().any(|x| !(1.0 / FAR_GAIN..=FAR_GAIN).contains(x)))
        .map(|(g, p)| format!("'{}' {:.2} / {:.2} / {:.2}", p.name, g[0], g[1], g[2]))
        .collect();
    if !far.is_empty() {
        let why = format!(
            "gains beyond {FAR_GAIN}× either way ({}) under the model {}",
            far.join(", "),
            d.lighting.model_name
        );
        warnings.push(format!(
            "de-lighting: {why}; the lighting is kept (each photo's exposure and white balance only)"
        ));
        d.lighting.fallback = Some(why);
    }
    warnings
}

/// Vertex-to-photo binding (Rocchini et al. 1999 as in §3.2): bit i is set when vertex v
/// projects into photo i, faces it, is not on its silhouette (every triangle of its fan faces
/// the camera) and nothing lies between it and the camera (a ray from v, offset along its
/// normal, to the camera centre).
pub fn bind(
    topo: &Topology,
    normals: &[Vec3],
    photos: &[Photo],
    bvh: &Bvh,
    offset: f32,
) -> Vec<u32> {
    let n = topo.positions.len();
    let mut fan_ok = vec![u32::MAX; n];
    for t in &topo.triangles {
        let [a, b, c] = t.map(|i| topo.positions[i as usize]);
        let fnrm = (b - a).cross(c - a);
        let centre = (a + b + c) / 3.0;
        for (i, ph) in photos.iter().enumerate() {
            let cam = ph.camera.centre();
            if fnrm.as_dvec3().dot(cam - centre.as_dvec3()) <= 0.0 {
                for &v in t {
                    fan_ok[v as usize] &= !(1 << i);
                }
            }
        }
    }
    (0..n)
        .into_par_iter()
        .map(|v| {
            let p = topo.positions[v];
            let nrm = normals[v];
            let mut m = 0u32;
            for (i, ph) in photos.iter().enumerate() {
                if fan_ok[v] & (1 << i) == 0 {
                    continue;
                }
                let cam = ph.camera.centre();
                let to = cam - p.as_dvec3();
                if nrm.as_dvec3().dot(to) <= 0.0 {
                    continue;
                }
                let Some(px) = ph.camera.project(p.as_dvec3()) else {
                    continue;
                };
                if !ph.camera.in_image(px) {
                    continue;
                }
                let dist = to.length() as f32;
                let dir = (to / to.length()).as_vec3();
                let origin = p + nrm * offset;
                if !bvh.occluded(origin, dir, 0.0, dist) {
                    m |= 1 << i;
                }
            }
            m
        })
        .collect()
}

/// The one-ring colour fill of §3.2: unbound vertices take the mean colour of their coloured
/// neighbours once at least p = 80 %, then 60, 40, 20 % of the one-ring is coloured, and finally
/// any coloured neighbour will do; repeated at each p until nothing changes. Returns how many
/// vertices were filled.
pub fn fill_vertex_colors(neighbours: &[Vec<u32>], colors: &mut [Option<[f32; 3]>]) -> usize {
    let mut filled = 0;
    for p in [0.8f32, 0.6, 0.4, 0.2, 0.0] {
        loop {
            let mut changed = 0;
            // Gauss–Seidel order over vertices, as the paper loops over them.
            for v in 0..colors.len() {
                if colors[v].is_some() || neighbours[v].is_empty() {
                    continue;
                }
                let nb = &neighbours[v];
                let (mut sum, mut k) = ([0.0f32; 3], 0usize);
                for &w in nb {
                    if let Some(c) = colors[w as usize] {
                        for j in 0..3 {
                            sum[j] += c[j];
                        }
                        k += 1;
                    }
                }
                if k > 0 && k as f32 >= p * nb.len() as f32 {
                    colors[v] = Some(sum.map(|s| s / k as f32));
                    changed += 1;
                }
            }
            filled += changed;
            if changed == 0 {
                break;
            }
        }
    }
    filled
}

/// Resamples a UV-mapped mesh's texture from calibrated photos.
pub fn bake(
    mesh: &TriMesh,
    photos: &[Photo],
    opts: &BakeOptions,
    progress: &dyn Progress,
) -> Result<Baked> {
    check_inputs(mesh, photos, opts)?;
    let size = opts.size;
    let t0 = std::time::Instant::now();
    progress.stage("bind vertices to photos", 0, Unit::Steps);
    let welded = welded_geometry(mesh, opts)?;
    let topo = &welded.topo;
    let masks = bind(topo, &welded.normals, photos, &welded.bvh, welded.offset);
    let mut views = first_views(&welded, &masks, photos, opts);
    let mut fits = delight_and_register(&welded, &mut views, photos, opts, progress);
    let warnings = settle_fits(&mut fits, &mut views, photos, opts, progress)?;
    // The lighting as found, for the report; where it was kept, the bake goes on exactly as
    // with the lighting kept (Brown–Lowe gains, every sample trusted).
    let lighting = fits.delit.as_ref().map(|d| d.lighting.clone());
    if lighting.as_ref().is_some_and(|l| l.fallback.is_some()) {
        fits.delit = None;
    }
    let (samples, neighbours) = (&views.samples, &topo.neighbours);
    let cor = correction_of(fits.delit.as_ref(), samples, neighbours, photos.len(), opts);
    let (vcolor, unbound) = vertex_colours(samples, &views.view_weights, &cor, neighbours);
    drop(views.samples);
    let cams = views.cams;
    // Per triangle: the paper's case, and the best photo at its centroid (for the masks).
    let (tri_w, best, cases) = triangle_sources(mesh, topo, &masks, &cams, opts);
    let t_bind = t0.elapsed().as_secs_f64();
    progress.stage("resample texels", 0, Unit::Steps);
    let raster = UvRaster::new(mesh, size, size);
    let projected = projections(mesh, &welded, &cams);
    let (covered, dil) = gutter_sources(&raster, size)?;
    let r = Resampler {
        mesh,
        raster: &raster,
        dil: &dil,
        photos,
        cams: &cams,
        projected: &projected,
        masks: &masks,
        tri_w: &tri_w,
        best: &best,
        vcolor: &vcolor,
        cor: &cor,
        falloff: opts.falloff,
        size,
    };
    let (texture, source, t_resample) = blend(&r, topo.positions.len(), opts, progress, || {
        t0.elapsed().as_secs_f64() - t_bind
    });
    let (photo_reports, photo_coverage) = photo_reports(photos, &cor, &masks, &source, &covered);
    let report = BakeReport {
        photos: photo_reports,
        triangle_cases: cases,
        unbound_vertices: unbound,
        photo_coverage,
        lighting,
        registration: fits.registration,
        warnings,
        seconds: [
            t_bind,
            t_resample,
            t0.elapsed().as_secs_f64() - t_bind - t_resample,
        ],
    };
    Ok(Baked {
        shading: shading_images(topo, &cor, &cams, opts),
        texture: RgbImage {
            width: size,
            height: size,
            data: texture,
        },
        source,
        report,
    })
}

/// The welded mesh a bake works on: its topology, area-weighted normals (continuous across UV
/// seams), BVH, and the visibility rays' offset from the surface.
struct Welded {
    topo: Topology,
    normals: Vec<Vec3>,
    bvh: Bvh,
    offset: f32,
}

/// The welded mesh of a UV-mapped mesh ([`Welded`]), the ray offset scaled by its extent.
fn welded_geometry(mesh: &TriMesh, opts: &BakeOptions) -> Result<Welded> {
    let topo = Topology::new(mesh)?;
    // Area-weighted normals of the welded mesh (continuous across UV seams).
    let mut welded = TriMesh {
        positions: topo.positions.clone(),
        triangles: topo.triangles.clone(),
        ..Default::default()
    };
    welded.compute_normals();
    let normals = welded.normals;
    let bvh = Bvh::new(&topo.positions, &topo.triangles);
    let offset = opts.ray_offset * mesh.extent();
    Ok(Welded {
        topo,
        normals,
        bvh,
        offset,
    })
}

/// The cameras and, per welded vertex, its samples in the photos it is bound to, each with
/// that view's weight.
#[derive(Clone)]
struct Views {
    cams: Vec<Prepared>,
    samples: Vec<Vec<Sample>>,
    view_weights: Vec<Vec<f32>>,
}

/// The calibrated cameras, and each vertex sampled once in every photo it is bound to
/// (`masks`), with that view's weight.
fn first_views(welded: &Welded, masks: &[u32], photos: &[Photo], opts: &BakeOptions) -> Views {
    let cams: Vec<Prepared> = photos.iter().map(|p| Prepared::new(&p.camera)).collect();
    let (samples, view_weights): (Vec<Vec<Sample>>, Vec<Vec<f32>>) =
        (0..welded.topo.positions.len())
            .into_par_iter()
            .map(|v| {
                let p = welded.topo.positions[v];
                (0..photos.len())
                    .filter(|i| masks[v] & (1 << i) != 0)
                    .filter_map(|i| {
                        sample_at(&cams[i], &photos[i], i, p, welded.normals[v], opts.falloff)
                    })
                    .unzip()
            })
            .unzip();
    Views {
        cams,
        samples,
        view_weights,
    }
}

/// What de-lighting and registration found: the lighting, each photo's registration, and the
/// calibrated views while a correction is kept (should the lighting found after registration
/// not be trusted).
struct Fits {
    delit: Option<Delit>,
    registration: Vec<Registration>,
    calibrated: Option<Views>,
}

/// De-lighting on the mesh's shadowed SH transfer, then photometric registration ([`Fits`]).
fn delight_and_register(
    welded: &Welded,
    views: &mut Views,
    photos: &[Photo],
    opts: &BakeOptions,
    progress: &dyn Progress,
) -> Fits {
    // De-lighting: per photo and welded vertex, the shading to divide by and the robust weight.
    if opts.delight.is_some() {
        progress.stage("estimate the lighting", 0, Unit::Steps);
    }
    let (positions, normals, offset) = (&welded.topo.positions, &welded.normals, welded.offset);
    let transfer = transfer_of(welded, opts);
    let open = |v: usize, dir: Vec3| {
        !welded
            .bvh
            .occluded(positions[v] + normals[v] * offset, dir, 0.0, f32::MAX)
    };
    let surface = Surface {
        normals,
        transfer: &transfer,
        open: &open,
    };
    let mut delit = opts
        .delight
        .map(|d| estimate(&surface, &views.samples, photos.len(), &d));
    // Photometric registration on the de-lit photos: the cameras nudged so that the photos'
    // detail coincides, each vertex weighted as the blend weights it (view × robust weight);
    // where a correction is kept, every sample is taken again through its photo's refined
    // camera and the lighting estimated again, warm from the keys found (the misregistered
    // samples had blurred it: on issue 38's ground truth a key and the vignetting are found
    // only after registration).
    // Registration compares de-lit photos; where the lighting was kept (no model explained
    // it), their shadows would steer the cameras, so they stay as calibrated.
    let registration = register_stage(
        positions,
        (&views.samples, &views.view_weights),
        delit.as_ref(),
        photos,
        opts,
        progress,
    );
    // Kept for all photos or none.
    let kept = registration.first().is_some_and(|r| r.kept);
    // The calibrated cameras and their samples, should the lighting found after registration
    // not be trusted (the bake then goes on as with the lighting kept: calibrated cameras).
    let calibrated = kept.then(|| views.clone());
    if kept {
        views.cams = registration
            .iter()
            .map(|r| Prepared::new(&r.camera))
            .collect();
        retake_samples(
            (positions, normals),
            &views.cams,
            photos,
            opts,
            (&mut views.samples, &mut views.view_weights),
        );
        // Registration ran on the de-lit photos, so both are there.
        if let (Some(d), Some(first)) = (opts.delight, &delit) {
            progress.stage("estimate the lighting again", 0, Unit::Steps);
            delit = Some(relight(&surface, first, d, &views.samples, photos.len()));
        }
    }
    Fits {
        delit,
        registration,
        calibrated,
    }
}

/// The welded mesh's shadowed SH transfer ([`BakeOptions::transfer_side`]² rays per vertex)
/// for de-lighting; none with the lighting kept.
fn transfer_of(welded: &Welded, opts: &BakeOptions) -> Vec<[f32; derma_core::sh::SH9]> {
    match opts.delight {
        Some(_) => derma_core::sh::shadowed_transfer(
            &welded.topo.positions,
            &welded.normals,
            &welded.bvh,
            opts.transfer_side.max(1),
            welded.offset,
            0,
        ),
        None => Vec::new(),
    }
}

/// The lighting estimated again on the samples through the refined cameras, warm from the keys
/// `first` found.
fn relight(
    surface: &Surface,
    first: &Delit,
    d: DelightOptions,
    samples: &[Vec<Sample>],
    photos: usize,
) -> Delit {
    let keys: Vec<Option<Vec3>> = first
        .lighting
        .key_direction
        .iter()
        .map(|k| k.map(Vec3::from_array))
        .collect();
    // The model the photos chose stays (the cameras moved by a pixel or two), and so do
    // its candidates' scores.
    let d = DelightOptions {
        model: Some(first.lighting.model),
        ..d
    };
    let candidates = first.lighting.candidates.clone();
    let mut again = estimate_from(surface, samples, photos, &d, Some(&keys));
    again.lighting.candidates = candidates;
    again
}

/// The fits checked ([`check_fits`]); where the lighting found after registration is not
/// trusted, the calibrated views back and the registration undone. Each warning is noted, and
/// with [`BakeOptions::strict`] any warning refuses the bake.
fn settle_fits(
    fits: &mut Fits,
    views: &mut Views,
    photos: &[Photo],
    opts: &BakeOptions,
    progress: &dyn Progress,
) -> Result<Vec<String>> {
    let (registration, delit) = (&mut fits.registration, &mut fits.delit);
    let mut warnings = check_fits(registration, delit, photos, opts);
    if let (Some(c), true) = (
        fits.calibrated.take(),
        delit
            .as_ref()
            .is_some_and(|d| d.lighting.fallback.is_some()),
    ) {
        *views = c;
        for (r, p) in registration.iter_mut().zip(photos) {
            r.kept = false;
            r.camera = p.camera;
        }
        warnings.push(
            "the registration is undone with the lighting kept: the cameras as calibrated".into(),
        );
    }
    for w in &warnings {
        progress.note(Note::warning(w.clone()));
    }
    if opts.strict && !warnings.is_empty() {
        return Err(PhotoError::Strict(warnings.join("; ")));
    }
    Ok(warnings)
}

/// How a sample's colour is corrected: with de-lighting, divided by its photo's shading
/// (per welded vertex) and vignetting and trusted as far as `trust`; with the lighting kept,
/// multiplied by its photo's gain.
struct Correction<'a> {
    /// The lighting (`None` where it was kept).
    delit: Option<&'a Delit>,
    /// Per photo and channel ([`gains_of`]).
    gains: Vec<[f32; 3]>,
    /// Per photo and welded vertex: the shading to divide by (floored, levelled).
    shade: Vec<Vec<[f32; 3]>>,
    /// Per photo and welded vertex: the trust in that shading ([`shading_and_trust`]).
    trust: Vec<Vec<f32>>,
}

impl Correction<'_> {
    /// A sample's colour with the lighting (or the gain) taken out.
    fn unlit(&self, k: usize, v: usize, c: [f32; 3], r2: f32) -> [f32; 3] {
        match self.delit {
            Some(d) => {
                let f = d.lighting.vignette(k, r2);
                std::array::from_fn(|j| c[j] / (self.shade[k][v][j] * f))
            }
            None => std::array::from_fn(|j| c[j] * self.gains[k][j]),
        }
    }
}

/// The corrections of [`Correction`]: the gains, and where de-lit the shading and the trust
/// ([`shading_and_trust`]).
fn correction_of<'a>(
    delit: Option<&'a Delit>,
    samples: &[Vec<Sample>],
    neighbours: &[Vec<u32>],
    photos: usize,
    opts: &BakeOptions,
) -> Correction<'a> {
    let gains = gains_of(delit, samples, photos, opts);
    // Per photo and welded vertex: shading (floored) and robust weight.
    let (shade, trust) = match delit {
        Some(d) => shading_and_trust(d, samples, neighbours, photos),
        None => (Vec::new(), Vec::new()),
    };
    Correction {
        delit,
        gains,
        shade,
        trust,
    }
}

/// Vertex colours (case 2) and the fill (case 3), from the corrected samples, each weighted by
/// its view and robust weight; with the number of vertices the fill coloured.
fn vertex_colours(
    samples: &[Vec<Sample>],
    view_weights: &[Vec<f32>],
    cor: &Correction,
    neighbours: &[Vec<u32>],
) -> (Vec<[f32; 3]>, usize) {
    let mut vcolor: Vec<Option<[f32; 3]>> = samples
        .par_iter()
        .zip(view_weights)
        .enumerate()
        .map(|(v, (s, vw))| {
            let rw = |k: usize| cor.trust.get(k).map_or(1.0, |w| w[v]);
            let wsum: f32 = s.iter().zip(vw).map(|(x, w)| w * rw(x.photo)).sum();
            (wsum > 0.0).then(|| {
                let mut c = [0.0f32; 3];
                for (x, w) in s.iter().zip(vw) {
                    let u = cor.unlit(x.photo, v, x.colour, x.r2);
                    for k in 0..3 {
                        c[k] += u[k] * w * rw(x.photo) / wsum;
                    }
                }
                c
            })
        })
        .collect();
    let unbound = vcolor.iter().filter(|c| c.is_none()).count();
    fill_vertex_colors(neighbours, &mut vcolor);
    let vcolor = vcolor.into_iter().map(|c| c.unwrap_or([0.0; 3])).collect();
    (vcolor, unbound)
}

/// Each mesh vertex projected into each photo once, with ⟨N, V⟩ there; a texel's pixel and
/// cosine are interpolated from its triangle's corners. The projection is projective, not
/// affine, but across a 1–2 mm triangle at half a metre the difference is ~0.005 px.
fn projections(mesh: &TriMesh, welded: &Welded, cams: &[Prepared]) -> Vec<Vec<Option<Corner>>> {
    let vertex_normal = |v: usize| -> Vec3 {
        if mesh.normals.len() == mesh.positions.len() {
            mesh.normals[v]
        } else {
            welded.normals[welded.topo.weld[v] as usize]
        }
    };
    cams.iter()
        .map(|cam| {
            (0..mesh.positions.len())
                .into_par_iter()
                .map(|v| {
                    let p = mesh.positions[v].as_dvec3();
                    let px = cam.project(p)?;
                    let cos = vertex_normal(v)
                        .as_dvec3()
                        .dot((cam.centre - p).normalize());
                    Some(([px.x as f32, px.y as f32], cos as f32))
                })
                .collect()
        })
        .collect()
}

/// The texels a triangle covers, and each texel's dilation source (itself where covered, the
/// nearest covered texel in the gutter); an error where no triangle covers a texel.
fn gutter_sources(raster: &UvRaster, size: usize) -> Result<(Vec<bool>, Vec<u32>)> {
    let covered: Vec<bool> = raster.triangle.iter().map(|t| *t != NO_TRIANGLE).collect();
    let dil = dilation_sources(&covered, size, size).ok_or_else(|| {
        PhotoError::Mesh("no triangle covers a texel: are the UVs inside [0, 1]²?".into())
    })?;
    Ok((covered, dil))
}

/// What resampling reads: the mesh, its UV raster and the gutter's dilation sources, the photos
/// and their cameras (each mesh vertex projected once), the bindings, each triangle's welded
/// corners and best photo, the vertex colours and the corrections.
struct Resampler<'a> {
    mesh: &'a TriMesh,
    raster: &'a UvRaster,
    dil: &'a [u32],
    photos: &'a [Photo],
    cams: &'a [Prepared],
    projected: &'a [Vec<Option<Corner>>],
    masks: &'a [u32],
    tri_w: &'a [[u32; 3]],
    best: &'a [u8],
    vcolor: &'a [[f32; 3]],
    cor: &'a Correction<'a>,
    falloff: [f32; 2],
    size: usize,
}

/// The running sums of the weighted blend per texel, and each texel's source.
struct Sums {
    acc: Vec<[f32; 3]>,
    wsum: Vec<f32>,
    source: Vec<u8>,
}

impl Resampler<'_> {
    /// The vertex colours interpolated at texel `i` (inside a triangle).
    fn interpolate(&self, i: usize) -> [f32; 3] {
        let w = self.tri_w[self.raster.triangle[i] as usize];
        let [b1, b2] = self.raster.bary[i];
        let b0 = 1.0 - b1 - b2;
        let vc = self.vcolor;
        std::array::from_fn(|k| {
            vc[w[0] as usize][k] * b0 + vc[w[1] as usize][k] * b1 + vc[w[2] as usize][k] * b2
        })
    }

    /// The photos bound to all three corners of texel `i`'s triangle, a bit each.
    fn common_of(&self, i: usize) -> u32 {
        let w = self.tri_w[self.raster.triangle[i] as usize];
        self.masks[w[0] as usize] & self.masks[w[1] as usize] & self.masks[w[2] as usize]
    }

    /// Photo k's sample of texel `i`: (colour, weight, trust), trust the robust weight (1 with
    /// the lighting kept); `None` where the photo does not see it.
    fn sample(&self, i: usize, k: usize) -> Option<([f32; 3], f32, f32)> {
        let t = self.mesh.triangles[self.raster.triangle[i] as usize];
        let [b1, b2] = self.raster.bary[i];
        let projected = self.projected;
        let (c0, c1, c2) = (
            projected[k][t[0] as usize]?,
            projected[k][t[1] as usize]?,
            projected[k][t[2] as usize]?,
        );
        let b0 = 1.0 - b1 - b2;
        let cos = b0 * c0.1 + b1 * c1.1 + b2 * c2.1;
        let px = [0, 1].map(|a| b0 * c0.0[a] + b1 * c1.0[a] + b2 * c2.0[a]);
        let cam = &self.cams[k].camera;
        let mut w = texel_weight(cam, px, cos, self.falloff)?;
        let mut trust = 1.0;
        let c = self.photos[k]
            .image
            .sample(glam::DVec2::new(px[0] as f64, px[1] as f64));
        let cor = self.cor;
        let c = match cor.delit {
            Some(d) => {
                let wv = self.tri_w[self.raster.triangle[i] as usize];
                let b = [b0, b1, b2];
                let sh: [f32; 3] = std::array::from_fn(|j| {
                    (0..3).map(|q| cor.shade[k][wv[q] as usize][j] * b[q]).sum()
                });
                trust = (0..3)
                    .map(|q| cor.trust[k][wv[q] as usize] * b[q])
                    .sum::<f32>()
                    .min(1.0);
                w *= trust;
                let f = d.lighting.vignette(k, radius2(cam, px));
                std::array::from_fn(|j| c[j] / (sh[j] * f))
            }
            None => std::array::from_fn(|j| c[j] * cor.gains[k][j]),
        };
        (w > 0.0).then_some((c, w, trust))
    }

    /// Gutter texels (no triangle) take the value of their dilation source.
    fn dilate(&self, img: &mut [[f32; 3]]) {
        for (i, &s) in self.dil.iter().enumerate() {
            if s as usize != i {
                img[i] = img[s as usize];
            }
        }
    }

    /// The weighted blend of the photos per texel (§3.2 case 1) divided out of the sums into
    /// `out`, or the interpolated vertex colours where no photo sees (cases 2 and 3); `source`
    /// records which. Gutter texels take the value of their dilation source, computed there.
    fn finish_blend(
        &self,
        acc: &[[f32; 3]],
        wsum: &[f32],
        out: &mut [[f32; 3]],
        source: &mut [u8],
    ) {
        let (size, raster) = (self.size, self.raster);
        let blend_at = |i: usize| {
            if wsum[i] > 0.0 {
                acc[i].map(|a| a / wsum[i])
            } else {
                self.interpolate(i)
            }
        };
        out.par_chunks_mut(size)
            .zip(source.par_chunks_mut(size))
            .enumerate()
            .for_each(|(y, (row, srow))| {
                for x in 0..size {
                    let i = y * size + x;
                    if raster.triangle[i] == NO_TRIANGLE {
                        row[x] = blend_at(self.dil[i] as usize);
                        continue;
                    }
                    row[x] = blend_at(i);
                    srow[x] = if wsum[i] > 0.0 {
                        self.best[raster.triangle[i] as usize]
                    } else {
                        SOURCE_INTERPOLATED
                    };
                }
            });
    }

    /// Adds photo k's samples of row `y` to the sums; writes them (or the interpolated vertex
    /// colours where photo k does not see the texel) into `irow` when given.
    fn add_row(
        &self,
        k: usize,
        y: usize,
        arow: &mut [[f32; 3]],
        wrow: &mut [f32],
        mut irow: Option<&mut [[f32; 3]]>,
    ) {
        for x in 0..self.size {
            let i = y * self.size + x;
            if self.raster.triangle[i] == NO_TRIANGLE {
                continue;
            }
            let seen = if self.common_of(i) & (1 << k) != 0 {
                self.sample(i, k)
            } else {
                None
            };
            let c = match seen {
                Some((c, w, trust)) => {
                    for j in 0..3 {
                        arow[x][j] += c[j] * w;
                    }
                    wrow[x] += w;
                    // The spline image keeps what the photo is trusted with; a highlight or a
                    // deep shadow gives way to the vertices' robust colour.
                    if trust < 1.0 && irow.is_some() {
                        let v = self.interpolate(i);
                        std::array::from_fn(|j| trust * c[j] + (1.0 - trust) * v[j])
                    } else {
                        c
                    }
                }
                None if irow.is_some() => self.interpolate(i),
                None => continue,
            };
            if let Some(r) = irow.as_deref_mut() {
                r[x] = c;
            }
        }
    }

    /// Adds photo k's samples to the sums, row by row; writes its image into `img` when given
    /// ([`Self::add_row`]).
    fn add_photo(
        &self,
        k: usize,
        acc: &mut [[f32; 3]],
        wsum: &mut [f32],
        img: Option<&mut [[f32; 3]]>,
    ) {
        let size = self.size;
        let rows = acc.par_chunks_mut(size).zip(wsum.par_chunks_mut(size));
        match img {
            Some(img) => rows
                .zip(img.par_chunks_mut(size))
                .enumerate()
                .for_each(|(y, ((a, w), r))| self.add_row(k, y, a, w, Some(r))),
            None => rows
                .enumerate()
                .for_each(|(y, (a, w))| self.add_row(k, y, a, w, None)),
        }
    }
}

/// The texture and each texel's source: the weighted blend (§3.2; the photos' sums accumulated
/// photo by photo in photo order — the same sums whether one pass does all photos or each
/// photo's pass adds its own), or with [`BakeOptions::multiband`] and more than one photo the
/// multiresolution spline ([`spline_blend`]); with what `resample_time` reads once the photos
/// are resampled, before the spline (the resampling's seconds).
fn blend(
    r: &Resampler,
    vertices: usize,
    opts: &BakeOptions,
    progress: &dyn Progress,
    resample_time: impl Fn() -> f64,
) -> (Vec<[f32; 3]>, Vec<u8>, f64) {
    let n_tex = r.size * r.size;
    let mut sums = Sums {
        acc: derma_core::image::zeroed(n_tex),
        wsum: vec![0.0; n_tex],
        source: vec![SOURCE_NONE; n_tex],
    };
    let multiband = opts.multiband && r.photos.len() > 1;
    let mut texture: Vec<[f32; 3]> = derma_core::image::zeroed(n_tex);
    if !multiband {
        for k in 0..r.photos.len() {
            r.add_photo(k, &mut sums.acc, &mut sums.wsum, None);
        }
        r.finish_blend(&sums.acc, &sums.wsum, &mut texture, &mut sums.source);
    }
    let t_resample = resample_time();
    if multiband {
        progress.stage("multiresolution spline", 0, Unit::Steps);
        let label = spline_labels(r, vertices);
        let levels = opts
            .levels
            .unwrap_or_else(|| default_levels(r.size, r.size));
        spline_blend(r, &mut sums, &label, levels, &mut texture);
    }
    (texture, sums.source, t_resample)
}

/// Each texel's mask for the spline: its triangle's shrunk region, else the complement (the
/// last, the photos' count). A vertex is inside region r when all its triangles are best seen
/// from r; a triangle stays in r's mask when its three vertices are inside (the outmost ring
/// of triangles removed, §3.2).
fn spline_labels(r: &Resampler, vertices: usize) -> Vec<u8> {
    let photos = r.photos.len();
    let mut region = vec![u8::MAX - 1; vertices];
    for (t, &b) in r.tri_w.iter().zip(r.best) {
        for &v in t {
            let g = &mut region[v as usize];
            if *g == u8::MAX - 1 {
                *g = b;
            } else if *g != b {
                *g = u8::MAX;
            }
        }
    }
    let tri_mask: Vec<u8> = r
        .tri_w
        .iter()
        .zip(r.best)
        .map(|(t, &b)| {
            if (b as usize) < photos && t.iter().all(|&v| region[v as usize] == b) {
                b
            } else {
                SOURCE_INTERPOLATED
            }
        })
        .collect();
    (0..r.size * r.size)
        .into_par_iter()
        .map(|i| match r.raster.triangle[i] {
            NO_TRIANGLE => photos as u8,
            t => match tri_mask[t as usize] {
                m if (m as usize) < photos => m,
                _ => photos as u8,
            },
        })
        .collect()
}

/// The multiresolution spline (Burt & Adelson 1983) over the masks `label`, into `texture`
/// (clamped at 0, dilated into the gutter). One pass per photo: its image for the spline (its
/// own samples where it sees the texel, the interpolated vertex colours elsewhere, dilated into
/// the gutter) and its share of the blend; the last image is the finished blend (the
/// complement's image).
fn spline_blend(
    r: &Resampler,
    sums: &mut Sums,
    label: &[u8],
    levels: usize,
    texture: &mut [[f32; 3]],
) {
    let photos = r.photos.len();
    let mask = |k: usize, m: &mut Plane| {
        m.data
            .par_iter_mut()
            .zip(label)
            .for_each(|(v, l)| v[0] = (*l as usize == k) as u8 as f32);
    };
    let sums = std::cell::RefCell::new(sums);
    let out = multiband_with(
        r.size,
        r.size,
        photos + 1,
        levels,
        mask,
        |k, img: &mut Image<3>| {
            let mut s = sums.borrow_mut();
            let Sums { acc, wsum, source } = &mut **s;
            if k < photos {
                r.add_photo(k, acc, wsum, Some(&mut img.data));
            } else {
                r.finish_blend(acc, wsum, &mut img.data, source);
            }
            r.dilate(&mut img.data);
        },
    );
    for (t, o) in texture.iter_mut().zip(&out.data) {
        *t = o.map(|v| v.max(0.0));
    }
    r.dilate(texture);
}

/// Per photo: its gain, the vertices bound to it and its share of the chart's texels (those
/// `covered`) as the best view; with the share of the chart coloured from photos directly.
fn photo_reports(
    photos: &[Photo],
    cor: &Correction,
    masks: &[u32],
    source: &[u8],
    covered: &[bool],
) -> (Vec<PhotoReport>, f64) {
    let chart = covered.iter().filter(|c| **c).count().max(1);
    let photo_coverage = source
        .iter()
        .filter(|s| (**s as usize) < photos.len())
        .count() as f64
        / chart as f64;
    let reports = photos
        .iter()
        .enumerate()
        .map(|(i, p)| PhotoReport {
            name: p.name.clone(),
            gain: cor.delit.map_or(cor.gains[i], |d| d.lighting.gains[i]),
            bound_vertices: masks.iter().filter(|m| *m & (1 << i) != 0).count(),
            best_share: source.iter().filter(|s| **s as usize == i).count() as f64 / chart as f64,
        })
        .collect();
    (reports, photo_coverage)
}

/// Each photo's shading image ([`shading_image`]) with [`BakeOptions::shading_images`] and
/// de-lighting; else none.
fn shading_images(
    topo: &Topology,
    cor: &Correction,
    cams: &[Prepared],
    opts: &BakeOptions,
) -> Vec<RgbImage> {
    match (cor.delit, opts.shading_images) {
        (Some(d), true) => (0..cams.len())
            .map(|k| shading_image(topo, &cor.shade[k], &cams[k].camera, &d.lighting, k))
            .collect(),
        _ => Vec::new(),
    }
}

/// What a bake refuses before any work: no photos or more than [`MAX_PHOTOS`], a mesh without
/// UVs, a size outside 16–16384, a photo that does not match its camera.
fn check_inputs(mesh: &TriMesh, photos: &[Photo], opts: &BakeOptions) -> Result<()> {
    if photos.is_empty() {
        return Err(PhotoError::Invalid(derma_core::Invalid::new(
            "photos to bake from",
            "at least one",
            "none",
        )));
    }
    if photos.len() > MAX_PHOTOS {
        return Err(PhotoError::Invalid(derma_core::Invalid::new(
            "photos to bake from",
            format!("at most {MAX_PHOTOS} per bake"),
            photos.len(),
        )));
    }
    if mesh.uvs.len() != mesh.positions.len() {
        return Err(PhotoError::Mesh(
            "the mesh has no UVs; unwrap it first (derma photo unwrap)".into(),
        ));
    }
    if !(16..=16384).contains(&opts.size) {
        return Err(PhotoError::Invalid(derma_core::Invalid::new(
            "texture size",
            "16–16384",
            opts.size,
        )));
    }
    for p in photos {
        p.check()?;
    }
    Ok(())
}

/// Photometric registration on the de-lit photos ([`crate::register`]), each vertex weighted
/// as the blend weights it (view × robust weight); none where the lighting was kept (no model
/// explained it: the lit photos' shadows would steer the cameras) or with one photo.
fn register_stage(
    positions: &[Vec3],
    (samples, view_weights): (&[Vec<Sample>], &[Vec<f32>]),
    delit: Option<&crate::delight::Delit>,
    photos: &[Photo],
    opts: &BakeOptions,
    progress: &dyn Progress,
) -> Vec<Registration> {
    match (delit, opts.register) {
        (Some(d), Some(r)) if photos.len() >= 2 && d.lighting.fallback.is_none() => {
            progress.stage("register the photos", 0, Unit::Steps);
            let nv = positions.len();
            let mut wt = vec![vec![0.0f32; nv]; photos.len()];
            let mut sh = vec![vec![0.0f32; nv]; photos.len()];
            let shading: Vec<Vec<[f32; 3]>> = (0..photos.len()).map(|k| d.shadings(k)).collect();
            for (v, s) in samples.iter().enumerate() {
                for (a, x) in s.iter().enumerate() {
                    wt[x.photo][v] = view_weights[v][a] * d.weights[v][a];
                    sh[x.photo][v] = shading[x.photo][v].iter().sum::<f32>()
                        * d.lighting.vignette(x.photo, x.r2);
                }
            }
            let signals: Vec<Vec<Grey>> = photos
                .par_iter()
                .map(|p| luminance_pyramid(&p.image, r.levels))
                .collect();
            let cameras: Vec<Camera> = photos.iter().map(|p| p.camera).collect();
            register(
                positions,
                &|v, k| wt[k][v],
                &|v, k| sh[k][v],
                &cameras,
                &signals,
                &r,
            )
        }
        _ => Vec::new(),
    }
}

/// Each sample and its view weight again through the refined cameras; one a camera no longer
/// sees (off the image's edge) keeps no weight.
fn retake_samples(
    (positions, normals): (&[Vec3], &[Vec3]),
    cams: &[Prepared],
    photos: &[Photo],
    opts: &BakeOptions,
    (samples, view_weights): (&mut [Vec<Sample>], &mut [Vec<f32>]),
) {
    samples
        .par_iter_mut()
        .zip(view_weights.par_iter_mut())
        .enumerate()
        .for_each(|(v, (s, vw))| {
            let p = positions[v];
            for (x, w) in s.iter_mut().zip(vw.iter_mut()) {
                let i = x.photo;
                *w = match sample_at(&cams[i], &photos[i], i, p, normals[v], opts.falloff) {
                    Some((again, wt)) => {
                        *x = again;
                        wt
                    }
                    None => 0.0,
                };
            }
        });
}

/// Each photo's gain per channel: 1 where de-lit (the shading holds exposure and white
/// balance); else Brown–Lowe's over the vertices seen twice or more, or 1 without gains.
fn gains_of(
    delit: Option<&crate::delight::Delit>,
    samples: &[Vec<Sample>],
    photos: usize,
    opts: &BakeOptions,
) -> Vec<[f32; 3]> {
    match delit {
        // The shading holds exposure and white balance.
        Some(_) => vec![[1.0; 3]; photos],
        None if opts.gain_compensation => {
            // Sums in vertex order: the same gains at any thread count.
            let mut o = Overlaps::new(photos);
            for s in samples.iter().filter(|s| s.len() >= 2) {
                let pairs: Vec<(usize, [f32; 3])> = s.iter().map(|x| (x.photo, x.colour)).collect();
                o.add(&pairs);
            }
            crate::gain::unit_mean(o.gains())
        }
        None => vec![[1.0; 3]; photos],
    }
}

/// Per photo and welded vertex: the shading to divide by (floored at [`MIN_SHADING`] of the
/// photo's mean, levelled across views) and the trust in it (the robust weight times
/// (S / mean S)², up to 1: dividing a dim sample amplifies its noise and any error of the
/// shadow model).
fn shading_and_trust(
    d: &crate::delight::Delit,
    samples: &[Vec<Sample>],
    neighbours: &[Vec<u32>],
    photos: usize,
) -> (Vec<Vec<[f32; 3]>>, Vec<Vec<f32>>) {
    let nv = samples.len();
    // Per photo: the mean of per-vertex values over the vertices it sees.
    let mean_seen = |k: usize, val: &dyn Fn(usize) -> [f32; 3]| -> [f32; 3] {
        let (mut sum, mut n) = ([0.0f64; 3], 0usize);
        for (v, smp) in samples.iter().enumerate() {
            if smp.iter().any(|x| x.photo == k) {
                let x = val(v);
                for c in 0..3 {
                    sum[c] += x[c] as f64;
                }
                n += 1;
            }
        }
        sum.map(|s| (s / n.max(1) as f64) as f32)
    };
    let shade: Vec<Vec<[f32; 3]>> = (0..photos)
        .map(|k| {
            let raw = d.shadings(k);
            let mean = mean_seen(k, &|v| raw[v]);
            raw.iter()
                .map(|r| std::array::from_fn(|c| r[c].max(MIN_SHADING * mean[c])))
                .collect()
        })
        .collect();
    // Robust weights, times (S / mean S)² up to 1: dividing a dim sample amplifies its
    // noise and any error of the shadow model (the least-squares weight of I / S).
    let level: Vec<f32> = (0..photos)
        .map(|k| mean_seen(k, &|v| shade[k][v]).iter().sum())
        .collect();
    let mut wt = vec![vec![1.0f32; nv]; photos];
    for (v, (s, w)) in samples.iter().zip(&d.weights).enumerate() {
        for (x, w) in s.iter().zip(w) {
            let r = shade[x.photo][v].iter().sum::<f32>() / level[x.photo].max(1e-12);
            wt[x.photo][v] = *w * (r * r).min(1.0);
        }
    }
    let shade = level_views(neighbours, samples, &d.albedo, &wt, shade, |k, r2| {
        d.lighting.vignette(k, r2)
    });
    (shade, wt)
}

/// Per triangle: its welded corners, the best photo at its centroid (for the masks:
/// [`SOURCE_INTERPOLATED`] where no photo sees all three corners) and the counts of the
/// paper's three cases.
fn triangle_sources(
    mesh: &TriMesh,
    topo: &Topology,
    masks: &[u32],
    cams: &[Prepared],
    opts: &BakeOptions,
) -> (Vec<[u32; 3]>, Vec<u8>, [usize; 3]) {
    let tri_w: Vec<[u32; 3]> = mesh
        .triangles
        .iter()
        .map(|t| t.map(|i| topo.weld[i as usize]))
        .collect();
    let mut cases = [0usize; 3];
    let best: Vec<u8> = tri_w
        .iter()
        .map(|t| {
            let common = masks[t[0] as usize] & masks[t[1] as usize] & masks[t[2] as usize];
            if common != 0 {
                cases[0] += 1;
                let p = t.map(|v| topo.positions[v as usize]);
                let c = (p[0] + p[1] + p[2]) / 3.0;
                let n = (p[1] - p[0]).cross(p[2] - p[0]).normalize_or(Vec3::Z);
                let mut b = (SOURCE_INTERPOLATED, 0.0f32);
                for (i, cam) in cams.iter().enumerate() {
                    if common & (1 << i) != 0 {
                        if let Some((w, _)) = weight(cam, c, n, opts.falloff) {
                            if w > b.1 {
                                b = (i as u8, w);
                            }
                        }
                    }
                }
                b.0
            } else if t.iter().all(|&v| masks[v as usize] != 0) {
                cases[1] += 1;
                SOURCE_INTERPOLATED
            } else {
                cases[2] += 1;
                SOURCE_INTERPOLATED
            }
        })
        .collect();
    (tri_w, best, cases)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_fill_colours_every_vertex_of_a_connected_mesh() {
        // A path 0–1–2–3–4 with only vertex 0 coloured: all get its colour, in order.
        let nb: Vec<Vec<u32>> = vec![vec![1], vec![0, 2], vec![1, 3], vec![2, 4], vec![3]];
        let mut c = vec![Some([1.0, 0.5, 0.25]), None, None, None, None];
        let n = fill_vertex_colors(&nb, &mut c);
        assert_eq!(n, 4);
        assert!(c.iter().all(|x| *x == Some([1.0, 0.5, 0.25])));
    }

    #[test]
    fn the_fill_prefers_well_surrounded_vertices() {
        // Vertex 2 has 2 of 2 neighbours coloured (100 %): filled first with their mean.
        let nb: Vec<Vec<u32>> = vec![vec![2], vec![2], vec![0, 1]];
        let mut c = vec![Some([0.0; 3]), Some([1.0; 3]), None];
        fill_vertex_colors(&nb, &mut c);
        assert_eq!(c[2], Some([0.5; 3]));
    }
}

//! The generative model of the eye region (thesis §3.5–3.7): gaze and aperture g → eyelid shape
//! l = K L g (eq. 3.2) → skin motion u = u₀ + J M l (eq. 3.3), both principal components plus
//! multivariate linear regression; aperture normalisation (eqs. 3.6–3.7), the baseline aperture
//! model (eq. 3.11), cross-validated error against the number of components (fig. 3.7) and the
//! optimised per-vertex form ũ⁺ = Ũ W g̃ (eqs. 3.9–3.10).

use crate::gaze::{Gaze, EYE_INPUTS, PER_EYE};
use crate::lids::mid_height;
use crate::pca::Pca;
use crate::regression::Linear;
use crate::tracked::{Frame, Tracked};
use crate::{EyesError, Result};
use derma_core::numerics::robust::mad_sigma;
use glam::Vec2;
use serde::{Deserialize, Serialize};

/// Principal components kept (the thesis: 5 or 13 for the lids, 4 for the skin).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct Components {
    /// Eyelid shape components.
    pub lids: usize,
    /// Skin motion components (at most [`MAX_SKIN`]).
    pub skin: usize,
}

impl Default for Components {
    fn default() -> Self {
        Components { lids: 5, skin: 4 }
    }
}

/// Most skin components.
pub const MAX_SKIN: usize = 8;
/// Most coefficients (skin plus eyelid components) of the optimised per-vertex form.
pub const MAX_COEF: usize = 24;

/// A trained eye-region model.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct EyeModel {
    /// Action-unit names (inputs g₁₁…).
    pub units: Vec<String>,
    /// Control points per lid.
    pub lid_points: usize,
    /// Tracked vertices.
    pub vertices: usize,
    /// Height (mm) of each eye's closure plane: where the lids meet when closed.
    pub plane: [f32; 2],
    /// Lid displacements (g₄, g₅ per eye) of the most closed training frame, g^c.
    pub closed: [[f32; 2]; 2],
    /// Lid displacements of the most open training frame, g^o.
    pub open: [[f32; 2]; 2],
    /// Eyelid shape basis (K and the mean).
    pub lid_pca: Pca,
    /// L: g₁…₁₀ → eyelid coefficients.
    pub lid_map: Linear,
    /// Skin motion basis (J and u₀).
    pub skin_pca: Pca,
    /// M: (eyelid coefficients, action units) → skin coefficients e.
    pub skin_map: Linear,
    /// A per eye: [`baseline_features`] of (h, v) → normalised (upper, lower) opening at rest
    /// (eq. 3.11).
    pub baseline: [Linear; 2],
}

/// Inputs of the baseline aperture model: the thesis' A is linear in (h, v); real and rigged lids
/// respond differently to up- and downgaze (the upper lid follows both, the aperture is widest
/// near primary position), so derma regresses on the rectified angles (h, |h|, v⁺, v⁻), still a
/// linear least-squares model of eq. 3.11's form.
pub fn baseline_features(h: f64, v: f64) -> Vec<f64> {
    vec![h, h.abs(), v.max(0.0), v.min(0.0)]
}

/// Held-out error against the number of components (fig. 3.7).
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct Curve {
    /// Components 1, 2, ….
    pub components: Vec<usize>,
    /// Eyelid model: held-out Σ‖l̂ − l‖² / Σ‖l − l̄‖², per number of components.
    pub lids: Vec<f64>,
    /// Skin model (from the true lids): the same ratio for the tracked vertices.
    pub skin: Vec<f64>,
}

/// The closure plane of each eye: the mean lid height of its most closed frame.
fn planes(t: &Tracked) -> [f32; 2] {
    [0, 1].map(|e| {
        let f = t
            .frames
            .iter()
            .min_by(|a, b| opening(t, a, e).total_cmp(&opening(t, b, e)))
            .expect("validated: frames");
        0.5 * (mid_height(t.lid(f, e, 0)) + mid_height(t.lid(f, e, 1)))
    })
}

fn opening(t: &Tracked, f: &Frame, e: usize) -> f32 {
    mid_height(t.lid(f, e, 0)) - mid_height(t.lid(f, e, 1))
}

/// g of a frame: per eye (h, v, t, g₄ = upper height − plane, g₅ = lower height − plane), then
/// the units.
fn raw_inputs(t: &Tracked, f: &Frame, plane: [f32; 2]) -> Vec<f64> {
    let mut g = Vec::with_capacity(EYE_INPUTS + f.units.len());
    for e in 0..2 {
        let (up, lo) = (mid_height(t.lid(f, e, 0)), mid_height(t.lid(f, e, 1)));
        let a = f.gaze[e];
        g.extend([a.h, a.v, a.t, up - plane[e], lo - plane[e]].map(f64::from));
    }
    g.extend(f.units.iter().map(|&u| u as f64));
    g
}

/// One training row per frame: (g, lid control points, tracked vertices), flattened.
type Row = (Vec<f64>, Vec<f64>, Vec<f64>);

fn rows_of(t: &Tracked, plane: [f32; 2]) -> Vec<Row> {
    t.frames
        .iter()
        .map(|f| (raw_inputs(t, f, plane), flat(&f.lids), flat(&f.vertices)))
        .collect()
}

fn flat(p: &[Vec2]) -> Vec<f64> {
    p.iter().flat_map(|v| [v.x as f64, v.y as f64]).collect()
}

/// Sum of squared differences.
fn sq(a: &[f64], b: &[f64]) -> f64 {
    a.iter().zip(b).map(|(x, y)| (x - y) * (x - y)).sum()
}

struct Fitted {
    lid_pca: Pca,
    lid_map: Linear,
    skin_pca: Pca,
    skin_map: Linear,
}

/// Fits both stages on `rows` (g, lids, skin) with `c` components each.
fn fit_stages(rows: &[Row], c: Components) -> Result<Fitted> {
    let lids: Vec<Vec<f64>> = rows.iter().map(|r| r.1.clone()).collect();
    let skin: Vec<Vec<f64>> = rows.iter().map(|r| r.2.clone()).collect();
    let lid_pca = Pca::fit(&lids, c.lids)?;
    let skin_pca = Pca::fit(&skin, c.skin.min(MAX_SKIN))?;
    let g10: Vec<Vec<f64>> = rows.iter().map(|r| r.0[..EYE_INPUTS].to_vec()).collect();
    let lid_coef: Vec<Vec<f64>> = lids
        .iter()
        .map(|l| lid_pca.project(l, lid_pca.len()))
        .collect();
    let lid_map = Linear::fit(&g10, &lid_coef)?;
    let skin_in: Vec<Vec<f64>> = rows
        .iter()
        .zip(&lid_coef)
        .map(|(r, lc)| lc.iter().chain(&r.0[EYE_INPUTS..]).copied().collect())
        .collect();
    let skin_coef: Vec<Vec<f64>> = skin
        .iter()
        .map(|s| skin_pca.project(s, skin_pca.len()))
        .collect();
    let skin_map = Linear::fit(&skin_in, &skin_coef)?;
    Ok(Fitted {
        lid_pca,
        lid_map,
        skin_pca,
        skin_map,
    })
}

impl EyeModel {
    /// Trains the model on tracked data.
    pub fn fit(t: &Tracked, c: Components) -> Result<EyeModel> {
        if c.lids == 0 || c.skin == 0 || c.skin > MAX_SKIN || c.lids + c.skin > MAX_COEF {
            return Err(derma_core::Invalid::new(
                "lid and skin components",
                format!("at least 1 each, at most {MAX_SKIN} for the skin and {MAX_COEF} together"),
                format!("lids {} and skin {}", c.lids, c.skin),
            )
            .into());
        }
        let plane = planes(t);
        let rows = rows_of(t, plane);
        // Eq. 3.6: ι = |g₄ − g₅| + |g₉ − g₁₀|; the most open frame has the largest ι, the most
        // closed the smallest (the thesis' text swaps the two words; its meaning is this). The
        // sign is kept: rigs and real lids overlap when squeezed shut, and a frame whose lids
        // just touch mid-blink is less closed than one where they overlap.
        let iota = |g: &[f64]| (g[3] - g[4]) + (g[8] - g[9]);
        let by = |better: fn(f64, f64) -> bool| {
            rows.iter()
                .map(|r| &r.0)
                .fold(None::<&Vec<f64>>, |best, g| match best {
                    Some(b) if !better(iota(g), iota(b)) => Some(b),
                    _ => Some(g),
                })
                .expect("frames")
        };
        let gc = by(|a, b| a < b);
        let closed = [0, 1].map(|e| [gc[e * PER_EYE + 3] as f32, gc[e * PER_EYE + 4] as f32]);
        // g^o per component: the most open value each lid reaches (highest upper lid, lowest
        // lower lid). The thesis takes both from the single most open frame; in rigs and real
        // faces the lower lid barely moves between blink and wide-eyed frames (it moves in
        // downgaze and squint), which would make its normalisation divide by almost nothing.
        let open = [0, 1].map(|e| {
            let up = rows
                .iter()
                .map(|r| r.0[e * PER_EYE + 3])
                .fold(f64::MIN, f64::max);
            let lo = rows
                .iter()
                .map(|r| r.0[e * PER_EYE + 4])
                .fold(f64::MAX, f64::min);
            [up as f32, lo as f32]
        });
        let mut open = open;
        for e in 0..2 {
            let travel = [0, 1].map(|k| (open[e][k] - closed[e][k]).abs());
            if travel[0].max(travel[1]) < 0.3 {
                return Err(derma_core::Invalid::new(
                    format!(
                        "the {} lids' travel between the most closed and the most open frame",
                        ["left", "right"][e]
                    ),
                    "at least 0.3 mm (the data needs a blink, eye closed, and open eyes)",
                    format!("{:.2} mm at most", travel[0].max(travel[1])),
                )
                .into());
            }
            // A lid that barely moves in the data (the built-in rig's lower lid: 0.1 mm)
            // borrows the other lid's travel, so its g̃ stays on a comparable scale.
            for k in 0..2 {
                if travel[k] < 0.3 {
                    let s = if k == 0 { 1.0 } else { -1.0 };
                    open[e][k] = closed[e][k] + s * travel[1 - k];
                }
            }
        }
        let f = fit_stages(&rows, c)?;
        let mut model = EyeModel {
            units: t.units.clone(),
            lid_points: t.lid_points,
            vertices: t.vertex_count(),
            plane,
            closed,
            open,
            lid_pca: f.lid_pca,
            lid_map: f.lid_map,
            skin_pca: f.skin_pca,
            skin_map: f.skin_map,
            baseline: [0, 1].map(|_| Linear {
                inputs: 4,
                w: vec![vec![0.0, 0.0, 0.0, 0.0, 1.0]; 2],
            }),
        };
        model.baseline = [0, 1]
            .map(|e| model.fit_baseline(t, &rows, e))
            .into_iter()
            .collect::<Result<Vec<_>>>()?
            .try_into()
            .expect("two eyes");
        Ok(model)
    }

    /// A of eq. 3.11 for eye `e`: normalised openings of the baseline frames from (h, v), with
    /// one pass that drops frames more than 3 robust σ off (partial blinks in real captures).
    fn fit_baseline(&self, t: &Tracked, rows: &[Row], e: usize) -> Result<Linear> {
        let mut xs = Vec::new();
        let mut ys = Vec::new();
        for (f, r) in t.frames.iter().zip(rows) {
            if f.baseline {
                let g = &r.0[e * PER_EYE..(e + 1) * PER_EYE];
                xs.push(baseline_features(g[0], g[1]));
                ys.push(
                    self.normalise_lids(e, [g[3] as f32, g[4] as f32])
                        .map(f64::from)
                        .to_vec(),
                );
            }
        }
        if xs.len() < 4 {
            return Err(derma_core::Invalid::new(
                "baseline frames (eyes at rest)",
                "at least 4 for the aperture model",
                xs.len(),
            )
            .into());
        }
        let a = Linear::fit(&xs, &ys)?;
        let res: Vec<f64> = xs
            .iter()
            .zip(&ys)
            .map(|(x, y)| sq(&a.apply(x), y).sqrt())
            .collect();
        let mad = mad_sigma(&mut res.clone()).expect("a fit has samples");
        let keep: Vec<usize> = (0..xs.len())
            .filter(|&i| res[i] <= 3.0 * mad.max(1e-6))
            .collect();
        if keep.len() == xs.len() || keep.len() < 4 {
            return Ok(a);
        }
        let xs2: Vec<Vec<f64>> = keep.iter().map(|&i| xs[i].clone()).collect();
        let ys2: Vec<Vec<f64>> = keep.iter().map(|&i| ys[i].clone()).collect();
        Linear::fit(&xs2, &ys2)
    }

    /// Eq. 3.7 inverted: lid displacements (mm) → normalised openings g̃ (0 closed, 1 open).
    pub fn normalise_lids(&self, e: usize, g: [f32; 2]) -> [f32; 2] {
        [0, 1].map(|k| (g[k] - self.closed[e][k]) / (self.open[e][k] - self.closed[e][k]))
    }

    /// Eq. 3.7: normalised openings → lid displacements (mm).
    pub fn denormalise_lids(&self, e: usize, n: [f32; 2]) -> [f32; 2] {
        [0, 1].map(|k| self.closed[e][k] + (self.open[e][k] - self.closed[e][k]) * n[k])
    }

    /// Eq. 3.11: the normalised (upper, lower) opening of eye `e` at gaze (h, v)°, scaled by the
    /// closing factor c (1 at rest, 0 closed, above 1 wide).
    pub fn baseline_aperture(&self, e: usize, h: f32, v: f32, c: f32) -> [f32; 2] {
        let a = self.baseline[e].apply(&baseline_features(h as f64, v as f64));
        // Scaling by c acts on the opening about the closure plane: c = 0 closes both lids.
        [(c as f64 * a[0]) as f32, (c as f64 * a[1]) as f32]
    }

    /// The palpebral opening (mm) of eye `e` that the baseline model predicts at gaze (h, v).
    pub fn baseline_opening_mm(&self, e: usize, h: f32, v: f32) -> f32 {
        let d = self.denormalise_lids(e, self.baseline_aperture(e, h, v, 1.0));
        d[0] - d[1]
    }

    /// Raw g from the normalised g̃ (eq. 3.7 on the lid entries).
    pub fn raw(&self, g: &Gaze) -> Vec<f64> {
        let mut x = g.inputs();
        for e in 0..2 {
            let d = self.denormalise_lids(e, g.lids[e]);
            x[e * PER_EYE + 3] = d[0] as f64;
            x[e * PER_EYE + 4] = d[1] as f64;
        }
        x
    }

    /// Eyelid coefficients l̈ = L g and control points l = K l̈ (eq. 3.2) from raw g.
    pub fn lids_raw(&self, g: &[f64]) -> (Vec<f64>, Vec<f64>) {
        let c = self.lid_map.apply(&g[..EYE_INPUTS]);
        let l = self.lid_pca.reconstruct(&c);
        (c, l)
    }

    /// Skin coefficients e = M (l̈, units) and positions u = u₀ + J e (eq. 3.3).
    pub fn skin_raw(&self, lid_coef: &[f64], units: &[f64]) -> (Vec<f64>, Vec<f64>) {
        let x: Vec<f64> = lid_coef.iter().chain(units).copied().collect();
        let e = self.skin_map.apply(&x);
        let u = self.skin_pca.reconstruct(&e);
        (e, u)
    }

    /// The whole model on normalised input: lid control points and tracked-vertex positions.
    pub fn predict(&self, g: &Gaze) -> (Vec<Vec2>, Vec<Vec2>) {
        let raw = self.raw(g);
        let (c, l) = self.lids_raw(&raw);
        let (_, u) = self.skin_raw(&c, &raw[EYE_INPUTS..]);
        (pairs(&l), pairs(&u))
    }

    /// The normalised g̃ of a tracked frame (what a user would have animated to get it).
    pub fn gaze_of(&self, t: &Tracked, f: &Frame) -> Gaze {
        let g = raw_inputs(t, f, self.plane);
        Gaze {
            eyes: f.gaze,
            lids: [0, 1].map(|e| {
                self.normalise_lids(e, [g[e * PER_EYE + 3] as f32, g[e * PER_EYE + 4] as f32])
            }),
            units: f.units.clone(),
        }
    }

    /// W of eq. 3.10 as one affine map g̃ → e (normalisation, L, K's coefficients and M
    /// pre-multiplied).
    pub fn w(&self) -> Linear {
        let ni = EYE_INPUTS + self.units.len();
        // N: g̃ → g (eq. 3.7), identity except the lid entries.
        let mut n = Linear {
            inputs: ni,
            w: (0..ni)
                .map(|i| {
                    let mut r = vec![0.0; ni + 1];
                    r[i] = 1.0;
                    r
                })
                .collect(),
        };
        for e in 0..2 {
            for k in 0..2 {
                let i = e * PER_EYE + 3 + k;
                n.w[i][i] = (self.open[e][k] - self.closed[e][k]) as f64;
                n.w[i][ni] = self.closed[e][k] as f64;
            }
        }
        // S: g → (l̈, units): L on the first ten inputs, the units passed through.
        let mut s = Linear {
            inputs: ni,
            w: Vec::new(),
        };
        for r in &self.lid_map.w {
            let mut row = vec![0.0; ni + 1];
            row[..EYE_INPUTS].copy_from_slice(&r[..EYE_INPUTS]);
            row[ni] = r[EYE_INPUTS];
            s.w.push(row);
        }
        for u in 0..self.units.len() {
            let mut row = vec![0.0; ni + 1];
            row[EYE_INPUTS + u] = 1.0;
            s.w.push(row);
        }
        self.skin_map.after(&s.after(&n))
    }

    /// W extended with the eyelid coefficients: g̃ → (e, l̈), so lid control points can serve
    /// as extrapolation sources beside the tracked vertices.
    fn w_with_lids(&self) -> Linear {
        let mut w = self.w();
        let ni = EYE_INPUTS + self.units.len();
        for r in &self.lid_map.w {
            // l̈ = L g on the first ten inputs, composed with the lid normalisation (eq. 3.7).
            let mut row = vec![0.0; ni + 1];
            row[..EYE_INPUTS].copy_from_slice(&r[..EYE_INPUTS]);
            row[ni] = r[EYE_INPUTS];
            for e in 0..2 {
                for k in 0..2 {
                    let i = e * PER_EYE + 3 + k;
                    let (c, o) = (self.closed[e][k] as f64, self.open[e][k] as f64);
                    row[ni] += row[i] * c;
                    row[i] *= o - c;
                }
            }
            w.w.push(row);
        }
        w
    }

    /// The optimised model of eqs. 3.9–3.10 over the tracked vertices, extended to untracked
    /// ones by `extrapolate` (eq. 3.5): each row lists (source, weight) where sources are the
    /// tracked vertices, then the 4 × `lid_points` lid control points (the lid curves are
    /// tracked too, and they are what the inner margins follow).
    pub fn optimised(&self, extrapolate: &[Vec<(u32, f32)>]) -> Optimised {
        let (ks, kl) = (self.skin_pca.len(), self.lid_pca.len());
        let k = ks + kl;
        let nt = self.vertices;
        let nl = 4 * self.lid_points;
        let stride = 2 * (k + 1);
        // Sources: tracked vertices (skin part), then control points (lid part).
        let mut src = vec![0.0f32; (nt + nl) * stride];
        for i in 0..nt {
            let b = &mut src[i * stride..(i + 1) * stride];
            b[0] = self.skin_pca.mean[2 * i] as f32;
            b[1] = self.skin_pca.mean[2 * i + 1] as f32;
            for c in 0..ks {
                b[2 + 2 * c] = self.skin_pca.components[c][2 * i] as f32;
                b[3 + 2 * c] = self.skin_pca.components[c][2 * i + 1] as f32;
            }
        }
        for j in 0..nl {
            let b = &mut src[(nt + j) * stride..(nt + j + 1) * stride];
            b[0] = self.lid_pca.mean[2 * j] as f32;
            b[1] = self.lid_pca.mean[2 * j + 1] as f32;
            for c in 0..kl {
                b[2 + 2 * (ks + c)] = self.lid_pca.components[c][2 * j] as f32;
                b[3 + 2 * (ks + c)] = self.lid_pca.components[c][2 * j + 1] as f32;
            }
        }
        let mut basis = src[..nt * stride].to_vec();
        for row in extrapolate {
            let mut acc = vec![0.0f32; stride];
            for &(s, w) in row {
                let s = &src[s as usize * stride..(s as usize + 1) * stride];
                for (a, v) in acc.iter_mut().zip(s) {
                    *a += w * v;
                }
            }
            basis.extend_from_slice(&acc);
        }
        Optimised {
            w: self.w_with_lids(),
            k,
            basis,
        }
    }

    /// Reads a model written by [`EyeModel::write`].
    pub fn read(path: &std::path::Path) -> Result<EyeModel> {
        let text = std::fs::read_to_string(path).map_err(|e| EyesError::Model {
            path: path.to_path_buf(),
            detail: format!("cannot read: {e}"),
        })?;
        serde_json::from_str(&text).map_err(|e| EyesError::Model {
            path: path.to_path_buf(),
            detail: format!("not a derma eye model: {e}"),
        })
    }

    /// Writes the model as JSON, atomically.
    pub fn write(&self, path: &std::path::Path) -> Result<()> {
        derma_core::report::write_json(path, self, derma_core::report::JsonFormat::DATA)?;
        Ok(())
    }
}

fn pairs(v: &[f64]) -> Vec<Vec2> {
    v.chunks_exact(2)
        .map(|c| Vec2::new(c[0] as f32, c[1] as f32))
        .collect()
}

/// The per-vertex form ũ⁺ = Ũ e, e = W g̃: a small matrix on the CPU, then 2(k + 1) numbers per
/// vertex (the thesis evaluates this part in the vertex shader).
#[derive(Clone, Debug)]
pub struct Optimised {
    /// W: g̃ → e.
    pub w: Linear,
    /// Coefficients: skin components, then eyelid components.
    pub k: usize,
    /// Per vertex: u₀ then the k component columns (x, y each).
    pub basis: Vec<f32>,
}

impl Optimised {
    /// e = W g̃.
    pub fn coefficients(&self, g: &Gaze) -> [f32; MAX_COEF] {
        let e = self.w.apply(&g.inputs());
        let mut out = [0.0; MAX_COEF];
        for (o, v) in out.iter_mut().zip(e) {
            *o = v as f32;
        }
        out
    }

    /// ũ⁺ = Ũ e for every vertex, into `out`.
    pub fn evaluate(&self, e: &[f32; MAX_COEF], out: &mut [Vec2]) {
        let stride = 2 * (self.k + 1);
        for (u, b) in out.iter_mut().zip(self.basis.chunks_exact(stride)) {
            let (mut x, mut y) = (b[0], b[1]);
            for c in 0..self.k {
                x += e[c] * b[2 + 2 * c];
                y += e[c] * b[3 + 2 * c];
            }
            *u = Vec2::new(x, y);
        }
    }

    /// Number of vertices.
    pub fn len(&self) -> usize {
        self.basis.len() / (2 * (self.k + 1))
    }

    /// True without vertices.
    pub fn is_empty(&self) -> bool {
        self.basis.is_empty()
    }
}

/// Deterministic fold of frame `i` among `folds` (a fixed permutation by a multiplicative hash,
/// so consecutive frames of a sequence fall in different folds).
fn fold_of(i: usize, folds: usize) -> usize {
    ((i as u64).wrapping_mul(0x9E37_79B9_7F4A_7C15) >> 40) as usize % folds
}

/// Cross-validated error against the number of components (fig. 3.7): `folds`-fold, up to
/// `max` components for each model.
pub fn cross_validate(t: &Tracked, max: Components, folds: usize) -> Result<Curve> {
    let rows = rows_of(t, planes(t));
    let kmax = max.lids.max(max.skin).min(MAX_SKIN.max(max.lids));
    let mut lid_num = vec![0.0; kmax];
    let mut lid_den = 0.0;
    let mut skin_num = vec![0.0; kmax];
    let mut skin_den = 0.0;
    for fold in 0..folds {
        let train: Vec<_> = rows
            .iter()
            .enumerate()
            .filter(|(i, _)| fold_of(*i, folds) != fold)
            .map(|(_, r)| r.clone())
            .collect();
        let test: Vec<_> = rows
            .iter()
            .enumerate()
            .filter(|(i, _)| fold_of(*i, folds) == fold)
            .map(|(_, r)| r)
            .collect();
        if test.is_empty() || train.len() < 3 {
            continue;
        }
        let f = fit_stages(
            &train,
            Components {
                lids: max.lids,
                skin: max.skin.min(MAX_SKIN),
            },
        )?;
        // Per component count: refit the regressions on the first k coefficients (each
        // coefficient's regression is independent, so truncating rows is the same fit).
        for r in &test {
            lid_den += sq(&r.1, &f.lid_pca.mean);
            skin_den += sq(&r.2, &f.skin_pca.mean);
            let lc = f.lid_map.apply(&r.0[..EYE_INPUTS]);
            let true_lc = f.lid_pca.project(&r.1, f.lid_pca.len());
            let x: Vec<f64> = true_lc.iter().chain(&r.0[EYE_INPUTS..]).copied().collect();
            let sc = f.skin_map.apply(&x);
            for k in 1..=kmax {
                if k <= f.lid_pca.len() {
                    lid_num[k - 1] += sq(&f.lid_pca.reconstruct(&lc[..k]), &r.1);
                }
                if k <= f.skin_pca.len() {
                    skin_num[k - 1] += sq(&f.skin_pca.reconstruct(&sc[..k]), &r.2);
                }
            }
        }
    }
    let nl = max.lids.min(kmax);
    let ns = max.skin.min(MAX_SKIN).min(kmax);
    Ok(Curve {
        components: (1..=kmax).collect(),
        lids: lid_num[..nl]
            .iter()
            .map(|n| n / lid_den.max(1e-300))
            .collect(),
        skin: skin_num[..ns]
            .iter()
            .map(|n| n / skin_den.max(1e-300))
            .collect(),
    })
}

/// Training-set error of both models with k components each (the same ratios as [`Curve`]).
pub fn training_error(t: &Tracked, k: usize) -> Result<(f64, f64)> {
    let rows = rows_of(t, planes(t));
    let f = fit_stages(
        &rows,
        Components {
            lids: k,
            skin: k.min(MAX_SKIN),
        },
    )?;
    let (mut ln, mut ld, mut sn, mut sd) = (0.0, 0.0, 0.0, 0.0);
    for r in &rows {
        let lc = f.lid_map.apply(&r.0[..EYE_INPUTS]);
        ln += sq(&f.lid_pca.reconstruct(&lc), &r.1);
        ld += sq(&r.1, &f.lid_pca.mean);
        let true_lc = f.lid_pca.project(&r.1, f.lid_pca.len());
        let x: Vec<f64> = true_lc.iter().chain(&r.0[EYE_INPUTS..]).copied().collect();
        sn += sq(&f.skin_pca.reconstruct(&f.skin_map.apply(&x)), &r.2);
        sd += sq(&r.2, &f.skin_pca.mean);
    }
    Ok((ln / ld.max(1e-300), sn / sd.max(1e-300)))
}

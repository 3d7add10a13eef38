//! Fitting a render model to a sampled BRDF (thesis §4.6–4.7): minimise the discretised squared
//! difference over (θi, θo, Δφ) bins, by simulated annealing over the shape parameters with the
//! linear weights solved exactly at every step (variable projection; Golub & Pereyra 1973), then
//! a Levenberg–Marquardt polish of all parameters together.
//!
//! The model is averaged over each bin (2×2×2 Gauss–Legendre points in sinθi, sin²θo and φ, the
//! measures the Monte Carlo tallies bins with), so bins are compared like for like.

use crate::annealing::{anneal, Schedule};
use crate::render_model::{bounds, combine, n_params, Basis, Dirs, RenderModel, MAX_LOBES};
use derma_core::numerics::{levenberg_marquardt, nnls_normal, LmOptions};
use derma_optics::tally::BrdfBins;
use std::f64::consts::{FRAC_PI_2, PI};

/// How bins are weighted in the squared difference.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Weighting {
    /// cosθi · cosθo: the error in reflected radiance a renderer shows (it multiplies f by
    /// cosθi, and a surface seen at θo is foreshortened by cosθo). Grazing bins, where the
    /// Monte Carlo is noisiest and no model's asymptotics are exact, count for less. Default.
    Cosine,
    /// Every bin alike: the thesis' integral over dζi dζr dα (§4.6) taken literally.
    Uniform,
}

impl Weighting {
    /// The weighting's command-line name.
    pub fn name(self) -> &'static str {
        match self {
            Weighting::Cosine => "cosine",
            Weighting::Uniform => "uniform",
        }
    }
}

/// Fits use every bin, grazing ones included: the Monte Carlo skin's surface is a Smith
/// microsurface (derma-optics' `microsurface.rs`), whose BRDF conserves energy at every angle.
/// The cut-off stays a parameter — 80° (as Ngan, Matusik & Durand 2005 do with measured data)
/// was needed while the surface was the thesis' unmasked one, whose grazing bins grow as 1/cosθ
/// where every render model with a masking term goes to zero.
pub const DEFAULT_MAX_ZENITH_DEG: f64 = 90.0;

/// Gauss–Legendre 2-point nodes on [0, 1].
const GL2: [f64; 2] = [0.211_324_865_405_187_1, 0.788_675_134_594_812_9];
/// Quadrature points per bin.
pub const POINTS_PER_BIN: usize = 8;

/// Directions and weights for a bin layout, shared by every entry of a table.
pub struct FitGeometry {
    /// The BRDF bins of the precompute table.
    pub bins: BrdfBins,
    /// How bins count in the residual.
    pub weighting: Weighting,
    /// Bins whose incident or outgoing zenith centre lies beyond this (degrees) get weight 0.
    pub max_zenith_deg: f64,
    /// `POINTS_PER_BIN` direction pairs per bin.
    dirs: Vec<Dirs>,
    /// Per-bin weight, Σ = 1.
    weight: Vec<f64>,
}

impl FitGeometry {
    /// Bins with both zenith centres up to [`DEFAULT_MAX_ZENITH_DEG`].
    pub fn new(bins: BrdfBins, weighting: Weighting) -> Self {
        Self::with_cutoff(bins, weighting, DEFAULT_MAX_ZENITH_DEG)
    }

    /// The geometry of `bins`, leaving out bins whose centre lies beyond `max_zenith_deg` (90°: none).
    pub fn with_cutoff(bins: BrdfBins, weighting: Weighting, max_zenith_deg: f64) -> Self {
        let (ni, no, np) = (bins.theta_in, bins.theta_out, bins.phi);
        let mut dirs = Vec::with_capacity(bins.len() * POINTS_PER_BIN);
        let mut weight = Vec::with_capacity(bins.len());
        for ti in 0..ni {
            let (a, b) = (
                (ti as f64 * FRAC_PI_2 / ni as f64).sin(),
                ((ti + 1) as f64 * FRAC_PI_2 / ni as f64).sin(),
            );
            for to in 0..no {
                let (c, d) = (
                    (to as f64 * FRAC_PI_2 / no as f64).sin().powi(2),
                    ((to + 1) as f64 * FRAC_PI_2 / no as f64).sin().powi(2),
                );
                for p in 0..np {
                    let (e, f) = (p as f64 * PI / np as f64, (p + 1) as f64 * PI / np as f64);
                    for gi in GL2 {
                        let theta_i = (a + (b - a) * gi).asin();
                        for go in GL2 {
                            let theta_o = (c + (d - c) * go).sqrt().asin();
                            for gp in GL2 {
                                dirs.push(Dirs::from_angles(theta_i, theta_o, e + (f - e) * gp));
                            }
                        }
                    }
                    let ci = ((ti as f64 + 0.5) * FRAC_PI_2 / ni as f64).cos();
                    let co = ((to as f64 + 0.5) * FRAC_PI_2 / no as f64).cos();
                    let zi = (ti as f64 + 0.5) * 90.0 / ni as f64;
                    let zo = (to as f64 + 0.5) * 90.0 / no as f64;
                    let keep = zi <= max_zenith_deg && zo <= max_zenith_deg;
                    weight.push(match (keep, weighting) {
                        (false, _) => 0.0,
                        (true, Weighting::Cosine) => ci * co,
                        (true, Weighting::Uniform) => 1.0,
                    });
                }
            }
        }
        let s: f64 = weight.iter().sum();
        weight.iter_mut().for_each(|w| *w /= s);
        Self {
            bins,
            weighting,
            max_zenith_deg,
            dirs,
            weight,
        }
    }

    /// Number of bins.
    pub fn len(&self) -> usize {
        self.weight.len()
    }

    /// True without bins.
    pub fn is_empty(&self) -> bool {
        self.weight.is_empty()
    }

    /// Bin-averaged basis of `model` at shape `theta`.
    pub fn basis(&self, model: &dyn RenderModel, theta: &[f64], out: &mut [Basis]) {
        self.basis_where(model, theta, out, false)
    }

    /// As [`Self::basis`]; with `fit_only`, bins of weight 0 are skipped (left zero).
    fn basis_where(
        &self,
        model: &dyn RenderModel,
        theta: &[f64],
        out: &mut [Basis],
        fit_only: bool,
    ) {
        let inv = 1.0 / POINTS_PER_BIN as f64;
        for (b, o) in out.iter_mut().enumerate() {
            if fit_only && self.weight[b] == 0.0 {
                *o = Basis::default();
                continue;
            }
            let mut acc = Basis::default();
            for d in &self.dirs[b * POINTS_PER_BIN..(b + 1) * POINTS_PER_BIN] {
                let x = model.basis(theta, d);
                acc.offset += x.offset;
                acc.diffuse += x.diffuse;
                for k in 0..MAX_LOBES {
                    acc.lobes[k] += x.lobes[k];
                }
            }
            acc.offset *= inv;
            acc.diffuse *= inv;
            acc.lobes.iter_mut().for_each(|v| *v *= inv);
            *o = acc;
        }
    }

    /// The sampled BRDF of `model` with full parameters `params` (bin averages, RGB).
    pub fn sample(&self, model: &dyn RenderModel, params: &[f64]) -> Vec<[f64; 3]> {
        let nl = model.lobes().len();
        let mut b = vec![Basis::default(); self.len()];
        self.basis(model, &params[3 + nl..], &mut b);
        b.iter().map(|x| combine(x, params, nl)).collect()
    }
}

/// Fit settings.
#[derive(Clone, Copy, Debug)]
pub struct FitOptions {
    /// The annealing over shape parameters.
    pub schedule: Schedule,
    /// The Levenberg–Marquardt polish after it.
    pub lm: LmOptions,
    /// Seed of the annealing's random steps.
    pub seed: u64,
}

impl Default for FitOptions {
    fn default() -> Self {
        Self {
            schedule: Schedule::default(),
            lm: LmOptions::default(),
            seed: 1,
        }
    }
}

/// A fitted model.
#[derive(Clone, Debug, PartialEq)]
pub struct BrdfFit {
    /// Full parameter vector ([`crate::render_model::param_names`]).
    pub params: Vec<f64>,
    /// Weighted RMS difference (sr⁻¹) over bins and channels.
    pub rms: f64,
    /// `rms` relative to the weighted RMS of the data.
    pub relative_rms: f64,
}

/// Optimal non-negative linear weights for bin-averaged `basis` against `data`; returns the
/// weights (kd_r, kd_g, kd_b, s_1..s_K) and the weighted squared error.
fn linear_weights(basis: &[Basis], data: &[[f64; 3]], w: &[f64], nl: usize) -> (Vec<f64>, f64) {
    let n = 3 + nl;
    let mut ata = vec![0.0; n * n];
    let mut atb = vec![0.0; n];
    for ((b, y), &wb) in basis.iter().zip(data).zip(w) {
        for c in 0..3 {
            let t = y[c] - b.offset;
            ata[c * n + c] += wb * b.diffuse * b.diffuse;
            atb[c] += wb * b.diffuse * t;
            for k in 0..nl {
                ata[c * n + 3 + k] += wb * b.diffuse * b.lobes[k];
                atb[3 + k] += wb * b.lobes[k] * t;
                for j in 0..nl {
                    ata[(3 + k) * n + 3 + j] += wb * b.lobes[k] * b.lobes[j];
                }
            }
        }
    }
    for c in 0..3 {
        for k in 0..nl {
            ata[(3 + k) * n + c] = ata[c * n + 3 + k];
        }
    }
    let x = nnls_normal(&ata, &atb, n);
    let cost = basis
        .iter()
        .zip(data)
        .zip(w)
        .map(|((b, y), &wb)| {
            let f = combine(b, &x, nl);
            (0..3).map(|c| wb * (f[c] - y[c]).powi(2)).sum::<f64>()
        })
        .sum();
    (x, cost)
}

fn warp(p: &crate::render_model::ShapeParam, u: f64) -> f64 {
    if p.log {
        (p.lo.ln() + (p.hi.ln() - p.lo.ln()) * u).exp()
    } else {
        p.lo + (p.hi - p.lo) * u
    }
}

/// Fits `model` to `data` (one RGB value per bin of `geom`). `stream` separates the annealing
/// random numbers of different entries.
pub fn fit_brdf(
    model: &dyn RenderModel,
    geom: &FitGeometry,
    data: &[[f64; 3]],
    opts: &FitOptions,
    stream: u32,
) -> BrdfFit {
    assert_eq!(data.len(), geom.len(), "one RGB value per bin");
    let shape = model.shape();
    let nl = model.lobes().len();
    let np = n_params(model);
    let mut basis = vec![Basis::default(); geom.len()];
    // 1. Anneal over the shape parameters, linear weights solved exactly.
    let mut cost_u = |u: &[f64]| -> f64 {
        let theta: Vec<f64> = shape.iter().zip(u).map(|(p, &x)| warp(p, x)).collect();
        geom.basis_where(model, &theta, &mut basis, true);
        linear_weights(&basis, data, &geom.weight, nl).1
    };
    let start = vec![0.5; shape.len()];
    let (u, _) = anneal(&mut cost_u, &start, opts.schedule, opts.seed, stream);
    let theta: Vec<f64> = shape.iter().zip(&u).map(|(p, &x)| warp(p, x)).collect();
    geom.basis_where(model, &theta, &mut basis, true);
    let (lin, _) = linear_weights(&basis, data, &geom.weight, nl);
    let mut p0 = lin;
    p0.extend_from_slice(&theta);

    // 2. Levenberg–Marquardt on everything. Residuals √w (f − y); linear columns analytic,
    //    shape columns by forward differences of the basis.
    let (lo, hi) = bounds(model);
    let sw: Vec<f64> = geom.weight.iter().map(|w| w.sqrt()).collect();
    let m = 3 * geom.len();
    let mut bplus = vec![Basis::default(); geom.len()];
    let mut residuals = |p: &[f64], r: &mut [f64], jac: Option<&mut [f64]>| {
        geom.basis_where(model, &p[3 + nl..], &mut basis, true);
        for (b, ((x, y), s)) in basis.iter().zip(data).zip(&sw).enumerate() {
            let f = combine(x, p, nl);
            for c in 0..3 {
                r[b * 3 + c] = s * (f[c] - y[c]);
            }
        }
        let Some(j) = jac else { return };
        j.iter_mut().for_each(|v| *v = 0.0);
        for (b, (x, s)) in basis.iter().zip(&sw).enumerate() {
            for c in 0..3 {
                let row = (b * 3 + c) * np;
                j[row + c] = s * x.diffuse;
                for k in 0..nl {
                    j[row + 3 + k] = s * x.lobes[k];
                }
            }
        }
        for (t, sp) in shape.iter().enumerate() {
            let mut th = p[3 + nl..].to_vec();
            let h = 1e-6 * (sp.hi - sp.lo).max(th[t].abs());
            let h = if th[t] + h > sp.hi { -h } else { h };
            th[t] += h;
            geom.basis_where(model, &th, &mut bplus, true);
            for (b, ((x0, x1), s)) in basis.iter().zip(&bplus).zip(&sw).enumerate() {
                let f0 = combine(x0, p, nl);
                let f1 = combine(x1, p, nl);
                for c in 0..3 {
                    j[(b * 3 + c) * np + 3 + nl + t] = s * (f1[c] - f0[c]) / h;
                }
            }
        }
    };
    let (p, cost) = levenberg_marquardt(&mut residuals, &p0, &lo, &hi, m, opts.lm);
    let data_sq: f64 = data
        .iter()
        .zip(&geom.weight)
        .map(|(y, w)| w * (y[0] * y[0] + y[1] * y[1] + y[2] * y[2]))
        .sum();
    BrdfFit {
        rms: (cost / 3.0).sqrt(),
        relative_rms: (cost / data_sq.max(1e-300)).sqrt(),
        params: p,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model_kind::ModelKind;

    fn bins() -> BrdfBins {
        BrdfBins {
            theta_in: 9,
            theta_out: 9,
            phi: 12,
        }
    }

    /// A BRDF generated by a model is recovered by fitting the same model (within 1 %).
    #[test]
    fn recovers_parameters_of_its_own_model() {
        let geom = FitGeometry::new(bins(), Weighting::Cosine);
        let truth: [(ModelKind, Vec<f64>); 4] = [
            (ModelKind::Ggx, vec![0.55, 0.35, 0.25, 0.62, 0.035]),
            (
                ModelKind::AshikhminShirley,
                vec![0.55, 0.35, 0.25, 12.0, 0.06],
            ),
            (ModelKind::Kelemen, vec![0.55, 0.35, 0.25, 0.6, 0.35]),
            (
                ModelKind::SkinDualLobe,
                vec![0.55, 0.35, 0.25, 0.3, 0.7, 0.4, 0.2, 0.8, 0.5],
            ),
        ];
        for (kind, p) in truth {
            let m = kind.model();
            let data = geom.sample(m, &p);
            let fit = fit_brdf(m, &geom, &data, &FitOptions::default(), 3);
            for (i, (a, b)) in fit.params.iter().zip(&p).enumerate() {
                assert!(
                    ((a - b) / b).abs() < 0.01,
                    "{}: parameter {i} {a} vs {b} (all {:?})",
                    kind.name(),
                    fit.params
                );
            }
            assert!(
                fit.relative_rms < 1e-3,
                "{}: {}",
                kind.name(),
                fit.relative_rms
            );
        }
    }

    #[test]
    fn weights_sum_to_one_and_favour_normal_incidence() {
        let g = FitGeometry::new(bins(), Weighting::Cosine);
        assert!((g.weight.iter().sum::<f64>() - 1.0).abs() < 1e-12);
        assert!(g.weight[0] > g.weight[g.len() - 1]);
        // By default every bin counts, the grazing ones too, each alike under uniform weights.
        let all = FitGeometry::new(bins(), Weighting::Uniform);
        assert!(all
            .weight
            .iter()
            .all(|&w| (w - all.weight[0]).abs() < 1e-15));
        // An 80° cut-off keeps bin (θi 75°, θo 75°, last φ) at bin 0's weight and drops θo 85°.
        let u = FitGeometry::with_cutoff(bins(), Weighting::Uniform, 80.0);
        assert!((u.weight[0] - u.weight[bins().index(7, 7, 11)]).abs() < 1e-15);
        assert_eq!(u.weight[bins().index(7, 8, 11)], 0.0);
    }

    #[test]
    fn bin_average_of_a_lambertian_is_exact() {
        // Lambert kd/π is constant: bin averages equal it everywhere.
        let g = FitGeometry::new(bins(), Weighting::Cosine);
        let s = g.sample(ModelKind::Kelemen.model(), &[0.5, 0.5, 0.5, 0.0, 0.3]);
        for v in s {
            assert!((v[0] - 0.5 / PI).abs() < 1e-12);
        }
    }
}

//! A layered turbid slab as the transport sees it at one wavelength: per layer thickness,
//! absorption (split by chromophore), scattering, Henyey–Greenstein anisotropy and index.

use crate::error::{OpticsError, Result};

/// Number of absorber classes tallied separately.
pub const N_ABSORBERS: usize = 5;
/// Names of the absorber classes, in tally order. A plain slab puts all its absorption in
/// `medium` (index 4, shared with the skin's baseline tissue absorption).
pub const ABSORBER_NAMES: [&str; N_ABSORBERS] = [
    "eumelanin",
    "pheomelanin",
    "oxyhemoglobin",
    "deoxyhemoglobin",
    "baseline",
];
/// Index of the absorber class a plain slab uses.
pub const MEDIUM: usize = 4;

/// One homogeneous layer. Lengths in mm, coefficients in mm⁻¹.
#[derive(Clone, Debug, PartialEq)]
pub struct Layer {
    /// Thickness in mm.
    pub thickness_mm: f64,
    /// Absorption coefficient μa (mm⁻¹).
    pub mua: f64,
    /// Scattering coefficient μs (mm⁻¹).
    pub mus: f64,
    /// Henyey–Greenstein anisotropy g ∈ (−1, 1).
    pub g: f64,
    /// Refractive index.
    pub n: f64,
    /// Share of μa per absorber class (sums to 1 where μa > 0).
    pub absorber_share: [f64; N_ABSORBERS],
}

impl Layer {
    /// A layer whose absorption is all `medium`.
    pub fn plain(thickness_mm: f64, mua: f64, mus: f64, g: f64, n: f64) -> Self {
        let mut absorber_share = [0.0; N_ABSORBERS];
        absorber_share[MEDIUM] = 1.0;
        Self {
            thickness_mm,
            mua,
            mus,
            g,
            n,
            absorber_share,
        }
    }

    /// Extinction μt = μa + μs.
    pub fn mut_(&self) -> f64 {
        self.mua + self.mus
    }
}

/// What lies below the last layer.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Bottom {
    /// A semi-infinite clear medium: light crossing into it is transmitted.
    Medium {
        /// Its refractive index.
        n: f64,
    },
    /// A diffusely (Lambertian) reflecting surface of this albedo, BioSpec's white hypodermis
    /// (thesis §2.1); what it does not reflect counts as transmitted.
    Lambertian {
        /// Its albedo.
        albedo: f64,
    },
}

/// The top surface between the ambient medium and the first layer.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Surface {
    /// A flat interface.
    Smooth,
    /// Micro-facets with normals drawn by the thesis' Trowbridge–Reitz formula (§4.5.1), as
    /// BioSpec does: no shadowing or masking, normals not weighted by their visible area.
    TrowbridgeReitz {
        /// Their aspect ratio σ.
        sigma: f64,
    },
    /// A Smith microsurface with Trowbridge–Reitz (GGX) normals of roughness α: visible
    /// normals, shadowing and masking, and the light masking catches scattered again
    /// ([`crate::microsurface`]).
    Smith {
        /// GGX α (the spheroids' aspect ratio).
        alpha: f64,
    },
}

/// A stack of layers at one wavelength.
#[derive(Clone, Debug, PartialEq)]
pub struct Stack {
    /// The layers, top first.
    pub layers: Vec<Layer>,
    /// Index of the medium above (1 for air).
    pub n_above: f64,
    /// What lies below the last layer.
    pub bottom: Bottom,
    /// The top surface.
    pub surface: Surface,
}

impl Stack {
    /// Checks every value; the error names the layer and field.
    pub fn validate(&self) -> Result<()> {
        if self.layers.is_empty() {
            return Err(OpticsError::Invalid(derma_core::Invalid::new(
                "layers of a stack",
                "at least one",
                "none",
            )));
        }
        if self.layers.len() > crate::MAX_LAYERS {
            return Err(OpticsError::Invalid(derma_core::Invalid::new(
                "layers of a stack",
                format!("at most {}", crate::MAX_LAYERS),
                self.layers.len(),
            )));
        }
        let check = |ok: bool, what: String, expected: &str, got: String| {
            if ok {
                Ok(())
            } else {
                Err(OpticsError::Invalid(derma_core::Invalid::new(
                    what, expected, got,
                )))
            }
        };
        for (i, l) in self.layers.iter().enumerate() {
            let k = i + 1;
            check(
                l.thickness_mm.is_finite() && l.thickness_mm > 0.0,
                format!("layer {k} thickness"),
                "a finite value > 0",
                format!("{} mm", l.thickness_mm),
            )?;
            check(
                l.mua.is_finite() && l.mua >= 0.0,
                format!("layer {k} absorption μa"),
                "a finite value ≥ 0",
                format!("{} mm⁻¹", l.mua),
            )?;
            check(
                l.mus.is_finite() && l.mus >= 0.0,
                format!("layer {k} scattering μs"),
                "a finite value ≥ 0",
                format!("{} mm⁻¹", l.mus),
            )?;
            check(
                l.g.is_finite() && l.g > -1.0 && l.g < 1.0,
                format!("layer {k} anisotropy g"),
                "a value in (−1, 1)",
                l.g.to_string(),
            )?;
            check(
                l.n.is_finite() && (1.0..=3.0).contains(&l.n),
                format!("layer {k} refractive index n"),
                "a value in [1, 3]",
                l.n.to_string(),
            )?;
        }
        check(
            self.n_above.is_finite() && (1.0..=3.0).contains(&self.n_above),
            "refractive index n above the stack".into(),
            "a value in [1, 3]",
            self.n_above.to_string(),
        )?;
        match self.bottom {
            Bottom::Medium { n } => check(
                n.is_finite() && (1.0..=3.0).contains(&n),
                "refractive index n below the stack".into(),
                "a value in [1, 3]",
                n.to_string(),
            )?,
            Bottom::Lambertian { albedo } => check(
                (0.0..=1.0).contains(&albedo),
                "bottom albedo".into(),
                "a value in [0, 1]",
                albedo.to_string(),
            )?,
        }
        if let Surface::TrowbridgeReitz { sigma: a } | Surface::Smith { alpha: a } = self.surface {
            check(
                a.is_finite() && a > 0.0 && a <= 1.0,
                "surface aspect ratio σ".into(),
                "a value in (0, 1]",
                a.to_string(),
            )?;
        }
        Ok(())
    }

    /// Depth of the top of each layer and of the bottom of the stack (mm).
    pub fn boundaries(&self) -> Vec<f64> {
        let mut z = vec![0.0];
        for l in &self.layers {
            z.push(z.last().copied().unwrap_or(0.0) + l.thickness_mm);
        }
        z
    }
}

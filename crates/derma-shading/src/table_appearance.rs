//! The Monte Carlo appearance: bio parameters → base colour and subsurface parameters through a
//! model-match table (thesis §4.8.6, mmd), multilinear in the grid's hypercube. This is the
//! texture-set path, so the table is compiled to a compact f32 form for 16-megapixel maps.

use crate::appearance::{Appearance, BioTexel, Subsurface};
use crate::error::{Result, ShadingError};
use crate::match_table::MatchTable;
use crate::render_model::ModelKind;
use std::path::Path;

/// Values kept per node: base colour (3), subsurface colour (3), scatter distance (3).
const N: usize = 9;
const MAX_AXES: usize = 6;

/// The committed default table (see docs/matching.md for the command that rebuilds it).
pub const BUILTIN_TABLE: &[u8] = include_bytes!("../data/match-table.dtab");

/// Where the base colour comes from.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum BaseColor {
    /// kd of the fitted glTF GGX model: what a glTF/Unreal/Unity metallic-roughness material
    /// needs to reproduce the simulated BRDF's diffuse part.
    GgxFit,
    /// The Monte Carlo diffuse reflectance under diffuse light.
    DiffuseAlbedo,
}

/// An [`Appearance`] backed by a match table.
pub struct TableAppearance {
    /// (BioTexel field index, node positions, stride in nodes) of axes with ≥ 2 nodes.
    active: Vec<(usize, Vec<f32>, usize)>,
    values: Vec<[f32; N]>,
    pub base: BaseColor,
}

impl TableAppearance {
    /// Compiles `table`; the base colour from the GGX fit when the table has one.
    pub fn new(table: &MatchTable) -> Result<Self> {
        let h = &table.dtab.header;
        let base = if h.offset(ModelKind::Ggx.name()).is_some() {
            BaseColor::GgxFit
        } else {
            BaseColor::DiffuseAlbedo
        };
        let need = |name: &str| {
            h.offset(name)
                .ok_or_else(|| ShadingError::Invalid(format!("match table has no value '{name}'")))
        };
        let (ob, _) = match base {
            BaseColor::GgxFit => need(ModelKind::Ggx.name())?,
            BaseColor::DiffuseAlbedo => need("albedo")?,
        };
        let (oc, _) = need("burley.albedo")?;
        let (or, _) = need("burley.mfp_mm")?;
        let stride = h.stride();
        let values = (0..h.nodes())
            .map(|n| {
                let row = &table.dtab.data[n * stride..(n + 1) * stride];
                let mut v = [0.0; N];
                v[0..3].copy_from_slice(&row[ob..ob + 3]);
                v[3..6].copy_from_slice(&row[oc..oc + 3]);
                v[6..9].copy_from_slice(&row[or..or + 3]);
                v
            })
            .collect();
        let mut strides = vec![1usize; h.axes.len()];
        for k in (0..h.axes.len().saturating_sub(1)).rev() {
            strides[k] = strides[k + 1] * h.axes[k + 1].values.len();
        }
        let mut active = Vec::new();
        for (field, name) in crate::match_table::BIO_AXES.iter().enumerate() {
            let k = h
                .axes
                .iter()
                .position(|a| a.name == *name)
                .expect("checked");
            let a = &h.axes[k];
            if a.values.len() >= 2 {
                active.push((
                    field,
                    a.values.iter().map(|&x| x as f32).collect(),
                    strides[k],
                ));
            }
        }
        Ok(Self {
            active,
            values,
            base,
        })
    }

    /// The committed default table.
    pub fn builtin() -> Self {
        let dtab =
            derma_core::dtab::Dtab::from_bytes(BUILTIN_TABLE, Path::new("<built-in match table>"))
                .expect("the built-in match table is valid");
        let t = MatchTable::new(dtab, Path::new("<built-in match table>"))
            .expect("the built-in match table is a match table");
        Self::new(&t).expect("the built-in match table has the values")
    }

    pub fn read(path: &Path) -> Result<Self> {
        Self::new(&MatchTable::read(path)?)
    }

    /// All nine values at `bio`.
    #[inline]
    pub fn lookup(&self, bio: &BioTexel) -> [f32; N] {
        let f = [
            bio.melanin,
            bio.pheomelanin,
            bio.blood,
            bio.oxygenation,
            bio.stratum_corneum_um,
            bio.epidermis_um,
        ];
        let d = self.active.len();
        let mut base = 0usize;
        let mut t = [0.0f32; MAX_AXES];
        let mut step = [0usize; MAX_AXES];
        for (k, (field, nodes, stride)) in self.active.iter().enumerate() {
            let x = f[*field];
            let n = nodes.len();
            let (i, w) = if !(x > nodes[0]) {
                (0, 0.0)
            } else if x >= nodes[n - 1] {
                (n - 2, 1.0)
            } else {
                let mut i = 0;
                while nodes[i + 1] <= x {
                    i += 1;
                }
                (i, (x - nodes[i]) / (nodes[i + 1] - nodes[i]))
            };
            base += i * stride;
            t[k] = w;
            step[k] = *stride;
        }
        let mut out = [0.0f32; N];
        for mask in 0..(1usize << d) {
            let mut w = 1.0f32;
            let mut idx = base;
            for k in 0..d {
                if mask >> k & 1 == 1 {
                    w *= t[k];
                    idx += step[k];
                } else {
                    w *= 1.0 - t[k];
                }
            }
            if w != 0.0 {
                let v = &self.values[idx];
                for j in 0..N {
                    out[j] += w * v[j];
                }
            }
        }
        out
    }
}

impl Appearance for TableAppearance {
    fn name(&self) -> &'static str {
        "match-table"
    }
    fn albedo(&self, bio: &BioTexel) -> [f32; 3] {
        let v = self.lookup(bio);
        [v[0], v[1], v[2]]
    }
    fn subsurface(&self, bio: &BioTexel) -> Option<Subsurface> {
        self.shade(bio).1
    }
    fn shade(&self, bio: &BioTexel) -> ([f32; 3], Option<Subsurface>) {
        let v = self.lookup(bio);
        (
            [v[0], v[1], v[2]],
            Some(Subsurface {
                color: [v[3], v[4], v[5]],
                radius_mm: [v[6], v[7], v[8]],
            }),
        )
    }
}

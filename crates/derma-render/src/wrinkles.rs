//! Expression wrinkles at draw time (Jimenez et al. 2011, masks and per-region weights; the
//! eye-region thesis §3.9 blends wrinkle maps in the fragment shader by expression weights):
//! the set's rest normal and its normal with every furrow at full activation, blended per texel
//! by the activation m = clamp(Σ_r w_r · mask_r, 0, 1) ([`derma_head::wrinkle_regions`]):
//! n = normalize(lerp(n_rest, n_wrinkled, m)), the blend engines apply to wrinkle normal maps.

use crate::error::{RenderError, Result};
use crate::material::files;
use derma_core::Map;
use derma_head::wrinkle_regions::{self, COUNT, REGIONS};
use std::path::Path;

/// A texture set's expression-wrinkle maps.
#[derive(Clone, Debug)]
pub struct WrinkleMaps {
    /// `wrinkle_normal.png`: n·½ + ½ with every furrow at full activation.
    pub normal: [Map; 3],
    /// `wrinkle_masks.exr`: one mask per [`REGIONS`] entry, in that order.
    pub masks: Vec<Map>,
}

impl WrinkleMaps {
    /// Reads the maps of the texture set in `dir`; `None` when the set has none (written
    /// before expression wrinkles, or on a surface without landmarks).
    pub fn from_dir(dir: &Path) -> Result<Option<WrinkleMaps>> {
        let (np, mp) = (
            dir.join(files::WRINKLE_NORMAL),
            dir.join(files::WRINKLE_MASKS),
        );
        if !np.is_file() || !mp.is_file() {
            return Ok(None);
        }
        let img = derma_core::image_io::read_rgb(&np)?;
        let mut it = img.channels.into_iter();
        let normal = [0, 1, 2].map(|_| it.next().expect("rgb"));
        let mut channels = derma_core::image_io::read_exr_channels(&mp)?;
        let masks = REGIONS
            .iter()
            .map(|r| {
                let k = channels
                    .iter()
                    .position(|(n, _)| n == r.name)
                    .ok_or_else(|| {
                        crate::RenderError::from(derma_core::CoreError::Format {
                            path: mp.clone(),
                            message: format!(
                                "has no channel '{}'; expected one per wrinkle region ({})",
                                r.name,
                                REGIONS.map(|r| r.name).join(", ")
                            ),
                        })
                    })?;
                Ok(channels.swap_remove(k).1)
            })
            .collect::<Result<Vec<Map>>>()?;
        Ok(Some(WrinkleMaps { normal, masks }))
    }

    /// The activation m per texel of the normal map for region weights `w`
    /// ([`wrinkle_regions::weights`]): the masks sampled bilinearly at the texel's UV.
    pub fn activation(&self, w: &[f32; COUNT], wrap: bool) -> Map {
        let (nw, nh) = (self.normal[0].width(), self.normal[0].height());
        let active: Vec<usize> = (0..COUNT).filter(|&k| w[k] > 0.0).collect();
        Map::from_par_fn(nw, nh, |i| {
            if active.is_empty() {
                return 0.0;
            }
            let (u, v) = (
                ((i % nw) as f32 + 0.5) / nw as f32,
                1.0 - ((i / nw) as f32 + 0.5) / nh as f32,
            );
            let mut m = [0.0f32; COUNT];
            for &k in &active {
                m[k] = self.masks[k].sample_uv(u, v, wrap);
            }
            wrinkle_regions::activation(&m, w)
        })
    }

    /// The rest normal `rest` (n·½ + ½, as normal.png) with the furrows of face units `units`
    /// blended in; `rest` itself, to the bit, on every texel whose activation is 0 or whose
    /// wrinkled normal is the rest one (no furrow within a texel).
    pub fn blend<'a>(
        &self,
        rest: &[Map; 3],
        units: impl IntoIterator<Item = (&'a str, f32)> + Clone,
        wrap: bool,
    ) -> Result<[Map; 3]> {
        let (w, h) = (rest[0].width(), rest[0].height());
        if (self.normal[0].width(), self.normal[0].height()) != (w, h) {
            return Err(RenderError::Invalid(derma_core::Invalid::new(
                files::WRINKLE_NORMAL,
                format!("the size of normal.png ({w}×{h})"),
                format!("{}×{}", self.normal[0].width(), self.normal[0].height()),
            )));
        }
        let weights = wrinkle_regions::weights(units);
        if weights.iter().all(|v| *v == 0.0) {
            return Ok(rest.clone());
        }
        let m = self.activation(&weights, wrap);
        use rayon::prelude::*;
        let px: Vec<[f32; 3]> = (0..w * h)
            .into_par_iter()
            .map(|i| {
                let a = m.data()[i];
                let r = [0, 1, 2].map(|c| rest[c].data()[i]);
                let f = [0, 1, 2].map(|c| self.normal[c].data()[i]);
                // No furrow here (the wrinkled normal is the rest one) or no activation.
                if a == 0.0 || f == r {
                    return r;
                }
                blend_normal(std::array::from_fn(|c| {
                    2.0 * (r[c] + (f[c] - r[c]) * a) - 1.0
                }))
            })
            .collect();
        Ok(std::array::from_fn(|c| Map::from_fn(w, h, |i| px[i][c])))
    }
}

/// A lerped normal `n` (components in [−1, 1]) renormalised and encoded n·½ + ½.
#[inline]
pub fn blend_normal(n: [f32; 3]) -> [f32; 3] {
    let len = (n[0] * n[0] + n[1] * n[1] + n[2] * n[2]).sqrt().max(1e-6);
    n.map(|v| 0.5 * v / len + 0.5)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn maps(rest: [f32; 3], full: [f32; 3], mask: f32) -> (WrinkleMaps, [Map; 3]) {
        let enc = |n: [f32; 3]| n.map(|v| Map::filled(4, 4, 0.5 * v + 0.5));
        let mut masks = vec![Map::filled(2, 2, 0.0); COUNT];
        masks[0] = Map::filled(2, 2, mask); // forehead_left
        (
            WrinkleMaps {
                normal: enc(full),
                masks,
            },
            enc(rest),
        )
    }

    #[test]
    fn no_driven_region_keeps_the_rest_normal() {
        let (wm, rest) = maps([0.0, 0.0, 1.0], [0.6, 0.0, 0.8], 1.0);
        let out = wm.blend(&rest, [("jawOpen", 1.0)], false).unwrap();
        assert_eq!(out[0].data(), rest[0].data());
        // A unit that drives another region leaves this one's texels alone.
        let out = wm.blend(&rest, [("browDownLeft", 1.0)], false).unwrap();
        assert_eq!(out[0].data(), rest[0].data());
    }

    #[test]
    fn full_activation_gives_the_wrinkled_normal_and_half_lies_between() {
        let (wm, rest) = maps([0.0, 0.0, 1.0], [0.6, 0.0, 0.8], 1.0);
        // browInnerUp 1 and browOuterUpLeft 1: 0.7 + 0.6 clamps at 1.
        let full = wm
            .blend(
                &rest,
                [("browInnerUp", 1.0), ("browOuterUpLeft", 1.0)],
                false,
            )
            .unwrap();
        assert!((full[0].data()[5] - 0.8).abs() < 1e-6 && (full[2].data()[5] - 0.9).abs() < 1e-6);
        // Mask 0.5 and weight 1: the normal of (0.3, 0, 0.9) renormalised.
        let (wm, rest) = maps([0.0, 0.0, 1.0], [0.6, 0.0, 0.8], 0.5);
        let half = wm
            .blend(
                &rest,
                [("browInnerUp", 1.0), ("browOuterUpLeft", 1.0)],
                false,
            )
            .unwrap();
        let l = (0.09f32 + 0.81).sqrt();
        assert!((half[0].data()[5] - (0.5 * 0.3 / l + 0.5)).abs() < 1e-5);
    }

    #[test]
    fn a_set_without_wrinkle_maps_has_none() {
        let dir = std::env::temp_dir().join(format!("derma-wrinkles-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        assert!(WrinkleMaps::from_dir(&dir).unwrap().is_none());
        std::fs::remove_dir_all(&dir).unwrap();
    }
}

//! Rig weights (Jimenez et al. 2010 eq. 6: "w_i are relative weights that sum up to one") and
//! the global hemoglobin scale (§7: anger ×1.27, fear ×0.81).
//!
//! A blend-shape rig gives weights to the targets only; the neutral pose takes the rest,
//! w_0 = 1 − Σ w_i, which is the normalisation eq. 6 implies for partial weights. Weights over
//! one are an error unless [`Normalization::Rescale`] is asked for (then w_i / Σ w_i, w_0 = 0).

use crate::basis::Rig;
use crate::error::{invalid, Result};

/// Tolerance on "sums to one".
pub const SUM_TOLERANCE: f32 = 1e-4;

/// Named weights as given by a user or a curve (`smile=0.7,anger=0.3`; `neutral` may be named).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct WeightSpec {
    /// (name, weight) pairs in the order given.
    pub entries: Vec<(String, f32)>,
}

impl std::str::FromStr for WeightSpec {
    type Err = crate::error::RigError;

    fn from_str(s: &str) -> Result<Self> {
        let mut entries = Vec::new();
        for item in s.split(',').map(str::trim).filter(|i| !i.is_empty()) {
            let (name, value) = item.split_once('=').ok_or_else(|| {
                invalid(
                    "weight",
                    format!("'{item}': expected NAME=WEIGHT, e.g. happiness=0.7"),
                )
            })?;
            let w: f32 = value
                .trim()
                .parse()
                .map_err(|_| invalid("weight", format!("'{item}': '{value}' is not a number")))?;
            entries.push((name.trim().to_string(), w));
        }
        Ok(Self { entries })
    }
}

/// What to do with weights that do not sum to one.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Normalization {
    /// w_0 = 1 − Σ w_i; an error when Σ w_i > 1 (or, with `neutral` named, when Σ ≠ 1).
    #[default]
    NeutralTakesRest,
    /// As above when Σ w_i ≤ 1, otherwise every weight divided by the sum.
    Rescale,
}

/// Resolves `spec` against the rig's target names into w_0 (neutral), w_1 … w_k.
pub fn resolve(names: &[&str], spec: &WeightSpec, norm: Normalization) -> Result<Vec<f32>> {
    let mut w = vec![0.0f32; names.len() + 1];
    let mut seen = vec![false; names.len() + 1];
    for (name, v) in &spec.entries {
        let i = if name == "neutral" {
            0
        } else {
            1 + names.iter().position(|n| n == name).ok_or_else(|| {
                invalid(
                    "weight",
                    format!(
                        "no target '{name}' in the rig; it has: neutral, {}",
                        names.join(", ")
                    ),
                )
            })?
        };
        if seen[i] {
            return Err(invalid("weight", format!("'{name}' given twice")));
        }
        if !(v.is_finite() && *v >= 0.0) {
            return Err(invalid(
                "weight",
                format!("{name}={v}: weights are non-negative shares of the pose"),
            ));
        }
        seen[i] = true;
        w[i] = *v;
    }
    let sum: f32 = w.iter().sum();
    let rest: f32 = w[1..].iter().sum();
    if seen[0] {
        if (sum - 1.0).abs() <= SUM_TOLERANCE {
            return Ok(w);
        }
        if norm == Normalization::Rescale && sum > 0.0 {
            return Ok(w.iter().map(|x| x / sum).collect());
        }
        return Err(invalid(
            "weights",
            format!("with 'neutral' named, the weights must sum to 1; they sum to {sum}"),
        ));
    }
    if rest <= 1.0 + SUM_TOLERANCE {
        w[0] = (1.0 - rest).max(0.0);
        return Ok(w);
    }
    match norm {
        Normalization::Rescale => {
            w[0] = 0.0;
            Ok(w.iter().map(|x| x / rest).collect())
        }
        Normalization::NeutralTakesRest => Err(invalid(
            "weights",
            format!(
                "the target weights sum to {rest} > 1 (eq. 6 needs Σ w_i = 1 with the neutral); lower them or ask for them to be normalised"
            ),
        )),
    }
}

/// The global hemoglobin scale of a frame.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub enum GlobalScale {
    /// This factor.
    Fixed(f32),
    /// 1 + Σ w_i (g_i − 1): each target's suggested scale at its weight.
    #[default]
    Auto,
}

impl std::fmt::Display for GlobalScale {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            GlobalScale::Auto => f.write_str("auto"),
            GlobalScale::Fixed(g) => write!(f, "{g}"),
        }
    }
}

impl std::str::FromStr for GlobalScale {
    type Err = crate::error::RigError;
    fn from_str(s: &str) -> Result<Self> {
        if s == "auto" {
            return Ok(Self::Auto);
        }
        match s.parse::<f32>() {
            Ok(g) if g.is_finite() && g > 0.0 => Ok(Self::Fixed(g)),
            _ => Err(invalid(
                "global scale",
                format!("'{s}': expected 'auto' or a positive factor such as 1.27"),
            )),
        }
    }
}

/// Weights w_0, w_1 … w_k and the global scale of one frame of `rig`: `spec` resolved against
/// its targets with `norm`, and `global` (Auto: each target's suggested scale at its weight).
pub fn frame_weights(
    rig: &Rig,
    spec: &WeightSpec,
    norm: Normalization,
    global: GlobalScale,
) -> Result<(Vec<f32>, f32)> {
    let names: Vec<&str> = rig.targets.iter().map(|t| t.name.as_str()).collect();
    let w = resolve(&names, spec, norm)?;
    let suggested: Vec<f32> = rig.targets.iter().map(|t| t.global_scale).collect();
    let g = global_scale(global, &w, &suggested);
    Ok((w, g))
}

/// The scale for weights `w` (w_0 first) given each target's suggested scale.
pub fn global_scale(g: GlobalScale, w: &[f32], suggested: &[f32]) -> f32 {
    match g {
        GlobalScale::Fixed(s) => s,
        GlobalScale::Auto => {
            1.0 + w[1..]
                .iter()
                .zip(suggested)
                .map(|(wi, gi)| wi * (gi - 1.0))
                .sum::<f32>()
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const NAMES: [&str; 3] = ["happiness", "anger", "fear"];

    fn spec(s: &str) -> WeightSpec {
        s.parse().unwrap()
    }

    #[test]
    fn neutral_takes_the_rest_and_weights_sum_to_one() {
        let w = resolve(
            &NAMES,
            &spec("happiness=0.7,anger=0.2"),
            Normalization::default(),
        )
        .unwrap();
        assert_eq!(w.len(), 4);
        assert!((w[0] - 0.1).abs() < 1e-6 && w[1] == 0.7 && w[2] == 0.2 && w[3] == 0.0);
        assert!((w.iter().sum::<f32>() - 1.0).abs() < 1e-6);
        let w = resolve(&NAMES, &spec(""), Normalization::default()).unwrap();
        assert_eq!(w, vec![1.0, 0.0, 0.0, 0.0]);
    }

    #[test]
    fn over_one_is_an_error_unless_rescaled() {
        let e = resolve(
            &NAMES,
            &spec("happiness=0.8,anger=0.6"),
            Normalization::default(),
        )
        .unwrap_err()
        .to_string();
        assert!(e.contains("1.4") && e.contains("normalised"), "{e}");
        let w = resolve(
            &NAMES,
            &spec("happiness=0.8,anger=0.6"),
            Normalization::Rescale,
        )
        .unwrap();
        assert!((w[1] - 0.8 / 1.4).abs() < 1e-6 && w[0] == 0.0);
        assert!((w.iter().sum::<f32>() - 1.0).abs() < 1e-6);
    }

    #[test]
    fn named_neutral_must_close_the_sum() {
        assert!(resolve(
            &NAMES,
            &spec("neutral=0.5,fear=0.5"),
            Normalization::default()
        )
        .is_ok());
        let e = resolve(
            &NAMES,
            &spec("neutral=0.5,fear=0.2"),
            Normalization::default(),
        )
        .unwrap_err()
        .to_string();
        assert!(e.contains("0.7"), "{e}");
    }

    #[test]
    fn bad_weights_are_named() {
        for (s, want) in [
            ("smile=0.5", "no target 'smile'"),
            ("anger=-0.1", "anger=-0.1"),
            ("anger=0.1,anger=0.2", "twice"),
        ] {
            let e = resolve(&NAMES, &spec(s), Normalization::default())
                .unwrap_err()
                .to_string();
            assert!(e.contains(want), "{s}: {e}");
        }
        assert!("anger"
            .parse::<WeightSpec>()
            .unwrap_err()
            .to_string()
            .contains("NAME=WEIGHT"));
        assert!("anger=x".parse::<WeightSpec>().is_err());
        assert!("-1".parse::<GlobalScale>().is_err());
    }

    #[test]
    fn auto_global_scale_blends_suggestions() {
        let w = [0.5, 0.5, 0.0];
        assert!((global_scale(GlobalScale::Auto, &w, &[1.27, 0.81]) - 1.135).abs() < 1e-6);
        assert_eq!(
            global_scale(GlobalScale::Fixed(0.9), &w, &[1.27, 0.81]),
            0.9
        );
    }
}

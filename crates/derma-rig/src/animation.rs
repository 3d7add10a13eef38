//! Weight curves: keyframed rig weights over time, sampled into frames. Transitions are taken
//! as the curves give them, without perfusion dynamics of their own (Jimenez et al. 2010 §3.1,
//! observation 6: transition dynamics are of lesser visual importance).
//!
//! CSV: a header `time,NAME,…[,global_scale]` and one keyframe per row (seconds, increasing).
//! JSON: `{"fps": 24, "curves": {"NAME": [[t, w], …], …}, "global_scale": [[t, s], …]}`.
//! Curves are piecewise linear and held constant outside their keys.

use crate::error::{invalid, Result, RigError};
use std::path::Path;

/// One piecewise-linear curve: (time s, value), times strictly increasing.
#[derive(Clone, Debug, PartialEq)]
pub struct Curve {
    /// The keys.
    pub keys: Vec<(f64, f32)>,
}

impl Curve {
    /// The value at time `t` (seconds): linear between keys, held outside them.
    pub fn at(&self, t: f64) -> f32 {
        let k = &self.keys;
        if t <= k[0].0 {
            return k[0].1;
        }
        if t >= k[k.len() - 1].0 {
            return k[k.len() - 1].1;
        }
        let i = k.partition_point(|&(kt, _)| kt <= t);
        let ((t0, v0), (t1, v1)) = (k[i - 1], k[i]);
        let a = ((t - t0) / (t1 - t0)) as f32;
        v0 + (v1 - v0) * a
    }
}

/// Named weight curves and an optional global-scale curve.
#[derive(Clone, Debug, PartialEq)]
pub struct Curves {
    /// Frame rate the file asks for, if any.
    pub fps: Option<f64>,
    /// A curve per target name (or "neutral").
    pub weights: Vec<(String, Curve)>,
    /// A curve of the global hemoglobin scale, if the file has one.
    pub global_scale: Option<Curve>,
}

fn check_curve(path: &Path, name: &str, keys: &[(f64, f32)]) -> Result<()> {
    let bad = |detail: String| RigError::File {
        path: path.to_path_buf(),
        detail: format!("curve '{name}': {detail}"),
    };
    if keys.is_empty() {
        return Err(bad("has no keys".into()));
    }
    for w in keys.windows(2) {
        if !(w[1].0 > w[0].0) {
            return Err(bad(format!(
                "times must increase; {} follows {}",
                w[1].0, w[0].0
            )));
        }
    }
    if let Some((t, v)) = keys.iter().find(|(t, v)| !(t.is_finite() && v.is_finite())) {
        return Err(bad(format!("key ({t}, {v}) is not finite")));
    }
    Ok(())
}

impl Curves {
    /// Reads curves from CSV or JSON (by extension).
    pub fn read(path: &Path) -> Result<Self> {
        let text = std::fs::read_to_string(path).map_err(|e| RigError::File {
            path: path.to_path_buf(),
            detail: format!("cannot read: {e}"),
        })?;
        let is_json = path
            .extension()
            .is_some_and(|e| e.eq_ignore_ascii_case("json"));
        if is_json {
            Self::from_json(&text, path)
        } else {
            Self::from_csv(&text, path)
        }
    }

    /// Parses CSV keyframes; `path` names the file in errors.
    pub fn from_csv(text: &str, path: &Path) -> Result<Self> {
        let bad = |line: usize, detail: String| RigError::File {
            path: path.to_path_buf(),
            detail: format!("line {line}: {detail}"),
        };
        let mut lines = text
            .lines()
            .enumerate()
            .filter(|(_, l)| !l.trim().is_empty() && !l.trim_start().starts_with('#'));
        let (hl, header) = lines
            .next()
            .ok_or_else(|| bad(1, "empty file; expected a header 'time,NAME,…'".into()))?;
        let cols: Vec<&str> = header.split(',').map(str::trim).collect();
        if cols.first() != Some(&"time") || cols.len() < 2 {
            return Err(bad(
                hl + 1,
                format!("header '{header}': expected 'time,NAME,…'"),
            ));
        }
        let mut keys: Vec<Vec<(f64, f32)>> = vec![Vec::new(); cols.len() - 1];
        for (ln, line) in lines {
            let vals: Vec<&str> = line.split(',').map(str::trim).collect();
            if vals.len() != cols.len() {
                return Err(bad(
                    ln + 1,
                    format!("{} fields; the header has {}", vals.len(), cols.len()),
                ));
            }
            let t: f64 = vals[0]
                .parse()
                .map_err(|_| bad(ln + 1, format!("time '{}' is not a number", vals[0])))?;
            for (k, v) in vals[1..].iter().enumerate() {
                if v.is_empty() {
                    continue; // no key for this curve at this time
                }
                let x: f32 = v
                    .parse()
                    .map_err(|_| bad(ln + 1, format!("{} '{v}' is not a number", cols[k + 1])))?;
                keys[k].push((t, x));
            }
        }
        let mut out = Curves {
            fps: None,
            weights: Vec::new(),
            global_scale: None,
        };
        for (name, keys) in cols[1..].iter().zip(keys) {
            check_curve(path, name, &keys)?;
            if *name == "global_scale" {
                out.global_scale = Some(Curve { keys });
            } else {
                out.weights.push((name.to_string(), Curve { keys }));
            }
        }
        Ok(out)
    }

    /// Parses JSON keyframes; `path` names the file in errors.
    pub fn from_json(text: &str, path: &Path) -> Result<Self> {
        #[derive(serde::Deserialize)]
        #[serde(deny_unknown_fields)]
        struct J {
            fps: Option<f64>,
            curves: std::collections::BTreeMap<String, Vec<(f64, f32)>>,
            global_scale: Option<Vec<(f64, f32)>>,
        }
        let j: J = serde_json::from_str(text).map_err(|e| RigError::File {
            path: path.to_path_buf(),
            detail: format!("{e}; expected {{\"fps\": 24, \"curves\": {{\"NAME\": [[t, w], …]}}, \"global_scale\": [[t, s], …]}}"),
        })?;
        let mut weights = Vec::new();
        for (name, keys) in j.curves {
            check_curve(path, &name, &keys)?;
            weights.push((name, Curve { keys }));
        }
        let global_scale = match j.global_scale {
            Some(k) => {
                check_curve(path, "global_scale", &k)?;
                Some(Curve { keys: k })
            }
            None => None,
        };
        if let Some(f) = j.fps {
            if !(f.is_finite() && f > 0.0) {
                return Err(invalid(
                    "fps",
                    format!("{f} in '{}'; expected > 0", path.display()),
                ));
            }
        }
        Ok(Curves {
            fps: j.fps,
            weights,
            global_scale,
        })
    }

    /// First and last key time over all curves.
    pub fn span(&self) -> (f64, f64) {
        let all = self
            .weights
            .iter()
            .map(|(_, c)| c)
            .chain(self.global_scale.as_ref())
            .flat_map(|c| c.keys.iter().map(|k| k.0));
        all.fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), t| {
            (a.min(t), b.max(t))
        })
    }

    /// Number of frames from the first to the last key at `fps` (without making them).
    pub fn frame_count(&self, fps: f64) -> usize {
        let (t0, t1) = self.span();
        if !t0.is_finite() {
            return 0;
        }
        ((t1 - t0) * fps + 1e-9).floor() as usize + 1
    }

    /// Frame times from the first to the last key at `fps` (the last key included when it falls
    /// on a frame); see [`Curves::frame_count`] for how many.
    pub fn frame_times(&self, fps: f64) -> Vec<f64> {
        let t0 = self.span().0;
        (0..self.frame_count(fps))
            .map(|k| t0 + k as f64 / fps)
            .collect()
    }

    /// The weights at time `t` as NAME=W entries.
    pub fn weights_at(&self, t: f64) -> crate::weights::WeightSpec {
        crate::weights::WeightSpec {
            entries: self
                .weights
                .iter()
                .map(|(n, c)| (n.clone(), c.at(t)))
                .collect(),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn csv_and_json_agree_and_interpolate_linearly() {
        let p = Path::new("curves.csv");
        let csv = "# a smile that fades into anger\ntime,happiness,anger,global_scale\n0,0,0,1\n1,0.8,,\n2,0,1,1.27\n";
        let c = Curves::from_csv(csv, p).unwrap();
        assert_eq!(c.weights.len(), 2);
        assert!((c.weights[0].1.at(0.5) - 0.4).abs() < 1e-6);
        // anger has keys at 0 and 2 only: 0.25 at t = 0.5.
        assert!((c.weights[1].1.at(0.5) - 0.25).abs() < 1e-6);
        assert_eq!(c.weights[1].1.at(5.0), 1.0);
        assert!((c.global_scale.as_ref().unwrap().at(1.0) - 1.135).abs() < 1e-6);
        let j = r#"{"fps": 10, "curves": {"happiness": [[0,0],[1,0.8],[2,0]], "anger": [[0,0],[2,1]]}, "global_scale": [[0,1],[2,1.27]]}"#;
        let cj = Curves::from_json(j, Path::new("c.json")).unwrap();
        for t in [0.0, 0.3, 1.0, 1.7, 2.0] {
            let a = c.weights_at(t);
            let b = cj.weights_at(t);
            for (n, w) in &a.entries {
                let wb = b.entries.iter().find(|(m, _)| m == n).unwrap().1;
                assert!((w - wb).abs() < 1e-6, "{n} at {t}");
            }
        }
        assert_eq!(cj.frame_times(10.0).len(), 21);
    }

    #[test]
    fn bad_curves_name_the_line_and_curve() {
        let p = Path::new("bad.csv");
        let e = Curves::from_csv("t,a\n0,1\n", p).unwrap_err().to_string();
        assert!(e.contains("line 1") && e.contains("bad.csv"), "{e}");
        let e = Curves::from_csv("time,a\n0,1\n0,2\n", p)
            .unwrap_err()
            .to_string();
        assert!(e.contains("curve 'a'") && e.contains("increase"), "{e}");
        let e = Curves::from_csv("time,a\n0,x\n", p)
            .unwrap_err()
            .to_string();
        assert!(e.contains("line 2") && e.contains("'x'"), "{e}");
        let e = Curves::from_json("{\"curves\": {}, \"fsp\": 2}", Path::new("c.json"))
            .unwrap_err()
            .to_string();
        assert!(e.contains("fsp"), "{e}");
    }
}

//! Tracked training data (thesis §3.4): per frame the gaze of each eye, the four lid margins as
//! spline control points and the 2D positions of the tracked skin vertices in the modelling
//! camera, optionally action units — read from and written to JSON or CSV (docs/eyes.md gives
//! both layouts), with every inconsistency reported by file, frame and field.

use crate::gaze::Fick;
use crate::{EyesError, Result};
use glam::Vec2;
use serde::{Deserialize, Serialize};
use std::path::Path;

/// The format tag of derma's tracked-data JSON.
pub const FORMAT: &str = "derma-eyes tracked 1";

/// One tracked frame.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Frame {
    /// Fick angles (°) of the left (+X) and right eye.
    pub gaze: [Fick; 2],
    /// Lid control points, 4 × `lid_points`: left upper, left lower, right upper, right lower,
    /// each from the inner to the outer canthus (mm, modelling camera).
    pub lids: Vec<Vec2>,
    /// Action-unit strengths in [0, 1], in the file's unit order.
    #[serde(default)]
    pub units: Vec<f32>,
    /// 2D positions of the tracked vertices (mm, modelling camera).
    pub vertices: Vec<Vec2>,
    /// True when the lids are at their gaze-driven rest (no blink, no voluntary squint or
    /// widening): the frames the baseline aperture model (eq. 3.11) is fitted to.
    #[serde(default = "yes")]
    pub baseline: bool,
}

fn yes() -> bool {
    true
}

/// A tracked sequence.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Tracked {
    /// Always [`FORMAT`].
    pub format: String,
    /// Frames per second (for sequences; 0 for unordered samples).
    pub fps: f32,
    /// Names of the action units, in the order of each frame's `units`.
    #[serde(default)]
    pub units: Vec<String>,
    /// Control points per lid.
    pub lid_points: usize,
    /// The frames.
    pub frames: Vec<Frame>,
}

impl Tracked {
    /// Number of tracked vertices (that of the first frame).
    pub fn vertex_count(&self) -> usize {
        self.frames.first().map_or(0, |f| f.vertices.len())
    }

    /// One lid's control points of a frame: `eye` 0 left / 1 right, `lid` 0 upper / 1 lower.
    pub fn lid<'a>(&self, f: &'a Frame, eye: usize, lid: usize) -> &'a [Vec2] {
        let n = self.lid_points;
        let k = 2 * eye + lid;
        &f.lids[k * n..(k + 1) * n]
    }

    /// Checks sizes and values; `path` names the file in the error.
    pub fn validate(&self, path: &Path) -> Result<()> {
        let bad = |detail: String| EyesError::Tracked {
            path: path.to_path_buf(),
            detail,
        };
        if self.format != FORMAT {
            return Err(bad(format!(
                "format is '{}', expected '{FORMAT}'",
                self.format
            )));
        }
        if !(4..=64).contains(&self.lid_points) {
            return Err(bad(format!(
                "lid_points is {}, expected 4 to 64 control points per lid",
                self.lid_points
            )));
        }
        if self.frames.len() < 10 {
            return Err(bad(format!(
                "{} frames; a model needs at least 10 (the thesis' captures have thousands)",
                self.frames.len()
            )));
        }
        let nv = self.vertex_count();
        if nv == 0 {
            return Err(bad("frame 0 has no vertices".into()));
        }
        for (i, f) in self.frames.iter().enumerate() {
            if f.lids.len() != 4 * self.lid_points {
                return Err(bad(format!(
                    "frame {i}: {} lid points, expected 4 × {} (left upper, left lower, right upper, right lower)",
                    f.lids.len(),
                    self.lid_points
                )));
            }
            if f.vertices.len() != nv {
                return Err(bad(format!(
                    "frame {i}: {} vertices, expected {nv} like frame 0",
                    f.vertices.len()
                )));
            }
            if f.units.len() != self.units.len() {
                return Err(bad(format!(
                    "frame {i}: {} unit values, expected {} ({})",
                    f.units.len(),
                    self.units.len(),
                    self.units.join(", ")
                )));
            }
            for (e, g) in f.gaze.iter().enumerate() {
                for (name, v) in [("h", g.h), ("v", g.v), ("t", g.t)] {
                    if !v.is_finite() || v.abs() > 90.0 {
                        return Err(bad(format!(
                            "frame {i}: gaze {} {name} = {v}°, expected a finite angle within ±90°",
                            ["left", "right"][e]
                        )));
                    }
                }
            }
            if let Some(u) = f.units.iter().find(|u| !(0.0..=1.5).contains(*u)) {
                return Err(bad(format!(
                    "frame {i}: unit value {u}, expected 0 to 1 (1.5 at most)"
                )));
            }
            if f.lids.iter().chain(&f.vertices).any(|p| !p.is_finite()) {
                return Err(bad(format!("frame {i}: a non-finite coordinate")));
            }
        }
        Ok(())
    }

    /// Reads a `.json` or `.csv` file and validates it.
    pub fn read(path: &Path) -> Result<Tracked> {
        let text = std::fs::read_to_string(path).map_err(|e| EyesError::Tracked {
            path: path.to_path_buf(),
            detail: format!("cannot read: {e}"),
        })?;
        let t = if path
            .extension()
            .is_some_and(|e| e.eq_ignore_ascii_case("csv"))
        {
            from_csv(&text).map_err(|detail| EyesError::Tracked {
                path: path.to_path_buf(),
                detail,
            })?
        } else {
            serde_json::from_str(&text).map_err(|e| EyesError::Tracked {
                path: path.to_path_buf(),
                detail: format!("not derma tracked JSON: {e}"),
            })?
        };
        t.validate(path)?;
        Ok(t)
    }

    /// Writes `.json` or `.csv` (by extension), atomically.
    pub fn write(&self, path: &Path) -> Result<()> {
        if path
            .extension()
            .is_some_and(|e| e.eq_ignore_ascii_case("csv"))
        {
            derma_core::atomic::write_bytes(path, to_csv(self).as_bytes())?;
        } else {
            derma_core::report::write_json(path, self, derma_core::report::JsonFormat::DATA)?;
        }
        Ok(())
    }
}

const GAZE_COLUMNS: [&str; 6] = [
    "gaze_left_h",
    "gaze_left_v",
    "gaze_left_t",
    "gaze_right_h",
    "gaze_right_v",
    "gaze_right_t",
];

/// The CSV layout: a header row, then one row per frame: `fps` (first row only, else empty),
/// the six gaze columns, `baseline` (0/1), `unit:NAME` per unit, `lid{k}_x,lid{k}_y` for
/// k < 4 × lid points, `v{i}_x,v{i}_y` per vertex.
fn to_csv(t: &Tracked) -> String {
    let mut head: Vec<String> = vec!["fps".into()];
    head.extend(GAZE_COLUMNS.iter().map(|s| s.to_string()));
    head.push("baseline".into());
    head.extend(t.units.iter().map(|u| format!("unit:{u}")));
    for k in 0..4 * t.lid_points {
        head.push(format!("lid{k}_x"));
        head.push(format!("lid{k}_y"));
    }
    for i in 0..t.vertex_count() {
        head.push(format!("v{i}_x"));
        head.push(format!("v{i}_y"));
    }
    let mut out = head.join(",");
    out.push('\n');
    for (n, f) in t.frames.iter().enumerate() {
        let mut row: Vec<String> = vec![if n == 0 {
            format!("{}", t.fps)
        } else {
            String::new()
        }];
        for g in &f.gaze {
            row.extend([g.h, g.v, g.t].map(|v| format!("{v}")));
        }
        row.push(if f.baseline { "1" } else { "0" }.into());
        row.extend(f.units.iter().map(|v| format!("{v}")));
        for p in f.lids.iter().chain(&f.vertices) {
            row.push(format!("{}", p.x));
            row.push(format!("{}", p.y));
        }
        out.push_str(&row.join(","));
        out.push('\n');
    }
    out
}

fn from_csv(text: &str) -> std::result::Result<Tracked, String> {
    let mut lines = text.lines().filter(|l| !l.trim().is_empty());
    let head: Vec<&str> = lines
        .next()
        .ok_or("empty file")?
        .split(',')
        .map(str::trim)
        .collect();
    let col = |name: &str| {
        head.iter()
            .position(|h| *h == name)
            .ok_or_else(|| format!("no column '{name}' in the header"))
    };
    let gaze_cols = GAZE_COLUMNS.map(col);
    let gaze_cols: Vec<usize> = gaze_cols
        .into_iter()
        .collect::<std::result::Result<_, _>>()?;
    let fps_col = col("fps").ok();
    let base_col = col("baseline").ok();
    let units: Vec<(usize, String)> = head
        .iter()
        .enumerate()
        .filter_map(|(i, h)| h.strip_prefix("unit:").map(|n| (i, n.to_string())))
        .collect();
    let pairs = |prefix: &str| -> std::result::Result<Vec<(usize, usize)>, String> {
        let mut v = Vec::new();
        loop {
            let k = v.len();
            match (
                col(&format!("{prefix}{k}_x")),
                col(&format!("{prefix}{k}_y")),
            ) {
                (Ok(x), Ok(y)) => v.push((x, y)),
                (Err(_), Err(_)) => return Ok(v),
                _ => {
                    return Err(format!(
                        "column {prefix}{k}_x or {prefix}{k}_y is missing its pair"
                    ))
                }
            }
        }
    };
    let lid_cols = pairs("lid")?;
    let v_cols = pairs("v")?;
    if lid_cols.is_empty() || !lid_cols.len().is_multiple_of(4) {
        return Err(format!(
            "{} lid points; expected 4 lids × the same number of points (lid0_x, lid0_y, …)",
            lid_cols.len()
        ));
    }
    let mut frames = Vec::new();
    let mut fps = 0.0;
    for (n, line) in lines.enumerate() {
        let cells: Vec<&str> = line.split(',').map(str::trim).collect();
        let num = |i: usize| -> std::result::Result<f32, String> {
            let c = cells
                .get(i)
                .ok_or_else(|| format!("row {}: no value for column '{}'", n + 1, head[i]))?;
            c.parse::<f32>().map_err(|_| {
                format!(
                    "row {}: column '{}' is '{c}', expected a number",
                    n + 1,
                    head[i]
                )
            })
        };
        if n == 0 {
            if let Some(c) = fps_col {
                fps = num(c)?;
            }
        }
        let g: Vec<f32> = gaze_cols
            .iter()
            .map(|&c| num(c))
            .collect::<std::result::Result<_, _>>()?;
        let pts = |cols: &[(usize, usize)]| -> std::result::Result<Vec<Vec2>, String> {
            cols.iter()
                .map(|&(x, y)| Ok(Vec2::new(num(x)?, num(y)?)))
                .collect()
        };
        frames.push(Frame {
            gaze: [
                Fick {
                    h: g[0],
                    v: g[1],
                    t: g[2],
                },
                Fick {
                    h: g[3],
                    v: g[4],
                    t: g[5],
                },
            ],
            lids: pts(&lid_cols)?,
            units: units
                .iter()
                .map(|(c, _)| num(*c))
                .collect::<std::result::Result<_, _>>()?,
            vertices: pts(&v_cols)?,
            baseline: match base_col {
                Some(c) => num(c)? != 0.0,
                None => true,
            },
        });
    }
    Ok(Tracked {
        format: FORMAT.into(),
        fps,
        units: units.into_iter().map(|(_, n)| n).collect(),
        lid_points: lid_cols.len() / 4,
        frames,
    })
}

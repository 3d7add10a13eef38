//! The feature points of each photo, read from a documented JSON or CSV file (Tarini et al.
//! 2002 §3: the one manual step), with MediaPipe's 468-landmark face-mesh topology accepted as
//! is; 3D positions come from the mesh's named landmarks, its vertices or the file itself.
//!
//! JSON:
//! ```json
//! { "photos": [ { "image": "front.jpg", "focal_px": 4200,
//!     "points": [ {"name": "nose_tip", "pixel": [1510.5, 1022.0]},
//!                 {"vertex": 1234, "pixel": [980.0, 700.0]},
//!                 {"world": [31.0, 12.5, 80.1], "pixel": [1700.2, 820.4]} ],
//!     "mediapipe": [[x, y], …] } ] }
//! ```
//! CSV: a header `image,point,x,y` (optionally `,X,Y,Z`), one row per point; `point` is a
//! landmark name, `v<index>` (a mesh vertex) or `mp<id>` (a MediaPipe landmark).
//! Pixels have their origin at the image's top-left corner; `image` is relative to the file.

use crate::error::{PhotoError, Result};
use crate::resection::{Correspondence, PhotoPoints};
use derma_core::mesh::TriMesh;
use derma_head::landmarks::{MEDIAPIPE, MEDIAPIPE_HAIRLINE};
use derma_head::Landmarks;
use glam::{DVec2, DVec3};
use serde::Deserialize;
use std::path::{Path, PathBuf};

/// Landmarks of MediaPipe's face mesh (vertex index = landmark id).
pub const MEDIAPIPE_POINTS: usize = 468;

/// Where 3D points come from.
pub struct Surface<'a> {
    /// The mesh (vertex indices refer to it).
    pub mesh: &'a TriMesh,
    /// Its named landmarks, when known.
    pub landmarks: Option<&'a Landmarks>,
    /// The mesh is in MediaPipe's topology: vertex i is landmark i.
    pub mediapipe_topology: bool,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct FileJson {
    photos: Vec<PhotoJson>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct PhotoJson {
    image: String,
    #[serde(default)]
    width: Option<u32>,
    #[serde(default)]
    height: Option<u32>,
    #[serde(default)]
    focal_px: Option<f64>,
    #[serde(default)]
    points: Vec<PointJson>,
    #[serde(default)]
    mediapipe: Option<Vec<[f64; 2]>>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct PointJson {
    #[serde(default)]
    name: Option<String>,
    #[serde(default)]
    vertex: Option<usize>,
    #[serde(default)]
    world: Option<[f64; 3]>,
    pixel: [f64; 2],
}

/// One photo's entry: its image file and points.
pub struct PhotoEntry {
    /// The image file (resolved against the correspondence file's folder).
    pub image: PathBuf,
    /// The points, with their 3D positions resolved.
    pub points: PhotoPoints,
}

/// A point's 3D position from a name, a vertex or a MediaPipe id.
fn resolve(label: &str, surface: &Surface, err: &dyn Fn(String) -> PhotoError) -> Result<DVec3> {
    let mesh = surface.mesh;
    if let Some(v) = label
        .strip_prefix('v')
        .and_then(|s| s.parse::<usize>().ok())
    {
        return mesh.positions.get(v).map(|p| p.as_dvec3()).ok_or_else(|| {
            err(format!(
                "point '{label}': the mesh has {} vertices",
                mesh.positions.len()
            ))
        });
    }
    if let Some(id) = label
        .strip_prefix("mp")
        .and_then(|s| s.parse::<usize>().ok())
    {
        if id >= MEDIAPIPE_POINTS {
            return Err(err(format!("point '{label}': MediaPipe ids are 0–467")));
        }
        if surface.mediapipe_topology {
            return mesh.positions.get(id).map(|p| p.as_dvec3()).ok_or_else(|| {
                err(format!(
                    "point '{label}': the mesh has only {} vertices, not MediaPipe's 468",
                    mesh.positions.len()
                ))
            });
        }
        let name = MEDIAPIPE
            .iter()
            .find(|(_, i)| *i == id)
            .map(|(n, _)| *n)
            .or((id == MEDIAPIPE_HAIRLINE).then_some("hairline"))
            .ok_or_else(|| err(format!("point '{label}': not one of the MediaPipe ids derma maps to a named landmark (give the mesh in MediaPipe topology to use all 468)")))?;
        return resolve(name, surface, err);
    }
    let lm = surface.landmarks.ok_or_else(|| {
        err(format!(
            "point '{label}' is a landmark name, but the mesh has no landmarks (give its landmark file)"
        ))
    })?;
    if !lm.points.contains_key(label) {
        return Err(err(format!(
            "unknown landmark '{label}'; expected one of {:?}, v<index> or mp<id>",
            lm.points.keys().collect::<Vec<_>>()
        )));
    }
    Ok(lm.get(label).as_dvec3())
}

fn check_pixel(p: [f64; 2], label: &str, err: &dyn Fn(String) -> PhotoError) -> Result<DVec2> {
    if !(p[0].is_finite() && p[1].is_finite()) {
        return Err(err(format!("point '{label}': pixel {p:?} is not finite")));
    }
    Ok(DVec2::from(p))
}

/// Reads a correspondence file (JSON or CSV by extension). Image sizes come from the file or,
/// when absent, from `image_size(path)`.
pub fn read(
    path: &Path,
    surface: &Surface,
    image_size: &dyn Fn(&Path) -> Result<(u32, u32)>,
) -> Result<Vec<PhotoEntry>> {
    let text = std::fs::read_to_string(path).map_err(|e| PhotoError::Correspondences {
        path: path.to_path_buf(),
        detail: format!("cannot read: {e}"),
    })?;
    let err = |detail: String| PhotoError::Correspondences {
        path: path.to_path_buf(),
        detail,
    };
    let dir = path.parent().unwrap_or(Path::new("."));
    let is_csv = path
        .extension()
        .is_some_and(|e| e.eq_ignore_ascii_case("csv"));
    let photos: Vec<PhotoJson> = if is_csv {
        parse_csv(&text, &err)?
    } else {
        serde_json::from_str::<FileJson>(&text)
            .map_err(|e| err(format!("not valid correspondence JSON: {e}")))?
            .photos
    };
    if photos.is_empty() {
        return Err(err("no photos listed".into()));
    }
    let mut out = Vec::with_capacity(photos.len());
    for p in photos {
        let image = dir.join(&p.image);
        let (width, height) = match (p.width, p.height) {
            (Some(w), Some(h)) => (w, h),
            _ => image_size(&image)?,
        };
        let mut points = Vec::new();
        for (k, q) in p.points.iter().enumerate() {
            let given = q.name.is_some() as u8 + q.vertex.is_some() as u8 + q.world.is_some() as u8;
            if given != 1 {
                return Err(err(format!(
                    "photo '{}', point {k}: give exactly one of name, vertex or world",
                    p.image
                )));
            }
            let (label, world) = if let Some(w) = q.world {
                if !w.iter().all(|v| v.is_finite()) {
                    return Err(err(format!(
                        "photo '{}', point {k}: world {w:?} is not finite",
                        p.image
                    )));
                }
                (format!("p{k}"), DVec3::from(w))
            } else if let Some(v) = q.vertex {
                let l = format!("v{v}");
                let w = resolve(&l, surface, &err)?;
                (l, w)
            } else {
                let l = q.name.clone().expect("one given");
                let w = resolve(&l, surface, &err)?;
                (l, w)
            };
            points.push(Correspondence {
                pixel: check_pixel(q.pixel, &label, &err)?,
                label,
                world,
            });
        }
        if let Some(mp) = &p.mediapipe {
            if mp.len() != MEDIAPIPE_POINTS && mp.len() != 478 {
                return Err(err(format!(
                    "photo '{}': {} MediaPipe points; expected 468 (or 478 with irises)",
                    p.image,
                    mp.len()
                )));
            }
            let ids: Vec<usize> = if surface.mediapipe_topology {
                (0..MEDIAPIPE_POINTS).collect()
            } else {
                MEDIAPIPE
                    .iter()
                    .map(|(_, i)| *i)
                    .chain([MEDIAPIPE_HAIRLINE])
                    .collect()
            };
            for id in ids {
                let label = format!("mp{id}");
                let world = resolve(&label, surface, &err)?;
                points.push(Correspondence {
                    pixel: check_pixel(mp[id], &label, &err)?,
                    label,
                    world,
                });
            }
        }
        out.push(PhotoEntry {
            image,
            points: PhotoPoints {
                name: p.image.clone(),
                width,
                height,
                focal_px: p.focal_px,
                points,
            },
        });
    }
    Ok(out)
}

fn parse_csv(text: &str, err: &dyn Fn(String) -> PhotoError) -> Result<Vec<PhotoJson>> {
    let mut lines = text
        .lines()
        .enumerate()
        .filter(|(_, l)| !l.trim().is_empty() && !l.starts_with('#'));
    let (_, header) = lines.next().ok_or_else(|| err("empty CSV".into()))?;
    let cols: Vec<String> = header
        .split(',')
        .map(|c| c.trim().to_ascii_lowercase())
        .collect();
    let want = ["image", "point", "x", "y"];
    if cols.len() < 4 || cols[..4] != want {
        return Err(err(format!(
            "CSV header {cols:?}; expected image,point,x,y[,X,Y,Z]"
        )));
    }
    let has_world = cols.len() >= 7;
    let mut photos: Vec<PhotoJson> = Vec::new();
    for (n, line) in lines {
        let f: Vec<&str> = line.split(',').map(|c| c.trim()).collect();
        if f.len() < 4 {
            return Err(err(format!(
                "line {}: {} fields; expected at least 4",
                n + 1,
                f.len()
            )));
        }
        let num = |s: &str, what: &str| -> Result<f64> {
            s.parse::<f64>()
                .ok()
                .filter(|v| v.is_finite())
                .ok_or_else(|| {
                    err(format!(
                        "line {}: {what} '{s}' is not a finite number",
                        n + 1
                    ))
                })
        };
        let pixel = [num(f[2], "x")?, num(f[3], "y")?];
        let world = if has_world && f.len() >= 7 && !f[4].is_empty() {
            Some([num(f[4], "X")?, num(f[5], "Y")?, num(f[6], "Z")?])
        } else {
            None
        };
        let point = if world.is_some() {
            PointJson {
                name: None,
                vertex: None,
                world,
                pixel,
            }
        } else if let Some(v) = f[1].strip_prefix('v').and_then(|s| s.parse().ok()) {
            PointJson {
                name: None,
                vertex: Some(v),
                world: None,
                pixel,
            }
        } else {
            PointJson {
                name: Some(f[1].to_string()),
                vertex: None,
                world: None,
                pixel,
            }
        };
        match photos.iter_mut().find(|p| p.image == f[0]) {
            Some(p) => p.points.push(point),
            None => photos.push(PhotoJson {
                image: f[0].to_string(),
                width: None,
                height: None,
                focal_px: None,
                points: vec![point],
                mediapipe: None,
            }),
        }
    }
    Ok(photos)
}

/// The focal length in pixels from a JPEG's EXIF: FocalLengthIn35mmFilm (tag 0xA405, defined
/// on the 43.27 mm diagonal of a 36 × 24 mm frame; CIPA DC-008 Exif 2.3 §4.6.5). `None` when
/// the file has no such tag.
pub fn exif_focal_px(bytes: &[u8], width: u32, height: u32) -> Option<f64> {
    // Find the APP1 "Exif\0\0" segment.
    let mut i = 2;
    if bytes.get(..2) != Some(&[0xFF, 0xD8]) {
        return None;
    }
    while i + 4 <= bytes.len() {
        if bytes[i] != 0xFF {
            return None;
        }
        let marker = bytes[i + 1];
        let len = u16::from_be_bytes([bytes[i + 2], bytes[i + 3]]) as usize;
        if marker == 0xE1 && bytes.get(i + 4..i + 10) == Some(b"Exif\0\0") {
            let tiff = bytes.get(i + 10..i + 2 + len)?;
            let f35 = tiff_tag(tiff, 0xA405)?;
            if f35 == 0 {
                return None;
            }
            let diag = ((width as f64).powi(2) + (height as f64).powi(2)).sqrt();
            return Some(f35 as f64 * diag / 43.2666);
        }
        if marker == 0xDA {
            return None;
        }
        i += 2 + len;
    }
    None
}

/// A SHORT tag's value from IFD0 or the Exif sub-IFD (0x8769) of a TIFF block.
fn tiff_tag(t: &[u8], tag: u16) -> Option<u32> {
    let le = match t.get(..2)? {
        b"II" => true,
        b"MM" => false,
        _ => return None,
    };
    let u16at = |o: usize| -> Option<u16> {
        let b = t.get(o..o + 2)?;
        Some(if le {
            u16::from_le_bytes([b[0], b[1]])
        } else {
            u16::from_be_bytes([b[0], b[1]])
        })
    };
    let u32at = |o: usize| -> Option<u32> {
        let b = t.get(o..o + 4)?;
        Some(if le {
            u32::from_le_bytes([b[0], b[1], b[2], b[3]])
        } else {
            u32::from_be_bytes([b[0], b[1], b[2], b[3]])
        })
    };
    let scan = |ifd: usize| -> (Option<u32>, Option<u32>) {
        let Some(n) = u16at(ifd) else {
            return (None, None);
        };
        let (mut found, mut sub) = (None, None);
        for k in 0..n as usize {
            let e = ifd + 2 + 12 * k;
            match u16at(e) {
                Some(x) if x == tag => found = u16at(e + 8).map(|v| v as u32),
                Some(0x8769) => sub = u32at(e + 8),
                _ => {}
            }
        }
        (found, sub)
    };
    let ifd0 = u32at(4)? as usize;
    let (found, sub) = scan(ifd0);
    found.or_else(|| sub.and_then(|s| scan(s as usize).0))
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::Vec3;

    fn head_surface() -> Surface<'static> {
        let head = derma_head::Head::builtin();
        Surface {
            mesh: &head.skin,
            landmarks: Some(&head.landmarks),
            mediapipe_topology: false,
        }
    }

    fn size(_: &Path) -> Result<(u32, u32)> {
        Ok((800, 600))
    }

    #[test]
    fn json_points_resolve_by_name_vertex_world_and_mediapipe_id() {
        let d = derma_test_support::scratch_dir("corr");
        let p = d.join("c.json");
        let mut mp = vec![[0.0, 0.0]; 468];
        mp[4] = [400.0, 300.0];
        let json = serde_json::json!({"photos": [{"image": "a.jpg", "focal_px": 1000.0,
            "points": [{"name": "nose_tip", "pixel": [1.0, 2.0]}, {"vertex": 5, "pixel": [3.0, 4.0]},
                       {"world": [1.0, 2.0, 3.0], "pixel": [5.0, 6.0]}],
            "mediapipe": mp}]});
        std::fs::write(&p, json.to_string()).unwrap();
        let s = head_surface();
        let e = read(&p, &s, &size).unwrap();
        assert_eq!(e.len(), 1);
        let pts = &e[0].points;
        assert_eq!(
            (pts.width, pts.height, pts.focal_px),
            (800, 600, Some(1000.0))
        );
        assert_eq!(
            pts.points[0].world,
            s.landmarks.unwrap().get("nose_tip").as_dvec3()
        );
        assert_eq!(pts.points[1].world, s.mesh.positions[5].as_dvec3());
        assert_eq!(pts.points[2].world, DVec3::new(1.0, 2.0, 3.0));
        // The 17 named MediaPipe ids and the hairline follow.
        assert_eq!(pts.points.len(), 3 + 18);
        let nose = pts.points.iter().find(|c| c.label == "mp4").unwrap();
        assert_eq!(nose.pixel, DVec2::new(400.0, 300.0));
        assert_eq!(nose.world, s.landmarks.unwrap().get("nose_tip").as_dvec3());
    }

    #[test]
    fn a_mesh_in_mediapipe_topology_uses_all_468_points() {
        let Some(path) = derma_test_support::shared_data("canonical_face_model.obj") else {
            return;
        };
        let text = std::fs::read_to_string(path).unwrap();
        let positions: Vec<Vec3> = text
            .lines()
            .filter_map(|l| l.strip_prefix("v "))
            .map(|l| {
                let v: Vec<f32> = l.split_whitespace().map(|x| x.parse().unwrap()).collect();
                Vec3::new(v[0], v[1], v[2])
            })
            .collect();
        assert_eq!(positions.len(), 468);
        let mesh = TriMesh {
            positions,
            ..Default::default()
        };
        let s = Surface {
            mesh: &mesh,
            landmarks: None,
            mediapipe_topology: true,
        };
        let d = derma_test_support::scratch_dir("corr_mp");
        let p = d.join("c.json");
        let json = serde_json::json!({"photos": [{"image": "a.jpg", "width": 640, "height": 480, "mediapipe": vec![[1.0, 1.0]; 468]}]});
        std::fs::write(&p, json.to_string()).unwrap();
        let e = read(&p, &s, &size).unwrap();
        assert_eq!(e[0].points.points.len(), 468);
        assert_eq!(e[0].points.points[17].world, mesh.positions[17].as_dvec3());
    }

    #[test]
    fn csv_rows_group_by_image() {
        let d = derma_test_support::scratch_dir("corr_csv");
        let p = d.join("c.csv");
        std::fs::write(
            &p,
            "image,point,x,y,X,Y,Z\na.png,nose_tip,10,20,,,\nb.png,v7,1,2,,,\na.png,q,3,4,1,2,3\n",
        )
        .unwrap();
        let e = read(&p, &head_surface(), &size).unwrap();
        assert_eq!(e.len(), 2);
        assert_eq!(e[0].points.points.len(), 2);
        assert_eq!(e[0].points.points[1].world, DVec3::new(1.0, 2.0, 3.0));
        assert_eq!(e[1].points.points[0].label, "v7");
    }

    #[test]
    fn bad_files_name_the_problem() {
        let d = derma_test_support::scratch_dir("corr_bad");
        let s = head_surface();
        let cases = [
            (
                "a.json",
                r#"{"photos": [{"image": "x.jpg", "points": [{"name": "nose", "pixel": [1, 2]}]}]}"#,
                "unknown landmark 'nose'",
            ),
            (
                "b.json",
                r#"{"photos": [{"image": "x.jpg", "points": [{"vertex": 99999999, "pixel": [1, 2]}]}]}"#,
                "vertices",
            ),
            (
                "c.json",
                r#"{"photos": [{"image": "x.jpg", "mediapipe": [[1, 2]]}]}"#,
                "expected 468",
            ),
            (
                "d.json",
                r#"{"photos": [{"image": "x.jpg", "points": [{"name": "chin", "vertex": 2, "pixel": [1, 2]}]}]}"#,
                "exactly one",
            ),
            ("e.csv", "img,pt,x,y\n", "expected image,point,x,y"),
            ("f.json", r#"{"photos": []}"#, "no photos"),
            (
                "g.csv",
                "image,point,x,y,X,Y,Z\nx.jpg,p0,10,20,1,NaN,3\n",
                "line 2: Y 'NaN' is not a finite number",
            ),
            (
                "h.csv",
                "image,point,x,y\nx.jpg,chin,inf,20\n",
                "line 2: x 'inf' is not a finite number",
            ),
        ];
        for (name, text, want) in cases {
            let p = d.join(name);
            std::fs::write(&p, text).unwrap();
            let e = read(&p, &s, &size).err().unwrap().to_string();
            assert!(e.contains(want) && e.contains(name), "{name}: {e}");
        }
    }

    #[test]
    fn exif_focal_length_in_35mm_is_read() {
        // A minimal JPEG: SOI, APP1 Exif with IFD0 → Exif IFD holding 0xA405 = 50, then EOI.
        let mut tiff: Vec<u8> = b"II*\0".to_vec();
        tiff.extend(8u32.to_le_bytes());
        // IFD0: one entry, the Exif pointer.
        tiff.extend(1u16.to_le_bytes());
        tiff.extend(0x8769u16.to_le_bytes());
        tiff.extend(4u16.to_le_bytes());
        tiff.extend(1u32.to_le_bytes());
        tiff.extend(26u32.to_le_bytes());
        tiff.extend(0u32.to_le_bytes());
        // Exif IFD at 26: one entry, 0xA405 SHORT 50.
        tiff.extend(1u16.to_le_bytes());
        tiff.extend(0xA405u16.to_le_bytes());
        tiff.extend(3u16.to_le_bytes());
        tiff.extend(1u32.to_le_bytes());
        tiff.extend(50u16.to_le_bytes());
        tiff.extend([0, 0]);
        tiff.extend(0u32.to_le_bytes());
        let mut jpg = vec![0xFF, 0xD8, 0xFF, 0xE1];
        jpg.extend(((tiff.len() + 8) as u16).to_be_bytes());
        jpg.extend(b"Exif\0\0");
        jpg.extend(&tiff);
        jpg.extend([0xFF, 0xD9]);
        let f = exif_focal_px(&jpg, 3000, 2000).unwrap();
        // 50 mm equivalent on a 3:2 frame: 50/36 of the width.
        assert!((f - 50.0 / 36.0 * 3000.0).abs() < 1.0, "{f}");
        assert_eq!(exif_focal_px(&[0xFF, 0xD8, 0xFF, 0xD9], 10, 10), None);
    }
}

//! Layouts of renders for people to judge: renders beside map thumbnails, contact sheets (views
//! under each lighting setup beside the raw maps) and turntables.

use crate::camera::View;
use crate::draw::Draw;
use crate::error::Result;
use crate::lighting::Setup;
use crate::material::SkinMaps;
use derma_core::Map;

/// Lays out the preview: the render(s) on the left, a 3×2 contact sheet of maps on the right
/// (none when `sheet` is empty).
/// Returns encoded sRGB channels.
pub fn compose(renders: &[[Map; 3]], sheet: &[[Map; 3]], panel: usize) -> [Map; 3] {
    let thumb = panel / 2;
    let width = panel * renders.len() + if sheet.is_empty() { 0 } else { thumb * 3 };
    let height = panel;
    let mut out = [
        Map::filled(width, height, 0.0),
        Map::filled(width, height, 0.0),
        Map::filled(width, height, 0.0),
    ];
    let mut blit = |img: &[Map; 3], x0: usize, y0: usize, n: usize, encode: bool| {
        for k in 0..3 {
            let r = img[k].resized(n, n);
            for y in 0..n {
                for x in 0..n {
                    let v = r.get(x, y);
                    out[k].set(
                        x0 + x,
                        y0 + y,
                        if encode {
                            derma_core::color::srgb_encode(v)
                        } else {
                            v
                        },
                    );
                }
            }
        }
    };
    for (i, r) in renders.iter().enumerate() {
        blit(r, i * panel, 0, panel, true);
    }
    for (i, s) in sheet.iter().take(6).enumerate() {
        blit(
            s,
            panel * renders.len() + (i % 3) * thumb,
            (i / 3) * thumb,
            thumb,
            false,
        );
    }
    out
}

/// Greyscale thumbnail channels of `m` normalised to its [min, max].
pub fn normalised(m: &Map) -> [Map; 3] {
    let s = m.stats(None);
    let span = (s.max - s.min).max(1e-12);
    let mut n = m.clone();
    n.data_mut()
        .iter_mut()
        .for_each(|v| *v = (*v - s.min) / span);
    [n.clone(), n.clone(), n]
}

/// Thumbnails of the raw maps (sRGB-encoded where colour, normalised where data): base
/// colour, normal, roughness, specular, and with subsurface maps sss colour and radius.
pub fn map_thumbnails(s: &SkinMaps, size: usize) -> Vec<[Map; 3]> {
    let small = |m: &Map| m.resized(size, size);
    let enc = |c: &[Map; 3]| {
        c.clone().map(|m| {
            let mut m = small(&m);
            m.data_mut()
                .iter_mut()
                .for_each(|v| *v = derma_core::color::srgb_encode(*v));
            m
        })
    };
    let grey = |m: &Map| {
        let m = small(m);
        [m.clone(), m.clone(), m]
    };
    let mut out = vec![
        enc(&s.base_color),
        s.normal.clone().map(|m| small(&m)),
        grey(&s.roughness),
        grey(&s.specular),
    ];
    if let Some((c, r)) = &s.subsurface {
        out.push(enc(c));
        out.push(normalised(&small(&r[0])));
    }
    out
}

/// A contact sheet: for each setup a row of views (front, three-quarter, profile) at `panel`²,
/// and beside all rows the raw maps as a grid as tall as the rows (see [`map_grid`]).
pub fn contact_sheet(
    r: &dyn Draw,
    skin: &SkinMaps,
    setups: &[Setup],
    panel: u32,
) -> Result<[Map; 3]> {
    let mut rows = Vec::new();
    for s in setups {
        let mut views = Vec::new();
        for yaw in [0.0, 35.0, 90.0] {
            let v = View {
                yaw_deg: yaw,
                ..Default::default()
            };
            views.push(
                r.draw(&v, &s.lighting(), panel, panel)?
                    .display_linear_maps(),
            );
        }
        rows.push(compose(&views, &[], panel as usize));
    }
    let views = stack(&rows);
    let (grid_rows, tile) = map_grid(setups.len(), panel as usize);
    let thumbs = map_thumbnails(skin, tile);
    let cols = thumbs.len().div_ceil(grid_rows);
    let (vw, h) = (views[0].width(), views[0].height());
    let mut out = [
        Map::filled(vw + cols * tile, h, 0.0),
        Map::filled(vw + cols * tile, h, 0.0),
        Map::filled(vw + cols * tile, h, 0.0),
    ];
    blit(&mut out, &views, 0, 0);
    for (i, t) in thumbs.iter().enumerate() {
        blit(&mut out, t, vw + (i % cols) * tile, (i / cols) * tile);
    }
    Ok(out)
}

/// The map grid beside `setups` rows of `panel`-pixel views: (rows of tiles, tile side). One
/// setup: two rows of half-panel tiles; more: three rows filling the height.
pub fn map_grid(setups: usize, panel: usize) -> (usize, usize) {
    if setups <= 1 {
        (2, panel / 2)
    } else {
        (3, setups * panel / 3)
    }
}

/// `img` copied into `out` with its top-left corner at (x0, y0).
fn blit(out: &mut [Map; 3], img: &[Map; 3], x0: usize, y0: usize) {
    for k in 0..3 {
        for y in 0..img[k].height() {
            for x in 0..img[k].width() {
                out[k].set(x0 + x, y0 + y, img[k].get(x, y));
            }
        }
    }
}

/// Rows stacked top to bottom, left-aligned on a black background.
fn stack(rows: &[[Map; 3]]) -> [Map; 3] {
    let w = rows.iter().map(|r| r[0].width()).max().unwrap_or(0);
    let h: usize = rows.iter().map(|r| r[0].height()).sum();
    let mut out = [
        Map::filled(w, h, 0.0),
        Map::filled(w, h, 0.0),
        Map::filled(w, h, 0.0),
    ];
    let mut y0 = 0;
    for r in rows {
        blit(&mut out, r, 0, y0);
        y0 += r[0].height();
    }
    out
}

/// `frames` views in a full turn (yaw 0 → 360°) under `setup`, as 8-bit sRGB RGB frames.
pub fn turntable(
    r: &dyn Draw,
    setup: Setup,
    frames: usize,
    w: u32,
    h: u32,
) -> Result<Vec<Vec<u8>>> {
    (0..frames)
        .map(|i| {
            let v = View {
                yaw_deg: 360.0 * i as f32 / frames as f32,
                ..Default::default()
            };
            let img = r.draw(&v, &setup.lighting(), w, h)?;
            Ok(img
                .display
                .chunks_exact(4)
                .flat_map(|p| [p[0], p[1], p[2]])
                .collect())
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_map_grid_fills_the_height_of_the_rows() {
        // Six maps (with subsurface): 3 × 2 beside one row, 2 × 3 beside two or three.
        for setups in 1..=3 {
            let (rows, tile) = map_grid(setups, 1024);
            let h = setups * 1024;
            assert!(
                rows * tile <= h && rows * tile + rows > h,
                "{setups}: {rows} × {tile}"
            );
            assert!(6usize.div_ceil(rows) <= 3);
        }
        assert_eq!(map_grid(1, 1024), (2, 512));
        assert_eq!(map_grid(2, 1024), (3, 682));
    }
}

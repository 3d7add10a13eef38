//! Image input and output: greyscale and RGB fields from PNG (8/16-bit) or OpenEXR; PNG 8/16-bit
//! and multi-layer OpenEXR outputs, all written atomically (see [`crate::atomic`]).

use crate::atomic;
use crate::error::{CoreError, Result};
use crate::map::Map;
use image::codecs::png::{CompressionType, FilterType, PngEncoder};
use image::{ExtendedColorType, ImageEncoder};
use std::path::Path;

/// A decoded image as linear-in-file values in [0, 1] (PNG values are used as stored, i.e. an
/// artist's grey level is the probability; EXR values are taken as they are).
pub struct LoadedImage {
    /// The channels: three (R, G, B) from [`read_rgb`], one from [`read_grey`].
    pub channels: Vec<Map>,
    /// True when the file had colour channels that differ from each other.
    pub is_color: bool,
    /// The file's alpha channel in [0, 1] where it has one ([`read_rgb`]: a PNG with alpha, an
    /// EXR with an `A` channel beside R, G and B); `None` otherwise.
    pub alpha: Option<Map>,
}

fn decode(path: &Path) -> Result<image::DynamicImage> {
    let bytes = std::fs::read(path).map_err(|source| CoreError::Read {
        path: path.to_path_buf(),
        source,
    })?;
    image::load_from_memory(&bytes).map_err(|e| CoreError::Image {
        path: path.to_path_buf(),
        detail: e.to_string(),
    })
}

/// Loads an image as RGB maps with values in [0, 1] (EXR: as stored).
pub fn read_rgb(path: &Path) -> Result<LoadedImage> {
    let is_exr = path
        .extension()
        .is_some_and(|e| e.eq_ignore_ascii_case("exr"));
    if is_exr {
        return read_exr_rgb(path);
    }
    let decoded = decode(path)?;
    let has_alpha = decoded.color().has_alpha();
    let img = decoded.into_rgba32f();
    let (w, h) = (img.width() as usize, img.height() as usize);
    if w == 0 || h == 0 {
        return Err(CoreError::Image {
            path: path.to_path_buf(),
            detail: "image has zero size".into(),
        });
    }
    let mut ch = [
        Vec::with_capacity(w * h),
        Vec::with_capacity(w * h),
        Vec::with_capacity(w * h),
        Vec::with_capacity(if has_alpha { w * h } else { 0 }),
    ];
    let mut is_color = false;
    for p in img.pixels() {
        if has_alpha {
            ch[3].push(p.0[3]);
        }
        for (c, &v) in ch[..3].iter_mut().zip(&p.0[..3]) {
            if !v.is_finite() {
                return Err(CoreError::Image {
                    path: path.to_path_buf(),
                    detail: "contains NaN or infinite values".into(),
                });
            }
            c.push(v);
        }
        if (p.0[0] - p.0[1]).abs() > 1.0 / 255.0 || (p.0[0] - p.0[2]).abs() > 1.0 / 255.0 {
            is_color = true;
        }
    }
    let [r, g, b, a] = ch;
    Ok(LoadedImage {
        channels: vec![
            Map::from_vec(w, h, r)?,
            Map::from_vec(w, h, g)?,
            Map::from_vec(w, h, b)?,
        ],
        is_color,
        alpha: if has_alpha {
            Some(Map::from_vec(w, h, a)?)
        } else {
            None
        },
    })
}

/// Loads a greyscale image. Colour images are converted by Rec. 709 luminance and reported
/// through `is_color` so the caller can warn.
pub fn read_grey(path: &Path) -> Result<LoadedImage> {
    let rgb = read_rgb(path)?;
    if !rgb.is_color {
        let r = rgb.channels.into_iter().next().expect("three channels");
        return Ok(LoadedImage {
            channels: vec![r],
            is_color: false,
            alpha: rgb.alpha,
        });
    }
    let (w, h) = (rgb.channels[0].width(), rgb.channels[0].height());
    let d: Vec<f32> = (0..w * h)
        .map(|i| {
            crate::color::luminance([
                rgb.channels[0].data()[i],
                rgb.channels[1].data()[i],
                rgb.channels[2].data()[i],
            ])
        })
        .collect();
    Ok(LoadedImage {
        channels: vec![Map::from_vec(w, h, d)?],
        is_color: true,
        alpha: rgb.alpha,
    })
}

/// EXR through the `exr` crate, so single-channel (Y, or any one channel) files — what paint
/// packages save for masks — load as well as RGB ones.
fn read_exr_rgb(path: &Path) -> Result<LoadedImage> {
    let channels = read_exr_channels(path)?;
    let find = |names: &[&str]| {
        channels
            .iter()
            .find(|(n, _)| names.iter().any(|m| n.eq_ignore_ascii_case(m)))
            .map(|(_, m)| m.clone())
    };
    let bad = |detail: &str| CoreError::Image {
        path: path.to_path_buf(),
        detail: detail.into(),
    };
    let (r, g, b, alpha) = match (find(&["R"]), find(&["G"]), find(&["B"])) {
        (Some(r), Some(g), Some(b)) => (r, g, b, find(&["A"])),
        _ => {
            let y = find(&["Y", "L", "A"])
                .or_else(|| (channels.len() == 1).then(|| channels[0].1.clone()));
            let y = y.ok_or_else(|| bad("no R,G,B channels and no single grey (Y) channel"))?;
            (y.clone(), y.clone(), y, None)
        }
    };
    if [Some(&r), Some(&g), Some(&b), alpha.as_ref()]
        .iter()
        .flatten()
        .any(|m| m.data().iter().any(|v| !v.is_finite()))
    {
        return Err(bad("contains NaN or infinite values"));
    }
    let is_color = r
        .data()
        .iter()
        .zip(g.data())
        .zip(b.data())
        .any(|((r, g), b)| (r - g).abs() > 1.0 / 255.0 || (r - b).abs() > 1.0 / 255.0);
    Ok(LoadedImage {
        channels: vec![r, g, b],
        is_color,
        alpha,
    })
}

/// 8-bit PNG bytes in memory (for containers such as GLB) of 1, 3 or 4 maps of already-encoded
/// values in [0, 1]; `what` names the image in errors.
pub fn png8_bytes(what: &str, maps: &[&Map]) -> Result<Vec<u8>> {
    let path = Path::new(what);
    let (w, h) = check_maps(path, maps)?;
    let n = maps.len();
    let ty = match n {
        1 => ExtendedColorType::L8,
        3 => ExtendedColorType::Rgb8,
        4 => ExtendedColorType::Rgba8,
        n => {
            return Err(CoreError::Encode {
                path: path.to_path_buf(),
                detail: format!("{n} channels (expected 1, 3 or 4)"),
            })
        }
    };
    let mut bytes = vec![0u8; w * h * n];
    for (k, m) in maps.iter().enumerate() {
        for (i, &v) in m.data().iter().enumerate() {
            bytes[i * n + k] = q8(v);
        }
    }
    let mut out = Vec::new();
    PngEncoder::new_with_quality(&mut out, CompressionType::Fast, FilterType::Adaptive)
        .write_image(&bytes, w as u32, h as u32, ty)
        .map_err(|e| CoreError::Encode {
            path: path.to_path_buf(),
            detail: e.to_string(),
        })?;
    Ok(out)
}

/// A value in [0, 1] as an 8-bit code (rounded to nearest; out-of-range values clamped).
#[inline]
pub fn quantize8(v: f32) -> u8 {
    (v.clamp(0.0, 1.0) * 255.0 + 0.5) as u8
}

/// A value in [0, 1] as a 16-bit code (rounded to nearest; out-of-range values clamped).
#[inline]
pub fn quantize16(v: f32) -> u16 {
    (v.clamp(0.0, 1.0) * 65535.0 + 0.5) as u16
}

/// The value a 16-bit code stands for (what [`read_rgb`] gives for a 16-bit PNG):
/// `dequantize16(quantize16(v))` is `v` as a 16-bit file holds it.
#[inline]
pub fn dequantize16(q: u16) -> f32 {
    q as f32 / 65535.0
}

use quantize16 as q16;
use quantize8 as q8;

/// The 8-bit sRGB code of a *linear* value, through a 65 536-entry table of the transfer
/// function (exact to the 8-bit rounding except within 1/65 535 of a code boundary).
#[inline]
pub fn srgb8(v: f32) -> u8 {
    static TABLE: std::sync::OnceLock<Vec<u8>> = std::sync::OnceLock::new();
    let t = TABLE.get_or_init(|| {
        (0..65536u32)
            .map(|i| q8(crate::color::srgb_encode(i as f32 / 65535.0)))
            .collect()
    });
    t[(v.clamp(0.0, 1.0) * 65535.0 + 0.5) as usize]
}

/// Bits per sample of a PNG.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum PngDepth {
    /// 8 bits.
    Eight,
    /// 16 bits (big-endian in the rows, as PNG stores them).
    Sixteen,
}

/// Rows of a PNG filled at once (in parallel) before they are compressed.
const PNG_STRIP_ROWS: usize = 64;

/// Writes a `width` × `height` PNG of `channels` samples per texel (1 grey, 3 RGB, 4 RGBA)
/// atomically, its rows made by `fill(y, row)` (row 0 at the top; `row` holds the row's bytes
/// as PNG stores them) in strips filled in parallel and compressed in order (fdeflate, adaptive
/// filters): no whole-image buffer is made, and the bytes do not depend on the thread count.
pub fn write_png_rows<F>(
    path: &Path,
    width: usize,
    height: usize,
    channels: usize,
    depth: PngDepth,
    fill: F,
) -> Result<()>
where
    F: Fn(usize, &mut [u8]) + Sync,
{
    let mut sink = PngRowSink::create(path, width, height, channels, depth)?;
    sink.push(height, fill)?;
    sink.finish()
}

/// A PNG written from rows pushed in order ([`PngRowSink::push`]), for callers that make the
/// image band by band; [`write_png_rows`] is one push of every row. The file appears at its
/// path on [`PngRowSink::finish`] (atomically); dropped unfinished, it leaves nothing.
pub struct PngRowSink {
    path: std::path::PathBuf,
    tmp: std::path::PathBuf,
    stream: Option<png::StreamWriter<'static, Recording>>,
    failed: std::sync::Arc<std::sync::Mutex<Option<std::io::Error>>>,
    row: usize,
    next: usize,
    height: usize,
    strip: Vec<u8>,
}

/// The file a PNG stream writes to, keeping the first I/O error (the encoder's own writer
/// drops its last errors).
struct Recording {
    file: std::io::BufWriter<std::fs::File>,
    failed: std::sync::Arc<std::sync::Mutex<Option<std::io::Error>>>,
}

impl Recording {
    fn keep<T>(&self, r: std::io::Result<T>) -> std::io::Result<T> {
        if let Err(e) = &r {
            let mut f = self.failed.lock().unwrap_or_else(|p| p.into_inner());
            f.get_or_insert_with(|| std::io::Error::new(e.kind(), e.to_string()));
        }
        r
    }
}

impl std::io::Write for Recording {
    fn write(&mut self, buf: &[u8]) -> std::io::Result<usize> {
        let r = self.file.write(buf);
        self.keep(r)
    }
    fn flush(&mut self) -> std::io::Result<()> {
        let r = self.file.flush();
        self.keep(r)
    }
}

impl Drop for Recording {
    fn drop(&mut self) {
        let r = std::io::Write::flush(&mut self.file);
        let _ = self.keep(r);
    }
}

impl PngRowSink {
    /// Starts `path` (written beside it until [`Self::finish`]); the size and format as
    /// [`write_png_rows`] takes them.
    pub fn create(
        path: &Path,
        width: usize,
        height: usize,
        channels: usize,
        depth: PngDepth,
    ) -> Result<Self> {
        let color = png_color(path, channels)?;
        if width == 0 || height == 0 || width > u32::MAX as usize || height > u32::MAX as usize {
            return Err(encode_error(
                path,
                format!("{width}×{height} texels: expected a positive size"),
            ));
        }
        let bytes = match depth {
            PngDepth::Eight => 1,
            PngDepth::Sixteen => 2,
        };
        let tmp = atomic::temp_path(path);
        let file = std::fs::File::create(&tmp).map_err(|source| CoreError::Write {
            path: path.to_path_buf(),
            source,
        })?;
        let failed = std::sync::Arc::default();
        let out = Recording {
            file: std::io::BufWriter::with_capacity(1 << 20, file),
            failed: std::sync::Arc::clone(&failed),
        };
        let mut sink = PngRowSink {
            path: path.to_path_buf(),
            tmp,
            stream: None,
            failed,
            row: width * channels * bytes,
            next: 0,
            height,
            strip: Vec::new(),
        };
        let mut enc = png::Encoder::new(out, width as u32, height as u32);
        enc.set_color(color);
        enc.set_depth(match depth {
            PngDepth::Eight => png::BitDepth::Eight,
            PngDepth::Sixteen => png::BitDepth::Sixteen,
        });
        enc.set_compression(png::Compression::Fast);
        enc.set_filter(png::Filter::Adaptive);
        let stream = enc
            .write_header()
            .and_then(|w| w.into_stream_writer_with_size(1 << 20))
            .map_err(|e| sink.error(e))?;
        sink.stream = Some(stream);
        Ok(sink)
    }

    /// Appends the next `n` rows, row `y` (counted from the image's top) made by `fill(y, row)`
    /// in strips filled in parallel and compressed in order.
    pub fn push<F>(&mut self, n: usize, fill: F) -> Result<()>
    where
        F: Fn(usize, &mut [u8]) + Sync,
    {
        use rayon::prelude::*;
        if self.next + n > self.height {
            return Err(encode_error(
                &self.path,
                format!(
                    "rows {}..{} pushed: the image has {}",
                    self.next,
                    self.next + n,
                    self.height
                ),
            ));
        }
        let (row, end) = (self.row, self.next + n);
        self.strip.resize(row * PNG_STRIP_ROWS.min(n.max(1)), 0);
        while self.next < end {
            let (y0, k) = (self.next, PNG_STRIP_ROWS.min(end - self.next));
            self.strip[..k * row]
                .par_chunks_mut(row)
                .enumerate()
                .for_each(|(j, r)| fill(y0 + j, r));
            let stream = self.stream.as_mut().expect("a sink writes until finished");
            let r = std::io::Write::write_all(stream, &self.strip[..k * row]);
            r.map_err(|source| CoreError::Write {
                path: self.path.clone(),
                source,
            })?;
            self.next += k;
        }
        Ok(())
    }

    /// Ends the image (every row must have been pushed) and moves it to its path.
    pub fn finish(mut self) -> Result<()> {
        if self.next != self.height {
            let detail = format!("{} of {} rows pushed", self.next, self.height);
            return Err(encode_error(&self.path, detail));
        }
        let stream = self.stream.take().expect("a sink writes until finished");
        let done = stream.finish();
        // The stream's writer (and the file) are closed now; their last errors were kept.
        done.map_err(|e| self.error(e))?;
        if let Some(source) = self.failed.lock().unwrap_or_else(|p| p.into_inner()).take() {
            return Err(CoreError::Write {
                path: self.path.clone(),
                source,
            });
        }
        std::fs::rename(&self.tmp, &self.path).map_err(|source| CoreError::Write {
            path: self.path.clone(),
            source,
        })?;
        self.tmp = std::path::PathBuf::new();
        Ok(())
    }

    fn error(&self, e: png::EncodingError) -> CoreError {
        encode_error(&self.path, e.to_string())
    }
}

impl Drop for PngRowSink {
    fn drop(&mut self) {
        drop(self.stream.take());
        if !self.tmp.as_os_str().is_empty() {
            let _ = std::fs::remove_file(&self.tmp);
        }
    }
}

fn encode_error(path: &Path, detail: String) -> CoreError {
    CoreError::Encode {
        path: path.to_path_buf(),
        detail,
    }
}

/// The PNG colour type of `channels` samples per texel.
fn png_color(path: &Path, channels: usize) -> Result<png::ColorType> {
    match channels {
        1 => Ok(png::ColorType::Grayscale),
        3 => Ok(png::ColorType::Rgb),
        4 => Ok(png::ColorType::Rgba),
        n => Err(encode_error(
            path,
            format!("{n} channels (expected 1, 3 or 4)"),
        )),
    }
}

/// Writes 1 (grey), 3 (RGB) or 4 (RGBA) maps of already-encoded values in [0, 1] as an 8-bit PNG.
pub fn write_png8(path: &Path, maps: &[&Map]) -> Result<()> {
    write_png8_with(path, maps, q8)
}

/// Writes 1 or 3 maps of *linear* values as an 8-bit sRGB PNG (alpha is not encoded), through
/// [`srgb8`].
pub fn write_png8_srgb(path: &Path, maps: &[&Map]) -> Result<()> {
    write_png8_with(path, maps, srgb8)
}

/// Interleaves `maps` into 8-bit samples with `quantise`, row by row, and encodes them.
fn write_png8_with(path: &Path, maps: &[&Map], quantise: impl Fn(f32) -> u8 + Sync) -> Result<()> {
    let (w, h) = check_maps(path, maps)?;
    let n = maps.len();
    write_png_rows(path, w, h, n, PngDepth::Eight, |y, row| {
        for (k, m) in maps.iter().enumerate() {
            for (x, &v) in m.data()[y * w..(y + 1) * w].iter().enumerate() {
                row[x * n + k] = quantise(v);
            }
        }
    })
}

/// Writes 1, 3 or 4 maps of values in [0, 1] as a 16-bit PNG.
pub fn write_png16(path: &Path, maps: &[&Map]) -> Result<()> {
    let (w, h) = check_maps(path, maps)?;
    let n = maps.len();
    write_png_rows(path, w, h, n, PngDepth::Sixteen, |y, row| {
        for (k, m) in maps.iter().enumerate() {
            for (x, &v) in m.data()[y * w..(y + 1) * w].iter().enumerate() {
                let i = 2 * (x * n + k);
                row[i..i + 2].copy_from_slice(&q16(v).to_be_bytes());
            }
        }
    })
}

fn check_maps(path: &Path, maps: &[&Map]) -> Result<(usize, usize)> {
    let Some(first) = maps.first() else {
        return Err(CoreError::Encode {
            path: path.to_path_buf(),
            detail: "no channels (expected 1, 3 or 4)".into(),
        });
    };
    let (w, h) = (first.width(), first.height());
    if maps.iter().any(|m| m.width() != w || m.height() != h) {
        return Err(CoreError::Encode {
            path: path.to_path_buf(),
            detail: "channels differ in size".into(),
        });
    }
    Ok((w, h))
}

pub use crate::exr_writer::ExrPrecision;

/// Writes named single-channel maps into one OpenEXR file (scan lines, one channel per map;
/// half floats RLE-compressed, f32 uncompressed: noisy f32 samples do not compress under RLE,
/// BENCHMARKS.md) through [`crate::exr_writer`], which compresses blocks in parallel and writes
/// them in order: the bytes are identical at any thread count.
pub fn write_exr(path: &Path, channels: &[(&str, &Map)], precision: ExrPrecision) -> Result<()> {
    let (w, h) = match channels.first() {
        Some((_, m)) => (m.width(), m.height()),
        None => {
            return Err(CoreError::Encode {
                path: path.to_path_buf(),
                detail: "no channels".into(),
            })
        }
    };
    if channels
        .iter()
        .any(|(_, m)| m.width() != w || m.height() != h)
    {
        return Err(CoreError::Encode {
            path: path.to_path_buf(),
            detail: "channels differ in size".into(),
        });
    }
    let list: Vec<crate::exr_writer::ExrChannel> = channels
        .iter()
        .map(|(name, _)| crate::exr_writer::ExrChannel { name, precision })
        .collect();
    let compression = match precision {
        ExrPrecision::F32 => crate::exr_writer::ExrCompression::None,
        ExrPrecision::F16 => crate::exr_writer::ExrCompression::Rle,
    };
    crate::exr_writer::write_exr_rows(path, w, h, &list, compression, |y, rows| {
        for (row, (_, m)) in rows.iter_mut().zip(channels) {
            row.copy_from_slice(&m.data()[y * w..(y + 1) * w]);
        }
    })
}

/// Most samples an EXR file may promise per byte of its size. Lossless EXR compressors expand
/// far less (RLE at most 64:1, ZIP's deflate about 1032:1 per block): a header promising more
/// is damaged, and is refused before its samples are allocated (a flipped bit in the data
/// window can otherwise claim gigabytes).
const MAX_EXR_EXPANSION: u64 = 4096;

/// Refuses an EXR whose headers promise more sample bytes than its size can hold.
fn check_exr_size(path: &Path) -> Result<()> {
    let bad = |detail: String| CoreError::Image {
        path: path.to_path_buf(),
        detail,
    };
    let meta = exr::meta::MetaData::read_from_file(path, false).map_err(|e| bad(e.to_string()))?;
    let len = std::fs::metadata(path)
        .map_err(|source| CoreError::Read {
            path: path.to_path_buf(),
            source,
        })?
        .len();
    let promised: u64 = meta
        .headers
        .iter()
        .map(|h| h.layer_size.area() as u64 * h.channels.bytes_per_pixel as u64)
        .sum();
    if promised > len.saturating_mul(MAX_EXR_EXPANSION) {
        let size = meta.headers.first().map(|h| h.layer_size);
        return Err(bad(format!(
            "its header promises {} texels ({} MB of samples) in a {len}-byte file: it is damaged",
            size.map_or("?".into(), |s| format!("{}×{}", s.width(), s.height())),
            promised >> 20
        )));
    }
    Ok(())
}

/// Reads every channel of an OpenEXR file's first layer, by name.
pub fn read_exr_channels(path: &Path) -> Result<Vec<(String, Map)>> {
    use exr::prelude::*;
    check_exr_size(path)?;
    let img = read_all_flat_layers_from_file(path).map_err(|e| CoreError::Image {
        path: path.to_path_buf(),
        detail: e.to_string(),
    })?;
    let layer = img.layer_data.first().ok_or_else(|| CoreError::Image {
        path: path.to_path_buf(),
        detail: "no layers".into(),
    })?;
    let (w, h) = (layer.size.width(), layer.size.height());
    layer
        .channel_data
        .list
        .iter()
        .map(|c| {
            let v: Vec<f32> = c.sample_data.values_as_f32().collect();
            Ok((c.name.to_string(), Map::from_vec(w, h, v)?))
        })
        .collect()
}

/// Writes an animated PNG of `frames` (RGB 8-bit sRGB bytes, all `w` × `h`) at `fps`,
/// atomically (turntables, eye sequences: every browser plays it).
pub fn write_apng(path: &Path, frames: &[Vec<u8>], w: usize, h: usize, fps: u16) -> Result<()> {
    let mut out = Vec::new();
    {
        let err = |e: png::EncodingError| CoreError::Encode {
            path: path.to_path_buf(),
            detail: e.to_string(),
        };
        let mut enc = png::Encoder::new(&mut out, w as u32, h as u32);
        enc.set_color(png::ColorType::Rgb);
        enc.set_depth(png::BitDepth::Eight);
        enc.set_animated(frames.len() as u32, 0).map_err(err)?;
        enc.set_frame_delay(1, fps).map_err(err)?;
        let mut wr = enc.write_header().map_err(err)?;
        for f in frames {
            wr.write_image_data(f).map_err(err)?;
        }
        wr.finish().map_err(err)?;
    }
    crate::atomic::write_bytes(path, &out)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn tmpdir(tag: &str) -> std::path::PathBuf {
        derma_test_support::scratch_dir(&format!("io-{tag}"))
    }

    #[test]
    fn an_rgba_pngs_alpha_is_read_and_an_rgb_pngs_is_none() {
        let d = tmpdir("alpha");
        let g = Map::from_fn(4, 2, |i| i as f32 / 7.0);
        let a = Map::from_fn(4, 2, |i| if i % 2 == 0 { 0.0 } else { 1.0 });
        let (rgba, rgb) = (d.join("rgba.png"), d.join("rgb.png"));
        write_png8(&rgba, &[&g, &g, &g, &a]).unwrap();
        write_png8(&rgb, &[&g, &g, &g]).unwrap();
        let read = read_rgb(&rgba).unwrap();
        assert_eq!(read.alpha.unwrap().data(), a.data());
        for (x, y) in read.channels[0].data().iter().zip(g.data()) {
            assert!((x - y).abs() <= 0.5 / 255.0, "{x} vs {y}");
        }
        assert!(read_rgb(&rgb).unwrap().alpha.is_none());
        // An EXR with A beside R, G and B keeps it.
        let exr = d.join("rgba.exr");
        write_exr(
            &exr,
            &[("R", &g), ("G", &g), ("B", &g), ("A", &a)],
            ExrPrecision::F32,
        )
        .unwrap();
        assert_eq!(read_rgb(&exr).unwrap().alpha.unwrap().data(), a.data());
    }

    #[test]
    fn png16_and_exr_roundtrip() {
        let d = tmpdir("rt");
        let mut m = Map::filled(5, 3, 0.0);
        for i in 0..15 {
            m.data_mut()[i] = i as f32 / 14.0;
        }
        let p = d.join("g.png");
        write_png16(&p, &[&m]).unwrap();
        let back = read_grey(&p).unwrap();
        assert!(!back.is_color);
        for (a, b) in back.channels[0].data().iter().zip(m.data()) {
            assert!((a - b).abs() < 1.0 / 65535.0 + 1e-6);
            // Bit for bit what dequantize16 says the file holds (the template round trip).
            assert_eq!(a.to_bits(), dequantize16(quantize16(*b)).to_bits());
        }
        // Values already on the 16-bit grid come back unchanged, through RGB too.
        let g = m.map(|v| dequantize16(quantize16(v)));
        write_png16(&p, &[&g, &g, &m]).unwrap();
        let back = read_rgb(&p).unwrap();
        assert_eq!(back.channels[0], g);
        let e = d.join("m.exr");
        write_exr(&e, &[("height", &m), ("melanin", &m)], ExrPrecision::F32).unwrap();
        let ch = read_exr_channels(&e).unwrap();
        assert_eq!(ch.len(), 2);
        assert_eq!(ch[0].1, m);
        std::fs::remove_dir_all(&d).unwrap();
    }

    #[test]
    fn png_rows_cross_strips_and_read_back_exactly() {
        // 150 rows: two full strips and a partial one; 16-bit RGB and 8-bit grey, decoded by the
        // image crate.
        let d = tmpdir("rows");
        let (w, h) = (70, 150);
        let v = |x: usize, y: usize, k: usize| ((x * 977 + y * 131 + k * 7919) % 65536) as u16;
        let p = d.join("rgb16.png");
        write_png_rows(&p, w, h, 3, PngDepth::Sixteen, |y, row| {
            for x in 0..w {
                for k in 0..3 {
                    let i = 2 * (3 * x + k);
                    row[i..i + 2].copy_from_slice(&v(x, y, k).to_be_bytes());
                }
            }
        })
        .unwrap();
        let img = image::open(&p).unwrap().into_rgb16();
        for (x, y, px) in img.enumerate_pixels() {
            let (x, y) = (x as usize, y as usize);
            assert_eq!(px.0, [v(x, y, 0), v(x, y, 1), v(x, y, 2)], "({x}, {y})");
        }
        let p = d.join("grey8.png");
        write_png_rows(&p, w, h, 1, PngDepth::Eight, |y, row| {
            row.iter_mut()
                .enumerate()
                .for_each(|(x, b)| *b = v(x, y, 0) as u8);
        })
        .unwrap();
        let img = image::open(&p).unwrap().into_luma8();
        assert!(img
            .enumerate_pixels()
            .all(|(x, y, px)| px.0[0] == v(x as usize, y as usize, 0) as u8));
        let e = write_png_rows(&p, w, h, 2, PngDepth::Eight, |_, _| {}).unwrap_err();
        assert!(e.to_string().contains("2 channels"), "{e}");
        std::fs::remove_dir_all(&d).unwrap();
    }

    #[test]
    fn srgb_table_matches_the_transfer_function() {
        let d = tmpdir("srgb");
        let m = Map::from_vec(
            256,
            1,
            (0..256).map(|i| (i as f32 / 255.0).powf(2.2)).collect(),
        )
        .unwrap();
        let p = d.join("s.png");
        write_png8_srgb(&p, &[&m]).unwrap();
        let back = read_grey(&p).unwrap();
        for (i, &v) in back.channels[0].data().iter().enumerate() {
            let want = q8(crate::color::srgb_encode(m.data()[i]));
            assert!(((v * 255.0).round() as i32 - want as i32).abs() <= 1, "{i}");
        }
        std::fs::remove_dir_all(&d).unwrap();
    }

    #[test]
    fn greyscale_exr_reads_as_a_field() {
        // A painted field saved from a paint package as single-channel (Y) float EXR.
        let d = tmpdir("exrfield");
        let mut m = Map::filled(6, 4, 0.25);
        m.set(5, 3, 0.75);
        let p = d.join("moles.exr");
        write_exr(&p, &[("Y", &m)], ExrPrecision::F32).unwrap();
        let g = read_grey(&p).unwrap();
        assert!(!g.is_color);
        assert_eq!((g.channels[0].width(), g.channels[0].height()), (6, 4));
        assert!(
            (g.channels[0].get(0, 0) - 0.25).abs() < 1e-6
                && (g.channels[0].get(5, 3) - 0.75).abs() < 1e-6
        );
        std::fs::remove_dir_all(&d).unwrap();
    }

    #[test]
    fn color_image_is_flagged_and_converted() {
        let d = tmpdir("col");
        let r = Map::filled(2, 2, 1.0);
        let z = Map::filled(2, 2, 0.0);
        let p = d.join("c.png");
        write_png8(&p, &[&r, &z, &z]).unwrap();
        let g = read_grey(&p).unwrap();
        assert!(g.is_color);
        assert!((g.channels[0].get(0, 0) - 0.2126).abs() < 1e-3);
        std::fs::remove_dir_all(&d).unwrap();
    }

    #[test]
    fn corrupt_file_error_names_the_file() {
        let d = tmpdir("bad");
        let p = d.join("broken.png");
        std::fs::write(&p, b"not a png at all").unwrap();
        let e = read_grey(&p).err().unwrap().to_string();
        assert!(e.contains("broken.png"), "{e}");
        let e = read_grey(&d.join("missing.png")).err().unwrap().to_string();
        assert!(e.contains("missing.png"), "{e}");
        std::fs::remove_dir_all(&d).unwrap();
    }

    #[test]
    fn rows_pushed_in_uneven_bands_give_the_bytes_of_one_push_and_decode() {
        let d = tmpdir("bands");
        let (w, h) = (23, 150);
        let fill = |y: usize, row: &mut [u8]| {
            for (x, v) in row.iter_mut().enumerate() {
                *v = ((x * 7 + y * 13) % 251) as u8;
            }
        };
        let whole = d.join("whole.png");
        write_png_rows(&whole, w, h, 3, PngDepth::Sixteen, fill).unwrap();
        let banded = d.join("banded.png");
        let mut sink = PngRowSink::create(&banded, w, h, 3, PngDepth::Sixteen).unwrap();
        for n in [1, 70, 0, 64, 15] {
            sink.push(n, fill).unwrap();
        }
        assert!(!banded.exists(), "the file appears only when finished");
        sink.finish().unwrap();
        let bytes = std::fs::read(&banded).unwrap();
        assert_eq!(std::fs::read(&whole).unwrap(), bytes);
        // The image crate (an independent decoder) reads the rows back.
        let img = image::load_from_memory(&bytes).unwrap().into_rgb16();
        let px = img.get_pixel(5, 101);
        let byte = |k: usize| ((k * 7 + 101 * 13) % 251) as u16;
        assert_eq!(px[1], byte(5 * 6 + 2) << 8 | byte(5 * 6 + 3));
    }

    #[test]
    fn an_unfinished_png_leaves_nothing() {
        let d = tmpdir("unfinished");
        let p = d.join("u.png");
        let mut sink = PngRowSink::create(&p, 4, 4, 1, PngDepth::Eight).unwrap();
        sink.push(2, |_, _| {}).unwrap();
        let e = sink.finish().unwrap_err();
        assert!(e.to_string().contains("2 of 4 rows pushed"), "{e}");
        let left: Vec<_> = std::fs::read_dir(&d).unwrap().flatten().collect();
        assert!(left.is_empty(), "left behind: {left:?}");
    }
}

//! OpenEXR scan-line files written straight from their rows (OpenEXR 2 file layout, Kainz,
//! Bogart & Stanczyk, "Technical Introduction to OpenEXR" and "OpenEXR File Layout"): the caller
//! fills one channel of one line at a time, blocks are compressed in parallel and written in
//! order, and no whole-image copy of the samples is ever made.
//!
//! Why derma writes EXR itself: a texture set's EXRs hold up to 12 channels of 16.8 M texels;
//! going through a general image library needed every channel as a whole planar copy (and its
//! half-float copy) before the first byte was written, 800 MB at 4096² for `bio.exr` alone
//! (BENCHMARKS.md, issue 15). Reading stays with the `exr` crate, which the tests use as the
//! independent decoder of every file written here.

use crate::atomic;
use crate::error::{CoreError, Result};
use rayon::prelude::*;
use std::io::{Seek, SeekFrom, Write};
use std::path::Path;

/// Sample precision of an EXR layer.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ExrPrecision {
    /// 32-bit float.
    F32,
    /// 16-bit half float.
    F16,
}

/// How the blocks of an EXR file are compressed (all lossless).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ExrCompression {
    /// Samples as they are (one line per block).
    None,
    /// Byte-wise run-length coding after the byte split and delta predictor (one line per
    /// block).
    Rle,
    /// zlib (deflate level 1) after the same predictor, 16 lines per block.
    Zip,
}

impl ExrCompression {
    /// The header's compression code (OpenEXR file layout, "compression" attribute).
    fn code(self) -> u8 {
        match self {
            ExrCompression::None => 0,
            ExrCompression::Rle => 1,
            ExrCompression::Zip => 3,
        }
    }

    /// Scan lines per block for the method.
    pub fn lines_per_block(self) -> usize {
        match self {
            ExrCompression::None | ExrCompression::Rle => 1,
            ExrCompression::Zip => 16,
        }
    }
}

/// One channel of the file: its name and sample precision.
#[derive(Clone, Copy, Debug)]
pub struct ExrChannel<'a> {
    /// Channel name (stored sorted, as the format requires).
    pub name: &'a str,
    /// Sample type.
    pub precision: ExrPrecision,
}

/// Blocks compressed per batch before they are written (bounds the memory in flight).
const BLOCKS_PER_BATCH: usize = 64;

/// Writes a `width` × `height` scan-line EXR atomically. `fill(y, rows)` writes line `y`
/// (0 = top) of every channel, `rows[c]` (`width` samples) for `channels[c]` as given, in one
/// pass over the caller's data. It is called from several threads; the file's bytes do not
/// depend on how many.
pub fn write_exr_rows<F>(
    path: &Path,
    width: usize,
    height: usize,
    channels: &[ExrChannel<'_>],
    compression: ExrCompression,
    fill: F,
) -> Result<()>
where
    F: Fn(usize, &mut [&mut [f32]]) + Sync,
{
    let mut sink = ExrRowSink::create(path, width, height, channels, compression)?;
    sink.push(height, fill)?;
    sink.finish()
}

/// A scan-line EXR written from lines pushed in order ([`ExrRowSink::push`]), for callers that
/// make the image band by band; [`write_exr_rows`] is one push of every line. Blocks are
/// compressed as soon as their lines are in; the file appears at its path on
/// [`ExrRowSink::finish`] (atomically); dropped unfinished, it leaves nothing.
pub struct ExrRowSink {
    path: std::path::PathBuf,
    tmp: std::path::PathBuf,
    out: std::io::BufWriter<std::fs::File>,
    width: usize,
    height: usize,
    /// Channel precisions as given, and the order the file stores them in.
    precisions: Vec<ExrPrecision>,
    order: Vec<usize>,
    compression: ExrCompression,
    table_at: u64,
    at: u64,
    offsets: Vec<u64>,
    /// The next line to push, and the raw lines of its block pushed so far.
    next: usize,
    pending: Vec<u8>,
}

impl ExrRowSink {
    /// Starts `path` (written beside it until [`Self::finish`]), its header and a blank offset
    /// table written; the size, channels and compression as [`write_exr_rows`] takes them.
    pub fn create(
        path: &Path,
        width: usize,
        height: usize,
        channels: &[ExrChannel<'_>],
        compression: ExrCompression,
    ) -> Result<Self> {
        let order = checked_order(path, width, height, channels)?;
        let sorted: Vec<ExrChannel> = order.iter().map(|&k| channels[k]).collect();
        let header = header_bytes(width, height, &sorted, compression);
        let blocks = height.div_ceil(compression.lines_per_block());
        let tmp = atomic::temp_path(path);
        let io = |source: std::io::Error| CoreError::Write {
            path: path.to_path_buf(),
            source,
        };
        let file = std::fs::File::create(&tmp).map_err(io)?;
        let mut sink = ExrRowSink {
            path: path.to_path_buf(),
            tmp,
            out: std::io::BufWriter::with_capacity(1 << 20, file),
            width,
            height,
            precisions: channels.iter().map(|c| c.precision).collect(),
            order,
            compression,
            table_at: header.len() as u64,
            at: (header.len() + 8 * blocks) as u64,
            offsets: Vec::with_capacity(blocks),
            next: 0,
            pending: Vec::new(),
        };
        sink.out.write_all(&header).map_err(io)?;
        // The offset table, filled in once every block's position is known.
        sink.out.write_all(&vec![0u8; 8 * blocks]).map_err(io)?;
        Ok(sink)
    }

    /// Appends the next `n` lines, line `y` (counted from the image's top) made by
    /// `fill(y, rows)`; whole blocks are filled and compressed in parallel.
    pub fn push<F>(&mut self, n: usize, fill: F) -> Result<()>
    where
        F: Fn(usize, &mut [&mut [f32]]) + Sync,
    {
        let end = self.next + n;
        if end > self.height {
            return Err(self.bad(format!(
                "lines {}..{end} pushed: the image has {}",
                self.next, self.height
            )));
        }
        let lpb = self.compression.lines_per_block();
        // A block begun by the last push, line by line.
        while self.next < end && (!self.next.is_multiple_of(lpb) || !self.pending.is_empty()) {
            self.push_line(&fill)?;
        }
        // Whole blocks, in parallel batches.
        let whole_end = if end == self.height {
            end
        } else {
            end - end % lpb
        };
        while self.next < whole_end {
            let first = self.next / lpb;
            let last = (first + BLOCKS_PER_BATCH).min(whole_end.div_ceil(lpb));
            let chunks = self.blocks(first..last, &fill);
            for c in &chunks {
                self.emit(c)?;
            }
            self.next = (last * lpb).min(self.height);
        }
        // The start of a block the next push ends.
        while self.next < end {
            self.push_line(&fill)?;
        }
        Ok(())
    }

    /// Fills and compresses `blocks` in parallel.
    fn blocks<F>(&self, blocks: std::ops::Range<usize>, fill: &F) -> Vec<Vec<u8>>
    where
        F: Fn(usize, &mut [&mut [f32]]) + Sync,
    {
        let lpb = self.compression.lines_per_block();
        blocks
            .into_par_iter()
            .map_init(
                || (Vec::new(), Vec::new(), Vec::new()),
                |(rows, raw, halves), b| {
                    let (y0, y1) = (b * lpb, ((b + 1) * lpb).min(self.height));
                    raw.clear();
                    for y in y0..y1 {
                        self.line(y, fill, rows, raw, halves);
                    }
                    chunk(y0 as i32, raw, self.compression)
                },
            )
            .collect()
    }

    /// Line `y` from `fill`, appended to `raw` in the file's channel order.
    fn line<F>(
        &self,
        y: usize,
        fill: &F,
        rows: &mut Vec<Vec<f32>>,
        raw: &mut Vec<u8>,
        halves: &mut Vec<half::f16>,
    ) where
        F: Fn(usize, &mut [&mut [f32]]) + Sync,
    {
        rows.resize(self.precisions.len(), Vec::new());
        for r in rows.iter_mut() {
            r.clear();
            r.resize(self.width, 0.0);
        }
        let mut refs: Vec<&mut [f32]> = rows.iter_mut().map(|r| r.as_mut_slice()).collect();
        fill(y, &mut refs);
        for &k in &self.order {
            push_samples(raw, &rows[k], halves, self.precisions[k]);
        }
    }

    /// The next line into the pending block, which is compressed and written once complete.
    fn push_line<F>(&mut self, fill: &F) -> Result<()>
    where
        F: Fn(usize, &mut [&mut [f32]]) + Sync,
    {
        let lpb = self.compression.lines_per_block();
        let mut raw = std::mem::take(&mut self.pending);
        self.line(self.next, fill, &mut Vec::new(), &mut raw, &mut Vec::new());
        self.next += 1;
        if self.next.is_multiple_of(lpb) || self.next == self.height {
            let y0 = (self.next - 1) / lpb * lpb;
            let c = chunk(y0 as i32, &raw, self.compression);
            self.emit(&c)?;
        } else {
            self.pending = raw;
        }
        Ok(())
    }

    fn emit(&mut self, c: &[u8]) -> Result<()> {
        self.offsets.push(self.at);
        self.at += c.len() as u64;
        let path = &self.path;
        self.out.write_all(c).map_err(|source| CoreError::Write {
            path: path.clone(),
            source,
        })
    }

    /// Ends the image (every line must have been pushed): writes the offset table and moves
    /// the file to its path.
    pub fn finish(mut self) -> Result<()> {
        if self.next != self.height {
            return Err(self.bad(format!("{} of {} lines pushed", self.next, self.height)));
        }
        let path = self.path.clone();
        let io = |source: std::io::Error| CoreError::Write {
            path: path.clone(),
            source,
        };
        self.out.seek(SeekFrom::Start(self.table_at)).map_err(io)?;
        let table: Vec<u8> = self.offsets.iter().flat_map(|o| o.to_le_bytes()).collect();
        self.out.write_all(&table).map_err(io)?;
        self.out.flush().map_err(io)?;
        std::fs::rename(&self.tmp, &self.path).map_err(io)?;
        self.tmp = std::path::PathBuf::new();
        Ok(())
    }

    fn bad(&self, detail: String) -> CoreError {
        CoreError::Encode {
            path: self.path.clone(),
            detail,
        }
    }
}

impl Drop for ExrRowSink {
    fn drop(&mut self) {
        if !self.tmp.as_os_str().is_empty() {
            let _ = std::fs::remove_file(&self.tmp);
        }
    }
}

/// Checks the size and channels of an EXR to write; returns the order the file stores the
/// channels in (sorted by name, as the format requires).
fn checked_order(
    path: &Path,
    width: usize,
    height: usize,
    channels: &[ExrChannel<'_>],
) -> Result<Vec<usize>> {
    let bad = |detail: String| CoreError::Encode {
        path: path.to_path_buf(),
        detail,
    };
    if width == 0 || height == 0 || width > i32::MAX as usize || height > i32::MAX as usize {
        return Err(bad(format!(
            "{width}×{height} texels: expected a positive size"
        )));
    }
    if channels.is_empty() {
        return Err(bad("no channels".into()));
    }
    let mut order: Vec<usize> = (0..channels.len()).collect();
    order.sort_by(|&a, &b| channels[a].name.as_bytes().cmp(channels[b].name.as_bytes()));
    for w in order.windows(2) {
        if channels[w[0]].name == channels[w[1]].name {
            return Err(bad(format!(
                "channel '{}' is given twice",
                channels[w[0]].name
            )));
        }
    }
    if let Some(c) = channels
        .iter()
        .find(|c| c.name.is_empty() || c.name.len() > 255 || c.name.contains('\0'))
    {
        return Err(bad(format!(
            "channel name '{}': expected 1 to 255 bytes without NUL",
            c.name
        )));
    }
    Ok(order)
}

/// Appends `row` to `raw` as little-endian samples of `precision` (half floats rounded to
/// nearest even, by the CPU's conversion instructions where it has them).
fn push_samples(
    raw: &mut Vec<u8>,
    row: &[f32],
    halves: &mut Vec<half::f16>,
    precision: ExrPrecision,
) {
    use half::slice::HalfFloatSliceExt;
    match precision {
        ExrPrecision::F32 => {
            let at = raw.len();
            raw.resize(at + 4 * row.len(), 0);
            for (o, v) in raw[at..].chunks_exact_mut(4).zip(row) {
                o.copy_from_slice(&v.to_le_bytes());
            }
        }
        ExrPrecision::F16 => {
            halves.resize(row.len(), half::f16::ZERO);
            halves.convert_from_f32_slice(row);
            let at = raw.len();
            raw.resize(at + 2 * row.len(), 0);
            for (o, v) in raw[at..].chunks_exact_mut(2).zip(halves.iter()) {
                o.copy_from_slice(&v.to_le_bytes());
            }
        }
    }
}

/// One chunk: first line, data size, data (stored raw when compression does not shrink it, as
/// the format allows: a reader takes a block of the uncompressed size as uncompressed).
fn chunk(y: i32, raw: &[u8], compression: ExrCompression) -> Vec<u8> {
    let packed = match compression {
        ExrCompression::None => None,
        ExrCompression::Rle => Some(rle(&predict(raw))),
        ExrCompression::Zip => Some(miniz_oxide::deflate::compress_to_vec_zlib(&predict(raw), 1)),
    };
    let data = match &packed {
        Some(p) if p.len() < raw.len() => p.as_slice(),
        _ => raw,
    };
    let mut c = Vec::with_capacity(8 + data.len());
    c.extend_from_slice(&y.to_le_bytes());
    c.extend_from_slice(&(data.len() as i32).to_le_bytes());
    c.extend_from_slice(data);
    c
}

/// The RLE and ZIP methods' preprocessing: the bytes at even positions, then those at odd
/// positions (the low and high bytes of half floats fall apart), then each byte replaced by its
/// difference to the previous one plus 128 (mod 256).
fn predict(raw: &[u8]) -> Vec<u8> {
    let mut split = vec![0u8; raw.len()];
    let (even, odd) = split.split_at_mut(raw.len().div_ceil(2));
    let pairs = raw.chunks_exact(2);
    if let [last] = pairs.remainder() {
        even[even.len() - 1] = *last;
    }
    for ((e, o), p) in even.iter_mut().zip(odd.iter_mut()).zip(pairs) {
        (*e, *o) = (p[0], p[1]);
    }
    // Differences to the previous byte of the split stream (independent: it vectorises).
    let mut out = vec![0u8; raw.len()];
    let Some(&first) = split.first() else {
        return out;
    };
    out[0] = first;
    for (o, w) in out[1..].iter_mut().zip(split.windows(2)) {
        *o = w[1].wrapping_sub(w[0]).wrapping_add(128);
    }
    out
}

/// OpenEXR's run-length code: a signed count byte, then either count + 1 copies of one byte
/// (count ≥ 0, runs of 3 to 128) or −count literal bytes (count < 0, up to 127). Greedy: a run
/// wherever three equal bytes start, literals in between.
fn rle(data: &[u8]) -> Vec<u8> {
    let mut out = Vec::with_capacity(data.len() / 2);
    let n = data.len();
    let mut i = 0;
    while i < n {
        let r = run_length(data, i, 128);
        if r >= 3 {
            out.push((r - 1) as u8);
            out.push(data[i]);
            i += r;
        } else {
            // Literals until the next run of three (or 127 bytes).
            let end = next_run3(data, i, (i + 127).min(n));
            out.push((-((end - i) as i32)) as i8 as u8);
            out.extend_from_slice(&data[i..end]);
            i = end;
        }
    }
    out
}

/// Bytes equal to `data[i]` from `i` on, at most `max`.
#[inline]
fn run_length(data: &[u8], i: usize, max: usize) -> usize {
    let end = (i + max).min(data.len());
    let b = data[i];
    let mut j = i + 1;
    let word = u64::from_ne_bytes([b; 8]);
    while j + 8 <= end {
        let w = u64::from_ne_bytes(data[j..j + 8].try_into().expect("8 bytes"));
        let diff = w ^ word;
        if diff != 0 {
            // The first differing byte in memory order.
            let k = if cfg!(target_endian = "little") {
                diff.trailing_zeros()
            } else {
                diff.leading_zeros()
            } / 8;
            return j + k as usize - i;
        }
        j += 8;
    }
    while j < end && data[j] == b {
        j += 1;
    }
    j - i
}

/// The first position in [`from`, `limit`) where three equal bytes start (`limit` if none): eight
/// positions per step, a zero byte of (w ⊕ w≫8) | (w ⊕ w≫16) marking one (the classic
/// "has a zero byte" test, whose lowest flag is exact).
#[inline]
fn next_run3(data: &[u8], from: usize, limit: usize) -> usize {
    const LO: u64 = 0x0101_0101_0101_0101;
    const HI: u64 = 0x8080_8080_8080_8080;
    let n = data.len();
    let mut i = from;
    while i < limit && i + 10 <= n {
        let at = |k: usize| u64::from_le_bytes(data[k..k + 8].try_into().expect("8 bytes"));
        let z = (at(i) ^ at(i + 1)) | (at(i) ^ at(i + 2));
        let flags = z.wrapping_sub(LO) & !z & HI;
        if flags != 0 {
            return (i + (flags.trailing_zeros() / 8) as usize).min(limit);
        }
        i += 8;
    }
    while i < limit {
        if i + 2 < n && data[i] == data[i + 1] && data[i] == data[i + 2] {
            return i;
        }
        i += 1;
    }
    limit
}

/// The header: magic number, version 2 (single-part scan lines), the required attributes, and
/// the terminating NUL.
fn header_bytes(
    width: usize,
    height: usize,
    channels: &[ExrChannel<'_>],
    compression: ExrCompression,
) -> Vec<u8> {
    let mut h = Vec::new();
    h.extend_from_slice(&20000630i32.to_le_bytes());
    // Version 2; bit 10 (0x400) marks names longer than 31 bytes.
    let long_names = channels.iter().any(|c| c.name.len() > 31);
    h.extend_from_slice(&(2u32 | if long_names { 0x400 } else { 0 }).to_le_bytes());
    let mut attr = |name: &str, ty: &str, value: &[u8]| {
        h.extend_from_slice(name.as_bytes());
        h.push(0);
        h.extend_from_slice(ty.as_bytes());
        h.push(0);
        h.extend_from_slice(&(value.len() as i32).to_le_bytes());
        h.extend_from_slice(value);
    };
    let mut chlist = Vec::new();
    for c in channels {
        chlist.extend_from_slice(c.name.as_bytes());
        chlist.push(0);
        let pixel_type: i32 = match c.precision {
            ExrPrecision::F16 => 1,
            ExrPrecision::F32 => 2,
        };
        chlist.extend_from_slice(&pixel_type.to_le_bytes());
        chlist.extend_from_slice(&[0, 0, 0, 0]); // pLinear, reserved
        chlist.extend_from_slice(&1i32.to_le_bytes()); // x sampling
        chlist.extend_from_slice(&1i32.to_le_bytes()); // y sampling
    }
    chlist.push(0);
    attr("channels", "chlist", &chlist);
    attr("compression", "compression", &[compression.code()]);
    let window: Vec<u8> = [0i32, 0, width as i32 - 1, height as i32 - 1]
        .iter()
        .flat_map(|v| v.to_le_bytes())
        .collect();
    attr("dataWindow", "box2i", &window);
    attr("displayWindow", "box2i", &window);
    attr("lineOrder", "lineOrder", &[0]); // increasing y
    attr("pixelAspectRatio", "float", &1.0f32.to_le_bytes());
    let centre: Vec<u8> = [0.0f32, 0.0].iter().flat_map(|v| v.to_le_bytes()).collect();
    attr("screenWindowCenter", "v2f", &centre);
    attr("screenWindowWidth", "float", &1.0f32.to_le_bytes());
    h.push(0);
    h
}

#[cfg(test)]
mod tests {
    use super::*;

    fn tmp(tag: &str) -> std::path::PathBuf {
        let d = std::env::temp_dir().join(format!("derma-exr-{tag}-{}", std::process::id()));
        std::fs::create_dir_all(&d).unwrap();
        d.join("t.exr")
    }

    /// Decodes with the `exr` crate (an independent implementation of the format).
    fn read(path: &Path) -> Vec<(String, usize, usize, Vec<f32>)> {
        use exr::prelude::*;
        let img = read_all_flat_layers_from_file(path).unwrap();
        let l = &img.layer_data[0];
        l.channel_data
            .list
            .iter()
            .map(|c| {
                (
                    c.name.to_string(),
                    l.size.width(),
                    l.size.height(),
                    c.sample_data.values_as_f32().collect(),
                )
            })
            .collect()
    }

    /// A field with runs (flat areas, which RLE and ZIP shrink) and noise (which they cannot).
    fn value(c: usize, x: usize, y: usize) -> f32 {
        let flat = x < 20 || (x / 7 + y / 5).is_multiple_of(3);
        if flat {
            c as f32 * 0.25
        } else {
            let h =
                ((x as u64 * 0x9e37_79b9) ^ (y as u64 * 0x85eb_ca6b) ^ (c as u64 * 0xc2b2_ae35))
                    .wrapping_mul(0x2545_f491_4f6c_dd1d);
            (h >> 40) as f32 / (1u64 << 24) as f32 - 0.3
        }
    }

    #[test]
    fn every_compression_reads_back_exactly_in_an_independent_decoder() {
        // Odd sizes (not a multiple of ZIP's 16 lines), mixed precisions, names out of order.
        let (w, h) = (37, 41);
        let chans = [
            ExrChannel {
                name: "melanin",
                precision: ExrPrecision::F32,
            },
            ExrChannel {
                name: "blood",
                precision: ExrPrecision::F16,
            },
            ExrChannel {
                name: "Z.long_channel_name_of_more_than_31_bytes",
                precision: ExrPrecision::F16,
            },
        ];
        for comp in [
            ExrCompression::None,
            ExrCompression::Rle,
            ExrCompression::Zip,
        ] {
            let p = tmp(&format!("{comp:?}"));
            write_exr_rows(&p, w, h, &chans, comp, |y, rows| {
                for (c, row) in rows.iter_mut().enumerate() {
                    for (x, v) in row.iter_mut().enumerate() {
                        *v = value(c, x, y);
                    }
                }
            })
            .unwrap();
            let got = read(&p);
            assert_eq!(got.len(), 3);
            // Half the texels are flat: the compressed files are smaller than the samples.
            let samples = (w * h * (4 + 2 + 2)) as u64;
            let size = std::fs::metadata(&p).unwrap().len();
            assert_eq!(
                comp == ExrCompression::None,
                size > samples,
                "{comp:?}: {size} bytes"
            );
            for (k, ch) in chans.iter().enumerate() {
                let (_, gw, gh, data) = got.iter().find(|g| g.0 == ch.name).unwrap();
                assert_eq!((*gw, *gh), (w, h));
                for y in 0..h {
                    for x in 0..w {
                        let want = match ch.precision {
                            ExrPrecision::F32 => value(k, x, y),
                            ExrPrecision::F16 => half::f16::from_f32(value(k, x, y)).to_f32(),
                        };
                        assert_eq!(
                            data[y * w + x].to_bits(),
                            want.to_bits(),
                            "{comp:?} {} ({x}, {y})",
                            ch.name
                        );
                    }
                }
            }
        }
    }

    /// The greedy RLE written plainly, byte by byte: the reference for the word-wise one.
    fn rle_reference(data: &[u8]) -> Vec<u8> {
        let mut out = Vec::new();
        let n = data.len();
        let mut i = 0;
        while i < n {
            let mut j = i + 1;
            while j < n && data[j] == data[i] && j - i < 128 {
                j += 1;
            }
            if j - i >= 3 {
                out.push((j - i - 1) as u8);
                out.push(data[i]);
                i = j;
            } else {
                let start = i;
                while i < n && i - start < 127 {
                    if i + 2 < n && data[i] == data[i + 1] && data[i] == data[i + 2] {
                        break;
                    }
                    i += 1;
                }
                out.push((-((i - start) as i32)) as i8 as u8);
                out.extend_from_slice(&data[start..i]);
            }
        }
        out
    }

    #[test]
    fn the_predictor_splits_bytes_and_takes_differences() {
        // Odd length: the even half has one byte more.
        let raw = [10u8, 200, 13, 0, 7];
        // Split: 10 13 7 | 200 0; differences + 128 from the second byte on.
        let want = [
            10u8,
            13u8.wrapping_sub(10).wrapping_add(128),
            7u8.wrapping_sub(13).wrapping_add(128),
            200u8.wrapping_sub(7).wrapping_add(128),
            0u8.wrapping_sub(200).wrapping_add(128),
        ];
        assert_eq!(predict(&raw), want);
        assert!(predict(&[]).is_empty());
    }

    #[test]
    fn word_wise_rle_equals_the_plain_one() {
        // Random data with runs of every length near the limits, few symbols (many short runs).
        let rng = crate::rng::Philox::new(4, 0);
        for case in 0..400u64 {
            let mut data = Vec::new();
            let mut k = 0u64;
            while data.len() < 50 + (case as usize * 37) % 900 {
                let r = rng.u32x4(case << 20 | k);
                k += 1;
                let len = match r[0] % 6 {
                    0 => 1,
                    1 => 2,
                    2 => 3,
                    3 => 120 + (r[1] % 20) as usize,
                    _ => (r[1] % 9) as usize,
                };
                data.extend(std::iter::repeat_n((r[2] % 3) as u8, len));
            }
            assert_eq!(rle(&data), rle_reference(&data), "case {case}");
        }
    }

    #[test]
    fn rle_codes_runs_and_literals_within_their_limits() {
        // A decoder of the format's RLE, written from its description.
        fn unrle(mut d: &[u8]) -> Vec<u8> {
            let mut out = Vec::new();
            while let [c, rest @ ..] = d {
                let c = *c as i8;
                if c < 0 {
                    let n = (-(c as i32)) as usize;
                    out.extend_from_slice(&rest[..n]);
                    d = &rest[n..];
                } else {
                    out.extend(std::iter::repeat_n(rest[0], c as usize + 1));
                    d = &rest[1..];
                }
            }
            out
        }
        let mut data = vec![7u8; 300];
        data.extend((0..400).map(|i| (i * 37 % 251) as u8));
        data.extend([1, 1, 2, 2, 2, 3]);
        let packed = rle(&data);
        assert_eq!(unrle(&packed), data);
        // 300 equal bytes: runs of 128, 128 and 44 (6 bytes), far below the input.
        assert_eq!(&packed[..6], &[127, 7, 127, 7, 43, 7]);
    }

    #[test]
    fn bytes_do_not_depend_on_threads() {
        let chans = [ExrChannel {
            name: "h",
            precision: ExrPrecision::F16,
        }];
        let write = |threads: usize, tag: &str| {
            let p = tmp(tag);
            rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .unwrap()
                .install(|| {
                    write_exr_rows(&p, 300, 700, &chans, ExrCompression::Zip, |y, rows| {
                        for (x, v) in rows[0].iter_mut().enumerate() {
                            *v = value(0, x, y);
                        }
                    })
                })
                .unwrap();
            std::fs::read(&p).unwrap()
        };
        assert_eq!(write(1, "t1"), write(3, "t3"));
    }

    #[test]
    fn bad_input_is_named() {
        let p = tmp("bad");
        let c = [
            ExrChannel {
                name: "a",
                precision: ExrPrecision::F16,
            },
            ExrChannel {
                name: "a",
                precision: ExrPrecision::F16,
            },
        ];
        let e = write_exr_rows(&p, 4, 4, &c, ExrCompression::Rle, |_, _| {}).unwrap_err();
        assert!(e.to_string().contains("'a' is given twice"), "{e}");
        let e = write_exr_rows(&p, 0, 4, &c[..1], ExrCompression::Rle, |_, _| {}).unwrap_err();
        assert!(e.to_string().contains("0×4"), "{e}");
        assert!(!p.exists());
    }

    #[test]
    fn lines_pushed_in_uneven_bands_give_the_bytes_of_one_push() {
        // Bands that split ZIP's 16-line blocks anywhere, one of a single line, an empty one.
        let chans = [
            ExrChannel {
                name: "b",
                precision: ExrPrecision::F32,
            },
            ExrChannel {
                name: "a",
                precision: ExrPrecision::F16,
            },
        ];
        let fill = |y: usize, rows: &mut [&mut [f32]]| {
            for (c, r) in rows.iter_mut().enumerate() {
                for (x, v) in r.iter_mut().enumerate() {
                    *v = value(c, x, y);
                }
            }
        };
        for compression in [ExrCompression::Zip, ExrCompression::Rle] {
            let whole = tmp("whole");
            write_exr_rows(&whole, 29, 83, &chans, compression, fill).unwrap();
            let banded = tmp("banded");
            let mut sink = ExrRowSink::create(&banded, 29, 83, &chans, compression).unwrap();
            for n in [7, 1, 0, 24, 3, 16, 32] {
                sink.push(n, fill).unwrap();
            }
            sink.finish().unwrap();
            assert_eq!(
                std::fs::read(&whole).unwrap(),
                std::fs::read(&banded).unwrap()
            );
        }
    }

    #[test]
    fn an_unfinished_sink_leaves_nothing_and_a_short_one_is_refused() {
        let chans = [ExrChannel {
            name: "h",
            precision: ExrPrecision::F16,
        }];
        let p = tmp("short");
        let _ = std::fs::remove_file(&p);
        let mut sink = ExrRowSink::create(&p, 8, 10, &chans, ExrCompression::Rle).unwrap();
        sink.push(4, |_, _| {}).unwrap();
        let e = sink.push(7, |_, _| {}).unwrap_err();
        assert!(
            e.to_string()
                .contains("lines 4..11 pushed: the image has 10"),
            "{e}"
        );
        let e = sink.finish().unwrap_err();
        assert!(e.to_string().contains("4 of 10 lines pushed"), "{e}");
        let dir = p.parent().unwrap();
        let left: Vec<_> = std::fs::read_dir(dir).unwrap().flatten().collect();
        assert!(left.is_empty(), "left behind: {left:?}");
    }
}

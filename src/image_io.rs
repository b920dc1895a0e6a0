//! Image files in memory: OpenEXR for HDR data (any channel names, half or float), PNG for
//! previews. Encoders return bytes (stages hand them to the bundle's atomic writer) and are
//! deterministic: single-threaded compression, scan lines in increasing order.
//!
//! ZIP16 files are written here ([`encode_exr`]) rather than by the `exr` crate, whose deflate
//! (miniz_oxide at level 4) was most of a radiance map's encoding; zlib-rs at the same level
//! gives files of about the same size in about half the time (docs/tuning.md#exr-deflate).
//! Its output depends on no CPU feature, so the bytes are the same on every machine.

use std::collections::BTreeMap;
use std::io::Cursor;

use exr::prelude::{
    AnyChannel, AnyChannels, Blocks, Compression, Encoding, FlatSamples, Image, Layer,
    LayerAttributes, LineOrder, ReadChannels, ReadLayers, WritableImage, f16, read,
};
use glam::Vec3;

/// Why an image could not be encoded or decoded.
#[derive(Debug, thiserror::Error)]
pub enum ImageError {
    /// The OpenEXR codec failed.
    #[error("OpenEXR: {0}")]
    Exr(#[from] exr::error::Error),
    /// The PNG codec failed.
    #[error("PNG: {0}")]
    Png(#[from] image::ImageError),
    /// Channel sizes disagree with the image size, or a wanted channel is missing.
    #[error("{0}")]
    Shape(String),
}

/// Storage precision of an EXR channel.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Precision {
    /// 16-bit half float: radiance, colours.
    Half,
    /// 32-bit float: depth, anything needing precision.
    Float,
}

/// EXR compression choices (all lossless).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ExrCompression {
    /// No compression.
    None,
    /// ZIP over 16 scan lines: small files, the default.
    Zip16,
    /// PIZ wavelet: good on noisy data.
    Piz,
}

/// One named channel of `width × height` samples, row-major, row 0 at the top.
pub struct ChannelData<'a> {
    /// Channel name (`R`, `G`, `B`, `Z`, …).
    pub name: &'a str,
    /// Stored precision.
    pub precision: Precision,
    /// The samples.
    pub samples: &'a [f32],
}

/// Encodes channels into an OpenEXR file in memory.
pub fn encode_exr(
    width: usize,
    height: usize,
    channels: &[ChannelData],
    compression: ExrCompression,
) -> Result<Vec<u8>, ImageError> {
    if width == 0 || height == 0 {
        return Err(ImageError::Shape(format!(
            "an image of {width}×{height} pixels has no pixels"
        )));
    }
    for c in channels {
        if c.samples.len() != width * height {
            return Err(ImageError::Shape(format!(
                "channel {} has {} samples, the image {width}×{height} needs {}",
                c.name,
                c.samples.len(),
                width * height
            )));
        }
    }
    match compression {
        ExrCompression::Zip16 => encode_zip16(width, height, channels),
        ExrCompression::None => {
            encode_with_crate(width, height, channels, Compression::Uncompressed)
        }
        ExrCompression::Piz => encode_with_crate(width, height, channels, Compression::PIZ),
    }
}

/// [`encode_exr`] by the `exr` crate, with its `compression`.
fn encode_with_crate(
    width: usize,
    height: usize,
    channels: &[ChannelData],
    compression: Compression,
) -> Result<Vec<u8>, ImageError> {
    let mut list = smallvec::SmallVec::<[AnyChannel<FlatSamples>; 4]>::new();
    for c in channels {
        let samples = match c.precision {
            Precision::Half => {
                FlatSamples::F16(c.samples.iter().map(|&v| f16::from_f32(v)).collect())
            }
            Precision::Float => FlatSamples::F32(c.samples.to_vec()),
        };
        list.push(AnyChannel::new(c.name, samples));
    }
    let encoding = Encoding {
        compression,
        blocks: Blocks::ScanLines,
        line_order: LineOrder::Increasing,
    };
    let layer = Layer::new(
        (width, height),
        LayerAttributes::default(),
        encoding,
        AnyChannels::sort(list),
    );
    let mut out = Cursor::new(Vec::new());
    Image::from_layer(layer)
        .write()
        .non_parallel()
        .to_buffered(&mut out)?;
    Ok(out.into_inner())
}

/// Scan lines per ZIP block (OpenEXR's `ZIP_COMPRESSION`).
const ZIP_LINES: usize = 16;

/// The deflate level of ZIP blocks: the `exr` crate's, whose files these replaced.
const ZIP_LEVEL: i32 = 4;

/// Appends an OpenEXR header attribute: `name\0 type\0 size:i32 value`.
fn push_attribute(out: &mut Vec<u8>, name: &str, kind: &str, value: &[u8]) {
    for text in [name, kind] {
        out.extend_from_slice(text.as_bytes());
        out.push(0);
    }
    out.extend_from_slice(&(value.len() as i32).to_le_bytes());
    out.extend_from_slice(value);
}

/// A single-part scan-line OpenEXR file with ZIP blocks of [`ZIP_LINES`] lines, laid out as
/// the `exr` crate lays it out (its attributes in its order; channels sorted by name, each
/// line's samples channel by channel, little-endian; a channel other than R, G, B, L, X, Y
/// and Z marked as quantized linearly). A block's bytes are split into even and odd bytes,
/// delta-coded and deflated (OpenEXR's ZIP predictor), or stored as they are where that is
/// not smaller.
fn encode_zip16(
    width: usize,
    height: usize,
    channels: &[ChannelData],
) -> Result<Vec<u8>, ImageError> {
    let too_big = || {
        ImageError::Shape(format!(
            "an image of {width}×{height} pixels is too large for OpenEXR"
        ))
    };
    let (w, h) = (
        i32::try_from(width).map_err(|_| too_big())?,
        i32::try_from(height).map_err(|_| too_big())?,
    );
    let mut sorted: Vec<&ChannelData> = channels.iter().collect();
    sorted.sort_by(|a, b| a.name.as_bytes().cmp(b.name.as_bytes()));
    let blocks = height.div_ceil(ZIP_LINES);
    let mut out = vec![0x76, 0x2f, 0x31, 0x01, 2, 0, 0, 0];
    push_attribute(
        &mut out,
        "chunkCount",
        "int",
        &(blocks as i32).to_le_bytes(),
    );
    let mut list = Vec::new();
    for c in &sorted {
        list.extend_from_slice(c.name.as_bytes());
        list.push(0);
        let kind: i32 = match c.precision {
            Precision::Half => 1,
            Precision::Float => 2,
        };
        list.extend_from_slice(&kind.to_le_bytes());
        let linear = !["R", "G", "B", "L", "Y", "X", "Z"]
            .iter()
            .any(|n| n.eq_ignore_ascii_case(c.name));
        list.extend_from_slice(&[u8::from(linear), 0, 0, 0]);
        list.extend_from_slice(&1i32.to_le_bytes());
        list.extend_from_slice(&1i32.to_le_bytes());
    }
    list.push(0);
    push_attribute(&mut out, "channels", "chlist", &list);
    push_attribute(&mut out, "compression", "compression", &[3]);
    push_attribute(&mut out, "lineOrder", "lineOrder", &[0]);
    let window: Vec<u8> = [0, 0, w - 1, h - 1]
        .iter()
        .flat_map(|v: &i32| v.to_le_bytes())
        .collect();
    push_attribute(&mut out, "displayWindow", "box2i", &window);
    push_attribute(&mut out, "pixelAspectRatio", "float", &1f32.to_le_bytes());
    push_attribute(&mut out, "screenWindowCenter", "v2f", &[0; 8]);
    push_attribute(&mut out, "screenWindowWidth", "float", &1f32.to_le_bytes());
    push_attribute(&mut out, "dataWindow", "box2i", &window);
    push_attribute(&mut out, "type", "string", b"scanlineimage");
    out.push(0);
    let table = out.len();
    out.resize(table + 8 * blocks, 0);
    let line_bytes: usize = sorted
        .iter()
        .map(|c| match c.precision {
            Precision::Half => 2,
            Precision::Float => 4,
        })
        .sum::<usize>()
        * width;
    let (mut raw, mut split): (Vec<u8>, Vec<u8>) = (Vec::new(), Vec::new());
    let mut deflated = vec![0u8; zlib_rs::compress_bound(ZIP_LINES * line_bytes)];
    for b in 0..blocks {
        let rows = b * ZIP_LINES..((b + 1) * ZIP_LINES).min(height);
        raw.clear();
        for y in rows.clone() {
            for c in &sorted {
                let line = &c.samples[y * width..(y + 1) * width];
                let start = raw.len();
                match c.precision {
                    Precision::Half => {
                        raw.resize(start + 2 * width, 0);
                        for (d, &v) in raw[start..].chunks_exact_mut(2).zip(line) {
                            d.copy_from_slice(&f16::from_f32(v).to_le_bytes());
                        }
                    }
                    Precision::Float => {
                        raw.resize(start + 4 * width, 0);
                        for (d, &v) in raw[start..].chunks_exact_mut(4).zip(line) {
                            d.copy_from_slice(&v.to_le_bytes());
                        }
                    }
                }
            }
        }
        // Every sample has an even number of bytes: the two halves are the same length.
        split.resize(raw.len(), 0);
        let (even, odd) = split.split_at_mut(raw.len() / 2);
        for ((e, o), pair) in even.iter_mut().zip(odd).zip(raw.chunks_exact(2)) {
            *e = pair[0];
            *o = pair[1];
        }
        let mut previous = split[0];
        for v in &mut split[1..] {
            let here = *v;
            *v = here.wrapping_sub(previous).wrapping_add(128);
            previous = here;
        }
        let (z, code) = zlib_rs::compress_slice(
            &mut deflated,
            &split,
            zlib_rs::DeflateConfig::new(ZIP_LEVEL),
        );
        if !matches!(code, zlib_rs::ReturnCode::Ok) {
            return Err(ImageError::Shape(format!(
                "deflate failed (zlib code {})",
                code as i32
            )));
        }
        let data: &[u8] = if z.len() < raw.len() { z } else { &raw };
        let at = out.len() as u64;
        out[table + 8 * b..table + 8 * b + 8].copy_from_slice(&at.to_le_bytes());
        out.extend_from_slice(&(rows.start as i32).to_le_bytes());
        out.extend_from_slice(&(data.len() as i32).to_le_bytes());
        out.extend_from_slice(data);
    }
    Ok(out)
}

/// Encodes an RGB half-float EXR (ZIP16) from linear radiance.
pub fn encode_rgb_exr(width: usize, height: usize, rgb: &[Vec3]) -> Result<Vec<u8>, ImageError> {
    encode_rgb_exr_with(width, height, rgb, &[], ExrCompression::Zip16)
}

/// Encodes linear radiance as R, G, B half-float channels plus `extra` channels (a mask, a
/// depth).
pub fn encode_rgb_exr_with(
    width: usize,
    height: usize,
    rgb: &[Vec3],
    extra: &[ChannelData],
    compression: ExrCompression,
) -> Result<Vec<u8>, ImageError> {
    let split = |k: usize| rgb.iter().map(|c| c[k]).collect::<Vec<f32>>();
    let (r, g, b) = (split(0), split(1), split(2));
    let half = |name, samples| ChannelData {
        name,
        precision: Precision::Half,
        samples,
    };
    let mut channels = vec![half("R", &r), half("G", &g), half("B", &b)];
    channels.extend(extra.iter().map(|c| ChannelData {
        name: c.name,
        precision: c.precision,
        samples: c.samples,
    }));
    encode_exr(width, height, &channels, compression)
}

/// A decoded EXR: its size and every channel as f32, by name.
#[derive(Clone, Debug, PartialEq)]
pub struct ExrImage {
    /// Width in pixels.
    pub width: usize,
    /// Height in pixels.
    pub height: usize,
    /// Channels by name, row-major, row 0 at the top.
    pub channels: BTreeMap<String, Vec<f32>>,
}

impl ExrImage {
    /// A channel by name, or an error naming what the file has.
    pub fn channel(&self, name: &str) -> Result<&[f32], ImageError> {
        self.channels
            .get(name)
            .map(|v| v.as_slice())
            .ok_or_else(|| {
                ImageError::Shape(format!(
                    "no channel {name}; the image has {}",
                    self.channels
                        .keys()
                        .map(String::as_str)
                        .collect::<Vec<_>>()
                        .join(", ")
                ))
            })
    }

    /// The R, G and B channels as colours.
    pub fn rgb(&self) -> Result<Vec<Vec3>, ImageError> {
        let (r, g, b) = (self.channel("R")?, self.channel("G")?, self.channel("B")?);
        Ok((0..r.len()).map(|i| Vec3::new(r[i], g[i], b[i])).collect())
    }
}

/// Most pixels an EXR layer may have when read: 2²⁵, 128 MiB per f32 channel (glint's
/// largest images, 4096² radiosity pages, hold 2²⁴).
pub const MAX_EXR_PIXELS: u64 = 1 << 25;

/// Most bytes of samples (as stored, all channels) an EXR layer may have when read: 128 MiB
/// (a 4096² RGB half-float page holds 96 MiB).
pub const MAX_EXR_BYTES: u64 = 1 << 27;

/// Walks an OpenEXR file's layout (magic, version, header attributes
/// `name\0 type\0 size:i32 value[size]` until an empty name, the chunk offset table, then each
/// chunk `y:i32 size:i32 data[size]`, back to back) and refuses what would make the decoder allocate more
/// than the file holds: an attribute or a chunk whose declared size runs past the end of the
/// file, a `preview` whose 4·w·h pixels disagree with its size, a window (`box2i`) that is
/// empty or over [`MAX_EXR_PIXELS`]. glint writes single-part scanline files only, so tiled,
/// deep and multi-part files are refused here too. Anything else is left to the decoder.
fn check_exr_attributes(bytes: &[u8]) -> Result<(), ImageError> {
    const MAGIC: [u8; 4] = [0x76, 0x2f, 0x31, 0x01];
    const TILED: u32 = 0x200;
    const DEEP: u32 = 0x800;
    const MULTIPART: u32 = 0x1000;
    let bad = |m: String| Err(ImageError::Shape(format!("OpenEXR file: {m}")));
    if bytes.len() < 8 || bytes[..4] != MAGIC {
        return Ok(());
    }
    let flags = u32::from_le_bytes(bytes[4..8].try_into().expect("4 bytes"));
    if flags & (TILED | DEEP | MULTIPART) != 0 {
        return bad(format!(
            "version field {flags:#x} marks a tiled, deep or multi-part file; glint reads single-part scanline files"
        ));
    }
    let i32_at = |p: usize| -> Option<i64> {
        Some(i32::from_le_bytes(bytes.get(p..p + 4)?.try_into().ok()?) as i64)
    };
    // A NUL-terminated string at `pos` (None: runs off the end).
    let cstr = |pos: usize| -> Option<(&[u8], usize)> {
        let end = pos + bytes.get(pos..)?.iter().position(|&b| b == 0)?;
        Some((&bytes[pos..end], end + 1))
    };
    let (mut chunk_count, mut data_rows, mut compression) = (None, None, None);
    let mut pos = 8;
    // The header: attributes until an empty name.
    loop {
        match bytes.get(pos) {
            None => return bad("the header runs past the end of the file".into()),
            Some(0) => {
                pos += 1;
                break;
            }
            Some(_) => {}
        }
        let Some((name, p)) = cstr(pos) else {
            return bad("the header runs past the end of the file".into());
        };
        let Some((kind, p)) = cstr(p) else {
            return bad("the header runs past the end of the file".into());
        };
        let Some(size) = i32_at(p) else {
            return bad("the header runs past the end of the file".into());
        };
        let value = p + 4;
        let left = bytes.len() - value;
        let name = String::from_utf8_lossy(name);
        if size < 0 || size as usize > left {
            return bad(format!(
                "attribute `{name}` declares {size} bytes, {left} remain in the file"
            ));
        }
        let v = &bytes[value..value + size as usize];
        if kind == b"box2i" && size == 16 {
            // (xMin, yMin, xMax, yMax), inclusive: an empty or vast window is refused here,
            // before the decoder sizes its buffers from it.
            let c =
                |k: usize| i32::from_le_bytes(v[4 * k..4 * k + 4].try_into().expect("4")) as i64;
            let (w, h) = (c(2) - c(0) + 1, c(3) - c(1) + 1);
            if w < 1 || h < 1 || (w as u64).saturating_mul(h as u64) > MAX_EXR_PIXELS {
                return bad(format!(
                    "attribute `{name}` is a window of {w}×{h} pixels, not 1 ..= {MAX_EXR_PIXELS} pixels"
                ));
            }
            if name == "dataWindow" {
                data_rows = Some(h as u64);
            }
        }
        if kind == b"preview" {
            let dims = v.get(..8).map(|d| {
                let w = u32::from_le_bytes(d[..4].try_into().expect("4 bytes")) as u64;
                let h = u32::from_le_bytes(d[4..].try_into().expect("4 bytes")) as u64;
                (w, h)
            });
            match dims {
                Some((w, h)) if 8 + 4 * w * h == size as u64 => {}
                Some((w, h)) => {
                    return bad(format!(
                        "attribute `{name}`: a {w}×{h} preview does not fill its {size} bytes"
                    ));
                }
                None => {
                    return bad(format!(
                        "attribute `{name}`: {size} bytes cannot hold a preview's size"
                    ));
                }
            }
        }
        if name == "chunkCount" && size == 4 {
            chunk_count = Some(i32::from_le_bytes(v.try_into().expect("4 bytes")).max(0) as u64);
        }
        if name == "compression" && size == 1 {
            compression = Some(v[0]);
        }
        pos = value + size as usize;
    }
    // Scanlines per chunk of each compression (OpenEXR file layout, "Scan Line Blocks").
    let rows_per_chunk = match compression {
        Some(0..=2) => 1,
        Some(3 | 5) => 16,
        Some(4 | 6..=8) => 32,
        Some(9) => 256,
        Some(c) => return bad(format!("compression {c} is not one OpenEXR defines")),
        None => return bad("the header names no compression".into()),
    };
    // A header without its data window is not OpenEXR; the decoder would guess the layout.
    let Some(rows) = data_rows else {
        return bad("the header has no dataWindow".into());
    };
    let count = chunk_count.unwrap_or(rows.div_ceil(rows_per_chunk));
    // The offset table, then each chunk inside the file.
    if count.saturating_mul(8) > (bytes.len() - pos) as u64 {
        return bad(format!(
            "{count} chunk offsets do not fit in the {} bytes after the header",
            bytes.len() - pos
        ));
    }
    // The chunks follow the table back to back, and the decoder reads them in that order.
    let mut at = pos + 8 * count as usize;
    for k in 0..count as usize {
        match i32_at(at + 4) {
            Some(s) if s >= 0 && at + 8 + s as usize <= bytes.len() => at += 8 + s as usize,
            _ => {
                return bad(format!(
                    "chunk {k} at byte {at} runs past the end of the file ({} bytes)",
                    bytes.len()
                ));
            }
        }
    }
    for k in 0..count as usize {
        let at = pos + 8 * k;
        let offset = u64::from_le_bytes(bytes[at..at + 8].try_into().expect("8 bytes"));
        let size = usize::try_from(offset)
            .ok()
            .and_then(|o| i32_at(o.checked_add(4)?));
        let table_end = (pos + 8 * count as usize) as u64;
        match size {
            Some(s)
                if offset >= table_end && s >= 0 && offset + 8 + s as u64 <= bytes.len() as u64 => {
            }
            _ => {
                return bad(format!(
                    "chunk {k} at byte {offset} runs past the end of the file ({} bytes)",
                    bytes.len()
                ));
            }
        }
    }
    Ok(())
}

/// Decodes the first layer of an EXR file in memory. Headers are read first: a layer larger
/// than [`MAX_EXR_PIXELS`] or [`MAX_EXR_BYTES`] is an error before anything is allocated
/// for it (a header alone could otherwise ask for terabytes).
pub fn decode_exr(bytes: &[u8]) -> Result<ExrImage, ImageError> {
    check_exr_attributes(bytes)?;
    let meta = exr::meta::MetaData::read_from_buffered(Cursor::new(bytes), false)?;
    for (i, h) in meta.headers.iter().enumerate() {
        let (w, h_) = (h.layer_size.0 as u64, h.layer_size.1 as u64);
        let pixels = w.saturating_mul(h_);
        let sample_bytes = pixels.saturating_mul(h.channels.bytes_per_pixel as u64);
        if pixels > MAX_EXR_PIXELS || sample_bytes > MAX_EXR_BYTES {
            return Err(ImageError::Shape(format!(
                "layer {i} is {w}×{h_} pixels of {} bytes, more than this reader accepts ({MAX_EXR_PIXELS} pixels, {MAX_EXR_BYTES} bytes)",
                h.channels.bytes_per_pixel
            )));
        }
    }
    // Decoded on this thread, and a panic of the decoder on malformed data is an error: on
    // the decoder's thread pool it would abort the process.
    let image = std::panic::catch_unwind(|| {
        read()
            .no_deep_data()
            .largest_resolution_level()
            .all_channels()
            .first_valid_layer()
            .all_attributes()
            .non_parallel()
            .from_buffered(Cursor::new(bytes))
    })
    .map_err(|_| ImageError::Shape("the OpenEXR decoder failed on malformed data".into()))??;
    let layer = image.layer_data;
    let size = layer.size;
    let channels = layer
        .channel_data
        .list
        .iter()
        .map(|c| (c.name.to_string(), c.sample_data.values_as_f32().collect()))
        .collect();
    Ok(ExrImage {
        width: size.0,
        height: size.1,
        channels,
    })
}

/// Encodes 8-bit sRGB(A) pixels as PNG.
pub fn encode_png(
    width: u32,
    height: u32,
    pixels: &[u8],
    alpha: bool,
) -> Result<Vec<u8>, ImageError> {
    let mut out = Cursor::new(Vec::new());
    let color = if alpha {
        image::ExtendedColorType::Rgba8
    } else {
        image::ExtendedColorType::Rgb8
    };
    image::write_buffer_with_format(
        &mut out,
        pixels,
        width,
        height,
        color,
        image::ImageFormat::Png,
    )?;
    Ok(out.into_inner())
}

/// Linear radiance to a displayable 8-bit sRGB preview: exposure so that the image's
/// 95th-percentile luminance maps to 0.8 before Reinhard's x / (1 + x), then the sRGB curve.
pub fn tonemap_preview(rgb: &[Vec3]) -> Vec<u8> {
    let mut lum: Vec<f32> = rgb
        .iter()
        .map(|&c| crate::colour::luminance(c))
        .filter(|l| l.is_finite() && *l > 0.0)
        .collect();
    let exposure = if lum.is_empty() {
        1.0
    } else {
        let k = ((lum.len() as f32 * 0.95) as usize).min(lum.len() - 1);
        let (_, p95, _) = lum.select_nth_unstable_by(k, f32::total_cmp);
        4.0 / *p95 // x/(1+x) = 0.8 at x = 4
    };
    rgb.iter()
        .flat_map(|c| {
            let c = (*c * exposure).max(Vec3::ZERO);
            let t = c / (Vec3::ONE + c);
            t.to_array()
                .map(|v| (linear_to_srgb(v) * 255.0 + 0.5) as u8)
        })
        .collect()
}

/// `rgb` (`w` × `h`, row-major) resampled to `nw` × `nh` by the mean of the source texels each
/// target texel covers (a box filter; `nw` ≤ `w`, `nh` ≤ `h`).
pub fn downsample(rgb: &[Vec3], w: usize, h: usize, nw: usize, nh: usize) -> Vec<Vec3> {
    let mut out = vec![Vec3::ZERO; nw * nh];
    for ty in 0..nh {
        let (y0, y1) = (ty * h / nh, ((ty + 1) * h).div_ceil(nh).min(h));
        for tx in 0..nw {
            let (x0, x1) = (tx * w / nw, ((tx + 1) * w).div_ceil(nw).min(w));
            let mut sum = Vec3::ZERO;
            for y in y0..y1 {
                for x in x0..x1 {
                    sum += rgb[y * w + x];
                }
            }
            out[ty * nw + tx] = sum / ((y1 - y0) * (x1 - x0)).max(1) as f32;
        }
    }
    out
}

/// The sRGB transfer curve for one linear value in [0, 1].
pub fn linear_to_srgb(v: f32) -> f32 {
    let v = v.clamp(0.0, 1.0);
    if v <= 0.003_130_8 {
        12.92 * v
    } else {
        1.055 * v.powf(1.0 / 2.4) - 0.055
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn downsampling_averages_each_block() {
        let rgb: Vec<Vec3> = (0..16).map(|i| Vec3::splat(i as f32)).collect();
        let half = downsample(&rgb, 4, 4, 2, 2);
        assert_eq!(half[0], Vec3::splat((0.0 + 1.0 + 4.0 + 5.0) / 4.0));
        assert_eq!(half[3], Vec3::splat((10.0 + 11.0 + 14.0 + 15.0) / 4.0));
    }

    #[test]
    fn exr_round_trip_keeps_half_and_float_channels() {
        let (w, h) = (5, 3);
        let r: Vec<f32> = (0..15).map(|i| i as f32 * 0.25).collect();
        let z: Vec<f32> = (0..15).map(|i| 1000.0 + i as f32 * 1e-3).collect();
        let bytes = encode_exr(
            w,
            h,
            &[
                ChannelData {
                    name: "R",
                    precision: Precision::Half,
                    samples: &r,
                },
                ChannelData {
                    name: "Z",
                    precision: Precision::Float,
                    samples: &z,
                },
            ],
            ExrCompression::Zip16,
        )
        .unwrap();
        let img = decode_exr(&bytes).unwrap();
        assert_eq!((img.width, img.height), (w, h));
        assert_eq!(
            img.channel("R").unwrap(),
            r.as_slice(),
            "quarters are exact in half"
        );
        assert_eq!(
            img.channel("Z").unwrap(),
            z.as_slice(),
            "float depth is exact"
        );
        let e = img.channel("G").unwrap_err().to_string();
        assert!(e.contains("no channel G; the image has R, Z"), "{e}");
        // Deterministic bytes.
        let again = encode_exr(
            w,
            h,
            &[
                ChannelData {
                    name: "R",
                    precision: Precision::Half,
                    samples: &r,
                },
                ChannelData {
                    name: "Z",
                    precision: Precision::Float,
                    samples: &z,
                },
            ],
            ExrCompression::Zip16,
        )
        .unwrap();
        assert_eq!(bytes, again);
    }

    /// glint's ZIP16 files have the `exr` crate's header and layout and the same pixels, over
    /// several blocks (the last one short), blocks that deflate and one that does not.
    #[test]
    fn zip16_files_are_the_exr_crates_layout_with_the_same_pixels() {
        let (w, h) = (37, 40);
        let smooth: Vec<f32> = (0..w * h).map(|i| (i / w) as f32 * 0.5).collect();
        // Bits that do not compress: every block's bytes are stored as they are.
        let mut x = 0x2545_f491_4f6c_dd1du64;
        let noise: Vec<f32> = (0..w * h)
            .map(|_| {
                x ^= x << 13;
                x ^= x >> 7;
                x ^= x << 17;
                f32::from_bits((x as u32 & 0x007f_ffff) | 0x3f80_0000)
            })
            .collect();
        let channels = [
            ChannelData {
                name: "Z",
                precision: Precision::Float,
                samples: &noise,
            },
            ChannelData {
                name: "NX",
                precision: Precision::Half,
                samples: &smooth,
            },
            ChannelData {
                name: "A",
                precision: Precision::Half,
                samples: &smooth,
            },
        ];
        for only in [&channels[..], &channels[..1], &channels[1..]] {
            let ours = encode_exr(w, h, only, ExrCompression::Zip16).unwrap();
            let theirs = encode_with_crate(w, h, only, Compression::ZIP16).unwrap();
            // The headers (attributes up to the empty name) are the same bytes.
            let header = |b: &[u8]| {
                let mut at = 8;
                let text = |at: &mut usize| {
                    let end = *at + b[*at..].iter().position(|&c| c == 0).unwrap();
                    let empty = end == *at;
                    *at = end + 1;
                    empty
                };
                while !text(&mut at) {
                    text(&mut at);
                    let size = i32::from_le_bytes(b[at..at + 4].try_into().unwrap());
                    at += 4 + size as usize;
                }
                b[..at].to_vec()
            };
            assert_eq!(header(&ours), header(&theirs));
            let img = decode_exr(&ours).unwrap();
            let want = decode_exr(&theirs).unwrap();
            assert_eq!(img, want);
            assert_eq!(ours, encode_exr(w, h, only, ExrCompression::Zip16).unwrap());
        }
    }

    #[test]
    fn wrong_channel_size_is_an_error() {
        let e = encode_exr(
            2,
            2,
            &[ChannelData {
                name: "R",
                precision: Precision::Half,
                samples: &[0.0; 3],
            }],
            ExrCompression::None,
        );
        assert!(e.unwrap_err().to_string().contains("3 samples"));
    }

    #[test]
    fn preview_maps_black_to_zero_and_saturates_bright() {
        // The 95th percentile (1.0) maps to 0.8 before the sRGB curve: 231.
        let mut img = vec![Vec3::splat(1.0); 30];
        img[0] = Vec3::ZERO;
        img[29] = Vec3::splat(1e6);
        let px = tonemap_preview(&img);
        assert_eq!(&px[0..3], &[0, 0, 0]);
        assert_eq!(px[3], 231);
        assert_eq!(px[29 * 3], 255);
        let png = encode_png(30, 1, &px, false).unwrap();
        assert_eq!(&png[1..4], b"PNG");
    }
}

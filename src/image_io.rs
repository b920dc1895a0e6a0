//! Image files in memory: OpenEXR for HDR data (any channel names, half or float), PNG for
//! previews. Encoders return bytes (stages hand them to the bundle's atomic writer) and are
//! deterministic: single-threaded compression, scan lines in increasing order.

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
    let mut list = smallvec::SmallVec::<[AnyChannel<FlatSamples>; 4]>::new();
    for c in channels {
        if c.samples.len() != width * height {
            return Err(ImageError::Shape(format!(
                "channel {} has {} samples, the image {width}×{height} needs {}",
                c.name,
                c.samples.len(),
                width * height
            )));
        }
        let samples = match c.precision {
            Precision::Half => {
                FlatSamples::F16(c.samples.iter().map(|&v| f16::from_f32(v)).collect())
            }
            Precision::Float => FlatSamples::F32(c.samples.to_vec()),
        };
        list.push(AnyChannel::new(c.name, samples));
    }
    let encoding = Encoding {
        compression: match compression {
            ExrCompression::None => Compression::Uncompressed,
            ExrCompression::Zip16 => Compression::ZIP16,
            ExrCompression::Piz => Compression::PIZ,
        },
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

/// Decodes the first layer of an EXR file in memory. Headers are read first: a layer larger
/// than [`MAX_EXR_PIXELS`] or [`MAX_EXR_BYTES`] is an error before anything is allocated
/// for it (a header alone could otherwise ask for terabytes).
pub fn decode_exr(bytes: &[u8]) -> Result<ExrImage, ImageError> {
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
        .map(|c| c.dot(Vec3::new(0.2126, 0.7152, 0.0722)))
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
        assert!(img.channel("G").unwrap_err().to_string().contains("\"R\""));
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

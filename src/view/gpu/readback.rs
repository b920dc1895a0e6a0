//! Readback: textures and buffers copied from the GPU to the CPU (frames, screenshots,
//! compute probes' outputs, timestamps).

use std::sync::mpsc;

use exr::prelude::f16;
use glam::Vec4;

use super::build::buffer;
use crate::view::gpu::{Gpu, GpuError, error_scoped};

/// Bytes per texel of the RGBA8 formats handled by [`read_texture_rgba8`].
const RGBA8_BYTES_PER_PIXEL: u32 = 4;

/// Copies mip level 0, layer 0 of a single-sampled, uncompressed, colour 2D texture created
/// with [`wgpu::TextureUsages::COPY_SRC`] back to the CPU: `width * height * texel size`
/// bytes, rows top to bottom without padding, texels as the format stores them (e.g. four
/// little-endian f16 per texel for `Rgba16Float`). Blocks until the copy has finished.
pub fn read_texture(gpu: &Gpu, texture: &wgpu::Texture) -> Result<Vec<u8>, GpuError> {
    let format = texture.format();
    let Some(bytes_per_pixel) = format
        .block_copy_size(None)
        .filter(|_| format.block_dimensions() == (1, 1) && !format.has_depth_aspect())
    else {
        return Err(GpuError::UnsupportedTexture(format!(
            "format {format:?} is not an uncompressed colour format"
        )));
    };
    read_texture_bytes(gpu, texture, bytes_per_pixel)
}

/// Copies a whole buffer created with [`wgpu::BufferUsages::COPY_SRC`] back to the CPU,
/// after all work submitted so far. Blocks until the copy has finished.
pub fn read_buffer(gpu: &Gpu, source: &wgpu::Buffer) -> Result<Vec<u8>, GpuError> {
    let size = source.size();
    copy_back(
        gpu,
        "copying a buffer for readback",
        size,
        |encoder, buffer| encoder.copy_buffer_to_buffer(source, 0, buffer, 0, size),
    )
}

/// Records `copy` into a new `size`-byte readback buffer, submits it and returns the buffer's
/// bytes once the copy has finished.
fn copy_back(
    gpu: &Gpu,
    context: &'static str,
    size: u64,
    copy: impl FnOnce(&mut wgpu::CommandEncoder, &wgpu::Buffer),
) -> Result<Vec<u8>, GpuError> {
    let (buffer, submission) = error_scoped(&gpu.device, context, || {
        let buffer = buffer(
            &gpu.device,
            "glint readback buffer",
            size,
            wgpu::BufferUsages::MAP_READ,
        );
        let mut encoder = gpu
            .device
            .create_command_encoder(&wgpu::CommandEncoderDescriptor {
                label: Some("glint readback encoder"),
            });
        copy(&mut encoder, &buffer);
        let submission = gpu.queue.submit([encoder.finish()]);
        (buffer, submission)
    })?;
    map_read(gpu, &buffer, Some(submission))
}

/// Waits for `submission` (`None`: all work submitted so far), maps `buffer` (created with
/// [`wgpu::BufferUsages::MAP_READ`]) for reading and returns its contents.
pub(crate) fn map_read(
    gpu: &Gpu,
    buffer: &wgpu::Buffer,
    submission: Option<wgpu::SubmissionIndex>,
) -> Result<Vec<u8>, GpuError> {
    let slice = buffer.slice(..);
    let (sender, receiver) = mpsc::channel();
    slice.map_async(wgpu::MapMode::Read, move |result| {
        // The receiver outlives the poll below; a failed send only means nobody is listening.
        let _ = sender.send(result);
    });
    gpu.device.poll(wgpu::PollType::Wait {
        submission_index: submission,
        timeout: None,
    })?;
    receiver
        .recv()
        .map_err(|_| GpuError::MapCallbackDropped)??;
    let bytes = slice.get_mapped_range()?.to_vec();
    buffer.unmap();
    Ok(bytes)
}

/// Copies mip level 0, layer 0 of an RGBA8 2D texture back to the CPU.
///
/// The texture must be `Rgba8Unorm` or `Rgba8UnormSrgb`, single-sampled and created with
/// [`wgpu::TextureUsages::COPY_SRC`]. The GPU copy pads every row to
/// [`wgpu::COPY_BYTES_PER_ROW_ALIGNMENT`] bytes; the returned vector has the padding removed:
/// `width * height * 4` bytes, rows top to bottom, each pixel as R, G, B, A. sRGB textures are
/// returned as stored (sRGB-encoded), not converted to linear.
///
/// Blocks until the copy has finished.
pub fn read_texture_rgba8(gpu: &Gpu, texture: &wgpu::Texture) -> Result<Vec<u8>, GpuError> {
    let format = texture.format();
    if !matches!(
        format,
        wgpu::TextureFormat::Rgba8Unorm | wgpu::TextureFormat::Rgba8UnormSrgb
    ) {
        return Err(GpuError::UnsupportedTexture(format!(
            "format is {format:?}, expected Rgba8Unorm or Rgba8UnormSrgb"
        )));
    }
    read_texture_bytes(gpu, texture, RGBA8_BYTES_PER_PIXEL)
}

/// Copies an `Rgba16Float` texture back as in [`read_texture`], each texel widened to f32:
/// `width * height` values, rows top to bottom.
pub fn read_texture_rgba16f(gpu: &Gpu, texture: &wgpu::Texture) -> Result<Vec<Vec4>, GpuError> {
    let format = texture.format();
    if format != wgpu::TextureFormat::Rgba16Float {
        return Err(GpuError::UnsupportedTexture(format!(
            "format is {format:?}, expected Rgba16Float"
        )));
    }
    let bytes = read_texture_bytes(gpu, texture, 8)?;
    let half = |b: &[u8]| f16::from_bits(u16::from_le_bytes([b[0], b[1]])).to_f32();
    Ok(bytes
        .chunks_exact(8)
        .map(|t| {
            Vec4::new(
                half(&t[0..2]),
                half(&t[2..4]),
                half(&t[4..6]),
                half(&t[6..8]),
            )
        })
        .collect())
}

/// Readback of a 2D colour texture whose texels are `bytes_per_pixel` bytes.
fn read_texture_bytes(
    gpu: &Gpu,
    texture: &wgpu::Texture,
    bytes_per_pixel: u32,
) -> Result<Vec<u8>, GpuError> {
    if texture.dimension() != wgpu::TextureDimension::D2 {
        return Err(GpuError::UnsupportedTexture(format!(
            "dimension is {:?}, expected D2",
            texture.dimension()
        )));
    }
    if texture.sample_count() != 1 {
        return Err(GpuError::UnsupportedTexture(format!(
            "sample count is {}, expected 1 (resolve multisampled targets first)",
            texture.sample_count()
        )));
    }
    if !texture.usage().contains(wgpu::TextureUsages::COPY_SRC) {
        return Err(GpuError::UnsupportedTexture(
            "texture was not created with TextureUsages::COPY_SRC".to_owned(),
        ));
    }

    let width = texture.width();
    let height = texture.height();
    let row_bytes = width * bytes_per_pixel;
    let padded_row_bytes = row_bytes.next_multiple_of(wgpu::COPY_BYTES_PER_ROW_ALIGNMENT);
    let buffer_size = u64::from(padded_row_bytes) * u64::from(height);

    let mapped = copy_back(
        gpu,
        "copying a texture for readback",
        buffer_size,
        |encoder, buffer| {
            encoder.copy_texture_to_buffer(
                wgpu::TexelCopyTextureInfo {
                    texture,
                    mip_level: 0,
                    origin: wgpu::Origin3d::ZERO,
                    aspect: wgpu::TextureAspect::All,
                },
                wgpu::TexelCopyBufferInfo {
                    buffer,
                    layout: wgpu::TexelCopyBufferLayout {
                        offset: 0,
                        bytes_per_row: Some(padded_row_bytes),
                        rows_per_image: Some(height),
                    },
                },
                wgpu::Extent3d {
                    width,
                    height,
                    depth_or_array_layers: 1,
                },
            )
        },
    )?;
    let mut pixels = Vec::with_capacity(row_bytes as usize * height as usize);
    for row in mapped.chunks_exact(padded_row_bytes as usize) {
        pixels.extend_from_slice(&row[..row_bytes as usize]);
    }
    Ok(pixels)
}

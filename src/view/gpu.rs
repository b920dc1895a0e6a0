//! Headless GPU access: adapter and device selection, offscreen rendering and texture readback.
//!
//! Nothing here needs a window or a surface, so it runs on CI machines whose only GPU is a
//! software Vulkan driver (Mesa lavapipe, from the Debian/Ubuntu package `mesa-vulkan-drivers`).
//!
//! Errors that wgpu reports through error scopes (validation, out of memory) are turned into
//! [`GpuError`] values instead of the default panicking handler.

use std::sync::mpsc;

use thiserror::Error;

use super::build::{bind_group_layout, buffer, buffer_init, render_pipeline, shader};
use super::target::{check_target_size, clear_pass, texture_2d};

/// Backends searched first: Vulkan (and Metal / DX12 on the platforms that have them).
const PREFERRED_BACKENDS: wgpu::Backends = wgpu::Backends::PRIMARY;

/// Backends searched only when no preferred backend exposes an adapter.
const FALLBACK_BACKENDS: wgpu::Backends = wgpu::Backends::GL;

/// Bytes per texel of the RGBA8 formats handled by [`read_texture_rgba8`].
const RGBA8_BYTES_PER_PIXEL: u32 = 4;

/// Pixel format of the offscreen target used by [`render_test_triangle`].
const TEST_TRIANGLE_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Rgba8Unorm;

/// Errors from GPU setup, rendering and readback.
#[derive(Debug, Error)]
pub enum GpuError {
    /// No backend exposed an adapter.
    #[error(
        "no GPU adapter found (backends tried: {backends}): \
         install mesa-vulkan-drivers for the software Vulkan adapter"
    )]
    NoAdapter {
        /// The backends that were enumerated.
        backends: String,
    },

    /// The adapter refused to create a device.
    #[error("could not create a GPU device on adapter `{adapter}`: {source}")]
    RequestDevice {
        /// Name of the adapter the device was requested from.
        adapter: String,
        /// The error reported by wgpu.
        #[source]
        source: wgpu::RequestDeviceError,
    },

    /// A render target size of zero, or above the device's 2D texture limit.
    #[error("invalid render target size {width}x{height} (each side must be 1..={max})")]
    InvalidSize {
        /// Requested width in pixels.
        width: u32,
        /// Requested height in pixels.
        height: u32,
        /// The device's `max_texture_dimension_2d`.
        max: u32,
    },

    /// The texture given to [`read_texture_rgba8`] cannot be read back as RGBA8 pixels.
    #[error("cannot read back texture as RGBA8: {0}")]
    UnsupportedTexture(String),

    /// wgpu reported a validation or out-of-memory error while doing `context`.
    #[error("GPU error while {context}: {source}")]
    Wgpu {
        /// What was being done when the error was reported.
        context: &'static str,
        /// The error captured by the error scope.
        #[source]
        source: wgpu::Error,
    },

    /// Waiting for submitted GPU work failed.
    #[error("waiting for the GPU failed: {0}")]
    Poll(#[from] wgpu::PollError),

    /// Mapping the readback buffer failed.
    #[error("mapping the readback buffer failed: {0}")]
    MapAsync(#[from] wgpu::BufferAsyncError),

    /// The buffer-mapping callback was dropped without being called.
    #[error("the readback buffer was never mapped (map callback dropped)")]
    MapCallbackDropped,

    /// Getting a view of the mapped readback buffer failed.
    #[error("reading the mapped readback buffer failed: {0}")]
    MapRange(#[from] wgpu::MapRangeError),
}

/// A wgpu adapter together with the device and queue created from it.
pub struct Gpu {
    /// The physical (or software) adapter the device runs on.
    pub adapter: wgpu::Adapter,
    /// The logical device.
    pub device: wgpu::Device,
    /// The device's command queue.
    pub queue: wgpu::Queue,
}

impl Gpu {
    /// Opens a GPU without any window or surface.
    ///
    /// Searches Vulkan/Metal/DX12 and GL (the `WGPU_BACKEND` environment variable can narrow
    /// that down, e.g. `WGPU_BACKEND=gl`). Adapters from Vulkan/Metal/DX12 are preferred; GL is
    /// used only when none of those has an adapter. Within a backend group, hardware GPUs win
    /// over virtual and CPU adapters, but software adapters such as lavapipe are accepted, which
    /// is what CI uses.
    ///
    /// The device is created with no optional features and with the adapter's own limits, so
    /// texture sizes are bounded by the hardware rather than by wgpu's conservative defaults.
    pub fn headless() -> Result<Gpu, GpuError> {
        Gpu::headless_with_features(wgpu::Features::empty())
    }

    /// As [`Gpu::headless`], also enabling those of the `optional` features the adapter has
    /// (e.g. [`wgpu::Features::TIMESTAMP_QUERY`]); check [`wgpu::Device::features`] for which.
    pub fn headless_with_features(optional: wgpu::Features) -> Result<Gpu, GpuError> {
        let backends = (PREFERRED_BACKENDS | FALLBACK_BACKENDS).with_env();
        let adapter = select_adapter(backends)?;
        Gpu::from_adapter(adapter, optional)
    }

    /// Creates the device on a chosen adapter (a window picks one that can present to its
    /// surface), with those of the `optional` features the adapter has and its own limits.
    pub fn from_adapter(adapter: wgpu::Adapter, optional: wgpu::Features) -> Result<Gpu, GpuError> {
        let info = adapter.get_info();
        log::info!(
            "GPU adapter: {} ({} backend, {:?}, driver: {} {})",
            info.name,
            info.backend,
            info.device_type,
            info.driver,
            info.driver_info
        );

        let (device, queue) = pollster::block_on(adapter.request_device(&wgpu::DeviceDescriptor {
            label: Some("glint device"),
            required_features: optional & adapter.features(),
            required_limits: adapter.limits(),
            ..Default::default()
        }))
        .map_err(|source| GpuError::RequestDevice {
            adapter: info.name.clone(),
            source,
        })?;

        Ok(Gpu {
            adapter,
            device,
            queue,
        })
    }

    /// One-line description of the adapter: name, backend, device type and driver.
    pub fn adapter_summary(&self) -> String {
        let info = self.adapter.get_info();
        let mut summary = format!(
            "{} ({} backend, {:?})",
            info.name, info.backend, info.device_type
        );
        let driver = format!("{} {}", info.driver, info.driver_info);
        let driver = driver.trim();
        if !driver.is_empty() {
            summary.push_str(", driver: ");
            summary.push_str(driver);
        }
        summary
    }
}

/// Picks the best adapter among `backends`, trying [`PREFERRED_BACKENDS`] before the rest.
///
/// Each backend group gets its own instance, created only when the previous group had no
/// adapter: initialising GL (EGL) is slow and logs driver-probing errors, so it is skipped
/// entirely when Vulkan works.
fn select_adapter(backends: wgpu::Backends) -> Result<wgpu::Adapter, GpuError> {
    let groups = [backends & PREFERRED_BACKENDS, backends - PREFERRED_BACKENDS];
    for group in groups.into_iter().filter(|group| !group.is_empty()) {
        let mut descriptor = wgpu::InstanceDescriptor::new_without_display_handle().with_env();
        descriptor.backends = group;
        let instance = wgpu::Instance::new(descriptor);
        let adapters = pollster::block_on(instance.enumerate_adapters(group));
        for adapter in &adapters {
            let info = adapter.get_info();
            log::debug!(
                "found GPU adapter: {} ({} backend, {:?})",
                info.name,
                info.backend,
                info.device_type
            );
        }
        if let Some(adapter) = adapters
            .into_iter()
            .min_by_key(|adapter| device_type_rank(adapter.get_info().device_type))
        {
            return Ok(adapter);
        }
    }
    Err(GpuError::NoAdapter {
        backends: format!("{backends:?}"),
    })
}

/// Preference order of device types within one backend group (lower is better).
fn device_type_rank(device_type: wgpu::DeviceType) -> u8 {
    match device_type {
        wgpu::DeviceType::DiscreteGpu => 0,
        wgpu::DeviceType::IntegratedGpu => 1,
        wgpu::DeviceType::VirtualGpu => 2,
        wgpu::DeviceType::Other => 3,
        wgpu::DeviceType::Cpu => 4,
    }
}

/// Runs `work` inside validation and out-of-memory error scopes and reports the first error.
///
/// wgpu's default behaviour is to panic on such errors; this turns them into [`GpuError::Wgpu`].
pub(crate) fn error_scoped<T>(
    device: &wgpu::Device,
    context: &'static str,
    work: impl FnOnce() -> T,
) -> Result<T, GpuError> {
    let out_of_memory = device.push_error_scope(wgpu::ErrorFilter::OutOfMemory);
    let validation = device.push_error_scope(wgpu::ErrorFilter::Validation);
    let value = work();
    // Scopes must be popped in reverse order of pushing.
    let validation_error = pollster::block_on(validation.pop());
    let out_of_memory_error = pollster::block_on(out_of_memory.pop());
    match validation_error.or(out_of_memory_error) {
        Some(source) => Err(GpuError::Wgpu { context, source }),
        None => Ok(value),
    }
}

/// The bind-group layout of a compute probe's own buffers: binding 0 the input items
/// (read-only storage), binding 1 one output item per input (storage).
pub(crate) fn probe_io_layout(device: &wgpu::Device, label: &str) -> wgpu::BindGroupLayout {
    let compute = wgpu::ShaderStages::COMPUTE;
    bind_group_layout()
        .storage(0, compute)
        .storage_rw(1, compute)
        .build(device, label)
}

/// Runs a compute probe (what a shader computes, for tests against the CPU): uploads
/// `input` (`count` items), binds it with an output buffer of `output_size` bytes as group
/// `io_group` (layout [`probe_io_layout`]) beside `groups`, dispatches one invocation per
/// item in workgroups of 64 and returns the output's bytes.
#[allow(clippy::too_many_arguments)]
pub(crate) fn run_probe(
    gpu: &Gpu,
    context: &'static str,
    pipeline: &wgpu::ComputePipeline,
    io_layout: &wgpu::BindGroupLayout,
    io_group: u32,
    groups: &[(u32, &wgpu::BindGroup)],
    input: &[u8],
    count: usize,
    output_size: u64,
) -> Result<Vec<u8>, GpuError> {
    let device = &gpu.device;
    let output = error_scoped(device, context, || {
        // A binding must not be empty; pad to one 16-byte element.
        let input_buffer = buffer_init(
            gpu,
            "glint probe input",
            wgpu::BufferUsages::STORAGE,
            input,
            16,
        );
        let output = buffer(
            device,
            "glint probe output",
            output_size.max(16),
            wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC,
        );
        let io = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("glint probe buffers"),
            layout: io_layout,
            entries: &[
                wgpu::BindGroupEntry {
                    binding: 0,
                    resource: input_buffer.as_entire_binding(),
                },
                wgpu::BindGroupEntry {
                    binding: 1,
                    resource: output.as_entire_binding(),
                },
            ],
        });
        let mut encoder = device.create_command_encoder(&wgpu::CommandEncoderDescriptor {
            label: Some("glint probe encoder"),
        });
        {
            let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
                label: Some(context),
                timestamp_writes: None,
            });
            pass.set_pipeline(pipeline);
            for (index, group) in groups {
                pass.set_bind_group(*index, *group, &[]);
            }
            pass.set_bind_group(io_group, &io, &[]);
            pass.dispatch_workgroups((count as u32).div_ceil(64), 1, 1);
        }
        gpu.queue.submit([encoder.finish()]);
        output
    })?;
    let mut bytes = read_buffer(gpu, &output)?;
    bytes.truncate(output_size as usize);
    Ok(bytes)
}

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
    let (buffer, submission) = error_scoped(&gpu.device, "copying a buffer for readback", || {
        let buffer = buffer(
            &gpu.device,
            "glint buffer readback",
            size,
            wgpu::BufferUsages::MAP_READ,
        );
        let mut encoder = gpu
            .device
            .create_command_encoder(&wgpu::CommandEncoderDescriptor {
                label: Some("glint buffer readback encoder"),
            });
        encoder.copy_buffer_to_buffer(source, 0, &buffer, 0, size);
        let submission = gpu.queue.submit([encoder.finish()]);
        (buffer, submission)
    })?;
    let bytes = map_read(gpu, &buffer, submission)?;
    Ok(bytes)
}

/// Waits for `submission`, maps `buffer` for reading and returns its contents.
fn map_read(
    gpu: &Gpu,
    buffer: &wgpu::Buffer,
    submission: wgpu::SubmissionIndex,
) -> Result<Vec<u8>, GpuError> {
    let slice = buffer.slice(..);
    let (sender, receiver) = mpsc::channel();
    slice.map_async(wgpu::MapMode::Read, move |result| {
        // The receiver outlives the poll below; a failed send only means nobody is listening.
        let _ = sender.send(result);
    });
    gpu.device.poll(wgpu::PollType::Wait {
        submission_index: Some(submission),
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

    let (buffer, submission) = error_scoped(&gpu.device, "copying a texture for readback", || {
        let buffer = buffer(
            &gpu.device,
            "glint readback buffer",
            buffer_size,
            wgpu::BufferUsages::MAP_READ,
        );
        let mut encoder = gpu
            .device
            .create_command_encoder(&wgpu::CommandEncoderDescriptor {
                label: Some("glint readback encoder"),
            });
        encoder.copy_texture_to_buffer(
            wgpu::TexelCopyTextureInfo {
                texture,
                mip_level: 0,
                origin: wgpu::Origin3d::ZERO,
                aspect: wgpu::TextureAspect::All,
            },
            wgpu::TexelCopyBufferInfo {
                buffer: &buffer,
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
        );
        let submission = gpu.queue.submit([encoder.finish()]);
        (buffer, submission)
    })?;

    let mapped = map_read(gpu, &buffer, submission)?;
    let mut pixels = Vec::with_capacity(row_bytes as usize * height as usize);
    for row in mapped.chunks_exact(padded_row_bytes as usize) {
        pixels.extend_from_slice(&row[..row_bytes as usize]);
    }
    Ok(pixels)
}

/// Renders the smoke-test triangle offscreen and returns its RGBA8 pixels.
///
/// The target is a `width` x `height` `Rgba8Unorm` texture cleared to opaque black. The shader
/// `shaders/test_triangle.wgsl` generates the vertices from the vertex index at clip coordinates
/// (-0.5, -0.5), (0.5, -0.5), (0, 0.5) and fills the triangle with opaque red (1, 0, 0, 1).
/// Pixels are returned as by [`read_texture_rgba8`], top row first.
///
/// This exercises shader compilation, pipeline creation, rasterisation and readback, which is
/// enough to prove that an adapter (for example lavapipe on CI) can run the viewer.
pub fn render_test_triangle(gpu: &Gpu, width: u32, height: u32) -> Result<Vec<u8>, GpuError> {
    check_target_size(&gpu.device, width, height)?;
    let texture = error_scoped(&gpu.device, "rendering the test triangle", || {
        let texture = texture_2d(
            &gpu.device,
            "glint test triangle target",
            width,
            height,
            TEST_TRIANGLE_FORMAT,
            wgpu::TextureUsages::RENDER_ATTACHMENT | wgpu::TextureUsages::COPY_SRC,
        );
        let view = texture.create_view(&wgpu::TextureViewDescriptor::default());
        let shader = shader(
            &gpu.device,
            "glint test triangle shader",
            include_str!("../../shaders/test_triangle.wgsl"),
        );
        let pipeline = render_pipeline("glint test triangle", &shader, "vs_main", "fs_main")
            .color(TEST_TRIANGLE_FORMAT, None)
            .build(&gpu.device);

        let mut encoder = gpu
            .device
            .create_command_encoder(&wgpu::CommandEncoderDescriptor {
                label: Some("glint test triangle encoder"),
            });
        {
            let mut pass = clear_pass(
                &mut encoder,
                "glint test triangle pass",
                &[Some(&view)],
                wgpu::Color::BLACK,
                None,
                None,
            );
            pass.set_pipeline(&pipeline);
            pass.draw(0..3, 0..1);
        }
        gpu.queue.submit([encoder.finish()]);
        texture
    })?;

    read_texture_rgba8(gpu, &texture)
}

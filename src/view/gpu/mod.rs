//! Headless GPU access: adapter and device selection and the errors GPU work reports. The
//! wgpu plumbing every pass shares is in the submodules:
//! - [`build`]: shader modules, render and compute pipelines, bind-group layouts, buffers;
//! - [`target`]: target formats, the offscreen target, depth and blend state, how passes begin;
//! - [`readback`]: textures and buffers copied back to the CPU;
//! - [`radiosity_textures`], [`surface_textures`]: the uploads of D's atlas pages and of the
//!   scene's textures and material records;
//! - [`probe`]: compute probes of the shaders, for tests against the CPU;
//! - [`wgsl_layout`]: the checks that a `repr(C)` struct has its WGSL twin's layout (naga);
//! - [`triangle`]: the smoke-test triangle that proves an adapter can run the viewer.
//!
//! Nothing here needs a window or a surface, so it runs on CI machines whose only GPU is a
//! software Vulkan driver (Mesa lavapipe, from the Debian/Ubuntu package `mesa-vulkan-drivers`).
//!
//! Only Vulkan, Metal and DX12 adapters are used. wgpu's GL backend (GLES 3 semantics) cannot
//! bind one layer of an array texture as a 2D view and guesses view dimensions from the layer
//! count (a 6-layer array becomes a cube map), so on GL the radiosity pages read as zero and
//! every wall comes out black while nothing fails. Rather than write such frames, a machine
//! with only GL is refused with [`GpuError::NoAdapter`] or [`GpuError::UnsupportedBackend`],
//! whose messages name the package to install.
//!
//! Errors that wgpu reports through error scopes (validation, out of memory) are turned into
//! [`GpuError`] values instead of the default panicking handler.

use thiserror::Error;

pub mod build;
pub mod image_pass;
pub mod probe;
pub mod radiosity_textures;
pub mod readback;
pub mod surface_textures;
pub mod target;
pub mod triangle;
pub mod wgsl_layout;

/// The backends the viewer renders with: Vulkan (and Metal / DX12 on the platforms that have
/// them). GL is not among them (see the module documentation).
pub const SUPPORTED_BACKENDS: wgpu::Backends = wgpu::Backends::PRIMARY;

/// What to install where only GL is available, for the error messages.
pub const VULKAN_INSTALL_HINT: &str = "glint-view renders only with Vulkan, Metal or DX12 \
     (wgpu's GL backend draws black walls); on Debian/Ubuntu install Mesa's Vulkan driver: \
     apt-get install mesa-vulkan-drivers libvulkan1";

/// Why the scene cannot be drawn on this device.
#[derive(Debug, thiserror::Error)]
pub enum RenderError {
    /// wgpu reported an error.
    #[error(transparent)]
    Gpu(#[from] GpuError),
    /// The atlas does not fit the device's texture limits.
    #[error(
        "the radiosity atlas ({width}×{height} texels × {layers} pages) exceeds this GPU's limits ({max_side} texels per side, {max_layers} layers)"
    )]
    AtlasTooLarge {
        /// Layer width.
        width: u32,
        /// Layer height.
        height: u32,
        /// Pages.
        layers: u32,
        /// `max_texture_dimension_2d`.
        max_side: u32,
        /// `max_texture_array_layers`.
        max_layers: u32,
    },
    /// The scene's textures do not fit the device's texture limits (one layer per image, as
    /// large as the largest image).
    #[error(
        "the scene's textures ({width}×{height} texels × {layers} images) exceed this GPU's limits ({max_side} texels per side, {max_layers} layers)"
    )]
    TexturesTooLarge {
        /// Layer width.
        width: u32,
        /// Layer height.
        height: u32,
        /// Images.
        layers: u32,
        /// `max_texture_dimension_2d`.
        max_side: u32,
        /// `max_texture_array_layers`.
        max_layers: u32,
    },
    /// The reflection passes cannot be set up (a missing stage, an unreadable radiance map).
    #[error("reflections: {0}")]
    Reflections(String),
    /// The scene's vertex buffer exceeds the device's buffer limit.
    #[error("the scene's {bytes} bytes of vertices exceed this GPU's buffer limit of {max} bytes")]
    TooManyVertices {
        /// Bytes needed.
        bytes: u64,
        /// `max_buffer_size`.
        max: u64,
    },
}

/// Whether a 2D texture array of `layers` layers of `width` × `height` fits the device.
pub(crate) fn check_array_size(
    gpu: &Gpu,
    width: u32,
    height: u32,
    layers: u32,
) -> Result<(), RenderError> {
    let limits = gpu.device.limits();
    if width > limits.max_texture_dimension_2d
        || height > limits.max_texture_dimension_2d
        || layers > limits.max_texture_array_layers
    {
        return Err(RenderError::AtlasTooLarge {
            width,
            height,
            layers,
            max_side: limits.max_texture_dimension_2d,
            max_layers: limits.max_texture_array_layers,
        });
    }
    Ok(())
}

/// Errors from GPU setup, rendering and readback.
#[derive(Debug, Error)]
pub enum GpuError {
    /// No supported backend exposed an adapter.
    #[error(
        "no Vulkan, Metal or DX12 GPU adapter found (backends searched: {backends}): {VULKAN_INSTALL_HINT}"
    )]
    NoAdapter {
        /// The backends that were enumerated (after `WGPU_BACKEND`).
        backends: String,
    },

    /// The adapter runs on a backend the viewer refuses (GL).
    #[error("GPU adapter `{adapter}` uses the {backend} backend: {VULKAN_INSTALL_HINT}")]
    UnsupportedBackend {
        /// Name of the adapter.
        adapter: String,
        /// Its backend.
        backend: String,
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

    /// The texture given to [`read_texture_rgba8`](readback::read_texture_rgba8) cannot be read back as RGBA8 pixels.
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
    /// Searches Vulkan/Metal/DX12 ([`SUPPORTED_BACKENDS`]; the `WGPU_BACKEND` environment
    /// variable can narrow that down, e.g. `WGPU_BACKEND=vulkan`; naming only `gl` leaves
    /// nothing to search). Hardware GPUs win over virtual and CPU adapters, but software
    /// adapters such as lavapipe are accepted, which is what CI uses.
    ///
    /// The device is created with no optional features and with the adapter's own limits, so
    /// texture sizes are bounded by the hardware rather than by wgpu's conservative defaults.
    pub fn headless() -> Result<Gpu, GpuError> {
        Gpu::headless_with_features(wgpu::Features::empty())
    }

    /// As [`Gpu::headless`], also enabling those of the `optional` features the adapter has
    /// (e.g. [`wgpu::Features::TIMESTAMP_QUERY`]); check [`wgpu::Device::features`] for which.
    pub fn headless_with_features(optional: wgpu::Features) -> Result<Gpu, GpuError> {
        let adapter = select_adapter(SUPPORTED_BACKENDS.with_env())?;
        Gpu::from_adapter(adapter, optional)
    }

    /// Creates the device on a chosen adapter (a window picks one that can present to its
    /// surface), with those of the `optional` features the adapter has and its own limits.
    /// An adapter outside [`SUPPORTED_BACKENDS`] is refused.
    pub fn from_adapter(adapter: wgpu::Adapter, optional: wgpu::Features) -> Result<Gpu, GpuError> {
        let info = adapter.get_info();
        if !SUPPORTED_BACKENDS.contains(info.backend.into()) {
            return Err(GpuError::UnsupportedBackend {
                adapter: info.name,
                backend: info.backend.to_string(),
            });
        }
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

/// Picks the best adapter among `backends` ∩ [`SUPPORTED_BACKENDS`]; GL is never initialised.
fn select_adapter(backends: wgpu::Backends) -> Result<wgpu::Adapter, GpuError> {
    let group = backends & SUPPORTED_BACKENDS;
    let no_adapter = || GpuError::NoAdapter {
        backends: format!("{backends:?}"),
    };
    if group.is_empty() {
        return Err(no_adapter());
    }
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
    adapters
        .into_iter()
        .min_by_key(|adapter| device_type_rank(adapter.get_info().device_type))
        .ok_or_else(no_adapter)
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

//! Small builders for the wgpu objects every pass makes, with the viewer's defaults written
//! once: shader modules ([`shader`]), render pipelines ([`RenderPipelineBuilder`]: triangle
//! lists, no culling, one sample, vertex and fragment stage from one shader module), compute
//! pipelines ([`compute_pipeline`]), bind-group layouts ([`LayoutBuilder`]) and buffers
//! ([`buffer`], [`buffer_init`]).

use super::Gpu;

/// A shader module compiled from the WGSL `source`.
pub fn shader(device: &wgpu::Device, label: &str, source: &str) -> wgpu::ShaderModule {
    device.create_shader_module(wgpu::ShaderModuleDescriptor {
        label: Some(label),
        source: wgpu::ShaderSource::Wgsl(source.into()),
    })
}

/// A compute pipeline `label` running `shader`'s `entry` over the bind groups `layouts`
/// (group 0 first; `None`: a group the entry point does not use).
pub fn compute_pipeline(
    device: &wgpu::Device,
    label: &str,
    shader: &wgpu::ShaderModule,
    layouts: &[Option<&wgpu::BindGroupLayout>],
    entry: &str,
) -> wgpu::ComputePipeline {
    let layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
        label: Some(label),
        bind_group_layouts: layouts,
        immediate_size: 0,
    });
    device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
        label: Some(label),
        layout: Some(&layout),
        module: shader,
        entry_point: Some(entry),
        compilation_options: wgpu::PipelineCompilationOptions::default(),
        cache: None,
    })
}

/// A render pipeline being described; [`RenderPipelineBuilder::build`] creates it with its
/// pipeline layout.
pub struct RenderPipelineBuilder<'a> {
    label: &'a str,
    shader: &'a wgpu::ShaderModule,
    vs: &'a str,
    fs: &'a str,
    layouts: Vec<Option<&'a wgpu::BindGroupLayout>>,
    buffers: Vec<Option<wgpu::VertexBufferLayout<'a>>>,
    targets: Vec<Option<wgpu::ColorTargetState>>,
    depth: Option<wgpu::DepthStencilState>,
    topology: wgpu::PrimitiveTopology,
    constants: Vec<(&'a str, f64)>,
    samples: u32,
}

/// A pipeline `label` drawing with `shader`'s `vs` and `fs` entry points; by default a
/// triangle list without culling, no bind groups, vertex buffers, targets or depth.
pub fn render_pipeline<'a>(
    label: &'a str,
    shader: &'a wgpu::ShaderModule,
    vs: &'a str,
    fs: &'a str,
) -> RenderPipelineBuilder<'a> {
    RenderPipelineBuilder {
        label,
        shader,
        vs,
        fs,
        layouts: Vec::new(),
        buffers: Vec::new(),
        targets: Vec::new(),
        depth: None,
        topology: wgpu::PrimitiveTopology::TriangleList,
        constants: Vec::new(),
        samples: 1,
    }
}

impl<'a> RenderPipelineBuilder<'a> {
    /// The bind-group layouts, group 0 first.
    pub fn layouts(mut self, layouts: &[&'a wgpu::BindGroupLayout]) -> Self {
        self.layouts = layouts.iter().map(|&l| Some(l)).collect();
        self
    }

    /// The bind-group layouts, group 0 first, `None` for a group this pipeline does not use.
    pub fn layout_slots(mut self, layouts: &[Option<&'a wgpu::BindGroupLayout>]) -> Self {
        self.layouts = layouts.to_vec();
        self
    }

    /// Adds a vertex buffer layout (slot 0 first).
    pub fn vertex(mut self, layout: wgpu::VertexBufferLayout<'a>) -> Self {
        self.buffers.push(Some(layout));
        self
    }

    /// Adds a colour target (`None`: a slot the fragment stage does not write here).
    pub fn target(mut self, target: Option<wgpu::ColorTargetState>) -> Self {
        self.targets.push(target);
        self
    }

    /// Adds a colour target of `format` with `blend`, writing every channel.
    pub fn color(self, format: wgpu::TextureFormat, blend: Option<wgpu::BlendState>) -> Self {
        self.target(Some(wgpu::ColorTargetState {
            format,
            blend,
            write_mask: wgpu::ColorWrites::ALL,
        }))
    }

    /// The depth state.
    pub fn depth(mut self, depth: wgpu::DepthStencilState) -> Self {
        self.depth = Some(depth);
        self
    }

    /// The primitive topology (default: triangle list).
    pub fn topology(mut self, topology: wgpu::PrimitiveTopology) -> Self {
        self.topology = topology;
        self
    }

    /// Samples per pixel of the targets it draws into (default 1: single-sampled).
    pub fn samples(mut self, count: u32) -> Self {
        self.samples = count;
        self
    }

    /// Sets the shader's pipeline-overridable bool `name` (a WGSL `override`) in both stages.
    pub fn override_bool(mut self, name: &'a str, value: bool) -> Self {
        self.constants.push((name, f64::from(u8::from(value))));
        self
    }

    /// Sets the shader's pipeline-overridable number `name` (a WGSL `override` of any
    /// numeric type) in both stages.
    pub fn override_number(mut self, name: &'a str, value: f64) -> Self {
        self.constants.push((name, value));
        self
    }

    /// Creates the pipeline layout and the pipeline.
    pub fn build(self, device: &wgpu::Device) -> wgpu::RenderPipeline {
        let options = || wgpu::PipelineCompilationOptions {
            constants: &self.constants,
            ..Default::default()
        };
        let layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some(self.label),
            bind_group_layouts: &self.layouts,
            immediate_size: 0,
        });
        device.create_render_pipeline(&wgpu::RenderPipelineDescriptor {
            label: Some(self.label),
            layout: Some(&layout),
            vertex: wgpu::VertexState {
                module: self.shader,
                entry_point: Some(self.vs),
                compilation_options: options(),
                buffers: &self.buffers,
            },
            primitive: wgpu::PrimitiveState {
                topology: self.topology,
                cull_mode: None,
                ..Default::default()
            },
            depth_stencil: self.depth,
            multisample: wgpu::MultisampleState {
                count: self.samples,
                ..Default::default()
            },
            fragment: Some(wgpu::FragmentState {
                module: self.shader,
                entry_point: Some(self.fs),
                compilation_options: options(),
                targets: &self.targets,
            }),
            multiview_mask: None,
            cache: None,
        })
    }
}

/// A bind-group layout being described, entry by entry.
#[derive(Clone, Debug, Default)]
pub struct LayoutBuilder {
    entries: Vec<wgpu::BindGroupLayoutEntry>,
}

/// An empty bind-group layout description.
pub fn bind_group_layout() -> LayoutBuilder {
    LayoutBuilder::default()
}

impl LayoutBuilder {
    /// Adds an entry.
    pub fn entry(mut self, entry: wgpu::BindGroupLayoutEntry) -> Self {
        self.entries.push(entry);
        self
    }

    fn with(self, binding: u32, visibility: wgpu::ShaderStages, ty: wgpu::BindingType) -> Self {
        self.entry(wgpu::BindGroupLayoutEntry {
            binding,
            visibility,
            ty,
            count: None,
        })
    }

    /// A uniform buffer holding one `T` (its size is the minimum binding size).
    pub fn uniform<T>(self, binding: u32, visibility: wgpu::ShaderStages) -> Self {
        self.with(
            binding,
            visibility,
            wgpu::BindingType::Buffer {
                ty: wgpu::BufferBindingType::Uniform,
                has_dynamic_offset: false,
                min_binding_size: wgpu::BufferSize::new(std::mem::size_of::<T>() as u64),
            },
        )
    }

    /// A read-only storage buffer of any size.
    pub fn storage(self, binding: u32, visibility: wgpu::ShaderStages) -> Self {
        self.storage_buffer(binding, visibility, true)
    }

    /// A storage buffer of any size the shader writes.
    pub fn storage_rw(self, binding: u32, visibility: wgpu::ShaderStages) -> Self {
        self.storage_buffer(binding, visibility, false)
    }

    fn storage_buffer(self, binding: u32, visibility: wgpu::ShaderStages, read_only: bool) -> Self {
        self.with(
            binding,
            visibility,
            wgpu::BindingType::Buffer {
                ty: wgpu::BufferBindingType::Storage { read_only },
                has_dynamic_offset: false,
                min_binding_size: None,
            },
        )
    }

    /// A float texture of `dimension`, filterable or not.
    pub fn texture(
        self,
        binding: u32,
        visibility: wgpu::ShaderStages,
        dimension: wgpu::TextureViewDimension,
        filterable: bool,
    ) -> Self {
        self.with(
            binding,
            visibility,
            wgpu::BindingType::Texture {
                sample_type: wgpu::TextureSampleType::Float { filterable },
                view_dimension: dimension,
                multisampled: false,
            },
        )
    }

    /// A filtering sampler.
    pub fn sampler(self, binding: u32, visibility: wgpu::ShaderStages) -> Self {
        self.with(
            binding,
            visibility,
            wgpu::BindingType::Sampler(wgpu::SamplerBindingType::Filtering),
        )
    }

    /// The entries so far.
    pub fn entries(&self) -> &[wgpu::BindGroupLayoutEntry] {
        &self.entries
    }

    /// Creates the layout.
    pub fn build(&self, device: &wgpu::Device, label: &str) -> wgpu::BindGroupLayout {
        device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some(label),
            entries: &self.entries,
        })
    }
}

/// An unmapped buffer of `size` bytes for `usage` (plus `COPY_DST`, so it can be written).
pub fn buffer(
    device: &wgpu::Device,
    label: &str,
    size: u64,
    usage: wgpu::BufferUsages,
) -> wgpu::Buffer {
    device.create_buffer(&wgpu::BufferDescriptor {
        label: Some(label),
        size,
        usage: usage | wgpu::BufferUsages::COPY_DST,
        mapped_at_creation: false,
    })
}

/// A buffer for `usage` holding `bytes` (a multiple of 4 bytes), at least `min_size` bytes
/// long, rounded up to a multiple of 4; the write lands before the next submission.
pub fn buffer_init(
    gpu: &Gpu,
    label: &str,
    usage: wgpu::BufferUsages,
    bytes: &[u8],
    min_size: u64,
) -> wgpu::Buffer {
    let b = buffer(
        &gpu.device,
        label,
        (bytes.len() as u64).max(min_size).next_multiple_of(4),
        usage,
    );
    gpu.queue.write_buffer(&b, 0, bytes);
    b
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn layout_entries_carry_their_binding_type() {
        let all = wgpu::ShaderStages::VERTEX_FRAGMENT;
        let l = bind_group_layout()
            .uniform::<[f32; 8]>(0, all)
            .storage(1, wgpu::ShaderStages::FRAGMENT)
            .texture(2, all, wgpu::TextureViewDimension::Cube, false)
            .sampler(3, all)
            .storage_rw(4, wgpu::ShaderStages::COMPUTE);
        let e = l.entries();
        assert_eq!(
            e.iter().map(|e| e.binding).collect::<Vec<_>>(),
            [0, 1, 2, 3, 4]
        );
        assert!(matches!(
            e[4].ty,
            wgpu::BindingType::Buffer {
                ty: wgpu::BufferBindingType::Storage { read_only: false },
                min_binding_size: None,
                ..
            }
        ));
        assert!(matches!(
            e[0].ty,
            wgpu::BindingType::Buffer {
                ty: wgpu::BufferBindingType::Uniform,
                min_binding_size: Some(s),
                ..
            } if s.get() == 32
        ));
        assert!(matches!(
            e[1].ty,
            wgpu::BindingType::Buffer {
                ty: wgpu::BufferBindingType::Storage { read_only: true },
                min_binding_size: None,
                ..
            }
        ));
        assert!(matches!(
            e[2].ty,
            wgpu::BindingType::Texture {
                sample_type: wgpu::TextureSampleType::Float { filterable: false },
                view_dimension: wgpu::TextureViewDimension::Cube,
                multisampled: false,
            }
        ));
        assert_eq!(e[1].visibility, wgpu::ShaderStages::FRAGMENT);
        assert!(e.iter().all(|e| e.count.is_none()));
    }
}

//! Thin glass in the viewer ([`crate::scene::material::Transmission`]): the scene pass leaves
//! transmissive triangles out, and after every pass over the scene (reflections included,
//! so a mirror seen through glass is tinted too) they are drawn in two passes over the frame
//! (`shaders/glass.wgsl`): one multiplies what is behind by the transmittance
//! tint × factor × (1 − F) at the pixel's view angle, the next adds the glass's own D. Both
//! depth test against the opaque scene and write no depth.
//!
//! Overlapping panes are approximated: every pane's tint applies before any pane's D is
//! added, so the nearer pane does not tint the farther one's D. A planar reflector's mirrored
//! view draws its glass the same way after its opaque surfaces ([`MirroredGlass`]); the
//! baked radiance maps and cube maps pass their rays through glass
//! ([`crate::radiance::shading::exitant`], [`crate::materials::envmap::capture_cube`]).

use std::ops::Range;

use crate::scene::Scene;
use crate::view::gpu::build::{bind_group_layout, buffer_init, render_pipeline, shader};
use crate::view::gpu::target::{ADDITIVE_KEEP_ALPHA, overlay_pass, reverse_z_depth};
use crate::view::gpu::{Gpu, RenderError, error_scoped};

use super::renderer::{
    Renderer, SHADER_SOURCE, SURFACE_TEXTURES, SurfaceShading, frame_bind_group,
    frame_bind_group_layout, scene_vertex_layout, sides,
};

/// WGSL of the glass passes, appended to [`SHADER_SOURCE`].
pub const GLASS_SOURCE: &str = include_str!("../../../shaders/glass.wgsl");

/// WGSL of the glass passes in a mirrored view, appended to the reflection shader and
/// [`GLASS_SOURCE`].
pub const MIRRORED_GLASS_SOURCE: &str = include_str!("../../../shaders/glass_mirrored.wgsl");

/// Multiplies the target by the fragment's colour (the transmittance) and keeps its alpha.
const MULTIPLY_KEEP_ALPHA: wgpu::BlendState = wgpu::BlendState {
    color: wgpu::BlendComponent {
        src_factor: wgpu::BlendFactor::Zero,
        dst_factor: wgpu::BlendFactor::Src,
        operation: wgpu::BlendOperation::Add,
    },
    alpha: wgpu::BlendComponent {
        src_factor: wgpu::BlendFactor::Zero,
        dst_factor: wgpu::BlendFactor::One,
        operation: wgpu::BlendOperation::Add,
    },
};

/// Per material (`GlassRecord` in glass.wgsl): tint × transmission factor and the Fresnel
/// F₀, then 1 where the material is double-sided (0: its back faces add no light).
pub fn glass_records(scene: &Scene) -> Vec<[[f32; 4]; 2]> {
    let mut records: Vec<[[f32; 4]; 2]> = scene
        .materials
        .iter()
        .map(|m| {
            let t = &m.transmission;
            let c = t.tint * if m.is_transmissive() { t.factor } else { 0.0 };
            [[c.x, c.y, c.z, t.f0()], [sides(m), 0.0, 0.0, 0.0]]
        })
        .collect();
    // A storage buffer may not be empty.
    records.push([[0.0; 4]; 2]);
    records
}

/// The glass passes: their pipelines, their records, and the index ranges they draw.
pub struct GlassPasses {
    tint: wgpu::RenderPipeline,
    add: wgpu::RenderPipeline,
    /// The scene pass's bindings (group 0).
    frame_group: wgpu::BindGroup,
    bind_group: wgpu::BindGroup,
    runs: Vec<Range<u32>>,
}

impl GlassPasses {
    /// The passes of `renderer`'s transmissive triangles (`scene`'s); `None` without any.
    pub fn new(
        gpu: &Gpu,
        scene: &Scene,
        renderer: &Renderer,
    ) -> Result<Option<GlassPasses>, RenderError> {
        let formats = renderer.formats();
        Self::for_target(gpu, scene, renderer, formats.color, formats.samples)
    }

    /// [`GlassPasses::new`] into targets of `format` with `samples` samples (a cube map's
    /// faces: [`GlassPasses::record`] with their frame groups).
    pub fn for_target(
        gpu: &Gpu,
        scene: &Scene,
        renderer: &Renderer,
        format: wgpu::TextureFormat,
        samples: u32,
    ) -> Result<Option<GlassPasses>, RenderError> {
        let runs = renderer.glass_runs();
        if runs.is_empty() {
            return Ok(None);
        }
        let device = &gpu.device;
        let passes = error_scoped(device, "creating the glass pipelines", || {
            let source = format!("{SHADER_SOURCE}\n{GLASS_SOURCE}");
            let module = shader(device, "glint glass shader", &source);
            let frame_layout = frame_bind_group_layout(device);
            let frame_group = frame_bind_group(
                device,
                &frame_layout,
                renderer.frame_uniform_buffer(),
                renderer.textures(),
            );
            let textures = runs.iter().any(|r| r.shading != SurfaceShading::Plain);
            let (layout, bind_group) = records_group(gpu, scene);
            let pipeline = |label, entry, blend| {
                render_pipeline(label, &module, "vs_world", entry)
                    .layout_slots(&[Some(&frame_layout), None, Some(&layout)])
                    .vertex(scene_vertex_layout())
                    .depth(reverse_z_depth(false, wgpu::CompareFunction::Greater))
                    .color(format, Some(blend))
                    .samples(samples)
                    .override_bool(SURFACE_TEXTURES, textures)
                    .build(device)
            };
            GlassPasses {
                tint: pipeline("glint glass tint", "fs_glass_tint", MULTIPLY_KEEP_ALPHA),
                add: pipeline("glint glass light", "fs_glass_add", ADDITIVE_KEEP_ALPHA),
                frame_group,
                bind_group,
                runs: runs.iter().map(|r| r.indices.clone()).collect(),
            }
        })?;
        Ok(Some(passes))
    }

    /// Records both passes over the finished frame in `color`, depth tested against `depth`,
    /// with `renderer`'s vertices and indices.
    pub fn draw(
        &self,
        encoder: &mut wgpu::CommandEncoder,
        renderer: &Renderer,
        color: &wgpu::TextureView,
        depth: &wgpu::TextureView,
    ) {
        let mut pass = overlay_pass(encoder, "glint glass passes", color, depth);
        self.record(&mut pass, renderer, &self.frame_group);
    }

    /// Records both passes into `pass` (after its opaque surfaces, depth attached) with
    /// `frame_group` (a frame bind group: the view's camera) and `renderer`'s buffers.
    pub fn record(
        &self,
        pass: &mut wgpu::RenderPass<'_>,
        renderer: &Renderer,
        frame_group: &wgpu::BindGroup,
    ) {
        let (vertices, indices) = (renderer.vertex_buffer(), renderer.index_buffer());
        pass.set_bind_group(0, frame_group, &[]);
        pass.set_bind_group(2, &self.bind_group, &[]);
        pass.set_vertex_buffer(0, vertices.slice(..));
        pass.set_index_buffer(indices.slice(..), wgpu::IndexFormat::Uint32);
        for pipeline in [&self.tint, &self.add] {
            pass.set_pipeline(pipeline);
            for r in &self.runs {
                pass.draw_indexed(r.clone(), 0, 0..1);
            }
        }
    }
}

/// The glass records' bind group layout and group (group 2 of the glass shaders).
fn records_group(gpu: &Gpu, scene: &Scene) -> (wgpu::BindGroupLayout, wgpu::BindGroup) {
    let device = &gpu.device;
    let layout = bind_group_layout()
        .storage(0, wgpu::ShaderStages::FRAGMENT)
        .build(device, "glint glass bind group layout");
    let records = glass_records(scene);
    let buffer = buffer_init(
        gpu,
        "glint glass records",
        wgpu::BufferUsages::STORAGE,
        bytemuck::cast_slice(&records),
        16,
    );
    let group = device.create_bind_group(&wgpu::BindGroupDescriptor {
        label: Some("glint glass bind group"),
        layout: &layout,
        entries: &[wgpu::BindGroupEntry {
            binding: 0,
            resource: buffer.as_entire_binding(),
        }],
    });
    (layout, group)
}

/// The glass passes of a planar reflector's mirrored view (`shaders/glass_mirrored.wgsl`):
/// after the mirror pass's opaque surfaces, the frame's two glass passes into M, clipped at
/// the reflector's plane as the mirror pass is.
pub struct MirroredGlass {
    tint: wgpu::RenderPipeline,
    add: wgpu::RenderPipeline,
    bind_group: wgpu::BindGroup,
    runs: Vec<Range<u32>>,
}

impl MirroredGlass {
    /// The passes of `renderer`'s transmissive triangles into a map of `format` with the
    /// mirror pass's layouts (`frame_layout`, `params_layout`) and shader source
    /// (`reflect_source`); `None` without glass. Call inside an error scope.
    pub fn build(
        gpu: &Gpu,
        scene: &Scene,
        renderer: &Renderer,
        reflect_source: &str,
        layouts: [&wgpu::BindGroupLayout; 2],
        format: wgpu::TextureFormat,
    ) -> Option<MirroredGlass> {
        let runs = renderer.glass_runs();
        if runs.is_empty() {
            return None;
        }
        let device = &gpu.device;
        let source = format!("{reflect_source}\n{GLASS_SOURCE}\n{MIRRORED_GLASS_SOURCE}");
        let module = shader(device, "glint mirrored glass shader", &source);
        let textures = runs.iter().any(|r| r.shading != SurfaceShading::Plain);
        let (layout, bind_group) = records_group(gpu, scene);
        let pipeline = |label, entry, blend| {
            render_pipeline(label, &module, "vs_mirror", entry)
                .layout_slots(&[Some(layouts[0]), Some(layouts[1]), Some(&layout)])
                .vertex(scene_vertex_layout())
                .depth(reverse_z_depth(false, wgpu::CompareFunction::Greater))
                .color(format, Some(blend))
                .override_bool(SURFACE_TEXTURES, textures)
                .build(device)
        };
        Some(MirroredGlass {
            tint: pipeline(
                "glint mirrored glass tint",
                "fs_mirror_glass_tint",
                MULTIPLY_KEEP_ALPHA,
            ),
            add: pipeline(
                "glint mirrored glass light",
                "fs_mirror_glass_add",
                ADDITIVE_KEEP_ALPHA,
            ),
            bind_group,
            runs: runs.iter().map(|r| r.indices.clone()).collect(),
        })
    }

    /// Draws both passes into the mirror `pass` with its groups 0 (`frame_group`) and 1
    /// (`params_group`), after its opaque surfaces.
    pub fn draw(
        &self,
        pass: &mut wgpu::RenderPass<'_>,
        renderer: &Renderer,
        frame_group: &wgpu::BindGroup,
        params_group: &wgpu::BindGroup,
    ) {
        pass.set_bind_group(0, frame_group, &[]);
        pass.set_bind_group(1, params_group, &[]);
        pass.set_bind_group(2, &self.bind_group, &[]);
        pass.set_vertex_buffer(0, renderer.vertex_buffer().slice(..));
        pass.set_index_buffer(renderer.index_buffer().slice(..), wgpu::IndexFormat::Uint32);
        for pipeline in [&self.tint, &self.add] {
            pass.set_pipeline(pipeline);
            for r in &self.runs {
                pass.draw_indexed(r.clone(), 0, 0..1);
            }
        }
    }
}

//! The scene pass: the wgpu pipeline that draws a scene lit by its radiosity textures.
//! What every pass shares (formats, targets, depth and blend state) is in
//! [`crate::view::gpu::target`], the wgpu builders in [`crate::view::gpu::build`].
//!
//! - One indexed draw for the whole scene ([`SceneMesh`]): a vertex is a position, lightmap
//!   coordinates in texels of its atlas page, the page, both texture coordinate sets and the
//!   material ([`Vertex`]); corners that agree on all of them are shared (within a chart they
//!   do), which lets the GPU's vertex cache work.
//! - The radiosity pages hold D, or for a material with a base colour texture D over that
//!   texture's texel mean; the fragment shader multiplies the full-resolution texture back in
//!   and adds textured emission (`surface_d`), and discards alpha-masked cut-outs, from the
//!   scene's images and material records in the frame bind group
//!   ([`crate::view::gpu::surface_textures`]). Only triangles of alpha-masked materials are
//!   drawn with that shader (`fs_main`); the rest with one that never discards
//!   (`fs_opaque`), which lets the depth test run before shading, and triangles of materials
//!   with neither textures nor cut-outs with `fs_opaque` specialised to leave the textures out
//!   (`SURFACE_TEXTURES` false, [`SurfaceShading`]). The draw is split into runs in scene order
//!   ([`shading_runs`]), so it draws what one draw would, in the same order.
//! - The atlas pages in one `Rgba16Float` 2D texture array, every layer the size of the largest
//!   page; smaller pages are padded by repeating their edge texels, so the clamp-to-edge
//!   sampler behaves at a page's edge exactly as the CPU's clamped lookups do.
//! - The fragment shader reconstructs D with the cubic B-spline ([`crate::view::cpu::bicubic`]).
//! - Depth: `Depth32Float`, reverse Z with an infinite far plane (depth 1 at the near plane,
//!   compare `Greater`), which keeps precision across scenes of any size.
//! - Output: linear D to the frame's radiance target (`Rgba16Float`,
//!   [`super::display::RADIANCE_FORMAT`]); the display pass exposes, tone-maps and encodes it
//!   ([`super::display`]), so the shaders' `exposure` is 1 and `encode_srgb` 0 for frames.
//! - No back-face culling: the CPU reference's ray casts see both faces too.

use std::ops::Range;

use bytemuck::{Pod, Zeroable};
use glam::{Mat4, Vec4};

use crate::camera::Camera;
use crate::radiosity::RadiosityMap;
use crate::radiosity::atlas::Atlas;
use crate::scene::{Material, Scene};
use crate::view::gpu::build::{bind_group_layout, buffer, buffer_init, render_pipeline, shader};
use crate::view::gpu::radiosity_textures::RadiosityTextures;
use crate::view::gpu::target::{TargetFormats, clear_pass, reverse_z_depth};
use crate::view::gpu::{Gpu, RenderError, error_scoped};

/// WGSL source of the viewer's shaders.
pub const SHADER_SOURCE: &str = include_str!("../../../shaders/view.wgsl");

/// Near plane as a fraction of the scene's bounding-box diagonal (the far plane is at
/// infinity; reverse Z keeps depth precision even this close).
pub const NEAR_FRACTION: f32 = 1e-4;

/// Mirrors `FrameUniforms` in `shaders/view.wgsl` (80 bytes).
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, Pod, Zeroable)]
pub struct FrameUniforms {
    /// World to clip, column-major.
    pub view_proj: [[f32; 4]; 4],
    /// Size of a texture-array layer in texels.
    pub atlas_size: [f32; 2],
    /// Multiplies D before output.
    pub exposure: f32,
    /// 1 when the shader must encode sRGB itself (non-sRGB target), else 0.
    pub encode_srgb: u32,
    /// The camera's position (w unused): cube faces store each fragment's distance from it.
    pub eye: [f32; 4],
}

/// One vertex of the scene (68 bytes): `@location(0..=8)` of `VertexIn` in the shader.
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, Pod, Zeroable)]
pub struct Vertex {
    /// World position, metres.
    pub position: [f32; 3],
    /// Lightmap coordinates in texels of the page.
    pub lightmap: [f32; 2],
    /// Atlas page (texture-array layer).
    pub page: u32,
    /// Texture coordinates, set 0 (`TEXCOORD_0`).
    pub uv0: [f32; 2],
    /// Texture coordinates, set 1 (zero without `TEXCOORD_1`).
    pub uv1: [f32; 2],
    /// Material index (into the material records of [`crate::view::gpu::surface_textures`]).
    pub material: u32,
    /// The triangle's unit face normal where its back side has texels of its own
    /// ([`Atlas::backs`]), zero elsewhere: seen from behind it, an eye reads the back's.
    pub face: [f32; 3],
    /// The back side's lightmap coordinates (`lightmap` where the sides share texels).
    pub lightmap_back: [f32; 2],
    /// The back side's page (`page` where the sides share texels).
    pub page_back: u32,
}

/// The vertex attributes of [`Vertex`].
const VERTEX_ATTRIBUTES: [wgpu::VertexAttribute; 9] = wgpu::vertex_attr_array![
    0 => Float32x3, 1 => Float32x2, 2 => Uint32, 3 => Float32x2, 4 => Float32x2, 5 => Uint32,
    6 => Float32x3, 7 => Float32x2, 8 => Uint32
];

/// The vertex buffer layout of a [`SceneMesh`], for every pass that draws scene triangles.
pub(crate) fn scene_vertex_layout() -> wgpu::VertexBufferLayout<'static> {
    wgpu::VertexBufferLayout {
        array_stride: std::mem::size_of::<Vertex>() as u64,
        step_mode: wgpu::VertexStepMode::Vertex,
        attributes: &VERTEX_ATTRIBUTES,
    }
}

/// The scene as one indexed triangle list.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct SceneMesh {
    /// Distinct vertices, in order of first use.
    pub vertices: Vec<Vertex>,
    /// Three per triangle, in the scene's triangle order.
    pub indices: Vec<u32>,
}

impl SceneMesh {
    /// The mesh of `scene`'s triangles with `atlas`'s lightmap coordinates (both sides'
    /// where the back has texels of its own); corners equal in every attribute (bit for bit)
    /// share a vertex.
    pub fn new(scene: &Scene, atlas: &Atlas) -> SceneMesh {
        let mut mesh = SceneMesh::default();
        let mut ids: std::collections::HashMap<[u32; 17], u32> = std::collections::HashMap::new();
        for (i, (t, (&page, c))) in scene
            .triangles
            .iter()
            .zip(atlas.tri_page.iter().zip(&atlas.tri_coords))
            .enumerate()
        {
            let uv1 = t.uv1.unwrap_or([glam::Vec2::ZERO; 3]);
            // The twin's corners are this triangle's in the order 0, 2, 1.
            let (face, back_page, back) = match atlas.back_of(i as u32) {
                Some(twin) => {
                    let b = atlas.tri_coords[twin as usize];
                    (
                        t.face_normal(),
                        atlas.tri_page[twin as usize],
                        [b[0], b[2], b[1]],
                    )
                }
                None => (glam::Vec3::ZERO, page, *c),
            };
            for (k, (p, uv)) in t.p.iter().zip(c).enumerate() {
                let v = Vertex {
                    position: p.to_array(),
                    lightmap: uv.to_array(),
                    page,
                    uv0: t.uv[k].to_array(),
                    uv1: uv1[k].to_array(),
                    material: t.material,
                    face: face.to_array(),
                    lightmap_back: back[k].to_array(),
                    page_back: back_page,
                };
                let key = bytemuck::cast::<Vertex, [u32; 17]>(v);
                let next = mesh.vertices.len() as u32;
                let id = *ids.entry(key).or_insert(next);
                if id == next {
                    mesh.vertices.push(v);
                }
                mesh.indices.push(id);
            }
        }
        mesh
    }

    /// The indices of `triangles` (scene triangle numbers), three each, in the given order.
    pub fn triangle_indices(&self, triangles: impl IntoIterator<Item = usize>) -> Vec<u32> {
        triangles
            .into_iter()
            .flat_map(|t| self.indices[3 * t..3 * t + 3].iter().copied())
            .collect()
    }
}

/// Which of the scene pass's fragment shaders a material's triangles need.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SurfaceShading {
    /// D as stored: no base colour texture, no cut-outs (`fs_opaque` with `SURFACE_TEXTURES`
    /// false).
    Plain,
    /// D times the base colour texture plus textured emission (`fs_opaque`).
    Textured,
    /// Textured, and alpha-masked cut-outs discarded (`fs_main`).
    Masked,
}

impl SurfaceShading {
    /// The shading `material` needs (as
    /// [`crate::view::gpu::surface_textures::material_records`] reads it: a material without a
    /// base colour texture stores D itself).
    pub fn of(material: &Material) -> SurfaceShading {
        if material.has_cutouts() {
            SurfaceShading::Masked
        } else if material.base_texture.is_some() {
            SurfaceShading::Textured
        } else {
            SurfaceShading::Plain
        }
    }

    /// The shading of each of `scene`'s triangles, in scene order (a triangle whose material
    /// index is out of range is drawn as the GPU's material table pads it: plain).
    pub fn of_triangles(scene: &Scene) -> impl Iterator<Item = SurfaceShading> + '_ {
        scene.triangles.iter().map(|t| {
            scene
                .materials
                .get(t.material as usize)
                .map_or(SurfaceShading::Plain, SurfaceShading::of)
        })
    }
}

/// A run of consecutive scene triangles of one [`SurfaceShading`], as a range of
/// [`SceneMesh::indices`].
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct ShadingRun {
    /// Indices of the run's triangles (three per triangle, scene order).
    pub indices: Range<u32>,
    /// The fragment shader that draws them.
    pub shading: SurfaceShading,
}

/// Triangles, given each one's [`SurfaceShading`] (in scene order), split into maximal
/// [`ShadingRun`]s: a scene of untextured opaque materials is one run; an empty scene has
/// none.
pub fn shading_runs(shadings: impl IntoIterator<Item = SurfaceShading>) -> Vec<ShadingRun> {
    let mut runs: Vec<ShadingRun> = Vec::new();
    for (t, shading) in shadings.into_iter().enumerate() {
        let end = 3 * (t as u32 + 1);
        match runs.last_mut() {
            Some(run) if run.shading == shading => run.indices.end = end,
            _ => runs.push(ShadingRun {
                indices: end - 3..end,
                shading,
            }),
        }
    }
    runs
}

/// Whether each of `scene`'s triangles transmits (scene order).
pub fn transmissive_triangles(scene: &Scene) -> Vec<bool> {
    scene
        .triangles
        .iter()
        .map(|t| {
            scene
                .materials
                .get(t.material as usize)
                .is_some_and(|m| m.is_transmissive())
        })
        .collect()
}

/// Splits `runs` (of scene triangles, three indices each) into the runs of opaque triangles
/// and those of transmissive ones (`glass[t]`), each in scene order.
pub fn split_runs(runs: Vec<ShadingRun>, glass: &[bool]) -> (Vec<ShadingRun>, Vec<ShadingRun>) {
    let (mut opaque, mut clear) = (Vec::new(), Vec::new());
    for run in runs {
        let mut start = run.indices.start;
        while start < run.indices.end {
            let is_glass = glass[start as usize / 3];
            let mut end = start + 3;
            while end < run.indices.end && glass[end as usize / 3] == is_glass {
                end += 3;
            }
            let part = ShadingRun {
                indices: start..end,
                shading: run.shading,
            };
            if is_glass {
                clear.push(part);
            } else {
                opaque.push(part);
            }
            start = end;
        }
    }
    (opaque, clear)
}

/// The `override` in view.wgsl that specialises a pipeline to scenes (or runs) without
/// surface textures or cut-outs ([`SurfaceShading::Plain`]).
pub(crate) const SURFACE_TEXTURES: &str = "SURFACE_TEXTURES";

/// World-to-clip matrix of `camera` for an image of `aspect` = width / height: a reverse-Z
/// perspective with the far plane at infinity. Consistent with [`Camera::ray_direction`]: the
/// centre of pixel (x, y) projects to [`Camera::pixel_ndc`]`(x, y)`.
pub fn view_projection(camera: &Camera, aspect: f32, near: f32) -> Mat4 {
    let (r, u, f) = (camera.right, camera.up, camera.forward);
    let p = camera.position;
    // World to view: rows right, up, −forward (the camera looks down its −Z).
    let view = Mat4::from_cols(
        Vec4::new(r.x, u.x, -f.x, 0.0),
        Vec4::new(r.y, u.y, -f.y, 0.0),
        Vec4::new(r.z, u.z, -f.z, 0.0),
        Vec4::new(-r.dot(p), -u.dot(p), f.dot(p), 1.0),
    );
    // Infinite reverse-Z perspective: clip w = −z_view and clip z = near, so depth =
    // near / −z_view is 1 at the near plane and falls towards 0 at infinity.
    let s = 1.0 / (0.5 * camera.fov_y).tan();
    let proj = Mat4::from_cols(
        Vec4::new(s / aspect, 0.0, 0.0, 0.0),
        Vec4::new(0.0, s, 0.0, 0.0),
        Vec4::new(0.0, 0.0, 0.0, -1.0),
        Vec4::new(0.0, 0.0, near, 0.0),
    );
    proj * view
}

/// The near plane for a scene: [`NEAR_FRACTION`] of its diagonal.
pub fn near_plane(scene: &Scene) -> f32 {
    (scene.bounds.diagonal() * NEAR_FRACTION).max(1e-6)
}

/// Bind group 0 of every entry point: the frame uniforms, the pages and their sampler, the
/// scene's images and the material records.
pub(crate) fn frame_bind_group_layout(device: &wgpu::Device) -> wgpu::BindGroupLayout {
    let visibility =
        wgpu::ShaderStages::VERTEX | wgpu::ShaderStages::FRAGMENT | wgpu::ShaderStages::COMPUTE;
    bind_group_layout()
        .uniform::<FrameUniforms>(0, visibility)
        .texture(1, visibility, wgpu::TextureViewDimension::D2Array, true)
        .sampler(2, visibility)
        .texture(3, visibility, wgpu::TextureViewDimension::D2Array, true)
        .storage(
            4,
            wgpu::ShaderStages::FRAGMENT | wgpu::ShaderStages::COMPUTE,
        )
        .build(device, "glint frame bind group layout")
}

pub(crate) fn frame_bind_group(
    device: &wgpu::Device,
    layout: &wgpu::BindGroupLayout,
    uniforms: &wgpu::Buffer,
    textures: &RadiosityTextures,
) -> wgpu::BindGroup {
    device.create_bind_group(&wgpu::BindGroupDescriptor {
        label: Some("glint frame bind group"),
        layout,
        entries: &[
            wgpu::BindGroupEntry {
                binding: 0,
                resource: uniforms.as_entire_binding(),
            },
            wgpu::BindGroupEntry {
                binding: 1,
                resource: wgpu::BindingResource::TextureView(&textures.view),
            },
            wgpu::BindGroupEntry {
                binding: 2,
                resource: wgpu::BindingResource::Sampler(&textures.sampler),
            },
            wgpu::BindGroupEntry {
                binding: 3,
                resource: wgpu::BindingResource::TextureView(&textures.surfaces.view),
            },
            wgpu::BindGroupEntry {
                binding: 4,
                resource: textures.surfaces.materials.as_entire_binding(),
            },
        ],
    })
}

/// The frame uniforms' buffer ([`FrameUniforms`]).
pub(crate) fn uniform_buffer(device: &wgpu::Device) -> wgpu::Buffer {
    buffer(
        device,
        "glint frame uniforms",
        std::mem::size_of::<FrameUniforms>() as u64,
        wgpu::BufferUsages::UNIFORM,
    )
}

/// The scene on the GPU and the pipeline that draws it.
pub struct Renderer {
    /// `fs_opaque` without the surface textures: [`SurfaceShading::Plain`] triangles.
    plain_pipeline: wgpu::RenderPipeline,
    /// `fs_opaque`: [`SurfaceShading::Textured`] triangles.
    pipeline: wgpu::RenderPipeline,
    /// `fs_main`: triangles of alpha-masked materials.
    masked_pipeline: wgpu::RenderPipeline,
    runs: Vec<ShadingRun>,
    /// `runs` less the transmissive triangles, which [`super::glass`] draws.
    opaque_runs: Vec<ShadingRun>,
    glass_runs: Vec<ShadingRun>,
    bind_group: wgpu::BindGroup,
    uniforms: wgpu::Buffer,
    vertices: wgpu::Buffer,
    indices: wgpu::Buffer,
    index_count: u32,
    textures: RadiosityTextures,
    formats: TargetFormats,
    near: f32,
}

impl Renderer {
    /// Uploads the scene's vertices and radiosity pages and builds the pipeline.
    pub fn new(
        gpu: &Gpu,
        scene: &Scene,
        map: &RadiosityMap,
        formats: TargetFormats,
    ) -> Result<Renderer, RenderError> {
        let mesh = SceneMesh::new(scene, &map.atlas);
        let bytes = std::mem::size_of_val(mesh.vertices.as_slice()) as u64;
        let index_bytes = std::mem::size_of_val(mesh.indices.as_slice()) as u64;
        let max = gpu.device.limits().max_buffer_size;
        if bytes.max(index_bytes) > max {
            return Err(RenderError::TooManyVertices {
                bytes: bytes.max(index_bytes),
                max,
            });
        }
        let textures = RadiosityTextures::upload_for(gpu, map, Some(scene))?;
        let device = &gpu.device;
        let renderer = error_scoped(device, "creating the scene pipeline", || {
            let shader = shader(device, "glint view shader", SHADER_SOURCE);
            let bind_group_layout = frame_bind_group_layout(device);
            let uniforms = uniform_buffer(device);
            let bind_group = frame_bind_group(device, &bind_group_layout, &uniforms, &textures);
            let pipeline = |label, entry, textures| {
                render_pipeline(label, &shader, "vs_main", entry)
                    .layouts(&[&bind_group_layout])
                    .vertex(scene_vertex_layout())
                    .depth(reverse_z_depth(true, wgpu::CompareFunction::Greater))
                    .color(formats.color, None)
                    .samples(formats.samples)
                    .override_bool(SURFACE_TEXTURES, textures)
                    .build(device)
            };
            let plain = pipeline("glint view pipeline (untextured)", "fs_opaque", false);
            let opaque = pipeline("glint view pipeline", "fs_opaque", true);
            let masked = pipeline("glint view pipeline (cut-outs)", "fs_main", true);
            let vertex_buffer = buffer_init(
                gpu,
                "glint scene vertices",
                wgpu::BufferUsages::VERTEX,
                bytemuck::cast_slice(&mesh.vertices),
                std::mem::size_of::<Vertex>() as u64,
            );
            let index_buffer = buffer_init(
                gpu,
                "glint scene indices",
                wgpu::BufferUsages::INDEX,
                bytemuck::cast_slice(&mesh.indices),
                4,
            );
            (
                (plain, opaque, masked),
                bind_group,
                uniforms,
                vertex_buffer,
                index_buffer,
            )
        })?;
        let (
            (plain_pipeline, pipeline, masked_pipeline),
            bind_group,
            uniforms,
            vertex_buffer,
            index_buffer,
        ) = renderer;
        let runs = shading_runs(SurfaceShading::of_triangles(scene));
        let (opaque_runs, glass_runs) = split_runs(runs.clone(), &transmissive_triangles(scene));
        Ok(Renderer {
            plain_pipeline,
            pipeline,
            masked_pipeline,
            runs,
            opaque_runs,
            glass_runs,
            bind_group,
            uniforms,
            vertices: vertex_buffer,
            indices: index_buffer,
            index_count: mesh.indices.len() as u32,
            textures,
            formats,
            near: near_plane(scene),
        })
    }

    /// The runs of transmissive triangles, which the scene pass leaves out.
    pub(crate) fn glass_runs(&self) -> &[ShadingRun] {
        &self.glass_runs
    }

    /// Draws the opaque triangles into `pass` with the pipeline and buffers it has set: the
    /// whole index buffer in one draw where the scene has no glass, else each opaque run (the
    /// glass follows in passes of its own).
    pub(crate) fn draw_opaque(&self, pass: &mut wgpu::RenderPass<'_>) {
        if self.glass_runs.is_empty() {
            pass.draw_indexed(0..self.index_count(), 0, 0..1);
        } else {
            for run in &self.opaque_runs {
                pass.draw_indexed(run.indices.clone(), 0, 0..1);
            }
        }
    }

    /// The formats the pipeline renders to.
    pub fn formats(&self) -> TargetFormats {
        self.formats
    }

    /// The frame uniform buffer (written by [`Renderer::prepare`]).
    pub(crate) fn frame_uniform_buffer(&self) -> &wgpu::Buffer {
        &self.uniforms
    }

    /// The radiosity textures.
    pub(crate) fn textures(&self) -> &RadiosityTextures {
        &self.textures
    }

    /// The scene's vertex buffer ([`Vertex`]).
    pub(crate) fn vertex_buffer(&self) -> &wgpu::Buffer {
        &self.vertices
    }

    /// The scene's index buffer (`u32`, three per triangle in scene order).
    pub(crate) fn index_buffer(&self) -> &wgpu::Buffer {
        &self.indices
    }

    /// Indices in [`Renderer::index_buffer`].
    pub(crate) fn index_count(&self) -> u32 {
        self.index_count
    }

    /// Whether any triangle needs the surface textures (a textured or alpha-masked
    /// material): the [`SURFACE_TEXTURES`] value of the other passes' pipelines that draw the
    /// scene's triangles with view.wgsl's `surface_d` and `cut_out`.
    pub(crate) fn surface_textures(&self) -> bool {
        self.runs.iter().any(|r| r.shading != SurfaceShading::Plain)
    }

    /// The uniforms for `camera` on a `width` × `height` target.
    pub fn uniforms(&self, camera: &Camera, width: u32, height: u32) -> FrameUniforms {
        let aspect = width.max(1) as f32 / height.max(1) as f32;
        FrameUniforms {
            view_proj: view_projection(camera, aspect, self.near).to_cols_array_2d(),
            atlas_size: self.textures.layer_size.map(|v| v as f32),
            // Radiance as baked, linear: the display pass applies exposure and encodes.
            exposure: 1.0,
            encode_srgb: 0,
            eye: camera.position.extend(1.0).to_array(),
        }
    }

    /// Writes the uniforms of `camera` (the write lands before the next submission).
    pub fn prepare(&self, gpu: &Gpu, camera: &Camera, width: u32, height: u32) {
        let u = self.uniforms(camera, width, height);
        gpu.queue
            .write_buffer(&self.uniforms, 0, bytemuck::bytes_of(&u));
    }

    /// Records the scene's render pass: clears colour to black and depth to 0 (reverse Z),
    /// draws every triangle, each [`ShadingRun`] with its pipeline.
    pub fn draw(
        &self,
        encoder: &mut wgpu::CommandEncoder,
        color: &wgpu::TextureView,
        depth: &wgpu::TextureView,
        timestamps: Option<wgpu::RenderPassTimestampWrites<'_>>,
    ) {
        let mut pass = clear_pass(
            encoder,
            "glint scene pass",
            &[Some(color)],
            wgpu::Color::BLACK,
            // Depth kept: the reflection composite (`view::reflections`) depth-tests against it.
            Some((depth, true)),
            timestamps,
        );
        pass.set_bind_group(0, &self.bind_group, &[]);
        pass.set_vertex_buffer(0, self.vertices.slice(..));
        pass.set_index_buffer(self.indices.slice(..), wgpu::IndexFormat::Uint32);
        for run in &self.opaque_runs {
            pass.set_pipeline(match run.shading {
                SurfaceShading::Plain => &self.plain_pipeline,
                SurfaceShading::Textured => &self.pipeline,
                SurfaceShading::Masked => &self.masked_pipeline,
            });
            pass.draw_indexed(run.indices.clone(), 0, 0..1);
        }
    }
}

/// How a shader is told `material`'s sides (`ProbeParams::info.y`, `GlassRecord::sides.x`):
/// 1 double-sided, 0 single-sided, whose back seen from behind is black, as the radiosity
/// solver and the path tracer have it (a glass jar's far panes seen through it).
pub fn sides(material: &crate::scene::material::Material) -> f32 {
    if material.double_sided { 1.0 } else { 0.0 }
}

#[cfg(test)]
mod tests {
    use glam::{Vec2, Vec3};

    use super::*;

    #[test]
    fn frame_uniforms_match_the_wgsl_struct() {
        crate::assert_wgsl_layout!(
            SHADER_SOURCE,
            "FrameUniforms",
            FrameUniforms {
                view_proj,
                atlas_size,
                exposure,
                encode_srgb,
                eye
            }
        );
    }

    #[test]
    fn vertex_layout_matches_the_wgsl_input() {
        crate::view::gpu::wgsl_layout::assert_vertex_layout(
            &scene_vertex_layout(),
            std::mem::size_of::<Vertex>(),
            &[
                std::mem::offset_of!(Vertex, position),
                std::mem::offset_of!(Vertex, lightmap),
                std::mem::offset_of!(Vertex, page),
                std::mem::offset_of!(Vertex, uv0),
                std::mem::offset_of!(Vertex, uv1),
                std::mem::offset_of!(Vertex, material),
                std::mem::offset_of!(Vertex, face),
                std::mem::offset_of!(Vertex, lightmap_back),
                std::mem::offset_of!(Vertex, page_back),
            ],
            SHADER_SOURCE,
            "VertexIn",
        );
    }

    #[test]
    fn shading_runs_cover_every_triangle_in_order() {
        use SurfaceShading::{Masked, Plain, Textured};
        assert_eq!(shading_runs([]), vec![]);
        let run = |indices: Range<u32>, shading| ShadingRun { indices, shading };
        assert_eq!(shading_runs([Plain; 4]), vec![run(0..12, Plain)]);
        assert_eq!(shading_runs([Masked]), vec![run(0..3, Masked)]);
        assert_eq!(
            shading_runs([Plain, Plain, Masked, Masked, Masked, Textured]),
            vec![run(0..6, Plain), run(6..15, Masked), run(15..18, Textured)]
        );
        assert_eq!(
            shading_runs([Textured, Plain, Textured]),
            vec![run(0..3, Textured), run(3..6, Plain), run(6..9, Textured)]
        );
    }

    #[test]
    fn split_runs_separates_glass_triangles_in_order() {
        use SurfaceShading::{Plain, Textured};
        let run = |indices: Range<u32>, shading| ShadingRun { indices, shading };
        let runs = vec![run(0..12, Plain), run(12..18, Textured)];
        let glass = [false, true, true, false, true, false];
        let (opaque, clear) = split_runs(runs.clone(), &glass);
        assert_eq!(
            opaque,
            vec![run(0..3, Plain), run(9..12, Plain), run(15..18, Textured)]
        );
        assert_eq!(clear, vec![run(3..9, Plain), run(12..15, Textured)]);
        let (all, none) = split_runs(runs.clone(), &[false; 6]);
        assert_eq!((all, none), (runs, vec![]));
    }

    #[test]
    fn a_material_is_plain_without_base_texture_or_cut_outs() {
        use crate::scene::material::{AlphaMode, TextureRef, Transmission};
        let plain = Material {
            name: "plain".into(),
            albedo: Vec3::splat(0.5),
            emission: Vec3::ZERO,
            lobes: Vec::new(),
            base_texture: None,
            emissive_texture: None,
            alpha_factor: 1.0,
            alpha_mode: AlphaMode::Opaque,
            double_sided: false,
            transmission: Transmission::NONE,
        };
        let texture = TextureRef {
            image: 0,
            sampler: Default::default(),
            tex_coord: 0,
            transform: Default::default(),
        };
        let textured = Material {
            base_texture: Some(texture),
            ..plain.clone()
        };
        // An emissive texture alone is not read: without a base colour texture the texels
        // hold D itself, emission included (`surface_textures::material_records`).
        let emissive_only = Material {
            emissive_texture: Some(texture),
            emission: Vec3::ONE,
            ..plain.clone()
        };
        // A cut-out needs the textures even without a base colour texture (the alpha factor
        // alone can cut).
        let masked = Material {
            alpha_mode: AlphaMode::Mask { cutoff: 0.5 },
            alpha_factor: 0.25,
            ..plain.clone()
        };
        assert_eq!(SurfaceShading::of(&plain), SurfaceShading::Plain);
        assert_eq!(SurfaceShading::of(&emissive_only), SurfaceShading::Plain);
        assert_eq!(SurfaceShading::of(&textured), SurfaceShading::Textured);
        assert_eq!(SurfaceShading::of(&masked), SurfaceShading::Masked);
        let masked_textured = Material {
            alpha_mode: AlphaMode::Mask { cutoff: 0.5 },
            ..textured
        };
        assert_eq!(SurfaceShading::of(&masked_textured), SurfaceShading::Masked);
    }

    #[test]
    fn projection_agrees_with_camera_rays() {
        let cam = Camera::look_at(
            Vec3::new(0.3, 1.2, 4.0),
            Vec3::new(-0.2, 0.9, 0.0),
            Vec3::Y,
            40f32.to_radians(),
        );
        let (w, h) = (720u32, 486u32);
        let m = view_projection(&cam, w as f32 / h as f32, 1e-3);
        for (x, y) in [(0, 0), (719, 485), (360, 100), (17, 400)] {
            let ndc = Camera::pixel_ndc(x, y, w, h);
            let p = cam.position + cam.ray_direction(ndc, w as f32 / h as f32) * 2.5;
            let clip = m * p.extend(1.0);
            let got = Vec2::new(clip.x / clip.w, clip.y / clip.w);
            assert!((got - ndc).length() < 1e-4, "{x},{y}: {got} vs {ndc}");
            let depth = clip.z / clip.w;
            assert!(depth > 0.0 && depth < 1.0, "reverse-Z depth {depth}");
        }
    }
}

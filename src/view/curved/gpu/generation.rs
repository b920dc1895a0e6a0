//! Generating the live cube maps (Nielsen & Christensen 2002 §3.2, McReynolds'
//! interreflection scheme): per generation and reflector, the scene without it and the other
//! curved reflectors' mirror terms from the previous generation's maps into each face, and
//! the planar near-mirrors' mirror terms from its own previous map, then the scene's thin
//! glass over all of it (the frame's glass passes), then the faces' MIP levels (2×2 box).
//! The scene's area lights are drawn over the scene behind them: a reflected ray collects
//! them on its way, as the path tracer's do.

use glam::Vec3;

use super::super::{CurvedParams, generation_plan};
use super::layout::{CurvedVertex, curved_group};
use super::{CubeTexture, CurvedReflections, MIN_BUFFER};
use crate::scene::AreaLight;
use crate::view::gpu::Gpu;
use crate::view::gpu::build::{bind_group_layout, buffer_init, render_pipeline};
use crate::view::gpu::target::clear_pass;
use crate::view::gpu::target::{ADDITIVE_KEEP_ALPHA, HDR_FORMAT, reverse_z_depth};
use crate::view::passes::glass::GlassPasses;
use crate::view::passes::renderer::{Renderer, SURFACE_TEXTURES, scene_vertex_layout};

impl CurvedReflections {
    /// Records every generation: per generation (written set `w`, read set `r`, never equal)
    /// and reflector i, each face of `maps[w][i]` gets the scene without reflector i (D) and
    /// every other curved reflector's mirror term from `maps[r]`; then its MIP levels.
    pub(super) fn record_generations(
        &self,
        gpu: &Gpu,
        pipes: &GenerationPipelines,
        renderer: &Renderer,
        encoder: &mut wgpu::CommandEncoder,
    ) {
        let device = &gpu.device;
        let scene_vertices = renderer.vertex_buffer();
        // Interreflection parameters per ordered pair (i sees j): j's lobes seen from i's centre.
        let mut pair_params: Vec<Vec<Option<wgpu::Buffer>>> = Vec::new();
        for (i, ri) in self.reflectors.iter().enumerate() {
            let row = self
                .reflectors
                .iter()
                .enumerate()
                .map(|(j, rj)| {
                    (i != j).then(|| {
                        let mut p = rj.base_params;
                        p.eye = ri.reflector.centre.extend(0.0).to_array();
                        p.info[1] = 0; // mirror lookups
                        buffer_init(
                            gpu,
                            "glint interreflection params",
                            wgpu::BufferUsages::UNIFORM,
                            bytemuck::bytes_of(&p),
                            MIN_BUFFER,
                        )
                    })
                })
                .collect();
            pair_params.push(row);
        }
        // Per reflector i and near-mirror k: k's lobes seen from i's centre, its rays looked up
        // in i's own map (distance-corrected from the mirror's point, its own triangles hit
        // first), so the mirror shows the room i's previous generation saw.
        let mirror_params: Vec<Vec<wgpu::Buffer>> = self
            .reflectors
            .iter()
            .enumerate()
            .map(|(i, ri)| {
                self.mirrors
                    .iter()
                    .map(|m| {
                        let mut p = CurvedParams::new(
                            &m.reflector,
                            None,
                            ri.reflector.centre,
                            self.maps[0][i].size,
                        );
                        p.centre = ri.base_params.centre;
                        p.info[3] = ri.base_params.info[3];
                        buffer_init(
                            gpu,
                            "glint mirror-in-cube params",
                            wgpu::BufferUsages::UNIFORM,
                            bytemuck::bytes_of(&p),
                            MIN_BUFFER,
                        )
                    })
                    .collect()
            })
            .collect();
        for (g, step) in generation_plan(self.settings.generations)
            .into_iter()
            .enumerate()
        {
            assert_ne!(step.write, step.read, "a cube map never reads its own set");
            for (i, ri) in self.reflectors.iter().enumerate() {
                // A reflector without lobes adds nothing where it is drawn, so nothing reads
                // its map: none is rendered (the terminal set's rough planar reflectors).
                if ri.reflector.lobes.is_empty() {
                    continue;
                }
                let target = &self.maps[step.write][i];
                let groups: Vec<Option<wgpu::BindGroup>> = self
                    .reflectors
                    .iter()
                    .enumerate()
                    .map(|(j, rj)| {
                        pair_params[i][j].as_ref().map(|params| {
                            curved_group(
                                device,
                                &self.curved_layout,
                                params,
                                &rj.patterns,
                                &self.maps[step.read][j].cube,
                                &self.sampler,
                                &self.maps[step.read][j].cube,
                                (&rj.own_nodes, &rj.own_tris),
                            )
                        })
                    })
                    .collect();
                // The first generation reads the cleared set: a mirror would add nothing.
                let mirror_groups: Vec<wgpu::BindGroup> = if g == 0 {
                    Vec::new()
                } else {
                    mirror_params[i]
                        .iter()
                        .map(|params| {
                            curved_group(
                                device,
                                &self.curved_layout,
                                params,
                                &ri.patterns,
                                &self.maps[step.read][i].cube,
                                &self.sampler,
                                &self.maps[step.read][i].cube,
                                (&ri.own_nodes, &ri.own_tris),
                            )
                        })
                        .collect()
                };
                for face in 0..6 {
                    let mut pass = clear_pass(
                        encoder,
                        "glint cube face pass",
                        &[Some(&target.faces[0][face])],
                        // Alpha 0: no distance where nothing is drawn (`curved_lookup`).
                        wgpu::Color::TRANSPARENT,
                        Some((&pipes.depth_view, false)),
                        None,
                    );
                    pass.set_pipeline(&pipes.env);
                    pass.set_bind_group(0, &ri.face_groups[face], &[]);
                    pass.set_vertex_buffer(0, scene_vertices.slice(..));
                    pass.set_index_buffer(ri.others.slice(..), wgpu::IndexFormat::Uint32);
                    pass.draw_indexed(0..ri.others_count, 0, 0..1);
                    if let Some(lights) = &pipes.lights {
                        pass.set_pipeline(&lights.pipeline);
                        pass.set_vertex_buffer(0, lights.vertices.slice(..));
                        pass.draw(0..lights.count, 0..1);
                    }
                    pass.set_pipeline(&pipes.interreflect);
                    for (j, rj) in self.reflectors.iter().enumerate() {
                        if rj.reflector.lobes.is_empty() {
                            continue;
                        }
                        if let Some(group) = &groups[j] {
                            pass.set_bind_group(1, group, &[]);
                            pass.set_vertex_buffer(0, rj.vertices.slice(..));
                            pass.draw(0..rj.vertex_count, 0..1);
                        }
                    }
                    for (m, group) in self.mirrors.iter().zip(&mirror_groups) {
                        pass.set_bind_group(1, group, &[]);
                        pass.set_vertex_buffer(0, m.vertices.slice(..));
                        pass.draw(0..m.vertex_count, 0..1);
                    }
                    if let Some(glass) = &pipes.glass {
                        glass.record(&mut pass, renderer, &ri.face_groups[face]);
                    }
                }
                pipes.record_mips(device, target, encoder);
            }
        }
    }
}

/// One vertex of an area light's quad in the cube faces (`LightVertexIn` in the shader).
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, bytemuck::Pod, bytemuck::Zeroable)]
pub(super) struct LightVertex {
    position: [f32; 3],
    /// The emitting side; zero where the light emits from both.
    normal: [f32; 3],
    radiance: [f32; 3],
}

const LIGHT_ATTRIBUTES: [wgpu::VertexAttribute; 3] =
    wgpu::vertex_attr_array![0 => Float32x3, 1 => Float32x3, 2 => Float32x3];

/// The scene's area lights as the cube faces draw them, two triangles each.
pub(super) fn light_vertices(lights: &[AreaLight]) -> Vec<LightVertex> {
    lights
        .iter()
        .flat_map(|l| {
            let normal = if l.two_sided { Vec3::ZERO } else { l.normal };
            let [a, b, c, d] = [
                l.corner,
                l.corner + l.edge_u,
                l.corner + l.edge_u + l.edge_v,
                l.corner + l.edge_v,
            ];
            [a, b, c, a, c, d].map(|p| LightVertex {
                position: p.to_array(),
                normal: normal.to_array(),
                radiance: l.radiance.to_array(),
            })
        })
        .collect()
}

/// The area lights' draw into each face (`fs_env_light`).
pub(super) struct LightDraw {
    pipeline: wgpu::RenderPipeline,
    vertices: wgpu::Buffer,
    count: u32,
}

/// The pipelines and scratch targets that render the cube maps.
pub(super) struct GenerationPipelines {
    env: wgpu::RenderPipeline,
    interreflect: wgpu::RenderPipeline,
    downsample: wgpu::RenderPipeline,
    mip_layout: wgpu::BindGroupLayout,
    depth_view: wgpu::TextureView,
    _depth: wgpu::Texture,
    /// The scene's thin glass, drawn into each face over what lies behind it (`None`: no
    /// glass; `others` then holds every triangle).
    pub(super) glass: Option<GlassPasses>,
    /// The scene's area lights (`None`: it has none).
    lights: Option<LightDraw>,
}

impl GenerationPipelines {
    pub(super) fn new(
        device: &wgpu::Device,
        shader: &wgpu::ShaderModule,
        frame_layout: &wgpu::BindGroupLayout,
        curved_layout: &wgpu::BindGroupLayout,
        face_size: u32,
        surface_textures: bool,
        gpu: &Gpu,
    ) -> GenerationPipelines {
        let additive = Some(ADDITIVE_KEEP_ALPHA);
        let scene = render_pipeline("glint cube env", shader, "vs_world", "fs_env")
            .layouts(&[frame_layout])
            .vertex(scene_vertex_layout())
            .color(HDR_FORMAT, None)
            .depth(reverse_z_depth(true, wgpu::CompareFunction::Greater))
            .override_bool(SURFACE_TEXTURES, surface_textures)
            .build(device);
        let interreflect = render_pipeline(
            "glint cube interreflection",
            shader,
            "vs_curved",
            "fs_curved_env",
        )
        .layouts(&[frame_layout, curved_layout])
        .vertex(CurvedVertex::layout())
        .color(HDR_FORMAT, additive)
        .override_bool(SURFACE_TEXTURES, surface_textures)
        .depth(reverse_z_depth(false, wgpu::CompareFunction::GreaterEqual))
        .build(device);
        let mip_layout = bind_group_layout()
            .texture(
                8,
                wgpu::ShaderStages::FRAGMENT,
                wgpu::TextureViewDimension::D2,
                false,
            )
            .build(device, "glint mip layout");
        let empty = bind_group_layout().build(device, "glint empty layout");
        let downsample = render_pipeline(
            "glint cube downsample",
            shader,
            "vs_fullscreen",
            "fs_downsample",
        )
        .layouts(&[&empty, &mip_layout])
        .color(HDR_FORMAT, None)
        .build(device);
        let depth = crate::view::gpu::target::depth_texture(gpu, face_size, face_size);
        let depth_view = depth.create_view(&wgpu::TextureViewDescriptor::default());
        GenerationPipelines {
            env: scene,
            interreflect,
            downsample,
            mip_layout,
            depth_view,
            _depth: depth,
            glass: None,
            lights: None,
        }
    }

    /// Draws `lights` into every face from now on, over the scene behind them.
    pub(super) fn set_lights(
        &mut self,
        gpu: &Gpu,
        shader: &wgpu::ShaderModule,
        frame_layout: &wgpu::BindGroupLayout,
        lights: &[AreaLight],
    ) {
        if lights.is_empty() {
            self.lights = None;
            return;
        }
        let vertices = light_vertices(lights);
        let layout = wgpu::VertexBufferLayout {
            array_stride: std::mem::size_of::<LightVertex>() as u64,
            step_mode: wgpu::VertexStepMode::Vertex,
            attributes: &LIGHT_ATTRIBUTES,
        };
        let pipeline = render_pipeline("glint cube lights", shader, "vs_env_light", "fs_env_light")
            .layouts(&[frame_layout])
            .vertex(layout)
            .color(HDR_FORMAT, Some(ADDITIVE_KEEP_ALPHA))
            .depth(reverse_z_depth(false, wgpu::CompareFunction::GreaterEqual))
            .build(&gpu.device);
        self.lights = Some(LightDraw {
            pipeline,
            vertices: buffer_init(
                gpu,
                "glint cube light vertices",
                wgpu::BufferUsages::VERTEX,
                bytemuck::cast_slice(&vertices),
                MIN_BUFFER,
            ),
            count: vertices.len() as u32,
        });
    }

    /// Levels 1 … of `target` from level 0, face by face (2×2 box).
    fn record_mips(
        &self,
        device: &wgpu::Device,
        target: &CubeTexture,
        encoder: &mut wgpu::CommandEncoder,
    ) {
        for level in 1..target.faces.len() {
            for face in 0..6 {
                let group = device.create_bind_group(&wgpu::BindGroupDescriptor {
                    label: Some("glint mip source"),
                    layout: &self.mip_layout,
                    entries: &[wgpu::BindGroupEntry {
                        binding: 8,
                        resource: wgpu::BindingResource::TextureView(
                            &target.faces[level - 1][face],
                        ),
                    }],
                });
                let mut pass = clear_pass(
                    encoder,
                    "glint cube mip pass",
                    &[Some(&target.faces[level][face])],
                    wgpu::Color::BLACK,
                    None,
                    None,
                );
                pass.set_pipeline(&self.downsample);
                pass.set_bind_group(1, &group, &[]);
                pass.draw(0..3, 0..1);
            }
        }
    }
}

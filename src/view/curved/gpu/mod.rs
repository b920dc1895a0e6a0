//! The GPU half of curved reflectors (see [`super`] for the equations): the composite pass
//! that shades the reflectors' pixels, in the frame and inside planar mirrors' passes.
//!
//! - `layout`: the reflector vertex format and the curved shader's bind group 1;
//! - `cube`: cube textures with every MIP level, and baked pyramids uploaded as cubes;
//! - `baked`: the materials stage's baked MIP pyramids and ξ₀;
//! - each reflector's own triangles with their BVH ([`super::own_mesh`]), which reflected
//!   rays are cast at first (self-reflection);
//! - `generation`: the live cube maps, generated once, double-buffered across generations;
//! - `probe`: compute probes of the shader, for tests.

mod baked;
mod cube;
mod generation;
mod layout;
mod probe;

use std::sync::Mutex;

use glam::Vec4;

use baked::baked_xi0;
pub use baked::load_baked_pyramid;
pub use cube::CubeTexture;
use generation::GenerationPipelines;
pub use layout::{CurvedVertex, reflector_vertices};
use layout::{curved_group, curved_layout, trilinear_sampler};
pub use probe::glossy_probe;

use super::own_mesh::{self, OWN_STACK, OwnMesh};
use super::{
    CurvedParams, CurvedReflector, CurvedSettings, bounding_radius, curved_reflectors, face_camera,
    generation_plan, near_mirrors, own_offset, pack_patterns, patterns_for, shader_source,
};
use crate::camera::Camera;
use crate::view::gpu::RenderError;
use crate::view::gpu::build::{buffer_init, render_pipeline, shader};
use crate::view::gpu::target::{ADDITIVE_KEEP_ALPHA, HDR_FORMAT, reverse_z_depth};
use crate::view::gpu::{Gpu, GpuError, error_scoped};
use crate::view::load::ViewData;
use crate::view::passes::composite::Composite;
use crate::view::passes::glass::GlassPasses;
use crate::view::passes::renderer::{
    Renderer, SURFACE_TEXTURES, SceneMesh, frame_bind_group, frame_bind_group_layout,
    transmissive_triangles, uniform_buffer,
};

/// Smallest buffer the curved passes make (a pattern buffer may be empty).
const MIN_BUFFER: u64 = 16;

/// Smallest own-mesh buffer: one record of the larger kind (a binding must hold one element
/// of its array, and with self-reflection off they are stand-ins).
const OWN_MIN_BUFFER: u64 = std::mem::size_of::<own_mesh::OwnTri>() as u64;

/// Where a reflector's glossy term reads its environment.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum EnvSource {
    /// The live cube map (rendered by the viewer, with interreflections).
    Live,
    /// The materials stage's baked MIP pyramid.
    Baked,
}

struct ReflectorGpu {
    reflector: CurvedReflector,
    vertices: wgpu::Buffer,
    vertex_count: u32,
    /// The scene without this reflector (its cube map's draw), and without the glass,
    /// which each face gets after it.
    others: wgpu::Buffer,
    others_count: u32,
    /// Its own triangles' BVH nodes and records (`own_closest`; stand-ins when off).
    own_nodes: wgpu::Buffer,
    own_tris: wgpu::Buffer,
    /// Frame uniforms of its six face cameras.
    face_groups: Vec<wgpu::BindGroup>,
    _face_uniforms: Vec<wgpu::Buffer>,
    params: wgpu::Buffer,
    base_params: CurvedParams,
    composite_group: wgpu::BindGroup,
    source: EnvSource,
    _baked: Option<CubeTexture>,
    patterns: wgpu::Buffer,
}

/// A planar near-mirror as the cube maps draw it ([`super::near_mirrors`]).
struct SeenMirror {
    reflector: CurvedReflector,
    vertices: wgpu::Buffer,
    vertex_count: u32,
}

/// One mirrored view of the curved reflectors (a planar mirror's pass): its frame uniforms
/// and, per reflector, its parameters (mirrored eye, the mirror's clip plane).
struct MirrorView {
    uniforms: wgpu::Buffer,
    frame_group: wgpu::BindGroup,
    /// Per reflector: parameters and the composite group reading them.
    reflectors: Vec<(wgpu::Buffer, wgpu::BindGroup)>,
}

/// A view mirrored about a planar reflector, as its map sees the scene.
#[derive(Clone, Copy)]
pub struct MirroredView<'a> {
    /// The camera mirrored about the reflector: the map's frame uniforms and the eye of every
    /// curved reflector's term.
    pub camera: &'a Camera,
    /// The map's width in pixels.
    pub width: u32,
    /// The map's height in pixels.
    pub height: u32,
    /// The reflector's plane (normal xyz, w = normal · point + clip distance): fragments
    /// behind it are discarded.
    pub clip: Vec4,
    /// Whether the map is drawn at more than one texel a frame pixel and box-filtered
    /// (`reflections::downsample`): its supersampling then stands in for the curved
    /// reflectors' specular AA, which would widen their lobes for a footprint the filter
    /// already averages (and darken their highlights by it).
    pub supersampled: bool,
}

/// `CurvedParams::info[3]`'s bit that turns the specular AA on (`curved.wgsl`'s
/// `kernel2`); bit 0 is the parallax correction.
const SPECULAR_AA_BIT: u32 = 2;

/// The curved-reflector passes of one [`Renderer`]: cube maps made at construction, the
/// composite recorded per frame ([`CurvedReflections::prepare`], [`CurvedReflections::draw`])
/// and inside planar mirrors' passes ([`CurvedReflections::prepare_mirror`],
/// [`CurvedReflections::draw_mirror`]).
pub struct CurvedReflections {
    settings: CurvedSettings,
    reflectors: Vec<ReflectorGpu>,
    /// The near-mirrors that are not among `reflectors`, drawn into their cube maps.
    mirrors: Vec<SeenMirror>,
    /// `maps[set][reflector]`.
    maps: [Vec<CubeTexture>; 2],
    final_set: usize,
    composite: Composite,
    /// The composite inside a planar mirror's pass (`fs_curved_mirror`, the HDR map M).
    mirror_pipeline: wgpu::RenderPipeline,
    /// Mirrored views, by the slot the planar passes give them (grown as needed).
    mirror_views: Mutex<Vec<MirrorView>>,
    frame_layout: wgpu::BindGroupLayout,
    curved_layout: wgpu::BindGroupLayout,
    sampler: wgpu::Sampler,
    /// Seconds the cube maps took (all generations, submit to complete).
    pub generation_seconds: f64,
}

impl CurvedReflections {
    /// The passes for `renderer` drawing `data`, with every generation of cube maps rendered
    /// (this blocks until the GPU has finished them).
    pub fn new(
        gpu: &Gpu,
        renderer: &Renderer,
        data: &ViewData,
        settings: CurvedSettings,
    ) -> Result<CurvedReflections, RenderError> {
        Self::with_reflectors(
            gpu,
            renderer,
            data,
            settings,
            curved_reflectors(&data.scene),
        )
    }

    /// [`CurvedReflections::new`] for the given reflectors (any triangles with a centre and
    /// lobes: geometry mode also cube-maps planar reflectors at the recursion's end,
    /// [`crate::view::reflections::terminal`]).
    pub fn with_reflectors(
        gpu: &Gpu,
        renderer: &Renderer,
        data: &ViewData,
        settings: CurvedSettings,
        reflectors: Vec<CurvedReflector>,
    ) -> Result<CurvedReflections, RenderError> {
        let mut baked = Vec::new();
        for r in &reflectors {
            let pyramid = if settings.glossy_samples > 0 {
                load_baked_pyramid(data, &r.name).map_err(RenderError::Reflections)?
            } else {
                None
            };
            baked.push(match pyramid {
                Some(p) => Some(CubeTexture::from_pyramid(gpu, &p)?),
                None => None,
            });
        }
        let face_size = settings
            .face_size
            .clamp(1, gpu.device.limits().max_texture_dimension_2d);
        let glass = GlassPasses::for_target(gpu, &data.scene, renderer, HDR_FORMAT, 1)?;
        let built = Self::build(
            gpu, renderer, data, settings, face_size, reflectors, baked, glass,
        )?;
        let start = std::time::Instant::now();
        let submission = error_scoped(&gpu.device, "rendering the cube maps", || {
            let mut encoder = gpu
                .device
                .create_command_encoder(&wgpu::CommandEncoderDescriptor {
                    label: Some("glint cube maps"),
                });
            built
                .0
                .record_generations(gpu, &built.1, renderer, &mut encoder);
            gpu.queue.submit([encoder.finish()])
        })?;
        gpu.device
            .poll(wgpu::PollType::Wait {
                submission_index: Some(submission),
                timeout: None,
            })
            .map_err(GpuError::from)?;
        let mut passes = built.0;
        passes.generation_seconds = start.elapsed().as_secs_f64();
        Ok(passes)
    }

    #[allow(clippy::too_many_arguments)]
    fn build(
        gpu: &Gpu,
        renderer: &Renderer,
        data: &ViewData,
        settings: CurvedSettings,
        face_size: u32,
        reflectors: Vec<CurvedReflector>,
        baked: Vec<Option<CubeTexture>>,
        glass_passes: Option<GlassPasses>,
    ) -> Result<(CurvedReflections, GenerationPipelines), GpuError> {
        let device = &gpu.device;
        let scene = &data.scene;
        let mesh = SceneMesh::new(scene, &data.map.atlas);
        let xi0 = baked_xi0(data);
        let textures = renderer.surface_textures();
        error_scoped(device, "creating the curved-reflector passes", || {
            let shader = shader(device, "glint curved shader", &shader_source());
            let frame_layout = frame_bind_group_layout(device);
            let curved_layout = curved_layout(device);
            let sampler = trilinear_sampler(device);
            let levels = CubeTexture::full_chain(face_size);
            let maps = [0, 1].map(|_| {
                reflectors
                    .iter()
                    .map(|_| CubeTexture::new(gpu, face_size, levels, "glint live cube map"))
                    .collect::<Vec<_>>()
            });
            let plan = generation_plan(settings.generations);
            let final_set = plan.last().expect("at least one generation").write;
            let composite = Composite::new(
                device,
                renderer,
                &frame_layout,
                render_pipeline("glint curved composite", &shader, "vs_curved", "fs_curved")
                    .layouts(&[&frame_layout, &curved_layout])
                    .vertex(CurvedVertex::layout())
                    .override_bool(SURFACE_TEXTURES, textures),
            );
            // Inside a mirror pass: one linear HDR target (M), depth tested, not written; the
            // specular term added, M's alpha (the beyond fraction K's scale reads) replaced by
            // the unfolded path's (`fs_curved_mirror`).
            let mirror_pipeline = render_pipeline(
                "glint curved composite in a mirror",
                &shader,
                "vs_curved",
                "fs_curved_mirror",
            )
            .layouts(&[&frame_layout, &curved_layout])
            .vertex(CurvedVertex::layout())
            .color(
                HDR_FORMAT,
                Some(wgpu::BlendState {
                    color: ADDITIVE_KEEP_ALPHA.color,
                    alpha: wgpu::BlendComponent::REPLACE,
                }),
            )
            .depth(reverse_z_depth(false, wgpu::CompareFunction::GreaterEqual))
            .override_bool(SURFACE_TEXTURES, textures)
            .build(device);
            let mut generation = GenerationPipelines::new(
                device,
                &shader,
                &frame_layout,
                &curved_layout,
                face_size,
                textures,
                gpu,
            );
            // Thin glass is drawn into each face after the opaque scene, as the frame draws it.
            let glass = match glass_passes {
                Some(_) => transmissive_triangles(scene),
                None => vec![false; scene.triangles.len()],
            };
            generation.glass = glass_passes;
            generation.set_lights(gpu, &shader, &frame_layout, &scene.lights);
            let in_reflector = {
                let mut v = vec![usize::MAX; scene.triangles.len()];
                for (i, r) in reflectors.iter().enumerate() {
                    for &t in &r.triangles {
                        v[t as usize] = i;
                    }
                }
                v
            };
            let mirrors = near_mirrors(scene)
                .into_iter()
                .filter(|m| {
                    m.triangles
                        .iter()
                        .all(|&t| in_reflector[t as usize] == usize::MAX)
                })
                .map(|reflector| {
                    let verts = reflector_vertices(scene, &reflector.triangles);
                    SeenMirror {
                        vertices: buffer_init(
                            gpu,
                            "glint mirror vertices",
                            wgpu::BufferUsages::VERTEX,
                            bytemuck::cast_slice(&verts),
                            MIN_BUFFER,
                        ),
                        vertex_count: verts.len() as u32,
                        reflector,
                    }
                })
                .collect();
            let gpus = reflectors
                .into_iter()
                .zip(baked)
                .enumerate()
                .map(|(i, (reflector, baked))| {
                    let verts = reflector_vertices(scene, &reflector.triangles);
                    let vertices = buffer_init(
                        gpu,
                        "glint curved vertices",
                        wgpu::BufferUsages::VERTEX,
                        bytemuck::cast_slice(&verts),
                        MIN_BUFFER,
                    );
                    let others = mesh.triangle_indices(
                        (0..scene.triangles.len()).filter(|&t| in_reflector[t] != i && !glass[t]),
                    );
                    let others_buffer = buffer_init(
                        gpu,
                        "glint cube map indices",
                        wgpu::BufferUsages::INDEX,
                        bytemuck::cast_slice(&others),
                        MIN_BUFFER,
                    );
                    let own_mesh = if settings.self_occlusion {
                        OwnMesh::build(scene, &data.map.atlas, &reflector.triangles)
                    } else {
                        OwnMesh::default()
                    };
                    let self_hits = settings.self_occlusion && own_mesh.traversable();
                    if settings.self_occlusion && !self_hits {
                        log::warn!(
                            "curved reflector {}: its BVH is {} levels deep, over the shader's {}: no self-reflection",
                            reflector.name,
                            own_mesh.depth,
                            OWN_STACK
                        );
                    }
                    let own_nodes = buffer_init(
                        gpu,
                        "glint own BVH nodes",
                        wgpu::BufferUsages::STORAGE,
                        bytemuck::cast_slice(&own_mesh.nodes),
                        OWN_MIN_BUFFER,
                    );
                    let own_tris = buffer_init(
                        gpu,
                        "glint own triangles",
                        wgpu::BufferUsages::STORAGE,
                        bytemuck::cast_slice(&own_mesh.tris),
                        OWN_MIN_BUFFER,
                    );
                    let mut face_uniforms = Vec::new();
                    let mut face_groups = Vec::new();
                    for face in 0..6 {
                        let mut u = renderer.uniforms(
                            &face_camera(reflector.centre, face),
                            face_size,
                            face_size,
                        );
                        u.exposure = 1.0; // the maps hold radiance; the frame applies exposure
                        u.encode_srgb = 0;
                        let b = uniform_buffer(device);
                        gpu.queue.write_buffer(&b, 0, bytemuck::bytes_of(&u));
                        face_groups.push(frame_bind_group(
                            device,
                            &frame_layout,
                            &b,
                            renderer.textures(),
                        ));
                        face_uniforms.push(b);
                    }
                    let regular = settings.glossy_samples > 0;
                    let patterns = if regular {
                        patterns_for(&reflector.lobes, settings.glossy_samples, xi0)
                    } else {
                        Vec::new()
                    };
                    let (packed, offsets) = pack_patterns(&patterns);
                    let pattern_buffer = buffer_init(
                        gpu,
                        "glint curved patterns",
                        wgpu::BufferUsages::STORAGE,
                        bytemuck::cast_slice(&packed),
                        MIN_BUFFER,
                    );
                    let (source, env_view, env_size) = match &baked {
                        Some(t) => (EnvSource::Baked, &t.cube, t.size),
                        None => (EnvSource::Live, &maps[final_set][i].cube, face_size),
                    };
                    let mut base_params = CurvedParams::new(
                        &reflector,
                        regular.then_some((patterns.as_slice(), offsets.as_slice())),
                        reflector.centre,
                        env_size,
                    );
                    base_params.info[3] = u32::from(settings.parallax)
                        | if settings.specular_aa { SPECULAR_AA_BIT } else { 0 };
                    if self_hits {
                        base_params.centre[3] = own_offset(bounding_radius(scene, &reflector));
                    }
                    let params = buffer_init(
                        gpu,
                        "glint curved params",
                        wgpu::BufferUsages::UNIFORM,
                        bytemuck::bytes_of(&base_params),
                        MIN_BUFFER,
                    );
                    let composite_group = curved_group(
                        device,
                        &curved_layout,
                        &params,
                        &pattern_buffer,
                        env_view,
                        &sampler,
                        &maps[final_set][i].cube,
                        (&own_nodes, &own_tris),
                    );
                    ReflectorGpu {
                        vertex_count: verts.len() as u32,
                        vertices,
                        others_count: others.len() as u32,
                        others: others_buffer,
                        own_nodes,
                        own_tris,
                        face_groups,
                        _face_uniforms: face_uniforms,
                        params,
                        base_params,
                        composite_group,
                        source,
                        _baked: baked,
                        patterns: pattern_buffer,
                        reflector,
                    }
                })
                .collect();
            (
                CurvedReflections {
                    settings,
                    reflectors: gpus,
                    mirrors,
                    maps,
                    final_set,
                    composite,
                    mirror_pipeline,
                    mirror_views: Mutex::new(Vec::new()),
                    frame_layout,
                    curved_layout,
                    sampler,
                    generation_seconds: 0.0,
                },
                generation,
            )
        })
    }

    /// The reflectors it draws, in order.
    pub fn reflectors(&self) -> impl Iterator<Item = &CurvedReflector> {
        self.reflectors.iter().map(|r| &r.reflector)
    }

    /// How many reflectors it draws.
    pub fn reflector_count(&self) -> usize {
        self.reflectors.len()
    }

    /// The settings it was built with.
    pub fn settings(&self) -> CurvedSettings {
        self.settings
    }

    /// Per reflector: its name and where its glossy term reads the environment.
    pub fn sources(&self) -> Vec<(String, EnvSource)> {
        self.reflectors
            .iter()
            .map(|r| (r.reflector.name.clone(), r.source))
            .collect()
    }

    /// Per reflector, the regular samples per lobe (empty with mirror lookups).
    pub fn pattern_samples(&self) -> Vec<Vec<u32>> {
        self.reflectors
            .iter()
            .map(|r| {
                let p = &r.base_params;
                if p.info[1] == 0 {
                    return Vec::new();
                }
                p.lobes[..p.info[0] as usize]
                    .iter()
                    .map(|l| l.samples[1])
                    .collect()
            })
            .collect()
    }

    /// Bytes of the live cube maps (both sets, every level).
    pub fn live_map_bytes(&self) -> u64 {
        let per_map: u64 = (0..CubeTexture::full_chain(self.settings.face_size))
            .map(|l| {
                let n = (self.settings.face_size >> l).max(1) as u64;
                6 * n * n * 8
            })
            .sum();
        2 * per_map * self.reflectors.len() as u64
    }

    /// Writes each reflector's parameters for `camera` (lands before the next submission).
    pub fn prepare(&self, gpu: &Gpu, camera: &Camera) {
        for r in &self.reflectors {
            let mut p = r.base_params;
            p.eye = camera.position.extend(0.0).to_array();
            gpu.queue.write_buffer(&r.params, 0, bytemuck::bytes_of(&p));
        }
    }

    /// Records, after the scene pass into `color`/`depth` (depth stored), the
    /// reflectors' specular term, depth-tested against the scene so only their visible pixels
    /// get it, added to kd·D.
    pub fn draw(
        &self,
        encoder: &mut wgpu::CommandEncoder,
        color: &wgpu::TextureView,
        depth: &wgpu::TextureView,
    ) {
        if self.reflectors.is_empty() {
            return;
        }
        let mut pass = self
            .composite
            .begin(encoder, "glint curved composite pass", color, depth);
        for r in &self.reflectors {
            pass.set_bind_group(1, &r.composite_group, &[]);
            pass.set_vertex_buffer(0, r.vertices.slice(..));
            pass.draw(0..r.vertex_count, 0..1);
        }
    }

    /// The environment reflector `index` reads (the baked pyramid, else the final live map).
    fn env_view(&self, index: usize) -> &wgpu::TextureView {
        match &self.reflectors[index]._baked {
            Some(t) => &t.cube,
            None => &self.maps[self.final_set][index].cube,
        }
    }

    fn new_mirror_view(&self, gpu: &Gpu, renderer: &Renderer) -> MirrorView {
        let device = &gpu.device;
        let uniforms = uniform_buffer(device);
        let frame_group =
            frame_bind_group(device, &self.frame_layout, &uniforms, renderer.textures());
        let reflectors = self
            .reflectors
            .iter()
            .enumerate()
            .map(|(i, r)| {
                let params = buffer_init(
                    gpu,
                    "glint curved params in a mirror",
                    wgpu::BufferUsages::UNIFORM,
                    bytemuck::bytes_of(&r.base_params),
                    MIN_BUFFER,
                );
                let group = curved_group(
                    device,
                    &self.curved_layout,
                    &params,
                    &r.patterns,
                    self.env_view(i),
                    &self.sampler,
                    &self.maps[self.final_set][i].cube,
                    (&r.own_nodes, &r.own_tris),
                );
                (params, group)
            })
            .collect();
        MirrorView {
            uniforms,
            frame_group,
            reflectors,
        }
    }

    /// Writes mirrored view `slot` (the planar passes number their mirror passes), `view`.
    /// The writes land before the next submission.
    pub fn prepare_mirror(&self, gpu: &Gpu, renderer: &Renderer, slot: usize, view: &MirroredView) {
        if self.reflectors.is_empty() {
            return;
        }
        let Ok(mut views) = self.mirror_views.lock() else {
            return;
        };
        while views.len() <= slot {
            let view = self.new_mirror_view(gpu, renderer);
            views.push(view);
        }
        let MirroredView {
            camera,
            width,
            height,
            clip,
            supersampled,
        } = *view;
        let view = &views[slot];
        let mut u = renderer.uniforms(camera, width, height);
        u.encode_srgb = 0; // M holds linear radiance
        gpu.queue
            .write_buffer(&view.uniforms, 0, bytemuck::bytes_of(&u));
        for (r, (params, _)) in self.reflectors.iter().zip(&view.reflectors) {
            let mut p = r.base_params;
            p.eye = camera.position.extend(0.0).to_array();
            p.clip = clip.to_array();
            if supersampled {
                p.info[3] &= !SPECULAR_AA_BIT;
            }
            gpu.queue.write_buffer(params, 0, bytemuck::bytes_of(&p));
        }
    }

    /// Records, inside a planar mirror's pass (its HDR map M bound as the only colour target,
    /// the mirrored scene's depth), the curved reflectors' specular term of mirrored view
    /// `slot` ([`CurvedReflections::prepare_mirror`]), added to their kd·D there.
    pub fn draw_mirror(&self, pass: &mut wgpu::RenderPass<'_>, slot: usize) {
        self.draw_mirror_where(pass, slot, |_| true);
    }

    /// [`CurvedReflections::draw_mirror`] for the reflectors whose index `keep` accepts.
    pub fn draw_mirror_where(
        &self,
        pass: &mut wgpu::RenderPass<'_>,
        slot: usize,
        keep: impl Fn(usize) -> bool,
    ) {
        let Ok(views) = self.mirror_views.lock() else {
            return;
        };
        let Some(view) = views.get(slot) else {
            return;
        };
        pass.set_pipeline(&self.mirror_pipeline);
        pass.set_bind_group(0, &view.frame_group, &[]);
        for (i, (r, (_, group))) in self.reflectors.iter().zip(&view.reflectors).enumerate() {
            // Without lobes nothing is added.
            if !keep(i) || r.reflector.lobes.is_empty() {
                continue;
            }
            pass.set_bind_group(1, group, &[]);
            pass.set_vertex_buffer(0, r.vertices.slice(..));
            pass.draw(0..r.vertex_count, 0..1);
        }
    }
}

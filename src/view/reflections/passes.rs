//! The reflection passes on the GPU (`shaders/reflect.wgsl`): the mirror pass (geometry
//! re-rendered, or radiance-map splats) into M, and the composite that adds ks·(M*K)·R over
//! the reflector. The math they use lives in [`super::splats`] and [`super::material`].
//!
//! One concept over 700 lines: the mirror, splat and composite passes share one per-reflector
//! GPU state (params, M, splat tables) built and recorded together.

use std::sync::Mutex;

use bytemuck::{Pod, Zeroable};
use glam::{Mat4, Vec3};

use super::material::{MAX_TAPS, MODULATION_SIZE, Modulation};
use super::splats::{self, MapImage, MapSplats, NodeParams, Splat};
use super::{
    CLIP_FRACTION, PlanarReflector, ReflectanceSettings, Source, mirror_camera, mirror_point,
    reflectors_with_materials, signed_distance,
};
use crate::camera::Camera;
use crate::materials::reflectance;
use crate::radiance::index::{MapEntry, load_cameras, read_map};
use crate::view::build::{LayoutBuilder, bind_group_layout, buffer, buffer_init, render_pipeline};
use crate::view::curved::gpu::CurvedReflections;
use crate::view::gpu::{Gpu, GpuError, error_scoped};
use crate::view::load::ViewData;
use crate::view::radiance_maps::select;
use crate::view::renderer::{
    ADDITIVE_KEEP_ALPHA, HDR_FORMAT, RenderError, Renderer, frame_bind_group,
    frame_bind_group_layout, reverse_z_depth, scene_vertex_layout, uniform_buffer,
};

/// The parent clip of a composite that clips nothing ([`ReflectParams::parent`]).
pub const NO_PARENT_CLIP: [f32; 4] = [0.0, 0.0, 0.0, -1.0];

/// Mirrors `ReflectParams` in `shaders/reflect.wgsl` (3200 bytes).
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, Pod, Zeroable)]
pub struct ReflectParams {
    /// Normal xyz, w = normal · point.
    pub plane: [f32; 4],
    /// ks rgb, a = clip distance.
    pub ks: [f32; 4],
    /// The eye xyz (written per frame), w = the 1D map's grazing bound C.
    pub eye: [f32; 4],
    /// The plane's tangent xyz; w: 1 to read R from the sphere map, 0 from the 1D table.
    pub tangent: [f32; 4],
    /// The plane's bitangent xyz; w: the sphere map's size in texels.
    pub bitangent: [f32; 4],
    /// x: screen pixels per kernel texel at beyond-fraction 1 (per frame); y: tap count.
    pub kernel: [f32; 4],
    /// The composite's clip: in a recursive map, the parent mirror's plane (normal xyz,
    /// w = normal · point + clip distance), fragments p with xyz · p ≤ w discarded;
    /// [`NO_PARENT_CLIP`] for a composite into the frame.
    pub parent: [f32; 4],
    /// ks·R at the 1D map's cosines (rgb; a unused).
    pub modulation: [[f32; 4]; MODULATION_SIZE],
    /// K's taps: offset in texels (x right, y up), weight.
    pub taps: [[f32; 4]; MAX_TAPS],
}

impl ReflectParams {
    /// The parameters of `reflector` with clip distance `clip`, seen from `eye` (kernel
    /// scale 0 until [`GeometryReflections::prepare`] sets it).
    pub fn new(reflector: &PlanarReflector, clip: f32, eye: Vec3) -> ReflectParams {
        let n = reflector.plane.normal;
        let mut modulation = [[0.0; 4]; MODULATION_SIZE];
        let mut sphere = (0.0, 0.0);
        match &reflector.modulation {
            Modulation::OneD(table) => {
                for (m, v) in modulation.iter_mut().zip(table) {
                    *m = v.extend(0.0).to_array();
                }
            }
            Modulation::Sphere { size, .. } => sphere = (1.0, *size as f32),
        }
        let mut taps = [[0.0; 4]; MAX_TAPS];
        for (t, k) in taps.iter_mut().zip(&reflector.kernel.taps) {
            *t = [k.offset.x, k.offset.y, k.weight, 0.0];
        }
        ReflectParams {
            plane: n.extend(n.dot(reflector.plane.point)).to_array(),
            ks: reflector.ks.extend(clip).to_array(),
            eye: eye.extend(reflectance::C_GRAZING).to_array(),
            tangent: reflector.tangent.extend(sphere.0).to_array(),
            bitangent: reflector.bitangent.extend(sphere.1).to_array(),
            kernel: [
                0.0,
                reflector.kernel.taps.len().min(MAX_TAPS) as f32,
                0.0,
                0.0,
            ],
            parent: NO_PARENT_CLIP,
            modulation,
            taps,
        }
    }
}

/// The full WGSL module of the reflection passes.
pub fn shader_source() -> String {
    format!(
        "{}\n{}",
        crate::view::renderer::SHADER_SOURCE,
        super::REFLECT_SHADER_SOURCE
    )
}

/// What the image-based mode drew for one reflector in the last prepared frame.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct FrameStats {
    /// Maps selected (all elements).
    pub maps: usize,
    /// Splats of the selected maps.
    pub selected_splats: u64,
    /// Splats drawn (after culling and minification skipping).
    pub drawn_splats: u64,
    /// Quadtree nodes culled.
    pub culled_nodes: usize,
    /// Draw calls.
    pub draws: usize,
}

/// A reflector's maps on the GPU: every map's splats in one instance buffer, in quadtree
/// order; the quadtrees stay on the CPU for per-frame culling and sizing.
struct SplatMaps {
    maps: Vec<MapEntry>,
    /// Per map: its quadtree and node ranges (splats dropped after upload), node base.
    trees: Vec<(MapSplats, u32)>,
    node_count: usize,
    instances: wgpu::Buffer,
    nodes: wgpu::Buffer,
    group: Option<wgpu::BindGroup>,
    /// The last prepared frame's draws and statistics.
    plan: Mutex<(Vec<splats::Draw>, FrameStats)>,
}

fn load_splat_maps(gpu: &Gpu, data: &ViewData, reflector: &str) -> Result<SplatMaps, String> {
    let cams = load_cameras(&data.bundle, reflector).map_err(|e| e.to_string())?;
    let mut all = Vec::new();
    let mut trees = Vec::new();
    let mut node_base = 0u32;
    for m in &cams.maps {
        let map_path = crate::radiance::index::map_path(reflector, &m.file, "exr");
        let at = |e: String| format!("radiance/{map_path}: {e}");
        let stored = read_map(&data.bundle, reflector, m).map_err(|e| e.to_string())?;
        let (image, nodes) = (stored.image, stored.nodes);
        let ch = |n: &str| image.channel(n).map_err(|e| at(e.to_string()));
        let map_image = MapImage {
            rgb: [ch("R")?, ch("G")?, ch("B")?],
            hit: ch("A")?,
            z: ch("Z")?,
        };
        let count = nodes.len() as u32;
        let mut tree = splats::map_splats(&m.view, &map_image, nodes, node_base).map_err(at)?;
        let offset = all.len() as u32;
        for r in &mut tree.ranges {
            *r = r.start + offset..r.end + offset;
        }
        all.append(&mut tree.splats);
        trees.push((tree, node_base));
        node_base += count;
    }
    let instances = buffer_init(
        gpu,
        "glint radiance-map splats",
        wgpu::BufferUsages::VERTEX,
        bytemuck::cast_slice(&all),
        32,
    );
    let nodes = buffer(
        &gpu.device,
        "glint quadtree node params",
        (node_base as u64 * std::mem::size_of::<NodeParams>() as u64).max(16),
        wgpu::BufferUsages::STORAGE,
    );
    Ok(SplatMaps {
        maps: cams.maps,
        trees,
        node_count: node_base as usize,
        instances,
        nodes,
        group: None,
        plan: Mutex::new((Vec::new(), FrameStats::default())),
    })
}

struct ReflectorGpu {
    splats: Option<SplatMaps>,
    reflector: PlanarReflector,
    params: wgpu::Buffer,
    mirror_uniforms: wgpu::Buffer,
    mirror_frame_group: wgpu::BindGroup,
    mirror_params_group: wgpu::BindGroup,
    composite_params_group: wgpu::BindGroup,
    _sphere: wgpu::Texture,
    indices: wgpu::Buffer,
    index_count: u32,
}

/// The reflection passes (either source) of one [`Renderer`] at one frame size.
pub struct GeometryReflections {
    source: Source,
    splat_pipeline: wgpu::RenderPipeline,
    mirror_pipeline: wgpu::RenderPipeline,
    composite_pipeline: wgpu::RenderPipeline,
    composite_frame_group: wgpu::BindGroup,
    reflectors: Vec<ReflectorGpu>,
    clip: f32,
    _texture: wgpu::Texture,
    texture_view: wgpu::TextureView,
    _depth: wgpu::Texture,
    depth_view: wgpu::TextureView,
    width: u32,
    height: u32,
}

pub(super) fn sphere_texture(gpu: &Gpu, modulation: &Modulation) -> wgpu::Texture {
    let (size, texels) = match modulation {
        Modulation::Sphere { size, texels } => (*size, texels.clone()),
        Modulation::OneD(_) => (1, vec![Vec3::ZERO]),
    };
    let texture = gpu.device.create_texture(&wgpu::TextureDescriptor {
        label: Some("glint reflectance sphere map"),
        size: wgpu::Extent3d {
            width: size,
            height: size,
            depth_or_array_layers: 1,
        },
        mip_level_count: 1,
        sample_count: 1,
        dimension: wgpu::TextureDimension::D2,
        format: wgpu::TextureFormat::Rgba32Float,
        usage: wgpu::TextureUsages::TEXTURE_BINDING | wgpu::TextureUsages::COPY_DST,
        view_formats: &[],
    });
    let data: Vec<[f32; 4]> = texels.iter().map(|v| v.extend(0.0).to_array()).collect();
    gpu.queue.write_texture(
        texture.as_image_copy(),
        bytemuck::cast_slice(&data),
        wgpu::TexelCopyBufferLayout {
            offset: 0,
            bytes_per_row: Some(size * 16),
            rows_per_image: None,
        },
        texture.size(),
    );
    texture
}

impl GeometryReflections {
    /// The passes for `renderer` (drawing `data`) on `width` × `height` targets, with K and R
    /// from the bundle's materials stage, R from the 1D map's albedo channel.
    pub fn new(
        gpu: &Gpu,
        renderer: &Renderer,
        data: &ViewData,
        width: u32,
        height: u32,
        source: Source,
    ) -> Result<GeometryReflections, RenderError> {
        Self::with_reflectance(
            gpu,
            renderer,
            data,
            width,
            height,
            source,
            ReflectanceSettings::default(),
        )
    }

    /// [`GeometryReflections::new`] with R read as `reflectance` says.
    pub fn with_reflectance(
        gpu: &Gpu,
        renderer: &Renderer,
        data: &ViewData,
        width: u32,
        height: u32,
        source: Source,
        reflectance: ReflectanceSettings,
    ) -> Result<GeometryReflections, RenderError> {
        let planar = reflectors_with_materials(data, reflectance);
        let mut splats = Vec::new();
        if let Source::Image { .. } = source
            && !planar.is_empty()
        {
            if data.bundle.stage("radiance").is_none() {
                return Err(RenderError::Reflections(format!(
                    "bundle {}: image-based reflections need the `radiance` stage; bake it with glint-bake",
                    data.bundle.dir().display()
                )));
            }
            for r in &planar {
                splats.push(Some(
                    load_splat_maps(gpu, data, &r.name).map_err(RenderError::Reflections)?,
                ));
            }
        }
        splats.resize_with(planar.len(), || None);
        let built = Self::build(gpu, renderer, data, width, height, source, planar, splats)?;
        Ok(built)
    }

    #[allow(clippy::too_many_arguments)]
    fn build(
        gpu: &Gpu,
        renderer: &Renderer,
        data: &ViewData,
        width: u32,
        height: u32,
        source: Source,
        planar: Vec<PlanarReflector>,
        splats: Vec<Option<SplatMaps>>,
    ) -> Result<GeometryReflections, GpuError> {
        let (scene, map) = (&data.scene, &data.map);
        let device = &gpu.device;
        let mesh = crate::view::renderer::SceneMesh::new(scene, &map.atlas);
        let clip = (scene.bounds.diagonal() * CLIP_FRACTION).max(1e-5);
        let formats = renderer.formats();
        error_scoped(device, "creating the reflection passes", || {
            let shader = device.create_shader_module(wgpu::ShaderModuleDescriptor {
                label: Some("glint reflection shader"),
                source: wgpu::ShaderSource::Wgsl(shader_source().into()),
            });
            let frame_layout = frame_bind_group_layout(device);
            let mirror_layout = params_layout().build(device, "glint mirror params layout");
            let splat_layout = params_layout()
                .storage(6, wgpu::ShaderStages::VERTEX)
                .build(device, "glint splat params layout");
            let composite_layout =
                composite_bind_group_layout(device, "glint composite params layout");
            let mirror_pipeline =
                render_pipeline("glint mirror pipeline", &shader, "vs_mirror", "fs_mirror")
                    .layouts(&[&frame_layout, &mirror_layout])
                    .vertex(scene_vertex_layout())
                    .color(HDR_FORMAT, None)
                    .depth(reverse_z_depth(true, wgpu::CompareFunction::Greater))
                    .build(device);
            let splat_pipeline =
                render_pipeline("glint splat pipeline", &shader, "vs_splat", "fs_splat")
                    .layouts(&[&frame_layout, &splat_layout])
                    .vertex(Splat::layout())
                    .topology(wgpu::PrimitiveTopology::TriangleStrip)
                    .color(HDR_FORMAT, None)
                    .depth(reverse_z_depth(true, wgpu::CompareFunction::Greater))
                    .build(device);
            let additive = Some(ADDITIVE_KEEP_ALPHA);
            let composite_pipeline = render_pipeline(
                "glint reflection composite pipeline",
                &shader,
                "vs_mirror",
                "fs_composite",
            )
            .layouts(&[&frame_layout, &composite_layout])
            .vertex(scene_vertex_layout())
            .color(formats.color, additive)
            .target(formats.hdr.then_some(wgpu::ColorTargetState {
                format: HDR_FORMAT,
                blend: additive,
                write_mask: wgpu::ColorWrites::ALL,
            }))
            .depth(reverse_z_depth(false, wgpu::CompareFunction::GreaterEqual))
            .build(device);
            let size = wgpu::Extent3d {
                width,
                height,
                depth_or_array_layers: 1,
            };
            let texture = device.create_texture(&wgpu::TextureDescriptor {
                label: Some("glint reflection texture"),
                size,
                mip_level_count: 1,
                sample_count: 1,
                dimension: wgpu::TextureDimension::D2,
                format: HDR_FORMAT,
                usage: wgpu::TextureUsages::RENDER_ATTACHMENT
                    | wgpu::TextureUsages::TEXTURE_BINDING,
                view_formats: &[],
            });
            let texture_view = texture.create_view(&wgpu::TextureViewDescriptor::default());
            let sampler = device.create_sampler(&wgpu::SamplerDescriptor {
                label: Some("glint reflection sampler"),
                mag_filter: wgpu::FilterMode::Linear,
                min_filter: wgpu::FilterMode::Linear,
                ..Default::default()
            });
            let depth = crate::view::renderer::depth_texture(gpu, width, height);
            let depth_view = depth.create_view(&wgpu::TextureViewDescriptor::default());
            let composite_frame_group = frame_bind_group(
                device,
                &frame_layout,
                renderer.frame_uniform_buffer(),
                renderer.textures(),
            );
            let reflectors = planar
                .into_iter()
                .zip(splats)
                .map(|(reflector, mut splats)| {
                    let indices: Vec<u32> = reflector
                        .triangles
                        .iter()
                        .flat_map(|&t| {
                            let t = t as usize * 3;
                            mesh.indices[t..t + 3].iter().copied()
                        })
                        .collect();
                    let index_buffer = buffer_init(
                        gpu,
                        "glint reflector indices",
                        wgpu::BufferUsages::INDEX,
                        bytemuck::cast_slice(&indices),
                        4,
                    );
                    let params = buffer_init(
                        gpu,
                        "glint reflector params",
                        wgpu::BufferUsages::UNIFORM,
                        bytemuck::bytes_of(&ReflectParams::new(&reflector, clip, Vec3::ZERO)),
                        0,
                    );
                    let mirror_uniforms = uniform_buffer(device);
                    let mirror_frame_group = frame_bind_group(
                        device,
                        &frame_layout,
                        &mirror_uniforms,
                        renderer.textures(),
                    );
                    let params_entry = || wgpu::BindGroupEntry {
                        binding: 2,
                        resource: params.as_entire_binding(),
                    };
                    let mirror_params_group =
                        device.create_bind_group(&wgpu::BindGroupDescriptor {
                            label: Some("glint mirror params"),
                            layout: &mirror_layout,
                            entries: &[params_entry()],
                        });
                    if let Some(s) = &mut splats {
                        s.group = Some(device.create_bind_group(&wgpu::BindGroupDescriptor {
                            label: Some("glint splat params"),
                            layout: &splat_layout,
                            entries: &[
                                params_entry(),
                                wgpu::BindGroupEntry {
                                    binding: 6,
                                    resource: s.nodes.as_entire_binding(),
                                },
                            ],
                        }));
                    }
                    let sphere = sphere_texture(gpu, &reflector.modulation);
                    let sphere_view = sphere.create_view(&wgpu::TextureViewDescriptor::default());
                    let composite_params_group =
                        device.create_bind_group(&wgpu::BindGroupDescriptor {
                            label: Some("glint composite params"),
                            layout: &composite_layout,
                            entries: &[
                                params_entry(),
                                wgpu::BindGroupEntry {
                                    binding: 3,
                                    resource: wgpu::BindingResource::TextureView(&texture_view),
                                },
                                wgpu::BindGroupEntry {
                                    binding: 4,
                                    resource: wgpu::BindingResource::Sampler(&sampler),
                                },
                                wgpu::BindGroupEntry {
                                    binding: 5,
                                    resource: wgpu::BindingResource::TextureView(&sphere_view),
                                },
                            ],
                        });
                    ReflectorGpu {
                        splats,
                        index_count: indices.len() as u32,
                        reflector,
                        params,
                        mirror_uniforms,
                        mirror_frame_group,
                        mirror_params_group,
                        composite_params_group,
                        _sphere: sphere,
                        indices: index_buffer,
                    }
                })
                .collect();
            GeometryReflections {
                source,
                splat_pipeline,
                mirror_pipeline,
                composite_pipeline,
                composite_frame_group,
                reflectors,
                clip,
                _texture: texture,
                texture_view,
                _depth: depth,
                depth_view,
                width,
                height,
            }
        })
    }

    /// How many reflectors it draws.
    pub fn reflector_count(&self) -> usize {
        self.reflectors.len()
    }

    /// The reflectors it draws (with their K and R).
    pub fn reflectors(&self) -> impl Iterator<Item = &PlanarReflector> {
        self.reflectors.iter().map(|r| &r.reflector)
    }

    /// Per reflector, what the image-based mode drew in the last prepared frame (default
    /// statistics in geometry mode).
    pub fn frame_stats(&self) -> Vec<FrameStats> {
        self.reflectors
            .iter()
            .map(|r| {
                r.splats.as_ref().map_or_else(FrameStats::default, |s| {
                    s.plan.lock().map(|p| p.1).unwrap_or_default()
                })
            })
            .collect()
    }

    fn visible(&self, r: &ReflectorGpu, camera: &Camera) -> bool {
        r.index_count > 0 && signed_distance(&r.reflector.plane, camera.position) > 0.0
    }

    /// How many render passes [`GeometryReflections::draw`] records for `camera` (two per
    /// reflector seen from its reflecting side).
    pub fn pass_count(&self, camera: &Camera) -> usize {
        2 * self
            .reflectors
            .iter()
            .filter(|r| self.visible(r, camera))
            .count()
    }

    /// Writes each reflector's mirrored-view uniforms for `camera` and, in image mode, plans
    /// its splats (map selection, Eq. 3 sizes, culling, skipping; the writes land before the
    /// next submission). With `curved`, also the curved reflectors' mirrored views (geometry
    /// mode: slot = the reflector's index), which [`GeometryReflections::draw_timed`] draws
    /// into each mirror pass.
    pub fn prepare(
        &self,
        gpu: &Gpu,
        renderer: &Renderer,
        camera: &Camera,
        curved: Option<&CurvedReflections>,
    ) {
        let pitch = splats::pixel_tangent(camera.fov_y, self.height);
        for (slot, r) in self.reflectors.iter().enumerate() {
            let mirrored = mirror_camera(camera, &r.reflector.plane);
            if let (Some(c), Source::Geometry) = (curved, self.source)
                && self.visible(r, camera)
            {
                let plane = &r.reflector.plane;
                let clip = plane
                    .normal
                    .extend(plane.normal.dot(plane.point) + self.clip);
                c.prepare_mirror(
                    gpu,
                    renderer,
                    slot,
                    &mirrored,
                    self.width,
                    self.height,
                    clip,
                );
            }
            let u = renderer.uniforms(&mirrored, self.width, self.height);
            gpu.queue
                .write_buffer(&r.mirror_uniforms, 0, bytemuck::bytes_of(&u));
            let mut p = ReflectParams::new(&r.reflector, self.clip, camera.position);
            // Screen pixels per kernel texel at beyond-fraction 1 (scaled per pixel).
            p.kernel[0] = super::material::texel_pixels(r.reflector.kernel.texel_angle, 1.0, pitch);
            gpu.queue.write_buffer(&r.params, 0, bytemuck::bytes_of(&p));
            if let (Source::Image { selection, count }, Some(maps)) = (self.source, &r.splats)
                && self.visible(r, camera)
            {
                let view_proj = Mat4::from_cols_array_2d(&u.view_proj);
                let planes = splats::frustum_planes(&view_proj);
                let eye = mirror_point(&r.reflector.plane, camera.position);
                let chosen = select(&maps.maps, eye, selection, count);
                let mut params = vec![NodeParams::default(); maps.node_count];
                let mut draws = Vec::new();
                let mut stats = FrameStats {
                    maps: chosen.len(),
                    ..FrameStats::default()
                };
                let mut rank = 0;
                for (k, &i) in chosen.iter().enumerate() {
                    // `select` groups maps by element, best first.
                    rank = if k > 0 && maps.maps[chosen[k - 1]].element == maps.maps[i].element {
                        rank + 1
                    } else {
                        0
                    };
                    let (tree, base) = &maps.trees[i];
                    stats.selected_splats += tree
                        .ranges
                        .first()
                        .map_or(0, |r| u64::from(r.end - r.start));
                    stats.culled_nodes += splats::plan_map(
                        tree,
                        *base,
                        rank,
                        &mirrored,
                        &planes,
                        self.width,
                        self.height,
                        &mut params,
                        &mut draws,
                    );
                }
                stats.draws = draws.len();
                stats.drawn_splats = draws.iter().map(|d| u64::from(d.end - d.start)).sum();
                gpu.queue
                    .write_buffer(&maps.nodes, 0, bytemuck::cast_slice(&params));
                if let Ok(mut plan) = maps.plan.lock() {
                    *plan = (draws, stats);
                }
            }
        }
    }

    /// Records, after the scene pass into `color`/`hdr`/`depth` (depth stored), each visible
    /// reflector's mirror pass and composite. Reflectors seen from behind are skipped.
    pub fn draw(
        &self,
        encoder: &mut wgpu::CommandEncoder,
        renderer: &Renderer,
        camera: &Camera,
        color: &wgpu::TextureView,
        hdr: Option<&wgpu::TextureView>,
        depth: &wgpu::TextureView,
    ) {
        self.draw_timed(encoder, renderer, camera, color, hdr, depth, None, None);
    }

    /// [`GeometryReflections::draw`], the last pass writing its end timestamp into
    /// `end_timestamp` (query set, index) when given. With `curved` (prepared by
    /// [`GeometryReflections::prepare`] with the same passes), geometry mode's mirror passes
    /// also draw the curved reflectors' specular term in the mirrored view, so a curved
    /// reflector seen in a planar mirror is not kd·D alone. Image mode has no scene pass in
    /// the mirrored view (its M is splatted from radiance maps), so it draws none.
    #[allow(clippy::too_many_arguments)]
    pub fn draw_timed(
        &self,
        encoder: &mut wgpu::CommandEncoder,
        renderer: &Renderer,
        camera: &Camera,
        color: &wgpu::TextureView,
        hdr: Option<&wgpu::TextureView>,
        depth: &wgpu::TextureView,
        end_timestamp: Option<(&wgpu::QuerySet, u32)>,
        curved: Option<&CurvedReflections>,
    ) {
        let visible: Vec<(usize, &ReflectorGpu)> = self
            .reflectors
            .iter()
            .enumerate()
            .filter(|(_, r)| self.visible(r, camera))
            .collect();
        for (k, &(slot, r)) in visible.iter().enumerate() {
            {
                let mut pass = mirror_target_pass(
                    encoder,
                    "glint mirror pass",
                    &self.texture_view,
                    &self.depth_view,
                    false,
                );
                match (self.source, &r.splats) {
                    (Source::Image { .. }, Some(maps)) => {
                        pass.set_pipeline(&self.splat_pipeline);
                        pass.set_bind_group(0, &r.mirror_frame_group, &[]);
                        pass.set_bind_group(1, maps.group.as_ref(), &[]);
                        pass.set_vertex_buffer(0, maps.instances.slice(..));
                        if let Ok(plan) = maps.plan.lock() {
                            for d in &plan.0 {
                                pass.draw(0..4, d.clone());
                            }
                        }
                    }
                    _ => {
                        pass.set_pipeline(&self.mirror_pipeline);
                        pass.set_bind_group(0, &r.mirror_frame_group, &[]);
                        pass.set_bind_group(1, &r.mirror_params_group, &[]);
                        pass.set_vertex_buffer(0, renderer.vertex_buffer().slice(..));
                        pass.set_index_buffer(
                            renderer.index_buffer().slice(..),
                            wgpu::IndexFormat::Uint32,
                        );
                        pass.draw_indexed(0..renderer.index_count(), 0, 0..1);
                        if let (Some(c), Source::Geometry) = (curved, self.source) {
                            c.draw_mirror(&mut pass, slot);
                        }
                    }
                }
            }
            let end = end_timestamp.filter(|_| k + 1 == visible.len());
            let mut pass = crate::view::renderer::overlay_pass(
                encoder,
                "glint reflection composite pass",
                color,
                hdr,
                depth,
                end,
            );
            pass.set_pipeline(&self.composite_pipeline);
            pass.set_bind_group(0, &self.composite_frame_group, &[]);
            pass.set_bind_group(1, &r.composite_params_group, &[]);
            pass.set_vertex_buffer(0, renderer.vertex_buffer().slice(..));
            pass.set_index_buffer(r.indices.slice(..), wgpu::IndexFormat::Uint32);
            pass.draw_indexed(0..r.index_count, 0, 0..1);
        }
    }
}

/// Begins a pass drawing a mirrored view into a reflection map: `view` cleared to
/// transparent (alpha 0 marks texels nothing was drawn to), reverse-Z `depth` cleared to 0 and
/// kept afterwards only when `keep_depth` (nested composites test against it).
pub(super) fn mirror_target_pass<'e>(
    encoder: &'e mut wgpu::CommandEncoder,
    label: &str,
    view: &wgpu::TextureView,
    depth: &wgpu::TextureView,
    keep_depth: bool,
) -> wgpu::RenderPass<'e> {
    encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
        label: Some(label),
        color_attachments: &[Some(wgpu::RenderPassColorAttachment {
            view,
            depth_slice: None,
            resolve_target: None,
            ops: wgpu::Operations {
                load: wgpu::LoadOp::Clear(wgpu::Color::TRANSPARENT),
                store: wgpu::StoreOp::Store,
            },
        })],
        depth_stencil_attachment: Some(wgpu::RenderPassDepthStencilAttachment {
            view: depth,
            depth_ops: Some(wgpu::Operations {
                load: wgpu::LoadOp::Clear(0.0),
                store: if keep_depth {
                    wgpu::StoreOp::Store
                } else {
                    wgpu::StoreOp::Discard
                },
            }),
            stencil_ops: None,
        }),
        timestamp_writes: None,
        occlusion_query_set: None,
        multiview_mask: None,
    })
}

/// A layout with the `ReflectParams` uniform (binding 2) every reflection pass reads.
pub(super) fn params_layout() -> LayoutBuilder {
    bind_group_layout()
        .uniform::<ReflectParams>(2, wgpu::ShaderStages::VERTEX | wgpu::ShaderStages::FRAGMENT)
}

/// The composite's bindings: params, the reflected image M (filterable), its sampler and the
/// sphere-map R (read by texel).
pub(super) fn composite_bind_group_layout(
    device: &wgpu::Device,
    label: &str,
) -> wgpu::BindGroupLayout {
    let fragment = wgpu::ShaderStages::FRAGMENT;
    let d2 = wgpu::TextureViewDimension::D2;
    params_layout()
        .texture(3, fragment, d2, true)
        .sampler(4, fragment)
        .texture(5, fragment, d2, false)
        .build(device, label)
}

//! Recursive planar reflections (Nielsen & Christensen 2002 §3.1, Figure 4).
//!
//! Reflection maps are rendered while the frame is drawn, one render target per recursion
//! level (Figure 3): the view at level k renders each reflector it sees into map k, from the
//! view mirrored about that reflector, which in turn renders the reflectors *it* sees into
//! map k + 1, and so on to the depth d. A map is composited onto its reflector (ks·(M*K)·R,
//! the issue-9 composite with the material's kernel K, so glossy levels are filtered too) as
//! soon as it is complete, after which its target is free for the next reflector of that
//! level. Memory: d maps (+ depth buffers) of the frame's size, whatever the reflector count.
//!
//! The CPU half ([`plan`]) walks the reflection tree of a frame: per view, the reflectors
//! seen from their reflecting side, in front of the parent mirror, inside the view's
//! (mirrored) frustum, and whose accumulated specular weight (the product of max(ks·R) along
//! the path) stays above [`RecursionSettings::cutoff`] (Nielsen's suggested termination).
//! The GPU half ([`RecursiveReflections`]) records the passes of that tree depth first.
//!
//! Nothing behind a mirror leaks into its map: the scene pass of a mirrored view uses the
//! same per-fragment clip plane as the issue-9 geometry mode (`fs_mirror` discards fragments
//! at or behind the reflector's plane) rather than Lengyel's oblique near plane. The clip is
//! exact for any plane, and it leaves the reverse-Z infinite projection (and its depth
//! precision) untouched, which an oblique near plane would not (it tilts the near plane into
//! the depth range and needs a finite far plane).

use std::sync::Mutex;

use glam::{Vec3, Vec4};

use super::passes::{ReflectParams, shader_source, sphere_texture};
use super::splats::{frustum_planes, pixel_tangent};
use super::{
    CLIP_FRACTION, PlanarReflector, ReflectanceSettings, mirror_camera, reflectors_with_materials,
    signed_distance,
};
use crate::camera::Camera;
use crate::view::gpu::{Gpu, GpuError, error_scoped};
use crate::view::load::ViewData;
use crate::view::renderer::{
    DEPTH_FORMAT, HDR_FORMAT, RenderError, Renderer, Vertex, frame_bind_group,
    frame_bind_group_layout, reverse_z_depth, uniform_buffer, view_projection,
};

/// The deepest recursion the viewer draws (Nielsen's Table 1 goes to 4).
pub const MAX_RECURSION_DEPTH: u8 = 4;

/// Default specular-weight cutoff: a branch whose accumulated max(ks·R) falls below 1 % adds
/// at most ~2.5 steps of an 8-bit channel at full white, so its map is not rendered.
pub const DEFAULT_WEIGHT_CUTOFF: f32 = 0.01;

/// Most reflection maps one frame renders (a guard against n^d blow-up; further branches are
/// counted in [`RecursionStats::truncated`]).
pub const MAX_MAPS: usize = 256;

/// The recursion settings.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RecursionSettings {
    /// Recursion depth d (0–[`MAX_RECURSION_DEPTH`]); 0 draws no reflections, 1 mirrors the
    /// scene once (the issue-9 geometry mode).
    pub depth: u8,
    /// A branch stops when its accumulated specular weight falls below this.
    pub cutoff: f32,
}

impl Default for RecursionSettings {
    fn default() -> Self {
        RecursionSettings {
            depth: 1,
            cutoff: DEFAULT_WEIGHT_CUTOFF,
        }
    }
}

/// Parses a recursion depth for the command line: an integer 0–4.
pub fn parse_depth(s: &str) -> Result<u8, String> {
    match s.parse::<u8>() {
        Ok(d) if d <= MAX_RECURSION_DEPTH => Ok(d),
        _ => Err(format!(
            "{s:?} is not a recursion depth: give an integer from 0 to {MAX_RECURSION_DEPTH}"
        )),
    }
}

/// One reflection map of a frame: `reflector` seen in its parent's view (or the camera's).
#[derive(Clone, Debug, PartialEq)]
pub struct Node {
    /// Index into the reflectors.
    pub reflector: usize,
    /// Recursion level = the map (render target) it is rendered into.
    pub level: usize,
    /// The node whose view sees this reflector (`None`: the camera's).
    pub parent: Option<usize>,
    /// The eye of the view it is seen in.
    pub eye: Vec3,
    /// The view mirrored about the reflector, rendered into map `level`.
    pub camera: Camera,
    /// Accumulated specular weight: the product of max(ks·R) along the path.
    pub weight: f32,
    /// The reflectors this view sees (their maps are at `level + 1`).
    pub children: Vec<usize>,
}

/// What [`plan`] generated and culled.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct RecursionStats {
    /// Reflection maps rendered (tree nodes).
    pub maps: usize,
    /// Maps per recursion level.
    pub per_level: [usize; MAX_RECURSION_DEPTH as usize],
    /// Reflectors wholly outside the (mirrored) view frustum.
    pub culled_frustum: usize,
    /// Reflectors seen from behind, or wholly behind the parent mirror.
    pub culled_behind: usize,
    /// Branches stopped by the specular-weight cutoff.
    pub culled_weight: usize,
    /// Branches dropped at [`MAX_MAPS`].
    pub truncated: usize,
}

/// A frame's reflection tree, nodes in depth-first order.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Plan {
    /// Every map of the frame.
    pub nodes: Vec<Node>,
    /// The reflectors the camera sees.
    pub roots: Vec<usize>,
    /// Counts.
    pub stats: RecursionStats,
}

/// The view geometry [`plan`] needs.
#[derive(Clone, Copy, Debug)]
pub struct ViewGeometry {
    /// Width / height.
    pub aspect: f32,
    /// Near plane distance.
    pub near: f32,
    /// Geometry within this distance of a mirror counts as behind it.
    pub clip: f32,
}

/// Whether the points lie wholly outside one of the `planes` (a·p + w < 0 outside).
pub fn outside(planes: &[Vec4], points: &[Vec3]) -> bool {
    planes
        .iter()
        .any(|p| points.iter().all(|v| p.truncate().dot(*v) + p.w < 0.0))
}

/// The reflection tree of a frame seen by `camera` (Figure 4's recursion, unrolled on the
/// CPU): `vertices[i]` are reflector i's vertices (for culling).
pub fn plan(
    camera: &Camera,
    view: ViewGeometry,
    reflectors: &[PlanarReflector],
    vertices: &[Vec<Vec3>],
    settings: RecursionSettings,
) -> Plan {
    let mut plan = Plan::default();
    let depth = settings.depth.min(MAX_RECURSION_DEPTH) as usize;
    plan.roots = visit(
        &mut plan, camera, None, 0, 1.0, view, reflectors, vertices, depth, settings,
    );
    plan
}

#[allow(clippy::too_many_arguments)]
fn visit(
    plan: &mut Plan,
    camera: &Camera,
    parent: Option<usize>,
    level: usize,
    weight: f32,
    view: ViewGeometry,
    reflectors: &[PlanarReflector],
    vertices: &[Vec<Vec3>],
    depth: usize,
    settings: RecursionSettings,
) -> Vec<usize> {
    if level >= depth {
        return Vec::new();
    }
    let planes = frustum_planes(&view_projection(camera, view.aspect, view.near));
    let mirror = parent.map(|p| plan.nodes[p].reflector);
    let mut seen = Vec::new();
    for (i, (r, verts)) in reflectors.iter().zip(vertices).enumerate() {
        // A planar mirror never sees itself (its mirrored eye is behind it).
        if Some(i) == mirror || verts.is_empty() {
            continue;
        }
        let behind_parent = mirror.is_some_and(|m| {
            verts
                .iter()
                .all(|&v| signed_distance(&reflectors[m].plane, v) <= view.clip)
        });
        if signed_distance(&r.plane, camera.position) <= 0.0 || behind_parent {
            plan.stats.culled_behind += 1;
            continue;
        }
        if outside(&planes, verts) {
            plan.stats.culled_frustum += 1;
            continue;
        }
        let centre = verts.iter().copied().sum::<Vec3>() / verts.len() as f32;
        let w = weight * r.modulation_at(centre, camera.position).max_element();
        if w < settings.cutoff {
            plan.stats.culled_weight += 1;
            continue;
        }
        if plan.nodes.len() >= MAX_MAPS {
            plan.stats.truncated += 1;
            continue;
        }
        let id = plan.nodes.len();
        let mirrored = mirror_camera(camera, &r.plane);
        plan.nodes.push(Node {
            reflector: i,
            level,
            parent,
            eye: camera.position,
            camera: mirrored,
            weight: w,
            children: Vec::new(),
        });
        plan.stats.maps += 1;
        plan.stats.per_level[level] += 1;
        let children = visit(
            plan,
            &mirrored,
            Some(id),
            level + 1,
            w,
            view,
            reflectors,
            vertices,
            depth,
            settings,
        );
        plan.nodes[id].children = children;
        seen.push(id);
    }
    seen
}

/// Bytes of the per-level targets for `depth` levels of `width` × `height`: an Rgba16Float
/// map and a Depth32Float buffer each.
pub fn texture_bytes(depth: u8, width: u32, height: u32) -> u64 {
    u64::from(depth) * u64::from(width) * u64::from(height) * (8 + 4)
}

/// One recursion level's render target.
struct Level {
    _color: wgpu::Texture,
    view: wgpu::TextureView,
    _depth: wgpu::Texture,
    depth_view: wgpu::TextureView,
}

/// Per-node GPU state, reused across frames (grown as needed).
struct Slot {
    /// The node's mirrored view (its scene pass, and its children's composites).
    uniforms: wgpu::Buffer,
    frame_group: wgpu::BindGroup,
    /// The node's reflector seen from its parent's eye (clip plane, ks·R, K).
    params: wgpu::Buffer,
    params_group: wgpu::BindGroup,
    /// Composite group for (reflector, level): the params, map `level`, R's sphere map.
    composite: Option<((usize, usize), wgpu::BindGroup)>,
}

/// Recursive planar reflections of one [`Renderer`] at one frame size (geometry source).
pub struct RecursiveReflections {
    settings: RecursionSettings,
    reflectors: Vec<PlanarReflector>,
    vertices: Vec<Vec<Vec3>>,
    indices: Vec<(wgpu::Buffer, u32)>,
    _spheres: Vec<wgpu::Texture>,
    sphere_views: Vec<wgpu::TextureView>,
    mirror_pipeline: wgpu::RenderPipeline,
    frame_composite_pipeline: wgpu::RenderPipeline,
    map_composite_pipeline: wgpu::RenderPipeline,
    frame_layout: wgpu::BindGroupLayout,
    params_layout: wgpu::BindGroupLayout,
    composite_layout: wgpu::BindGroupLayout,
    composite_frame_group: wgpu::BindGroup,
    sampler: wgpu::Sampler,
    levels: Vec<Level>,
    slots: Mutex<Vec<Slot>>,
    plan: Mutex<Plan>,
    clip: f32,
    near: f32,
    width: u32,
    height: u32,
}

impl RecursiveReflections {
    /// The passes for `renderer` drawing `data` on `width` × `height` targets, K and R read as
    /// `reflectance` says.
    pub fn new(
        gpu: &Gpu,
        renderer: &Renderer,
        data: &ViewData,
        width: u32,
        height: u32,
        reflectance: ReflectanceSettings,
        settings: RecursionSettings,
    ) -> Result<RecursiveReflections, RenderError> {
        if settings.depth > MAX_RECURSION_DEPTH {
            return Err(RenderError::Reflections(format!(
                "recursion depth {} is over {MAX_RECURSION_DEPTH}",
                settings.depth
            )));
        }
        let reflectors = reflectors_with_materials(data, reflectance);
        Ok(Self::build(
            gpu, renderer, data, width, height, reflectors, settings,
        )?)
    }

    fn build(
        gpu: &Gpu,
        renderer: &Renderer,
        data: &ViewData,
        width: u32,
        height: u32,
        reflectors: Vec<PlanarReflector>,
        settings: RecursionSettings,
    ) -> Result<RecursiveReflections, GpuError> {
        let device = &gpu.device;
        let mesh = crate::view::renderer::SceneMesh::new(&data.scene, &data.map.atlas);
        let clip = (data.scene.bounds.diagonal() * CLIP_FRACTION).max(1e-5);
        let formats = renderer.formats();
        error_scoped(device, "creating the recursive reflection passes", || {
            let shader = device.create_shader_module(wgpu::ShaderModuleDescriptor {
                label: Some("glint recursive reflection shader"),
                source: wgpu::ShaderSource::Wgsl(shader_source().into()),
            });
            let frame_layout = frame_bind_group_layout(device);
            let params_entry = wgpu::BindGroupLayoutEntry {
                binding: 2,
                visibility: wgpu::ShaderStages::VERTEX | wgpu::ShaderStages::FRAGMENT,
                ty: wgpu::BindingType::Buffer {
                    ty: wgpu::BufferBindingType::Uniform,
                    has_dynamic_offset: false,
                    min_binding_size: wgpu::BufferSize::new(
                        std::mem::size_of::<ReflectParams>() as u64
                    ),
                },
                count: None,
            };
            let params_layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
                label: Some("glint recursive params layout"),
                entries: &[params_entry],
            });
            let texture_entry = |binding, filterable| wgpu::BindGroupLayoutEntry {
                binding,
                visibility: wgpu::ShaderStages::FRAGMENT,
                ty: wgpu::BindingType::Texture {
                    sample_type: wgpu::TextureSampleType::Float { filterable },
                    view_dimension: wgpu::TextureViewDimension::D2,
                    multisampled: false,
                },
                count: None,
            };
            let composite_layout =
                device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
                    label: Some("glint recursive composite layout"),
                    entries: &[
                        params_entry,
                        texture_entry(3, true),
                        wgpu::BindGroupLayoutEntry {
                            binding: 4,
                            visibility: wgpu::ShaderStages::FRAGMENT,
                            ty: wgpu::BindingType::Sampler(wgpu::SamplerBindingType::Filtering),
                            count: None,
                        },
                        texture_entry(5, false),
                    ],
                });
            let layout = |params: &wgpu::BindGroupLayout| {
                device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
                    label: Some("glint recursive pipeline layout"),
                    bind_group_layouts: &[Some(&frame_layout), Some(params)],
                    immediate_size: 0,
                })
            };
            let vertex_buffers = [Some(wgpu::VertexBufferLayout {
                array_stride: std::mem::size_of::<Vertex>() as u64,
                step_mode: wgpu::VertexStepMode::Vertex,
                attributes: &wgpu::vertex_attr_array![0 => Float32x3, 1 => Float32x2, 2 => Uint32],
            })];
            let primitive = wgpu::PrimitiveState {
                topology: wgpu::PrimitiveTopology::TriangleList,
                cull_mode: None,
                ..Default::default()
            };
            let additive = wgpu::BlendState {
                color: wgpu::BlendComponent {
                    src_factor: wgpu::BlendFactor::One,
                    dst_factor: wgpu::BlendFactor::One,
                    operation: wgpu::BlendOperation::Add,
                },
                // Keeps the map's alpha (the beyond fraction its own composite reads).
                alpha: wgpu::BlendComponent {
                    src_factor: wgpu::BlendFactor::Zero,
                    dst_factor: wgpu::BlendFactor::One,
                    operation: wgpu::BlendOperation::Add,
                },
            };
            let pipeline = |label,
                            params: &wgpu::BindGroupLayout,
                            fragment: &str,
                            depth_write: bool,
                            compare,
                            targets: &[Option<wgpu::ColorTargetState>]| {
                let l = layout(params);
                device.create_render_pipeline(&wgpu::RenderPipelineDescriptor {
                    label: Some(label),
                    layout: Some(&l),
                    vertex: wgpu::VertexState {
                        module: &shader,
                        entry_point: Some("vs_mirror"),
                        compilation_options: wgpu::PipelineCompilationOptions::default(),
                        buffers: &vertex_buffers,
                    },
                    primitive,
                    depth_stencil: Some(reverse_z_depth(depth_write, compare)),
                    multisample: wgpu::MultisampleState::default(),
                    fragment: Some(wgpu::FragmentState {
                        module: &shader,
                        entry_point: Some(fragment),
                        compilation_options: wgpu::PipelineCompilationOptions::default(),
                        targets,
                    }),
                    multiview_mask: None,
                    cache: None,
                })
            };
            let hdr_target = |blend| {
                Some(wgpu::ColorTargetState {
                    format: HDR_FORMAT,
                    blend,
                    write_mask: wgpu::ColorWrites::ALL,
                })
            };
            // The scene in a mirrored view, clipped at the mirror (`fs_mirror`).
            let mirror_pipeline = pipeline(
                "glint recursive mirror pipeline",
                &params_layout,
                "fs_mirror",
                true,
                wgpu::CompareFunction::Greater,
                &[hdr_target(None)],
            );
            // A level-(k+1) map onto its reflector in map k (linear, `encode_srgb` = 0; the shader's
            // HDR output has no target here).
            let map_composite_pipeline = pipeline(
                "glint recursive map composite pipeline",
                &composite_layout,
                "fs_composite",
                false,
                wgpu::CompareFunction::GreaterEqual,
                &[hdr_target(Some(additive))],
            );
            // A level-0 map onto its reflector in the frame (as issue 9's composite).
            let frame_target = |format| {
                Some(wgpu::ColorTargetState {
                    format,
                    blend: Some(additive),
                    write_mask: wgpu::ColorWrites::ALL,
                })
            };
            let frame_composite_pipeline = pipeline(
                "glint recursive frame composite pipeline",
                &composite_layout,
                "fs_composite",
                false,
                wgpu::CompareFunction::GreaterEqual,
                &[
                    frame_target(formats.color),
                    if formats.hdr {
                        frame_target(HDR_FORMAT)
                    } else {
                        None
                    },
                ],
            );
            let size = wgpu::Extent3d {
                width,
                height,
                depth_or_array_layers: 1,
            };
            // Figure 3: one reflection map per recursion level.
            let levels = (0..settings.depth)
                .map(|_| {
                    let color = device.create_texture(&wgpu::TextureDescriptor {
                        label: Some("glint recursion level map"),
                        size,
                        mip_level_count: 1,
                        sample_count: 1,
                        dimension: wgpu::TextureDimension::D2,
                        format: HDR_FORMAT,
                        usage: wgpu::TextureUsages::RENDER_ATTACHMENT
                            | wgpu::TextureUsages::TEXTURE_BINDING,
                        view_formats: &[],
                    });
                    let depth = crate::view::renderer::depth_texture(gpu, width, height);
                    debug_assert_eq!(depth.format(), DEPTH_FORMAT);
                    Level {
                        view: color.create_view(&wgpu::TextureViewDescriptor::default()),
                        _color: color,
                        depth_view: depth.create_view(&wgpu::TextureViewDescriptor::default()),
                        _depth: depth,
                    }
                })
                .collect();
            let sampler = device.create_sampler(&wgpu::SamplerDescriptor {
                label: Some("glint recursive reflection sampler"),
                mag_filter: wgpu::FilterMode::Linear,
                min_filter: wgpu::FilterMode::Linear,
                ..Default::default()
            });
            let composite_frame_group = frame_bind_group(
                device,
                &frame_layout,
                renderer.frame_uniform_buffer(),
                renderer.textures(),
            );
            let mut vertices = Vec::new();
            let mut indices = Vec::new();
            for r in &reflectors {
                let idx: Vec<u32> = r
                    .triangles
                    .iter()
                    .flat_map(|&t| {
                        let t = t as usize * 3;
                        mesh.indices[t..t + 3].iter().copied()
                    })
                    .collect();
                let mut v: Vec<Vec3> = idx
                    .iter()
                    .map(|&i| Vec3::from_array(mesh.vertices[i as usize].position))
                    .collect();
                v.dedup();
                vertices.push(v);
                let buffer = device.create_buffer(&wgpu::BufferDescriptor {
                    label: Some("glint recursive reflector indices"),
                    size: (idx.len() as u64 * 4).max(4),
                    usage: wgpu::BufferUsages::INDEX | wgpu::BufferUsages::COPY_DST,
                    mapped_at_creation: false,
                });
                gpu.queue
                    .write_buffer(&buffer, 0, bytemuck::cast_slice(&idx));
                indices.push((buffer, idx.len() as u32));
            }
            let spheres: Vec<wgpu::Texture> = reflectors
                .iter()
                .map(|r| sphere_texture(gpu, &r.modulation))
                .collect();
            let sphere_views = spheres
                .iter()
                .map(|s| s.create_view(&wgpu::TextureViewDescriptor::default()))
                .collect();
            RecursiveReflections {
                settings,
                reflectors,
                vertices,
                indices,
                _spheres: spheres,
                sphere_views,
                mirror_pipeline,
                frame_composite_pipeline,
                map_composite_pipeline,
                frame_layout,
                params_layout,
                composite_layout,
                composite_frame_group,
                sampler,
                levels,
                slots: Mutex::new(Vec::new()),
                plan: Mutex::new(Plan::default()),
                clip,
                near: crate::view::renderer::near_plane(&data.scene),
                width,
                height,
            }
        })
    }

    /// The settings it was built with.
    pub fn settings(&self) -> RecursionSettings {
        self.settings
    }

    /// The reflectors it draws.
    pub fn reflectors(&self) -> &[PlanarReflector] {
        &self.reflectors
    }

    /// Bytes of its per-level render targets.
    pub fn texture_bytes(&self) -> u64 {
        texture_bytes(self.levels.len() as u8, self.width, self.height)
    }

    /// The last prepared frame's reflection tree.
    pub fn last_plan(&self) -> Plan {
        self.plan.lock().map(|p| p.clone()).unwrap_or_default()
    }

    /// The last prepared frame's counts.
    pub fn stats(&self) -> RecursionStats {
        self.plan.lock().map(|p| p.stats).unwrap_or_default()
    }

    /// Render passes [`RecursiveReflections::draw_timed`] records for the last prepared frame
    /// (a scene pass and a composite per map).
    pub fn pass_count(&self) -> usize {
        2 * self.plan.lock().map(|p| p.nodes.len()).unwrap_or(0)
    }

    fn new_slot(&self, gpu: &Gpu, renderer: &Renderer) -> Slot {
        let device = &gpu.device;
        let uniforms = uniform_buffer(device);
        let frame_group =
            frame_bind_group(device, &self.frame_layout, &uniforms, renderer.textures());
        let params = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("glint recursive node params"),
            size: std::mem::size_of::<ReflectParams>() as u64,
            usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        let params_group = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("glint recursive node params"),
            layout: &self.params_layout,
            entries: &[wgpu::BindGroupEntry {
                binding: 2,
                resource: params.as_entire_binding(),
            }],
        });
        Slot {
            uniforms,
            frame_group,
            params,
            params_group,
            composite: None,
        }
    }

    /// Plans the reflection tree for `camera` and writes every node's uniforms (the writes
    /// land before the next submission).
    pub fn prepare(&self, gpu: &Gpu, renderer: &Renderer, camera: &Camera) {
        let view = ViewGeometry {
            aspect: self.width.max(1) as f32 / self.height.max(1) as f32,
            near: self.near,
            clip: self.clip,
        };
        let plan = plan(
            camera,
            view,
            &self.reflectors,
            &self.vertices,
            self.settings,
        );
        let pitch = pixel_tangent(camera.fov_y, self.height);
        let Ok(mut slots) = self.slots.lock() else {
            return;
        };
        while slots.len() < plan.nodes.len() {
            let slot = self.new_slot(gpu, renderer);
            slots.push(slot);
        }
        for (node, slot) in plan.nodes.iter().zip(slots.iter_mut()) {
            let r = &self.reflectors[node.reflector];
            let mut u = renderer.uniforms(&node.camera, self.width, self.height);
            // Maps hold linear radiance.
            u.encode_srgb = 0;
            gpu.queue
                .write_buffer(&slot.uniforms, 0, bytemuck::bytes_of(&u));
            let mut p = ReflectParams::new(r, self.clip, node.eye);
            p.kernel[0] = super::material::texel_pixels(r.kernel.texel_angle, 1.0, pitch);
            gpu.queue
                .write_buffer(&slot.params, 0, bytemuck::bytes_of(&p));
            let key = (node.reflector, node.level);
            if slot.composite.as_ref().is_none_or(|(k, _)| *k != key) {
                let group = gpu.device.create_bind_group(&wgpu::BindGroupDescriptor {
                    label: Some("glint recursive composite"),
                    layout: &self.composite_layout,
                    entries: &[
                        wgpu::BindGroupEntry {
                            binding: 2,
                            resource: slot.params.as_entire_binding(),
                        },
                        wgpu::BindGroupEntry {
                            binding: 3,
                            resource: wgpu::BindingResource::TextureView(
                                &self.levels[node.level].view,
                            ),
                        },
                        wgpu::BindGroupEntry {
                            binding: 4,
                            resource: wgpu::BindingResource::Sampler(&self.sampler),
                        },
                        wgpu::BindGroupEntry {
                            binding: 5,
                            resource: wgpu::BindingResource::TextureView(
                                &self.sphere_views[node.reflector],
                            ),
                        },
                    ],
                });
                slot.composite = Some((key, group));
            }
        }
        if let Ok(mut p) = self.plan.lock() {
            *p = plan;
        }
    }

    /// Records, after the scene pass into `color`/`hdr`/`depth` (depth stored), the last
    /// prepared frame's reflection tree depth first (Figure 4), the last pass writing its end
    /// timestamp into `end_timestamp` when given.
    #[allow(clippy::too_many_arguments)]
    pub fn draw_timed(
        &self,
        encoder: &mut wgpu::CommandEncoder,
        renderer: &Renderer,
        color: &wgpu::TextureView,
        hdr: Option<&wgpu::TextureView>,
        depth: &wgpu::TextureView,
        end_timestamp: Option<(&wgpu::QuerySet, u32)>,
    ) {
        let (Ok(plan), Ok(slots)) = (self.plan.lock(), self.slots.lock()) else {
            return;
        };
        let load = |view| {
            Some(wgpu::RenderPassColorAttachment {
                view,
                depth_slice: None,
                resolve_target: None,
                ops: wgpu::Operations {
                    load: wgpu::LoadOp::Load,
                    store: wgpu::StoreOp::Store,
                },
            })
        };
        for (k, &root) in plan.roots.iter().enumerate() {
            self.draw_node(encoder, renderer, &plan, &slots, root);
            let timestamp_writes = match end_timestamp {
                Some((query_set, index)) if k + 1 == plan.roots.len() => {
                    Some(wgpu::RenderPassTimestampWrites {
                        query_set,
                        beginning_of_pass_write_index: None,
                        end_of_pass_write_index: Some(index),
                    })
                }
                _ => None,
            };
            let mut pass = encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
                label: Some("glint recursive frame composite"),
                color_attachments: &[load(color), hdr.and_then(load)],
                depth_stencil_attachment: Some(wgpu::RenderPassDepthStencilAttachment {
                    view: depth,
                    depth_ops: Some(wgpu::Operations {
                        load: wgpu::LoadOp::Load,
                        store: wgpu::StoreOp::Store,
                    }),
                    stencil_ops: None,
                }),
                timestamp_writes,
                occlusion_query_set: None,
                multiview_mask: None,
            });
            self.composite(
                &mut pass,
                renderer,
                &self.frame_composite_pipeline,
                &self.composite_frame_group,
                &plan.nodes[root],
                &slots[root],
            );
        }
    }

    fn composite(
        &self,
        pass: &mut wgpu::RenderPass<'_>,
        renderer: &Renderer,
        pipeline: &wgpu::RenderPipeline,
        frame_group: &wgpu::BindGroup,
        node: &Node,
        slot: &Slot,
    ) {
        let (indices, count) = &self.indices[node.reflector];
        pass.set_pipeline(pipeline);
        pass.set_bind_group(0, frame_group, &[]);
        pass.set_bind_group(1, slot.composite.as_ref().map(|c| &c.1), &[]);
        pass.set_vertex_buffer(0, renderer.vertex_buffer().slice(..));
        pass.set_index_buffer(indices.slice(..), wgpu::IndexFormat::Uint32);
        pass.draw_indexed(0..*count, 0, 0..1);
    }

    /// Figure 4's `DrawScene(mirror_view, depth + 1)`: node `id`'s mirrored view into its
    /// level's map, then each reflector it sees, recursively, composited into that map.
    fn draw_node(
        &self,
        encoder: &mut wgpu::CommandEncoder,
        renderer: &Renderer,
        plan: &Plan,
        slots: &[Slot],
        id: usize,
    ) {
        let node = &plan.nodes[id];
        let level = &self.levels[node.level];
        {
            let mut pass = encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
                label: Some("glint recursive mirror pass"),
                color_attachments: &[Some(wgpu::RenderPassColorAttachment {
                    view: &level.view,
                    depth_slice: None,
                    resolve_target: None,
                    ops: wgpu::Operations {
                        load: wgpu::LoadOp::Clear(wgpu::Color::TRANSPARENT),
                        store: wgpu::StoreOp::Store,
                    },
                })],
                depth_stencil_attachment: Some(wgpu::RenderPassDepthStencilAttachment {
                    view: &level.depth_view,
                    depth_ops: Some(wgpu::Operations {
                        load: wgpu::LoadOp::Clear(0.0),
                        store: wgpu::StoreOp::Store,
                    }),
                    stencil_ops: None,
                }),
                timestamp_writes: None,
                occlusion_query_set: None,
                multiview_mask: None,
            });
            pass.set_pipeline(&self.mirror_pipeline);
            pass.set_bind_group(0, &slots[id].frame_group, &[]);
            pass.set_bind_group(1, &slots[id].params_group, &[]);
            pass.set_vertex_buffer(0, renderer.vertex_buffer().slice(..));
            pass.set_index_buffer(renderer.index_buffer().slice(..), wgpu::IndexFormat::Uint32);
            pass.draw_indexed(0..renderer.index_count(), 0, 0..1);
        }
        for &child in &node.children {
            // Map level + 1 is overwritten per child: generated, applied, discarded (§3.1).
            self.draw_node(encoder, renderer, plan, slots, child);
            let mut pass = encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
                label: Some("glint recursive map composite"),
                color_attachments: &[Some(wgpu::RenderPassColorAttachment {
                    view: &level.view,
                    depth_slice: None,
                    resolve_target: None,
                    ops: wgpu::Operations {
                        load: wgpu::LoadOp::Load,
                        store: wgpu::StoreOp::Store,
                    },
                })],
                depth_stencil_attachment: Some(wgpu::RenderPassDepthStencilAttachment {
                    view: &level.depth_view,
                    depth_ops: Some(wgpu::Operations {
                        load: wgpu::LoadOp::Load,
                        store: wgpu::StoreOp::Store,
                    }),
                    stencil_ops: None,
                }),
                timestamp_writes: None,
                occlusion_query_set: None,
                multiview_mask: None,
            });
            self.composite(
                &mut pass,
                renderer,
                &self.map_composite_pipeline,
                &slots[id].frame_group,
                &plan.nodes[child],
                &slots[child],
            );
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::Plane;
    use crate::view::reflections::{Modulation, ScreenKernel};

    fn mirror(name: &str, normal: Vec3, point: Vec3, ks: f32) -> PlanarReflector {
        let (tangent, bitangent) = crate::sampling::basis(normal);
        PlanarReflector {
            name: name.into(),
            plane: Plane { normal, point },
            tangent,
            bitangent,
            material: 0,
            ks: Vec3::splat(ks),
            modulation: Modulation::constant(Vec3::splat(ks)),
            kernel: ScreenKernel::identity(),
            triangles: vec![],
        }
    }

    /// A square of half size `h` in the plane x = `x`.
    fn square_x(x: f32, h: f32) -> Vec<Vec3> {
        vec![
            Vec3::new(x, -h, -h),
            Vec3::new(x, h, -h),
            Vec3::new(x, h, h),
            Vec3::new(x, -h, h),
        ]
    }

    const VIEW: ViewGeometry = ViewGeometry {
        aspect: 1.5,
        near: 0.01,
        clip: 1e-3,
    };

    /// Two facing mirrors at x = ∓1, the camera between them looking at the one at x = −1.
    fn corridor(ks: f32) -> (Camera, Vec<PlanarReflector>, Vec<Vec<Vec3>>) {
        let a = mirror("A", Vec3::X, Vec3::new(-1.0, 0.0, 0.0), ks);
        let b = mirror("B", -Vec3::X, Vec3::new(1.0, 0.0, 0.0), ks);
        let cam = Camera::look_at(
            Vec3::new(0.6, 0.3, 0.0),
            Vec3::new(-1.0, 0.0, 0.0),
            Vec3::Y,
            60f32.to_radians(),
        );
        (
            cam,
            vec![a, b],
            vec![square_x(-1.0, 1.0), square_x(1.0, 1.0)],
        )
    }

    #[test]
    fn facing_mirrors_alternate_down_the_tree() {
        let (cam, r, v) = corridor(1.0);
        for depth in 0..=MAX_RECURSION_DEPTH {
            let p = plan(
                &cam,
                VIEW,
                &r,
                &v,
                RecursionSettings {
                    depth,
                    cutoff: DEFAULT_WEIGHT_CUTOFF,
                },
            );
            // B is behind the camera: only A at level 0, then B, A, B… one map per level.
            assert_eq!(p.stats.maps, depth as usize, "depth {depth}");
            for (k, n) in p.nodes.iter().enumerate() {
                assert_eq!(n.level, k);
                assert_eq!(n.reflector, k % 2);
                assert_eq!(n.parent, k.checked_sub(1));
            }
            if depth > 0 {
                assert_eq!(p.stats.culled_frustum, 1, "B behind the camera is culled");
                assert_eq!(p.roots, vec![0]);
            }
        }
    }

    #[test]
    fn weight_cutoff_stops_the_branch() {
        let (cam, r, v) = corridor(0.3);
        // Weights 0.3, 0.09, 0.027, 0.0081: a 0.05 cutoff keeps two levels of four.
        let p = plan(
            &cam,
            VIEW,
            &r,
            &v,
            RecursionSettings {
                depth: 4,
                cutoff: 0.05,
            },
        );
        assert_eq!(p.stats.maps, 2);
        assert_eq!(p.stats.culled_weight, 1);
        assert!((p.nodes[1].weight - 0.09).abs() < 1e-6);
        let all = plan(
            &cam,
            VIEW,
            &r,
            &v,
            RecursionSettings {
                depth: 4,
                cutoff: 0.0,
            },
        );
        assert_eq!(all.stats.maps, 4);
    }

    #[test]
    fn reflector_outside_the_mirrored_frustum_is_culled() {
        let (cam, mut r, mut v) = corridor(1.0);
        // C: a mirror on the floor far to the side, seen by neither the camera nor A's view.
        r.push(mirror("C", Vec3::Y, Vec3::new(0.0, -1.0, 20.0), 1.0));
        v.push(vec![
            Vec3::new(-0.5, -1.0, 19.5),
            Vec3::new(0.5, -1.0, 19.5),
            Vec3::new(0.5, -1.0, 20.5),
            Vec3::new(-0.5, -1.0, 20.5),
        ]);
        let settings = RecursionSettings {
            depth: 2,
            cutoff: DEFAULT_WEIGHT_CUTOFF,
        };
        let p = plan(&cam, VIEW, &r, &v, settings);
        assert_eq!(p.stats.maps, 2);
        // Level 0: B and C; level 1 (A's mirrored view): C.
        assert_eq!(p.stats.culled_frustum, 3);
        assert!(p.nodes.iter().all(|n| n.reflector != 2));
        // Widen the view: C comes in.
        let mut wide = cam;
        wide.forward = (Vec3::new(-0.2, -0.5, 1.0)).normalize();
        wide.right = wide.forward.cross(Vec3::Y).normalize();
        wide.up = wide.right.cross(wide.forward);
        let p = plan(&wide, VIEW, &r, &v, settings);
        assert!(p.nodes.iter().any(|n| n.reflector == 2));
    }

    #[test]
    fn reflector_behind_the_parent_mirror_is_culled() {
        let (cam, mut r, mut v) = corridor(1.0);
        // D behind A (x < −1), facing +x: A's mirrored view must not draw it.
        r.push(mirror("D", Vec3::X, Vec3::new(-3.0, 0.0, 0.0), 1.0));
        v.push(square_x(-3.0, 1.0));
        let p = plan(
            &cam,
            VIEW,
            &r,
            &v,
            RecursionSettings {
                depth: 2,
                cutoff: 0.0,
            },
        );
        assert!(
            p.nodes
                .iter()
                .all(|n| n.reflector != 2 || n.parent.is_none())
        );
        assert!(p.stats.culled_behind > 0);
    }

    #[test]
    fn depths_parse_and_bound_memory() {
        assert_eq!(parse_depth("0"), Ok(0));
        assert_eq!(parse_depth("4"), Ok(4));
        assert!(parse_depth("5").is_err());
        assert!(parse_depth("-1").is_err());
        assert!(parse_depth("two").is_err());
        assert_eq!(texture_bytes(2, 10, 10), 2 * 100 * 12);
    }
}

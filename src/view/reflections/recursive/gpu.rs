//! The GPU half of the recursive planar reflections: per-level targets, the passes of a
//! frame's reflection tree ([`super::plan`]) recorded depth first (Nielsen Figure 4).

use std::sync::Mutex;

use glam::Vec3;

use super::super::filter::{FILTER_RINGS, FilterTap, filter_taps};
use super::super::map_target::{ReflectionMap, map_sampler};
use super::super::params::{
    ReflectParams, composite_bind_group_layout, composite_group, params_group, params_layout,
    planar_composite, shader_source, sphere_texture,
};
use super::super::pyramid::{Pyramid, PyramidPasses};
use super::super::splats::pixel_tangent;
use super::super::{
    CLIP_FRACTION, PlanarReflector, ReflectanceSettings, reflectors_with_materials,
};
use super::{
    MAX_RECURSION_DEPTH, Node, Plan, RecursionSettings, RecursionStats, ViewGeometry, plan,
    texture_bytes,
};
use crate::camera::Camera;
use crate::view::curved::gpu::{CurvedReflections, MirroredView};
use crate::view::gpu::RenderError;
use crate::view::gpu::build::{
    RenderPipelineBuilder, buffer, buffer_init, render_pipeline, shader,
};
use crate::view::gpu::target::{ADDITIVE_KEEP_ALPHA, HDR_FORMAT, reverse_z_depth};
use crate::view::gpu::{Gpu, GpuError, error_scoped};
use crate::view::load::ViewData;
use crate::view::passes::composite::Composite;
use crate::view::passes::glass::MirroredGlass;
use crate::view::passes::renderer::{
    Renderer, SURFACE_TEXTURES, frame_bind_group, frame_bind_group_layout, scene_vertex_layout,
    uniform_buffer,
};

/// A child's map composited into its parent's: colour added, and the parent's alpha f_q (the
/// beyond fraction of the child reflector's surface) becomes f_q + f_c·(1 − f_q), with f_c the
/// child map's own beyond fraction (`composite` writes it). That is the beyond fraction of
/// the unfolded path, parent eye → reflector → what it shows: with L the parent eye's distance
/// to the point and d the reflected leg, f_c = d / (L + d) and f = (f_q·L + d) / (L + d).
/// K then blurs a mirror's reflection, seen in a glossy reflector, as far away as its content
/// lies (as `fs_curved_mirror` does for curved and terminal reflectors).
const UNFOLDED_ALPHA: wgpu::BlendState = wgpu::BlendState {
    color: ADDITIVE_KEEP_ALPHA.color,
    alpha: wgpu::BlendComponent {
        src_factor: wgpu::BlendFactor::OneMinusDstAlpha,
        dst_factor: wgpu::BlendFactor::One,
        operation: wgpu::BlendOperation::Add,
    },
};

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
    /// Each reflector's M*K filter ([`crate::view::reflections::filter::filter_taps`]).
    filters: Vec<Vec<FilterTap>>,
    vertices: Vec<Vec<Vec3>>,
    indices: Vec<(wgpu::Buffer, u32)>,
    _spheres: Vec<wgpu::Texture>,
    sphere_views: Vec<wgpu::TextureView>,
    mirror_pipeline: wgpu::RenderPipeline,
    /// The scene's thin glass in each mirrored view, drawn over its finished map (its opaque
    /// surfaces and the reflectors it sees composited).
    glass: Option<MirroredGlass>,
    /// A level-0 map onto its reflector in the frame.
    frame_composite: Composite,
    map_composite_pipeline: wgpu::RenderPipeline,
    frame_layout: wgpu::BindGroupLayout,
    params_layout: wgpu::BindGroupLayout,
    composite_layout: wgpu::BindGroupLayout,
    sampler: wgpu::Sampler,
    /// Figure 3: one reflection map per recursion level.
    levels: Vec<ReflectionMap>,
    /// Each level's MIP pyramid, rebuilt once its map is complete.
    pyramids: Vec<Pyramid>,
    pyramid_passes: PyramidPasses,
    slots: Mutex<Vec<Slot>>,
    plan: Mutex<Plan>,
    /// The reflectors as cube-mapped ones, for where one is seen in a map without a map of
    /// its own ([`crate::view::reflections::terminal`]); index for index.
    terminal: Option<CurvedReflections>,
    clip: f32,
    near: f32,
    width: u32,
    height: u32,
}

impl RecursiveReflections {
    /// The passes for `renderer` drawing `data` on `width` × `height` targets, K and R read as
    /// `reflectance` says. With `terminal`, the reflectors are cube-mapped with these
    /// settings for where one is seen in a map without a map of its own: past the last level,
    /// or cut by the weight cutoff ([`crate::view::reflections::terminal`]), as
    /// [`super::super::GeometryReflections::with_reflectance`] does at depth 1.
    #[allow(clippy::too_many_arguments)]
    pub fn new(
        gpu: &Gpu,
        renderer: &Renderer,
        data: &ViewData,
        width: u32,
        height: u32,
        reflectance: ReflectanceSettings,
        settings: RecursionSettings,
        terminal: Option<crate::view::curved::CurvedSettings>,
    ) -> Result<RecursiveReflections, RenderError> {
        if settings.depth > MAX_RECURSION_DEPTH {
            return Err(RenderError::Reflections(format!(
                "recursion depth {} is over {MAX_RECURSION_DEPTH}",
                settings.depth
            )));
        }
        let reflectors = reflectors_with_materials(data, reflectance);
        let mut built = Self::build(gpu, renderer, data, width, height, reflectors, settings)?;
        built.terminal = crate::view::reflections::terminal::terminal_passes(
            gpu,
            renderer,
            data,
            terminal,
            &built.reflectors,
        )?;
        Ok(built)
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
        let mesh = crate::view::passes::renderer::SceneMesh::new(&data.scene, &data.map.atlas);
        let clip = (data.scene.bounds.diagonal() * CLIP_FRACTION).max(1e-5);
        error_scoped(device, "creating the recursive reflection passes", || {
            let source = shader_source();
            let shader = shader(device, "glint recursive reflection shader", &source);
            let frame_layout = frame_bind_group_layout(device);
            let params_layout = params_layout().build(device, "glint recursive params layout");
            let composite_layout =
                composite_bind_group_layout(device, "glint recursive composite layout");
            fn scene_pipeline<'a>(
                shader: &'a wgpu::ShaderModule,
                layouts: &[&'a wgpu::BindGroupLayout],
                label: &'a str,
                fragment: &'a str,
                depth: wgpu::DepthStencilState,
            ) -> RenderPipelineBuilder<'a> {
                render_pipeline(label, shader, "vs_mirror", fragment)
                    .layouts(layouts)
                    .vertex(scene_vertex_layout())
                    .depth(depth)
            }
            let pipeline = |label, params, fragment, depth| {
                scene_pipeline(&shader, &[&frame_layout, params], label, fragment, depth)
            };
            // The scene in a mirrored view, clipped at the mirror (`fs_mirror`).
            let mirror_pipeline = pipeline(
                "glint recursive mirror pipeline",
                &params_layout,
                "fs_mirror",
                reverse_z_depth(true, wgpu::CompareFunction::Greater),
            )
            .color(HDR_FORMAT, None)
            .override_bool(SURFACE_TEXTURES, renderer.surface_textures())
            .build(device);
            // A level-(k+1) map onto its reflector in map k (linear, `encode_srgb` = 0; the shader's
            // HDR output has no target here).
            let map_composite_pipeline = pipeline(
                "glint recursive map composite pipeline",
                &composite_layout,
                "fs_composite",
                reverse_z_depth(false, wgpu::CompareFunction::GreaterEqual),
            )
            .color(HDR_FORMAT, Some(UNFOLDED_ALPHA))
            .build(device);
            // A level-0 map onto its reflector in the frame (as the single mirror pass's
            // composite).
            let frame_composite = planar_composite(
                device,
                renderer,
                "glint recursive frame composite pipeline",
                &shader,
                &frame_layout,
                &composite_layout,
            );
            let glass = MirroredGlass::build(
                gpu,
                &data.scene,
                renderer,
                &source,
                [&frame_layout, &params_layout],
                HDR_FORMAT,
            );
            let levels: Vec<ReflectionMap> = (0..settings.depth)
                .map(|_| ReflectionMap::new(gpu, "glint recursion level map", width, height))
                .collect();
            let pyramid_passes = PyramidPasses::new(device);
            let pyramids = levels
                .iter()
                .map(|l| pyramid_passes.pyramid(gpu, &l.view, width, height))
                .collect();
            let sampler = map_sampler(device, "glint recursive reflection sampler");
            let mut vertices = Vec::new();
            let mut indices = Vec::new();
            for r in &reflectors {
                let idx = mesh.triangle_indices(r.triangles.iter().map(|&t| t as usize));
                let mut v: Vec<Vec3> = idx
                    .iter()
                    .map(|&i| Vec3::from_array(mesh.vertices[i as usize].position))
                    .collect();
                v.dedup();
                vertices.push(v);
                let buffer = buffer_init(
                    gpu,
                    "glint recursive reflector indices",
                    wgpu::BufferUsages::INDEX,
                    bytemuck::cast_slice(&idx),
                    4,
                );
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
                filters: reflectors
                    .iter()
                    .map(|r| filter_taps(&r.kernel.taps, FILTER_RINGS))
                    .collect(),
                reflectors,
                vertices,
                indices,
                _spheres: spheres,
                sphere_views,
                mirror_pipeline,
                glass,
                frame_composite,
                map_composite_pipeline,
                frame_layout,
                params_layout,
                composite_layout,
                sampler,
                levels,
                pyramids,
                pyramid_passes,
                slots: Mutex::new(Vec::new()),
                plan: Mutex::new(Plan::default()),
                terminal: None,
                clip,
                near: crate::view::passes::renderer::near_plane(&data.scene),
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

    /// Render passes [`RecursiveReflections::draw`] records for the last prepared frame
    /// (a scene pass, one per level of its pyramid, a composite per map, and the glass pass
    /// of each map where the scene has glass).
    pub fn pass_count(&self) -> usize {
        (2 + usize::from(self.glass.is_some())
            + crate::view::reflections::filter::level_count(self.width, self.height) as usize)
            * self.plan.lock().map(|p| p.nodes.len()).unwrap_or(0)
    }

    fn new_slot(&self, gpu: &Gpu, renderer: &Renderer) -> Slot {
        let device = &gpu.device;
        let uniforms = uniform_buffer(device);
        let frame_group =
            frame_bind_group(device, &self.frame_layout, &uniforms, renderer.textures());
        let params = buffer(
            device,
            "glint recursive node params",
            std::mem::size_of::<ReflectParams>() as u64,
            wgpu::BufferUsages::UNIFORM,
        );
        let params_group = params_group(
            device,
            "glint recursive node params",
            &self.params_layout,
            &params,
        );
        Slot {
            uniforms,
            frame_group,
            params,
            params_group,
            composite: None,
        }
    }

    /// Clip plane of reflector `index` (normal xyz, w = normal · point + clip distance).
    fn clip_plane(&self, index: usize) -> glam::Vec4 {
        let plane = &self.reflectors[index].plane;
        plane
            .normal
            .extend(plane.normal.dot(plane.point) + self.clip)
    }

    /// Plans the reflection tree for `camera` and writes every node's uniforms (the writes
    /// land before the next submission). With `curved`, also the curved reflectors' view of
    /// every node (slot = the node's index), drawn into its map by
    /// [`RecursiveReflections::draw`].
    pub fn prepare(
        &self,
        gpu: &Gpu,
        renderer: &Renderer,
        camera: &Camera,
        curved: Option<&CurvedReflections>,
    ) {
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
        for (id, (node, slot)) in plan.nodes.iter().zip(slots.iter_mut()).enumerate() {
            for c in curved.into_iter().chain(self.terminal.as_ref()) {
                let view = MirroredView {
                    camera: &node.camera,
                    width: self.width,
                    height: self.height,
                    clip: self.clip_plane(node.reflector),
                    supersampled: false,
                };
                c.prepare_mirror(gpu, renderer, id, &view);
            }
            let r = &self.reflectors[node.reflector];
            let mut u = renderer.uniforms(&node.camera, self.width, self.height);
            // Maps hold linear radiance.
            u.encode_srgb = 0;
            gpu.queue
                .write_buffer(&slot.uniforms, 0, bytemuck::bytes_of(&u));
            let mut p =
                ReflectParams::with_filter(r, &self.filters[node.reflector], self.clip, node.eye);
            p.kernel[0] = super::super::material::texel_pixels(r.kernel.texel_angle, 1.0, pitch);
            // Nielsen §3.1: a map shows only what lies in front of its mirror, so the
            // composite of a child into its parent's map is clipped at the parent's plane too.
            if let Some(parent) = node.parent {
                p.parent = self.clip_plane(plan.nodes[parent].reflector).to_array();
            }
            gpu.queue
                .write_buffer(&slot.params, 0, bytemuck::bytes_of(&p));
            let key = (node.reflector, node.level);
            if slot.composite.as_ref().is_none_or(|(k, _)| *k != key) {
                let group = composite_group(
                    &gpu.device,
                    "glint recursive composite",
                    &self.composite_layout,
                    &slot.params,
                    (
                        &self.levels[node.level].view,
                        &self.pyramids[node.level].view,
                    ),
                    &self.sampler,
                    &self.sphere_views[node.reflector],
                );
                slot.composite = Some((key, group));
            }
        }
        if let Ok(mut p) = self.plan.lock() {
            *p = plan;
        }
    }

    /// Records, after the scene pass into `color`/`depth` (depth stored), the last prepared
    /// frame's reflection tree depth first (Figure 4); with `curved` (prepared with the same
    /// passes), each map also gets the curved reflectors' specular term in its view.
    pub fn draw(
        &self,
        encoder: &mut wgpu::CommandEncoder,
        renderer: &Renderer,
        color: &wgpu::TextureView,
        depth: &wgpu::TextureView,
        curved: Option<&CurvedReflections>,
    ) {
        let (Ok(plan), Ok(slots)) = (self.plan.lock(), self.slots.lock()) else {
            return;
        };
        for &root in &plan.roots {
            self.draw_node(encoder, renderer, &plan, &slots, root, curved);
            self.filter_node(encoder, &plan.nodes[root]);
            let mut pass = self.frame_composite.begin(
                encoder,
                "glint recursive frame composite",
                color,
                depth,
            );
            self.composite(&mut pass, renderer, &plan.nodes[root], &slots[root]);
        }
    }

    /// Draws `node`'s reflector with its map (`slot`'s composite group) in a composite pass
    /// whose pipeline and group 0 are set.
    fn composite(
        &self,
        pass: &mut wgpu::RenderPass<'_>,
        renderer: &Renderer,
        node: &Node,
        slot: &Slot,
    ) {
        let (indices, count) = &self.indices[node.reflector];
        pass.set_bind_group(1, slot.composite.as_ref().map(|c| &c.1), &[]);
        pass.set_vertex_buffer(0, renderer.vertex_buffer().slice(..));
        pass.set_index_buffer(indices.slice(..), wgpu::IndexFormat::Uint32);
        pass.draw_indexed(0..*count, 0, 0..1);
    }

    /// Builds the pyramid of `node`'s finished map, which its composite reads.
    fn filter_node(&self, encoder: &mut wgpu::CommandEncoder, node: &Node) {
        self.pyramid_passes
            .record(encoder, &self.pyramids[node.level], false);
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
        curved: Option<&CurvedReflections>,
    ) {
        let node = &plan.nodes[id];
        let level = &self.levels[node.level];
        {
            let mut pass = level.begin_mirror(encoder, "glint recursive mirror pass", true);
            pass.set_pipeline(&self.mirror_pipeline);
            pass.set_bind_group(0, &slots[id].frame_group, &[]);
            pass.set_bind_group(1, &slots[id].params_group, &[]);
            pass.set_vertex_buffer(0, renderer.vertex_buffer().slice(..));
            pass.set_index_buffer(renderer.index_buffer().slice(..), wgpu::IndexFormat::Uint32);
            renderer.draw_opaque(&mut pass);
            // Curved reflectors seen in this mirror: their specular term in the mirrored view.
            if let Some(c) = curved {
                c.draw_mirror(&mut pass, id);
            }
            // Planar ones seen from their reflecting side without a map of their own (this
            // view's children get theirs below): their cube-mapped specular term.
            if let Some(t) = &self.terminal {
                let eye = node.camera.position;
                t.draw_mirror_where(&mut pass, id, |i| {
                    i != node.reflector
                        && !node.children.iter().any(|&c| plan.nodes[c].reflector == i)
                        && super::super::signed_distance(&self.reflectors[i].plane, eye) > 0.0
                });
            }
        }
        for &child in &node.children {
            // Map level + 1 is overwritten per child: generated, applied, discarded (§3.1).
            self.draw_node(encoder, renderer, plan, slots, child, curved);
            self.filter_node(encoder, &plan.nodes[child]);
            let mut pass = level.begin_over(encoder, "glint recursive map composite");
            pass.set_pipeline(&self.map_composite_pipeline);
            pass.set_bind_group(0, &slots[id].frame_group, &[]);
            self.composite(&mut pass, renderer, &plan.nodes[child], &slots[child]);
        }
        // Glass last, so that a mirror seen through a pane is tinted with what lies behind it.
        if let Some(g) = &self.glass {
            let mut pass = level.begin_over(encoder, "glint recursive mirrored glass");
            g.draw(
                &mut pass,
                renderer,
                &slots[id].frame_group,
                &slots[id].params_group,
            );
        }
    }
}

//! The single-level reflection passes on the GPU (`shaders/reflect.wgsl`): per reflector, the
//! mirror pass (geometry re-rendered, or radiance-map splats from [`super::splat_maps`]) into
//! M, and the composite that adds ks·(M*K)·R over the reflector (in image mode filling the
//! texels no splat covered first, [`super::splats::fill_hole`]). The math they use lives in
//! [`super::splats`] and [`super::material`], the shader's inputs in [`super::params`].
//!
//! Kept in one file: the per-reflector state (`ReflectorGpu`: its uniforms, image mode's
//! resident maps and this frame's exact-surface ranges) is written by
//! [`GeometryReflections::prepare`] and read by [`GeometryReflections::draw`], and the maps'
//! residency follows the same visibility test as the passes.

use std::sync::Mutex;
use std::sync::atomic::{AtomicU8, AtomicU64, Ordering};

use glam::{Mat4, Vec2, Vec3};

use super::downsample::{downsample_pass, map_factor};
use super::filter::{FILTER_RINGS, FilterTap, detail_pixels, filter_taps};
use super::gap_fill::gap_fill_pass;
use super::map_target::{ReflectionMap, map_sampler};
use super::material::{beyond_fraction, texel_pixels};
use super::params::{
    ReflectParams, composite_bind_group_layout, composite_group, params_group, params_layout,
    planar_composite, shader_source, sphere_texture,
};
use super::pyramid::{Pyramid, PyramidPasses};
use super::splat_maps::{FrameStats, SplatMaps, check_map_sizes, load_splat_maps};
use super::splats;
use super::{
    CLIP_FRACTION, PlanarReflector, ReflectanceSettings, Source, mirror_camera, mirror_point,
    reflectors_with_materials, signed_distance,
};
use crate::camera::Camera;
use crate::geometry::Aabb;
use crate::view::curved::CurvedSettings;
use crate::view::curved::gpu::{CurvedReflections, MirroredView};
use crate::view::gpu::RenderError;
use crate::view::gpu::build::{buffer_init, render_pipeline, shader};
use crate::view::gpu::image_pass::ImagePass;
use crate::view::gpu::target::{HDR_FORMAT, reverse_z_depth};
use crate::view::gpu::{Gpu, GpuError, error_scoped};
use crate::view::load::ViewData;
use crate::view::passes::composite::Composite;
use crate::view::passes::glass::MirroredGlass;
use crate::view::passes::renderer::{
    Renderer, SURFACE_TEXTURES, frame_bind_group, frame_bind_group_layout, near_plane,
    scene_vertex_layout, uniform_buffer, view_projection,
};

/// Screen pixels beyond the filter's reach that image mode's splats still cover around an
/// element's window: the gap fill's radius ([`super::gap_fill::GAP_RADIUS`]) and the first rings of
/// the composite's hole fill, with room to spare.
const WINDOW_MARGIN: f32 = 16.0;

/// Which of its passes [`GeometryReflections::draw`] leaves out: the view bench times each
/// pass by the frame time it saves, since lavapipe gives no per-pass timestamps. Every pass
/// is drawn by default; a frame with a pass left out shows stale or missing reflections.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct SkippedPasses {
    /// The mirror pass into M (geometry mode: the scene re-rendered; image mode: the
    /// splats and the exact surfaces).
    pub mirror: bool,
    /// Image mode's gap fill.
    pub gap_fill: bool,
    /// M's pyramid.
    pub pyramid: bool,
    /// The composite over the reflector.
    pub composite: bool,
}

impl SkippedPasses {
    fn bits(self) -> u8 {
        u8::from(self.mirror)
            | u8::from(self.gap_fill) << 1
            | u8::from(self.pyramid) << 2
            | u8::from(self.composite) << 3
    }

    fn from_bits(b: u8) -> SkippedPasses {
        SkippedPasses {
            mirror: b & 1 != 0,
            gap_fill: b & 2 != 0,
            pyramid: b & 4 != 0,
            composite: b & 8 != 0,
        }
    }
}

/// Bytes of radiance-map splats image mode keeps on the GPU for reflectors the frame does not
/// see, the least recently seen dropped first: the maps of every reflector the frame sees stay
/// whatever their size, so memory follows the view, not the scene (the full generated
/// building has 96 planar reflectors). A reflector seen again within the budget is not read
/// again from the bundle.
pub const RESIDENT_SPLAT_BYTES: u64 = 256 << 20;

/// Image mode: a reflector's maps on the GPU while resident, and the last frame that saw it.
#[derive(Default)]
struct Resident {
    maps: Option<SplatMaps>,
    seen: u64,
}

/// Image mode: what reading a reflector's maps needs when a frame first sees it.
struct SplatLoader {
    bundle: crate::bundle::Bundle,
    exact: super::exact::ExactSurfaces,
    buffer_bytes: Option<u64>,
    layout: wgpu::BindGroupLayout,
    /// Frames prepared so far (the clock of [`Resident::seen`]).
    frame: AtomicU64,
    /// [`RESIDENT_SPLAT_BYTES`] unless [`GeometryReflections::set_resident_budget`] says
    /// otherwise.
    budget: AtomicU64,
}

/// Triangles of the exact surfaces culled together: the runs follow the scene's order, so a
/// run mostly lies in one object, and a building's emitters and curved reflectors in rooms its
/// mirrored views do not see are not drawn into M.
const EXACT_CLUSTER: usize = 256;

struct ReflectorGpu {
    resident: Mutex<Resident>,
    /// Image mode: this frame's ranges of the exact surfaces' indices that the mirrored view
    /// may see (the others lie wholly outside its frustum or behind the mirror).
    exact_ranges: Mutex<Vec<std::ops::Range<u32>>>,
    reflector: PlanarReflector,
    /// Its M*K filter ([`super::filter::filter_taps`]).
    filter: Vec<FilterTap>,
    params: wgpu::Buffer,
    mirror_uniforms: wgpu::Buffer,
    mirror_frame_group: wgpu::BindGroup,
    mirror_params_group: wgpu::BindGroup,
    composite_params_group: wgpu::BindGroup,
    _sphere: wgpu::Texture,
    indices: wgpu::Buffer,
    index_count: u32,
    /// The box around its triangles, to skip it where the camera cannot see it.
    bounds: Aabb,
}

/// The reflection passes (either source) of one [`Renderer`] at one frame size.
pub struct GeometryReflections {
    source: Source,
    splat_pipeline: wgpu::RenderPipeline,
    mirror_pipeline: wgpu::RenderPipeline,
    composite: Composite,
    reflectors: Vec<ReflectorGpu>,
    clip: f32,
    /// M, reused by every reflector in turn, drawn at `factor` × the frame's size.
    map: ReflectionMap,
    /// M's texels per frame pixel along each axis ([`map_factor`]: 2 in a multisampled
    /// frame).
    factor: u32,
    /// With `factor` > 1: M box-filtered to the frame's pixels, which the gap fill (image
    /// mode), the pyramid and the composite read instead of M.
    downsample: Option<ImagePass>,
    /// Image mode: M with the gaps between splats closed, which the pyramid and the composite
    /// read instead of M.
    gap_fill: Option<ImagePass>,
    /// M's pyramid, rebuilt after each mirror pass.
    pyramid: Pyramid,
    /// Image mode: the scene's emitters and curved reflectors (indices, count), drawn into M
    /// after the splats, which leave them out ([`super::exact`]).
    exact: Option<(wgpu::Buffer, u32)>,
    /// Image mode: the exact surfaces in runs of [`EXACT_CLUSTER`] triangles (scene order,
    /// so mostly one object's) with their boxes, culled per mirrored view.
    exact_clusters: Vec<Aabb>,
    /// Image mode: reads a reflector's maps when a frame first sees it.
    loader: Option<SplatLoader>,
    pyramid_passes: PyramidPasses,
    /// Geometry mode: the reflectors as cube-mapped ones, for where they are seen in another
    /// one's map (the recursion's end, [`super::terminal`]); index for index.
    terminal: Option<CurvedReflections>,
    /// Geometry mode: the scene's thin glass in the mirrored view, drawn after its opaque
    /// surfaces (image mode's maps already see through it).
    glass: Option<MirroredGlass>,
    width: u32,
    height: u32,
    /// The scene pass's near plane (the view [`GeometryReflections::visible`] tests against).
    near: f32,
    /// [`SkippedPasses`] as bits: set through a shared reference, as the frame holds the
    /// passes.
    skipped: AtomicU8,
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
            None,
            None,
            true,
        )
    }

    /// [`GeometryReflections::new`] with R read as `reflectance` says; image mode's splats
    /// in buffers of at most `splat_buffer_bytes` (`None`: what the GPU binds in one). With
    /// `terminal`, a near-mirror seen in another reflector's map gets its specular term from
    /// a cube map made with these settings ([`super::terminal`]): in geometry mode on top of
    /// its kd·D, in image mode drawn exactly in place of its map points
    /// ([`super::exact`]), whose one glossy bounce ([`crate::radiance::shading`]) shows the
    /// room as the map's camera, 20 cm behind glossy-room's table, saw it in the mirror. With
    /// `anti_aliased`, M is drawn at [`map_factor`] texels a pixel along each axis for the
    /// renderer's sample count and box-filtered; without, at one.
    #[allow(clippy::too_many_arguments)]
    pub fn with_reflectance(
        gpu: &Gpu,
        renderer: &Renderer,
        data: &ViewData,
        width: u32,
        height: u32,
        source: Source,
        reflectance: ReflectanceSettings,
        splat_buffer_bytes: Option<u64>,
        terminal: Option<CurvedSettings>,
        anti_aliased: bool,
    ) -> Result<GeometryReflections, RenderError> {
        let planar = reflectors_with_materials(data, reflectance);
        let terminal = super::terminal::terminal_passes(gpu, renderer, data, terminal, &planar)?;
        // Image mode: what the splats leave out and the mirror pass draws as geometry, the
        // same for every reflector; with terminal cube maps, the near-mirrors too, drawn with
        // the specular term their cube map gives the mirrored eye.
        let exact = (matches!(source, Source::Image { .. }) && !planar.is_empty()).then(|| {
            let mirrors = terminal
                .as_ref()
                .map(super::terminal::mirror_triangles)
                .unwrap_or_default();
            super::exact::ExactSurfaces::of_scene(&data.scene, &mirrors)
        });
        if exact.is_some() {
            if data.bundle.stage("radiance").is_none() {
                return Err(RenderError::Reflections(format!(
                    "bundle {}: image-based reflections need the `radiance` stage; bake it with glint-bake",
                    data.bundle.dir().display()
                )));
            }
            // Every reflector's camera list now, so that a bundle without one's maps, or
            // with a map no buffer binds, is refused here, not when a frame first sees it.
            for r in &planar {
                check_map_sizes(gpu, &data.bundle, &r.name, splat_buffer_bytes)
                    .map_err(RenderError::Reflections)?;
            }
        }
        let exact_triangles = exact
            .as_ref()
            .map(|e| e.triangles().to_vec())
            .unwrap_or_default();
        let loader = match exact {
            Some(exact) => Some((
                crate::bundle::Bundle::open(data.bundle.dir())
                    .map_err(|e| RenderError::Reflections(e.to_string()))?,
                exact,
                splat_buffer_bytes,
            )),
            None => None,
        };
        let mut built = Self::build(
            gpu,
            renderer,
            data,
            width,
            height,
            source,
            planar,
            loader,
            &exact_triangles,
            anti_aliased,
        )?;
        built.terminal = terminal;
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
        loader: Option<(
            crate::bundle::Bundle,
            super::exact::ExactSurfaces,
            Option<u64>,
        )>,
        exact_triangles: &[u32],
        anti_aliased: bool,
    ) -> Result<GeometryReflections, GpuError> {
        let (scene, map) = (&data.scene, &data.map);
        let device = &gpu.device;
        let mesh = crate::view::passes::renderer::SceneMesh::new(scene, &map.atlas);
        let clip = (scene.bounds.diagonal() * CLIP_FRACTION).max(1e-5);
        error_scoped(device, "creating the reflection passes", || {
            let source_text = shader_source();
            let shader = shader(device, "glint reflection shader", &source_text);
            let frame_layout = frame_bind_group_layout(device);
            let mirror_layout = params_layout().build(device, "glint mirror params layout");
            let splat_layout = params_layout()
                .storage(6, wgpu::ShaderStages::VERTEX)
                .storage(8, wgpu::ShaderStages::VERTEX)
                .storage(9, wgpu::ShaderStages::VERTEX)
                .storage(10, wgpu::ShaderStages::VERTEX)
                .build(device, "glint splat params layout");
            let composite_layout =
                composite_bind_group_layout(device, "glint composite params layout");
            let mirror_pipeline =
                render_pipeline("glint mirror pipeline", &shader, "vs_mirror", "fs_mirror")
                    .layouts(&[&frame_layout, &mirror_layout])
                    .vertex(scene_vertex_layout())
                    .color(HDR_FORMAT, None)
                    .depth(reverse_z_depth(true, wgpu::CompareFunction::Greater))
                    .override_bool(SURFACE_TEXTURES, renderer.surface_textures())
                    .build(device);
            let splat_pipeline =
                render_pipeline("glint splat pipeline", &shader, "vs_splat", "fs_splat")
                    .layouts(&[&frame_layout, &splat_layout])
                    .color(HDR_FORMAT, None)
                    .depth(reverse_z_depth(true, wgpu::CompareFunction::Greater))
                    .build(device);
            let glass = matches!(source, Source::Geometry)
                .then(|| {
                    MirroredGlass::build(
                        gpu,
                        scene,
                        renderer,
                        &source_text,
                        [&frame_layout, &mirror_layout],
                        HDR_FORMAT,
                    )
                })
                .flatten();
            let composite = planar_composite(
                device,
                renderer,
                "glint reflection composite pipeline",
                &shader,
                &frame_layout,
                &composite_layout,
            );
            let factor = if anti_aliased {
                map_factor(renderer.formats().samples)
            } else {
                1
            };
            let map = ReflectionMap::new(
                gpu,
                "glint reflection texture",
                width * factor,
                height * factor,
            );
            let sampler = map_sampler(device, "glint reflection sampler");
            let pyramid_passes = PyramidPasses::new(device);
            let downsample =
                (factor > 1).then(|| downsample_pass(device, &map.view, width, height, factor));
            let drawn = downsample.as_ref().map_or(&map.view, |d| &d.view);
            let gap_fill = matches!(source, Source::Image { .. })
                .then(|| gap_fill_pass(device, drawn, width, height));
            let m_view = gap_fill.as_ref().map_or(drawn, |g| &g.view);
            let pyramid = pyramid_passes.pyramid(gpu, m_view, width, height);
            let exact = (!exact_triangles.is_empty()).then(|| {
                let indices = mesh.triangle_indices(exact_triangles.iter().map(|&t| t as usize));
                let b = buffer_init(
                    gpu,
                    "glint exact surface indices",
                    wgpu::BufferUsages::INDEX,
                    bytemuck::cast_slice(&indices),
                    4,
                );
                (b, indices.len() as u32)
            });
            let reflectors = planar
                .into_iter()
                .map(|reflector| {
                    let indices =
                        mesh.triangle_indices(reflector.triangles.iter().map(|&t| t as usize));
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
                    let mirror_params_group =
                        params_group(device, "glint mirror params", &mirror_layout, &params);
                    let sphere = sphere_texture(gpu, &reflector.modulation);
                    let sphere_view = sphere.create_view(&wgpu::TextureViewDescriptor::default());
                    let composite_params_group = composite_group(
                        device,
                        "glint composite params",
                        &composite_layout,
                        &params,
                        (m_view, &pyramid.view),
                        &sampler,
                        &sphere_view,
                    );
                    let bounds = Aabb::from_points(
                        reflector
                            .triangles
                            .iter()
                            .flat_map(|&t| scene.triangles[t as usize].p.iter()),
                    );
                    ReflectorGpu {
                        resident: Mutex::new(Resident::default()),
                        exact_ranges: Mutex::new(Vec::new()),
                        bounds,
                        filter: filter_taps(&reflector.kernel.taps, FILTER_RINGS),
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
                composite,
                reflectors,
                clip,
                map,
                factor,
                downsample,
                gap_fill,
                pyramid,
                exact,
                exact_clusters: exact_triangles
                    .chunks(EXACT_CLUSTER)
                    .map(|run| {
                        Aabb::from_points(
                            run.iter()
                                .flat_map(|&t| scene.triangles[t as usize].p.iter()),
                        )
                    })
                    .collect(),
                loader: loader.map(|(bundle, exact, buffer_bytes)| SplatLoader {
                    bundle,
                    exact,
                    buffer_bytes,
                    layout: splat_layout,
                    frame: AtomicU64::new(0),
                    budget: AtomicU64::new(RESIDENT_SPLAT_BYTES),
                }),
                pyramid_passes,
                terminal: None,
                glass,
                width,
                height,
                near: near_plane(scene),
                skipped: AtomicU8::new(0),
            }
        })
    }

    /// Leaves `skipped` passes out of the frames drawn from now on (for timing the others).
    pub fn skip_passes(&self, skipped: SkippedPasses) {
        self.skipped.store(skipped.bits(), Ordering::Relaxed);
    }

    /// The passes [`GeometryReflections::draw`] leaves out.
    pub fn skipped_passes(&self) -> SkippedPasses {
        SkippedPasses::from_bits(self.skipped.load(Ordering::Relaxed))
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
                r.resident
                    .lock()
                    .ok()
                    .and_then(|res| {
                        res.maps
                            .as_ref()
                            .map(|s| s.plan.lock().map(|p| p.1).unwrap_or_default())
                    })
                    .unwrap_or_default()
            })
            .collect()
    }

    /// Image mode: how many reflectors' maps are on the GPU (read when a frame first saw
    /// them, kept within the budget, [`RESIDENT_SPLAT_BYTES`]); 0 in geometry mode.
    pub fn resident_maps(&self) -> usize {
        self.reflectors
            .iter()
            .filter(|r| r.resident.lock().is_ok_and(|res| res.maps.is_some()))
            .count()
    }

    /// Image mode: bytes of the GPU buffers of the resident maps.
    pub fn resident_bytes(&self) -> u64 {
        self.reflectors
            .iter()
            .filter_map(|r| {
                r.resident
                    .lock()
                    .ok()
                    .and_then(|res| res.maps.as_ref().map(SplatMaps::gpu_bytes))
            })
            .sum()
    }

    /// Image mode: keeps at most `bytes` of maps of reflectors a frame does not see
    /// ([`RESIDENT_SPLAT_BYTES`] by default), from the next prepared frame on.
    pub fn set_resident_budget(&self, bytes: u64) {
        if let Some(l) = &self.loader {
            l.budget.store(bytes, Ordering::Relaxed);
        }
    }

    /// Image mode: reflector `r`'s maps read from the bundle and uploaded, with the splat
    /// pass's bind group for each of their buffers.
    fn load_maps(
        &self,
        gpu: &Gpu,
        loader: &SplatLoader,
        r: &ReflectorGpu,
    ) -> Result<SplatMaps, String> {
        let mut maps = load_splat_maps(
            gpu,
            &loader.bundle,
            &r.reflector.name,
            &loader.exact,
            loader.buffer_bytes,
        )?;
        for chunk in &mut maps.chunks {
            chunk.group = Some(gpu.device.create_bind_group(&wgpu::BindGroupDescriptor {
                label: Some("glint splat params"),
                layout: &loader.layout,
                entries: &[
                    wgpu::BindGroupEntry {
                        binding: 2,
                        resource: r.params.as_entire_binding(),
                    },
                    wgpu::BindGroupEntry {
                        binding: 6,
                        resource: maps.nodes.as_entire_binding(),
                    },
                    wgpu::BindGroupEntry {
                        binding: 8,
                        resource: chunk.points.as_entire_binding(),
                    },
                    wgpu::BindGroupEntry {
                        binding: 9,
                        resource: chunk.kept.as_entire_binding(),
                    },
                    wgpu::BindGroupEntry {
                        binding: 10,
                        resource: maps.views.as_entire_binding(),
                    },
                ],
            }));
        }
        Ok(maps)
    }

    /// Image mode: drops the maps of reflectors not seen in `frame`, least recently seen
    /// first, until those left fit the budget.
    fn evict(&self, loader: &SplatLoader, frame: u64) {
        let budget = loader.budget.load(Ordering::Relaxed);
        let mut unseen: Vec<(u64, u64, usize)> = self
            .reflectors
            .iter()
            .enumerate()
            .filter_map(|(i, r)| {
                let res = r.resident.lock().ok()?;
                let maps = res.maps.as_ref()?;
                (res.seen != frame).then(|| (res.seen, maps.gpu_bytes(), i))
            })
            .collect();
        let mut kept: u64 = unseen.iter().map(|u| u.1).sum();
        unseen.sort_unstable();
        for (_, bytes, i) in unseen {
            if kept <= budget {
                break;
            }
            if let Ok(mut res) = self.reflectors[i].resident.lock() {
                res.maps = None;
            }
            kept -= bytes;
        }
    }

    /// Records, in reflector `slot`'s mirror pass for `camera`, the cube-mapped specular
    /// term of the other reflectors it sees from their reflecting side ([`super::terminal`]).
    fn draw_terminal(&self, pass: &mut wgpu::RenderPass<'_>, slot: usize, camera: &Camera) {
        let Some(t) = &self.terminal else {
            return;
        };
        let eye = mirror_point(&self.reflectors[slot].reflector.plane, camera.position);
        t.draw_mirror_where(pass, slot, |i| {
            i != slot && signed_distance(&self.reflectors[i].reflector.plane, eye) > 0.0
        });
    }

    /// The clip plane of `r`'s mirrored view (normal xyz, w = normal · point + clip
    /// distance): what lies at or behind it is discarded.
    fn clip_plane(&self, r: &ReflectorGpu) -> glam::Vec4 {
        let plane = &r.reflector.plane;
        plane
            .normal
            .extend(plane.normal.dot(plane.point) + self.clip)
    }

    /// Whether `camera` sees reflector `r`: from its reflecting side, and not wholly outside
    /// the view (its box beyond one side of the frustum, as the recursion culls). A reflector
    /// it does not see gets no mirror pass, pyramid or composite: the composite would draw
    /// none of its pixels.
    fn visible(&self, r: &ReflectorGpu, camera: &Camera) -> bool {
        r.index_count > 0
            && signed_distance(&r.reflector.plane, camera.position) > 0.0
            && !splats::box_outside(
                &splats::frustum_planes(&self.frame_view_proj(camera)),
                r.bounds.min,
                r.bounds.max,
            )
    }

    /// The scene pass's view-projection for `camera` on these targets (as
    /// [`Renderer::uniforms`] writes it).
    fn frame_view_proj(&self, camera: &Camera) -> Mat4 {
        let aspect = self.width.max(1) as f32 / self.height.max(1) as f32;
        view_projection(camera, aspect, self.near)
    }

    /// How many reflection maps [`GeometryReflections::draw`] draws for `camera` (one per
    /// reflector in view, seen from its reflecting side).
    pub fn map_count(&self, camera: &Camera) -> usize {
        self.reflectors
            .iter()
            .filter(|r| self.visible(r, camera))
            .count()
    }

    /// How many render passes [`GeometryReflections::draw`] records for `camera`: per map
    /// ([`GeometryReflections::map_count`]), the mirror pass, one per level of M's pyramid
    /// and the composite.
    pub fn pass_count(&self, camera: &Camera) -> usize {
        (2 + super::filter::level_count(self.width, self.height) as usize) * self.map_count(camera)
    }

    /// Writes each reflector's mirrored-view uniforms for `camera` and, in image mode, plans
    /// its splats (map selection, Eq. 3 sizes, culling, skipping; the writes land before the
    /// next submission). With `curved`, also the curved reflectors' mirrored views (slot =
    /// the reflector's index), which [`GeometryReflections::draw`] draws
    /// into each mirror pass.
    pub fn prepare(
        &self,
        gpu: &Gpu,
        renderer: &Renderer,
        camera: &Camera,
        curved: Option<&CurvedReflections>,
    ) {
        let pitch = splats::pixel_tangent(camera.fov_y, self.height);
        // M's size: what the mirrored view is drawn and its splats sized for.
        let (map_width, map_height) = (self.width * self.factor, self.height * self.factor);
        let frame_vp = self.frame_view_proj(camera);
        let frame = self
            .loader
            .as_ref()
            .map_or(0, |l| l.frame.fetch_add(1, Ordering::Relaxed) + 1);
        for (slot, r) in self.reflectors.iter().enumerate() {
            let mirrored = mirror_camera(camera, &r.reflector.plane);
            let seen = self.visible(r, camera);
            if seen {
                // The curved reflectors and the terminal ones seen in this mirror.
                for c in curved.into_iter().chain(self.terminal.as_ref()) {
                    let view = MirroredView {
                        camera: &mirrored,
                        width: map_width,
                        height: map_height,
                        clip: self.clip_plane(r),
                        supersampled: self.factor > 1,
                    };
                    c.prepare_mirror(gpu, renderer, slot, &view);
                }
            }
            let u = renderer.uniforms(&mirrored, map_width, map_height);
            gpu.queue
                .write_buffer(&r.mirror_uniforms, 0, bytemuck::bytes_of(&u));
            let mut p =
                ReflectParams::with_filter(&r.reflector, &r.filter, self.clip, camera.position);
            // Screen pixels per kernel texel at beyond-fraction 1 (scaled per pixel).
            let texel = texel_pixels(r.reflector.kernel.texel_angle, 1.0, pitch);
            p.kernel[0] = texel;
            // Image mode: M's uncovered texels are holes to fill, not empty reflections.
            p.kernel[2] = if matches!(self.source, Source::Image { .. }) {
                1.0
            } else {
                0.0
            };
            gpu.queue.write_buffer(&r.params, 0, bytemuck::bytes_of(&p));
            if seen
                && self.exact.is_some()
                && let Ok(mut ranges) = r.exact_ranges.lock()
            {
                let planes = splats::frustum_planes(&Mat4::from_cols_array_2d(&u.view_proj));
                let clip = self.clip_plane(r);
                ranges.clear();
                for (k, b) in self.exact_clusters.iter().enumerate() {
                    // Wholly behind the clip plane: every fragment would be discarded.
                    let far = Vec3::select(clip.truncate().cmpge(Vec3::ZERO), b.max, b.min);
                    if clip.truncate().dot(far) < clip.w - 1e-3 * self.clip
                        || splats::box_outside(&planes, b.min, b.max)
                    {
                        continue;
                    }
                    let (start, end) = (
                        (3 * k * EXACT_CLUSTER) as u32,
                        (3 * ((k + 1) * EXACT_CLUSTER)) as u32,
                    );
                    match ranges.last_mut() {
                        Some(last) if last.end == start => last.end = end,
                        _ => ranges.push(start..end),
                    }
                }
            }
            let Some(loader) = &self.loader else {
                continue;
            };
            let Ok(mut resident) = r.resident.lock() else {
                continue;
            };
            if seen {
                resident.seen = frame;
                if resident.maps.is_none() {
                    match self.load_maps(gpu, loader, r) {
                        Ok(maps) => resident.maps = Some(maps),
                        Err(e) => log::error!(
                            "reflector {}: its radiance maps: {e}; drawn without them",
                            r.reflector.name
                        ),
                    }
                }
            }
            if let (Source::Image { selection, count }, Some(maps)) =
                (self.source, resident.maps.as_ref())
                && seen
            {
                // The detail of M the composite keeps at a reflected point: its filter's
                // sharpest footprint at the point's beyond fraction, in M's texels.
                let eye_side = signed_distance(&r.reflector.plane, camera.position);
                let detail = |q: Vec3| {
                    let f = beyond_fraction(signed_distance(&r.reflector.plane, q), eye_side);
                    detail_pixels(&r.filter, texel * f) * self.factor as f32
                };
                // Each map's nodes are culled to its element's window on screen, grown by
                // the filter's reach and the gap fill's.
                let margin = p.reach_pixels() + WINDOW_MARGIN;
                let cull = splats::Cull {
                    mirrored: Mat4::from_cols_array_2d(&u.view_proj),
                    frame: frame_vp,
                    margin: Vec2::new(
                        2.0 * margin / self.width.max(1) as f32,
                        2.0 * margin / self.height.max(1) as f32,
                    ),
                };
                maps.plan(
                    gpu,
                    &mirrored,
                    &cull,
                    mirror_point(&r.reflector.plane, camera.position),
                    selection,
                    count,
                    map_width,
                    map_height,
                    &detail,
                );
            } else if let Some(maps) = &resident.maps
                && let Ok(mut plan) = maps.plan.lock()
            {
                // Not seen: no splats drawn this frame (the stats say so).
                plan.0.iter_mut().for_each(|c| *c = 0);
                plan.1 = FrameStats::default();
            }
        }
        if let Some(loader) = &self.loader {
            self.evict(loader, frame);
        }
    }

    /// Records, after the scene pass into `color`/`depth` (depth stored), each visible
    /// reflector's mirror pass and composite. Reflectors seen from behind are skipped. With
    /// `curved` (prepared by [`GeometryReflections::prepare`] with the same passes), the mirror
    /// passes also draw the curved reflectors' specular term in the mirrored view, so a curved
    /// reflector seen in a planar mirror is not kd·D alone: geometry mode over its scene pass,
    /// image mode over the curved reflectors' kd·D it draws after the splats
    /// ([`super::exact`]).
    pub fn draw(
        &self,
        encoder: &mut wgpu::CommandEncoder,
        renderer: &Renderer,
        camera: &Camera,
        color: &wgpu::TextureView,
        depth: &wgpu::TextureView,
        curved: Option<&CurvedReflections>,
    ) {
        let visible: Vec<(usize, &ReflectorGpu)> = self
            .reflectors
            .iter()
            .enumerate()
            .filter(|(_, r)| self.visible(r, camera))
            .collect();
        let skipped = self.skipped_passes();
        for &(slot, r) in &visible {
            if !skipped.mirror {
                let mut pass = self.map.begin_mirror(encoder, "glint mirror pass", false);
                let resident = r.resident.lock().ok();
                let maps = resident.as_ref().and_then(|res| res.maps.as_ref());
                match self.source {
                    Source::Image { .. } => {
                        pass.set_bind_group(0, &r.mirror_frame_group, &[]);
                        // Every kept splat of a chunk in one draw: 6 vertices (two
                        // triangles) each.
                        if let Some(maps) = maps
                            && let Ok(plan) = maps.plan.lock()
                        {
                            pass.set_pipeline(&self.splat_pipeline);
                            for (chunk, &count) in maps.chunks.iter().zip(&plan.0) {
                                if count > 0 {
                                    pass.set_bind_group(1, chunk.group.as_ref(), &[]);
                                    pass.draw(0..6 * count, 0..1);
                                }
                            }
                        }
                        // The surfaces the splats left out, exact to the pixel: kd·D and
                        // emission, then the curved reflectors' specular term and the
                        // near-mirrors' (terminal cube maps).
                        if let Some((indices, count)) = &self.exact {
                            pass.set_pipeline(&self.mirror_pipeline);
                            pass.set_bind_group(1, &r.mirror_params_group, &[]);
                            pass.set_vertex_buffer(0, renderer.vertex_buffer().slice(..));
                            pass.set_index_buffer(indices.slice(..), wgpu::IndexFormat::Uint32);
                            if let Ok(ranges) = r.exact_ranges.lock() {
                                for range in ranges.iter() {
                                    pass.draw_indexed(range.start..range.end.min(*count), 0, 0..1);
                                }
                            }
                            if let Some(c) = curved {
                                c.draw_mirror(&mut pass, slot);
                            }
                            self.draw_terminal(&mut pass, slot, camera);
                        }
                    }
                    Source::Geometry => {
                        pass.set_pipeline(&self.mirror_pipeline);
                        pass.set_bind_group(0, &r.mirror_frame_group, &[]);
                        pass.set_bind_group(1, &r.mirror_params_group, &[]);
                        pass.set_vertex_buffer(0, renderer.vertex_buffer().slice(..));
                        pass.set_index_buffer(
                            renderer.index_buffer().slice(..),
                            wgpu::IndexFormat::Uint32,
                        );
                        renderer.draw_opaque(&mut pass);
                        if let (Some(c), Source::Geometry) = (curved, self.source) {
                            c.draw_mirror(&mut pass, slot);
                        }
                        self.draw_terminal(&mut pass, slot, camera);
                        if let Some(g) = &self.glass {
                            g.draw(
                                &mut pass,
                                renderer,
                                &r.mirror_frame_group,
                                &r.mirror_params_group,
                            );
                        }
                    }
                }
            }
            if let Some(d) = &self.downsample {
                d.record(encoder);
            }
            if let Some(g) = self.gap_fill.as_ref().filter(|_| !skipped.gap_fill) {
                g.record(encoder);
            }
            if !skipped.pyramid {
                self.pyramid_passes.record(
                    encoder,
                    &self.pyramid,
                    matches!(self.source, Source::Image { .. }),
                );
            }
            if skipped.composite {
                continue;
            }
            let mut pass =
                self.composite
                    .begin(encoder, "glint reflection composite pass", color, depth);
            pass.set_bind_group(1, &r.composite_params_group, &[]);
            pass.set_vertex_buffer(0, renderer.vertex_buffer().slice(..));
            pass.set_index_buffer(r.indices.slice(..), wgpu::IndexFormat::Uint32);
            pass.draw_indexed(0..r.index_count, 0, 0..1);
        }
    }
}

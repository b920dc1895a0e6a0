//! The probe pass on the GPU: per glossy group its triangles, its parameters and the cube
//! maps of the probe it reads; drawn over the finished scene through a `Composite`
//! (`view::passes::composite`).

use glam::Vec3;

use super::{Normalization, ProbeParams, irradiance_sh, shader_source};
use crate::materials::MaterialsIndex;
use crate::materials::envmap::MipPyramid;
use crate::materials::probes::{Probe, assign, lobe_lod, scene_groups};
use crate::materials::reflectance::map_1d_cos;
use crate::view::curved::gpu::{CubeTexture, CurvedVertex, reflector_vertices};
use crate::view::gpu::build::{bind_group_layout, buffer_init, render_pipeline, shader};
use crate::view::gpu::{Gpu, RenderError, error_scoped};
use crate::view::load::ViewData;
use crate::view::options::ReflectanceSettings;
use crate::view::passes::composite::Composite;
use crate::view::passes::renderer::sides;
use crate::view::passes::renderer::{Renderer, frame_bind_group_layout};
use crate::view::reflections::material::{MODULATION_SIZE, ReflectanceLayout, load_material};

/// Where a corner of a group's triangle reads its lightmap: `@location(2..=3)` of
/// `ProbeVertexIn`, in a second vertex buffer beside its [`CurvedVertex`].
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, bytemuck::Pod, bytemuck::Zeroable)]
pub struct ProbeLightmap {
    /// Lightmap coordinates in texels of the page.
    pub lightmap: [f32; 2],
    /// Atlas page (texture-array layer).
    pub page: u32,
}

const LIGHTMAP_ATTRIBUTES: [wgpu::VertexAttribute; 2] =
    wgpu::vertex_attr_array![2 => Float32x2, 3 => Uint32];

impl ProbeLightmap {
    /// The vertex buffer layout of the second buffer.
    pub fn layout() -> wgpu::VertexBufferLayout<'static> {
        wgpu::VertexBufferLayout {
            array_stride: std::mem::size_of::<ProbeLightmap>() as u64,
            step_mode: wgpu::VertexStepMode::Vertex,
            attributes: &LIGHTMAP_ATTRIBUTES,
        }
    }

    /// Per corner of `triangles`, in [`reflector_vertices`]' order, its place in `atlas`.
    pub fn of(atlas: &crate::radiosity::atlas::Atlas, triangles: &[u32]) -> Vec<ProbeLightmap> {
        triangles
            .iter()
            .flat_map(|&t| {
                let (page, coords) = (atlas.tri_page[t as usize], atlas.tri_coords[t as usize]);
                coords.into_iter().map(move |c| ProbeLightmap {
                    lightmap: c.to_array(),
                    page,
                })
            })
            .collect()
    }
}

/// One glossy group as the pass draws it.
struct GroupGpu {
    vertices: wgpu::Buffer,
    lightmap: wgpu::Buffer,
    vertex_count: u32,
    /// Its parameters (static: the eye comes from the frame's uniforms) and textures.
    group: wgpu::BindGroup,
}

/// What the probe pass draws, for tests and the startup line.
#[derive(Clone, Debug, PartialEq)]
pub struct ProbeUse {
    /// The group's material.
    pub material: String,
    /// The probe it reads.
    pub probe: String,
    /// The MIP level of its lobe.
    pub lod: f32,
}

/// The probe pass of one [`Renderer`].
pub struct ProbeReflections {
    composite: Composite,
    groups: Vec<GroupGpu>,
    uses: Vec<ProbeUse>,
    /// Per probe: its radiance pyramid and distances on the GPU (kept alive for the groups).
    _cubes: Vec<(CubeTexture, CubeTexture)>,
}

impl ProbeReflections {
    /// The pass for `renderer` drawing `data`'s glossy groups with the probes its materials
    /// stage holds, R read as `reflectance` says (its channel; the 1D map, or the sphere
    /// map's 1D form for anisotropic lobes), each lobe widened by the pixel's spread of
    /// normals where `specular_aa`. `Ok(None)` when the bundle has no probes.
    pub fn new(
        gpu: &Gpu,
        renderer: &Renderer,
        data: &ViewData,
        reflectance: ReflectanceSettings,
        specular_aa: bool,
    ) -> Result<Option<ProbeReflections>, RenderError> {
        let err = |e: String| RenderError::Reflections(format!("reflection probes: {e}"));
        let Some(index) = MaterialsIndex::load(&data.bundle).map_err(|e| err(e.to_string()))?
        else {
            return Ok(None);
        };
        if index.probes.is_empty() {
            return Ok(None);
        }
        let probes: Vec<Probe> = index
            .probes
            .iter()
            .map(|p| Probe {
                name: p.name.clone(),
                position: Vec3::from_array(p.centre),
                radius: p.radius,
            })
            .collect();
        let mut read = Vec::new();
        for k in 0..probes.len() {
            read.push(
                index
                    .read_probe(&data.bundle, k)
                    .map_err(|e| err(e.to_string()))?,
            );
        }
        let scene = &data.scene;
        let device = &gpu.device;
        let mut cubes = Vec::new();
        for (pyramid, distances) in &read {
            let env = CubeTexture::from_pyramid(gpu, pyramid)?;
            let dist = CubeTexture::from_pyramid(
                gpu,
                &MipPyramid {
                    filter: pyramid.filter,
                    levels: vec![distances.clone()],
                },
            )?;
            cubes.push((env, dist));
        }
        // Each probe's irradiance, for the normalization of its light (`Normalization`).
        let irradiance: Vec<[f32; 9]> = read
            .iter()
            .map(|(pyramid, _)| irradiance_sh(&pyramid.levels[0]))
            .collect();
        let mut lit = Vec::new();
        let groups = scene_groups(scene);
        for (k, g) in groups.iter().enumerate() {
            let Some(p) = assign(&probes, &groups, k) else {
                continue;
            };
            let material = &scene.materials[g.material as usize];
            let modulation =
                modulation_table(data, &index, &material.name, reflectance).map_err(err)?;
            // The strongest lobe's roughness picks the level (its footprint on the cube).
            let lobe = material
                .lobes
                .iter()
                .max_by(|a, b| {
                    let w = |l: &crate::scene::desc::LobeDesc| l.ks.iter().sum::<f32>();
                    w(a).total_cmp(&w(b))
                })
                .expect("glossy groups have lobes");
            let alpha = (lobe.mx * lobe.my).sqrt();
            let lod = lobe_lod(alpha, read[p].0.base_size() as u32)
                .min((read[p].0.levels.len() - 1) as f32);
            lit.push((g.clone(), p, modulation, lod, [alpha, lobe.r0]));
        }
        let shader_text = shader_source();
        let built = error_scoped(device, "creating the probe pass", || {
            let shader = shader(device, "glint probe shader", &shader_text);
            let frame_layout = frame_bind_group_layout(device);
            let stages = wgpu::ShaderStages::FRAGMENT;
            let layout = bind_group_layout()
                .uniform::<ProbeParams>(20, wgpu::ShaderStages::FRAGMENT)
                .texture(21, stages, wgpu::TextureViewDimension::Cube, true)
                .texture(22, stages, wgpu::TextureViewDimension::Cube, true)
                .sampler(23, stages)
                .build(device, "glint probe layout");
            let sampler = device.create_sampler(&wgpu::SamplerDescriptor {
                label: Some("glint probe sampler"),
                address_mode_u: wgpu::AddressMode::ClampToEdge,
                address_mode_v: wgpu::AddressMode::ClampToEdge,
                address_mode_w: wgpu::AddressMode::ClampToEdge,
                mag_filter: wgpu::FilterMode::Linear,
                min_filter: wgpu::FilterMode::Linear,
                mipmap_filter: wgpu::MipmapFilterMode::Linear,
                ..Default::default()
            });
            let composite = Composite::new(
                device,
                renderer,
                &frame_layout,
                render_pipeline("glint probe composite", &shader, "vs_probe", "fs_probe")
                    .layouts(&[&frame_layout, &layout])
                    .vertex(CurvedVertex::layout())
                    .vertex(ProbeLightmap::layout()),
            );
            let mut uses = Vec::new();
            let groups: Vec<GroupGpu> = lit
                .iter()
                .map(|(g, p, modulation, lod, [alpha, r0])| {
                    let verts = reflector_vertices(scene, &g.triangles);
                    let vertices = buffer_init(
                        gpu,
                        "glint probe vertices",
                        wgpu::BufferUsages::VERTEX,
                        bytemuck::cast_slice(&verts),
                        16,
                    );
                    let lightmap = buffer_init(
                        gpu,
                        "glint probe lightmap coordinates",
                        wgpu::BufferUsages::VERTEX,
                        bytemuck::cast_slice(&ProbeLightmap::of(&data.map.atlas, &g.triangles)),
                        16,
                    );
                    let material = &scene.materials[g.material as usize];
                    let normalization = Normalization::of(material);
                    let sh = &irradiance[*p];
                    let mut base = ProbeParams {
                        centre: probes[*p].position.extend(1.0).to_array(),
                        info: [
                            *lod,
                            sides(&scene.materials[g.material as usize]),
                            *alpha,
                            *r0,
                        ],
                        surface: [
                            normalization.albedo,
                            normalization.emission,
                            f32::from(u8::from(specular_aa)),
                            0.0,
                        ],
                        irradiance: [
                            [sh[0], sh[1], sh[2], sh[3]],
                            [sh[4], sh[5], sh[6], sh[7]],
                            [sh[8], 0.0, 0.0, 0.0],
                        ],
                        modulation: [[0.0; 4]; MODULATION_SIZE],
                    };
                    for (m, v) in base.modulation.iter_mut().zip(modulation) {
                        *m = v.extend(0.0).to_array();
                    }
                    let params = buffer_init(
                        gpu,
                        "glint probe parameters",
                        wgpu::BufferUsages::UNIFORM,
                        bytemuck::bytes_of(&base),
                        16,
                    );
                    let (env, dist) = &cubes[*p];
                    let group = device.create_bind_group(&wgpu::BindGroupDescriptor {
                        label: Some("glint probe group"),
                        layout: &layout,
                        entries: &[
                            wgpu::BindGroupEntry {
                                binding: 20,
                                resource: params.as_entire_binding(),
                            },
                            wgpu::BindGroupEntry {
                                binding: 21,
                                resource: wgpu::BindingResource::TextureView(&env.cube),
                            },
                            wgpu::BindGroupEntry {
                                binding: 22,
                                resource: wgpu::BindingResource::TextureView(&dist.cube),
                            },
                            wgpu::BindGroupEntry {
                                binding: 23,
                                resource: wgpu::BindingResource::Sampler(&sampler),
                            },
                        ],
                    });
                    uses.push(ProbeUse {
                        material: scene.materials[g.material as usize].name.clone(),
                        probe: probes[*p].name.clone(),
                        lod: *lod,
                    });
                    GroupGpu {
                        vertices,
                        lightmap,
                        vertex_count: verts.len() as u32,
                        group,
                    }
                })
                .collect();
            (composite, groups, uses)
        })?;
        let (composite, groups, uses) = built;
        Ok(Some(ProbeReflections {
            composite,
            groups,
            uses,
            _cubes: cubes,
        }))
    }

    /// Which probe each glossy group reads, at which level.
    pub fn uses(&self) -> &[ProbeUse] {
        &self.uses
    }

    /// Records, after the scene pass into `color`/`depth` (depth stored), the groups'
    /// specular term, depth-tested against the scene, added to kd·D.
    pub fn draw(
        &self,
        encoder: &mut wgpu::CommandEncoder,
        color: &wgpu::TextureView,
        depth: &wgpu::TextureView,
    ) {
        if self.groups.is_empty() {
            return;
        }
        let mut pass = self
            .composite
            .begin(encoder, "glint probe composite pass", color, depth);
        for g in &self.groups {
            pass.set_bind_group(1, &g.group, &[]);
            pass.set_vertex_buffer(0, g.vertices.slice(..));
            pass.set_vertex_buffer(1, g.lightmap.slice(..));
            pass.draw(0..g.vertex_count, 0..1);
        }
    }
}

/// ks·(R's channel) of material `name` at the 1D map's cosines, from the materials stage: the
/// 1D map, else (anisotropic lobes) the sphere map read in the plane of incidence.
fn modulation_table(
    data: &ViewData,
    index: &MaterialsIndex,
    name: &str,
    reflectance: ReflectanceSettings,
) -> Result<Vec<Vec3>, String> {
    let one_d = load_material(
        &data.bundle,
        index,
        name,
        ReflectanceLayout::OneD,
        reflectance.channel,
    );
    let (_, m) = match one_d {
        Ok(m) => m,
        Err(_) => load_material(
            &data.bundle,
            index,
            name,
            ReflectanceLayout::Sphere,
            reflectance.channel,
        )?,
    };
    let table = m.table_1d();
    debug_assert_eq!(table.len(), MODULATION_SIZE);
    debug_assert!(map_1d_cos(0, MODULATION_SIZE as u32) > 0.0);
    Ok(table)
}

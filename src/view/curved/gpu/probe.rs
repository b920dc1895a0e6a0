//! Compute probes of the curved shader, for tests: the live cube map as the composite reads
//! it, and the glossy term against a given environment.

use glam::{Vec2, Vec3};

use super::super::{CurvedParams, CurvedReflector, pack_patterns, shader_source};
use super::layout::{curved_group, curved_layout, trilinear_sampler};
use super::{CubeTexture, CurvedReflections, MIN_BUFFER, OWN_MIN_BUFFER};
use crate::materials::envmap::MipPyramid;
use crate::radiosity::RadiosityMap;
use crate::radiosity::atlas::{Atlas, PageSize};
use crate::view::gpu::RenderError;
use crate::view::gpu::build::{buffer_init, compute_pipeline, shader};
use crate::view::gpu::probe::{probe_frame_group, probe_io_layout, run_probe};
use crate::view::gpu::radiosity_textures::RadiosityTextures;
use crate::view::gpu::{Gpu, error_scoped};
use crate::view::passes::renderer::frame_bind_group_layout;

/// A ray's hit with a reflector itself: (t, the scene triangle, barycentrics).
pub type SceneHit = (f32, u32, Vec2);

impl CurvedReflections {
    /// The live cube map of reflector `index` (final generation) sampled at `dirs` (xyz,
    /// w = MIP level), in a compute pass: what the composite reads. For tests.
    pub fn probe_live_map(
        &self,
        gpu: &Gpu,
        index: usize,
        dirs: &[[f32; 4]],
    ) -> Result<Vec<Vec3>, RenderError> {
        let texels = self.probe_live_texels(gpu, index, dirs)?;
        Ok(texels.iter().map(|v| Vec3::new(v[0], v[1], v[2])).collect())
    }

    /// The distance from the centre of reflector `index`'s live cube map (final generation)
    /// to what it sees at `dirs` (xyz, w = MIP level), as distance-corrected lookups read it
    /// (the map's alpha; 0: nothing seen). For tests.
    pub fn probe_live_distances(
        &self,
        gpu: &Gpu,
        index: usize,
        dirs: &[[f32; 4]],
    ) -> Result<Vec<f32>, RenderError> {
        let texels = self.probe_live_texels(gpu, index, dirs)?;
        Ok(texels.iter().map(|v| v[3]).collect())
    }

    fn probe_live_texels(
        &self,
        gpu: &Gpu,
        index: usize,
        dirs: &[[f32; 4]],
    ) -> Result<Vec<[f32; 4]>, RenderError> {
        let r = &self.reflectors[index];
        let inputs: Vec<[f32; 8]> = dirs
            .iter()
            .map(|d| [d[0], d[1], d[2], d[3], 0.0, 0.0, 0.0, 0.0])
            .collect();
        let map = &self.maps[self.final_set][index].cube;
        curved_probe(
            gpu,
            "cs_env_probe",
            &r.base_params,
            &r.patterns,
            map,
            None,
            &inputs,
        )
    }

    /// The nearest hit of each ray (origin, unit direction, t_min) with reflector `index`'s
    /// own triangles as the shader's `own_closest` finds it, in a compute pass: (t, the
    /// scene triangle, barycentrics), or `None`. Empty when it casts no rays at itself
    /// (`--cube-self-occlusion off`, or a BVH deeper than the shader's stack). For tests
    /// against the CPU's ray casting.
    pub fn probe_own_hits(
        &self,
        gpu: &Gpu,
        index: usize,
        rays: &[(Vec3, Vec3, f32)],
    ) -> Result<Vec<Option<SceneHit>>, RenderError> {
        let r = &self.reflectors[index];
        if r.base_params.centre[3] <= 0.0 {
            return Ok(Vec::new());
        }
        let inputs: Vec<[f32; 8]> = rays
            .iter()
            .map(|(o, d, t_min)| [o.x, o.y, o.z, *t_min, d.x, d.y, d.z, 0.0])
            .collect();
        let map = &self.maps[self.final_set][index].cube;
        let out = curved_probe(
            gpu,
            "cs_own_probe",
            &r.base_params,
            &r.patterns,
            map,
            Some((&r.own_nodes, &r.own_tris)),
            &inputs,
        )?;
        Ok(out
            .iter()
            .map(|v| (v[0] >= 0.0).then(|| (v[0], v[1].to_bits(), Vec2::new(v[2], v[3]))))
            .collect())
    }
}

/// Runs `entry` (`cs_glossy_probe`, `cs_env_probe` or `cs_own_probe`) of
/// `shaders/curved.wgsl` over `inputs` (normal, direction or ray origin xyzw, ω_o or ray
/// direction xyzw) with `params`, `patterns`, environment `env` (also bound as the distances,
/// which `params` leave unread unless `info.w` is 1) and the reflector's own BVH nodes and
/// triangles (stand-ins when `None`; `params` leave them unread unless `centre.w` > 0). Group
/// 0 holds a 1-texel D of 0 (a self-hit's D is not what these probes test).
fn curved_probe(
    gpu: &Gpu,
    entry: &'static str,
    params: &CurvedParams,
    patterns: &wgpu::Buffer,
    env: &wgpu::TextureView,
    own: Option<(&wgpu::Buffer, &wgpu::Buffer)>,
    inputs: &[[f32; 8]],
) -> Result<Vec<[f32; 4]>, RenderError> {
    if inputs.is_empty() {
        return Ok(Vec::new());
    }
    let device = &gpu.device;
    let blank = RadiosityMap {
        atlas: Atlas {
            texel_density: 1.0,
            pages: vec![PageSize {
                width: 1,
                height: 1,
            }],
            tri_page: Vec::new(),
            tri_coords: Vec::new(),
            texel_chart: Vec::new(),
            charts: 0,
            from_uv1: false,
            backs: Vec::new(),
        },
        pages: vec![vec![Vec3::ZERO]],
    };
    let textures = RadiosityTextures::upload(gpu, &blank)?;
    let (pipeline, probe_layout, group0, group1) =
        error_scoped(device, "creating a curved-shader probe", || {
            let shader = shader(device, "glint curved probe", &shader_source());
            let frame_layout = frame_bind_group_layout(device);
            let curved_layout = curved_layout(device);
            let probe_layout = probe_io_layout(device, "glint curved probe layout");
            let pipeline = compute_pipeline(
                device,
                "glint curved probe",
                &shader,
                &[
                    Some(&frame_layout),
                    Some(&curved_layout),
                    Some(&probe_layout),
                ],
                entry,
            );
            let sampler = trilinear_sampler(device);
            let params = buffer_init(
                gpu,
                "glint probe params",
                wgpu::BufferUsages::UNIFORM,
                bytemuck::bytes_of(params),
                MIN_BUFFER,
            );
            let stand_in = own.is_none().then(|| {
                buffer_init(
                    gpu,
                    "glint own stand-in",
                    wgpu::BufferUsages::STORAGE,
                    &[0; OWN_MIN_BUFFER as usize],
                    OWN_MIN_BUFFER,
                )
            });
            let own = own.unwrap_or_else(|| {
                let b = stand_in.as_ref().expect("made when there is no own mesh");
                (b, b)
            });
            let group1 = curved_group(
                device,
                &curved_layout,
                &params,
                patterns,
                env,
                &sampler,
                env,
                own,
            );
            let group0 = probe_frame_group(gpu, &frame_layout, &textures);
            (pipeline, probe_layout, group0, group1)
        })?;
    let bytes = run_probe(
        gpu,
        "running a curved-shader probe",
        &pipeline,
        &probe_layout,
        2,
        &[(0, &group0), (1, &group1)],
        bytemuck::cast_slice(inputs),
        inputs.len(),
        (inputs.len() * 16) as u64,
    )?;
    Ok(bytemuck::cast_slice::<u8, [f32; 4]>(&bytes).to_vec())
}

/// The shader's specular term of `reflector` (its lobes; regular sampling with `patterns`
/// when given, else the mirror lookup) against the environment `pyramid`, at each
/// (world normal, ω_o towards the eye) of `inputs`: what `fs_curved` computes, in a compute
/// pass. For tests against [`crate::materials::envmap::specular_regular`].
pub fn glossy_probe(
    gpu: &Gpu,
    reflector: &CurvedReflector,
    patterns: Option<&[crate::brdf::pattern::Pattern]>,
    pyramid: &MipPyramid,
    inputs: &[(Vec3, Vec3)],
) -> Result<Vec<Vec3>, RenderError> {
    let env = CubeTexture::from_pyramid(gpu, pyramid)?;
    let (packed, offsets) = pack_patterns(patterns.unwrap_or_default());
    let pattern_buffer = buffer_init(
        gpu,
        "glint probe patterns",
        wgpu::BufferUsages::STORAGE,
        bytemuck::cast_slice(&packed),
        MIN_BUFFER,
    );
    let params = CurvedParams::new(
        reflector,
        patterns.map(|p| (p, offsets.as_slice())),
        Vec3::ZERO,
        env.size,
    );
    let inputs: Vec<[f32; 8]> = inputs
        .iter()
        .map(|(n, wo)| [n.x, n.y, n.z, 0.0, wo.x, wo.y, wo.z, 0.0])
        .collect();
    let out = curved_probe(
        gpu,
        "cs_glossy_probe",
        &params,
        &pattern_buffer,
        &env.cube,
        None,
        &inputs,
    )?;
    Ok(out.iter().map(|v| Vec3::new(v[0], v[1], v[2])).collect())
}

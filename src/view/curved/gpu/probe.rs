//! Compute probes of the curved shader, for tests: the live cube map as the composite reads
//! it, and the glossy term against a given environment.

use glam::Vec3;

use super::super::{CurvedParams, CurvedReflector, pack_patterns, shader_source};
use super::layout::{curved_group, curved_layout, trilinear_sampler};
use super::{CubeTexture, CurvedReflections, MIN_BUFFER};
use crate::materials::envmap::MipPyramid;
use crate::view::build::{bind_group_layout, buffer_init, compute_pipeline, shader};
use crate::view::gpu::{Gpu, error_scoped};
use crate::view::probe::{probe_io_layout, run_probe};
use crate::view::renderer::RenderError;

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
            &inputs,
        )
    }
}

/// Runs `entry` (`cs_glossy_probe` or `cs_env_probe`) of `shaders/curved.wgsl` over `inputs`
/// (normal or direction xyzw, ω_o xyzw) with `params`, `patterns` and environment `env` (also
/// bound as the distances, which `params` leave unread unless `info.w` is 1).
fn curved_probe(
    gpu: &Gpu,
    entry: &'static str,
    params: &CurvedParams,
    patterns: &wgpu::Buffer,
    env: &wgpu::TextureView,
    inputs: &[[f32; 8]],
) -> Result<Vec<[f32; 4]>, RenderError> {
    if inputs.is_empty() {
        return Ok(Vec::new());
    }
    let device = &gpu.device;
    let (pipeline, probe_layout, group0, group1) =
        error_scoped(device, "creating a curved-shader probe", || {
            let shader = shader(device, "glint curved probe", &shader_source());
            let curved_layout = curved_layout(device);
            let probe_layout = probe_io_layout(device, "glint curved probe layout");
            let empty = bind_group_layout().build(device, "glint empty layout");
            let pipeline = compute_pipeline(
                device,
                "glint curved probe",
                &shader,
                &[Some(&empty), Some(&curved_layout), Some(&probe_layout)],
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
            let group1 = curved_group(
                device,
                &curved_layout,
                &params,
                patterns,
                env,
                &sampler,
                env,
                (env, env),
            );
            let group0 = device.create_bind_group(&wgpu::BindGroupDescriptor {
                label: Some("glint empty group"),
                layout: &empty,
                entries: &[],
            });
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
        &inputs,
    )?;
    Ok(out.iter().map(|v| Vec3::new(v[0], v[1], v[2])).collect())
}

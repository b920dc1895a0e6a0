//! The planar reflection shader's per-reflector inputs (group 1 of `shaders/reflect.wgsl`),
//! read by the single-level passes ([`super::passes`]) and the recursive ones alike:
//! [`ReflectParams`], R's sphere map, the bind-group layouts and the composite's group.

use bytemuck::{Pod, Zeroable};
use glam::Vec3;

use super::PlanarReflector;
use super::filter::{FILTER_RINGS, FilterTap, MAX_FILTER_TAPS, filter_taps};
use super::lobe_shape::SHAPE_SIZE;
use super::material::{MODULATION_SIZE, Modulation};
use crate::materials::reflectance;
use crate::view::gpu::Gpu;
use crate::view::gpu::build::{LayoutBuilder, bind_group_layout, render_pipeline};
use crate::view::gpu::target::texture_2d;
use crate::view::passes::composite::Composite;
use crate::view::passes::renderer::{Renderer, scene_vertex_layout};

/// The parent clip of a composite that clips nothing ([`ReflectParams::parent`]).
pub const NO_PARENT_CLIP: [f32; 4] = [0.0, 0.0, 0.0, -1.0];

/// Mirrors `ReflectParams` in `shaders/reflect.wgsl` (2432 bytes).
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
    /// x: screen pixels per kernel texel at beyond-fraction 1 (per frame); y: filter tap count;
    /// z: 1 to fill M's texels no splat covered (image mode, [`super::splats::fill_hole`]).
    pub kernel: [f32; 4],
    /// The composite's clip: in a recursive map, the parent mirror's plane (normal xyz,
    /// w = normal · point + clip distance), fragments p with xyz · p ≤ w discarded;
    /// `NO_PARENT_CLIP` for a composite into the frame.
    pub parent: [f32; 4],
    /// ks·R at the 1D map's cosines (rgb; a unused).
    pub modulation: [[f32; 4]; MODULATION_SIZE],
    /// M*K's filter taps ([`super::filter::filter_taps`]): offset in kernel texels (x right,
    /// y up), weight, per-axis variance (kernel texels²).
    pub taps: [[f32; 4]; MAX_FILTER_TAPS],
    /// K's shape per view cosine k / (SHAPE_SIZE − 1) ([`super::lobe_shape`]): x its lean in
    /// kernel texels, y its scale along the plane of incidence, z across it.
    pub shape: [[f32; 4]; SHAPE_SIZE],
}

impl ReflectParams {
    /// How far from a reflector pixel, in screen pixels, the composite's filter reads M at
    /// most (at beyond fraction 1, the widest): each tap's offset plus three of its standard
    /// deviations, scaled by the lobe's widest shape, plus its largest lean. 0 for a mirror.
    pub fn reach_pixels(&self) -> f32 {
        let taps = (self.kernel[1] as usize).min(MAX_FILTER_TAPS);
        let extent = self.taps[..taps]
            .iter()
            .map(|t| (t[0] * t[0] + t[1] * t[1]).sqrt() + 3.0 * t[3].max(0.0).sqrt())
            .fold(0.0f32, f32::max);
        let (widest, lean) = self.shape.iter().fold((0.0f32, 0.0f32), |(w, l), s| {
            (w.max(s[1]).max(s[2]), l.max(s[0].abs()))
        });
        self.kernel[0] * (extent * widest + lean)
    }

    /// The parameters of `reflector` with clip distance `clip`, seen from `eye` (kernel
    /// scale 0 until [`super::GeometryReflections::prepare`] sets it).
    pub fn new(reflector: &PlanarReflector, clip: f32, eye: Vec3) -> ReflectParams {
        let filter = filter_taps(&reflector.kernel.taps, FILTER_RINGS);
        Self::with_filter(reflector, &filter, clip, eye)
    }

    /// [`ReflectParams::new`] with the reflector's M*K filter already gathered
    /// ([`filter_taps`] of its kernel, [`FILTER_RINGS`]).
    pub fn with_filter(
        reflector: &PlanarReflector,
        filter: &[FilterTap],
        clip: f32,
        eye: Vec3,
    ) -> ReflectParams {
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
        let mut taps = [[0.0; 4]; MAX_FILTER_TAPS];
        for (t, k) in taps.iter_mut().zip(filter) {
            *t = [k.offset.x, k.offset.y, k.weight, k.variance];
        }
        let mut shape = [[0.0; 4]; SHAPE_SIZE];
        let texel = reflector.kernel.texel_angle;
        for (s, k) in shape.iter_mut().zip(&reflector.kernel.shape.table) {
            let lean = if texel > 0.0 { k.lean / texel } else { 0.0 };
            *s = [lean, k.along, k.across, 0.0];
        }
        ReflectParams {
            plane: n.extend(n.dot(reflector.plane.point)).to_array(),
            ks: reflector.ks.extend(clip).to_array(),
            eye: eye.extend(reflectance::C_GRAZING).to_array(),
            tangent: reflector.tangent.extend(sphere.0).to_array(),
            bitangent: reflector.bitangent.extend(sphere.1).to_array(),
            kernel: [0.0, filter.len().min(MAX_FILTER_TAPS) as f32, 0.0, 0.0],
            parent: NO_PARENT_CLIP,
            modulation,
            taps,
            shape,
        }
    }
}

/// The full WGSL module of the reflection passes.
pub fn shader_source() -> String {
    format!(
        "{}\n{}",
        crate::view::passes::renderer::SHADER_SOURCE,
        super::REFLECT_SHADER_SOURCE
    )
}

/// R's sphere map as a texture (a 1×1 placeholder for the 1D map).
pub(super) fn sphere_texture(gpu: &Gpu, modulation: &Modulation) -> wgpu::Texture {
    let (size, texels) = match modulation {
        Modulation::Sphere { size, texels } => (*size, texels.clone()),
        Modulation::OneD(_) => (1, vec![Vec3::ZERO]),
    };
    let texture = texture_2d(
        &gpu.device,
        "glint reflectance sphere map",
        size,
        size,
        wgpu::TextureFormat::Rgba32Float,
        wgpu::TextureUsages::TEXTURE_BINDING | wgpu::TextureUsages::COPY_DST,
    );
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

/// A layout with the `ReflectParams` uniform (binding 2) every reflection pass reads.
pub(super) fn params_layout() -> LayoutBuilder {
    bind_group_layout()
        .uniform::<ReflectParams>(2, wgpu::ShaderStages::VERTEX | wgpu::ShaderStages::FRAGMENT)
}

/// The composite's bindings: params, the reflected image M (filterable), the trilinear
/// sampler, the sphere-map R (read by texel) and M's pyramid ([`super::pyramid`]).
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
        .texture(7, fragment, d2, true)
        .build(device, label)
}

/// The composite of a planar reflector's map M into `renderer`'s frame (`fs_composite_frame`
/// of `shader`, over the reflector's scene triangles): group 0 `frame_layout`, group 1
/// `composite_layout` ([`composite_bind_group_layout`]).
pub(super) fn planar_composite(
    device: &wgpu::Device,
    renderer: &Renderer,
    label: &str,
    shader: &wgpu::ShaderModule,
    frame_layout: &wgpu::BindGroupLayout,
    composite_layout: &wgpu::BindGroupLayout,
) -> Composite {
    Composite::new(
        device,
        renderer,
        frame_layout,
        render_pipeline(label, shader, "vs_mirror", "fs_composite_frame")
            .layouts(&[frame_layout, composite_layout])
            .vertex(scene_vertex_layout()),
    )
}

/// The composite's group 1 on `layout` ([`composite_bind_group_layout`]): `params`, the
/// reflected image M and its pyramid (`maps`), the `sampler` and R's `sphere` map.
pub(super) fn composite_group(
    device: &wgpu::Device,
    label: &str,
    layout: &wgpu::BindGroupLayout,
    params: &wgpu::Buffer,
    maps: (&wgpu::TextureView, &wgpu::TextureView),
    sampler: &wgpu::Sampler,
    sphere: &wgpu::TextureView,
) -> wgpu::BindGroup {
    let (m, pyramid) = maps;
    device.create_bind_group(&wgpu::BindGroupDescriptor {
        label: Some(label),
        layout,
        entries: &[
            wgpu::BindGroupEntry {
                binding: 2,
                resource: params.as_entire_binding(),
            },
            wgpu::BindGroupEntry {
                binding: 3,
                resource: wgpu::BindingResource::TextureView(m),
            },
            wgpu::BindGroupEntry {
                binding: 4,
                resource: wgpu::BindingResource::Sampler(sampler),
            },
            wgpu::BindGroupEntry {
                binding: 5,
                resource: wgpu::BindingResource::TextureView(sphere),
            },
            wgpu::BindGroupEntry {
                binding: 7,
                resource: wgpu::BindingResource::TextureView(pyramid),
            },
        ],
    })
}

/// The group of the mirror pass on `layout` ([`params_layout`]): `params` alone.
pub(super) fn params_group(
    device: &wgpu::Device,
    label: &str,
    layout: &wgpu::BindGroupLayout,
    params: &wgpu::Buffer,
) -> wgpu::BindGroup {
    device.create_bind_group(&wgpu::BindGroupDescriptor {
        label: Some(label),
        layout,
        entries: &[wgpu::BindGroupEntry {
            binding: 2,
            resource: params.as_entire_binding(),
        }],
    })
}

#[cfg(test)]
mod tests {
    /// The composite's reach: none for a mirror's single centred tap; else the farthest tap's
    /// offset plus three standard deviations, times the widest shape, plus the lean, in
    /// kernel texels, times the pixels a texel spans.
    #[test]
    fn the_reach_is_the_farthest_tap_scaled_by_the_lobes_shape() {
        let mut p: super::ReflectParams = bytemuck::Zeroable::zeroed();
        p.kernel = [12.0, 1.0, 0.0, 0.0];
        p.taps[0] = [0.0, 0.0, 1.0, 0.0];
        p.shape = [[0.0, 1.0, 1.0, 0.0]; super::SHAPE_SIZE];
        assert_eq!(p.reach_pixels(), 0.0);
        p.kernel[1] = 3.0;
        p.taps[1] = [3.0, 4.0, 0.5, 0.25];
        p.taps[2] = [-1.0, 0.0, 0.5, 4.0];
        // Tap 1: 5 + 3·0.5 = 6.5; tap 2: 1 + 3·2 = 7.
        assert!((p.reach_pixels() - 12.0 * 7.0).abs() < 1e-4);
        p.shape[3] = [-0.5, 1.5, 0.75, 0.0];
        assert!((p.reach_pixels() - 12.0 * (7.0 * 1.5 + 0.5)).abs() < 1e-4);
        // Taps past the count are not read.
        p.taps[5] = [100.0, 0.0, 1.0, 0.0];
        assert!((p.reach_pixels() - 12.0 * (7.0 * 1.5 + 0.5)).abs() < 1e-4);
    }

    /// `fs_splat` tells a splat's own extent from its overlap by the Rust constant.
    #[test]
    fn the_splat_shader_uses_the_splat_overlap() {
        let want = format!(
            "const SPLAT_OVERLAP: f32 = {:?};",
            super::super::SPLAT_OVERLAP
        );
        assert!(super::shader_source().contains(&want), "{want}");
    }

    /// `fs_splat` pushes a splat's gap fill back by the Rust constant.
    #[test]
    fn the_splat_shader_uses_the_gap_fill_depth() {
        let want = format!(
            "const GAP_FILL_DEPTH: f32 = {:?};",
            super::super::splats::GAP_FILL_DEPTH
        );
        assert!(super::shader_source().contains(&want), "{want}");
    }

    /// `vs_splat` bounds a splat's footprint by the Rust constants.
    #[test]
    fn the_splat_shader_uses_the_footprint_bounds() {
        use super::super::splats::{MIN_SLANT_COSINE, MIN_SQUEEZE};
        for want in [
            format!("const MIN_SLANT_COSINE: f32 = {MIN_SLANT_COSINE:?};"),
            format!("const MIN_SQUEEZE: f32 = {MIN_SQUEEZE:?};"),
        ] {
            assert!(super::shader_source().contains(&want), "{want}");
        }
    }

    /// `vs_splat` pushes back splats seen through another element by the Rust constants.
    #[test]
    fn the_splat_shader_uses_the_element_bounds() {
        use super::super::splats::{ELEMENT_MARGIN, OFF_ELEMENT_DEPTH_SCALE};
        for want in [
            format!("const ELEMENT_MARGIN: f32 = {ELEMENT_MARGIN:?};"),
            format!("const OFF_ELEMENT_DEPTH_SCALE: f32 = {OFF_ELEMENT_DEPTH_SCALE:?};"),
        ] {
            assert!(super::shader_source().contains(&want), "{want}");
        }
    }
}

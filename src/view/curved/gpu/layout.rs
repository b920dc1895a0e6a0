//! The curved shader's inputs: the reflector vertex format, bind group 1 (parameters,
//! patterns, environment cube, sampler, the live cube whose alpha holds distances, the
//! reflector's own triangles) and its sampler.

use super::super::CurvedParams;
use crate::view::gpu::build::bind_group_layout;

/// One vertex of a curved reflector (24 bytes): `CurvedVertexIn` in the shader.
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, bytemuck::Pod, bytemuck::Zeroable)]
pub struct CurvedVertex {
    /// World position.
    pub position: [f32; 3],
    /// Vertex normal (interpolated, normalized in the shader).
    pub normal: [f32; 3],
}

const CURVED_ATTRIBUTES: [wgpu::VertexAttribute; 2] =
    wgpu::vertex_attr_array![0 => Float32x3, 1 => Float32x3];

impl CurvedVertex {
    /// The vertex buffer layout of `CurvedVertexIn` (and of the impostor pass's `ImpostorIn`).
    pub fn layout() -> wgpu::VertexBufferLayout<'static> {
        wgpu::VertexBufferLayout {
            array_stride: std::mem::size_of::<CurvedVertex>() as u64,
            step_mode: wgpu::VertexStepMode::Vertex,
            attributes: &CURVED_ATTRIBUTES,
        }
    }
}

/// Bind group 1 of the curved shader: the reflector's parameters, its sampling patterns,
/// its environment cube, the cube's sampler, the live cube map whose alpha holds the
/// distances of distance-corrected lookups, and the reflector's own triangles with their BVH
/// ([`super::super::own_mesh`]).
pub(super) fn curved_layout(device: &wgpu::Device) -> wgpu::BindGroupLayout {
    let all =
        wgpu::ShaderStages::VERTEX | wgpu::ShaderStages::FRAGMENT | wgpu::ShaderStages::COMPUTE;
    let lookups = wgpu::ShaderStages::FRAGMENT | wgpu::ShaderStages::COMPUTE;
    bind_group_layout()
        .uniform::<CurvedParams>(4, all)
        .storage(5, lookups)
        .texture(6, lookups, wgpu::TextureViewDimension::Cube, true)
        .sampler(7, lookups)
        .texture(9, lookups, wgpu::TextureViewDimension::Cube, true)
        .storage(10, lookups)
        .storage(11, lookups)
        .build(device, "glint curved layout")
}

/// The cube maps' sampler: trilinear, clamped.
pub(super) fn trilinear_sampler(device: &wgpu::Device) -> wgpu::Sampler {
    device.create_sampler(&wgpu::SamplerDescriptor {
        label: Some("glint cube sampler"),
        address_mode_u: wgpu::AddressMode::ClampToEdge,
        address_mode_v: wgpu::AddressMode::ClampToEdge,
        address_mode_w: wgpu::AddressMode::ClampToEdge,
        mag_filter: wgpu::FilterMode::Linear,
        min_filter: wgpu::FilterMode::Linear,
        mipmap_filter: wgpu::MipmapFilterMode::Linear,
        ..Default::default()
    })
}

/// Bind group 1 of the curved shader ([`curved_layout`]): `distances` is the reflector's
/// live cube map (or any cube when its parameters turn the correction off), `own` its own
/// BVH nodes and triangles (any buffers when they turn `own_closest` off).
#[allow(clippy::too_many_arguments)]
pub(super) fn curved_group(
    device: &wgpu::Device,
    layout: &wgpu::BindGroupLayout,
    params: &wgpu::Buffer,
    patterns: &wgpu::Buffer,
    env: &wgpu::TextureView,
    sampler: &wgpu::Sampler,
    distances: &wgpu::TextureView,
    own: (&wgpu::Buffer, &wgpu::Buffer),
) -> wgpu::BindGroup {
    device.create_bind_group(&wgpu::BindGroupDescriptor {
        label: Some("glint curved group"),
        layout,
        entries: &[
            wgpu::BindGroupEntry {
                binding: 4,
                resource: params.as_entire_binding(),
            },
            wgpu::BindGroupEntry {
                binding: 5,
                resource: patterns.as_entire_binding(),
            },
            wgpu::BindGroupEntry {
                binding: 6,
                resource: wgpu::BindingResource::TextureView(env),
            },
            wgpu::BindGroupEntry {
                binding: 7,
                resource: wgpu::BindingResource::Sampler(sampler),
            },
            wgpu::BindGroupEntry {
                binding: 9,
                resource: wgpu::BindingResource::TextureView(distances),
            },
            wgpu::BindGroupEntry {
                binding: 10,
                resource: own.0.as_entire_binding(),
            },
            wgpu::BindGroupEntry {
                binding: 11,
                resource: own.1.as_entire_binding(),
            },
        ],
    })
}

/// The vertices (position, normal) of `triangles`, three per triangle.
pub fn reflector_vertices(scene: &crate::scene::Scene, triangles: &[u32]) -> Vec<CurvedVertex> {
    triangles
        .iter()
        .flat_map(|&t| {
            let tri = &scene.triangles[t as usize];
            (0..3).map(move |k| CurvedVertex {
                position: tri.p[k].to_array(),
                normal: tri.n[k].to_array(),
            })
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn curved_vertex_matches_the_wgsl_input() {
        crate::view::gpu::wgsl_layout::assert_vertex_layout(
            &CurvedVertex::layout(),
            std::mem::size_of::<CurvedVertex>(),
            &[
                std::mem::offset_of!(CurvedVertex, position),
                std::mem::offset_of!(CurvedVertex, normal),
            ],
            &super::super::super::shader_source(),
            "CurvedVertexIn",
        );
    }
}

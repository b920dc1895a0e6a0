//! Cube textures: every MIP level with a cube view and per-face 2D views (render targets or
//! sources), and the upload of a baked MIP pyramid.

use exr::prelude::f16;

use crate::materials::envmap::MipPyramid;
use crate::view::gpu::target::HDR_FORMAT;
use crate::view::gpu::{Gpu, GpuError, error_scoped};

/// A cube texture with every MIP level, and the views the passes need.
pub struct CubeTexture {
    /// The texture (6 layers).
    pub texture: wgpu::Texture,
    /// All levels as a cube.
    pub cube: wgpu::TextureView,
    /// `faces[level][face]`: one face of one level as a 2D view (render target or source).
    pub(super) faces: Vec<Vec<wgpu::TextureView>>,
    /// Face size of level 0.
    pub size: u32,
}

impl CubeTexture {
    pub(super) fn new(gpu: &Gpu, size: u32, levels: u32, label: &str) -> CubeTexture {
        let texture = gpu.device.create_texture(&wgpu::TextureDescriptor {
            label: Some(label),
            size: wgpu::Extent3d {
                width: size,
                height: size,
                depth_or_array_layers: 6,
            },
            mip_level_count: levels,
            sample_count: 1,
            dimension: wgpu::TextureDimension::D2,
            format: HDR_FORMAT,
            usage: wgpu::TextureUsages::RENDER_ATTACHMENT
                | wgpu::TextureUsages::TEXTURE_BINDING
                | wgpu::TextureUsages::COPY_DST,
            view_formats: &[],
        });
        let cube = texture.create_view(&wgpu::TextureViewDescriptor {
            label: Some("glint cube map"),
            dimension: Some(wgpu::TextureViewDimension::Cube),
            ..Default::default()
        });
        let faces = (0..levels)
            .map(|level| {
                (0..6)
                    .map(|face| {
                        texture.create_view(&wgpu::TextureViewDescriptor {
                            label: Some("glint cube face"),
                            dimension: Some(wgpu::TextureViewDimension::D2),
                            base_mip_level: level,
                            mip_level_count: Some(1),
                            base_array_layer: face,
                            array_layer_count: Some(1),
                            ..Default::default()
                        })
                    })
                    .collect()
            })
            .collect();
        CubeTexture {
            texture,
            cube,
            faces,
            size,
        }
    }

    /// Levels of a full chain down to 1×1 for face size `size`.
    pub(super) fn full_chain(size: u32) -> u32 {
        32 - size.max(1).leading_zeros()
    }

    /// Uploads a MIP pyramid (level sizes halving exactly: a power-of-two base).
    pub fn from_pyramid(gpu: &Gpu, pyramid: &MipPyramid) -> Result<CubeTexture, GpuError> {
        let size = pyramid.base_size() as u32;
        error_scoped(&gpu.device, "uploading an environment map", || {
            let t = CubeTexture::new(gpu, size, pyramid.levels.len() as u32, "glint baked env");
            for (level, map) in pyramid.levels.iter().enumerate() {
                let n = map.size as u32;
                let halves: Vec<u16> = map
                    .texels
                    .iter()
                    .flat_map(|v| [v.x, v.y, v.z, 1.0])
                    .map(|c| f16::from_f32(c).to_bits())
                    .collect();
                gpu.queue.write_texture(
                    wgpu::TexelCopyTextureInfo {
                        texture: &t.texture,
                        mip_level: level as u32,
                        origin: wgpu::Origin3d::ZERO,
                        aspect: wgpu::TextureAspect::All,
                    },
                    bytemuck::cast_slice(&halves),
                    wgpu::TexelCopyBufferLayout {
                        offset: 0,
                        bytes_per_row: Some(n * 8),
                        rows_per_image: Some(n),
                    },
                    wgpu::Extent3d {
                        width: n,
                        height: n,
                        depth_or_array_layers: 6,
                    },
                );
            }
            t
        })
    }
}

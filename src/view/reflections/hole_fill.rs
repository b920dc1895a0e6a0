//! Hole filling of image mode's reflected image M (`shaders/hole_fill.wgsl`): pull-push
//! (Gortler et al. 1996 §3.3) over the texels no splat covered, restricted to the reflector's
//! screen rectangle.
//!
//! Why fill rather than only grow splats: at grazing views most uncovered texels are not gaps
//! between splats but directions no selected map saw at all. Bastos §8.1.3's cameras stop at
//! 80° from the reflector's normal and sit a few per ring, so a mirror seen at 80° is
//! reflected through directions 50–60° from the nearest map's axis, beyond the edge of its
//! frustum (a glossy-room-like test scene at draft: 47% of the mirror's pixels black). No
//! splat size reaches them; a fill from the nearest covered texels does, at any angle, for
//! the cost of a pyramid of M (about ⅓ of a full-screen pass) and one pass over the holes.
//!
//! Per reflector and frame, after the splat pass (which keeps its depth):
//! 1. pull: pyramid level 1 = M's covered texels averaged 2×2, premultiplied by coverage
//!    (rgb·w, w); each further level the 2×2 average of the one below;
//! 2. fill: a full-screen triangle at reverse Z's clear depth, `Equal`-tested against the
//!    splat pass's depth, scissored to the reflector's screen rectangle, writes each hole the
//!    finest pyramid level's bilinear sample that has coverage (rgb / w, alpha 1).

use glam::{Mat4, Vec3};

use crate::view::build::{bind_group_layout, render_pipeline, shader};
use crate::view::gpu::Gpu;
use crate::view::target::{HDR_FORMAT, clear_pass, overlay_pass_on, reverse_z_depth};

/// WGSL of the pull and fill passes.
pub const HOLE_FILL_SHADER_SOURCE: &str = include_str!("../../../shaders/hole_fill.wgsl");

/// The pyramid and pipelines of one M target's hole filling.
pub(super) struct HoleFill {
    pull_first: wgpu::RenderPipeline,
    pull: wgpu::RenderPipeline,
    fill: wgpu::RenderPipeline,
    _pyramid: wgpu::Texture,
    /// Per pyramid level: its view (a render target) and the group reading the level below
    /// (M for level 0).
    levels: Vec<(wgpu::TextureView, wgpu::BindGroup)>,
    /// The whole pyramid for the fill pass.
    fill_group: wgpu::BindGroup,
    width: u32,
    height: u32,
}

/// Pyramid levels for an M of `width` × `height`: halving (floor, at least 1) down to 1 × 1.
pub fn pyramid_levels(width: u32, height: u32) -> u32 {
    let top = (width / 2).max(height / 2).max(1);
    32 - top.leading_zeros()
}

/// The pixel rectangle (x, y, width, height) of a `width` × `height` frame covering the
/// projections by `view_proj` of `points` (a reflector's vertices), grown by a pixel; the
/// whole frame when a point lies behind the eye (its projection is unbounded); `None` when
/// the rectangle is empty.
pub fn screen_rect(view_proj: &Mat4, points: &[Vec3], width: u32, height: u32) -> Option<[u32; 4]> {
    let (mut lo, mut hi) = (glam::Vec2::INFINITY, glam::Vec2::NEG_INFINITY);
    for p in points {
        let c = *view_proj * p.extend(1.0);
        if c.w <= 1e-6 {
            return Some([0, 0, width, height]);
        }
        let ndc = c.truncate().truncate() / c.w;
        // NDC y up, pixel rows down.
        let px = glam::Vec2::new(
            (ndc.x * 0.5 + 0.5) * width as f32,
            (0.5 - ndc.y * 0.5) * height as f32,
        );
        lo = lo.min(px);
        hi = hi.max(px);
    }
    let x0 = (lo.x.floor() - 1.0).clamp(0.0, width as f32) as u32;
    let y0 = (lo.y.floor() - 1.0).clamp(0.0, height as f32) as u32;
    let x1 = (hi.x.ceil() + 1.0).clamp(0.0, width as f32) as u32;
    let y1 = (hi.y.ceil() + 1.0).clamp(0.0, height as f32) as u32;
    (x1 > x0 && y1 > y0).then_some([x0, y0, x1 - x0, y1 - y0])
}

impl HoleFill {
    /// The passes for an M of `width` × `height` whose colour is `m` (read by the first pull).
    pub(super) fn new(gpu: &Gpu, m: &wgpu::TextureView, width: u32, height: u32) -> HoleFill {
        let device = &gpu.device;
        let module = shader(device, "glint hole fill shader", HOLE_FILL_SHADER_SOURCE);
        let layout = bind_group_layout()
            .texture(
                0,
                wgpu::ShaderStages::FRAGMENT,
                wgpu::TextureViewDimension::D2,
                true,
            )
            .sampler(1, wgpu::ShaderStages::FRAGMENT)
            .build(device, "glint hole fill layout");
        let pipeline = |label, fs, depth: Option<wgpu::DepthStencilState>| {
            let mut b = render_pipeline(label, &module, "vs_fill_screen", fs)
                .layouts(&[&layout])
                .color(HDR_FORMAT, None);
            if let Some(d) = depth {
                b = b.depth(d);
            }
            b.build(device)
        };
        let pull_first = pipeline("glint pull (first)", "fs_pull_first", None);
        let pull = pipeline("glint pull", "fs_pull", None);
        let fill = pipeline(
            "glint hole fill",
            "fs_fill",
            Some(reverse_z_depth(false, wgpu::CompareFunction::Equal)),
        );
        let count = pyramid_levels(width, height);
        let pyramid = device.create_texture(&wgpu::TextureDescriptor {
            label: Some("glint hole fill pyramid"),
            size: wgpu::Extent3d {
                width: (width / 2).max(1),
                height: (height / 2).max(1),
                depth_or_array_layers: 1,
            },
            mip_level_count: count,
            sample_count: 1,
            dimension: wgpu::TextureDimension::D2,
            format: HDR_FORMAT,
            usage: wgpu::TextureUsages::RENDER_ATTACHMENT | wgpu::TextureUsages::TEXTURE_BINDING,
            view_formats: &[],
        });
        let sampler = device.create_sampler(&wgpu::SamplerDescriptor {
            label: Some("glint hole fill sampler"),
            mag_filter: wgpu::FilterMode::Linear,
            min_filter: wgpu::FilterMode::Linear,
            ..Default::default()
        });
        let group = |label, view: &wgpu::TextureView| {
            device.create_bind_group(&wgpu::BindGroupDescriptor {
                label: Some(label),
                layout: &layout,
                entries: &[
                    wgpu::BindGroupEntry {
                        binding: 0,
                        resource: wgpu::BindingResource::TextureView(view),
                    },
                    wgpu::BindGroupEntry {
                        binding: 1,
                        resource: wgpu::BindingResource::Sampler(&sampler),
                    },
                ],
            })
        };
        let level_view = |l: u32| {
            pyramid.create_view(&wgpu::TextureViewDescriptor {
                base_mip_level: l,
                mip_level_count: Some(1),
                ..Default::default()
            })
        };
        let mut levels = Vec::new();
        for l in 0..count {
            let below = if l == 0 {
                group("glint pull source", m)
            } else {
                group("glint pull source", &level_view(l - 1))
            };
            levels.push((level_view(l), below));
        }
        let fill_group = group(
            "glint hole fill pyramid",
            &pyramid.create_view(&wgpu::TextureViewDescriptor::default()),
        );
        HoleFill {
            pull_first,
            pull,
            fill,
            _pyramid: pyramid,
            levels,
            fill_group,
            width,
            height,
        }
    }

    /// Records the pull passes over M and the fill pass into M (`m`, with the splat pass's
    /// kept depth `depth`) within `rect` ([`screen_rect`]).
    pub(super) fn record(
        &self,
        encoder: &mut wgpu::CommandEncoder,
        m: &wgpu::TextureView,
        depth: &wgpu::TextureView,
        rect: [u32; 4],
    ) {
        for (l, (target, below)) in self.levels.iter().enumerate() {
            let mut pass = clear_pass(
                encoder,
                "glint pull pass",
                &[Some(target)],
                wgpu::Color::TRANSPARENT,
                None,
                None,
            );
            pass.set_pipeline(if l == 0 { &self.pull_first } else { &self.pull });
            pass.set_bind_group(0, below, &[]);
            pass.draw(0..3, 0..1);
        }
        let mut pass = overlay_pass_on(encoder, "glint hole fill pass", &[Some(m)], depth, None);
        pass.set_pipeline(&self.fill);
        pass.set_bind_group(0, &self.fill_group, &[]);
        let [x, y, w, h] = rect;
        let (x, y) = (x.min(self.width - 1), y.min(self.height - 1));
        pass.set_scissor_rect(x, y, w.min(self.width - x), h.min(self.height - y));
        pass.draw(0..3, 0..1);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_pyramid_halves_down_to_one_texel() {
        assert_eq!(pyramid_levels(400, 270), 8); // 200, 100, 50, 25, 12, 6, 3, 1
        assert_eq!(pyramid_levels(2, 2), 1);
        assert_eq!(pyramid_levels(1, 1), 1);
        assert_eq!(pyramid_levels(1024, 1), 10);
    }

    #[test]
    fn screen_rect_bounds_the_projection_and_opens_up_behind_the_eye() {
        let cam = crate::camera::Camera::look_at(Vec3::ZERO, -Vec3::Z, Vec3::Y, 1.0);
        let vp = crate::view::renderer::view_projection(&cam, 2.0, 0.01);
        let quad = [
            Vec3::new(-0.1, -0.1, -2.0),
            Vec3::new(0.1, 0.1, -2.0),
            Vec3::new(0.1, -0.1, -2.0),
        ];
        let [x, y, w, h] = screen_rect(&vp, &quad, 200, 100).unwrap();
        // Centred, a few pixels across, inside the frame.
        assert!(
            x > 80 && x + w < 120 && y > 30 && y + h < 70,
            "{x} {y} {w} {h}"
        );
        let behind = [Vec3::new(0.0, 0.0, 1.0), Vec3::new(0.0, 0.0, -1.0)];
        assert_eq!(screen_rect(&vp, &behind, 200, 100), Some([0, 0, 200, 100]));
        let off = [Vec3::new(50.0, 0.0, -1.0), Vec3::new(60.0, 0.0, -1.0)];
        assert_eq!(screen_rect(&vp, &off, 200, 100), None);
    }
}

//! The smoke test: one triangle drawn offscreen and read back, which proves an adapter can run
//! the viewer.

use super::build::{render_pipeline, shader};
use super::readback::read_texture_rgba8;
use super::target::{check_target_size, clear_pass, texture_2d};
use super::{Gpu, GpuError, error_scoped};

/// Pixel format of the offscreen target used by [`render_test_triangle`].
const TEST_TRIANGLE_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Rgba8Unorm;

/// Renders the smoke-test triangle offscreen and returns its RGBA8 pixels.
///
/// The target is a `width` x `height` `Rgba8Unorm` texture cleared to opaque black. The shader
/// `shaders/test_triangle.wgsl` generates the vertices from the vertex index at clip coordinates
/// (-0.5, -0.5), (0.5, -0.5), (0, 0.5) and fills the triangle with opaque red (1, 0, 0, 1).
/// Pixels are returned as by [`read_texture_rgba8`], top row first.
///
/// This exercises shader compilation, pipeline creation, rasterisation and readback, which is
/// enough to prove that an adapter (for example lavapipe on CI) can run the viewer.
pub fn render_test_triangle(gpu: &Gpu, width: u32, height: u32) -> Result<Vec<u8>, GpuError> {
    check_target_size(&gpu.device, width, height)?;
    let texture = error_scoped(&gpu.device, "rendering the test triangle", || {
        let texture = texture_2d(
            &gpu.device,
            "glint test triangle target",
            width,
            height,
            TEST_TRIANGLE_FORMAT,
            wgpu::TextureUsages::RENDER_ATTACHMENT | wgpu::TextureUsages::COPY_SRC,
        );
        let view = texture.create_view(&wgpu::TextureViewDescriptor::default());
        let shader = shader(
            &gpu.device,
            "glint test triangle shader",
            include_str!("../../../shaders/test_triangle.wgsl"),
        );
        let pipeline = render_pipeline("glint test triangle", &shader, "vs_main", "fs_main")
            .color(TEST_TRIANGLE_FORMAT, None)
            .build(&gpu.device);

        let mut encoder = gpu
            .device
            .create_command_encoder(&wgpu::CommandEncoderDescriptor {
                label: Some("glint test triangle encoder"),
            });
        {
            let mut pass = clear_pass(
                &mut encoder,
                "glint test triangle pass",
                &[Some(&view)],
                wgpu::Color::BLACK,
                None,
                None,
            );
            pass.set_pipeline(&pipeline);
            pass.draw(0..3, 0..1);
        }
        gpu.queue.submit([encoder.finish()]);
        texture
    })?;

    read_texture_rgba8(gpu, &texture)
}

//! GPU smoke test: renders the test triangle offscreen and checks the pixels.
//!
//! CI runs this on Mesa's software Vulkan adapter (lavapipe, package `mesa-vulkan-drivers`).
//! There is deliberately no skip: without an adapter the test fails with the `GpuError` message.

#![cfg(feature = "view")]

use glint::view::gpu::Gpu;
use glint::view::gpu::readback::read_texture_rgba8;
use glint::view::gpu::triangle::render_test_triangle;

/// Clip-space corners of the triangle drawn by `shaders/test_triangle.wgsl`.
const TRIANGLE_CLIP: [[f32; 2]; 3] = [[-0.5, -0.5], [0.5, -0.5], [0.0, 0.5]];

/// Allowed relative difference between the rasterised and the analytic triangle area.
const AREA_TOLERANCE: f64 = 0.15;

fn open_gpu() -> Gpu {
    let _ = env_logger::builder().is_test(true).try_init();
    let gpu = Gpu::headless().unwrap_or_else(|err| panic!("{err}"));
    println!("adapter: {}", gpu.adapter_summary());
    gpu
}

/// RGBA of pixel (x, y), with y counted from the top row.
fn pixel(pixels: &[u8], width: u32, x: u32, y: u32) -> [u8; 4] {
    let start = ((y * width + x) * 4) as usize;
    [
        pixels[start],
        pixels[start + 1],
        pixels[start + 2],
        pixels[start + 3],
    ]
}

fn is_red(rgba: [u8; 4]) -> bool {
    rgba[0] >= 250 && rgba[1] <= 5 && rgba[2] <= 5 && rgba[3] == 255
}

/// Area in pixels of the triangle once its clip coordinates are mapped to a `width` x `height`
/// viewport (shoelace formula).
fn analytic_area(width: u32, height: u32) -> f64 {
    let to_pixels = |[x, y]: [f32; 2]| {
        (
            (f64::from(x) + 1.0) * 0.5 * f64::from(width),
            (1.0 - f64::from(y)) * 0.5 * f64::from(height),
        )
    };
    let [a, b, c] = TRIANGLE_CLIP.map(to_pixels);
    0.5 * ((b.0 - a.0) * (c.1 - a.1) - (c.0 - a.0) * (b.1 - a.1)).abs()
}

/// Checks size, red coverage against the analytic area and black corners; returns the red count.
fn check_triangle(pixels: &[u8], width: u32, height: u32) -> usize {
    assert_eq!(
        pixels.len(),
        (width * height * 4) as usize,
        "pixel buffer size"
    );
    for (x, y) in [
        (0, 0),
        (width - 1, 0),
        (0, height - 1),
        (width - 1, height - 1),
    ] {
        assert_eq!(
            pixel(pixels, width, x, y),
            [0, 0, 0, 255],
            "corner pixel ({x}, {y}) should be the black clear colour"
        );
    }
    let red = pixels
        .chunks_exact(4)
        .filter(|rgba| is_red([rgba[0], rgba[1], rgba[2], rgba[3]]))
        .count();
    let expected = analytic_area(width, height);
    let relative_error = (red as f64 - expected).abs() / expected;
    assert!(
        relative_error <= AREA_TOLERANCE,
        "{red} red pixels, expected about {expected} (relative error {relative_error:.3})"
    );
    red
}

#[test]
fn triangle_renders_on_the_headless_adapter() {
    let gpu = open_gpu();
    let (width, height) = (64, 64);
    let pixels = render_test_triangle(&gpu, width, height).unwrap_or_else(|err| panic!("{err}"));

    let centre = pixel(&pixels, 32, 32, 36);
    assert!(
        is_red(centre),
        "pixel (32, 36) inside the triangle should be red, got {centre:?}"
    );
    let red = check_triangle(&pixels, width, height);
    println!(
        "{width}x{height}: {red} red pixels, analytic area {}",
        analytic_area(width, height)
    );
}

/// A width whose rows are not a multiple of 256 bytes exercises the padding removal: if rows
/// were unpacked with the wrong stride the triangle would shear and its rows lose their symmetry.
#[test]
fn triangle_rows_stay_aligned_with_padded_readback() {
    let gpu = open_gpu();
    let (width, height) = (50, 38);
    let pixels = render_test_triangle(&gpu, width, height).unwrap_or_else(|err| panic!("{err}"));
    check_triangle(&pixels, width, height);

    for y in 0..height {
        let reds: Vec<u32> = (0..width)
            .filter(|&x| is_red(pixel(&pixels, width, x, y)))
            .collect();
        if let (Some(&first), Some(&last)) = (reds.first(), reds.last()) {
            assert_eq!(
                reds.len() as u32,
                last - first + 1,
                "row {y}: red pixels should be one contiguous run"
            );
            let centre_twice = first + last + 1;
            assert!(
                centre_twice.abs_diff(width) <= 2,
                "row {y}: red run {first}..={last} should be centred on x = {}",
                width / 2
            );
        }
    }
}

/// Byte-exact readback of a texture uploaded from the CPU, with a row size (5 * 4 = 20 bytes)
/// far from the 256-byte copy alignment.
#[test]
fn readback_returns_tightly_packed_rows() {
    let gpu = open_gpu();
    let (width, height) = (5, 3);
    let texture = gpu.device.create_texture(&wgpu::TextureDescriptor {
        label: Some("readback test texture"),
        size: wgpu::Extent3d {
            width,
            height,
            depth_or_array_layers: 1,
        },
        mip_level_count: 1,
        sample_count: 1,
        dimension: wgpu::TextureDimension::D2,
        format: wgpu::TextureFormat::Rgba8UnormSrgb,
        usage: wgpu::TextureUsages::COPY_DST | wgpu::TextureUsages::COPY_SRC,
        view_formats: &[],
    });
    let expected: Vec<u8> = (0..width * height * 4)
        .map(|i| (i * 7 % 251) as u8)
        .collect();
    gpu.queue.write_texture(
        texture.as_image_copy(),
        &expected,
        wgpu::TexelCopyBufferLayout {
            offset: 0,
            bytes_per_row: Some(width * 4),
            rows_per_image: Some(height),
        },
        texture.size(),
    );
    let pixels = read_texture_rgba8(&gpu, &texture).unwrap_or_else(|err| panic!("{err}"));
    assert_eq!(pixels, expected);
}

// Smoke-test triangle for the headless GPU path (`glint::view::gpu::render_test_triangle`).
//
// No vertex buffers: the three clip-space corners are generated from the vertex index.
// The integration test `tests/gpu_triangle.rs` checks coverage against these exact coordinates,
// so keep the two in sync.

@vertex
fn vs_main(@builtin(vertex_index) vertex_index: u32) -> @builtin(position) vec4<f32> {
    var corners = array<vec2<f32>, 3>(
        vec2<f32>(-0.5, -0.5),
        vec2<f32>(0.5, -0.5),
        vec2<f32>(0.0, 0.5),
    );
    return vec4<f32>(corners[vertex_index], 0.0, 1.0);
}

@fragment
fn fs_main() -> @location(0) vec4<f32> {
    // Solid opaque red.
    return vec4<f32>(1.0, 0.0, 0.0, 1.0);
}

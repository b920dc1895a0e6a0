// Thin glass in a planar reflector's mirrored view (src/view/passes/glass.rs,
// `MirroredGlass`), appended to view.wgsl, reflect.wgsl and glass.wgsl: the glass passes of
// the frame, drawn into M after its opaque surfaces, clipped as `fs_mirror` clips. Alpha (the
// beyond fraction of what lies behind) is kept by the blend.

@fragment
fn fs_mirror_glass_tint(in: MirrorOut) -> @location(0) vec4<f32> {
    let t = transmittance(in.material, in.world);
    if side(in.world) <= reflect_params.ks.a || cut_out(in.material, in.uv0, in.uv1) {
        discard;
    }
    return vec4<f32>(t, 1.0);
}

@fragment
fn fs_mirror_glass_add(in: MirrorOut) -> @location(0) vec4<f32> {
    let g = uv_grads(in.uv0, in.uv1);
    if side(in.world) <= reflect_params.ks.a || cut_out(in.material, in.uv0, in.uv1) {
        discard;
    }
    let q = max(sample_radiosity(in.lightmap, in.page), vec3<f32>(0.0));
    return vec4<f32>(surface_d(q, in.material, in.uv0, in.uv1, g) * frame.exposure, 0.0);
}

// Thin glass (src/view/passes/glass.rs), appended to view.wgsl: transmissive triangles are
// drawn after everything opaque, in two passes over the finished frame. The first multiplies
// what is behind by the transmittance tint × factor × (1 − F(cos θ)) (`fs_glass_tint`), the
// second adds the glass's own light, its diffuse D (`fs_glass_add`), so that a pixel holds
// D + T · (the frame behind).

// Per material (`glass::glass_records`).
struct GlassRecord {
    // rgb: tint × transmission factor (0 for opaque materials); a: the Fresnel reflectance
    // at normal incidence ((n − 1)/(n + 1))².
    transmit: vec4<f32>,
    // x: 1 double-sided, 0 single-sided (its back faces add no light); yzw: unused.
    sides: vec4<f32>,
};
@group(2) @binding(0) var<storage, read> glass: array<GlassRecord>;

// What the pane of `material` at `world` lets through towards the eye: tint × factor ×
// (1 − F), Schlick's F at the facet's angle (either side). Called before any discard: the
// facet's normal comes from screen derivatives.
fn transmittance(material: u32, world: vec3<f32>) -> vec3<f32> {
    let n = normalize(cross(dpdx(world), dpdy(world)));
    let c = abs(dot(n, normalize(frame.eye.xyz - world)));
    let g = glass[material].transmit;
    let f = g.a + (1.0 - g.a) * pow(1.0 - min(c, 1.0), 5.0);
    return g.rgb * (1.0 - f);
}

@fragment
fn fs_glass_tint(in: WorldOut) -> @location(0) vec4<f32> {
    let t = transmittance(in.material, in.world);
    if cut_out(in.material, in.uv0, in.uv1) {
        discard;
    }
    return vec4<f32>(t, 1.0);
}

// The glass's own exitant radiance D, as the scene pass shades an opaque surface. A
// single-sided pane seen from behind (a jar's far side through its near one) adds none: its
// back is black, as in the radiosity solver and the path tracer.
@fragment
fn fs_glass_add(in: WorldOut, @builtin(front_facing) front: bool) -> FragmentOut {
    let g = uv_grads(in.uv0, in.uv1);
    let hidden = !front && glass[in.material].sides.x == 0.0;
    if hidden || cut_out(in.material, in.uv0, in.uv1) {
        discard;
    }
    let v = VertexOut(in.clip, in.lightmap, in.page, in.uv0, in.uv1, in.material, in.lightmap, in.lightmap);
    return shade(v, g);
}

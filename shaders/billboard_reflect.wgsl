// glint-view: reflections of billboards (Popescu §3.1), appended to `view.wgsl`,
// `srdm.wgsl`, `impostors.wgsl` and `billboards.wgsl` when the impostor pass draws billboards.
// Same steps 1 and 3 as `fs_impostor`; step 2 is `bb_trace` over the group of
// billboards made for this reflector (settings.w), whose misses read its environment map.
@fragment
fn fs_billboard(in: ImpostorOut) -> FragmentOut {
    let to_pixel = normalize(in.world - impostor_params.eye.xyz);
    let n = impostor_normal(in, to_pixel);
    let dir = reflect(to_pixel, n);
    let res = bb_trace(u32(impostor_params.settings.w), in.world, dir, impostor_params.settings.z);
    var out: FragmentOut;
    if res.kind == 0u {
        out.color = vec4<f32>(0.0);
        out.hdr = vec4<f32>(0.0);
        return out;
    }
    let cos_theta = dot(n, -to_pixel);
    var atten = 1.0;
    if res.kind != 3u {
        atten = impostor_attenuation(res.t);
    }
    let c = impostor_modulation(cos_theta) * res.colour * atten * frame.exposure;
    var color = c;
    if frame.encode_srgb != 0u {
        color = linear_to_srgb(c);
    }
    out.color = vec4<f32>(color, 0.0);
    out.hdr = vec4<f32>(c, 0.0);
    return out;
}

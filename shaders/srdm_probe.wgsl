// glint-view: a batch of rays against the SRDM tables (`srdm.wgsl`), for the test that holds
// the shader to the CPU intersection (`tests/view_impostors.rs`) and for timing it. Appended to
// `srdm.wgsl`. Keep `ProbeRay` and `ProbeHit` in sync with `src/view/impostors/probes.rs`.

struct ProbeRay {
    // xyz: origin; w: t_max.
    origin: vec4<f32>,
    // xyz: direction; w: the view searched, as bits (bitcast<u32>).
    dir: vec4<f32>,
};

struct ProbeHit {
    // t, pixel x, pixel y, depth.
    t_pixel_depth: vec4<f32>,
    // 1 on a hit, domain, row, 0.
    found: vec4<u32>,
    // The captured colour at the hit (rgb), 0 on a miss.
    colour: vec4<f32>,
};

@group(2) @binding(0) var<storage, read> probe_rays: array<ProbeRay>;
@group(2) @binding(1) var<storage, read_write> probe_hits: array<ProbeHit>;

@compute @workgroup_size(64)
fn cs_srdm_probe(@builtin(global_invocation_id) id: vec3<u32>) {
    let k = id.x;
    if k >= arrayLength(&probe_rays) {
        return;
    }
    let r = probe_rays[k];
    let vi = bitcast<u32>(r.dir.w);
    let h = srdm_intersect(vi, r.origin.xyz, r.dir.xyz, r.origin.w);
    var out: ProbeHit;
    if h.hit {
        out.t_pixel_depth = vec4<f32>(h.t, h.pixel, h.depth);
        out.found = vec4<u32>(1u, h.domain, h.row, 0u);
        out.colour = vec4<f32>(srdm_colour(vi, h.pixel), 1.0);
    } else {
        out.t_pixel_depth = vec4<f32>(0.0);
        out.found = vec4<u32>(0u);
        out.colour = vec4<f32>(0.0);
    }
    probe_hits[k] = out;
}

// glint-view: a batch of rays through `bb_trace` (`billboards.wgsl`), for the tests that hold
// the shader to `BillboardTables::trace`. Keep `BbProbeRay`/`BbProbeHit` in sync with
// `src/view/impostors/probes.rs`.

struct BbProbeRay {
    // xyz: origin; w: t_max.
    origin: vec4<f32>,
    // xyz: direction; w: the group, as bits.
    dir: vec4<f32>,
};

struct BbProbeHit {
    // rgb: colour; w: t.
    colour: vec4<f32>,
    // kind, billboard, 0, 0.
    kind: vec4<u32>,
};

@group(2) @binding(0) var<storage, read> bb_probe_rays: array<BbProbeRay>;
@group(2) @binding(1) var<storage, read_write> bb_probe_hits: array<BbProbeHit>;

@compute @workgroup_size(64)
fn cs_billboard_probe(@builtin(global_invocation_id) id: vec3<u32>) {
    let k = id.x;
    if k >= arrayLength(&bb_probe_rays) {
        return;
    }
    let r = bb_probe_rays[k];
    let res = bb_trace(bitcast<u32>(r.dir.w), r.origin.xyz, r.dir.xyz, r.origin.w);
    var out: BbProbeHit;
    out.colour = vec4<f32>(res.colour, res.t);
    out.kind = vec4<u32>(res.kind, res.billboard, 0u, 0u);
    bb_probe_hits[k] = out;
}

// glint-view: glossy planar reflections, L = kd·D + ks·(M*K)·R (Bastos Eq. 2).
//
// Appended to `shaders/view.wgsl` at pipeline creation (`src/view/reflections/passes.rs`): it
// uses that file's `frame` uniforms, `VertexIn`, `FragmentOut` and `sample_radiosity`.
//
// Per glossy planar reflector and frame:
// 1. M, in the view mirrored about the reflector's plane (`frame` holds the mirrored camera's
//    matrix), into an Rgba16Float texture the size of the frame; alpha = the fraction of the
//    reflected ray beyond the plane (K's per-pixel scale), 0 where nothing is reflected:
//    - `vs_mirror`/`fs_mirror` (geometry mode): the scene re-rendered, whatever lies behind
//      the plane (or on it: the reflector itself) discarded, the clip plane;
//    - `vs_splat`/`fs_splat` (image mode): radiance-map points as quads, each its map pixel's
//      patch on its own surface (Eq. 3 per point, with the facet normal baked with the map)
//      × the node's spacing (`splat_nodes`), lower-ranked maps pushed back, and so is each
//      quad's overlap beyond its own patch (it only fills gaps).
// 2. `vs_mirror`/`fs_composite`: the reflector's triangles drawn again over the frame, depth
//    tested (GreaterEqual, reverse Z) against the scene pass's depth (the mask), adding
//    ks·R × (M*K) at the same pixel (additive blend): M*K at a cost independent of K's width,
//    K's taps gathered onto a regular pattern whose samples read M's MIP pyramid
//    (`shaders/pyramid.wgsl`) at the level of their share of the lobe (`filter.rs`, Luksch
//    et al. §5–6), shaped per view angle by the lobe's lean and widths (`lobe_shape.rs`) and
//    read along the plane of incidence by up to 6 reads per tap; R from the 1D table (cos θ)
//    or the sphere map (reflected direction). In image mode a pixel of the reflector whose M
//    texel no splat covered is filled first (`fill_hole`), and the pyramid counts holes for
//    nothing.
//
// Keep `ReflectParams` in sync with `reflections::ReflectParams` (a test compares them).

struct ReflectParams {
    // xyz: the plane's unit normal (the side it reflects); w: normal · (a point of the plane).
    plane: vec4<f32>,
    // rgb: ks of the reflector's material (sum of its lobes); a: clip distance (metres):
    // fragments at a signed distance ≤ a from the plane are discarded in the mirrored view.
    ks: vec4<f32>,
    // xyz: the eye (per frame); w: the 1D reflectance map's grazing bound C (cos θ).
    eye: vec4<f32>,
    // xyz: the plane's tangent; w: 1 = R from the sphere map, 0 = from `modulation`.
    tangent: vec4<f32>,
    // xyz: the plane's bitangent; w: the sphere map's size in texels.
    bitangent: vec4<f32>,
    // x: screen pixels per kernel texel for a point wholly beyond the plane; y: filter taps;
    // z: 1 = fill M's uncovered texels (image mode), 0 = they reflect nothing (geometry mode).
    kernel: vec4<f32>,
    // The composite's clip (`fs_composite`): in a recursive map (Nielsen §3.1), the parent
    // mirror's plane, xyz its normal, w = normal · point + clip distance; fragments p with
    // xyz · p ≤ w (behind the parent mirror) are discarded. (0, 0, 0, −1) into the frame.
    parent: vec4<f32>,
    // ks·R at the 1D map's cosines C + (1 − C) s², s = k/63 (rgb).
    modulation: array<vec4<f32>, 64>,
    // M*K's filter taps (`filter::filter_taps`): xy offset in kernel texels (x right, y up),
    // z weight (they sum to 1), w per-axis variance of the kernel mass it stands for (texels²).
    taps: array<vec4<f32>, 64>,
    // K's shape per view cosine k/15 (`lobe_shape::LobeShape`): x its lean (kernel texels,
    // towards higher elevation of the reflected ray), y its scale along the plane of
    // incidence, z across it.
    shape: array<vec4<f32>, 16>,
};

@group(1) @binding(2) var<uniform> reflect_params: ReflectParams;
@group(1) @binding(3) var reflection: texture_2d<f32>;
@group(1) @binding(4) var reflection_sampler: sampler;
@group(1) @binding(5) var sphere_map: texture_2d<f32>;
// Per quadtree node and frame (`splats::NodeParams`): a splat's size in map pixels, the
// rank's depth scale, the node's map, half a pixel in NDC.
struct SplatNode {
    spacing: f32,
    depth_scale: f32,
    view: u32,
    pad: f32,
    pixel_ndc: vec2<f32>,
    pad2: vec2<f32>,
};
// Per map, fixed (`splats::SplatView`): centre of projection (w: the element's depth), the
// reflector's normal, one map pixel's edges on the element.
struct SplatView {
    centre: vec4<f32>,
    normal: vec4<f32>,
    pixel_u: vec4<f32>,
    pixel_v: vec4<f32>,
    corner: vec4<f32>,
};
@group(1) @binding(6) var<storage, read> splat_nodes: array<SplatNode>;
@group(1) @binding(10) var<storage, read> splat_views: array<SplatView>;
// Image mode: the reflector's radiance-map points (`splats::Splat`), and this frame's kept
// ones (indices into `splat_points`, `splat_maps::SplatMaps::plan`).
@group(1) @binding(8) var<storage, read> splat_points: array<SplatPoint>;
@group(1) @binding(9) var<storage, read> splat_kept: array<u32>;
// M's pyramid: (rgb·c, c) per level, c = 0 for a hole (`pyramid.wgsl`).
@group(1) @binding(7) var pyramid: texture_2d<f32>;

struct MirrorOut {
    @builtin(position) clip: vec4<f32>,
    @location(0) lightmap: vec2<f32>,
    @location(1) @interpolate(flat) page: u32,
    @location(2) world: vec3<f32>,
    @location(3) uv0: vec2<f32>,
    @location(4) uv1: vec2<f32>,
    @location(5) @interpolate(flat) material: u32,
    // `world` at a point the primitive covers: apart from `world` only at a multisampled
    // pixel it covers in part.
    @location(6) @interpolate(perspective, centroid) inside: vec3<f32>,
    // `lightmap` at a covered point and at the provoking corner (`lightmap_at`).
    @location(7) @interpolate(perspective, centroid) lightmap_centroid: vec2<f32>,
    @location(8) @interpolate(flat) lightmap_corner: vec2<f32>,
};

@vertex
fn vs_mirror(v: VertexIn) -> MirrorOut {
    var out: MirrorOut;
    out.clip = frame.view_proj * vec4<f32>(v.position, 1.0);
    // `frame` is the mirrored camera's: its eye is the mirrored eye.
    let lm = lightmap_seen(v, frame.eye.xyz);
    out.lightmap = lm.coords;
    out.page = lm.page;
    out.world = v.position;
    out.inside = v.position;
    out.lightmap_centroid = lm.coords;
    out.lightmap_corner = lm.coords;
    out.uv0 = v.uv0;
    out.uv1 = v.uv1;
    out.material = v.material;
    return out;
}

fn side(p: vec3<f32>) -> f32 {
    return dot(reflect_params.plane.xyz, p) - reflect_params.plane.w;
}

// The fraction of the mirrored eye's ray to `p` that lies beyond the plane
// (`material::beyond_fraction`).
fn beyond(p: vec3<f32>) -> f32 {
    let s = max(side(p), 0.0);
    let total = s + max(side(reflect_params.eye.xyz), 0.0);
    return select(0.0, s / total, total > 0.0);
}

@fragment
fn fs_mirror(in: MirrorOut) -> @location(0) vec4<f32> {
    let g = uv_grads(in.uv0, in.uv1);
    if side(in.world) <= reflect_params.ks.a || cut_out(in.material, in.uv0, in.uv1) {
        discard;
    }
    let lightmap = lightmap_at(in.lightmap, in.lightmap_centroid, in.lightmap_corner);
    let q = max(sample_radiosity(lightmap, in.page), vec3<f32>(0.0));
    let d = surface_d(q, in.material, in.uv0, in.uv1, g) * frame.exposure;
    return vec4<f32>(d, beyond(in.world));
}

// ks·R at view cosine c: linear in the 1D map's coordinate s = √((c − C)/(1 − C)), clamped
// (`reflectance::sample_1d` on the CPU).
fn modulation(c: f32) -> vec3<f32> {
    let g = reflect_params.eye.w;
    let s = sqrt(clamp((c - g) / (1.0 - g), 0.0, 1.0));
    let x = s * 63.0;
    let i = min(u32(floor(x)), 63u);
    let j = min(i + 1u, 63u);
    let f = x - f32(i);
    return reflect_params.modulation[i].rgb * (1.0 - f) + reflect_params.modulation[j].rgb * f;
}

// ks·R from the sphere map at reflected direction r (tangent frame), nearest texel, the disk
// point kept inside the rim (`material::sphere_texel`).
fn sphere_modulation(r: vec3<f32>) -> vec3<f32> {
    let size = reflect_params.bitangent.w;
    let g = reflect_params.eye.w;
    let rim = min(sqrt(1.0 - g * g), 1.0 - 1.5 / size);
    var d = r.xy;
    let len = length(d);
    if len > rim {
        d = d * (rim / len);
    }
    let x = clamp(floor((d.x + 1.0) * 0.5 * size), 0.0, size - 1.0);
    let y = clamp(floor((1.0 - d.y) * 0.5 * size), 0.0, size - 1.0);
    return textureLoad(sphere_map, vec2<i32>(i32(x), i32(y)), 0).rgb;
}

// Offsets of the 8 directions `fill_hole` samples (axes and diagonals).
const RING = array<vec2<i32>, 8>(
    vec2<i32>(1, 0), vec2<i32>(1, 1), vec2<i32>(0, 1), vec2<i32>(-1, 1),
    vec2<i32>(-1, 0), vec2<i32>(-1, -1), vec2<i32>(0, -1), vec2<i32>(1, -1),
);

// An M texel no splat covered (image mode: a gap between splats, or a direction no selected
// radiance map saw, as at grazing views beyond the maps' frusta): the mean of the covered
// texels among 8 directions on the nearest ring, of radius 1, 2, 4, … pixels, that has any
// (`splats::fill_hole` on the CPU). Zero when nothing is covered within the frame.
fn fill_hole(p: vec2<i32>) -> vec4<f32> {
    let size = vec2<i32>(textureDimensions(reflection));
    for (var r = 1; r < 2 * max(size.x, size.y); r = r * 2) {
        var sum = vec4<f32>(0.0);
        var n = 0.0;
        for (var k = 0; k < 8; k++) {
            let q = p + RING[k] * r;
            if all(q >= vec2<i32>(0)) && all(q < size) {
                let t = textureLoad(reflection, q, 0);
                if t.a > 0.0 {
                    sum += t;
                    n += 1.0;
                }
            }
        }
        if n > 0.0 {
            return sum / n;
        }
    }
    return vec4<f32>(0.0);
}

// The unit screen direction (pixels, y down) of the plane of incidence's trace at world
// point `p`: the derivative of p's pixel position along the normal `n` (`Grazing::at`).
fn grazing_axis(p: vec3<f32>, n: vec3<f32>, size: vec2<f32>) -> vec2<f32> {
    let c = frame.view_proj * vec4<f32>(p, 1.0);
    let dc = frame.view_proj * vec4<f32>(n, 0.0);
    let d = (dc.xy * c.w - c.xy * dc.w) / (c.w * c.w);
    let along = vec2<f32>(d.x * size.x, -d.y * size.y);
    if dot(along, along) > 1e-12 {
        return normalize(along);
    }
    return vec2<f32>(1.0, 0.0);
}

// K's shape at view cosine c, linear between the table's entries (`LobeShape::at`).
fn lobe_shape(c: f32) -> vec3<f32> {
    let x = clamp(c, 0.0, 1.0) * 15.0;
    let i = min(u32(floor(x)), 15u);
    let j = min(i + 1u, 15u);
    let f = x - f32(i);
    return mix(reflect_params.shape[i].xyz, reflect_params.shape[j].xyz, f);
}

// Into a recursive map (Nielsen §3.1).
@fragment
fn fs_composite(in: MirrorOut) -> FragmentOut {
    // A child reflector straddling its parent mirror's plane: the part behind the parent was
    // clipped from the parent's map by `fs_mirror`, and must not get a reflection either (it
    // lies nearer the mirrored eye than anything in the map, so the depth test keeps it).
    if dot(reflect_params.parent.xyz, in.world) <= reflect_params.parent.w {
        discard;
    }
    return composite(in);
}

// Into the frame, where nothing is clipped (`parent` is (0, 0, 0, −1)). A shader that never
// discards lets the depth test run before the gather, so the parts of a reflector that the
// scene hides cost nothing.
@fragment
fn fs_composite_frame(in: MirrorOut) -> FragmentOut {
    return composite(in);
}

fn composite(in: MirrorOut) -> FragmentOut {
    var centre = textureLoad(reflection, vec2<i32>(floor(in.clip.xy)), 0);
    // A multisampled edge pixel whose centre lies off the reflector: M there continues the
    // plane past the reflector's edge (behind the wall a mirror floor meets, where it holds
    // nothing), so the covered samples read the nearest covered texels, as a hole does.
    let off_edge =
        distance(in.inside, in.world) > 1e-5 * distance(in.world, reflect_params.eye.xyz);
    let hole = centre.a <= 0.0 && (reflect_params.kernel.z > 0.5 || off_edge);
    if hole {
        centre = fill_hole(vec2<i32>(floor(in.clip.xy)));
    }
    var m = centre.rgb;
    let taps = u32(reflect_params.kernel.y);
    // M*K: the filter's taps around the pixel, a kernel texel spanning kernel.x × (beyond
    // fraction) pixels, each reading the pyramid at ½ log₂(4 (v·scale² + 1/6))
    // (`filter::level`); Σ w·rgb / Σ w·c (not around a filled texel: its neighbours are
    // holes too, and the fill is a blur).
    // At a grazing view the lobe narrows across the plane of incidence and leans away from
    // the horizon (`filter::Grazing`, `lobe_shape`): offsets scaled along and across `axis`
    // and shifted down it by the lean, levels from the variance's geometric mean over the two
    // axes.
    if taps > 1u && centre.a > 0.0 && !hole {
        let size = vec2<f32>(textureDimensions(pyramid));
        let scale = reflect_params.kernel.x * centre.a;
        let n = reflect_params.plane.xyz;
        let cos_v = clamp(abs(dot(n, normalize(reflect_params.eye.xyz - in.world))), 1e-3, 1.0);
        let axis = grazing_axis(in.world, n, size);
        let shape = lobe_shape(cos_v);
        // Reads per tap along the axis (`Grazing::reads`, at most `filter::MAX_READS`), each of variance own = max(V_across,
        // 3 V_along / (n² + 2)), a step δ apart with V_along = own + δ²(n² − 1)/12
        // (`Grazing::footprint`); one read: the variance's geometric mean.
        let k2 = (shape.y * shape.y) / max(shape.z * shape.z, 1e-12);
        var reads = 1u;
        if k2 > 1.0 {
            reads = clamp(u32(floor(sqrt(3.0 * k2 - 2.0))), 1u, 6u);
        }
        let n2 = f32(reads * reads);
        var sum = vec4<f32>(0.0);
        for (var i = 0u; i < taps; i = i + 1u) {
            let t = reflect_params.taps[i];
            let o = vec2<f32>(t.x, -t.y) * scale;
            let a = dot(o, axis);
            let across = o - axis * a;
            let p = in.clip.xy + axis * (a * shape.y - shape.x * scale) + across * shape.z;
            var own = t.w * shape.y * shape.z * scale * scale;
            var step = 0.0;
            if reads > 1u {
                let v_along = t.w * shape.y * shape.y * scale * scale;
                let v_across = t.w * shape.z * shape.z * scale * scale;
                own = max(v_across, 3.0 * v_along / (n2 + 2.0));
                step = sqrt(12.0 * max(v_along - own, 0.0) / (n2 - 1.0));
            }
            let level = max(0.5 * log2(4.0 * (own + 1.0 / 6.0)), 0.0);
            var taken = vec4<f32>(0.0);
            for (var j = 0u; j < reads; j = j + 1u) {
                let q = p + axis * step * (f32(j) - 0.5 * f32(reads - 1u));
                // A read beyond the frame has nothing to read: M holds only the frame's
                // view. It is left out (the sum is normalized by Σ w·c), not clamped: the
                // edge texels repeated would stand for everything beyond, spreading a lamp
                // at the frame's edge as a glow along it (docs/tuning.md#frame-edge-reads).
                // It fades out over one footprint across the edge (`filter::edge_fade`):
                // cut there, each read crossing it stepped the whole row.
                let inside = min(min(q.x, q.y), min(size.x - q.x, size.y - q.y));
                let fade = clamp(inside / exp2(level) + 0.5, 0.0, 1.0);
                if fade > 0.0 {
                    taken = taken + fade * textureSampleLevel(pyramid, reflection_sampler, q / size, level);
                }
            }
            sum = sum + t.z / f32(reads) * taken;
        }
        if sum.a > 1e-4 {
            m = sum.rgb / sum.a;
        }
    }
    let n = reflect_params.plane.xyz;
    let v = normalize(reflect_params.eye.xyz - in.world);
    var k: vec3<f32>;
    if reflect_params.tangent.w > 0.5 {
        let r = reflect(-v, n);
        k = sphere_modulation(vec3<f32>(
            dot(r, reflect_params.tangent.xyz),
            dot(r, reflect_params.bitangent.xyz),
            dot(r, n),
        ));
    } else {
        k = modulation(dot(n, v));
    }
    let c = k * m;
    var out: FragmentOut;
    // Added to the scene pass's colour by the blend state. A non-sRGB target (the shader
    // encodes there) gets the linear sum approximated by encoding the added term alone.
    var color = c;
    if frame.encode_srgb != 0u {
        color = linear_to_srgb(c);
    }
    // Alpha: the beyond fraction f_c of what the map shows here. Only a recursive map
    // composite's blend reads it (`UNFOLDED_ALPHA`): the parent map's alpha f_q becomes the
    // unfolded path's f_q + f_c (1 − f_q), so K blurs what a mirror shows at the distance
    // where it lies (as `fs_curved_mirror`); every other composite keeps the target's alpha.
    let f_c = clamp(centre.a, 0.0, 1.0);
    out.color = vec4<f32>(color, f_c);
    out.hdr = vec4<f32>(c, f_c);
    return out;
}

// Image-based mode: the selected radiance maps' points as quads (parallelograms) in the
// mirrored view, nearest wins (WebGPU has no point size). One non-instanced triangle list per
// reflector: 6 vertices per kept point, the point read from `splat_points` through
// `splat_kept`, so a frame's thinned and culled selection is one draw call (a software
// rasteriser runs the vertex stage per instance: instanced quads cost a draw each).
// Keep in sync with `splats::Splat` (a test compares them).
struct SplatPoint {
    position: vec3<f32>,
    node: u32,
    color: vec3<f32>,
    // The surface's facet normal, octahedral, pack2x16snorm.
    normal: u32,
};

struct SplatOut {
    @builtin(position) clip: vec4<f32>,
    @location(0) color: vec3<f32>,
    @location(1) @interpolate(flat) beyond: f32,
    // The quad's corner coordinate, ±1 at its edges.
    @location(2) corner: vec2<f32>,
    // The same point in the corner coordinates of the squeezed footprint (±1 at its edges).
    @location(3) own: vec2<f32>,
};

// `splats::SPLAT_OVERLAP`: a splat's quad over its own extent (its map pixel's patch).
const SPLAT_OVERLAP: f32 = 1.5;

// The quad's corner per vertex of its two triangles, as triangle-strip indices.
const SPLAT_CORNER = array<u32, 6>(0u, 1u, 2u, 2u, 1u, 3u);

// `splats::MIN_SLANT_COSINE` and `splats::MIN_SQUEEZE`.
const MIN_SLANT_COSINE: f32 = 0.3;
const MIN_SQUEEZE: f32 = 0.25;

fn octahedral_decode(e: vec2<f32>) -> vec3<f32> {
    let z = 1.0 - abs(e.x) - abs(e.y);
    var xy = e;
    if z < 0.0 {
        xy = (vec2<f32>(1.0) - abs(e.yx)) * select(vec2<f32>(-1.0), vec2<f32>(1.0), e >= vec2<f32>(0.0));
    }
    return normalize(vec3<f32>(xy, z));
}

// `splats::ndc_differential`: world vector a at clip position c, in NDC.
fn ndc_differential(c: vec4<f32>, a: vec3<f32>) -> vec2<f32> {
    let ac = frame.view_proj * vec4<f32>(a, 0.0);
    return (ac.xy * c.w - c.xy * ac.w) / (c.w * c.w);
}

// `splats::footprint`: Eq. 3 on the surface's own plane, the NDC edges u, v of a map pixel's
// patch where its ray pyramid meets the surface through p with normal n, and the squeeze per
// screen axis that fits it into Eq. 3's box (to no less than a quarter).
struct Patch {
    u: vec2<f32>,
    v: vec2<f32>,
    squeeze: vec2<f32>,
};

fn footprint(view: SplatView, p: vec3<f32>, n: vec3<f32>, c: vec4<f32>) -> Patch {
    let ray = p - view.centre.xyz;
    let scale = dot(ray, view.normal.xyz) / view.centre.w;
    let w = normalize(ray);
    let nw0 = dot(n, w);
    let nw = select(min(nw0, -MIN_SLANT_COSINE), max(nw0, MIN_SLANT_COSINE), nw0 >= 0.0);
    let au = view.pixel_u.xyz * scale;
    let av = view.pixel_v.xyz * scale;
    let su = au - w * (dot(n, au) / nw);
    let sv = av - w * (dot(n, av) / nw);
    let u = ndc_differential(c, su);
    let v = ndc_differential(c, sv);
    // Never wider or taller than Eq. 3's box, nor squeezed below MIN_SQUEEZE.
    let box_extent = abs(ndc_differential(c, au)) + abs(ndc_differential(c, av));
    let s = clamp(box_extent / max(abs(u) + abs(v), vec2<f32>(1e-30)), vec2<f32>(MIN_SQUEEZE), vec2<f32>(1.0));
    return Patch(u, v, s);
}

// `splats::GAP_FILL_DEPTH`: the clip-z scale of the patch outside the squeezed footprint.
const GAP_FILL_DEPTH: f32 = 0.95;

// `splats::ELEMENT_MARGIN` and `splats::OFF_ELEMENT_DEPTH_SCALE`.
const ELEMENT_MARGIN: f32 = 8.0;
const OFF_ELEMENT_DEPTH_SCALE: f32 = 0.001;

// `splats::off_element`: whether the mirrored eye (`frame.eye` in the mirrored view) sees p
// through another element than the map's, by more than ELEMENT_MARGIN map pixels.
fn off_element(view: SplatView, p: vec3<f32>) -> bool {
    let eye = frame.eye.xyz;
    let d = p - eye;
    let t = dot(view.corner.xyz - eye, view.normal.xyz) / dot(d, view.normal.xyz);
    let x = eye + d * t - view.corner.xyz;
    let pu = view.pixel_u.xyz;
    let pv = view.pixel_v.xyz;
    let a = vec2<f32>(dot(x, pu) / dot(pu, pu), dot(x, pv) / dot(pv, pv));
    let inside = all(a >= vec2<f32>(-ELEMENT_MARGIN)) && all(a <= vec2<f32>(view.corner.w + ELEMENT_MARGIN));
    return !inside;
}

@vertex
fn vs_splat(@builtin(vertex_index) vi: u32) -> SplatOut {
    let s = splat_points[splat_kept[vi / 6u]];
    let ci = SPLAT_CORNER[vi % 6u];
    let corner = vec2<f32>(f32(ci & 1u) * 2.0 - 1.0, f32((ci >> 1u) & 1u) * 2.0 - 1.0);
    let node = splat_nodes[s.node];
    let c = frame.view_proj * vec4<f32>(s.position, 1.0);
    // Eq. 3, per point on its own surface: the patch itself, a parallelogram, × the node's
    // spacing (`splats::splat_half_edges`), grown to a pixel along its squeezed box's major
    // axis. The whole patch is drawn; `own` locates each corner in the squeezed footprint.
    let n = octahedral_decode(unpack2x16snorm(s.normal));
    let view = splat_views[node.view];
    let shape = footprint(view, s.position, n, c);
    let f = mat2x2<f32>(shape.u * shape.squeeze, shape.v * shape.squeeze);
    let whole = mat2x2<f32>(shape.u, shape.v);
    var k = 0.5 * node.spacing;
    let pixels = (abs(f[0]) + abs(f[1])) * k / max(node.pixel_ndc, vec2<f32>(1e-30));
    k = k * max(1.0 / max(max(pixels.x, pixels.y), 1e-6), 1.0);
    // Behind the eye the quad is clipped whole; keep its corners finite.
    let offset = select(vec2<f32>(0.0), (whole * corner) * k, c.w > 0.0);
    let det = f[0].x * f[1].y - f[1].x * f[0].y;
    let inv = mat2x2<f32>(vec2<f32>(f[1].y, -f[0].y), vec2<f32>(-f[1].x, f[0].x)) * (1.0 / det);
    let own = select(corner, inv * (whole * corner), abs(det) > 1e-30);
    var out: SplatOut;
    // Lower-ranked maps' depth scaled back (reverse Z), and so is a splat seen through
    // another element than its map's.
    let off = select(1.0, OFF_ELEMENT_DEPTH_SCALE, off_element(view, s.position));
    out.clip = vec4<f32>(c.xy + offset * c.w, c.z * node.depth_scale * off, c.w);
    out.color = s.color * frame.exposure;
    out.beyond = beyond(s.position);
    out.corner = corner;
    out.own = own;
    return out;
}

struct SplatFragment {
    @location(0) color: vec4<f32>,
    @builtin(frag_depth) depth: f32,
};

// A splat's own extent, the ellipse inscribed in its squeezed footprint (the quad over
// SPLAT_OVERLAP), at its depth; the rest of the whole patch's ellipse a little behind
// (GAP_FILL_DEPTH): it closes the gaps the squeeze leaves between rows of splats on a curved
// model, yet loses to a neighbour's own extent at nearly the same depth, so a panel does not
// spill onto the wall it hangs on; the quad's remaining overlap ring far back (depth × 10⁻³,
// reverse Z, as a lower rank is): it fills what no splat covers but never paints over one, so
// a surface in front (an emitter before a wall) is not fattened by it. On the 80° floor of
// `tests/view_gltf_grazing.rs` (image mode, relative RMSE): all of the quad at its depth
// 0.251, Eq. 3's box 0.142, the disc inscribed in the box 0.131, the ellipse in the patch
// squeezed into the box 0.114, with the whole patch's gap fill 0.107.
@fragment
fn fs_splat(in: SplatOut) -> SplatFragment {
    var out: SplatFragment;
    out.color = vec4<f32>(in.color, in.beyond);
    let own = length(in.own) <= 1.0 / SPLAT_OVERLAP;
    let inside = length(in.corner) <= 1.0 / SPLAT_OVERLAP;
    out.depth = select(select(in.clip.z * 1e-3, in.clip.z * GAP_FILL_DEPTH, inside), in.clip.z, own);
    return out;
}

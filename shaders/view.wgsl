// glint-view: the scene lit by its radiosity textures (Bastos et al. 1999 §7).
//
// One draw for the whole scene: every vertex carries its lightmap coordinates in texel units
// of its atlas page and the page's layer in a 2D texture array of Rgba16Float radiosity
// (linear exitant radiance D; for a material with a base colour texture, D over the texture's
// texel mean, multiplied here by the texture, mipmapped: `surface_d`). The fragment shader reconstructs D with the uniform cubic
// B-spline as four bilinear taps (Sigg and Hadwiger 2005); `src/view/cpu/bicubic.rs` is the same
// filter on the CPU (`bspline_4tap`) and the definition it is tested against (`bspline`).
//
// Keep `FrameUniforms` in sync with `src/view/passes/renderer.rs` (a test compares their layouts).

struct FrameUniforms {
    // World to clip: reverse-Z infinite perspective (depth 1 at the near plane, 0 at infinity).
    view_proj: mat4x4<f32>,
    // Width and height of a texture-array layer, in texels (pages are padded to it).
    atlas_size: vec2<f32>,
    // Multiplies D before output (1 for viewer frames: the display pass, display.wgsl, exposes).
    exposure: f32,
    // 1: the colour target is not an sRGB format, so encode sRGB here; 0: the hardware does
    // or the target is linear (viewer frames draw linear radiance; display.wgsl encodes).
    encode_srgb: u32,
    // xyz: the camera's position (cube faces store each fragment's distance from it).
    eye: vec4<f32>,
};

@group(0) @binding(0) var<uniform> frame: FrameUniforms;
@group(0) @binding(1) var radiosity: texture_2d_array<f32>;
@group(0) @binding(2) var radiosity_sampler: sampler;
// The scene's images (sRGB, one per layer from the corner) and per-material records:
// `src/view/gpu/surface_textures.rs` (keep `TexRef` and `MaterialRecord` in sync).
@group(0) @binding(3) var surface_images: texture_2d_array<f32>;
@group(0) @binding(4) var<storage, read> materials: array<MaterialRecord>;

// false: no triangle this pipeline draws has a base colour texture or alpha cut-outs, so
// `surface_d` is D as stored and `cut_out` never holds (`renderer::SurfaceShading`). A
// constant per pipeline rather than a branch per fragment: Mesa's lavapipe runs both sides
// of a branch that varies between fragments, and untaken texture reads cost every fragment
// (docs/tuning.md#surface-textures-override).
override SURFACE_TEXTURES: bool = true;

struct TexRef {
    // layer (< 0: none), width, height, UV set
    a: vec4<f32>,
    // wrap u, wrap v (0 repeat, 1 mirrored repeat, 2 clamp), nearest, rotation
    b: vec4<f32>,
    // offset u, v, scale u, v (KHR_texture_transform)
    c: vec4<f32>,
};

struct MaterialRecord {
    base: TexRef,
    emissive: TexRef,
    emission: vec4<f32>,
    // alpha MASK: cutoff (< 0: opaque), alpha factor, cut-out texture layer (< 0: none)
    alpha: vec4<f32>,
    cutout: TexRef,
};

struct VertexIn {
    @location(0) position: vec3<f32>,
    // Lightmap coordinates in texels of the vertex's page.
    @location(1) lightmap: vec2<f32>,
    @location(2) page: u32,
    @location(3) uv0: vec2<f32>,
    @location(4) uv1: vec2<f32>,
    @location(5) material: u32,
    // A triangle whose back side has texels of its own (`radiosity::back_sides`): its unit
    // face normal and the back's lightmap place; elsewhere a zero normal.
    @location(6) face: vec3<f32>,
    @location(7) lightmap_back: vec2<f32>,
    @location(8) page_back: u32,
};

// Where vertex `v` reads D seen from `eye`: the back side's place when the eye is behind its
// triangle. Every corner of a flat triangle is on its plane, so all three choose alike.
struct LightmapPlace {
    coords: vec2<f32>,
    page: u32,
};

fn lightmap_seen(v: VertexIn, eye: vec3<f32>) -> LightmapPlace {
    if dot(v.face, eye - v.position) < 0.0 {
        return LightmapPlace(v.lightmap_back, v.page_back);
    }
    return LightmapPlace(v.lightmap, v.page);
}

struct VertexOut {
    @builtin(position) clip: vec4<f32>,
    @location(0) lightmap: vec2<f32>,
    @location(1) @interpolate(flat) page: u32,
    @location(2) uv0: vec2<f32>,
    @location(3) uv1: vec2<f32>,
    @location(4) @interpolate(flat) material: u32,
    // `lightmap` at a covered point and at the provoking corner (`lightmap_at`).
    @location(5) @interpolate(perspective, centroid) lightmap_centroid: vec2<f32>,
    @location(6) @interpolate(flat) lightmap_corner: vec2<f32>,
};

@vertex
fn vs_main(v: VertexIn) -> VertexOut {
    return scene_vertex(v);
}

// `VertexOut` and the world position, for the passes that need the view ray at a fragment
// (cube-map faces, glass); the scene pass keeps one varying fewer.
struct WorldOut {
    @builtin(position) clip: vec4<f32>,
    @location(0) lightmap: vec2<f32>,
    @location(1) @interpolate(flat) page: u32,
    @location(2) uv0: vec2<f32>,
    @location(3) uv1: vec2<f32>,
    @location(4) @interpolate(flat) material: u32,
    @location(5) world: vec3<f32>,
};

@vertex
fn vs_world(v: VertexIn) -> WorldOut {
    let s = scene_vertex(v);
    return WorldOut(s.clip, s.lightmap, s.page, s.uv0, s.uv1, s.material, v.position);
}

// `vs_main`'s work, callable by other entry points (`vs_world`).
fn scene_vertex(v: VertexIn) -> VertexOut {
    var out: VertexOut;
    out.clip = frame.view_proj * vec4<f32>(v.position, 1.0);
    let lm = lightmap_seen(v, frame.eye.xyz);
    out.lightmap = lm.coords;
    out.page = lm.page;
    out.uv0 = v.uv0;
    out.uv1 = v.uv1;
    out.material = v.material;
    out.lightmap_centroid = lm.coords;
    out.lightmap_corner = lm.coords;
    return out;
}

// Texels of the lightmap a pixel spans, along both screen axes, above which a triangle that
// covers a multisampled pixel in part reads D at its corner (`lightmap_at`).
const LIGHTMAP_DENSE: f32 = 4.0;

// Texels past a covered point that a partly covered pixel's centre may lie and still be read
// there (`lightmap_at`).
const LIGHTMAP_REACH: f32 = 10.0;

// Where a fragment reads the lightmap. A multisampled pixel is shaded once, at its centre,
// where `centre` is extrapolated past a triangle that covers the pixel in part; where the
// pixel spans many texels (a small or distant triangle), or the centre lies far past the
// covered part (a thin chart seen edge-on: a window slat), that reaches other charts of the
// atlas (a sliver of glossy-room's teapot read the ceiling light's D; slats showed white
// specks from whatever chart the packing put beside theirs). Such a fragment reads at its
// provoking `corner`, inside its own chart; every other one at its centre. A partly covered
// pixel is told by its `centroid` (a covered point) lying off the centre.
fn lightmap_at(centre: vec2<f32>, centroid: vec2<f32>, corner: vec2<f32>) -> vec2<f32> {
    let partial = distance(centre, centroid) > 1e-3;
    let dense = min(length(dpdx(centre)), length(dpdy(centre))) > LIGHTMAP_DENSE;
    let far = distance(centre, centroid) > LIGHTMAP_REACH;
    return select(centre, corner, partial && (dense || far));
}

// Integer texel index i folded into [0, n) (glint::scene::texture::wrap_index).
fn wrap_index(i: i32, n: i32, mode: f32) -> i32 {
    if mode > 1.5 {
        return clamp(i, 0, n - 1);
    }
    if mode > 0.5 {
        let m = ((i % (2 * n)) + 2 * n) % (2 * n);
        return select(2 * n - 1 - m, m, m < n);
    }
    return ((i % n) + n) % n;
}

// The fragment's UV sets' screen derivatives: d0 for uv0, d1 for uv1, each (d/dx, d/dy).
// Taken by each fragment entry point before any branch or discard (derivatives need uniform
// control flow), and passed down to `surface_d`.
struct UvGrads {
    d0: vec4<f32>,
    d1: vec4<f32>,
};

fn uv_grads(uv0: vec2<f32>, uv1: vec2<f32>) -> UvGrads {
    return UvGrads(vec4<f32>(dpdx(uv0), dpdy(uv0)), vec4<f32>(dpdx(uv1), dpdy(uv1)));
}

// No footprint on the screen (a point a ray found): every texture at full resolution.
fn level_zero() -> UvGrads {
    return UvGrads(vec4<f32>(0.0), vec4<f32>(0.0));
}

// Texel (x, y) of mip level `level` of texture `t`, wrapped by that level's own size
// (glint::scene::texture::mips::level_size: halved, rounded down, at least 1).
fn texel(t: TexRef, level: i32, x: i32, y: i32) -> vec4<f32> {
    let w = max(i32(t.a.y) >> u32(level), 1);
    let h = max(i32(t.a.z) >> u32(level), 1);
    let i = wrap_index(x, w, t.b.x);
    let j = wrap_index(y, h, t.b.y);
    return textureLoad(surface_images, vec2<i32>(i, j), i32(t.a.x), level);
}

// Bilinear between the texel centres of level `level` at transformed coordinate `uv`, as
// Image::sample on that level.
fn bilinear(t: TexRef, uv: vec2<f32>, level: i32) -> vec4<f32> {
    let size = vec2<f32>(vec2<i32>(max(i32(t.a.y) >> u32(level), 1), max(i32(t.a.z) >> u32(level), 1)));
    let p = uv * size - vec2<f32>(0.5);
    let p0 = floor(p);
    let f = p - p0;
    let x0 = i32(p0.x);
    let y0 = i32(p0.y);
    let top = mix(texel(t, level, x0, y0), texel(t, level, x0 + 1, y0), f.x);
    let bottom = mix(texel(t, level, x0, y0 + 1), texel(t, level, x0 + 1, y0 + 1), f.x);
    return mix(top, bottom, f.y);
}

// Trilinear: bilinear in the two mip levels around level of detail `lod` (already clamped
// to the image's levels), blended, as glint::scene::texture::mips::sample_trilinear.
fn trilinear(t: TexRef, uv: vec2<f32>, lod: f32) -> vec4<f32> {
    let l0 = floor(lod);
    let a = bilinear(t, uv, i32(l0));
    let f = lod - l0;
    if f <= 0.0 {
        return a;
    }
    return mix(a, bilinear(t, uv, i32(l0) + 1), f);
}

// Most trilinear taps along a footprint's longer axis (glint::scene::texture::mips::MAX_ANISOTROPY).
const MAX_ANISOTROPY: f32 = 16.0;

// Linear RGBA of texture `t` at the fragment's UVs: the transform, then (linear samplers)
// anisotropic filtering as glint::scene::texture::mips::sample_anisotropic: `g`, the UVs'
// screen derivatives in level-0 texels, span a footprint whose shorter axis picks the level
// of detail (the ratio of the axes clamped to MAX_ANISOTROPY) and whose longer axis carries
// ceil(ratio) trilinear taps, averaged, so a grazing view keeps detail across its
// footprint. Nearest samplers (glTF magFilter NEAREST; the scene keeps no minFilter) read
// the nearest level-0 texel, as Image::sample.
fn sample_surface(t: TexRef, uv0: vec2<f32>, uv1: vec2<f32>, g: UvGrads) -> vec4<f32> {
    let uv_in = select(uv0, uv1, t.a.w > 0.5);
    let s = sin(t.b.w);
    let c = cos(t.b.w);
    let q = uv_in * t.c.zw;
    let uv = t.c.xy + vec2<f32>(c * q.x + s * q.y, -s * q.x + c * q.y);
    if t.b.z > 0.5 {
        let n = floor(uv * t.a.yz);
        return texel(t, 0, i32(n.x), i32(n.y));
    }
    // The transform's linear part applied to the derivatives, in level-0 texels.
    let d = select(g.d0, g.d1, t.a.w > 0.5);
    let qx = d.xy * t.c.zw;
    let qy = d.zw * t.c.zw;
    let dx = vec2<f32>(c * qx.x + s * qx.y, -s * qx.x + c * qx.y) * t.a.yz;
    let dy = vec2<f32>(c * qy.x + s * qy.y, -s * qy.x + c * qy.y) * t.a.yz;
    let lx = dot(dx, dx);
    let ly = dot(dy, dy);
    let major = select(dy, dx, lx >= ly);
    let major2 = max(lx, ly);
    let minor2 = min(lx, ly);
    let ratio = clamp(sqrt(major2 / max(minor2, 1e-20)), 1.0, MAX_ANISOTROPY);
    let top = min(firstLeadingBit(u32(max(t.a.y, t.a.z))), textureNumLevels(surface_images) - 1u);
    // log2(0) is −∞: no footprint clamps to level 0.
    let lod = clamp(0.5 * log2(major2 / (ratio * ratio)), 0.0, f32(top));
    let n = u32(ceil(ratio));
    let axis = major / t.a.yz;
    var sum = vec4<f32>(0.0);
    for (var i = 0u; i < n; i++) {
        let k = (f32(i) + 0.5) / f32(n) - 0.5;
        sum += trilinear(t, uv + axis * k, lod);
    }
    return sum / f32(n);
}

// Whether the fragment lies in a cut-out (alpha MASK: factor × base colour alpha < cutoff),
// as glint::scene::texturing::cut_out: rays pass there, so it is not drawn. The test reads
// level 0, as the solve's and the path tracer's rays do: a level's averaged alpha would
// thin the coverage away with distance.
fn cut_out(material: u32, uv0: vec2<f32>, uv1: vec2<f32>) -> bool {
    if !SURFACE_TEXTURES {
        return false;
    }
    let m = materials[material];
    if m.alpha.x < 0.0 {
        return false;
    }
    var a = m.alpha.y;
    if m.alpha.z >= 0.0 {
        a = a * sample_surface(m.cutout, uv0, uv1, level_zero()).a;
    }
    return a < m.alpha.x;
}

// D at the fragment from the stored texel value q (glint::scene::texturing): q itself for a
// material without a base colour texture, else q · t(x) + E(x), the textures filtered over
// the footprint `g` gives (`sample_surface`).
fn surface_d(q: vec3<f32>, material: u32, uv0: vec2<f32>, uv1: vec2<f32>, g: UvGrads) -> vec3<f32> {
    if !SURFACE_TEXTURES {
        return q;
    }
    let m = materials[material];
    if m.base.a.x < 0.0 {
        return q;
    }
    let t = sample_surface(m.base, uv0, uv1, g).rgb;
    var e = m.emission.rgb;
    if m.emissive.a.x >= 0.0 {
        e = e * sample_surface(m.emissive, uv0, uv1, g).rgb;
    }
    return q * t + e;
}

// Specular anti-aliasing of the passes appended to this file (curved reflectors, probes):
// the pixel filter's variance σ² and the most the kernel may add to α², κ (Filament's
// defaults).
const SAA_SIGMA2: f32 = 0.15;
const SAA_KAPPA: f32 = 0.2;

// α² the shading normal's spread across the pixel adds to every lobe (0 where the pass has
// no pixel footprint), so that a highlight narrower than a pixel is spread over it.
// Tokuyoshi & Kaplanyan 2019 (Filament's specularAntiAliasing): α² += min(2σ²(|∂n/∂x|² + |∂n/∂y|²), κ).
// Fragment stages only (derivatives), in uniform control flow.
fn kernel_roughness2(n: vec3<f32>) -> f32 {
    let du = dpdx(n);
    let dv = dpdy(n);
    return min(2.0 * SAA_SIGMA2 * (dot(du, du) + dot(dv, dv)), SAA_KAPPA);
}

// Cubic B-spline reconstruction at continuous texel coordinates `p` of layer `page`
// (texel (i, j) spans [i, i+1) x [j, j+1)): per axis, weights (w0, w1) and (w2, w3) of the
// four texels around p become one bilinear tap each, placed between the pair's two texel
// centres where linear interpolation yields the pair's weighted mean.
fn sample_radiosity(p: vec2<f32>, page: u32) -> vec3<f32> {
    let q = p - vec2<f32>(0.5);
    let i = floor(q);
    let f = q - i;
    let g = vec2<f32>(1.0) - f;
    let f2 = f * f;
    let f3 = f2 * f;
    let w0 = g * g * g / 6.0;
    let w1 = (vec2<f32>(4.0) - 6.0 * f2 + 3.0 * f3) / 6.0;
    let w2 = (vec2<f32>(1.0) + 3.0 * f + 3.0 * f2 - 3.0 * f3) / 6.0;
    let w3 = f3 / 6.0;
    // g0, g1 >= 1/6 on [0, 1]: the divisions are safe.
    let g0 = w0 + w1;
    let g1 = w2 + w3;
    let h0 = (i - vec2<f32>(0.5) + w1 / g0) / frame.atlas_size;
    let h1 = (i + vec2<f32>(1.5) + w3 / g1) / frame.atlas_size;
    let s00 = textureSampleLevel(radiosity, radiosity_sampler, vec2<f32>(h0.x, h0.y), page, 0.0).rgb;
    let s10 = textureSampleLevel(radiosity, radiosity_sampler, vec2<f32>(h1.x, h0.y), page, 0.0).rgb;
    let s01 = textureSampleLevel(radiosity, radiosity_sampler, vec2<f32>(h0.x, h1.y), page, 0.0).rgb;
    let s11 = textureSampleLevel(radiosity, radiosity_sampler, vec2<f32>(h1.x, h1.y), page, 0.0).rgb;
    return g0.y * (g0.x * s00 + g1.x * s10) + g1.y * (g0.x * s01 + g1.x * s11);
}

// The sRGB transfer curve (IEC 61966-2-1), as `glint::image_io::linear_to_srgb`.
fn linear_to_srgb(c: vec3<f32>) -> vec3<f32> {
    let v = clamp(c, vec3<f32>(0.0), vec3<f32>(1.0));
    let lo = 12.92 * v;
    let hi = 1.055 * pow(v, vec3<f32>(1.0 / 2.4)) - 0.055;
    return select(hi, lo, v <= vec3<f32>(0.0031308));
}

struct FragmentOut {
    // Display colour: linear, encoded to sRGB by the target format (or here).
    @location(0) color: vec4<f32>,
    // Linear radiance for HDR output (the pipeline leaves this target out when not wanted).
    @location(1) hdr: vec4<f32>,
};

// Triangles of alpha-masked materials: cut-outs discarded, then shaded as `fs_opaque`.
@fragment
fn fs_main(in: VertexOut) -> FragmentOut {
    let g = uv_grads(in.uv0, in.uv1);
    if cut_out(in.material, in.uv0, in.uv1) {
        discard;
    }
    return shade(in, g);
}

// Every other triangle. A shader that never discards lets the depth test run before shading
// (docs/tuning.md#opaque-entry-point), so opaque runs of
// triangles are drawn with this entry point (`renderer::alpha_runs`).
@fragment
fn fs_opaque(in: VertexOut) -> FragmentOut {
    return shade(in, uv_grads(in.uv0, in.uv1));
}

fn shade(in: VertexOut, g: UvGrads) -> FragmentOut {
    let lightmap = lightmap_at(in.lightmap, in.lightmap_centroid, in.lightmap_corner);
    let q = max(sample_radiosity(lightmap, in.page), vec3<f32>(0.0));
    let d = surface_d(q, in.material, in.uv0, in.uv1, g) * frame.exposure;
    var out: FragmentOut;
    var color = d;
    if frame.encode_srgb != 0u {
        color = linear_to_srgb(d);
    }
    out.color = vec4<f32>(color, 1.0);
    out.hdr = vec4<f32>(d, 1.0);
    return out;
}

// Test entry: reconstructs D at given lightmap coordinates, to hold this shader's filter to
// the CPU's (`bicubic_probe` in src/view/gpu/probe.rs; tests/view.rs). Keep `ProbeInput` in sync
// with `probe::ProbeInput`.
struct ProbeInput {
    lightmap: vec2<f32>,
    page: u32,
    _pad: u32,
};

@group(1) @binding(0) var<storage, read> probe_in: array<ProbeInput>;
@group(1) @binding(1) var<storage, read_write> probe_out: array<vec4<f32>>;

@compute @workgroup_size(64)
fn cs_probe(@builtin(global_invocation_id) id: vec3<u32>) {
    let k = id.x;
    if k >= arrayLength(&probe_in) {
        return;
    }
    probe_out[k] = vec4<f32>(sample_radiosity(probe_in[k].lightmap, probe_in[k].page), 1.0);
}

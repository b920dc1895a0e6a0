// glint-view: gaps between image-mode splats closed in the reflected image M before its
// pyramid and the composite read it (`src/view/reflections/gap_fill.rs`, whose CPU form
// `gap_fill::fill` this shader follows).
//
// Where rows of splats do not meet (a surface the radiance maps saw at a grazing angle), M
// shows whatever lies farther behind the mirror through the gap. A texel is taken for such a
// gap when, along at least 3 of the 4 axes (horizontal, vertical, both diagonals), a texel
// nearer the mirror lies within `GAP_RADIUS` on both sides; it then takes the mean of those
// nearer texels. A background texel beside a silhouette has nearer texels on one side only,
// so it is kept. Image-space hole filling for point rendering in the manner of Rosenthal and
// Linsen (2008); the depth compared is M's alpha, the fraction a of the reflected ray beyond
// the plane, as a / (1 − a), the distance behind the plane over the eye's height above it.

@group(0) @binding(0) var source: texture_2d<f32>;

// Keep in sync with `gap_fill::GAP_RADIUS`, `gap_fill::NEARER` and `gap_fill::MIN_AXES`.
const GAP_RADIUS: i32 = 3;
const NEARER: f32 = 0.8;
const MIN_AXES: i32 = 3;

@vertex
fn vs_full(@builtin(vertex_index) i: u32) -> @builtin(position) vec4<f32> {
    let uv = vec2<f32>(f32((i << 1u) & 2u), f32(i & 2u));
    return vec4<f32>(uv * 2.0 - vec2<f32>(1.0), 0.0, 1.0);
}

fn behind(a: f32) -> f32 {
    return a / max(1.0 - a, 1e-6);
}

// The first texel within GAP_RADIUS of `c` along `step` that lies nearer than `limit`
// (alpha 0: none).
fn nearer(c: vec2<i32>, step: vec2<i32>, limit: f32) -> vec4<f32> {
    let size = vec2<i32>(textureDimensions(source));
    for (var r = 1; r <= GAP_RADIUS; r = r + 1) {
        let q = c + step * r;
        if any(q < vec2<i32>(0)) || any(q >= size) {
            break;
        }
        let t = textureLoad(source, q, 0);
        if t.a > 0.0 && behind(t.a) < limit {
            return t;
        }
    }
    return vec4<f32>(0.0);
}

@fragment
fn fs_gap_fill(@builtin(position) p: vec4<f32>) -> @location(0) vec4<f32> {
    let c = vec2<i32>(floor(p.xy));
    let m = textureLoad(source, c, 0);
    if m.a <= 0.0 {
        return m;
    }
    let limit = behind(m.a) * NEARER;
    let axes = array<vec2<i32>, 4>(vec2<i32>(1, 0), vec2<i32>(1, 1), vec2<i32>(0, 1), vec2<i32>(-1, 1));
    var held = 0;
    var sum = vec4<f32>(0.0);
    for (var k = 0; k < 4; k = k + 1) {
        // Stop once too few axes are left to reach MIN_AXES (most texels: at once).
        if held + (4 - k) < MIN_AXES {
            break;
        }
        let a = nearer(c, axes[k], limit);
        if a.a <= 0.0 {
            continue;
        }
        let b = nearer(c, -axes[k], limit);
        if b.a <= 0.0 {
            continue;
        }
        held = held + 1;
        sum = sum + a + b;
    }
    if held >= MIN_AXES {
        return sum / f32(2 * held);
    }
    return m;
}

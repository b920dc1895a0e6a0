//! Reflected billboards' capture (Popescu et al. 2006 §3): where the billboard of an object
//! for a reflector lies, and its colour, alpha and (for reflective objects) normals, by ray
//! casting the object's own triangles. A bake kernel: pure, deterministic, no GPU. The viewer
//! packs and traces billboards in `view::billboard_tables` (feature `view`).

use glam::{Vec2, Vec3};

use super::capture::ColourSource;
use crate::geometry::Triangle;
use crate::scene::Scene;

/// Field of view of the billboard capture (§3: "a narrow field of view (10°) to avoid
/// perspective effects").
pub const CAPTURE_FOV_DEGREES: f32 = 10.0;

/// One billboard before packing.
#[derive(Clone, Debug, PartialEq)]
pub struct Billboard {
    /// Impostor object it stands for.
    pub impostor: usize,
    /// Centre B.
    pub centre: Vec3,
    /// Right axis (unit).
    pub right: Vec3,
    /// Up axis (unit).
    pub up: Vec3,
    /// Half size along `right`, metres.
    pub half: f32,
    /// Half size along `up`, metres (= `half` for a square billboard).
    pub half_up: f32,
    /// Resolution.
    pub resolution: u32,
    /// Colour and alpha per texel (w², row 0 at the top).
    pub colour: Vec<[f32; 4]>,
    /// Per-texel normals of a reflective billboard (xyz; w: the surface's offset from the
    /// plane along its normal), with its ks and tertiary group.
    pub reflective: Option<(Vec<glam::Vec4>, Vec3, usize)>,
    /// Transition wall height H (§3.2), 0 when not connected to the environment.
    pub wall: f32,
}

/// Area-weighted centroid of triangles.
pub fn centroid(tris: &[Triangle]) -> Vec3 {
    let (mut sum, mut area) = (Vec3::ZERO, 0.0f32);
    for t in tris {
        let a = 0.5 * (t.p[1] - t.p[0]).cross(t.p[2] - t.p[0]).length();
        sum += a * (t.p[0] + t.p[1] + t.p[2]) / 3.0;
        area += a;
    }
    if area > 0.0 {
        sum / area
    } else {
        tris.first().map_or(Vec3::ZERO, |t| t.p[0])
    }
}

/// The billboard's frame: centre, right, up (right × up faces the reflector), half sizes.
struct Frame {
    centre: Vec3,
    right: Vec3,
    up: Vec3,
    half: f32,
    half_up: f32,
}

/// §3 "a billboard that tightly approximates" a flat object (a floor, a table top): the
/// object's own plane, facing the side of `towards`, as the rectangle of its outline (axes
/// along the outline's principal directions), so every reflector sees the same billboard and
/// the texels lie on the surface itself (no parallax).
fn surface_frame(tris: &[Triangle], plane: &crate::scene::Plane, towards: Vec3) -> Frame {
    let n = plane.normal;
    let axis = if (towards - plane.point).dot(n) >= 0.0 {
        n
    } else {
        -n
    };
    let helper = if axis.y.abs() < 0.9 { Vec3::Y } else { Vec3::X };
    let e1 = helper.cross(axis).normalize();
    let e2 = axis.cross(e1);
    let points: Vec<Vec3> = tris.iter().flat_map(|t| t.p).collect();
    // Principal in-plane direction of the surface: its area second moments (a triangle's is
    // A/12 (Σ vᵢvᵢᵀ + s sᵀ), s = Σ vᵢ), so shared vertices do not bias it.
    let (mut cxx, mut cxy, mut cyy) = (0.0f32, 0.0f32, 0.0f32);
    for t in tris {
        let v = t.p.map(|p| {
            let q = p - plane.point;
            Vec2::new(q.dot(e1), q.dot(e2))
        });
        let area = 0.5 * (t.p[1] - t.p[0]).cross(t.p[2] - t.p[0]).length();
        let s = v[0] + v[1] + v[2];
        let k = area / 12.0;
        cxx += k * (v.iter().map(|q| q.x * q.x).sum::<f32>() + s.x * s.x);
        cxy += k * (v.iter().map(|q| q.x * q.y).sum::<f32>() + s.x * s.y);
        cyy += k * (v.iter().map(|q| q.y * q.y).sum::<f32>() + s.y * s.y);
    }
    let theta = 0.5 * (2.0 * cxy).atan2(cxx - cyy);
    let right = (e1 * theta.cos() + e2 * theta.sin()).normalize();
    let up = axis.cross(right);
    let (mut lo, mut hi) = (Vec2::splat(f32::INFINITY), Vec2::splat(f32::NEG_INFINITY));
    for p in &points {
        let q = *p - plane.point;
        let v = Vec2::new(q.dot(right), q.dot(up));
        lo = lo.min(v);
        hi = hi.max(v);
    }
    let mid = 0.5 * (lo + hi);
    // A hair larger than the outline so its edges are inside.
    let half = (0.5 * (hi - lo)).max(Vec2::splat(1e-6)) * (1.0 + 1e-4);
    Frame {
        centre: plane.point + right * mid.x + up * mid.y,
        right,
        up,
        half: half.x,
        half_up: half.y,
    }
}

/// §3: the billboard of `object` (its triangles) for a reflector with centroid `towards`.
/// Centroid placement (`surface` `None`): the plane through the object's centroid B
/// perpendicular to B→reflector, captured by casting one ray per texel from a camera on that
/// line with a 10° field of view holding the object's bounding sphere. Surface placement: the
/// flat object's own plane (`surface_frame`), captured by rays along its normal. Colour is
/// `colour` at the hit (D or the albedo, as the SRDM stage), alpha the coverage; `normals`
/// asks for per-texel normals (a reflective object).
pub fn capture(
    scene: &Scene,
    ids: &[u32],
    towards: Vec3,
    surface: Option<&crate::scene::Plane>,
    resolution: u32,
    colour: &ColourSource,
    normals: bool,
) -> (Billboard, Option<Vec<glam::Vec4>>) {
    let tris: Vec<Triangle> = ids.iter().map(|&t| scene.triangles[t as usize]).collect();
    let b = centroid(&tris);
    let radius = tris
        .iter()
        .flat_map(|t| t.p)
        .map(|p| (p - b).length())
        .fold(1e-6f32, f32::max);
    // Centroid placement: the perspective camera's eye; surface: none (parallel rays).
    let (frame, eye) = match surface {
        Some(plane) => (surface_frame(&tris, plane, towards), None),
        None => {
            let axis = (towards - b).try_normalize().unwrap_or(Vec3::Z);
            let helper = if axis.y.abs() < 0.9 { Vec3::Y } else { Vec3::X };
            let right = helper.cross(axis).normalize();
            // Seen from the reflector's side: right × up = axis.
            let up = axis.cross(right);
            let half_angle = (0.5 * CAPTURE_FOV_DEGREES).to_radians();
            let distance = radius / half_angle.sin();
            let half =
                radius * distance / (distance * distance - radius * radius).max(1e-12).sqrt();
            let frame = Frame {
                centre: b,
                right,
                up,
                half,
                half_up: half,
            };
            (frame, Some(b + axis * distance))
        }
    };
    let axis = frame.right.cross(frame.up);
    let lift = 1e-3 * radius + 1e-4;
    let bvh = scene.build_bvh_of(ids);
    let w = resolution as usize;
    let mut col = vec![[0.0f32; 4]; w * w];
    let mut nrm = vec![glam::Vec4::ZERO; w * w];
    for y in 0..w {
        for x in 0..w {
            let u = ((x as f32 + 0.5) / w as f32) * 2.0 - 1.0;
            let v = 1.0 - ((y as f32 + 0.5) / w as f32) * 2.0;
            let target =
                frame.centre + frame.right * (u * frame.half) + frame.up * (v * frame.half_up);
            let (origin, dir) = match eye {
                Some(e) => (e, (target - e).normalize()),
                None => (target + axis * lift, -axis),
            };
            if let Some(hit) = bvh.closest_hit(origin, dir, f32::INFINITY) {
                let t = &tris[hit.triangle as usize];
                let back = dir.dot(t.face_normal()) > 0.0;
                let c = colour.colour(scene, ids[hit.triangle as usize], hit.bary, back);
                col[y * w + x] = [c.x, c.y, c.z, 1.0];
                let Vec2 { x: bu, y: bv } = hit.bary;
                let mut n = (t.n[0] * (1.0 - bu - bv) + t.n[1] * bu + t.n[2] * bv)
                    .try_normalize()
                    .unwrap_or(axis);
                if n.dot(dir) > 0.0 {
                    n = -n;
                }
                let offset = (origin + dir * hit.t - frame.centre).dot(axis);
                nrm[y * w + x] = n.extend(offset);
            }
        }
    }
    // Centroid placement: the plane moves along the axis to the captured surface's mean depth
    // (the texels' mean offset), where the reflector's rays meet the object, so the parallax
    // of a deep object (a block whose near faces stand 0.2 m before its centroid) halves. The
    // capture rays are the same, so the quad shrinks to where they cross the moved plane.
    let mut frame = frame;
    if let Some(e) = eye {
        let covered: Vec<f32> = col
            .iter()
            .zip(&nrm)
            .filter(|(c, _)| c[3] > 0.0)
            .map(|(_, n)| n.w)
            .collect();
        let distance = (e - frame.centre).length();
        if !covered.is_empty() {
            let depth = covered.iter().sum::<f32>() / covered.len() as f32;
            let depth = depth.clamp(-radius, radius).min(0.9 * distance);
            let scale = (distance - depth) / distance;
            frame.centre += axis * depth;
            frame.half *= scale;
            frame.half_up *= scale;
            for n in &mut nrm {
                n.w -= depth;
            }
        }
    }
    (
        Billboard {
            impostor: 0,
            centre: frame.centre,
            right: frame.right,
            up: frame.up,
            half: frame.half,
            half_up: frame.half_up,
            resolution,
            colour: col,
            reflective: None,
            wall: 0.0,
        },
        normals.then_some(nrm),
    )
}

/// Where the billboard of an object at `b` looks for a planar reflector with normal `n` and
/// centroid `towards`. §3's line from B to the reflector's centroid is nearly along the normal
/// for an object standing on a mirror (bunny-mirror's bunny sits over the floor's centre),
/// which lays the billboard flat, seen from under the floor, while the floor's reflected
/// rays meet the object from the side, from the viewer's side of it. So the billboard stands
/// upright in the reflector's frame, facing the scene's first camera keyframe (as the SRDM
/// bake's first view), the direction projected into the reflector's plane; without a camera,
/// the projected line to the centroid, else +Z.
pub fn planar_target(b: Vec3, towards: Vec3, n: Vec3, camera: Option<Vec3>) -> Vec3 {
    let flat = |v: Vec3| v - n * v.dot(n);
    let candidates = [
        camera.map(|c| c - b),
        Some(towards - b),
        Some(Vec3::Z),
        Some(Vec3::X),
    ];
    for v in candidates.into_iter().flatten() {
        let v = v.normalize_or_zero();
        let f = flat(v);
        if f.length() > 0.2 {
            return b + f.normalize();
        }
    }
    b + Vec3::Z
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn planar_reflectors_get_upright_billboards() {
        // An object right above the floor's centroid: the camera's side.
        let t = planar_target(Vec3::Y, Vec3::ZERO, Vec3::Y, Some(Vec3::new(0.0, 2.0, 3.0)));
        assert!((t - Vec3::new(0.0, 1.0, 1.0)).length() < 1e-6, "{t}");
        // Without a camera, off-centre: the projected line to the centroid.
        let t = planar_target(Vec3::new(2.0, 1.0, 0.0), Vec3::ZERO, Vec3::Y, None);
        assert!((t - Vec3::new(1.0, 1.0, 0.0)).length() < 1e-6, "{t}");
    }
}

//! Reflected billboards (Popescu et al. 2006 §3): their capture from the scene, their packing
//! for `shaders/billboards.wgsl`, and the CPU reference of the per-ray algorithm of §3.1 with
//! the billboard-to-environment morph of §3.2. Pure: no GPU here; [`super::impostors`]
//! uploads the tables.
//!
//! Layout: billboards are grouped per reflector ([`BillboardTables::groups`]): group g holds
//! the billboards made for reflector g (one per impostor object, §3: "a different billboard is
//! used for each reflector") and that reflector's environment map, if any. A reflective
//! billboard (an impostor object that is itself a glossy reflector) carries per-texel normals
//! and names the group its tertiary rays search (the billboards made for it).
//!
//! Made at viewer load time (not baked): a billboard depends on the pair (object, reflector),
//! which the viewer decides (`--impostors`, `--curved impostor`), and costs one 10° ray-cast
//! capture of w² rays, milliseconds for the shipped scenes.

use bytemuck::{Pod, Zeroable};
use glam::{Vec2, Vec3};

use crate::bake::materials::envmap::{CubeMap, locate};
use crate::bake::srdm_stage::{ColourSource, impostor_triangles};
use crate::geometry::{Bvh, Triangle};
use crate::scene::Scene;

use super::impostor_tables::ImpostorReflector;

/// Field of view of the billboard capture (§3: "a narrow field of view (10°) to avoid
/// perspective effects").
pub const CAPTURE_FOV_DEGREES: f32 = 10.0;

/// Billboard resolution unless set, texels per side.
pub const DEFAULT_RESOLUTION: u32 = 128;

/// Alpha at and above which a billboard texel is opaque (the alpha test).
pub const ALPHA_CUTOFF: f32 = 0.5;

/// Smallest ray parameter accepted (metres): keeps a ray off the surface it leaves.
pub const T_MIN: f32 = 1e-4;

/// No normals / no tertiary group / no environment map.
pub const NONE: u32 = u32::MAX;

/// One billboard as the shader reads it (`Billboard` in `shaders/billboards.wgsl`).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct GpuBillboard {
    /// xyz: centre B; w: half size s along the right axis (metres).
    pub centre: [f32; 4],
    /// xyz: right axis (unit); w: transition wall height H (§3.2; 0: not connected).
    pub right: [f32; 4],
    /// xyz: up axis (unit); w: half size along it (metres; a surface billboard is a
    /// rectangle). The quad's normal is right × up; walls rise along it.
    pub up: [f32; 4],
    /// rgb: ks of a reflective object's mirror lobe; w: 0.
    pub spec: [f32; 4],
    /// Resolution w, first colour texel, first normal texel ([`NONE`]: diffuse), tertiary
    /// group ([`NONE`]: none).
    pub info: [u32; 4],
}

/// A group: the billboards made for one reflector and its environment map.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct GpuGroup {
    /// First billboard, count, first environment texel ([`NONE`]: no map), face size.
    pub range: [u32; 4],
    /// xyz: the environment map's centre E (§3.2); w: 0.
    pub centre: [f32; 4],
}

/// Every billboard, packed.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct BillboardTables {
    /// Per billboard, grouped.
    pub billboards: Vec<GpuBillboard>,
    /// Per group (reflector).
    pub groups: Vec<GpuGroup>,
    /// Colour (rgb) and alpha per texel, row 0 at the top.
    pub texels: Vec<[f32; 4]>,
    /// Per texel of reflective billboards: unit normal (xyz) and the captured surface's
    /// offset from the billboard's plane along its normal (w).
    pub normals: Vec<[f32; 4]>,
    /// Environment cube maps, faces in [`crate::bake::materials::envmap::FACE_NAMES`] order,
    /// rgb per texel.
    pub env: Vec<[f32; 4]>,
}

/// One group to pack: the billboards made for a reflector, and its environment map with the
/// map's centre E.
pub type Group<'a> = (Vec<Billboard>, Option<(&'a CubeMap, Vec3)>);

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

impl BillboardTables {
    /// Packs `groups[g]` = (billboards made for reflector g, its environment map and centre).
    pub fn pack(groups: &[Group<'_>]) -> BillboardTables {
        let mut t = BillboardTables::default();
        for (bbs, env) in groups {
            let first = t.billboards.len() as u32;
            for b in bbs {
                let w = b.resolution;
                assert_eq!(b.colour.len(), (w * w) as usize, "colour is w² texels");
                let (normals, spec, tertiary) = match &b.reflective {
                    Some((n, ks, g)) => {
                        assert_eq!(n.len(), (w * w) as usize, "normals are w² texels");
                        let first = t.normals.len() as u32;
                        t.normals.extend(n.iter().map(|v| v.to_array()));
                        (first, *ks, *g as u32)
                    }
                    None => (NONE, Vec3::ZERO, NONE),
                };
                t.billboards.push(GpuBillboard {
                    centre: b.centre.extend(b.half).to_array(),
                    right: b.right.extend(b.wall).to_array(),
                    up: b.up.extend(b.half_up).to_array(),
                    spec: spec.extend(0.0).to_array(),
                    info: [w, t.texels.len() as u32, normals, tertiary],
                });
                t.texels.extend_from_slice(&b.colour);
            }
            let (env_first, size, centre) = match env {
                Some((map, e)) => {
                    let first = t.env.len() as u32;
                    for f in 0..6 {
                        t.env
                            .extend(map.face(f).iter().map(|c| c.extend(1.0).to_array()));
                    }
                    (first, map.size as u32, *e)
                }
                None => (NONE, 0, Vec3::ZERO),
            };
            t.groups.push(GpuGroup {
                range: [first, bbs.len() as u32, env_first, size],
                centre: centre.extend(0.0).to_array(),
            });
        }
        t
    }

    /// Environment map of group `g` in direction `d` (nearest texel), `None` without one.
    pub fn env(&self, g: usize, d: Vec3) -> Option<Vec3> {
        let [_, _, first, size] = self.groups[g].range;
        if first == NONE || size == 0 {
            return None;
        }
        let (face, s, t) = locate(d);
        let x = ((s * 0.5 + 0.5) * size as f32)
            .floor()
            .clamp(0.0, size as f32 - 1.0) as u32;
        let y = ((t * 0.5 + 0.5) * size as f32)
            .floor()
            .clamp(0.0, size as f32 - 1.0) as u32;
        let i = first + (face as u32 * size + y) * size + x;
        Some(Vec3::from_slice(&self.env[i as usize][..3]))
    }
}

/// Where a ray met a billboard.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BillboardHit {
    /// Ray parameter.
    pub t: f32,
    /// Billboard index.
    pub billboard: u32,
    /// Texel index (into [`BillboardTables::texels`]).
    pub texel: u32,
    /// Wall height h of a §3.2 transition-wall hit, negative for a quad hit.
    pub wall_h: f32,
}

/// What a ray gathered (`BbResult`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BillboardShade {
    /// 0: nothing (no hit, no environment map); 1: a diffuse billboard texel; 2: a reflective
    /// billboard (texel + ks × tertiary); 3: the environment map; 4: a transition wall (§3.2).
    pub kind: u32,
    /// Linear colour.
    pub colour: Vec3,
    /// Ray parameter of the hit (0 for the environment).
    pub t: f32,
    /// Billboard hit, [`NONE`] for the environment or nothing.
    pub billboard: u32,
}

fn v3(a: [f32; 4]) -> Vec3 {
    Vec3::new(a[0], a[1], a[2])
}

impl BillboardTables {
    /// The nearest alpha-tested hit of `o + t d`, t ∈ (T_MIN, t_max), among group `g`'s
    /// billboards (only the diffuse ones when `diffuse_only`), with the transition walls of
    /// connected billboards (§3.2). Same steps as `bb_nearest`.
    pub fn nearest(
        &self,
        g: usize,
        o: Vec3,
        d: Vec3,
        t_max: f32,
        diffuse_only: bool,
    ) -> Option<BillboardHit> {
        let [first, count, ..] = self.groups[g].range;
        let mut best: Option<BillboardHit> = None;
        let mut best_t = t_max;
        for i in first..first + count {
            let b = &self.billboards[i as usize];
            if diffuse_only && b.info[2] != NONE {
                continue;
            }
            let (c, s, su) = (v3(b.centre), b.centre[3], b.up[3]);
            let (r, u) = (v3(b.right), v3(b.up));
            let n = r.cross(u);
            let denom = d.dot(n);
            if denom.abs() > 1e-8 {
                let t = (c - o).dot(n) / denom;
                if t > T_MIN && t < best_t {
                    let p = o + d * t - c;
                    let (x, y) = (p.dot(r) / s, p.dot(u) / su);
                    if x.abs() <= 1.0 && y.abs() <= 1.0 {
                        let w = b.info[0];
                        let tx = ((x * 0.5 + 0.5) * w as f32)
                            .floor()
                            .clamp(0.0, w as f32 - 1.0);
                        let ty = ((0.5 - y * 0.5) * w as f32)
                            .floor()
                            .clamp(0.0, w as f32 - 1.0);
                        let texel = b.info[1] + ty as u32 * w + tx as u32;
                        if self.texels[texel as usize][3] >= ALPHA_CUTOFF {
                            best_t = t;
                            best = Some(BillboardHit {
                                t,
                                billboard: i,
                                texel,
                                wall_h: -1.0,
                            });
                        }
                    }
                }
            }
            // §3.2: the transition walls of height H on the quad's four edges.
            let height = b.right[3];
            if height > 0.0 {
                for (axis, along, off, ext) in
                    [(r, u, s, su), (-r, u, s, su), (u, r, su, s), (-u, r, su, s)]
                {
                    let den = d.dot(axis);
                    if den.abs() <= 1e-8 {
                        continue;
                    }
                    let t = (off - (o - c).dot(axis)) / den;
                    if !(t > T_MIN && t < best_t) {
                        continue;
                    }
                    let p = o + d * t - c;
                    let h = p.dot(n);
                    if p.dot(along).abs() <= ext && (0.0..=height).contains(&h) {
                        best_t = t;
                        best = Some(BillboardHit {
                            t,
                            billboard: i,
                            texel: NONE,
                            wall_h: h,
                        });
                    }
                }
            }
        }
        best
    }

    /// §3.2: the colour of a ray that hit a transition wall at a = o + t d, height h: the
    /// environment map along r_m, the blend of r_a (from E to a) and r₁ᵈ (direction d) by h/H.
    fn morph(&self, g: usize, hit: &BillboardHit, o: Vec3, d: Vec3) -> Vec3 {
        let b = &self.billboards[hit.billboard as usize];
        let e = v3(self.groups[g].centre);
        let a = o + d * hit.t;
        let ra = (a - e).normalize_or_zero();
        let k = (hit.wall_h / b.right[3]).clamp(0.0, 1.0);
        let rm = ra * (1.0 - k) + d * k;
        self.env(g, rm).unwrap_or(Vec3::ZERO)
    }

    /// §3.1 for one reflected ray `o + t d` of a pixel of reflector group `g`: the nearest
    /// billboard texel; for a reflective billboard, its texel plus ks × what the tertiary ray
    /// (reflected about the texel's normal) finds among the diffuse billboards of its group,
    /// else that group's environment; with no hit, the environment map. Same steps as
    /// `bb_trace`.
    pub fn trace(&self, g: usize, o: Vec3, d: Vec3, t_max: f32) -> BillboardShade {
        let miss = |g: usize, d: Vec3| match self.env(g, d) {
            Some(c) => BillboardShade {
                kind: 3,
                colour: c,
                t: 0.0,
                billboard: NONE,
            },
            None => BillboardShade {
                kind: 0,
                colour: Vec3::ZERO,
                t: 0.0,
                billboard: NONE,
            },
        };
        let Some(hit) = self.nearest(g, o, d, t_max, false) else {
            return miss(g, d);
        };
        if hit.texel == NONE {
            return BillboardShade {
                kind: 4,
                colour: self.morph(g, &hit, o, d),
                t: hit.t,
                billboard: hit.billboard,
            };
        }
        let b = &self.billboards[hit.billboard as usize];
        let texel = self.texels[hit.texel as usize];
        let base = Vec3::new(texel[0], texel[1], texel[2]);
        if b.info[2] == NONE || b.info[3] == NONE {
            return BillboardShade {
                kind: 1,
                colour: base,
                t: hit.t,
                billboard: hit.billboard,
            };
        }
        // Second order: the tertiary ray from the reflective billboard's texel.
        let local = hit.texel - b.info[1];
        let nw = self.normals[(b.info[2] + local) as usize];
        let n = v3(nw);
        // The tertiary ray leaves from the captured surface, not the plane: back along the
        // ray to the texel's offset w from the plane (0 for a flat object).
        let np = v3(b.right).cross(v3(b.up));
        let dn = d.dot(np);
        let back = if dn.abs() > 1e-6 { nw[3] / dn } else { 0.0 };
        let p = o + d * (hit.t + back);
        let d2 = (d - 2.0 * d.dot(n) * n).normalize_or_zero();
        let g2 = b.info[3] as usize;
        let second = match self.nearest(g2, p, d2, t_max, true) {
            Some(h2) if h2.texel != NONE => {
                let c = self.texels[h2.texel as usize];
                Vec3::new(c[0], c[1], c[2])
            }
            Some(h2) => self.morph(g2, &h2, p, d2),
            None => miss(g2, d2).colour,
        };
        BillboardShade {
            kind: 2,
            colour: base + v3(b.spec) * second,
            t: hit.t,
            billboard: hit.billboard,
        }
    }
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
/// flat object's own plane ([`surface_frame`]), captured by rays along its normal. Colour is
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
    let bvh = Bvh::build(&tris);
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
                let c = colour.colour(scene, ids[hit.triangle as usize], hit.bary);
                col[y * w + x] = [c.x, c.y, c.z, 1.0];
                let t = &tris[hit.triangle as usize];
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

/// The billboards of every impostor object for every reflector in `reflectors` (groups in
/// reflector order), with each reflector's environment map from `env` (by index, with its
/// centre). An impostor object that is itself one of `reflectors` (shares a triangle) gets a
/// reflective billboard whose tertiary rays search its own group; a reflector's group leaves
/// out the impostor it is part of.
pub fn build(
    scene: &Scene,
    reflectors: &[ImpostorReflector],
    resolution: u32,
    colour: &ColourSource,
    env: &[Option<(CubeMap, Vec3)>],
) -> BillboardTables {
    let objects: Vec<Vec<u32>> = scene
        .impostors
        .iter()
        .map(|imp| impostor_triangles(scene, imp))
        .collect();
    // Reflector index of each impostor object that is a reflector, with its ks.
    let as_reflector: Vec<Option<(usize, Vec3)>> = objects
        .iter()
        .map(|ids| {
            reflectors.iter().enumerate().find_map(|(j, r)| {
                r.triangles
                    .iter()
                    .any(|t| ids.contains(t))
                    .then(|| (j, r.modulation.last().copied().unwrap_or(Vec3::ZERO)))
            })
        })
        .collect();
    let mut groups = Vec::new();
    for (j, r) in reflectors.iter().enumerate() {
        let rtris: Vec<Triangle> = r
            .triangles
            .iter()
            .map(|&t| scene.triangles[t as usize])
            .collect();
        let towards = centroid(&rtris);
        let mut bbs = Vec::new();
        let first_camera = scene
            .desc
            .camera_paths
            .first()
            .and_then(|p| p.keyframes.first())
            .map(|k| Vec3::from(k.position));
        for (k, ids) in objects.iter().enumerate() {
            if ids.is_empty() || as_reflector[k].is_some_and(|(jj, _)| jj == j) {
                continue;
            }
            let reflective = as_reflector[k];
            let spec = scene.impostors[k].billboard;
            let target = match r.normal {
                _ if spec.surface.is_some() => towards,
                Some(n) => {
                    let tris: Vec<Triangle> =
                        ids.iter().map(|&t| scene.triangles[t as usize]).collect();
                    let b = centroid(&tris);
                    planar_target(b, towards, n, first_camera)
                }
                None => towards,
            };
            let (mut bb, normals) = capture(
                scene,
                ids,
                target,
                spec.surface.as_ref(),
                resolution,
                colour,
                reflective.is_some(),
            );
            bb.impostor = k;
            // §3.2: connected to the environment by walls of height H.
            bb.wall = spec.wall;
            if let (Some((jj, ks)), Some(n)) = (reflective, normals) {
                bb.reflective = Some((n, ks, jj));
            }
            bbs.push(bb);
        }
        groups.push((bbs, env.get(j).and_then(|e| e.as_ref())));
    }
    let refs: Vec<Group<'_>> = groups
        .into_iter()
        .map(|(b, e)| (b, e.map(|(m, c)| (m, *c))))
        .collect();
    BillboardTables::pack(&refs)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn square(centre: Vec3, colour: [f32; 4], w: u32) -> Billboard {
        Billboard {
            impostor: 0,
            centre,
            right: Vec3::X,
            up: Vec3::Y,
            half: 1.0,
            half_up: 1.0,
            resolution: w,
            colour: vec![colour; (w * w) as usize],
            reflective: None,
            wall: 0.0,
        }
    }

    #[test]
    fn the_nearest_opaque_billboard_wins() {
        let mut far = square(Vec3::new(0.0, 0.0, -3.0), [0.0, 1.0, 0.0, 1.0], 4);
        far.colour[5][3] = 0.0;
        let near = square(Vec3::new(0.0, 0.0, -1.0), [1.0, 0.0, 0.0, 1.0], 4);
        let t = BillboardTables::pack(&[(vec![far, near], None)]);
        let s = t.trace(0, Vec3::ZERO, -Vec3::Z, 1e6);
        assert_eq!((s.kind, s.billboard), (1, 1));
        assert!((s.t - 1.0).abs() < 1e-6);
        // Beside the near one, through the far one's transparent texel (1, 1): nothing.
        let s = t.trace(0, Vec3::new(-0.3, 0.3, 0.0), -Vec3::Z, 1e6);
        assert_eq!(s.kind, 1, "{s:?}");
        let t2 =
            BillboardTables::pack(&[(vec![square(Vec3::new(0.0, 0.0, -3.0), [0.0; 4], 4)], None)]);
        assert_eq!(t2.trace(0, Vec3::ZERO, -Vec3::Z, 1e6).kind, 0);
    }

    #[test]
    fn planar_reflectors_get_upright_billboards() {
        // An object right above the floor's centroid: the camera's side.
        let t = planar_target(Vec3::Y, Vec3::ZERO, Vec3::Y, Some(Vec3::new(0.0, 2.0, 3.0)));
        assert!((t - Vec3::new(0.0, 1.0, 1.0)).length() < 1e-6, "{t}");
        // Without a camera, off-centre: the projected line to the centroid.
        let t = planar_target(Vec3::new(2.0, 1.0, 0.0), Vec3::ZERO, Vec3::Y, None);
        assert!((t - Vec3::new(1.0, 1.0, 0.0)).length() < 1e-6, "{t}");
    }

    #[test]
    fn misses_read_the_environment_map() {
        let env = CubeMap::from_fn(4, |d| d.abs());
        let t = BillboardTables::pack(&[(vec![], Some((&env, Vec3::ZERO)))]);
        let s = t.trace(0, Vec3::ZERO, Vec3::Y, 1e6);
        assert_eq!(s.kind, 3);
        assert!(s.colour.y > 0.9);
    }
}

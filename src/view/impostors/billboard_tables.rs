//! Reflected billboards (Popescu et al. 2006 §3): their packing for `shaders/billboards.wgsl`,
//! per reflector, and the CPU reference of the per-ray algorithm of §3.1 with the
//! billboard-to-environment morph of §3.2. Pure: no GPU here; [`super`] uploads the tables.
//! Each billboard is captured by [`crate::srdm::billboard`].
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
use glam::Vec3;

use crate::geometry::Triangle;
use crate::materials::envmap::{CubeMap, locate};
use crate::scene::Scene;
use crate::srdm::billboard::{capture, centroid, planar_target};
use crate::srdm::capture::{ColourSource, impostor_triangles};

pub use crate::srdm::billboard::Billboard;

use super::srdm_tables::ImpostorReflector;

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
    /// Environment cube maps, faces in [`crate::materials::envmap::FACE_NAMES`] order,
    /// rgb per texel.
    pub env: Vec<[f32; 4]>,
}

/// One group to pack: the billboards made for a reflector, and its environment map with the
/// map's centre E.
pub type Group<'a> = (Vec<Billboard>, Option<(&'a CubeMap, Vec3)>);

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
    fn misses_read_the_environment_map() {
        let env = CubeMap::from_fn(4, |d| d.abs());
        let t = BillboardTables::pack(&[(vec![], Some((&env, Vec3::ZERO)))]);
        let s = t.trace(0, Vec3::ZERO, Vec3::Y, 1e6);
        assert_eq!(s.kind, 3);
        assert!(s.colour.y > 0.9);
    }
}

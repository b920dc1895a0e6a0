//! Reflection probes: where the bake captures the room for glossy surfaces that no reflector
//! declares, and what it stores there (a prefiltered radiance cube map with the distance to
//! what each texel sees, [`capture_distances`]).
//!
//! # Placement ([`place`])
//!
//! The glossy triangles that belong to no declared reflector are grouped ([`glossy_groups`]):
//! per material; within a material, the faces that stand with their backs to its probe, where
//! those of one side (the dominant axis of their normal) are about flat and a large share of
//! the material's, get a group of their own ([`split_sides`]): a cabinet's end reflects the
//! room beside it, which a probe in front of the cabinet cannot see. The viewer reads one
//! probe per group, with its material's lobe,
//! so a group is the unit a probe serves. The probe stands above the group's bounding box,
//! along the area-weighted mean of its face normals (glTF's up, +y, where those cancel, as on
//! a closed object such as a table), a tenth of the box's diagonal off its face (where that
//! normal leans along two axes, as a cabinet's top and front make it, off the box's faces on
//! both, so the top sees the wall behind it past the cabinet): there it
//! sees the room the group's surfaces face, with few of their own triangles in the way, and
//! the viewer's distance-corrected lookups move each reflected ray to the surface's own
//! point. Where something stands on the surfaces (a teapot on a table) it goes on up, a lift
//! at a time, until nothing lies within a lift of it ([`placed`]). Where off the box lies
//! outside the room (a box that reaches the ceiling, the back of a mirror on a wall), the
//! probe comes back to a lift inside it. Its reach is its distance
//! from the box's centre plus the box's half diagonal. A material's first group's probe
//! bears the material's name, its others `NAME.2`, `NAME.3`, … ([`Group::name`]). A side
//! that no eye ray of the scene's camera paths meets ([`super::sight`]) gets no probe: it
//! reads the nearest of the rest, and the bake captures nothing no camera looks at.
//! scene.json's `probes` move a placed probe (same name) or add one; a scene without such a
//! group has no probes at all.
//!
//! Kept in one file: grouping and placement call each other (a side is split off where the
//! rest's probe would stand), and their tests build the same small scenes.

use glam::Vec3;
use rayon::prelude::*;

use super::envmap::{CubeMap, texel_direction};
use super::sight::{eye_rays, sights};
use crate::geometry::{Aabb, Bvh, Triangle};
use crate::scene::Scene;
use crate::scene::desc::ProbeDesc;

/// Glossy triangles that no reflector declares, served by one probe.
#[derive(Clone, Debug, PartialEq)]
pub struct Group {
    /// The material (index into the scene's materials).
    pub material: u32,
    /// The name of its placed probe: the material's for its first group, `NAME.k` for its
    /// k-th (from 2).
    pub name: String,
    /// Whether it is a side split off its material's first group ([`split_sides`]): its probe
    /// serves it alone.
    pub side: bool,
    /// Its triangles, in scene order.
    pub triangles: Vec<u32>,
    /// Their bounding box.
    pub bounds: Aabb,
    /// Area-weighted sum of their unit face normals over their total area (length ≤ 1).
    pub mean_normal: Vec3,
}

/// A probe as the bake captures it.
#[derive(Clone, Debug, PartialEq)]
pub struct Probe {
    /// Name (a placed probe's: its material's).
    pub name: String,
    /// Capture point, metres.
    pub position: Vec3,
    /// Reach, metres.
    pub radius: f32,
}

/// Mean normals shorter than this count as cancelled (a closed object): the probe goes up.
const MIN_MEAN_NORMAL: f32 = 0.25;

/// The lift off a group's box, as a fraction of its diagonal.
const LIFT: f32 = 0.1;

/// The least share of a material's area that one side's faces turned away from its probe must
/// hold for [`split_sides`] to give them their own probe (docs/tuning.md#probe-sides).
const MIN_SIDE_SHARE: f32 = 0.15;

/// The least length of the mean normal of one side's faces for [`split_sides`] to give them
/// their own probe: a flat side (a cabinet's end) has one, a quarter of a cylinder's wall
/// about 0.9; a curved object's probe above it sees round it.
const MIN_SIDE_FLATNESS: f32 = 0.95;

/// The group of `tris` (in scene order) of `material`, named `name`.
fn group_of(triangles: &[Triangle], material: u32, name: String, tris: Vec<u32>) -> Group {
    let mut bounds = Aabb::EMPTY;
    let (mut normal, mut area) = (Vec3::ZERO, 0.0f32);
    for &t in &tris {
        let tri = &triangles[t as usize];
        bounds = tri.p.iter().fold(bounds, |b, p| b.grow(*p));
        let a = tri.area();
        normal += tri.face_normal() * a;
        area += a;
    }
    Group {
        material,
        name,
        side: false,
        triangles: tris,
        bounds,
        mean_normal: if area > 0.0 {
            normal / area
        } else {
            Vec3::ZERO
        },
    }
}

/// The probe name of a material's `k`-th group (from 0): the material's own, then `NAME.2`, ….
pub fn group_name(material: &str, k: usize) -> String {
    if k == 0 {
        material.to_string()
    } else {
        format!("{material}.{}", k + 1)
    }
}

/// The groups of glossy triangles outside `declared` (the triangles of declared reflectors),
/// in material order, named after `names[material]` (see the module's comment): per material
/// (`glossy[m]`), per side turned away from its probe ([`split_sides`], the probe kept inside
/// `bounds`). Materials with none have no group.
pub fn glossy_groups(
    triangles: &[Triangle],
    glossy: &[bool],
    declared: &[bool],
    names: &[&str],
    bounds: &Aabb,
) -> Vec<Group> {
    let mut per_material: Vec<Vec<u32>> = vec![Vec::new(); glossy.len()];
    for (t, tri) in triangles.iter().enumerate() {
        let m = tri.material as usize;
        if glossy.get(m).copied().unwrap_or(false) && !declared.get(t).copied().unwrap_or(false) {
            per_material[m].push(t as u32);
        }
    }
    let mut groups = Vec::new();
    for (m, tris) in per_material.into_iter().enumerate() {
        if tris.is_empty() {
            continue;
        }
        let parts = split_sides(triangles, tris, bounds);
        let name = names.get(m).copied().unwrap_or("");
        for (k, part) in parts.into_iter().enumerate() {
            let group = group_of(triangles, m as u32, group_name(name, k), part);
            groups.push(Group {
                side: k > 0,
                ..group
            });
        }
    }
    groups
}

/// The side of a face normal: its dominant axis and that component's sign (+x 0, −x 1, +y 2,
/// −y 3, +z 4, −z 5).
fn side(n: Vec3) -> usize {
    let a = n.abs();
    let axis = if a.x >= a.y && a.x >= a.z {
        0
    } else if a.y >= a.z {
        1
    } else {
        2
    };
    2 * axis + usize::from(n[axis] < 0.0)
}

/// A material's triangles (`tris`, in scene order) as the parts its probes serve, the rest
/// first: where the faces of one side (see `side`) that stand with their backs to the probe
/// the rest would get (placed in the open) hold `MIN_SIDE_SHARE` of the material's area and
/// are about flat (`MIN_SIDE_FLATNESS`), they become a part of their own, provided its own
/// probe stands inside `bounds`; the rest's probe is placed again, until no side splits off
/// (each side once).
pub fn split_sides(triangles: &[Triangle], tris: Vec<u32>, bounds: &Aabb) -> Vec<Vec<u32>> {
    let area = |ts: &[u32]| {
        ts.iter()
            .map(|&t| triangles[t as usize].area())
            .sum::<f32>()
    };
    let total = area(&tris);
    let mut rest = tris;
    let mut sides: Vec<Vec<u32>> = Vec::new();
    let mut done = [false; 6];
    if total <= 0.0 {
        return vec![rest];
    }
    // Each pass splits off a side not split before, or ends.
    for _ in 0..6 {
        let probe = off_the_box(&group_of(triangles, 0, String::new(), rest.clone()), bounds);
        // Per triangle of `rest`, its side where it turns its back to the probe, else 6.
        let tags: Vec<usize> = rest
            .iter()
            .map(|&t| {
                let tri = &triangles[t as usize];
                let n = tri.face_normal();
                let centroid = (tri.p[0] + tri.p[1] + tri.p[2]) / 3.0;
                if n.dot(probe - centroid) < 0.0 {
                    side(n)
                } else {
                    6
                }
            })
            .collect();
        let mut behind: [Vec<u32>; 6] = Default::default();
        for (&t, &s) in rest.iter().zip(&tags) {
            if s < 6 {
                behind[s].push(t);
            }
        }
        let split: Vec<usize> = (0..6)
            .filter(|&s| !done[s] && area(&behind[s]) >= MIN_SIDE_SHARE * total)
            .filter(|&s| {
                let g = group_of(triangles, 0, String::new(), behind[s].clone());
                g.mean_normal.length() >= MIN_SIDE_FLATNESS
                    && inside(bounds, off_the_box(&g, bounds))
            })
            .collect();
        let kept = rest.len() - split.iter().map(|&s| behind[s].len()).sum::<usize>();
        if split.is_empty() || kept == 0 {
            break;
        }
        rest = rest
            .iter()
            .zip(&tags)
            .filter(|(_, s)| !split.contains(s))
            .map(|(&t, _)| t)
            .collect();
        for &s in &split {
            done[s] = true;
            sides.push(std::mem::take(&mut behind[s]));
        }
    }
    let mut parts = vec![rest];
    parts.extend(sides);
    parts
}

/// The groups of `scene` ([`glossy_groups`]).
pub fn scene_groups(scene: &Scene) -> Vec<Group> {
    let glossy: Vec<bool> = scene.materials.iter().map(|m| m.is_glossy()).collect();
    let mut declared = vec![false; scene.triangles.len()];
    for r in &scene.reflectors {
        for &t in &r.triangles {
            declared[t as usize] = true;
        }
    }
    let names: Vec<&str> = scene.materials.iter().map(|m| m.name.as_str()).collect();
    glossy_groups(&scene.triangles, &glossy, &declared, &names, &scene.bounds)
}

/// Where the bake puts a group's probe (see the module's comment) and its reach: off the
/// group's box along its normal (`off_the_box`), then further along it, a lift at a time,
/// while something lies nearer than a lift (`clearance`: the distance from a point to the
/// nearest surface around it), so a probe never ends up inside an object on the surface (a
/// teapot on a table). Where the point off the box lies outside `bounds` behind a wall (a
/// group whose box reaches the ceiling, the back of a mirror hung on a wall: seen from there,
/// the way back to the box's centre meets a surface from behind), it is pulled back towards
/// the box's centre to a lift inside them, since a probe outside the room sees the room's
/// outside and nothing the group reflects; in an open scene (an object on a ground plane) it
/// stays above the object. Where no point is clear, it stays at the first.
pub fn placed(group: &Group, bounds: &Aabb, around: &dyn Surroundings) -> (Vec3, f32) {
    let b = &group.bounds;
    let lift = lift_of(group);
    let up = up_of(group);
    let mut first = off_the_box(group, bounds);
    if !inside(bounds, first) && around.walled_off(first, b.center()) {
        first = pulled_inside(first, b.center(), bounds, lift);
    }
    let clear = (0..MAX_LIFTS)
        .map(|k| first + up * (k as f32 * lift))
        .take_while(|&p| inside(bounds, p))
        .find(|&p| around.clearance(p) >= lift);
    let position = clear.unwrap_or(first);
    let half = 0.5 * (b.max - b.min);
    (position, position.distance(b.center()) + half.length())
}

/// What [`placed`] asks of the scene around a group.
pub trait Surroundings {
    /// The distance from `p` to the nearest surface around it.
    fn clearance(&self, p: Vec3) -> f32;
    /// Whether the way from `from` (outside the scene's bounds) to `to` first meets a surface
    /// from behind: `from` stands outside a closed room.
    fn walled_off(&self, _from: Vec3, _to: Vec3) -> bool {
        false
    }
}

/// A clearance alone: nothing is walled off (an open scene).
impl<F: Fn(Vec3) -> f32> Surroundings for F {
    fn clearance(&self, p: Vec3) -> f32 {
        self(p)
    }
}

/// A scene's surroundings: [`clearance`] and back faces met by its BVH.
pub struct SceneSurroundings<'a> {
    /// The scene's BVH.
    pub bvh: &'a Bvh,
    /// Its triangles (the BVH's hits index them).
    pub triangles: &'a [Triangle],
}

impl Surroundings for SceneSurroundings<'_> {
    fn clearance(&self, p: Vec3) -> f32 {
        clearance(self.bvh, p)
    }

    fn walled_off(&self, from: Vec3, to: Vec3) -> bool {
        let d = to - from;
        let length = d.length();
        if length <= 0.0 {
            return false;
        }
        let dir = d / length;
        self.bvh
            .closest_hit(from, dir, length)
            .is_some_and(|h| self.triangles[h.triangle as usize].face_normal().dot(dir) > 0.0)
    }
}

/// Whether `p` lies in `bounds` (faces included).
fn inside(bounds: &Aabb, p: Vec3) -> bool {
    bounds.min.cmple(p).all() && p.cmple(bounds.max).all()
}

/// The direction a group's probe stands off its box: its mean normal, or +y (glTF's up)
/// where the normals cancel (a closed object).
fn up_of(group: &Group) -> Vec3 {
    if group.mean_normal.length() >= MIN_MEAN_NORMAL {
        group.mean_normal.normalize()
    } else {
        Vec3::Y
    }
}

/// A group's lift: a tenth of its box's diagonal, at least [`MIN_LIFT`].
fn lift_of(group: &Group) -> f32 {
    (LIFT * group.bounds.diagonal()).max(MIN_LIFT)
}

/// The first point [`placed`] tries, before `bounds` and clearance move it: from the box's
/// centre to its face along the group's up (its support distance), then a lift off it. Where
/// up leans along two axes or more (a cabinet's top and front), on out past the box's faces
/// on each of them, if that stays inside `bounds`: short of the top's plane the probe sees
/// the cabinet itself where the top reflects the wall behind it.
fn off_the_box(group: &Group, bounds: &Aabb) -> Vec3 {
    let b = &group.bounds;
    let half = 0.5 * (b.max - b.min);
    let up = up_of(group);
    let lift = lift_of(group);
    let support = half.dot(up.abs());
    let leaning: Vec<usize> = (0..3).filter(|&i| up[i].abs() >= MIN_AXIS).collect();
    let beyond = if leaning.len() > 1 {
        leaning
            .iter()
            .map(|&i| half[i] / up[i].abs())
            .fold(support, f32::max)
    } else {
        support
    };
    let at = |d: f32| b.center() + up * (d + lift);
    if inside(bounds, at(beyond)) {
        at(beyond)
    } else {
        at(support)
    }
}

/// `p` (outside `bounds`) moved along the line from `from` towards it to where that line
/// leaves `bounds` shrunk by `margin` on every side (by less where they are thinner than
/// four margins); `from` is first clamped into the shrunk box.
fn pulled_inside(p: Vec3, from: Vec3, bounds: &Aabb, margin: f32) -> Vec3 {
    let extent = bounds.max - bounds.min;
    let m = Vec3::splat(margin).min(0.25 * extent);
    let (lo, hi) = (bounds.min + m, bounds.max - m);
    let from = from.clamp(lo, hi);
    let d = p - from;
    let mut t = 1.0f32;
    for i in 0..3 {
        if d[i] > 0.0 {
            t = t.min((hi[i] - from[i]) / d[i]);
        } else if d[i] < 0.0 {
            t = t.min((lo[i] - from[i]) / d[i]);
        }
    }
    from + d * t.max(0.0)
}

/// The least component along an axis of a group's mean normal for [`placed`] to count it
/// as leaning along that axis.
const MIN_AXIS: f32 = 0.25;

/// The smallest lift off a group's box, metres (a group of one tiny triangle).
const MIN_LIFT: f32 = 0.02;

/// The most lifts [`placed`] tries.
const MAX_LIFTS: usize = 64;

/// The distance from `p` to the nearest surface along 26 directions (the cube's faces, edges
/// and corners; infinite where none is hit): [`placed`]'s clearance on a scene.
pub fn clearance(bvh: &Bvh, p: Vec3) -> f32 {
    let mut nearest = f32::INFINITY;
    for x in -1i32..=1 {
        for y in -1i32..=1 {
            for z in -1i32..=1 {
                if (x, y, z) == (0, 0, 0) {
                    continue;
                }
                let d = Vec3::new(x as f32, y as f32, z as f32).normalize();
                if let Some(h) = bvh.closest_hit(p, d, nearest) {
                    nearest = nearest.min(h.t);
                }
            }
        }
    }
    nearest
}

/// The probes of a scene: one per group ([`placed`]), named after it ([`Group::name`]), but
/// none for a side ([`split_sides`]) that the camera paths do not see (`sights`: per group,
/// the eye rays that meet it first, [`sights`]; empty where the scene has no camera paths:
/// every side keeps its probe); then
/// scene.json's `given` probes, each moving the placed probe of its name or added after them
/// (reach: the given radius, else the placed one's, else `bounds`' diagonal). None without
/// groups, whatever `given` says.
pub fn place(
    groups: &[Group],
    sights: &[u32],
    given: &[ProbeDesc],
    bounds: &Aabb,
    around: &dyn Surroundings,
) -> Vec<Probe> {
    if groups.is_empty() {
        return Vec::new();
    }
    let mut probes: Vec<Probe> = groups
        .iter()
        .enumerate()
        .filter_map(|(k, g)| {
            if g.side && sights.get(k) == Some(&0) {
                return None;
            }
            let (position, radius) = placed(g, bounds, around);
            Some(Probe {
                name: g.name.clone(),
                position,
                radius,
            })
        })
        .collect();
    for d in given {
        let position = Vec3::from_array(d.position);
        match probes.iter_mut().find(|p| p.name == d.name) {
            Some(p) => {
                p.position = position;
                if let Some(r) = d.radius {
                    p.radius = r;
                }
            }
            None => probes.push(Probe {
                name: d.name.clone(),
                position,
                radius: d.radius.unwrap_or(bounds.diagonal()),
            }),
        }
    }
    probes
}

/// The probes of `scene` ([`place`] of [`scene_groups`], seen from its camera paths).
pub fn scene_probes(scene: &Scene) -> Vec<Probe> {
    let groups = scene_groups(scene);
    if groups.is_empty() {
        return Vec::new();
    }
    let bvh = scene.build_bvh();
    let rays = eye_rays(&scene.camera_paths);
    let seen = if rays.is_empty() {
        Vec::new()
    } else {
        let sets: Vec<&[u32]> = groups.iter().map(|g| g.triangles.as_slice()).collect();
        sights(&scene.triangles, &sets, &bvh, &rays)
    };
    let around = SceneSurroundings {
        bvh: &bvh,
        triangles: &scene.triangles,
    };
    place(&groups, &seen, &scene.desc.probes, &scene.bounds, &around)
}

/// The probe group `k` of `groups` reads: the nearest to its box's centre whose reach holds
/// it, else the nearest (ties: the first), of all but the probes of the other groups' sides
/// (each serves its own side alone; a side no camera sees has none, [`place`], and reads the
/// nearest of the rest). `None` without probes.
pub fn assign(probes: &[Probe], groups: &[Group], k: usize) -> Option<usize> {
    let group = &groups[k];
    let c = group.bounds.center();
    let others_side =
        |p: &Probe| p.name != group.name && groups.iter().any(|g| g.side && g.name == p.name);
    let nearest = |reach: bool| {
        probes
            .iter()
            .enumerate()
            .filter(|(_, p)| !others_side(p))
            .filter(|(_, p)| !reach || p.position.distance(c) <= p.radius)
            .min_by(|a, b| {
                a.1.position
                    .distance(c)
                    .total_cmp(&b.1.position.distance(c))
            })
            .map(|(i, _)| i)
    };
    nearest(true).or_else(|| nearest(false))
}

/// Per texel centre of a `size`² cube map about `centre`, the distance to the first surface
/// its ray meets (0: none), one work item per face row (deterministic).
pub fn capture_distances(bvh: &Bvh, centre: Vec3, size: usize) -> CubeMap {
    let size = size.max(1);
    let rows: Vec<Vec<Vec3>> = (0..6 * size)
        .into_par_iter()
        .map(|row| {
            let (face, y) = (row / size, row % size);
            (0..size)
                .map(|x| {
                    let d = texel_direction(size, face, x, y);
                    Vec3::splat(bvh.closest_hit(centre, d, f32::MAX).map_or(0.0, |h| h.t))
                })
                .collect()
        })
        .collect();
    CubeMap {
        size,
        texels: rows.concat(),
    }
}

/// The MIP level of a probe lookup for a lobe of roughness `m` (GGX α or Beckmann m): half the
/// log₂ of the ratio of the reflected lobe's solid angle, about π (2m)², to what a trilinear
/// lookup spans at level 0, 2×2 texels of 4π / (6 size²) each: at a level whose single texels
/// matched the lobe, the lookup would spread a bright window over about four times its solid
/// angle.
pub fn lobe_lod(m: f32, size: u32) -> f32 {
    let ratio = 6.0 * (size as f32).powi(2) * (2.0 * m).powi(2) / 16.0;
    (0.5 * ratio.max(1.0).log2()).max(0.0)
}

#[cfg(test)]
mod tests {
    use glam::Vec2;

    use super::*;

    /// Two triangles of material 0 per quad (corners in order), flat-shaded.
    fn quad_triangles(quads: &[[Vec3; 4]]) -> Vec<Triangle> {
        quads
            .iter()
            .flat_map(|q| {
                [[0, 1, 2], [0, 2, 3]].map(|[a, b, c]| Triangle {
                    p: [q[a], q[b], q[c]],
                    n: [Vec3::ZERO; 3],
                    uv: [Vec2::ZERO; 3],
                    uv1: None,
                    material: 0,
                    object: 0,
                })
            })
            .collect()
    }

    /// Nothing around: every point is clear.
    fn open(_: Vec3) -> f32 {
        f32::INFINITY
    }

    /// Materials' names in the tests.
    const NAMES: [&str; 3] = ["a", "b", "c"];

    /// A room about the tests' surfaces.
    fn room() -> Aabb {
        Aabb::from_points([Vec3::splat(-10.0), Vec3::splat(10.0)].iter())
    }

    /// [`glossy_groups`] with [`NAMES`] in [`room`].
    fn groups_of(triangles: &[Triangle], glossy: &[bool], declared: &[bool]) -> Vec<Group> {
        glossy_groups(triangles, glossy, declared, &NAMES, &room())
    }

    fn quad(material: u32, y: f32, x0: f32, up: bool) -> [Triangle; 2] {
        let p = [
            Vec3::new(x0, y, 0.0),
            Vec3::new(x0 + 1.0, y, 0.0),
            Vec3::new(x0 + 1.0, y, 1.0),
            Vec3::new(x0, y, 1.0),
        ];
        let tri = |a: usize, b: usize, c: usize| {
            let (b, c) = if up { (c, b) } else { (b, c) };
            Triangle {
                p: [p[a], p[b], p[c]],
                n: [Vec3::Y; 3],
                uv: [Vec2::ZERO; 3],
                uv1: None,
                material,
                object: 0,
            }
        };
        [tri(0, 1, 2), tri(0, 2, 3)]
    }

    #[test]
    fn no_glossy_material_no_probe() {
        let tris: Vec<Triangle> = quad(0, 0.0, 0.0, true).into();
        let groups = groups_of(&tris, &[false], &[false; 2]);
        assert!(groups.is_empty());
        let given = [ProbeDesc {
            name: "extra".into(),
            position: [0.5; 3],
            radius: None,
        }];
        let b = Aabb::from_points(tris.iter().flat_map(|t| t.p.iter()));
        assert!(place(&groups, &[], &given, &b, &open).is_empty());
    }

    #[test]
    fn declared_triangles_need_no_probe() {
        let tris: Vec<Triangle> = quad(0, 0.0, 0.0, true).into();
        assert!(groups_of(&tris, &[true], &[true, true]).is_empty());
        assert_eq!(
            groups_of(&tris, &[true], &[true, false])[0].triangles,
            vec![1]
        );
    }

    #[test]
    fn one_probe_per_glossy_material_above_its_surfaces() {
        let mut tris: Vec<Triangle> = quad(0, 0.0, 0.0, true).into();
        tris.extend(quad(1, 0.5, 2.0, true));
        tris.extend(quad(2, 0.5, 4.0, true)); // diffuse
        tris.extend(quad(0, 0.0, 6.0, true)); // the same material again: the same group
        let groups = groups_of(&tris, &[true, true, false], &vec![false; tris.len()]);
        assert_eq!(groups.len(), 2);
        assert_eq!(groups[0].triangles, vec![0, 1, 6, 7]);
        let b = Aabb::from_points(tris.iter().flat_map(|t| t.p.iter()));
        let probes = place(&groups, &[], &[], &b, &open);
        let names: Vec<&str> = probes.iter().map(|p| p.name.as_str()).collect();
        assert_eq!(names, ["a", "b"]);
        // Above the faces they serve (normals +y), over the box's centre.
        assert!(probes[0].position.y > 0.0 && probes[1].position.y > 0.5);
        assert!((probes[0].position.x - 3.5).abs() < 1e-5);
        for (p, g) in probes.iter().zip(&groups) {
            assert!(p.position.distance(g.bounds.center()) <= p.radius);
            let k = groups.iter().position(|h| h == g).unwrap();
            assert_eq!(assign(&probes, &groups, k), Some(k));
        }
    }

    #[test]
    fn a_closed_object_gets_its_probe_above_it() {
        // Faces up and down cancel: the probe goes up (+y), off the box.
        let mut tris: Vec<Triangle> = quad(0, 0.0, 0.0, true).into();
        tris.extend(quad(0, -0.2, 0.0, false));
        let group = group_of(&tris, 0, "a".into(), vec![0, 1, 2, 3]);
        assert!(group.mean_normal.length() < 1e-6);
        let b = Aabb::from_points([Vec3::splat(-5.0), Vec3::splat(5.0)].iter());
        let (p, _) = placed(&group, &b, &open);
        assert!(p.y > 0.0, "{p}");
        // Its underside turns its back to that probe: a group of its own, read by a probe
        // below it; where below lies outside the room, the underside stays.
        let groups = groups_of(&tris, &[true], &[false; 4]);
        let parts: Vec<(&str, &[u32])> = groups
            .iter()
            .map(|g| (g.name.as_str(), g.triangles.as_slice()))
            .collect();
        assert_eq!(parts, [("a", &[0, 1][..]), ("a.2", &[2, 3][..])]);
        let (under, _) = placed(&groups[1], &b, &open);
        assert!(under.y < -0.2, "{under}");
        let floor = Aabb::from_points([Vec3::new(-5.0, -0.2, -5.0), Vec3::splat(5.0)].iter());
        assert_eq!(
            glossy_groups(&tris, &[true], &[false; 4], &NAMES, &floor).len(),
            1
        );
    }

    #[test]
    fn a_side_no_camera_sees_gets_no_probe() {
        // The closed object of `a_closed_object_gets_its_probe_above_it`: its underside is a
        // side of its own, which eyes above never see.
        let mut tris: Vec<Triangle> = quad(0, 0.0, 0.0, true).into();
        tris.extend(quad(0, -0.2, 0.0, false));
        let groups = groups_of(&tris, &[true], &[false; 4]);
        assert_eq!(groups.len(), 2);
        assert!(groups[1].side);
        let bvh = Bvh::build(&tris);
        let above: Vec<(Vec3, Vec3)> = (1..10)
            .map(|i| (Vec3::new(i as f32 / 10.0, 2.0, 0.5), Vec3::NEG_Y))
            .collect();
        let sets: Vec<&[u32]> = groups.iter().map(|g| g.triangles.as_slice()).collect();
        let seen = sights(&tris, &sets, &bvh, &above);
        let probes = place(&groups, &seen, &[], &room(), &open);
        let names: Vec<&str> = probes.iter().map(|p| p.name.as_str()).collect();
        assert_eq!(names, ["a"]);
        // The underside reads the probe above it.
        assert_eq!(assign(&probes, &groups, 1), Some(0));
        // Seen from below, it keeps its probe; without camera paths, every side does.
        let below: Vec<(Vec3, Vec3)> = above
            .iter()
            .map(|&(o, _)| (Vec3::new(o.x, -2.0, o.z), Vec3::Y))
            .collect();
        let seen = sights(&tris, &sets, &bvh, &[above, below].concat());
        assert_eq!(place(&groups, &seen, &[], &room(), &open).len(), 2);
        assert_eq!(place(&groups, &[], &[], &room(), &open).len(), 2);
    }

    #[test]
    fn a_side_turned_away_from_its_probe_gets_a_probe_in_front_of_it() {
        // A 1.2 × 0.85 × 0.55 m cabinet against the wall z = 0, glossy on its top, its front
        // and both ends: the probe past the top and the front stands behind the ends' planes,
        // where it sees the cabinet's front in place of the room beside each end.
        let (x1, y1, z1) = (1.2, 0.85, 0.55);
        let quads = [
            // top (+y), front (+z), +x end, −x end
            [[0.0, y1, 0.0], [0.0, y1, z1], [x1, y1, z1], [x1, y1, 0.0]],
            [[0.0, 0.0, z1], [x1, 0.0, z1], [x1, y1, z1], [0.0, y1, z1]],
            [[x1, 0.0, z1], [x1, 0.0, 0.0], [x1, y1, 0.0], [x1, y1, z1]],
            [
                [0.0, 0.0, 0.0],
                [0.0, 0.0, z1],
                [0.0, y1, z1],
                [0.0, y1, 0.0],
            ],
        ];
        let tris = quad_triangles(&quads.map(|q| q.map(Vec3::from_array)));
        assert!(tris[4].face_normal().x > 0.99 && tris[6].face_normal().x < -0.99);
        let room = Aabb::from_points([Vec3::new(-2.0, 0.0, 0.0), Vec3::splat(3.0)].iter());
        let groups = glossy_groups(&tris, &[true], &[false; 8], &NAMES, &room);
        let parts: Vec<(&str, &[u32])> = groups
            .iter()
            .map(|g| (g.name.as_str(), g.triangles.as_slice()))
            .collect();
        assert_eq!(
            parts,
            [
                ("a", &[0, 1, 2, 3][..]),
                ("a.2", &[4, 5][..]),
                ("a.3", &[6, 7][..])
            ]
        );
        let mut probes = place(&groups, &[], &[], &room, &open);
        // Every face stands in front of its own probe, which each group reads.
        for (k, (g, p)) in groups.iter().zip(&probes).enumerate() {
            for &t in &g.triangles {
                let tri = &tris[t as usize];
                let to = p.position - tri.p[0];
                assert!(tri.face_normal().dot(to) > 0.0, "{} {t}", g.name);
            }
            assert_eq!(assign(&probes, &groups, k), Some(k));
        }
        // A side's probe serves that side alone, even where it reaches the others.
        probes[1].radius = 10.0;
        probes[1].position = groups[0].bounds.center();
        assert_eq!(assign(&probes, &groups, 0), Some(0));
        assert_eq!(assign(&probes, &groups, 2), Some(2));
        // Ends a tenth as deep hold too little of the cabinet's area: they keep its probe.
        let thin: Vec<Triangle> = tris
            .iter()
            .map(|t| Triangle {
                p: t.p.map(|p| Vec3::new(p.x, p.y, p.z * 0.1)),
                ..*t
            })
            .collect();
        let groups = glossy_groups(&thin, &[true], &[false; 8], &NAMES, &room);
        assert_eq!(groups.len(), 1);
    }

    #[test]
    fn a_cabinets_probe_stands_past_its_top_and_its_front() {
        // A 1.2 × 0.85 × 0.55 m cabinet against the wall z = 0: a top (+y) and a front (+z),
        // its mean normal between them. The top reflects the wall behind it, so the probe
        // must stand above the top's plane, and in front of the front's.
        let (x0, x1, y1, z1) = (0.0, 1.2, 0.85, 0.55);
        let top = [
            Vec3::new(x0, y1, 0.0),
            Vec3::new(x0, y1, z1),
            Vec3::new(x1, y1, z1),
            Vec3::new(x1, y1, 0.0),
        ];
        let front = [
            Vec3::new(x0, 0.0, z1),
            Vec3::new(x1, 0.0, z1),
            Vec3::new(x1, y1, z1),
            Vec3::new(x0, y1, z1),
        ];
        let tris = quad_triangles(&[top, front]);
        let groups = groups_of(&tris, &[true], &[false; 4]);
        let n = groups[0].mean_normal;
        assert!(n.y > 0.2 && n.z > 0.2 && n.x.abs() < 1e-6, "{n}");
        let room = Aabb::from_points([Vec3::new(-2.0, 0.0, 0.0), Vec3::splat(3.0)].iter());
        let (p, r) = placed(&groups[0], &room, &open);
        assert!(p.y > y1 && p.z > z1, "{p}");
        assert!(p.distance(groups[0].bounds.center()) <= r);
        // Where past both faces lies outside the room, the probe stays inside it.
        let low = Aabb::from_points([Vec3::new(-2.0, 0.0, 0.0), Vec3::new(3.0, 1.0, 0.9)].iter());
        let (p, _) = placed(&groups[0], &low, &open);
        assert!(low.min.cmple(p).all() && p.cmple(low.max).all(), "{p}");
    }

    #[test]
    fn a_probe_whose_box_reaches_the_ceiling_stays_in_the_room() {
        // Shades hung from a 2.4 m ceiling and chairs on the floor, one glossy material (0),
        // under a diffuse ceiling (1) facing down: off the box's top lies above the ceiling,
        // outside the room.
        let mut tris: Vec<Triangle> = quad(0, 0.2, 0.0, true).into();
        tris.extend(quad(0, 0.0, 0.0, false));
        tris.extend(quad(0, 2.35, 0.0, true));
        tris.extend(quad(0, 2.2, 0.0, false));
        let ceiling = [
            Vec3::new(-3.0, 2.4, -3.0),
            Vec3::new(3.0, 2.4, -3.0),
            Vec3::new(3.0, 2.4, 3.0),
            Vec3::new(-3.0, 2.4, 3.0),
        ];
        let mut room_tris = tris.clone();
        room_tris.extend(
            quad_triangles(&[ceiling])
                .into_iter()
                .map(|t| Triangle { material: 1, ..t }),
        );
        assert!(room_tris[8].face_normal().y < -0.99);
        // The faces up (the undersides split off as a side of their own).
        let groups = groups_of(&room_tris, &[true, false], &[false; 10]);
        let g = &groups[0];
        assert_eq!(g.triangles, [0, 1, 4, 5]);
        let room = Aabb::from_points(room_tris.iter().flat_map(|t| t.p.iter()));
        let bvh = Bvh::build(&room_tris);
        let around = SceneSurroundings {
            bvh: &bvh,
            triangles: &room_tris,
        };
        let lift = 0.1 * g.bounds.diagonal();
        assert!(off_the_box(g, &room).y > 2.4);
        let (p, r) = placed(g, &room, &around);
        // A lift under the ceiling, straight above the box's centre.
        assert!(inside(&room, p), "{p}");
        assert!((p.y - (2.4 - lift)).abs() < 1e-4, "{p}");
        assert!((p - g.bounds.center()).with_y(0.0).length() < 1e-5, "{p}");
        assert!(p.distance(g.bounds.center()) <= r);
        // Without the ceiling the scene is open: the probe stays above the box, outside the
        // scene's bounds, where it sees what the surfaces face.
        let open_bounds = Aabb::from_points(tris.iter().flat_map(|t| t.p.iter()));
        let bvh = Bvh::build(&tris);
        let around = SceneSurroundings {
            bvh: &bvh,
            triangles: &tris,
        };
        let (p, _) = placed(
            &groups_of(&tris, &[true], &[false; 8])[0],
            &open_bounds,
            &around,
        );
        assert!(p.y > 2.35, "{p}");
    }

    #[test]
    fn scene_json_moves_and_adds_probes() {
        let mut tris: Vec<Triangle> = quad(0, 0.0, 0.0, true).into();
        tris.extend(quad(1, 0.0, 3.0, true));
        let groups = groups_of(&tris, &[true, true], &[false; 4]);
        let b = Aabb::from_points(tris.iter().flat_map(|t| t.p.iter()));
        let given = [
            ProbeDesc {
                name: "a".into(),
                position: [0.5, 2.0, 0.5],
                radius: Some(3.0),
            },
            ProbeDesc {
                name: "extra".into(),
                position: [3.5, 0.05, 0.5],
                radius: Some(0.5),
            },
        ];
        let probes = place(&groups, &[], &given, &b, &open);
        assert_eq!(probes.len(), 3);
        assert_eq!(probes[0].position, Vec3::new(0.5, 2.0, 0.5));
        assert_eq!(probes[0].radius, 3.0);
        assert_eq!(probes[2].name, "extra");
        // The added probe is nearer to b's surfaces than b's own and reaches them.
        assert_eq!(assign(&probes, &groups, 1), Some(2));
        assert_eq!(assign(&probes, &groups, 0), Some(0));
    }

    #[test]
    fn a_probe_rises_clear_of_what_stands_on_its_surfaces() {
        let tris: Vec<Triangle> = quad(0, 0.0, 0.0, true).into();
        let groups = groups_of(&tris, &[true], &[false; 2]);
        let room = Aabb::from_points([Vec3::new(-3.0, 0.0, -3.0), Vec3::splat(3.0)].iter());
        // A box 0.5 m tall over the quad's middle: clear only above y = 0.5 + a lift.
        let lift = 0.1 * groups[0].bounds.diagonal();
        let clearance = |p: Vec3| if p.y < 0.5 { 0.0 } else { p.y - 0.5 };
        let (p, r) = placed(&groups[0], &room, &clearance);
        assert!(p.y >= 0.5 + lift && p.y < 0.5 + 2.0 * lift + 1e-4, "{p}");
        assert!(p.distance(groups[0].bounds.center()) <= r);
        // Where nothing is clear within the room, the first point off the surface.
        let (p, _) = placed(&groups[0], &room, &|_: Vec3| 0.0);
        assert!((p.y - lift).abs() < 1e-5, "{p}");
    }

    #[test]
    fn rougher_lobes_read_coarser_levels() {
        assert_eq!(lobe_lod(0.0, 64), 0.0);
        assert!(lobe_lod(0.1, 64) < lobe_lod(0.3, 64));
        assert!(lobe_lod(0.1, 64) < lobe_lod(0.1, 128));
    }
}

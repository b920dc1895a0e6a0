//! Reflection probes: where the bake captures the room for glossy surfaces that no reflector
//! declares, and what it stores there (a prefiltered radiance cube map with the distance to
//! what each texel sees, [`capture_distances`]).
//!
//! # Placement ([`place`])
//!
//! One group per glossy material, of its triangles that belong to no declared reflector
//! ([`glossy_groups`]): the viewer reads one probe per material, with that material's lobe,
//! so a group is the unit a probe serves. The probe stands above the group's bounding box,
//! along the area-weighted mean of its face normals (glTF's up, +y, where those cancel, as on
//! a closed object such as a table), a tenth of the box's diagonal off its face (where that
//! normal leans along two axes, as a cabinet's top and front make it, off the box's faces on
//! both, so the top sees the wall behind it past the cabinet): there it
//! sees the room the group's surfaces face, with few of their own triangles in the way, and
//! the viewer's distance-corrected lookups move each reflected ray to the surface's own
//! point. Where something stands on the surfaces (a teapot on a table) it goes on up, a lift
//! at a time, until nothing lies within a lift of it ([`placed`]). Its reach is its distance
//! from the box's centre plus the box's half diagonal. scene.json's `probes` move a
//! placed probe (same name: the material's) or add one; a scene without such a group has no
//! probes at all.

use glam::Vec3;
use rayon::prelude::*;

use super::envmap::{CubeMap, texel_direction};
use crate::geometry::{Aabb, Bvh, Triangle};
use crate::scene::Scene;
use crate::scene::desc::ProbeDesc;

/// The glossy triangles of one material that no reflector declares.
#[derive(Clone, Debug, PartialEq)]
pub struct Group {
    /// The material (index into the scene's materials).
    pub material: u32,
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

/// Per glossy material (`glossy[m]`), its triangles outside `declared` (the triangles of
/// declared reflectors), in material order; materials with none have no group.
pub fn glossy_groups(triangles: &[Triangle], glossy: &[bool], declared: &[bool]) -> Vec<Group> {
    let mut groups: Vec<Option<Group>> = vec![None; glossy.len()];
    // Per material, the area summed (the mean normal's divisor).
    let mut areas = vec![0.0f32; glossy.len()];
    for (t, tri) in triangles.iter().enumerate() {
        let m = tri.material as usize;
        if !glossy.get(m).copied().unwrap_or(false) || declared.get(t).copied().unwrap_or(false) {
            continue;
        }
        let g = groups[m].get_or_insert_with(|| Group {
            material: m as u32,
            triangles: Vec::new(),
            bounds: Aabb::EMPTY,
            mean_normal: Vec3::ZERO,
        });
        g.triangles.push(t as u32);
        g.bounds = tri.p.iter().fold(g.bounds, |b, p| b.grow(*p));
        let a = tri.area();
        g.mean_normal += tri.face_normal() * a;
        areas[m] += a;
    }
    groups
        .into_iter()
        .zip(areas)
        .filter_map(|(g, area)| {
            let mut g = g?;
            g.mean_normal = if area > 0.0 {
                g.mean_normal / area
            } else {
                Vec3::ZERO
            };
            Some(g)
        })
        .collect()
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
    glossy_groups(&scene.triangles, &glossy, &declared)
}

/// Where the bake puts a group's probe (see the module's comment) and its reach: off the
/// group's box along its normal, then further along it, a lift at a time, while something
/// lies nearer than a lift (`clearance`: the distance from a point to the nearest surface
/// around it), so a probe never ends up inside an object on the surface (a teapot on a
/// table); it stays inside `bounds`, and where no point is clear, at the first.
pub fn placed(group: &Group, bounds: &Aabb, clearance: &dyn Fn(Vec3) -> f32) -> (Vec3, f32) {
    let b = &group.bounds;
    let half = 0.5 * (b.max - b.min);
    let up = if group.mean_normal.length() >= MIN_MEAN_NORMAL {
        group.mean_normal.normalize()
    } else {
        Vec3::Y
    };
    let lift = (LIFT * b.diagonal()).max(MIN_LIFT);
    let inside = |p: Vec3| bounds.min.cmple(p).all() && p.cmple(bounds.max).all();
    // From the centre to the box's face along `up` (its support distance), then off it. Where
    // `up` leans along two axes or more (a cabinet's top and front), on out past the box's
    // faces on each of them, if that stays inside `bounds`: short of the top's plane the
    // probe sees the cabinet itself where the top reflects the wall behind it.
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
    let first = if inside(at(beyond)) {
        at(beyond)
    } else {
        at(support)
    };
    let clear = (0..MAX_LIFTS)
        .map(|k| first + up * (k as f32 * lift))
        .take_while(|&p| inside(p))
        .find(|&p| clearance(p) >= lift);
    let position = clear.unwrap_or(first);
    (position, position.distance(b.center()) + half.length())
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

/// The probes of a scene: one per group, named after its material (`names[material]`), then
/// scene.json's `given` probes, each moving the placed probe of its name or added after them
/// (reach: the given radius, else the placed one's, else `bounds`' diagonal). None without
/// groups, whatever `given` says.
pub fn place(
    groups: &[Group],
    names: &[&str],
    given: &[ProbeDesc],
    bounds: &Aabb,
    clearance: &dyn Fn(Vec3) -> f32,
) -> Vec<Probe> {
    if groups.is_empty() {
        return Vec::new();
    }
    let mut probes: Vec<Probe> = groups
        .iter()
        .map(|g| {
            let (position, radius) = placed(g, bounds, clearance);
            Probe {
                name: names[g.material as usize].to_string(),
                position,
                radius,
            }
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

/// The probes of `scene` ([`place`] of [`scene_groups`]).
pub fn scene_probes(scene: &Scene) -> Vec<Probe> {
    let groups = scene_groups(scene);
    if groups.is_empty() {
        return Vec::new();
    }
    let names: Vec<&str> = scene.materials.iter().map(|m| m.name.as_str()).collect();
    let bvh = scene.build_bvh();
    let clear = |p: Vec3| clearance(&bvh, p);
    place(&groups, &names, &scene.desc.probes, &scene.bounds, &clear)
}

/// The probe a group reads: the nearest whose reach holds its box's centre, else the nearest
/// (ties: the first). `None` without probes.
pub fn assign(probes: &[Probe], group: &Group) -> Option<usize> {
    let c = group.bounds.center();
    let nearest = |reach: bool| {
        probes
            .iter()
            .enumerate()
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

    /// Nothing around: every point is clear.
    fn open(_: Vec3) -> f32 {
        f32::INFINITY
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
        let groups = glossy_groups(&tris, &[false], &[false; 2]);
        assert!(groups.is_empty());
        let given = [ProbeDesc {
            name: "extra".into(),
            position: [0.5; 3],
            radius: None,
        }];
        let b = Aabb::from_points(tris.iter().flat_map(|t| t.p.iter()));
        assert!(place(&groups, &["m"], &given, &b, &open).is_empty());
    }

    #[test]
    fn declared_triangles_need_no_probe() {
        let tris: Vec<Triangle> = quad(0, 0.0, 0.0, true).into();
        assert!(glossy_groups(&tris, &[true], &[true, true]).is_empty());
        assert_eq!(
            glossy_groups(&tris, &[true], &[true, false])[0].triangles,
            vec![1]
        );
    }

    #[test]
    fn one_probe_per_glossy_material_above_its_surfaces() {
        let mut tris: Vec<Triangle> = quad(0, 0.0, 0.0, true).into();
        tris.extend(quad(1, 0.5, 2.0, true));
        tris.extend(quad(2, 0.5, 4.0, true)); // diffuse
        tris.extend(quad(0, 0.0, 6.0, true)); // the same material again: the same group
        let groups = glossy_groups(&tris, &[true, true, false], &vec![false; tris.len()]);
        assert_eq!(groups.len(), 2);
        assert_eq!(groups[0].triangles, vec![0, 1, 6, 7]);
        let b = Aabb::from_points(tris.iter().flat_map(|t| t.p.iter()));
        let probes = place(&groups, &["a", "b", "c"], &[], &b, &open);
        let names: Vec<&str> = probes.iter().map(|p| p.name.as_str()).collect();
        assert_eq!(names, ["a", "b"]);
        // Above the faces they serve (normals +y), over the box's centre.
        assert!(probes[0].position.y > 0.0 && probes[1].position.y > 0.5);
        assert!((probes[0].position.x - 3.5).abs() < 1e-5);
        for (p, g) in probes.iter().zip(&groups) {
            assert!(p.position.distance(g.bounds.center()) <= p.radius);
            assert_eq!(
                assign(&probes, g),
                Some(groups.iter().position(|h| h == g).unwrap())
            );
        }
    }

    #[test]
    fn a_closed_object_gets_its_probe_above_it() {
        // Faces up and down cancel: the probe goes up (+y), off the box.
        let mut tris: Vec<Triangle> = quad(0, 0.0, 0.0, true).into();
        tris.extend(quad(0, -0.2, 0.0, false));
        let groups = glossy_groups(&tris, &[true], &[false; 4]);
        assert!(groups[0].mean_normal.length() < 1e-6);
        let b = Aabb::from_points([Vec3::splat(-5.0), Vec3::splat(5.0)].iter());
        let (p, _) = placed(&groups[0], &b, &open);
        assert!(p.y > 0.0, "{p}");
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
        let tris: Vec<Triangle> = [top, front]
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
            .collect();
        let groups = glossy_groups(&tris, &[true], &[false; 4]);
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
    fn scene_json_moves_and_adds_probes() {
        let mut tris: Vec<Triangle> = quad(0, 0.0, 0.0, true).into();
        tris.extend(quad(1, 0.0, 3.0, true));
        let groups = glossy_groups(&tris, &[true, true], &[false; 4]);
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
        let probes = place(&groups, &["a", "b"], &given, &b, &open);
        assert_eq!(probes.len(), 3);
        assert_eq!(probes[0].position, Vec3::new(0.5, 2.0, 0.5));
        assert_eq!(probes[0].radius, 3.0);
        assert_eq!(probes[2].name, "extra");
        // The added probe is nearer to b's surfaces than b's own and reaches them.
        assert_eq!(assign(&probes, &groups[1]), Some(2));
        assert_eq!(assign(&probes, &groups[0]), Some(0));
    }

    #[test]
    fn a_probe_rises_clear_of_what_stands_on_its_surfaces() {
        let tris: Vec<Triangle> = quad(0, 0.0, 0.0, true).into();
        let groups = glossy_groups(&tris, &[true], &[false; 2]);
        let room = Aabb::from_points([Vec3::new(-3.0, 0.0, -3.0), Vec3::splat(3.0)].iter());
        // A box 0.5 m tall over the quad's middle: clear only above y = 0.5 + a lift.
        let lift = 0.1 * groups[0].bounds.diagonal();
        let clearance = |p: Vec3| if p.y < 0.5 { 0.0 } else { p.y - 0.5 };
        let (p, r) = placed(&groups[0], &room, &clearance);
        assert!(p.y >= 0.5 + lift && p.y < 0.5 + 2.0 * lift + 1e-4, "{p}");
        assert!(p.distance(groups[0].bounds.center()) <= r);
        // Where nothing is clear within the room, the first point off the surface.
        let (p, _) = placed(&groups[0], &room, &|_| 0.0);
        assert!((p.y - lift).abs() < 1e-5, "{p}");
    }

    #[test]
    fn rougher_lobes_read_coarser_levels() {
        assert_eq!(lobe_lod(0.0, 64), 0.0);
        assert!(lobe_lod(0.1, 64) < lobe_lod(0.3, 64));
        assert!(lobe_lod(0.1, 64) < lobe_lod(0.1, 128));
    }
}

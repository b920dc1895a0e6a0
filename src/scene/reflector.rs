//! Reflectors: the glossy surfaces of scene.json's `reflectors`, selected by glTF mesh or
//! material, planar (with a fitted plane) or curved.

use glam::Vec3;

use super::desc::{FaceDesc, ReflectorDesc};
use super::faces::{self, FaceSet, MIN_FACE_SHARE};
use super::plane::{fit_plane, fit_plane_sized};
use super::{Material, Object, Plane, ReflectorKind, list};
use crate::geometry::{Aabb, Triangle};

/// A resolved reflector.
#[derive(Clone, Debug, PartialEq)]
pub struct Reflector {
    /// Name used in messages and the bundle.
    pub name: String,
    /// Planar or curved.
    pub kind: ReflectorKind,
    /// Its triangles (indices into [`Scene::triangles`](super::Scene::triangles)): for a
    /// planar reflector, its reflecting face (of a slab, the front; the object's other
    /// triangles are ordinary surfaces).
    pub triangles: Vec<u32>,
    /// The material covering most of its area.
    pub material: u32,
    /// The fitted plane of a planar reflector.
    pub plane: Option<Plane>,
    /// Bounds of its triangles (a planar reflector's: of its face).
    pub bounds: Aabb,
    /// Index of its entry in scene.json's `reflectors`.
    pub index: usize,
}

/// Resolves scene.json's `reflectors`: each selects triangles by mesh/node or by material,
/// has a unique name, valid radiance overrides and, when planar, triangles within its
/// planarity tolerance of a fitted plane. `Err((field, why))` with the field from the scene's
/// root (`reflectors[1].mesh`).
pub(super) fn resolve(
    descs: &[ReflectorDesc],
    objects: &[Object],
    materials: &[Material],
    triangles: &[Triangle],
) -> Result<Vec<Reflector>, (String, String)> {
    let mut reflectors = Vec::new();
    for (i, r) in descs.iter().enumerate() {
        let at = |f: &str| format!("reflectors[{i}]{f}");
        let (selected, name) = match (&r.mesh, &r.material) {
            (Some(mesh), None) => {
                let tris: Vec<u32> = objects
                    .iter()
                    .filter(|o| o.is_named(mesh))
                    .flat_map(|o| o.triangles.clone())
                    .collect();
                if tris.is_empty() && objects.iter().any(|o| o.is_named(mesh)) {
                    return Err((
                        at(".mesh"),
                        format!(
                            "{mesh:?} matches a glTF mesh or node, but all its triangles were dropped as degenerate or non-finite (zero area: is a node scaled by 0?)"
                        ),
                    ));
                }
                if tris.is_empty() {
                    return Err((
                        at(".mesh"),
                        format!(
                            "{mesh:?} matches no glTF mesh or node; the glTF has meshes {}",
                            list(objects.iter().map(|o| o.mesh_name.as_str()))
                        ),
                    ));
                }
                (tris, mesh)
            }
            (None, Some(mat)) => {
                let Some(id) = materials.iter().position(|m| &m.name == mat) else {
                    return Err((
                        at(".material"),
                        format!(
                            "{mat:?} matches no glTF material; the glTF has {}",
                            list(materials.iter().map(|m| m.name.as_str()))
                        ),
                    ));
                };
                let tris: Vec<u32> = (0..triangles.len() as u32)
                    .filter(|&t| triangles[t as usize].material == id as u32)
                    .collect();
                if tris.is_empty() {
                    return Err((
                        at(".material"),
                        format!("no triangle uses material {mat:?}"),
                    ));
                }
                (tris, mat)
            }
            _ => {
                return Err((at(""), "give exactly one of `mesh` and `material`".into()));
            }
        };
        let name = r.name.clone().unwrap_or_else(|| name.clone());
        if reflectors.iter().any(|o: &Reflector| o.name == name) {
            return Err((
                at(".name"),
                format!("{name:?} names an earlier reflector too"),
            ));
        }
        if let Some(o) = &r.radiance {
            o.check()
                .map_err(|e| (at(&format!(".radiance.{}", e.field)), e.message))?;
        }
        let tol = r.planarity_tolerance;
        if !(tol.is_finite() && tol >= 0.0) {
            return Err((
                at(".planarity_tolerance"),
                format!("{tol} is not a finite number ≥ 0"),
            ));
        }
        let side = match (&r.face, r.kind) {
            (None, _) => Side::Auto,
            (Some(_), ReflectorKind::Curved) => {
                return Err((
                    at(".face"),
                    "only a \"planar\" reflector has a face; remove it or declare it planar".into(),
                ));
            }
            (Some(f), ReflectorKind::Planar) => Side::parse(f).map_err(|m| (at(".face"), m))?,
        };
        let (selected, plane) = match r.kind {
            ReflectorKind::Planar => {
                let (tris, plane) = planar_face(&name, triangles, selected, tol, &side)
                    .map_err(|(f, m)| (at(f), format!("reflector {name:?}: {m}")))?;
                (tris, Some(plane))
            }
            ReflectorKind::Curved => (selected, None),
        };
        let bounds = Aabb::from_points(
            selected
                .iter()
                .flat_map(|&t| triangles[t as usize].p.iter()),
        );
        reflectors.push(Reflector {
            name,
            kind: r.kind,
            material: dominant_material(triangles, &selected),
            triangles: selected,
            plane,
            bounds,
            index: i,
        });
    }
    Ok(reflectors)
}

fn dominant_material(triangles: &[Triangle], selected: &[u32]) -> u32 {
    let mut area = std::collections::BTreeMap::<u32, f64>::new();
    for &t in selected {
        let t = &triangles[t as usize];
        *area.entry(t.material).or_default() += t.area() as f64;
    }
    area.into_iter()
        .max_by(|a, b| a.1.total_cmp(&b.1))
        .map(|(m, _)| m)
        .unwrap_or(0)
}

/// Face sets whose areas are within this factor of the largest's are a tie for `"auto"`,
/// broken by the open space in front of them ([`faces::free_distance`]).
const AMBIGUOUS_AREA: f64 = 0.9;

/// The side of its object a planar reflector faces (scene.json's `face`).
#[derive(Clone, Debug, PartialEq)]
enum Side {
    /// The largest coplanar face set.
    Auto,
    /// The largest face set whose normal has a positive dot product with this direction
    /// (unit), named as in scene.json.
    Toward(Vec3, String),
}

impl Side {
    fn parse(face: &FaceDesc) -> Result<Side, String> {
        const NAMES: &str =
            "\"auto\", \"+x\", \"-x\", \"+y\", \"-y\", \"+z\", \"-z\" or a direction [x, y, z]";
        match face {
            FaceDesc::Named(n) => {
                let axis = match n.as_str() {
                    "auto" => return Ok(Side::Auto),
                    "+x" => Vec3::X,
                    "-x" => Vec3::NEG_X,
                    "+y" => Vec3::Y,
                    "-y" => Vec3::NEG_Y,
                    "+z" => Vec3::Z,
                    "-z" => Vec3::NEG_Z,
                    _ => return Err(format!("{n:?} is not a face; expected {NAMES}")),
                };
                Ok(Side::Toward(axis, n.clone()))
            }
            FaceDesc::Direction(d) => {
                let v = Vec3::from_array(*d);
                if !(v.is_finite() && v.length() > 1e-6) {
                    return Err(format!(
                        "{d:?} is not a direction (finite, not zero); expected {NAMES}"
                    ));
                }
                Ok(Side::Toward(v.normalize(), format!("{d:?}")))
            }
        }
    }

    fn accepts(&self, normal: Vec3) -> bool {
        match self {
            Side::Auto => true,
            Side::Toward(d, _) => normal.dot(*d) > 0.0,
        }
    }
}

/// A planar reflector's reflecting triangles and plane. When every selected triangle lies in
/// one plane (within `tol` × their bounding-box diagonal) facing `side`, all of them, as
/// fitted by [`fit_plane`]. Otherwise the object is more than one plane (a slab mirror: front,
/// back, bevelled edges): its coplanar face sets ([`faces::coplanar_sets`]: normals within
/// [`faces::COPLANAR_ANGLE_DEG`], vertices within `tol` × the object's bounding-box diagonal
/// of one plane), and the largest facing `side` reflects, if it holds at least
/// [`MIN_FACE_SHARE`] of the area of the object's faces that face its way
/// ([`faces::share_of_its_side`]: so a bent panel is refused, not halved). `Err((field,
/// message))`.
fn planar_face(
    name: &str,
    triangles: &[Triangle],
    selected: Vec<u32>,
    tol: f32,
    side: &Side,
) -> Result<(Vec<u32>, Plane), (&'static str, String)> {
    let whole = fit_plane(triangles, &selected, tol);
    if let Ok(plane) = &whole
        && side.accepts(plane.normal)
    {
        return Ok((selected, *plane));
    }
    let size = Aabb::from_points(
        selected
            .iter()
            .flat_map(|&t| triangles[t as usize].p.iter()),
    )
    .diagonal();
    let sets = faces::coplanar_sets(triangles, &selected, tol as f64 * size as f64);
    let facing: Vec<&FaceSet> = sets.iter().filter(|s| side.accepts(s.normal)).collect();
    let found = || {
        format!(
            "its {} triangles form {} coplanar face set{} (normals within {}°, vertices within {tol:.1e} × its size {size:.3} m of one plane): {}",
            selected.len(),
            sets.len(),
            if sets.len() == 1 { "" } else { "s" },
            faces::COPLANAR_ANGLE_DEG,
            faces::describe(&sets)
        )
    };
    // "auto" between face sets of about equal area (a slab's front and back): the one with
    // more open space in front of it (a wall-mounted mirror's back faces the wall).
    let mut facing = facing;
    let mut open_space = None;
    if matches!(side, Side::Auto)
        && facing
            .get(1)
            .is_some_and(|n| n.area >= AMBIGUOUS_AREA * facing[0].area)
    {
        let bvh = crate::geometry::Bvh::build(triangles);
        let scene = Aabb::from_points(triangles.iter().flat_map(|t| t.p.iter())).diagonal();
        let close: Vec<(f32, &FaceSet)> = facing
            .iter()
            .take_while(|s| s.area >= AMBIGUOUS_AREA * facing[0].area)
            .map(|s| {
                (
                    faces::free_distance(s, triangles, &bvh, 1e-3 * size, scene),
                    *s,
                )
            })
            .collect();
        // Most open first; equal distances keep the larger area (stable sort).
        let mut order = close.clone();
        order.sort_by(|a, b| b.0.total_cmp(&a.0));
        open_space = Some((order[0].0, order[1].0));
        let chosen = order[0].1;
        facing.retain(|s| *s != chosen);
        facing.insert(0, chosen);
    }
    let Some(best) = facing.first() else {
        let Side::Toward(_, name) = side else {
            unreachable!("\"auto\" accepts every face set and there is at least one");
        };
        return Err((
            ".face",
            format!(
                "no coplanar face set faces {name} (normal · direction > 0); {}",
                found()
            ),
        ));
    };
    let share = faces::share_of_its_side(best, &sets);
    if share < MIN_FACE_SHARE {
        let need = format!(
            "holds only {:.0}% of the area of its faces that face that way (a planar reflector's face must hold {:.0}%)",
            100.0 * share,
            100.0 * MIN_FACE_SHARE
        );
        return Err(match side {
            Side::Toward(_, n) => (
                ".face",
                format!(
                    "the largest coplanar face set facing {n} {need}: {}; name another side",
                    found()
                ),
            ),
            Side::Auto => (
                ".kind",
                format!(
                    "{}; and its largest coplanar face set {need}: {}; or select the reflecting surface alone by its `material`",
                    whole
                        .err()
                        .unwrap_or_else(|| "declared planar; declare it \"curved\"".into()),
                    found()
                ),
            ),
        });
    }
    let plane = fit_plane_sized(triangles, &best.triangles, tol, size)
        .map_err(|m| (".kind", format!("its largest face set: {m}")))?;
    let rest = selected.len() - best.triangles.len();
    let how = match side {
        Side::Auto => {
            let next = facing.get(1).map_or(String::new(), |n| {
                format!(
                    "; the next largest holds {:.4} m² facing ({:.2}, {:.2}, {:.2})",
                    n.area, n.normal.x, n.normal.y, n.normal.z
                )
            });
            match open_space {
                None => format!(
                    "face \"auto\": the largest of its {} coplanar face sets{next}; name the side with `face` to choose another",
                    sets.len()
                ),
                Some((mine, other)) => format!(
                    "face \"auto\": of its {} coplanar face sets, the largest are within {:.0}% of each other in area and this one has the most open space in front of it (rays travel {mine:.3} m on average, {other:.3} m in front of the next){next}; name the side with `face` to choose another",
                    sets.len(),
                    100.0 * (1.0 - AMBIGUOUS_AREA)
                ),
            }
        }
        Side::Toward(_, n) => format!("face {n}: the largest coplanar face set facing it"),
    };
    log::info!(
        "reflector {name:?}: planar, {:.4} m² facing ({:.2}, {:.2}, {:.2}), {} triangles ({how}); its other {rest} triangles (back, edges) are drawn as ordinary surfaces",
        best.area,
        plane.normal.x,
        plane.normal.y,
        plane.normal.z,
        best.triangles.len(),
    );
    let tie = match open_space {
        Some((mine, other)) => other >= 0.9 * mine,
        None => false,
    };
    if tie {
        log::warn!(
            "reflector {name:?}: faces ({:.2}, {:.2}, {:.2}) by \"auto\", but another face set is within 10% of its area and of its open space in front; name the side with `face` (\"+z\", [0, 0, 1], …)",
            plane.normal.x,
            plane.normal.y,
            plane.normal.z
        );
    }
    Ok((best.triangles.clone(), plane))
}

//! Reflectors: the glossy surfaces of scene.json's `reflectors`, selected by glTF mesh or
//! material, planar (with a fitted plane) or curved.

use super::desc::ReflectorDesc;
use super::plane::fit_plane;
use super::{Material, Object, Plane, ReflectorKind, list};
use crate::geometry::{Aabb, Triangle};

/// A resolved reflector.
#[derive(Clone, Debug, PartialEq)]
pub struct Reflector {
    /// Name used in messages and the bundle.
    pub name: String,
    /// Planar or curved.
    pub kind: ReflectorKind,
    /// Its triangles (indices into [`Scene::triangles`](super::Scene::triangles)).
    pub triangles: Vec<u32>,
    /// The material covering most of its area.
    pub material: u32,
    /// The fitted plane of a planar reflector.
    pub plane: Option<Plane>,
    /// Bounds of its triangles.
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
        let bounds = Aabb::from_points(
            selected
                .iter()
                .flat_map(|&t| triangles[t as usize].p.iter()),
        );
        let plane = match r.kind {
            ReflectorKind::Planar => Some(
                fit_plane(triangles, &selected, tol)
                    .map_err(|m| (at(".kind"), format!("reflector {name:?}: {m}")))?,
            ),
            ReflectorKind::Curved => None,
        };
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

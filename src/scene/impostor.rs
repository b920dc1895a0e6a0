//! Impostors: objects of scene.json's `impostors` drawn in reflections as depth-map
//! impostors (Popescu et al. 2006), with the billboard each is reflected on.

use super::desc::{BillboardPlacement, ImpostorDesc};
use super::plane::fit_plane;
use super::{Object, Plane, list};
use crate::geometry::{Aabb, Triangle};

/// A resolved impostor object.
#[derive(Clone, Debug, PartialEq)]
pub struct Impostor {
    /// The selecting mesh or node name.
    pub name: String,
    /// Objects it covers.
    pub objects: Vec<u32>,
    /// Capture views.
    pub views: u32,
    /// Bounds of its triangles.
    pub bounds: Aabb,
    /// How its reflected billboards are made (Popescu et al. 2006 §3, §3.2).
    pub billboard: ImpostorBillboard,
}

/// The resolved `billboard` of an impostor.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct ImpostorBillboard {
    /// `placement: "surface"`: the object's own plane (normal: its triangles' side), the same
    /// for every reflector; `None`: through the centroid, facing each reflector (§3).
    pub surface: Option<Plane>,
    /// Transition wall height H of a billboard connected to the environment (§3.2), metres;
    /// 0: not connected.
    pub wall: f32,
}

/// Largest distance of a vertex from a `surface` billboard's fitted plane, relative to the
/// object's bounding-box diagonal.
pub const SURFACE_PLANARITY: f32 = 1e-2;

/// Resolves scene.json's `impostors`: each selects objects by mesh/node name, once, with at
/// least one view and a valid billboard. `Err((field, why))` with the field from the scene's
/// root (`impostors[0].mesh`).
pub(super) fn resolve(
    descs: &[ImpostorDesc],
    objects: &[Object],
    triangles: &[Triangle],
) -> Result<Vec<Impostor>, (String, String)> {
    let mut impostors = Vec::new();
    for (i, imp) in descs.iter().enumerate() {
        let ids: Vec<u32> = (0..objects.len() as u32)
            .filter(|&o| objects[o as usize].is_named(&imp.mesh))
            .collect();
        if ids.is_empty() {
            return Err((
                format!("impostors[{i}].mesh"),
                format!(
                    "{:?} matches no glTF mesh or node; the glTF has meshes {}",
                    imp.mesh,
                    list(objects.iter().map(|o| o.mesh_name.as_str()))
                ),
            ));
        }
        if impostors.iter().any(|o: &Impostor| o.name == imp.mesh) {
            return Err((
                format!("impostors[{i}].mesh"),
                format!("{:?} is listed twice", imp.mesh),
            ));
        }
        if imp.views == 0 {
            return Err((format!("impostors[{i}].views"), "must be ≥ 1".into()));
        }
        let bounds = Aabb::from_points(ids.iter().flat_map(|&o| {
            objects[o as usize]
                .triangles
                .clone()
                .flat_map(|t| triangles[t as usize].p.iter())
        }));
        let billboard = match &imp.billboard {
            None => ImpostorBillboard::default(),
            Some(b) => {
                let wall = match b.wall_height {
                    None => 0.0,
                    Some(h) if h.is_finite() && h > 0.0 => h,
                    Some(h) => {
                        return Err((
                            format!("impostors[{i}].billboard.wall_height"),
                            format!(
                                "{h} is not a finite height > 0 in metres (leave it out for a billboard not connected to the environment)"
                            ),
                        ));
                    }
                };
                let surface = match b.placement {
                    BillboardPlacement::Centroid => None,
                    BillboardPlacement::Surface => {
                        let tris: Vec<u32> = ids
                            .iter()
                            .flat_map(|&o| objects[o as usize].triangles.clone())
                            .collect();
                        Some(fit_plane(triangles, &tris, SURFACE_PLANARITY).map_err(|m| {
                            (
                                format!("impostors[{i}].billboard.placement"),
                                format!(
                                    "\"surface\" needs a flat object, but {:?}: {}; use \"centroid\"",
                                    imp.mesh,
                                    m.replace("declared planar, but ", "")
                                        .replace("; declare it \"curved\" or raise planarity_tolerance", "")
                                        .replace("; declare it \"curved\"", "")
                                ),
                            )
                        })?)
                    }
                };
                ImpostorBillboard { surface, wall }
            }
        };
        impostors.push(Impostor {
            name: imp.mesh.clone(),
            objects: ids,
            views: imp.views,
            bounds,
            billboard,
        });
    }
    Ok(impostors)
}

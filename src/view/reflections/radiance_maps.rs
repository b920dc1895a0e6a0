//! The baked radiance maps of a planar reflector as the viewer's image-based mode (Bastos §6)
//! reads them, and the selection of the maps closest to the reflected view
//! (Bastos et al. 1999 §8.1.3): "we mirror the viewpoint and viewing direction about each
//! reflection plane … a search for the minimal angle … \[or\] the distance from the reference
//! of the radiance maps to the reflected camera".
//!
//! - [`load_cameras`]: `radiance/NAME/cameras.json` (every map's file stem, element, camera
//!   index and [`MapCamera`]), read by [`crate::radiance::index`], the stage's own reader.
//! - [`select`]: per reflector element (one hemisphere of cameras), the `count` maps whose
//!   centre of projection is closest to the mirrored eye by angle seen from the element's
//!   centre ([`Selection::Angle`], Bastos's default) or by distance ([`Selection::Distance`]).
//!
//! The maps and their quadtrees are decoded and splatted by [`crate::view::reflections`]
//! (Eq. 3 sizes per node, culling and skipping in [`super::splats`]).

use glam::Vec3;

pub use crate::radiance::index::{CamerasFile, MapEntry, load_cameras};
use crate::radiance::sampling::MapCamera;

pub use crate::view::options::Selection;

/// Centre of a map's element.
pub fn element_centre(view: &MapCamera) -> Vec3 {
    view.corner + 0.5 * (view.edge_u + view.edge_v)
}

/// The selection cost of `view` for the mirrored eye `eye` (smaller is better): the angle in
/// radians at the element's centre, or the distance in metres.
pub fn cost(view: &MapCamera, eye: Vec3, selection: Selection) -> f32 {
    match selection {
        Selection::Angle => {
            let c = element_centre(view);
            let (a, b) = (view.centre - c, eye - c);
            let denom = (a.length() * b.length()).max(1e-20);
            (a.dot(b) / denom).clamp(-1.0, 1.0).acos()
        }
        Selection::Distance => view.centre.distance(eye),
    }
}

/// Indices into `maps` of the `count` best maps of every element for the mirrored eye `eye`
/// (all of an element's maps when it has fewer), grouped by element in order of first
/// appearance, best first within an element; ties keep file order.
pub fn select(maps: &[MapEntry], eye: Vec3, selection: Selection, count: usize) -> Vec<usize> {
    let mut elements: Vec<[u32; 2]> = Vec::new();
    for m in maps {
        if !elements.contains(&m.element) {
            elements.push(m.element);
        }
    }
    let mut out = Vec::new();
    for e in elements {
        let mut ids: Vec<(f32, usize)> = maps
            .iter()
            .enumerate()
            .filter(|(_, m)| m.element == e)
            .map(|(i, m)| (cost(&m.view, eye, selection), i))
            .collect();
        ids.sort_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)));
        out.extend(ids.into_iter().take(count).map(|(_, i)| i));
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    /// One element of the floor (y = 0, normal +y) with cameras below it at the given offsets.
    fn maps(element: [u32; 2], centres: &[Vec3]) -> Vec<MapEntry> {
        centres
            .iter()
            .enumerate()
            .map(|(k, &c)| MapEntry {
                file: format!("e{}_{}_c{k}", element[0], element[1]),
                element,
                camera: k as u32,
                nodes: 0,
                view: MapCamera {
                    centre: c,
                    corner: Vec3::new(-0.5, 0.0, 0.5),
                    edge_u: Vec3::X,
                    edge_v: -Vec3::Z,
                    normal: Vec3::Y,
                    resolution: 16,
                },
            })
            .collect()
    }

    #[test]
    fn angle_selection_picks_the_camera_towards_the_mirrored_eye() {
        let m = maps(
            [0, 0],
            &[
                Vec3::new(0.0, -1.0, 0.0),
                Vec3::new(0.7, -0.7, 0.0),
                Vec3::new(-0.7, -0.7, 0.0),
            ],
        );
        // Eye above and to the −x side: mirrored below, still to the −x side.
        let eye = Vec3::new(-3.0, -3.0, 0.0);
        assert_eq!(select(&m, eye, Selection::Angle, 1), [2]);
        assert_eq!(select(&m, eye, Selection::Angle, 2), [2, 0]);
        assert_eq!(select(&m, eye, Selection::Angle, 10).len(), 3);
        // Straight above: the central camera.
        assert_eq!(
            select(&m, Vec3::new(0.0, -5.0, 0.0), Selection::Angle, 1),
            [0]
        );
    }

    #[test]
    fn distance_selection_can_differ_from_angle() {
        // A far camera exactly in the eye's direction, a near one slightly off it.
        let m = maps(
            [0, 0],
            &[Vec3::new(-4.0, -4.0, 0.0), Vec3::new(-0.5, -0.8, 0.0)],
        );
        let eye = Vec3::new(-0.6, -0.6, 0.0);
        assert_eq!(select(&m, eye, Selection::Angle, 1), [0]);
        assert_eq!(select(&m, eye, Selection::Distance, 1), [1]);
    }

    #[test]
    fn selection_is_per_element() {
        let mut m = maps(
            [0, 0],
            &[Vec3::new(0.0, -1.0, 0.0), Vec3::new(1.0, -1.0, 0.0)],
        );
        m.extend(maps(
            [1, 0],
            &[Vec3::new(0.0, -1.0, 0.0), Vec3::new(1.0, -1.0, 0.0)],
        ));
        let got = select(&m, Vec3::new(5.0, -5.0, 0.0), Selection::Angle, 1);
        assert_eq!(got, [1, 3]);
        assert_eq!("distance".parse(), Ok(Selection::Distance));
        assert!("nearest".parse::<Selection>().is_err());
    }
}

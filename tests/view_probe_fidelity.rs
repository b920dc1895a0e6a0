//! The shipped stand-in's glossy materials that no reflector declares, against the path
//! tracer, each from the camera where it was furthest off: the glossy wooden Vanity and its
//! +x end (their specular terms from the probes the bake places for them) from `room`, the glass jar (its
//! transmittance, its D and its probe's specular term) from `tiles`, and from `tiles` the
//! tiled floor where it reflects the Vanity (its probe stands far from that part of it).
//!
//! The reference keeps the lobes of the material measured and makes every other material
//! diffuse, and the bake's radiosity leaves glossy transport out (`glossy_depth` 0): then D
//! is the same diffuse solution on both sides, and what differs is the viewer's term for the
//! material itself. The pixels are those all of whose 4×4 sub-pixel rays meet the material
//! first; the viewer draws with 4× MSAA, as `glint-view` does.

#![cfg(feature = "view")]

mod common;

use common::*;
use glam::Vec3;
use glint::bake::materials::MaterialsSettings;
use glint::camera::Camera;
use glint::scene::Scene;
use glint::scene::desc::{Quality, RadiositySettings};
use glint::view::headless::Offscreen;
use glint::view::load::{ViewData, load};
use glint::view::options::ViewOptions;

/// The frame's size.
const SIZE: (u32, u32) = (192, 128);
/// Sub-pixel rays per axis that must all meet the material for a pixel to count as its.
const SUPER: u32 = 4;
/// Issue 44's bound on a glossy material's mean luminance against the path tracer's.
const TOLERANCE: f64 = 0.10;
/// The bound on the Vanity's +x end alone, at draft: its own probe, a tenth of the end's
/// diagonal off it, still reads it darker than the path tracer at the draft preset's probe
/// resolution (open in issue 44); without that probe the end is darker still.
const END_TOLERANCE: f64 = 0.15;

/// The bound on a specular term alone against the path tracer's (the difference of two
/// 64 spp frames: noisier than a whole pixel's mean).
const SPECULAR_TOLERANCE: f64 = 0.2;

/// stand-in at draft quality with the diffuse radiosity solution, and its probes.
fn bundle() -> ViewData {
    let radiosity = RadiositySettings {
        glossy_depth: 0,
        ..RadiositySettings::preset(Quality::Draft)
    };
    let bundle = shipped_bundle(
        &Recipe::new("stand-in")
            .then(Step::Scene)
            .then(Step::Radiosity(radiosity))
            .then(Step::Materials(MaterialsSettings::preset(Quality::Draft))),
    );
    load(&bundle).unwrap_or_else(|e| panic!("{e}"))
}

/// The first keyframe of `data`'s camera path `name`.
fn camera(data: &ViewData, name: &str) -> Camera {
    let path = data
        .scene
        .camera_paths
        .iter()
        .find(|p| p.name == name)
        .unwrap_or_else(|| panic!("stand-in has a camera path {name}"));
    Camera::from_keyframe(&path.keyframes[0])
}

/// The pixels all of whose 4×4 sub-pixel rays meet `material` first.
fn pixels_of(data: &ViewData, camera: &Camera, material: u32) -> Vec<bool> {
    faces_of(data, camera, material, |_| true)
}

/// The pixels all of whose 4×4 sub-pixel rays meet first a triangle of `material` whose face
/// normal `facing` takes.
fn faces_of(
    data: &ViewData,
    camera: &Camera,
    material: u32,
    facing: impl Fn(Vec3) -> bool,
) -> Vec<bool> {
    let bvh = data.scene.build_bvh();
    common::covered_pixels(camera, SIZE, SUPER, |d| {
        bvh.closest_hit(camera.position, d, f32::INFINITY)
            .is_some_and(|hit| {
                let t = &data.scene.triangles[hit.triangle as usize];
                t.material == material && facing(t.face_normal())
            })
    })
}

/// The pixels all of whose 4×4 sub-pixel rays meet the floor `floor` (facing +y) first and,
/// mirrored there, `seen` next.
fn floor_reflecting(data: &ViewData, camera: &Camera, floor: u32, seen: u32) -> Vec<bool> {
    let bvh = data.scene.build_bvh();
    let material = |hit: Option<glint::geometry::Hit>| {
        hit.map(|h| data.scene.triangles[h.triangle as usize].material)
    };
    common::covered_pixels(camera, SIZE, SUPER, |d| {
        let Some(hit) = bvh.closest_hit(camera.position, d, f32::INFINITY) else {
            return false;
        };
        let on_floor = camera.position + d * hit.t + Vec3::Y * 1e-4;
        let mirrored = Vec3::new(d.x, -d.y, d.z);
        material(Some(hit)) == Some(floor)
            && material(bvh.closest_hit(on_floor, mirrored, f32::INFINITY)) == Some(seen)
    })
}

/// The viewer's linear frame with probes on or off, 4× MSAA.
fn view(data: &ViewData, camera: &Camera, probes: bool) -> Vec<Vec3> {
    let gpu = gpu();
    let options = ViewOptions {
        probes,
        samples: 4,
        ..ViewOptions::default().linear_display()
    };
    let off = Offscreen::with_options(&gpu, data, SIZE.0, SIZE.1, &options).unwrap();
    off.render(&gpu, camera).unwrap();
    off.read_hdr(&gpu).unwrap()
}

/// The path tracer's frame (64 spp) of stand-in with `material`'s lobes alone, or none.
fn traced(camera: &Camera, material: &str, lobes: bool) -> Vec<Vec3> {
    let mut scene =
        Scene::load(repo("scenes/stand-in/scene.json")).unwrap_or_else(|e| panic!("{e}"));
    let kept = if lobes {
        vec![common::material_id(&scene, material)]
    } else {
        Vec::new()
    };
    common::traced_with_lobes_of(&mut scene, &kept, camera, SIZE)
        .1
        .image
        .rgb
}

/// Seen through its near pane, the jar's far panes are the back faces of single-sided glass:
/// they let light through but reflect none and have no D (the path tracer and the radiosity
/// solver make them black). The viewer added their D and their probe's specular term.
#[test]
fn the_glass_jar_from_tiles_is_as_bright_as_the_path_tracer() {
    let data = bundle();
    let camera = camera(&data, "tiles");
    let mask = pixels_of(&data, &camera, common::material_id(&data.scene, "Glass"));
    let count = mask.iter().filter(|m| **m).count();
    assert!(count > 50, "the jar covers {count} pixels");
    // D plus what the panes let through, without the specular term.
    let flat = masked_luminance(&view(&data, &camera, false), &mask);
    let flat_traced = masked_luminance(&traced(&camera, "Glass", false), &mask);
    // With the probe's specular term.
    let lit = masked_luminance(&view(&data, &camera, true), &mask);
    let lit_traced = masked_luminance(&traced(&camera, "Glass", true), &mask);
    let (flat_ratio, lit_ratio) = (flat / flat_traced, lit / lit_traced);
    eprintln!(
        "jar from tiles, {count} px: without specular {flat:.4} vs {flat_traced:.4} ({flat_ratio:.3}), \
         with the probe {lit:.4} vs {lit_traced:.4} ({lit_ratio:.3})"
    );
    assert!(
        (flat_ratio - 1.0).abs() < 0.05,
        "the jar's D and transmittance are {flat_ratio:.3} of the path tracer's"
    );
    assert!(
        (lit_ratio - 1.0).abs() < TOLERANCE,
        "the jar is {lit_ratio:.3} of the path tracer's"
    );
}

/// The Vanity (a cabinet against the wall: its top, its front and its ends are glossy) from
/// `room`, which looks down at its top and front and at its +x end: the top's probe must see
/// the wall behind the top, and the end, which reflects the room beside the cabinet, needs a
/// probe of its own (the cabinet's one stands in front of it, behind the end's plane, and
/// sees the cabinet's front where the end reflects the wall beside it).
#[test]
fn the_vanity_and_its_end_from_room_are_as_bright_as_the_path_tracer() {
    let data = bundle();
    let camera = camera(&data, "room");
    let vanity = common::material_id(&data.scene, "Vanity");
    let lit = view(&data, &camera, true);
    let want = traced(&camera, "Vanity", true);
    let ratios: Vec<(&str, f64, f64)> = [
        (
            "the vanity",
            pixels_of(&data, &camera, vanity),
            400,
            TOLERANCE,
        ),
        (
            "its +x end",
            faces_of(&data, &camera, vanity, |n| n.x > 0.9),
            50,
            END_TOLERANCE,
        ),
    ]
    .into_iter()
    .map(|(what, mask, least, bound)| {
        let count = mask.iter().filter(|m| **m).count();
        assert!(count > least, "{what} covers {count} pixels");
        let (got, traced) = (
            masked_luminance(&lit, &mask),
            masked_luminance(&want, &mask),
        );
        let ratio = got / traced;
        eprintln!("{what} from room, {count} px: {got:.4} vs {traced:.4} ({ratio:.3})");
        (what, ratio, bound)
    })
    .collect();
    for (what, ratio, bound) in ratios {
        assert!(
            (ratio - 1.0).abs() < bound,
            "{what} is {ratio:.3} of the path tracer's"
        );
    }
}

/// From `tiles`, the floor in front of the Vanity reflects the cabinet at a grazing angle.
/// Read in the mirror direction at the level of the whole lobe, the floor's probe, which
/// stands far from there, mixed in the bright floor beside the cabinet's base that the
/// floor cannot see: its specular term came out half as bright again as the path tracer's.
#[test]
fn the_floor_reflecting_the_vanity_from_tiles_is_as_bright_as_the_path_tracer() {
    let data = bundle();
    let camera = camera(&data, "tiles");
    let (tiles, vanity) = (
        common::material_id(&data.scene, "Tiles"),
        common::material_id(&data.scene, "Vanity"),
    );
    let mask = floor_reflecting(&data, &camera, tiles, vanity);
    let count = mask.iter().filter(|m| **m).count();
    assert!(
        count > 400,
        "the floor reflecting the vanity covers {count} pixels"
    );
    let flat = masked_luminance(&view(&data, &camera, false), &mask);
    let flat_traced = masked_luminance(&traced(&camera, "Tiles", false), &mask);
    let lit = masked_luminance(&view(&data, &camera, true), &mask);
    let want = masked_luminance(&traced(&camera, "Tiles", true), &mask);
    let (ratio, specular) = (lit / want, (lit - flat) / (want - flat_traced));
    eprintln!(
        "floor reflecting the vanity from tiles, {count} px: without specular {flat:.4} vs \
         {flat_traced:.4}, with the probe {lit:.4} vs {want:.4} ({ratio:.3}; specular term \
         {specular:.3})"
    );
    assert!(
        (flat / flat_traced - 1.0).abs() < 0.05,
        "the floor's D there is {:.3} of the path tracer's",
        flat / flat_traced
    );
    assert!(
        (ratio - 1.0).abs() < TOLERANCE,
        "the floor reflecting the vanity is {ratio:.3} of the path tracer's"
    );
    assert!(
        (specular - 1.0).abs() < SPECULAR_TOLERANCE,
        "the floor's specular term there is {specular:.3} of the path tracer's"
    );
}

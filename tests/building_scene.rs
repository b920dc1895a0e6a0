//! `scenes/tools/make_building.py`, the generated building of the scale bench: the same
//! arguments give the same bytes, the seed changes them, and at the smallest size (1/16) the
//! scene glint loads holds what the generator says it wrote — triangles, glossy planar
//! reflectors, curved reflectors, impostors, window and lamp lights and a camera path through it;
//! the views the view bench times reflections from see 1, 3 and 10 planar reflectors by the
//! viewer's test (6, all there are, at 1/16 for the last).

mod common;

use std::path::Path;
use std::process::Command;

use common::{repo, skip};
use glam::Vec3;
use glint::scene::{ReflectorKind, Scene};

/// Runs the generator into `out`; its counts (the JSON line it prints), or `None` (with a
/// skip message) where `python3` is not on PATH.
fn generate(out: &Path, size: &str, seed: u32) -> Option<serde_json::Value> {
    let script = repo("scenes/tools/make_building.py");
    let result = Command::new("python3")
        .arg(&script)
        .arg(out)
        .args(["--size", size, "--seed", &seed.to_string()])
        .output();
    let output = match result {
        Ok(output) => output,
        Err(err) if err.kind() == std::io::ErrorKind::NotFound => {
            skip("python3 is not on PATH, cannot run make_building.py");
            return None;
        }
        Err(err) => panic!("make_building.py: cannot run python3: {err}"),
    };
    assert!(
        output.status.success(),
        "make_building.py --size {size} failed ({}):\n{}",
        output.status,
        String::from_utf8_lossy(&output.stderr)
    );
    let text = String::from_utf8(output.stdout).expect("UTF-8 counts");
    Some(serde_json::from_str(text.trim()).expect("one JSON line of counts"))
}

fn read(dir: &Path, file: &str) -> Vec<u8> {
    std::fs::read(dir.join(file)).unwrap_or_else(|e| panic!("{}: {e}", dir.join(file).display()))
}

fn count(counts: &serde_json::Value, key: &str) -> usize {
    counts[key]
        .as_u64()
        .unwrap_or_else(|| panic!("counts lack {key}: {counts}")) as usize
}

/// Per `mirrors-N` camera path, the planar reflectors its first frame sees as the viewer
/// decides it (`GeometryReflections::map_count`): the eye on the reflecting side and the
/// box of the reflector's triangles not beyond one side of the 720×486 frustum.
#[cfg(feature = "view")]
fn reflectors_in_view(scene: &Scene) -> Vec<usize> {
    use glint::view::passes::renderer::{near_plane, view_projection};
    use glint::view::reflections::signed_distance;
    use glint::view::reflections::splats::{box_outside, frustum_planes};
    scene
        .camera_paths
        .iter()
        .filter(|p| p.name.starts_with("mirrors-"))
        .map(|path| {
            let camera = glint::camera::pose_at(path, 0.0);
            let planes =
                frustum_planes(&view_projection(&camera, 720.0 / 486.0, near_plane(scene)));
            scene
                .reflectors
                .iter()
                .filter(|r| {
                    r.plane.as_ref().is_some_and(|plane| {
                        signed_distance(plane, camera.position) > 0.0
                            && !box_outside(&planes, r.bounds.min, r.bounds.max)
                    })
                })
                .count()
        })
        .collect()
}

#[test]
fn the_building_generator_is_deterministic_and_the_seed_matters() {
    let dir = tempfile::tempdir().expect("temporary folder");
    let (a, b, c) = (
        dir.path().join("a"),
        dir.path().join("b"),
        dir.path().join("c"),
    );
    let Some(first) = generate(&a, "1/16", 7) else {
        return;
    };
    let second = generate(&b, "1/16", 7).expect("python3 ran once");
    assert_eq!(first, second, "counts of two runs with the same arguments");
    for file in ["building.glb", "scene.json"] {
        assert!(
            read(&a, file) == read(&b, file),
            "{file} differs between two runs with the same arguments"
        );
    }
    let other = generate(&c, "1/16", 8).expect("python3 ran once");
    assert_eq!(
        count(&other, "triangles"),
        count(&first, "triangles"),
        "another seed changes the layout, not the contents' size"
    );
    assert!(
        read(&a, "building.glb") != read(&c, "building.glb"),
        "seeds 7 and 8 gave the same building.glb"
    );
}

#[test]
fn the_smallest_building_loads_with_what_the_generator_counted() {
    let dir = tempfile::tempdir().expect("temporary folder");
    let Some(counts) = generate(dir.path(), "1/16", 1) else {
        return;
    };
    let _ = env_logger::builder().is_test(true).try_init();
    let scene = Scene::load(dir.path().join("scene.json")).unwrap_or_else(|e| panic!("{e}"));

    // One bay of five rooms: a dining room (about half the breakfast room's 269,538 triangles:
    // one chair of six), a glossy room, two bunny rooms and a Cornell box.
    assert_eq!(count(&counts, "rooms"), 5);
    assert_eq!(scene.triangles.len(), count(&counts, "triangles"));
    assert!(
        (100_000..160_000).contains(&scene.triangles.len()),
        "1/16 of about 2M triangles, got {}",
        scene.triangles.len()
    );
    assert_eq!(scene.dropped_triangles, 0, "no triangle dropped at load");

    let planar: Vec<_> = scene
        .reflectors
        .iter()
        .filter(|r| r.kind == ReflectorKind::Planar)
        .collect();
    assert_eq!(planar.len(), count(&counts, "planar_reflectors"));
    assert_eq!(planar.len(), 6, "6 glossy planar reflectors a bay");
    for r in &planar {
        assert!(
            r.plane.is_some(),
            "planar reflector {:?} has no plane",
            r.name
        );
        let material = &scene.materials[r.material as usize];
        assert!(
            material.sharpest_roughness().is_some(),
            "planar reflector {:?}: material {:?} has no glossy lobe",
            r.name,
            material.name
        );
    }
    let curved = scene.reflectors.len() - planar.len();
    assert_eq!(curved, count(&counts, "curved_reflectors"));
    assert_eq!(curved, 3, "teapots and the centrepiece");
    assert_eq!(scene.impostors.len(), count(&counts, "impostors"));
    assert_eq!(scene.impostors.len(), 2, "a bunny in each bunny room");

    // Windows: the dining room's and one per glossy or bunny room; its two pendant lamps are
    // area lights too; the other rooms' lamps are emissive ceiling meshes.
    assert_eq!(scene.lights.len(), count(&counts, "lights"));
    let windows = scene
        .lights
        .iter()
        .filter(|l| l.name.ends_with("_window"))
        .count();
    let pendants = scene
        .lights
        .iter()
        .filter(|l| l.name.contains("_pendant_"))
        .count();
    assert_eq!((windows, pendants), (4, 2), "{:?}", scene.lights);
    for l in &scene.lights {
        assert!(
            l.normal.y.abs() > 0.99 || l.normal.y.abs() < 1e-6,
            "light {:?} faces {}: windows face sideways, lamps down",
            l.name,
            l.normal
        );
    }
    let lamps = scene
        .materials
        .iter()
        .filter(|m| m.emission.max_element() > 1.0)
        .count();
    assert_eq!(lamps, 3, "Glossy, Bunny and Cornell ceiling lights");

    // One camera path through the ground floor, a keyframe in each room, inside the building
    // and looking at a wall's front, not from inside an object; then the still views of the
    // reflection modes' timings.
    let paths: Vec<(&str, usize)> = scene
        .camera_paths
        .iter()
        .map(|p| (p.name.as_str(), p.keyframes.len()))
        .collect();
    assert_eq!(
        paths,
        [
            ("walkthrough", count(&counts, "keyframes")),
            ("mirrors-1", 2),
            ("mirrors-3", 2),
            ("mirrors-10", 2)
        ]
    );
    #[cfg(feature = "view")]
    assert_eq!(reflectors_in_view(&scene), [1, 3, 6]);
    assert_eq!(count(&counts, "keyframes"), 5);
    let bvh = scene.build_bvh();
    for k in &scene.camera_paths[0].keyframes {
        let eye = Vec3::from(k.position);
        assert!(
            eye.cmpgt(scene.bounds.min).all() && eye.cmplt(scene.bounds.max).all(),
            "eye {eye} at t = {} is outside the building {:?}",
            k.time,
            scene.bounds
        );
        let dir = (Vec3::from(k.target) - eye).normalize();
        let hit = bvh
            .closest_hit(eye, dir, f32::INFINITY)
            .unwrap_or_else(|| panic!("the view at t = {} sees nothing", k.time));
        assert!(
            hit.t > 0.1
                && scene.triangles[hit.triangle as usize]
                    .face_normal()
                    .dot(dir)
                    < 0.0,
            "the view at t = {} hits the back of a triangle or is against it (t = {})",
            k.time,
            hit.t
        );
    }
}

#[test]
fn a_quarter_building_has_four_bays_on_two_storeys() {
    let dir = tempfile::tempdir().expect("temporary folder");
    let Some(counts) = generate(dir.path(), "1/4", 1) else {
        return;
    };
    assert_eq!((count(&counts, "bays"), count(&counts, "storeys")), (4, 2));
    #[cfg(feature = "view")]
    {
        let scene = Scene::load(dir.path().join("scene.json")).unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(reflectors_in_view(&scene), [1, 3, 10]);
    }
    assert_eq!(count(&counts, "planar_reflectors"), 24);
    let triangles = count(&counts, "triangles");
    assert!(
        (400_000..640_000).contains(&triangles),
        "1/4 of about 2M triangles, got {triangles}"
    );
}

//! Radiance maps with depth: exact radiance and depth against a flat wall, reprojection into
//! the map's own camera, all-miss reflectors, scale invariance, and the stage end to end.

mod common;

use std::path::Path;

use common::*;
use glam::{Vec2, Vec3};
use glint::bake::{radiance_stage, radiosity_stage};
use glint::bundle::Bundle;
use glint::progress::Silent;
use glint::radiance::footprint::PixelRays;
use glint::radiance::reads::{PixelWriter, Read};
use glint::radiance::sampling::{MapCamera, ReflectorFrame, hemisphere_cameras};
use glint::radiance::{RadianceMap, render};
use glint::scene::desc::RadiositySettings;
use glint::scene::{Quality, Scene};

/// A 1 m glossy floor reflector at y = 0 facing up, under an emissive ceiling "wall" of
/// radiance 2 at height `h`, `wall` metres across; all scaled by `scale`.
fn wall_scene(dir: &Path, scale: f32, h: f32, wall: f32) -> Scene {
    let floor = quad("Floor", 0, 1, 0.0, 0.5 * scale);
    let ceiling = flip(quad("Wall", 1, 1, h * scale, 0.5 * wall * scale));
    write_gltf(
        dir,
        "w",
        &[floor, ceiling],
        &[
            MaterialSpec {
                metallic: 1.0,
                roughness: 0.1,
                ..MaterialSpec::diffuse("floor", 0.9)
            },
            MaterialSpec {
                emissive: [1.0; 3],
                strength: 2.0,
                ..MaterialSpec::diffuse("lamp", 0.0)
            },
        ],
    );
    Scene::load(write_scene(dir, r#"{ "version": 1, "geometry": "w.gltf", "reflectors": [ { "mesh": "Floor", "kind": "planar" } ] }"#)).unwrap()
}

fn cameras(scene: &Scene, count: u32, res: u32) -> Vec<MapCamera> {
    let r = &scene.reflectors[0];
    let frame = ReflectorFrame::new(r.plane.as_ref().unwrap(), r, &scene.triangles);
    let (corner, eu, ev) = frame.element(0, 0, 1, 1);
    hemisphere_cameras(corner, eu, ev, frame.normal, count)
        .into_iter()
        .map(|c| MapCamera {
            centre: c,
            corner,
            edge_u: eu,
            edge_v: ev,
            normal: frame.normal,
            resolution: res,
        })
        .collect()
}

/// Radiance of the hit triangle's emission: exact D for a black emitter.
fn render_with_emission(scene: &Scene, cam: &MapCamera) -> RadianceMap {
    let bvh = scene.build_bvh();
    let shade = |h: &glint::geometry::Hit, _: Vec3, _: &PixelRays, out: &mut PixelWriter| {
        let read = Read {
            triangle: h.triangle,
            bary: h.bary,
            factors: None,
        };
        out.layer(Vec3::ONE, &read);
        out.d_alone();
    };
    let emission =
        |t: u32, _| scene.materials[scene.triangles[t as usize].material as usize].emission;
    render(
        cam,
        &bvh,
        &scene.triangles,
        4.0 * bvh.epsilon(),
        &shade,
        &emission,
        None,
    )
    .map
}

#[test]
fn a_flat_wall_gives_its_radiance_and_exact_depth_in_every_pixel() {
    let dir = tempfile::tempdir().unwrap();
    let h = 3.0;
    let scene = wall_scene(dir.path(), 1.0, h, 2000.0);
    for cam in cameras(&scene, 23, 32) {
        let map = render_with_emission(&scene, &cam);
        assert!(
            map.hit.iter().all(|&x| x),
            "camera {}: some pixel missed the wall",
            cam.centre
        );
        let want_z = h - cam.centre.y; // depth along +Y from the centre of projection
        for (i, (c, z)) in map.rgb.iter().zip(&map.depth).enumerate() {
            assert_eq!(*c, Vec3::splat(2.0), "pixel {i}");
            // The wall (a ceiling at y = h) is parallel to the floor: facet normal ±y.
            let n = map.normals[i];
            assert!(
                (n.y.abs() - 1.0).abs() < 1e-6 && n.x == 0.0 && n.z == 0.0,
                "pixel {i} normal {n}"
            );
            assert!(
                (z - want_z).abs() <= 1e-4 * want_z,
                "camera {}: pixel {i} depth {z}, exact {want_z}",
                cam.centre
            );
        }
    }
}

#[test]
fn reprojecting_a_maps_points_into_its_own_camera_reproduces_the_map() {
    let dir = tempfile::tempdir().unwrap();
    let scene = wall_scene(dir.path(), 1.0, 0.7, 2000.0);
    for cam in cameras(&scene, 9, 16) {
        let map = render_with_emission(&scene, &cam);
        for y in 0..16 {
            for x in 0..16 {
                let i = (y * 16 + x) as usize;
                let (p, z) = cam.project(map.points[i]).unwrap();
                assert!(
                    (p - Vec2::new(x as f32 + 0.5, y as f32 + 0.5)).length() < 1e-2,
                    "{p} for pixel ({x}, {y})"
                );
                assert!((z - map.depth[i]).abs() < 1e-4 * z);
            }
        }
    }
}

#[test]
fn a_reflector_facing_out_of_the_scene_gives_a_valid_all_miss_map() {
    let dir = tempfile::tempdir().unwrap();
    // The ceiling is below the floor's back: every ray from the floor goes up into nothing.
    let floor = quad("Floor", 0, 1, 0.0, 0.5);
    let below = quad("Below", 1, 1, -2.0, 5.0);
    write_gltf(
        dir.path(),
        "m",
        &[floor, below],
        &[
            MaterialSpec {
                metallic: 1.0,
                roughness: 0.01,
                ..MaterialSpec::diffuse("mirror", 0.9)
            },
            MaterialSpec {
                emissive: [1.0; 3],
                ..MaterialSpec::diffuse("lamp", 0.0)
            },
        ],
    );
    let scene = Scene::load(write_scene(dir.path(), r#"{ "version": 1, "geometry": "m.gltf", "reflectors": [ { "mesh": "Floor", "kind": "planar" } ] }"#)).unwrap();
    let cam = cameras(&scene, 5, 16)[4];
    let map = render_with_emission(&scene, &cam);
    assert!(map.hit.iter().all(|&h| !h));
    assert!(map.rgb.iter().all(|c| *c == Vec3::ZERO) && map.depth.iter().all(|&z| z == 0.0));
    let tree = glint::radiance::quadtree::build(
        16,
        &map.points,
        &map.depth,
        &map.hit,
        &radiance_stage::quadtree_limits(&scene),
    );
    assert!(tree.is_empty());
    let exr = radiance_stage::encode_map(
        16,
        &map,
        glint::image_io::ExrCompression::Zip16,
        glint::image_io::Precision::Float,
    )
    .unwrap();
    let img = glint::image_io::decode_exr(&exr).unwrap();
    assert!(img.channel("A").unwrap().iter().all(|&a| a == 0.0));
}

#[test]
fn tiny_and_huge_reflectors_work_at_their_scale() {
    let mut base: Option<(Vec<bool>, Vec<f32>)> = None;
    for scale in [1e-3f32, 1.0, 1e3] {
        let dir = tempfile::tempdir().unwrap();
        let scene = wall_scene(dir.path(), scale, 3.0, 40.0);
        let cam = cameras(&scene, 9, 16)[8];
        let map = render_with_emission(&scene, &cam);
        let z: Vec<f32> = map.depth.iter().map(|z| z / scale).collect();
        match &base {
            None => base = Some((map.hit.clone(), z)),
            Some((hit, zs)) => {
                assert_eq!(&map.hit, hit, "scale {scale}: different pixels hit");
                for (a, b) in z.iter().zip(zs) {
                    assert!(
                        (a - b).abs() <= 1e-3 * b.abs().max(1.0),
                        "scale {scale}: depth {a} vs {b}"
                    );
                }
            }
        }
    }
}

#[test]
fn stage_bakes_maps_quadtrees_and_table_one() {
    let dir = tempfile::tempdir().unwrap();
    let scene = wall_scene(dir.path(), 1.0, 2.0, 6.0);
    let out = dir.path().join("r.glint");
    // Without D the stage refuses, naming what to run.
    let e = radiance_stage::bake(&scene, &out, Quality::Draft, false, &Silent)
        .unwrap_err()
        .to_string();
    assert!(e.contains("glint-radiosity"), "{e}");

    let rs = RadiositySettings {
        texel_density: 4.0,
        min_chart_texels: 0,
        min_scene_texels: 0,
        contact_boost: 0.0,
        texels_per_radian: 0.0,
        rays: 16,
        light_samples: 4,
        bounces: 1,
        tolerance: 0.0,
        glossy_depth: 0,
        target_error: None,
        stitch_seams: false,
        cache_budget_mib: 2048,
        max_elements: 0,
    };
    radiosity_stage::bake(&scene, &out, &rs, false, &Silent).unwrap();
    let rec = radiance_stage::bake(&scene, &out, Quality::Draft, false, &Silent).unwrap();
    let plan = &radiance_stage::plans(&scene, Quality::Draft)[0].2;
    let maps = (plan.elements[0] * plan.elements[1] * plan.cameras) as usize;
    assert_eq!(rec.stats["maps"], maps);
    assert_eq!(
        rec.assets
            .iter()
            .filter(|a| a.kind == "radiance-exr")
            .count(),
        maps
    );
    assert_eq!(
        rec.assets.iter().filter(|a| a.kind == "quadtree").count(),
        maps
    );
    let row = &rec.stats["reflectors"][0];
    assert_eq!(row["reflector"], "Floor");
    assert_eq!(row["maps_per_hemisphere"], plan.cameras);
    // A map opens as EXR with its depth channel; its lit pixels show the lamp (D = 2).
    let bundle = Bundle::open(&out).unwrap();
    assert!(bundle.verify().is_empty());
    let exr = rec
        .assets
        .iter()
        .find(|a| a.kind == "radiance-exr")
        .unwrap();
    let img = glint::image_io::decode_exr(&bundle.read_asset(exr).unwrap()).unwrap();
    assert_eq!(img.width as u32, plan.resolution);
    let (a, r, z) = (
        img.channel("A").unwrap(),
        img.channel("R").unwrap(),
        img.channel("Z").unwrap(),
    );
    let lit: Vec<usize> = (0..a.len()).filter(|&i| a[i] == 1.0).collect();
    assert!(!lit.is_empty());
    assert!(lit.iter().all(|&i| (r[i] - 2.0).abs() < 1e-3 && z[i] > 2.0));
}

#[test]
fn maps_follow_glossiness() {
    let size = Vec2::new(4.0, 2.0);
    let mirror = glint::radiance::MapPlan::for_roughness(0.001, size, 1.0);
    let glossy = glint::radiance::MapPlan::for_roughness(0.08, size, 1.0);
    let rough = glint::radiance::MapPlan::for_roughness(0.3, size, 1.0);
    assert!(mirror.resolution > glossy.resolution && glossy.resolution > rough.resolution);
    assert!(mirror.cameras > glossy.cameras && glossy.cameras > rough.cameras);
    assert_eq!(mirror.elements, [4, 2], "elements follow the aspect ratio");
    assert_eq!(mirror.resolution, 128);
    assert_eq!(rough.resolution, 32);
}

#[test]
fn a_glossy_surface_in_a_map_shows_what_it_reflects() {
    // A metal floor (k_d = 0, a mirror-like Kurt lobe, F₀ = 1, α = 0) under a ceiling of D = 1:
    // a map's ray that meets the floor sees the ceiling in it, by the lobe's mirror-limit
    // albedo F cos θ = 0.8 at this 36.9° view, where the maps held the floor's D alone (0). A
    // matte floor, and the floor's back, keep their D.
    let dir = tempfile::tempdir().unwrap();
    let meshes = [
        quad("Floor", 0, 1, 0.0, 2.0),
        flip(quad("Ceiling", 1, 1, 1.0, 50.0)),
    ];
    write_gltf(
        dir.path(),
        "s",
        &meshes,
        &[
            MaterialSpec::diffuse("metal", 0.0),
            MaterialSpec::diffuse("white", 0.5),
        ],
    );
    let json = |lobes: &str| {
        format!(
            r#"{{ "version": 1, "geometry": "s.gltf", "materials": {{ "metal": {{ "albedo": [0, 0, 0], "lobes": [{lobes}] }} }} }}"#
        )
    };
    let load = |lobes: &str| Scene::load(write_scene(dir.path(), &json(lobes))).unwrap();
    let d = |scene: &Scene| {
        let ceiling = scene
            .objects
            .iter()
            .find(|o| o.is_named("Ceiling"))
            .unwrap();
        let ceiling = ceiling.triangles.clone();
        move |t: u32, _: glam::Vec2| Vec3::splat(if ceiling.contains(&t) { 1.0 } else { 0.0 })
    };
    let down = Vec3::new(0.6, -0.8, 0.0);
    let floor_hit = |scene: &Scene, bvh: &glint::geometry::Bvh, dir: Vec3| {
        bvh.closest_hit(Vec3::new(-0.3, 0.4, 0.1), dir, f32::INFINITY)
            .filter(|h| scene.objects[0].triangles.contains(&h.triangle))
            .expect("the ray meets the floor")
    };
    let metal = load(
        r#"{ "model": "kurt", "ks": [1, 1, 1], "r0": 1.0, "mx": 0.01, "my": 0.01, "alpha": 0.0 }"#,
    );
    let bvh = metal.build_bvh();
    let h = floor_hit(&metal, &bvh, down);
    let d_metal = d(&metal);
    let l = glint::radiance::shading::exitant_with(&metal, &bvh, &d_metal, &h, down);
    assert!(
        (l.x - 0.8).abs() < 0.01,
        "the mirror shows the ceiling: {l}"
    );
    // A wider lobe at this view still sees only the ceiling: k_s times its albedo, a little
    // under the mirror's.
    let glossy = load(
        r#"{ "model": "kurt", "ks": [0.5, 0.5, 0.5], "r0": 1.0, "mx": 0.2, "my": 0.2, "alpha": 0.0 }"#,
    );
    let l = glint::radiance::shading::exitant_with(&glossy, &bvh, &d(&glossy), &h, down);
    assert!(
        l.x > 0.3 && l.x < 0.41,
        "about half as much, from a lobe of k_s 0.5: {l}"
    );
    // From below (the floor's back face), only D.
    let up_hit = bvh
        .closest_hit(Vec3::new(0.0, -0.5, 0.0), Vec3::Y, f32::INFINITY)
        .unwrap();
    let l = glint::radiance::shading::exitant_with(&metal, &bvh, &d_metal, &up_hit, Vec3::Y);
    assert_eq!(l, Vec3::ZERO, "a back face is D alone");
    // A floor without lobes: D alone.
    let matte = Scene::load(write_scene(
        dir.path(),
        r#"{ "version": 1, "geometry": "s.gltf" }"#,
    ))
    .unwrap();
    let l = glint::radiance::shading::exitant_with(&matte, &bvh, &d(&matte), &h, down);
    assert_eq!(l, Vec3::ZERO, "a matte floor is D alone");
}

/// The bits of a map's radiance and depth.
fn map_bits(m: &RadianceMap) -> Vec<u32> {
    let rgb = m.rgb.iter().flat_map(|c| c.to_array()).map(f32::to_bits);
    rgb.chain(m.depth.iter().map(|z| z.to_bits())).collect()
}

/// A map evaluated from the records of an earlier render ([`glint::radiance::reads`]) with
/// another D has the bits of the map traced with that D; after a lobe change, the pixels that
/// met the changed material are traced again and the map is still the traced one, which
/// records evaluated as if nothing changed are not.
#[test]
fn a_map_evaluated_from_its_records_is_the_map_traced() {
    use glint::bake::read_cache::MaterialPrints;
    use glint::radiance::Replay;
    use glint::radiance::shading::{d_point, d_seen, exitant};

    let dir = tempfile::tempdir().unwrap();
    write_room(dir.path());
    let load = |alpha: f32| {
        let json = format!(
            r#"{{ "version": 1, "geometry": "room.gltf", "materials": {{ "FloorMat": {{ "lobes": [{{ "ks": [0.5, 0.5, 0.5], "r0": 0.04, "mx": {alpha}, "my": {alpha} }}] }} }}, "reflectors": [{{ "mesh": "Panel", "kind": "planar" }}] }}"#
        );
        Scene::load(write_scene(dir.path(), &json)).unwrap()
    };
    let (before, after) = (load(0.3), load(0.1));
    let cam = cameras(&before, 5, 32)[2];
    let bvh = before.build_bvh();
    let render_with = |scene: &Scene, d: &(dyn Fn(u32, Vec2) -> Vec3 + Sync), replay| {
        let levels = glint::scene::texturing::texture_levels(&scene.textures);
        let d_at = |h: &glint::geometry::Hit, _back: bool| d_point(scene, h);
        let shade =
            |h: &glint::geometry::Hit, dir: Vec3, rays: &PixelRays, out: &mut PixelWriter| {
                let seen = |h: &glint::geometry::Hit, _back: bool| d_seen(scene, &levels, h, rays);
                exitant(scene, &bvh, &d_at, &seen, h, dir, out)
            };
        let offset = 4.0 * bvh.epsilon();
        render(&cam, &bvh, &scene.triangles, offset, &shade, d, replay)
    };
    let d1 = |t: u32, b: Vec2| Vec3::new(1.0 + b.x, 2.0 * b.y, 0.1 * t as f32);
    let d2 = |t: u32, b: Vec2| Vec3::new(0.5 + b.y * b.y, 1.0 + b.x, 0.3 * t as f32 + b.x);
    let first = render_with(&before, &d1, None);
    assert_eq!(first.shaded, 32 * 32);
    let traced = render_with(&before, &d2, None);
    let none = vec![false; before.materials.len()];
    let kept = |changed| Some(Replay::of(first.reads.clone(), changed));
    let evaluated = render_with(&before, &d2, kept(&none));
    assert_eq!(evaluated.shaded, 0);
    assert_ne!(map_bits(&evaluated.map), map_bits(&first.map), "D changed");
    assert_eq!(map_bits(&evaluated.map), map_bits(&traced.map));
    assert_eq!(evaluated.map, traced.map);
    assert_eq!(evaluated.reads, traced.reads);

    let changed =
        MaterialPrints::of(&after.materials).changed_since(&MaterialPrints::of(&before.materials));
    assert_eq!(changed.iter().filter(|&&c| c).count(), 1);
    let traced = render_with(&after, &d2, None);
    let again = render_with(&after, &d2, kept(&changed));
    assert!(
        again.shaded > 0 && again.shaded < 32 * 32,
        "{} pixels traced again",
        again.shaded
    );
    assert_eq!(map_bits(&again.map), map_bits(&traced.map));
    assert_eq!(again.reads, traced.reads);
    let stale = render_with(&after, &d2, kept(&none));
    assert_ne!(map_bits(&stale.map), map_bits(&traced.map));
}

//! Reflection probes in glint-view, on the software Vulkan adapter (lavapipe): glossy-room
//! with its glossy table top left undeclared (no `TableTop` reflector, as a user who declares
//! only the floor, the mirror and the teapot has it), so only the probe the bake places gives
//! the table a specular term; with it the table's pixels come closer to the reference path
//! tracer's than kd·D alone.

#![cfg(feature = "view")]

mod common;

use common::*;
use glam::Vec3;
use glint::camera::Camera;
use glint::materials::probes::scene_groups;
use glint::scene::Scene;
use glint::scene::desc::RadiositySettings;
use glint::view::headless::Offscreen;
use glint::view::load::load;
use glint::view::options::ViewOptions;

fn radiosity_settings() -> RadiositySettings {
    RadiositySettings {
        texel_density: 8.0,
        rays: 32,
        light_samples: 4,
        bounces: 3,
        tolerance: 1e-2,
        glossy_depth: 0,
        target_error: None,
        min_chart_texels: 0,
        min_scene_texels: 0,
        contact_boost: 0.0,
        texels_per_radian: 0.0,
        stitch_seams: false,
        cache_budget_mib: 2048,
        max_elements: 0,
    }
}

#[test]
fn the_glossy_table_reflects_its_probe_towards_the_path_tracer() {
    let (flat, lit, want) = table_top(false);
    assert!(flat < want, "kd·D alone is darker than the path tracer");
    // The probe closes at least half of the gap, without overshooting by as much.
    assert!(
        (lit - want).abs() <= 0.5 * (flat - want).abs(),
        "with the probe {lit:.4} is not much closer to {want:.4} than kd·D's {flat:.4}"
    );
}

/// A probe captured next to the ceiling light sees the room far brighter than the table
/// below receives it; normalized by the table's lightmap texels (`probes::Normalization`),
/// its light on the table stays near the path tracer's instead of a multiple of it.
#[test]
fn a_probe_by_the_light_lights_the_table_as_the_lightmap_does() {
    let (flat, lit, want) = table_top(true);
    assert!(
        lit >= flat,
        "the probe adds light: {lit:.4} vs kd·D's {flat:.4}"
    );
    assert!(
        lit <= want * 1.1,
        "with the probe by the light the table reads {lit:.4} against the path tracer's {want:.4}"
    );
}

/// The mean luminance of `rgb` over the pixels of `mask`.
fn masked_mean(mask: &[bool], rgb: &[Vec3]) -> f64 {
    let (sum, count) = mask
        .iter()
        .zip(rgb)
        .filter(|(m, _)| **m)
        .fold((0.0, 0usize), |(s, n), (_, c)| {
            (s + f64::from(glint::colour::luminance(*c)), n + 1)
        });
    sum / count.max(1) as f64
}

/// A copy of glossy-room in `dir` whose scene.json declares no reflector on `mesh` (so a probe
/// lights it): the scene.json's path and its JSON.
fn glossy_room_without(
    dir: &std::path::Path,
    mesh: &str,
) -> (std::path::PathBuf, serde_json::Value) {
    let folder = dir.join("glossy-room");
    copy_dir(&repo("scenes/glossy-room"), &folder);
    let scene_json = folder.join("scene.json");
    let mut v: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&scene_json).unwrap()).unwrap();
    v["reflectors"]
        .as_array_mut()
        .unwrap()
        .retain(|r| r["mesh"] != mesh);
    std::fs::write(&scene_json, v.to_string()).unwrap();
    (scene_json, v)
}

/// The table top's mean luminance drawn with kd·D alone, with its probe, and by the path
/// tracer; the probe placed by the bake, or (`by_the_light`) moved by scene.json to just under
/// the ceiling light.
fn table_top(by_the_light: bool) -> (f64, f64, f64) {
    let dir = tempfile::tempdir().unwrap();
    let (scene_json, mut v) = glossy_room_without(dir.path(), "TableTop");
    if by_the_light {
        let scene = Scene::load(&scene_json).unwrap_or_else(|e| panic!("{e}"));
        let light = scene
            .triangles
            .iter()
            .filter(|t| scene.materials[t.material as usize].emission.max_element() > 0.0)
            .fold(glint::geometry::Aabb::EMPTY, |b, t| {
                t.p.iter().fold(b, |b, p| b.grow(*p))
            });
        let under = light.center() - Vec3::Y * 0.05;
        v["probes"] = serde_json::json!([{ "name": "GlossyTable", "position": under.to_array() }]);
        std::fs::write(&scene_json, v.to_string()).unwrap();
    }
    let scene = Scene::load(&scene_json).unwrap_or_else(|e| panic!("{e}"));
    let bundle = dir.path().join("glossy-room.glint");
    bake_with_materials(&scene, &bundle, &radiosity_settings());
    let data = load(&bundle).unwrap_or_else(|e| panic!("{e}"));
    let groups = scene_groups(&data.scene);
    assert_eq!(groups.len(), 1, "the undeclared table top alone");
    let group = &groups[0];
    // The table top from its south side, 0.5 m above it: the top reflects the north wall,
    // the mirror panel and the teapot.
    let b = group.bounds;
    let c = b.center();
    let camera = Camera::look_at(
        Vec3::new(c.x + 0.1, b.max.y + 0.5, b.max.z + 0.7),
        c,
        Vec3::Y,
        50f32.to_radians(),
    );
    let (w, h) = (96u32, 72u32);

    // The reference: the table's lobes kept, every other material diffuse (D is the diffuse
    // solution; the probe shows that room).
    let mut reference_scene = scene;
    let (bvh, reference) =
        traced_with_lobes_of(&mut reference_scene, &[group.material], &camera, (w, h));

    // The pixels whose ray and its four neighbours' hit the table top.
    let mut in_group = vec![false; reference_scene.triangles.len()];
    for &t in &group.triangles {
        in_group[t as usize] = true;
    }
    let hits: Vec<bool> = (0..h)
        .flat_map(|y| (0..w).map(move |x| (x, y)))
        .map(|(x, y)| {
            let d = camera.ray_direction(Camera::pixel_ndc(x, y, w, h), w as f32 / h as f32);
            bvh.closest_hit(camera.position, d, f32::INFINITY)
                .is_some_and(|hit| in_group[hit.triangle as usize])
        })
        .collect();
    let mask: Vec<bool> = (0..(w * h) as usize)
        .map(|i| {
            let (x, y, w) = (i % w as usize, i / w as usize, w as usize);
            x > 0
                && y > 0
                && x + 1 < w
                && y + 1 < h as usize
                && [i, i - 1, i + 1, i - w, i + w].iter().all(|&j| hits[j])
        })
        .collect();
    let count = mask.iter().filter(|&&m| m).count();
    assert!(count > 500, "the table top covers {count} interior pixels");
    let mean = |rgb: &[Vec3]| masked_mean(&mask, rgb);
    let want = mean(&reference.image.rgb);

    let gpu = gpu();
    let mut got = Vec::new();
    for probes in [false, true] {
        let options = ViewOptions {
            probes,
            ..ViewOptions::default()
        }
        .linear_display();
        let off = Offscreen::with_options(&gpu, &data, w, h, &options).unwrap();
        assert_eq!(off.frame().probes().is_some(), probes);
        if let Some(p) = off.frame().probes() {
            assert_eq!(p.uses().len(), 1);
            assert_eq!(p.uses()[0].probe, "GlossyTable");
        }
        off.render(&gpu, &camera).unwrap();
        got.push(mean(&off.read_hdr(&gpu).unwrap()));
    }
    let (flat, lit) = (got[0], got[1]);
    eprintln!(
        "table top, {count} pixels (probe by the light: {by_the_light}): kd·D {flat:.4}, with \
         the probe {lit:.4}, path tracer {want:.4}"
    );
    (flat, lit, want)
}

/// Specular anti-aliasing of probe light: glossy-room with its copper teapot undeclared (read
/// through the probe the bake places for it), seen from the walkthrough's first keyframe at
/// 192×128 with 4× MSAA, which shades once per pixel. Its sub-pixel highlights fill whole
/// pixels unless the lobe is widened by the pixel's spread of normals; with it the teapot's
/// mean luminance is within 10% of the path tracer's and closer to it than without.
#[test]
fn the_probe_lit_teapot_keeps_its_mean_at_low_resolution() {
    let dir = tempfile::tempdir().unwrap();
    let (scene_json, _) = glossy_room_without(dir.path(), "Teapot");
    let scene = Scene::load(&scene_json).unwrap_or_else(|e| panic!("{e}"));
    let bundle = dir.path().join("glossy-room.glint");
    bake_with_materials(&scene, &bundle, &radiosity_settings());
    let data = load(&bundle).unwrap_or_else(|e| panic!("{e}"));
    let teapot = scene_groups(&data.scene)
        .into_iter()
        .find(|g| data.scene.materials[g.material as usize].name == "PolishedMetal")
        .expect("the undeclared teapot is a probe's group");
    let path = &data.scene.camera_paths[0];
    let camera = Camera::from_keyframe(&path.keyframes[0]);
    let (w, h) = (192u32, 128u32);
    let bvh = data.scene.build_bvh();
    let mut mine = vec![false; data.scene.triangles.len()];
    for &t in &teapot.triangles {
        mine[t as usize] = true;
    }
    let mask = covered_pixels(&camera, (w, h), 4, |d| {
        bvh.closest_hit(camera.position, d, f32::INFINITY)
            .is_some_and(|hit| mine[hit.triangle as usize])
    });
    let count = mask.iter().filter(|&&m| m).count();
    assert!(count > 40, "the teapot covers {count} pixels");
    let mean = |rgb: &[Vec3]| masked_mean(&mask, rgb);
    let mut reference_scene = Scene::load(&scene_json).unwrap_or_else(|e| panic!("{e}"));
    let (_, reference) =
        traced_with_lobes_of(&mut reference_scene, &[teapot.material], &camera, (w, h));
    let want = mean(&reference.image.rgb);
    let gpu = gpu();
    let mut got = Vec::new();
    for specular_aa in [false, true] {
        let options = ViewOptions {
            probes: true,
            samples: 4,
            curved_settings: glint::view::curved::CurvedSettings {
                specular_aa,
                ..Default::default()
            },
            ..ViewOptions::default()
        }
        .linear_display();
        let off = Offscreen::with_options(&gpu, &data, w, h, &options).unwrap();
        off.render(&gpu, &camera).unwrap();
        got.push(mean(&off.read_hdr(&gpu).unwrap()));
    }
    let (aliased, widened) = (got[0], got[1]);
    eprintln!(
        "probe-lit teapot, {count} pixels at {w}×{h}: without specular AA {aliased:.4}, with \
         {widened:.4}, path tracer {want:.4}"
    );
    assert!(
        (widened / want - 1.0).abs() < 0.1,
        "with specular AA the teapot reads {widened:.4} against the path tracer's {want:.4}"
    );
    assert!(
        (widened - want).abs() < (aliased - want).abs(),
        "specular AA does not bring the teapot ({aliased:.4} → {widened:.4}) closer to {want:.4}"
    );
}

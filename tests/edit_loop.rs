//! The edit loop: the same `glint-bake SCENE --bundle B` after each kind of edit rebakes only
//! the work units whose inputs changed, and leaves a bundle byte for byte what a bake from
//! scratch of the edited scene gives; nothing changed, nothing is written; a bundle of
//! another scene is replaced only with `--force`, and the refusal names both scenes.

mod common;

use std::collections::BTreeMap;
use std::path::Path;

use common::*;

fn bake(args: &[&str]) -> (i32, String, String) {
    run_exe(env!("CARGO_BIN_EXE_glint-bake"), args)
}

fn s(p: &Path) -> &str {
    p.to_str().unwrap()
}

/// A room (diffuse floor, metal panel, emissive ceiling), an area light, a camera path, a
/// glossy lobe on the floor and the panel as planar reflector; sampled coarsely, to bake in
/// seconds.
fn edit_room(dir: &Path) -> std::path::PathBuf {
    write_room(dir);
    write_scene(
        dir,
        r#"{
  "version": 1,
  "name": "edit-room",
  "geometry": "room.gltf",
  "materials": {
    "FloorMat": { "lobes": [{ "ks": [0.3, 0.3, 0.3], "r0": 0.04, "mx": 0.3, "my": 0.3, "alpha": 0.0 }] }
  },
  "lights": [
    { "name": "lamp", "corner": [-0.2, 1.9, -0.2], "edge_u": [0.4, 0.0, 0.0], "edge_v": [0.0, 0.0, 0.4], "radiance": [5.0, 5.0, 5.0] }
  ],
  "reflectors": [{ "mesh": "Panel", "kind": "planar", "radiance": { "elements": [2, 2], "cameras_per_hemisphere": 4, "resolution": 16 } }],
  "bake": { "radiosity": { "rays": 16, "light_samples": 4, "bounces": 4 } },
  "camera_paths": [
    { "name": "walk", "fps": 30, "keyframes": [
      { "time": 0.0, "position": [0.5, 1.0, 1.5], "target": [-0.9, 0.8, 0.0], "fov_y_deg": 60.0 },
      { "time": 1.0, "position": [0.0, 1.0, 1.5], "target": [-0.9, 0.8, 0.0], "fov_y_deg": 60.0 }
    ] }
  ]
}"#,
    )
}

fn edit(scene: &Path, f: impl FnOnce(&mut serde_json::Value)) {
    let mut v: serde_json::Value = serde_json::from_slice(&std::fs::read(scene).unwrap()).unwrap();
    f(&mut v);
    std::fs::write(scene, serde_json::to_string_pretty(&v).unwrap()).unwrap();
}

/// Per stage: (scene hash, settings, every asset's path, kind, size and BLAKE3 in order).
type Stages = BTreeMap<String, serde_json::Value>;

fn stages(bundle: &Path) -> Stages {
    let m: serde_json::Value =
        serde_json::from_slice(&std::fs::read(bundle.join("manifest.json")).unwrap()).unwrap();
    m["stages"]
        .as_object()
        .unwrap()
        .iter()
        .map(|(name, r)| {
            let v = serde_json::json!([r["scene_hash"], r["settings"], r["assets"]]);
            (name.clone(), v)
        })
        .collect()
}

/// Per stage, the folder the manifest names.
fn folders(bundle: &Path) -> BTreeMap<String, String> {
    let m: serde_json::Value =
        serde_json::from_slice(&std::fs::read(bundle.join("manifest.json")).unwrap()).unwrap();
    m["stages"]
        .as_object()
        .unwrap()
        .iter()
        .map(|(name, r)| (name.clone(), r["dir"].as_str().unwrap().to_string()))
        .collect()
}

/// `glint-bake` at draft into `bundle`: the units it baked.
fn bake_units(scene: &Path, bundle: &Path) -> Vec<String> {
    bake_units_logged(scene, bundle).0
}

/// [`bake_units`], with what it logged.
fn bake_units_logged(scene: &Path, bundle: &Path) -> (Vec<String>, String) {
    let (code, out, err) = bake(&[
        s(scene),
        "--quality",
        "draft",
        "--bundle",
        s(bundle),
        "--json",
    ]);
    assert_eq!(code, 0, "{err}");
    let v: serde_json::Value = serde_json::from_str(&out).unwrap();
    let units = v["units"]
        .as_array()
        .unwrap_or_else(|| panic!("no units in the report: {out}"))
        .iter()
        .filter(|u| u["baked"] == true)
        .map(|u| u["unit"].as_str().unwrap().to_string())
        .collect();
    (units, err)
}

/// From a bake's log, the radiance maps' pixels it traced and shaded, and all their pixels
/// (the rest were evaluated from their records: `glint::bake::read_cache`).
fn pixels_traced(log: &str) -> (u64, u64) {
    let mut sum = (0, 0);
    for line in log.lines() {
        let Some((_, rest)) = line.split_once("radiance maps: ") else {
            continue;
        };
        let words: Vec<&str> = rest.split_whitespace().collect();
        if words.get(3) != Some(&"pixels") {
            continue;
        }
        sum.0 += words[0].parse::<u64>().unwrap();
        sum.1 += words[2].parse::<u64>().unwrap();
    }
    sum
}

/// From a bake's log, the radiance maps' quadtrees kept with their records (not built again),
/// and all their quadtrees.
fn quadtrees_kept(log: &str) -> (u64, u64) {
    let mut sum = (0, 0);
    for line in log.lines() {
        let Some((head, _)) = line.split_once(" quadtrees kept") else {
            continue;
        };
        let words: Vec<&str> = head.split_whitespace().rev().take(3).collect();
        sum.0 += words[2].parse::<u64>().unwrap();
        sum.1 += words[0].parse::<u64>().unwrap();
    }
    sum
}

/// From a bake's log, the probes' and environment maps' cube texels it traced, and all their
/// texels (the rest were evaluated from their records).
fn texels_traced(log: &str) -> (u64, u64) {
    let mut sum = (0, 0);
    for line in log.lines() {
        let Some((head, _)) = line.split_once(" texels traced") else {
            continue;
        };
        let words: Vec<&str> = head.split_whitespace().rev().take(3).collect();
        sum.0 += words[2].parse::<u64>().unwrap();
        sum.1 += words[0].parse::<u64>().unwrap();
    }
    sum
}

/// From a bake's log, the cube faces whose records the probes and environment maps wrote,
/// and all their faces.
fn faces_written(log: &str) -> (u64, u64) {
    let mut sum = (0, 0);
    for line in log.lines() {
        let Some((head, _)) = line.split_once(" faces' records written") else {
            continue;
        };
        let words: Vec<&str> = head.split_whitespace().rev().take(3).collect();
        sum.0 += words[2].parse::<u64>().unwrap();
        sum.1 += words[0].parse::<u64>().unwrap();
    }
    sum
}

/// The bundle at `bundle` holds what a bake from scratch of `scene` gives, byte for byte.
fn assert_same_as_fresh(scene: &Path, bundle: &Path, fresh: &Path, what: &str) {
    bake_units(scene, fresh);
    let (a, b) = (stages(fresh), stages(bundle));
    assert_eq!(
        a.keys().collect::<Vec<_>>(),
        b.keys().collect::<Vec<_>>(),
        "{what}: stages"
    );
    for (name, v) in &a {
        assert_eq!(
            v, &b[name],
            "{what}: stage {name} differs from a fresh bake"
        );
    }
}

#[test]
fn each_edit_rebakes_only_what_it_touches_and_gives_the_bytes_of_a_fresh_bake() {
    let tmp = tempfile::tempdir().unwrap();
    let scene = edit_room(tmp.path());
    let bundle = tmp.path().join("out/room.glint");
    let args = [s(&scene), "--quality", "draft", "--bundle", s(&bundle)];
    let (code, _, err) = bake(&args);
    assert_eq!(code, 0, "{err}");
    // The first bake traces every map pixel.
    let (traced, pixels) = pixels_traced(&err);
    assert!(traced == pixels && pixels > 0, "{err}");
    // Every map's quadtree is built.
    let (_, maps) = quadtrees_kept(&err);
    assert!(maps > 0, "{err}");
    assert_eq!(quadtrees_kept(&err), (0, maps), "{err}");
    // And every texel of the floor's probe.
    let (traced, texels) = texels_traced(&err);
    assert!(traced == texels && texels > 0, "{err}");

    // Nothing changed: nothing baked, nothing written.
    let manifest = std::fs::read(bundle.join("manifest.json")).unwrap();
    let (code, out, err) = bake(&args);
    assert_eq!(code, 0, "{err}");
    assert!(!out.contains("baked in"), "{out}");
    assert_eq!(
        std::fs::read(bundle.join("manifest.json")).unwrap(),
        manifest
    );

    let fresh = |k: &str| tmp.path().join(format!("fresh/{k}.glint"));
    let has = |v: &[String], id: &str| v.iter().any(|u| u == id);

    // A camera path: the scene copy alone; the other stages' folders are kept, not copied.
    let before = folders(&bundle);
    edit(&scene, |v| v["camera_paths"][0]["fps"] = 24.into());
    assert_eq!(bake_units(&scene, &bundle), ["scene"]);
    let after = folders(&bundle);
    assert_ne!(before["scene"], after["scene"]);
    for stage in ["radiosity", "materials", "radiance"] {
        assert_eq!(before[stage], after[stage], "{stage}");
    }
    assert_same_as_fresh(&scene, &bundle, &fresh("camera"), "camera path");

    // One albedo: D and what reads it; the materials whose lobes did not change are kept.
    edit(&scene, |v| {
        v["materials"]["FloorMat"]["albedo"] = serde_json::json!([0.6, 0.5, 0.4])
    });
    let (baked, log) = bake_units_logged(&scene, &bundle);
    assert!(
        has(&baked, "radiosity") && has(&baked, "radiance.Panel"),
        "{baked:?}"
    );
    // An albedo is in the ray cache's key: no ray is kept. It only changes D for the radiance
    // maps: every pixel is evaluated from its record.
    assert!(!log.contains("gathering rays kept"), "{log}");
    assert_eq!(pixels_traced(&log), (0, pixels), "{log}");
    // Records kept as they are: so are the maps' quadtrees, built from the same hits.
    assert_eq!(quadtrees_kept(&log), (maps, maps), "{log}");
    // The probe is rebaked (it reads D) but captures nothing: every texel from its record.
    assert!(has(&baked, "probe.FloorMat"), "{baked:?}");
    assert_eq!(texels_traced(&log), (0, texels), "{log}");
    assert!(!has(&baked, "material.PanelMat"), "{baked:?}");
    assert_same_as_fresh(&scene, &bundle, &fresh("albedo"), "albedo");

    // A glossy roughness of a material that is no reflector: its lobes, and D (glossy
    // transport carries its light); the other material's kernels are kept.
    edit(&scene, |v| {
        v["materials"]["FloorMat"]["lobes"][0]["mx"] = 0.2.into();
        v["materials"]["FloorMat"]["lobes"][0]["my"] = 0.2.into();
    });
    let (baked, log) = bake_units_logged(&scene, &bundle);
    assert!(has(&baked, "material.FloorMat"), "{baked:?}");
    // The rays whose paths did not read FloorMat's lobes are kept from the ray cache; the
    // map pixels that see the floor are shaded again, the rest evaluated from their records.
    assert!(log.contains("gathering rays kept"), "{log}");
    let (traced, all) = pixels_traced(&log);
    assert!(traced > 0 && traced < all && all == pixels, "{log}");
    // The probe's texels that see the floor are captured again, the rest evaluated.
    let (traced, all) = texels_traced(&log);
    assert!(traced > 0 && traced < all && all == texels, "{log}");
    // Only the faces with a texel traced again have their records written again.
    let (written, faces) = faces_written(&log);
    assert!(written > 0 && written < faces && faces == 6, "{log}");
    assert!(!has(&baked, "material.PanelMat"), "{baked:?}");
    assert_same_as_fresh(&scene, &bundle, &fresh("roughness"), "roughness");
    // The ray cache, its kept batches as they were, is the one a fresh bake writes.
    let rays = |b: &Path| std::fs::read(b.with_extension("glint.units").join("radiosity.rays"));
    let kept = rays(&bundle).unwrap();
    assert!(
        kept == rays(&fresh("roughness")).unwrap(),
        "ray caches differ"
    );
    // An albedo again: no lobe changed, so no probe texel is traced, on a face kept as it was
    // by the roughness edit (its file holding the prints of before it) as on one written then.
    edit(&scene, |v| {
        v["materials"]["FloorMat"]["albedo"] = serde_json::json!([0.5, 0.5, 0.4])
    });
    let (_, log) = bake_units_logged(&scene, &bundle);
    assert_eq!(texels_traced(&log), (0, texels), "{log}");
    assert_eq!(faces_written(&log), (0, 6), "{log}");

    // One light's power: D and what reads it, no material kernel. A map's record under another
    // key (its first bytes past the format's name damaged) is not used: that map alone is traced.
    let reads = tmp.path().join("out/room.glint.units/radiance.Panel.reads");
    let mut records: Vec<_> = std::fs::read_dir(&reads)
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|e| e == "reads"))
        .collect();
    records.sort();
    let mut damaged = std::fs::read(&records[0]).unwrap();
    damaged[b"glint-reads-1".len()] ^= 1;
    std::fs::write(&records[0], damaged).unwrap();
    edit(&scene, |v| {
        v["lights"][0]["radiance"] = serde_json::json!([8.0, 8.0, 8.0])
    });
    let (baked, log) = bake_units_logged(&scene, &bundle);
    assert_eq!(pixels_traced(&log), (16 * 16, pixels), "{log}");
    // The map traced again gets a quadtree built from its new records.
    assert_eq!(quadtrees_kept(&log), (maps - 1, maps), "{log}");
    assert!(has(&baked, "radiosity"), "{baked:?}");
    assert!(
        !baked.iter().any(|u| u.starts_with("material.")),
        "{baked:?}"
    );
    assert_same_as_fresh(&scene, &bundle, &fresh("light"), "light power");

    // A reflector added: its radiance maps (and D: mirror lights read the reflectors); the
    // other reflector's material kernels are kept.
    edit(&scene, |v| {
        v["reflectors"]
            .as_array_mut()
            .unwrap()
            .push(serde_json::json!({ "mesh": "Floor", "kind": "planar",
                "radiance": { "elements": [2, 2], "cameras_per_hemisphere": 4, "resolution": 16 } }))
    });
    let baked = bake_units(&scene, &bundle);
    assert!(has(&baked, "radiance.Floor"), "{baked:?}");
    assert!(!has(&baked, "material.PanelMat"), "{baked:?}");
    assert_same_as_fresh(&scene, &bundle, &fresh("reflector"), "reflector added");
    // And what a bake stage by stage (no unit cache, D gathered in one run) gives.
    let whole = tmp.path().join("whole.glint");
    let loaded = glint::scene::Scene::load(&scene).unwrap();
    let settings =
        glint::bake::BakeSettings::resolve(&loaded, glint::scene::Quality::Draft).unwrap();
    glint::bake::bake_all(&loaded, &whole, &settings, false, &glint::progress::Silent).unwrap();
    assert_eq!(stages(&whole), stages(&bundle), "stage by stage");

    // And once more: nothing to do.
    assert_eq!(bake_units(&scene, &bundle), Vec::<String>::new());

    // A damaged shard in the cache: its unit alone is rebaked.
    let cache = tmp.path().join("out/room.glint.units");
    let file = first_file(&cache.join("material.PanelMat.glint"));
    std::fs::write(&file, b"damaged").unwrap();
    assert_eq!(bake_units(&scene, &bundle), ["material.PanelMat"]);
    assert_same_as_fresh(&scene, &bundle, &fresh("reflector"), "damaged shard");

    // A damaged or deleted bundle: assembled again from the cache, nothing baked.
    std::fs::write(first_file(&bundle), b"damaged").unwrap();
    assert_eq!(bake_units(&scene, &bundle), Vec::<String>::new());
    assert_same_as_fresh(&scene, &bundle, &fresh("reflector"), "damaged bundle");
    let problems = glint::bundle::Bundle::open(&bundle).unwrap().verify();
    assert!(problems.is_empty(), "{problems:?}");
    std::fs::remove_dir_all(&bundle).unwrap();
    assert_eq!(bake_units(&scene, &bundle), Vec::<String>::new());
    assert_same_as_fresh(&scene, &bundle, &fresh("reflector"), "deleted bundle");
}

/// The first asset file (not `manifest.json`, `unit.json` or the lock) under `dir`'s stage
/// folders, in name order.
fn first_file(dir: &Path) -> std::path::PathBuf {
    let mut entries: Vec<_> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().path())
        .collect();
    entries.sort();
    for p in entries {
        if p.is_dir() {
            return first_file(&p);
        }
        let name = p.file_name().unwrap().to_str().unwrap();
        if !["manifest.json", "unit.json", ".lock"].contains(&name) {
            return p;
        }
    }
    panic!("{}: no asset file", dir.display())
}

#[test]
fn a_bundle_of_another_scene_is_replaced_only_with_force_and_the_refusal_names_both() {
    let tmp = tempfile::tempdir().unwrap();
    let scene = lit_floor(tmp.path());
    let bundle = tmp.path().join("b.glint");
    let (code, _, err) = bake(&[s(&scene), "--quality", "draft", "--bundle", s(&bundle)]);
    assert_eq!(code, 0, "{err}");
    edit(&scene, |v| v["name"] = "other-floor".into());
    let manifest = std::fs::read(bundle.join("manifest.json")).unwrap();
    let (code, _, err) = bake(&[s(&scene), "--quality", "draft", "--bundle", s(&bundle)]);
    assert_ne!(code, 0);
    assert!(
        err.contains("`other-floor`") && err.contains("--force"),
        "{err}"
    );
    let old: serde_json::Value = serde_json::from_slice(&manifest).unwrap();
    let old_name = old["scene_name"].as_str().unwrap();
    assert!(err.contains(&format!("`{old_name}`")), "{err}");
    assert_eq!(
        std::fs::read(bundle.join("manifest.json")).unwrap(),
        manifest
    );
    let (code, _, err) = bake(&[
        s(&scene),
        "--quality",
        "draft",
        "--bundle",
        s(&bundle),
        "--force",
    ]);
    assert_eq!(code, 0, "{err}");
    let m: serde_json::Value =
        serde_json::from_slice(&std::fs::read(bundle.join("manifest.json")).unwrap()).unwrap();
    assert_eq!(m["scene_name"], "other-floor");
}

#[test]
fn a_shard_checked_or_written_in_this_run_is_not_hashed_again() {
    use glint::bake::shard::{Checked, bake_unit_gathering, read_shard, read_shard_checked};
    let tmp = tempfile::tempdir().unwrap();
    let scene = glint::scene::Scene::load(edit_room(tmp.path())).unwrap();
    let settings =
        glint::bake::BakeSettings::resolve(&scene, glint::scene::Quality::Draft).unwrap();
    let plan = glint::bake::units::plan_units(&scene, &settings).unwrap();
    let shard = tmp.path().join("scene.glint");
    let checked = Checked::default();
    let silent = &glint::progress::Silent;
    bake_unit_gathering(
        &scene, &settings, &plan, "scene", &shard, None, true, &checked, silent,
    )
    .unwrap();
    std::fs::write(first_file(&shard), b"damaged").unwrap();
    // Written in this run: read back without hashing its files again.
    assert!(read_shard_checked(&shard, &checked).is_ok());
    // A run that has not checked it hashes them, and finds the damage.
    let err = read_shard(&shard).unwrap_err().to_string();
    assert!(err.contains("damaged asset"), "{err}");
    let fresh = Checked::default();
    assert!(read_shard_checked(&shard, &fresh).is_err());
    // Baked again, the unit sees the damage (its own check) and rebakes; what it wrote then
    // reads back intact.
    let r = bake_unit_gathering(
        &scene, &settings, &plan, "scene", &shard, None, true, &fresh, silent,
    )
    .unwrap();
    assert!(
        matches!(r.status, glint::bake::StageStatus::Baked { .. }),
        "{r:?}"
    );
    assert!(read_shard(&shard).is_ok());
}

/// Through the ray cache, a roughness edit of a glossy material that is no reflector
/// follows again only the rays whose paths read its lobes, and gives the bytes of a solve from
/// scratch of the edited scene, refinement rounds included; an albedo edit does not use it.
#[test]
fn the_ray_cache_keeps_the_rays_a_roughness_edit_leaves_alone() {
    use glint::progress::Silent;
    use glint::radiosity::atlas;
    use glint::radiosity::solve::{
        CACHE_BUDGET, RAY_CACHE_BUDGET, SolveSettings, solve, solve_cached,
    };
    let tmp = tempfile::tempdir().unwrap();
    let mut scene = glint::scene::Scene::load(edit_room(tmp.path())).unwrap();
    let (atlas, samples) = atlas::build(&scene.triangles, 6.0).unwrap();
    let bvh = scene.build_bvh();
    let set = SolveSettings {
        rays: 24,
        light_samples: 4,
        bounces: 8,
        glossy_depth: 3,
        tolerance: 1e-4,
        target_error: Some(0.01),
        seed: 5,
        cache_budget: CACHE_BUDGET,
    };
    let budget = RAY_CACHE_BUDGET;
    let (first, cache, used) =
        solve_cached(&scene, &bvh, &atlas, &samples, &set, None, budget, &Silent).unwrap();
    assert_eq!(used.kept, 0);
    let cache = cache.expect("the cache fits its budget");
    let bits = |v: &[glam::Vec3]| -> Vec<[u32; 3]> {
        v.iter().map(|c| c.to_array().map(f32::to_bits)).collect()
    };

    // A cache over its budget is dropped whole; the solve's bytes are the same.
    let size = cache.encode().len() as u64;
    let (small, none, _) = solve_cached(
        &scene,
        &bvh,
        &atlas,
        &samples,
        &set,
        None,
        size / 2,
        &Silent,
    )
    .unwrap();
    assert!(none.is_none());
    assert!(bits(&first.radiance) == bits(&small.radiance), "D differs");

    let floor = scene
        .materials
        .iter()
        .position(|m| m.name == "FloorMat")
        .unwrap();
    scene.materials[floor].lobes[0].mx = 0.2;
    scene.materials[floor].lobes[0].my = 0.2;
    let fresh = solve(&scene, &bvh, &atlas, &samples, &set, &Silent).unwrap();
    assert!(fresh.stats.rounds > 0, "refinement is exercised");
    let through = |scene: &glint::scene::Scene, cache| {
        solve_cached(
            scene,
            &bvh,
            &atlas,
            &samples,
            &set,
            Some(cache),
            budget,
            &Silent,
        )
        .unwrap()
    };
    let (cached, cache, used) = through(&scene, cache);
    let cache = cache.expect("the cache fits its budget");
    assert!(bits(&fresh.radiance) == bits(&cached.radiance), "D differs");
    assert_eq!(fresh.stats, cached.stats);
    assert!(
        used.kept > used.gathered / 4 && used.kept < used.gathered,
        "{used:?}"
    );

    // Another albedo is in the cache's key: every ray is followed again.
    scene.materials[floor].albedo *= 0.5;
    let (_, _, used) = through(&scene, cache);
    assert_eq!(used.kept, 0);
}

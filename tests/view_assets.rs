//! What the viewer reads of a bundle, through each stage's own reader: a reflector whose name
//! is not a file name (a space and a slash) bakes and loads, and one flipped bit in any
//! radiance, materials or SRDM asset makes the viewer's load fail naming the file. No GPU.
#![cfg(feature = "view")]

mod common;

use std::path::{Path, PathBuf};
use std::sync::OnceLock;

use common::{MaterialSpec, copy_dir, quad, write_gltf, write_scene};
use glint::bake::{BakeSettings, bake_all};
use glint::bundle::Bundle;
use glint::materials::MaterialsIndex;
use glint::progress::Silent;
use glint::scene::Scene;
use glint::scene::desc::{Quality, RadiositySettings};
use glint::srdm::SrdmSettings;
use glint::view::load::load;
use glint::view::reflections::material::{ReflectanceChannel, ReflectanceLayout, load_material};
use glint::view::reflections::radiance_maps;

/// The reflector's name: a space and a slash, so its folder name differs from it.
const REFLECTOR: &str = "Glossy Panel/1";

/// A lit room with a glossy planar panel named [`REFLECTOR`] and one impostor block, baked
/// (scene, radiosity, materials, radiance, srdm) at small settings.
fn bundle() -> &'static Path {
    static BUNDLE: OnceLock<(tempfile::TempDir, PathBuf)> = OnceLock::new();
    &BUNDLE
        .get_or_init(|| {
            let dir = tempfile::tempdir().unwrap();
            let meshes = vec![
                quad("Floor", 0, 1, 0.0, 1.0),
                quad(REFLECTOR, 1, 0, -0.9, 0.5),
                quad("Ceiling", 2, 1, 2.0, 1.0),
                quad("Block", 0, 2, 0.3, 0.2),
            ];
            let materials = vec![
                MaterialSpec::diffuse("FloorMat", 0.5),
                MaterialSpec {
                    name: "PanelMat",
                    base: [0.9, 0.9, 0.9, 1.0],
                    metallic: 1.0,
                    roughness: 0.2,
                    emissive: [0.0; 3],
                    strength: 1.0,
                },
                MaterialSpec::emitter("LightMat", [1.0, 1.0, 1.0], 10.0),
            ];
            write_gltf(dir.path(), "room", &meshes, &materials);
            let json = format!(
                r#"{{ "version": 1, "geometry": "room.gltf",
                    "reflectors": [ {{ "mesh": "{REFLECTOR}", "kind": "planar" }} ],
                    "impostors": [ {{ "mesh": "Block", "views": 1 }} ] }}"#
            );
            let scene =
                Scene::load(write_scene(dir.path(), &json)).unwrap_or_else(|e| panic!("{e}"));
            let mut settings = BakeSettings::resolve(&scene, Quality::Draft).unwrap();
            settings.radiosity = RadiositySettings {
                texel_density: 4.0,
                rays: 16,
                light_samples: 4,
                bounces: 1,
                tolerance: 0.0,
                glossy_depth: 0,
                target_error: None,
                min_chart_texels: 0,
                min_scene_texels: 0,
                contact_boost: 0.0,
                texels_per_radian: 0.0,
                stitch_seams: false,
                cache_budget_mib: 2048,
                max_elements: 0,
            };
            settings.srdm = SrdmSettings {
                domains: 4,
                points: 4,
                resolution: 32,
            };
            let out = dir.path().join("room.glint");
            bake_all(&scene, &out, &settings, false, &Silent).unwrap_or_else(|e| panic!("{e}"));
            (dir, out)
        })
        .1
}

#[test]
fn a_reflector_named_with_a_space_and_a_slash_bakes_and_loads() {
    let data = load(bundle()).unwrap_or_else(|e| panic!("{e}"));
    for stage in ["materials", "radiance", "srdm"] {
        assert!(data.bundle.stage(stage).is_some(), "stage {stage} baked");
    }
    // Radiance: the stage wrote `radiance/Glossy_Panel_1/`; the viewer finds it by the name.
    let cams =
        radiance_maps::load_cameras(&data.bundle, REFLECTOR).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(cams.reflector, REFLECTOR);
    assert!(!cams.maps.is_empty());
    for m in &cams.maps {
        let stored = glint::radiance::index::read_map(&data.bundle, REFLECTOR, m)
            .unwrap_or_else(|e| panic!("{}: {e}", m.file));
        assert_eq!(stored.image.width as u32, m.view.resolution);
        assert_eq!(stored.nodes.len(), m.nodes);
    }
    // Materials: the panel's K and R load through the typed index.
    let index = MaterialsIndex::load(&data.bundle).unwrap().unwrap();
    assert!(index.material("PanelMat").is_some());
    load_material(
        &data.bundle,
        &index,
        "PanelMat",
        ReflectanceLayout::OneD,
        ReflectanceChannel::default(),
    )
    .unwrap_or_else(|e| panic!("{e}"));
    // SRDM: every view loads.
    let (srdm_index, views) = glint::srdm::index::load(&data.bundle).unwrap().unwrap();
    assert_eq!(views.len(), srdm_index.views.len());
    assert_eq!(views.len(), 1);
}

#[test]
fn one_flipped_bit_in_a_radiance_materials_or_srdm_asset_fails_the_load_naming_the_file() {
    let original = Bundle::open(bundle()).unwrap();
    let pick = |stage: &str, kind: &str| -> String {
        original
            .stage(stage)
            .unwrap()
            .assets
            .iter()
            .find(|a| a.kind == kind)
            .unwrap_or_else(|| panic!("stage {stage} has a {kind} asset"))
            .path
            .clone()
    };
    let targets = [
        pick("radiance", "radiance-exr"),
        pick("radiance", "radiance-cameras"),
        pick("materials", "kernel"),
        pick("materials", "materials-index"),
        pick("srdm", "srdm"),
        pick("srdm", "impostor-exr"),
    ];
    for rel in &targets {
        let dir = tempfile::tempdir().unwrap();
        let copy = dir.path().join("damaged.glint");
        copy_dir(bundle(), &copy);
        let asset = Bundle::open(&copy)
            .unwrap()
            .manifest()
            .assets()
            .find(|(_, a)| &a.path == rel)
            .map(|(_, a)| a.clone())
            .unwrap();
        let file = Bundle::open(&copy).unwrap().asset_path(&asset);
        let mut bytes = std::fs::read(&file).unwrap();
        let mid = bytes.len() / 2;
        bytes[mid] ^= 0x10;
        std::fs::write(&file, &bytes).unwrap();

        let err = load(&copy).expect_err(&format!("a flipped bit in {rel} is refused"));
        let msg = err.to_string();
        // Named as it lies on disk (in the stage's versioned folder).
        assert!(msg.contains(&file.display().to_string()), "{rel}: {msg}");
        assert!(msg.contains("BLAKE3"), "{rel}: {msg}");
    }
}

#[test]
fn the_stage_readers_check_hashes_on_read() {
    // A file changed after the viewer's load is still caught where it is read.
    let dir = tempfile::tempdir().unwrap();
    let copy = dir.path().join("late.glint");
    copy_dir(bundle(), &copy);
    let data = load(&copy).unwrap_or_else(|e| panic!("{e}"));
    let cams = radiance_maps::load_cameras(&data.bundle, REFLECTOR).unwrap();
    let rel = glint::radiance::index::map_path(REFLECTOR, &cams.maps[0].file, "qtree");
    let asset = data.bundle.stage_asset("radiance", &rel).unwrap();
    let file = data.bundle.asset_path(asset);
    let mut bytes = std::fs::read(&file).unwrap();
    bytes[0] ^= 1;
    std::fs::write(&file, &bytes).unwrap();
    let err = glint::radiance::index::read_map(&data.bundle, REFLECTOR, &cams.maps[0])
        .err()
        .expect("the damaged quadtree is refused")
        .to_string();
    assert!(err.contains(&rel), "{err}");
}

//! The fuzz targets: one per loader. Each runs the loader on the input and, when it accepts,
//! the first things a reader does with the result (index lookups, a few rays), so that a
//! loader that accepts something its readers cannot use is found too.

use std::path::Path;

use glam::{Vec2, Vec3};

use super::{Target, TargetContext};
// The materials file formats (sample-pattern tables).
use crate::bundle::Bundle;
use crate::materials::pattern_format as materials_format;
use crate::radiance::quadtree;
use crate::radiosity::RadiosityMap;
use crate::radiosity::format as atlas_format;
use crate::scene::Scene;
use crate::srdm::Srdm;

/// Every target, in the order the runs report them.
pub static TARGETS: &[Target] = &[
    Target {
        name: "scene_json",
        about: "scene.json (Scene::load, with the shipped scenes' small glTF files)",
        prepare: prepare_scene,
        run: run_scene,
    },
    Target {
        name: "gltf",
        about: "glTF / GLB import (scene::gltf_import)",
        prepare: prepare_gltf,
        run: run_gltf,
    },
    Target {
        name: "manifest",
        about: "bundle manifest.json (Bundle::open, stage_asset, asset_metadata, verify_asset, scene references)",
        prepare: prepare_manifest,
        run: run_manifest,
    },
    Target {
        name: "merge",
        about: "shards' unit.json and manifest.json as `glint-bundle merge` checks them (parse_marker, check_marker, check_shards; in memory)",
        prepare: prepare_none,
        run: run_merge,
    },
    Target {
        name: "atlas",
        about: "radiosity/atlas.bin (radiosity::format::decode, RadiosityMap lookups)",
        prepare: prepare_none,
        run: run_atlas,
    },
    Target {
        name: "qtree",
        about: "radiance map quadtree *.qtree (radiance::quadtree::decode, splat ordering)",
        prepare: prepare_none,
        run: run_qtree,
    },
    Target {
        name: "srdm",
        about: "*.srdm (Srdm::from_bytes, ray intersections, re-encoding)",
        prepare: prepare_none,
        run: run_srdm,
    },
    Target {
        name: "pattern",
        about: "materials *-pattern.bin (decode_pattern)",
        prepare: prepare_none,
        run: run_pattern,
    },
    Target {
        name: "exr",
        about: "OpenEXR images (image_io::decode_exr)",
        prepare: prepare_none,
        run: run_exr,
    },
    Target {
        name: "srdm_index",
        about: "srdm/index.json (bake::srdm_stage::SrdmIndex)",
        prepare: prepare_none,
        run: run_srdm_index,
    },
    #[cfg(feature = "view")]
    Target {
        name: "cameras_json",
        about: "radiance/NAME/cameras.json (view::radiance_maps::CamerasFile, map selection)",
        prepare: prepare_none,
        run: run_cameras,
    },
    #[cfg(feature = "view")]
    Target {
        name: "materials_index",
        about: "materials/index.json with its EXR files (view::reflections::material::load_material)",
        prepare: prepare_materials,
        run: run_materials,
    },
];

fn prepare_none(_repo: &Path, scratch: &Path) -> Result<TargetContext, String> {
    Ok(TargetContext {
        scratch: scratch.to_owned(),
        ..Default::default()
    })
}

/// Copies `files` (paths under `repo`) into `scratch`, by file name.
fn copy_in(repo: &Path, scratch: &Path, files: &[&str]) -> Result<(), String> {
    std::fs::create_dir_all(scratch).map_err(|e| format!("{}: {e}", scratch.display()))?;
    for f in files {
        let from = repo.join(f);
        let name = from.file_name().expect("a file name");
        std::fs::copy(&from, scratch.join(name)).map_err(|e| format!("{}: {e}", from.display()))?;
    }
    Ok(())
}

/// The shipped scenes' glTF files small enough to load thousands of times a second (the
/// bunny's and the breakfast room's are left out: their scene.json then fails at `geometry`,
/// which still exercises the JSON parse and schema).
const SCENE_GLTF: &[&str] = &[
    "scenes/cornell-box/cornell_box.glb",
    "scenes/glossy-room/glossy-room.glb",
];

fn prepare_scene(repo: &Path, scratch: &Path) -> Result<TargetContext, String> {
    copy_in(repo, scratch, SCENE_GLTF)?;
    prepare_none(repo, scratch)
}

fn run_scene(ctx: &TargetContext, input: &[u8]) -> Result<(), String> {
    let path = ctx.scratch.join("scene.json");
    std::fs::write(&path, input).map_err(|e| format!("{}: {e}", path.display()))?;
    let scene = Scene::load(&path).map_err(|e| e.to_string())?;
    scene.has_emitters();
    for p in &scene.camera_paths {
        scene.camera_path(Some(&p.name));
    }
    Ok(())
}

fn prepare_gltf(repo: &Path, scratch: &Path) -> Result<TargetContext, String> {
    // A .gltf seed names its buffer `fuzz.bin`: the cornell box's binary chunk.
    copy_in(repo, scratch, &[])?;
    let glb = std::fs::read(repo.join("fuzz/corpus/gltf/cornell_box.glb"))
        .map_err(|e| format!("fuzz/corpus/gltf/cornell_box.glb: {e}"))?;
    let bin = glb_binary_chunk(&glb).ok_or("cornell_box.glb has no binary chunk")?;
    std::fs::write(scratch.join("fuzz.bin"), bin).map_err(|e| e.to_string())?;
    prepare_none(repo, scratch)
}

/// The BIN chunk of a GLB (header 12 bytes, then JSON and BIN chunks).
fn glb_binary_chunk(glb: &[u8]) -> Option<&[u8]> {
    let u32_at = |o: usize| Some(u32::from_le_bytes(glb.get(o..o + 4)?.try_into().ok()?));
    let json_len = u32_at(12)? as usize;
    let bin_at = 20 + json_len;
    let bin_len = u32_at(bin_at)? as usize;
    glb.get(bin_at + 8..bin_at + 8 + bin_len)
}

fn run_gltf(ctx: &TargetContext, input: &[u8]) -> Result<(), String> {
    let path = ctx.scratch.join("fuzz.glb");
    let imported = crate::scene::gltf_import::import_bytes(&path, input.to_vec(), 1.0)
        .map_err(|e| e.to_string())?;
    // What the scene loader does next: look up each triangle's material and object.
    for t in &imported.triangles {
        assert!(
            (t.material as usize) < imported.materials.len(),
            "material index out of range"
        );
        assert!(
            (t.object as usize) < imported.objects.len(),
            "object index out of range"
        );
    }
    Ok(())
}

/// The scene stage the `scene-stage` and `scene-link` seeds list, in `scene.1/`: scene.json,
/// a glTF naming a buffer, an image and a data: URI, and `link.bin`, a symbolic link to
/// `/dev/zero` (a reader that follows it never ends, which the driver reports as a hang).
const MANIFEST_FIXTURE: [(&str, &str); 4] = [
    (
        "scene.json",
        "{ \"version\": 1, \"geometry\": \"s.gltf\" }\n",
    ),
    (
        "s.gltf",
        "{\"asset\":{\"version\":\"2.0\"},\"buffers\":[{\"uri\":\"s.bin\",\"byteLength\":4}],\"images\":[{\"uri\":\"img.png\"},{\"uri\":\"data:image/png;base64,AAAA\"},{\"bufferView\":0,\"mimeType\":\"image/png\"}]}\n",
    ),
    ("s.bin", "bin\n"),
    ("img.png", "png\n"),
];

fn prepare_manifest(repo: &Path, scratch: &Path) -> Result<TargetContext, String> {
    let folder = scratch.join("scene.1");
    std::fs::create_dir_all(&folder).map_err(|e| format!("{}: {e}", folder.display()))?;
    for (name, text) in MANIFEST_FIXTURE {
        let path = folder.join(name);
        std::fs::write(&path, text).map_err(|e| format!("{}: {e}", path.display()))?;
    }
    #[cfg(unix)]
    {
        let link = folder.join("link.bin");
        let _ = std::fs::remove_file(&link);
        std::os::unix::fs::symlink("/dev/zero", &link)
            .map_err(|e| format!("{}: {e}", link.display()))?;
    }
    prepare_none(repo, scratch)
}

fn run_manifest(ctx: &TargetContext, input: &[u8]) -> Result<(), String> {
    std::fs::write(ctx.scratch.join(crate::bundle::MANIFEST), input).map_err(|e| e.to_string())?;
    let bundle = Bundle::open(&ctx.scratch).map_err(|e| e.to_string())?;
    for (stage, asset) in bundle.manifest().assets().take(8) {
        let rel = asset
            .path
            .strip_prefix(&format!("{stage}/"))
            .unwrap_or(&asset.path);
        let _ = bundle.stage_asset(stage, rel);
        let _ = bundle.asset_metadata(asset);
        let _ = bundle.verify_asset(asset);
    }
    // What verify and the viewer check next: the scene stage's references.
    let _ = bundle.check_scene_references();
    Ok(())
}

/// Separates the files of a `merge` input: a shard's `unit.json`, its `manifest.json`, the
/// next shard's `unit.json`, …
const MERGE_SEPARATOR: &[u8] = b"\n%%\n";

/// Most shards one `merge` input is read as.
const MERGE_SHARDS: usize = 64;

/// The shards' files: what a merge reads from disk, checked as it checks them; when the
/// merge accepts, each stage's units must lie in shards holding that stage (the merge reads
/// their records next).
fn run_merge(_ctx: &TargetContext, input: &[u8]) -> Result<(), String> {
    use crate::bake::merge::{ShardView, check_shards};
    use crate::bake::shard::{check_marker, parse_marker};
    use crate::bundle::Manifest;
    let mut files = Vec::new();
    let mut rest = input;
    while let Some(at) = rest
        .windows(MERGE_SEPARATOR.len())
        .position(|w| w == MERGE_SEPARATOR)
    {
        files.push(&rest[..at]);
        rest = &rest[at + MERGE_SEPARATOR.len()..];
    }
    files.push(rest);
    let mut read = Vec::new();
    let mut problems = Vec::new();
    for (i, pair) in files.chunks(2).take(MERGE_SHARDS).enumerate() {
        let path = std::path::PathBuf::from(format!("shard{i}.glint"));
        let shard = (|| {
            let marker = parse_marker(&path, pair[0]).map_err(|e| e.to_string())?;
            let manifest: Manifest =
                serde_json::from_slice(pair.get(1).copied().unwrap_or_default())
                    .map_err(|e| format!("{}: manifest.json: {e}", path.display()))?;
            check_marker(&path, &marker, &manifest).map_err(|e| e.to_string())?;
            Ok::<_, String>((marker, manifest))
        })();
        match shard {
            Ok((marker, manifest)) => read.push((path, marker, manifest)),
            Err(e) => problems.push(e),
        }
    }
    let views: Vec<ShardView> = read
        .iter()
        .map(|(path, marker, manifest)| ShardView {
            path,
            marker,
            manifest,
        })
        .collect();
    let assembly = check_shards(&views, problems).map_err(|e| e.to_string())?;
    for part in &assembly.stages {
        for (id, i) in &part.units {
            let v = views.get(*i).ok_or("a unit's shard index out of range")?;
            assert!(
                v.marker.unit == *id,
                "unit {id} assembled from another unit's shard"
            );
            assert!(
                v.manifest.stages.contains_key(part.stage.name()),
                "unit {id}'s shard lacks its stage {}",
                part.stage.name()
            );
        }
    }
    Ok(())
}

fn run_atlas(_ctx: &TargetContext, input: &[u8]) -> Result<(), String> {
    let atlas = atlas_format::decode(input).map_err(|e| e.to_string())?;
    for &p in &atlas.tri_page {
        assert!(
            (p as usize) < atlas.pages.len(),
            "triangle page out of range"
        );
    }
    // Look D up the way the stages do, on pages filled with a constant (small atlases only).
    let texels: u64 = atlas
        .pages
        .iter()
        .map(|p| p.width as u64 * p.height as u64)
        .sum();
    if texels <= 1 << 14 {
        let pages = atlas
            .pages
            .iter()
            .map(|p| vec![Vec3::ONE; (p.width * p.height) as usize])
            .collect();
        let tris = atlas.tri_page.len().min(64) as u32;
        let map = RadiosityMap { atlas, pages };
        for t in 0..tris {
            for bary in [Vec2::ZERO, Vec2::new(0.25, 0.5), Vec2::new(1.0, 0.0)] {
                map.radiance(t, bary);
            }
        }
    }
    Ok(())
}

fn run_qtree(_ctx: &TargetContext, input: &[u8]) -> Result<(), String> {
    let (res, nodes) = quadtree::decode(input)?;
    // Readers walk the tree from the root: children after their parent and in range, pixel
    // rectangles inside the map.
    for (i, n) in nodes.iter().enumerate() {
        assert!(
            n.rect[0] < n.rect[2] && n.rect[2] <= res,
            "node {i} x range"
        );
        assert!(
            n.rect[1] < n.rect[3] && n.rect[3] <= res,
            "node {i} y range"
        );
        if !n.is_leaf() {
            assert!(n.first_child as usize > i, "node {i} child before parent");
            assert!(
                n.first_child as u64 + n.children as u64 <= nodes.len() as u64,
                "node {i} children out of range"
            );
        }
    }
    #[cfg(feature = "view")]
    if res <= 64 && !nodes.is_empty() {
        use crate::view::reflections::splats::{MapImage, map_splats};
        let n = (res * res) as usize;
        let ones = vec![1.0f32; n];
        let view = crate::radiance::sampling::MapCamera {
            centre: Vec3::new(0.0, -1.0, 0.0),
            corner: Vec3::new(-0.5, 0.0, -0.5),
            edge_u: Vec3::X,
            edge_v: Vec3::Z,
            normal: Vec3::Y,
            resolution: res,
        };
        let image = MapImage {
            rgb: [&ones, &ones, &ones],
            hit: &ones,
            z: &ones,
            normal: Some([&ones, &ones]),
        };
        map_splats(
            &view,
            &image,
            nodes,
            0,
            &crate::view::reflections::exact::ExactSurfaces::new(&[], Vec::new(), 1e-3, 1e-2),
        )?;
    }
    Ok(())
}

fn run_srdm(_ctx: &TargetContext, input: &[u8]) -> Result<(), String> {
    let srdm = Srdm::from_bytes(input).map_err(|e| e.to_string())?;
    // Rays from in front of the camera through the image (the viewer's first use).
    let cam = *srdm.camera();
    let w = cam.resolution as f32;
    for (x, y) in [
        (0.5, 0.5),
        (0.5 * w, 0.5 * w),
        (w - 0.5, 0.25 * w),
        (0.1, w - 0.1),
    ] {
        let target = cam.unproject(Vec2::new(x, y), 0.5);
        let origin = cam.view.position;
        let dir = (target - origin).normalize_or_zero();
        srdm.intersect(origin, dir, 1e4);
        srdm.intersect(target + cam.view.right, -cam.view.right, 10.0);
    }
    let again = Srdm::from_bytes(&srdm.to_bytes()).map_err(|e| e.to_string())?;
    assert!(again == srdm, "re-encoding changes the SRDM");
    Ok(())
}

fn run_pattern(_ctx: &TargetContext, input: &[u8]) -> Result<(), String> {
    materials_format::decode_pattern(input).map_err(|e| e.to_string())?;
    Ok(())
}

fn run_exr(_ctx: &TargetContext, input: &[u8]) -> Result<(), String> {
    let img = crate::image_io::decode_exr(input).map_err(|e| e.to_string())?;
    for (name, c) in &img.channels {
        assert!(
            c.len() == img.width * img.height,
            "channel {name} has {} samples for {}×{}",
            c.len(),
            img.width,
            img.height
        );
    }
    let _ = img.rgb();
    Ok(())
}

fn run_srdm_index(_ctx: &TargetContext, input: &[u8]) -> Result<(), String> {
    serde_json::from_slice::<crate::srdm::index::SrdmIndex>(input).map_err(|e| e.to_string())?;
    Ok(())
}

#[cfg(feature = "view")]
fn run_cameras(_ctx: &TargetContext, input: &[u8]) -> Result<(), String> {
    use crate::view::reflections::radiance_maps::{CamerasFile, Selection, select};
    let cams: CamerasFile = serde_json::from_slice(input).map_err(|e| e.to_string())?;
    for s in [Selection::Angle, Selection::Distance] {
        for i in select(&cams.maps, Vec3::new(0.3, 1.7, -2.0), s, 2) {
            assert!(i < cams.maps.len(), "selected map {i} out of range");
        }
    }
    Ok(())
}

/// The materials stage of a small bake: `index.json` is the input, the files it names
/// come from `fuzz/fixtures/materials/` (names with `__` for `/`).
#[cfg(feature = "view")]
fn prepare_materials(repo: &Path, scratch: &Path) -> Result<TargetContext, String> {
    let dir = repo.join("fuzz/fixtures/materials");
    let files = super::read_dir_files(&dir)?
        .into_iter()
        .map(|(p, b)| {
            let name = p.file_name().unwrap_or_default().to_string_lossy();
            (name.replace("__", "/"), b)
        })
        .collect::<std::collections::BTreeMap<_, _>>();
    if files.is_empty() {
        return Err(format!("{}: no fixture files", dir.display()));
    }
    Ok(TargetContext {
        scratch: scratch.to_owned(),
        files,
    })
}

#[cfg(feature = "view")]
fn run_materials(ctx: &TargetContext, input: &[u8]) -> Result<(), String> {
    use crate::materials::MaterialsIndex;
    use crate::view::reflections::material::{
        ReflectanceChannel, ReflectanceLayout, load_material_from,
    };
    let index = MaterialsIndex::parse(input).map_err(|e| e.to_string())?;
    let read = |path: &str| -> Result<crate::image_io::ExrImage, String> {
        let bytes = ctx
            .files
            .get(path)
            .ok_or_else(|| format!("{path}: not in the stage"))?;
        crate::image_io::decode_exr(bytes).map_err(|e| format!("{path}: {e}"))
    };
    let names: Vec<String> = index
        .materials
        .iter()
        .map(|m| m.name.clone())
        .take(8)
        .collect();
    // Accepted when any material loads in any layout (the fixtures hold some materials' files).
    let mut first_err = Err("no materials".to_string());
    for name in &names {
        for layout in [ReflectanceLayout::OneD, ReflectanceLayout::Sphere] {
            for channel in [ReflectanceChannel::Albedo, ReflectanceChannel::Bastos] {
                match load_material_from(&read, &index, name, layout, channel) {
                    Ok(_) => return Ok(()),
                    Err(e) => {
                        if first_err.as_ref().is_err_and(|m| m == "no materials") {
                            first_err = Err(e);
                        }
                    }
                }
            }
        }
    }
    first_err
}

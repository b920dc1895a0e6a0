//! A glTF metal-rough material's planar reflection seen at 80° from its normal, in both
//! reflection modes, against the reference path tracer (`glint::eval::reference`) at the
//! same camera, over the reflector's pixels.
//!
//! The scene isolates the reflection: a closed 4 × 3 × 4 m room whose walls are black
//! (albedo 0) and whose only light is three emissive panels (red, white, blue, albedo 0) low
//! on the far wall; the floor is a glTF metal (metallic 1, a gold base colour, roughness
//! [`ROUGHNESS`]: GGX α = roughness², two lobes for its coloured F₀, glTF 2.0 Appendix B)
//! read from the .gltf with no scene.json override. The floor's D is 0 (a metal has no
//! diffuse term) and every surface it reflects is an emitter or black, so D and the path
//! tracer agree exactly on what the floor reflects: what differs on the floor's pixels is
//! the reflection alone (K, R, the radiance maps and the path tracer's noise).
//!
//! Compared as relative RMSE over 4×4-pixel blocks wholly on the floor (the path tracer's
//! per-pixel noise at 64 spp is 7.9%; in the block means 1.8%). R is exact here (ks·R at 80°
//! within 0.1% of the lobes' directional albedo, asserted). Measured against this 64-path
//! reference (and against a 256-path one, block-mean noise 0.9%, in brackets):
//!
//! - K isotropic (as baked): geometry 0.219, image 0.315;
//! - K squeezed by cos θ across the plane of incidence: 0.128 (0.127), 0.290 (0.294);
//! - K shaped by the lobe's measured widths and median lean at the view angle
//!   ([`glint::view::reflections::lobe_shape`]), up to 6 reads per tap along the plane of
//!   incidence ([`glint::view::reflections::filter::Grazing`]): 0.047 (0.046), (0.251);
//! - and a splat's quad beyond its own Eq. 3 box pushed back in depth: 0.047 (0.046), 0.141
//!   (0.142); beyond the disc inscribed in the box: 0.047 (0.046), 0.130 (0.131);
//! - each splat its map pixel's patch on its own surface (a parallelogram, facet normals
//!   baked with the maps, `splats::footprint`): image 0.175, the panels' splats grown past
//!   their edges; that patch squeezed per screen axis into Eq. 3's box: image 0.114;
//! - the whole patch drawn behind the squeezed one, pushed back 5% of its distance
//!   (`splats::GAP_FILL_DEPTH`, which closes the gaps between rows of a curved model's
//!   splats): image 0.107;
//! - emitters drawn into M as geometry, their map points left out of the splats
//!   (`reflections::exact`), and splats seen through another element than their map's
//!   pushed back to hole filling (`splats::off_element`): image 0.043.
//!
//! What remains in geometry mode: the panels' reflections' sides a little too bright (the
//! reads' footprint is wider across the plane of incidence than the lobe: 6 reads cannot
//! reach the lobe's 1 : 5.7 aspect), the rows nearest the camera (dim) 10–40% dark. In image
//! mode, the panels' reflections are wider on each side than the path tracer's (the splats'
//! own extents reach past the panels' edges over the black wall behind, and the nearer
//! panel wins), and the rows of the panels' bottom edges, next to the floor's far edge, are
//! too bright by up to 10% (measured with Eq. 3's box, before emitters were drawn as
//! geometry).
//!
//! `GLINT_GRAZING_SPP=n` renders the reference at n paths per pixel; `GLINT_GRAZING_REUSE=1`
//! keeps it in the tests' temporary folder between runs (to measure the viewer against one
//! longer reference); `GLINT_GRAZING_IMAGES=1` writes the frames (below).

#![cfg(feature = "view")]

mod common;

use std::path::{Path, PathBuf};

use glam::Vec3;
use glint::bake::materials;
use glint::camera::Camera;
use glint::geometry::Bvh;
use glint::progress::Silent;
use glint::scene::Scene;
use glint::scene::desc::Quality;
use glint::view::load::load;
use glint::view::reflections::ReflectionMode;

use common::{MaterialSpec, rect};

/// The floor's glTF roughness (GGX α = 0.04).
const ROUGHNESS: f32 = 0.2;

/// Angle between the camera's view direction and the floor's normal.
const VIEW_ANGLE_DEG: f32 = 80.0;

/// Frame size of both renderers.
const SIZE: (u32, u32) = (160, 108);

/// Paths per pixel of the reference.
const SPP: u32 = 64;

/// Relative RMSE allowed between geometry mode's frame and the path tracer's over the
/// floor's blocks: the issue's 5%. Measured 0.047 (0.046 against a 256-path reference).
const GEOMETRY_TOLERANCE: f64 = 0.05;

/// The same for image mode, the issue's 5% too: measured 0.043 (0.107 while emitters were
/// splatted and splats were not kept to their elements, 0.114 without the gap fill, 0.130
/// with Eq. 3's box); see the module documentation for what remains.
const IMAGE_TOLERANCE: f64 = 0.05;

/// Writes and bakes the room (scene, radiosity, materials and radiance stages, draft) into
/// `view-gltf-grazing` under the tests' temporary folder; returns the bundle.
fn bake_room() -> PathBuf {
    let dir = Path::new(env!("CARGO_TARGET_TMPDIR")).join("view-gltf-grazing");
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    let materials = vec![
        MaterialSpec::diffuse("Black", 0.0),
        MaterialSpec {
            name: "Gold",
            base: [1.0, 0.77, 0.34, 1.0],
            metallic: 1.0,
            roughness: ROUGHNESS,
            emissive: [0.0; 3],
            strength: 1.0,
        },
        MaterialSpec::emitter("Red", [1.0, 0.15, 0.1], 2.0),
        MaterialSpec::emitter("White", [1.0, 1.0, 1.0], 2.0),
        MaterialSpec::emitter("Blue", [0.1, 0.2, 1.0], 2.0),
    ];
    let (x, y, z) = (Vec3::X, Vec3::Y, Vec3::Z);
    // The panels stand 1 cm in front of the far wall, facing +z.
    let panel = |name, material, x0: f32| {
        rect(name, material, Vec3::new(x0, 0.05, -1.99), 0.9 * x, 0.6 * y)
    };
    let meshes = vec![
        rect("Floor", 1, Vec3::new(-2.0, 0.0, 2.0), 4.0 * x, -4.0 * z),
        rect("Ceiling", 0, Vec3::new(-2.0, 3.0, -2.0), 4.0 * x, 4.0 * z),
        rect("Back", 0, Vec3::new(-2.0, 0.0, -2.0), 4.0 * x, 3.0 * y),
        rect("Front", 0, Vec3::new(2.0, 0.0, 2.0), -4.0 * x, 3.0 * y),
        rect("Left", 0, Vec3::new(-2.0, 0.0, 2.0), -4.0 * z, 3.0 * y),
        rect("Right", 0, Vec3::new(2.0, 0.0, -2.0), 4.0 * z, 3.0 * y),
        panel("PanelRed", 2, -1.45),
        panel("PanelWhite", 3, -0.45),
        panel("PanelBlue", 4, 0.55),
    ];
    common::write_gltf(&dir, "room", &meshes, &materials);
    let scene_json = common::write_scene(
        &dir,
        r#"{ "version": 1, "name": "gltf-grazing", "geometry": "room.gltf",
  "reflectors": [ { "mesh": "Floor", "kind": "planar" } ] }"#,
    );
    let scene = Scene::load(&scene_json).unwrap_or_else(|e| panic!("{e}"));
    let bundle = dir.join("gltf-grazing.glint");
    let settings = common::quick_radiosity(1);
    glint::bake::scene_stage::bake(&scene, &bundle, false).unwrap_or_else(|e| panic!("{e}"));
    glint::bake::radiosity_stage::bake(&scene, &bundle, &settings, false, &Silent)
        .unwrap_or_else(|e| panic!("{e}"));
    materials::bake(
        &scene,
        &bundle,
        &materials::MaterialsSettings::preset(Quality::Draft),
        false,
        &Silent,
    )
    .unwrap_or_else(|e| panic!("{e}"));
    glint::bake::radiance_stage::bake(&scene, &bundle, Quality::Draft, false, &Silent)
        .unwrap_or_else(|e| panic!("{e}"));
    bundle
}

/// Side of the square blocks of pixels compared (the path tracer's noise averaged down).
const BLOCK: u32 = 4;

/// Per [`BLOCK`]² block of pixels all in `mask`, the block's mean (other blocks: `None`).
fn block_means(f: &[Vec3], mask: &[bool]) -> Vec<Option<Vec3>> {
    let (bw, bh) = (SIZE.0 / BLOCK, SIZE.1 / BLOCK);
    (0..bw * bh)
        .map(|b| {
            let (bx, by) = (b % bw, b / bw);
            let pixels: Vec<usize> = (0..BLOCK * BLOCK)
                .map(|k| ((by * BLOCK + k / BLOCK) * SIZE.0 + bx * BLOCK + k % BLOCK) as usize)
                .collect();
            pixels
                .iter()
                .all(|&i| mask[i])
                .then(|| pixels.iter().map(|&i| f[i]).sum::<Vec3>() / pixels.len() as f32)
        })
        .collect()
}

/// sqrt(Σ|a − b|² / Σ|b|²) over the [`BLOCK`]² blocks wholly in `mask` (all channels), and
/// how many.
fn relative_rmse(a: &[Vec3], b: &[Vec3], mask: &[bool]) -> (f64, usize) {
    let (mut num, mut den, mut n) = (0.0f64, 0.0f64, 0);
    for (p, q) in block_means(a, mask).iter().zip(block_means(b, mask)) {
        if let (Some(p), Some(q)) = (p, q) {
            num += f64::from((*p - q).length_squared());
            den += f64::from(q.length_squared());
            n += 1;
        }
    }
    ((num / den.max(1e-30)).sqrt(), n)
}

/// The floor seen at [`VIEW_ANGLE_DEG`] from its normal: the viewer's ks·R there is the glTF
/// lobes' directional albedo; in both modes the frame's relative RMSE against the path tracer
/// over the floor's [`BLOCK`]² blocks is at most [`GEOMETRY_TOLERANCE`] / [`IMAGE_TOLERANCE`];
/// the reflection is not vacuous (the floor is black without it). `GLINT_GRAZING_IMAGES=1`
/// writes the frames, the difference (×4) and raw linear frames (`viewer.f32`, `pt.f32`, RGB
/// f32 little-endian, and `mask.u8`) into `target/golden-failures/` even when passing.
#[test]
fn gltf_metal_reflection_at_80_degrees_matches_the_path_tracer() {
    let bundle = bake_room();
    let data = load(&bundle).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(
        data.scene.materials[1].lobes.len(),
        2,
        "a coloured F0: two lobes"
    );
    let target = Vec3::new(0.0, 0.0, 0.2);
    let a = VIEW_ANGLE_DEG.to_radians();
    let view = Vec3::new(0.0, -a.cos(), -a.sin());
    let camera = Camera::look_at(target - 1.6 * view, target, Vec3::Y, 40f32.to_radians());
    assert!((camera.forward.dot(Vec3::Y) + a.cos()).abs() < 1e-5);
    // R: the viewer's ks·R at 80° is the lobes' directional albedo (so what remains below is
    // K, M and the path tracer's noise).
    {
        let r = &glint::view::reflections::reflectors_with_reflectance(&data)[0];
        let wo = Vec3::new(a.sin(), 0.0, a.cos());
        let albedo = data.scene.materials[1]
            .lobes
            .iter()
            .fold(Vec3::ZERO, |s, l| {
                let lobe = glint::brdf::Lobe::of_model(l.model, l.r0, l.mx, l.my);
                s + Vec3::from_array(l.ks) * lobe.albedo(wo, 128)
            });
        let viewer = r.modulation.at(Vec3::new(-wo.x, 0.0, wo.z));
        eprintln!("ks·R at 80°: viewer {viewer}, directional albedo {albedo}");
        assert!((viewer - albedo).abs().max_element() < 0.01 * albedo.max_element());
    }
    let mask = common::reflector_mask(&data, 0, &camera, SIZE.0, SIZE.1);
    let pixels = mask.iter().filter(|m| **m).count();
    assert!(pixels > 3000, "the floor covers {pixels} pixels");
    // The reference: [`SPP`] paths per pixel unless `GLINT_GRAZING_SPP` says otherwise, read
    // from (or written to) the tests' temporary folder with `GLINT_GRAZING_REUSE`.
    let spp: u32 = std::env::var("GLINT_GRAZING_SPP")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(SPP);
    let cache = std::env::var_os("GLINT_GRAZING_REUSE").map(|_| {
        Path::new(env!("CARGO_TARGET_TMPDIR")).join(format!("view-gltf-grazing-pt-{spp}.f32"))
    });
    let reference = {
        use glint::eval::reference::{self, RenderOptions};
        let bvh = Bvh::build(&data.scene.triangles);
        let opts = RenderOptions {
            width: SIZE.0,
            height: SIZE.1,
            spp,
            seed: 7,
            ..RenderOptions::default()
        };
        let cached = cache.as_ref().and_then(|p| std::fs::read(p).ok()).map(|b| {
            let f: Vec<f32> = b
                .chunks_exact(4)
                .map(|c| f32::from_le_bytes([c[0], c[1], c[2], c[3]]))
                .collect();
            let n = (SIZE.0 * SIZE.1) as usize;
            let rgb = (0..n)
                .map(|i| Vec3::from_slice(&f[3 * i..]))
                .collect::<Vec<_>>();
            let variance = f[3 * n..].to_vec();
            (rgb, variance)
        });
        let (rgb, variance) = match cached {
            Some(c) => c,
            None => {
                let t0 = std::time::Instant::now();
                let r = reference::render(&data.scene, &bvh, &camera, &opts, &Silent).unwrap();
                eprintln!(
                    "path tracer: {:.1} s at {spp} spp",
                    t0.elapsed().as_secs_f64()
                );
                if let Some(p) = &cache {
                    let bytes: Vec<u8> = r
                        .image
                        .rgb
                        .iter()
                        .flat_map(|v| v.to_array())
                        .chain(r.variance.iter().copied())
                        .flat_map(|x| x.to_le_bytes())
                        .collect();
                    std::fs::write(p, bytes).unwrap();
                }
                (r.image.rgb, r.variance)
            }
        };
        // The estimate's own noise, relative, over the floor (luminance).
        let (mut var, mut sq) = (0.0f64, 0.0f64);
        for ((v, p), m) in variance.iter().zip(&rgb).zip(&mask) {
            if *m {
                var += f64::from(*v);
                sq += f64::from(glint::colour::luminance(*p)).powi(2);
            }
        }
        eprintln!(
            "path tracer: relative noise {:.4} per pixel",
            (var / sq).sqrt()
        );
        // Of the block means (the variance of a mean of BLOCK² pixels, luminance for each
        // channel): what noise alone adds to the block RMSE.
        let v: Vec<Vec3> = variance.iter().map(|v| Vec3::splat(*v)).collect();
        let (mut nv, mut nq) = (0.0f64, 0.0f64);
        for (v, q) in block_means(&v, &mask).iter().zip(block_means(&rgb, &mask)) {
            if let (Some(v), Some(q)) = (v, q) {
                nv += f64::from(v.element_sum()) / f64::from(BLOCK * BLOCK);
                nq += f64::from(q.length_squared());
            }
        }
        eprintln!(
            "path tracer: noise of the block means {:.4}",
            (nv / nq).sqrt()
        );
        rgb
    };
    let modes = [
        ReflectionMode::Off,
        ReflectionMode::Geometry,
        ReflectionMode::Image,
    ];
    let frames = common::hdr_frames(&data, &camera, SIZE, &modes);
    let (off, blocks) = relative_rmse(&frames[0], &reference, &mask);
    eprintln!("reflections off: {off:.4} over {blocks} blocks of {pixels} floor pixels");
    assert!(
        off > 0.9,
        "the floor is not black without reflections: {off:.4}"
    );
    let mut errors = Vec::new();
    for (k, name, tolerance) in [
        (1, "geometry", GEOMETRY_TOLERANCE),
        (2, "image", IMAGE_TOLERANCE),
    ] {
        let (e, _) = relative_rmse(&frames[k], &reference, &mask);
        let sum = |f: &[Vec3]| {
            f.iter()
                .zip(&mask)
                .filter(|(_, m)| **m)
                .fold(Vec3::ZERO, |s, (p, _)| s + *p)
        };
        eprintln!(
            "{name}: relative RMSE vs path tracer {e:.4}; floor sum {} vs {}",
            sum(&frames[k]),
            sum(&reference)
        );
        if e > tolerance || std::env::var_os("GLINT_GRAZING_IMAGES").is_some() {
            let dir = common::failure_dir(&format!("gltf-grazing-{name}"));
            let png = |f: &[Vec3]| {
                let rgb = glint::view::headless::rgba_to_rgb(&glint::view::cpu::to_srgb8(f));
                glint::image_io::encode_png(SIZE.0, SIZE.1, &rgb, false).unwrap()
            };
            std::fs::write(dir.join("viewer.png"), png(&frames[k])).unwrap();
            std::fs::write(dir.join("path-tracer.png"), png(&reference)).unwrap();
            let diff: Vec<Vec3> = frames[k]
                .iter()
                .zip(&reference)
                .map(|(a, b)| ((*a - *b) * 4.0).abs())
                .collect();
            std::fs::write(dir.join("diff-x4.png"), png(&diff)).unwrap();
            let raw = |f: &[Vec3]| -> Vec<u8> {
                f.iter()
                    .flat_map(|v| v.to_array())
                    .flat_map(|x| x.to_le_bytes())
                    .collect()
            };
            std::fs::write(dir.join("viewer.f32"), raw(&frames[k])).unwrap();
            std::fs::write(dir.join("pt.f32"), raw(&reference)).unwrap();
            std::fs::write(
                dir.join("mask.u8"),
                mask.iter().map(|m| u8::from(*m)).collect::<Vec<u8>>(),
            )
            .unwrap();
            eprintln!("written to {}", dir.display());
        }
        errors.push((name, e, tolerance));
    }
    for (name, e, tolerance) in errors {
        assert!(e <= tolerance, "{name}: {e:.4} > {tolerance}");
    }
}

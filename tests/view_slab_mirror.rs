//! Real mirrors in glint-view: a slab mirror (a thin bevelled box, as assets model one)
//! declared planar reflects from its front face in both reflection modes, as an ideal
//! single-quad mirror of the same outline does; and image mode's splats cover every pixel of
//! a mirror seen at a grazing angle.
//!
//! The scene: a closed 4 × 3 × 4 m room with coloured walls, a ceiling light and a yellow
//! pillar in front of a 1 × 0.7 m mirror on the back wall (black: albedo 0, so everything on
//! its front is reflection; ks = 1, roughness 5e-4: K = identity, R = 1 without a materials
//! stage). Frames are compared as linear HDR over the mirror's front as ray cast on the CPU
//! (eroded by a pixel: rasterisation and ray casting disagree on edge pixels).

#![cfg(feature = "view")]

mod common;

use std::path::{Path, PathBuf};
use std::sync::OnceLock;

use glam::Vec3;
use glint::camera::Camera;
use glint::geometry::Bvh;
use glint::scene::Scene;
use glint::view::load::{ViewData, load};
use glint::view::reflections::{self, ReflectionMode};

use common::{MaterialSpec, MeshSpec, rect};

/// Centre of the mirror's front face (on the back wall, facing +z).
const MIRROR: Vec3 = Vec3::new(0.0, 1.4, -1.988);

/// An axis-aligned box of `size` about `centre`, faces outward.
fn cuboid(name: &'static str, material: usize, centre: Vec3, size: Vec3) -> MeshSpec {
    let h = 0.5 * size;
    let mut faces = Vec::new();
    for axis in 0..3 {
        let (a, b) = ((axis + 1) % 3, (axis + 2) % 3);
        for sign in [-1.0f32, 1.0] {
            let corner = |s: f32, t: f32| {
                let mut p = centre;
                p[axis] += sign * h[axis];
                p[a] += s * h[a];
                p[b] += t * h[b];
                p.to_array()
            };
            // Counter-clockwise seen from +axis; reversed for the −axis face.
            let mut q = [
                corner(-1.0, -1.0),
                corner(1.0, -1.0),
                corner(1.0, 1.0),
                corner(-1.0, 1.0),
            ];
            if sign < 0.0 {
                q.reverse();
            }
            faces.push(q);
        }
    }
    common::quads(name, material, &faces)
}

/// Writes the room with a slab mirror (`slab`) or a single-quad mirror of the slab's front
/// outline, bakes scene, radiosity and radiance (draft) stages, and returns the bundle.
fn bake_room(slab: bool) -> PathBuf {
    let name = if slab { "slab" } else { "quad" };
    let dir = Path::new(env!("CARGO_TARGET_TMPDIR")).join(format!("view-slab-mirror-{name}"));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    let mut materials = common::coloured_walls();
    materials.extend([
        common::coloured("Yellow", [0.85, 0.7, 0.1]),
        MaterialSpec::emitter("Light", [1.0, 1.0, 1.0], 6.0),
        MaterialSpec::diffuse("MirrorMat", 0.5),
    ]);
    let (x, y, z) = (Vec3::X, Vec3::Y, Vec3::Z);
    let mut meshes = vec![
        rect("Floor", 0, Vec3::new(-2.0, 0.0, 2.0), 4.0 * x, -4.0 * z),
        rect("Ceiling", 0, Vec3::new(-2.0, 3.0, -2.0), 4.0 * x, 4.0 * z),
        rect("Back", 0, Vec3::new(-2.0, 0.0, -2.0), 4.0 * x, 3.0 * y),
        rect("Front", 3, Vec3::new(2.0, 0.0, 2.0), -4.0 * x, 3.0 * y),
        rect("Left", 1, Vec3::new(-2.0, 0.0, 2.0), -4.0 * z, 3.0 * y),
        rect("Right", 2, Vec3::new(2.0, 0.0, -2.0), 4.0 * z, 3.0 * y),
        rect("Lamp", 5, Vec3::new(-0.5, 2.99, -0.5), x, z),
        cuboid(
            "Pillar",
            4,
            Vec3::new(0.2, 0.5, -1.2),
            Vec3::new(0.4, 1.0, 0.4),
        ),
    ];
    if slab {
        meshes.push(common::slab(
            "Mirror",
            6,
            MIRROR.to_array(),
            [1.0, 0.0, 0.0],
            [0.0, 1.0, 0.0],
            (1.0, 0.7, 0.01),
            0.005,
        ));
    } else {
        meshes.push(rect(
            "Mirror",
            6,
            MIRROR - Vec3::new(0.495, 0.345, 0.0),
            0.99 * x,
            0.69 * y,
        ));
    }
    common::write_gltf(&dir, "room", &meshes, &materials);
    let face = if slab { r#", "face": "+z""# } else { "" };
    let scene_json = common::write_scene(
        &dir,
        &format!(
            r#"{{ "version": 1, "name": "{name}-mirror", "geometry": "room.gltf",
  "materials": {{ "MirrorMat": {{ "albedo": [0, 0, 0], "lobes": [ {{ "model": "kurt", "ks": [1, 1, 1], "r0": 1.0, "mx": 0.0005, "my": 0.0005, "alpha": 0 }} ] }} }},
  "reflectors": [ {{ "mesh": "Mirror", "kind": "planar"{face} }} ] }}"#
        ),
    );
    let scene = Scene::load(&scene_json).unwrap_or_else(|e| panic!("{e}"));
    let bundle = dir.join(format!("{name}.glint"));
    common::bake_with_radiance(&scene, &bundle, &common::quick_radiosity(2));
    bundle
}

fn bundle(slab: bool) -> &'static Path {
    static SLAB: OnceLock<PathBuf> = OnceLock::new();
    static QUAD: OnceLock<PathBuf> = OnceLock::new();
    if slab {
        SLAB.get_or_init(|| bake_room(true))
    } else {
        QUAD.get_or_init(|| bake_room(false))
    }
}

/// Writes the frames (sRGB PNG) and the holes (white on black) into
/// `target/golden-failures/NAME/`.
fn write_failure(
    name: &str,
    size: (u32, u32),
    frames: &[(&str, &[Vec3])],
    holes: &[(usize, usize)],
) {
    let dir = common::failure_dir(name);
    let png = |rgb: &[u8]| glint::image_io::encode_png(size.0, size.1, rgb, false).unwrap();
    for (file, f) in frames {
        let rgb = glint::view::headless::rgba_to_rgb(&glint::view::cpu::to_srgb8(f));
        std::fs::write(dir.join(format!("{file}.png")), png(&rgb)).unwrap();
    }
    let mut mask = vec![0u8; (size.0 * size.1 * 3) as usize];
    for &(x, y) in holes {
        let k = 3 * (y * size.0 as usize + x);
        mask[k..k + 3].fill(255);
    }
    std::fs::write(dir.join("holes.png"), png(&mask)).unwrap();
    eprintln!("written to {}", dir.display());
}

/// Σ|a − b| / Σ|b| over the masked pixels (all channels).
fn relative_diff(a: &[Vec3], b: &[Vec3], mask: &[bool]) -> f64 {
    let (mut num, mut den) = (0.0f64, 0.0f64);
    for ((p, q), m) in a.iter().zip(b).zip(mask) {
        if *m {
            num += f64::from((*p - *q).abs().element_sum());
            den += f64::from(q.abs().element_sum());
        }
    }
    num / den.max(1e-12)
}

/// Relative difference allowed between the slab mirror's frame and the single-quad mirror's
/// over the mirror's front (the two bakes' radiosity noise: the slab's back and edges change
/// the light a little; splat rasterisation).
const SLAB_TOLERANCE: f64 = 0.04;

/// The slab mirror bakes radiance maps over its front's outline, as the quad does, and in both
/// modes its frame matches the quad mirror's over the front within [`SLAB_TOLERANCE`]; the
/// reflection is not vacuous (the mirror is black without it, and the yellow pillar shows in
/// it); geometry mode also matches the CPU evaluation of the same equation.
#[test]
fn slab_mirror_reflects_like_a_single_quad_mirror_in_both_modes() {
    let slab = load(bundle(true)).unwrap_or_else(|e| panic!("{e}"));
    let quad = load(bundle(false)).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(slab.scene.reflectors[0].triangles.len(), 2, "the front");
    // Radiance maps: as many, over the same element rectangles, as the quad's.
    let cams = |d: &ViewData| glint::radiance::index::load_cameras(&d.bundle, "Mirror").unwrap();
    let (cs, cq) = (cams(&slab), cams(&quad));
    assert!(!cs.maps.is_empty());
    assert_eq!(cs.plan, cq.plan);
    for (a, b) in cs.maps.iter().zip(&cq.maps) {
        assert!((a.view.corner - b.view.corner).length() < 1e-5);
        assert!((a.view.edge_u - b.view.edge_u).length() < 1e-5);
        assert!((a.view.centre - b.view.centre).length() < 1e-5);
    }
    const SIZE: (u32, u32) = (240, 160);
    let camera = Camera::look_at(
        Vec3::new(0.9, 2.2, 0.5),
        MIRROR,
        Vec3::Y,
        40f32.to_radians(),
    );
    let mask = common::reflector_mask(&slab, 0, &camera, SIZE.0, SIZE.1);
    let pixels = mask.iter().filter(|m| **m).count();
    assert!(pixels > 2000, "the mirror covers {pixels} pixels");
    let modes = [
        ReflectionMode::Off,
        ReflectionMode::Geometry,
        ReflectionMode::Image,
    ];
    let fs = common::hdr_frames(&slab, &camera, SIZE, &modes);
    let fq = common::hdr_frames(&quad, &camera, SIZE, &modes);
    let bright: f64 = fs[1]
        .iter()
        .zip(&mask)
        .filter(|(_, m)| **m)
        .map(|(p, _)| f64::from(p.element_sum()))
        .sum();
    let dark: f64 = fs[0]
        .iter()
        .zip(&mask)
        .filter(|(_, m)| **m)
        .map(|(p, _)| f64::from(p.element_sum()))
        .sum();
    assert!(dark < 1e-3 * bright, "off {dark} vs geometry {bright}");
    for (k, name) in [(1, "geometry"), (2, "image")] {
        let d = relative_diff(&fs[k], &fq[k], &mask);
        let yellow = fs[k]
            .iter()
            .zip(&mask)
            .filter(|(p, m)| **m && p.x > 2.0 * p.z && p.y > 1.5 * p.z)
            .count();
        eprintln!(
            "{name}: slab vs quad {d:.4} over {pixels} pixels; the pillar in {yellow} of them"
        );
        assert!(d <= SLAB_TOLERANCE, "{name}: {d:.4} > {SLAB_TOLERANCE}");
        assert!(
            yellow > pixels / 20,
            "{name}: the pillar shows in {yellow} pixels"
        );
    }
    let bvh = Bvh::build(&slab.scene.triangles);
    let cpu = reflections::cpu_reference(
        &slab.scene,
        &reflections::reflectors_with_reflectance(&slab),
        &bvh,
        &slab.map,
        &camera,
        SIZE.0,
        SIZE.1,
        1.0,
    );
    let d = relative_diff(&fs[1], &cpu, &mask);
    eprintln!("geometry vs CPU equation {d:.4}");
    assert!(d <= 0.02, "geometry vs CPU {d:.4}");
}

/// A mirror seen at 80° from its normal, image mode: every pixel inside its outline gets a
/// reflected value from the splats. A hole is a pixel where the reflection adds less than
/// 1% of what geometry mode adds there (M left at its clear colour); there must be none
/// (before the hole fill: 2566 of 5428), and the frame stays within 8% of geometry mode's
/// over the mirror (measured 4.0%).
#[test]
fn image_mode_leaves_no_hole_in_a_mirror_seen_at_80_degrees() {
    for slab in [false, true] {
        let data = load(bundle(slab)).unwrap_or_else(|e| panic!("{e}"));
        const SIZE: (u32, u32) = (400, 270);
        let dir = Vec3::new(80f32.to_radians().sin(), 0.0, 80f32.to_radians().cos());
        let camera = Camera::look_at(MIRROR + 1.6 * dir, MIRROR, Vec3::Y, 45f32.to_radians());
        let mask = common::reflector_mask(&data, 0, &camera, SIZE.0, SIZE.1);
        let pixels = mask.iter().filter(|m| **m).count();
        assert!(pixels > 1000, "the mirror covers {pixels} pixels");
        let f = common::hdr_frames(
            &data,
            &camera,
            SIZE,
            &[
                ReflectionMode::Off,
                ReflectionMode::Geometry,
                ReflectionMode::Image,
            ],
        );
        let holes: Vec<(usize, usize)> = (0..mask.len())
            .filter(|&i| mask[i])
            .filter(|&i| {
                let image = (f[2][i] - f[0][i]).max_element();
                let geometry = (f[1][i] - f[0][i]).max_element();
                image < 0.01 * geometry
            })
            .map(|i| (i % SIZE.0 as usize, i / SIZE.0 as usize))
            .collect();
        eprintln!(
            "{}: {} holes among {pixels} mirror pixels; first {:?}; image vs geometry {:.4}",
            if slab { "slab" } else { "quad" },
            holes.len(),
            &holes[..holes.len().min(8)],
            relative_diff(&f[2], &f[1], &mask)
        );
        if !holes.is_empty() {
            write_failure(
                &format!("slab-mirror-80-{}", if slab { "slab" } else { "quad" }),
                SIZE,
                &[("geometry", &f[1]), ("image", &f[2])],
                &holes,
            );
        }
        assert!(holes.is_empty(), "{} uncovered mirror pixels", holes.len());
        // The filled texels are estimates from their covered neighbours: the frame stays near
        // geometry mode's (without the fill, half the mirror is black: 0.50).
        let d = relative_diff(&f[2], &f[1], &mask);
        assert!(d <= 0.08, "image vs geometry {d:.4}");
    }
}

//! Reflected billboards in glint-view (Popescu et al. 2006 §3, §3.1, §3.2),
//! on the software Vulkan adapter.
//!
//! 1. `bb_trace` (`shaders/billboards.wgsl`) against [`BillboardTables::trace`] on a grid of
//!    rays: alpha-tested hits, misses to the environment map, reflective billboards and
//!    transition walls.
//! 2. A second-order reflection through a reflective billboard lands on the texel the
//!    geometry predicts (synthetic billboards, GPU).
//! 3. The §3.2 morph is continuous across a connected billboard's edge (and without walls the
//!    same sweep jumps).
//! 4. `--curved impostor --impostor-kind billboard` headless on a box with two mirror spheres,
//!    one of them also an impostor (a reflective billboard), and a white block: the block
//!    appears on sphere A where CPU ray casting of the real geometry predicts; and the same
//!    switches through `glint-view --headless` (the srdm kind without the stage is refused).

#![cfg(feature = "view")]

mod common;

use std::path::Path;

use common::*;
use glam::Vec3;
use glint::bake::{radiosity_stage, scene_stage};
use glint::camera::Camera;
use glint::geometry::Bvh;
use glint::materials::envmap::CubeMap;
use glint::progress::Silent;
use glint::scene::Scene;
use glint::scene::desc::RadiositySettings;
use glint::view::curved::{CurvedMode, CurvedSettings};
use glint::view::headless::Offscreen;
use glint::view::impostors::billboard_tables::{Billboard, BillboardTables};
use glint::view::impostors::{BillboardProbe, BillboardRay, ImpostorKind};
use glint::view::load::load;

fn bb(
    centre: Vec3,
    right: Vec3,
    up: Vec3,
    half: f32,
    w: u32,
    f: impl Fn(u32, u32) -> [f32; 4],
) -> Billboard {
    Billboard {
        impostor: 0,
        centre,
        right: right.normalize(),
        up: up.normalize(),
        half,
        half_up: half,
        resolution: w,
        colour: (0..w * w).map(|i| f(i % w, i / w)).collect(),
        reflective: None,
        wall: 0.0,
    }
}

/// A smooth environment: colour from direction.
fn env_map(size: usize) -> CubeMap {
    CubeMap::from_fn(size, |d| {
        Vec3::new(0.5 + 0.5 * d.x, 0.5 + 0.5 * d.y, 0.5 + 0.5 * d.z)
    })
}

/// Two groups: group 0 (a reflector's) with three diffuse billboards (alpha holes, one tilted)
/// and a reflective one whose tertiary rays search group 1; group 1 with a diffuse billboard
/// and a connected floor with transition walls. Both with environment maps.
fn tables() -> BillboardTables {
    let env = env_map(16);
    let checker = |x: u32, y: u32| {
        let a = if (x / 3 + y / 3).is_multiple_of(2) {
            1.0
        } else {
            0.0
        };
        [x as f32 / 16.0, y as f32 / 16.0, 0.3, a]
    };
    let a = bb(
        Vec3::new(0.0, 0.0, -3.0),
        Vec3::X,
        Vec3::Y,
        1.0,
        16,
        checker,
    );
    let b = bb(
        Vec3::new(0.8, 0.3, -5.0),
        Vec3::new(1.0, 0.0, 0.4),
        Vec3::Y,
        1.5,
        12,
        |x, y| {
            [
                0.9,
                x as f32 / 12.0,
                y as f32 / 12.0,
                if x + y > 4 { 1.0 } else { 0.2 },
            ]
        },
    );
    let c = bb(
        Vec3::new(-1.5, -0.5, -4.0),
        Vec3::new(0.7, 0.2, 0.3),
        Vec3::new(-0.1, 1.0, 0.2),
        0.8,
        8,
        |x, _| [0.2, 0.8, x as f32 / 8.0, 1.0],
    );
    let mut m = bb(
        Vec3::new(1.8, -1.2, -2.5),
        Vec3::new(0.0, 0.0, 1.0),
        Vec3::Y,
        0.7,
        16,
        |x, y| {
            [
                0.1,
                0.1,
                0.1,
                if (x as i32 - 8).pow(2) + (y as i32 - 8).pow(2) < 56 {
                    1.0
                } else {
                    0.0
                },
            ]
        },
    );
    // A convex mirror: normals tilting away from the centre.
    let normals = (0..16 * 16)
        .map(|i| {
            let (x, y) = ((i % 16) as f32 / 8.0 - 1.0, 1.0 - (i / 16) as f32 / 8.0);
            (Vec3::new(-1.0, 0.0, 0.0) + Vec3::new(0.0, 0.5 * y, 0.5 * x))
                .normalize()
                .extend(0.1 * (1.0 - x * x))
        })
        .collect();
    m.reflective = Some((normals, Vec3::splat(0.8), 1));
    let d = bb(
        Vec3::new(4.0, -1.0, -1.0),
        Vec3::new(0.0, 0.0, 1.0),
        Vec3::Y,
        1.2,
        10,
        |x, y| [x as f32 / 10.0, 0.5, y as f32 / 10.0, 1.0],
    );
    let mut floor = bb(
        Vec3::new(0.0, -2.0, -2.0),
        Vec3::X,
        -Vec3::Z,
        2.0,
        32,
        |x, y| [0.4 + 0.01 * x as f32, 0.4, 0.4 + 0.01 * y as f32, 1.0],
    );
    floor.wall = 0.5;
    BillboardTables::pack(&[
        (vec![a, b, c, m], Some((&env, Vec3::ZERO))),
        (vec![d, floor], Some((&env, Vec3::new(1.0, -1.0, -2.0)))),
    ])
}

/// Largest fraction of rays whose kind or billboard differs between WGSL and CPU: rays within
/// rounding of a texel, alpha or quad edge (FMA contraction, division rounding).
const MAX_MISMATCH: f64 = 0.01;
/// Largest colour difference where both agree (f32 rounding; nearest texels are exact).
const COLOUR_TOLERANCE: f32 = 1e-4;
/// Largest relative t difference where both agree.
const T_TOLERANCE: f32 = 1e-4;

#[test]
fn wgsl_billboard_trace_agrees_with_the_cpu() {
    let gpu = gpu();
    let t = tables();
    let probe = BillboardProbe::new(&gpu, &t).unwrap_or_else(|e| panic!("{e}"));
    let mut rays = Vec::new();
    for g in 0..2u32 {
        for origin in [
            Vec3::ZERO,
            Vec3::new(0.3, 0.2, 0.5),
            Vec3::new(1.0, -1.5, -1.0),
        ] {
            for iy in 0..48 {
                for ix in 0..48 {
                    let u = ix as f32 / 47.0 * 2.0 - 1.0;
                    let v = iy as f32 / 47.0 * 2.0 - 1.0;
                    let d = Vec3::new(1.3 * u, 1.3 * v, -1.0).normalize();
                    rays.push((g, origin, d));
                }
            }
        }
    }
    let gpu_rays: Vec<BillboardRay> = rays
        .iter()
        .map(|(g, o, d)| BillboardRay::new(*o, *d, 1e6, *g))
        .collect();
    let hits = probe
        .trace(&gpu, &gpu_rays)
        .unwrap_or_else(|e| panic!("{e}"));
    let (mut mismatch, mut kinds) = (0usize, [0usize; 5]);
    let (mut worst_c, mut worst_t) = (0.0f32, 0.0f32);
    for ((g, o, d), h) in rays.iter().zip(&hits) {
        let cpu = t.trace(*g as usize, *o, *d, 1e6);
        kinds[cpu.kind as usize] += 1;
        if cpu.kind != h.kind[0] || cpu.billboard != h.kind[1] {
            mismatch += 1;
            continue;
        }
        let c = Vec3::from_slice(&h.colour[..3]);
        worst_c = worst_c.max((c - cpu.colour).abs().max_element());
        if cpu.t > 0.0 {
            worst_t = worst_t.max((h.colour[3] - cpu.t).abs() / cpu.t);
        }
    }
    let frac = mismatch as f64 / rays.len() as f64;
    eprintln!(
        "{} rays, kinds (none, diffuse, reflective, env, wall) {kinds:?}, mismatch {frac:.4}, \
         worst colour {worst_c:.2e}, worst t {worst_t:.2e}",
        rays.len()
    );
    // Every path is exercised.
    assert!(kinds[1..].iter().all(|k| *k > 20), "{kinds:?}");
    assert!(frac <= MAX_MISMATCH, "{frac}");
    assert!(worst_c <= COLOUR_TOLERANCE, "{worst_c}");
    assert!(worst_t <= T_TOLERANCE, "{worst_t}");
}

#[test]
fn second_order_reflection_lands_where_geometry_predicts() {
    // Two reflective objects' billboards: a flat mirror A facing +z at z = −2 (normals +z) and
    // a tilted mirror C; a diffuse target B with a texel-position colour. A ray from the
    // origin reflects off A and must hit B at the analytic point.
    let w = 32u32;
    let mut a = bb(
        Vec3::new(0.0, 0.0, -2.0),
        Vec3::X,
        Vec3::Y,
        1.0,
        w,
        |_, _| [0.0, 0.0, 0.0, 1.0],
    );
    a.reflective = Some((
        vec![Vec3::Z.extend(0.0); (w * w) as usize],
        Vec3::splat(0.5),
        1,
    ));
    let mut c = bb(
        Vec3::new(-3.0, 0.0, -2.0),
        Vec3::X,
        Vec3::Y,
        1.0,
        w,
        |_, _| [0.0, 0.0, 0.0, 1.0],
    );
    c.reflective = Some((
        vec![Vec3::new(0.3, 0.0, 1.0).normalize().extend(0.0); (w * w) as usize],
        Vec3::splat(0.5),
        1,
    ));
    let target = |x: u32, y: u32| [x as f32 / 64.0, y as f32 / 64.0, 1.0, 1.0];
    let b = bb(
        Vec3::new(1.05, 0.0, -0.5),
        Vec3::X,
        Vec3::Y,
        0.4,
        64,
        target,
    );
    let t = BillboardTables::pack(&[(vec![a, c], None), (vec![b], None)]);
    let gpu = gpu();
    let probe = BillboardProbe::new(&gpu, &t).unwrap();
    let mut rays = Vec::new();
    let mut expected = Vec::new();
    for k in 0..40 {
        let sx = 0.15 + 0.3 * k as f32 / 39.0;
        let sy = -0.2 + 0.4 * ((k * 7) % 40) as f32 / 39.0;
        let d = Vec3::new(sx, sy, -1.0).normalize();
        // Analytic: hit A at z = −2, mirror z, then reach B's plane z = −0.5.
        let p = d * (2.0 / -d.z);
        let d2 = Vec3::new(d.x, d.y, -d.z);
        let q = p + d2 * (1.5 / d2.z);
        let local = q - Vec3::new(1.05, 0.0, -0.5);
        let (u, v) = (local.x / 0.4, local.y / 0.4);
        let want = if u.abs() < 1.0 && v.abs() < 1.0 {
            let tx = ((u * 0.5 + 0.5) * 64.0).floor() as u32;
            let ty = ((0.5 - v * 0.5) * 64.0).floor() as u32;
            Some(Vec3::from_slice(&target(tx, ty)[..3]) * 0.5)
        } else {
            None
        };
        rays.push(BillboardRay::new(Vec3::ZERO, d, 1e6, 0));
        expected.push(want);
    }
    let hits = probe.trace(&gpu, &rays).unwrap();
    let mut seen = 0;
    for (h, want) in hits.iter().zip(&expected) {
        let c = Vec3::from_slice(&h.colour[..3]);
        match want {
            Some(w) => {
                seen += 1;
                assert_eq!(h.kind[0], 2, "reflective billboard hit");
                assert!(
                    (c - *w).abs().max_element() < 1.0 / 64.0 * 0.5 + 1e-4,
                    "{c} vs {w}"
                );
            }
            None => assert!(c.max_element() < 1e-6, "nothing beyond the target: {c}"),
        }
    }
    assert!(seen >= 10, "{seen} rays reach the target");
}

#[test]
fn the_billboard_to_environment_morph_is_continuous() {
    // A floor billboard connected to the environment (§3.2), its colour stored in the EM as
    // the paper does ("the color texture of the billboard is stored in the environment map"):
    // each texel holds EM along E → texel centre. A sweep of rays from above the floor crosses
    // quad → transition wall → clear of the walls.
    let env = CubeMap::from_fn(64, |d| {
        Vec3::new(0.5 + 0.5 * d.x, 0.5 + 0.5 * d.y, 0.5 + 0.5 * d.z)
    });
    let e = Vec3::new(0.0, -0.5, 0.0);
    let w = 64u32;
    let centre = Vec3::new(0.0, -1.0, 0.0);
    let envt = BillboardTables::pack(&[(vec![], Some((&env, e)))]);
    let floor = |wall: f32| {
        let mut f = bb(centre, Vec3::X, -Vec3::Z, 1.0, w, |x, y| {
            let u = (x as f32 + 0.5) / w as f32 * 2.0 - 1.0;
            let v = 1.0 - (y as f32 + 0.5) / w as f32 * 2.0;
            let p = centre + Vec3::X * u - Vec3::Z * v;
            envt.env(0, (p - e).normalize())
                .unwrap()
                .extend(1.0)
                .to_array()
        });
        f.wall = wall;
        f
    };
    // From a reflector point R away from the map's centre E (at E itself r₁ᵈ = r_a and
    // nothing would need morphing).
    let o = Vec3::new(0.5, -0.2, 0.4);
    let sweep = |t: &BillboardTables| -> Vec<(u32, Vec3)> {
        (0..2000)
            .map(|k| {
                let a = -1.2 + 1.4 * k as f32 / 1999.0;
                let d = Vec3::new(0.3, a.sin(), -a.cos()).normalize();
                let s = t.trace(0, o, d, 1e6);
                (s.kind, s.colour)
            })
            .collect()
    };
    let morph = BillboardTables::pack(&[(vec![floor(0.6)], Some((&env, e)))]);
    let plain = BillboardTables::pack(&[(vec![floor(0.0)], Some((&env, e)))]);
    let jumps = |s: &[(u32, Vec3)]| {
        s.windows(2)
            .map(|p| (p[1].1 - p[0].1).abs().max_element())
            .fold(0.0f32, f32::max)
    };
    let (m, p) = (sweep(&morph), sweep(&plain));
    let kinds: std::collections::BTreeSet<u32> = m.iter().map(|s| s.0).collect();
    eprintln!(
        "morph sweep kinds {kinds:?}: largest step {:.4} (no walls: {:.4})",
        jumps(&m),
        jumps(&p)
    );
    assert!(
        kinds.contains(&1) && kinds.contains(&4) && kinds.contains(&3),
        "{kinds:?}"
    );
    // Continuous: no step larger than a few env/billboard texels' change.
    assert!(jumps(&m) < MORPH_STEP, "{}", jumps(&m));
    assert!(jumps(&p) > 2.0 * jumps(&m), "without walls the edge jumps");

    // The shader agrees along the same sweep.
    let gpu = gpu();
    let probe = BillboardProbe::new(&gpu, &morph).unwrap();
    let rays: Vec<BillboardRay> = (0..2000)
        .map(|k| {
            let a = -1.2 + 1.4 * k as f32 / 1999.0;
            let d = Vec3::new(0.3, a.sin(), -a.cos()).normalize();
            BillboardRay::new(o, d, 1e6, 0)
        })
        .collect();
    let hits = probe.trace(&gpu, &rays).unwrap();
    let g: Vec<(u32, Vec3)> = hits
        .iter()
        .map(|h| (h.kind[0], Vec3::from_slice(&h.colour[..3])))
        .collect();
    eprintln!("GPU sweep largest step {:.4}", jumps(&g));
    assert!(jumps(&g) < MORPH_STEP, "{}", jumps(&g));
}

/// Largest colour step between neighbouring rays of the morph sweep (0.0007 rad apart): a few
/// texels of the 64² maps (a texel spans ~1/32 of the map's colour range 1, 0.016 per
/// channel, ×2 for the nearest-texel rounding on both sides of the edge).
const MORPH_STEP: f32 = 0.05;

// ─────────────────────────── headless: --curved impostor ───────────────────────────

const WALLS: [[f32; 3]; 6] = [
    [0.3, 0.05, 0.05],
    [0.05, 0.3, 0.05],
    [0.05, 0.05, 0.3],
    [0.3, 0.3, 0.05],
    [0.3, 0.05, 0.3],
    [0.05, 0.3, 0.3],
];
const RADIUS: f32 = 0.25;
const SPHERE_X: f32 = 0.45;
const BLOCK: Vec3 = Vec3::new(0.1, 0.0, 0.7);
const BLOCK_HALF: f32 = 0.2;

fn cube(name: &'static str, material: usize, c: Vec3, h: f32) -> MeshSpec {
    let positions: Vec<[f32; 3]> = (0..8)
        .map(|k| {
            let s = |b: u32| if k & b == 0 { -h } else { h };
            (c + Vec3::new(s(1), s(2), s(4))).to_array()
        })
        .collect();
    // Two triangles per face, wound counter-clockwise seen from outside.
    let faces = [
        [0, 2, 6, 4],
        [1, 5, 7, 3],
        [0, 4, 5, 1],
        [2, 3, 7, 6],
        [0, 1, 3, 2],
        [4, 6, 7, 5],
    ];
    let mut indices = Vec::new();
    for f in faces {
        for t in [[f[0], f[1], f[2]], [f[0], f[2], f[3]]] {
            let p = t.map(|i: u32| Vec3::from(positions[i as usize]));
            let n = (p[1] - p[0]).cross(p[2] - p[0]);
            if n.dot((p[0] + p[1] + p[2]) / 3.0 - c) >= 0.0 {
                indices.extend(t);
            } else {
                indices.extend([t[0], t[2], t[1]]);
            }
        }
    }
    MeshSpec {
        normals: Vec::new(),
        name,
        material,
        positions,
        indices,
    }
}

fn box_scene(root: &Path) -> (Scene, std::path::PathBuf) {
    let wall = |i: usize| MaterialSpec {
        name: ["Xp", "Xn", "Yp", "Yn", "Zp", "Zn"][i],
        base: [0.0, 0.0, 0.0, 1.0],
        metallic: 0.0,
        roughness: 1.0,
        emissive: WALLS[i],
        strength: 1.0,
    };
    let mut materials: Vec<MaterialSpec> = (0..6).map(wall).collect();
    materials.push(MaterialSpec {
        name: "Chrome",
        base: [0.9, 0.9, 0.9, 1.0],
        metallic: 1.0,
        roughness: 0.05,
        emissive: [0.0; 3],
        strength: 1.0,
    });
    // The block: white, lit by the glowing walls.
    materials.push(MaterialSpec::diffuse("White", 0.9));
    let meshes = vec![
        flip(quad("WallXp", 0, 0, 1.0, 1.0)),
        quad("WallXn", 1, 0, -1.0, 1.0),
        flip(quad("WallYp", 2, 1, 1.0, 1.0)),
        quad("WallYn", 3, 1, -1.0, 1.0),
        flip(quad("WallZp", 4, 2, 1.0, 1.0)),
        quad("WallZn", 5, 2, -1.0, 1.0),
        common::uv_sphere("SphereA", 6, [-SPHERE_X, 0.0, 0.0], RADIUS, true),
        common::uv_sphere("SphereB", 6, [SPHERE_X, 0.0, 0.0], RADIUS, true),
        cube("Block", 7, BLOCK, BLOCK_HALF),
    ];
    write_gltf(root, "box", &meshes, &materials);
    let scene_path = write_scene(
        root,
        r#"{ "version": 1, "geometry": "box.gltf",
            "reflectors": [ { "mesh": "SphereA", "kind": "curved" }, { "mesh": "SphereB", "kind": "curved" } ],
            "impostors": [ { "mesh": "SphereB" }, { "mesh": "Block" } ],
            "camera_paths": [ { "name": "look", "fps": 30, "keyframes": [
                { "time": 0.0, "position": [-0.3, 0.02, 0.9], "target": [-0.27, 0.0, 0.12], "fov_y_deg": 12.0 },
                { "time": 0.1, "position": [-0.25, 0.02, 0.9], "target": [-0.27, 0.0, 0.12], "fov_y_deg": 12.0 } ] } ] }"#,
    );
    let scene = Scene::load(&scene_path).unwrap_or_else(|e| panic!("{e}"));
    let bundle = root.join("box.glint");
    scene_stage::bake(&scene, &bundle, false).unwrap_or_else(|e| panic!("{e}"));
    let settings = RadiositySettings {
        texel_density: 8.0,
        rays: 32,
        light_samples: 4,
        bounces: 2,
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
    };
    radiosity_stage::bake(&scene, &bundle, &settings, false, &Silent)
        .unwrap_or_else(|e| panic!("{e}"));
    (scene, bundle)
}

const SIZE: (u32, u32) = (240, 180);

/// Smallest intersection-over-union of the pixels the pass brightens on sphere A with those
/// where ray casting the real geometry reaches the block (first order, or second order via
/// sphere B): billboards are flat cut-outs, so the reflection of the block (first order) and
/// of sphere B (a flat card with the sphere's normals) shift by up to their depth. Measured
/// 0.826 (0.684 when the pass reflected about face normals).
const MIN_IOU: f64 = 0.7;

#[test]
fn curved_impostor_switch_reflects_billboards_headless() {
    let dir = tempfile::tempdir().unwrap();
    let (scene, bundle) = box_scene(dir.path());
    let data = load(&bundle).unwrap_or_else(|e| panic!("{e}"));
    let gpu = gpu();
    let camera = Camera::look_at(
        Vec3::new(-0.3, 0.02, 0.9),
        Vec3::new(-0.27, 0.0, 0.12),
        Vec3::Y,
        12f32.to_radians(),
    );
    let frame = |mode: CurvedMode, kind: ImpostorKind| {
        let mut off = Offscreen::new(&gpu, &data, SIZE.0, SIZE.1).unwrap();
        off.options.impostor_kind = kind;
        off.set_curved(&gpu, &data, mode, CurvedSettings::default())
            .unwrap_or_else(|e| panic!("{e}"));
        if mode == CurvedMode::Impostor {
            let pass = off.curved_impostors().expect("the impostor pass");
            assert_eq!(pass.kind(), kind);
            if kind == ImpostorKind::Billboard {
                // Sphere A: SphereB's and Block's; sphere B: Block's.
                assert_eq!(pass.billboard_count(), 3);
            }
        }
        off.render(&gpu, &camera).unwrap();
        off.read_hdr(&gpu).unwrap()
    };
    let off = frame(CurvedMode::Off, ImpostorKind::Billboard);
    let on = frame(CurvedMode::Impostor, ImpostorKind::Billboard);
    // The SRDM kind needs the srdm stage: the switch reports it rather than drawing nothing.
    let mut o = Offscreen::new(&gpu, &data, SIZE.0, SIZE.1).unwrap();
    o.options.impostor_kind = ImpostorKind::Srdm;
    assert!(
        o.set_curved(&gpu, &data, CurvedMode::Impostor, CurvedSettings::default())
            .is_err()
    );

    // Prediction by ray casting the real triangles.
    let bvh = Bvh::build(&scene.triangles);
    let of = |name: &str| -> std::collections::HashSet<u32> {
        let o = scene
            .objects
            .iter()
            .position(|o| o.mesh_name == name)
            .unwrap();
        scene.objects[o].triangles.clone().collect()
    };
    let (sa, sb, block) = (of("SphereA"), of("SphereB"), of("Block"));
    let (w, h) = SIZE;
    let aspect = w as f32 / h as f32;
    let mut first = vec![false; (w * h) as usize];
    let mut second = vec![false; (w * h) as usize];
    // The sphere-A rays of the second-order pixels, with the sphere's smooth normal.
    let mut second_rays = Vec::new();
    for i in 0..w * h {
        let d = camera.ray_direction(Camera::pixel_ndc(i % w, i / w, w, h), aspect);
        let Some(hit) = bvh.closest_hit(camera.position, d, f32::INFINITY) else {
            continue;
        };
        if !sa.contains(&hit.triangle) {
            continue;
        }
        let p = camera.position + d * hit.t;
        let n = (p - Vec3::new(-SPHERE_X, 0.0, 0.0)).normalize();
        let r = d - 2.0 * d.dot(n) * n;
        let Some(h2) = bvh.closest_hit(p + r * 1e-4, r, f32::INFINITY) else {
            continue;
        };
        if block.contains(&h2.triangle) {
            first[i as usize] = true;
        } else if sb.contains(&h2.triangle) {
            let q = p + r * h2.t;
            let n2 = (q - Vec3::new(SPHERE_X, 0.0, 0.0)).normalize();
            let r2 = r - 2.0 * r.dot(n2) * n2;
            if bvh
                .closest_hit(q + r2 * 1e-4, r2, f32::INFINITY)
                .is_some_and(|h3| block.contains(&h3.triangle))
            {
                second[i as usize] = true;
                second_rays.push(BillboardRay::new(p, r, 1e6, 0));
            }
        }
    }
    let seen: Vec<bool> = on
        .iter()
        .zip(&off)
        .map(|(a, b)| glint::eval::luminance(*a) - glint::eval::luminance(*b) > BRIGHTER)
        .collect();
    let iou = |pred: &[bool]| {
        let i = pred.iter().zip(&seen).filter(|(a, b)| **a && **b).count();
        let u = pred.iter().zip(&seen).filter(|(a, b)| **a || **b).count();
        (i as f64 / u.max(1) as f64, i)
    };
    let both: Vec<bool> = first.iter().zip(&second).map(|(a, b)| *a || *b).collect();
    let n1 = first.iter().filter(|v| **v).count();
    let n2 = second.iter().filter(|v| **v).count();
    let (iou_all, _) = iou(&both);
    let (_, hit2) = iou(&second);
    eprintln!(
        "predicted {n1} first-order and {n2} second-order px, {} brightened, IoU {iou_all:.3}, \
         second order recalled {hit2}/{n2}",
        seen.iter().filter(|v| **v).count()
    );
    assert!(n1 > 20 && n2 > 5, "the view shows both orders ({n1}, {n2})");
    assert!(iou_all >= MIN_IOU, "IoU {iou_all:.3}");
    // The same switches on the command line, headless.
    let out = dir.path().join("frames");
    let run = |args: &[&str]| {
        let o = std::process::Command::new(env!("CARGO_BIN_EXE_glint-view"))
            .arg(&bundle)
            .args([
                "--headless",
                "--replay",
                "--reflections",
                "off",
                "--size",
                "64x48",
                "--out",
            ])
            .arg(&out)
            .args(args)
            .env("XDG_RUNTIME_DIR", std::env::temp_dir())
            .output()
            .unwrap();
        (
            o.status.success(),
            String::from_utf8_lossy(&o.stderr).into_owned(),
        )
    };
    let (ok, err) = run(&["--curved", "impostor", "--impostor-kind", "billboard"]);
    assert!(ok, "{err}");
    assert!(out.join("frame_00000.png").is_file());
    let (ok, err) = run(&["--curved", "impostor", "--impostor-kind", "srdm"]);
    assert!(!ok && err.contains("srdm"), "{err}");
    let (ok, err) = run(&["--curved", "billboard"]);
    assert!(!ok && err.contains("cubemap, impostor, off"), "{err}");
    let (ok, err) = run(&[
        "--impostors",
        "on",
        "--impostor-kind",
        "billboard",
        "--curved",
        "off",
    ]);
    assert!(ok, "{err}");

    // Second order (§3.1, through sphere B's reflective billboard, whose tertiary rays search
    // the billboards made for sphere B), two ways: the rendered pass (its pixels brightened,
    // counted above as `hit2`) and, for the algorithm alone, the same pixels' reflected rays
    // with the sphere's exact normal through `bb_trace` on the GPU. The pass reflects about the
    // interpolated vertex normal: with face normals (dpdx × dpdy) the 24 × 48 sphere's facets
    // turned the tertiary rays by up to ~15° and the pass drew none of these pixels (0/231).
    let rendered = hit2 as f64 / n2.max(1) as f64;
    assert!(
        rendered >= MIN_SECOND_ORDER_RECALL,
        "rendered second order {hit2}/{n2}"
    );
    let tables = glint::view::impostors::build_billboards(
        &data,
        &glint::view::impostors::srdm_tables::impostor_reflectors(&data.scene, &[]),
        0,
    )
    .unwrap();
    let probe = BillboardProbe::new(&gpu, &tables).unwrap();
    let got = probe.trace(&gpu, &second_rays).unwrap();
    let recalled = got
        .iter()
        .filter(|h| {
            h.kind[0] == 2 && glint::eval::luminance(Vec3::from_slice(&h.colour[..3])) > BRIGHTER
        })
        .count();
    let recall = recalled as f64 / second_rays.len().max(1) as f64;
    eprintln!(
        "second order through bb_trace: {recalled}/{} ({recall:.3})",
        second_rays.len()
    );
    assert!(recall >= MIN_SECOND_ORDER_RECALL, "{recall}");
}

/// Smallest fraction of the predicted second-order pixels brightened with the block seen in
/// sphere B, in the rendered frame (measured 204/231 = 0.883) and through `bb_trace` with the
/// exact normal (0.883), the billboard plane at the captured surface's mean depth: the rest
/// fall near the block's silhouette, which the flat cut-out shifts by its remaining parallax.
const MIN_SECOND_ORDER_RECALL: f64 = 0.75;

/// Luminance increase counted as a reflection of the block (its D × ks 0.9; the walls glow
/// 0.05–0.3 and light it).
const BRIGHTER: f32 = 0.02;

// ───────────────── a surface billboard connected to the environment (§3, §3.2) ─────────────────

const TABLE_Y: f32 = -0.3;
const TABLE_HALF: [f32; 2] = [0.6, 0.35];
const TABLE_WALL: f32 = 0.15;

/// A mirror ball resting on a flat table top (an impostor with a connected surface billboard)
/// in the glowing box.
fn table_scene(root: &Path) -> Scene {
    let wall = |i: usize| MaterialSpec {
        name: ["Xp", "Xn", "Yp", "Yn", "Zp", "Zn"][i],
        base: [0.0, 0.0, 0.0, 1.0],
        metallic: 0.0,
        roughness: 1.0,
        emissive: WALLS[i],
        strength: 1.0,
    };
    let mut materials: Vec<MaterialSpec> = (0..6).map(wall).collect();
    materials.push(MaterialSpec {
        name: "Chrome",
        base: [0.9, 0.9, 0.9, 1.0],
        metallic: 1.0,
        roughness: 0.05,
        emissive: [0.0; 3],
        strength: 1.0,
    });
    materials.push(MaterialSpec::diffuse("Wood", 0.5));
    let [a, b] = TABLE_HALF;
    let table = MeshSpec {
        normals: Vec::new(),
        name: "Table",
        material: 7,
        positions: vec![
            [-a, TABLE_Y, -b],
            [-a, TABLE_Y, b],
            [a, TABLE_Y, b],
            [a, TABLE_Y, -b],
        ],
        indices: vec![0, 1, 2, 0, 2, 3],
    };
    let meshes = vec![
        flip(quad("WallXp", 0, 0, 1.0, 1.0)),
        quad("WallXn", 1, 0, -1.0, 1.0),
        flip(quad("WallYp", 2, 1, 1.0, 1.0)),
        quad("WallYn", 3, 1, -1.0, 1.0),
        flip(quad("WallZp", 4, 2, 1.0, 1.0)),
        quad("WallZn", 5, 2, -1.0, 1.0),
        common::uv_sphere("Ball", 6, [0.0, TABLE_Y + RADIUS, 0.0], RADIUS, true),
        table,
    ];
    write_gltf(root, "table", &meshes, &materials);
    let scene_path = write_scene(
        root,
        &format!(
            r#"{{ "version": 1, "geometry": "table.gltf",
            "reflectors": [ {{ "mesh": "Ball", "kind": "curved" }} ],
            "impostors": [ {{ "mesh": "Table", "billboard": {{ "placement": "surface", "wall_height": {TABLE_WALL} }} }} ] }}"#
        ),
    );
    Scene::load(&scene_path).unwrap_or_else(|e| panic!("{e}"))
}

/// Smallest fraction of the sweep rays that reach the real table top and hit its billboard at
/// the same distance (within [`TABLE_T_TOLERANCE`]): texels on the surface itself, so only
/// the outline's texel rounding differs.
const MIN_TABLE_AGREEMENT: f64 = 0.98;
/// Largest distance between the billboard hit and the real hit, metres (surface placement
/// puts the quad in the table's plane: f32 rounding only).
const TABLE_T_TOLERANCE: f32 = 1e-3;
/// Largest mean error (sweep steps of 0.1°) of where the table's reflection first ends along
/// a sweep with the walls, against ray casting: the billboard's edge is the table's, and the
/// morph continues it with what the environment map shows just beyond the table's edge (seen
/// from E), so the reflection does not stretch there. Measured 16.8 steps (1.7°: sweeps that
/// leave over a wall's low end still see the table's edge in the map along r_m); without walls
/// the map along the ray's own direction shows the table again past its edge (parallax: E is
/// not the ray's origin), measured 164 steps.
const MAX_EDGE_ERROR_STEPS: f64 = 30.0;

#[test]
fn surface_billboard_of_a_table_top_matches_the_geometry_and_morphs_continuously() {
    use glint::bake::srdm_stage::ColourSource;
    use glint::view::impostors::billboard_tables;
    use glint::view::impostors::srdm_tables::impostor_reflectors;

    let dir = tempfile::tempdir().unwrap();
    let scene = table_scene(dir.path());
    let spec = scene.impostors[0].billboard;
    assert_eq!(spec.wall, TABLE_WALL);
    let plane = spec
        .surface
        .expect("surface placement resolved to the table's plane");
    assert!(plane.normal.abs().y > 0.999, "{plane:?}");

    let reflectors = impostor_reflectors(&scene, &[]);
    assert_eq!(reflectors.len(), 1, "the ball");
    let ball: std::collections::HashSet<u32> = reflectors[0].triangles.iter().copied().collect();
    let of = |name: &str| -> std::collections::HashSet<u32> {
        let o = scene
            .objects
            .iter()
            .position(|o| o.mesh_name == name)
            .unwrap();
        scene.objects[o].triangles.clone().collect()
    };
    let table = of("Table");
    // The real scene without the ball, as the ball's reflected rays see it.
    let others: Vec<u32> = (0..scene.triangles.len() as u32)
        .filter(|t| !ball.contains(t))
        .collect();
    let tris: Vec<_> = others
        .iter()
        .map(|&t| scene.triangles[t as usize])
        .collect();
    let bvh = Bvh::build(&tris);
    let is_table = |h: &glint::geometry::Hit| table.contains(&others[h.triangle as usize]);
    // The ball's environment map from its centre E: red where it sees the table.
    let e = Vec3::new(0.0, TABLE_Y + RADIUS, 0.0);
    let env = CubeMap::from_fn(128, |d| match bvh.closest_hit(e, d, f32::INFINITY) {
        Some(h) if is_table(&h) => Vec3::new(1.0, 0.0, 0.0),
        Some(_) => Vec3::new(0.0, 0.0, 1.0),
        None => Vec3::ZERO,
    });
    let mut t = billboard_tables::build(
        &scene,
        &reflectors,
        128,
        &ColourSource::Albedo,
        &[Some((env, e))],
    );
    assert_eq!(t.billboards.len(), 1);
    let b = t.billboards[0];
    // In the table's plane, facing the ball, the table's outline as its rectangle.
    assert!((b.centre[1] - TABLE_Y).abs() < 1e-4, "{b:?}");
    let n = Vec3::from_slice(&b.right[..3]).cross(Vec3::from_slice(&b.up[..3]));
    assert!(n.y > 0.999, "faces the ball: {n}");
    let mut halves = [b.centre[3], b.up[3]];
    halves.sort_by(f32::total_cmp);
    assert!(
        (halves[0] - TABLE_HALF[1]).abs() < 1e-3 && (halves[1] - TABLE_HALF[0]).abs() < 1e-3,
        "{halves:?}"
    );
    assert_eq!(b.right[3], TABLE_WALL, "connected: walls of height H");
    // Red billboard texels, as the map shows the table.
    for c in &mut t.texels {
        if c[3] >= billboard_tables::ALPHA_CUTOFF {
            *c = [1.0, 0.0, 0.0, 1.0];
        }
    }
    let mut plain = t.clone();
    plain.billboards[0].right[3] = 0.0;

    // Sweeps of rays from points on the ball, in vertical planes around it, from steep (the
    // table) to shallow (past its edge).
    let steps = 900;
    let (mut on_table, mut agree, mut false_hits, mut total) = (0usize, 0usize, 0usize, 0usize);
    let (mut err_walls, mut err_plain, mut sweeps) = (0.0f64, 0.0f64, 0usize);
    let mut kinds = std::collections::BTreeSet::new();
    let mut gpu_rays = Vec::new();
    for az in 0..24 {
        let phi = std::f32::consts::TAU * (az as f32 + 0.25) / 24.0;
        let h = Vec3::new(phi.cos(), 0.0, phi.sin());
        for alpha in [-30f32, 0.0, 30.0] {
            let nn = h * alpha.to_radians().cos() + Vec3::Y * alpha.to_radians().sin();
            let o = e + nn * (RADIUS + 1e-3);
            // First index past the first run of table (red) of each.
            let (mut end_true, mut end_walls, mut end_plain) =
                (Run::default(), Run::default(), Run::default());
            for k in 0..steps {
                let beta = (-80.0 + 0.1 * k as f32).to_radians();
                let d = h * beta.cos() + Vec3::Y * beta.sin();
                total += 1;
                let real = bvh.closest_hit(o, d, f32::INFINITY);
                let cpu = t.trace(0, o, d, 1e6);
                kinds.insert(cpu.kind);
                if let Some(r) = real.filter(is_table) {
                    on_table += 1;
                    if cpu.kind == 1 && (cpu.t - r.t).abs() < TABLE_T_TOLERANCE {
                        agree += 1;
                    }
                } else if cpu.kind == 1 {
                    false_hits += 1;
                }
                end_true.see(k, real.is_some_and(|r| is_table(&r)));
                end_walls.see(k, cpu.colour.x > 0.5);
                end_plain.see(k, plain.trace(0, o, d, 1e6).colour.x > 0.5);
                if k % 9 == 0 {
                    gpu_rays.push(BillboardRay::new(o, d, 1e6, 0));
                }
            }
            // Where the table's reflection ends, against where it really ends.
            if let (Some(a), Some(w), Some(p)) = (end_true.end, end_walls.end, end_plain.end) {
                err_walls += (w as f64 - a as f64).abs();
                err_plain += (p as f64 - a as f64).abs();
                sweeps += 1;
            }
        }
    }
    let frac = agree as f64 / on_table.max(1) as f64;
    let (err_walls, err_plain) = (err_walls / sweeps as f64, err_plain / sweeps as f64);
    eprintln!(
        "{total} rays: {on_table} reach the table, {frac:.4} hit its billboard at the same t, \
         {false_hits} billboard hits off it; kinds {kinds:?}; {sweeps} sweeps: the table's \
         reflection ends {err_walls:.2} steps from the truth with walls, {err_plain:.2} without"
    );
    assert!(on_table > 1000, "{on_table}");
    assert!(frac >= MIN_TABLE_AGREEMENT, "{frac}");
    assert!(
        (false_hits as f64) < (1.0 - MIN_TABLE_AGREEMENT) * on_table as f64,
        "{false_hits}"
    );
    assert!(
        kinds.contains(&1) && kinds.contains(&4) && kinds.contains(&3),
        "{kinds:?}"
    );
    assert!(sweeps > 24, "{sweeps}");
    assert!(err_walls <= MAX_EDGE_ERROR_STEPS, "{err_walls}");
    assert!(
        err_plain > 4.0 * err_walls,
        "without walls: {err_plain} vs {err_walls}"
    );

    // The shader agrees on the rectangle and its walls.
    let gpu = gpu();
    let probe = BillboardProbe::new(&gpu, &t).unwrap();
    let hits = probe.trace(&gpu, &gpu_rays).unwrap();
    let mismatch = gpu_rays
        .iter()
        .zip(&hits)
        .filter(|(r, h)| {
            let o = Vec3::from_slice(&r.origin[..3]);
            let d = Vec3::from_slice(&r.dir[..3]);
            let c = t.trace(0, o, d, 1e6);
            c.kind != h.kind[0]
                || (c.colour - Vec3::from_slice(&h.colour[..3]))
                    .abs()
                    .max_element()
                    > COLOUR_TOLERANCE
        })
        .count();
    let mfrac = mismatch as f64 / gpu_rays.len() as f64;
    eprintln!("GPU vs CPU on {} rays: {mfrac:.4} differ", gpu_rays.len());
    assert!(mfrac <= MAX_MISMATCH, "{mfrac}");
}

/// The end of the first run of `true` along a sweep.
#[derive(Default)]
struct Run {
    started: bool,
    end: Option<usize>,
}

impl Run {
    fn see(&mut self, k: usize, on: bool) {
        if on {
            self.started = true;
        } else if self.started && self.end.is_none() {
            self.end = Some(k);
        }
    }
}

#[test]
fn viewer_billboards_take_their_colour_from_d() {
    use glint::bake::srdm_stage;
    use glint::view::impostors::build_billboards;
    use glint::view::impostors::srdm_tables::impostor_reflectors;

    let dir = tempfile::tempdir().unwrap();
    let (scene, bundle) = box_scene(dir.path());
    let data = load(&bundle).unwrap_or_else(|e| panic!("{e}"));
    // The viewer's scene is the bundle's copy (re-serialized); it carries the identity the
    // stages recorded, so the stages' freshness checks accept it.
    assert_eq!(data.scene.content_hash, scene.content_hash);
    let colour = srdm_stage::colour_source(data.bundle.dir(), &data.scene).unwrap();
    assert_eq!(colour.name(), "radiosity");
    // The block's billboard in sphere A's group: D (lit by walls glowing 0.05–0.3), not the
    // white albedo 0.9.
    let reflectors = impostor_reflectors(&data.scene, &[]);
    let tables = build_billboards(&data, &reflectors, 32).unwrap();
    let block = data
        .scene
        .impostors
        .iter()
        .position(|i| i.name == "Block")
        .unwrap();
    let bb = tables
        .billboards
        .iter()
        .zip(0..)
        .find(|(b, i)| {
            // Group 0 (sphere A) holds SphereB's billboard first, then Block's.
            *i < tables.groups[0].range[1]
                && b.info[2] == glint::view::impostors::billboard_tables::NONE
        })
        .map(|(b, _)| *b)
        .expect("the block's billboard");
    let w = bb.info[0] as usize;
    let texels = &tables.texels[bb.info[1] as usize..bb.info[1] as usize + w * w];
    let opaque: Vec<Vec3> = texels
        .iter()
        .filter(|c| c[3] >= 0.5)
        .map(|c| Vec3::from_slice(&c[..3]))
        .collect();
    assert!(opaque.len() > w * w / 10, "{}", opaque.len());
    let mean = opaque.iter().copied().sum::<Vec3>() / opaque.len() as f32;
    let albedo = data.scene.materials[data.scene.triangles[data.scene.objects
        [data.scene.impostors[block].objects[0] as usize]
        .triangles
        .start as usize]
        .material as usize]
        .albedo;
    // D as the map holds it at the texels' hits.
    eprintln!("block billboard mean {mean}, albedo {albedo}");
    assert!(
        (mean - albedo).abs().max_element() > 0.3,
        "billboard colour {mean} is the albedo {albedo}"
    );
    assert!(
        mean.max_element() < 0.6 && mean.min_element() > 0.0,
        "D of a white block lit by walls glowing ≤ 0.3: {mean}"
    );
}

/// Every `repr(C)` struct the billboard passes upload has its WGSL twin's layout (naga's
/// layouter: size and each member's offset), in the modules the passes build.
#[test]
fn billboard_structs_match_the_shader_layout() {
    use glint::assert_wgsl_layout;
    use glint::view::impostors::billboard_tables::{GpuBillboard, GpuGroup};
    use glint::view::impostors::{
        BILLBOARD_PROBE_SHADER_SOURCE, BILLBOARD_SHADER_SOURCE, BillboardProbeHit,
    };
    let probe = format!("{BILLBOARD_SHADER_SOURCE}\n{BILLBOARD_PROBE_SHADER_SOURCE}");
    assert_wgsl_layout!(
        probe,
        "Billboard",
        GpuBillboard {
            centre,
            right,
            up,
            spec,
            info
        }
    );
    assert_wgsl_layout!(probe, "BbGroup", GpuGroup { range, centre });
    assert_wgsl_layout!(probe, "BbProbeRay", BillboardRay { origin, dir });
    assert_wgsl_layout!(probe, "BbProbeHit", BillboardProbeHit { colour, kind });
}

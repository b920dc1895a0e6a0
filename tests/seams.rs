//! Chart seams of the radiosity atlas: found where a smooth surface crosses charts, measured
//! by paired lookups on both sides, and stitched so that D does not jump there. A synthetic
//! pair of charts with an exact linear D, a smooth cylinder baked on 1 and 3 threads, and
//! bunny-mirror baked at default quality.

mod common;

use common::{MaterialSpec, MeshSpec, flip, quad, write_gltf, write_scene};
use glam::{Vec2, Vec3};
use glint::bake::radiosity_stage;
use glint::bundle::Bundle;
use glint::geometry::Triangle;
use glint::progress::Silent;
use glint::radiosity::RadiosityMap;
use glint::radiosity::atlas::{Atlas, PageSize};
use glint::radiosity::seams::{self, Filter, StitchSettings};
use glint::scene::desc::RadiositySettings;
use glint::scene::{Quality, Scene};

/// Texels per metre of the synthetic atlas.
const DENSITY: f32 = 16.0;

fn tri(p: [Vec2; 3], n: Vec3) -> Triangle {
    Triangle {
        p: p.map(|q| q.extend(0.0)),
        n: [n; 3],
        uv: [Vec2::ZERO; 3],
        uv1: None,
        material: 0,
        object: 0,
    }
}

/// The unit square of the plane z = 0 as two charts meeting at x = 0.5: the left half
/// (triangles 0, 1) at texels (2 + 16x, 2 + 16y), the right half (2, 3) turned a quarter and
/// placed at (18 + 16y, 2 + 16(x − 0.5)), each framed by 2 texels of padding, on one
/// 40 × 24 page. `right_normal` is the right half's shading normal.
fn two_charts(right_normal: Vec3) -> (Vec<Triangle>, Atlas) {
    let v = Vec2::new;
    let z = Vec3::Z;
    let tris = vec![
        tri([v(0.0, 0.0), v(0.5, 0.0), v(0.5, 1.0)], z),
        tri([v(0.0, 0.0), v(0.5, 1.0), v(0.0, 1.0)], z),
        tri([v(0.5, 0.0), v(1.0, 0.0), v(1.0, 1.0)], right_normal),
        tri([v(0.5, 0.0), v(1.0, 1.0), v(0.5, 1.0)], right_normal),
    ];
    let (w, h) = (40u32, 24u32);
    let mut texel_chart = vec![u32::MAX; (w * h) as usize];
    for y in 0..h {
        for x in 0..w {
            let chart = if x < 12 && y < 20 {
                0
            } else if (16..38).contains(&x) && y < 12 {
                1
            } else {
                continue;
            };
            texel_chart[(y * w + x) as usize] = chart;
        }
    }
    let tri_coords = tris
        .iter()
        .enumerate()
        .map(|(i, t)| t.p.map(|p| to_texels(i >= 2, p.truncate())))
        .collect();
    let atlas = Atlas {
        texel_density: DENSITY,
        pages: vec![PageSize {
            width: w,
            height: h,
        }],
        tri_page: vec![0; 4],
        tri_coords,
        texel_chart,
        charts: 2,
        from_uv1: false,
        backs: Vec::new(),
    };
    (tris, atlas)
}

/// World (x, y) to texels of the left or right chart.
fn to_texels(right: bool, p: Vec2) -> Vec2 {
    if right {
        Vec2::new(18.0 + DENSITY * p.y, 2.0 + DENSITY * (p.x - 0.5))
    } else {
        Vec2::splat(2.0) + DENSITY * p
    }
}

/// Texels to world (x, y): the inverse of [`to_texels`].
fn to_world(right: bool, t: Vec2) -> Vec2 {
    if right {
        Vec2::new(0.5 + (t.y - 2.0) / DENSITY, (t.x - 18.0) / DENSITY)
    } else {
        (t - Vec2::splat(2.0)) / DENSITY
    }
}

/// An exact, linear D over the plane.
fn field(p: Vec2) -> f32 {
    1.0 + 0.5 * p.x + 0.25 * p.y
}

/// Every chart texel holds the field at the world point of its centre (padding included:
/// a linear field extends linearly), so both filters reproduce it exactly inside charts.
fn linear_texels(atlas: &Atlas) -> Vec<Vec3> {
    let w = atlas.pages[0].width;
    let mut texels = vec![Vec3::ZERO; atlas.texel_count()];
    for (i, &chart) in atlas.texel_chart.iter().enumerate() {
        if chart != u32::MAX {
            let centre = Vec2::new((i as u32 % w) as f32 + 0.5, (i as u32 / w) as f32 + 0.5);
            texels[i] = Vec3::splat(field(to_world(chart == 1, centre)));
        }
    }
    texels
}

#[test]
fn the_seam_between_two_charts_is_found_with_both_sides_on_the_same_points() {
    let (tris, atlas) = two_charts(Vec3::Z);
    let found = seams::find(&tris, &atlas);
    assert_eq!(found.len(), 1, "{found:?}");
    let s = found[0];
    assert_eq!(s.triangles, [0, 3]);
    for e in 0..2 {
        let a = tris[0].point(s.ends[0][e]);
        let b = tris[3].point(s.ends[1][e]);
        assert!(a.distance(b) < 1e-6, "{a} vs {b}");
        assert!((a.x - 0.5).abs() < 1e-6, "{a} is not on x = 0.5");
    }
    // 16 texels long: 3 paired samples per texel, both sides on one world point.
    let points = seams::seam_points(&atlas, &found);
    assert_eq!(points.len(), 48);
    for p in &points {
        let (a, b) = (tris[0].point(p.bary[0]), tris[3].point(p.bary[1]));
        assert!(a.distance(b) < 1e-6, "{a} vs {b}");
    }
    // A crease (normals split 90° along the edge) is no seam: D may jump there.
    let (tris, atlas) = two_charts(Vec3::X);
    assert!(seams::find(&tris, &atlas).is_empty());
}

#[test]
fn an_exact_linear_field_shows_no_seam_and_stitching_leaves_it_alone() {
    let (tris, atlas) = two_charts(Vec3::Z);
    let texels = linear_texels(&atlas);
    let points = seams::seam_points(&atlas, &seams::find(&tris, &atlas));
    for f in [Filter::Bilinear, Filter::BSpline] {
        let m = seams::measure(&atlas, &texels, &points, f);
        assert_eq!(m.pairs, 48);
        assert!(m.max < 1e-6, "{f:?}: {m:?}");
    }
    // Lookups reproduce the field along the seam.
    let offsets = atlas.page_offsets();
    for p in &points {
        let d = seams::lookup(Filter::BSpline, &atlas, &offsets, &texels, 0, p.bary[0]);
        let want = field(tris[0].point(p.bary[0]).truncate());
        assert!((d.x - want).abs() < 1e-5, "{d} vs {want}");
    }
    let mut stitched = texels.clone();
    seams::stitch(
        &atlas,
        &mut stitched,
        &points,
        &[Filter::Bilinear, Filter::BSpline],
        &StitchSettings::default(),
    );
    // Nothing to stitch but the lookups' float rounding (~1e-7), which the weak pull may
    // amplify a little: nothing moves by 1e-4 of D.
    let moved = stitched
        .iter()
        .zip(&texels)
        .map(|(a, b)| (*a - *b).abs().max_element())
        .fold(0.0f32, f32::max);
    assert!(moved < 1e-4, "a texel moved by {moved}");
}

#[test]
fn stitching_closes_a_jump_and_leaves_texels_away_from_the_seam_alone() {
    let (tris, atlas) = two_charts(Vec3::Z);
    let mut texels = linear_texels(&atlas);
    // The right chart 0.1 too bright: a jump of 0.1 / D ∈ [0.1/1.5, 0.1/1.25] at the seam.
    for (t, &c) in texels.iter_mut().zip(&atlas.texel_chart) {
        if c == 1 {
            *t += Vec3::splat(0.1);
        }
    }
    let before = texels.clone();
    let found = seams::find(&tris, &atlas);
    let points = seams::seam_points(&atlas, &found);
    for f in [Filter::Bilinear, Filter::BSpline] {
        let m = seams::measure(&atlas, &texels, &points, f);
        assert!(
            m.median > 0.1 / 1.5 - 1e-4 && m.max < 0.1 / 1.25 + 1e-4,
            "{f:?}: {m:?}"
        );
    }
    let stats = seams::stitch(
        &atlas,
        &mut texels,
        &points,
        &[Filter::Bilinear, Filter::BSpline],
        &StitchSettings::default(),
    );
    assert_eq!(stats.constraints, 96);
    for f in [Filter::Bilinear, Filter::BSpline] {
        let m = seams::measure(&atlas, &texels, &points, f);
        assert!(m.max < 1e-3, "{f:?} after stitching: {m:?}");
    }
    // Both sides meet halfway, at the field + 0.05 (the two sides are mirror images of the
    // same problem), and the stitched value stays within the two sides' values.
    let offsets = atlas.page_offsets();
    for p in &points {
        let d = seams::lookup(Filter::Bilinear, &atlas, &offsets, &texels, 0, p.bary[0]).x;
        let want = field(tris[0].point(p.bary[0]).truncate()) + 0.05;
        assert!((d - want).abs() < 0.02, "{d} vs {want}");
    }
    // Only texels a lookup on the seam reads may move: within 2 texels of the seam (the
    // B-spline's reach) in either chart.
    let w = atlas.pages[0].width;
    for (i, (a, b)) in before.iter().zip(&texels).enumerate() {
        let t = Vec2::new((i as u32 % w) as f32 + 0.5, (i as u32 / w) as f32 + 0.5);
        let from_seam = match atlas.texel_chart[i] {
            0 => (t.x - 10.0).abs(),
            1 => (t.y - 2.0).abs(),
            _ => f32::INFINITY,
        };
        if from_seam > 2.5 {
            assert_eq!(a, b, "texel {i}, {from_seam} texels from the seam, moved");
        } else {
            assert!((*a - *b).abs().max_element() < 0.2, "texel {i}: {a} → {b}");
        }
    }
}

/// bunny-mirror at default quality, through the radiosity stage: the D its bundle holds
/// (half floats) must not jump across the bunny's chart seams by more than 1% of D, neither
/// through the bilinear lookup of the bake stages nor through the viewer's B-spline, and the
/// jump must be far below the texel-to-texel variation inside the same charts. Without
/// stitching the jump's p95 is about 100% of D (the bunny's charts are a texel or two wide).
///
/// Both with the bunny's curved charts at the preset's texels per radian (24) and without
/// contact boosts, and with the preset's contact boosts (charts near the floor and in folds
/// at up to 8× their neighbours' density, where D changes fastest) and every other chart at
/// the rule's density: the stitch weighs each seam point by 1 / D, so the dark seams under
/// the bunny close as well as the bright ones. The two together (the full preset) pass too
/// (release: p95 0.03%, max 0.15% of D), but a third bake of the bunny at default costs CI
/// more than it tells.
#[test]
fn bunny_mirror_seams_are_below_one_percent_of_d_and_the_texel_noise() {
    let preset = RadiositySettings::preset(Quality::Default);
    bunny_mirror_seams(0.0, preset.texels_per_radian);
    bunny_mirror_seams(preset.contact_boost, 0.0);
}

fn bunny_mirror_seams(contact_boost: f32, texels_per_radian: f32) {
    let scene = Scene::load(
        std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/bunny-mirror/scene.json"),
    )
    .unwrap();
    let settings = RadiositySettings {
        stitch_seams: true,
        contact_boost,
        texels_per_radian,
        ..RadiositySettings::preset(Quality::Default)
    };
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("bunny.glint");
    let record = radiosity_stage::bake(&scene, &out, &settings, false, &Silent).unwrap();
    let map = RadiosityMap::load(&Bundle::open(&out).unwrap())
        .unwrap()
        .unwrap();
    // The stage's atlas: the rule's, with the preset's contact boosts.
    let (atlas, samples, _) = glint::radiosity::contacts::build(
        &scene,
        &scene.build_bvh(),
        radiosity_stage::density_rule(&scene, &settings)
            .unwrap()
            .rule,
        settings.contact_boost,
    )
    .unwrap();
    assert_eq!(
        (&atlas.pages, &atlas.tri_coords),
        (&map.atlas.pages, &map.atlas.tri_coords)
    );
    let texels: Vec<Vec3> = map.pages.concat();
    let found = seams::find(&scene.triangles, &atlas);
    assert!(found.len() > 100, "{} seam edges", found.len());
    let points = seams::seam_points(&atlas, &found);
    let noise = seams::texel_noise(
        &atlas,
        &samples,
        &texels,
        Some(&seams::seam_charts(&atlas, &points)),
    );
    let before = record.stats["seam_jump_p95_before"].as_f64().unwrap();
    for f in [Filter::Bilinear, Filter::BSpline] {
        let m = seams::measure(&atlas, &texels, &points, f);
        println!(
            "contact_boost {contact_boost}, texels_per_radian {texels_per_radian}, {f:?}: jump {m:?}, texel noise {noise:?}, p95 before stitching {before}"
        );
        assert!(m.pairs > 500, "{m:?}");
        assert!(m.p95 <= 0.01 && m.max <= 0.01, "{f:?}: jump {m:?}");
        assert!(
            m.p95 < 0.1 * noise.median,
            "{f:?}: jump {m:?}, noise {noise:?}"
        );
    }
    assert!(
        before > 0.05,
        "stitching had nothing to do? p95 before {before}"
    );
}

/// A smooth-shaded cylinder (24 facets, vertex normals radial: its charts meet at seams)
/// standing on a floor under an emissive quad.
fn cylinder_scene(dir: &std::path::Path) -> Scene {
    let n = 24;
    let mut positions = Vec::new();
    let mut normals = Vec::new();
    for i in 0..n {
        let a = i as f32 / n as f32 * std::f32::consts::TAU;
        for y in [0.0, 1.0] {
            positions.push([0.5 * a.cos(), y, 0.5 * a.sin()]);
            normals.push([a.cos(), 0.0, a.sin()]);
        }
    }
    let mut indices = Vec::new();
    for i in 0..n as u32 {
        let j = (i + 1) % n as u32;
        let (b0, t0, b1, t1) = (2 * i, 2 * i + 1, 2 * j, 2 * j + 1);
        // Outward: seen from outside, bottom i → top i → top j is counter-clockwise.
        indices.extend([b0, t0, t1, b0, t1, b1]);
    }
    let cylinder = MeshSpec {
        name: "Cylinder",
        material: 0,
        positions,
        indices,
        normals,
    };
    let materials = [
        MaterialSpec::diffuse("White", 0.7),
        MaterialSpec {
            emissive: [1.0; 3],
            strength: 5.0,
            ..MaterialSpec::diffuse("Light", 0.0)
        },
    ];
    let meshes = [
        cylinder,
        quad("Floor", 0, 1, 0.0, 2.0),
        flip(quad("Light", 1, 1, 2.0, 0.5)),
    ];
    write_gltf(dir, "s", &meshes, &materials);
    Scene::load(write_scene(
        dir,
        r#"{ "version": 1, "geometry": "s.gltf" }"#,
    ))
    .unwrap()
}

#[test]
fn stitched_bakes_are_byte_identical_whatever_the_thread_count() {
    let dir = tempfile::tempdir().unwrap();
    let scene = cylinder_scene(dir.path());
    let outward = scene
        .triangles
        .iter()
        .filter(|t| t.object == 0)
        .all(|t| t.face_normal().dot(t.p[0].with_y(0.0)) > 0.0);
    assert!(outward, "the cylinder's facets face outward");
    let settings = RadiositySettings {
        texel_density: 16.0,
        min_chart_texels: 0,
        min_scene_texels: 0,
        contact_boost: 0.0,
        texels_per_radian: 0.0,
        rays: 32,
        light_samples: 4,
        bounces: 2,
        tolerance: 0.0,
        glossy_depth: 0,
        target_error: None,
        stitch_seams: true,
        cache_budget_mib: 2048,
        max_elements: 0,
    };
    let pages: Vec<Vec<u8>> = [1, 3]
        .iter()
        .map(|&threads| {
            let out = dir.path().join(format!("t{threads}.glint"));
            let record = rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .unwrap()
                .install(|| radiosity_stage::bake(&scene, &out, &settings, false, &Silent))
                .unwrap();
            let edges = record.stats["seam_edges"].as_u64().unwrap();
            let after = record.stats["seam_jump_max_after"].as_f64().unwrap();
            let before = record.stats["seam_jump_p95_before"].as_f64().unwrap();
            println!("{edges} seam edges, jump p95 {before} before stitching, max {after} after");
            assert!(edges >= 4, "{edges} seam edges on the cylinder");
            assert!(before > 0.01, "no jump to stitch? p95 {before}");
            assert!(after <= 0.01, "jump after stitching {after}");
            Bundle::open(&out)
                .unwrap()
                .read_stage_file("radiosity", "page0.exr")
                .unwrap()
        })
        .collect();
    assert!(
        pages[0] == pages[1],
        "page0.exr differs between 1 and 3 threads"
    );
}

//! D at the edges of a small chart: a thin panel on a wall (a picture, a shelf), its front
//! meeting its top and bottom through rounded edges a few millimetres wide, far narrower than
//! a texel, with smooth shading across them (so the charts meet at seams there). The front is
//! lit evenly, its top and bottom less: stitching those seams must leave the front's D, read
//! the viewer's way, as the solve left it, and where the front's chart ends at its own edge
//! that D is level up to the edge.

mod common;

use common::{MaterialSpec, MeshSpec, flip, quad, write_gltf, write_scene};
use glam::{Vec2, Vec3};
use glint::bake::radiosity_stage;
use glint::bundle::Bundle;
use glint::progress::Silent;
use glint::radiosity::RadiosityMap;
use glint::radiosity::atlas::closest_point;
use glint::radiosity::seams::{self, Filter};
use glint::scene::Scene;
use glint::scene::desc::RadiositySettings;

/// Half the panel's width (x), half its front's flat height (y), its depth (z) and the
/// radius of its rounded top and bottom edges, metres.
const HALF_W: f32 = 0.4;
const HALF_H: f32 = 0.15;
const DEPTH: f32 = 0.06;
const RADIUS: f32 = 0.005;
/// Texels per metre: a texel is 12 rounded edges wide.
const DENSITY: f32 = 16.0;

/// The panel's profile in (y, z), from the back of its bottom face round to the back of its
/// top face, with the outward normal at each point: flat bottom, a quarter circle in
/// `segments` steps, flat front, another quarter circle, flat top (the back is open, against
/// the wall).
fn profile(segments: usize) -> Vec<(Vec2, Vec2)> {
    let mut out = vec![(Vec2::new(-HALF_H - RADIUS, -DEPTH), Vec2::NEG_X)];
    for (cy, from) in [(-HALF_H, -90.0f32), (HALF_H, 0.0)] {
        for k in 0..=segments {
            let a = (from + 90.0 * k as f32 / segments as f32).to_radians();
            let n = Vec2::new(a.sin(), a.cos());
            out.push((Vec2::new(cy, -RADIUS) + RADIUS * n, n));
        }
    }
    out.push((Vec2::new(HALF_H + RADIUS, -DEPTH), Vec2::X));
    out
}

/// The panel swept along x, flat end caps. Its rounded edges shaded `smooth`ly (vertex
/// normals along the profile) or flat (no normals: each facet its face normal, a few tens of
/// degrees from the next): either way its charts meet at seams there. Triangles run from the
/// bottom face up to the top, as modelling tools write such a mesh: the front's chart grows
/// from a rounded edge's facet.
fn panel(smooth: bool) -> MeshSpec {
    let prof = profile(4);
    let mut positions = Vec::new();
    let mut normals = Vec::new();
    let mut indices = Vec::new();
    for (p, n) in &prof {
        for x in [-HALF_W, HALF_W] {
            positions.push([x, p.x, p.y]);
            normals.push([0.0, n.x, n.y]);
        }
    }
    for i in 0..prof.len() as u32 - 1 {
        let (a0, a1, b0, b1) = (2 * i, 2 * i + 1, 2 * i + 2, 2 * i + 3);
        // The profile climbs in y and turns towards +z: (a0 a1 b1) faces outward.
        indices.extend([a0, a1, b1, a0, b1, b0]);
    }
    for (x, nx) in [(-HALF_W, -1.0f32), (HALF_W, 1.0)] {
        let base = positions.len() as u32;
        for (p, _) in &prof {
            positions.push([x, p.x, p.y]);
            normals.push([nx, 0.0, 0.0]);
        }
        for k in 1..prof.len() as u32 - 1 {
            let t = [base, base + k, base + k + 1];
            // The profile runs clockwise seen from +x.
            indices.extend(if nx > 0.0 { [t[0], t[2], t[1]] } else { t });
        }
    }
    MeshSpec {
        name: "Panel",
        material: 0,
        positions,
        indices,
        normals: if smooth { normals } else { Vec::new() },
    }
}

#[test]
fn a_small_chart_keeps_its_level_up_to_rounded_edges_narrower_than_a_texel() {
    panel_keeps_its_level(true);
}

#[test]
fn a_small_chart_keeps_its_level_up_to_flat_shaded_rounded_edges() {
    panel_keeps_its_level(false);
}

fn panel_keeps_its_level(smooth: bool) {
    let dir = tempfile::tempdir().unwrap();
    let materials = [
        MaterialSpec::diffuse("Paint", 0.7),
        MaterialSpec::diffuse("Wall", 0.5),
        MaterialSpec::emitter("Light", [1.0; 3], 4.0),
    ];
    let wall = quad("Wall", 1, 2, -DEPTH, 1.0);
    // A large emitter close in front: the front sees nearly all its hemisphere lit, the top
    // and bottom half of theirs.
    let light = flip(quad("Light", 2, 2, 0.6, 2.0));
    write_gltf(dir.path(), "s", &[panel(smooth), wall, light], &materials);
    let scene = Scene::load(write_scene(
        dir.path(),
        r#"{ "version": 1, "geometry": "s.gltf" }"#,
    ))
    .unwrap();
    let front = |t: &glint::geometry::Triangle| {
        t.object == 0 && t.face_normal().z > 0.999 && t.p.iter().all(|p| p.z > -1e-4)
    };
    assert_eq!(scene.triangles.iter().filter(|t| front(t)).count(), 2);
    let settings = |stitch_seams: bool| RadiositySettings {
        texel_density: DENSITY,
        min_chart_texels: 0,
        min_scene_texels: 0,
        contact_boost: 0.0,
        texels_per_radian: 0.0,
        rays: 64,
        light_samples: 8,
        bounces: 2,
        tolerance: 1e-2,
        glossy_depth: 0,
        target_error: None,
        stitch_seams,
        cache_budget_mib: 2048,
        max_elements: 0,
    };
    // Bands a quarter and half a texel in from the top and bottom edges of the flat front,
    // and its middle row, each over the panel's width away from its ends.
    let texel = 1.0 / DENSITY;
    let rows = [
        0.0,
        HALF_H - 0.25 * texel,
        HALF_H - 0.5 * texel,
        -HALF_H + 0.25 * texel,
        -HALF_H + 0.5 * texel,
    ];
    let xs: Vec<f32> = (0..9).map(|i| -0.25 + 0.0625 * i as f32).collect();
    // Per row, the mean D that the viewer reads (its cubic B-spline) along it.
    let read = |stitch: bool| -> Vec<f32> {
        let out = dir.path().join(format!("s-{stitch}.glint"));
        radiosity_stage::bake(&scene, &out, &settings(stitch), false, &Silent).unwrap();
        let map = RadiosityMap::load(&Bundle::open(&out).unwrap())
            .unwrap()
            .unwrap();
        let texels: Vec<Vec3> = map.pages.concat();
        let offsets = map.atlas.page_offsets();
        let d_at = |p: Vec2| -> f32 {
            let (t, b) = scene
                .triangles
                .iter()
                .enumerate()
                .filter(|(_, t)| front(t))
                .map(|(i, t)| (i, closest_point(t.p.map(|q| q.truncate()), p)))
                .find(|(_, (d, _))| *d == 0.0)
                .map(|(i, (_, b))| (i, b))
                .unwrap_or_else(|| panic!("no front triangle holds {p}"));
            let d = seams::lookup(Filter::BSpline, &map.atlas, &offsets, &texels, t as u32, b);
            glint::colour::luminance(d)
        };
        rows.iter()
            .map(|&y| xs.iter().map(|&x| d_at(Vec2::new(x, y))).sum::<f32>() / xs.len() as f32)
            .collect()
    };
    let (solved, stitched) = (read(false), read(true));
    for ((y, a), b) in rows.iter().zip(&solved).zip(&stitched) {
        println!(
            "y {y:+.4}: solved {a}, stitched {b} ({:.3} of the middle)",
            b / stitched[0]
        );
    }
    // The seams at the rounded edges join faces lit unlike the front: stitching them would
    // pull the front's last texels, and through the smoothness pull its whole level, towards
    // theirs.
    for ((y, a), b) in rows.iter().zip(&solved).zip(&stitched) {
        assert!(
            (b / a - 1.0).abs() < 0.02,
            "stitching moved D {y:+.4} m from the front's centre from {a} to {b}"
        );
    }
    // At the top the chart ends at the front's own edge: D is level up to it.
    for (y, b) in rows.iter().zip(&stitched).take(3) {
        assert!(
            (b / stitched[0] - 1.0).abs() < 0.03,
            "D {y:+.4} m from the front's centre reads {b}, {:.3} of its middle {}",
            b / stitched[0],
            stitched[0]
        );
    }
}

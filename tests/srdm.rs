//! SRDM construction and intersection (Popescu et al. 2006 §4.1–4.3) against exact answers:
//! planar maps, monotone error in m, the extremes of rows and domain counts, a brute-force
//! march of the height field, the binary format and determinism across thread counts.

use glam::{Vec2, Vec3};
use glint::camera::Camera;
use glint::progress::{Progress, Silent};
use glint::sampling::Rng;
use glint::srdm::{
    BACKGROUND, DepthMap, Domain, ImpostorCamera, SPLIT_TOLERANCE, SRDM_VERSION, Srdm, SrdmError,
    SrdmParams, error_stats, march, row_samples, simplify_row,
};

/// A camera at the origin looking down −Z, 40° field of view, hither 1, yon 3.
fn camera(w: u32) -> ImpostorCamera {
    ImpostorCamera {
        view: Camera::look_at(Vec3::ZERO, -Vec3::Z, Vec3::Y, 40f32.to_radians()),
        hither: 1.0,
        yon: 3.0,
        resolution: w,
    }
}

fn build(map: &DepthMap, n: u32, m: u32) -> Srdm {
    Srdm::build(
        map,
        camera(map.size()),
        SrdmParams {
            domains: n,
            points: m,
        },
        &Silent,
    )
    .unwrap()
}

fn hash(x: u32, y: u32) -> f32 {
    let mut h = x.wrapping_mul(0x9E37_79B1) ^ y.wrapping_mul(0x85EB_CA77);
    h ^= h >> 15;
    h = h.wrapping_mul(0x2C1B_3C6D);
    h ^= h >> 12;
    (h & 0xffff) as f32 / 65535.0
}

/// A disc-shaped object with bumps, a depth step, a hole and noise: the hard case.
fn rough_map(w: u32) -> DepthMap {
    let c = w as f32 / 2.0;
    DepthMap::from_fn(w, |x, y| {
        let (fx, fy) = (x as f32 + 0.5 - c, y as f32 + 0.5 - c);
        if fx * fx + fy * fy > (0.46 * w as f32).powi(2) {
            return None;
        }
        if (fx - 0.2 * c).abs() < 0.08 * c && (fy + 0.1 * c).abs() < 0.2 * c {
            return None; // a hole: rows get two spans
        }
        let mut d = 0.4 + 0.2 * (x as f32 / 7.0).sin() * (y as f32 / 5.0).cos();
        if fx > 0.3 * c {
            d += 0.15; // a depth discontinuity inside the span
        }
        Some(d + 0.01 * hash(x, y))
    })
    .unwrap()
}

/// A smooth field over the whole map: d = 0.5 + 0.15 sin(x/9) cos(y/11).
fn smooth_map(w: u32) -> DepthMap {
    DepthMap::from_fn(w, |x, y| {
        let (px, py) = (x as f32 + 0.5, y as f32 + 0.5);
        Some(0.5 + 0.15 * (px / 9.0).sin() * (py / 11.0).cos())
    })
    .unwrap()
}

#[test]
fn planar_depth_map_is_reproduced_exactly_with_two_points_per_span() {
    let w = 64;
    let plane = DepthMap::from_fn(w, |x, y| {
        Some(0.3 + 0.004 * (x as f32 + 0.5) - 0.002 * (y as f32 + 0.5))
    })
    .unwrap();
    for n in [1, 7, 60, 180] {
        for m in [2, 16] {
            let s = build(&plane, n, m);
            for i in 0..n {
                for j in 0..w {
                    let count = s.counts()[(i * w + j) as usize];
                    assert!(
                        count == 0 || count == 2,
                        "n {n} m {m} domain {i} row {j}: {count} points"
                    );
                    assert!(
                        s.row_error(i, j) <= SPLIT_TOLERANCE,
                        "n {n} m {m} domain {i} row {j}: error {}",
                        s.row_error(i, j)
                    );
                }
            }
            // Domain 0 is the map itself: every row is one span of w samples.
            assert!((0..w).all(|j| s.counts()[j as usize] == 2));
            let e = error_stats(&plane, &s);
            assert!(e.mean_depth_error < 1e-6, "{e:?}");
            assert_eq!(e.samples, e.represented);
        }
    }
    // Two planes side by side on background: 2 points per span, 4 in all, exact.
    let two = DepthMap::from_fn(w, |x, y| match x {
        2..=20 => Some(0.2 + 0.01 * x as f32 + 0.001 * y as f32),
        30..=60 => Some(0.9 - 0.005 * x as f32),
        _ => None,
    })
    .unwrap();
    let s = build(&two, 1, 4);
    for j in 0..w {
        let row = s.row_used(0, j);
        assert_eq!(row.len(), 4, "row {j}: {row:?}");
        assert!(s.row_error(0, j) <= SPLIT_TOLERANCE);
        // Span edges: u = first sample's left edge, last sample's right edge.
        assert_eq!(
            [row[0][0], row[1][0], row[2][0], row[3][0]],
            [2.0, 21.0, 30.0, 61.0]
        );
        assert!(row[0][1] < 0.0 && row[2][1] < 0.0, "openers are negative");
        assert!(row[1][1] > 0.0 && row[3][1] > 0.0);
        // The extrapolated edge depth lies on the plane.
        let y = j as f32 + 0.5;
        assert!((-row[0][1] - (0.2 + 0.01 * 1.5 + 0.001 * (y - 0.5))).abs() < 1e-6);
    }
}

#[test]
fn error_never_increases_as_m_grows() {
    let map = rough_map(96);
    let n = 12;
    let mut grew_elsewhere = 0;
    for i in 0..n {
        for j in (0..96).step_by(3) {
            let samples = row_samples(&map, n, i, j);
            let mut last = f32::INFINITY;
            for m in 2..=48 {
                let r = simplify_row(&samples, m);
                assert!(r.points.len() <= m);
                assert!(
                    r.error <= last,
                    "domain {i} row {j}: error {} at m = {m} > {last} at m = {}",
                    r.error,
                    m - 1
                );
                if r.points.len() < m && r.error > SPLIT_TOLERANCE {
                    grew_elsewhere += 1; // a split that would have raised the error was held back
                }
                last = r.error;
            }
        }
    }
    // The depth step makes plain greedy splitting non-monotone somewhere in this map.
    assert!(grew_elsewhere > 0);
    // The same through whole builds, and the aggregate figures follow.
    let mut prev: Option<(Vec<f32>, f64)> = None;
    for m in [2, 4, 8, 16, 32, 64] {
        let s = build(&map, 24, m);
        let e = error_stats(&map, &s);
        if let Some((errors, rel)) = &prev {
            assert!(
                s.errors().iter().zip(errors).all(|(a, b)| a <= b),
                "m = {m}"
            );
            assert!(e.mean_relative_z_error <= *rel * 1.05, "m = {m}: {e:?}");
        }
        prev = Some((s.errors().to_vec(), e.mean_relative_z_error));
    }
}

#[test]
fn all_background_rows_are_empty_and_never_hit() {
    let w = 32;
    let blob = DepthMap::from_fn(w, |x, y| {
        ((12..20).contains(&x) && (12..20).contains(&y)).then_some(0.5)
    })
    .unwrap();
    let s = build(&blob, 4, 8);
    for j in (0..w).filter(|j| !(11..21).contains(j)) {
        assert_eq!(s.row_used(0, j).len(), 0);
        assert_eq!(s.row_error(0, j), 0.0);
        assert!(s.row(0, j).iter().all(|p| *p == [0.0, -1.0]));
    }
    let cam = camera(w);
    // A ray across the top rows, through the depth range: nothing to hit.
    let a = cam.unproject(Vec2::new(1.0, 3.5), 0.9);
    let b = cam.unproject(Vec2::new(31.0, 3.5), 0.1);
    assert!(
        s.intersect(a, (b - a).normalize(), (b - a).length())
            .is_none()
    );
    // All background: every row empty.
    let empty = DepthMap::from_fn(w, |_, _| None).unwrap();
    let s = build(&empty, 3, 4);
    assert!(s.counts().iter().all(|c| *c == 0));
    assert!(s.intersect(a, (b - a).normalize(), 10.0).is_none());
}

#[test]
fn single_texel_spans_cover_their_texel() {
    let w = 16;
    let dots = DepthMap::from_fn(w, |x, y| {
        (x % 4 == 1 && y % 2 == 0).then_some(0.25 + 0.05 * x as f32)
    })
    .unwrap();
    let s = build(&dots, 1, 16);
    let row = s.row_used(0, 0);
    assert_eq!(row.len(), 8, "{row:?}");
    for (k, pair) in row.chunks(2).enumerate() {
        let x = 4 * k as u32 + 1;
        let d = 0.25 + 0.05 * x as f32;
        assert_eq!(pair[0], [x as f32, -d]);
        assert_eq!(pair[1], [x as f32 + 1.0, d]);
    }
    assert_eq!(s.row_error(0, 0), 0.0);
    // A ray along row 0 dipping through the depth of the dot at x = 5 hits inside its texel.
    // (Entering the texel already below its depth would pass: the map is a sheet.)
    let cam = camera(w);
    let d = 0.25 + 0.05 * 5.0;
    let a = cam.unproject(Vec2::new(5.1, 0.5), d + 0.01);
    let b = cam.unproject(Vec2::new(5.9, 0.5), d - 0.01);
    let hit = s
        .intersect(a, (b - a).normalize(), (b - a).length())
        .unwrap();
    assert!((hit.pixel.x - 5.5).abs() < 1e-3, "{hit:?}");
    assert!((hit.depth - d).abs() < 1e-4);
}

#[test]
fn m_larger_than_the_row_keeps_every_sample() {
    let w = 8;
    let map = DepthMap::from_fn(w, |x, y| Some(0.2 + 0.6 * hash(x, y))).unwrap();
    let s = build(&map, 3, 64);
    for j in 0..w {
        let row = s.row_used(0, j);
        // Two edges and the 8 samples (the first and last only if the line through the
        // extrapolated edges misses them).
        assert!(row.len() <= 10 && row.len() >= 8, "{row:?}");
        assert!(s.row_error(0, j) <= SPLIT_TOLERANCE);
        for k in 0..w {
            let u = k as f32 + 0.5;
            if let Some(p) = row.iter().find(|p| p[0] == u) {
                assert_eq!(p[1], map.at(k as i64, j as i64).unwrap());
            }
        }
        // Padding repeats the last point as a span opener: no segment.
        let full = s.row(0, j);
        let last = row[row.len() - 1];
        assert!(full[row.len()..].iter().all(|p| *p == [last[0], -last[1]]));
    }
    assert!(error_stats(&map, &s).mean_depth_error < 1e-7);
}

#[test]
fn depth_discontinuities_at_the_map_edge() {
    let w = 32;
    // The object fills the right part of the map and jumps in depth at its last column.
    let map = DepthMap::from_fn(w, |x, _| match x {
        0..=9 => None,
        31 => Some(0.95),
        _ => Some(0.3 + 0.01 * x as f32),
    })
    .unwrap();
    let s = build(&map, 8, 6);
    for j in 0..w {
        let row = s.row_used(0, j);
        assert_eq!(row.first().map(|p| p[0]), Some(10.0));
        assert_eq!(
            row.last().map(|p| p[0]),
            Some(w as f32),
            "the span ends at the map edge"
        );
        assert!(row.iter().all(|p| (0.0..=w as f32).contains(&p[0])));
        assert!(s.row_error(0, j) <= SPLIT_TOLERANCE, "{row:?}");
    }
    // Every domain's rows stay within their window and in increasing u.
    for i in 0..8 {
        for j in 0..w {
            let row = s.row_used(i, j);
            assert!(
                row.windows(2).all(|p| p[0][0] < p[1][0]),
                "{i} {j}: {row:?}"
            );
            assert!(row.iter().all(|p| p[1].abs() > 0.0 && p[1].abs() <= 1.0));
        }
    }
    // A ray along row 5 towards the edge, between the slope and the jump's depth: the SRDM
    // and the brute-force march agree on whether and where it meets the map (the step in
    // the last column is a steep segment of the row, not a wall).
    let cam = camera(w);
    let a = cam.unproject(Vec2::new(20.5, 5.5), 0.55);
    let b = cam.unproject(Vec2::new(31.9, 5.5), 0.66);
    let dir = (b - a).normalize();
    let len = (b - a).length();
    let srdm = s.intersect(a, dir, len).map(|h| h.pixel.x);
    let brute = march(&map, &cam, a, dir, len, 0.05).map(|h| h.pixel.x);
    assert_eq!(srdm.is_some(), brute.is_some(), "{srdm:?} {brute:?}");
    if let (Some(x), Some(y)) = (srdm, brute) {
        assert!((x - y).abs() < 1.0, "{x} {y}");
    }
}

#[test]
fn one_domain_and_180_domains() {
    let map = smooth_map(48);
    let cam = camera(48);
    let one = build(&map, 1, 12);
    let many = build(&map, 180, 12);
    assert_eq!(one.counts().len(), 48);
    assert_eq!(many.counts().len(), 180 * 48);
    // 180 domains: every direction is within half a degree (π/2n) of a domain.
    for k in 0..720 {
        let phi = std::f32::consts::PI * k as f32 / 720.0;
        let i = Domain::nearest(Vec2::new(phi.cos(), phi.sin()), 180);
        let theta = std::f32::consts::PI * i as f32 / 180.0;
        let diff = (phi - theta)
            .abs()
            .min(std::f32::consts::PI - (phi - theta).abs());
        assert!(diff <= 0.5f32.to_radians() + 1e-6, "{phi} → {i}");
    }
    // One domain: a ray whose projection runs across the rows is tested at its midpoint and
    // still finds the surface it pierces; a horizontal one is exact.
    for (a_px, b_px) in [
        (Vec2::new(24.5, 10.0), Vec2::new(24.5, 38.0)),
        (Vec2::new(5.0, 24.5), Vec2::new(43.0, 24.5)),
    ] {
        let a = cam.unproject(a_px, 0.95);
        let b = cam.unproject(b_px, 0.05);
        let dir = (b - a).normalize();
        let h1 = one.intersect(a, dir, 10.0).expect("one domain hits");
        let h180 = many.intersect(a, dir, 10.0).expect("180 domains hit");
        let m = march(&map, &cam, a, dir, 10.0, 0.05).expect("march hits");
        let field = map.sample(h180.pixel).unwrap();
        let e = many.row_error(h180.domain, h180.row);
        assert!(
            (h180.depth - field).abs() <= e + 1e-4,
            "{h180:?} {field} {e}"
        );
        assert!((h180.t - m.t).abs() < 0.02 * m.t, "{h180:?} {m:?}");
        assert!((h1.depth - m.depth).abs() < 0.1, "{h1:?} {m:?}");
    }
    // Straight down a line of sight: the projection is a point.
    let p = cam.unproject(Vec2::new(20.5, 20.5), 0.5);
    let hit = many.intersect(Vec3::ZERO, p.normalize(), 10.0).unwrap();
    let want = map.sample(Vec2::new(20.5, 20.5)).unwrap();
    assert!((hit.depth - want).abs() < 1e-3, "{hit:?} {want}");
}

#[test]
fn rows_with_more_spans_than_points_keep_the_longest() {
    let mut row = vec![BACKGROUND; 30];
    for k in (1..6).chain(8..9).chain(12..15) {
        row[k] = 0.5;
    }
    let r = simplify_row(&row, 4);
    assert_eq!(r.dropped_spans, 1);
    assert_eq!(r.error, 1.0);
    let us: Vec<f32> = r.points.iter().map(|p| p[0]).collect();
    assert_eq!(us, [1.0, 6.0, 12.0, 15.0]);
    let r = simplify_row(&row, 6);
    assert_eq!((r.dropped_spans, r.error, r.points.len()), (0, 0.0, 6));
    // An odd m: the spare point has nothing to split (the kept spans are flat).
    let r = simplify_row(&row, 5);
    assert_eq!((r.dropped_spans, r.points.len()), (1, 4));
}

/// Rays along a row of a domain: the SRDM's answer against that row's own samples, with the
/// bound the simplification promises. Before the SRDM's hit, no span of the row holds samples
/// more than the row's error on both sides of the ray (a crossing the SRDM could have missed);
/// at the hit, the depth is within the row's error of the samples' linear interpolation.
#[test]
fn intersection_agrees_with_the_row_march_within_the_row_error() {
    let w = 96;
    let map = rough_map(w);
    let cam = camera(w);
    let n = 24;
    let s = build(&map, n, 10);
    let mut rng = Rng::new(7, 0);
    let (mut hits, mut checked) = (0, 0);
    for _ in 0..3000 {
        let i = (rng.uniform() * n as f32) as u32;
        let j = (rng.uniform() * w as f32) as u32;
        let dom = Domain::new(i, n, w);
        let (ua, ub) = (rng.uniform() * w as f32, rng.uniform() * w as f32);
        if (ua - ub).abs() < 2.0 {
            continue;
        }
        let (da, db) = (0.05 + 0.9 * rng.uniform(), 0.05 + 0.9 * rng.uniform());
        let (pa, pb) = (dom.pixel(ua, j as f32 + 0.5), dom.pixel(ub, j as f32 + 0.5));
        let inside = |p: Vec2| p.min_element() > 0.0 && p.max_element() < w as f32;
        if !inside(pa) || !inside(pb) {
            continue;
        }
        let (a, b) = (cam.unproject(pa, da), cam.unproject(pb, db));
        let (dir, len) = ((b - a).normalize(), (b - a).length());
        let hit = s.intersect(a, dir, len);
        checked += 1;
        let e = s.row_error(i, j) + 2e-4;
        let samples = row_samples(&map, n, i, j);
        let ray = |u: f32| da + (u - ua) * (db - da) / (ub - ua);
        let forward = ub > ua;
        let u_hit = hit.map(|h| {
            assert_eq!((h.domain, h.row), (i, j), "the row the ray lies along");
            dom.coords(h.pixel).x
        });
        // Samples strictly before the hit, in ray order, span by span.
        let before = |u: f32| match u_hit {
            None => true,
            Some(uh) => {
                if forward {
                    u < uh - 1e-3
                } else {
                    u > uh + 1e-3
                }
            }
        };
        let (lo, hi) = (ua.min(ub), ua.max(ub));
        let (mut above, mut below) = (false, false);
        for (k, &d) in samples.iter().enumerate() {
            let u = k as f32 + 0.5;
            if d < 0.0 {
                (above, below) = (false, false); // a gap ends the span
                continue;
            }
            if u < lo || u > hi || !before(u) {
                continue;
            }
            let g = ray(u) - d;
            above |= g > e;
            below |= g < -e;
            assert!(
                !(above && below),
                "domain {i} row {j}: the ray crosses the row by more than {e} before {u_hit:?} (sample {k})"
            );
        }
        if let (Some(h), Some(uh)) = (hit, u_hit) {
            hits += 1;
            let k = (uh - 0.5).floor();
            let (k0, k1) = (k as i64, k as i64 + 1);
            if k0 >= 0
                && k1 < w as i64
                && samples[k0 as usize] >= 0.0
                && samples[k1 as usize] >= 0.0
            {
                let f = uh - 0.5 - k;
                let interp = samples[k0 as usize] * (1.0 - f) + samples[k1 as usize] * f;
                assert!(
                    (h.depth - interp).abs() <= e,
                    "domain {i} row {j}: hit depth {} vs samples {interp} (row error {e})",
                    h.depth
                );
            }
        }
    }
    assert!(checked > 1000 && hits > 200, "{checked} rays, {hits} hits");
}

/// Random rays in every direction against a brute-force march of the height field: where the
/// SRDM hits, the field at the ray's point is within the row error plus the field's slope times
/// the ray's distance from its row (the price of θ's quantization, §5.2); before it, the ray
/// never went through the field by more than that; and the two agree on hit or miss.
#[test]
fn intersection_agrees_with_a_brute_force_march_on_random_rays() {
    let w = 64;
    let map = smooth_map(w);
    let cam = camera(w);
    let n = 180;
    let s = build(&map, n, 16);
    let e_max = s.errors().iter().cloned().fold(0.0, f32::max);
    // Field slope per texel (≤ 0.15/9 + 0.15/11) and the bilinear/linear gap.
    let (slope, curvature) = (0.032, 0.002);
    let mut rng = Rng::new(11, 0);
    let (mut agree, mut both, mut total) = (0, 0, 0);
    let mut rel = Vec::new();
    for _ in 0..2000 {
        let pa = Vec2::new(rng.uniform(), rng.uniform()) * w as f32;
        let pb = Vec2::new(rng.uniform(), rng.uniform()) * w as f32;
        let a = cam.unproject(pa, 0.02 + 0.96 * rng.uniform());
        let b = cam.unproject(pb, 0.02 + 0.96 * rng.uniform());
        let (dir, len) = ((b - a).normalize(), (b - a).length());
        let Some((t0, t1)) = cam.clip(a, dir, 0.0, len) else {
            continue;
        };
        total += 1;
        let hit = s.intersect(a, dir, len);
        let brute = march(&map, &cam, a, dir, len, 0.05);
        // The row the SRDM searches, as §4.3 picks it (none: it sees nothing to cross).
        let Some((i, j)) = s.search_row(a, dir, len) else {
            assert!(hit.is_none());
            agree += usize::from(brute.is_none());
            continue;
        };
        let dom = Domain::new(i, n, w);
        let row_v = j as f32 + 0.5;
        let tol = |p: Vec2| e_max + slope * (dom.coords(p).y - row_v).abs() + curvature + 1e-4;
        let t_end = hit.map_or(t1, |h| h.t);
        let mut sign = 0.0f32;
        for q in 0..=400 {
            let t = t0 + (t_end - t0) * q as f32 / 400.0;
            let p = cam.project(a + t * dir).unwrap();
            // Where the searched row has no data (a gap, off the domain's window, or off the
            // map at the row's offset) the SRDM cannot see a crossing: a new stretch starts.
            let u = dom.coords(p.truncate()).x;
            let on_row = (0.0..=w as f32).contains(&u);
            let (Some(f), Some(_), true) = (
                map.sample(p.truncate()),
                map.sample(dom.pixel(u, row_v)),
                on_row,
            ) else {
                sign = 0.0;
                continue;
            };
            let g = p.z - f;
            if sign == 0.0 && g.abs() > tol(p.truncate()) {
                sign = g.signum();
            }
            if q < 400 {
                assert!(
                    sign * g >= -tol(p.truncate()),
                    "the ray went {g} through the field before the SRDM's hit at t = {t_end} (tolerance {})",
                    tol(p.truncate())
                );
            }
        }
        if let Some(h) = hit {
            let f = map.sample(h.pixel).expect("the hit is over the object");
            assert!((h.depth - f).abs() <= tol(h.pixel), "{h:?}: field {f}");
        }
        if hit.is_some() == brute.is_some() {
            agree += 1;
        }
        if let (Some(h), Some(m)) = (hit, brute) {
            both += 1;
            rel.push((h.t - m.t).abs() / m.t);
        }
    }
    rel.sort_by(f32::total_cmp);
    assert!(total > 1500);
    assert!(
        agree as f64 >= 0.97 * total as f64,
        "{agree} of {total} agree on hit or miss"
    );
    // Where both hit, they agree on t to 0.6 % in the median here (the simplification error
    // and θ's quantization, through z = 1/(1/z)); a few grazing rays differ more.
    let median = rel[rel.len() / 2];
    assert!(
        median < 0.01,
        "median |Δt|/t {median} over {both} rays hit by both"
    );
}

#[test]
fn format_round_trips_and_refuses_bad_files() {
    let map = rough_map(40);
    let s = build(&map, 9, 7);
    let bytes = s.to_bytes();
    assert_eq!(bytes.len() as u64, Srdm::file_bytes(9, 40, 7));
    assert_eq!(&bytes[0..8], b"GLSRDM\r\n");
    assert_eq!(u16::from_le_bytes([bytes[8], bytes[9]]), SRDM_VERSION);
    assert_eq!(u32::from_le_bytes(bytes[12..16].try_into().unwrap()), 9);
    // Points start at byte 96: row (0, 0)'s first u.
    let back = Srdm::from_bytes(&bytes).unwrap();
    assert_eq!(back, s);
    assert_eq!(back.to_bytes(), bytes);

    let mut newer = bytes.clone();
    newer[8..10].copy_from_slice(&(SRDM_VERSION + 1).to_le_bytes());
    let e = Srdm::from_bytes(&newer).unwrap_err();
    assert!(matches!(
        e,
        SrdmError::NewerVersion {
            found: 2,
            supported: 1
        }
    ));
    assert!(
        e.to_string().contains('2') && e.to_string().contains('1'),
        "{e}"
    );
    let e = Srdm::from_bytes(&bytes[..bytes.len() - 1]).unwrap_err();
    assert!(matches!(e, SrdmError::Size { .. }), "{e}");
    let mut magic = bytes.clone();
    magic[0] = b'X';
    assert!(matches!(
        Srdm::from_bytes(&magic),
        Err(SrdmError::Magic { .. })
    ));
    let mut counts = bytes.clone();
    let last = counts.len() - 2;
    counts[last..].copy_from_slice(&100u16.to_le_bytes());
    let e = Srdm::from_bytes(&counts).unwrap_err();
    assert!(e.to_string().contains("more than m = 7"), "{e}");
    assert!(Srdm::from_bytes(&bytes[..50]).is_err());
}

#[test]
fn builds_are_identical_whatever_the_thread_count() {
    let map = rough_map(80);
    let bytes = |threads: usize| {
        rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap()
            .install(|| build(&map, 30, 12).to_bytes())
    };
    let one = bytes(1);
    assert_eq!(one, bytes(3));
    assert_eq!(one, bytes(8));
}

#[test]
fn bad_parameters_and_cancellation() {
    let map = smooth_map(16);
    let params = |domains, points| SrdmParams { domains, points };
    for (p, needle) in [
        (params(0, 8), "rotated domains"),
        (params(4, 1), "points per row"),
    ] {
        let e = Srdm::build(&map, camera(16), p, &Silent).unwrap_err();
        assert!(e.to_string().contains(needle), "{e}");
    }
    let e = Srdm::build(&map, camera(32), params(4, 8), &Silent).unwrap_err();
    assert!(e.to_string().contains("32×32"), "{e}");
    assert!(DepthMap::new(4, vec![0.5; 15]).is_err());
    assert!(DepthMap::new(2, vec![0.5, 1.5, 0.5, 0.5]).is_err());
    assert!(DepthMap::new(1, vec![0.5]).is_err());

    struct Stop;
    impl Progress for Stop {
        fn phase(&self, _: &str, _: u64) {}
        fn advance(&self, _: u64) {}
        fn cancelled(&self) -> bool {
            true
        }
    }
    let e = Srdm::build(&map, camera(16), params(4, 8), &Stop).unwrap_err();
    assert!(matches!(e, SrdmError::Cancelled(_)));
}

#[test]
fn camera_projection_round_trips_and_depth_is_normalized_inverse_z() {
    let cam = camera(100);
    assert_eq!(cam.depth_of_z(1.0), 1.0);
    assert_eq!(cam.depth_of_z(3.0), 0.0);
    assert!(
        (cam.depth_of_z(1.5) - 0.5).abs() < 1e-6,
        "1/z is what is normalized"
    );
    let p = cam.unproject(Vec2::new(12.25, 80.5), 0.3);
    let q = cam.project(p).unwrap();
    assert!(
        (q - Vec3::new(12.25, 80.5, 0.3)).abs().max_element() < 1e-4,
        "{q}"
    );
    // The texel ray through (12, 80) projects to its centre.
    let r = cam.project(cam.texel_ray(12, 80) * 2.0).unwrap();
    assert!((r.truncate() - Vec2::new(12.5, 80.5)).length() < 1e-4);
    // Clipping keeps exactly the part between hither and yon along the axis.
    let (t0, t1) = cam
        .clip(Vec3::new(0.0, 0.0, 1.0), -Vec3::Z, 0.0, 10.0)
        .unwrap();
    assert!((t0 - 2.0).abs() < 1e-6 && (t1 - 4.0).abs() < 1e-6);
    assert!(
        cam.clip(Vec3::new(0.0, 0.0, 1.0), Vec3::Z, 0.0, 10.0)
            .is_none()
    );
}

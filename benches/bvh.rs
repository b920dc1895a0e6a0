//! BVH benchmark: build time and closest-hit / occlusion rays per second, for camera rays and
//! for cosine-distributed rays leaving surfaces, on one thread (and on every core), compared
//! with Embree on the same rays in the same run when its driver is built.
//!
//! `cargo bench --bench bvh [-- SCENE.json]` (default: scenes/breakfast-room/scene.json).
//! Writes the triangles, both ray sets and glint's results to `target/bvh-rays/`. If
//! `target/bvh-rays/embree_rays` exists (`benches/embree/build.sh`), it is started on those
//! files and each of its passes is interleaved with one of glint's; the table then shows
//! Embree's rate, the ratio and whether both found the same hits. Figures are medians of
//! `RUNS` passes. Camera closest hits are also traced in packets of eight consecutive rays
//! (`Bvh::closest_hits`), against Embree's single rays and its `rtcIntersect8` on the same
//! packets, and checked bit for bit against glint's single rays.
//!
//! `-- --options` adds rows for the other layouts tried, each on the same rays in the same
//! run: obvhs' CWBVH as glint used it before (medium build, and the slow build with
//! pre-splits) and obvhs' BVH2, each with a Möller–Trumbore test on the stored vertices.

use std::io::{BufRead, BufReader, Write};
use std::path::{Path, PathBuf};
use std::process::{Child, ChildStdin, ChildStdout, Command, Stdio};
use std::time::Instant;

use glam::Vec3;
use glint::bundle::stats::format_table;
use glint::bundle::write_atomic;
use glint::camera::{Camera, pose_at};
use glint::geometry::Bvh;
use glint::sampling::{Rng, basis, sample_cosine_hemisphere, sample_triangle};
use glint::scene::Scene;
use obvhs::BvhBuildParams;
use rayon::prelude::*;

const CAMERA_W: u32 = 1024;
const CAMERA_H: u32 = 768;
const DIFFUSE_RAYS: usize = 786_432;
const RUNS: usize = 5;
/// Relative distance difference within which glint's and Embree's hits count as the same.
const SAME_T: f32 = 1e-4;

struct RaySet {
    name: &'static str,
    origins: Vec<Vec3>,
    dirs: Vec<Vec3>,
}

#[derive(Clone, Copy, PartialEq)]
enum Query {
    Closest,
    Occluded,
}

impl Query {
    fn name(self) -> &'static str {
        match self {
            Query::Closest => "closest",
            Query::Occluded => "occluded",
        }
    }
}

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

fn camera_rays(scene: &Scene) -> RaySet {
    let cam = match scene.camera_path(None) {
        Some(p) => pose_at(p, p.keyframes[0].time),
        None => {
            let c = scene.bounds.center();
            let eye = c + Vec3::new(0.0, 0.0, scene.bounds.diagonal());
            Camera::look_at(eye, c, Vec3::Y, 50f32.to_radians())
        }
    };
    let aspect = CAMERA_W as f32 / CAMERA_H as f32;
    let mut set = RaySet {
        name: "camera",
        origins: Vec::new(),
        dirs: Vec::new(),
    };
    for y in 0..CAMERA_H {
        for x in 0..CAMERA_W {
            set.origins.push(cam.position);
            set.dirs
                .push(cam.ray_direction(Camera::pixel_ndc(x, y, CAMERA_W, CAMERA_H), aspect));
        }
    }
    set
}

/// Rays from area-uniform surface points, cosine-distributed about the face normal.
fn diffuse_rays(scene: &Scene, bvh: &Bvh) -> RaySet {
    let mut cdf = Vec::with_capacity(scene.triangles.len());
    let mut total = 0.0f64;
    for t in &scene.triangles {
        total += t.area() as f64;
        cdf.push(total);
    }
    let mut rng = Rng::new(42, 0);
    let mut set = RaySet {
        name: "diffuse",
        origins: Vec::new(),
        dirs: Vec::new(),
    };
    for _ in 0..DIFFUSE_RAYS {
        let target = rng.uniform() as f64 * total;
        let i = cdf.partition_point(|&c| c <= target).min(cdf.len() - 1);
        let tri = &scene.triangles[i];
        let n = tri.face_normal();
        let p = tri.point(sample_triangle(rng.uniform2()));
        let (t, b) = basis(n);
        let l = sample_cosine_hemisphere(rng.uniform2());
        set.origins.push(bvh.offset_origin(p, n));
        set.dirs.push(t * l.x + b * l.y + n * l.z);
    }
    set
}

/// Per ray: the hit distance (closest) or 1 (occluded), +∞ for a miss.
fn results(bvh: &Bvh, rays: &RaySet, query: Query) -> Vec<f32> {
    (0..rays.dirs.len())
        .map(|i| {
            let (o, d) = (rays.origins[i], rays.dirs[i]);
            match query {
                Query::Closest => bvh
                    .closest_hit(o, d, f32::INFINITY)
                    .map_or(f32::INFINITY, |h| h.t),
                Query::Occluded => {
                    if bvh.occluded(o, d, f32::INFINITY) {
                        1.0
                    } else {
                        f32::INFINITY
                    }
                }
            }
        })
        .collect()
}

/// One pass of `hit` over `rays` (seconds, hits), on one thread or on rayon's pool.
fn pass(rays: &RaySet, hit: &(dyn Fn(Vec3, Vec3) -> bool + Sync), parallel: bool) -> (f64, usize) {
    let hit = |i: usize| hit(rays.origins[i], rays.dirs[i]);
    let start = Instant::now();
    let hits = if parallel {
        (0..rays.dirs.len())
            .into_par_iter()
            .with_min_len(4096)
            .filter(|&i| hit(i))
            .count()
    } else {
        (0..rays.dirs.len()).filter(|&i| hit(i)).count()
    };
    (start.elapsed().as_secs_f64(), std::hint::black_box(hits))
}

/// One pass of glint's packet traversal over `rays` ([`Bvh::closest_hits`]: packets of eight
/// consecutive rays, the set's order kept), on one thread (seconds, hits).
fn packet_pass(bvh: &Bvh, rays: &RaySet) -> (f64, usize) {
    let start = Instant::now();
    let mut hits = 0;
    bvh.closest_hits(&rays.origins, &rays.dirs, f32::INFINITY, |_, h| {
        hits += h.is_some() as usize
    });
    (start.elapsed().as_secs_f64(), std::hint::black_box(hits))
}

/// A ray caster under test: (closest-hit, occluded) per ray.
struct Engine<'a> {
    name: String,
    closest: Box<dyn Fn(Vec3, Vec3) -> bool + Sync + 'a>,
    occluded: Box<dyn Fn(Vec3, Vec3) -> bool + Sync + 'a>,
}

impl Engine<'_> {
    fn query(&self, query: Query) -> &(dyn Fn(Vec3, Vec3) -> bool + Sync + '_) {
        match query {
            Query::Closest => &*self.closest,
            Query::Occluded => &*self.occluded,
        }
    }
}

/// The other layouts measured with `--options`: obvhs' own BVHs and traversals.
mod options {
    use std::time::Duration;

    use glam::{Vec3, Vec3A};
    use obvhs::{
        BvhBuildParams,
        bvh2::{Bvh2, builder::build_bvh2_from_tris},
        cwbvh::{CwBvh, builder::build_cwbvh_from_tris},
        ray::{Ray, RayHit},
        triangle::Triangle,
    };

    /// obvhs' CWBVH node test culls children nearer than this absolute distance; the origin
    /// moves back past it (as glint's `Bvh` did while it used the CWBVH).
    const NODE_T_MIN: f32 = 1e-4;

    fn make_ray(origin: Vec3, dir: Vec3) -> Ray {
        let dir = dir + Vec3::ZERO;
        let back = 2.0 * NODE_T_MIN + origin.abs().max_element() * 16.0 * f32::EPSILON;
        Ray::new(
            (origin - dir * back).into(),
            dir.into(),
            back,
            f32::INFINITY,
        )
    }

    #[inline(always)]
    fn intersect(t: &Triangle, ray: &Ray) -> f32 {
        let e1 = t.v1 - t.v0;
        let e2 = t.v2 - t.v0;
        let pvec = ray.direction.cross(e2);
        let det = e1.dot(pvec);
        if det == 0.0 || !det.is_finite() {
            return f32::INFINITY;
        }
        let inv = 1.0 / det;
        let tvec = ray.origin - t.v0;
        let u = tvec.dot(pvec) * inv;
        if !(0.0..=1.0).contains(&u) {
            return f32::INFINITY;
        }
        let qvec = tvec.cross(e1);
        let v = ray.direction.dot(qvec) * inv;
        if v < 0.0 || u + v > 1.0 {
            return f32::INFINITY;
        }
        let d = e2.dot(qvec) * inv;
        if d > ray.tmin && d <= ray.tmax {
            d
        } else {
            f32::INFINITY
        }
    }

    pub fn triangles(scene: &glint::scene::Scene) -> Vec<Triangle> {
        scene
            .triangles
            .iter()
            .map(|t| Triangle {
                v0: Vec3A::from(t.p[0]),
                v1: Vec3A::from(t.p[1]),
                v2: Vec3A::from(t.p[2]),
            })
            .collect()
    }

    pub struct Cw {
        bvh: CwBvh,
        ordered: Vec<Triangle>,
    }

    impl Cw {
        pub fn build(tris: &[Triangle], params: BvhBuildParams) -> Cw {
            let bvh = build_cwbvh_from_tris(tris, params, &mut Duration::default());
            let ordered = bvh
                .primitive_indices
                .iter()
                .map(|&i| tris[i as usize])
                .collect();
            Cw { bvh, ordered }
        }

        pub fn closest(&self, o: Vec3, d: Vec3) -> bool {
            let mut hit = RayHit::none();
            self.bvh.ray_traverse(make_ray(o, d), &mut hit, |r, id| {
                intersect(&self.ordered[id], r)
            })
        }

        pub fn occluded(&self, o: Vec3, d: Vec3) -> bool {
            !self
                .bvh
                .ray_traverse_miss(make_ray(o, d), |r, id| intersect(&self.ordered[id], r))
        }
    }

    pub struct Two {
        bvh: Bvh2,
        ordered: Vec<Triangle>,
    }

    impl Two {
        pub fn build(tris: &[Triangle], params: BvhBuildParams) -> Two {
            let bvh = build_bvh2_from_tris(tris, params, &mut Duration::default());
            let ordered = bvh
                .primitive_indices
                .iter()
                .map(|&i| tris[i as usize])
                .collect();
            Two { bvh, ordered }
        }

        fn ray(o: Vec3, d: Vec3) -> Ray {
            Ray::new(o.into(), (d + Vec3::ZERO).into(), 0.0, f32::INFINITY)
        }

        pub fn closest(&self, o: Vec3, d: Vec3) -> bool {
            let mut hit = RayHit::none();
            self.bvh.ray_traverse(Two::ray(o, d), &mut hit, |r, id| {
                intersect(&self.ordered[id], r)
            })
        }

        pub fn occluded(&self, o: Vec3, d: Vec3) -> bool {
            !self
                .bvh
                .ray_traverse_miss(Two::ray(o, d), |r, id| intersect(&self.ordered[id], r))
        }
    }
}

fn f32_bytes(values: impl IntoIterator<Item = f32>) -> Vec<u8> {
    values.into_iter().flat_map(f32::to_le_bytes).collect()
}

fn write(path: &Path, bytes: &[u8]) {
    if let Err(e) = write_atomic(path, bytes) {
        eprintln!("error: writing {}: {e}", path.display());
        std::process::exit(1);
    }
}

/// The Embree driver (`benches/embree/embree_rays.c`) running on the files in the ray folder.
struct Embree {
    child: Child,
    stdin: ChildStdin,
    stdout: BufReader<ChildStdout>,
    build_ms: f64,
}

impl Embree {
    fn start(dir: &Path) -> Option<Embree> {
        let exe = dir.join("embree_rays");
        if !exe.is_file() {
            return None;
        }
        let mut child = Command::new(&exe)
            .arg(dir)
            .stdin(Stdio::piped())
            .stdout(Stdio::piped())
            .spawn()
            .map_err(|e| eprintln!("warning: cannot start {}: {e}", exe.display()))
            .ok()?;
        let stdin = child.stdin.take()?;
        let mut stdout = BufReader::new(child.stdout.take()?);
        let mut line = String::new();
        stdout.read_line(&mut line).ok()?;
        let build_ms = match line.split_whitespace().collect::<Vec<_>>()[..] {
            ["ready", ms, _] => ms.parse().ok()?,
            _ => {
                eprintln!(
                    "warning: {} answered {line:?}, expected `ready MS N`",
                    exe.display()
                );
                return None;
            }
        };
        Some(Embree {
            child,
            stdin,
            stdout,
            build_ms,
        })
    }

    /// One pass of Embree over the set (seconds, hits): `query` is `closest`, `occluded` or
    /// `closest8` (`rtcIntersect8` on packets of eight consecutive rays).
    fn pass(&mut self, set: &str, query: &str) -> (f64, usize) {
        writeln!(self.stdin, "{set} {query}").expect("embree_rays: stdin closed");
        let mut line = String::new();
        self.stdout
            .read_line(&mut line)
            .expect("embree_rays: stdout closed");
        let mut it = line.split_whitespace();
        let parsed = (|| Some((it.next()?.parse().ok()?, it.next()?.parse().ok()?)))();
        parsed.unwrap_or_else(|| panic!("embree_rays answered {line:?}, expected `SECONDS HITS`"))
    }
}

impl Drop for Embree {
    fn drop(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}

/// How glint's and Embree's results for one set and query compare.
struct Agreement {
    rays: usize,
    glint_hits: usize,
    embree_hits: usize,
    /// Rays one hits and the other does not, or (closest) whose distances differ by more than
    /// `SAME_T` relative.
    differ: usize,
}

fn agreement(glint: &[f32], embree_file: &Path) -> Option<Agreement> {
    let bytes = std::fs::read(embree_file).ok()?;
    let embree: Vec<f32> = bytes
        .chunks_exact(4)
        .take(glint.len())
        .map(|b| f32::from_le_bytes(b.try_into().unwrap()))
        .collect();
    if embree.len() != glint.len() {
        return None;
    }
    let mut a = Agreement {
        rays: glint.len(),
        glint_hits: 0,
        embree_hits: 0,
        differ: 0,
    };
    for (&g, &e) in glint.iter().zip(&embree) {
        a.glint_hits += g.is_finite() as usize;
        a.embree_hits += e.is_finite() as usize;
        let same = match (g.is_finite(), e.is_finite()) {
            (true, true) => (g - e).abs() <= SAME_T * e.abs().max(g.abs()),
            (false, false) => true,
            _ => false,
        };
        a.differ += !same as usize;
    }
    Some(a)
}

fn main() {
    glint::cli::init_logging();
    let path = std::env::args()
        .skip(1)
        .find(|a| !a.starts_with("--"))
        .unwrap_or_else(|| "scenes/breakfast-room/scene.json".into());
    let t = Instant::now();
    let scene = match Scene::load(&path) {
        Ok(s) => s,
        Err(e) => {
            eprintln!("error: {e}");
            std::process::exit(1);
        }
    };
    let load_s = t.elapsed().as_secs_f64();

    let builds: Vec<f64> = (0..RUNS)
        .map(|_| {
            let t = Instant::now();
            let bvh = Bvh::build(&scene.triangles);
            std::hint::black_box(&bvh);
            t.elapsed().as_secs_f64() * 1e3
        })
        .collect();
    // Without the scene's cut-out filter: Embree is given the bare triangles too.
    let bvh = Bvh::build(&scene.triangles);
    let threads = rayon::current_num_threads();
    let sets = [camera_rays(&scene), diffuse_rays(&scene, &bvh)];

    let dir = PathBuf::from(concat!(env!("CARGO_MANIFEST_DIR"), "/target/bvh-rays"));
    if let Err(e) = std::fs::create_dir_all(&dir) {
        eprintln!("error: creating {}: {e}", dir.display());
        std::process::exit(1);
    }
    write(
        &dir.join("triangles.f32"),
        &f32_bytes(
            scene
                .triangles
                .iter()
                .flat_map(|t| t.p)
                .flat_map(|p| p.to_array()),
        ),
    );
    for s in &sets {
        let rays = s.origins.iter().zip(&s.dirs);
        write(
            &dir.join(format!("{}.rays", s.name)),
            &f32_bytes(rays.flat_map(|(o, d)| [o.x, o.y, o.z, d.x, d.y, d.z])),
        );
    }
    let mut embree = Embree::start(&dir);

    println!(
        "BVH benchmark: {} ({} triangles{}), scene load {:.2} s, BVH build median {:.1} ms ({} threads){}, medians of {RUNS} passes",
        scene.name,
        scene.triangles.len(),
        if scene.cutout_filter().is_some() {
            ", measured without its cut-out filter"
        } else {
            ""
        },
        load_s,
        median(builds),
        threads,
        match &embree {
            Some(e) => format!(", Embree build {:.1} ms (1 thread)", e.build_ms),
            None => String::new(),
        }
    );
    if embree.is_none() {
        println!(
            "(no Embree comparison: run benches/embree/build.sh to build {}/embree_rays)",
            dir.display()
        );
    }
    println!();

    let options = std::env::args().any(|a| a == "--options");
    let others = options.then(|| {
        let tris = options::triangles(&scene);
        (
            options::Cw::build(&tris, BvhBuildParams::medium_build()),
            options::Cw::build(&tris, BvhBuildParams::very_slow_build()),
            options::Two::build(&tris, BvhBuildParams::medium_build()),
        )
    });
    let mut engines = vec![Engine {
        name: "glint".into(),
        closest: Box::new(|o, d| bvh.closest_hit(o, d, f32::INFINITY).is_some()),
        occluded: Box::new(|o, d| bvh.occluded(o, d, f32::INFINITY)),
    }];
    if let Some((cw, cw_split, two)) = &others {
        engines.push(Engine {
            name: "obvhs CWBVH medium".into(),
            closest: Box::new(|o, d| cw.closest(o, d)),
            occluded: Box::new(|o, d| cw.occluded(o, d)),
        });
        engines.push(Engine {
            name: "obvhs CWBVH very slow, pre-split".into(),
            closest: Box::new(|o, d| cw_split.closest(o, d)),
            occluded: Box::new(|o, d| cw_split.occluded(o, d)),
        });
        engines.push(Engine {
            name: "obvhs BVH2 medium".into(),
            closest: Box::new(|o, d| two.closest(o, d)),
            occluded: Box::new(|o, d| two.occluded(o, d)),
        });
    }

    let mut rows = vec![[
        "rays".to_string(),
        "query".to_string(),
        "BVH".to_string(),
        "Mrays/s".to_string(),
        "Embree Mrays/s".to_string(),
        "÷ Embree".to_string(),
        format!("{threads} threads"),
        "hit fraction".to_string(),
        "hits differ from Embree".to_string(),
    ]];
    for set in &sets {
        for query in [Query::Closest, Query::Occluded] {
            let n = set.dirs.len() as f64;
            let mine = results(&bvh, set, query);
            let file = format!("{}-{}.f32", set.name, query.name());
            write(
                &dir.join(format!("glint-{file}")),
                &f32_bytes(mine.iter().copied()),
            );
            // Interleaved: one pass of each per run, so all see the same machine load.
            let mut ours = vec![Vec::new(); engines.len()];
            let mut theirs = Vec::new();
            // Camera closest hits: also glint's packets and Embree's (rtcIntersect8), the
            // ratios taken pass by pass against Embree's single rays and packets.
            let packets = set.name == "camera" && query == Query::Closest;
            let (mut packet_rates, mut vs_single, mut vs_packets) =
                (Vec::new(), Vec::new(), Vec::new());
            let mut theirs8 = Vec::new();
            for _ in 0..RUNS {
                for (e, rates) in engines.iter().zip(&mut ours) {
                    rates.push(n / pass(set, e.query(query), false).0 / 1e6);
                }
                if packets {
                    packet_rates.push(n / packet_pass(&bvh, set).0 / 1e6);
                }
                if let Some(e) = embree.as_mut() {
                    theirs.push(n / e.pass(set.name, query.name()).0 / 1e6);
                    if packets {
                        theirs8.push(n / e.pass(set.name, "closest8").0 / 1e6);
                        let k = theirs.len() - 1;
                        vs_single.push(packet_rates[k] / theirs[k]);
                        vs_packets.push(packet_rates[k] / theirs8[k]);
                    }
                }
            }
            let packet_rows = packets.then(|| {
                // The packets' hits against single rays': the same triangle and distance bits.
                let mut single = Vec::with_capacity(set.dirs.len());
                for i in 0..set.dirs.len() {
                    single.push(bvh.closest_hit(set.origins[i], set.dirs[i], f32::INFINITY));
                }
                let mut differ = 0;
                bvh.closest_hits(&set.origins, &set.dirs, f32::INFINITY, |i, h| {
                    let bits = |h: Option<glint::geometry::Hit>| {
                        h.map(|h| {
                            (
                                h.triangle,
                                h.t.to_bits(),
                                h.bary.to_array().map(f32::to_bits),
                            )
                        })
                    };
                    differ += (bits(h) != bits(single[i])) as usize;
                });
                let rate = median(packet_rates.clone());
                let name = |against: &str| format!("glint, packets of 8 (÷ Embree {against})");
                let embree_col = |r: &[f64]| (!r.is_empty()).then(|| median(r.to_vec()));
                let (e1, e8) = (embree_col(&theirs), embree_col(&theirs8));
                let r1 = (!vs_single.is_empty()).then(|| median(vs_single.clone()));
                let r8 = (!vs_packets.is_empty()).then(|| median(vs_packets.clone()));
                let agree8 = embree.as_ref().and_then(|_| {
                    agreement(
                        &mine,
                        &dir.join(format!("embree-{}-closest8.f32", set.name)),
                    )
                });
                let fmt = |x: Option<f64>| x.map_or("-".into(), |x| format!("{x:.2}"));
                [
                    [
                        format!("{} ({})", set.name, set.dirs.len()),
                        query.name().to_string(),
                        name("1 ray"),
                        format!("{rate:.2}"),
                        fmt(e1),
                        fmt(r1),
                        "-".into(),
                        "-".into(),
                        format!(
                            "{differ} of {} differ from glint's single rays",
                            set.dirs.len()
                        ),
                    ],
                    [
                        format!("{} ({})", set.name, set.dirs.len()),
                        query.name().to_string(),
                        name("rtcIntersect8"),
                        format!("{rate:.2}"),
                        fmt(e8),
                        fmt(r8),
                        "-".into(),
                        "-".into(),
                        match agree8 {
                            Some(a) => format!(
                                "{} of {} (hits {} vs {})",
                                a.differ, a.rays, a.glint_hits, a.embree_hits
                            ),
                            None => "-".into(),
                        },
                    ],
                ]
            });
            let theirs = (!theirs.is_empty()).then(|| median(theirs));
            let agree = embree
                .as_ref()
                .and_then(|_| agreement(&mine, &dir.join(format!("embree-{file}"))));
            let hits = mine.iter().filter(|t| t.is_finite()).count();
            for (k, (e, rates)) in engines.iter().zip(ours).enumerate() {
                let rate = median(rates);
                let parallel = (k == 0).then(|| {
                    let rates = (0..RUNS)
                        .map(|_| n / pass(set, e.query(query), true).0 / 1e6)
                        .collect();
                    format!("{:.2}", median(rates))
                });
                rows.push([
                    format!("{} ({})", set.name, set.dirs.len()),
                    query.name().to_string(),
                    e.name.clone(),
                    format!("{rate:.2}"),
                    theirs.map_or("-".into(), |t| format!("{t:.2}")),
                    theirs.map_or("-".into(), |t| format!("{:.2}", rate / t)),
                    parallel.unwrap_or_else(|| "-".into()),
                    if k == 0 {
                        format!("{:.3}", hits as f64 / n)
                    } else {
                        "-".into()
                    },
                    match (&agree, k) {
                        (Some(a), 0) => format!(
                            "{} of {} (hits {} vs {})",
                            a.differ, a.rays, a.glint_hits, a.embree_hits
                        ),
                        _ => "-".to_string(),
                    },
                ]);
            }
            rows.extend(packet_rows.into_iter().flatten());
        }
    }
    print!(
        "{}",
        format_table(
            &rows,
            &[false, false, false, true, true, true, true, true, true]
        )
    );
}

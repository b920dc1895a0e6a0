//! Radiance maps per shipped scene: maps, rays per second, bake time and bytes per reflector,
//! beside Bastos et al. Table 1's memory figures; and the storage trade of EXR precision and
//! compression on one reflector's maps.
//!
//! `cargo bench --bench radiance [-- SCENE.json ...]` (default: every shipped scene with a
//! glossy planar reflector). Radiosity is baked at draft quality first, into target/.

use std::time::Instant;

use glint::bake::radiance_stage::{self, encode_map};
use glint::bundle::Bundle;
use glint::bundle::stats::{format_table, human_bytes};
use glint::image_io::{ExrCompression, Precision};
use glint::progress::Silent;
use glint::radiance::footprint::PixelRays;
use glint::radiance::quadtree;
use glint::radiance::reads::PixelWriter;
use glint::radiance::render;
use glint::radiance::sampling::{MapCamera, hemisphere_cameras};
use glint::radiosity::RadiosityMap;
use glint::scene::desc::RadiositySettings;
use glint::scene::{Quality, Scene};

fn main() {
    glint::cli::init_logging();
    let mut scenes: Vec<String> = std::env::args()
        .skip(1)
        .filter(|a| !a.starts_with("--"))
        .collect();
    if scenes.is_empty() {
        scenes = ["glossy-room", "breakfast-room", "bunny-mirror"]
            .iter()
            .map(|s| format!("scenes/{s}/scene.json"))
            .collect();
    }
    let mut rows = vec![
        [
            "scene",
            "reflector",
            "hemispheres",
            "maps/hemi",
            "resolution",
            "maps",
            "bake s",
            "Mrays/s",
            "bytes",
            "bytes/map",
        ]
        .map(String::from),
    ];
    let mut trade = vec![
        [
            "scene / reflector",
            "depth",
            "compression",
            "bytes/map",
            "vs half+float ZIP",
        ]
        .map(String::from),
    ];
    for path in &scenes {
        let scene = Scene::load(path).unwrap_or_else(|e| panic!("{e}"));
        let out = std::path::PathBuf::from(format!("target/bench-radiance/{}.glint", scene.name));
        let _ = std::fs::remove_dir_all(&out);
        glint::bake::radiosity_stage::bake(
            &scene,
            &out,
            &RadiositySettings::preset(Quality::Draft),
            true,
            &Silent,
        )
        .unwrap();
        let bundle = Bundle::open(&out).unwrap();
        let d = RadiosityMap::load(&bundle).unwrap().unwrap();
        let bvh = scene.build_bvh();
        let d_at =
            |h: &glint::geometry::Hit, _back: bool| glint::radiance::shading::d_point(&scene, h);
        let stored = |t: u32, b: glam::Vec2| d.radiance(t, b);
        let shade =
            |h: &glint::geometry::Hit, dir: glam::Vec3, _: &PixelRays, out: &mut PixelWriter| {
                glint::radiance::shading::exitant(&scene, &bvh, &d_at, &d_at, h, dir, out)
            };
        let limits = radiance_stage::quadtree_limits(&scene);
        for (ri, frame, plan) in radiance_stage::plans(&scene, Quality::Default) {
            let t = Instant::now();
            let (mut bytes, mut maps, mut sample) = (0u64, 0u64, None);
            for j in 0..plan.elements[1] {
                for i in 0..plan.elements[0] {
                    let (corner, eu, ev) = frame.element(i, j, plan.elements[0], plan.elements[1]);
                    for c in hemisphere_cameras(corner, eu, ev, frame.normal, plan.cameras) {
                        let cam = MapCamera {
                            centre: c,
                            corner,
                            edge_u: eu,
                            edge_v: ev,
                            normal: frame.normal,
                            resolution: plan.resolution,
                        };
                        let map = render(
                            &cam,
                            &bvh,
                            &scene.triangles,
                            4.0 * bvh.epsilon(),
                            &shade,
                            &stored,
                            None,
                        )
                        .map;
                        let exr = encode_map(
                            plan.resolution,
                            &map,
                            ExrCompression::Zip16,
                            Precision::Float,
                        )
                        .unwrap();
                        let qt = quadtree::encode(
                            plan.resolution,
                            &quadtree::build(
                                plan.resolution,
                                &map.points,
                                &map.depth,
                                &map.hit,
                                &limits,
                            ),
                        );
                        bytes += (exr.len() + qt.len()) as u64;
                        maps += 1;
                        sample.get_or_insert(map);
                    }
                }
            }
            let secs = t.elapsed().as_secs_f64();
            let rays = maps as f64 * (plan.resolution * plan.resolution) as f64;
            let name = scene.reflectors[ri].name.clone();
            rows.push([
                scene.name.clone(),
                name.clone(),
                (plan.elements[0] * plan.elements[1]).to_string(),
                plan.cameras.to_string(),
                format!("{0}x{0}", plan.resolution),
                maps.to_string(),
                format!("{secs:.2}"),
                format!("{:.2}", rays / secs / 1e6),
                human_bytes(bytes),
                human_bytes(bytes / maps),
            ]);
            let map = sample.unwrap();
            let base = encode_map(
                plan.resolution,
                &map,
                ExrCompression::Zip16,
                Precision::Float,
            )
            .unwrap()
            .len() as f64;
            for (depth, dn) in [(Precision::Float, "float"), (Precision::Half, "half")] {
                for (comp, cn) in [
                    (ExrCompression::None, "none"),
                    (ExrCompression::Zip16, "ZIP16"),
                    (ExrCompression::Piz, "PIZ"),
                ] {
                    let n = encode_map(plan.resolution, &map, comp, depth)
                        .unwrap()
                        .len();
                    trade.push([
                        format!("{} / {name}", scene.name),
                        dn.into(),
                        cn.into(),
                        human_bytes(n as u64),
                        format!("{:.2}", n as f64 / base),
                    ]);
                }
            }
        }
    }
    println!(
        "Radiance maps at the default preset ({} threads); bytes include EXR (RGB half + A half + Z float, ZIP16) and quadtree\n",
        rayon::current_num_threads()
    );
    print!(
        "{}",
        format_table(
            &rows,
            &[false, false, true, true, true, true, true, true, true, true]
        )
    );
    println!(
        "\nBastos et al. Table 1 (SGI Onyx2, 1999): piano top 1 × 23 maps 128² = 2.54 MB (110 KB/map); living floor 12 × 6 × 128² = 7.98 MB;"
    );
    println!(
        "door mirrors 11 × 17 × 128² = 20.69 MB; music floor 8 × 7 × 128² = 6.21 MB; bench top 1 × 67 × 32² = 0.57 MB (8.5 KB/map)\n"
    );
    println!("Storage trade for one map per reflector (RGB and A half; depth as given):\n");
    print!(
        "{}",
        format_table(&trade, &[false, false, false, true, true])
    );
}

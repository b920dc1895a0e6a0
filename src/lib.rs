//! glint: precompute toolchain and viewer for globally illuminated walkthroughs with glossy
//! reflections.
//!
//! The library holds everything; each binary in `bin/` is a thin command line over it.
//! - [`scene`]: scene.json + glTF, validated; materials; camera paths.
//! - [`settings`]: each bake stage's settings, defined once (the layering is in its docs).
//! - [`geometry`]: world-space triangles and BVH ray casting (obvhs).
//! - [`bundle`]: the versioned asset bundle (`NAME.glint/`) and its manifest.
//! - [`fuzz`]: fuzz targets for every loader and the loop that drives them.
//! - [`view`]: the wgpu viewer (feature `view`); its [`view::options`] are always built.
//!
//! A program that reads or bakes bundles depends on this crate without the viewer
//! (`glint = { path = "…", default-features = false }`). Its entry points:
//!
//! # Reading a bundle
//!
//! [`Bundle::open`](bundle::Bundle::open) reads and checks the manifest and holds the stage
//! folders it names for as long as the [`Bundle`](bundle::Bundle) lives, so a concurrent bake
//! never removes what is being read. Each stage has a typed reader that hash-checks what it
//! reads and returns `Ok(None)` when the bundle lacks the stage:
//!
//! | stage | reader | gives |
//! |---|---|---|
//! | `scene` | [`Bundle::load_scene`](bundle::Bundle::load_scene) | the [`Scene`](scene::Scene): triangles, materials, cameras |
//! | `radiosity` | [`RadiosityMap::load`](radiosity::RadiosityMap::load) | D, the lightmap atlas and its pages |
//! | `materials` | [`MaterialsIndex::load`](materials::index::MaterialsIndex::load) | kernels K, reflectance R, environment maps |
//! | `radiance` | [`load_cameras`](radiance::index::load_cameras), [`read_map`](radiance::index::read_map) | radiance maps with depth, per reflector |
//! | `srdm` | [`srdm::index::load`] | the impostors' depth maps |
//!
//! D at a world point, as `glint-eval probe` reads it (`examples/sample_d.rs` is the whole
//! program; `examples/bundle_stats.rs` lists a bundle's stages and assets):
//!
//! ```no_run
//! use glint::bundle::Bundle;
//! use glint::eval::probe::{self, ProbePoint};
//! use glint::radiosity::RadiosityMap;
//!
//! # fn main() -> Result<(), Box<dyn std::error::Error>> {
//! let bundle = Bundle::open("out/cornell-box.glint")?;
//! let scene = bundle.load_scene()?;
//! let d = RadiosityMap::load(&bundle)?.ok_or("no radiosity stage")?;
//! let floor = ProbePoint { name: None, position: [0.0, 0.0, 0.0], normal: [0.0, 1.0, 0.0] };
//! let reach = probe::default_reach(&scene);
//! let values = probe::probe(&scene, &scene.build_bvh(), &d, &[floor], reach)?;
//! println!("D = {:?}", values[0].radiance);
//! # Ok(())
//! # }
//! ```
//!
//! # Baking
//!
//! [`bake_all`](bake::bake_all) bakes every stage a [`Scene`](scene::Scene) needs, in
//! dependency order, leaving stages already up to date alone: what `glint-bake` runs.
//! [`BakeSettings::resolve`](bake::BakeSettings::resolve) applies the scene's overrides to a
//! preset; [`progress::Silent`] reports nothing.
//!
//! ```no_run
//! use glint::bake::{BakeSettings, bake_all};
//! use glint::progress::Silent;
//! use glint::scene::{Quality, Scene};
//!
//! # fn main() -> Result<(), Box<dyn std::error::Error>> {
//! let scene = Scene::load("scenes/cornell-box/scene.json")?;
//! let settings = BakeSettings::resolve(&scene, Quality::Draft)?;
//! for stage in bake_all(&scene, "out/cornell-box.glint".as_ref(), &settings, false, &Silent)? {
//!     println!("{}: {}", stage.plan.stage.name(), stage.status);
//! }
//! # Ok(())
//! # }
//! ```
//!
//! # In a build script
//!
//! [`bake_in_build_script`](bake::build_script::bake_in_build_script) bakes from a Cargo
//! `build.rs` and tells Cargo to run the script again only when one of the scene's files
//! changes; README's "Bake in build.rs" section is the recipe, this `build.rs` its heart:
//!
//! ```rust,no_run
//! // build.rs: bakes scenes/room into OUT_DIR; the program reads it at
//! // concat!(env!("OUT_DIR"), "/room.glint").
//! fn main() {
//!     let out = std::path::PathBuf::from(std::env::var_os("OUT_DIR").unwrap());
//!     let baked = glint::bake::build_script::bake_in_build_script(
//!         "scenes/room/scene.json",
//!         out.join("room.glint"),
//!         glint::scene::Quality::Draft,
//!     );
//!     if let Err(e) = baked {
//!         // A failed build script fails the build; Cargo shows what it printed.
//!         eprintln!("error: {e}");
//!         std::process::exit(1);
//!     }
//! }
//! ```

// The build-script example above is a whole build.rs: its `fn main` is the point.
#![allow(clippy::needless_doctest_main)]

pub mod bake;
pub mod brdf;
pub mod bundle;
pub mod camera;
pub mod cli;
pub mod colour;
pub mod eval;
pub mod export;
pub mod fuzz;
pub mod geometry;
pub mod image_io;
pub mod lossy_path;
pub mod materials;
pub mod out_dir;
pub mod progress;
pub mod radiance;
pub mod radiosity;
pub mod sampling;
pub mod scene;
pub mod settings;
pub mod srdm;

pub mod view;

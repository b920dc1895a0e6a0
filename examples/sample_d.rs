//! Reads D, the baked exitant radiance, at a world point, as `glint-eval probe` does: the
//! scene and D come out of the bundle through their typed readers, and the library's probe
//! finds the surface under the point and looks D up there.
//!
//! ```sh
//! cargo run --example sample_d -- out/cornell-box.glint 0 0 0 0 1 0
//! ```
//!
//! Arguments: the bundle, the point (metres) and the normal of the surface there (pointing
//! away from it, any length). Prints `D R G B (triangle T, offset O m)`: linear RGB in W/(sr·m²),
//! the triangle found in scene order and the point's distance above it. Exit code 2 on a wrong
//! command line, 1 when the bundle cannot be read or no surface lies within reach.

use std::error::Error;
use std::path::Path;
use std::process::ExitCode;

use glint::bundle::Bundle;
use glint::eval::probe::{self, ProbePoint};
use glint::radiosity::RadiosityMap;

fn main() -> ExitCode {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let numbers: Option<Vec<f32>> = args.iter().skip(1).map(|a| a.parse().ok()).collect();
    let (Some(bundle), Some(numbers)) = (args.first(), numbers) else {
        return usage();
    };
    let [x, y, z, nx, ny, nz] = numbers[..] else {
        return usage();
    };
    let point = ProbePoint {
        name: None,
        position: [x, y, z],
        normal: [nx, ny, nz],
    };
    match sample(Path::new(bundle), point) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {e}");
            ExitCode::FAILURE
        }
    }
}

fn usage() -> ExitCode {
    eprintln!("usage: sample_d BUNDLE X Y Z NX NY NZ");
    ExitCode::from(2)
}

fn sample(dir: &Path, point: ProbePoint) -> Result<(), Box<dyn Error>> {
    let bundle = Bundle::open(dir)?;
    let scene = bundle.load_scene()?;
    let map = RadiosityMap::load(&bundle)?.ok_or_else(|| {
        format!(
            "{}: no radiosity stage (bake it with glint-bake)",
            dir.display()
        )
    })?;
    let bvh = scene.build_bvh();
    let reach = probe::default_reach(&scene);
    let values = probe::probe(&scene, &bvh, &map, &[point], reach)?;
    let value = &values[0];
    let (Some(triangle), Some(offset)) = (value.triangle, value.offset) else {
        return Err(format!("no surface within {reach} m of the point, facing its normal").into());
    };
    let [r, g, b] = value.radiance;
    println!("D {r} {g} {b} (triangle {triangle}, offset {offset} m)");
    Ok(())
}

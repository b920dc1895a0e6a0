//! Export a bundle's scene with its baked light as glTF lightmaps, from a program:
//!
//! ```sh
//! cargo run --example export_lightmaps -- out/glossy-room.glint out/glossy-room.glb [MAX_PAGE]
//! ```
//!
//! What `glint-bundle export` does, through the library: [`glint::export::export`] reads the
//! bundle's scene and radiosity stages and writes the .glb; the report says how to decode the
//! lightmaps (`scale`, the encoding) and the exposure glint-view uses. The formula an engine
//! needs is in docs/export.md.

use std::path::PathBuf;
use std::process::ExitCode;

use glint::export::lightmap::LightmapFormat;
use glint::export::{ExportOptions, export};

fn main() -> ExitCode {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let (Some(bundle), Some(out)) = (args.first(), args.get(1)) else {
        eprintln!("usage: export_lightmaps BUNDLE.glint OUT.glb [MAX_PAGE]");
        return ExitCode::from(2);
    };
    let max_page = match args.get(2).map(|s| s.parse::<u32>()) {
        None => 0,
        Some(Ok(n)) => n,
        Some(Err(e)) => {
            eprintln!("MAX_PAGE {:?}: {e}", args[2]);
            return ExitCode::from(2);
        }
    };
    let options = ExportOptions {
        max_page,
        format: LightmapFormat::Rgbd,
    };
    match export(&PathBuf::from(bundle), &PathBuf::from(out), &options) {
        Ok(r) => {
            println!(
                "{}: {} triangles, {} bytes",
                r.out.display(),
                r.triangles,
                r.bytes
            );
            for (i, (w, h)) in r.pages.iter().enumerate() {
                println!("  lightmap page {i}: {w}×{h}");
            }
            println!(
                "  L = {} × decode_{}(texel); frame = sRGB(PBR_Neutral(2^{:.3} × (baseColor·L + emissive)))",
                r.scale, r.encoding, r.exposure_ev
            );
            ExitCode::SUCCESS
        }
        Err(e) => {
            eprintln!("error: {e}");
            ExitCode::FAILURE
        }
    }
}

//! The materials stage's outputs the curved passes read: a reflector's baked MIP pyramid
//! and the patterns' ξ₀.

use glam::Vec3;

use super::super::DEFAULT_XI0;
use crate::bake::materials::envmap::{CubeMap, MipPyramid};
use crate::view::load::ViewData;

/// Reads the baked MIP pyramid of `reflector` from the bundle's materials stage, if any.
pub fn load_baked_pyramid(data: &ViewData, reflector: &str) -> Result<Option<MipPyramid>, String> {
    if data.bundle.stage("materials").is_none() {
        return Ok(None);
    }
    let dir = data.bundle.dir().join("materials");
    let index: serde_json::Value = std::fs::read(dir.join("index.json"))
        .map_err(|e| e.to_string())
        .and_then(|b| serde_json::from_slice(&b).map_err(|e| e.to_string()))
        .map_err(|e| format!("materials/index.json: {e}"))?;
    let Some(entry) = index["env_maps"]
        .as_array()
        .and_then(|a| a.iter().find(|e| e["reflector"] == reflector))
    else {
        return Ok(None);
    };
    let mut levels = Vec::new();
    for path in entry["levels"].as_array().into_iter().flatten() {
        let path = path.as_str().ok_or("env map level is not a path")?;
        let bytes = std::fs::read(dir.join(path)).map_err(|e| format!("{path}: {e}"))?;
        let image = crate::image_io::decode_exr(&bytes).map_err(|e| format!("{path}: {e}"))?;
        let n = image.height;
        if image.width != 6 * n || n == 0 {
            return Err(format!(
                "{path}: {}×{n} is not a strip of six faces",
                image.width
            ));
        }
        let ch = |c: &str| image.channel(c).map_err(|e| format!("{path}: {e}"));
        let (r, g, b) = (ch("R")?, ch("G")?, ch("B")?);
        let mut map = CubeMap::new(n);
        for face in 0..6 {
            for y in 0..n {
                for x in 0..n {
                    let s = y * 6 * n + face * n + x; // the strip: faces side by side
                    let i = map.index(face, x, y);
                    map.texels[i] = Vec3::new(r[s], g[s], b[s]);
                }
            }
        }
        levels.push(map);
    }
    if levels.is_empty() || !levels[0].size.is_power_of_two() {
        return Err(format!("env maps of {reflector}: no power-of-two level 0"));
    }
    let filter = crate::bake::materials::envmap::MipFilter::Box2; // only recorded, not used
    Ok(Some(MipPyramid { filter, levels }))
}

/// ξ₀ of the bundle's materials stage (its patterns' threshold), else [`DEFAULT_XI0`].
pub(super) fn baked_xi0(data: &ViewData) -> f32 {
    let index = data.bundle.dir().join("materials").join("index.json");
    std::fs::read(index)
        .ok()
        .and_then(|b| serde_json::from_slice::<serde_json::Value>(&b).ok())
        .and_then(|v| v["settings"]["xi0"].as_f64())
        .map_or(DEFAULT_XI0, |v| v as f32)
}

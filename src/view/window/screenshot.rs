//! Window screenshots: the frame just drawn, read back from the surface (so the file shows
//! exactly what the window showed), or the same passes rendered offscreen where the surface
//! cannot be copied.

use std::path::{Path, PathBuf};

use super::{Running, WindowError, next_free_name};
use crate::camera::Camera;
use crate::image_io;
use crate::view::gpu::readback::read_texture;
use crate::view::headless::{Offscreen, rgba_to_rgb};
use crate::view::load::ViewData;

/// Writes the frame just drawn into `texture` as `screenshot-N.png` in `out`: read back from
/// the surface when it can be copied, else the same passes rendered offscreen from `camera`.
pub(super) fn save_screenshot(
    r: &Running,
    data: &ViewData,
    texture: &wgpu::Texture,
    camera: &Camera,
    out: &Path,
) -> Result<PathBuf, WindowError> {
    let (w, h) = (r.config.width, r.config.height);
    let rgb = match surface_rgb(r, texture)? {
        Some(rgb) => {
            log::info!("screenshot read back from the window's surface");
            rgb
        }
        None => {
            log::info!("the surface cannot be copied: screenshot rendered offscreen");
            let off = Offscreen::with_options(&r.gpu, data, w, h, r.frame.options())?;
            off.render(&r.gpu, camera)?;
            rgba_to_rgb(&off.read_rgba8(&r.gpu)?)
        }
    };
    let path = next_free_name(out, "screenshot", "png");
    let write_err = |message: String| WindowError::Write {
        path: path.clone(),
        message,
    };
    let png = image_io::encode_png(w, h, &rgb, false).map_err(|e| write_err(e.to_string()))?;
    crate::out_dir::create_dir_all(out).map_err(|e| write_err(e.to_string()))?;
    std::fs::write(&path, png).map_err(|e| write_err(e.to_string()))?;
    log::info!("screenshot: {}", path.display());
    Ok(path)
}

/// The surface texture's pixels as RGB8, top row first; `None` when the surface was not
/// configured for copies or its format is not 8-bit RGBA or BGRA.
pub(super) fn surface_rgb(
    r: &Running,
    texture: &wgpu::Texture,
) -> Result<Option<Vec<u8>>, WindowError> {
    use wgpu::TextureFormat as F;
    let bgra = match r.config.format {
        F::Rgba8Unorm | F::Rgba8UnormSrgb => false,
        F::Bgra8Unorm | F::Bgra8UnormSrgb => true,
        _ => return Ok(None),
    };
    if !r.config.usage.contains(wgpu::TextureUsages::COPY_SRC) {
        return Ok(None);
    }
    let bytes = read_texture(&r.gpu, texture)?;
    Ok(Some(
        bytes
            .chunks_exact(4)
            .flat_map(|p| {
                if bgra {
                    [p[2], p[1], p[0]]
                } else {
                    [p[0], p[1], p[2]]
                }
            })
            .collect(),
    ))
}

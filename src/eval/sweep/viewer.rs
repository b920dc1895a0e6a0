//! The sweep's viewer adapter: a bundle's frame rendered by the headless viewer with the
//! point's [`ViewOptions`], timed, and box-filtered down to the reference's size.

use std::path::Path;

use super::SweepError;
use crate::camera::Camera;
use crate::eval::Image;
use crate::view::options::ViewOptions;

/// The headless viewer, when built and a GPU adapter opens.
#[cfg(feature = "view")]
pub(super) struct Viewer {
    gpu: crate::view::gpu::Gpu,
    width: u32,
    height: u32,
    frames: usize,
    /// The compared frame is rendered at `supersample`× the size and box-filtered down, as
    /// the reference's pixels are (timed frames are rendered at the real size).
    supersample: u32,
}

#[cfg(feature = "view")]
impl Viewer {
    /// The viewer, or why none opens.
    pub(super) fn open(width: u32, height: u32, frames: usize, spp: u32) -> Result<Viewer, String> {
        match crate::view::gpu::Gpu::headless_with_features(wgpu::Features::TIMESTAMP_QUERY) {
            Ok(gpu) => Ok(Viewer {
                gpu,
                width,
                height,
                frames: frames.max(1),
                supersample: (spp.max(1) as f64).sqrt().floor() as u32,
            }),
            Err(e) => {
                log::warn!("no GPU for the headless viewer ({e}): views are D on the CPU, untimed");
                Err(e.to_string())
            }
        }
    }

    /// The HDR frame of the bundle at `dir` from `camera`, and the median frame and GPU
    /// times of `frames` frames after a warm-up one.
    pub(super) fn render(
        &mut self,
        dir: &Path,
        view: &ViewOptions,
        camera: &Camera,
        label: &str,
    ) -> Result<(Image, Option<f64>, Option<f64>), SweepError> {
        use crate::view::headless::Offscreen;
        let fail = |e: &dyn std::fmt::Display| SweepError::View(label.to_string(), e.to_string());
        let data = crate::view::load::load(dir).map_err(|e| fail(&e))?;
        let gpu = &self.gpu;
        let offscreen =
            |w: u32, h: u32| Offscreen::with_options(gpu, &data, w, h, view).map_err(|e| fail(&e));
        let timed = offscreen(self.width, self.height)?;
        timed.render(gpu, camera).map_err(|e| fail(&e))?;
        let mut frame = Vec::with_capacity(self.frames);
        let mut gpu_ms = Vec::with_capacity(self.frames);
        for _ in 0..self.frames {
            let t = timed.render(gpu, camera).map_err(|e| fail(&e))?;
            frame.push(t.frame_ms);
            gpu_ms.push(t.gpu_ms);
        }
        let k = self.supersample;
        let big;
        let shown = if k > 1 {
            big = offscreen(self.width * k, self.height * k)?;
            big.render(gpu, camera).map_err(|e| fail(&e))?;
            &big
        } else {
            &timed
        };
        let fine = shown.read_hdr(gpu).map_err(|e| fail(&e))?;
        let (w, h) = (self.width as usize, self.height as usize);
        let img = Image {
            width: w,
            height: h,
            rgb: crate::image_io::downsample(&fine, w * k as usize, h * k as usize, w, h),
        };
        Ok((img, Some(median(&mut frame)), Some(median(&mut gpu_ms))))
    }
}

#[cfg(feature = "view")]
fn median(v: &mut [f64]) -> f64 {
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

/// Without the viewer there is none to open.
#[cfg(not(feature = "view"))]
pub(super) struct Viewer;

#[cfg(not(feature = "view"))]
impl Viewer {
    pub(super) fn open(_: u32, _: u32, _: usize, _: u32) -> Result<Viewer, String> {
        Err("glint was built without the `view` feature".into())
    }

    pub(super) fn render(
        &mut self,
        _: &Path,
        _: &ViewOptions,
        _: &Camera,
        _: &str,
    ) -> Result<(Image, Option<f64>, Option<f64>), SweepError> {
        unreachable!("never opened")
    }
}

//! Supersampled headless frames (`glint-view --supersample N`): a frame rendered at N × N
//! times its pixels is box-filtered down ([`crate::image_io::downsample`]) in linear radiance,
//! before exposure and the tone curve, so that every pixel is the mean of N² shaded samples as a path tracer's pixel is the
//! mean of its paths. Multisampling alone shades once a pixel: a highlight smaller than a
//! pixel on a sharp curved reflector then fills the pixel, which no resolve can undo.

/// Largest `--supersample`: 8 × 8 samples a pixel (the frame's target grows by N² and
/// must stay within the device's texture size).
pub const MAX_SUPERSAMPLE: u32 = 8;

/// `--supersample N`: 1 (off) to [`MAX_SUPERSAMPLE`] samples a pixel along each axis.
pub fn parse_supersample(s: &str) -> Result<u32, String> {
    match s.trim().parse::<u32>() {
        Ok(n) if (1..=MAX_SUPERSAMPLE).contains(&n) => Ok(n),
        _ => Err(format!(
            "expected samples a pixel along each axis, 1 (off) to {MAX_SUPERSAMPLE}, e.g. 2 for 2×2"
        )),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::Vec3;

    /// A `width` × `height` frame from one drawn at `k` × `k` samples a pixel.
    fn box_filter(fine: &[Vec3], width: usize, height: usize, k: usize) -> Vec<Vec3> {
        crate::image_io::downsample(fine, width * k, height * k, width, height)
    }

    #[test]
    fn each_pixel_is_the_mean_of_its_own_block() {
        // A 3×2 frame at 2×2 samples: each fine sample holds its coarse pixel's index in x
        // and its position inside the block in y, so a block read from the wrong place or
        // the wrong row shows.
        let (w, h, k) = (3usize, 2usize, 2usize);
        let fine: Vec<Vec3> = (0..w * k * h * k)
            .map(|i| {
                let (fx, fy) = (i % (w * k), i / (w * k));
                let pixel = (fy / k) * w + fx / k;
                let inside = (fy % k) * k + fx % k;
                Vec3::new(pixel as f32, inside as f32, 1.0)
            })
            .collect();
        let coarse = box_filter(&fine, w, h, k);
        assert_eq!(coarse.len(), w * h);
        for (i, c) in coarse.iter().enumerate() {
            assert_eq!(*c, Vec3::new(i as f32, 1.5, 1.0), "pixel {i}");
        }
    }

    #[test]
    fn one_sample_a_pixel_is_the_frame_itself() {
        let fine = vec![Vec3::new(0.25, 2.0, 7.0); 6];
        assert_eq!(box_filter(&fine, 3, 2, 1), fine);
    }

    #[test]
    fn a_thin_bright_line_keeps_its_energy() {
        // One fine row of radiance 16 in a 4×4 block: its pixel shows a quarter of it.
        let (w, h, k) = (1usize, 1usize, 4usize);
        let fine: Vec<Vec3> = (0..16)
            .map(|i| Vec3::splat(if i / 4 == 1 { 16.0 } else { 0.0 }))
            .collect();
        assert_eq!(box_filter(&fine, w, h, k), vec![Vec3::splat(4.0)]);
    }

    #[test]
    fn the_count_is_checked() {
        for good in ["1", "2", "8"] {
            assert!(parse_supersample(good).is_ok(), "{good}");
        }
        for bad in ["0", "9", "-1", "two", ""] {
            let e = parse_supersample(bad).unwrap_err();
            assert!(e.contains("1 (off) to 8"), "{bad}: {e}");
        }
    }
}

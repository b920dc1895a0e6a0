//! Colour: the one luminance every stage, the evaluation and the previews weigh RGB by.

use glam::Vec3;

/// Relative luminance of linear RGB with Rec. 709 primaries.
pub fn luminance(c: Vec3) -> f32 {
    c.dot(Vec3::new(0.2126, 0.7152, 0.0722))
}

#[cfg(test)]
mod tests {
    #[test]
    fn white_is_one_and_green_weighs_most() {
        use glam::Vec3;
        assert!((super::luminance(Vec3::ONE) - 1.0).abs() < 1e-6);
        assert!(super::luminance(Vec3::Y) > super::luminance(Vec3::X));
        assert!(super::luminance(Vec3::X) > super::luminance(Vec3::Z));
    }
}

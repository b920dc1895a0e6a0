//! Depth-map impostors and simplified rotated depth maps (SRDM), Popescu et al. 2006 §4.
//!
//! An object seen in a curved reflector is replaced by a depth map captured with a planar
//! pinhole camera ([`ImpostorCamera`]). A reflected ray projects onto that camera's image as a
//! segment, so its intersection with the depth map is a 1D search (§4.1). The search is
//! bounded by pre-simplifying the depth map along the rows of `n` rotated domains, each row to a
//! polyline of at most `m` points (§4.2, [`Srdm::build`]); a ray then walks the `m − 1`
//! segments of the one row its projection lies along (§4.3, [`Srdm::intersect`]).
//!
//! The structure is pure: no file system, no printing; [`Srdm::to_bytes`] / [`Srdm::from_bytes`]
//! hold the binary format. Beside it: [`capture`] (the impostor captures and their EXR),
//! [`billboard`] (the §3 billboard capture), [`settings`](crate::settings::srdm), and [`index`] (`srdm/index.json` and
//! the hash-checked reader the viewer uses). The bake stage (`bake::srdm_stage`) runs the
//! captures and writes the bundle.
//!
//! Conventions shared by every part:
//! - Image coordinates are pixels, x right, y down, (0, 0) the image's top-left corner; texel
//!   (x, y) covers [x, x + 1) × [y, y + 1) and its centre is (x + ½, y + ½). Maps are square,
//!   `w × w`.
//! - Depth is normalized 1/z ([`ImpostorCamera::depth_of_z`]): 1 on the hither plane, 0 on the
//!   yon plane. Along the image projection of any 3D line it is affine, which is why a ray is
//!   a straight line in (u, depth) and its intersection with a row is a 2D segment test.
//! - Domain `i` of `n` is rotated by θᵢ = πi/n (§4.1) about the image centre: row direction
//!   (cos θᵢ, sin θᵢ) in image coordinates. Its `w` rows are one texel apart; along a row the
//!   coordinate u runs over [0, w] and sample k sits at u = k + ½. Domain 0 is the map itself.

pub mod billboard;
mod build;
mod camera;
pub mod capture;
mod depth_map;
mod format;
pub mod index;
mod intersect;

pub use crate::settings::srdm::{SrdmOverride, SrdmSettings};
pub use build::{
    ErrorStats, MAX_DOMAINS, MAX_POINTS, SPLIT_TOLERANCE, SimplifiedRow, Srdm, SrdmParams,
    error_stats, row_samples, simplify_row,
};
pub use camera::ImpostorCamera;
pub use depth_map::{BACKGROUND, DepthMap, MAX_RESOLUTION, MIN_DEPTH};
pub use format::{SRDM_MAGIC, SRDM_VERSION};
pub use intersect::{MarchHit, SrdmHit, march};

use glam::Vec2;

/// Bytes as hex digits, for messages (`47 4c 53 52`).
fn hex(bytes: &[u8]) -> String {
    bytes
        .iter()
        .map(|b| format!("{b:02x}"))
        .collect::<Vec<_>>()
        .join(" ")
}

/// Why an SRDM or a depth map cannot be built or read.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum SrdmError {
    /// A size, count or value outside what the structure allows.
    #[error("{0}")]
    Invalid(String),
    /// Not an SRDM file.
    #[error(
        "not an SRDM file: the first bytes are {}, expected {}",
        crate::srdm::hex(found),
        crate::srdm::hex(&SRDM_MAGIC)
    )]
    Magic {
        /// The first bytes found.
        found: [u8; 8],
    },
    /// Written by a newer glint.
    #[error(
        "SRDM format version {found} is newer than this glint reads ({supported}); update glint or re-bake"
    )]
    NewerVersion {
        /// Version in the file.
        found: u16,
        /// Version this build reads and writes.
        supported: u16,
    },
    /// The file is shorter or longer than its header says.
    #[error("SRDM file is {found} bytes, its header implies {expected}")]
    Size {
        /// Bytes the header implies.
        expected: u64,
        /// Bytes present.
        found: u64,
    },
    /// The user asked to stop.
    #[error(transparent)]
    Cancelled(#[from] crate::progress::Cancelled),
}

/// The geometry of rotated domain `i` of `n` over a `w × w` map (§4.1, Figure 11).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Domain {
    /// Row direction (cos θ, sin θ) in image coordinates.
    pub e: Vec2,
    /// Across-row direction (−sin θ, cos θ).
    pub n: Vec2,
    /// w / 2: the rotation centre on both axes, and the offset of row coordinates.
    pub half: f32,
}

impl Domain {
    /// Domain `i` of `n` for maps of resolution `w`: θ = πi/n, computed in f64 so every build
    /// (and the viewer) gets the same rounding.
    pub fn new(i: u32, n: u32, w: u32) -> Domain {
        let theta = std::f64::consts::PI * i as f64 / n as f64;
        let (s, c) = theta.sin_cos();
        let (c, s) = (c as f32, s as f32);
        Domain {
            e: Vec2::new(c, s),
            n: Vec2::new(-s, c),
            half: 0.5 * w as f32,
        }
    }

    /// The domain whose rows are most nearly parallel to image direction `d` (§4.3 step 4).
    pub fn nearest(d: Vec2, n: u32) -> u32 {
        let mut phi = (d.y as f64).atan2(d.x as f64);
        if phi < 0.0 {
            phi += std::f64::consts::PI;
        }
        ((phi * n as f64 / std::f64::consts::PI).round() as u64 % n as u64) as u32
    }

    /// Image position of row coordinate `u` on the line at across-row coordinate `v`
    /// (row j's centre line is v = j + ½).
    #[inline]
    pub fn pixel(&self, u: f32, v: f32) -> Vec2 {
        let c = Vec2::splat(self.half);
        c + (u - self.half) * self.e + (v - self.half) * self.n
    }

    /// (u, v) of an image position: u along the rows, v across (row j covers v ∈ [j, j + 1)).
    #[inline]
    pub fn coords(&self, p: Vec2) -> Vec2 {
        let q = p - Vec2::splat(self.half);
        Vec2::new(q.dot(self.e) + self.half, q.dot(self.n) + self.half)
    }
}

//! The `.srdm` file: one SRDM set and its camera, little-endian.

use glam::Vec3;

use super::{ImpostorCamera, MAX_DOMAINS, MAX_POINTS, MAX_RESOLUTION, Srdm, SrdmError};
use crate::camera::Camera;

/// First 8 bytes of every `.srdm` file.
pub const SRDM_MAGIC: [u8; 8] = *b"GLSRDM\r\n";

/// The format version this build writes and reads.
pub const SRDM_VERSION: u16 = 1;

const HEADER: usize = 96;

impl Srdm {
    /// Reads a `.srdm` file (format version 1), little-endian throughout:
    ///
    /// | offset | type | field |
    /// |---|---|---|
    /// | 0 | `[u8; 8]` | magic `GLSRDM\r\n` |
    /// | 8 | `u16` | format version, 1 |
    /// | 10 | `u16` | reserved, 0 |
    /// | 12 | `u32` | n, rotated domains (domain i at θᵢ = πi/n) |
    /// | 16 | `u32` | w, depth-map resolution: rows per domain, samples per row |
    /// | 20 | `u32` | m, points per row |
    /// | 24 | `f32 × 3` | camera position (world, metres) |
    /// | 36 | `f32 × 3` | camera right (image +x) |
    /// | 48 | `f32 × 3` | camera up (image −y) |
    /// | 60 | `f32 × 3` | camera forward (view direction) |
    /// | 72 | `f32` | vertical (and horizontal) field of view, radians |
    /// | 76 | `f32` | hither distance |
    /// | 80 | `f32` | yon distance |
    /// | 84 | 12 bytes | reserved, 0 |
    /// | 96 | `f32 × 2 × n·w·m` | points (u, z), row (i, j) at index (i·w + j)·m |
    /// | … | `f32 × n·w` | per-row error: largest \|depth − polyline\| over its samples (1: a span was dropped) |
    /// | … | `u16 × n·w` | per-row count of points in use |
    ///
    /// u is the row coordinate in texels (sample k at k + ½), z the normalized depth
    /// (1/z − 1/yon)/(1/hither − 1/yon), negated on a point that opens a span; see [`Srdm`]
    /// for padding and [`crate::srdm`] for the domain geometry. A newer version is an error
    /// naming both versions; callers add the file's path.
    pub fn from_bytes(bytes: &[u8]) -> Result<Srdm, SrdmError> {
        if bytes.len() < HEADER {
            return Err(SrdmError::Size {
                expected: HEADER as u64,
                found: bytes.len() as u64,
            });
        }
        let magic: [u8; 8] = bytes[0..8].try_into().expect("8 bytes");
        if magic != SRDM_MAGIC {
            return Err(SrdmError::Magic { found: magic });
        }
        let u16_at = |o: usize| u16::from_le_bytes([bytes[o], bytes[o + 1]]);
        let u32_at = |o: usize| u32::from_le_bytes(bytes[o..o + 4].try_into().expect("4 bytes"));
        let f32_at = |o: usize| f32::from_le_bytes(bytes[o..o + 4].try_into().expect("4 bytes"));
        let vec_at = |o: usize| Vec3::new(f32_at(o), f32_at(o + 4), f32_at(o + 8));
        let version = u16_at(8);
        if version > SRDM_VERSION {
            return Err(SrdmError::NewerVersion {
                found: version,
                supported: SRDM_VERSION,
            });
        }
        if version == 0 {
            return Err(SrdmError::Invalid(
                "SRDM format version 0 does not exist".into(),
            ));
        }
        let (n, w, m) = (u32_at(12), u32_at(16), u32_at(20));
        if !(1..=MAX_DOMAINS).contains(&n)
            || !(2..=MAX_RESOLUTION).contains(&w)
            || !(2..=MAX_POINTS).contains(&m)
        {
            return Err(SrdmError::Invalid(format!(
                "SRDM header: n = {n}, w = {w}, m = {m} outside 1…{MAX_DOMAINS}, 2…{MAX_RESOLUTION}, 2…{MAX_POINTS}"
            )));
        }
        let camera = ImpostorCamera {
            view: Camera {
                position: vec_at(24),
                right: vec_at(36),
                up: vec_at(48),
                forward: vec_at(60),
                fov_y: f32_at(72),
            },
            hither: f32_at(76),
            yon: f32_at(80),
            resolution: w,
        };
        camera
            .validate()
            .map_err(|e| SrdmError::Invalid(format!("SRDM header: {e}")))?;
        let rows = n as usize * w as usize;
        let npoints = rows * m as usize;
        let expected = HEADER + npoints * 8 + rows * 4 + rows * 2;
        if bytes.len() != expected {
            return Err(SrdmError::Size {
                expected: expected as u64,
                found: bytes.len() as u64,
            });
        }
        let mut o = HEADER;
        let points: Vec<[f32; 2]> = (0..npoints)
            .map(|p| [f32_at(o + 8 * p), f32_at(o + 8 * p + 4)])
            .collect();
        o += npoints * 8;
        let errors: Vec<f32> = (0..rows).map(|r| f32_at(o + 4 * r)).collect();
        o += rows * 4;
        let counts: Vec<u16> = (0..rows).map(|r| u16_at(o + 2 * r)).collect();
        if let Some(r) = counts.iter().position(|&c| c as u32 > m) {
            return Err(SrdmError::Invalid(format!(
                "row {} of domain {} uses {} points, more than m = {m}",
                r % w as usize,
                r / w as usize,
                counts[r]
            )));
        }
        if points
            .iter()
            .any(|p| !(p[0].is_finite() && p[1].is_finite()))
            || errors.iter().any(|e| !e.is_finite())
        {
            return Err(SrdmError::Invalid(
                "SRDM data holds a non-finite value".into(),
            ));
        }
        Ok(Srdm {
            camera,
            domains: n,
            points_per_row: m,
            points,
            counts,
            errors,
        })
    }

    /// Writes the `.srdm` file described in [`Srdm::from_bytes`].
    pub fn to_bytes(&self) -> Vec<u8> {
        let rows = self.counts.len();
        let mut out = Vec::with_capacity(HEADER + self.points.len() * 8 + rows * 6);
        out.extend_from_slice(&SRDM_MAGIC);
        out.extend_from_slice(&SRDM_VERSION.to_le_bytes());
        out.extend_from_slice(&0u16.to_le_bytes());
        for v in [self.domains, self.resolution(), self.points_per_row] {
            out.extend_from_slice(&v.to_le_bytes());
        }
        let c = &self.camera;
        for v in [c.view.position, c.view.right, c.view.up, c.view.forward] {
            for x in v.to_array() {
                out.extend_from_slice(&x.to_le_bytes());
            }
        }
        for x in [c.view.fov_y, c.hither, c.yon] {
            out.extend_from_slice(&x.to_le_bytes());
        }
        out.resize(HEADER, 0);
        for p in &self.points {
            out.extend_from_slice(&p[0].to_le_bytes());
            out.extend_from_slice(&p[1].to_le_bytes());
        }
        for e in &self.errors {
            out.extend_from_slice(&e.to_le_bytes());
        }
        for c in &self.counts {
            out.extend_from_slice(&c.to_le_bytes());
        }
        out
    }

    /// Size of the `.srdm` file of an n × w × m set.
    pub fn file_bytes(n: u32, w: u32, m: u32) -> u64 {
        let rows = n as u64 * w as u64;
        HEADER as u64 + rows * m as u64 * 8 + rows * 6
    }
}

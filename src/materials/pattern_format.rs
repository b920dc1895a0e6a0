//! The sample-pattern table file (`*-pattern.bin`): one regular pattern of half vectors
//! (Luksch et al. §5–7) with what a shader needs to use it.
//!
//! # Format, version 1 (little-endian)
//!
//! | offset | type      | field                                                            |
//! |-------:|-----------|------------------------------------------------------------------|
//! | 0      | `[u8; 8]` | magic `GLNTSPAT`                                                 |
//! | 8      | `u16`     | format version (1)                                               |
//! | 10     | `u16`     | spacing: 1 = s₁ (pole + circles), 2 = s₂ (circles only) (Eq. 12) |
//! | 12     | `u32`     | sample count N                                                   |
//! | 16     | `u32`     | circles n_c                                                      |
//! | 20     | `f32`     | threshold ξ₀                                                     |
//! | 24     | `f32`     | roughness m_x (tangent)                                          |
//! | 28     | `f32`     | roughness m_y (bitangent)                                        |
//! | 32     | `f32`     | θ_max, radians (Eq. 11)                                          |
//! | 36     | `f32`     | circle spacing, radians (Eq. 12)                                 |
//! | 40     | `f32`     | PDF constant p_h = (1/N) Σ D(h_i), per steradian (Eq. 18)        |
//! | 44     | `u32`     | distribution: 0 = Beckmann (Eq. 4–5; Kurt and Beckmann lobes), 1 = GGX |
//! | 48     | N × 16 B  | per sample: `f32` h_x, h_y, h_z (unit half vector in the tangent frame: x tangent, y bitangent, z normal), `f32` q(h) (Eq. 5 for Beckmann, 1/(1+e)² for GGX: [`crate::brdf::Ndf::q`]) |
//!
//! The file is exactly 48 + 16 N bytes. Records are 16-byte `vec4`s, ready for a GPU buffer.
//! In numpy: `np.frombuffer(b, '<f4', offset=48).reshape(-1, 4)`.

use glam::Vec3;

use crate::brdf::Ndf;
use crate::brdf::pattern::{Pattern, Spacing};

/// The file's magic bytes.
pub const PATTERN_MAGIC: [u8; 8] = *b"GLNTSPAT";
/// The format version this build writes and reads.
pub const PATTERN_VERSION: u16 = 1;
/// Header size in bytes.
pub const PATTERN_HEADER: usize = 48;

/// Why a pattern table could not be read.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum PatternFormatError {
    /// Not a pattern table.
    #[error("not a glint sample-pattern table (magic bytes differ)")]
    Magic,
    /// Written by a newer glint.
    #[error("sample-pattern format version {found} is newer than this glint reads ({supported})")]
    Version {
        /// Version in the file.
        found: u16,
        /// Version this build reads.
        supported: u16,
    },
    /// Sizes or fields do not add up.
    #[error("corrupt sample-pattern table: {0}")]
    Corrupt(String),
}

/// A decoded pattern table.
#[derive(Clone, Debug, PartialEq)]
pub struct PatternTable {
    /// The distribution (header offset 44; 0 in files written before GGX existed).
    pub ndf: Ndf,
    /// Spacing.
    pub spacing: Spacing,
    /// Circles.
    pub circles: u32,
    /// ξ₀.
    pub xi0: f32,
    /// m_x.
    pub mx: f32,
    /// m_y.
    pub my: f32,
    /// θ_max, radians.
    pub theta_max: f32,
    /// Circle spacing, radians.
    pub step: f32,
    /// p_h (Eq. 18).
    pub pdf_constant: f32,
    /// Half vectors.
    pub half_vectors: Vec<Vec3>,
    /// q(h) per sample.
    pub q: Vec<f32>,
}

/// Encodes a pattern (see the module documentation for the layout).
pub fn encode_pattern(p: &Pattern) -> Vec<u8> {
    let mut b = Vec::with_capacity(PATTERN_HEADER + 16 * p.len());
    b.extend_from_slice(&PATTERN_MAGIC);
    b.extend_from_slice(&PATTERN_VERSION.to_le_bytes());
    let spacing: u16 = match p.spacing {
        Spacing::S1 => 1,
        Spacing::S2 => 2,
    };
    b.extend_from_slice(&spacing.to_le_bytes());
    b.extend_from_slice(&(p.len() as u32).to_le_bytes());
    b.extend_from_slice(&p.circles.to_le_bytes());
    for v in [p.xi0, p.mx, p.my, p.theta_max, p.step, p.pdf_constant] {
        b.extend_from_slice(&v.to_le_bytes());
    }
    b.extend_from_slice(&ndf_code(p.ndf).to_le_bytes());
    for h in &p.half_vectors {
        for v in [h.x, h.y, h.z, p.ndf.q(*h, p.mx, p.my)] {
            b.extend_from_slice(&v.to_le_bytes());
        }
    }
    b
}

/// The header's code of a distribution.
fn ndf_code(ndf: Ndf) -> u32 {
    match ndf {
        Ndf::Beckmann => 0,
        Ndf::Ggx => 1,
    }
}

/// Decodes a pattern table, checking magic, version and size.
pub fn decode_pattern(bytes: &[u8]) -> Result<PatternTable, PatternFormatError> {
    if bytes.len() < 10 || bytes[..8] != PATTERN_MAGIC {
        return Err(PatternFormatError::Magic);
    }
    let u16_at = |o: usize| u16::from_le_bytes([bytes[o], bytes[o + 1]]);
    let version = u16_at(8);
    if version > PATTERN_VERSION {
        return Err(PatternFormatError::Version {
            found: version,
            supported: PATTERN_VERSION,
        });
    }
    if version == 0 {
        return Err(PatternFormatError::Corrupt(
            "version 0 does not exist".into(),
        ));
    }
    if bytes.len() < PATTERN_HEADER {
        return Err(PatternFormatError::Corrupt(format!(
            "{} bytes, shorter than the {PATTERN_HEADER}-byte header",
            bytes.len()
        )));
    }
    let u32_at = |o: usize| u32::from_le_bytes(bytes[o..o + 4].try_into().expect("4 bytes"));
    let f32_at = |o: usize| f32::from_le_bytes(bytes[o..o + 4].try_into().expect("4 bytes"));
    let spacing = match u16_at(10) {
        1 => Spacing::S1,
        2 => Spacing::S2,
        s => {
            return Err(PatternFormatError::Corrupt(format!(
                "spacing {s} is neither 1 nor 2"
            )));
        }
    };
    let ndf = match u32_at(44) {
        0 => Ndf::Beckmann,
        1 => Ndf::Ggx,
        d => {
            return Err(PatternFormatError::Corrupt(format!(
                "distribution {d} at offset 44 is neither 0 (Beckmann) nor 1 (GGX)"
            )));
        }
    };
    let n = u32_at(12) as usize;
    let want = PATTERN_HEADER + 16 * n;
    if bytes.len() != want {
        return Err(PatternFormatError::Corrupt(format!(
            "{} bytes, {n} samples need {want}",
            bytes.len()
        )));
    }
    let mut half_vectors = Vec::with_capacity(n);
    let mut q = Vec::with_capacity(n);
    for i in 0..n {
        let o = PATTERN_HEADER + 16 * i;
        half_vectors.push(Vec3::new(f32_at(o), f32_at(o + 4), f32_at(o + 8)));
        q.push(f32_at(o + 12));
    }
    Ok(PatternTable {
        ndf,
        spacing,
        circles: u32_at(16),
        xi0: f32_at(20),
        mx: f32_at(24),
        my: f32_at(28),
        theta_max: f32_at(32),
        step: f32_at(36),
        pdf_constant: f32_at(40),
        half_vectors,
        q,
    })
}

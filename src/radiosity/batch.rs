//! A first gathering batch of a range of elements ([`super::solve::gather_batch`]), and its
//! file: what a radiosity gathering work unit writes and the unit that solves reads.
//!
//! Little-endian, every float as its bits (the solve reads back exactly what was gathered):
//! | bytes | field |
//! |---|---|
//! | 8 | magic `GLNTGATH` |
//! | u32 | version (2) |
//! | 32 | BLAKE3 of the elements' samples (the atlas they were gathered on) |
//! | u32 | elements in the atlas |
//! | u32, u32 | the batch's element range, start and end |
//! | per element | 3 × f32 emitted, 3 × f32 glossy, u8 inside, u32 gathering rays, u64 rays, u64 light rays, u32 light samples, 3 × f64 moments (light variance, Σ and Σ² of the rays' constant radiance), u32 hit count H, H × u32 hits, u32 term count T, T × (u32 texel, 3 × f32 weight) |

use std::ops::Range;

use glam::Vec3;

use super::atlas::{Atlas, TexelSample};
use super::gather::{Gathered, Moments};
use super::transport::Term;

/// File magic.
pub const MAGIC: &[u8; 8] = b"GLNTGATH";
/// Format version written.
pub const VERSION: u32 = 2;

/// The first gathering batch of elements `range`.
pub struct GatherBatch {
    /// The elements, as indices into the atlas's samples.
    pub range: Range<u32>,
    pub(super) elements: Vec<Gathered>,
}

/// Why a batch file cannot be read.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum BatchError {
    /// Not a batch file.
    #[error("not a glint gathering batch (bad magic)")]
    Magic,
    /// A version this build does not read.
    #[error("gathering batch format version {0}, this glint reads version {VERSION}")]
    Version(u32),
    /// Gathered on another atlas than the one being solved.
    #[error(
        "gathered on another atlas ({found} elements, samples {found_hash:.12}…) than this bake's ({expected} elements, {expected_hash:.12}…): the scene or the radiosity settings changed; rerun the gathering units"
    )]
    Atlas {
        /// Elements in the file's atlas.
        found: u32,
        /// Its samples' hash.
        found_hash: String,
        /// Elements now.
        expected: u32,
        /// Their hash.
        expected_hash: String,
    },
    /// Truncated, trailing bytes or impossible values.
    #[error("corrupt gathering batch: {0}")]
    Corrupt(String),
}

/// BLAKE3 of the elements' samples: which atlas a batch belongs to.
pub fn samples_hash(samples: &[TexelSample]) -> [u8; 32] {
    let mut h = blake3::Hasher::new();
    for s in samples {
        h.update(&s.texel.to_le_bytes());
        h.update(&s.triangle.to_le_bytes());
        h.update(&s.bary.x.to_bits().to_le_bytes());
        h.update(&s.bary.y.to_bits().to_le_bytes());
    }
    *h.finalize().as_bytes()
}

fn put_f32(out: &mut Vec<u8>, v: f32) {
    out.extend_from_slice(&v.to_bits().to_le_bytes());
}

impl GatherBatch {
    /// The batch's file, for the atlas whose samples are `samples`.
    pub fn encode(&self, samples: &[TexelSample]) -> Vec<u8> {
        let rays: usize = self.elements.iter().map(|g| g.hits.len()).sum();
        let terms: usize = self.elements.iter().map(|g| g.terms.len()).sum();
        let mut out = Vec::with_capacity(64 + self.elements.len() * 64 + rays * 4 + terms * 16);
        out.extend_from_slice(MAGIC);
        out.extend_from_slice(&VERSION.to_le_bytes());
        out.extend_from_slice(&samples_hash(samples));
        out.extend_from_slice(&(samples.len() as u32).to_le_bytes());
        out.extend_from_slice(&self.range.start.to_le_bytes());
        out.extend_from_slice(&self.range.end.to_le_bytes());
        for g in &self.elements {
            for c in g.emitted.to_array().into_iter().chain(g.glossy.to_array()) {
                put_f32(&mut out, c);
            }
            out.push(u8::from(g.inside));
            out.extend_from_slice(&g.gathering_rays.to_le_bytes());
            out.extend_from_slice(&g.rays.to_le_bytes());
            out.extend_from_slice(&g.light_rays.to_le_bytes());
            out.extend_from_slice(&g.light_samples.to_le_bytes());
            for m in [
                g.moments.light_var,
                g.moments.ray_const,
                g.moments.ray_const2,
            ] {
                out.extend_from_slice(&m.to_bits().to_le_bytes());
            }
            out.extend_from_slice(&(g.hits.len() as u32).to_le_bytes());
            for h in &g.hits {
                out.extend_from_slice(&h.to_le_bytes());
            }
            out.extend_from_slice(&(g.terms.len() as u32).to_le_bytes());
            for t in &g.terms {
                out.extend_from_slice(&t.texel.to_le_bytes());
                for c in t.weight.to_array() {
                    put_f32(&mut out, c);
                }
            }
        }
        out
    }

    /// Reads a batch file gathered on `atlas`, whose samples are `samples`.
    pub fn decode(
        bytes: &[u8],
        atlas: &Atlas,
        samples: &[TexelSample],
    ) -> Result<GatherBatch, BatchError> {
        let mut r = Reader { bytes, at: 0 };
        if r.take(8)? != MAGIC {
            return Err(BatchError::Magic);
        }
        let version = r.u32()?;
        if version != VERSION {
            return Err(BatchError::Version(version));
        }
        let hash: [u8; 32] = r.take(32)?.try_into().expect("32 bytes");
        let count = r.u32()?;
        let expected = samples_hash(samples);
        if hash != expected || count as usize != samples.len() {
            return Err(BatchError::Atlas {
                found: count,
                found_hash: hex(&hash),
                expected: samples.len() as u32,
                expected_hash: hex(&expected),
            });
        }
        let (start, end) = (r.u32()?, r.u32()?);
        if start > end || end > count {
            return Err(BatchError::Corrupt(format!(
                "element range {start}..{end} of {count}"
            )));
        }
        let texels = atlas.texel_count();
        let texels_ok = |t: u32| t == u32::MAX || (t as usize) < texels;
        let mut elements = Vec::with_capacity((end - start) as usize);
        for _ in start..end {
            let emitted = Vec3::new(r.f32()?, r.f32()?, r.f32()?);
            let glossy = Vec3::new(r.f32()?, r.f32()?, r.f32()?);
            let inside = match r.take(1)?[0] {
                0 => false,
                1 => true,
                b => return Err(BatchError::Corrupt(format!("inside flag {b}"))),
            };
            let gathering_rays = r.u32()?;
            let rays = r.u64()?;
            let light_rays = r.u64()?;
            let light_samples = r.u32()?;
            let moments = Moments {
                light_var: r.f64()?,
                ray_const: r.f64()?,
                ray_const2: r.f64()?,
            };
            let n = r.u32()? as usize;
            if n != gathering_rays as usize {
                return Err(BatchError::Corrupt(format!(
                    "{n} hits for {gathering_rays} gathering rays"
                )));
            }
            let raw = r.take(n.checked_mul(4).ok_or_else(overflow)?)?;
            let hits: Vec<u32> = raw
                .chunks_exact(4)
                .map(|c| u32::from_le_bytes(c.try_into().expect("4 bytes")))
                .collect();
            let n_terms = r.u32()? as usize;
            let mut terms = Vec::with_capacity(n_terms.min(r.left() / 16));
            for _ in 0..n_terms {
                let texel = r.u32()?;
                let weight = Vec3::new(r.f32()?, r.f32()?, r.f32()?);
                terms.push(Term { texel, weight });
            }
            if !hits
                .iter()
                .chain(terms.iter().map(|t| &t.texel))
                .all(|&t| texels_ok(t))
            {
                return Err(BatchError::Corrupt("a hit names no texel".into()));
            }
            elements.push(Gathered {
                emitted,
                glossy,
                gathering_rays,
                hits,
                terms,
                inside,
                rays,
                light_rays,
                light_samples,
                moments,
            });
        }
        if r.left() != 0 {
            return Err(BatchError::Corrupt(format!("{} trailing bytes", r.left())));
        }
        Ok(GatherBatch {
            range: start..end,
            elements,
        })
    }
}

fn overflow() -> BatchError {
    BatchError::Corrupt("a count overflows".into())
}

fn hex(bytes: &[u8]) -> String {
    bytes.iter().map(|b| format!("{b:02x}")).collect()
}

struct Reader<'a> {
    bytes: &'a [u8],
    at: usize,
}

impl<'a> Reader<'a> {
    fn left(&self) -> usize {
        self.bytes.len() - self.at
    }

    fn take(&mut self, n: usize) -> Result<&'a [u8], BatchError> {
        if self.left() < n {
            return Err(BatchError::Corrupt(format!(
                "truncated at byte {} (wanted {n} more, {} left)",
                self.at,
                self.left()
            )));
        }
        let s = &self.bytes[self.at..self.at + n];
        self.at += n;
        Ok(s)
    }

    fn u32(&mut self) -> Result<u32, BatchError> {
        Ok(u32::from_le_bytes(self.take(4)?.try_into().expect("4")))
    }

    fn u64(&mut self) -> Result<u64, BatchError> {
        Ok(u64::from_le_bytes(self.take(8)?.try_into().expect("8")))
    }

    fn f32(&mut self) -> Result<f32, BatchError> {
        Ok(f32::from_bits(self.u32()?))
    }

    fn f64(&mut self) -> Result<f64, BatchError> {
        Ok(f64::from_bits(self.u64()?))
    }
}

#[cfg(test)]
mod tests {
    use glam::Vec2;

    use super::*;
    use crate::radiosity::atlas::PageSize;

    fn atlas() -> (Atlas, Vec<TexelSample>) {
        let atlas = Atlas {
            texel_density: 4.0,
            pages: vec![PageSize {
                width: 4,
                height: 2,
            }],
            tri_page: vec![0],
            tri_coords: vec![[Vec2::ZERO, Vec2::X * 4.0, Vec2::Y * 2.0]],
            texel_chart: vec![0; 8],
            charts: 1,
            from_uv1: false,
            backs: Vec::new(),
        };
        let samples = (0..3)
            .map(|i| TexelSample {
                texel: i,
                triangle: 0,
                bary: Vec2::new(0.1 * i as f32, 0.2),
            })
            .collect();
        (atlas, samples)
    }

    fn element(seed: u32, hits: Vec<u32>) -> Gathered {
        Gathered {
            emitted: Vec3::new(0.25, seed as f32, -0.0),
            glossy: Vec3::new(f32::MAX, 0.5, seed as f32),
            gathering_rays: hits.len() as u32,
            hits,
            terms: vec![Term {
                texel: 7,
                weight: Vec3::new(0.5, f32::MIN_POSITIVE, 3.0),
            }],
            inside: seed % 2 == 1,
            rays: 1 << 40 | seed as u64,
            light_rays: 1 << 39 | seed as u64,
            light_samples: 9,
            moments: Moments {
                light_var: 1e-300,
                ray_const: 0.1 + seed as f64,
                ray_const2: f64::MAX,
            },
        }
    }

    fn same(a: &Gathered, b: &Gathered) -> bool {
        let bits = |v: Vec3| v.to_array().map(f32::to_bits);
        bits(a.emitted) == bits(b.emitted)
            && bits(a.glossy) == bits(b.glossy)
            && a.light_rays == b.light_rays
            && a.gathering_rays == b.gathering_rays
            && a.hits == b.hits
            && a.terms == b.terms
            && a.inside == b.inside
            && a.rays == b.rays
            && a.light_samples == b.light_samples
            && a.moments.light_var.to_bits() == b.moments.light_var.to_bits()
            && a.moments.ray_const.to_bits() == b.moments.ray_const.to_bits()
            && a.moments.ray_const2.to_bits() == b.moments.ray_const2.to_bits()
    }

    #[test]
    fn a_batch_reads_back_bit_for_bit_and_only_on_its_atlas() {
        let (atlas, samples) = atlas();
        let batch = GatherBatch {
            range: 1..3,
            elements: vec![element(1, vec![0, u32::MAX, 7]), element(2, vec![])],
        };
        let bytes = batch.encode(&samples);
        let back = GatherBatch::decode(&bytes, &atlas, &samples).unwrap();
        assert_eq!(back.range, 1..3);
        assert_eq!(back.elements.len(), 2);
        for (a, b) in batch.elements.iter().zip(&back.elements) {
            assert!(same(a, b));
        }

        // Another atlas (a sample moved) is refused, naming what to rerun.
        let mut moved = samples.clone();
        moved[2].bary.x += 1e-6;
        let e = GatherBatch::decode(&bytes, &atlas, &moved).err().unwrap();
        assert!(matches!(e, BatchError::Atlas { .. }), "{e}");
        assert!(e.to_string().contains("rerun the gathering units"), "{e}");

        // Truncated, trailing bytes, a bad magic, a hit beyond the atlas: refused.
        for cut in [0, 7, 50, bytes.len() - 1] {
            assert!(
                GatherBatch::decode(&bytes[..cut], &atlas, &samples).is_err(),
                "{cut}"
            );
        }
        let mut long = bytes.clone();
        long.push(0);
        assert!(matches!(
            GatherBatch::decode(&long, &atlas, &samples),
            Err(BatchError::Corrupt(_))
        ));
        let mut magic = bytes.clone();
        magic[0] = b'X';
        assert!(matches!(
            GatherBatch::decode(&magic, &atlas, &samples),
            Err(BatchError::Magic)
        ));
        let far = GatherBatch {
            range: 0..1,
            elements: vec![element(0, vec![8])],
        };
        let e = GatherBatch::decode(&far.encode(&samples), &atlas, &samples)
            .err()
            .unwrap();
        assert!(e.to_string().contains("names no texel"), "{e}");
    }
}

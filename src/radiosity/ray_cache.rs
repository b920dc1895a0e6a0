//! The ray cache: every gathering ray of a bake kept with what it brought back, so that a
//! bake after an edit of some materials' lobes (a roughness) follows again only the rays whose
//! glossy paths evaluated those lobes, and keeps the rest.
//!
//! Each ray draws from its own stream (`gather::ray_rng`) and an element's rays are
//! summed in one place (`gather::assemble`), so a ray kept and a ray followed again
//! give the bytes of a full gathering. A ray is kept when its path read no changed material's
//! lobes and, if it reached an emitter (whose MIS weight depends on the batch's counts), its
//! batch had the same ray and emitter-sample counts; an element's emitter samples are kept
//! when its batch is the same (round, first ray, counts). Everything else a ray's result
//! depends on (geometry, atlas, the other material fields, which materials are glossy or
//! mirrors, lights, reflectors, settings, seed) is in the cache's key: a cache of another key
//! is not used at all.
//!
//! File (little-endian, floats as their bits):
//! | bytes | field |
//! |---|---|
//! | 8 | magic `GLNTRAYS` |
//! | u32 | version (1) |
//! | 32 | key (BLAKE3) |
//! | u32 | materials M; M × 32 bytes: BLAKE3 of each material's lobes |
//! | u32 | elements E; per element: u32 batches, per batch: u32 round, u32 first ray, u32 rays, u32 emitter samples, u8 inside, 3 × f32 light, f64 light variance, u64 light rays, u32 byte length L, L bytes of rays |
//!
//! A batch's rays, in order: varint (texel hit + 1, 0: none), a flag byte, then as flagged:
//! 3 × f32 emission (bit 0), 3 × f32 glossy (bit 1), varint rays cast (bit 3, when not 1),
//! varint term count and terms (bit 4: varint texel << 1 | grey, then 1 or 3 f32), varint
//! materials read (bit 5); bit 2: the emission carries MIS weights.

use glam::Vec3;

use super::transport::Term;
use super::varint;

/// Bytes of packed batches a bake keeps at most. A bake through the cache holds the prior
/// bake's and its own in memory, so this bounds what the cache adds to a bake's memory (twice
/// this) and to the unit cache's disk; a larger scene keeps none.
pub const RAY_CACHE_BUDGET: u64 = 1 << 30;

/// File magic.
pub const MAGIC: &[u8; 8] = b"GLNTRAYS";
/// Format version written.
pub const VERSION: u32 = 1;

/// What one gathering ray brings back to its element, before the element sums its rays
/// ([`super::gather::assemble`]): a full gathering and one that keeps most rays from an earlier bake
/// ([`super::ray_cache`]) sum the same records in the same order.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub(super) struct RayRecord {
    /// The atlas texel hit (u32::MAX: miss or back face).
    pub hit: u32,
    /// Emission reached, MIS-weighted against the element's emitter samples (not yet over the
    /// element's ray count).
    pub emission: Vec3,
    /// Radiance brought back through glossy reflection besides its terms.
    pub glossy: Vec3,
    /// Rays cast (this one, its glossy paths' and through glass).
    pub rays: u32,
    /// How many of the element's terms are this ray's (they follow the earlier rays' terms).
    pub terms: u32,
    /// The materials whose lobes its path evaluated, as bits `material % 64`.
    pub lobes_read: u64,
    /// Whether `emission` carries MIS weights, which depend on the batch's ray and
    /// emitter-sample counts.
    pub weighted: bool,
}

/// What an element's emitter samples (and the emitters' images in mirrors) found: drawn from
/// the element's own stream of the round, after its rays.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub(super) struct LightPart {
    /// Irradiance/π.
    pub direct: Vec3,
    /// Its variance (luminance, of the mean).
    pub var: f64,
    /// Shadow rays cast.
    pub rays: u64,
}

/// One batch of one element's gathering, as kept.
#[derive(Clone, Debug, Default, PartialEq)]
pub(super) struct KeptBatch {
    /// Refinement round (0: the first batch).
    pub round: u32,
    /// Its first ray's index in the element's sequence.
    pub first: u32,
    pub n_rays: u32,
    pub n_light: u32,
    pub inside: bool,
    pub lights: LightPart,
    /// The rays' records and terms, packed (module comment).
    pub rays: Vec<u8>,
}

const EMISSION: u8 = 1;
const GLOSSY: u8 = 2;
const WEIGHTED: u8 = 4;
const RAYS: u8 = 8;
const TERMS: u8 = 16;
const LOBES: u8 = 32;

fn put_f32(out: &mut Vec<u8>, v: f32) {
    out.extend_from_slice(&v.to_bits().to_le_bytes());
}

fn put_vec3(out: &mut Vec<u8>, v: Vec3) {
    for c in v.to_array() {
        put_f32(out, c);
    }
}

impl KeptBatch {
    /// Packs `records` with their `terms` (in ray order).
    pub fn pack(records: &[RayRecord], terms: &[Term]) -> Vec<u8> {
        let mut out = Vec::with_capacity(records.len() * 5);
        let mut at = 0usize;
        for r in records {
            varint::push(&mut out, u64::from(r.hit.wrapping_add(1)));
            let mut flags = 0u8;
            // Bits, not values: -0.0 must come back as -0.0.
            let zero = |v: Vec3| v.to_array().iter().all(|c| c.to_bits() == 0);
            if !zero(r.emission) {
                flags |= EMISSION;
            }
            if !zero(r.glossy) {
                flags |= GLOSSY;
            }
            if r.weighted {
                flags |= WEIGHTED;
            }
            if r.rays != 1 {
                flags |= RAYS;
            }
            if r.terms > 0 {
                flags |= TERMS;
            }
            if r.lobes_read != 0 {
                flags |= LOBES;
            }
            out.push(flags);
            if flags & EMISSION != 0 {
                put_vec3(&mut out, r.emission);
            }
            if flags & GLOSSY != 0 {
                put_vec3(&mut out, r.glossy);
            }
            if flags & RAYS != 0 {
                varint::push(&mut out, u64::from(r.rays));
            }
            if flags & TERMS != 0 {
                varint::push(&mut out, u64::from(r.terms));
                for t in &terms[at..at + r.terms as usize] {
                    let w = t.weight;
                    let grey = w.x.to_bits() == w.y.to_bits() && w.x.to_bits() == w.z.to_bits();
                    varint::push(&mut out, (u64::from(t.texel) << 1) | u64::from(grey));
                    if grey {
                        put_f32(&mut out, w.x);
                    } else {
                        put_vec3(&mut out, w);
                    }
                }
                at += r.terms as usize;
            }
            if flags & LOBES != 0 {
                varint::push(&mut out, r.lobes_read);
            }
        }
        out.shrink_to_fit();
        out
    }

    /// What the batch adds to the cache's memory and file, near enough.
    pub fn bytes(&self) -> u64 {
        self.rays.len() as u64 + 48
    }

    /// The batch's records and terms, as packed; `None` when its bytes are not `n_rays`
    /// well-formed records.
    pub fn unpack(&self) -> Option<(Vec<RayRecord>, Vec<Term>)> {
        let bytes = &self.rays;
        let mut at = 0usize;
        let f32_at = |at: &mut usize| -> Option<f32> {
            let b: [u8; 4] = bytes.get(*at..*at + 4)?.try_into().ok()?;
            *at += 4;
            Some(f32::from_bits(u32::from_le_bytes(b)))
        };
        let vec3_at = |at: &mut usize| -> Option<Vec3> {
            Some(Vec3::new(f32_at(at)?, f32_at(at)?, f32_at(at)?))
        };
        let small = |v: u64| u32::try_from(v).ok();
        let mut records = Vec::with_capacity(self.n_rays as usize);
        let mut terms = Vec::new();
        for _ in 0..self.n_rays {
            let hit = small(varint::read(bytes, &mut at)?)?.wrapping_sub(1);
            let flags = *bytes.get(at)?;
            at += 1;
            let mut r = RayRecord {
                hit,
                rays: 1,
                weighted: flags & WEIGHTED != 0,
                ..Default::default()
            };
            if flags & EMISSION != 0 {
                r.emission = vec3_at(&mut at)?;
            }
            if flags & GLOSSY != 0 {
                r.glossy = vec3_at(&mut at)?;
            }
            if flags & RAYS != 0 {
                r.rays = small(varint::read(bytes, &mut at)?)?;
            }
            if flags & TERMS != 0 {
                r.terms = small(varint::read(bytes, &mut at)?)?;
                for _ in 0..r.terms {
                    let head = varint::read(bytes, &mut at)?;
                    let texel = small(head >> 1)?;
                    let weight = if head & 1 == 1 {
                        Vec3::splat(f32_at(&mut at)?)
                    } else {
                        vec3_at(&mut at)?
                    };
                    terms.push(Term { texel, weight });
                }
            }
            if flags & LOBES != 0 {
                r.lobes_read = varint::read(bytes, &mut at)?;
            }
            records.push(r);
        }
        (at == bytes.len()).then_some((records, terms))
    }
}

/// The ray cache of one bake: per element, its batches in the order gathered.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct RayCache {
    /// What every ray depends on besides the materials' lobes.
    pub(super) key: [u8; 32],
    /// Per material, BLAKE3 of its lobes.
    pub(super) lobes: Vec<[u8; 32]>,
    pub(super) elements: Vec<Vec<KeptBatch>>,
}

/// Why a cache file cannot be read.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("corrupt ray cache: {0}")]
pub struct CacheError(String);

impl RayCache {
    /// Bits `material % 64` of the materials whose lobes differ from `lobes` (the current
    /// scene's); `None` when the cache was made under another key or for another count of
    /// materials or elements, and cannot be used.
    pub(super) fn changed(
        &self,
        key: &[u8; 32],
        lobes: &[[u8; 32]],
        elements: usize,
    ) -> Option<u64> {
        if self.key != *key || self.lobes.len() != lobes.len() || self.elements.len() != elements {
            return None;
        }
        Some(
            self.lobes
                .iter()
                .zip(lobes)
                .enumerate()
                .filter(|(_, (a, b))| a != b)
                .fold(0u64, |m, (i, _)| m | 1 << (i % 64)),
        )
    }

    /// Bytes of packed rays held.
    pub fn ray_bytes(&self) -> u64 {
        self.elements
            .iter()
            .flatten()
            .map(|b| b.rays.len() as u64)
            .sum()
    }

    /// The cache's file.
    pub fn encode(&self) -> Vec<u8> {
        let mut out = Vec::with_capacity(self.ray_bytes() as usize + 64 * self.elements.len());
        self.write_to(&mut out).expect("a Vec takes every byte");
        out
    }

    /// Writes the cache's file ([`Self::encode`]'s bytes) to `out`, the rays from where they
    /// lie; returns the bytes written. A large scene's cache runs to gigabytes, which a copy
    /// in one buffer would double at the end of the solve.
    pub fn write_to(&self, out: &mut impl std::io::Write) -> std::io::Result<u64> {
        let mut head = Vec::with_capacity(64);
        head.extend_from_slice(MAGIC);
        head.extend_from_slice(&VERSION.to_le_bytes());
        head.extend_from_slice(&self.key);
        head.extend_from_slice(&(self.lobes.len() as u32).to_le_bytes());
        for l in &self.lobes {
            head.extend_from_slice(l);
        }
        head.extend_from_slice(&(self.elements.len() as u32).to_le_bytes());
        let mut written = 0u64;
        for batches in &self.elements {
            head.extend_from_slice(&(batches.len() as u32).to_le_bytes());
            for b in batches {
                for v in [b.round, b.first, b.n_rays, b.n_light] {
                    head.extend_from_slice(&v.to_le_bytes());
                }
                head.push(u8::from(b.inside));
                put_vec3(&mut head, b.lights.direct);
                head.extend_from_slice(&b.lights.var.to_bits().to_le_bytes());
                head.extend_from_slice(&b.lights.rays.to_le_bytes());
                head.extend_from_slice(&(b.rays.len() as u32).to_le_bytes());
                out.write_all(&head)?;
                out.write_all(&b.rays)?;
                written += (head.len() + b.rays.len()) as u64;
                head.clear();
            }
        }
        out.write_all(&head)?;
        Ok(written + head.len() as u64)
    }

    /// Reads a cache file (its rays are checked as they are used).
    pub fn decode(bytes: &[u8]) -> Result<RayCache, CacheError> {
        let mut at = 0usize;
        let err = |what: &str| CacheError(what.into());
        let mut take = |n: usize| -> Result<&[u8], CacheError> {
            let s = bytes
                .get(at..at.checked_add(n).ok_or_else(|| err("length overflows"))?)
                .ok_or_else(|| err("truncated"))?;
            at += n;
            Ok(s)
        };
        if take(8)? != MAGIC {
            return Err(err("bad magic"));
        }
        let u32_of = |s: &[u8]| u32::from_le_bytes(s.try_into().expect("4 bytes"));
        let u64_of = |s: &[u8]| u64::from_le_bytes(s.try_into().expect("8 bytes"));
        let f32_of = |s: &[u8]| f32::from_bits(u32_of(s));
        let version = u32_of(take(4)?);
        if version != VERSION {
            return Err(CacheError(format!(
                "version {version}, this glint reads {VERSION}"
            )));
        }
        let key: [u8; 32] = take(32)?.try_into().expect("32 bytes");
        let m = u32_of(take(4)?) as usize;
        let mut lobes = Vec::with_capacity(m.min(1 << 16));
        for _ in 0..m {
            lobes.push(take(32)?.try_into().expect("32 bytes"));
        }
        let e = u32_of(take(4)?) as usize;
        let mut elements = Vec::with_capacity(e.min(bytes.len() / 4));
        for _ in 0..e {
            let n = u32_of(take(4)?) as usize;
            let mut batches = Vec::with_capacity(n.min(64));
            for _ in 0..n {
                let (round, first, n_rays, n_light) = (
                    u32_of(take(4)?),
                    u32_of(take(4)?),
                    u32_of(take(4)?),
                    u32_of(take(4)?),
                );
                let inside = match take(1)?[0] {
                    0 => false,
                    1 => true,
                    _ => return Err(err("inside flag")),
                };
                let direct = Vec3::new(f32_of(take(4)?), f32_of(take(4)?), f32_of(take(4)?));
                let var = f64::from_bits(u64_of(take(8)?));
                let rays = u64_of(take(8)?);
                let len = u32_of(take(4)?) as usize;
                let packed = take(len)?.to_vec();
                batches.push(KeptBatch {
                    round,
                    first,
                    n_rays,
                    n_light,
                    inside,
                    lights: LightPart { direct, var, rays },
                    rays: packed,
                });
            }
            elements.push(batches);
        }
        if at != bytes.len() {
            return Err(err("trailing bytes"));
        }
        Ok(RayCache {
            key,
            lobes,
            elements,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn record(hit: u32, terms: u32) -> RayRecord {
        RayRecord {
            hit,
            terms,
            ..Default::default()
        }
    }

    #[test]
    fn rays_and_batches_read_back_bit_for_bit() {
        let records = vec![
            RayRecord {
                rays: 1,
                ..record(u32::MAX, 0)
            },
            RayRecord {
                emission: Vec3::new(0.5, -0.0, 1e-30),
                weighted: true,
                rays: 1,
                ..record(0, 0)
            },
            RayRecord {
                glossy: Vec3::splat(0.25),
                rays: 7,
                lobes_read: 1 << 63 | 5,
                ..record(123_456, 2)
            },
            RayRecord {
                rays: 0,
                ..record(u32::MAX - 1, 1)
            },
        ];
        let terms = vec![
            Term {
                texel: 9,
                weight: Vec3::splat(0.5),
            },
            Term {
                texel: u32::MAX - 1,
                weight: Vec3::new(0.1, 0.2, -0.0),
            },
            Term {
                texel: 0,
                weight: Vec3::new(-0.0, 0.0, 0.0),
            },
        ];
        let batch = KeptBatch {
            round: 2,
            first: 40,
            n_rays: records.len() as u32,
            n_light: 3,
            inside: true,
            lights: LightPart {
                direct: Vec3::new(1.0, 2.0, 3.0),
                var: 1e-300,
                rays: 1 << 40,
            },
            rays: KeptBatch::pack(&records, &terms),
        };
        let (r, t) = batch.unpack().unwrap();
        let bits = |v: Vec3| v.to_array().map(f32::to_bits);
        assert_eq!(r.len(), records.len());
        for (a, b) in r.iter().zip(&records) {
            assert_eq!(
                (a.hit, a.rays, a.terms, a.lobes_read),
                (b.hit, b.rays, b.terms, b.lobes_read)
            );
            assert_eq!(a.weighted, b.weighted);
            assert_eq!(bits(a.emission), bits(b.emission));
            assert_eq!(bits(a.glossy), bits(b.glossy));
        }
        assert_eq!(t.len(), terms.len());
        for (a, b) in t.iter().zip(&terms) {
            assert_eq!((a.texel, bits(a.weight)), (b.texel, bits(b.weight)));
        }
        let cache = RayCache {
            key: [7; 32],
            lobes: vec![[1; 32], [2; 32]],
            elements: vec![vec![batch.clone()], Vec::new()],
        };
        let bytes = cache.encode();
        assert_eq!(RayCache::decode(&bytes).unwrap(), cache);
        // Streamed, the same bytes, counted (an element without batches included).
        let mut streamed = std::io::Cursor::new(Vec::new());
        assert_eq!(cache.write_to(&mut streamed).unwrap(), bytes.len() as u64);
        assert_eq!(streamed.into_inner(), bytes);
        for cut in [0, 9, bytes.len() / 2, bytes.len() - 1] {
            assert!(RayCache::decode(&bytes[..cut]).is_err(), "{cut}");
        }
        // A batch whose bytes hold fewer records than it claims is not used.
        let short = KeptBatch { n_rays: 5, ..batch };
        assert!(short.unpack().is_none());
    }

    #[test]
    fn only_the_materials_whose_lobes_changed_are_named_and_only_under_the_same_key() {
        let cache = RayCache {
            key: [7; 32],
            lobes: vec![[1; 32], [2; 32], [3; 32]],
            elements: vec![Vec::new(); 4],
        };
        assert_eq!(
            cache.changed(&[7; 32], &[[1; 32], [2; 32], [3; 32]], 4),
            Some(0)
        );
        assert_eq!(
            cache.changed(&[7; 32], &[[1; 32], [9; 32], [3; 32]], 4),
            Some(0b10)
        );
        assert_eq!(
            cache.changed(&[8; 32], &[[1; 32], [2; 32], [3; 32]], 4),
            None
        );
        assert_eq!(cache.changed(&[7; 32], &[[1; 32], [2; 32]], 4), None);
        assert_eq!(
            cache.changed(&[7; 32], &[[1; 32], [2; 32], [3; 32]], 5),
            None
        );
    }
}

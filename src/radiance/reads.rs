//! What a radiance map's pixels read of D, kept so that a bake after an edit that changes only
//! D re-shades the map from its reads instead of sampling and tracing it again.
//!
//! A map pixel's radiance ([`super::shading::exitant`]) is a fixed sum over reads of D: D
//! where its ray meets a surface (through a textured material's factors, read over the
//! pixel's footprint), the same behind each pane of thin glass it sees through (times the
//! panes' transmittance), and D where each lobe sample of a glossy surface lands (times the
//! sample's weight, the lobe's k_s and 1/N). Everything but D is fixed by the geometry, the
//! map's camera and the materials met. The shading writes that sum as a record (bytes, one
//! pixel after another); [`eval_pixel`] evaluates it against a D in the float operations of
//! the shading, so a map evaluated from its record after an edit has the bytes of a map
//! traced with the new D. Every bake evaluates its maps through its records, traced or kept.
//!
//! A pixel's record: `u8` layer count (0: its ray met nothing), `f32` the ray's distance to
//! its hit, then per layer: the cumulative transmittance (`3 × f32`, layers after the first),
//! the read of D at the surface, a `u8` lobe count ([`NO_GLOSSY`]: D alone) and per lobe its
//! k_s (`3 × f32`), a `u8` sample count and per sample its weight (`f32`) and its read. A read:
//! `u32` triangle (top bit: textured), barycentrics (`2 × f32`) and, textured, the factors
//! ([`crate::scene::texturing::apply_d_factors`], `6 × f32`). Little-endian.

use std::borrow::Cow;

use glam::{Vec2, Vec3};

use crate::scene::texturing::apply_d_factors;

/// Directions sampled per glossy lobe at a map pixel that meets a glossy surface (the
/// shading's, and the divisor of a lobe's sum when a record is evaluated).
pub const GLOSSY_SAMPLES: u32 = 16;

/// Lobe count of a layer whose surface gives D alone (no glossy lobe faces the ray).
pub const NO_GLOSSY: u8 = u8::MAX;

/// The top bit of a read's triangle: the read carries a textured material's factors.
const TEXTURED: u32 = 1 << 31;

/// One read of D: the stored value at barycentrics `bary` of `triangle`, through a textured
/// material's factors.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Read {
    /// The triangle.
    pub triangle: u32,
    /// Barycentrics on it.
    pub bary: Vec2,
    /// A textured material's factors ([`crate::scene::texturing::d_factors_over`]).
    pub factors: Option<(Vec3, Vec3)>,
}

/// Appends `v` (`3 × f32`, little-endian).
pub fn push_vec3(out: &mut Vec<u8>, v: Vec3) {
    for c in v.to_array() {
        out.extend(c.to_le_bytes());
    }
}

/// Appends a read: its triangle (top bit: textured), barycentrics and any factors.
pub fn push_read(out: &mut Vec<u8>, r: &Read) {
    let flag = if r.factors.is_some() { TEXTURED } else { 0 };
    out.extend((r.triangle | flag).to_le_bytes());
    out.extend(r.bary.x.to_le_bytes());
    out.extend(r.bary.y.to_le_bytes());
    if let Some((t, e)) = r.factors {
        push_vec3(out, t);
        push_vec3(out, e);
    }
}

/// Writes one hit pixel's record into a row's bytes, as the shading meets its reads.
pub struct PixelWriter<'a> {
    out: &'a mut Vec<u8>,
    /// Where the layer count is.
    start: usize,
    /// Where the current lobe's sample count is.
    samples_at: usize,
}

impl<'a> PixelWriter<'a> {
    /// Begins the record of a pixel whose ray met a surface at distance `t`.
    pub fn hit(out: &'a mut Vec<u8>, t: f32) -> PixelWriter<'a> {
        let start = out.len();
        out.push(0);
        out.extend(t.to_le_bytes());
        PixelWriter {
            out,
            start,
            samples_at: 0,
        }
    }

    /// A new layer (the first: the surface the ray meets; then each surface behind a pane of
    /// glass, `weight` the panes' transmittance so far) and the read of D at it.
    pub fn layer(&mut self, weight: Vec3, seen: &Read) {
        let layers = &mut self.out[self.start];
        let first = *layers == 0;
        *layers += 1;
        if !first {
            push_vec3(self.out, weight);
        }
        push_read(self.out, seen);
    }

    /// The current layer gives D alone.
    pub fn d_alone(&mut self) {
        self.out.push(NO_GLOSSY);
    }

    /// The current layer adds the reflection of `lobes` glossy lobes.
    pub fn lobes(&mut self, lobes: usize) {
        debug_assert!(lobes < NO_GLOSSY as usize);
        self.out.push(lobes as u8);
    }

    /// Begins a lobe of reflectance `ks`.
    pub fn lobe(&mut self, ks: Vec3) {
        push_vec3(self.out, ks);
        self.samples_at = self.out.len();
        self.out.push(0);
    }

    /// A sample of the current lobe: its weight and where it reads D.
    pub fn sample(&mut self, weight: f32, read: &Read) {
        self.out[self.samples_at] += 1;
        self.out.extend(weight.to_le_bytes());
        push_read(self.out, read);
    }
}

/// Writes the record of a pixel whose ray met nothing.
pub fn push_miss(out: &mut Vec<u8>) {
    out.push(0);
}

/// A pixel evaluated from its record.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Evaluated {
    /// Its radiance.
    pub rgb: Vec3,
    /// The triangle its ray met and the distance to it; `None` for a miss.
    pub hit: Option<(u32, f32)>,
    /// Whether a surface it shaded (one of its layers) is one `stale` names.
    pub stale: bool,
    /// Bytes of its record.
    pub len: usize,
}

/// Reads a record's bytes in order; `None` past their end or at a triangle not below
/// `triangles`.
pub struct Cursor<'a> {
    bytes: &'a [u8],
    /// Bytes read so far.
    pub at: usize,
    triangles: usize,
}

impl<'a> Cursor<'a> {
    /// A cursor at the start of `bytes`, of a scene of `triangles` triangles.
    pub fn new(bytes: &'a [u8], triangles: usize) -> Cursor<'a> {
        Cursor {
            bytes,
            at: 0,
            triangles,
        }
    }

    /// The next byte.
    pub fn u8(&mut self) -> Option<u8> {
        let b = *self.bytes.get(self.at)?;
        self.at += 1;
        Some(b)
    }

    /// The next `u32`.
    pub fn u32(&mut self) -> Option<u32> {
        let b = self.bytes.get(self.at..self.at + 4)?;
        self.at += 4;
        Some(u32::from_le_bytes(b.try_into().ok()?))
    }

    /// The next `f32`.
    pub fn f32(&mut self) -> Option<f32> {
        self.u32().map(f32::from_bits)
    }

    /// The next `3 × f32`.
    pub fn vec3(&mut self) -> Option<Vec3> {
        Some(Vec3::new(self.f32()?, self.f32()?, self.f32()?))
    }

    /// The next read ([`push_read`]).
    pub fn read(&mut self) -> Option<Read> {
        let word = self.u32()?;
        let triangle = word & !TEXTURED;
        if triangle as usize >= self.triangles {
            return None;
        }
        let bary = Vec2::new(self.f32()?, self.f32()?);
        let factors = if word & TEXTURED != 0 {
            Some((self.vec3()?, self.vec3()?))
        } else {
            None
        };
        Some(Read {
            triangle,
            bary,
            factors,
        })
    }
}

/// Evaluates the record at the start of `bytes` against D (`d`: the stored value at
/// barycentrics of a triangle), in the float operations of [`super::shading::exitant`];
/// `stale` is asked of each layer's triangle. `None` for bytes that are no whole record or
/// read a triangle not below `triangles`.
pub fn eval_pixel(
    bytes: &[u8],
    triangles: usize,
    stale: &dyn Fn(u32) -> bool,
    d: &dyn Fn(u32, Vec2) -> Vec3,
) -> Option<Evaluated> {
    let mut c = Cursor::new(bytes, triangles);
    let layers = c.u8()?;
    if layers == 0 {
        return Some(Evaluated {
            rgb: Vec3::ZERO,
            hit: None,
            stale: false,
            len: 1,
        });
    }
    let t = c.f32()?;
    let read_d = |r: &Read| apply_d_factors(d(r.triangle, r.bary), r.factors);
    let (mut sum, mut first, mut is_stale) = (Vec3::ZERO, 0u32, false);
    for layer in 0..layers {
        let weight = if layer == 0 { Vec3::ONE } else { c.vec3()? };
        let seen = c.read()?;
        if layer == 0 {
            first = seen.triangle;
        }
        is_stale |= stale(seen.triangle);
        let base = read_d(&seen);
        let lobes = c.u8()?;
        let own = if lobes == NO_GLOSSY {
            base
        } else {
            let mut glossy = Vec3::ZERO;
            for _ in 0..lobes {
                let ks = c.vec3()?;
                let mut lobe_sum = Vec3::ZERO;
                for _ in 0..c.u8()? {
                    let w = c.f32()?;
                    lobe_sum += w * read_d(&c.read()?);
                }
                glossy += ks * lobe_sum / GLOSSY_SAMPLES as f32;
            }
            base + glossy
        };
        if layer == 0 {
            sum = own;
        } else {
            sum += weight * own;
        }
    }
    Some(Evaluated {
        rgb: sum,
        hit: Some((first, t)),
        stale: is_stale,
        len: c.at,
    })
}

/// One map's records: each row's pixels' records, in order. Rows kept from an earlier bake
/// borrow the bytes of the file they were read from ([`MapReads::decode`]); rows traced again
/// own theirs.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct MapReads<'a> {
    /// Row y's bytes.
    pub rows: Vec<Cow<'a, [u8]>>,
}

impl<'a> MapReads<'a> {
    /// The encoding's head: the row count and each row's length (`u32`); the rows follow it.
    pub fn head(&self) -> Vec<u8> {
        let mut out = Vec::with_capacity(4 + 4 * self.rows.len());
        out.extend((self.rows.len() as u32).to_le_bytes());
        for r in &self.rows {
            out.extend((r.len() as u32).to_le_bytes());
        }
        out
    }

    /// Bytes: [`MapReads::head`], then the rows.
    pub fn encode(&self) -> Vec<u8> {
        let mut out = self.head();
        out.reserve(self.size() - out.len());
        for r in &self.rows {
            out.extend_from_slice(r);
        }
        out
    }

    /// Decodes [`MapReads::encode`]'s bytes, the rows borrowing them; `None` unless they are
    /// whole.
    pub fn decode(bytes: &'a [u8]) -> Option<MapReads<'a>> {
        let word = |i: usize| -> Option<usize> {
            Some(u32::from_le_bytes(bytes.get(4 * i..4 * i + 4)?.try_into().ok()?) as usize)
        };
        let n = word(0)?;
        let lens: Vec<usize> = (0..n).map(|i| word(1 + i)).collect::<Option<_>>()?;
        let mut at = 4 * (n + 1);
        let mut rows = Vec::with_capacity(n);
        for len in lens {
            rows.push(Cow::Borrowed(bytes.get(at..at.checked_add(len)?)?));
            at += len;
        }
        (at == bytes.len()).then_some(MapReads { rows })
    }

    /// Bytes of the encoding.
    pub fn size(&self) -> usize {
        4 + self.rows.iter().map(|r| 4 + r.len()).sum::<usize>()
    }
}

/// Per row, its kept records (`None`: none kept, the row is traced whole).
pub type KeptRows<'a> = Vec<Option<Cow<'a, [u8]>>>;

/// A map's or cube map's kept records to evaluate with this bake's D instead of tracing, and
/// per material whether the lobes or transmission that shaped them changed since: an item
/// whose surfaces meet such a material is traced again.
#[derive(Clone, Debug)]
pub struct Replay<'a> {
    /// The records, row by row (`None`: a row none are kept of, traced whole).
    pub rows: KeptRows<'a>,
    /// Per material index, whether it changed since the records were made: one list for
    /// every row, or one per equal run of rows (a cube's faces, each kept in a file of its
    /// own).
    pub changed: Vec<&'a [bool]>,
}

impl<'a> Replay<'a> {
    /// Every row of `reads` kept, with the materials `changed` since they were made.
    pub fn of(reads: MapReads<'a>, changed: &'a [bool]) -> Replay<'a> {
        Replay {
            rows: reads.rows.into_iter().map(Some).collect(),
            changed: vec![changed],
        }
    }

    /// Per row of `n`, its kept records (none without a replay, or for records of another
    /// row count) and the materials changed since (none known: every material counts as
    /// changed).
    pub fn rows(replay: Option<Replay<'a>>, n: usize) -> (KeptRows<'a>, Vec<&'a [bool]>) {
        match replay {
            Some(r)
                if r.rows.len() == n
                    && !r.changed.is_empty()
                    && n.is_multiple_of(r.changed.len()) =>
            {
                let run = n / r.changed.len();
                let changed = (0..n).map(|row| r.changed[row / run]).collect();
                (r.rows, changed)
            }
            _ => (vec![None; n], vec![&[]; n]),
        }
    }
}

/// A kept record evaluated: its length in bytes, whether a surface it shaded is one whose
/// material changed, and its value.
pub struct Kept<T> {
    /// Bytes of the record.
    pub len: usize,
    /// Whether it must be traced again.
    pub stale: bool,
    /// The item's value from the record.
    pub value: T,
}

/// One row of `n` items (a map's pixels, a cube map's texels) from the row's kept records
/// `old`: an item whose record evaluates (`kept(i, bytes from its record on)`) and is not
/// stale keeps it; the others are traced again (`traced(i, out)` appends the new record to
/// `out` and gives the value). The row's records are rebuilt from its first item traced again
/// (until then, and if none is, they are the old ones); past a record that does not evaluate,
/// every item is traced. Returns the values, the row's records and how many were traced.
pub fn replay_row<'a, T>(
    old: Cow<'a, [u8]>,
    n: usize,
    kept: impl Fn(usize, &[u8]) -> Option<Kept<T>>,
    mut traced: impl FnMut(usize, &mut Vec<u8>) -> T,
) -> (Vec<T>, Cow<'a, [u8]>, u64) {
    let mut values = Vec::with_capacity(n);
    let mut fresh: Option<Vec<u8>> = None;
    let mut at = Some(0usize);
    let mut retraced = 0u64;
    for i in 0..n {
        let start = at;
        let evaluated = at.and_then(|a| {
            let e = kept(i, &old[a..]);
            at = e.as_ref().map(|e| a + e.len);
            e.filter(|e| !e.stale).map(|e| (a, e))
        });
        match evaluated {
            Some((a, e)) => {
                if let Some(f) = &mut fresh {
                    f.extend_from_slice(&old[a..a + e.len]);
                }
                values.push(e.value);
            }
            None => {
                let f = fresh.get_or_insert_with(|| old[..start.unwrap_or(0)].to_vec());
                values.push(traced(i, f));
                retraced += 1;
            }
        }
    }
    (values, fresh.map_or(old, Cow::Owned), retraced)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn read(triangle: u32, textured: bool) -> Read {
        Read {
            triangle,
            bary: Vec2::new(0.25, 0.5),
            factors: textured.then_some((Vec3::new(0.5, 0.25, 1.0), Vec3::new(0.0, 0.1, 0.0))),
        }
    }

    /// D of a made-up scene: a different value per triangle and point.
    fn d(t: u32, b: Vec2) -> Vec3 {
        Vec3::new(t as f32 + b.x, 1.0 + b.y, 0.5 * t as f32)
    }

    #[test]
    fn a_record_evaluates_to_its_sum_and_names_its_surfaces() {
        let mut row = Vec::new();
        push_miss(&mut row);
        let mut w = PixelWriter::hit(&mut row, 2.5);
        w.layer(Vec3::ONE, &read(1, true));
        w.lobes(1);
        w.lobe(Vec3::splat(0.5));
        w.sample(2.0, &read(2, false));
        w.sample(4.0, &read(0, true));
        w.layer(Vec3::splat(0.5), &read(3, false));
        w.d_alone();
        let miss = eval_pixel(&row, 4, &|_| false, &d).unwrap();
        assert_eq!((miss.rgb, miss.hit, miss.len), (Vec3::ZERO, None, 1));
        let hit = eval_pixel(&row[1..], 4, &|t| t == 3, &d).unwrap();
        assert_eq!(hit.len, row.len() - 1);
        assert_eq!(hit.hit, Some((1, 2.5)));
        assert!(hit.stale);
        let f = |r: Read| apply_d_factors(d(r.triangle, r.bary), r.factors);
        let lobe = 2.0 * f(read(2, false)) + 4.0 * f(read(0, true));
        let want = (f(read(1, true)) + Vec3::splat(0.5) * lobe / 16.0)
            + Vec3::splat(0.5) * f(read(3, false));
        assert_eq!(hit.rgb, want);
        assert!(!eval_pixel(&row[1..], 4, &|t| t == 2, &d).unwrap().stale);
        // A triangle the scene does not have, a cut record.
        assert_eq!(eval_pixel(&row[1..], 3, &|_| false, &d), None);
        assert_eq!(eval_pixel(&row[1..row.len() - 1], 4, &|_| false, &d), None);
    }

    #[test]
    fn map_reads_round_trip_and_cut_bytes_are_refused() {
        let m = MapReads {
            rows: vec![vec![0, 0].into(), vec![].into(), vec![1, 2, 3].into()],
        };
        let bytes = m.encode();
        assert_eq!(bytes.len(), m.size());
        assert_eq!(MapReads::decode(&bytes), Some(m));
        assert_eq!(MapReads::decode(&bytes[..bytes.len() - 1]), None);
        let mut long = bytes.clone();
        long.push(0);
        assert_eq!(MapReads::decode(&long), None);
    }
}

//! An element's glossy terms held packed, in their gathering order and with their exact
//! values: the solve reads them every bounce, and at building scale, unpacked, they would be
//! most of its memory (docs/tuning.md#cache-budget).
//!
//! Each term is one LEB128 varint ([`super::varint`]), the zigzagged difference from the previous term's texel
//! shifted left by one, its low bit set when the weight is grey (three equal components, as
//! every path through grey lobes gives: one float then, else three). The floats are stored as
//! their bits, so a term reads back exactly as it was pushed and the solve's sums do not
//! change by a bit.

use glam::Vec3;

use super::transport::Term;
use super::varint;

/// Glossy terms, packed (module comment).
#[derive(Clone, Debug, Default, PartialEq)]
pub(super) struct PackedTerms {
    bytes: Vec<u8>,
    /// The last pushed term's texel (the next difference's base).
    last: u32,
}

impl PackedTerms {
    /// Heap bytes held.
    pub fn bytes(&self) -> u64 {
        self.bytes.capacity() as u64
    }

    /// Bytes of packed terms (by length: independent of the allocator).
    pub fn len_bytes(&self) -> u64 {
        self.bytes.len() as u64
    }

    /// Appends `terms` in order, keeping no spare capacity.
    pub fn extend(&mut self, terms: impl IntoIterator<Item = Term>) {
        for t in terms {
            let delta = t.texel.wrapping_sub(self.last) as i32;
            self.last = t.texel;
            let zigzag = ((delta << 1) ^ (delta >> 31)) as u32;
            let grey = t.weight.x.to_bits() == t.weight.y.to_bits()
                && t.weight.x.to_bits() == t.weight.z.to_bits();
            varint::push(&mut self.bytes, (u64::from(zigzag) << 1) | u64::from(grey));
            let floats: &[f32] = if grey {
                &[t.weight.x]
            } else {
                &[t.weight.x, t.weight.y, t.weight.z]
            };
            for f in floats {
                self.bytes.extend_from_slice(&f.to_bits().to_le_bytes());
            }
        }
        self.bytes.shrink_to_fit();
    }

    /// Calls `f` with each term's texel and weight in the order they were pushed, exactly:
    /// the loop every bounce runs. One-byte heads (nearly all) are read without the varint
    /// loop.
    #[inline]
    pub fn for_each(&self, mut f: impl FnMut(u32, Vec3)) {
        let bytes = self.bytes.as_slice();
        let float = |at: usize| {
            let b: [u8; 4] = bytes[at..at + 4].try_into().expect("4 bytes");
            f32::from_bits(u32::from_le_bytes(b))
        };
        let (mut at, mut texel) = (0usize, 0u32);
        while at < bytes.len() {
            let head = match bytes[at] {
                b if b < 0x80 => {
                    at += 1;
                    u64::from(b)
                }
                _ => varint::read(bytes, &mut at).expect("terms end on a whole varint"),
            };
            let zigzag = (head >> 1) as u32;
            let delta = ((zigzag >> 1) as i32) ^ -((zigzag & 1) as i32);
            texel = texel.wrapping_add(delta as u32);
            let weight = if head & 1 == 1 {
                at += 4;
                Vec3::splat(float(at - 4))
            } else {
                at += 12;
                Vec3::new(float(at - 12), float(at - 8), float(at - 4))
            };
            f(texel, weight);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn term(texel: u32, weight: Vec3) -> Term {
        Term { texel, weight }
    }

    /// The terms `for_each` reads back, in its order.
    fn read_back(packed: &PackedTerms) -> Vec<Term> {
        let mut out = Vec::new();
        packed.for_each(|texel, weight| out.push(Term { texel, weight }));
        out
    }

    #[test]
    fn terms_read_back_exactly_in_their_order() {
        let terms = vec![
            term(7, Vec3::splat(0.25)),
            term(0, Vec3::new(0.1, 0.2, 0.3)),
            term(u32::MAX - 1, Vec3::splat(f32::MIN_POSITIVE)),
            term(3, Vec3::new(-0.0, 0.0, 0.0)),
            term(3, Vec3::splat(1e30)),
            term(1 << 31, Vec3::new(1.0, 1.0, 1.0 + f32::EPSILON)),
            term(12_345_678, Vec3::splat(f32::from_bits(0x3f80_0001))),
        ];
        let mut packed = PackedTerms::default();
        packed.extend(terms[..3].iter().copied());
        packed.extend(terms[3..].iter().copied());
        let back = read_back(&packed);
        assert_eq!(back.len(), terms.len());
        for (a, b) in back.iter().zip(&terms) {
            assert_eq!(a.texel, b.texel);
            // Bit for bit: -0.0 stays -0.0 and is not grey with +0.0.
            assert_eq!(
                a.weight.to_array().map(f32::to_bits),
                b.weight.to_array().map(f32::to_bits)
            );
        }
    }

    #[test]
    fn grey_terms_near_each_other_take_under_half_the_bytes() {
        // A glossy floor's terms: grey weights, texels near the last one.
        let mut packed = PackedTerms::default();
        let n = 1000u32;
        packed.extend((0..n).map(|k| term(50_000 + (k * 37) % 300, Vec3::splat(k as f32 * 1e-3))));
        assert_eq!(read_back(&packed).len(), n as usize);
        let unpacked = n as u64 * size_of::<Term>() as u64;
        assert!(
            packed.bytes() * 2 < unpacked,
            "{} bytes packed for {unpacked} unpacked",
            packed.bytes()
        );
        // A coloured weight costs its three floats.
        let mut colour = PackedTerms::default();
        colour.extend([term(5, Vec3::new(0.5, 0.25, 0.125))]);
        assert_eq!(colour.bytes(), 1 + 12);
    }

    #[test]
    fn an_empty_list_reads_nothing() {
        let packed = PackedTerms::default();
        assert_eq!(read_back(&packed).len(), 0);
    }
}

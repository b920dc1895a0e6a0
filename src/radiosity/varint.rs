//! LEB128 varints, the packing of the solve's cached links ([`super::terms`] and the links'
//! hit lists): 7 bits a byte, low bits first, the high bit set on every byte but the last.

/// Appends `v`.
pub(super) fn push(out: &mut Vec<u8>, mut v: u64) {
    while v >= 0x80 {
        out.push(v as u8 | 0x80);
        v >>= 7;
    }
    out.push(v as u8);
}

/// Reads the varint at `*at` and moves past it; `None` at the end of `bytes`.
///
/// The solve's bounces read every link this way, and the lengths of the links' gaps (one or
/// two bytes, about evenly) defeat branch prediction in a byte-at-a-time loop: where eight
/// bytes are left, the varint is found in one word without a branch on its length.
#[inline]
pub(super) fn read(bytes: &[u8], at: &mut usize) -> Option<u64> {
    if let Some(word) = bytes.get(*at..*at + 8) {
        let w = u64::from_le_bytes(word.try_into().expect("8 bytes"));
        // The last byte is the first whose high bit is clear.
        let ends = !w & 0x8080_8080_8080_8080;
        if ends != 0 {
            let len = ends.trailing_zeros() / 8 + 1;
            let kept = if len == 8 {
                u64::MAX
            } else {
                (1u64 << (8 * len)) - 1
            };
            // Drop the continuation bits, then close the 7-bit groups up pairwise.
            let mut v = w & kept & 0x7f7f_7f7f_7f7f_7f7f;
            v = (v & 0x007f_007f_007f_007f) | ((v & 0x7f00_7f00_7f00_7f00) >> 1);
            v = (v & 0x0000_3fff_0000_3fff) | ((v & 0x3fff_0000_3fff_0000) >> 2);
            v = (v & 0x0000_0000_0fff_ffff) | ((v & 0x0fff_ffff_0000_0000) >> 4);
            *at += len as usize;
            return Some(v);
        }
    }
    read_bytewise(bytes, at)
}

/// [`read`] a byte at a time: near the end of `bytes`, and for varints over eight bytes.
fn read_bytewise(bytes: &[u8], at: &mut usize) -> Option<u64> {
    let (mut v, mut shift) = (0u64, 0);
    loop {
        let b = *bytes.get(*at)?;
        *at += 1;
        v |= u64::from(b & 0x7f) << shift;
        if b < 0x80 {
            return Some(v);
        }
        shift += 7;
    }
}

#[cfg(test)]
mod tests {
    #[test]
    fn values_read_back_in_the_fewest_bytes() {
        let values = [
            0u64,
            1,
            0x7f,
            0x80,
            0x3fff,
            0x4000,
            u32::MAX as u64,
            u64::MAX,
        ];
        let mut out = Vec::new();
        let mut sizes = Vec::new();
        for v in values {
            let before = out.len();
            super::push(&mut out, v);
            sizes.push(out.len() - before);
        }
        assert_eq!(sizes, [1, 1, 1, 2, 2, 3, 5, 10]);
        let mut at = 0;
        for v in values {
            assert_eq!(super::read(&out, &mut at), Some(v));
        }
        assert_eq!(super::read(&out, &mut at), None);
    }

    #[test]
    fn the_word_read_gives_what_the_bytewise_read_gives_at_every_offset() {
        // Values of every length from 1 to 10 bytes, packed back to back, so that every
        // varint is read both from a full word and, near the end, byte by byte.
        let mut values = Vec::new();
        let mut x = 0x9e37_79b9_7f4a_7c15u64;
        for bits in 0..=64u32 {
            for _ in 0..3 {
                x ^= x << 13;
                x ^= x >> 7;
                x ^= x << 17;
                values.push(if bits == 64 {
                    x
                } else {
                    x & ((1u64 << bits) - 1)
                });
            }
        }
        let mut out = Vec::new();
        for &v in &values {
            super::push(&mut out, v);
        }
        let (mut at, mut slow) = (0, 0);
        for &v in &values {
            assert_eq!(super::read(&out, &mut at), Some(v));
            assert_eq!(super::read_bytewise(&out, &mut slow), Some(v));
            assert_eq!(at, slow);
        }
        assert_eq!(super::read(&out, &mut at), None);
        // From every offset, mid-varint included, both reads agree on value and length.
        for start in 0..out.len() {
            let (mut a, mut b) = (start, start);
            assert_eq!(
                super::read(&out, &mut a),
                super::read_bytewise(&out, &mut b)
            );
            assert_eq!(a, b);
        }
    }
}

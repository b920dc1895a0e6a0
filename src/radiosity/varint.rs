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
pub(super) fn read(bytes: &[u8], at: &mut usize) -> Option<u64> {
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
}

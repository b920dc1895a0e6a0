//! Mutations of a byte string: the input generator of the coverage-free fuzz loop.
//!
//! Each input is a seed from the corpus with one to eight stacked mutations: bit flips,
//! byte sets, "interesting" integers and floats written over the bytes (both endiannesses),
//! small additions, inserts, deletes, duplications, splices with another seed, and for text
//! formats number and token replacements. Everything is a pure function of the [`FuzzRng`]
//! state, so an input is reproducible from the seed and the execution index.

/// SplitMix64: a small, fast, seedable generator (Steele et al. 2014).
#[derive(Clone, Debug)]
pub struct FuzzRng(u64);

impl FuzzRng {
    /// The generator of execution `index` of a run seeded with `seed`.
    pub fn new(seed: u64, index: u64) -> FuzzRng {
        let mut r = FuzzRng(seed ^ index.wrapping_mul(0x9e37_79b9_7f4a_7c15));
        r.next_u64();
        r
    }

    /// The next 64 random bits.
    pub fn next_u64(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9e37_79b9_7f4a_7c15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
        z ^ (z >> 31)
    }

    /// Uniform in `0..n` (`n` > 0).
    pub fn below(&mut self, n: usize) -> usize {
        (self.next_u64() % n as u64) as usize
    }

    /// True with probability 1 / `n`.
    pub fn one_in(&mut self, n: usize) -> bool {
        self.below(n) == 0
    }
}

/// Integers that sit on boundaries: zero, one, sign bits, all ones, powers of two.
const INTERESTING: &[u64] = &[
    0,
    1,
    2,
    3,
    4,
    7,
    8,
    16,
    31,
    32,
    64,
    100,
    127,
    128,
    255,
    256,
    1000,
    1024,
    4096,
    32767,
    32768,
    65535,
    65536,
    0x7fff_ffff,
    0x8000_0000,
    0xffff_fffe,
    0xffff_ffff,
    0x1_0000_0000,
    0x7fff_ffff_ffff_ffff,
    0x8000_0000_0000_0000,
    u64::MAX,
];

/// Floats that break arithmetic: NaN, infinities, zero signs, extremes, denormals.
const INTERESTING_F32: &[f32] = &[
    0.0,
    -0.0,
    1.0,
    -1.0,
    0.5,
    f32::NAN,
    f32::INFINITY,
    f32::NEG_INFINITY,
    f32::MAX,
    f32::MIN,
    f32::MIN_POSITIVE,
    1e-45,
    1e30,
    -1e30,
    1e12,
];

/// Number texts for JSON: limits of the integer types, floats past f32, signs.
const NUMBERS: &[&str] = &[
    "0",
    "-0",
    "1",
    "-1",
    "2",
    "0.5",
    "-0.5",
    "1e-45",
    "1e12",
    "1e30",
    "1e39",
    "1e308",
    "1e309",
    "-1e309",
    "255",
    "256",
    "65535",
    "65536",
    "2147483647",
    "2147483648",
    "4294967295",
    "4294967296",
    "9007199254740993",
    "18446744073709551615",
    "18446744073709551616",
    "3.4028236e38",
];

/// JSON fragments: structure, literals, deep nesting.
const TOKENS: &[&str] = &[
    "{", "}", "[", "]", "\"", ",", ":", "null", "true", "false", "\"\"", "[]", "{}", "\"a\"",
    "\\u0000", "\\ud800", "[[[[[[[[", "]]]]]]]]", "{\"a\":", "../", "/", "..", "\u{0}",
];

/// Largest input the mutator makes.
pub const MAX_LEN: usize = 1 << 20;

/// Mutates `data` in place by one to eight stacked mutations; `other` is a second seed for
/// splices.
pub fn mutate(data: &mut Vec<u8>, other: &[u8], rng: &mut FuzzRng) {
    let rounds = 1 + if rng.one_in(4) {
        rng.below(8)
    } else {
        rng.below(2)
    };
    for _ in 0..rounds {
        mutate_once(data, other, rng);
    }
    data.truncate(MAX_LEN);
}

fn mutate_once(data: &mut Vec<u8>, other: &[u8], rng: &mut FuzzRng) {
    if data.is_empty() {
        data.push(rng.next_u64() as u8);
        return;
    }
    let len = data.len();
    match rng.below(16) {
        0 => {
            let bit = rng.below(len * 8);
            data[bit / 8] ^= 1 << (bit % 8);
        }
        1 => {
            let at = rng.below(len);
            data[at] = rng.next_u64() as u8;
        }
        2 | 3 => {
            // An interesting integer of 1, 2, 4 or 8 bytes, either endianness.
            let width = 1 << rng.below(4);
            let mut v = INTERESTING[rng.below(INTERESTING.len())];
            if rng.one_in(3) {
                v = v.wrapping_neg();
            }
            let mut bytes = v.to_le_bytes()[..width].to_vec();
            if rng.one_in(2) {
                bytes.reverse();
            }
            overwrite(data, &bytes, rng);
        }
        4 => {
            let v = INTERESTING_F32[rng.below(INTERESTING_F32.len())];
            overwrite(data, &v.to_le_bytes(), rng);
        }
        5 => {
            // Add a small signed delta to a little-endian u32.
            let at = rng.below(len);
            let end = (at + 4).min(len);
            let mut word = [0u8; 4];
            word[..end - at].copy_from_slice(&data[at..end]);
            let delta = rng.below(33) as i32 - 16;
            let v = u32::from_le_bytes(word).wrapping_add(delta as u32);
            data[at..end].copy_from_slice(&v.to_le_bytes()[..end - at]);
        }
        6 => {
            let at = rng.below(len + 1);
            let n = 1 + rng.below(16);
            let bytes: Vec<u8> = (0..n).map(|_| rng.next_u64() as u8).collect();
            data.splice(at..at, bytes);
        }
        7 => {
            let at = rng.below(len + 1);
            let most = if rng.one_in(8) { 4096 } else { 64 };
            let n = 1 + rng.below(most);
            let byte = if rng.one_in(2) {
                0
            } else {
                rng.next_u64() as u8
            };
            data.splice(at..at, std::iter::repeat_n(byte, n));
        }
        8 | 9 => {
            let at = rng.below(len);
            let most = if rng.one_in(4) { len } else { 16 };
            let n = 1 + rng.below((len - at).min(most));
            data.drain(at..at + n);
        }
        10 => {
            // Duplicate a range somewhere else.
            let from = rng.below(len);
            let n = 1 + rng.below((len - from).min(256));
            let chunk = data[from..from + n].to_vec();
            let at = rng.below(len + 1);
            data.splice(at..at, chunk);
        }
        11 => {
            // Splice: a prefix of this input, a suffix of the other.
            if other.is_empty() {
                data.truncate(rng.below(len + 1));
            } else {
                let cut = rng.below(len + 1);
                let from = rng.below(other.len());
                data.truncate(cut);
                data.extend_from_slice(&other[from..]);
            }
        }
        12 => data.truncate(rng.below(len)),
        13 | 14 => {
            // Replace a run of digits (a JSON number) with a boundary number.
            let start = rng.below(len);
            let Some(begin) = (start..len).find(|&i| data[i].is_ascii_digit()) else {
                let v = NUMBERS[rng.below(NUMBERS.len())];
                overwrite(data, v.as_bytes(), rng);
                return;
            };
            let begin = if begin > 0 && data[begin - 1] == b'-' {
                begin - 1
            } else {
                begin
            };
            let end = (begin + 1..len)
                .find(|&i| !(data[i].is_ascii_digit() || b".eE+-".contains(&data[i])))
                .unwrap_or(len);
            let v = NUMBERS[rng.below(NUMBERS.len())];
            data.splice(begin..end, v.bytes());
        }
        _ => {
            let t = TOKENS[rng.below(TOKENS.len())];
            let at = rng.below(len + 1);
            if rng.one_in(2) {
                data.splice(at..at, t.bytes());
            } else {
                let end = (at + t.len()).min(len);
                data.splice(at..end, t.bytes());
            }
        }
    }
}

/// Writes `bytes` over `data` at a random offset (growing it at the end if needed).
fn overwrite(data: &mut Vec<u8>, bytes: &[u8], rng: &mut FuzzRng) {
    let at = rng.below(data.len());
    if data.len() < at + bytes.len() {
        data.resize(at + bytes.len(), 0);
    }
    data[at..at + bytes.len()].copy_from_slice(bytes);
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn mutations_are_reproducible_and_change_the_input() {
        let seed: Vec<u8> = (0..64).collect();
        let run = |i| {
            let mut d = seed.clone();
            mutate(&mut d, b"other", &mut FuzzRng::new(7, i));
            d
        };
        assert_eq!(run(3), run(3));
        let changed = (0..100).filter(|&i| run(i) != seed).count();
        assert!(
            changed > 90,
            "{changed} of 100 mutants differ from the seed"
        );
        let distinct: std::collections::BTreeSet<Vec<u8>> = (0..100).map(run).collect();
        assert!(distinct.len() > 80, "{} distinct mutants", distinct.len());
    }

    #[test]
    fn empty_input_grows() {
        let mut d = Vec::new();
        mutate_once(&mut d, &[], &mut FuzzRng::new(1, 1));
        assert!(!d.is_empty());
    }
}

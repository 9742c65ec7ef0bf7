//! The one hash of the project: FNV-1a, 64 bits (Fowler, Noll and Vo; the
//! offset basis and prime of the 64-bit variant). It fingerprints the gear
//! set a worn-profile state belongs to, checksums worn-profile states and
//! serialized simulation states, and (two passes with different offsets) is
//! the FMU's GUID. Not a cryptographic hash: it detects accidents, not
//! forgeries.
//!
//! This file imports nothing, so build.rs includes it as it is.

/// The 64-bit FNV offset basis, the start of [`fnv1a64`].
pub const FNV_OFFSET: u64 = 0xcbf2_9ce4_8422_2325;
/// The 64-bit FNV prime.
const FNV_PRIME: u64 = 0x0000_0100_0000_01b3;

/// FNV-1a 64 of `data`, continuing from the hash state `seed` (pass
/// [`FNV_OFFSET`] to start afresh).
pub fn fnv1a64_from(seed: u64, data: &[u8]) -> u64 {
    let mut h = seed;
    for b in data {
        h ^= u64::from(*b);
        h = h.wrapping_mul(FNV_PRIME);
    }
    h
}

/// FNV-1a 64 of `data`.
pub fn fnv1a64(data: &[u8]) -> u64 {
    fnv1a64_from(FNV_OFFSET, data)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The published test vectors of FNV-1a 64 (the empty string, "a",
    /// "foobar").
    #[test]
    fn published_test_vectors() {
        assert_eq!(fnv1a64(b""), 0xcbf2_9ce4_8422_2325);
        assert_eq!(fnv1a64(b"a"), 0xaf63_dc4c_8601_ec8c);
        assert_eq!(fnv1a64(b"foobar"), 0x8594_4171_f739_67e8);
    }

    #[test]
    fn continuing_equals_hashing_the_concatenation() {
        assert_eq!(fnv1a64_from(fnv1a64(b"foo"), b"bar"), fnv1a64(b"foobar"));
    }
}

//! Seed mixing shared by every crate that derives seeds from seeds: the
//! splitmix64 finalizer (Steele, Lea & Flood 2014), one copy.

/// splitmix64's increment (the golden ratio in 64 bits).
pub const SPLITMIX_GOLDEN: u64 = 0x9E37_79B9_7F4A_7C15;

/// The splitmix64 finalizer: a well-mixed 64-bit value from another.
#[inline]
pub fn mix64(mut z: u64) -> u64 {
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^ (z >> 31)
}

/// One splitmix64 step: the increment, then [`mix64`].
#[inline]
pub fn splitmix64(seed: u64) -> u64 {
    mix64(seed.wrapping_add(SPLITMIX_GOLDEN))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn splitmix64_reference_values() {
        // The reference generator seeded with 0 gives 0xE220A8397B1DCDAF
        // first (Vigna's splitmix64.c).
        assert_eq!(splitmix64(0), 0xE220_A839_7B1D_CDAF);
        assert_eq!(mix64(0), 0);
    }
}

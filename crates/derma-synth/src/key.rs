//! The random keys that break ties among near-best matches (search.rs's definition, and the
//! k-coherence search's random candidates): an invertible 32-bit mix, the same in search.wgsl.

/// The random key of candidate `index` for a query's `salt`: an invertible 32-bit mix of
/// index + salt (xorshift–multiply rounds; each step is a bijection on u32).
#[inline]
pub fn pick_key(salt: u32, index: u32) -> u32 {
    let mut x = index.wrapping_add(salt);
    x ^= x >> 16;
    x = x.wrapping_mul(0x7feb_352d);
    x ^= x >> 15;
    x = x.wrapping_mul(0x846c_a68b);
    x ^= x >> 16;
    x
}

/// The index whose key is `key` (the inverse of [`pick_key`]; the GPU returns keys).
pub fn index_of_key(salt: u32, key: u32) -> u32 {
    let unshift = |mut x: u32, s: u32| {
        let mut y = x;
        let mut k = s;
        while k < 32 {
            x >>= s;
            y ^= x;
            k += s;
        }
        y
    };
    let mut x = unshift(key, 16);
    x = x.wrapping_mul(inverse_mod_2_32(0x846c_a68b));
    x = unshift(x, 15);
    x = x.wrapping_mul(inverse_mod_2_32(0x7feb_352d));
    x = unshift(x, 16);
    x.wrapping_sub(salt)
}

/// Multiplicative inverse of an odd number modulo 2³² (Newton's iteration).
const fn inverse_mod_2_32(a: u32) -> u32 {
    let mut x = a;
    let mut i = 0;
    while i < 5 {
        x = x.wrapping_mul(2u32.wrapping_sub(a.wrapping_mul(x)));
        i += 1;
    }
    x
}

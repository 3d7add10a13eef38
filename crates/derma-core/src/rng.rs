//! Counter-based random numbers: Philox4x32-10 (Salmon, Moraes, Dror & Shaw, "Parallel random
//! numbers: as easy as 1, 2, 3", SC 2011). A draw is a pure function of (seed, stream, index).
//!
//! Every random quantity in derma is addressed by a stream (what it is for) and an index (which
//! one), so results never depend on thread count or scheduling, and a WGSL port of the same
//! ten rounds reproduces the CPU stream bit for bit.

/// Philox multiplier of counter word 0 (Salmon et al. 2011, §5; the Random123 constants).
pub const PHILOX_M0: u32 = 0xD251_1F53;
/// Philox multiplier of counter word 2.
pub const PHILOX_M1: u32 = 0xCD9E_8D57;
/// Weyl increment of key word 0.
pub const PHILOX_W0: u32 = 0x9E37_79B9;
/// Weyl increment of key word 1.
pub const PHILOX_W1: u32 = 0xBB67_AE85;

#[inline]
fn mulhilo(a: u32, b: u32) -> (u32, u32) {
    let p = a as u64 * b as u64;
    (p as u32, (p >> 32) as u32)
}

/// The raw Philox4x32-10 bijection of a 128-bit counter under a 64-bit key.
#[inline]
pub fn philox4x32_10(mut ctr: [u32; 4], key: [u32; 2]) -> [u32; 4] {
    let (mut k0, mut k1) = (key[0], key[1]);
    for _ in 0..10 {
        let (lo0, hi0) = mulhilo(PHILOX_M0, ctr[0]);
        let (lo1, hi1) = mulhilo(PHILOX_M1, ctr[2]);
        ctr = [hi1 ^ ctr[1] ^ k0, lo1, hi0 ^ ctr[3] ^ k1, lo0];
        k0 = k0.wrapping_add(PHILOX_W0);
        k1 = k1.wrapping_add(PHILOX_W1);
    }
    ctr
}

/// A keyed random stream: `Philox::new(seed, stream).u32x4(index)`.
#[derive(Clone, Copy, Debug)]
pub struct Philox {
    key: [u32; 2],
    stream: u32,
}

impl Philox {
    /// The stream `stream` of generator `seed`.
    pub fn new(seed: u64, stream: u32) -> Self {
        Self {
            key: [seed as u32, (seed >> 32) as u32],
            stream,
        }
    }

    /// Four independent 32-bit words for (index, sub).
    #[inline]
    pub fn u32x4_sub(&self, index: u64, sub: u32) -> [u32; 4] {
        philox4x32_10(
            [index as u32, (index >> 32) as u32, self.stream, sub],
            self.key,
        )
    }

    #[inline]
    /// Four independent 32-bit words for `index`.
    pub fn u32x4(&self, index: u64) -> [u32; 4] {
        self.u32x4_sub(index, 0)
    }

    /// Four uniforms in [0, 1) with 24 bits of resolution each (exactly representable in f32).
    #[inline]
    pub fn uniform4(&self, index: u64, sub: u32) -> [f32; 4] {
        self.u32x4_sub(index, sub).map(unit_f32)
    }

    /// Two standard normal deviates (Box–Muller) from one draw.
    pub fn normal2(&self, index: u64, sub: u32) -> [f32; 2] {
        let w = self.u32x4_sub(index, sub);
        let u1 = ((w[0] >> 8) as f64 + 1.0) / 16_777_217.0; // (0, 1): log is finite
        let u2 = unit_f32(w[1]) as f64;
        let r = (-2.0 * u1.ln()).sqrt();
        let t = std::f64::consts::TAU * u2;
        [(r * t.cos()) as f32, (r * t.sin()) as f32]
    }
}

/// Maps a 32-bit word to [0, 1) using its top 24 bits.
#[inline]
pub fn unit_f32(w: u32) -> f32 {
    (w >> 8) as f32 * (1.0 / 16_777_216.0)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Known-answer vectors of Philox4x32-10 published with Random123 (kat_vectors).
    #[test]
    fn philox_known_answers() {
        assert_eq!(
            philox4x32_10([0; 4], [0; 2]),
            [0x6627e8d5, 0xe169c58d, 0xbc57ac4c, 0x9b00dbd8]
        );
        assert_eq!(
            philox4x32_10([u32::MAX; 4], [u32::MAX; 2]),
            [0x408f276d, 0x41c83b0e, 0xa20bc7c6, 0x6d5451fd]
        );
        assert_eq!(
            philox4x32_10(
                [0x243f6a88, 0x85a308d3, 0x13198a2e, 0x03707344],
                [0xa4093822, 0x299f31d0]
            ),
            [0xd16cfe09, 0x94fdcceb, 0x5001e420, 0x24126ea1]
        );
    }

    #[test]
    fn uniform_moments() {
        let r = Philox::new(7, 3);
        let n = 20_000u64;
        let (mut s, mut s2) = (0.0f64, 0.0f64);
        for i in 0..n {
            for u in r.uniform4(i, 0) {
                assert!((0.0..1.0).contains(&u));
                s += u as f64;
                s2 += (u as f64) * (u as f64);
            }
        }
        let m = s / (4 * n) as f64;
        let var = s2 / (4 * n) as f64 - m * m;
        assert!((m - 0.5).abs() < 0.005, "mean {m}");
        assert!((var - 1.0 / 12.0).abs() < 0.002, "var {var}");
    }

    #[test]
    fn normal_moments_and_streams_differ() {
        let r = Philox::new(1, 0);
        let n = 20_000u64;
        let (mut s, mut s2) = (0.0f64, 0.0f64);
        for i in 0..n {
            for z in r.normal2(i, 0) {
                s += z as f64;
                s2 += (z as f64).powi(2);
            }
        }
        let m = s / (2 * n) as f64;
        assert!(m.abs() < 0.02 && (s2 / (2 * n) as f64 - 1.0).abs() < 0.03);
        assert_ne!(Philox::new(1, 0).u32x4(5), Philox::new(1, 1).u32x4(5));
        assert_ne!(Philox::new(1, 0).u32x4(5), Philox::new(2, 0).u32x4(5));
    }
}

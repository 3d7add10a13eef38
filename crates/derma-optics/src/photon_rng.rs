//! The random stream of one photon: Philox4x32-10 (derma-core) over the counter
//! (photon index, stream, block), so photon k draws the same numbers on CPU and GPU.

use derma_core::rng::philox4x32_10;

/// Stream id of optics photons ("OP"), kept apart from the skin scatterer's streams.
pub const OPTICS_STREAM: u32 = 0x4f50;

/// Draws 32-bit words four at a time; the fourth counter word counts blocks.
pub struct PhotonRng {
    key: [u32; 2],
    ctr: [u32; 4],
    buf: [u32; 4],
    pos: usize,
}

impl PhotonRng {
    #[inline]
    /// Photon `photon`'s stream under `seed` (the counter starts at its first block).
    pub fn new(seed: u64, photon: u64) -> Self {
        Self {
            key: [seed as u32, (seed >> 32) as u32],
            ctr: [photon as u32, (photon >> 32) as u32, OPTICS_STREAM, 0],
            buf: [0; 4],
            pos: 4,
        }
    }

    #[inline]
    /// The next 32-bit word of the stream.
    pub fn next_u32(&mut self) -> u32 {
        if self.pos == 4 {
            self.buf = philox4x32_10(self.ctr, self.key);
            self.ctr[3] = self.ctr[3].wrapping_add(1);
            self.pos = 0;
        }
        let w = self.buf[self.pos];
        self.pos += 1;
        w
    }

    /// Uniform in [0, 1) with 24 bits (exactly representable in f32, so the GPU's f32 draws are
    /// the same numbers).
    #[inline]
    pub fn uniform(&mut self) -> f64 {
        (self.next_u32() >> 8) as f64 * (1.0 / 16_777_216.0)
    }
}

//! Eight f32 (or i32) lanes, for loops that run across texels or photons at once (issue 15:
//! the match-table look-up, the photon walk). Two implementations of one interface:
//! [`Avx2F32`] in an AVX2 register (runtime-dispatched: an [`Avx2`] token exists only where the
//! CPU has AVX2 and FMA, and the lane types are made from it, so the code that uses them is
//! safe) and [`PortableF32`], eight plain f32s for every other CPU.
//!
//! Every operation is one IEEE operation per lane, the same on both (fused multiply–add only
//! where asked for, and then fused on both; the same rounding, comparisons false with NaN,
//! `min`/`max` returning the second operand when either is NaN as the x86 instructions do), and
//! the elementary functions below are written once over the interface, so both give the same
//! bits — and [`Lanes::exp`] and [`Lanes::cbrt`] the bits of [`super::fastmath`]'s scalar
//! functions. Results do not depend on the CPU.
//!
//! Methods: e^x and ∛x as in [`super::fastmath`]; ln x from the exponent and
//! 2·atanh((m − 1)/(m + 1)) for the mantissa m ∈ [√½, √2) (series to s⁹, truncation below
//! 4·10⁻¹⁰; Abramowitz & Stegun 4.1.27); sin and cos of 2π·t by reduction to the nearest quarter
//! turn (exact for t of 24 bits) and Taylor polynomials on [−π/4, π/4] (degree 9 and 10,
//! truncation below 4·10⁻⁹).

use super::fastmath::{CBRT_BIAS, EXP_POLY, LN2_HI, LN2_LO, ROUND_MAGIC};

/// Eight f32 lanes. A comparison gives a mask: all bits set in the lanes where it holds.
pub trait Lanes: Copy + Send + Sync + std::fmt::Debug {
    /// What makes lanes: a proof of CPU support, or nothing.
    type Token: Copy + Send + Sync;
    /// The integer lanes of the same width.
    type I: IntLanes<F = Self, Token = Self::Token>;
    /// The token of these lanes.
    fn token(self) -> Self::Token;
    /// `v` in every lane.
    fn splat(t: Self::Token, v: f32) -> Self;
    /// The lanes of `v`.
    fn from_array(t: Self::Token, v: [f32; 8]) -> Self;
    /// The lanes as an array.
    fn to_array(self) -> [f32; 8];
    /// Lane-wise sum.
    fn add(self, o: Self) -> Self;
    /// Lane-wise difference.
    fn sub(self, o: Self) -> Self;
    /// Lane-wise product.
    fn mul(self, o: Self) -> Self;
    /// Lane-wise quotient.
    fn div(self, o: Self) -> Self;
    /// Lane-wise minimum (the second operand where either is NaN).
    fn min(self, o: Self) -> Self;
    /// Lane-wise maximum (the second operand where either is NaN).
    fn max(self, o: Self) -> Self;
    /// Square root, correctly rounded.
    fn sqrt(self) -> Self;
    /// Bitwise and (masks).
    fn and(self, o: Self) -> Self;
    /// Bitwise or (masks).
    fn or(self, o: Self) -> Self;
    /// Bitwise and-not: `!self & o` (masks).
    fn and_not(self, o: Self) -> Self;
    /// Mask of `self >= o` (false with NaN).
    fn ge(self, o: Self) -> Self;
    /// Mask of `self > o`.
    fn gt(self, o: Self) -> Self;
    /// Mask of `self < o`.
    fn lt(self, o: Self) -> Self;
    /// Mask of `self <= o`.
    fn le(self, o: Self) -> Self;
    /// Mask of `self == o`.
    fn eq(self, o: Self) -> Self;
    /// Lane-wise `if mask { a } else { b }` (`self` is the mask).
    fn select(self, a: Self, b: Self) -> Self;
    /// The bits of each lane as an integer.
    fn to_bits(self) -> Self::I;
    /// Lanes truncated towards zero to integers (exact for integral values).
    fn to_i32(self) -> Self::I;
    /// Lanes where a mask is set, as bits 0–7.
    fn mask_bits(self) -> u32;
    /// `self · a + b` with one rounding (fused multiply–add; `f32::mul_add` on the portable
    /// lanes, so both give the same bits).
    fn mul_add(self, a: Self, b: Self) -> Self;

    /// `v` in every lane (the token taken from `self`).
    #[inline(always)]
    fn splat_as(self, v: f32) -> Self {
        Self::splat(self.token(), v)
    }

    /// `self` clamped to [`lo`, `hi`] as `f32::clamp` does for numbers.
    #[inline(always)]
    fn clamp(self, lo: f32, hi: f32) -> Self {
        self.max(self.splat_as(lo)).min(self.splat_as(hi))
    }

    /// [`super::fastmath::round_ties_even`] lane by lane.
    #[inline(always)]
    fn round_ties_even(self) -> Self {
        let m = self.splat_as(ROUND_MAGIC);
        self.add(m).sub(m)
    }

    /// [`super::fastmath::exp_f32`] lane by lane (the same operations in the same order).
    #[inline(always)]
    fn exp(self) -> Self {
        let x = self.clamp(-87.0, 88.0);
        let n = x
            .mul(self.splat_as(std::f32::consts::LOG2_E))
            .round_ties_even();
        let r = x
            .sub(n.mul(self.splat_as(LN2_HI)))
            .sub(n.mul(self.splat_as(LN2_LO)));
        let mut p = self.splat_as(EXP_POLY[EXP_POLY.len() - 1]);
        for &c in EXP_POLY[..EXP_POLY.len() - 1].iter().rev() {
            p = self.splat_as(c).add(r.mul(p));
        }
        let t = self.token();
        let scale = n
            .to_i32()
            .add(Self::I::splat(t, 127))
            .shl::<23>()
            .to_f32_bits();
        p.mul(scale)
    }

    /// [`super::fastmath::cbrt_f32`] lane by lane.
    #[inline(always)]
    fn cbrt(self) -> Self {
        let bits = self.to_bits();
        let mut y = bits
            .div3_unsigned()
            .add(Self::I::splat(self.token(), CBRT_BIAS as i32))
            .to_f32_bits();
        let three = self.splat_as(3.0);
        for _ in 0..3 {
            let num = y.mul(y).mul(y).sub(self);
            let den = three.mul(y).mul(y);
            y = y.sub(num.div(den));
        }
        y
    }

    /// ln x for positive, finite, normal x (relative error below 2·10⁻⁷).
    #[inline(always)]
    fn ln(self) -> Self {
        let t = self.token();
        let bits = self.to_bits();
        // x = 2^e · m with m ∈ [1, 2), then m ∈ [√½, √2) by moving a factor 2 into e.
        let e = bits.shr::<23>().sub(Self::I::splat(t, 127));
        let m = bits
            .and(Self::I::splat(t, 0x007f_ffff))
            .or(Self::I::splat(t, 0x3f80_0000))
            .to_f32_bits();
        let big = m.gt(self.splat_as(std::f32::consts::SQRT_2));
        let m = big.select(m.mul(self.splat_as(0.5)), m);
        let e = big.select(e.to_f32().add(self.splat_as(1.0)), e.to_f32());
        let s = m.sub(self.splat_as(1.0)).div(m.add(self.splat_as(1.0)));
        let z = s.mul(s);
        let mut p = self.splat_as(1.0 / 9.0);
        for c in [1.0 / 7.0, 1.0 / 5.0, 1.0 / 3.0, 1.0] {
            p = z.mul_add(p, self.splat_as(c));
        }
        let ln_m = self.splat_as(2.0).mul(s).mul(p);
        e.mul_add(
            self.splat_as(LN2_HI),
            e.mul_add(self.splat_as(LN2_LO), ln_m),
        )
    }

    /// (sin 2πt, cos 2πt) for t ∈ [0, 1) with 24 fractional bits (the photons' uniform draws;
    /// the reduction to the nearest quarter turn is exact for them), errors below 3·10⁻⁷.
    #[inline(always)]
    fn sincos_turns(self) -> (Self, Self) {
        let t = self.token();
        let q = self.mul(self.splat_as(4.0)).round_ties_even();
        let r = self.sub(q.mul(self.splat_as(0.25)));
        let a = r.mul(self.splat_as(std::f32::consts::TAU));
        let a2 = a.mul(a);
        // sin a = a (1 − a²/3! + a⁴/5! − a⁶/7! + a⁸/9!), cos a = 1 − a²/2! + … + a¹⁰/10!.
        let mut s = self.splat_as(1.0 / 362_880.0);
        for c in [-1.0 / 5040.0, 1.0 / 120.0, -1.0 / 6.0, 1.0] {
            s = a2.mul_add(s, self.splat_as(c));
        }
        let s = a.mul(s);
        let mut c = self.splat_as(-1.0 / 3_628_800.0);
        for k in [1.0 / 40_320.0, -1.0 / 720.0, 1.0 / 24.0, -0.5, 1.0] {
            c = a2.mul_add(c, self.splat_as(k));
        }
        // Quarter turns: (s, c) → (c, −s) → (−s, −c) → (−c, s).
        let k = q.to_i32();
        let swap = k.and(Self::I::splat(t, 1)).eq(Self::I::splat(t, 1));
        let neg_s = k.and(Self::I::splat(t, 2)).eq(Self::I::splat(t, 2));
        let neg_c = k
            .add(Self::I::splat(t, 1))
            .and(Self::I::splat(t, 2))
            .eq(Self::I::splat(t, 2));
        let zero = self.splat_as(0.0);
        let (ss, cc) = (swap.select(c, s), swap.select(s, c));
        (
            neg_s.select(zero.sub(ss), ss),
            neg_c.select(zero.sub(cc), cc),
        )
    }
}

/// Eight i32 lanes (read as u32 where a method says so).
pub trait IntLanes: Copy + Send + Sync + std::fmt::Debug {
    /// The token of the lanes.
    type Token: Copy + Send + Sync;
    /// The f32 lanes of the same width.
    type F: Lanes<I = Self, Token = Self::Token>;
    /// `v` in every lane.
    fn splat(t: Self::Token, v: i32) -> Self;
    /// The lanes of `v`.
    fn from_array(t: Self::Token, v: [i32; 8]) -> Self;
    /// The lanes as an array.
    fn to_array(self) -> [i32; 8];
    /// Lane-wise wrapping sum.
    fn add(self, o: Self) -> Self;
    /// Lane-wise wrapping difference.
    fn sub(self, o: Self) -> Self;
    /// Lane-wise wrapping product (low 32 bits).
    fn mul(self, o: Self) -> Self;
    /// Bitwise and.
    fn and(self, o: Self) -> Self;
    /// Bitwise or.
    fn or(self, o: Self) -> Self;
    /// Bitwise exclusive or.
    fn xor(self, o: Self) -> Self;
    /// Shift left by `N` bits.
    fn shl<const N: i32>(self) -> Self;
    /// Logical shift right by `N` bits.
    fn shr<const N: i32>(self) -> Self;
    /// The lanes as f32 bit patterns.
    fn to_f32_bits(self) -> Self::F;
    /// The lanes converted to f32 (rounded to nearest).
    fn to_f32(self) -> Self::F;
    /// Mask (as f32 lanes) of `self == o`.
    fn eq(self, o: Self) -> Self::F;
    /// The low and high 32 bits of the lanes' unsigned 64-bit products with `o` (Philox's
    /// multiply).
    fn mul_wide_unsigned(self, o: Self) -> (Self, Self);

    /// Philox4x32-10 ([`crate::rng::philox4x32_10`]) of each lane's counter under one key.
    #[inline(always)]
    fn philox4x32_10(ctr: [Self; 4], key: [u32; 2]) -> [Self; 4] {
        use crate::rng::{PHILOX_M0, PHILOX_M1, PHILOX_W0, PHILOX_W1};
        let tok = ctr[0].to_f32_bits().token();
        let (m0, m1) = (
            Self::splat(tok, PHILOX_M0 as i32),
            Self::splat(tok, PHILOX_M1 as i32),
        );
        let (mut k0, mut k1) = (key[0], key[1]);
        let mut c = ctr;
        for _ in 0..10 {
            let (lo0, hi0) = m0.mul_wide_unsigned(c[0]);
            let (lo1, hi1) = m1.mul_wide_unsigned(c[2]);
            c = [
                hi1.xor(c[1]).xor(Self::splat(tok, k0 as i32)),
                lo1,
                hi0.xor(c[3]).xor(Self::splat(tok, k1 as i32)),
                lo0,
            ];
            k0 = k0.wrapping_add(PHILOX_W0);
            k1 = k1.wrapping_add(PHILOX_W1);
        }
        c
    }

    /// Each lane read as u32 divided by 3, exactly: ⌊x · ⌈2³³/3⌉ / 2³³⌋ = ⌊x/3⌋ for every
    /// 32-bit x (Granlund & Montgomery 1994, "Division by invariant integers using
    /// multiplication").
    #[inline(always)]
    fn div3_unsigned(self) -> Self {
        let m = Self::splat(self.to_f32_bits().token(), 0xAAAA_AAABu32 as i32);
        self.mul_wide_unsigned(m).1.shr::<1>()
    }
}

/// [`crate::rng::philox4x32_10`] in eight lanes at once (each lane its own counter, one key): the same
/// words as the scalar function, lane by lane.
#[inline(always)]
pub fn philox4x32_10_lanes<I: IntLanes>(ctr: [I; 4], key: [u32; 2]) -> [I; 4] {
    I::philox4x32_10(ctr, key)
}

/// Eight plain f32s: the lanes on every CPU.
#[derive(Clone, Copy, Debug)]
pub struct PortableF32(pub [f32; 8]);

/// Eight plain i32s.
#[derive(Clone, Copy, Debug)]
pub struct PortableI32(pub [i32; 8]);

#[inline(always)]
fn map2(a: [f32; 8], b: [f32; 8], f: impl Fn(f32, f32) -> f32) -> [f32; 8] {
    std::array::from_fn(|l| f(a[l], b[l]))
}

#[inline(always)]
fn mask(b: bool) -> f32 {
    f32::from_bits(if b { u32::MAX } else { 0 })
}

#[inline(always)]
fn bits2(a: [f32; 8], b: [f32; 8], f: impl Fn(u32, u32) -> u32) -> [f32; 8] {
    std::array::from_fn(|l| f32::from_bits(f(a[l].to_bits(), b[l].to_bits())))
}

impl Lanes for PortableF32 {
    type Token = ();
    type I = PortableI32;
    #[inline(always)]
    fn token(self) {}
    #[inline(always)]
    fn splat(_: (), v: f32) -> Self {
        Self([v; 8])
    }
    #[inline(always)]
    fn from_array(_: (), v: [f32; 8]) -> Self {
        Self(v)
    }
    #[inline(always)]
    fn to_array(self) -> [f32; 8] {
        self.0
    }
    #[inline(always)]
    fn add(self, o: Self) -> Self {
        Self(map2(self.0, o.0, |a, b| a + b))
    }
    #[inline(always)]
    fn sub(self, o: Self) -> Self {
        Self(map2(self.0, o.0, |a, b| a - b))
    }
    #[inline(always)]
    fn mul(self, o: Self) -> Self {
        Self(map2(self.0, o.0, |a, b| a * b))
    }
    #[inline(always)]
    fn div(self, o: Self) -> Self {
        Self(map2(self.0, o.0, |a, b| a / b))
    }
    #[inline(always)]
    fn min(self, o: Self) -> Self {
        // As MINPS: the second operand unless the first is smaller.
        Self(map2(self.0, o.0, |a, b| if a < b { a } else { b }))
    }
    #[inline(always)]
    fn max(self, o: Self) -> Self {
        Self(map2(self.0, o.0, |a, b| if a > b { a } else { b }))
    }
    #[inline(always)]
    fn sqrt(self) -> Self {
        Self(self.0.map(f32::sqrt))
    }
    #[inline(always)]
    fn and(self, o: Self) -> Self {
        Self(bits2(self.0, o.0, |a, b| a & b))
    }
    #[inline(always)]
    fn or(self, o: Self) -> Self {
        Self(bits2(self.0, o.0, |a, b| a | b))
    }
    #[inline(always)]
    fn and_not(self, o: Self) -> Self {
        Self(bits2(self.0, o.0, |a, b| !a & b))
    }
    #[inline(always)]
    fn ge(self, o: Self) -> Self {
        Self(map2(self.0, o.0, |a, b| mask(a >= b)))
    }
    #[inline(always)]
    fn gt(self, o: Self) -> Self {
        Self(map2(self.0, o.0, |a, b| mask(a > b)))
    }
    #[inline(always)]
    fn lt(self, o: Self) -> Self {
        Self(map2(self.0, o.0, |a, b| mask(a < b)))
    }
    #[inline(always)]
    fn le(self, o: Self) -> Self {
        Self(map2(self.0, o.0, |a, b| mask(a <= b)))
    }
    #[inline(always)]
    fn eq(self, o: Self) -> Self {
        Self(map2(self.0, o.0, |a, b| mask(a == b)))
    }
    #[inline(always)]
    fn select(self, a: Self, b: Self) -> Self {
        // As BLENDVPS: the mask's sign bit decides.
        Self(std::array::from_fn(|l| {
            if self.0[l].to_bits() >> 31 == 1 {
                a.0[l]
            } else {
                b.0[l]
            }
        }))
    }
    #[inline(always)]
    fn to_bits(self) -> PortableI32 {
        PortableI32(self.0.map(|v| v.to_bits() as i32))
    }
    #[inline(always)]
    fn to_i32(self) -> PortableI32 {
        // As CVTTPS2DQ: out of range and NaN give i32::MIN.
        PortableI32(self.0.map(|v| {
            if !(-2_147_483_648.0..2_147_483_648.0).contains(&v) {
                i32::MIN
            } else {
                v as i32
            }
        }))
    }
    #[inline(always)]
    fn mask_bits(self) -> u32 {
        (0..8).fold(0, |m, l| m | ((self.0[l].to_bits() >> 31) << l))
    }
    #[inline(always)]
    fn mul_add(self, a: Self, b: Self) -> Self {
        Self(std::array::from_fn(|l| self.0[l].mul_add(a.0[l], b.0[l])))
    }
}

impl IntLanes for PortableI32 {
    type Token = ();
    type F = PortableF32;
    #[inline(always)]
    fn splat(_: (), v: i32) -> Self {
        Self([v; 8])
    }
    #[inline(always)]
    fn from_array(_: (), v: [i32; 8]) -> Self {
        Self(v)
    }
    #[inline(always)]
    fn to_array(self) -> [i32; 8] {
        self.0
    }
    #[inline(always)]
    fn add(self, o: Self) -> Self {
        Self(std::array::from_fn(|l| self.0[l].wrapping_add(o.0[l])))
    }
    #[inline(always)]
    fn sub(self, o: Self) -> Self {
        Self(std::array::from_fn(|l| self.0[l].wrapping_sub(o.0[l])))
    }
    #[inline(always)]
    fn mul(self, o: Self) -> Self {
        Self(std::array::from_fn(|l| self.0[l].wrapping_mul(o.0[l])))
    }
    #[inline(always)]
    fn and(self, o: Self) -> Self {
        Self(std::array::from_fn(|l| self.0[l] & o.0[l]))
    }
    #[inline(always)]
    fn or(self, o: Self) -> Self {
        Self(std::array::from_fn(|l| self.0[l] | o.0[l]))
    }
    #[inline(always)]
    fn xor(self, o: Self) -> Self {
        Self(std::array::from_fn(|l| self.0[l] ^ o.0[l]))
    }
    #[inline(always)]
    fn shl<const N: i32>(self) -> Self {
        Self(self.0.map(|v| ((v as u32) << N) as i32))
    }
    #[inline(always)]
    fn shr<const N: i32>(self) -> Self {
        Self(self.0.map(|v| ((v as u32) >> N) as i32))
    }
    #[inline(always)]
    fn to_f32_bits(self) -> PortableF32 {
        PortableF32(self.0.map(|v| f32::from_bits(v as u32)))
    }
    #[inline(always)]
    fn to_f32(self) -> PortableF32 {
        PortableF32(self.0.map(|v| v as f32))
    }
    #[inline(always)]
    fn eq(self, o: Self) -> PortableF32 {
        PortableF32(std::array::from_fn(|l| mask(self.0[l] == o.0[l])))
    }
    #[inline(always)]
    fn mul_wide_unsigned(self, o: Self) -> (Self, Self) {
        let p: [u64; 8] = std::array::from_fn(|l| self.0[l] as u32 as u64 * o.0[l] as u32 as u64);
        (
            Self(p.map(|v| v as u32 as i32)),
            Self(p.map(|v| (v >> 32) as u32 as i32)),
        )
    }
}

#[cfg(target_arch = "x86_64")]
pub use x86::*;

#[cfg(target_arch = "x86_64")]
mod x86 {
    use super::{IntLanes, Lanes};
    use std::arch::x86_64::*;

    /// Proof that the CPU runs AVX2 and FMA; the AVX2 lane types are made from it.
    #[derive(Clone, Copy, Debug)]
    pub struct Avx2(());

    impl Avx2 {
        /// The token, where the CPU has AVX2 and FMA (detected at run time).
        #[inline]
        pub fn detect() -> Option<Avx2> {
            (is_x86_feature_detected!("avx2") && is_x86_feature_detected!("fma"))
                .then_some(Avx2(()))
        }
    }

    /// Eight f32 lanes in an AVX2 register.
    #[derive(Clone, Copy, Debug)]
    #[repr(transparent)]
    pub struct Avx2F32(__m256);

    /// Eight i32 lanes in an AVX2 register.
    #[derive(Clone, Copy, Debug)]
    #[repr(transparent)]
    pub struct Avx2I32(__m256i);

    // SAFETY (every `unsafe` block below): an Avx2F32 or Avx2I32 exists only after
    // `Avx2::detect` succeeded (the constructors take the token or a lane value), so the CPU
    // executes the AVX/AVX2 instructions the intrinsics emit.
    macro_rules! f32_binary {
        ($($name:ident => $intr:ident),* $(,)?) => {$(
            #[inline(always)]
            fn $name(self, o: Self) -> Self {
                Avx2F32(unsafe { $intr(self.0, o.0) })
            }
        )*};
    }

    macro_rules! f32_compare {
        ($($name:ident => $pred:ident),* $(,)?) => {$(
            #[inline(always)]
            fn $name(self, o: Self) -> Self {
                Avx2F32(unsafe { _mm256_cmp_ps::<$pred>(self.0, o.0) })
            }
        )*};
    }

    impl Lanes for Avx2F32 {
        type Token = Avx2;
        type I = Avx2I32;
        #[inline(always)]
        fn token(self) -> Avx2 {
            Avx2(())
        }
        #[inline(always)]
        fn splat(_: Avx2, v: f32) -> Self {
            Avx2F32(unsafe { _mm256_set1_ps(v) })
        }
        #[inline(always)]
        fn from_array(_: Avx2, v: [f32; 8]) -> Self {
            Avx2F32(unsafe { _mm256_loadu_ps(v.as_ptr()) })
        }
        #[inline(always)]
        fn to_array(self) -> [f32; 8] {
            let mut out = [0.0f32; 8];
            unsafe { _mm256_storeu_ps(out.as_mut_ptr(), self.0) };
            out
        }
        f32_binary! {
            add => _mm256_add_ps,
            sub => _mm256_sub_ps,
            mul => _mm256_mul_ps,
            div => _mm256_div_ps,
            min => _mm256_min_ps,
            max => _mm256_max_ps,
            and => _mm256_and_ps,
            or => _mm256_or_ps,
            and_not => _mm256_andnot_ps,
        }
        f32_compare! {
            ge => _CMP_GE_OQ,
            gt => _CMP_GT_OQ,
            lt => _CMP_LT_OQ,
            le => _CMP_LE_OQ,
            eq => _CMP_EQ_OQ,
        }
        #[inline(always)]
        fn sqrt(self) -> Self {
            Avx2F32(unsafe { _mm256_sqrt_ps(self.0) })
        }
        #[inline(always)]
        fn select(self, a: Self, b: Self) -> Self {
            Avx2F32(unsafe { _mm256_blendv_ps(b.0, a.0, self.0) })
        }
        #[inline(always)]
        fn to_bits(self) -> Avx2I32 {
            Avx2I32(unsafe { _mm256_castps_si256(self.0) })
        }
        #[inline(always)]
        fn to_i32(self) -> Avx2I32 {
            Avx2I32(unsafe { _mm256_cvttps_epi32(self.0) })
        }
        #[inline(always)]
        fn mask_bits(self) -> u32 {
            unsafe { _mm256_movemask_ps(self.0) as u32 }
        }
        #[inline(always)]
        fn mul_add(self, a: Self, b: Self) -> Self {
            Avx2F32(unsafe { _mm256_fmadd_ps(self.0, a.0, b.0) })
        }
    }

    impl IntLanes for Avx2I32 {
        type Token = Avx2;
        type F = Avx2F32;
        #[inline(always)]
        fn splat(_: Avx2, v: i32) -> Self {
            Avx2I32(unsafe { _mm256_set1_epi32(v) })
        }
        #[inline(always)]
        fn from_array(_: Avx2, v: [i32; 8]) -> Self {
            Avx2I32(unsafe { _mm256_loadu_si256(v.as_ptr() as *const __m256i) })
        }
        #[inline(always)]
        fn to_array(self) -> [i32; 8] {
            let mut out = [0i32; 8];
            unsafe { _mm256_storeu_si256(out.as_mut_ptr() as *mut __m256i, self.0) };
            out
        }
        #[inline(always)]
        fn add(self, o: Self) -> Self {
            Avx2I32(unsafe { _mm256_add_epi32(self.0, o.0) })
        }
        #[inline(always)]
        fn sub(self, o: Self) -> Self {
            Avx2I32(unsafe { _mm256_sub_epi32(self.0, o.0) })
        }
        #[inline(always)]
        fn mul(self, o: Self) -> Self {
            Avx2I32(unsafe { _mm256_mullo_epi32(self.0, o.0) })
        }
        #[inline(always)]
        fn and(self, o: Self) -> Self {
            Avx2I32(unsafe { _mm256_and_si256(self.0, o.0) })
        }
        #[inline(always)]
        fn or(self, o: Self) -> Self {
            Avx2I32(unsafe { _mm256_or_si256(self.0, o.0) })
        }
        #[inline(always)]
        fn xor(self, o: Self) -> Self {
            Avx2I32(unsafe { _mm256_xor_si256(self.0, o.0) })
        }
        #[inline(always)]
        fn shl<const N: i32>(self) -> Self {
            Avx2I32(unsafe { _mm256_slli_epi32::<N>(self.0) })
        }
        #[inline(always)]
        fn shr<const N: i32>(self) -> Self {
            Avx2I32(unsafe { _mm256_srli_epi32::<N>(self.0) })
        }
        #[inline(always)]
        fn to_f32_bits(self) -> Avx2F32 {
            Avx2F32(unsafe { _mm256_castsi256_ps(self.0) })
        }
        #[inline(always)]
        fn to_f32(self) -> Avx2F32 {
            Avx2F32(unsafe { _mm256_cvtepi32_ps(self.0) })
        }
        #[inline(always)]
        fn eq(self, o: Self) -> Avx2F32 {
            Avx2F32(unsafe { _mm256_castsi256_ps(_mm256_cmpeq_epi32(self.0, o.0)) })
        }
        /// Philox with the lanes spread over the 64-bit slots of two registers (even and odd
        /// lanes): each multiply then yields both halves of four products in place, and only
        /// the low 32 bits of a slot are ever read, so no lanes are reassembled between rounds.
        #[inline(always)]
        fn philox4x32_10(ctr: [Self; 4], key: [u32; 2]) -> [Self; 4] {
            use crate::rng::{PHILOX_M0, PHILOX_M1, PHILOX_W0, PHILOX_W1};
            unsafe {
                let m0 = _mm256_set1_epi64x(PHILOX_M0 as i64);
                let m1 = _mm256_set1_epi64x(PHILOX_M1 as i64);
                let spread = |v: __m256i| (v, _mm256_srli_epi64::<32>(v));
                let mut even = [_mm256_setzero_si256(); 4];
                let mut odd = even;
                for k in 0..4 {
                    (even[k], odd[k]) = spread(ctr[k].0);
                }
                let (mut k0, mut k1) = (key[0], key[1]);
                for _ in 0..10 {
                    let (kk0, kk1) = (_mm256_set1_epi32(k0 as i32), _mm256_set1_epi32(k1 as i32));
                    for c in [&mut even, &mut odd] {
                        let p0 = _mm256_mul_epu32(m0, c[0]);
                        let p1 = _mm256_mul_epu32(m1, c[2]);
                        *c = [
                            _mm256_xor_si256(
                                _mm256_xor_si256(_mm256_srli_epi64::<32>(p1), c[1]),
                                kk0,
                            ),
                            p1,
                            _mm256_xor_si256(
                                _mm256_xor_si256(_mm256_srli_epi64::<32>(p0), c[3]),
                                kk1,
                            ),
                            p0,
                        ];
                    }
                    k0 = k0.wrapping_add(PHILOX_W0);
                    k1 = k1.wrapping_add(PHILOX_W1);
                }
                std::array::from_fn(|k| {
                    Avx2I32(_mm256_blend_epi32::<0b1010_1010>(
                        even[k],
                        _mm256_slli_epi64::<32>(odd[k]),
                    ))
                })
            }
        }

        #[inline(always)]
        fn mul_wide_unsigned(self, o: Self) -> (Self, Self) {
            unsafe {
                let even = _mm256_mul_epu32(self.0, o.0);
                let odd = _mm256_mul_epu32(
                    _mm256_srli_epi64::<32>(self.0),
                    _mm256_srli_epi64::<32>(o.0),
                );
                let lo = _mm256_blend_epi32::<0b1010_1010>(even, _mm256_slli_epi64::<32>(odd));
                let hi = _mm256_blend_epi32::<0b1010_1010>(_mm256_srli_epi64::<32>(even), odd);
                (Avx2I32(lo), Avx2I32(hi))
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::numerics::fastmath::{cbrt_f32, exp_f32};

    /// The lanes' Philox gives each lane the scalar function's words (portable and AVX2).
    #[test]
    fn lanes_draw_the_scalar_words() {
        use crate::rng::philox4x32_10;
        let ctr: [[u32; 4]; 8] = std::array::from_fn(|l| [l as u32 * 977, 3, 0x4f50, l as u32]);
        let key = [0xdead_beef, 42];
        let lanes = |k: usize| PortableI32(std::array::from_fn(|l| ctr[l][k] as i32));
        let out = philox4x32_10_lanes([lanes(0), lanes(1), lanes(2), lanes(3)], key);
        for l in 0..8 {
            let want = philox4x32_10(ctr[l], key);
            for k in 0..4 {
                assert_eq!(out[k].to_array()[l] as u32, want[k]);
            }
        }
        #[cfg(target_arch = "x86_64")]
        if let Some(t) = Avx2::detect() {
            let lanes =
                |k: usize| Avx2I32::from_array(t, std::array::from_fn(|l| ctr[l][k] as i32));
            let a = philox4x32_10_lanes([lanes(0), lanes(1), lanes(2), lanes(3)], key);
            for k in 0..4 {
                assert_eq!(a[k].to_array(), out[k].to_array());
            }
        }
    }

    /// Inputs across the functions' ranges, ties of the rounding included.
    fn inputs(k: u64) -> [f32; 8] {
        let rng = crate::rng::Philox::new(7, 0);
        let (u, v) = (rng.uniform4(k, 0), rng.uniform4(k, 1));
        [
            (u[0] - 0.5) * 200.0,
            (u[1] - 0.5) * 20.0,
            u[2] * 1e-3,
            (u[3] - 0.5) * 2.0,
            v[0] * 1e6,
            v[1],
            v[2] * 1e-30,
            (k as f32 - 10_000.0) * 0.5,
        ]
    }

    /// Every function of the interface on one set of lanes, as arrays.
    fn all<L: Lanes>(x: L) -> Vec<[f32; 8]> {
        let pos = x.max(x.splat_as(0.0)).add(x.splat_as(1e-20));
        let unit = x.max(x.splat_as(0.0)).min(x.splat_as(0.999_999_9));
        let (s, c) = unit.sincos_turns();
        vec![
            x.exp().to_array(),
            pos.cbrt().to_array(),
            pos.ln().to_array(),
            s.to_array(),
            c.to_array(),
            x.round_ties_even().to_array(),
        ]
    }

    #[test]
    fn portable_lanes_equal_the_scalar_functions_and_are_accurate() {
        for k in 0..20_000u64 {
            let xs = inputs(k);
            let p = PortableF32(xs);
            let (e, c) = (p.exp().to_array(), p.cbrt().to_array());
            for l in 0..8 {
                assert_eq!(e[l].to_bits(), exp_f32(xs[l]).to_bits(), "exp({})", xs[l]);
                if xs[l] >= 0.0 {
                    assert_eq!(c[l].to_bits(), cbrt_f32(xs[l]).to_bits(), "cbrt({})", xs[l]);
                }
            }
            let pos = xs.map(|v| v.abs() + 1e-20);
            let ln = PortableF32(pos).ln().to_array();
            let t = xs.map(|v| (v.abs().fract() * 16_777_216.0).floor() / 16_777_216.0);
            let (s, c) = PortableF32(t).sincos_turns();
            for l in 0..8 {
                let want = (pos[l] as f64).ln();
                assert!(
                    (ln[l] as f64 - want).abs() <= 2e-7 * want.abs().max(1.0),
                    "ln({})",
                    pos[l]
                );
                let a = std::f64::consts::TAU * t[l] as f64;
                assert!((s.0[l] as f64 - a.sin()).abs() < 3e-7, "sin 2π·{}", t[l]);
                assert!((c.0[l] as f64 - a.cos()).abs() < 3e-7, "cos 2π·{}", t[l]);
            }
        }
    }

    #[test]
    fn avx2_lanes_equal_portable_lanes_bit_for_bit() {
        #[cfg(target_arch = "x86_64")]
        {
            let Some(t) = Avx2::detect() else {
                eprintln!("no AVX2 here: the AVX2 lanes are not exercised");
                return;
            };
            for k in 0..20_000u64 {
                let xs = inputs(k);
                let a = all(Avx2F32::from_array(t, xs));
                let p = all(PortableF32(xs));
                for (fa, fp) in a.iter().zip(&p) {
                    assert_eq!(fa.map(f32::to_bits), fp.map(f32::to_bits), "inputs {xs:?}");
                }
            }
        }
    }

    #[test]
    fn integer_lanes_divide_and_multiply_exactly() {
        let rng = crate::rng::Philox::new(8, 0);
        let edges = [
            0u32,
            1,
            2,
            3,
            4,
            5,
            u32::MAX,
            u32::MAX - 1,
            u32::MAX - 2,
            1 << 31,
        ];
        for k in 0..50_000u64 {
            let r = rng.u32x4(k);
            let s = rng.u32x4((k + 1) << 40);
            let a: [u32; 8] = if (k as usize) < edges.len() {
                [edges[k as usize]; 8]
            } else {
                [r[0], r[1], r[2], r[3], s[0], s[1], s[2], s[3]]
            };
            let b: [u32; 8] = [s[3], s[2], r[1], r[0], r[3], s[1], 0xD251_1F53, 0xCD9E_8D57];
            let check = |q: [i32; 8], lo: [i32; 8], hi: [i32; 8]| {
                for l in 0..8 {
                    assert_eq!(q[l] as u32, a[l] / 3, "{}", a[l]);
                    let p = a[l] as u64 * b[l] as u64;
                    assert_eq!((lo[l] as u32, hi[l] as u32), (p as u32, (p >> 32) as u32));
                }
            };
            let x = PortableI32(a.map(|v| v as i32));
            let (lo, hi) = x.mul_wide_unsigned(PortableI32(b.map(|v| v as i32)));
            check(x.div3_unsigned().0, lo.0, hi.0);
            #[cfg(target_arch = "x86_64")]
            if let Some(t) = Avx2::detect() {
                let x = Avx2I32::from_array(t, a.map(|v| v as i32));
                let (lo, hi) = x.mul_wide_unsigned(Avx2I32::from_array(t, b.map(|v| v as i32)));
                check(x.div3_unsigned().to_array(), lo.to_array(), hi.to_array());
            }
        }
    }
}

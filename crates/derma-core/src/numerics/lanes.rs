//! Eight f32 (or i32) lanes in one AVX2 register, for loops that run across texels or photons
//! at once (issue 15: the match-table look-up, the photon walk). Runtime-dispatched: an
//! [`Avx2`] token exists only where the CPU has AVX2 and FMA, and every lane type is made from
//! one, so the code that uses them is safe; callers keep a scalar path for other CPUs.
//!
//! Every operation is the IEEE operation the scalar code performs (no fused multiply–add unless
//! asked for, the same rounding), and [`F32x8::exp`] and [`F32x8::cbrt`] mirror
//! [`super::fastmath`] step by step: lanes give the scalar results bit for bit, which keeps
//! outputs identical on every machine.

#[cfg(target_arch = "x86_64")]
pub use x86::*;

#[cfg(target_arch = "x86_64")]
mod x86 {
    use crate::numerics::fastmath::{EXP_POLY, LN2_HI, LN2_LO, ROUND_MAGIC};
    use std::arch::x86_64::*;

    /// Proof that the CPU runs AVX2 and FMA; the lane types are made from it.
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

    /// Eight f32 lanes. A comparison gives a mask: all bits set in the lanes where it holds.
    #[derive(Clone, Copy, Debug)]
    #[repr(transparent)]
    pub struct F32x8(__m256);

    /// Eight i32 lanes.
    #[derive(Clone, Copy, Debug)]
    #[repr(transparent)]
    pub struct I32x8(__m256i);

    // SAFETY (every `unsafe` block below): an F32x8 or I32x8 exists only after `Avx2::detect`
    // succeeded (the constructors take the token or a lane value), so the CPU executes the
    // AVX/AVX2/FMA instructions the intrinsics emit.
    macro_rules! f32_binary {
        ($($(#[$doc:meta])* $name:ident => $intr:ident),* $(,)?) => {$(
            $(#[$doc])*
            #[inline(always)]
            pub fn $name(self, o: F32x8) -> F32x8 {
                F32x8(unsafe { $intr(self.0, o.0) })
            }
        )*};
    }

    macro_rules! f32_compare {
        ($($(#[$doc:meta])* $name:ident => $pred:ident),* $(,)?) => {$(
            $(#[$doc])*
            #[inline(always)]
            pub fn $name(self, o: F32x8) -> F32x8 {
                F32x8(unsafe { _mm256_cmp_ps::<$pred>(self.0, o.0) })
            }
        )*};
    }

    impl F32x8 {
        /// `v` in every lane.
        #[inline(always)]
        pub fn splat(_: Avx2, v: f32) -> F32x8 {
            F32x8(unsafe { _mm256_set1_ps(v) })
        }

        /// The lanes of `v`.
        #[inline(always)]
        pub fn from_array(_: Avx2, v: [f32; 8]) -> F32x8 {
            F32x8(unsafe { _mm256_loadu_ps(v.as_ptr()) })
        }

        /// The first eight values of `v`.
        #[inline(always)]
        pub fn load(_: Avx2, v: &[f32]) -> F32x8 {
            assert!(v.len() >= 8, "eight lanes");
            F32x8(unsafe { _mm256_loadu_ps(v.as_ptr()) })
        }

        /// The lanes as an array.
        #[inline(always)]
        pub fn to_array(self) -> [f32; 8] {
            let mut out = [0.0f32; 8];
            unsafe { _mm256_storeu_ps(out.as_mut_ptr(), self.0) };
            out
        }

        /// `v` in every lane (the token taken from `self`).
        #[inline(always)]
        pub fn splat_as(self, v: f32) -> F32x8 {
            F32x8(unsafe { _mm256_set1_ps(v) })
        }

        f32_binary! {
            /// Lane-wise sum.
            add => _mm256_add_ps,
            /// Lane-wise difference.
            sub => _mm256_sub_ps,
            /// Lane-wise product.
            mul => _mm256_mul_ps,
            /// Lane-wise quotient.
            div => _mm256_div_ps,
            /// Lane-wise minimum (the second operand where either is NaN).
            min => _mm256_min_ps,
            /// Lane-wise maximum (the second operand where either is NaN).
            max => _mm256_max_ps,
            /// Bitwise and (masks).
            and => _mm256_and_ps,
            /// Bitwise or (masks).
            or => _mm256_or_ps,
            /// Bitwise and-not: `!self & o` (masks).
            and_not => _mm256_andnot_ps,
        }

        f32_compare! {
            /// Mask of `self >= o` (false with NaN).
            ge => _CMP_GE_OQ,
            /// Mask of `self > o`.
            gt => _CMP_GT_OQ,
            /// Mask of `self < o`.
            lt => _CMP_LT_OQ,
            /// Mask of `self <= o`.
            le => _CMP_LE_OQ,
            /// Mask of `self == o`.
            eq => _CMP_EQ_OQ,
        }

        /// `self · a + b`, fused (one rounding): only where the scalar code uses `mul_add`.
        #[inline(always)]
        pub fn mul_add(self, a: F32x8, b: F32x8) -> F32x8 {
            F32x8(unsafe { _mm256_fmadd_ps(self.0, a.0, b.0) })
        }

        /// `self` clamped to [`lo`, `hi`] as `f32::clamp` does for numbers.
        #[inline(always)]
        pub fn clamp(self, lo: f32, hi: f32) -> F32x8 {
            self.max(self.splat_as(lo)).min(self.splat_as(hi))
        }

        /// Lane-wise `if mask { a } else { b }` (`self` is the mask).
        #[inline(always)]
        pub fn select(self, a: F32x8, b: F32x8) -> F32x8 {
            F32x8(unsafe { _mm256_blendv_ps(b.0, a.0, self.0) })
        }

        /// The bits of each lane as an integer.
        #[inline(always)]
        pub fn to_bits(self) -> I32x8 {
            I32x8(unsafe { _mm256_castps_si256(self.0) })
        }

        /// Lanes truncated towards zero to integers (exact for integral values).
        #[inline(always)]
        pub fn to_i32(self) -> I32x8 {
            I32x8(unsafe { _mm256_cvttps_epi32(self.0) })
        }

        /// Square root, correctly rounded (as `f32::sqrt`).
        #[inline(always)]
        pub fn sqrt(self) -> F32x8 {
            F32x8(unsafe { _mm256_sqrt_ps(self.0) })
        }

        /// Lanes where a mask is set, as bits 0–7.
        #[inline(always)]
        pub fn mask_bits(self) -> u32 {
            unsafe { _mm256_movemask_ps(self.0) as u32 }
        }

        /// [`crate::numerics::fastmath::round_ties_even`] lane by lane.
        #[inline(always)]
        pub fn round_ties_even(self) -> F32x8 {
            let m = self.splat_as(ROUND_MAGIC);
            self.add(m).sub(m)
        }

        /// [`crate::numerics::fastmath::exp_f32`] lane by lane (the same operations in the same
        /// order).
        #[inline(always)]
        pub fn exp(self) -> F32x8 {
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
            let scale = n
                .to_i32()
                .add(I32x8::splat_as(n.to_bits(), 127))
                .shl::<23>()
                .to_f32_bits();
            p.mul(scale)
        }

        /// [`crate::numerics::fastmath::cbrt_f32`] lane by lane.
        #[inline(always)]
        pub fn cbrt(self) -> F32x8 {
            let bits = self.to_bits();
            let mut y = bits
                .div3_unsigned()
                .add(I32x8::splat_as(bits, 0x2a51_67a8))
                .to_f32_bits();
            let three = self.splat_as(3.0);
            for _ in 0..3 {
                let num = y.mul(y).mul(y).sub(self);
                let den = three.mul(y).mul(y);
                y = y.sub(num.div(den));
            }
            y
        }
    }

    impl I32x8 {
        /// `v` in every lane.
        #[inline(always)]
        pub fn splat(_: Avx2, v: i32) -> I32x8 {
            I32x8(unsafe { _mm256_set1_epi32(v) })
        }

        /// `v` in every lane (the token taken from `like`).
        #[inline(always)]
        pub fn splat_as(_like: I32x8, v: i32) -> I32x8 {
            I32x8(unsafe { _mm256_set1_epi32(v) })
        }

        /// The lanes of `v`.
        #[inline(always)]
        pub fn from_array(_: Avx2, v: [i32; 8]) -> I32x8 {
            I32x8(unsafe { _mm256_loadu_si256(v.as_ptr() as *const __m256i) })
        }

        /// The lanes as an array.
        #[inline(always)]
        pub fn to_array(self) -> [i32; 8] {
            let mut out = [0i32; 8];
            unsafe { _mm256_storeu_si256(out.as_mut_ptr() as *mut __m256i, self.0) };
            out
        }

        /// Lane-wise wrapping sum.
        #[inline(always)]
        pub fn add(self, o: I32x8) -> I32x8 {
            I32x8(unsafe { _mm256_add_epi32(self.0, o.0) })
        }

        /// Lane-wise wrapping difference.
        #[inline(always)]
        pub fn sub(self, o: I32x8) -> I32x8 {
            I32x8(unsafe { _mm256_sub_epi32(self.0, o.0) })
        }

        /// Lane-wise wrapping product (low 32 bits).
        #[inline(always)]
        pub fn mul(self, o: I32x8) -> I32x8 {
            I32x8(unsafe { _mm256_mullo_epi32(self.0, o.0) })
        }

        /// Bitwise and.
        #[inline(always)]
        pub fn and(self, o: I32x8) -> I32x8 {
            I32x8(unsafe { _mm256_and_si256(self.0, o.0) })
        }

        /// Bitwise exclusive or.
        #[inline(always)]
        pub fn xor(self, o: I32x8) -> I32x8 {
            I32x8(unsafe { _mm256_xor_si256(self.0, o.0) })
        }

        /// Shift left by `N` bits.
        #[inline(always)]
        pub fn shl<const N: i32>(self) -> I32x8 {
            I32x8(unsafe { _mm256_slli_epi32::<N>(self.0) })
        }

        /// Logical shift right by `N` bits.
        #[inline(always)]
        pub fn shr<const N: i32>(self) -> I32x8 {
            I32x8(unsafe { _mm256_srli_epi32::<N>(self.0) })
        }

        /// The lanes as f32 bit patterns.
        #[inline(always)]
        pub fn to_f32_bits(self) -> F32x8 {
            F32x8(unsafe { _mm256_castsi256_ps(self.0) })
        }

        /// The lanes converted to f32 (rounded to nearest).
        #[inline(always)]
        pub fn to_f32(self) -> F32x8 {
            F32x8(unsafe { _mm256_cvtepi32_ps(self.0) })
        }

        /// Mask (as f32 lanes) of `self == o`.
        #[inline(always)]
        pub fn eq(self, o: I32x8) -> F32x8 {
            F32x8(unsafe { _mm256_castsi256_ps(_mm256_cmpeq_epi32(self.0, o.0)) })
        }

        /// Each lane read as u32 divided by 3, exactly: ⌊x · ⌈2³³/3⌉ / 2³³⌋ = ⌊x/3⌋ for every
        /// 32-bit x (Granlund & Montgomery 1994, "Division by invariant integers using
        /// multiplication").
        #[inline(always)]
        pub fn div3_unsigned(self) -> I32x8 {
            unsafe {
                let m = _mm256_set1_epi32(0xAAAA_AAABu32 as i32);
                let even = _mm256_srli_epi64::<33>(_mm256_mul_epu32(self.0, m));
                let odd =
                    _mm256_srli_epi64::<33>(_mm256_mul_epu32(_mm256_srli_epi64::<32>(self.0), m));
                I32x8(_mm256_blend_epi32::<0b1010_1010>(
                    even,
                    _mm256_slli_epi64::<32>(odd),
                ))
            }
        }

        /// The low and high 32 bits of the lanes' unsigned 64-bit products with `o`
        /// (Philox's multiply).
        #[inline(always)]
        pub fn mul_wide_unsigned(self, o: I32x8) -> (I32x8, I32x8) {
            unsafe {
                let even = _mm256_mul_epu32(self.0, o.0);
                let odd = _mm256_mul_epu32(
                    _mm256_srli_epi64::<32>(self.0),
                    _mm256_srli_epi64::<32>(o.0),
                );
                let lo = _mm256_blend_epi32::<0b1010_1010>(even, _mm256_slli_epi64::<32>(odd));
                let hi = _mm256_blend_epi32::<0b1010_1010>(_mm256_srli_epi64::<32>(even), odd);
                (I32x8(lo), I32x8(hi))
            }
        }
    }
}

#[cfg(all(test, target_arch = "x86_64"))]
mod tests {
    use super::*;
    use crate::numerics::fastmath::{cbrt_f32, exp_f32};

    #[test]
    fn lanes_equal_the_scalar_functions_bit_for_bit() {
        let Some(t) = Avx2::detect() else {
            eprintln!("no AVX2 here: the lane functions are not exercised");
            return;
        };
        let rng = crate::rng::Philox::new(7, 0);
        for k in 0..20_000u64 {
            let u = rng.uniform4(k, 0);
            let v = rng.uniform4(k, 1);
            let xs: [f32; 8] = [
                (u[0] - 0.5) * 200.0,
                (u[1] - 0.5) * 20.0,
                u[2] * 1e-3,
                (u[3] - 0.5) * 2.0,
                v[0] * 1e6,
                v[1],
                v[2] * 1e-30,
                (k as f32 - 10_000.0) * 0.5, // exact halves: the rounding's ties
            ];
            let x = F32x8::from_array(t, xs);
            let (e, c) = (x.exp().to_array(), x.cbrt().to_array());
            for l in 0..8 {
                assert_eq!(e[l].to_bits(), exp_f32(xs[l]).to_bits(), "exp({})", xs[l]);
                if xs[l] >= 0.0 {
                    assert_eq!(c[l].to_bits(), cbrt_f32(xs[l]).to_bits(), "cbrt({})", xs[l]);
                }
            }
        }
    }

    #[test]
    fn integer_division_and_wide_products_are_exact() {
        let Some(t) = Avx2::detect() else {
            return;
        };
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
            let s = rng.u32x4(k + 1 << 40);
            let a: [u32; 8] = if (k as usize) < edges.len() {
                [edges[k as usize]; 8]
            } else {
                [r[0], r[1], r[2], r[3], s[0], s[1], s[2], s[3]]
            };
            let b: [u32; 8] = [s[3], s[2], r[1], r[0], r[3], s[1], 0xD251_1F53, 0xCD9E_8D57];
            let x = I32x8::from_array(t, a.map(|v| v as i32));
            let q = x.div3_unsigned().to_array();
            let (lo, hi) = x.mul_wide_unsigned(I32x8::from_array(t, b.map(|v| v as i32)));
            let (lo, hi) = (lo.to_array(), hi.to_array());
            for l in 0..8 {
                assert_eq!(q[l] as u32, a[l] / 3, "{}", a[l]);
                let p = a[l] as u64 * b[l] as u64;
                assert_eq!((lo[l] as u32, hi[l] as u32), (p as u32, (p >> 32) as u32));
            }
        }
    }
}

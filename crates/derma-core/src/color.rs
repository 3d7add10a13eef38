//! Colour science: spectra sampled on 380–780 nm every 10 nm, the CIE 1931 2° observer, the
//! CIE D65 illuminant, XYZ → linear sRGB (IEC 61966-2-1) and the sRGB transfer function.

use crate::cie_table::CIE1931_XYZ_10NM;

/// Number of spectral samples: 380, 390, …, 780 nm.
pub const N_WAVELENGTHS: usize = 41;

/// Wavelength of sample `i` in nm.
#[inline]
pub fn wavelength_nm(i: usize) -> f64 {
    380.0 + 10.0 * i as f64
}

/// A reflectance or absorption spectrum on the 10 nm grid.
pub type Spectrum = [f64; N_WAVELENGTHS];

/// CIE standard illuminant D65, relative spectral power, 380–780 nm every 10 nm.
/// Source: CIE 15:2004 "Colorimetry", Table T.1 (values at the 10 nm points).
pub const D65_10NM: Spectrum = [
    49.9755, 54.6482, 82.7549, 91.486, 93.4318, 86.6823, 104.865, 117.008, 117.812, 114.861,
    115.923, 108.811, 109.354, 107.802, 104.79, 107.689, 104.405, 104.046, 100.0, 96.3342, 95.788,
    88.6856, 90.0062, 89.5991, 87.6987, 83.2886, 83.6992, 80.0268, 80.2146, 82.2778, 78.2842,
    69.7213, 71.6091, 74.349, 61.604, 69.8856, 75.087, 63.5927, 46.4182, 66.8054, 63.3828,
];

/// CIE 1931 colour-matching functions (x̄, ȳ, z̄) at sample `i`.
#[inline]
pub fn cmf(i: usize) -> [f64; 3] {
    CIE1931_XYZ_10NM[i]
}

/// XYZ (Y = 1 for the perfect white) of a reflectance spectrum lit by D65.
pub fn reflectance_to_xyz(r: &Spectrum) -> [f64; 3] {
    let mut xyz = [0.0; 3];
    let mut norm = 0.0;
    for i in 0..N_WAVELENGTHS {
        let c = cmf(i);
        let s = D65_10NM[i];
        xyz[0] += r[i] * s * c[0];
        xyz[1] += r[i] * s * c[1];
        xyz[2] += r[i] * s * c[2];
        norm += s * c[1];
    }
    xyz.map(|v| v / norm)
}

/// XYZ (D65 white) → linear sRGB, IEC 61966-2-1:1999 matrix.
pub fn xyz_to_linear_srgb(xyz: [f64; 3]) -> [f64; 3] {
    let [x, y, z] = xyz;
    [
        3.2406 * x - 1.5372 * y - 0.4986 * z,
        -0.9689 * x + 1.8758 * y + 0.0415 * z,
        0.0557 * x - 0.2040 * y + 1.0570 * z,
    ]
}

/// Linear sRGB → XYZ, the inverse matrix of IEC 61966-2-1:1999.
pub fn linear_srgb_to_xyz(rgb: [f64; 3]) -> [f64; 3] {
    let [r, g, b] = rgb;
    [
        0.4124 * r + 0.3576 * g + 0.1805 * b,
        0.2126 * r + 0.7152 * g + 0.0722 * b,
        0.0193 * r + 0.1192 * g + 0.9505 * b,
    ]
}

/// Linear sRGB of a reflectance spectrum under D65.
pub fn reflectance_to_linear_srgb(r: &Spectrum) -> [f64; 3] {
    xyz_to_linear_srgb(reflectance_to_xyz(r))
}

/// Relative luminance of linear Rec. 709 / sRGB primaries (ITU-R BT.709-6, item 3.2; the Y row
/// of the sRGB → XYZ matrix): 0.2126 R + 0.7152 G + 0.0722 B, in f32 or f64.
#[inline]
pub fn luminance<T: Luminance>(rgb: [T; 3]) -> T {
    T::luminance(rgb)
}

/// The float types [`luminance`] works in (each in its own precision).
pub trait Luminance: Copy {
    /// See [`luminance`].
    fn luminance(rgb: [Self; 3]) -> Self;
}

macro_rules! luminance_in {
    ($t:ty) => {
        impl Luminance for $t {
            #[inline]
            fn luminance(c: [$t; 3]) -> $t {
                0.2126 * c[0] + 0.7152 * c[1] + 0.0722 * c[2]
            }
        }
    };
}
luminance_in!(f32);
luminance_in!(f64);

/// sRGB opto-electronic transfer function (IEC 61966-2-1), linear \[0,1\] → encoded \[0,1\].
#[inline]
pub fn srgb_encode(x: f32) -> f32 {
    let x = x.clamp(0.0, 1.0);
    if x <= 0.003_130_8 {
        12.92 * x
    } else {
        1.055 * x.powf(1.0 / 2.4) - 0.055
    }
}

/// Inverse of [`srgb_encode`].
#[inline]
pub fn srgb_decode(x: f32) -> f32 {
    let x = x.clamp(0.0, 1.0);
    if x <= 0.040_45 {
        x / 12.92
    } else {
        ((x + 0.055) / 1.055).powf(2.4)
    }
}

/// Linear value of an 8-bit sRGB code ([`srgb_decode`] of code / 255, tabulated).
#[inline]
pub fn srgb8_decode(code: u8) -> f32 {
    static TABLE: std::sync::OnceLock<[f32; 256]> = std::sync::OnceLock::new();
    TABLE.get_or_init(|| std::array::from_fn(|i| srgb_decode(i as f32 / 255.0)))[code as usize]
}

/// CIELAB (D65 white) of an XYZ colour; used to compare colours perceptually in tests and reports.
pub fn xyz_to_lab(xyz: [f64; 3]) -> [f64; 3] {
    // D65 white point, CIE 15:2004 (2° observer): Xn = 0.95047, Yn = 1, Zn = 1.08883.
    let n = [0.95047, 1.0, 1.08883];
    let f = |t: f64| {
        if t > (6.0f64 / 29.0).powi(3) {
            crate::numerics::fastmath::cbrt_f64(t)
        } else {
            t / (3.0 * (6.0f64 / 29.0).powi(2)) + 4.0 / 29.0
        }
    };
    let (fx, fy, fz) = (f(xyz[0] / n[0]), f(xyz[1] / n[1]), f(xyz[2] / n[2]));
    [116.0 * fy - 16.0, 500.0 * (fx - fy), 200.0 * (fy - fz)]
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn perfect_white_is_srgb_white() {
        // A perfect reflector under D65 must land on the sRGB white point: this checks the observer
        // table, the illuminant table and the matrix against each other.
        let rgb = reflectance_to_linear_srgb(&[1.0; N_WAVELENGTHS]);
        for c in rgb {
            assert!((c - 1.0).abs() < 0.01, "{rgb:?}");
        }
    }

    #[test]
    fn ybar_peaks_at_555_and_integrates_like_cie() {
        // ȳ has its maximum (1.0) near 555 nm; on the 10 nm grid the largest sample is at 550 or 560.
        let (imax, _) = (0..N_WAVELENGTHS)
            .map(|i| (i, cmf(i)[1]))
            .fold((0, 0.0), |a, b| if b.1 > a.1 { b } else { a });
        assert!(matches!(wavelength_nm(imax) as i32, 550 | 560));
        // Σ ȳ Δλ ≈ 106.86 for the 1931 observer (CIE 15:2004).
        let s: f64 = (0..N_WAVELENGTHS).map(|i| cmf(i)[1] * 10.0).sum();
        assert!((s - 106.86).abs() < 0.5, "{s}");
    }

    #[test]
    fn luminance_is_the_y_row_of_the_srgb_matrix() {
        for rgb in [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.2, 0.5, 0.8]] {
            assert!((luminance(rgb) - linear_srgb_to_xyz(rgb)[1]).abs() < 1e-12);
        }
        assert_eq!(luminance([1.0f32; 3]), 1.0);
    }

    #[test]
    fn matrices_are_inverse_and_transfer_roundtrips() {
        let rgb = [0.2, 0.5, 0.8];
        let back = xyz_to_linear_srgb(linear_srgb_to_xyz(rgb));
        for k in 0..3 {
            assert!((back[k] - rgb[k]).abs() < 1e-3);
        }
        for i in 0..=100 {
            let x = i as f32 / 100.0;
            assert!((srgb_decode(srgb_encode(x)) - x).abs() < 1e-5);
        }
        assert!((srgb_encode(0.214_041) - 0.5).abs() < 1e-3);
    }
}

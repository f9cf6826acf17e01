//! The scalar type: `f32` on the board, `f64` on the host.

use nalgebra::RealField;

/// A real scalar the whole crate is generic over (implemented for `f32` and
/// `f64`). Tolerances are derived from its machine epsilon so that the same
/// code is correct in both precisions.
pub trait Real: RealField + Copy {
    /// Converts an `f64` literal (exact for the small constants used here).
    fn lit(x: f64) -> Self;
    /// Machine epsilon of the type.
    fn eps() -> Self;
    /// `(sin x, cos x)` in the type's own precision. `f64` uses libm; `f32` uses `sin_cos_f32`, which
    /// stays in single precision (libm's `sinf`/`cosf` work in `f64`, which
    /// the Cortex-M4F emulates in software at about 1200 instructions a call).
    fn sin_cos_native(self) -> (Self, Self);
    /// Square root in the type's own precision, correctly rounded where the
    /// processor has a square-root instruction: `f64` by `sqrt_f64`,
    /// `f32` by `sqrt_f32` (libm's `sqrtf` is a software loop on
    /// Cortex-M, where no libm routine uses the FPU's `vsqrt.f32`).
    fn sqrt_native(self) -> Self;
}

impl Real for f64 {
    #[inline]
    fn lit(x: f64) -> Self {
        x
    }
    #[inline]
    fn eps() -> Self {
        f64::EPSILON
    }
    #[inline]
    fn sin_cos_native(self) -> (Self, Self) {
        (nalgebra::ComplexField::sin(self), nalgebra::ComplexField::cos(self))
    }
    #[inline]
    fn sqrt_native(self) -> Self {
        sqrt_f64(self)
    }
}

impl Real for f32 {
    #[inline]
    fn lit(x: f64) -> Self {
        x as f32
    }
    #[inline]
    fn eps() -> Self {
        f32::EPSILON
    }
    #[inline]
    fn sin_cos_native(self) -> (Self, Self) {
        sin_cos_f32(self)
    }
    #[inline]
    fn sqrt_native(self) -> Self {
        sqrt_f32(self)
    }
}

/// Square root in double precision: nalgebra's, which is `std`'s (the
/// processor's instruction, as a compiler intrinsic) with this crate's
/// `std` feature, and libm's otherwise. Host builds should enable `std`:
/// libm's x86 `sqrt` is inline assembly `sqrtsd`, legacy-SSE encoded, and
/// inside AVX code (`-C target-cpu=native`) each one stalls on the switch
/// between the two encodings (issue 17: polygon code 2-3x slower).
#[inline]
pub fn sqrt_f64(x: f64) -> f64 {
    nalgebra::ComplexField::sqrt(x)
}

/// Square root in single precision, correctly rounded. On a hard-float
/// ARM board (the Cortex-M4F) the FPU's `vsqrt.f32` through [`vfp_sqrt`]
/// (a call of three instructions; libm's `sqrtf` is a software loop of
/// about 55 on Cortex-M, and the instruction is out of reach of safe stable
/// Rust in this crate); on another bare-metal target without it
/// [`sqrt_f32_newton`]; on a host the processor's (through `std` as
/// [`sqrt_f64`], or libm's `sqrtss`).
#[inline]
pub fn sqrt_f32(x: f32) -> f32 {
    #[cfg(all(target_arch = "arm", target_abi = "eabihf"))]
    {
        vfp_sqrt::sqrt(x)
    }
    #[cfg(all(target_os = "none", not(all(target_arch = "arm", target_abi = "eabihf"))))]
    {
        sqrt_f32_newton(x)
    }
    #[cfg(not(any(target_os = "none", all(target_arch = "arm", target_abi = "eabihf"))))]
    {
        nalgebra::ComplexField::sqrt(x)
    }
}

/// Square root in single precision without a square-root instruction: a
/// first guess from halving the exponent in the bit pattern (within 4 %),
/// then three Newton (Heron) steps `y <- (y + x / y) / 2`, each doubling the
/// correct digits (4e-2 -> 8e-4 -> 3e-7 -> rounding), so the result is
/// within one unit in the last place. Zero, infinity and NaN map to
/// themselves, a negative number to NaN, as `sqrt` does; subnormals are
/// scaled first.
// A host build or a hard-float board calls it from the tests only.
#[cfg_attr(any(not(target_os = "none"), target_abi = "eabihf"), allow(dead_code))]
pub fn sqrt_f32_newton(x: f32) -> f32 {
    if x.is_nan() || x < 0.0 {
        return f32::NAN;
    }
    if x == 0.0 || x == f32::INFINITY {
        return x;
    }
    // Scale subnormals into the normal range (sqrt(2^24) = 2^12).
    let (x, scale) = if x < f32::MIN_POSITIVE { (x * 16_777_216.0, 1.0 / 4096.0) } else { (x, 1.0) };
    let mut y = f32::from_bits((x.to_bits() >> 1) + 0x1fbd_1df5);
    for _ in 0..3 {
        y = 0.5 * (y + x / y);
    }
    y * scale
}

/// `(sin x, cos x)` in single precision: the quadrant `q = round(2x / pi)`,
/// the remainder `r = x - q pi/2` by Cody-Waite reduction with `pi/2` split in
/// three `f32` parts (exact products for `|q| < 2^12`), then the minimax
/// polynomials of the Cephes library's `sinf`/`cosf` on `[-pi/4, pi/4]`
/// (error below 2 ulp there). Arguments beyond `|x| = 8192` (never a pose
/// angle) go to libm. NaN in, NaN out; nothing panics.
#[allow(clippy::excessive_precision)] // the coefficients as published
pub fn sin_cos_f32(x: f32) -> (f32, f32) {
    use nalgebra::ComplexField;
    if x.is_nan() || x.abs() > 8192.0 {
        return (ComplexField::sin(x), ComplexField::cos(x));
    }
    const TWO_OVER_PI: f32 = core::f32::consts::FRAC_2_PI;
    const PIO2_1: f32 = 1.570_312_5;
    const PIO2_2: f32 = 4.837_512_969_970_703e-4;
    const PIO2_3: f32 = 7.549_789_948_768_648e-8;
    let qf = libm_round(x * TWO_OVER_PI);
    let r = ((x - qf * PIO2_1) - qf * PIO2_2) - qf * PIO2_3;
    let z = r * r;
    let s = r + r * z * (-1.666_665_461_1e-1 + z * (8.332_160_873_6e-3 + z * -1.951_529_589_1e-4));
    let c = 1.0 - 0.5 * z
        + z * z * (4.166_664_568_298_827e-2 + z * (-1.388_731_625_493_765e-3 + z * 2.443_315_711_809_948e-5));
    match (qf as i32) & 3 {
        0 => (s, c),
        1 => (c, -s),
        2 => (-s, -c),
        _ => (-c, s),
    }
}

/// Round half away from zero without `std` (exact for `|x| < 2^23`).
#[inline]
fn libm_round(x: f32) -> f32 {
    let t = (x.abs() + 0.5) as i32 as f32;
    if x < 0.0 {
        -t
    } else {
        t
    }
}

/// `true` when every entry of the slice is finite (a flat loop without early
/// exit: cheaper than an iterator chain for the small fixed sizes here).
#[inline]
pub(crate) fn finite<T: Real>(values: &[T]) -> bool {
    all_finite(values.iter().copied())
}

/// The larger of `a` and `b` by a plain comparison (`b` when they are
/// unordered). `f32::max` is a call to libm's software `fmaxf` on the
/// Cortex-M4F, whose FPU has no `vmaxnm`.
#[inline(always)]
pub fn max<T: Real>(a: T, b: T) -> T {
    if a > b {
        a
    } else {
        b
    }
}

/// The smaller of `a` and `b` by a plain comparison (`b` when they are
/// unordered); see [`max`].
#[inline(always)]
pub fn min<T: Real>(a: T, b: T) -> T {
    if a < b {
        a
    } else {
        b
    }
}

/// `true` when every value is finite: `0 x` is `0` for a finite `x` and NaN
/// for an infinite or NaN one, so the sum of the `0 x` is zero exactly when
/// all are finite (a multiply and an add per value, no branch: cheaper on
/// the Cortex-M4F than a test and a branch per value; `cdpr-control`'s
/// per-cycle checks call it too).
#[inline]
pub fn all_finite<T: Real>(values: impl IntoIterator<Item = T>) -> bool {
    values.into_iter().fold(T::zero(), |acc, v| acc + v * T::zero()) == T::zero()
}

/// `a > b`, false when either is NaN (written as a call so that the NaN case
/// reads as intended where it is negated).
#[inline]
pub(crate) fn greater<T: Real>(a: T, b: T) -> bool {
    a > b
}

#[cfg(test)]
mod tests {
    use super::*;

    /// `all_finite` is `all(is_finite)` on finite values of every kind
    /// (zeros of both signs, subnormals, the largest) and with one NaN or
    /// infinity at every position.
    #[test]
    fn all_finite_is_every_value_finite() {
        let finite = [0.0f32, -0.0, 1e-45, -1e-45, 1.0, -3.5, f32::MAX, f32::MIN, 1e-38, 7e37];
        assert!(all_finite(finite));
        assert!(all_finite([0.0f32; 0]));
        let mut refused = 0;
        for bad in [f32::NAN, -f32::NAN, f32::INFINITY, f32::NEG_INFINITY] {
            for i in 0..finite.len() {
                let mut values = finite;
                values[i] = bad;
                assert!(!all_finite(values), "{bad} at {i}");
                refused += 1;
            }
        }
        assert_eq!(refused, 40);
    }

    #[test]
    fn single_precision_sin_cos_matches_f64() {
        let mut worst = 0.0f64;
        let mut x = -100.0f32;
        while x < 100.0 {
            let (s, c) = sin_cos_f32(x);
            let xd = x as f64;
            worst = worst.max((s as f64 - xd.sin()).abs()).max((c as f64 - xd.cos()).abs());
            x += 0.000_37;
        }
        assert!(worst < 3.0e-7, "worst {worst}");
        for big in [1.0e4f32, -3.0e5, 1.0e30] {
            let (s, c) = sin_cos_f32(big);
            assert!(
                (s as f64 - (big as f64).sin()).abs() < 1e-6 && (c as f64 - (big as f64).cos()).abs() < 1e-6
            );
        }
        let mut worst_sqrt = 0.0f64;
        let (mut v, mut checked) = (1.0e-40f32, 0);
        while v < 1.0e38 {
            let exact = (v as f64).sqrt();
            worst_sqrt = worst_sqrt.max(((sqrt_f32_newton(v) as f64) - exact).abs() / exact);
            // The f64 root rounded to f32 is the correctly rounded f32 root
            // (53 bits are more than 2 x 24 + 2: no double rounding); the
            // host's `sqrt_f32` is the processor's.
            assert_eq!(sqrt_f32(v).to_bits(), (exact as f32).to_bits(), "sqrt_f32({v:e})");
            assert_eq!(sqrt_f64(f64::from(v)), exact, "sqrt_f64({v:e})");
            checked += 1;
            v *= 1.0137;
        }
        assert!(checked > 9_000, "{checked} values");
        assert!(worst_sqrt < 1.2e-7, "sqrt relative error {worst_sqrt}");
        for f in [sqrt_f32, sqrt_f32_newton] {
            assert_eq!(f(0.0), 0.0);
            assert_eq!(f(4.0), 2.0);
            assert_eq!(f(f32::INFINITY), f32::INFINITY);
            assert!(f(-1.0).is_nan() && f(f32::NAN).is_nan());
        }
        assert_eq!(sqrt_f64(0.0), 0.0);
        assert_eq!(sqrt_f64(f64::INFINITY), f64::INFINITY);
        assert!(sqrt_f64(-1.0).is_nan() && sqrt_f64(f64::NAN).is_nan());
        let (s, c) = sin_cos_f32(f32::NAN);
        assert!(s.is_nan() && c.is_nan());
        assert!(sin_cos_f32(f32::INFINITY).0.is_nan());
    }
}

//! `f32` functions for vectorised kernels: the same value on every machine
//! and in every SIMD build (plain `f32` operations in a fixed order, no
//! fused multiply-add, no library call), and branch-free (selects), so a
//! loop that calls them vectorises. The library's `exp` or `asin` are
//! calls into the C library on the x86-64 baseline: a loop that calls one
//! stays scalar, and the C library's last bit may differ between machines.
//! `f32::floor` is exact everywhere and one instruction (`vroundps`,
//! `vrndscaleps`) in the AVX2 and AVX-512 builds, which is where the
//! kernels run: they call it as it is (on the baseline it is a call).
//!
//! The polynomials are Cephes' single-precision ones (`expf`, `asinf`,
//! `atanf`), within a few units in the last place.

use std::f32::consts::{FRAC_PI_2, FRAC_PI_4, PI};

/// 2²³: from it up, every `f32` is an integer.
const MAGIC: f32 = 8_388_608.0;

/// `x`, an integer in [0, 2²³), as an integer: its bits past 2²³ added
/// (no conversion instruction: an `as` conversion saturates, and its
/// checks keep a loop from vectorising).
#[inline(always)]
pub(crate) fn small_uint(x: f32) -> u32 {
    (x + MAGIC).to_bits() & 0x7f_ffff
}

/// `x − floor(x)`, in [0, 1) for finite `x` below 2²³ in magnitude.
#[inline(always)]
pub(crate) fn fract(x: f32) -> f32 {
    x - x.floor()
}

/// e^x, 0 below −87.3 and e^88.3 above 88.3 (a NaN gives e^−87.3, ≈ 0).
#[inline(always)]
#[allow(clippy::manual_clamp, reason = "a NaN gives the lower bound")]
pub(crate) fn exp(x: f32) -> f32 {
    let x = x.max(-87.3).min(88.3);
    let n = (x * std::f32::consts::LOG2_E + 0.5).floor();
    // x − n·ln 2 in two parts (Cephes' C1 and C2), exactly representable.
    let r = x - n * 0.693_359_4 + n * 2.121_944_4e-4;
    let z = r * r;
    let p = (((((1.987_569_1e-4 * r + 1.398_2e-3) * r + 8.333_452e-3) * r + 4.166_579_6e-2) * r
        + 1.666_666_5e-1)
        * r
        + 0.5)
        * z
        + r
        + 1.0;
    // 2^n: n in [−126, 127], a normal float's exponent.
    let scale = f32::from_bits(small_uint(n + 127.0) << 23);
    p * scale
}

/// asin of `x` in [0, ½] (Cephes' polynomial in x²).
#[inline(always)]
fn asin_small(x: f32) -> f32 {
    let z = x * x;
    ((((4.216_32e-2 * z + 2.418_131e-2) * z + 4.547_002_6e-2) * z + 7.495_300_3e-2) * z
        + 1.666_675_2e-1)
        * z
        * x
        + x
}

/// The arc sine of `x` (clamped to [−1, 1]), in [−π/2, π/2].
#[inline(always)]
pub(crate) fn asin(x: f32) -> f32 {
    let a = x.abs().min(1.0);
    let big = a > 0.5;
    // asin a = π/2 − 2·asin √((1 − a)/2) above ½.
    let s = if big { (0.5 * (1.0 - a)).sqrt() } else { a };
    let p = asin_small(s);
    let r = if big { FRAC_PI_2 - 2.0 * p } else { p };
    if x < 0.0 { -r } else { r }
}

/// The arc cosine of `x` (clamped to [−1, 1]), in [0, π]: exact near 1,
/// where the angle is small (`2·asin √((1 − x)/2)`).
#[inline(always)]
pub(crate) fn acos(x: f32) -> f32 {
    let a = x.abs().min(1.0);
    let big = a > 0.5;
    let s = if big { (0.5 * (1.0 - a)).sqrt() } else { a };
    let p = asin_small(s);
    // acos |x|: 2·asin √((1 − |x|)/2) above ½, π/2 − asin |x| below.
    let r = if big { 2.0 * p } else { FRAC_PI_2 - p };
    if x < 0.0 { PI - r } else { r }
}

/// The arc tangent of `y / x` in (−π, π] (0 for the origin): Cephes'
/// `atanf` polynomial after reducing the ratio to [0, tan π/8].
#[inline(always)]
pub(crate) fn atan2(y: f32, x: f32) -> f32 {
    let (ax, ay) = (x.abs(), y.abs());
    let (lo, hi) = (ax.min(ay), ax.max(ay));
    let a = if hi > 0.0 { lo / hi } else { 0.0 };
    let reduce = a > 0.414_213_57;
    let t = if reduce { (a - 1.0) / (a + 1.0) } else { a };
    let z = t * t;
    let p =
        (((8.053_744_5e-2 * z - 1.387_768_6e-1) * z + 1.997_771_1e-1) * z - 3.333_295e-1) * z * t
            + t;
    let r = if reduce { p + FRAC_PI_4 } else { p };
    let r = if ay > ax { FRAC_PI_2 - r } else { r };
    let r = if x < 0.0 { PI - r } else { r };
    if y < 0.0 { -r } else { r }
}

/// GLSL's `smoothstep`: 0 below `e0`, 1 above `e1`, the cubic between.
#[inline(always)]
pub(crate) fn smoothstep(e0: f32, e1: f32, x: f32) -> f32 {
    let t = ((x - e0) / (e1 - e0)).clamp(0.0, 1.0);
    t * t * (3.0 - 2.0 * t)
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::f32::consts::TAU;

    /// The largest difference of `f` from `want` (in `f64`) over `xs`,
    /// relative to `want` where it is above 1.
    fn worst(xs: impl Iterator<Item = f32>, f: fn(f32) -> f32, want: fn(f64) -> f64) -> f64 {
        xs.map(|x| {
            let w = want(f64::from(x));
            (f64::from(f(x)) - w).abs() / w.abs().max(1.0)
        })
        .fold(0.0, f64::max)
    }

    #[test]
    fn the_arc_tangent_is_within_a_few_units_in_the_last_place() {
        let mut worst = 0f64;
        for i in 0..=720 {
            for r in [1e-6f32, 0.3, 1.0, 7.0, 1e6] {
                let angle = i as f32 / 720.0 * TAU - PI;
                let (y, x) = (r * angle.sin(), r * angle.cos());
                let want = f64::from(y).atan2(f64::from(x));
                let got = f64::from(atan2(y, x));
                worst = worst.max((got - want).abs());
            }
        }
        assert!(worst < 5e-7, "worst error {worst:e} rad");
        assert_eq!(atan2(0.0, 0.0), 0.0);
        assert_eq!(atan2(0.0, -1.0), PI);
        assert_eq!(atan2(1.0, 0.0), FRAC_PI_2);
        assert_eq!(atan2(-1.0, 0.0), -FRAC_PI_2);
    }

    #[test]
    fn exp_is_within_a_few_units_in_the_last_place() {
        let xs = (0..=20_000).map(|i| -87.0 + i as f32 * (175.0 / 20_000.0));
        let e = worst(xs, exp, f64::exp);
        // Relative error: the values span 1e-38 to 1e38.
        let rel = (0..=20_000)
            .map(|i| -87.0 + i as f32 * (175.0 / 20_000.0))
            .map(|x| (f64::from(exp(x)) / f64::from(x).exp() - 1.0).abs())
            .fold(0.0, f64::max);
        assert!(rel < 4e-7, "worst relative error {rel:e} ({e:e})");
        assert_eq!(exp(0.0), 1.0);
        assert!(exp(-200.0) < 1e-37 && exp(-200.0) >= 0.0);
        assert!(exp(f32::NAN).is_finite() && exp(200.0).is_finite());
    }

    #[test]
    fn asin_and_acos_are_within_a_few_units_in_the_last_place() {
        let xs = || (0..=40_000).map(|i| -1.0 + i as f32 / 20_000.0);
        let e = worst(xs(), asin, f64::asin);
        assert!(e < 4e-7, "asin: worst error {e:e}");
        let e = worst(xs(), acos, f64::acos);
        assert!(e < 4e-7, "acos: worst error {e:e}");
        // Small angles near 1 keep their precision (no π/2 − π/2 + ε).
        let x = 1.0 - 1e-6f32;
        let rel = f64::from(acos(x)) / f64::from(x).acos() - 1.0;
        assert!(rel.abs() < 1e-5, "acos near 1: {rel:e}");
        assert_eq!(asin(2.0), FRAC_PI_2);
        assert_eq!(acos(-3.0), PI);
    }

    #[test]
    fn small_uint_and_fract_are_exact() {
        for n in [0u32, 1, 254, 65_535, (1 << 23) - 1] {
            assert_eq!(small_uint(n as f32), n);
        }
        assert_eq!(fract(-0.25), 0.75);
        assert_eq!(fract(2.5), 0.5);
        assert_eq!(fract(-3.0), 0.0);
    }
}

//! Per-pixel randomness for sensor noise, the same on every machine and
//! for any number of threads: pixel `i`'s 64 random bits are SplitMix64's
//! output at position `i` of the stream seeded with the frame's noise seed
//! (`mix64(seed + (i + 1)·φ64)`, a counter-based hash, no state carried from
//! pixel to pixel), and each channel takes 12 of them as an index into a
//! table of 4 096 normal quantiles.
//!
//! The table holds Φ⁻¹((k + ½)/4096) (Acklam's rational approximation,
//! relative error < 1.2·10⁻⁹, computed once in f64), made exactly
//! antisymmetric and scaled to mean square 1, so the deviates have mean 0
//! and variance 1 exactly over the table; they reach ±3.6 σ.

use std::sync::OnceLock;

const GOLDEN_GAMMA: u64 = 0x9E37_79B9_7F4A_7C15;
/// Bits per channel deviate.
const BITS: u32 = 12;
const SIZE: usize = 1 << BITS;

/// The 64 random bits of pixel `index` under `seed`.
#[inline]
pub fn bits(seed: u64, index: u64) -> u64 {
    crate::seed::mix64(seed.wrapping_add(index.wrapping_add(1).wrapping_mul(GOLDEN_GAMMA)))
}

/// The standard normal deviate of `channel` (0, 1, 2) from a pixel's bits.
#[inline]
pub fn normal(table: &[f32; SIZE], bits: u64, channel: usize) -> f32 {
    table[((bits >> (BITS as usize * channel)) as usize) & (SIZE - 1)]
}

/// The quantile table (built once per process).
pub fn table() -> &'static [f32; SIZE] {
    static TABLE: OnceLock<Box<[f32; SIZE]>> = OnceLock::new();
    TABLE.get_or_init(|| {
        let mut t = [0f64; SIZE];
        for k in 0..SIZE / 2 {
            let q = inverse_normal((k as f64 + 0.5) / SIZE as f64);
            t[k] = q;
            t[SIZE - 1 - k] = -q;
        }
        let mean_square = t.iter().map(|x| x * x).sum::<f64>() / SIZE as f64;
        let scale = 1.0 / mean_square.sqrt();
        let mut out = Box::new([0f32; SIZE]);
        for (o, x) in out.iter_mut().zip(t) {
            *o = (x * scale) as f32;
        }
        out
    })
}

/// Φ⁻¹(p) for p in (0, 1): Peter Acklam's algorithm.
fn inverse_normal(p: f64) -> f64 {
    const A: [f64; 6] = [
        -3.969_683_028_665_376e1,
        2.209_460_984_245_205e2,
        -2.759_285_104_469_687e2,
        1.383_577_518_672_69e2,
        -3.066_479_806_614_716e1,
        2.506_628_277_459_239,
    ];
    const B: [f64; 5] = [
        -5.447_609_879_822_406e1,
        1.615_858_368_580_409e2,
        -1.556_989_798_598_866e2,
        6.680_131_188_771_972e1,
        -1.328_068_155_288_572e1,
    ];
    const C: [f64; 6] = [
        -7.784_894_002_430_293e-3,
        -3.223_964_580_411_365e-1,
        -2.400_758_277_161_838,
        -2.549_732_539_343_734,
        4.374_664_141_464_968,
        2.938_163_982_698_783,
    ];
    const D: [f64; 4] = [
        7.784_695_709_041_462e-3,
        3.224_671_290_700_398e-1,
        2.445_134_137_142_996,
        3.754_408_661_907_416,
    ];
    const LOW: f64 = 0.02425;
    let tail = |q: f64| {
        (((((C[0] * q + C[1]) * q + C[2]) * q + C[3]) * q + C[4]) * q + C[5])
            / ((((D[0] * q + D[1]) * q + D[2]) * q + D[3]) * q + 1.0)
    };
    if p < LOW {
        tail((-2.0 * p.ln()).sqrt())
    } else if p <= 1.0 - LOW {
        let q = p - 0.5;
        let r = q * q;
        (((((A[0] * r + A[1]) * r + A[2]) * r + A[3]) * r + A[4]) * r + A[5]) * q
            / (((((B[0] * r + B[1]) * r + B[2]) * r + B[3]) * r + B[4]) * r + 1.0)
    } else {
        -tail((-2.0 * (1.0 - p).ln()).sqrt())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn quantiles_are_normal() {
        assert!((inverse_normal(0.975) - 1.959_963_985).abs() < 1e-8);
        assert!((inverse_normal(0.5)).abs() < 1e-12);
        assert!((inverse_normal(0.001) + 3.090_232_306).abs() < 1e-8);
        let t = table();
        let n = t.len() as f64;
        let mean = t.iter().map(|&x| f64::from(x)).sum::<f64>() / n;
        let var = t.iter().map(|&x| f64::from(x).powi(2)).sum::<f64>() / n;
        assert!(mean.abs() < 1e-9, "{mean}");
        assert!((var - 1.0).abs() < 1e-6, "{var}");
        // Hashed draws over many pixels: mean 0, σ 1, each channel alike.
        let seed = 12345;
        for ch in 0..3 {
            let xs: Vec<f64> = (0..200_000u64)
                .map(|i| f64::from(normal(t, bits(seed, i), ch)))
                .collect();
            let m = xs.iter().sum::<f64>() / xs.len() as f64;
            let s = (xs.iter().map(|x| (x - m).powi(2)).sum::<f64>() / xs.len() as f64).sqrt();
            assert!(m.abs() < 0.01, "channel {ch}: mean {m}");
            assert!((s - 1.0).abs() < 0.01, "channel {ch}: σ {s}");
        }
        // Channels of one pixel are uncorrelated.
        let c: f64 = (0..200_000u64)
            .map(|i| {
                let b = bits(seed, i);
                f64::from(normal(t, b, 0)) * f64::from(normal(t, b, 1))
            })
            .sum::<f64>()
            / 200_000.0;
        assert!(c.abs() < 0.01, "{c}");
    }
}

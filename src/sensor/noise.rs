//! Per-pixel randomness for sensor noise, the same on every machine and
//! for any number of threads: the deviate of channel `c` of sensor pixel
//! `i` comes from a 32-bit counter-based hash of the counter `3·i + c`
//! under the frame's noise key (two 32-bit words of the frame's noise
//! seed): `lowbias32(counter·k₀ ⊕ k₁)`, k₀ odd (Chris Wellons' integer
//! hash, constants 0x21f0aaad / 0x735a2d97). No state is carried from
//! pixel to pixel, so any split of the rows gives the same deviates; the
//! counter wraps at 2³² (sensors over 1.4 G pixels repeat their noise).
//! The top 12 bits of the hash index a table of 4 096 normal quantiles.
//!
//! The hashes of a run of pixels are computed in one loop of 32-bit
//! integer operations that the compiler vectorises (SSE2 on any x86-64),
//! the table lookups in a second loop ([`deviates`]).
//!
//! The table holds Φ⁻¹((k + ½)/4096) (Acklam's rational approximation,
//! relative error < 1.2·10⁻⁹, computed once in f64), made exactly
//! antisymmetric and scaled to mean square 1, so the deviates have mean 0
//! and variance 1 exactly over the table; they reach ±3.6 σ.

use std::sync::OnceLock;

/// Bits per channel deviate.
const BITS: u32 = 12;
const SIZE: usize = 1 << BITS;

/// A frame's noise key: the multiplier (odd) and the mask of the hash's input.
#[derive(Clone, Copy, Debug)]
pub struct Key {
    k0: u32,
    k1: u32,
}

impl Key {
    /// The key of a frame's 64-bit noise seed.
    pub fn new(seed: u64) -> Self {
        Self {
            k0: (seed as u32) | 1,
            k1: (seed >> 32) as u32,
        }
    }

    /// The 32 random bits of `counter` (= 3 · pixel index + channel).
    #[inline(always)]
    pub fn bits(self, counter: u32) -> u32 {
        let mut x = counter.wrapping_mul(self.k0) ^ self.k1;
        x ^= x >> 16;
        x = x.wrapping_mul(0x21f0_aaad);
        x ^= x >> 15;
        x = x.wrapping_mul(0x735a_2d97);
        x ^ (x >> 15)
    }
}

/// The table index of a hash (its top [`BITS`] bits).
#[inline(always)]
fn index(bits: u32) -> u32 {
    bits >> (32 - BITS)
}

/// The standard normal deviates of sensor pixels `first`, `first + 1`, …
/// (as many as `out[0]` is long) for channels 0, 1, 2 into `out[c]`;
/// `scratch` is working memory (any contents).
#[inline(always)]
pub fn deviates(key: Key, first: u64, scratch: &mut Vec<u32>, out: [&mut [f32]; 3]) {
    let [d0, d1, d2] = out;
    let n = d0.len();
    debug_assert!(d1.len() == n && d2.len() == n);
    scratch.resize(3 * n, 0);
    // Counters 3·first … 3·(first + n) − 1, one per (pixel, channel), in order.
    let base = (first as u32).wrapping_mul(3);
    for (j, s) in scratch.iter_mut().enumerate() {
        *s = index(key.bits(base.wrapping_add(j as u32)));
    }
    let table = table();
    for (((a, b), c), s) in d0
        .iter_mut()
        .zip(d1.iter_mut())
        .zip(d2.iter_mut())
        .zip(scratch.chunks_exact(3))
    {
        *a = table[s[0] as usize & (SIZE - 1)];
        *b = table[s[1] as usize & (SIZE - 1)];
        *c = table[s[2] as usize & (SIZE - 1)];
    }
}

/// Clip `vals` (linear) at the full well, add Poisson–Gaussian noise with
/// the deviates `devs` (variance in linear 8-bit levels² = gain·signal +
/// read², so σ in linear units is √(gain·255·signal + read²) / 255), clip
/// again. A loop that vectorises.
#[inline(always)]
pub fn add(vals: &mut [f32], devs: &[f32], gain: f32, read2: f32) {
    for (v, n) in vals.iter_mut().zip(devs) {
        let signal = v.clamp(0.0, 1.0);
        let sigma = (gain * 255.0 * signal + read2).sqrt() * (1.0 / 255.0);
        *v = (signal + sigma * n).clamp(0.0, 1.0);
    }
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
        // Hashed draws over many pixels: mean 0, σ 1, each channel alike,
        // for a few keys; and one pixel's channels uncorrelated, as are
        // neighbouring pixels.
        for seed in [12345u64, 0, u64::MAX, 0x9E37_79B9_7F4A_7C15] {
            let n = 200_000usize;
            let mut ds = [vec![0f32; n], vec![0f32; n], vec![0f32; n]];
            let [a, b, c] = &mut ds;
            deviates(Key::new(seed), 7, &mut Vec::new(), [a, b, c]);
            for (ch, xs) in ds.iter().enumerate() {
                let m = xs.iter().map(|&x| f64::from(x)).sum::<f64>() / n as f64;
                let s =
                    (xs.iter().map(|&x| (f64::from(x) - m).powi(2)).sum::<f64>() / n as f64).sqrt();
                assert!(m.abs() < 0.01, "seed {seed}, channel {ch}: mean {m}");
                assert!((s - 1.0).abs() < 0.01, "seed {seed}, channel {ch}: σ {s}");
                let next = xs.windows(2).map(|p| f64::from(p[0] * p[1])).sum::<f64>() / n as f64;
                assert!(
                    next.abs() < 0.01,
                    "seed {seed}, channel {ch}: neighbours {next}"
                );
                // A normal puts 68.3 % within ±1σ and 95.4 % within ±2σ.
                let within = |k: f32| xs.iter().filter(|x| x.abs() < k).count() as f64 / n as f64;
                assert!((within(1.0) - 0.6827).abs() < 0.005, "{}", within(1.0));
                assert!((within(2.0) - 0.9545).abs() < 0.003, "{}", within(2.0));
            }
            let c01 = ds[0]
                .iter()
                .zip(&ds[1])
                .map(|(x, y)| f64::from(x * y))
                .sum::<f64>()
                / n as f64;
            let c12 = ds[1]
                .iter()
                .zip(&ds[2])
                .map(|(x, y)| f64::from(x * y))
                .sum::<f64>()
                / n as f64;
            assert!(c01.abs() < 0.01 && c12.abs() < 0.01, "{c01} {c12}");
        }
    }

    /// A run of pixels gets the deviates of the same pixels made one at a time.
    #[test]
    fn deviates_depend_on_the_pixel_alone() {
        let key = Key::new(0xDEAD_BEEF_0123_4567);
        let run = |first: u64, n: usize| {
            let mut ds = [vec![0f32; n], vec![0f32; n], vec![0f32; n]];
            let [a, b, c] = &mut ds;
            deviates(key, first, &mut vec![7; 3], [a, b, c]);
            ds
        };
        let whole = run(100, 50);
        for i in 0..50 {
            let one: Vec<f32> = run(100 + i as u64, 1).iter().map(|d| d[0]).collect();
            let same: Vec<f32> = whole.iter().map(|d| d[i]).collect();
            assert_eq!(one, same, "pixel {i}");
        }
        assert_ne!(whole[0], run(101, 50)[0]);
    }
}

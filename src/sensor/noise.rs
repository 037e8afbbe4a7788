//! Per-pixel randomness for sensor noise, the same on every machine and
//! for any number of threads: the deviate of channel `c` of sensor pixel
//! `i` comes from a 32-bit counter-based hash of the counter `3·i + c`
//! under the frame's noise key (two 32-bit words of the frame's noise
//! seed): `lowbias32(counter·k₀ ⊕ k₁)`, k₀ odd (Chris Wellons' integer
//! hash, constants 0x21f0aaad / 0x735a2d97). No state is carried from
//! pixel to pixel, so any split of the rows gives the same deviates; the
//! counter wraps at 2³² (sensors over 1.4 G pixels repeat their noise).
//! The hash's four bytes are summed (Irwin–Hall: 1 021 values, mean
//! 510) and the centred sum is stretched by a fixed cubic to the normal's
//! shape ([`deviate`]): mean 0 and variance 1 exactly over the 2³² hashes,
//! the normal's shares within ±1σ and ±2σ to 0.2 %, tails to ±3.9σ.
//!
//! The deviates of a run of pixels are computed channel by channel in one
//! loop of 32-bit integer and f32 operations that the compiler vectorises
//! ([`deviates`]): no table, so no look-ups; in AVX2 and AVX-512
//! registers where the CPU has them ([`avx2`], [`avx512`]), the same
//! deviates.

mod avx2;
mod avx512;

/// The sensor's last step on its pixels: the full well and Poisson–Gaussian
/// noise ([`add`]), or, without noise, the clipping to [0, 1] alone.
pub(super) struct Sensor {
    /// Shot gain, read noise², noise key (`None`: no noise).
    noise: Option<(f32, f32, Key)>,
}

impl Sensor {
    /// The draw's sensor, with its noise when `noisy` and drawn.
    pub(super) fn of(draw: &super::CameraDraw, noisy: bool) -> Self {
        let on = noisy && (draw.shot_noise_gain > 0.0 || draw.read_noise_levels > 0.0);
        Self {
            noise: on.then_some((
                draw.shot_noise_gain as f32,
                (draw.read_noise_levels * draw.read_noise_levels) as f32,
                Key::new(draw.noise_seed),
            )),
        }
    }

    pub(super) fn is_noisy(&self) -> bool {
        self.noise.is_some()
    }

    /// One row of sensor pixels `first`, `first + 1`, … (indices row-major
    /// over the sensor) of the three channels: noise added with the deviates
    /// made into `scratch` (each as long as the row), or clipped.
    #[inline(always)]
    pub(super) fn row(&self, first: u64, vals: [&mut [f32]; 3], scratch: &mut [Vec<f32>; 3]) {
        if let Some((gain, read2, key)) = self.noise {
            let [d0, d1, d2] = scratch;
            deviates(key, first, [d0, d1, d2]);
            for (vals, devs) in vals.into_iter().zip(scratch.iter()) {
                add(vals, devs, gain, read2);
            }
        } else {
            for v in vals {
                for v in v.iter_mut() {
                    *v = v.clamp(0.0, 1.0);
                }
            }
        }
    }
}

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

/// The standard normal deviates of sensor pixels `first`, `first + 1`, …
/// (as many as `out[0]` is long) for channels 0, 1, 2 into `out[c]`: per
/// channel one loop over the pixels (counters 3·pixel + c, stride 3) of
/// 32-bit integer and f32 operations: in AVX-512 with VNNI where the CPU
/// has them ([`avx512`]), else in AVX2 where it has that ([`avx2`]), else
/// in whatever the compiler makes of [`deviates_from`].
#[inline(always)]
pub fn deviates(key: Key, first: u64, out: [&mut [f32]; 3]) {
    #[cfg(target_arch = "x86_64")]
    if crate::simd::avx512_icl() {
        // SAFETY: the CPU has AVX-512 F, BW and VNNI (checked by `avx512_icl`).
        #[allow(unsafe_code)]
        unsafe {
            return avx512::deviates_avx512(key, first, out);
        }
    }
    #[cfg(target_arch = "x86_64")]
    if crate::simd::avx2() {
        // SAFETY: the CPU has AVX2 (checked by `avx2`).
        #[allow(unsafe_code)]
        unsafe {
            return avx2::deviates_avx2(key, first, out);
        }
    }
    let base = (first as u32).wrapping_mul(3);
    for (c, d) in out.into_iter().enumerate() {
        deviates_from(key, base.wrapping_add(c as u32), d);
    }
}

/// The deviates of counters `counter`, `counter + 3`, … into `out`, one at
/// a time (a channel's run, or the tail a SIMD build leaves).
#[inline(always)]
fn deviates_from(key: Key, mut counter: u32, out: &mut [f32]) {
    for o in out {
        *o = deviate(key.bits(counter));
        counter = counter.wrapping_add(3);
    }
}

/// 1 / the standard deviation of the sum of four uniform bytes, √(4·(256² − 1)/12).
const INV_SD: f64 = 1.0 / 147.800_541_271;
/// The cubic's coefficients on z (the sum centred and scaled to σ 1):
/// z·(A + B·z²), B chosen to bring the distribution closest to the normal
/// (Kolmogorov–Smirnov distance 0.0015), A to keep the variance exactly 1.
const A: f64 = 0.961_094_405;
const B: f64 = 0.014_272_252;
/// A and B on t = sum − 510 directly (t² < 2²⁴ is exact in f32).
const A_T: f32 = (A * INV_SD) as f32;
const B_T: f32 = (B * INV_SD * INV_SD * INV_SD) as f32;

/// The deviate of 32 hashed bits: t = the sum of its four bytes − 510
/// (Irwin–Hall with four uniform bytes: mean 0, 1 021 values), mapped
/// through t·(A_T + B_T·t²), which stretches the tails to the normal's
/// shape: mean 0, variance 1, 68.2 % within ±1, 95.3 % within ±2 (normal:
/// 68.3 %, 95.4 %), kurtosis 2.92, at most ±3.9.
#[inline(always)]
pub fn deviate(bits: u32) -> f32 {
    let pairs = (bits & 0x00FF_00FF) + ((bits >> 8) & 0x00FF_00FF);
    let sum = (pairs & 0xFFFF) + (pairs >> 16);
    let t = sum as f32 - 510.0;
    t * (A_T + B_T * (t * t))
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

#[cfg(test)]
mod tests {
    use super::*;

    /// The deviate's exact distribution (every 32-bit value weighed by how
    /// many of the 2³² hashes give it): mean 0, variance 1, and the
    /// normal's share within ±1 and ±2 to 0.2 %.
    #[test]
    fn deviates_are_normal() {
        let mut ways = vec![1u64; 256];
        for _ in 0..3 {
            let mut next = vec![0u64; ways.len() + 255];
            for (s, &n) in ways.iter().enumerate() {
                for b in 0..256 {
                    next[s + b] += n;
                }
            }
            ways = next;
        }
        let total = 2f64.powi(32);
        let moment = |f: &dyn Fn(f64) -> f64| -> f64 {
            (0..ways.len())
                .map(|s| {
                    let bits = (s.min(255) | (s.saturating_sub(255).min(255) << 8)) as u32
                        | ((s.saturating_sub(510).min(255) as u32) << 16)
                        | ((s.saturating_sub(765) as u32) << 24);
                    ways[s] as f64 * f(f64::from(deviate(bits)))
                })
                .sum::<f64>()
                / total
        };
        assert!(moment(&|x| x).abs() < 1e-7, "{}", moment(&|x| x));
        assert!(
            (moment(&|x| x * x) - 1.0).abs() < 1e-5,
            "{}",
            moment(&|x| x * x)
        );
        let within = |k: f64| moment(&|x| f64::from(u8::from(x.abs() < k)));
        assert!((within(1.0) - 0.6827).abs() < 0.002, "{}", within(1.0));
        assert!((within(2.0) - 0.9545).abs() < 0.002, "{}", within(2.0));
        // Hashed draws over many pixels: mean 0, σ 1, each channel alike,
        // for a few keys; and one pixel's channels uncorrelated, as are
        // neighbouring pixels.
        for seed in [12345u64, 0, u64::MAX, 0x9E37_79B9_7F4A_7C15] {
            let n = 200_000usize;
            let mut ds = [vec![0f32; n], vec![0f32; n], vec![0f32; n]];
            let [a, b, c] = &mut ds;
            deviates(Key::new(seed), 7, [a, b, c]);
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

    /// Every SIMD build of the deviates this CPU runs gives each pixel's
    /// scalar deviate, bit for bit: keys with high bits set, runs that leave
    /// tails, and counters that wrap at 2³².
    #[test]
    fn the_vector_deviates_are_the_scalar_deviates() {
        /// A build's name, whether this CPU runs it, and the build.
        type Build = (&'static str, bool, fn(Key, u64, [&mut [f32]; 3]));
        #[cfg(target_arch = "x86_64")]
        let builds: [Build; 2] = [
            ("AVX2", crate::simd::avx2(), |key, first, out| {
                // SAFETY: called only where `avx2()` holds (the filter below).
                #[allow(unsafe_code)]
                unsafe {
                    avx2::deviates_avx2(key, first, out);
                }
            }),
            ("AVX-512", crate::simd::avx512_icl(), |key, first, out| {
                // SAFETY: called only where `avx512_icl()` holds (the filter below).
                #[allow(unsafe_code)]
                unsafe {
                    avx512::deviates_avx512(key, first, out);
                }
            }),
        ];
        #[cfg(not(target_arch = "x86_64"))]
        let builds: [Build; 0] = [];
        let mut compared = 0;
        for (name, _, build) in builds.into_iter().filter(|b| b.1) {
            for (seed, first, n) in [
                (0x0123_4567_89ab_cdef_u64, 0u64, 1000usize),
                (u64::MAX, 7, 37),
                (0x8000_0001_ffff_fffe, (1u64 << 32) / 3 - 200, 517),
                (42, 1_431_655_700, 64),
                (9, 3, 5),
            ] {
                let key = Key::new(seed);
                let mut simd: [Vec<f32>; 3] = std::array::from_fn(|_| vec![0.0; n]);
                let [a, b, c] = &mut simd;
                build(key, first, [a, b, c]);
                for (ch, row) in simd.iter().enumerate() {
                    for (i, v) in row.iter().enumerate() {
                        let counter = (first as u32)
                            .wrapping_add(i as u32)
                            .wrapping_mul(3)
                            .wrapping_add(ch as u32);
                        let want = deviate(key.bits(counter));
                        assert_eq!(
                            v.to_bits(),
                            want.to_bits(),
                            "{name}: seed {seed:x}, pixel {i}, channel {ch}"
                        );
                    }
                }
            }
            compared += 1;
        }
        eprintln!("{compared} SIMD builds compared with the scalar deviates");
    }

    /// A run of pixels gets the deviates of the same pixels made one at a time.
    #[test]
    fn deviates_depend_on_the_pixel_alone() {
        let key = Key::new(0xDEAD_BEEF_0123_4567);
        let run = |first: u64, n: usize| {
            let mut ds = [vec![0f32; n], vec![0f32; n], vec![0f32; n]];
            let [a, b, c] = &mut ds;
            deviates(key, first, [a, b, c]);
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

//! The exact sRGB encode of the upsampling: linear values to 8-bit levels
//! rounded as the f64 transfer function rounds them (a table of the 255
//! decision thresholds, not a `pow` approximation), folded into one packed
//! bucket read a value ([`Buckets`]; in AVX2 eight values a gather,
//! `upsample/gather.rs`), for clipped linear values and for the
//! exponential tone map of HDR skies; and the exposure of an encoded
//! picture by a table on the same thresholds.

use std::sync::LazyLock;

/// Linear values where the sRGB-encoded 8-bit value steps up.
pub(super) struct SrgbTable {
    /// `thresholds[k]`: the least linear value encoded as `k` (k ≥ 1);
    /// `thresholds[0]` is `-inf`.
    pub(super) thresholds: [f32; 256],
}

/// The sRGB transfer function on linear `x` in [0, 1].
pub(super) fn srgb(x: f64) -> f64 {
    if x <= 0.003_130_8 {
        x * 12.92
    } else {
        1.055 * x.powf(1.0 / 2.4) - 0.055
    }
}

/// The inverse of [`srgb`].
fn linear(s: f64) -> f64 {
    if s <= 0.040_45 {
        s / 12.92
    } else {
        ((s + 0.055) / 1.055).powf(2.4)
    }
}

pub(super) static SRGB: LazyLock<SrgbTable> = LazyLock::new(|| {
    let mut thresholds = [f32::NEG_INFINITY; 256];
    for (k, t) in thresholds.iter_mut().enumerate().skip(1) {
        // The least f32 whose encoding rounds to k: start at the exact
        // crossing and step to the f32 where the rounding turns.
        let mut v = linear((k as f64 - 0.5) / 255.0) as f32;
        let encoded = |v: f32| (srgb(f64::from(v)) * 255.0).round_ties_even();
        while encoded(v) >= k as f64 {
            v = f32::from_bits(v.to_bits() - 1);
        }
        while encoded(v) < k as f64 {
            v = f32::from_bits(v.to_bits() + 1);
        }
        *t = v;
    }
    SrgbTable { thresholds }
});

/// The table that exposes an sRGB 8-bit picture by `gain` on linear light:
/// level k → the level of linear(k/255)·`gain` (clipped at white), rounded
/// as the encode rounds ([`SrgbTable`]'s thresholds).
pub(in crate::render) fn exposure_table(gain: f32) -> [u8; 256] {
    let t = &SRGB.thresholds[1..];
    std::array::from_fn(|k| {
        let y = linear(k as f64 / 255.0) * f64::from(gain);
        t.partition_point(|&v| f64::from(v) <= y) as u8
    })
}

/// `rgba`'s colour bytes (RGBA8, sRGB) exposed by `gain` ([`exposure_table`]),
/// alpha kept; rows of pixels split over rayon's threads.
pub(in crate::render) fn expose(rgba: &mut [u8], gain: f32) {
    use rayon::prelude::*;
    let table = exposure_table(gain);
    rgba.par_chunks_mut(4 * 8192)
        .for_each(|chunk| expose_with(&table, chunk));
}

/// `rgba`'s colour bytes through `table` ([`exposure_table`]), alpha kept.
pub(super) fn expose_with(table: &[u8; 256], rgba: &mut [u8]) {
    for px in rgba.chunks_exact_mut(4) {
        px[0] = table[usize::from(px[0])];
        px[1] = table[usize::from(px[1])];
        px[2] = table[usize::from(px[2])];
    }
}

/// Linear `x` sRGB-encoded and rounded to 8 bits (clamped to [0, 1], NaN → 0),
/// as `linear_to_srgb` in common.wgsl and an `Rgba8Unorm` store would.
#[cfg(test)]
pub(super) fn srgb_u8(x: f32) -> u8 {
    SRGB.encode(x)
}

impl SrgbTable {
    /// The level of linear `x` by a search of the thresholds (the
    /// reference the bucket encode is checked against).
    #[cfg(test)]
    pub(super) fn encode(&self, x: f32) -> u8 {
        let x = if x > 0.0 { x.min(1.0) } else { 0.0 };
        self.thresholds[1..].partition_point(|&t| t <= x) as u8
    }
}

/// Mantissa bits of a bucket: bucket `i` holds the f32 values whose bit
/// patterns share their top bits `(bits >> 16) = i + [`FIRST_BUCKET`]`, i.e.
/// 2⁷ buckets per octave, each 1/128 of its octave's low end or less wide.
pub(super) const BUCKET_SHIFT: u32 = 16;

/// The bucket of 2⁻¹³ (the least bucket's floor, [`FLOOR_MIN`]): its top bits.
pub(super) const FIRST_BUCKET: u32 = FLOOR_MIN.to_bits() >> BUCKET_SHIFT;

/// Buckets in a table: 2⁻¹³ up to 8 (16 octaves of 128), above every `top`.
pub(super) const BUCKETS: usize = 2048;

/// An exact threshold encode folded so that it vectorises: per bucket of
/// values `x` in [0, `top`] (buckets by the top bits of the f32 bit pattern,
/// [`BUCKET_SHIFT`]), the level at its low end and the one threshold that can
/// lie inside it, packed in one word so that a value costs one read of an
/// 8 KiB table (one gather a vector, not two): the level in the top 8 bits,
/// and in the low 24 the threshold's distance in f32 steps above the
/// bucket's floor (below 2¹⁶). The level of `x` is the level at the low end,
/// plus one when `x` lies that many steps or more above the floor: for
/// values ≥ 0 the order of f32 bit patterns is the order of the values, so
/// this is `x ≥ threshold`, and the distance is the low 16 bits of `x`.
/// Thresholds are never closer than a bucket: buckets are at most 1/128 =
/// 0.78 % of their values wide, and the closest thresholds relative to their
/// value, sRGB's top levels, are 2.4 / (k + 14) ≥ 0.89 % apart (checked when
/// built). Values below 2⁻¹³ share bucket 0, which no threshold reaches (the
/// least, sRGB level 1, is 1.5e-4: checked when built), so they encode 0.
pub(super) struct Buckets {
    pub(super) packed: [u32; BUCKETS],
    pub(super) top: f32,
}

/// The low 24 bits of a packed bucket with no threshold inside: more f32
/// steps than any bucket holds (2¹⁶).
pub(super) const NO_STEP: u32 = 0x00ff_ffff;

/// The low bits of a value's pattern: its f32 steps above its bucket's floor.
pub(super) const STEP_MASK: u32 = (1 << BUCKET_SHIFT) - 1;

/// 2⁻¹³: the least bucket floor.
pub(super) const FLOOR_MIN: f32 = 1.0 / 8192.0;

impl Buckets {
    /// The buckets of `thresholds` (`thresholds[k]`: the least value of
    /// level k; `thresholds[0]` unused), over [0, `top`].
    fn new(thresholds: &[f32; 256], top: f32) -> Box<Self> {
        let mut b = Box::new(Self {
            packed: [NO_STEP; BUCKETS],
            top,
        });
        let t = &thresholds[1..];
        assert!(
            t[0] >= FLOOR_MIN.next_up(),
            "a threshold in the least bucket"
        );
        let last = (top.to_bits() >> BUCKET_SHIFT) - FIRST_BUCKET;
        assert!((last as usize) < BUCKETS, "a top above the table");
        for i in 0..=last {
            let floor = (i + FIRST_BUCKET) << BUCKET_SHIFT;
            let (lo, hi) = (
                f32::from_bits(floor),
                f32::from_bits(floor + (1 << BUCKET_SHIFT)),
            );
            let k = t.iter().take_while(|&&v| v <= lo).count();
            assert!(
                t.iter().filter(|&&v| v > lo && v < hi).count() <= 1,
                "two thresholds in one bucket"
            );
            let steps = match t.get(k) {
                Some(&v) if v < hi => v.to_bits() - floor,
                _ => NO_STEP,
            };
            assert!(k < 256, "a bucket that does not pack");
            b.packed[i as usize] = (k as u32) << 24 | steps;
        }
        b
    }

    /// The level of `x`: NaN and values below 0 give 0, values above `top`
    /// the level of `top`.
    #[inline(always)]
    pub(super) fn encode(&self, x: f32) -> u32 {
        // `+ 0.0` turns a −0 into +0 (whose bits are those of bucket 0).
        let bits = (x.max(0.0).min(self.top) + 0.0).to_bits();
        let i = (bits >> BUCKET_SHIFT).saturating_sub(FIRST_BUCKET);
        let packed = self.packed[i as usize & (BUCKETS - 1)];
        (packed >> 24) + u32::from(bits & STEP_MASK >= packed & NO_STEP)
    }
}

/// Linear values in [0, 1] → sRGB 8-bit ([`SrgbTable::encode`] exactly).
pub(super) static CLIP: LazyLock<Box<Buckets>> =
    LazyLock::new(|| Buckets::new(&SRGB.thresholds, 1.0));

/// Radiance x ≥ 0 → the sRGB 8-bit code of 1 − e^(−x): the thresholds
/// −ln(1 − t) of [`SrgbTable`]'s thresholds t, in f64 rounded to f32 (the
/// top one is 4.7, so [0, 7] covers every level).
pub(super) static EXPONENTIAL: LazyLock<Box<Buckets>> = LazyLock::new(|| {
    let mut thresholds = SRGB.thresholds;
    for t in &mut thresholds[1..] {
        *t = (-(1.0 - f64::from(*t)).ln()) as f32;
    }
    Buckets::new(&thresholds, 7.0)
});

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_exposure_table_rounds_the_exposed_light_as_the_encode_does() {
        assert_eq!(exposure_table(1.0), std::array::from_fn(|k| k as u8));
        let half = exposure_table(0.5);
        for (k, &got) in half.iter().enumerate() {
            let want = srgb_u8((linear(k as f64 / 255.0) * 0.5) as f32);
            assert!(got.abs_diff(want) <= 1, "level {k}: {got} against {want}");
        }
        // Half the light of white is sRGB 188 (0.7354 · 255 = 187.5).
        assert_eq!(half[255], 188);
        assert_eq!(exposure_table(4.0)[200], 255, "clipped at white");
        let mut rgba = vec![255, 128, 0, 7, 255, 255, 255, 255];
        expose(&mut rgba, 0.5);
        assert_eq!(rgba, [188, half[128], 0, 7, 188, 188, 188, 255]);
    }

    #[test]
    fn srgb_u8_rounds_the_transfer_function_exactly() {
        // Every f32 step across [0, 1] in a fine sweep agrees with the f64 formula.
        for i in 0..=200_000u32 {
            let x = i as f32 / 200_000.0;
            let want = (srgb(f64::from(x)) * 255.0).round_ties_even() as u8;
            assert_eq!(srgb_u8(x), want, "x = {x}");
        }
        assert_eq!(srgb_u8(-0.5), 0);
        assert_eq!(srgb_u8(f32::NAN), 0);
        assert_eq!(srgb_u8(7.0), 255);
        assert_eq!(srgb_u8(1.0), 255);
        // Each threshold is the least value of its level.
        let t = &SRGB.thresholds;
        for (k, &least) in t.iter().enumerate().skip(1) {
            assert_eq!(usize::from(srgb_u8(least)), k);
            let below = f32::from_bits(least.to_bits() - 1);
            assert_eq!(usize::from(srgb_u8(below)), k - 1);
        }
    }

    #[test]
    fn the_bucket_encode_is_the_threshold_encode() {
        let b = &**CLIP;
        for i in 0..=300_000u32 {
            let x = i as f32 / 300_000.0;
            assert_eq!(b.encode(x), u32::from(SRGB.encode(x)), "x = {x}");
        }
        for &t in &SRGB.thresholds[1..] {
            for x in [
                f32::from_bits(t.to_bits() - 1),
                t,
                f32::from_bits(t.to_bits() + 1),
            ] {
                assert_eq!(b.encode(x), u32::from(SRGB.encode(x)), "x = {x}");
            }
        }
        for x in [
            -0.0,
            -1.0,
            2.0,
            f32::NAN,
            f32::INFINITY,
            f32::NEG_INFINITY,
            1.0,
        ] {
            assert_eq!(b.encode(x), u32::from(SRGB.encode(x)), "x = {x}");
        }
    }

    #[test]
    fn the_exponential_tone_encodes_one_minus_e_to_the_minus_x() {
        let b = &**EXPONENTIAL;
        let level = |x: f64| (srgb(1.0 - (-x).exp()) * 255.0).round_ties_even() as u32;
        let mut off = 0;
        for i in 0..=400_000u32 {
            let x = i as f32 / 40_000.0;
            if b.encode(x) != level(f64::from(x)) {
                // Only where the f32 thresholds round the crossing the other way.
                assert!(b.encode(x).abs_diff(level(f64::from(x))) == 1, "x = {x}");
                off += 1;
            }
        }
        assert!(off < 20, "{off} values a level off");
        // Exactly the count of its thresholds at or below a value, at and
        // one f32 step around each of them.
        let t: Vec<f32> = SRGB.thresholds[1..]
            .iter()
            .map(|&t| (-(1.0 - f64::from(t)).ln()) as f32)
            .collect();
        for &at in &t {
            for x in [at.next_down(), at, at.next_up()] {
                let want = t.partition_point(|&v| v <= x) as u32;
                assert_eq!(b.encode(x), want, "x = {x}");
            }
        }
        assert_eq!(b.encode(0.0), 0);
        assert_eq!(b.encode(f32::NAN), 0);
        assert_eq!(b.encode(1.0e9), 255);
        assert_eq!(b.encode(f32::INFINITY), 255);
        // 1 − e^(−1) = 0.632: sRGB 0.817.
        assert_eq!(b.encode(1.0), level(1.0));
    }
}

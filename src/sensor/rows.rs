//! The per-row kernels both develop paths share: the plane path
//! ([`super::stages`]) and the fused sweep ([`super::fused`], with its SIMD
//! builds in [`super::kernels`]) call these, so each pixel formula is written
//! once and the two paths give the same bytes: the sRGB decode and encode
//! tables (the encode table also folded into L1-sized buckets), the encode of
//! a finished row, the vignetting's radii and factors, the saturation, the row
//! interpolations of the chromatic aberration, and the PSF's weights and disc
//! spans. Imports nothing of the camera chain; the paths import it, one way.

use std::sync::OnceLock;

/// sRGB 8-bit → linear light.
pub(super) fn decode_table() -> &'static [f32; 256] {
    static T: OnceLock<[f32; 256]> = OnceLock::new();
    T.get_or_init(|| {
        std::array::from_fn(|i| {
            let c = i as f64 / 255.0;
            let l = if c <= 0.04045 {
                c / 12.92
            } else {
                ((c + 0.055) / 1.055).powf(2.4)
            };
            l as f32
        })
    })
}

/// Entries of the encoding table: linear [0, 1] in steps of 1/65535.
const ENCODE_STEPS: usize = 65_536;

/// Linear light (index = round(l·65535)) → sRGB 8-bit.
pub(super) fn encode_table() -> &'static [u8] {
    static T: OnceLock<Vec<u8>> = OnceLock::new();
    T.get_or_init(|| {
        (0..ENCODE_STEPS)
            .map(|i| {
                let l = i as f64 / (ENCODE_STEPS - 1) as f64;
                let c = if l <= 0.003_130_8 {
                    12.92 * l
                } else {
                    1.055 * l.powf(1.0 / 2.4) - 0.055
                };
                (c * 255.0).round().clamp(0.0, 255.0) as u8
            })
            .collect()
    })
}

#[inline]
pub(super) fn encode(table: &[u8], l: f32) -> u8 {
    table[encode_index(l) as usize]
}

/// The encode table's entry for linear `l` (in [0, 1], clipped by the
/// sensor; NaN maps to 0).
#[inline(always)]
fn encode_index(l: f32) -> u32 {
    ((l * (ENCODE_STEPS - 1) as f32 + 0.5) as u32).min(ENCODE_STEPS as u32 - 1)
}

/// [`encode_index`] without a saturating float-to-integer cast (which LLVM
/// makes one lane at a time): ⌊l·65 535 + ½⌋ clamped to the table, whose
/// floor plus 2²³ holds the integer in its low mantissa bits; the same
/// indices (unit test). For builds with SIMD rounding (the fused sweep's
/// AVX2 and AVX-512 builds); elsewhere `floor` is a library call.
#[inline(always)]
fn encode_index_simd(l: f32) -> u32 {
    const TWO23: f32 = 8_388_608.0;
    let top = (ENCODE_STEPS - 1) as f32;
    let x = (l * top + 0.5).max(0.0).min(top).floor();
    (x + TWO23).to_bits() - TWO23.to_bits()
}

/// Indices per bucket of [`encode_buckets`].
const BUCKET: usize = 16;

/// The encode table folded into 4 096 buckets of 16 consecutive indices,
/// small enough to stay in the L1 cache: entry = the code at the bucket's
/// first index | (the offset in the bucket where the code steps up by one
/// level; 16: nowhere) << 8. The sRGB curve rises by at most 12.92 · 255 /
/// 65 535 = 0.050 levels per index, so by at most one level in a bucket,
/// and `base + (offset ≥ step)` is exactly the 65 536-entry table's code
/// (checked for every index when built, and by a unit test).
fn encode_buckets() -> &'static [u32; ENCODE_STEPS / BUCKET] {
    static T: OnceLock<Box<[u32; ENCODE_STEPS / BUCKET]>> = OnceLock::new();
    T.get_or_init(|| {
        let table = encode_table();
        let mut out = Box::new([0u32; ENCODE_STEPS / BUCKET]);
        for (b, e) in out.iter_mut().enumerate() {
            let codes = &table[b * BUCKET..(b + 1) * BUCKET];
            let step = codes.iter().position(|&c| c != codes[0]).unwrap_or(BUCKET);
            for (k, &c) in codes.iter().enumerate() {
                assert_eq!(c, codes[0] + u8::from(k >= step), "one step per bucket");
            }
            *e = u32::from(codes[0]) | (step as u32) << 8;
        }
        out
    })
}

/// [`encode`] through [`encode_buckets`]: the same code, no 64 KiB table.
#[cfg(test)]
fn encode_bucketed(buckets: &[u32; ENCODE_STEPS / BUCKET], l: f32) -> u8 {
    bucket_code(buckets, encode_index(l))
}

/// The code of encode-table index `i` from the buckets.
#[inline(always)]
fn bucket_code(buckets: &[u32; ENCODE_STEPS / BUCKET], i: u32) -> u8 {
    // u32 arithmetic throughout: vectorised, 16 lanes to a register.
    let e = buckets[((i / BUCKET as u32) & (ENCODE_STEPS / BUCKET - 1) as u32) as usize];
    (e as u8).wrapping_add(u8::from(i % BUCKET as u32 >= e >> 8))
}

/// One row of RGBA8 from three rows of linear values, alpha copied from
/// `src` (the input's RGBA8 pixels at the same places): each pixel's three
/// codes through [`encode_buckets`] and its alpha written as one word.
/// `simd`: the indices by [`encode_index_simd`] (the same values).
#[inline(always)]
pub(super) fn encode_row(vals: [&[f32]; 3], src: &[u8], line: &mut [u8], simd: bool) {
    let buckets = encode_buckets();
    let code = |l: f32| {
        let i = if simd {
            encode_index_simd(l)
        } else {
            encode_index(l)
        };
        bucket_code(buckets, i)
    };
    let [r, g, b] = vals;
    for ((((px, s), r), g), b) in line
        .chunks_exact_mut(4)
        .zip(src.chunks_exact(4))
        .zip(r)
        .zip(g)
        .zip(b)
    {
        px.copy_from_slice(&[code(*r), code(*g), code(*b), s[3]]);
    }
}

/// Squared distance of the centre of pixel `x` (a column or a row) to the
/// image centre's `c` on that axis, over the squared half-diagonal.
#[inline]
pub(super) fn radius2(x: i64, c: f64, corner2: f64) -> f32 {
    ((x as f64 + 0.5 - c).powi(2) / corner2) as f32
}

/// Vignetting factors 1 − strength·ρ² of one row (ρ² = dx2 + dy2).
#[inline(always)]
pub(super) fn vignette_factors(strength: f32, dy2: f32, dx2: &[f32], out: &mut [f32]) {
    for (f, dx2) in out.iter_mut().zip(dx2) {
        *f = 1.0 - strength * (dx2 + dy2);
    }
}

/// Saturation `s` about each pixel's linear luminance (Rec. 709 weights),
/// on one pixel's three channels: the one formula both develop paths use.
#[inline(always)]
pub(super) fn saturate(s: f32, r: &mut f32, g: &mut f32, b: &mut f32) {
    let y = 0.2126 * *r + 0.7152 * *g + 0.0722 * *b;
    *r = y + s * (*r - y);
    *g = y + s * (*g - y);
    *b = y + s * (*b - y);
}

/// `out` = `r0` + (`r1` − `r0`)·`fy`, element by element (vectorises).
#[inline(always)]
pub(super) fn lerp_rows(r0: &[f32], r1: &[f32], fy: f32, out: &mut [f32]) {
    for ((o, a), b) in out.iter_mut().zip(r0).zip(r1) {
        *o = a + (b - a) * fy;
    }
}

/// `out[i]` = `src[c0]` + (`src[c1]` − `src[c0]`)·`fx` for the taps (c0, c1, fx).
#[inline(always)]
pub(super) fn taps_row(src: &[f32], taps: &[(usize, usize, f32)], out: &mut [f32]) {
    for (o, &(c0, c1, fx)) in out.iter_mut().zip(taps) {
        *o = src[c0] + (src[c1] - src[c0]) * fx;
    }
}

/// Normalised Gaussian weights for offsets −⌈3σ⌉ … ⌈3σ⌉.
pub(super) fn gaussian_weights(sigma_px: f64) -> Vec<f32> {
    let r = (3.0 * sigma_px).ceil() as i64;
    let raw: Vec<f64> = (-r..=r)
        .map(|k| (-(k * k) as f64 / (2.0 * sigma_px * sigma_px)).exp())
        .collect();
    let sum: f64 = raw.iter().sum();
    raw.iter().map(|w| (w / sum) as f32).collect()
}

/// The half-widths of a disc's rows −⌊r⌋ … ⌊r⌋ (−1: an empty row) and
/// 1 / its pixel count.
pub(super) fn disc_spans(radius_px: f64) -> (Vec<i64>, f64) {
    let r = radius_px.floor() as i64;
    let spans: Vec<i64> = (-r..=r)
        .map(|dy| {
            let rest = radius_px * radius_px - (dy * dy) as f64;
            if rest >= 0.0 {
                rest.sqrt().floor() as i64
            } else {
                -1
            }
        })
        .collect();
    let count: i64 = spans.iter().map(|h| 2 * h + 1).sum();
    (spans, 1.0 / count as f64)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_encoding_table_inverts_the_decoding_table() {
        let (d, e) = (decode_table(), encode_table());
        for v in 0..=255u8 {
            assert_eq!(encode(e, d[v as usize]), v);
        }
        let buckets = encode_buckets();
        for i in 0..ENCODE_STEPS {
            assert_eq!(bucket_code(buckets, i as u32), e[i], "index {i}");
            let l = i as f32 / (ENCODE_STEPS - 1) as f32;
            assert_eq!(encode_bucketed(buckets, l), encode(e, l), "{l}");
        }
        for l in [
            -1.0,
            -0.0,
            1.0,
            2.0,
            f32::NAN,
            f32::INFINITY,
            f32::NEG_INFINITY,
        ] {
            assert_eq!(encode_bucketed(buckets, l), encode(e, l), "{l}");
            assert_eq!(encode_index_simd(l), encode_index(l), "{l}");
        }
        // Every f32 in [-1, 2] by a fine step, and the halves between indices.
        for k in -65_536..=131_072 {
            for l in [k as f32 / 65_535.0, (k as f32 + 0.5) / 65_535.0] {
                assert_eq!(encode_index_simd(l), encode_index(l), "{l}");
            }
        }
    }
}

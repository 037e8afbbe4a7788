//! The upsampling's sRGB encode of one output row in AVX2 registers: eight
//! values a channel at a time, each bucket read with one gather (as
//! [`Buckets::encode`] does one value at a time, which LLVM leaves as
//! scalar loads and lane moves). The same operations on the same values:
//! the bytes are those of the scalar encode (checked by the tests of
//! `upsample.rs`).

#[cfg(target_arch = "x86_64")]
use std::arch::x86_64::{
    __m256i, _mm256_add_epi32, _mm256_and_si256, _mm256_castps_si256, _mm256_cmpgt_epi32,
    _mm256_i32gather_epi32, _mm256_loadu_ps, _mm256_max_epi32, _mm256_max_ps, _mm256_min_ps,
    _mm256_or_si256, _mm256_set1_epi32, _mm256_set1_ps, _mm256_setzero_ps, _mm256_setzero_si256,
    _mm256_slli_epi32, _mm256_srli_epi32, _mm256_storeu_si256, _mm256_sub_epi32,
};

use super::srgb::{BUCKET_SHIFT, BUCKETS, Buckets, FIRST_BUCKET, NO_STEP, STEP_MASK};

/// The levels of the eight values at `x` ([`Buckets::encode`] per lane).
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
#[inline]
fn encode8(buckets: &Buckets, x: &[f32; 8]) -> __m256i {
    // SAFETY: `x` holds eight f32; every gathered index is masked to
    // [0, BUCKETS), inside `buckets.packed`.
    #[allow(unsafe_code)]
    unsafe {
        let x = _mm256_loadu_ps(x.as_ptr());
        // max(x, 0) returns 0 for NaN and for −0 (the second operand), as
        // the scalar encode's `max(0.0) + 0.0`.
        let x = _mm256_max_ps(x, _mm256_setzero_ps());
        let bits = _mm256_castps_si256(_mm256_min_ps(x, _mm256_set1_ps(buckets.top)));
        let index = _mm256_max_epi32(
            _mm256_sub_epi32(
                _mm256_srli_epi32::<{ BUCKET_SHIFT as i32 }>(bits),
                _mm256_set1_epi32(FIRST_BUCKET as i32),
            ),
            _mm256_setzero_si256(),
        );
        let index = _mm256_and_si256(index, _mm256_set1_epi32(BUCKETS as i32 - 1));
        let packed = _mm256_i32gather_epi32::<4>(buckets.packed.as_ptr().cast(), index);
        let above = _mm256_and_si256(bits, _mm256_set1_epi32(STEP_MASK as i32));
        let step = _mm256_and_si256(packed, _mm256_set1_epi32(NO_STEP as i32));
        // −1 where the value lies below the bucket's threshold.
        let below = _mm256_cmpgt_epi32(step, above);
        let level = _mm256_add_epi32(_mm256_srli_epi32::<24>(packed), _mm256_set1_epi32(1));
        _mm256_add_epi32(level, below)
    }
}

/// `line` (RGBA8, alpha 255) from the planes `r`, `g`, `b` of linear values
/// through `buckets`: eight pixels at a time, the rest one at a time.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
pub(super) fn encode_line_avx2([r, g, b]: [&[f32]; 3], buckets: &Buckets, line: &mut [u8]) {
    let n = (line.len() / 4).min(r.len()).min(g.len()).min(b.len());
    let whole = n - n % 8;
    // Eight values of each plane as one load (not eight checked scalar reads).
    let (r8, g8, b8) = (
        r[..whole].as_chunks::<8>().0,
        g[..whole].as_chunks::<8>().0,
        b[..whole].as_chunks::<8>().0,
    );
    for (((r, g), b), px) in r8.iter().zip(g8).zip(b8).zip(line.chunks_exact_mut(32)) {
        let (lr, lg, lb) = (
            encode8(buckets, r),
            encode8(buckets, g),
            encode8(buckets, b),
        );
        // SAFETY: `px` is 32 bytes, written unaligned.
        #[allow(unsafe_code)]
        unsafe {
            let word = _mm256_or_si256(
                _mm256_or_si256(lr, _mm256_slli_epi32::<8>(lg)),
                _mm256_or_si256(
                    _mm256_slli_epi32::<16>(lb),
                    _mm256_set1_epi32(0xff00_0000_u32 as i32),
                ),
            );
            _mm256_storeu_si256(px.as_mut_ptr().cast(), word);
        }
    }
    for (k, px) in (whole..n).zip(line[whole * 4..].chunks_exact_mut(4)) {
        let word = buckets.encode(r[k])
            | buckets.encode(g[k]) << 8
            | buckets.encode(b[k]) << 16
            | 0xff00_0000;
        px.copy_from_slice(&word.to_le_bytes());
    }
}

#[cfg(test)]
mod tests {
    use super::super::srgb::{CLIP, EXPONENTIAL, SRGB};
    use super::*;

    #[test]
    fn the_gathered_encode_is_the_scalar_encode() {
        if !crate::simd::avx2() {
            return;
        }
        fn check(b: &Buckets, thresholds: &[f32]) {
            let mut x: Vec<f32> = thresholds
                .iter()
                .flat_map(|&t| [t.next_down(), t, t.next_up()])
                .collect();
            x.extend((0..=80_000).map(|i| i as f32 / 10_000.0));
            let odd = [
                -0.0,
                -1.0,
                f32::NAN,
                f32::INFINITY,
                f32::NEG_INFINITY,
                1e30,
                1e-40,
            ];
            x.extend(odd);
            // A length that leaves a tail for the scalar encode.
            x.push(0.5);
            let mut line = vec![0u8; x.len() * 4];
            // SAFETY: the CPU has AVX2 (checked above).
            #[allow(unsafe_code)]
            unsafe {
                encode_line_avx2([&x, &x, &x], b, &mut line);
            }
            for (v, px) in x.iter().zip(line.chunks_exact(4)) {
                let level = b.encode(*v) as u8;
                assert_eq!(px, [level, level, level, 255], "x = {v}");
            }
        }
        check(&CLIP, &SRGB.thresholds[1..]);
        let exponential: Vec<f32> = SRGB.thresholds[1..]
            .iter()
            .map(|&t| (-(1.0 - f64::from(t)).ln()) as f32)
            .collect();
        check(&EXPONENTIAL, &exponential);
    }
}

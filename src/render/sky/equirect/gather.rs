//! The equirect pass's bilinear samples eight pixels at a time in AVX2
//! registers: each of the four texels of each channel read with one gather
//! (the scalar loop's twelve bounds-checked loads a pixel), then the same
//! blend as [`super::blend`]: the same operations on the same values, so
//! the same values (checked by the tests of `equirect.rs`).

use std::arch::x86_64::{
    __m256, __m256i, _CMP_GT_OQ, _mm256_add_epi32, _mm256_add_ps, _mm256_blendv_epi8,
    _mm256_castps_si256, _mm256_cmp_ps, _mm256_cmpeq_epi32, _mm256_cmpgt_epi32, _mm256_cvtepi32_ps,
    _mm256_cvttps_epi32, _mm256_i32gather_ps, _mm256_loadu_ps, _mm256_max_epi32, _mm256_max_ps,
    _mm256_min_epi32, _mm256_min_ps, _mm256_mul_ps, _mm256_mullo_epi32, _mm256_set1_epi32,
    _mm256_set1_ps, _mm256_setzero_ps, _mm256_storeu_ps, _mm256_sub_ps,
};

use super::{Equirect, MAX_RADIANCE};

/// `f32::floor` in each lane: the truncation, less one where it lies
/// above `x` (`x` finite, |x| < 2³¹: [`super::Row::coordinates`] keeps it so).
#[target_feature(enable = "avx2")]
fn floor8(x: __m256) -> (__m256, __m256i) {
    let t = _mm256_cvttps_epi32(x);
    let tf = _mm256_cvtepi32_ps(t);
    // All ones (−1) where the truncation lies above x.
    let above = _mm256_castps_si256(_mm256_cmp_ps::<_CMP_GT_OQ>(tf, x));
    let i = _mm256_add_epi32(t, above);
    (_mm256_cvtepi32_ps(i), i)
}

/// The eight pixels at texel coordinates `tx`, `ty` (eight each) sampled as
/// [`super::Taps::at`] and [`super::blend`] do, into `px` (red, green and
/// blue: eight values each).
/// `image.rgb` must hold `width × height` RGB texels (`shade` checks it),
/// fewer than 2³¹ values (sky images are at most 4096 texels a side).
#[target_feature(enable = "avx2")]
pub(super) fn sample8(
    image: Equirect<'_>,
    exposure: f32,
    (tx, ty): (&[f32], &[f32]),
    px: [&mut [f32]; 3],
) {
    assert!(tx.len() >= 8 && ty.len() >= 8 && px.iter().all(|p| p.len() >= 8));
    assert!(image.rgb.len() >= image.width as usize * image.height as usize * 3);
    assert!(image.rgb.len() < i32::MAX as usize);
    let (iw, ih) = (image.width as i32, image.height as i32);
    // SAFETY: the loads read eight values of slices checked to hold them.
    #[allow(unsafe_code)]
    let (tx, ty) = unsafe { (_mm256_loadu_ps(tx.as_ptr()), _mm256_loadu_ps(ty.as_ptr())) };
    let (x0, xi) = floor8(tx);
    let (y0, yi) = floor8(ty);
    let (wx, wy) = (_mm256_sub_ps(tx, x0), _mm256_sub_ps(ty, y0));
    let (last_col, last_row) = (_mm256_set1_epi32(iw - 1), _mm256_set1_epi32(ih - 1));
    let (zero, one) = (_mm256_set1_epi32(0), _mm256_set1_epi32(1));
    let c0 = _mm256_min_epi32(_mm256_max_epi32(xi, _mm256_set1_epi32(-1)), last_col);
    let c0 = _mm256_blendv_epi8(c0, last_col, _mm256_cmpgt_epi32(zero, c0));
    let next = _mm256_add_epi32(c0, one);
    let c1 = _mm256_blendv_epi8(next, zero, _mm256_cmpeq_epi32(next, _mm256_set1_epi32(iw)));
    let r0 = _mm256_min_epi32(_mm256_max_epi32(yi, zero), last_row);
    let r1 = _mm256_min_epi32(_mm256_max_epi32(_mm256_add_epi32(yi, one), zero), last_row);
    let width = _mm256_set1_epi32(iw);
    let at = |r: __m256i, c: __m256i| {
        _mm256_mullo_epi32(
            _mm256_add_epi32(_mm256_mullo_epi32(r, width), c),
            _mm256_set1_epi32(3),
        )
    };
    let taps = [at(r0, c0), at(r0, c1), at(r1, c0), at(r1, c1)];
    let (exposure, top) = (_mm256_set1_ps(exposure), _mm256_set1_ps(MAX_RADIANCE));
    for (k, channel) in px.into_iter().enumerate() {
        let base = image.rgb[k..].as_ptr();
        // SAFETY: every offset is (r · width + c) · 3 with r, c clamped
        // into the image, so offset + k lies inside `image.rgb`.
        #[allow(unsafe_code)]
        let [a, b, c, d] = taps.map(|t| unsafe { _mm256_i32gather_ps::<4>(base, t) });
        let upper = _mm256_add_ps(a, _mm256_mul_ps(_mm256_sub_ps(b, a), wx));
        let lower = _mm256_add_ps(c, _mm256_mul_ps(_mm256_sub_ps(d, c), wx));
        let value = _mm256_mul_ps(
            _mm256_add_ps(upper, _mm256_mul_ps(_mm256_sub_ps(lower, upper), wy)),
            exposure,
        );
        // max(value, 0) is 0 for a NaN (the second operand), as `f32::max`.
        let value = _mm256_min_ps(_mm256_max_ps(value, _mm256_setzero_ps()), top);
        // SAFETY: `channel` holds eight values (asserted above).
        #[allow(unsafe_code)]
        unsafe {
            _mm256_storeu_ps(channel.as_mut_ptr(), value)
        };
    }
}

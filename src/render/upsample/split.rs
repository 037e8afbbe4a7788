//! A reduced pass's half-float row (RGBA16F, little endian) converted and
//! split into colour planes in one pass, four texels at a time in AVX2
//! registers (the last few of a row one at a time): F16C's conversion is exact, as the scalar one, so the planes
//! hold the values [`super::Texels::row_into`] gives (checked by the tests
//! of `upsample.rs`).

use std::arch::x86_64::{
    __m128i, _mm_loadu_si128, _mm_storeu_ps, _mm_unpackhi_ps, _mm_unpacklo_ps,
    _mm256_castps256_ps128, _mm256_cvtph_ps, _mm256_extractf128_ps, _mm256_unpackhi_ps,
    _mm256_unpacklo_ps,
};

/// The first three channels of the texels of `src` (8 bytes each) into
/// `r`, `g` and `b`, as many as all four hold: whole groups of four in
/// registers, the last few one at a time.
#[target_feature(enable = "avx2,f16c")]
pub(super) fn split_f16c(src: &[u8], [r, g, b]: [&mut [f32]; 3]) {
    let n = (src.len() / 8).min(r.len()).min(g.len()).min(b.len());
    let whole = n - n % 4;
    for x in (0..whole).step_by(4) {
        // SAFETY: texels x … x + 3 lie in `src` (32 bytes from x · 8) and
        // planes x … x + 3 in each plane (`n`); unaligned loads and stores.
        #[allow(unsafe_code)]
        unsafe {
            let at = src.as_ptr().add(x * 8).cast::<__m128i>();
            // [r0 g0 b0 a0 | r1 g1 b1 a1] and [r2 g2 b2 a2 | r3 g3 b3 a3].
            let (lo, hi) = (
                _mm256_cvtph_ps(_mm_loadu_si128(at)),
                _mm256_cvtph_ps(_mm_loadu_si128(at.add(1))),
            );
            // [r0 r2 g0 g2 | r1 r3 g1 g3] and [b0 b2 a0 a2 | b1 b3 a1 a3].
            let (rg, ba) = (_mm256_unpacklo_ps(lo, hi), _mm256_unpackhi_ps(lo, hi));
            let (rg0, rg1) = (_mm256_castps256_ps128(rg), _mm256_extractf128_ps::<1>(rg));
            let (ba0, ba1) = (_mm256_castps256_ps128(ba), _mm256_extractf128_ps::<1>(ba));
            _mm_storeu_ps(r.as_mut_ptr().add(x), _mm_unpacklo_ps(rg0, rg1));
            _mm_storeu_ps(g.as_mut_ptr().add(x), _mm_unpackhi_ps(rg0, rg1));
            _mm_storeu_ps(b.as_mut_ptr().add(x), _mm_unpacklo_ps(ba0, ba1));
        }
    }
    let half = |at: usize| half::f16::from_le_bytes([src[at], src[at + 1]]).to_f32();
    for x in whole..n {
        (r[x], g[x], b[x]) = (half(x * 8), half(x * 8 + 2), half(x * 8 + 4));
    }
}

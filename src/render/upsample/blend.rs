//! The upsampling's horizontal blend of an exact 2× or 4× layout in AVX2
//! registers: eight output values at a time, each lane the scalar blend's
//! `p + (q − p) · w` of its own texels and weight, in that order (a
//! multiply then an add, as the scalar code compiles without FMA): the
//! bytes are those of [`super::blend_chunks`] (checked by the tests of
//! `upsample.rs`).

use std::arch::x86_64::{
    _mm256_add_ps, _mm256_loadu_ps, _mm256_mul_ps, _mm256_permutevar8x32_ps, _mm256_set_epi32,
    _mm256_storeu_ps, _mm256_sub_ps,
};

/// Chunks of `K` output values (`chunks`, chunk c between texels c and
/// c + 1 of `plane`, with the weights `weight` of its values) blended
/// eight values at a time from the first, as far as whole groups of eight
/// values and loads within `plane` reach; how many chunks it blended.
#[target_feature(enable = "avx2")]
#[inline]
pub(super) fn chunks_avx2<const K: usize>(
    plane: &[f32],
    chunks: &mut [f32],
    weight: &[f32],
) -> usize {
    // Chunks a group of eight values spans.
    let per = 8 / K;
    let n = (chunks.len() / K).min(weight.len() / K);
    // A group from chunk c reads texels c … c + 8 (two loads of eight).
    let reach = if plane.len() >= 9 {
        (plane.len() - 9) / per + 1
    } else {
        0
    };
    let groups = (n / per).min(reach);
    // Lane l takes its group's chunk l / K.
    let l = |i: i32| i / K as i32;
    let index = _mm256_set_epi32(l(7), l(6), l(5), l(4), l(3), l(2), l(1), l(0));
    for g in 0..groups {
        let (c, at) = (g * per, g * 8);
        // SAFETY: c + 9 ≤ plane.len() (`reach`), at + 8 ≤ chunks.len() and
        // weight.len() (`n`); unaligned loads and stores.
        #[allow(unsafe_code)]
        unsafe {
            let p = _mm256_permutevar8x32_ps(_mm256_loadu_ps(plane.as_ptr().add(c)), index);
            let q = _mm256_permutevar8x32_ps(_mm256_loadu_ps(plane.as_ptr().add(c + 1)), index);
            let w = _mm256_loadu_ps(weight.as_ptr().add(at));
            let v = _mm256_add_ps(p, _mm256_mul_ps(_mm256_sub_ps(q, p), w));
            _mm256_storeu_ps(chunks.as_mut_ptr().add(at), v);
        }
    }
    groups * per
}

//! The deviates of a run of pixels ([`super::deviates`]) in AVX2 registers,
//! eight a channel at a time, as [`super::avx512`] makes them sixteen at a
//! time: the hash's input stepped by one addition a register (the
//! counters' products advance by 24·k₀, wrapping as the scalar products
//! do), and its four bytes summed by two multiply-adds with ones (bytes to
//! pairs, pairs to the word), where the compiler's loop multiplies each
//! counter and sums the bytes in seven operations. The same integer and
//! f32 operations otherwise, so the same deviates (unit test).

#[cfg(target_arch = "x86_64")]
use std::arch::x86_64::{
    __m256, __m256i, _mm256_add_epi32, _mm256_add_ps, _mm256_cvtepi32_ps, _mm256_madd_epi16,
    _mm256_maddubs_epi16, _mm256_mul_ps, _mm256_mullo_epi32, _mm256_set1_epi8, _mm256_set1_epi16,
    _mm256_set1_epi32, _mm256_set1_ps, _mm256_setr_epi32, _mm256_srli_epi32, _mm256_storeu_ps,
    _mm256_sub_ps, _mm256_xor_si256,
};

use super::{A_T, B_T, Key, deviates_from};

/// Deviates a register makes.
const LANES: usize = 8;

/// [`super::deviates`] for AVX2.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
#[inline(never)]
pub(super) fn deviates_avx2(key: Key, first: u64, out: [&mut [f32]; 3]) {
    let base = (first as u32).wrapping_mul(3);
    let steps = _mm256_setr_epi32(0, 3, 6, 9, 12, 15, 18, 21);
    let (k0, k1) = (
        _mm256_set1_epi32(key.k0 as i32),
        _mm256_set1_epi32(key.k1 as i32),
    );
    let stride = _mm256_set1_epi32(key.k0.wrapping_mul(3 * LANES as u32) as i32);
    for (c, d) in out.into_iter().enumerate() {
        let counter = base.wrapping_add(c as u32);
        let whole = d.len() - d.len() % LANES;
        let (blocks, tail) = d.split_at_mut(whole);
        // counter·k₀ in each lane, advanced by eight counters' worth.
        let mut product = _mm256_mullo_epi32(
            _mm256_add_epi32(_mm256_set1_epi32(counter as i32), steps),
            k0,
        );
        for block in blocks.as_chunks_mut::<LANES>().0 {
            let bits = hash(_mm256_xor_si256(product, k1));
            // SAFETY: `block` holds eight f32, written unaligned.
            #[allow(unsafe_code)]
            unsafe {
                _mm256_storeu_ps(block.as_mut_ptr(), stretch(bits));
            }
            product = _mm256_add_epi32(product, stride);
        }
        deviates_from(key, counter.wrapping_add(3 * whole as u32), tail);
    }
}

/// [`Key::bits`] after its input's multiply and mask, in each lane.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
#[inline]
fn hash(x: __m256i) -> __m256i {
    let x = _mm256_xor_si256(x, _mm256_srli_epi32::<16>(x));
    let x = _mm256_mullo_epi32(x, _mm256_set1_epi32(0x21f0_aaad));
    let x = _mm256_xor_si256(x, _mm256_srli_epi32::<15>(x));
    let x = _mm256_mullo_epi32(x, _mm256_set1_epi32(0x735a_2d97));
    _mm256_xor_si256(x, _mm256_srli_epi32::<15>(x))
}

/// [`super::deviate`] in each lane: the bytes' sum by two multiply-adds
/// with ones (unsigned bytes into 16-bit pairs of at most 510, pairs into
/// the 32-bit word), then the same f32 operations in the same order (no
/// fused multiply-add).
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
#[inline]
fn stretch(bits: __m256i) -> __m256 {
    let pairs = _mm256_maddubs_epi16(bits, _mm256_set1_epi8(1));
    let sum = _mm256_madd_epi16(pairs, _mm256_set1_epi16(1));
    let t = _mm256_sub_ps(_mm256_cvtepi32_ps(sum), _mm256_set1_ps(510.0));
    let tt = _mm256_mul_ps(t, t);
    _mm256_mul_ps(
        t,
        _mm256_add_ps(_mm256_set1_ps(A_T), _mm256_mul_ps(_mm256_set1_ps(B_T), tt)),
    )
}

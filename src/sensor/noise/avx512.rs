//! The deviates of a run of pixels ([`super::deviates`]) in AVX-512
//! registers, sixteen a channel at a time: the hash's input stepped by one
//! addition a register (the counters' products advance by 48·k₀, wrapping
//! as the scalar products do) and its four bytes summed by one VNNI dot
//! product with ones, where the compiler's loop multiplies each counter and
//! sums the bytes in seven operations. The same integer and f32
//! operations otherwise, so the same deviates (unit test).

#[cfg(target_arch = "x86_64")]
use std::arch::x86_64::{
    __m512i, _mm512_add_epi32, _mm512_add_ps, _mm512_cvtepi32_ps, _mm512_dpbusd_epi32,
    _mm512_mul_ps, _mm512_mullo_epi32, _mm512_set1_epi32, _mm512_set1_ps, _mm512_setr_epi32,
    _mm512_setzero_si512, _mm512_srli_epi32, _mm512_storeu_ps, _mm512_sub_ps, _mm512_xor_si512,
};

use super::{A_T, B_T, Key, deviates_from};

/// [`super::deviates`] for AVX-512 with VNNI.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx512f,avx512bw,avx512vnni")]
#[inline(never)]
pub(super) fn deviates_avx512(key: Key, first: u64, out: [&mut [f32]; 3]) {
    let base = (first as u32).wrapping_mul(3);
    for (c, d) in out.into_iter().enumerate() {
        let counter = base.wrapping_add(c as u32);
        let whole = d.len() - d.len() % 16;
        // SAFETY: each store writes sixteen f32 inside `d`, unaligned.
        #[allow(unsafe_code)]
        unsafe {
            let steps =
                _mm512_setr_epi32(0, 3, 6, 9, 12, 15, 18, 21, 24, 27, 30, 33, 36, 39, 42, 45);
            let k0 = _mm512_set1_epi32(key.k0 as i32);
            // counter·k₀ in each lane, advanced by 16 counters' worth.
            let mut product = _mm512_mullo_epi32(
                _mm512_add_epi32(_mm512_set1_epi32(counter as i32), steps),
                k0,
            );
            let stride = _mm512_set1_epi32(key.k0.wrapping_mul(48) as i32);
            for block in d[..whole].chunks_exact_mut(16) {
                let bits = hash(_mm512_xor_si512(product, _mm512_set1_epi32(key.k1 as i32)));
                _mm512_storeu_ps(block.as_mut_ptr(), stretch(bits));
                product = _mm512_add_epi32(product, stride);
            }
        }
        deviates_from(key, counter.wrapping_add(3 * whole as u32), &mut d[whole..]);
    }
}

/// [`Key::bits`] after its input's multiply and mask, in each lane.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx512f")]
#[inline]
fn hash(x: __m512i) -> __m512i {
    let x = _mm512_xor_si512(x, _mm512_srli_epi32::<16>(x));
    let x = _mm512_mullo_epi32(x, _mm512_set1_epi32(0x21f0_aaad));
    let x = _mm512_xor_si512(x, _mm512_srli_epi32::<15>(x));
    let x = _mm512_mullo_epi32(x, _mm512_set1_epi32(0x735a_2d97));
    _mm512_xor_si512(x, _mm512_srli_epi32::<15>(x))
}

/// [`deviate`] in each lane: the bytes' sum by one dot product with ones,
/// then the same f32 operations in the same order (no fused multiply-add).
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx512f,avx512vnni")]
#[inline]
fn stretch(bits: __m512i) -> std::arch::x86_64::__m512 {
    let sum = _mm512_dpbusd_epi32(_mm512_setzero_si512(), bits, _mm512_set1_epi32(0x0101_0101));
    let t = _mm512_sub_ps(_mm512_cvtepi32_ps(sum), _mm512_set1_ps(510.0));
    let tt = _mm512_mul_ps(t, t);
    _mm512_mul_ps(
        t,
        _mm512_add_ps(_mm512_set1_ps(A_T), _mm512_mul_ps(_mm512_set1_ps(B_T), tt)),
    )
}

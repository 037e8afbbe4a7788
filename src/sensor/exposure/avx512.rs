//! The decode of an image row's channel ([`super::decode_row`]) in AVX-512
//! registers with VBMI's byte permutes, 64 pixels at a time and no look-up
//! one lane at a time: the channel's bytes picked out of the pixels, the
//! decode table read as four planes of its values' bytes (each 256 bytes,
//! four registers, two permutes of 128 entries), and the planes' bytes
//! interleaved into the values. The same values as the table's look-ups
//! (unit test).

#[cfg(target_arch = "x86_64")]
use std::arch::x86_64::{
    __m512i, _mm512_loadu_si512, _mm512_mask_blend_epi8, _mm512_movepi8_mask,
    _mm512_permutex2var_epi8, _mm512_storeu_si512, _mm512_unpackhi_epi8, _mm512_unpackhi_epi16,
    _mm512_unpacklo_epi8, _mm512_unpacklo_epi16,
};

/// A decode table as the planes of its values' little-endian bytes:
/// `planes[b][v]` is byte `b` of entry `v`.
pub(super) struct Planes([[u8; 256]; 4]);

impl Planes {
    pub(super) fn of(lut: &[f32; 256]) -> Self {
        Self(std::array::from_fn(|b| {
            std::array::from_fn(|v| lut[v].to_le_bytes()[b])
        }))
    }
}

/// The pixel of a block of 64 whose channel byte lands at byte `p` of the
/// picked register: the unpacks interleave within 128-bit lanes, so that
/// byte `q` of lane `L` ends up in value register `q / 4`, lane `4L + q % 4`,
/// which must hold pixel `16·(q / 4) + 4L + q % 4`.
const fn pixel_at(p: usize) -> usize {
    let (lane, q) = (p / 16, p % 16);
    16 * (q / 4) + 4 * lane + q % 4
}

/// The byte permute that picks channel `c` of pixels [`pixel_at`] out of
/// two registers of 32 pixels (`4·(pixel mod 32) + c`), and the mask of the
/// bytes taken from the second pair (pixels 32 to 63).
const fn picker(c: usize) -> ([u8; 64], u64) {
    let (mut index, mut mask) = ([0u8; 64], 0u64);
    let mut p = 0;
    while p < 64 {
        let px = pixel_at(p);
        if px >= 32 {
            mask |= 1 << p;
        }
        index[p] = (4 * (px % 32) + c) as u8;
        p += 1;
    }
    (index, mask)
}

/// [`picker`] of each channel, made at compile time.
const PICKERS: [([u8; 64], u64); 4] = [picker(0), picker(1), picker(2), picker(3)];

/// Channel `c` of the RGBA8 pixels `px` through `lut` (whose planes are
/// `planes`) into `out`, one value a pixel (`px` at least `4·out.len()`
/// bytes): whole blocks of 64 in registers, the rest one at a time.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx512f,avx512bw,avx512vbmi")]
#[inline(never)]
pub(super) fn decode_avx512(
    (lut, planes): (&[f32; 256], &Planes),
    px: &[u8],
    c: usize,
    out: &mut [f32],
) {
    let n = out.len().min(px.len() / 4);
    let whole = n - n % 64;
    let (index, second) = PICKERS[c];
    // SAFETY: every load and store is 64 bytes inside its slice (a block's
    // 256 source bytes, a plane's 256 bytes, a block's 64 values), unaligned.
    #[allow(unsafe_code)]
    unsafe {
        let load = |s: &[u8]| _mm512_loadu_si512(s.as_ptr().cast());
        let index = load(&index);
        let table: [[__m512i; 4]; 4] = planes
            .0
            .map(|plane| std::array::from_fn(|k| load(&plane[64 * k..])));
        for (block, values) in px[..whole * 4]
            .chunks_exact(256)
            .zip(out[..whole].chunks_exact_mut(64))
        {
            let z: [__m512i; 4] = std::array::from_fn(|k| load(&block[64 * k..]));
            let v = _mm512_mask_blend_epi8(
                second,
                _mm512_permutex2var_epi8(z[0], index, z[1]),
                _mm512_permutex2var_epi8(z[2], index, z[3]),
            );
            let high = _mm512_movepi8_mask(v);
            let [b0, b1, b2, b3] = table.map(|t| {
                _mm512_mask_blend_epi8(
                    high,
                    _mm512_permutex2var_epi8(t[0], v, t[1]),
                    _mm512_permutex2var_epi8(t[2], v, t[3]),
                )
            });
            let (lo01, hi01) = (_mm512_unpacklo_epi8(b0, b1), _mm512_unpackhi_epi8(b0, b1));
            let (lo23, hi23) = (_mm512_unpacklo_epi8(b2, b3), _mm512_unpackhi_epi8(b2, b3));
            let words = [
                _mm512_unpacklo_epi16(lo01, lo23),
                _mm512_unpackhi_epi16(lo01, lo23),
                _mm512_unpacklo_epi16(hi01, hi23),
                _mm512_unpackhi_epi16(hi01, hi23),
            ];
            for (k, w) in words.into_iter().enumerate() {
                _mm512_storeu_si512(values[16 * k..].as_mut_ptr().cast(), w);
            }
        }
    }
    for (o, p) in out[whole..n]
        .iter_mut()
        .zip(px[whole * 4..].chunks_exact(4))
    {
        *o = lut[usize::from(p[c])];
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_permuted_decode_is_the_table_look_up() {
        #[cfg(target_arch = "x86_64")]
        if crate::simd::avx512_icl() {
            // Every level in every channel and position, odd table values,
            // and a length that leaves a tail.
            // Finite values whose four bytes all vary with the level.
            let lut: [f32; 256] =
                std::array::from_fn(|v| f32::from_bits(0x2000_0000 + (v as u32) * 0x0030_5a5b));
            let planes = Planes::of(&lut);
            let n = 64 * 9 + 37;
            let px: Vec<u8> = (0..n * 4).map(|i| ((i * 73 + i / 7) % 256) as u8).collect();
            for c in 0..4 {
                let mut out = vec![0.0f32; n];
                // SAFETY: the CPU has AVX-512 F, BW and VBMI (checked above).
                #[allow(unsafe_code)]
                unsafe {
                    decode_avx512((&lut, &planes), &px, c, &mut out);
                }
                for (k, o) in out.iter().enumerate() {
                    let want = lut[usize::from(px[4 * k + c])];
                    assert_eq!(o.to_bits(), want.to_bits(), "pixel {k}, channel {c}");
                }
            }
        }
    }
}

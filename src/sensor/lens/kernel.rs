//! The lens's bilinear resampling kernel (issue 41): a written pixel's
//! [`Tap`] (its source's top-left pixel and weights in 1/1024, from the
//! source position by `taps.rs`) and a row of pixels mixed from their
//! taps ([`remap_row`]) in integers: the scalar kernel, and on AVX2 eight
//! pixels at a time with the scalar kernel's bytes (tested).

/// One output pixel's bilinear taps, packed in a `u64`: the top-left
/// source pixel's index (bits 0–31) and the weights of the right column
/// (bits 32–47) and lower row (bits 48–63), in 1/1024.
#[derive(Clone, Copy, Debug, PartialEq)]
#[repr(transparent)]
pub(super) struct Tap(pub(super) u64);

impl Tap {
    #[inline(always)]
    pub(super) fn new(index: u32, wx: u32, wy: u32) -> Self {
        Self(u64::from(index) | u64::from(wx) << 32 | u64::from(wy) << 48)
    }
    #[inline(always)]
    pub(super) fn index(self) -> u32 {
        self.0 as u32
    }
    #[inline(always)]
    pub(super) fn wx(self) -> u32 {
        (self.0 >> 32) as u32 & 0xffff
    }
    #[inline(always)]
    pub(super) fn wy(self) -> u32 {
        (self.0 >> 48) as u32
    }
}

/// The weights' scale: 1024 = the whole pixel.
pub(super) const ONE: u32 = 1024;

/// One row of output pixels from their taps (fixed point, rounded): the
/// AVX2 kernel where the CPU has it, else the scalar one (the same bytes).
#[inline]
pub(super) fn remap_row(src: &[u8], w: usize, taps: &[Tap], row: &mut [u8]) {
    #[cfg(target_arch = "x86_64")]
    if super::super::simd::simd_level() >= 1 {
        // SAFETY: the CPU has AVX2 (checked by `simd_level`).
        #[allow(unsafe_code)]
        unsafe {
            return remap_row_avx2(src, w, taps, row);
        }
    }
    remap_row_scalar(src, w, taps, row);
}

/// A pixel's two source rows' 2×2 pixels (8 bytes each), `None` past the end.
#[inline(always)]
fn quad(src: &[u8], w: usize, t: Tap) -> Option<([u8; 8], [u8; 8])> {
    let o = t.index() as usize * 4;
    let a = <[u8; 8]>::try_from(src.get(o..o + 8)?).ok()?;
    let b = <[u8; 8]>::try_from(src.get(o + w * 4..o + w * 4 + 8)?).ok()?;
    Some((a, b))
}

/// [`remap_row`] in scalar integers: per channel, the two rows mixed along
/// x, then those along y, rounded (the reference the AVX2 kernel matches).
fn remap_row_scalar(src: &[u8], w: usize, taps: &[Tap], row: &mut [u8]) {
    for (px, &t) in row.chunks_exact_mut(4).zip(taps) {
        let Some((a, b)) = quad(src, w, t) else {
            px.fill(0);
            continue;
        };
        let (wx, wy) = (t.wx(), t.wy());
        for (c, out) in px.iter_mut().enumerate() {
            let top = u32::from(a[c]) * (ONE - wx) + u32::from(a[c + 4]) * wx;
            let bottom = u32::from(b[c]) * (ONE - wx) + u32::from(b[c + 4]) * wx;
            *out = ((top * (ONE - wy) + bottom * wy + ONE * ONE / 2) / (ONE * ONE)) as u8;
        }
    }
}

/// How many pixels ahead [`remap_row_avx2`] prefetches its sources.
#[cfg(target_arch = "x86_64")]
const AHEAD: usize = 128;

/// [`remap_row_scalar`]'s integers on AVX2, eight pixels at a time (the
/// scalar kernel for a block with a quad past the end of `src`, and for
/// the row's last pixels): each pixel's two 8-byte rows loaded whole, the
/// block mixed by [`mix8`]; the sources [`AHEAD`] pixels on prefetched.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
fn remap_row_avx2(src: &[u8], w: usize, taps: &[Tap], row: &mut [u8]) {
    use std::arch::x86_64::*;
    let n = taps.len().min(row.len() / 4);
    // A quad lies inside `src` where its index is at most this.
    let last = (src.len() / 4).checked_sub(w + 2);
    let blocks = taps[..n].chunks_exact(8).zip(row.chunks_exact_mut(32));
    for (k, (block, out)) in blocks.enumerate() {
        // The source's lines for the taps AHEAD pixels on, fetched early:
        // a row's sources cross the picture's rows (lens_bench's cached
        // resample: 7.0 → 4.0–5.0 ms CPU a 1080p frame).
        if let Some(ahead) = taps.get(k * 8 + AHEAD) {
            let at = ahead.index() as usize * 4;
            _mm_prefetch::<_MM_HINT_T0>(src.as_ptr().wrapping_add(at) as *const i8);
            _mm_prefetch::<_MM_HINT_T0>(src.as_ptr().wrapping_add(at + w * 4) as *const i8);
        }
        let Some(t) = <&[Tap; 8]>::try_from(block)
            .ok()
            .filter(|t| last.is_some_and(|l| t.iter().all(|t| t.index() as usize <= l)))
        else {
            remap_row_scalar(src, w, &taps[k * 8..k * 8 + 8], out);
            continue;
        };
        let p = src.as_ptr();
        // SAFETY: each read's 8 bytes start at a quad's index (or the pixel
        // under it) times 4, at most (last + w)·4 + 8 = src.len() / 4 · 4.
        #[allow(unsafe_code)]
        let ld = |k: usize, r: usize| unsafe {
            (p.add((t[k].index() as usize + r) * 4) as *const i64).read_unaligned()
        };
        // Per 128-bit lane two pixels' 8 bytes (the left and right pixel).
        let lanes = |a, b, c, d, r| _mm256_set_epi64x(ld(d, r), ld(c, r), ld(b, r), ld(a, r));
        let rows = [
            lanes(0, 1, 4, 5, 0),
            lanes(2, 3, 6, 7, 0),
            lanes(0, 1, 4, 5, w),
            lanes(2, 3, 6, 7, w),
        ];
        // SAFETY: `t` is 8 `Tap`s, 64 bytes (`Tap` is a transparent `u64`).
        #[allow(unsafe_code)]
        let wts = unsafe {
            let v = t.as_ptr() as *const __m256i;
            let (lo, hi) = (_mm256_loadu_si256(v), _mm256_loadu_si256(v.add(1)));
            // Each tap's upper half: [w0 w1 w4 w5 | w2 w3 w6 w7].
            _mm256_castps_si256(_mm256_shuffle_ps::<0b11_01_11_01>(
                _mm256_castsi256_ps(lo),
                _mm256_castsi256_ps(hi),
            ))
        };
        let bytes = mix8(rows, wts);
        // SAFETY: `out` is 32 bytes.
        #[allow(unsafe_code)]
        unsafe {
            _mm256_storeu_si256(out.as_mut_ptr() as *mut __m256i, bytes)
        };
    }
    let done = n / 8 * 8;
    remap_row_scalar(src, w, &taps[done..n], &mut row[done * 4..]);
}

/// Eight pixels' bytes (RGBA8, in order) from their quads' `rows` (top
/// pixels 0 1 | 4 5, 2 3 | 6 7, then the bottom's; 8 bytes each, left pixel
/// then right) and weights `wts` (each tap's upper half, pixels 0 1 4 5 |
/// 2 3 6 7): per channel the left and right bytes paired as words, one
/// multiply-add gives a row's x mix T (exact: ≤ 255·1024), then
/// T·1024 + (B − T)·wy is the y mix (exact in i32), rounded and packed.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
#[inline]
fn mix8(
    rows: [std::arch::x86_64::__m256i; 4],
    wts: std::arch::x86_64::__m256i,
) -> std::arch::x86_64::__m256i {
    use std::arch::x86_64::*;
    const Z: i8 = -128;
    // Per lane: the first pixel's r, g, b, a as (left, right) word pairs, or the second's.
    let first = _mm256_setr_epi8(
        0, Z, 4, Z, 8, Z, 12, Z, 1, Z, 5, Z, 9, Z, 13, Z, 0, Z, 4, Z, 8, Z, 12, Z, 1, Z, 5, Z, 9,
        Z, 13, Z,
    );
    let second = _mm256_setr_epi8(
        2, Z, 6, Z, 10, Z, 14, Z, 3, Z, 7, Z, 11, Z, 15, Z, 2, Z, 6, Z, 10, Z, 14, Z, 3, Z, 7, Z,
        11, Z, 15, Z,
    );
    // [0r 1r 0g 1g 0b 1b 0a 1a 2r 3r …] per lane → [0r 0g 0b 0a 1r …].
    let order = _mm256_setr_epi8(
        0, 2, 4, 6, 1, 3, 5, 7, 8, 10, 12, 14, 9, 11, 13, 15, 0, 2, 4, 6, 1, 3, 5, 7, 8, 10, 12,
        14, 9, 11, 13, 15,
    );
    let one = _mm256_set1_epi32(ONE as i32);
    let wx = _mm256_and_si256(wts, _mm256_set1_epi32(0xffff));
    let wy = _mm256_srli_epi32::<16>(wts);
    // (ONE − wx, wx) as the word pair the left and right bytes meet.
    let wxp = _mm256_or_si256(_mm256_sub_epi32(one, wx), _mm256_slli_epi32::<16>(wx));
    let (at01, at23) = (
        _mm256_setr_epi32(0, 1, 0, 1, 2, 3, 2, 3),
        _mm256_setr_epi32(4, 5, 4, 5, 6, 7, 6, 7),
    );
    let half = _mm256_set1_epi32((ONE * ONE / 2) as i32);
    let mix = |t, b, s, at| {
        let xw = _mm256_permutevar8x32_epi32(wxp, at);
        let top = _mm256_madd_epi16(_mm256_shuffle_epi8(t, s), xw);
        let bottom = _mm256_madd_epi16(_mm256_shuffle_epi8(b, s), xw);
        let y_mix = _mm256_mullo_epi32(
            _mm256_sub_epi32(bottom, top),
            _mm256_permutevar8x32_epi32(wy, at),
        );
        let v = _mm256_add_epi32(_mm256_slli_epi32::<10>(top), y_mix);
        _mm256_srli_epi32::<20>(_mm256_add_epi32(v, half))
    };
    let [t01, t23, b01, b23] = rows;
    let p = _mm256_packus_epi32(mix(t01, b01, first, at01), mix(t01, b01, second, at01));
    let q = _mm256_packus_epi32(mix(t23, b23, first, at23), mix(t23, b23, second, at23));
    _mm256_shuffle_epi8(_mm256_packus_epi16(p, q), order)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The AVX2 kernel and the scalar one give the same bytes for every
    /// weight (0 and 1024 included) on a noisy picture.
    #[test]
    fn the_avx2_resampler_gives_the_scalar_bytes() {
        let (w, n) = (64usize, 4099usize);
        let src: Vec<u8> = (0..w * 40 * 4).map(|i| (i * 7919 % 251) as u8).collect();
        // Every 500th quad past the picture's end (its pixel 0 in both).
        let taps: Vec<Tap> = (0..n as u32)
            .map(|i| {
                let at = if i % 500 == 7 {
                    39 * w as u32
                } else {
                    i * 37 % (39 * w as u32 - 1)
                };
                Tap::new(at, i * 97 % 1025, i * 61 % 1025)
            })
            .collect();
        let mut scalar = vec![0u8; n * 4];
        remap_row_scalar(&src, w, &taps, &mut scalar);
        let mut fast = vec![0u8; n * 4];
        remap_row(&src, w, &taps, &mut fast);
        assert_eq!(scalar, fast);
        assert_eq!(scalar[7 * 4..7 * 4 + 4], [0; 4]);
        assert!(scalar.iter().any(|&v| v > 200) && scalar.iter().any(|&v| v < 50));
    }
}

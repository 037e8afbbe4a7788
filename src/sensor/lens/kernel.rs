//! The lens's bilinear resampling kernel (issue 41): a row of output
//! pixels ([`remap_row`]), each the mix of its source's 2×2 pixels by its
//! [`Tap`]'s weights in 1/64 (`taps.rs`), in 16-bit integers: per channel
//! the left and right bytes mixed along x exactly (T, B ≤ 255·64), the
//! lower row's difference added by a rounded 16-bit multiply (`mulhrs`:
//! T + ⌊(2(B − T)·256·wy + 2¹⁴) / 2¹⁵⌋), and that rounded to a byte (the
//! result within 1 level of the exact mix, tested). The scalar kernel,
//! and on AVX2 eight pixels at a time, their taps computed in registers
//! ([`Block`]) and the mix by `maddubs` and `mulhrs`, with the scalar
//! kernel's bytes (tested).

#[cfg(target_arch = "x86_64")]
use super::taps::Block;
#[cfg(target_arch = "x86_64")]
use super::taps::packed_weights;
use super::taps::{ONE, Rows, Tap, row_taps_scalar};

/// The columns from `x0` of row `y` of a `w`×`h` picture resampled from
/// `src` (its RGBA8 pixels) into `row` through `rows`' nodes: the AVX2
/// kernel where the CPU has it, else the scalar one (the same bytes).
/// `taps` is scratch for the scalar kernel. Columns past the nodes' cells
/// are left as they are.
pub(super) fn remap_row(
    src: &[u8],
    rows: &Rows,
    (x0, y): (u32, u32),
    (w, h): (u32, u32),
    taps: &mut Vec<Tap>,
    row: &mut [u8],
) {
    let n = rows.covered(x0, row.len() / 4);
    let row = &mut row[..n * 4];
    #[cfg(target_arch = "x86_64")]
    if crate::simd::simd_level() >= 1 && src.len() / 4 >= w as usize * h as usize {
        // SAFETY: the CPU has AVX2 (checked by `simd_level`).
        #[allow(unsafe_code)]
        unsafe {
            return remap_row_avx2(src, rows, (x0, y), (w, h), row);
        }
    }
    taps.clear();
    taps.resize(n, Tap(0));
    row_taps_scalar(rows, x0, y, (w, h), taps);
    remap_taps_scalar(src, w as usize, taps, row);
}

/// Pixels from their taps (a map's table, `row`'s pixels): the AVX2
/// kernel where the CPU has it, else the scalar one (the same bytes).
pub(super) fn remap_taps(src: &[u8], w: usize, taps: &[Tap], row: &mut [u8]) {
    #[cfg(target_arch = "x86_64")]
    if crate::simd::simd_level() >= 1 {
        // SAFETY: the CPU has AVX2 (checked by `simd_level`).
        #[allow(unsafe_code)]
        unsafe {
            return remap_taps_avx2(src, w, taps, row);
        }
    }
    remap_taps_scalar(src, w, taps, row);
}

/// Pixels from their taps in scalar integers (the reference the AVX2
/// kernel matches): per channel the two rows mixed along x, the lower
/// one's difference added along y, rounded as `mulhrs` rounds; a quad
/// past the end of `src` gives 0.
pub(super) fn remap_taps_scalar(src: &[u8], w: usize, taps: &[Tap], row: &mut [u8]) {
    let one = ONE as i32;
    for (px, &t) in row.chunks_exact_mut(4).zip(taps) {
        let o = t.index() as usize * 4;
        let (Some(a), Some(b)) = (src.get(o..o + 8), src.get(o + w * 4..o + w * 4 + 8)) else {
            px.fill(0);
            continue;
        };
        let (wx, wy) = (t.wx() as i32, t.wy() as i32);
        for (c, out) in px.iter_mut().enumerate() {
            let x_mix = |r: &[u8]| i32::from(r[c]) * (one - wx) + i32::from(r[c + 4]) * wx;
            let (top, bottom) = (x_mix(a), x_mix(b));
            let v = top + ((2 * (bottom - top) * (wy << 8) + (1 << 14)) >> 15);
            *out = ((v * 512 + (1 << 14)) >> 15) as u8;
        }
    }
}

/// [`remap_row`] on AVX2: the columns before the first multiple of 8 and
/// the last few by the scalar kernel, the rest eight at a time, each
/// block's taps by [`Block::at`] and its pixels by [`mix8`]. `src` holds
/// the whole `w`×`h` picture (the caller checks), so every clamped tap's
/// quad lies inside it.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
fn remap_row_avx2(
    src: &[u8],
    rows: &Rows,
    (x0, y): (u32, u32),
    (w, h): (u32, u32),
    row: &mut [u8],
) {
    use std::arch::x86_64::*;
    let n = row.len() / 4;
    let head = ((8 - x0 % 8) % 8).min(n as u32) as usize;
    let scalar = |x: u32, out: &mut [u8]| {
        let mut taps = [Tap(0); 8];
        let taps = &mut taps[..out.len() / 4];
        row_taps_scalar(rows, x, y, (w, h), taps);
        remap_taps_scalar(src, w as usize, taps, out);
    };
    let (before, rest) = row.split_at_mut(head * 4);
    scalar(x0, before);
    let x0 = x0 + head as u32;
    let mut block = Block::new(rows, y, (w, h));
    let blocks = rest.chunks_exact_mut(32);
    let (n, x_tail) = (blocks.len(), x0 + (blocks.len() * 8) as u32);
    // SAFETY (each block): the CPU has AVX2 (this function's); the taps
    // are clamped inside the picture, which `src` holds.
    #[allow(unsafe_code)]
    let mut next = match n {
        0 => (_mm256_setzero_si256(), _mm256_setzero_si256()),
        _ => unsafe { block.at(rows, x0) },
    };
    for (b, out) in blocks.enumerate() {
        let x = x0 + 8 * b as u32;
        let (index, wts) = next;
        // The next block's taps first: their work overlaps this block's
        // loads and mix, which wait on them otherwise (a standalone copy
        // of this loop, one thread, the picture in cache: 25 % less time).
        #[allow(unsafe_code)]
        if b + 1 < n {
            unsafe {
                if x.is_multiple_of(16) {
                    prefetch(src, rows, (x + AHEAD, y), (w, h));
                }
                next = block.at(rows, x + 8);
            }
        }
        #[allow(unsafe_code)]
        unsafe {
            let bytes = mix8(src.as_ptr(), w as usize, index, wts);
            _mm256_storeu_si256(out.as_mut_ptr() as *mut __m256i, bytes);
        }
    }
    let tail = rest.chunks_exact_mut(32).into_remainder();
    scalar(x_tail, tail);
}

/// [`remap_taps_scalar`] on AVX2, eight pixels at a time by [`mix8`]
/// (the scalar kernel for a block with a quad past the end of `src`, and
/// for the row's last pixels); the sources [`AHEAD`] pixels on prefetched.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
fn remap_taps_avx2(src: &[u8], w: usize, taps: &[Tap], row: &mut [u8]) {
    use std::arch::x86_64::*;
    let n = taps.len().min(row.len() / 4);
    // A quad lies inside `src` where its index is at most this.
    let Some(last) = (src.len() / 4).checked_sub(w + 2) else {
        return remap_taps_scalar(src, w, taps, row);
    };
    let last = _mm256_set1_epi32(last.min(u32::MAX as usize) as u32 as i32);
    let blocks = taps[..n].chunks_exact(8).zip(row.chunks_exact_mut(32));
    for (k, (block, out)) in blocks.enumerate() {
        if let Some(ahead) = taps.get(k * 8 + AHEAD as usize) {
            let at = ahead.index() as usize * 4;
            _mm_prefetch::<_MM_HINT_T0>(src.as_ptr().wrapping_add(at) as *const i8);
            _mm_prefetch::<_MM_HINT_T0>(src.as_ptr().wrapping_add(at + w * 4) as *const i8);
        }
        // SAFETY: `block` is 8 `Tap`s, 64 bytes (`Tap` is a transparent `u64`).
        #[allow(unsafe_code)]
        let (lo, hi) = unsafe {
            let v = block.as_ptr() as *const __m256i;
            (_mm256_loadu_si256(v), _mm256_loadu_si256(v.add(1)))
        };
        // Each tap's halves in pixel order: [t0 t1 t4 t5 | t2 t3 t6 t7] → [t0 … t7].
        let half = |at: __m256| _mm256_permute4x64_epi64::<0b11_01_10_00>(_mm256_castps_si256(at));
        let (lo, hi) = (_mm256_castsi256_ps(lo), _mm256_castsi256_ps(hi));
        let index = half(_mm256_shuffle_ps::<0b10_00_10_00>(lo, hi));
        let packed = half(_mm256_shuffle_ps::<0b11_01_11_01>(lo, hi));
        // Every index at most `last` (unsigned), or the scalar kernel.
        let inside = _mm256_cmpeq_epi32(_mm256_max_epu32(index, last), last);
        if _mm256_movemask_epi8(inside) != -1 {
            remap_taps_scalar(src, w, block, out);
            continue;
        }
        let wx = _mm256_and_si256(packed, _mm256_set1_epi32(0xffff));
        let wy = _mm256_srli_epi32::<16>(packed);
        // SAFETY: the CPU has AVX2; every quad lies inside `src` (checked).
        #[allow(unsafe_code)]
        unsafe {
            let bytes = mix8(src.as_ptr(), w, index, packed_weights(wx, wy));
            _mm256_storeu_si256(out.as_mut_ptr() as *mut __m256i, bytes);
        }
    }
    let done = n / 8 * 8;
    remap_taps_scalar(src, w, &taps[done..n], &mut row[done * 4..]);
}

/// How many pixels ahead [`remap_row_avx2`] prefetches its sources.
#[cfg(target_arch = "x86_64")]
const AHEAD: u32 = 128;

/// The source lines of column `x` of row `y` (its node's source, if that
/// column starts a cell of `rows`), fetched early: a row's sources cross
/// the picture's rows, which the hardware does not foresee.
///
/// # Safety
/// The CPU has AVX2.
#[cfg(target_arch = "x86_64")]
#[inline(always)]
#[allow(unsafe_code)]
unsafe fn prefetch(src: &[u8], rows: &Rows, (x, y): (u32, u32), (w, h): (u32, u32)) {
    use std::arch::x86_64::{_MM_HINT_T0, _mm_prefetch};
    let c = (x / 16).wrapping_sub(rows.first) as usize + 1;
    let (Some(&u), Some(&v)) = (rows.u.get(c), rows.v.get(c)) else {
        return;
    };
    let one = ONE as f32;
    let sx = (x as f32 + u / one).clamp(0.0, (w - 1) as f32) as usize;
    let sy = (y as f32 + v / one).clamp(0.0, (h - 2) as f32) as usize;
    let at = (sy * w as usize + sx) * 4;
    for line in [at, at + 64, at + w as usize * 4, at + w as usize * 4 + 64] {
        // SAFETY: a prefetch never faults (the address may pass the end).
        unsafe { _mm_prefetch::<_MM_HINT_T0>(src.as_ptr().wrapping_add(line) as *const i8) };
    }
}

/// Eight pixels' bytes (RGBA8, in order) from their top-left source
/// pixels' indices and their weights ([`Block::at`]'s): per pixel its two
/// rows' 8 bytes loaded whole (pixels 0 1 | 4 5 in one register, 2 3 | 6 7
/// in the other), mixed by [`mix4`], packed.
///
/// # Safety
/// The CPU has AVX2, and each index's pixel and the one after it, in its
/// row and the next (`w` pixels on), lie inside the picture at `p`.
#[cfg(target_arch = "x86_64")]
#[inline(always)]
#[allow(unsafe_code)]
unsafe fn mix8(
    p: *const u8,
    w: usize,
    index: std::arch::x86_64::__m256i,
    wts: std::arch::x86_64::__m256i,
) -> std::arch::x86_64::__m256i {
    use std::arch::x86_64::*;
    // SAFETY: the caller's CPU has AVX2; it keeps each quad inside the picture.
    unsafe {
        let mut at = [0u32; 8];
        _mm256_storeu_si256(at.as_mut_ptr() as *mut __m256i, index);
        // Pixel k's quad's row r (0: its own, w: the next) as 8 bytes.
        let q =
            |k: usize, r: usize| (p.add((at[k] as usize + r) * 4) as *const i64).read_unaligned();
        let first = mix4(
            _mm256_set_epi64x(q(5, 0), q(4, 0), q(1, 0), q(0, 0)),
            _mm256_set_epi64x(q(5, w), q(4, w), q(1, w), q(0, w)),
            wts,
            0,
        );
        let second = mix4(
            _mm256_set_epi64x(q(7, 0), q(6, 0), q(3, 0), q(2, 0)),
            _mm256_set_epi64x(q(7, w), q(6, w), q(3, w), q(2, w)),
            wts,
            8,
        );
        _mm256_packus_epi16(first, second)
    }
}

/// Four pixels' channels (words: per lane its first pixel's r g b a, then
/// its second's) from their quads' `top` and `bottom` rows (per lane two
/// pixels' 8 bytes, left then right pixel) and the weights `wts` of the
/// eight pixels of [`mix8`] (per lane, the pixels at byte `at` and `at` +
/// 4): the left and right bytes paired and mixed by `maddubs` with
/// (ONE − wx, wx), then T + `mulhrs`(2(B − T), 256·wy), rounded to a byte
/// by `mulhrs`(·, 512).
///
/// # Safety
/// The CPU has AVX2.
#[cfg(target_arch = "x86_64")]
#[inline(always)]
#[allow(unsafe_code)]
unsafe fn mix4(
    top: std::arch::x86_64::__m256i,
    bottom: std::arch::x86_64::__m256i,
    wts: std::arch::x86_64::__m256i,
    at: i8,
) -> std::arch::x86_64::__m256i {
    use std::arch::x86_64::*;
    let (i, j) = (at, at + 4);
    // SAFETY: the caller's CPU has AVX2.
    unsafe {
        // Per lane: [left r, right r, left g, …] of its first pixel, then its second's.
        let pairs = _mm256_setr_epi8(
            0, 4, 1, 5, 2, 6, 3, 7, 8, 12, 9, 13, 10, 14, 11, 15, 0, 4, 1, 5, 2, 6, 3, 7, 8, 12, 9,
            13, 10, 14, 11, 15,
        );
        // Per lane, the word at byte i four times, then the one at j.
        #[rustfmt::skip]
        let spread = _mm256_setr_epi8(
            i, i + 1, i, i + 1, i, i + 1, i, i + 1, j, j + 1, j, j + 1, j, j + 1, j, j + 1,
            i, i + 1, i, i + 1, i, i + 1, i, i + 1, j, j + 1, j, j + 1, j, j + 1, j, j + 1,
        );
        let xw = _mm256_shuffle_epi8(wts, spread);
        // The y weight is the i32's upper word: its bytes 2 and 3.
        let yw = _mm256_shuffle_epi8(wts, _mm256_add_epi8(spread, _mm256_set1_epi8(2)));
        let t = _mm256_maddubs_epi16(_mm256_shuffle_epi8(top, pairs), xw);
        let b = _mm256_maddubs_epi16(_mm256_shuffle_epi8(bottom, pairs), xw);
        let d = _mm256_sub_epi16(b, t);
        let v = _mm256_add_epi16(t, _mm256_mulhrs_epi16(_mm256_add_epi16(d, d), yw));
        _mm256_mulhrs_epi16(v, _mm256_set1_epi16(512))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The taps' kernel against the exact bilinear mix at the same
    /// weights: within 1 level (the two roundings), and exact where a
    /// weight pair is whole.
    #[test]
    fn the_kernel_is_the_exact_mix_within_a_level() {
        let w = 2usize;
        let mut worst = 0.0f64;
        for k in 0..20_000u32 {
            let src: Vec<u8> = (0..16)
                .map(|i| ((k * 7 + i).wrapping_mul(2654435761) >> 24) as u8)
                .collect();
            let (wx, wy) = (k % (ONE + 1), k / 7 % (ONE + 1));
            let mut out = [0u8; 4];
            remap_taps_scalar(&src, w, &[Tap::new(0, wx, wy)], &mut out);
            let (fx, fy) = (f64::from(wx) / 64.0, f64::from(wy) / 64.0);
            for c in 0..4 {
                let p = |i: usize| f64::from(src[i * 4 + c]);
                let top = p(0) * (1.0 - fx) + p(1) * fx;
                let bottom = p(2) * (1.0 - fx) + p(3) * fx;
                let exact = top * (1.0 - fy) + bottom * fy;
                worst = worst.max((f64::from(out[c]) - exact).abs());
                if wy % ONE == 0 && wx % ONE == 0 {
                    assert_eq!(f64::from(out[c]), exact, "tap ({wx}, {wy})");
                }
            }
        }
        assert!(worst < 1.0, "{worst} levels");
        assert!(worst > 0.5, "{worst}: rounded to the nearest level at best");
    }

    /// The AVX2 kernel from a table of taps gives the scalar kernel's bytes
    /// for every weight (0 and 64 included) on a noisy picture, a quad past
    /// the picture's end giving 0 in both.
    #[test]
    fn the_avx2_kernel_gives_the_scalar_bytes_from_a_table() {
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
                Tap::new(at, i * 97 % (ONE + 1), i * 61 % (ONE + 1))
            })
            .collect();
        let mut scalar = vec![0u8; n * 4];
        remap_taps_scalar(&src, w, &taps, &mut scalar);
        let mut fast = vec![1u8; n * 4];
        remap_taps(&src, w, &taps, &mut fast);
        assert_eq!(scalar, fast);
        assert_eq!(scalar[7 * 4..7 * 4 + 4], [0; 4]);
        assert!(scalar.iter().any(|&v| v > 200) && scalar.iter().any(|&v| v < 50));
    }

    /// The AVX2 kernel (its taps in registers) gives the scalar kernel's
    /// bytes for the scalar taps, on a picture of extremes and noise, for
    /// displacements of every size (past either edge: the clamped last
    /// pixel's full weight), from a column that is not a multiple of 8,
    /// on a row that is not a multiple of 8 long.
    #[test]
    fn the_avx2_kernel_gives_the_scalar_bytes() {
        let (w, h, n) = (203u32, 77u32, 187usize);
        let src: Vec<u8> = (0..w * h * 4)
            .map(|i| match i % 11 {
                0 => 0,
                1 | 2 => 255,
                _ => (i * 7919 % 251) as u8,
            })
            .collect();
        let plane = |seed: f32| -> Vec<f32> {
            (0..20)
                .map(|i| match i {
                    1 => -1e5,
                    14 => 1e5,
                    _ if i % 5 == 0 => 32.5,
                    _ => ((i as f32 + seed) * 0.731).sin() * 900.0,
                })
                .collect()
        };
        let k: [[f32; 16]; 4] = std::array::from_fn(|i| {
            std::array::from_fn(|t| (i as f32 - 1.3) * 0.17 + t as f32 / 41.0)
        });
        let (u, v) = (plane(0.0), plane(17.0));
        let rows = Rows {
            u: &u,
            v: &v,
            first: 0,
            k: &k,
        };
        for (x0, y) in [(9u32, 0u32), (0, 5), (16, 76), (3, 40)] {
            let mut taps = vec![Tap(0); n];
            row_taps_scalar(&rows, x0, y, (w, h), &mut taps);
            let mut scalar = vec![0u8; n * 4];
            remap_taps_scalar(&src, w as usize, &taps, &mut scalar);
            let mut fast = vec![1u8; n * 4];
            remap_row(&src, &rows, (x0, y), (w, h), &mut Vec::new(), &mut fast);
            assert_eq!(scalar, fast, "from ({x0}, {y})");
            assert!(taps.iter().any(|t| t.wx() == ONE) && taps.iter().any(|t| t.wy() == 0));
            // Most taps fall between columns; some between rows too.
            assert!(taps.iter().filter(|t| t.wx() % ONE != 0).count() > n / 2);
            assert!(taps.iter().any(|t| t.wx() % ONE != 0 && t.wy() % ONE != 0));
        }
    }
}

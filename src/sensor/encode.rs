//! The chain's last step on linear light: sRGB encoding, by a 65 536-entry
//! table on the linear value (also folded into L1-sized buckets, which the
//! sweep reads), and the encode of a finished row into RGBA8 with the
//! input's alpha. [`super::motion`] and the test reference encode through
//! the same table.

use std::sync::OnceLock;

#[cfg(target_arch = "x86_64")]
mod avx512;

/// Entries of the encoding table: linear [0, 1] in steps of 1/65535.
const ENCODE_STEPS: usize = 65_536;

/// Linear light (index = round(l·65535)) → sRGB 8-bit.
pub(super) fn encode_table() -> &'static [u8] {
    static T: OnceLock<Vec<u8>> = OnceLock::new();
    T.get_or_init(|| {
        (0..ENCODE_STEPS as u32)
            .map(|i| level(i).round().clamp(0.0, 255.0) as u8)
            .collect()
    })
}

/// The sRGB level of encode-table index `i` before rounding (0 to 255).
fn level(i: u32) -> f64 {
    let l = f64::from(i) / (ENCODE_STEPS - 1) as f64;
    let c = if l <= 0.003_130_8 {
        12.92 * l
    } else {
        1.055 * l.powf(1.0 / 2.4) - 0.055
    };
    c * 255.0
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

/// One row of RGBA8 from the three linear rows (see [`encode_row`]): in
/// AVX-512 registers where the CPU has them ([`avx512`]: permutes, no
/// gather), else in AVX2 ([`encode_line_avx2`]: eight-lane gathers).
#[inline(always)]
pub(super) fn encode_line(vals: [&[f32]; 3], src: &[u8], line: &mut [u8]) {
    #[cfg(target_arch = "x86_64")]
    match crate::simd::simd_level() {
        // SAFETY: the CPU has AVX-512 F and BW (checked by `simd_level`).
        #[allow(unsafe_code)]
        2.. => unsafe { return avx512::encode_line_avx512(vals, src, line) },
        // SAFETY: the CPU has AVX2 (checked by `simd_level`).
        #[allow(unsafe_code)]
        1 => unsafe { return encode_line_avx2(vals, src, line) },
        _ => {}
    }
    encode_row(vals, src, line, false);
}

/// [`encode_row`] for AVX2: eight pixels at a time, each channel's eight
/// bucket words read with one gather ([`codes8`]; LLVM leaves the look-ups
/// of [`encode_row`] as scalar loads and lane moves), the alpha taken from
/// the source's words; the tail through [`encode_row`]. The same bytes.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
#[inline(never)]
fn encode_line_avx2(vals: [&[f32]; 3], src: &[u8], line: &mut [u8]) {
    use std::arch::x86_64::{
        __m256i, _mm256_and_si256, _mm256_loadu_si256, _mm256_or_si256, _mm256_set1_epi32,
        _mm256_slli_epi32, _mm256_storeu_si256,
    };
    let buckets = encode_buckets();
    let [r, g, b] = vals;
    let (n, whole) = line_blocks(vals, src, line, 8);
    let (r8, g8, b8) = (
        r[..whole].as_chunks::<8>().0,
        g[..whole].as_chunks::<8>().0,
        b[..whole].as_chunks::<8>().0,
    );
    let pixels = line[..whole * 4]
        .chunks_exact_mut(32)
        .zip(src.chunks_exact(32));
    for (((px, s), r), (g, b)) in pixels.zip(r8).zip(g8.iter().zip(b8)) {
        let (r, g, b) = (codes8(buckets, r), codes8(buckets, g), codes8(buckets, b));
        // SAFETY: `s` and `px` are 32 bytes each, read and written unaligned.
        #[allow(unsafe_code)]
        unsafe {
            let alpha = _mm256_and_si256(
                _mm256_loadu_si256(s.as_ptr().cast::<__m256i>()),
                _mm256_set1_epi32(0xff00_0000_u32 as i32),
            );
            let word = _mm256_or_si256(
                _mm256_or_si256(r, _mm256_slli_epi32::<8>(g)),
                _mm256_or_si256(_mm256_slli_epi32::<16>(b), alpha),
            );
            _mm256_storeu_si256(px.as_mut_ptr().cast::<__m256i>(), word);
        }
    }
    encode_tail(vals, src, line, whole..n);
}

/// The pixels of a line that its three rows and its source all hold, and
/// how many of them make whole blocks of `lanes`.
#[inline(always)]
fn line_blocks(vals: [&[f32]; 3], src: &[u8], line: &[u8], lanes: usize) -> (usize, usize) {
    let n = (line.len() / 4)
        .min(src.len() / 4)
        .min(vals.iter().map(|v| v.len()).min().unwrap_or(0));
    (n, n - n % lanes)
}

/// The line's pixels `tail` one at a time ([`encode_row`]), after a SIMD
/// encode's whole blocks.
#[inline(always)]
fn encode_tail(vals: [&[f32]; 3], src: &[u8], line: &mut [u8], tail: std::ops::Range<usize>) {
    let [r, g, b] = vals.map(|v| &v[tail.clone()]);
    let bytes = tail.start * 4..tail.end * 4;
    encode_row([r, g, b], &src[bytes.clone()], &mut line[bytes], true);
}

/// The codes of eight linear values, one a 32-bit lane: [`encode_index_simd`]
/// then [`bucket_code`] per lane, the bucket words gathered.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
#[inline]
fn codes8(buckets: &[u32; ENCODE_STEPS / BUCKET], l: &[f32; 8]) -> std::arch::x86_64::__m256i {
    use std::arch::x86_64::{
        _mm256_add_epi32, _mm256_add_ps, _mm256_and_si256, _mm256_cmpgt_epi32, _mm256_cvttps_epi32,
        _mm256_floor_ps, _mm256_i32gather_epi32, _mm256_loadu_ps, _mm256_max_ps, _mm256_min_ps,
        _mm256_mul_ps, _mm256_set1_epi32, _mm256_set1_ps, _mm256_setzero_ps, _mm256_srli_epi32,
    };
    let top = (ENCODE_STEPS - 1) as f32;
    // SAFETY: `l` holds eight f32; every gathered index is masked to the
    // table's length.
    #[allow(unsafe_code)]
    unsafe {
        let x = _mm256_add_ps(
            _mm256_mul_ps(_mm256_loadu_ps(l.as_ptr()), _mm256_set1_ps(top)),
            _mm256_set1_ps(0.5),
        );
        // max(x, 0) gives 0 for NaN (its second operand), as f32::max.
        let x = _mm256_min_ps(_mm256_max_ps(x, _mm256_setzero_ps()), _mm256_set1_ps(top));
        let i = _mm256_cvttps_epi32(_mm256_floor_ps(x));
        let bucket = _mm256_and_si256(
            _mm256_srli_epi32::<4>(i),
            _mm256_set1_epi32((ENCODE_STEPS / BUCKET - 1) as i32),
        );
        let e = _mm256_i32gather_epi32::<4>(buckets.as_ptr().cast(), bucket);
        let rem = _mm256_and_si256(i, _mm256_set1_epi32(BUCKET as i32 - 1));
        // −1 where the index lies below its bucket's step.
        let below = _mm256_cmpgt_epi32(_mm256_srli_epi32::<8>(e), rem);
        let low = _mm256_and_si256(e, _mm256_set1_epi32(0xff));
        _mm256_add_epi32(_mm256_add_epi32(low, _mm256_set1_epi32(1)), below)
    }
}

#[cfg(test)]
mod tests {
    use super::super::exposure::decode_table;
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

    /// Rows that hold every index's value and the halves between them,
    /// values past both ends and the odd ones, in a length that leaves a
    /// tail; and their source pixels.
    #[cfg(target_arch = "x86_64")]
    fn every_index() -> ([Vec<f32>; 3], Vec<u8>) {
        let mut l: Vec<f32> = (-2_000..=67_600)
            .flat_map(|k| [k as f32 / 65_535.0, (k as f32 + 0.5) / 65_535.0])
            .collect();
        l.extend([
            -0.0,
            f32::NAN,
            f32::INFINITY,
            f32::NEG_INFINITY,
            1e30,
            -1e30,
            1e-40,
        ]);
        l.push(0.5);
        let n = l.len();
        let (g, b): (Vec<f32>, Vec<f32>) = (
            l.iter().rev().copied().collect(),
            l.iter().map(|v| v * 0.7).collect(),
        );
        let src: Vec<u8> = (0..n * 4).map(|i| (i * 37 % 251) as u8).collect();
        ([l, g, b], src)
    }

    #[test]
    fn the_gathered_line_is_the_scalar_line() {
        #[cfg(target_arch = "x86_64")]
        if std::arch::is_x86_feature_detected!("avx2") {
            let ([l, g, b], src) = every_index();
            let (mut simd, mut scalar) = (vec![0u8; src.len()], vec![0u8; src.len()]);
            // SAFETY: the CPU has AVX2 (checked above).
            #[allow(unsafe_code)]
            unsafe {
                encode_line_avx2([&l, &g, &b], &src, &mut simd);
            }
            encode_row([&l, &g, &b], &src, &mut scalar, false);
            assert_eq!(simd, scalar);
        }
    }

    #[test]
    fn the_permuted_line_is_the_scalar_line() {
        #[cfg(target_arch = "x86_64")]
        if crate::simd::cpu_simd_level() >= 2 {
            let ([l, g, b], src) = every_index();
            let (mut simd, mut scalar) = (vec![0u8; src.len()], vec![0u8; src.len()]);
            // SAFETY: the CPU has AVX-512 F and BW (checked above).
            #[allow(unsafe_code)]
            unsafe {
                avx512::encode_line_avx512([&l, &g, &b], &src, &mut simd);
            }
            encode_row([&l, &g, &b], &src, &mut scalar, false);
            assert_eq!(simd, scalar);
        }
    }
}

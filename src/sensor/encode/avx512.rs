//! The encode of a finished row ([`super::encode_line`]) in AVX-512
//! registers, without a gather: sixteen values a channel at a time, each
//! value's code first estimated by a quadratic over its index's octave
//! and then settled by one threshold, both read by in-register permutes.
//! Gathers are the AVX2 encode's cost (two thirds of its samples wait on
//! them); the bytes are the same, checked for every index when the tables
//! are built and by the unit test.
//!
//! For encode-table index `i` ([`super::encode_index`]), the estimate is
//! `k₀ = ⌊p(i − 2ᵉ)⌋` with the quadratic `p` of `i`'s octave `[2ᵉ, 2ᵉ⁺¹)`
//! (sixteen octaves), fitted so that the code is `k₀` or `k₀ + 1`; the code
//! is then `k₀ + (i > above[k₀])`, where `above[k]` is the last index whose
//! code is at most `k`.

#[cfg(target_arch = "x86_64")]
use std::arch::x86_64::{
    __m512, __m512i, _mm512_add_ps, _mm512_and_si512, _mm512_castps_si512, _mm512_castsi512_ps,
    _mm512_cmpgt_epi32_mask, _mm512_cvtepi32_ps, _mm512_cvttps_epi32, _mm512_fmadd_ps,
    _mm512_loadu_ps, _mm512_loadu_si512, _mm512_mask_add_epi32, _mm512_mask_blend_epi16,
    _mm512_max_epi32, _mm512_max_ps, _mm512_min_ps, _mm512_mul_ps, _mm512_or_si512,
    _mm512_permutex2var_epi16, _mm512_permutexvar_ps, _mm512_set1_epi16, _mm512_set1_epi32,
    _mm512_set1_ps, _mm512_setzero_ps, _mm512_setzero_si512, _mm512_slli_epi32, _mm512_srli_epi32,
    _mm512_storeu_si512, _mm512_sub_epi32, _mm512_sub_ps, _mm512_test_epi16_mask,
};
use std::sync::OnceLock;

use super::{ENCODE_STEPS, encode_table, level};

/// The octaves of the index range: 1 to 65 535 as an f32 (index 0 in the first).
const OCTAVES: usize = 16;

/// The bits of an f32 that name its octave (its sign and exponent).
const EXPONENT: u32 = 0xff80_0000;

/// The tables of the estimate and its threshold.
pub(super) struct Segments {
    /// Each octave's quadratic `p(t) = (c2·t + c1)·t + c0` in the index's
    /// offset `t` from the octave's floor, through the middle of the
    /// levels' spread about it: within half a level of every index's
    /// unrounded level `l` (0.24 at most), so that the code, ⌊l + ½⌋, is
    /// ⌊p⌋ or one more.
    c: [[f32; OCTAVES]; 3],
    /// `above[k]`: the last index whose code is at most `k` (65 535 for 255).
    above: [u16; 256],
}

/// The octave of index `i` and its offset in it (the f32 `i` less its
/// octave's floor: exact; index 0 is offset 0 of the first octave).
#[inline(always)]
fn octave(i: u32) -> (usize, f32) {
    let f = i as f32;
    let floor = f32::from_bits(f.to_bits() & EXPONENT);
    ((f.to_bits() >> 23).saturating_sub(127) as usize, f - floor)
}

impl Segments {
    /// The estimate of index `i` before truncation, as the AVX-512 lanes
    /// compute it (two fused multiply-adds).
    #[inline(always)]
    fn estimate(&self, i: u32) -> f32 {
        let (o, t) = octave(i);
        let [c0, c1, c2] = self.c.map(|c| c[o]);
        c2.mul_add(t, c1).mul_add(t, c0)
    }

    /// The code of index `i` ([`encode_table`]'s entry).
    fn code(&self, i: u32) -> u8 {
        let k = self.estimate(i) as u32;
        (k + u32::from(i > u32::from(self.above[k as usize]))) as u8
    }
}

/// The quadratic `[c0, c1, c2]` through the levels of the indices `m` (an
/// octave's, in order: the first at offset 0) at their first, middle and
/// last offsets, its `c0` moved to the middle of their spread about it;
/// fewer points, a line or their mean.
fn fit(m: &[u32]) -> [f64; 3] {
    let pts: Vec<(f64, f64)> = m
        .iter()
        .map(|&i| (f64::from(octave(i).1), level(i)))
        .collect();
    let (first, mid, last) = (pts[0], pts[pts.len() / 2], pts[pts.len() - 1]);
    debug_assert_eq!(first.0, 0.0, "an octave starts at its floor");
    let mut c = if mid.0 > 0.0 && last.0 > mid.0 {
        // Newton's divided differences, expanded about t = 0.
        let d1 = (mid.1 - first.1) / mid.0;
        let d2 = ((last.1 - mid.1) / (last.0 - mid.0) - d1) / last.0;
        [first.1, d1 - d2 * mid.0, d2]
    } else if last.0 > 0.0 {
        [first.1, (last.1 - first.1) / last.0, 0.0]
    } else {
        [0.0; 3]
    };
    let (min, max) = pts
        .iter()
        .map(|&(t, l)| l - ((c[2] * t + c[1]) * t + c[0]))
        .fold((f64::MAX, f64::MIN), |(x, y), d| (x.min(d), y.max(d)));
    c[0] += (min + max) / 2.0;
    c
}

/// The tables, built once from [`encode_table`] and checked on every index.
pub(super) fn segments() -> &'static Segments {
    static T: OnceLock<Segments> = OnceLock::new();
    T.get_or_init(|| {
        let table = encode_table();
        let mut members: Vec<Vec<u32>> = vec![Vec::new(); OCTAVES];
        for i in 0..ENCODE_STEPS as u32 {
            members[octave(i).0].push(i);
        }
        let mut c = [[0.0f32; OCTAVES]; 3];
        for (o, m) in members.iter().enumerate() {
            for (k, v) in fit(m).into_iter().enumerate() {
                c[k][o] = v as f32;
            }
        }
        let mut above = [u16::MAX; 256];
        for (i, &code) in table.iter().enumerate().rev() {
            if code > 0 {
                above[usize::from(code) - 1] = i as u16 - 1;
            }
        }
        let t = Segments { c, above };
        for i in 0..ENCODE_STEPS as u32 {
            let (e, code) = (t.estimate(i), u32::from(table[i as usize]));
            let k = e as u32;
            assert!(
                e >= 0.0 && k <= 255 && (code == k || code == k + 1),
                "estimate {e} for code {code} at index {i}"
            );
            assert_eq!(t.code(i), table[i as usize], "index {i}");
        }
        t
    })
}

/// The tables in registers: the octaves' coefficients and `above` in
/// four pairs of 64 words.
#[cfg(target_arch = "x86_64")]
struct Regs {
    c: [__m512; 3],
    above: [[__m512i; 2]; 4],
}

#[cfg(target_arch = "x86_64")]
impl Regs {
    #[target_feature(enable = "avx512f,avx512bw")]
    fn load(t: &Segments) -> Self {
        // SAFETY: each load reads 64 bytes inside its table (16 f32 of 16,
        // 32 u16 of 256), unaligned.
        #[allow(unsafe_code)]
        unsafe {
            let w = |k: usize| _mm512_loadu_si512(t.above[k * 32..].as_ptr().cast());
            Self {
                c: t.c.map(|c| _mm512_loadu_ps(c.as_ptr())),
                above: std::array::from_fn(|p| [w(2 * p), w(2 * p + 1)]),
            }
        }
    }

    /// The codes of sixteen linear values, one a 32-bit lane: the index as
    /// [`super::encode_index_simd`] makes it, then [`Segments::code`].
    #[target_feature(enable = "avx512f,avx512bw")]
    #[inline]
    fn codes(&self, l: &[f32; 16]) -> __m512i {
        let top = (ENCODE_STEPS - 1) as f32;
        // SAFETY: `l` holds sixteen f32; the permutes read registers only.
        #[allow(unsafe_code)]
        unsafe {
            let x = _mm512_add_ps(
                _mm512_mul_ps(_mm512_loadu_ps(l.as_ptr()), _mm512_set1_ps(top)),
                _mm512_set1_ps(0.5),
            );
            // max(x, 0) gives 0 for NaN (its second operand), as f32::max;
            // x ≥ 0, so truncation is the floor.
            let x = _mm512_min_ps(_mm512_max_ps(x, _mm512_setzero_ps()), _mm512_set1_ps(top));
            let i = _mm512_cvttps_epi32(x);
            let fi = _mm512_cvtepi32_ps(i);
            let bits = _mm512_castps_si512(fi);
            let o = _mm512_max_epi32(
                _mm512_sub_epi32(_mm512_srli_epi32::<23>(bits), _mm512_set1_epi32(127)),
                _mm512_setzero_si512(),
            );
            let floor =
                _mm512_castsi512_ps(_mm512_and_si512(bits, _mm512_set1_epi32(EXPONENT as i32)));
            let t = _mm512_sub_ps(fi, floor);
            let [c0, c1, c2] = self.c.map(|c| _mm512_permutexvar_ps(o, c));
            let p = _mm512_fmadd_ps(_mm512_fmadd_ps(c2, t, c1), t, c0);
            // The estimate in each lane's low word, its high word zero.
            let k = _mm512_cvttps_epi32(p);
            let [p0, p1, p2, p3] = self
                .above
                .map(|[lo, hi]| _mm512_permutex2var_epi16(lo, k, hi));
            let bit6 = _mm512_test_epi16_mask(k, _mm512_set1_epi16(64));
            let bit7 = _mm512_test_epi16_mask(k, _mm512_set1_epi16(128));
            let above = _mm512_mask_blend_epi16(
                bit7,
                _mm512_mask_blend_epi16(bit6, p0, p1),
                _mm512_mask_blend_epi16(bit6, p2, p3),
            );
            let above = _mm512_and_si512(above, _mm512_set1_epi32(0xffff));
            let up = _mm512_cmpgt_epi32_mask(i, above);
            _mm512_mask_add_epi32(k, up, k, _mm512_set1_epi32(1))
        }
    }
}

/// [`super::encode_row`] for AVX-512: sixteen pixels at a time
/// ([`Regs::codes`]), the alpha taken from the source's words; the tail
/// through [`super::encode_tail`]. The same bytes.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx512f,avx512bw")]
#[inline(never)]
pub(super) fn encode_line_avx512(vals: [&[f32]; 3], src: &[u8], line: &mut [u8]) {
    let regs = Regs::load(segments());
    let [r, g, b] = vals;
    let (n, whole) = super::line_blocks(vals, src, line, 16);
    let (r16, g16, b16) = (
        r[..whole].as_chunks::<16>().0,
        g[..whole].as_chunks::<16>().0,
        b[..whole].as_chunks::<16>().0,
    );
    let pixels = line[..whole * 4]
        .chunks_exact_mut(64)
        .zip(src.chunks_exact(64));
    for (((px, s), r), (g, b)) in pixels.zip(r16).zip(g16.iter().zip(b16)) {
        let (r, g, b) = (regs.codes(r), regs.codes(g), regs.codes(b));
        // SAFETY: `s` and `px` are 64 bytes each, read and written unaligned.
        #[allow(unsafe_code)]
        unsafe {
            let alpha = _mm512_and_si512(
                _mm512_loadu_si512(s.as_ptr().cast()),
                _mm512_set1_epi32(0xff00_0000_u32 as i32),
            );
            let word = _mm512_or_si512(
                _mm512_or_si512(r, _mm512_slli_epi32::<8>(g)),
                _mm512_or_si512(_mm512_slli_epi32::<16>(b), alpha),
            );
            _mm512_storeu_si512(px.as_mut_ptr().cast(), word);
        }
    }
    super::encode_tail(vals, src, line, whole..n);
}

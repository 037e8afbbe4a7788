//! Where the upsampling's output pixels sample the source along one axis,
//! and the horizontal half of its blend: a source row of levels (RGBA8)
//! blended across to the output's columns, as sums in 16ths (`u16`, not
//! yet rounded: the vertical blend rounds once, [`super::down`]).

use std::ops::Range;

/// One output position's two source texels and the second's weight in
/// 16ths (0 to 16).
pub(super) type Tap = (usize, usize, u16);

/// The weights' resolution: 16ths of a texel, Vulkan's least required
/// sub-texel precision (`subTexelPrecisionBits` 4). An exact 2× or 4×
/// upsampling's weights (eighths) are exact in it.
pub(super) const ONE: u16 = 16;

/// Where `out` output pixels sample along one axis: the two texels and the
/// second's weight, as a clamping bilinear sampler at `(i + 0.5) /
/// (2 · centre)` of `source` texels, its weight rounded to 16ths.
pub(super) fn taps(out: u32, source: u32, centre: f32) -> Vec<Tap> {
    let last = source.saturating_sub(1) as usize;
    (0..out)
        .map(|i| {
            let uv = (i as f32 + 0.5) / (2.0 * centre);
            let t = uv * source as f32 - 0.5;
            let base = t.floor();
            let w = t - base;
            let clamp = |v: f32| (v.max(0.0) as usize).min(last);
            // NaN (a degenerate centre) gives 0.
            let w = (w * f32::from(ONE)).round().clamp(0.0, f32::from(ONE)) as u16;
            (clamp(base), clamp(base + 1.0), w)
        })
        .collect()
}

/// The column layout of an exact `k`× upsampling of `source` texels to
/// `out` columns: `k / 2` head columns on texel 0, then `mid` chunks of
/// `k` columns, chunk c between texels c and c + 1, then the tail on texel
/// `mid` alone (both taps the same texel). `(head, mid)`.
pub(super) fn chunk_layout(k: usize, out: usize, source: usize) -> (usize, usize) {
    let head = (k / 2).min(out);
    (head, ((out - head) / k).min(source.saturating_sub(1)))
}

/// How an output row samples its source row: each column's taps, their
/// weights per output byte (what the SIMD blend loads), and `factor` 2 or
/// 4 when the columns follow that exact integer pattern ([`chunk_layout`]),
/// else 0.
pub(super) struct Columns {
    pub(super) taps: Vec<Tap>,
    /// Per output byte (four a column): the first texel's weight, 16 − w.
    near: Vec<u16>,
    /// Per output byte: the second texel's weight, w.
    far: Vec<u16>,
    pub(super) factor: usize,
    /// Source texels a row.
    source: usize,
}

impl Columns {
    pub(super) fn new(out: u32, source: u32, centre: f32) -> Self {
        let taps = taps(out, source, centre);
        let follows = |k: usize| {
            let (head, mid) = chunk_layout(k, taps.len(), source as usize);
            source > 0
                && taps.iter().enumerate().all(|(i, &(a, b, _))| {
                    let want = if i < head {
                        (0, 0)
                    } else if i < head + mid * k {
                        ((i - head) / k, (i - head) / k + 1)
                    } else {
                        (mid, mid)
                    };
                    (a, b) == want
                })
        };
        let factor = [2, 4].into_iter().find(|&k| follows(k)).unwrap_or(0);
        let bytes = |f: fn(u16) -> u16| taps.iter().flat_map(|t| [f(t.2); 4]).collect();
        Self {
            near: bytes(|w| ONE - w),
            far: bytes(|w| w),
            taps,
            factor,
            source: source as usize,
        }
    }

    /// Source texels the columns of `window` read: the taps only move forward.
    pub(super) fn reads(&self, window: &Range<usize>) -> Range<usize> {
        self.taps[window.start].0..self.taps[window.end - 1].1 + 1
    }
}

/// Source row `src` (RGBA8 levels of texels `from` on) blended across to
/// the columns of `window` into `out` (four sums a column, in 16ths):
/// `p · (16 − w) + q · w` per channel. The whole chunks of an exact 2× or
/// 4× layout four columns at a time in AVX2 registers when `simd` (the same
/// integers).
pub(super) fn across(
    (src, from): (&[u8], usize),
    columns: &Columns,
    window: Range<usize>,
    out: &mut [u16],
    simd: bool,
) {
    let x0 = window.start;
    let done = if simd {
        chunked((src, from), columns, window.clone(), out)
    } else {
        x0..x0
    };
    for x in (x0..done.start).chain(done.end..window.end) {
        let (a, b, w) = columns.taps[x];
        let (p, q) = (&src[(a - from) * 4..][..4], &src[(b - from) * 4..][..4]);
        for (c, o) in out[(x - x0) * 4..][..4].iter_mut().enumerate() {
            *o = u16::from(p[c]) * (ONE - w) + u16::from(q[c]) * w;
        }
    }
}

/// The columns of `window` in whole groups of four of the exact layout's
/// chunks, blended in AVX2 registers into `out` (from the window's start):
/// which columns (none without AVX2 or an exact layout).
fn chunked(
    (src, from): (&[u8], usize),
    columns: &Columns,
    window: Range<usize>,
    out: &mut [u16],
) -> Range<usize> {
    let none = window.start..window.start;
    let k = columns.factor;
    if k == 0 {
        return none;
    }
    let (head, mid) = chunk_layout(k, columns.taps.len(), columns.source);
    // The first chunk at or after the window's start; a group is four
    // columns (4 / k chunks) and loads four texels from its first chunk's.
    let c0 = window.start.saturating_sub(head).div_ceil(k);
    let start = head + c0 * k;
    let texels = src.len() / 4 + from;
    let end = window.end.min(head + mid * k);
    let fit_columns = end.saturating_sub(start) / 4;
    let fit_loads = texels.checked_sub(c0 + 4).map_or(0, |n| n / (4 / k) + 1);
    let groups = fit_columns.min(fit_loads);
    if groups == 0 || c0 < from {
        return none;
    }
    let bytes = start * 4..(start + groups * 4) * 4;
    let o = &mut out[bytes.start - window.start * 4..bytes.end - window.start * 4];
    let weights = (&columns.near[bytes.clone()], &columns.far[bytes]);
    let src = &src[(c0 - from) * 4..];
    #[cfg(target_arch = "x86_64")]
    // SAFETY: `chunked` runs only where the caller passed `simd` (AVX2).
    #[allow(unsafe_code)]
    unsafe {
        match k {
            2 => groups_avx2::<2>(src, weights, o),
            _ => groups_avx2::<4>(src, weights, o),
        }
        start..start + groups * 4
    }
    #[cfg(not(target_arch = "x86_64"))]
    {
        let _ = (src, weights, o);
        none
    }
}

/// Groups of four output columns of a `K`× layout (two chunks of 2, one of
/// 4), the first from chunk 0 of `src` (RGBA8 texels from that chunk's
/// first): each group's four texels widened to 16 lanes, the columns'
/// first and second texels picked by lane permutes, and `p · near + q ·
/// far` per lane (`out.len() / 16` groups; the weights per output byte).
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
fn groups_avx2<const K: usize>(src: &[u8], (near, far): (&[u16], &[u16]), out: &mut [u16]) {
    use std::arch::x86_64::{
        __m128i, __m256i, _mm_loadu_si128, _mm256_add_epi16, _mm256_cvtepu8_epi16,
        _mm256_loadu_si256, _mm256_mullo_epi16, _mm256_permute4x64_epi64, _mm256_storeu_si256,
    };
    let groups = out.len() / 16;
    assert!(near.len() >= groups * 16 && far.len() >= groups * 16);
    assert!(groups == 0 || src.len() >= ((groups - 1) * (4 / K) + 4) * 4);
    for g in 0..groups {
        // SAFETY: group g loads texels g · 4/K … + 3 of `src` and 16 lanes
        // of the weights and `out` (asserted above); unaligned.
        #[allow(unsafe_code)]
        unsafe {
            let at = src.as_ptr().add(g * (4 / K) * 4).cast::<__m128i>();
            let t = _mm256_cvtepu8_epi16(_mm_loadu_si128(at));
            // Texels (0, 0, 1, 1) and (1, 1, 2, 2) at 2×, (0, 0, 0, 0) and (1, 1, 1, 1) at 4×.
            let (p, q) = if K == 2 {
                (
                    _mm256_permute4x64_epi64::<0x50>(t),
                    _mm256_permute4x64_epi64::<0xA5>(t),
                )
            } else {
                (
                    _mm256_permute4x64_epi64::<0x00>(t),
                    _mm256_permute4x64_epi64::<0x55>(t),
                )
            };
            let lane = |s: &[u16]| _mm256_loadu_si256(s.as_ptr().add(g * 16).cast::<__m256i>());
            let sum = _mm256_add_epi16(
                _mm256_mullo_epi16(p, lane(near)),
                _mm256_mullo_epi16(q, lane(far)),
            );
            _mm256_storeu_si256(out.as_mut_ptr().add(g * 16).cast(), sum);
        }
    }
}

//! The rolling shutter's background resampling kernel (issue 41): one
//! row's pixels from its knots' sources, bilinear in the bytes with weights
//! in 1/256, positions stepped in fixed point between knots; in scalar
//! integers, and on AVX2 eight pixels at a time with the same integers (so
//! the same bytes, tested).

use super::KNOT_PX;

/// Fraction bits of a fixed-point source position (1/65536 px).
pub(super) const FRAC: u32 = 16;

/// A pixel coordinate (a pixel's centre at +0.5) as the fixed-point
/// position on the tap grid (pixel centres at integers), clamped to
/// [−4096, 20480] px so that every sum stays in `i32` for images up to
/// [`crate::preset::MAX_IMAGE_SIDE`]; NaN to the first pixel. Rounded half
/// away from zero (`f64::round`'s rule) from the truncation and the exact
/// remainder, without a call into the maths library.
#[inline(always)]
pub(super) fn fixed(s: f64) -> i32 {
    let x = (s - 0.5).clamp(-4096.0, 20480.0) * f64::from(1u32 << FRAC);
    // |x| < 2³¹: the cast truncates (NaN to 0) and x − t is exact.
    let t = x as i32;
    let r = x - f64::from(t);
    t + i32::from(r >= 0.5) - i32::from(r <= -0.5)
}

/// `knots` in fixed point ([`fixed`]), into `out`.
#[inline(always)]
fn to_fixed(knots: &[(f64, f64)], out: &mut Vec<(i32, i32)>) {
    out.clear();
    out.extend(knots.iter().map(|&(u, v)| (fixed(u), fixed(v))));
}

/// One row's resampling from the whole `src` image (RGBA8, `size`, at
/// least 2×2 and `src` that long).
pub(super) struct Row<'a> {
    pub(super) src: &'a [u8],
    pub(super) size: (u32, u32),
}

/// The segments of a row with knots `fixed_knots` (fixed point) at
/// columns `xs`: column x in the segment of knot min(x / KNOT_PX, last − 1),
/// the last segment running to the row's end; `each` gets a segment's
/// start, step per pixel and pixels (RGBA8).
#[inline(always)]
fn segments(
    xs: &[u32],
    fixed_knots: &[(i32, i32)],
    out: &mut [u8],
    mut each: impl FnMut((i32, i32), (i32, i32), &mut [u8]),
) {
    let last = xs.len().saturating_sub(2);
    let width = out.len() / 4;
    for k in 0..=last {
        let next = (k + 1).min(xs.len() - 1);
        let (Some(&(u0, v0)), Some(&b)) = (fixed_knots.get(k), fixed_knots.get(next)) else {
            return;
        };
        let span = xs[next].saturating_sub(xs[k]).max(1) as i32;
        // The same quotients; a whole segment's by a shift ([`div_knot`]).
        let (du, dv) = (b.0 - u0, b.1 - v0);
        let step = if span == KNOT_PX as i32 {
            (div_knot(du), div_knot(dv))
        } else {
            (du / span, dv / span)
        };
        let from = k * KNOT_PX as usize;
        let to = if k == last {
            width
        } else {
            from + KNOT_PX as usize
        };
        let Some(pixels) = out.get_mut(from * 4..to * 4) else {
            return;
        };
        each((u0, v0), step, pixels);
    }
}

/// `d / KNOT_PX` (rounded towards zero, as `/`) by a shift: the bias
/// KNOT_PX − 1 added to a negative `d` first.
#[inline(always)]
fn div_knot(d: i32) -> i32 {
    const SHIFT: u32 = KNOT_PX.trailing_zeros();
    const _: () = assert!(KNOT_PX.is_power_of_two());
    (d + ((d >> 31) & (KNOT_PX as i32 - 1))) >> SHIFT
}

impl Row<'_> {
    /// The row's pixels (`out`, RGBA8) from its knots' sources (`knots`
    /// at columns `xs`, into `fixed_knots` in fixed point): each segment
    /// ([`segments`]) stepped in fixed point, eight pixels at a time on
    /// AVX2 (the same integers, so the same bytes), else pixel by pixel.
    pub(super) fn resample(
        &self,
        xs: &[u32],
        knots: &[(f64, f64)],
        fixed_knots: &mut Vec<(i32, i32)>,
        out: &mut [u8],
    ) {
        #[cfg(target_arch = "x86_64")]
        if crate::simd::simd_level() >= 1 {
            // SAFETY: the CPU has AVX2 (checked by `simd_level`).
            #[allow(unsafe_code)]
            unsafe {
                return self.resample_avx2(xs, knots, fixed_knots, out);
            }
        }
        to_fixed(knots, fixed_knots);
        segments(xs, fixed_knots, out, |start, step, pixels| {
            for (j, px) in (0..).zip(pixels.chunks_exact_mut(4)) {
                px.copy_from_slice(&self.pixel(start, step, j).to_le_bytes());
            }
        });
    }

    /// [`Self::resample`]'s segments on AVX2 ([`Self::segment_simd`]), the
    /// pixels it leaves by [`Self::pixel`].
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2")]
    fn resample_avx2(
        &self,
        xs: &[u32],
        knots: &[(f64, f64)],
        fixed_knots: &mut Vec<(i32, i32)>,
        out: &mut [u8],
    ) {
        to_fixed(knots, fixed_knots);
        segments(xs, fixed_knots, out, |start, step, pixels| {
            let done = self.segment_avx2(start, step, pixels);
            for (j, px) in (done as i32..).zip(pixels[done * 4..].chunks_exact_mut(4)) {
                px.copy_from_slice(&self.pixel(start, step, j).to_le_bytes());
            }
        });
    }

    /// Pixel `j` of a segment starting at `start` and stepping by `step`
    /// (fixed point), in scalar integers.
    #[inline(always)]
    pub(super) fn pixel(&self, (u0, v0): (i32, i32), (du, dv): (i32, i32), j: i32) -> u32 {
        self.bilinear(self.axis(u0 + du * j, 0), self.axis(v0 + dv * j, 1))
    }

    /// A fixed-point position on `axis` (0: x, 1: y) as its first tap's
    /// index and the second's weight in 1/256, clamped to the image.
    #[inline(always)]
    pub(super) fn axis(&self, s: i32, axis: usize) -> (u32, u32) {
        let n = [self.size.0, self.size.1][axis] as i32;
        let s = s.clamp(0, (n - 1) << FRAC);
        let i = (s >> FRAC).min(n - 2);
        let f = ((s - (i << FRAC)) + (1 << (FRAC - 9))) >> (FRAC - 8);
        (i as u32, f.min(256) as u32)
    }

    /// The bilinear sample at taps `(x0, fx)`, `(y0, fy)`, rounded twice:
    /// per channel each row t = (l·(256 − fx) + r·fx + 128) / 256, then
    /// (t_top·(256 − fy) + t_bottom·fy + 128) / 256, two channels to a word
    /// in 16-bit lanes.
    #[inline(always)]
    fn bilinear(&self, (x0, fx): (u32, u32), (y0, fy): (u32, u32)) -> u32 {
        let w = self.size.0 as usize;
        let o = (y0 as usize * w + x0 as usize) * 4;
        let pair = |o: usize| -> (u32, u32) {
            let p = self
                .src
                .get(o..o + 8)
                .and_then(|b| <[u8; 8]>::try_from(b).ok());
            let p = u64::from_le_bytes(p.unwrap_or([0; 8]));
            (p as u32, (p >> 32) as u32)
        };
        const M: u32 = 0x00ff_00ff;
        const HALF: u32 = 0x0080_0080;
        let lerp = |a: u32, b: u32, f: u32| ((a * (256 - f) + b * f + HALF) >> 8) & M;
        // r and b (even bytes), g and a (odd bytes) of a pair mixed along x.
        let mix =
            |(l, r): (u32, u32)| (lerp(l & M, r & M, fx), lerp((l >> 8) & M, (r >> 8) & M, fx));
        let (top, bottom) = (mix(pair(o)), mix(pair(o + w * 4)));
        lerp(top.0, bottom.0, fy) | lerp(top.1, bottom.1, fy) << 8
    }

    /// Whether the `len` pixels of a segment are a run: pixel j's taps are
    /// [`Self::axis`]'s (x0 + j, y0) with no clamp, so its 2×2 pixels are
    /// columns x0 + j, x0 + j + 1 of rows y0, y0 + 1 and its weights the
    /// fraction bits alone; `Some` the source index of (x0, y0). Checked at
    /// the ends: positions are linear in j, so unclamped at both ends is
    /// unclamped throughout, the row the same at both ends is the same
    /// throughout, and x0 rising by len − 1 over len − 1 steps, each
    /// ⌊du⌋ or ⌈du⌉ pixels, is a step of one each (a pan's usual segment).
    #[inline(always)]
    pub(super) fn run(&self, start: (i32, i32), step: (i32, i32), len: usize) -> Option<usize> {
        let last = i64::try_from(len).ok()?.checked_sub(1).filter(|&l| l > 0)?;
        let ((x0, x1), y0) = self.ends(start, step, last)?;
        (x1 - x0 == last).then_some((y0 * i64::from(self.size.0) + x0) as usize)
    }

    /// [`Self::run`] of a segment of [`KNOT_PX`] pixels (a pan's usual
    /// one), in `i32`: a last position past `i32` lies far off the image,
    /// where [`Self::run`] finds no run either.
    #[inline(always)]
    fn run32(&self, (u0, v0): (i32, i32), (du, dv): (i32, i32)) -> Option<usize> {
        const LAST: i32 = KNOT_PX as i32 - 1;
        let end = |a: i32, d: i32| d.checked_mul(LAST).and_then(|e| a.checked_add(e));
        let (u1, v1) = (end(u0, du)?, end(v0, dv)?);
        let (w, h) = (self.size.0 as i32, self.size.1 as i32);
        let (x0, x1, y0) = (u0 >> FRAC, u1 >> FRAC, v0 >> FRAC);
        let inside = u0 >= 0 && v0 >= 0 && v1 >= 0 && x1 <= w - 2 && y0 <= h - 2;
        (inside && x1 - x0 == LAST && v1 >> FRAC == y0)
            .then(|| y0 as usize * w as usize + x0 as usize)
    }

    /// The taps at both ends of `last` + 1 pixels from `start` (x at the
    /// first and last, the row), where neither is clamped and both read
    /// one source row; `None` otherwise.
    #[inline(always)]
    fn ends(
        &self,
        (u0, v0): (i32, i32),
        (du, dv): (i32, i32),
        last: i64,
    ) -> Option<((i64, i64), i64)> {
        let (w, h) = (i64::from(self.size.0), i64::from(self.size.1));
        // A tap index of fixed-point `s` where unclamped, else None.
        let tap = |s: i64, n: i64| (s >= 0 && (s >> FRAC) <= n - 2).then_some(s >> FRAC);
        let (u0, v0) = (i64::from(u0), i64::from(v0));
        let (x0, x1) = (tap(u0, w)?, tap(u0 + i64::from(du) * last, w)?);
        let (y0, y1) = (tap(v0, h)?, tap(v0 + i64::from(dv) * last, h)?);
        (y0 == y1).then_some(((x0, x1), y0))
    }

    /// Whether a block of eight pixels from `start` reads a window: one
    /// source row, no clamp, and its first taps x0 … x0 + 8 (rising by at
    /// most eight over seven steps, as a pan's slightly stretched or
    /// shrunk segment does), so that its 2×2 pixels lie among the 16 pixels
    /// from (x0, y0) of that row and the next, all inside `src`; `Some` the
    /// source index of (x0, y0).
    #[inline(always)]
    fn window(&self, start: (i32, i32), step: (i32, i32)) -> Option<usize> {
        let ((x0, x1), y0) = self.ends(start, step, 7)?;
        let at = y0 * i64::from(self.size.0) + x0;
        let end = at + i64::from(self.size.0) + 16;
        ((0..=8).contains(&(x1 - x0)) && end as usize * 4 <= self.src.len()).then_some(at as usize)
    }
}

/// `src` copied into `dst` (the shorter's length) with non-temporal
/// stores where both are 16-byte aligned in step (SSE2, every x86-64):
/// the bytes go to memory without evicting the cache or reading `dst`'s
/// lines first; a plain copy elsewhere.
pub(super) fn copy_streamed(dst: &mut [u8], src: &[u8]) {
    let n = dst.len().min(src.len());
    let (dst, src) = (&mut dst[..n], &src[..n]);
    #[cfg(target_arch = "x86_64")]
    {
        use std::arch::x86_64::{__m128i, _mm_loadu_si128, _mm_sfence, _mm_stream_si128};
        let head = dst.as_ptr().align_offset(16).min(n);
        dst[..head].copy_from_slice(&src[..head]);
        let body = head + (n - head) / 16 * 16;
        for (d, s) in dst[head..body]
            .chunks_exact_mut(16)
            .zip(src[head..body].chunks_exact(16))
        {
            // SAFETY: both are 16 bytes; `d` is 16-byte aligned (`head`);
            // the load takes any alignment.
            #[allow(unsafe_code)]
            unsafe {
                let v = _mm_loadu_si128(s.as_ptr().cast::<__m128i>());
                _mm_stream_si128(d.as_mut_ptr().cast::<__m128i>(), v);
            }
        }
        dst[body..].copy_from_slice(&src[body..]);
        // The streamed stores ordered before any later store (another
        // thread reads them after rayon's join).
        // SAFETY: SSE is part of x86-64.
        #[allow(unsafe_code)]
        unsafe {
            _mm_sfence()
        };
    }
    #[cfg(not(target_arch = "x86_64"))]
    dst.copy_from_slice(src);
}

/// Per 16-bit lane: (a·(256 − f) + b·f + 128) / 256 (a, b ≤ 255, f ≤ 256:
/// every sum fits the lane), `g` = 256 − f.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
#[inline]
fn lerp16(
    a: std::arch::x86_64::__m256i,
    b: std::arch::x86_64::__m256i,
    (f, g): (std::arch::x86_64::__m256i, std::arch::x86_64::__m256i),
) -> std::arch::x86_64::__m256i {
    use std::arch::x86_64::*;
    let s = _mm256_add_epi16(_mm256_mullo_epi16(a, g), _mm256_mullo_epi16(b, f));
    _mm256_srli_epi16::<8>(_mm256_add_epi16(s, _mm256_set1_epi16(128)))
}

/// [`Row::bilinear`]'s integers for eight pixels, one a 32-bit lane: the
/// top row's left and right pixels `t`, the bottom row's `b`, and the
/// weights `fx`, `fy` in both 16-bit halves of each lane; r and b (even
/// bytes), g and a (odd bytes) mixed in 16-bit lanes.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
#[inline]
fn mix8(
    t: (std::arch::x86_64::__m256i, std::arch::x86_64::__m256i),
    b: (std::arch::x86_64::__m256i, std::arch::x86_64::__m256i),
    fx: std::arch::x86_64::__m256i,
    fy: std::arch::x86_64::__m256i,
) -> std::arch::x86_64::__m256i {
    use std::arch::x86_64::*;
    let m = _mm256_set1_epi32(0x00ff_00ff);
    let one = _mm256_set1_epi16(256);
    let (wx, wy) = (
        (fx, _mm256_sub_epi16(one, fx)),
        (fy, _mm256_sub_epi16(one, fy)),
    );
    let row = |(l, r): (__m256i, __m256i)| {
        let rb = lerp16(_mm256_and_si256(l, m), _mm256_and_si256(r, m), wx);
        let ga = lerp16(_mm256_srli_epi16::<8>(l), _mm256_srli_epi16::<8>(r), wx);
        (rb, ga)
    };
    let (t, b) = (row(t), row(b));
    let (rb, ga) = (lerp16(t.0, b.0, wy), lerp16(t.1, b.1, wy));
    _mm256_or_si256(rb, _mm256_slli_epi16::<8>(ga))
}

/// [`Row::axis`]'s weight of unclamped fixed-point positions `s`, in both
/// 16-bit halves of each 32-bit lane.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
#[inline]
fn weight(s: std::arch::x86_64::__m256i) -> std::arch::x86_64::__m256i {
    use std::arch::x86_64::*;
    let r = _mm256_and_si256(s, _mm256_set1_epi32((1 << FRAC) - 1));
    let f = _mm256_srli_epi32::<8>(_mm256_add_epi32(r, _mm256_set1_epi32(1 << (FRAC - 9))));
    _mm256_or_si256(f, _mm256_slli_epi32::<16>(f))
}

/// The positions of eight pixels from `s0` stepping by `ds` (fixed point).
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
#[inline]
fn positions(s0: i32, ds: i32) -> std::arch::x86_64::__m256i {
    use std::arch::x86_64::*;
    let lanes = _mm256_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7);
    _mm256_add_epi32(
        _mm256_set1_epi32(s0),
        _mm256_mullo_epi32(_mm256_set1_epi32(ds), lanes),
    )
}

#[cfg(target_arch = "x86_64")]
impl Row<'_> {
    /// A segment's pixels eight at a time: a run ([`Self::run`]) by the
    /// contiguous kernel, else block by block ([`Self::blocks_avx2`]); how
    /// many it made (the rest are left to [`Self::pixel`]).
    #[target_feature(enable = "avx2")]
    #[inline]
    pub(super) fn segment_avx2(
        &self,
        start: (i32, i32),
        step: (i32, i32),
        out: &mut [u8],
    ) -> usize {
        let len = out.len() / 4;
        let run = if len == KNOT_PX as usize {
            self.run32(start, step)
        } else {
            self.run(start, step, len)
        };
        match run {
            Some(at) => self.run_avx2(at, start, step, out),
            None => self.blocks_avx2(start, step, out),
        }
    }

    /// A segment that is not a run, eight pixels at a time: a block whose
    /// eight pixels are a run ([`Self::run`]; a pan's segment that crosses
    /// a source row, or steps two pixels once, is mostly such blocks) by
    /// the contiguous kernel, one that reads a window ([`Self::window`]) by
    /// its kernel, the others by [`Self::general_avx2`]. Block b starts at
    /// the position of pixel 8b (the same integers as stepping from the
    /// segment's start, so the same bytes); how many it made.
    #[target_feature(enable = "avx2")]
    #[inline]
    fn blocks_avx2(&self, (u0, v0): (i32, i32), step: (i32, i32), out: &mut [u8]) -> usize {
        let mut done = 0;
        for (j, block) in (0i32..).step_by(8).zip(out.chunks_exact_mut(32)) {
            let at = (u0 + step.0 * j, v0 + step.1 * j);
            let made = if let Some(first) = self.run(at, step, 8) {
                self.run_avx2(first, at, step, block)
            } else if let Some(first) = self.window(at, step) {
                self.window_avx2(first, at, step, block)
            } else {
                self.general_avx2(at, step, block)
            };
            if made == 0 {
                break;
            }
            done += made;
        }
        done
    }

    /// A run's pixels ([`Self::run`], its first tap at source pixel `at`)
    /// eight at a time: the 2×2 pixels of eight as four plain loads (lanes
    /// in order) and the weights from the positions' fraction bits; how
    /// many it made.
    #[target_feature(enable = "avx2")]
    #[inline]
    fn run_avx2(
        &self,
        at: usize,
        (u0, v0): (i32, i32),
        (du, dv): (i32, i32),
        out: &mut [u8],
    ) -> usize {
        use std::arch::x86_64::*;
        let w = self.size.0 as usize;
        let n = out.len() / 32 * 8;
        // The last load ends at pixel at + n of the lower row.
        if self.src.len() < (at + w + n + 1) * 4 {
            return 0;
        }
        let (mut u, mut v) = (positions(u0, du), positions(v0, dv));
        let (su, sv) = (
            _mm256_set1_epi32(du.wrapping_mul(8)),
            _mm256_set1_epi32(dv.wrapping_mul(8)),
        );
        let top = self.src[at * 4..].as_ptr();
        for (k, px) in out.chunks_exact_mut(32).enumerate() {
            // SAFETY: pixels at + 8k … at + 8k + 8 of the row and the row
            // below lie inside `src` (its length checked above).
            #[allow(unsafe_code)]
            let load = |i: usize| unsafe { _mm256_loadu_si256(top.add((8 * k + i) * 4).cast()) };
            // The row the next output row reads below these, fetched early.
            _mm_prefetch::<_MM_HINT_T0>(top.wrapping_add((8 * k + 2 * w) * 4).cast());
            let bytes = mix8(
                (load(0), load(1)),
                (load(w), load(w + 1)),
                weight(u),
                weight(v),
            );
            // SAFETY: `px` is 32 bytes; storeu takes any alignment.
            #[allow(unsafe_code)]
            unsafe {
                _mm256_storeu_si256(px.as_mut_ptr().cast(), bytes)
            };
            (u, v) = (_mm256_add_epi32(u, su), _mm256_add_epi32(v, sv));
        }
        n
    }

    /// A window's eight pixels ([`Self::window`], the first tap at source
    /// pixel `at`): the 16 pixels from `at` of the row and the row below
    /// as four plain loads, each pixel's left and right pixels picked from
    /// them by its tap's offset from `at` (0 … 9: a lane permute of either
    /// half, blended), the weights from the positions' fraction bits.
    #[target_feature(enable = "avx2")]
    #[inline]
    fn window_avx2(
        &self,
        at: usize,
        (u0, v0): (i32, i32),
        (du, dv): (i32, i32),
        out: &mut [u8],
    ) -> usize {
        use std::arch::x86_64::*;
        let w = self.size.0 as usize;
        let Some(px) = out.get_mut(..32) else {
            return 0;
        };
        if self.src.len() < (at + w + 16) * 4 {
            return 0;
        }
        let (u, v) = (positions(u0, du), positions(v0, dv));
        let first = _mm256_set1_epi32(u0 >> FRAC);
        let left = _mm256_sub_epi32(_mm256_srai_epi32::<16>(u), first);
        let right = _mm256_add_epi32(left, _mm256_set1_epi32(1));
        let seven = _mm256_set1_epi32(7);
        let base = self.src[at * 4..].as_ptr();
        // SAFETY: pixels at … at + 16 of the row and the row below lie
        // inside `src` (its length checked above).
        #[allow(unsafe_code)]
        let load = |i: usize| unsafe { _mm256_loadu_si256(base.add(i * 4).cast()) };
        // Offset o's pixel: lane o of the first eight, or o − 8 of the next.
        let pick = |(lo, hi): (__m256i, __m256i), o: __m256i| {
            let upper = _mm256_cmpgt_epi32(o, seven);
            _mm256_blendv_epi8(
                _mm256_permutevar8x32_epi32(lo, o),
                _mm256_permutevar8x32_epi32(hi, o),
                upper,
            )
        };
        let (top, bottom) = ((load(0), load(8)), (load(w), load(w + 8)));
        let t = (pick(top, left), pick(top, right));
        let b = (pick(bottom, left), pick(bottom, right));
        let bytes = mix8(t, b, weight(u), weight(v));
        // SAFETY: `px` is 32 bytes; storeu takes any alignment.
        #[allow(unsafe_code)]
        unsafe {
            _mm256_storeu_si256(px.as_mut_ptr().cast(), bytes)
        };
        8
    }

    /// [`Self::axis`] and [`Self::bilinear`]'s integers for eight pixels at
    /// a time, any positions: the taps in `i32` lanes, each pixel's 2×2
    /// pixels loaded as two pairs, the left and right pixels split into two
    /// vectors (lanes in the order 0 1 4 5 2 3 6 7, the weights permuted
    /// alike and the result back); how many it made.
    #[target_feature(enable = "avx2")]
    #[inline]
    fn general_avx2(&self, (u0, v0): (i32, i32), (du, dv): (i32, i32), out: &mut [u8]) -> usize {
        use std::arch::x86_64::*;
        let (w, h) = (self.size.0 as i32, self.size.1 as i32);
        if w < 2 || h < 2 || self.src.len() < w as usize * h as usize * 4 {
            return 0;
        }
        let one = _mm256_set1_epi32(256);
        let axis = |s: __m256i, n: i32| {
            let top = _mm256_set1_epi32((n - 1) << FRAC);
            let s = _mm256_min_epi32(_mm256_max_epi32(s, _mm256_setzero_si256()), top);
            let i = _mm256_min_epi32(_mm256_srai_epi32::<16>(s), _mm256_set1_epi32(n - 2));
            let r = _mm256_sub_epi32(s, _mm256_slli_epi32::<16>(i));
            let r = _mm256_add_epi32(r, _mm256_set1_epi32(1 << (FRAC - 9)));
            (i, _mm256_min_epi32(_mm256_srai_epi32::<8>(r), one))
        };
        // Lanes 0 1 2 3 4 5 6 7 ↔ 0 1 4 5 2 3 6 7 (its own inverse).
        let swap = |x: __m256i| _mm256_permute4x64_epi64::<0b11_01_10_00>(x);
        let both = |f: __m256i| swap(_mm256_or_si256(f, _mm256_slli_epi32::<16>(f)));
        let base = self.src.as_ptr();
        let n = out.len() / 32 * 8;
        for (j, px) in (0..).step_by(8).zip(out.chunks_exact_mut(32)) {
            let u = positions(u0 + du * j, du);
            let v = positions(v0 + dv * j, dv);
            let ((x0, fx), (y0, fy)) = (axis(u, w), axis(v, h));
            let top = _mm256_add_epi32(_mm256_mullo_epi32(y0, _mm256_set1_epi32(w)), x0);
            let mut at = [0i32; 8];
            // SAFETY: `at` is 32 bytes; storeu takes any alignment.
            #[allow(unsafe_code)]
            unsafe {
                _mm256_storeu_si256(at.as_mut_ptr().cast(), top)
            };
            // SAFETY: 0 ≤ x0 ≤ w − 2 and 0 ≤ y0 ≤ h − 2 (`axis`) and `src`
            // holds w·h pixels (checked above), so the 8 bytes at pixel
            // y0·w + x0 and at the pixel below are inside it.
            #[allow(unsafe_code)]
            let pair = |i: i32| unsafe { base.add(i as usize * 4).cast::<i64>().read_unaligned() };
            let four = |k: usize, down: i32| {
                let p = |m: usize| pair(at[k + m] + down);
                _mm256_setr_epi64x(p(0), p(1), p(2), p(3))
            };
            // [l0 r0 l1 r1 | l2 r2 l3 r3], [l4 r4 …] → lefts and rights.
            let split = |a: __m256i, b: __m256i| {
                let (a, b) = (_mm256_castsi256_ps(a), _mm256_castsi256_ps(b));
                (
                    _mm256_castps_si256(_mm256_shuffle_ps::<0b10_00_10_00>(a, b)),
                    _mm256_castps_si256(_mm256_shuffle_ps::<0b11_01_11_01>(a, b)),
                )
            };
            let t = split(four(0, 0), four(4, 0));
            let b = split(four(0, w), four(4, w));
            let bytes = swap(mix8(t, b, both(fx), both(fy)));
            // SAFETY: `px` is 32 bytes; storeu takes any alignment.
            #[allow(unsafe_code)]
            unsafe {
                _mm256_storeu_si256(px.as_mut_ptr().cast(), bytes)
            };
        }
        n
    }
}

#[cfg(test)]
mod tests;

//! The rolling shutter's pixels (issue 41, `camera_model.rolling_shutter`):
//! row y of the picture shows the scene `readout · y / height` after the
//! first row. The pipeline (`pipeline/rolling.rs`) supplies the geometry:
//! where each output pixel's drone-free background comes from (the sky at
//! infinity turned by the camera's rotation, a homography per row) and how
//! far each drone's image has moved at each row's time. Here the background
//! is resampled row by row (bilinear in the bytes: positions stepped in
//! fixed point between knots, weights in 1/256, two channels to a word) and
//! each drone's difference against the drone-free frame,
//! D = lin(frame) − lin(background) in linear light (`motion::Difference`),
//! is moved row by row over it: out(p) = lin(B′(p)) + D(p − shift(row)).
//! A pixel in several drones' reach belongs to the first. Pixels no drone
//! reaches are the shuttered background's bytes.

use rayon::prelude::*;

use super::PixelRect;
use super::encode::{encode, encode_table};
use super::exposure::decode_table;
use super::motion::{Difference, lin};

/// Columns between the points where a row's background source is computed
/// exactly; linear in between (a homography's error over 32 px is under
/// 0.01 px for turns under a degree per readout).
pub const KNOT_PX: u32 = 32;

/// One drone under the rolling shutter.
#[derive(Clone, Debug, PartialEq)]
pub struct Shear {
    /// Where the drone is drawn in the rendered frame (its pixels differ
    /// from the drone-free frame only inside).
    pub rect: PixelRect,
    /// Per image row: how far the drone's image has moved at that row's
    /// time since the frame's time, pixels (x, y).
    pub shift_px: Vec<(f64, f64)>,
}

impl Shear {
    /// The output pixels the drone reaches: rows whose source row
    /// (y − shift) falls in its rect (one more for the bilinear tap), and
    /// its columns moved by those rows' shifts; `None` if none.
    pub fn reach(&self, width: u32, height: u32) -> Option<PixelRect> {
        let (lo, hi) = (f64::from(self.rect.y0) - 1.0, f64::from(self.rect.y1) + 1.0);
        let mut rows = (u32::MAX, 0u32);
        let mut cols = (f64::INFINITY, f64::NEG_INFINITY);
        for (y, &(sx, sy)) in (0..height).zip(&self.shift_px) {
            let source = f64::from(y) + 0.5 - sy;
            if source >= lo && source <= hi && sx.is_finite() {
                rows = (rows.0.min(y), rows.1.max(y + 1));
                cols = (cols.0.min(sx), cols.1.max(sx));
            }
        }
        if rows.0 >= rows.1 {
            return None;
        }
        let x0 = (f64::from(self.rect.x0) + cols.0 - 1.0).floor().max(0.0);
        let x1 = (f64::from(self.rect.x1) + cols.1 + 1.0).ceil().max(0.0);
        Some(PixelRect {
            x0: (x0.min(f64::from(width))) as u32,
            y0: rows.0,
            x1: (x1.min(f64::from(width))) as u32,
            y1: rows.1,
        })
    }
}

/// Where a row's pixels take the background from: called with the row's
/// centre `y` and the columns' centres `xs`, it fills `sources` (pixel
/// coordinates, one per column).
pub type RowSources<'a> = dyn Fn(f64, &[f64], &mut [(f64, f64)]) + Sync + 'a;

/// `background` (RGBA8, `width`×`height`) resampled row by row: output
/// pixel centre (x, y) takes the background at the row's source of x
/// (`sources`; clamped to the image), computed every [`KNOT_PX`] columns
/// and at the last, linear in between in fixed point, bilinear with
/// weights in 1/256 ([`Row::resample`]). Rows on rayon's threads, each with
/// its own knot buffer. A side under 2 or over
/// [`crate::preset::MAX_IMAGE_SIDE`], or a short `background`, is copied.
pub fn turn_background(
    background: &[u8],
    (width, height): (u32, u32),
    sources: &RowSources,
) -> Vec<u8> {
    let w = width as usize;
    // Fixed-point positions stay in `i32` up to the largest image side.
    let side = crate::preset::MAX_IMAGE_SIDE;
    if width < 2 || height < 2 || width.max(height) > side {
        return background.to_vec();
    }
    if background.len() < w * height as usize * 4 {
        return background.to_vec();
    }
    let mut out = vec![0u8; w * height as usize * 4];
    let knot_xs: Vec<u32> = knot_columns(width);
    let xs: Vec<f64> = knot_xs.iter().map(|&x| f64::from(x) + 0.5).collect();
    out.par_chunks_mut(w * 4).enumerate().for_each_init(
        || vec![(0.0, 0.0); xs.len()],
        |knots, (y, bytes)| {
            sources(y as f64 + 0.5, &xs, knots);
            let row = Row {
                src: background,
                size: (width, height),
            };
            row.resample(&knot_xs, knots, bytes);
        },
    );
    out
}

/// The columns where a row's source is computed: every [`KNOT_PX`] and the last.
fn knot_columns(width: u32) -> Vec<u32> {
    let mut knots: Vec<u32> = (0..width).step_by(KNOT_PX as usize).collect();
    if knots.last().is_some_and(|&x| x + 1 < width) {
        knots.push(width - 1);
    }
    knots
}

/// Fraction bits of a fixed-point source position (1/65536 px).
const FRAC: u32 = 16;

/// A pixel coordinate (a pixel's centre at +0.5) as the fixed-point
/// position on the tap grid (pixel centres at integers), clamped to
/// [−4096, 20480] px so that every sum stays in `i32` for images up to
/// [`crate::preset::MAX_IMAGE_SIDE`]; NaN to the first pixel.
#[inline(always)]
fn fixed(s: f64) -> i32 {
    ((s - 0.5).clamp(-4096.0, 20480.0) * f64::from(1u32 << FRAC)).round() as i32
}

/// One row's resampling from the whole `src` image (RGBA8, `size`, at
/// least 2×2 and `src` that long).
struct Row<'a> {
    src: &'a [u8],
    size: (u32, u32),
}

impl Row<'_> {
    /// The row's pixels (`out`, RGBA8) from its knots' sources (`knots`
    /// at columns `xs`): column x in the segment of knot
    /// min(x / KNOT_PX, last − 1), the last segment running to the row's
    /// end; the position stepped in fixed point along each segment, eight
    /// pixels at a time on AVX2 (the same integers, so the same bytes).
    fn resample(&self, xs: &[u32], knots: &[(f64, f64)], out: &mut [u8]) {
        let last = xs.len().saturating_sub(2);
        for k in 0..=last {
            let next = (k + 1).min(xs.len() - 1);
            let (a, b) = (knots[k], knots[next]);
            let span = xs[next].saturating_sub(xs[k]).max(1) as i32;
            let (u0, v0) = (fixed(a.0), fixed(a.1));
            let step = ((fixed(b.0) - u0) / span, (fixed(b.1) - v0) / span);
            let from = k * KNOT_PX as usize;
            let to = if k == last {
                out.len() / 4
            } else {
                from + KNOT_PX as usize
            };
            let Some(pixels) = out.get_mut(from * 4..to * 4) else {
                return;
            };
            let done = self.segment_simd((u0, v0), step, pixels);
            for (j, px) in (done as i32..).zip(pixels[done * 4..].chunks_exact_mut(4)) {
                px.copy_from_slice(&self.pixel((u0, v0), step, j).to_le_bytes());
            }
        }
    }

    /// Pixel `j` of a segment starting at `start` and stepping by `step`
    /// (fixed point), in scalar integers.
    #[inline(always)]
    fn pixel(&self, (u0, v0): (i32, i32), (du, dv): (i32, i32), j: i32) -> u32 {
        self.bilinear(self.axis(u0 + du * j, 0), self.axis(v0 + dv * j, 1))
    }

    /// A fixed-point position on `axis` (0: x, 1: y) as its first tap's
    /// index and the second's weight in 1/256, clamped to the image.
    #[inline(always)]
    fn axis(&self, s: i32, axis: usize) -> (u32, u32) {
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

    /// The segment's pixels eight at a time where the CPU has AVX2 (the
    /// rest by [`Self::bilinear`]); how many it made. A run
    /// ([`Self::run`]) takes the contiguous kernel; a segment that is not
    /// one goes block by block ([`Self::blocks_avx2`]).
    #[inline(always)]
    fn segment_simd(&self, start: (i32, i32), step: (i32, i32), out: &mut [u8]) -> usize {
        #[cfg(target_arch = "x86_64")]
        if super::simd::simd_level() >= 1 {
            let run = self.run(start, step, out.len() / 4);
            // SAFETY: the CPU has AVX2 (checked by `simd_level`).
            #[allow(unsafe_code)]
            unsafe {
                return match run {
                    Some(at) => self.run_avx2(at, start, step, out),
                    None => self.blocks_avx2(start, step, out),
                };
            }
        }
        let _ = (start, step, out);
        0
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
    fn run(&self, (u0, v0): (i32, i32), (du, dv): (i32, i32), len: usize) -> Option<usize> {
        let last = i64::try_from(len).ok()?.checked_sub(1).filter(|&l| l > 0)?;
        let (w, h) = (i64::from(self.size.0), i64::from(self.size.1));
        // A tap index of fixed-point `s` where unclamped, else None.
        let tap = |s: i64, n: i64| (s >= 0 && (s >> FRAC) <= n - 2).then_some(s >> FRAC);
        let (u0, v0) = (i64::from(u0), i64::from(v0));
        let (x0, x1) = (tap(u0, w)?, tap(u0 + i64::from(du) * last, w)?);
        let (y0, y1) = (tap(v0, h)?, tap(v0 + i64::from(dv) * last, h)?);
        (x1 - x0 == last && y0 == y1).then_some((y0 * w + x0) as usize)
    }

    /// [`Self::axis`] and [`Self::bilinear`]'s integers for eight pixels:
    /// the taps in `i32` lanes, each pixel's 2×2 pixels loaded as two pairs,
    /// the left and right pixels split into two vectors (lanes in the order
    /// 0 1 4 5 2 3 6 7, the weights permuted alike and the result back),
    /// the two mixes in 16-bit lanes, two channels to a lane.
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2")]
    fn segment_avx2(&self, (u0, v0): (i32, i32), (du, dv): (i32, i32), out: &mut [u8]) -> usize {
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
        let (m, half) = (_mm256_set1_epi32(0x00ff_00ff), _mm256_set1_epi16(128));
        // Per 16-bit lane: (a·(256 − f) + b·f + 128) / 256, f in both halves.
        let lerp = |a: __m256i, b: __m256i, f: __m256i| {
            let g = _mm256_sub_epi16(_mm256_set1_epi16(256), f);
            let s = _mm256_add_epi16(_mm256_mullo_epi16(a, g), _mm256_mullo_epi16(b, f));
            _mm256_srli_epi16::<8>(_mm256_add_epi16(s, half))
        };
        // Lanes 0 1 2 3 4 5 6 7 ↔ 0 1 4 5 2 3 6 7 (its own inverse).
        let swap = |x: __m256i| _mm256_permute4x64_epi64::<0b11_01_10_00>(x);
        let both = |f: __m256i| swap(_mm256_or_si256(f, _mm256_slli_epi32::<16>(f)));
        let lanes = _mm256_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7);
        let base = self.src.as_ptr();
        let n = out.len() / 32 * 8;
        for (j, px) in (0..).step_by(8).zip(out.chunks_exact_mut(32)) {
            let j = _mm256_add_epi32(_mm256_set1_epi32(j), lanes);
            let u = _mm256_mullo_epi32(_mm256_set1_epi32(du), j);
            let v = _mm256_mullo_epi32(_mm256_set1_epi32(dv), j);
            let u = _mm256_add_epi32(_mm256_set1_epi32(u0), u);
            let v = _mm256_add_epi32(_mm256_set1_epi32(v0), v);
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
            let (fx, fy) = (both(fx), both(fy));
            let row = |(l, r): (__m256i, __m256i)| {
                let rb = lerp(_mm256_and_si256(l, m), _mm256_and_si256(r, m), fx);
                let ga = lerp(_mm256_srli_epi16::<8>(l), _mm256_srli_epi16::<8>(r), fx);
                (rb, ga)
            };
            let t = row(split(four(0, 0), four(4, 0)));
            let b = row(split(four(0, w), four(4, w)));
            let (rb, ga) = (lerp(t.0, b.0, fy), lerp(t.1, b.1, fy));
            let bytes = swap(_mm256_or_si256(rb, _mm256_slli_epi16::<8>(ga)));
            let mut word = [0u8; 32];
            // SAFETY: `word` is 32 bytes; storeu takes any alignment.
            #[allow(unsafe_code)]
            unsafe {
                _mm256_storeu_si256(word.as_mut_ptr().cast(), bytes)
            };
            px.copy_from_slice(&word);
        }
        n
    }
}

impl Row<'_> {
    /// A segment that is not a run, eight pixels at a time: a block whose
    /// eight pixels are a run ([`Self::run`]; a pan's segment that crosses
    /// a source row, or steps two pixels once, is mostly such blocks) by
    /// the contiguous kernel, the others by [`Self::segment_avx2`]. Block
    /// b starts at the position of pixel 8b (the same integers as stepping
    /// from the segment's start, so the same bytes); how many it made.
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2")]
    fn blocks_avx2(&self, (u0, v0): (i32, i32), (du, dv): (i32, i32), out: &mut [u8]) -> usize {
        let mut done = 0;
        for (j, block) in (0i32..).step_by(8).zip(out.chunks_exact_mut(32)) {
            let at = (u0 + du * j, v0 + dv * j);
            let made = match self.run(at, (du, dv), 8) {
                Some(first) => self.run_avx2(first, at, (du, dv), block),
                None => self.segment_avx2(at, (du, dv), block),
            };
            if made == 0 {
                break;
            }
            done += made;
        }
        done
    }

    /// A run's pixels ([`Self::run`], its first tap at source pixel `at`)
    /// eight at a time: [`Self::segment_avx2`]'s integers with the 2×2
    /// pixels of eight as four plain loads (lanes in order) and the weights
    /// from the positions' fraction bits; how many it made.
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2")]
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
        let (m, half) = (_mm256_set1_epi32(0x00ff_00ff), _mm256_set1_epi16(128));
        let lerp = |a: __m256i, b: __m256i, f: __m256i| {
            let g = _mm256_sub_epi16(_mm256_set1_epi16(256), f);
            let s = _mm256_add_epi16(_mm256_mullo_epi16(a, g), _mm256_mullo_epi16(b, f));
            _mm256_srli_epi16::<8>(_mm256_add_epi16(s, half))
        };
        // [`Self::axis`]'s weight of an unclamped position, in both halves
        // of each 32-bit lane.
        let weight = |s: __m256i| {
            let r = _mm256_and_si256(s, _mm256_set1_epi32((1 << FRAC) - 1));
            let f = _mm256_srli_epi32::<8>(_mm256_add_epi32(r, _mm256_set1_epi32(1 << (FRAC - 9))));
            _mm256_or_si256(f, _mm256_slli_epi32::<16>(f))
        };
        let lanes = _mm256_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7);
        let mut u = _mm256_add_epi32(
            _mm256_set1_epi32(u0),
            _mm256_mullo_epi32(_mm256_set1_epi32(du), lanes),
        );
        let mut v = _mm256_add_epi32(
            _mm256_set1_epi32(v0),
            _mm256_mullo_epi32(_mm256_set1_epi32(dv), lanes),
        );
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
            let (fx, fy) = (weight(u), weight(v));
            let row = |l: __m256i, r: __m256i| {
                let rb = lerp(_mm256_and_si256(l, m), _mm256_and_si256(r, m), fx);
                let ga = lerp(_mm256_srli_epi16::<8>(l), _mm256_srli_epi16::<8>(r), fx);
                (rb, ga)
            };
            let (t, b) = (row(load(0), load(1)), row(load(w), load(w + 1)));
            let (rb, ga) = (lerp(t.0, b.0, fy), lerp(t.1, b.1, fy));
            let bytes = _mm256_or_si256(rb, _mm256_slli_epi16::<8>(ga));
            // SAFETY: `px` is 32 bytes; storeu takes any alignment.
            #[allow(unsafe_code)]
            unsafe {
                _mm256_storeu_si256(px.as_mut_ptr().cast(), bytes)
            };
            (u, v) = (_mm256_add_epi32(u, su), _mm256_add_epi32(v, sv));
        }
        n
    }
}

/// The shuttered picture: `turned` (the drone-free frame under the
/// shutter, [`turn_background`] or the rendered one when the camera holds
/// still) with each drone of `shears` moved row by row, its difference
/// taken between `frame` and `background` (the rendered frame and its
/// drone-free frame). All RGBA8, `width`×`height`; alpha is `turned`'s.
pub fn shear(
    frame: &[u8],
    background: &[u8],
    turned: &[u8],
    (width, height): (u32, u32),
    shears: &[Shear],
) -> Vec<u8> {
    let mut out = turned.to_vec();
    let n = width as usize * height as usize * 4;
    if frame.len() < n || background.len() < n || turned.len() < n {
        return out;
    }
    let (dec, enc) = (decode_table(), encode_table());
    let mut owned: Vec<PixelRect> = Vec::new();
    let inside = |o: &PixelRect, x: u32, y: u32| x >= o.x0 && x < o.x1 && y >= o.y0 && y < o.y1;
    for s in shears {
        let Some(reach) = s.reach(width, height) else {
            continue;
        };
        let diff = Difference::of(frame, background, width, height, s.rect, &[]);
        let region = union(reach, s.rect, width, height);
        for y in region.y0..region.y1 {
            let (sx, sy) = s.shift_px.get(y as usize).copied().unwrap_or((0.0, 0.0));
            for x in region.x0..region.x1 {
                if owned.iter().any(|o| inside(o, x, y)) {
                    continue;
                }
                let i = (y as usize * width as usize + x as usize) * 4;
                let (qx, qy) = (f64::from(x) + 0.5 - sx, f64::from(y) + 0.5 - sy);
                for c in 0..3 {
                    let d = diff.as_ref().map_or(0.0, |d| d.sample(qx, qy, c));
                    if d != 0.0 {
                        let v = lin(dec, turned, i + c) + d;
                        out[i + c] = encode(enc, v.clamp(0.0, 1.0));
                    }
                }
            }
        }
        owned.push(region);
    }
    out
}

/// The smallest rect holding `a` and `b`, clamped to the image.
fn union(a: PixelRect, b: PixelRect, width: u32, height: u32) -> PixelRect {
    PixelRect {
        x0: a.x0.min(b.x0).min(width),
        y0: a.y0.min(b.y0).min(height),
        x1: a.x1.max(b.x1).min(width),
        y1: a.y1.max(b.y1).min(height),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A 64×48 sky-blue frame with a 4×20 dark drone at (30, 10).
    fn frames() -> (Vec<u8>, Vec<u8>, (u32, u32)) {
        let (w, h) = (64u32, 48u32);
        let background: Vec<u8> = (0..w * h).flat_map(|_| [120, 160, 220, 255]).collect();
        let mut frame = background.clone();
        for y in 10..30 {
            for x in 30..34 {
                let i = ((y * w + x) * 4) as usize;
                frame[i..i + 3].copy_from_slice(&[20, 20, 20]);
            }
        }
        (frame, background, (w, h))
    }

    #[test]
    fn a_drone_moved_by_a_whole_pixel_per_row_is_a_sheared_copy() {
        let (frame, background, (w, h)) = frames();
        // Row y shows the drone moved right by y/4 px: rows 10..30 → +2.5…+7.25.
        let shift: Vec<(f64, f64)> = (0..h).map(|y| (f64::from(y / 4), 0.0)).collect();
        let s = Shear {
            rect: PixelRect {
                x0: 28,
                y0: 8,
                x1: 36,
                y1: 32,
            },
            shift_px: shift,
        };
        let out = shear(&frame, &background, &background, (w, h), &[s]);
        for y in 0..h {
            let dark: Vec<u32> = (0..w)
                .filter(|&x| out[((y * w + x) * 4) as usize] < 60)
                .collect();
            if (10..30).contains(&y) {
                let x0 = 30 + y / 4;
                assert_eq!(dark, (x0..x0 + 4).collect::<Vec<_>>(), "row {y}");
            } else {
                assert!(dark.is_empty(), "row {y}: {dark:?}");
            }
        }
    }

    #[test]
    fn the_simd_segment_gives_the_scalar_bytes_and_the_bilinear_mix() {
        // A 40×30 image of mixed bytes; segments crossing every edge.
        let (w, h) = (40u32, 30u32);
        let src: Vec<u8> = (0..w * h * 4).map(|i| (i * 37 % 251) as u8).collect();
        let row = Row {
            src: &src,
            size: (w, h),
        };
        for (start, step) in [
            ((-3.3, -2.0), (0.37, 0.11)),
            ((5.71, 3.2), (1.003, -0.019)),
            ((30.2, 27.9), (0.9, 0.08)),
        ] {
            let (u0, v0) = (fixed(start.0), fixed(start.1));
            let d = (fixed(start.0 + step.0) - u0, fixed(start.1 + step.1) - v0);
            let mut out = vec![0u8; 32 * 4];
            let done = row.segment_simd((u0, v0), d, &mut out);
            for (j, px) in (0..).zip(out.chunks_exact(4)) {
                let want = row.pixel((u0, v0), d, j).to_le_bytes();
                if (j as usize) < done {
                    assert_eq!(px, want, "pixel {j} of {start:?}");
                }
                // The integers are the bilinear mix within 2 levels: two
                // roundings and weights in 1/256 (≤ 1/512 px each way, here
                // between neighbours up to 250 levels apart).
                let (u, v) = (
                    start.0 + step.0 * f64::from(j),
                    start.1 + step.1 * f64::from(j),
                );
                let clamp = |s: f64, n: u32| (s - 0.5).clamp(0.0, f64::from(n - 1));
                let (x, y) = (clamp(u, w), clamp(v, h));
                let (x0, y0) = ((x.floor() as u32).min(w - 2), (y.floor() as u32).min(h - 2));
                let (fx, fy) = (x - f64::from(x0), y - f64::from(y0));
                for c in 0..4 {
                    let at = |x: u32, y: u32| f64::from(src[((y * w + x) * 4) as usize + c]);
                    let top = at(x0, y0) * (1.0 - fx) + at(x0 + 1, y0) * fx;
                    let bottom = at(x0, y0 + 1) * (1.0 - fx) + at(x0 + 1, y0 + 1) * fx;
                    let exact = top * (1.0 - fy) + bottom * fy;
                    let got = f64::from(want[c]);
                    assert!(
                        (got - exact).abs() <= 1.5,
                        "pixel {j} channel {c}: {got} vs {exact}"
                    );
                }
            }
        }
    }

    /// Segments along a pan (about a pixel a pixel, a slight slope) and
    /// off every edge: where [`Row::run`] says run, every pixel's taps are
    /// the run's, a segment that is not one has blocks that are (its
    /// block-by-block path), and the SIMD kernels give the scalar bytes
    /// either way.
    #[test]
    fn a_run_is_consecutive_taps_and_its_kernel_gives_the_scalar_bytes() {
        let (w, h) = (70u32, 40u32);
        let src: Vec<u8> = (0..w * h * 4).map(|i| (i * 53 % 253) as u8).collect();
        let row = Row {
            src: &src,
            size: (w, h),
        };
        let (mut runs, mut run_blocks) = (0, 0);
        for k in 0..400 {
            let k = f64::from(k);
            let start = ((k * 7.31) % 90.0 - 10.0, (k * 3.17) % 48.0 - 4.0);
            let step = (
                1.0 + ((k * 0.37) % 1.0 - 0.5) * 0.01,
                ((k * 0.61) % 1.0 - 0.5) * 0.02,
            );
            let (u0, v0) = (fixed(start.0), fixed(start.1));
            let d = (fixed(start.0 + step.0) - u0, fixed(start.1 + step.1) - v0);
            let len = [32, 37, 9][k as usize % 3];
            let blocks = (0..len as i32 / 8).filter(|b| {
                let at = (u0 + d.0 * 8 * b, v0 + d.1 * 8 * b);
                row.run(at, d, 8).is_some()
            });
            if let Some(at) = row.run((u0, v0), d, len) {
                runs += 1;
                for j in 0..len as i32 {
                    let (x, y) = (row.axis(u0 + d.0 * j, 0), row.axis(v0 + d.1 * j, 1));
                    assert_eq!((y.0 * w + x.0) as usize, at + j as usize, "segment {k}");
                }
            } else {
                // Not a run: its blocks that are go by the contiguous kernel.
                run_blocks += blocks.count();
            }
            let mut out = vec![0u8; len * 4];
            let done = row.segment_simd((u0, v0), d, &mut out);
            for (j, px) in (0..done as i32).zip(out.chunks_exact(4)) {
                let want = row.pixel((u0, v0), d, j).to_le_bytes();
                assert_eq!(px, want, "pixel {j} of segment {k}");
            }
        }
        assert!(runs > 100, "{runs} runs");
        assert!(
            run_blocks > 100,
            "{run_blocks} run blocks in other segments"
        );
    }

    #[test]
    fn a_still_drone_and_background_keep_every_byte() {
        let (frame, background, (w, h)) = frames();
        let s = Shear {
            rect: PixelRect {
                x0: 28,
                y0: 8,
                x1: 36,
                y1: 32,
            },
            shift_px: vec![(0.0, 0.0); h as usize],
        };
        assert_eq!(shear(&frame, &background, &background, (w, h), &[s]), frame);
        let still = turn_background(&frame, (w, h), &|y, xs, out| {
            for (o, &x) in out.iter_mut().zip(xs) {
                *o = (x, y);
            }
        });
        assert_eq!(still, frame);
    }
}

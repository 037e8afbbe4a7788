//! The image processor's sharpening (an unsharp mask, as consumer cameras
//! apply before JPEG): the last step of the chain, on the 8-bit
//! sRGB-encoded picture, on luma only (every channel moves by the same
//! amount, so no colour fringes appear):
//!
//! `out = c + round(amount · core(Y − blur(Y)))`, clamped to [0, 255],
//!
//! with `Y = (77 R + 150 G + 29 B) / 256`, `blur` the 3×3 binomial kernel
//! ([1 2 1] ⊗ [1 2 1] / 16, edges clamped) and `core(d)` = `d` moved one
//! level toward 0 (0 within a level): detail smaller than a level, noise and
//! rounding steps, is not sharpened. Integer arithmetic
//! throughout, so the bytes are the same on every machine; `amount` is
//! taken in steps of 1/256. Each output pixel reads the pixels around it
//! one step away: the chain's reach grows by one pixel.

use rayon::prelude::*;

use super::PixelRect;

/// The largest `amount`: the integer arithmetic below stays within i32 up to it.
use crate::preset::camera_model::MAX_SHARPEN as MAX_AMOUNT;

/// Luma detail below this (one 8-bit level, in the units of `detail`
/// below: ·256·16) is left alone and larger detail is reduced by it
/// ("coring", as image processors do): noise, and the ±1 steps of a smooth
/// gradient's 8-bit rounding, are not sharpened.
const CORING: i32 = 256 * 16;

/// The pixels of `out` (RGBA8, row by row) sharpened by `amount`, from
/// `px`: the unsharpened pixels (RGBA8, row by row) of `grown`, which is
/// `out` grown by one pixel on every side that is not the image's edge.
pub(super) fn sharpen(px: &[u8], grown: PixelRect, out: PixelRect, amount: f64) -> Vec<u8> {
    let (gw, gh) = (
        (grown.x1 - grown.x0) as usize,
        (grown.y1 - grown.y0) as usize,
    );
    let (ow, oh) = ((out.x1 - out.x0) as usize, (out.y1 - out.y0) as usize);
    if gw == 0 || gh == 0 || ow == 0 || oh == 0 || px.len() < gw * gh * 4 {
        return Vec::new();
    }
    let window = Window {
        px,
        size: (gw, gh),
        origin: ((out.x0 - grown.x0) as usize, (out.y0 - grown.y0) as usize),
        width: ow,
        amount: (amount.clamp(0.0, MAX_AMOUNT) * 256.0).round() as i32,
    };
    // In bands of rows on rayon's threads (each row depends only on the
    // three around it in `px`, so any split gives the same bytes).
    let mut result = vec![0u8; ow * oh * 4];
    result
        .par_chunks_mut(ow * 4 * BAND)
        .enumerate()
        .for_each(|(b, band)| window.rows_into(b * BAND, band));
    result
}

/// Output rows in a band of [`sharpen`].
const BAND: usize = 64;

/// What [`sharpen`] reads: the unsharpened pixels of `grown` (`size`), where
/// `out` starts in it (`origin`), `out`'s width, and the amount (·256).
struct Window<'a> {
    px: &'a [u8],
    size: (usize, usize),
    origin: (usize, usize),
    width: usize,
    amount: i32,
}

impl Window<'_> {
    /// Luma of row `y` of `grown` at `out`'s columns, with one neighbour each
    /// side (clamped at the image's edge, which is `grown`'s there), into
    /// `padded`; and the horizontal [1 2 1] sums at `out`'s columns into `sums`.
    fn across(&self, y: usize, padded: &mut [i32], sums: &mut Vec<i32>) {
        let ((gw, gh), (dx, _), ow) = (self.size, self.origin, self.width);
        let row = &self.px[y.min(gh - 1) * gw * 4..][..gw * 4];
        let luma = |p: &[u8]| 77 * i32::from(p[0]) + 150 * i32::from(p[1]) + 29 * i32::from(p[2]);
        let (left, right) = (dx.saturating_sub(1), (dx + ow).min(gw - 1));
        padded[0] = luma(&row[left * 4..left * 4 + 4]);
        padded[ow + 1] = luma(&row[right * 4..right * 4 + 4]);
        for (l, p) in padded[1..=ow].iter_mut().zip(row[dx * 4..].chunks_exact(4)) {
            *l = luma(p);
        }
        sums.clear();
        sums.extend(padded.windows(3).map(|w| w[0] + 2 * w[1] + w[2]));
    }

    /// Output rows `first`… into `band` (RGBA8 rows of `out`).
    fn rows_into(&self, first: usize, band: &mut [u8]) {
        let ((gw, _), (dx, dy), ow) = (self.size, self.origin, self.width);
        let mut pads = [vec![0i32; ow + 2], vec![0i32; ow + 2], vec![0i32; ow + 2]];
        let mut sums = [Vec::new(), Vec::new(), Vec::new()];
        let y0 = dy + first;
        let [p0, p1, p2] = &mut pads;
        let [s0, s1, s2] = &mut sums;
        self.across(y0.saturating_sub(1), p0, s0);
        self.across(y0, p1, s1);
        let mut delta = vec![0i32; ow];
        // Per byte of a row: the pixel's delta on R, G and B, 0 on alpha.
        let mut per_byte = vec![0i32; ow * 4];
        for (k, line) in band.chunks_exact_mut(ow * 4).enumerate() {
            let y = y0 + k;
            self.across(y + 1, p2, s2);
            for ((d, &l), ((&a, &b), &c)) in
                (delta.iter_mut().zip(&p1[1..=ow])).zip(s0.iter().zip(s1.iter()).zip(s2.iter()))
            {
                // Y·256·16 minus its blur (·256·16): within ±16·65 280; cored
                // (without branches: the part past ±CORING); × amount·256
                // (≤ 1 024): within i32; rounded half up.
                let detail = 16 * l - (a + 2 * b + c);
                let cored = (detail - CORING).max(0) + (detail + CORING).min(0);
                *d = (self.amount * cored + (1 << 19)) >> 20;
            }
            for (q, &d) in per_byte.chunks_exact_mut(4).zip(&delta) {
                q.copy_from_slice(&[d, d, d, 0]);
            }
            let row = &self.px[(y * gw + dx) * 4..(y * gw + dx + ow) * 4];
            for ((o, &p), &d) in line.iter_mut().zip(row).zip(&per_byte) {
                *o = (i32::from(p) + d).clamp(0, 255) as u8;
            }
            // Roll the three rows down by one.
            std::mem::swap(p0, p1);
            std::mem::swap(p1, p2);
            std::mem::swap(s0, s1);
            std::mem::swap(s1, s2);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn rect(x0: u32, y0: u32, x1: u32, y1: u32) -> PixelRect {
        PixelRect { x0, y0, x1, y1 }
    }

    /// A `w`×`h` grey frame with a vertical step from `dark` to `light` at column `edge`.
    fn step(w: u32, h: u32, edge: u32, dark: u8, light: u8) -> Vec<u8> {
        (0..h)
            .flat_map(|_| (0..w).map(|x| if x < edge { dark } else { light }))
            .flat_map(|v| [v, v, v, 255])
            .collect()
    }

    #[test]
    fn a_step_overshoots_on_both_sides_and_flat_areas_stay() {
        let (w, h) = (12, 6);
        let px = step(w, h, 6, 100, 150);
        let whole = rect(0, 0, w, h);
        let out = sharpen(&px, whole, whole, 1.0);
        let at = |x: usize, y: usize| out[(y * w as usize + x) * 4];
        // Y − blur beside the step: ∓ 50 · 4/16 = ∓ 12.5, cored to ∓ 11.5,
        // rounded half up.
        assert_eq!(at(5, 3), 100 - 11, "dark side undershoots");
        assert_eq!(at(6, 3), 150 + 12, "light side overshoots");
        assert_eq!(at(1, 3), 100);
        assert_eq!(at(10, 0), 150);
        // Grey stays grey (luma only), alpha is kept.
        assert!(
            out.chunks_exact(4)
                .all(|p| p[0] == p[1] && p[1] == p[2] && p[3] == 255)
        );
        // No sharpening: the same bytes.
        assert_eq!(sharpen(&px, whole, whole, 0.0), px);
    }

    /// The pixels of `r` of a `w`-wide RGBA8 frame, row by row.
    fn crop(frame: &[u8], w: u32, r: PixelRect) -> Vec<u8> {
        (r.y0..r.y1)
            .flat_map(|y| {
                frame[((y * w + r.x0) * 4) as usize..((y * w + r.x1) * 4) as usize].to_vec()
            })
            .collect()
    }

    #[test]
    fn a_window_grown_by_one_gives_the_whole_frames_bytes() {
        let (w, h) = (20u32, 14u32);
        let px: Vec<u8> = (0..w * h * 4)
            .map(|i| (i.wrapping_mul(2_654_435_761) >> 24) as u8)
            .collect();
        let whole = rect(0, 0, w, h);
        let all = sharpen(&px, whole, whole, 2.5);
        for out in [
            rect(3, 2, 9, 7),
            rect(0, 0, 5, 4),
            rect(15, 9, 20, 14),
            whole,
        ] {
            let grown = rect(
                out.x0.saturating_sub(1),
                out.y0.saturating_sub(1),
                (out.x1 + 1).min(w),
                (out.y1 + 1).min(h),
            );
            let got = sharpen(&crop(&px, w, grown), grown, out, 2.5);
            assert_eq!(got, crop(&all, w, out), "{out:?}");
        }
    }

    #[test]
    fn detail_under_a_level_is_left_alone() {
        // A one-level step: Y − blur is ±0.25 beside it, under the coring.
        let (w, h) = (10, 5);
        let px = step(w, h, 5, 120, 121);
        let whole = rect(0, 0, w, h);
        assert_eq!(sharpen(&px, whole, whole, MAX_AMOUNT), px);
    }

    #[test]
    fn the_largest_amount_on_the_largest_step_stays_in_range() {
        let (w, h) = (8, 8);
        let px = step(w, h, 4, 0, 255);
        let whole = rect(0, 0, w, h);
        let out = sharpen(&px, whole, whole, MAX_AMOUNT + 10.0);
        let at = |x: usize| out[(3 * w as usize + x) * 4];
        assert_eq!((at(3), at(4)), (0, 255), "clamped, not wrapped");
    }
}

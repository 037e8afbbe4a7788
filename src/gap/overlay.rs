//! Burnt-in overlays: a camera's on-screen text, date and reticle drawn into the frames
//! (surveillance and thermal cameras do), found per frame and left out of every statistic
//! on both sides of the report, so that the statistics describe the scene and the camera
//! rather than the overlay's font.
//!
//! The rule ([`detect`]), on the luminance plane in 8-bit levels:
//!
//! - only **grey frames** ([`super::measure::is_grey`]: thermal and monochrome cameras,
//!   which burn their text in): in a colour frame thin dark strokes are branches and
//!   wires against the sky, and colour frames are measured as they always were;
//! - a **stroke pixel** is near-saturated (≥ [`BRIGHT`] levels, or ≤ [`DARK`]) and thin:
//!   along x or along y, both pixels [`STROKE_REACH_PX`] px away differ from it by at least
//!   [`STROKE_CONTRAST`] levels on the other side (darker for a bright stroke; beyond the
//!   frame's edge counts as differing, so a line along the border qualifies), so a line
//!   or glyph stroke up to 5 px wide qualifies and a saturated area (a hot roof, the sun's
//!   disc) does not;
//! - stroke pixels within 8 px of a labelled box are not (a drone's arms may be hot, thin
//!   and saturated);
//! - a stroke pixel counts only in a group (8-connected) of at least [`MIN_STROKE_PX`]
//!   pixels: text and reticle lines are long; isolated bright specks (a glint, a bright
//!   pixel of foliage) are not overlay;
//! - **text** is filled in ([`fill_text`]): thin near-saturated pixels (strokes, not
//!   areas: [`THIN_PX`]) chained to the strokes by steps of at most [`TEXT_JOIN_PX`] join
//!   them (the cores of dense glyphs, e.g. CJK
//!   characters, whose strokes lie too close together to stand out one by one), and a
//!   group so joined that covers at least [`TEXT_FILL_SHARE`] of its bounding box (a line
//!   of text; a reticle's sparse lines do not) is overlay over its whole box, its
//!   anti-aliased and mid-grey glyph pixels with it;
//! - the overlay is those pixels grown by [`GROW_PX`] px (the glyphs' anti-aliased and
//!   JPEG-ringing halo); the gradient statistics, measured at 540 px high after
//!   smoothing, leave out [`GROW_WIDE_PX`] px around them ([`Overlay::wide`]).
//!
//! A frame without overlay pixels is measured exactly as before (no statistic changes by a
//! bit). Limits: a thin saturated part of the scene (a hot cable against a cold sky) is
//! taken for overlay, and thin saturated structures within [`TEXT_JOIN_PX`] of the text; an
//! overlay in mid-grey (not near-saturated) is not found.

use super::measure::{Luma, PixelBox};

/// A bright stroke pixel's least luminance (levels).
pub const BRIGHT: f32 = 230.0;
/// A dark stroke pixel's greatest luminance (levels).
pub const DARK: f32 = 25.0;
/// How far (px) on either side a stroke's surroundings are looked at.
pub const STROKE_REACH_PX: usize = 3;
/// How much (levels) a stroke stands out from its surroundings on both sides.
pub const STROKE_CONTRAST: f32 = 50.0;
/// Least size (pixels) of a connected group of stroke pixels.
pub const MIN_STROKE_PX: usize = 24;
/// Growth of the stroke pixels into the overlay left out of the pixel statistics.
pub const GROW_PX: usize = 2;
/// Growth left out of the 540 px gradient statistics (Sobel, Canny's smoothing).
pub const GROW_WIDE_PX: usize = 5;
/// How far (px) stroke pixels are joined into one line of text.
pub const TEXT_JOIN_PX: usize = 6;
/// How near (px) on both sides, along x or y, a thin pixel's run of near-saturated
/// pixels ends (runs of up to 2 · THIN_PX − 1 px: strokes, not areas).
pub const THIN_PX: usize = 3;
/// The least share of its bounding box a joined group covers to be filled as text.
pub const TEXT_FILL_SHARE: f64 = 0.5;

/// A frame's overlay: which pixels the statistics leave out.
#[derive(Clone, Debug)]
pub struct Overlay {
    pub width: usize,
    pub height: usize,
    /// The stroke pixels found (before growing).
    pub strokes: usize,
    /// Stroke pixels grown by [`GROW_PX`].
    near: Vec<bool>,
    /// Stroke pixels grown by [`GROW_WIDE_PX`].
    wide: Vec<bool>,
}

impl Overlay {
    /// Whether pixel (x, y) is overlay (or within [`GROW_PX`] of it).
    #[inline]
    pub fn at(&self, x: usize, y: usize) -> bool {
        self.near[y * self.width + x]
    }

    /// The overlay grown by [`GROW_PX`], row-major.
    pub fn near(&self) -> &[bool] {
        &self.near
    }

    /// Whether a pixel of a `w` × `h` resampling of the frame (the 540 px plane) lies
    /// within [`GROW_WIDE_PX`] of overlay: its centre mapped back to the frame.
    pub fn wide_at(&self, x: usize, y: usize, w: usize, h: usize) -> bool {
        let sx = ((x as f64 + 0.5) * self.width as f64 / w.max(1) as f64) as usize;
        let sy = ((y as f64 + 0.5) * self.height as f64 / h.max(1) as f64) as usize;
        self.wide[sy.min(self.height - 1) * self.width + sx.min(self.width - 1)]
    }

    /// The mask of a `w` × `h` resampling ([`Overlay::wide_at`]), row-major.
    pub fn wide_mask(&self, w: usize, h: usize) -> Vec<bool> {
        (0..h)
            .flat_map(|y| (0..w).map(move |x| (x, y)))
            .map(|(x, y)| self.wide_at(x, y, w, h))
            .collect()
    }
}

/// Stroke pixels of `l` ([module docs](self)), before grouping.
fn stroke_pixels(l: &Luma, boxes: &[PixelBox]) -> Vec<bool> {
    let (w, h, d) = (l.width, l.height, STROKE_REACH_PX);
    let mut s = vec![false; w * h];
    for y in 0..h {
        for x in 0..w {
            let v = l.at(x, y);
            let sign = if v >= BRIGHT {
                1.0
            } else if v <= DARK {
                -1.0
            } else {
                continue;
            };
            let stands = |a: f32| sign * (v - a) >= STROKE_CONTRAST;
            // Beyond the frame's edge counts as standing out (a line along the border).
            let side = |inside: bool, a: &dyn Fn() -> f32| !inside || stands(a());
            let across_x = (x >= d || x + d < w)
                && side(x >= d, &|| l.at(x - d, y))
                && side(x + d < w, &|| l.at(x + d, y));
            let across_y = (y >= d || y + d < h)
                && side(y >= d, &|| l.at(x, y - d))
                && side(y + d < h, &|| l.at(x, y + d));
            s[y * w + x] = across_x || across_y;
        }
    }
    clear_near_boxes(&mut s, boxes, w, h);
    s
}

/// Calls `f` with each 8-connected group of set pixels of `s` (indices, row-major).
fn each_group(s: &[bool], w: usize, h: usize, mut f: impl FnMut(&[usize])) {
    let mut seen = vec![false; s.len()];
    let mut group = Vec::new();
    let mut stack = Vec::new();
    for (start, &set) in s.iter().enumerate() {
        if !set || seen[start] {
            continue;
        }
        group.clear();
        seen[start] = true;
        stack.push(start);
        while let Some(i) = stack.pop() {
            group.push(i);
            let (x, y) = (i % w, i / w);
            for ny in y.saturating_sub(1)..=(y + 1).min(h - 1) {
                for nx in x.saturating_sub(1)..=(x + 1).min(w - 1) {
                    let j = ny * w + nx;
                    if s[j] && !seen[j] {
                        seen[j] = true;
                        stack.push(j);
                    }
                }
            }
        }
        f(&group);
    }
}

/// Keeps the 8-connected groups of at least [`MIN_STROKE_PX`] set pixels.
fn keep_long_groups(s: &[bool], w: usize, h: usize) -> Vec<bool> {
    let mut keep = vec![false; s.len()];
    each_group(s, w, h, |group| {
        if group.len() >= MIN_STROKE_PX {
            for &i in group {
                keep[i] = true;
            }
        }
    });
    keep
}

/// The stroke pixels `strokes` with their text filled in: strokes joined across
/// [`TEXT_JOIN_PX`] form a line of text (or a glyph, a bracket), and where the joined
/// group covers at least [`TEXT_FILL_SHARE`] of its bounding box (text is dense, a
/// reticle's lines are not), the whole box is overlay, less the pixels within 8 px of a
/// labelled box. A glyph whose strokes lie closer than [`STROKE_REACH_PX`] apart (dense
/// CJK characters) or whose anti-aliased strokes stay below [`BRIGHT`] has only some of
/// its pixels found as strokes; its box holds the rest.
fn fill_text(l: &Luma, strokes: &[bool], boxes: &[PixelBox]) -> Vec<bool> {
    let (w, h) = (l.width, l.height);
    let mut out = chain_saturated(l, strokes, boxes);
    let joined = grow(&out, w, h, TEXT_JOIN_PX);
    each_group(&joined, w, h, |group| {
        let (mut x0, mut y0, mut x1, mut y1) = (w, h, 0, 0);
        for &i in group {
            let (x, y) = (i % w, i / w);
            (x0, y0, x1, y1) = (x0.min(x), y0.min(y), x1.max(x + 1), y1.max(y + 1));
        }
        let area = (x1 - x0) * (y1 - y0);
        if (group.len() as f64) < TEXT_FILL_SHARE * area as f64 {
            return;
        }
        for row in out.chunks_mut(w).take(y1).skip(y0) {
            row[x0..x1].fill(true);
        }
    });
    clear_near_boxes(&mut out, boxes, w, h);
    out
}

/// The stroke pixels with every thin near-saturated pixel of their polarity (≥ [`BRIGHT`]
/// for a bright stroke, ≤ [`DARK`] for a dark one) chained to them by steps of at most
/// [`TEXT_JOIN_PX`], none within 8 px of a labelled box: the cores of glyphs whose strokes
/// are not found one by one. Thin: along x or along y, within [`THIN_PX`] on both sides a
/// pixel not of that polarity (or the frame's edge), so a saturated area (a hot roof, the
/// sun's disc) beside the text never joins it.
fn chain_saturated(l: &Luma, strokes: &[bool], boxes: &[PixelBox]) -> Vec<bool> {
    let (w, h, r) = (l.width, l.height, TEXT_JOIN_PX);
    let polarity: Vec<u8> = (l.y.iter())
        .map(|&v| u8::from(v >= BRIGHT) | u8::from(v <= DARK) << 1)
        .collect();
    let mut open: Vec<bool> = (0..w * h).map(|i| thin(&polarity, w, h, i)).collect();
    clear_near_boxes(&mut open, boxes, w, h);
    let mut out = strokes.to_vec();
    let mut stack: Vec<usize> = (0..w * h).filter(|&i| out[i]).collect();
    while let Some(i) = stack.pop() {
        let (x, y, p) = (i % w, i / w, polarity[i]);
        for ny in y.saturating_sub(r)..(y + r + 1).min(h) {
            for nx in x.saturating_sub(r)..(x + r + 1).min(w) {
                let j = ny * w + nx;
                if open[j] && !out[j] && polarity[j] & p != 0 {
                    out[j] = true;
                    stack.push(j);
                }
            }
        }
    }
    out
}

/// Whether pixel `i` is near-saturated and thin ([`chain_saturated`]).
fn thin(polarity: &[u8], w: usize, h: usize, i: usize) -> bool {
    let (p, x, y, d) = (polarity[i], i % w, i / w, THIN_PX);
    // Along the axis of `stride`, `before` and `after` pixels from the frame's edges: the
    // run ends within d on both sides.
    let ends = |stride: usize, before: usize, after: usize| {
        let differs = |j: usize| polarity[j] & p == 0;
        (before < d || (1..=d).any(|k| differs(i - k * stride)))
            && (after < d || (1..=d).any(|k| differs(i + k * stride)))
    };
    p != 0 && (ends(1, x, w - 1 - x) || ends(w, y, h - 1 - y))
}

/// Clears the pixels of `m` within 8 px of a labelled box.
fn clear_near_boxes(m: &mut [bool], boxes: &[PixelBox], w: usize, h: usize) {
    for b in boxes {
        let clamp = |v: f32, n: usize| (v.max(0.0) as usize).min(n);
        let (x0, x1) = (clamp(b.x0 - 8.0, w), clamp((b.x1 + 8.0).ceil(), w));
        let (y0, y1) = (clamp(b.y0 - 8.0, h), clamp((b.y1 + 8.0).ceil(), h));
        for row in m.chunks_mut(w.max(1)).take(y1).skip(y0) {
            row[x0..x1.max(x0)].fill(false);
        }
    }
}

/// `m` grown by `r` px (a square), separably.
fn grow(m: &[bool], w: usize, h: usize, r: usize) -> Vec<bool> {
    let mut rows = vec![false; m.len()];
    for y in 0..h {
        for x in 0..w {
            if m[y * w + x] {
                rows[y * w + x.saturating_sub(r)..y * w + (x + r + 1).min(w)].fill(true);
            }
        }
    }
    let mut out = vec![false; m.len()];
    for y in 0..h {
        for x in 0..w {
            if rows[y * w + x] {
                for ny in y.saturating_sub(r)..(y + r + 1).min(h) {
                    out[ny * w + x] = true;
                }
            }
        }
    }
    out
}

/// The overlay of a grey frame ([module docs](self)), `None` when it has none or the
/// frame is in colour (`grey` false).
pub fn detect(l: &Luma, boxes: &[PixelBox], grey: bool) -> Option<Overlay> {
    let (w, h) = (l.width, l.height);
    if !grey || w == 0 || h == 0 {
        return None;
    }
    let strokes = keep_long_groups(&stroke_pixels(l, boxes), w, h);
    let count = strokes.iter().filter(|&&v| v).count();
    if count == 0 {
        return None;
    }
    let text = fill_text(l, &strokes, boxes);
    Some(Overlay {
        width: w,
        height: h,
        strokes: count,
        near: grow(&text, w, h, GROW_PX),
        wide: grow(&text, w, h, GROW_WIDE_PX),
    })
}

/// Mean of `l` over the rows `rows`, leaving out `overlay`'s pixels (0 when none is left).
pub fn mean_rows(l: &Luma, rows: std::ops::Range<usize>, overlay: &Overlay) -> f64 {
    let (mut s, mut n) = (0f64, 0usize);
    for y in rows {
        for x in 0..l.width {
            if !overlay.at(x, y) {
                s += f64::from(l.at(x, y));
                n += 1;
            }
        }
    }
    if n == 0 { 0.0 } else { s / n as f64 }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A `w` × `h` frame at level 100 with `marks` (x0, y0, w, h, level) drawn in turn.
    fn luma(w: usize, h: usize, marks: &[(usize, usize, usize, usize, f32)]) -> Luma {
        let mut y = vec![100.0; w * h];
        for &(x0, y0, mw, mh, v) in marks {
            for row in y.chunks_mut(w).skip(y0).take(mh) {
                row[x0..x0 + mw].fill(v);
            }
        }
        Luma {
            width: w,
            height: h,
            y,
        }
    }

    /// A plain glyph (2 px strokes, found one by one) at (x0, y0), then four dense ones
    /// (1 px strokes 3 px apart, a mid-grey anti-aliased row under each) 4 px apart.
    fn text_line(x0: usize, y0: usize) -> Vec<(usize, usize, usize, usize, f32)> {
        let mut m = vec![(x0, y0, 2, 16, 255.0), (x0, y0, 12, 2, 255.0)];
        m.push((x0, y0 + 14, 12, 2, 255.0));
        for g in 0..4 {
            let x = x0 + 16 + g * 18;
            m.push((x, y0, 1, 16, 255.0));
            for k in 0..6 {
                m.push((x, y0 + 3 * k, 14, 1, 255.0));
                m.push((x + 1, y0 + 3 * k + 1, 13, 1, 190.0));
            }
        }
        m
    }

    #[test]
    fn dense_glyphs_beside_a_found_one_are_filled_as_text() {
        let l = luma(200, 80, &text_line(20, 20));
        let found = keep_long_groups(&stroke_pixels(&l, &[]), 200, 80);
        let dense = |x: usize, y: usize| (36..106).contains(&x) && (20..37).contains(&y);
        let found_dense = (0..200 * 80).filter(|&i| found[i] && dense(i % 200, i / 200));
        assert!(
            found_dense.count() < 40,
            "the strokes rule alone misses them"
        );
        let o = detect(&l, &[], true).expect("an overlay");
        for (x, y) in (36..106).flat_map(|x| (20..37).map(move |y| (x, y))) {
            assert!(o.at(x, y), "({x}, {y}) of the dense glyphs is not overlay");
        }
        assert!(!o.at(20, 50) && !o.at(150, 28), "beyond the line's box");
    }

    #[test]
    fn a_saturated_area_beside_the_text_is_not_taken_with_it() {
        // Beside the line a black area (the other polarity) right of x = 120, and under
        // it, 4 px below its last stroke row (35), a white one (the same polarity, but an
        // area, not strokes) from row 39.
        let mut marks = vec![(120, 0, 80, 160, 10.0), (0, 39, 120, 121, 245.0)];
        marks.extend(text_line(10, 20));
        let l = luma(200, 160, &marks);
        let o = detect(&l, &[], true).expect("an overlay");
        assert!(o.at(60, 28), "the text is overlay");
        assert!(
            !o.at(124, 10) && !o.at(190, 100),
            "the black area is not text"
        );
        let below = 35 + TEXT_JOIN_PX + GROW_PX + 1;
        assert!(
            !o.at(20, below) && !o.at(60, 150),
            "the white area is not text"
        );
    }
}

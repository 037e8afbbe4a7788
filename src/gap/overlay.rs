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
//! - the overlay is those pixels grown by [`GROW_PX`] px (the glyphs' anti-aliased and
//!   JPEG-ringing halo); the gradient statistics, measured at 540 px high after
//!   smoothing, leave out [`GROW_WIDE_PX`] px around them ([`Overlay::wide`]).
//!
//! A frame without overlay pixels is measured exactly as before (no statistic changes by a
//! bit). Limits: a thin saturated part of the scene (a hot cable against a cold sky) is
//! taken for overlay; an overlay in mid-grey (not near-saturated) is not found.

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
    for b in boxes {
        let clamp = |v: f32, n: usize| (v.max(0.0) as usize).min(n);
        let (x0, x1) = (clamp(b.x0 - 8.0, w), clamp((b.x1 + 8.0).ceil(), w));
        let (y0, y1) = (clamp(b.y0 - 8.0, h), clamp((b.y1 + 8.0).ceil(), h));
        for row in s.chunks_mut(w.max(1)).take(y1).skip(y0) {
            row[x0..x1.max(x0)].fill(false);
        }
    }
    s
}

/// Keeps the 8-connected groups of at least [`MIN_STROKE_PX`] set pixels.
fn keep_long_groups(s: &[bool], w: usize, h: usize) -> Vec<bool> {
    let mut keep = vec![false; s.len()];
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
        if group.len() >= MIN_STROKE_PX {
            for &i in &group {
                keep[i] = true;
            }
        }
    }
    keep
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
    Some(Overlay {
        width: w,
        height: h,
        strokes: count,
        near: grow(&strokes, w, h, GROW_PX),
        wide: grow(&strokes, w, h, GROW_WIDE_PX),
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

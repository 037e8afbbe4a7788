//! The rolling shutter's pixels (issue 41, `camera_model.rolling_shutter`):
//! row y of the picture shows the scene `readout · y / height` after the
//! first row. The pipeline (`pipeline/rolling.rs`) supplies the geometry:
//! where each output pixel's drone-free background comes from (the sky at
//! infinity turned by the camera's rotation, a homography per row) and how
//! far each drone's image has moved at each row's time. Here the background
//! is resampled row by row (bilinear in the bytes, with the lens map's taps)
//! and each drone's difference against the drone-free frame,
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

/// `background` (RGBA8, `width`×`height`) resampled row by row: output
/// pixel centre (x, y) takes the background at `source(x, y)` (pixel
/// coordinates; clamped to the image), computed every [`KNOT_PX`] columns
/// and at the last, linear in between. Rows on rayon's threads.
pub fn turn_background(
    background: &[u8],
    (width, height): (u32, u32),
    source: &(dyn Fn(f64, f64) -> (f64, f64) + Sync),
) -> Vec<u8> {
    let w = width as usize;
    let mut out = background.to_vec();
    if w == 0 || background.len() < w * height as usize * 4 {
        return out;
    }
    out.par_chunks_mut(w * 4).enumerate().for_each(|(y, row)| {
        let yc = y as f64 + 0.5;
        let mut knots: Vec<(u32, (f64, f64))> = (0..width)
            .step_by(KNOT_PX as usize)
            .map(|x| (x, source(f64::from(x) + 0.5, yc)))
            .collect();
        if knots.last().is_some_and(|&(x, _)| x + 1 < width) {
            knots.push((width - 1, source(f64::from(width) - 0.5, yc)));
        }
        let at = |x: u32| {
            let k = ((x / KNOT_PX) as usize).min(knots.len().saturating_sub(2));
            let ((xa, a), (xb, b)) = (knots[k], knots[(k + 1).min(knots.len() - 1)]);
            let t = if xb > xa {
                f64::from(x - xa) / f64::from(xb - xa)
            } else {
                0.0
            };
            (a.0 + (b.0 - a.0) * t, a.1 + (b.1 - a.1) * t)
        };
        super::lens::resample_row(background, (width, height), (0..width).map(at), row);
    });
    out
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
        let still = turn_background(&frame, (w, h), &|x, y| (x, y));
        assert_eq!(still, frame);
    }
}

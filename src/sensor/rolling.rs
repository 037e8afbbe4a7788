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
use super::pool::Picture;

mod kernel;
use kernel::Row;

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
        self.reach_of(self.rect, width, height)
    }

    /// The output pixels that the rendered pixels of `rect` (a part of the
    /// drone's rect, e.g. its visible box) reach under the drone's shifts,
    /// as [`Self::reach`]; `None` if none.
    pub fn reach_of(&self, rect: PixelRect, width: u32, height: u32) -> Option<PixelRect> {
        let (lo, hi) = (f64::from(rect.y0) - 1.0, f64::from(rect.y1) + 1.0);
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
        let x0 = (f64::from(rect.x0) + cols.0 - 1.0).floor().max(0.0);
        let x1 = (f64::from(rect.x1) + cols.1 + 1.0).ceil().max(0.0);
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
/// weights in 1/256 (`rolling/kernel.rs`). Rows on rayon's threads, each
/// with its own knot buffers. A side under 2 or over
/// [`crate::preset::MAX_IMAGE_SIDE`], or a short `background`, is copied.
pub fn turn_background(
    background: &[u8],
    (width, height): (u32, u32),
    sources: &RowSources,
) -> Picture {
    turn(background, (width, height), sources, false).0
}

/// [`turn_background`] and a second copy of its bytes, written row by row
/// as each is made (while the row is in the cache): the copy is the frame
/// that [`shear_over`] draws the drones over.
pub fn turn_background_twice(
    background: &[u8],
    (width, height): (u32, u32),
    sources: &RowSources,
) -> (Picture, Picture) {
    let (turned, copy) = turn(background, (width, height), sources, true);
    let copy = copy.unwrap_or_else(|| Picture::copy_of(&turned));
    (turned, copy)
}

/// [`turn_background`], with its copy when `twice` (`None` when the
/// background is copied as it is).
fn turn(
    background: &[u8],
    (width, height): (u32, u32),
    sources: &RowSources,
    twice: bool,
) -> (Picture, Option<Picture>) {
    let w = width as usize;
    let n = w * height as usize * 4;
    // Fixed-point positions stay in `i32` up to the largest image side.
    let side = crate::preset::MAX_IMAGE_SIDE;
    if width < 2 || height < 2 || width.max(height) > side || background.len() < n {
        return (Picture::copy_of(background), None);
    }
    let mut out = Picture::take(n);
    let mut copy = twice.then(|| Picture::take(n));
    let knot_xs: Vec<u32> = knot_columns(width);
    let xs: Vec<f64> = knot_xs.iter().map(|&x| f64::from(x) + 0.5).collect();
    let row = Row {
        src: background,
        size: (width, height),
    };
    let init = || (vec![(0.0, 0.0); xs.len()], Vec::new());
    let make = |(knots, fixed): &mut Knots, y: usize, bytes: &mut [u8]| {
        sources(y as f64 + 0.5, &xs, knots);
        row.resample(&knot_xs, knots, fixed, bytes);
    };
    let rows = out.par_chunks_mut(w * 4).enumerate();
    match copy.as_mut() {
        // The row made in the copy (the frame the drones are drawn over,
        // read whole next) and streamed past the cache into the turned
        // frame (read only near the drones).
        Some(copy) => {
            rows.zip(copy.par_chunks_mut(w * 4))
                .for_each_init(init, |k, ((y, turned), bytes)| {
                    make(k, y, bytes);
                    kernel::copy_streamed(turned, bytes);
                })
        }
        None => rows.for_each_init(init, |k, (y, bytes)| make(k, y, bytes)),
    }
    (out, copy)
}

/// A thread's buffers for its rows: a row's knots' sources, and in fixed point.
type Knots = (Vec<(f64, f64)>, Vec<(i32, i32)>);

/// The columns where a row's source is computed: every [`KNOT_PX`] and the last.
fn knot_columns(width: u32) -> Vec<u32> {
    let mut knots: Vec<u32> = (0..width).step_by(KNOT_PX as usize).collect();
    if knots.last().is_some_and(|&x| x + 1 < width) {
        knots.push(width - 1);
    }
    knots
}

/// The shuttered picture: `turned` (the drone-free frame under the
/// shutter, [`turn_background`] or the rendered one when the camera holds
/// still) with each drone of `shears` moved row by row ([`shear_over`]).
/// All RGBA8, `width`×`height`; alpha is `turned`'s.
pub fn shear(
    frame: &[u8],
    background: &[u8],
    turned: &[u8],
    size: (u32, u32),
    shears: &[Shear],
) -> Picture {
    let mut out = Picture::copy_of(turned);
    shear_over(&mut out, frame, background, size, shears);
    out
}

/// Each drone of `shears` moved row by row over `out`, which holds the
/// drone-free frame under the shutter: its difference taken between
/// `frame` and `background` (the rendered frame and its drone-free frame),
/// added in linear light to `out`'s pixel (each pixel is written at most
/// once, so it reads the drone-free byte). All RGBA8, `width`×`height`;
/// short buffers leave `out` as it is.
pub fn shear_over(
    out: &mut [u8],
    frame: &[u8],
    background: &[u8],
    (width, height): (u32, u32),
    shears: &[Shear],
) {
    let n = width as usize * height as usize * 4;
    if frame.len() < n || background.len() < n || out.len() < n {
        return;
    }
    let mut owned: Vec<PixelRect> = Vec::new();
    for s in shears {
        let Some(reach) = s.reach(width, height) else {
            continue;
        };
        // Only where its rows take it: its rendered rect shows the turned
        // drone-free frame, and claiming it would hide a drone moved there.
        if let Some(diff) = Difference::of(frame, background, width, height, s.rect, &[]) {
            draw_shear(out, width, (s, &diff), reach, &owned);
        }
        owned.push(reach);
    }
}

/// One drone's difference `diff` moved by `s`'s shifts and added over
/// `out`'s pixels of `region` (an image `width` wide) that no rect of
/// `owned` holds: per row, the rects holding it and the row's taps in
/// `diff` found once ([`Difference::row_at`]).
fn draw_shear(
    out: &mut [u8],
    width: u32,
    (s, diff): (&Shear, &Difference),
    region: PixelRect,
    owned: &[PixelRect],
) {
    let (dec, enc) = (decode_table(), encode_table());
    let mut blocked: Vec<(u32, u32)> = Vec::new();
    for y in region.y0..region.y1 {
        let (sx, sy) = s.shift_px.get(y as usize).copied().unwrap_or((0.0, 0.0));
        blocked.clear();
        let holding = owned.iter().filter(|o| y >= o.y0 && y < o.y1);
        blocked.extend(holding.map(|o| (o.x0, o.x1)));
        let row = diff.row_at(f64::from(y) + 0.5 - sy);
        let start = y as usize * width as usize * 4;
        for x in region.x0..region.x1 {
            if blocked.iter().any(|&(x0, x1)| x >= x0 && x < x1) {
                continue;
            }
            let i = start + x as usize * 4;
            let d = diff.sample_rgb_on(row, f64::from(x) + 0.5 - sx);
            for (c, d) in d.into_iter().enumerate() {
                if d != 0.0 {
                    let v = lin(dec, out, i + c) + d;
                    out[i + c] = encode(enc, v.clamp(0.0, 1.0));
                }
            }
        }
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
        // Pictures come from a pool of used buffers: make them dirty first.
        let dirty: Vec<Picture> = (0..6)
            .map(|_| Picture::copy_of(&[0xab; 64 * 48 * 4]))
            .collect();
        drop(dirty);
        assert_eq!(shear(&frame, &background, &background, (w, h), &[s]), frame);
        let still = |y: f64, xs: &[f64], out: &mut [(f64, f64)]| {
            for (o, &x) in out.iter_mut().zip(xs) {
                *o = (x, y);
            }
        };
        assert_eq!(turn_background(&frame, (w, h), &still), frame);
        let (turned, copy) = turn_background_twice(&frame, (w, h), &still);
        assert!(turned == frame && copy == frame);
    }

    /// The drones drawn over the turned frame's copy are [`shear`] of the
    /// turned frame: the copy holds its bytes, each pixel read before it
    /// is written.
    #[test]
    fn shearing_over_the_turned_copy_is_shearing_the_turned_frame() {
        let (w, h) = (64u32, 48u32);
        let background: Vec<u8> = (0..w * h)
            .flat_map(|i| [(i % w * 3) as u8, (i / w * 5) as u8, 200, 255])
            .collect();
        let (mut frame, _, _) = frames();
        for (f, b) in frame.chunks_exact_mut(4).zip(background.chunks_exact(4)) {
            if f[0] != 20 {
                f.copy_from_slice(b);
            }
        }
        let shift: Vec<(f64, f64)> = (0..h).map(|y| (f64::from(y) * 0.21, 0.3)).collect();
        let rect = PixelRect {
            x0: 28,
            y0: 8,
            x1: 36,
            y1: 32,
        };
        let shears = [Shear {
            rect,
            shift_px: shift,
        }];
        // A pan of about a pixel every 7 rows, slightly stretched.
        let pan = |y: f64, xs: &[f64], out: &mut [(f64, f64)]| {
            for (o, &x) in out.iter_mut().zip(xs) {
                *o = (x * 1.01 + y / 7.0, y + x * 0.003);
            }
        };
        let (turned, mut copy) = turn_background_twice(&background, (w, h), &pan);
        assert!(turned != background[..], "the background turns");
        shear_over(&mut copy, &frame, &background, (w, h), &shears);
        let want = shear(&frame, &background, &turned, (w, h), &shears);
        assert!(copy == want[..] && copy != turned[..]);
    }
}

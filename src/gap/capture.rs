//! What a recording's capture chain leaves in a grey frame (docs/realism.md, "The
//! capture chain"): the block steps of an earlier 8×8 compression and the border lines
//! at the frame's edges; `swarmshot fit` fits `thermal.capture` by them. And what the
//! optics leave: the narcissus' dark centre ([`centre_depth`]), by which the fit sets
//! `thermal.narcissus`.

use image::GrayImage;

use super::measure::{Luma, OverlayMask, PixelBox};

/// [`crate::sensor::thermal::capture::block_steps`] of the grey frame, the pixels set in
/// `overlay` (at the frame's size) left out.
pub fn block_steps(gray: &GrayImage, overlay: Option<OverlayMask>) -> Option<f32> {
    let dims = (gray.width() as usize, gray.height() as usize);
    let skip = |i: usize| overlay.is_some_and(|m| m[i]);
    crate::sensor::thermal::capture::block_steps(gray.as_raw(), dims, skip)
}

/// Level offsets of the four outermost rows or columns at each edge of a frame: top
/// (row 0 first), bottom (the last row first), left, right; each line's median over
/// its middle (1/16 of its length in from both ends) less the median of the line 8
/// further in (the same place on the 8-pixel grid).
pub type EdgeLines = [[f32; 4]; 4];

/// [`EdgeLines`] of a frame at least 24 px in each direction.
pub fn edge_lines(l: &Luma) -> Option<EdgeLines> {
    let (w, h) = (l.width, l.height);
    if w < 24 || h < 24 {
        return None;
    }
    let median = |mut v: Vec<f32>| {
        v.sort_by(f32::total_cmp);
        v[v.len() / 2]
    };
    let row = |y: usize| median(l.y[y * w + w / 16..y * w + w - w / 16].to_vec());
    let col = |x: usize| median((h / 16..h - h / 16).map(|y| l.y[y * w + x]).collect());
    Some([
        std::array::from_fn(|k| row(k) - row(k + 8)),
        std::array::from_fn(|k| row(h - 1 - k) - row(h - 9 - k)),
        std::array::from_fn(|k| col(k) - col(k + 8)),
        std::array::from_fn(|k| col(w - 1 - k) - col(w - 9 - k)),
    ])
}

/// The centre disc's outer radius and the ring's radii for [`centre_depth`], shares of
/// half the frame's height.
pub const CENTRE_DISC: f64 = 0.2;
pub const CENTRE_RING: (f64, f64) = (0.6, 0.8);
/// A labelled box's margin left out of [`centre_depth`], pixels.
const BOX_MARGIN_PX: f32 = 8.0;
/// The fewest pixels the disc and the ring each need.
const MIN_PIXELS: usize = 64;

/// The narcissus' depth in a grey frame: the median level in the centre disc (radius
/// [`CENTRE_DISC`] × half the height) less the median in the ring [`CENTRE_RING`] about
/// the same centre, levels (negative: a dark centre), labelled boxes (grown by 8 px) and
/// `overlay` pixels left out. A ring about the centre averages a vertical gradient away;
/// a scene's own structure (a horizon, trees) moves it from frame to frame, a camera's
/// narcissus does not.
pub fn centre_depth(l: &Luma, boxes: &[PixelBox], overlay: Option<OverlayMask>) -> Option<f32> {
    let (w, h) = (l.width, l.height);
    let half = h as f64 * 0.5;
    let (cx, cy) = (w as f64 * 0.5, half);
    let boxed = |x: usize, y: usize| {
        let (x, y) = (x as f32 + 0.5, y as f32 + 0.5);
        boxes.iter().any(|b| {
            x >= b.x0 - BOX_MARGIN_PX
                && x < b.x1 + BOX_MARGIN_PX
                && y >= b.y0 - BOX_MARGIN_PX
                && y < b.y1 + BOX_MARGIN_PX
        })
    };
    let (mut disc, mut ring) = (Vec::new(), Vec::new());
    for y in 0..h {
        let dy = (y as f64 + 0.5 - cy) / half;
        // Only the columns within the ring's outer radius (one pixel's margin): every
        // pixel outside them has r beyond the ring; those inside are tested as they are.
        let reach = (CENTRE_RING.1 * CENTRE_RING.1 - dy * dy).max(0.0).sqrt() * half + 1.0;
        let x0 = (cx - reach).floor().max(0.0) as usize;
        let x1 = ((cx + reach).ceil().max(0.0) as usize).min(w);
        for x in x0..x1 {
            let i = y * w + x;
            let dx = (x as f64 + 0.5 - cx) / half;
            let r = (dx * dx + dy * dy).sqrt();
            let into = if r < CENTRE_DISC {
                &mut disc
            } else if (CENTRE_RING.0..CENTRE_RING.1).contains(&r) {
                &mut ring
            } else {
                continue;
            };
            if overlay.is_some_and(|m| m[i]) || boxed(x, y) {
                continue;
            }
            into.push(l.y[i]);
        }
    }
    if disc.len() < MIN_PIXELS || ring.len() < MIN_PIXELS {
        return None;
    }
    let median = |v: &mut Vec<f32>| {
        let k = v.len() / 2;
        *v.select_nth_unstable_by(k, f32::total_cmp).1
    };
    Some(median(&mut disc) - median(&mut ring))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A `w`×`h` frame at 100 levels less a centred Gaussian of `depth` levels, σ 0.45 ×
    /// half the height, plus a vertical gradient of 0.1 levels a row.
    fn frame(w: usize, h: usize, depth: f32) -> Luma {
        let s = 0.45 * h as f32 * 0.5;
        let y = (0..w * h)
            .map(|i| {
                let (x, yy) = ((i % w) as f32 + 0.5, (i / w) as f32 + 0.5);
                let r2 = (x - w as f32 * 0.5).powi(2) + (yy - h as f32 * 0.5).powi(2);
                100.0 + 0.1 * yy - depth * (-r2 / (2.0 * s * s)).exp()
            })
            .collect();
        Luma {
            width: w,
            height: h,
            y,
        }
    }

    #[test]
    fn the_centre_depth_reads_the_spot_and_not_the_gradient() {
        let flat = centre_depth(&frame(160, 128, 0.0), &[], None).expect("measured");
        assert!(flat.abs() < 0.5, "{flat}");
        // A 30-level spot: the disc's median pixel (0.14 half-heights out) sits 28.6
        // below, the ring's (0.71) 8.7 below, so the difference is near −20.
        let d = centre_depth(&frame(160, 128, 30.0), &[], None).expect("measured");
        assert!((-22.0..-18.0).contains(&d), "{d}");
        // A box over the centre is left out; a frame too small has no measure.
        let b = PixelBox {
            x0: 60.0,
            y0: 50.0,
            x1: 100.0,
            y1: 78.0,
        };
        assert!(centre_depth(&frame(160, 128, 30.0), &[b], None).is_none());
        assert!(centre_depth(&frame(8, 8, 30.0), &[], None).is_none());
    }
}

//! What a recording's capture chain leaves in a grey frame (docs/realism.md, "The
//! capture chain"): the block steps of an earlier 8×8 compression and the border lines
//! at the frame's edges; `swarmshot fit` fits `thermal.capture` by them.

use image::GrayImage;

use super::measure::{Luma, OverlayMask};

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
    let mut out = [[0.0; 4]; 4];
    for k in 0..4 {
        out[0][k] = row(k) - row(k + 8);
        out[1][k] = row(h - 1 - k) - row(h - 9 - k);
        out[2][k] = col(k) - col(k + 8);
        out[3][k] = col(w - 1 - k) - col(w - 9 - k);
    }
    Some(out)
}

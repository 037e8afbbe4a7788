//! The parts of a frame's upsampling a frame's regions read, made alone:
//! the same bytes as those pixels of the whole upsampling, so that a
//! background's tiles under the regions can be uploaded before the rest of
//! it is upsampled (`render/background.rs`: the rest while the GPU draws
//! the frame's passes).

use std::ops::Range;

use super::across::{self, Columns, across, taps};
use super::down;
use crate::render::regions::Rect;

/// The pixels of `parts` (each inside the frame) of what
/// [`super::upsample_levels`] makes of `levels` (RGBA8 sRGB levels of
/// `size` texels, [`super::encode_source`]), written at their places in
/// `rgba` (the frame's RGBA8, already its size): a part's row by the same
/// integer blend over the source columns it reads, so with the same bytes
/// (tested). What the regions of a frame read, made before the rest of the
/// frame is upsampled ([`super::background`]).
pub(in crate::render) fn upsample_parts(
    levels: &[u8],
    (size, frame): ((u32, u32), (u32, u32)),
    centre: (f32, f32),
    parts: &[Rect],
    rgba: &mut [u8],
) {
    let (w, h) = (size.0 as usize, size.1 as usize);
    let stride = frame.0 as usize * 4;
    // The byte range of each of a part's rows in `rgba`.
    let lines = move |part: Rect| {
        (part.y0 as usize..part.y1 as usize)
            .map(move |y| y * stride + part.x0 as usize * 4..y * stride + part.x1 as usize * 4)
    };
    if w == 0 || h == 0 || levels.len() < w * h * 4 || frame.0 == 0 {
        // Black, as the whole upsampling of a source too short for its size.
        parts
            .iter()
            .flat_map(|&p| lines(p))
            .for_each(|l| rgba[l].fill(0));
        return;
    }
    let columns = Columns::new(frame.0, size.0, centre.0);
    let rows = taps(frame.1, size.1, centre.1);
    let mut sums = [Vec::new(), Vec::new()];
    for part in parts.iter().filter(|p| p.x0 < p.x1) {
        let window = part.x0 as usize..part.x1 as usize;
        for (y, line) in (part.y0 as usize..).zip(lines(*part)) {
            let at = (rows[y], window.clone());
            window_row((levels, w), &columns, at, &mut sums, &mut rgba[line]);
        }
    }
}

/// The columns of `window` of one output row, sampling source rows `r0`
/// and `r1` of `levels` (`w` texels a row) with weight `wy`, into `line`;
/// `sums` the rows blended across.
fn window_row(
    (levels, w): (&[u8], usize),
    columns: &Columns,
    ((r0, r1, wy), window): (across::Tap, Range<usize>),
    sums: &mut [Vec<u16>; 2],
    line: &mut [u8],
) {
    let reads = columns.reads(&window);
    let simd = crate::simd::avx2();
    for (r, out) in [r0, r1].into_iter().zip(sums.iter_mut()) {
        out.resize(window.len() * 4, 0);
        let src = &levels[(r * w + reads.start) * 4..(r * w + reads.end) * 4];
        across((src, reads.start), columns, window.clone(), out, simd);
    }
    down(&sums[0], &sums[1], wy, line);
}

#[cfg(test)]
mod tests {
    use super::super::tests::{LAYOUTS, planes, texels};
    use super::super::{Texels, Tone, encode_source, upsample_levels};
    use super::*;

    #[test]
    fn a_part_has_the_bytes_of_the_whole_upsampling() {
        // The layouts frames of 100 px and more (exact 2× and 4×, a layout
        // of neither, off-centre); both tones, exposed and not; parts at the
        // edges, inside, one pixel, a row, a tile.
        let cases = &LAYOUTS[..5];
        let mut compared = 0;
        for (k, &(size, frame, centre)) in cases.iter().enumerate() {
            let texels = planes(&texels(size.0 as usize * size.1 as usize * 4, k as u64 + 3));
            let (fw, fh) = frame;
            let parts = [
                Rect {
                    x0: 0,
                    y0: 0,
                    x1: 7,
                    y1: 5,
                },
                Rect {
                    x0: fw - 9,
                    y0: fh - 3,
                    x1: fw,
                    y1: fh,
                },
                Rect {
                    x0: 13,
                    y0: 17,
                    x1: 64,
                    y1: 29,
                },
                Rect {
                    x0: 5,
                    y0: 6,
                    x1: 6,
                    y1: 7,
                },
                Rect {
                    x0: 0,
                    y0: 31,
                    x1: fw,
                    y1: 32,
                },
                // Tile-aligned, as the background's upload tiles (their
                // whole chunks blended in AVX2 registers).
                Rect {
                    x0: 32,
                    y0: 40,
                    x1: 96,
                    y1: 44,
                },
            ];
            for tone in [
                (Tone::Clip, 1.0),
                (Tone::Clip, 0.7),
                (Tone::Exponential, 1.0),
                (Tone::Exponential, 1.3),
            ] {
                let (mut levels, mut whole) = (Vec::new(), Vec::new());
                let source = (size.0 as usize, size.1 as usize);
                encode_source(&Texels::Planes(&texels), source, tone, &mut levels);
                upsample_levels(&levels, size, (frame, centre), &mut whole);
                let mut got = vec![0x5A; whole.len()];
                upsample_parts(&levels, (size, frame), centre, &parts, &mut got);
                for p in &parts {
                    for y in p.y0..p.y1 {
                        let row = (y * fw) as usize * 4;
                        let span = row + p.x0 as usize * 4..row + p.x1 as usize * 4;
                        assert!(
                            got[span.clone()] == whole[span],
                            "case {k}, {tone:?}, row {y} of {p:?}"
                        );
                        compared += 1;
                    }
                }
                // Nothing outside the parts is written.
                assert_eq!(got[(40 * fw as usize + fw as usize - 1) * 4], 0x5A);
            }
        }
        assert_eq!(compared, 5 * 4 * 26, "rows compared");
        // A source too short for its size: black, as the whole upsampling.
        let mut got = vec![9; 64];
        upsample_parts(
            &[128; 12],
            ((2, 2), (4, 4)),
            (2.0, 2.0),
            &[Rect {
                x0: 1,
                y0: 1,
                x1: 3,
                y1: 2,
            }],
            &mut got,
        );
        assert_eq!(&got[20..28], &[0; 8]);
        assert_eq!(got[16], 9);
    }
}

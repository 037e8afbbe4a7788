//! The parts of a frame's upsampling a frame's regions read, made alone:
//! the same bytes as those pixels of the whole upsampling, so that a
//! background's tiles under the regions can be uploaded before the rest of
//! it is upsampled (`render/background.rs`: the rest while the GPU draws
//! the frame's passes).

use super::srgb;
use super::{Texels, Tone, encode_values, taps};
use crate::render::regions::Rect;

/// The pixels of `parts` (each inside the frame) of what
/// [`upsample_reduced`] makes of `planes` (a pass shaded on the CPU),
/// written at their places in `rgba` (the frame's RGBA8, already its size):
/// a part's row by the rows' f32 operations in their order, over the source
/// columns it reads (the two source rows blended, then across its own
/// columns) and encoded as a row is, so with the same bytes (tested). What
/// the regions of a frame read, made before the rest of the frame is
/// upsampled ([`super::background`]).
pub(in crate::render) fn upsample_parts(
    planes: &[Vec<f32>; 3],
    (size, frame): ((u32, u32), (u32, u32)),
    centre: (f32, f32),
    (tone, gain): (Tone, f32),
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
    if w == 0 || h == 0 || !Texels::Planes(planes).holds(w, h) || frame.0 == 0 {
        // Black, as the whole upsampling of a source too short for its size.
        parts
            .iter()
            .flat_map(|&p| lines(p))
            .for_each(|l| rgba[l].fill(0));
        return;
    }
    let (buckets, scale, exposure) = tone.encoding(gain);
    let exposed = (exposure != 1.0).then(|| srgb::exposure_table(exposure));
    let (cols, rows) = (
        taps(frame.0, size.0, centre.0),
        taps(frame.1, size.1, centre.1),
    );
    let (mut source, mut values): ([Vec<f32>; 3], [Vec<f32>; 3]) = Default::default();
    for part in parts.iter().filter(|p| p.x0 < p.x1) {
        let window = &cols[part.x0 as usize..part.x1 as usize];
        // The source columns the window reads: the taps only move forward.
        let first = window[0].0;
        let n = window[window.len() - 1].1 + 1 - first;
        for (y, line) in (part.y0 as usize..).zip(lines(*part)) {
            let (r0, r1, wy) = rows[y];
            for c in 0..3 {
                let (top, bottom) = (
                    &planes[c][r0 * w + first..][..n],
                    &planes[c][r1 * w + first..][..n],
                );
                let texel = |v: f32| if scale != 1.0 { v * scale } else { v };
                source[c].clear();
                source[c].extend(top.iter().zip(bottom).map(|(&p, &q)| {
                    let (p, q) = (texel(p), texel(q));
                    p + (q - p) * wy
                }));
                let across = &source[c];
                values[c].clear();
                values[c].extend(window.iter().map(|&(a, b, wx)| {
                    let (p, q) = (across[a - first], across[b - first]);
                    p + (q - p) * wx
                }));
            }
            let line = &mut rgba[line];
            let [r, g, b] = &values;
            encode_values([r, g, b], buckets, line, crate::simd::avx2());
            if let Some(table) = &exposed {
                srgb::expose_with(table, line);
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::super::tests::{LAYOUTS, planes, texels};
    use super::super::upsample_reduced;
    use super::*;

    #[test]
    fn a_part_has_the_bytes_of_the_whole_upsampling() {
        // The layouts frames of 100 px and more (exact 2× and 4×, a layout
        // of neither, off-centre); both tones, exposed and not; parts at the
        // edges, inside, one pixel, a row.
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
            ];
            for tone in [
                (Tone::Clip, 1.0),
                (Tone::Clip, 0.7),
                (Tone::Exponential, 1.0),
                (Tone::Exponential, 1.3),
            ] {
                let mut whole = Vec::new();
                upsample_reduced(
                    Texels::Planes(&texels),
                    size,
                    frame,
                    centre,
                    tone,
                    &mut whole,
                );
                let mut got = vec![0x5A; whole.len()];
                upsample_parts(&texels, (size, frame), centre, tone, &parts, &mut got);
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
        assert_eq!(compared, 5 * 4 * 22, "rows compared");
        // A source too short for its size: black, as the whole upsampling.
        let mut got = vec![9; 64];
        let short = planes(&[0.5; 4]);
        upsample_parts(
            &short,
            ((2, 2), (4, 4)),
            (2.0, 2.0),
            (Tone::Clip, 1.0),
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

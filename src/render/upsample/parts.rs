//! The parts of a frame's upsampling a frame's regions read, made alone:
//! the same bytes as those pixels of the whole upsampling, so that a
//! background's tiles under the regions can be uploaded before the rest of
//! it is upsampled (`render/background.rs`: the rest while the GPU draws
//! the frame's passes).

use std::ops::Range;

use super::srgb;
use super::{Columns, Texels, Tone, encode_values, taps};
use crate::render::regions::Rect;

/// The pixels of `parts` (each inside the frame) of what
/// [`upsample_reduced`] makes of `planes` (a pass shaded on the CPU),
/// written at their places in `rgba` (the frame's RGBA8, already its size):
/// a part's row by the rows' f32 operations in their order, over the source
/// columns it reads (the two source rows blended, then across its own
/// columns, in AVX2 registers where the whole rows are) and encoded as a
/// row is, so with the same bytes (tested). What the regions of a frame
/// read, made before the rest of the frame is upsampled
/// ([`super::background`]).
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
    let across = Across {
        taps: taps(frame.0, size.0, centre.0),
        columns: Columns::new(frame.0, size.0, centre.0),
        source: w,
    };
    let rows = taps(frame.1, size.1, centre.1);
    let simd = crate::simd::avx2();
    let mut scratch = Scratch::default();
    for part in parts.iter().filter(|p| p.x0 < p.x1) {
        let window = part.x0 as usize..part.x1 as usize;
        for (y, line) in (part.y0 as usize..).zip(lines(*part)) {
            let (r0, r1, wy) = rows[y];
            let pair = planes
                .each_ref()
                .map(|p| (&p[r0 * w..][..w], &p[r1 * w..][..w]));
            part_row(
                (pair, wy, scale),
                &across,
                window.clone(),
                &mut scratch,
                simd,
            );
            let line = &mut rgba[line];
            let [r, g, b] = &scratch.values;
            encode_values([r, g, b], buckets, line, simd);
            if let Some(table) = &exposed {
                srgb::expose_with(table, line);
            }
        }
    }
}

/// How an output row samples across: each column's two texels and weight,
/// and the same as the whole rows' layout (their chunks of an exact 2× or 4×).
struct Across {
    taps: Vec<(usize, usize, f32)>,
    columns: Columns,
    /// Source texels a row.
    source: usize,
}

/// A part's row: the two source rows blended over the columns it reads,
/// then its own columns' values, per channel.
#[derive(Default)]
struct Scratch {
    source: [Vec<f32>; 3],
    values: [Vec<f32>; 3],
}

/// The two source rows of each channel, the vertical weight, and the scale
/// the texels take as they are read (1: none).
type RowPair<'a> = ([(&'a [f32], &'a [f32]); 3], f32, f32);

/// The values of one output row's columns `window` into `scratch.values`:
/// [`part_row_in`], built for AVX2 when `simd`.
fn part_row(
    rows: RowPair<'_>,
    across: &Across,
    window: Range<usize>,
    scratch: &mut Scratch,
    simd: bool,
) {
    #[cfg(target_arch = "x86_64")]
    if simd {
        // SAFETY: callers pass `simd` only on a CPU with AVX2 (`avx2`).
        #[allow(unsafe_code)]
        unsafe {
            part_row_avx2(rows, across, window, scratch);
        }
        return;
    }
    let _ = simd;
    part_row_in(rows, across, window, scratch, false);
}

/// [`part_row_in`] built for AVX2 (the same operations: the same values).
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
#[inline(never)]
fn part_row_avx2(rows: RowPair<'_>, across: &Across, window: Range<usize>, scratch: &mut Scratch) {
    part_row_in(rows, across, window, scratch, true);
}

/// The whole rows' operations on a window of them: the source rows blended
/// (`p + (q − p) · wy`, the texels scaled first) over the source columns the
/// window reads, then across (`p + (q − p) · wx`), the chunks of an exact
/// layout eight values at a time when `chunks` ([`super::blend::chunks_avx2`]).
#[inline(always)]
fn part_row_in(
    (rows, wy, scale): RowPair<'_>,
    across: &Across,
    window: Range<usize>,
    Scratch { source, values }: &mut Scratch,
    chunks: bool,
) {
    // The source columns the window reads: the taps only move forward.
    let first = across.taps[window.start].0;
    let reads = first..across.taps[window.end - 1].1 + 1;
    for (c, (top, bottom)) in rows.into_iter().enumerate() {
        let (source, value) = (&mut source[c], &mut values[c]);
        source.resize(reads.len(), 0.0);
        for ((o, &p), &q) in source
            .iter_mut()
            .zip(&top[reads.clone()])
            .zip(&bottom[reads.clone()])
        {
            let (p, q) = if scale != 1.0 {
                (p * scale, q * scale)
            } else {
                (p, q)
            };
            *o = p + (q - p) * wy;
        }
        value.resize(window.len(), 0.0);
        let (x0, x1) = (window.start, window.end);
        let done = if chunks {
            chunked((source, first), across, x0..x1, value)
        } else {
            x0..x0
        };
        for x in (x0..done.start).chain(done.end..x1) {
            let (a, b, wx) = across.taps[x];
            let (p, q) = (source[a - first], source[b - first]);
            value[x - x0] = p + (q - p) * wx;
        }
    }
}

/// The columns of `window` in whole chunks of the rows' exact 2× or 4×
/// layout ([`super::chunk_layout`]), blended across in AVX2 registers as
/// the whole rows' chunks are ([`super::blend::chunks_avx2`]) into `value`
/// (the window's values; `source`: the blended source columns from
/// `first`): which columns it blended (from the window's start: none).
/// Only from [`part_row_avx2`].
#[inline(always)]
fn chunked(
    (source, first): (&[f32], usize),
    across: &Across,
    window: Range<usize>,
    value: &mut [f32],
) -> Range<usize> {
    let none = window.start..window.start;
    let k = across.columns.factor;
    if k == 0 {
        return none;
    }
    let (head, mid) = super::chunk_layout(k, across.taps.len(), across.source);
    // The window's first whole chunk, and the chunks it holds from there.
    let from = head + window.start.saturating_sub(head).div_ceil(k) * k;
    let (c0, c1) = (
        (from - head) / k,
        mid.min(window.end.saturating_sub(head) / k),
    );
    if c1 <= c0 {
        return none;
    }
    let span = from..from + (c1 - c0) * k;
    let (plane, weight) = (&source[c0 - first..], &across.columns.weight[span.clone()]);
    let out = &mut value[span.start - window.start..span.end - window.start];
    #[cfg(target_arch = "x86_64")]
    // SAFETY: only from `part_row_avx2`, on a CPU with AVX2.
    #[allow(unsafe_code)]
    let done = unsafe {
        match k {
            2 => super::blend::chunks_avx2::<2>(plane, out, weight),
            _ => super::blend::chunks_avx2::<4>(plane, out, weight),
        }
    };
    #[cfg(not(target_arch = "x86_64"))]
    let done = {
        let _ = (plane, weight, out);
        0
    };
    from..from + done * k
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
        assert_eq!(compared, 5 * 4 * 26, "rows compared");
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

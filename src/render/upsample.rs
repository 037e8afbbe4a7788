//! The reduced pass's upsampling, on the CPU: the procedural environment
//! and the magnified image skies are shaded at a reduced resolution (half
//! or a quarter per axis; linear RGB), and the frame's background is their
//! bilinear upsampling to 8-bit sRGB.
//!
//! The pass is sRGB-encoded at its own resolution, once a texel
//! (`upsample/source.rs`: the exact encode of `upsample/srgb.rs`, after the
//! tone and the exposure), and its 8-bit levels are interpolated in
//! integers: the sample positions of a clamping bilinear sampler at `uv =
//! position / (2 · principal point)`, the weights in 16ths (Vulkan's least
//! sub-texel precision; exact for a 2× or 4× upsampling), each output level
//! the weighted sum of its four texels' levels rounded once. So the
//! interpolation is in display values, as a GPU samples an sRGB texture
//! without its decode: a quarter (2×) or a sixteenth (4×) of the frame's
//! encodes, and a blend of small integers that vectorises on any CPU and
//! gives the same bytes on every one. docs/environments.md states how far
//! this lies from the same sky shaded at the frame's full resolution.

use half::slice::HalfFloatSliceExt;

mod across;
#[cfg(target_arch = "x86_64")]
mod gather;
mod parts;
mod source;
#[cfg(target_arch = "x86_64")]
mod split;
mod srgb;

use across::{Columns, ONE, across, taps};
pub(super) use parts::upsample_parts;
pub(super) use source::encode_source;
pub(super) use srgb::expose;
use srgb::{Buckets, CLIP, EXPONENTIAL};
#[cfg(test)]
use srgb::{SRGB, srgb_u8};

/// How the pass's values become display values before the sRGB encode.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) enum Tone {
    /// As they are, clipped to [0, 1] (the procedural environment; display-referred sky images).
    Clip,
    /// 1 − e^(−x) (HDR sky images, `tone_map` in environment.wgsl), each
    /// texel's before the interpolation.
    Exponential,
}

impl Tone {
    /// How the source encode applies exposure `gain` in this tone: the
    /// buckets it encodes through, the scale the texels take as they are
    /// read, and the gain the encoded levels are exposed by afterwards (1:
    /// none). Clipped values are scaled before the encode; the exponential
    /// tone's levels are exposed by the table ([`expose`]).
    fn encoding(self, gain: f32) -> (&'static Buckets, f32, f32) {
        match self {
            Self::Clip => (&**CLIP, gain, 1.0),
            Self::Exponential => (&**EXPONENTIAL, 1.0, gain),
        }
    }
}

/// A reduced pass's texels (RGBA, linear), read a row at a time.
#[derive(Clone, Copy)]
pub(super) enum Texels<'a> {
    /// Red, green and blue planes of `f32` values, rows one after the
    /// other (a pass shaded on the CPU: the procedural environment's on a
    /// CPU adapter, an image sky's), alpha 1.
    Planes(&'a [Vec<f32>; 3]),
    /// Half floats as the pass's RGBA16F readback holds them (little
    /// endian), rows `stride` bytes apart: converted a row at a time as the
    /// upsampling reaches it, with no frame-sized `f32` copy.
    F16 { bytes: &'a [u8], stride: usize },
}

impl Texels<'_> {
    /// Whether there are `h` rows of `w` texels.
    fn holds(&self, w: usize, h: usize) -> bool {
        match *self {
            Self::Planes(planes) => planes.iter().all(|p| p.len() >= w * h),
            Self::F16 { bytes, stride } => {
                h == 0 || (stride >= w * 8 && bytes.len() >= (h - 1) * stride + w * 8)
            }
        }
    }
}

/// Row `r` of half floats `bytes` (rows `stride` bytes apart; `out.len()`
/// values) into `out`.
fn f16_row_into((bytes, stride): (&[u8], usize), r: usize, out: &mut [f32]) {
    let src = &bytes[r * stride..r * stride + out.len() * 2];
    // In whole rows (vectorised where the CPU converts half floats).
    match bytemuck::try_cast_slice::<u8, half::f16>(src) {
        Ok(row) if cfg!(target_endian = "little") => row.convert_to_f32_slice(out),
        _ => {
            for (v, b) in out.iter_mut().zip(src.chunks_exact(2)) {
                *v = half::f16::from_le_bytes([b[0], b[1]]).to_f32();
            }
        }
    }
}

/// Upsample a reduced pass's `texels` (`size` of them) to the frame's
/// `frame` size into `rgba` (RGBA8, sRGB, alpha 255), for a camera whose
/// principal point is `centre` (pixels), through `tone` at exposure `gain`
/// (on linear light, 1: none): [`encode_source`] into `levels`, then
/// [`upsample_levels`].
pub(super) fn upsample_reduced(
    texels: Texels<'_>,
    size: (u32, u32),
    (frame, centre): ((u32, u32), (f32, f32)),
    tone: (Tone, f32),
    levels: &mut Vec<u8>,
    rgba: &mut Vec<u8>,
) {
    let source = (size.0 as usize, size.1 as usize);
    encode_source(&texels, source, tone, levels);
    upsample_levels(levels, size, (frame, centre), rgba);
}

/// Output rows per band of [`upsample_with`]: the bands are upsampled on
/// rayon's threads, each with its own blended rows (a band's first row
/// blends up to two source rows again).
const BAND_ROWS: usize = 64;

/// Upsample `levels` (RGBA8 sRGB levels of `size` texels, [`encode_source`])
/// to `frame` pixels into `rgba` for a camera whose principal point is
/// `centre`; black where the levels are too short for their size.
pub(super) fn upsample_levels(
    levels: &[u8],
    size: (u32, u32),
    (frame, centre): ((u32, u32), (f32, f32)),
    rgba: &mut Vec<u8>,
) {
    upsample_with(levels, (size, frame), centre, rgba, crate::simd::avx2());
}

/// [`upsample_levels`], its rows' horizontal blend in AVX2 registers when
/// `simd`, in bands of [`BAND_ROWS`] rows on rayon's threads: each row's
/// bytes depend only on its own two source rows, so the bands give the
/// bytes of one pass over the rows.
fn upsample_with(
    levels: &[u8],
    (size, frame): ((u32, u32), (u32, u32)),
    centre: (f32, f32),
    rgba: &mut Vec<u8>,
    simd: bool,
) {
    use rayon::prelude::*;
    let (w, h) = (size.0 as usize, size.1 as usize);
    // Every byte is written below (no clearing pass over the old contents).
    rgba.resize(frame.0 as usize * frame.1 as usize * 4, 0);
    if w == 0 || h == 0 || levels.len() < w * h * 4 || frame.0 == 0 {
        rgba.fill(0);
        return;
    }
    let columns = Columns::new(frame.0, size.0, centre.0);
    let rows = taps(frame.1, size.1, centre.1);
    let stride = frame.0 as usize * 4;
    let band = |(rows, lines): (&[across::Tap], &mut [u8])| {
        let mut blended = Blended::new(stride);
        for (&(r0, r1, wy), line) in rows.iter().zip(lines.chunks_exact_mut(stride)) {
            let source = |r: usize| &levels[r * w * 4..(r + 1) * w * 4];
            let (top, bottom) = blended.pair(source, &columns, (r0, r1), simd);
            crate::simd::widest(
                #[inline(always)]
                || down(top, bottom, wy, line),
            );
        }
    };
    rows.par_chunks(BAND_ROWS)
        .zip(rgba.par_chunks_mut(stride * BAND_ROWS))
        .for_each(band);
}

/// The last two source rows blended across ([`across`]): the rows only
/// move forward, so the second of one pair is often the first of the next.
struct Blended {
    rows: [usize; 2],
    sums: [Vec<u16>; 2],
}

impl Blended {
    /// Slots for rows of `bytes` sums (four an output pixel).
    fn new(bytes: usize) -> Self {
        Self {
            rows: [usize::MAX; 2],
            sums: [vec![0; bytes], vec![0; bytes]],
        }
    }

    /// Source rows `r0` and `r1` (`source(r)`: a row's levels) blended
    /// across every column.
    fn pair<'s, 'l>(
        &'s mut self,
        source: impl Fn(usize) -> &'l [u8],
        columns: &Columns,
        (r0, r1): (usize, usize),
        simd: bool,
    ) -> (&'s [u16], &'s [u16]) {
        let all = 0..columns.taps.len();
        let blend = |k: usize, r: usize, rows: &mut [usize; 2], sums: &mut [Vec<u16>; 2]| {
            across((source(r), 0), columns, all.clone(), &mut sums[k], simd);
            rows[k] = r;
        };
        if self.rows[0] != r0 {
            if self.rows[1] == r0 {
                self.rows.swap(0, 1);
                self.sums.swap(0, 1);
            } else {
                blend(0, r0, &mut self.rows, &mut self.sums);
            }
        }
        if r1 != r0 && self.rows[1] != r1 {
            blend(1, r1, &mut self.rows, &mut self.sums);
        }
        let [a, b] = &self.sums;
        (a, if r1 == r0 { a } else { b })
    }
}

/// The vertical half of the blend: two rows of sums in 16ths
/// ([`across`]) blended with weight `w` (16ths) on `bottom` and rounded
/// once to levels. The sums are at most 255 · 16, so every term fits 16 bits.
#[inline(always)]
fn down(top: &[u16], bottom: &[u16], w: u16, line: &mut [u8]) {
    let (near, far) = (ONE - w, w);
    for ((o, &p), &q) in line.iter_mut().zip(top).zip(bottom) {
        *o = ((p * near + q * far + 128) >> 8) as u8;
    }
}

/// The upsampling one pixel at a time: each texel encoded through
/// [`SrgbTable::encode`](srgb::SrgbTable::encode) (clipped, no exposure), each
/// output level its four texels' levels weighted by the taps' 16ths and
/// rounded once; the reference the kernels' bytes are checked against.
#[cfg(test)]
fn upsample_reference(
    half: &[f32],
    size: (u32, u32),
    frame: (u32, u32),
    centre: (f32, f32),
    rgba: &mut Vec<u8>,
) {
    let (w, h) = (size.0 as usize, size.1 as usize);
    rgba.clear();
    rgba.resize(frame.0 as usize * frame.1 as usize * 4, 0);
    if w == 0 || h == 0 || half.len() < w * h * 4 {
        return;
    }
    let level = |x: usize, y: usize, c: usize| u32::from(SRGB.encode(half[(y * w + x) * 4 + c]));
    let columns = taps(frame.0, size.0, centre.0);
    let rows = taps(frame.1, size.1, centre.1);
    let one = u32::from(ONE);
    for (px, i) in rgba.chunks_exact_mut(4).zip(0..) {
        let (c0, c1, wx) = columns[i % frame.0 as usize];
        let (r0, r1, wy) = rows[i / frame.0 as usize];
        let (wx, wy) = (u32::from(wx), u32::from(wy));
        for (c, out) in px[..3].iter_mut().enumerate() {
            let sum = level(c0, r0, c) * (one - wx) * (one - wy)
                + level(c1, r0, c) * wx * (one - wy)
                + level(c0, r1, c) * (one - wx) * wy
                + level(c1, r1, c) * wx * wy;
            *out = ((sum + 128) >> 8) as u8;
        }
        px[3] = 255;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn upsampling_interpolates_levels_with_the_samplers_weights() {
        // 2×1 texels (0 and 1 in red) to 4×2 pixels, centre (2, 1): the
        // columns sample at texel coordinates -0.25, 0.25, 0.75, 1.25.
        let upsample = |half: &[f32], tone: (Tone, f32)| {
            let (size, frame, centre) = ((2, 1), (4, 2), (2.0, 1.0));
            let texels = planes(half);
            let (mut levels, mut rgba) = (Vec::new(), Vec::new());
            upsample_reduced(
                Texels::Planes(&texels),
                size,
                (frame, centre),
                tone,
                &mut levels,
                &mut rgba,
            );
            assert_eq!(rgba.len(), 4 * 2 * 4);
            assert!(
                rgba.chunks_exact(4)
                    .all(|p| p[1] == 0 && p[2] == 0 && p[3] == 255)
            );
            rgba.chunks_exact(4).map(|p| p[0]).collect::<Vec<u8>>()
        };
        // Levels 0 and 255 blended a quarter and three quarters of the way:
        // the interpolation is in display values.
        let want = [0, 64, 191, 255];
        let red = upsample(&[0.0, 0.0, 0.0, 1.0, 1.0, 0.0, 0.0, 1.0], (Tone::Clip, 1.0));
        assert_eq!(&red[..4], &want);
        assert_eq!(&red[4..], &want, "rows clamp at the edge");
        // Exposed by half (a power of two: exact in f32), the light halves before the encode.
        let red = upsample(&[0.0, 0.0, 0.0, 1.0, 2.0, 0.0, 0.0, 1.0], (Tone::Clip, 0.5));
        assert_eq!(
            &red[..4],
            &want,
            "2.0 exposed by half is white, not clipped first"
        );
        // Tone-mapped per texel: 1 − e^(−x) of 0.5 is 0.393, level 167.
        let mid = srgb_u8(1.0 - (-0.5f32).exp());
        let red = upsample(
            &[0.0, 0.0, 0.0, 1.0, 0.5, 0.0, 0.0, 1.0],
            (Tone::Exponential, 1.0),
        );
        let quarter = ((u32::from(mid) * 4 * 16 + 128) >> 8) as u8;
        assert_eq!(&red[..4], &[0, quarter, mid - quarter, mid]);
    }

    /// RGBA texels as the red, green and blue planes of a pass shaded on the CPU.
    pub(super) fn planes(rgba: &[f32]) -> [Vec<f32>; 3] {
        [0, 1, 2].map(|c| rgba.iter().skip(c).step_by(4).copied().collect())
    }

    /// Random linear RGBA texels with edge cases: negative, above 1, ±∞, NaN.
    pub(super) fn texels(n: usize, seed: u64) -> Vec<f32> {
        let mut s = seed | 1;
        let mut next = move || {
            s ^= s << 13;
            s ^= s >> 7;
            s ^= s << 17;
            (s >> 40) as f32 / (1u64 << 24) as f32
        };
        (0..n)
            .map(|i| {
                let v = (i % 977) as f32 / 977.0 + (next() - 0.5) * 0.3;
                match (next() * 1000.0) as u32 {
                    0 => f32::INFINITY,
                    1 => f32::NAN,
                    2 => f32::NEG_INFINITY,
                    3..=9 => v * 4.0 - 2.0,
                    _ => v,
                }
            })
            .collect()
    }

    /// A source size, a frame size and the camera's principal point.
    pub(super) type Layout = ((u32, u32), (u32, u32), (f32, f32));

    /// Source and frame sizes and principal points the upsampling is tested
    /// on: exact 2× (even and odd), 4×, a layout of neither, off-centre, and
    /// tiny frames; the first three over several bands (a band's first row
    /// reloads its source rows).
    pub(super) const LAYOUTS: [Layout; 8] = [
        ((96, 54), (192, 108), (96.0, 54.0)),
        ((48, 27), (192, 108), (96.0, 54.0)),
        ((321, 240), (641, 479), (320.5, 239.5)),
        ((30, 17), (100, 60), (50.0, 30.0)),
        ((50, 30), (100, 60), (47.0, 33.0)),
        ((1, 1), (1, 1), (0.5, 0.5)),
        ((4, 3), (7, 5), (3.5, 2.5)),
        ((3, 2), (4, 3), (2.0, 1.5)),
    ];

    #[test]
    fn the_row_kernels_give_the_reference_bytes() {
        let cases = LAYOUTS;
        for (k, &(size, frame, centre)) in cases.iter().enumerate() {
            let half = texels(size.0 as usize * size.1 as usize * 4, k as u64 + 7);
            let mut want = Vec::new();
            upsample_reference(&half, size, frame, centre, &mut want);
            let source = (size.0 as usize, size.1 as usize);
            let mut levels = Vec::new();
            let texels = planes(&half);
            encode_source(
                &Texels::Planes(&texels),
                source,
                (Tone::Clip, 1.0),
                &mut levels,
            );
            for simd in [false, crate::simd::avx2()] {
                let mut got = Vec::new();
                upsample_with(&levels, (size, frame), centre, &mut got, simd);
                assert!(got == want, "case {k} (simd {simd}) differs");
            }
        }
        assert!(cases[..3].iter().all(|c| c.1.1 as usize > BAND_ROWS));
        // The exact 2× and 4× cases take the chunked paths.
        assert_eq!(Columns::new(192, 96, 96.0).factor, 2);
        assert_eq!(Columns::new(1920, 960, 960.0).factor, 2);
        assert_eq!(Columns::new(192, 48, 96.0).factor, 4);
        assert_eq!(Columns::new(1920, 480, 960.0).factor, 4);
        assert_eq!(Columns::new(100, 30, 50.0).factor, 0);
    }

    #[test]
    fn half_float_rows_give_the_bytes_of_their_f32_values() {
        // The readback's layout: RGBA16F rows padded to a stride, read a
        // row at a time, against the same values as f32 rows; rows of
        // whole groups of four texels and rows with one texel past them.
        for (size, frame, centre) in [
            ((96, 54), (192, 108), (96.0, 54.0)),
            ((45, 27), (90, 54), (45.0, 27.0)),
        ] {
            half_float_rows_of(size, frame, centre);
        }
    }

    fn half_float_rows_of(size: (u32, u32), frame: (u32, u32), centre: (f32, f32)) {
        let (w, h) = (size.0 as usize, size.1 as usize);
        let stride = (w * 8).next_multiple_of(256);
        let values = texels(w * h * 4, 11);
        let halves: Vec<half::f16> = values.iter().map(|&v| half::f16::from_f32(v)).collect();
        let mut bytes = vec![0xAB; stride * h];
        for (r, row) in halves.chunks_exact(w * 4).enumerate() {
            for (k, v) in row.iter().enumerate() {
                bytes[r * stride + 2 * k..][..2].copy_from_slice(&v.to_le_bytes());
            }
        }
        let exact: Vec<f32> = halves.iter().map(|v| v.to_f32()).collect();
        let mut levels = Vec::new();
        let exact = planes(&exact);
        for tone in [Tone::Clip, Tone::Exponential] {
            let (mut want, mut got) = (Vec::new(), Vec::new());
            let place = (frame, centre);
            let texels = Texels::Planes(&exact);
            upsample_reduced(texels, size, place, (tone, 0.75), &mut levels, &mut want);
            let f16 = Texels::F16 {
                bytes: &bytes,
                stride,
            };
            upsample_reduced(f16, size, place, (tone, 0.75), &mut levels, &mut got);
            assert!(got == want, "{tone:?}");
        }
        // A buffer one byte short of its last row is refused, not read past.
        let short = Texels::F16 {
            bytes: &bytes[..stride * (h - 1) + w * 8 - 1],
            stride,
        };
        let mut black = Vec::new();
        let tone = (Tone::Clip, 1.0);
        upsample_reduced(short, size, (frame, centre), tone, &mut levels, &mut black);
        assert!(black.iter().all(|&b| b == 0));
    }

    #[test]
    fn a_short_source_gives_a_black_frame_not_a_panic() {
        let mut rgba = vec![9; 3];
        let mut levels = vec![7; 5];
        upsample_reduced(
            Texels::Planes(&planes(&[0.5; 4])),
            (2, 2),
            ((4, 4), (2.0, 2.0)),
            (Tone::Clip, 1.0),
            &mut levels,
            &mut rgba,
        );
        assert_eq!(rgba, vec![0; 64]);
        // Levels too short for their size, as a caller may hold them.
        upsample_levels(&[200; 12], (2, 2), ((4, 4), (2.0, 2.0)), &mut rgba);
        assert_eq!(rgba, vec![0; 64]);
    }
}

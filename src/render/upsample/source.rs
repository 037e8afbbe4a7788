//! The upsampling's source encoded: a reduced pass's texels (colour planes,
//! or the readback's half floats) through the tone and the exposure to
//! sRGB 8-bit levels at the pass's own resolution, rounded exactly
//! ([`super::srgb`]); a quarter or a sixteenth of the frame's encodes.

use super::srgb::Buckets;
use super::{Texels, Tone, srgb};

/// Source rows per band of [`encode_source`] (the bands on rayon's threads).
const BAND_ROWS: usize = 16;

/// `texels` (`size` of them) encoded into `levels` (RGBA8, sRGB, alpha 255,
/// rows of `size.0` texels) through `tone` at exposure `gain`: the display
/// values times `gain` are encoded. With [`Tone::Clip`] the texels are scaled
/// as they are read; after [`Tone::Exponential`] the levels are exposed by
/// the table ([`srgb::expose_with`]). A source too short for its size gives
/// no levels (whose upsampling is black).
pub(in crate::render) fn encode_source(
    texels: &Texels<'_>,
    size: (usize, usize),
    (tone, gain): (Tone, f32),
    levels: &mut Vec<u8>,
) {
    use rayon::prelude::*;
    let (w, h) = size;
    levels.clear();
    if w == 0 || !texels.holds(w, h) {
        return;
    }
    levels.resize(w * h * 4, 0);
    let (buckets, scale, exposure) = tone.encoding(gain);
    let exposed = (exposure != 1.0).then(|| srgb::exposure_table(exposure));
    let simd = crate::simd::avx2();
    let band = |(b, lines): (usize, &mut [u8])| {
        let mut rows = SourceRow::new(w, scale, texels);
        for (r, line) in (b * BAND_ROWS..).zip(lines.chunks_exact_mut(w * 4)) {
            encode_values(rows.row(texels, r), buckets, line, simd);
            if let Some(table) = &exposed {
                srgb::expose_with(table, line);
            }
        }
    };
    levels
        .par_chunks_mut(w * 4 * BAND_ROWS)
        .enumerate()
        .for_each(band);
}

/// Three planes of linear values encoded into `line` (RGBA8, alpha 255):
/// eight pixels a gather when `gather` (only where the CPU has AVX2), else
/// one at a time; the same bytes.
#[inline(always)]
pub(super) fn encode_values(
    [r, g, b]: [&[f32]; 3],
    buckets: &Buckets,
    line: &mut [u8],
    gather: bool,
) {
    #[cfg(target_arch = "x86_64")]
    if gather {
        // SAFETY: callers pass `gather` only on a CPU with AVX2.
        #[allow(unsafe_code)]
        unsafe {
            super::gather::encode_line_avx2([r, g, b], buckets, line);
        }
        return;
    }
    let _ = gather;
    for (((px, r), g), b) in line.chunks_exact_mut(4).zip(r).zip(g).zip(b) {
        let word =
            buckets.encode(*r) | buckets.encode(*g) << 8 | buckets.encode(*b) << 16 | 0xff00_0000;
        px.copy_from_slice(&word.to_le_bytes());
    }
}

/// A source row as planes of linear values, one per colour channel: borrowed
/// where the texels are planes already and need no scaling, else converted
/// (and scaled) into the row's own planes.
struct SourceRow {
    /// Texels a row.
    width: usize,
    /// The row's planes when converted.
    planes: [Vec<f32>; 3],
    /// A row's half-float texels (RGBA) as converted, before they are split.
    texels: Vec<f32>,
    /// The scale each converted row is multiplied by (1: none).
    scale: f32,
}

impl SourceRow {
    /// Rows of `w` texels of `texels`, scaled by `scale`.
    fn new(w: usize, scale: f32, texels: &Texels<'_>) -> Self {
        let borrowed = matches!(texels, Texels::Planes(_)) && scale == 1.0;
        let planes = || if borrowed { Vec::new() } else { vec![0.0; w] };
        Self {
            width: w,
            planes: [planes(), planes(), planes()],
            texels: Vec::new(),
            scale,
        }
    }

    /// Row `r` of `texels` as planes.
    fn row<'s>(&'s mut self, texels: &Texels<'s>, r: usize) -> [&'s [f32]; 3] {
        let w = self.width;
        match *texels {
            Texels::Planes(planes) if self.scale == 1.0 => {
                return planes.each_ref().map(|p| &p[r * w..(r + 1) * w]);
            }
            Texels::Planes(planes) => {
                for (to, from) in self.planes.iter_mut().zip(planes) {
                    to.copy_from_slice(&from[r * w..(r + 1) * w]);
                }
            }
            Texels::F16 { bytes, stride } => self.split_f16((bytes, stride), r),
        }
        if self.scale != 1.0 {
            for plane in &mut self.planes {
                plane.iter_mut().for_each(|v| *v *= self.scale);
            }
        }
        self.planes.each_ref().map(|p| &p[..])
    }

    /// Row `r` of half floats `bytes` (rows `stride` bytes apart) into the
    /// planes: straight into them where the CPU converts half floats in AVX2
    /// registers, otherwise through `self.texels`.
    fn split_f16(&mut self, (bytes, stride): (&[u8], usize), r: usize) {
        let w = self.width;
        #[cfg(target_arch = "x86_64")]
        if crate::simd::f16c() {
            let [red, green, blue] = &mut self.planes;
            let src = &bytes[r * stride..r * stride + w * 8];
            // SAFETY: the CPU has AVX2 and F16C (`f16c`).
            #[allow(unsafe_code)]
            unsafe {
                super::split::split_f16c(src, [red, green, blue])
            };
            return;
        }
        self.texels.resize(w * 4, 0.0);
        super::f16_row_into((bytes, stride), r, &mut self.texels);
        let [red, green, blue] = &mut self.planes;
        let planes = red.iter_mut().zip(green.iter_mut()).zip(blue.iter_mut());
        for (((r, g), b), t) in planes.zip(self.texels.chunks_exact(4)) {
            (*r, *g, *b) = (t[0], t[1], t[2]);
        }
    }
}

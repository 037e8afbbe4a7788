//! The chain's first stage: exposure and white balance, × 2^EV × (R, 1, B)
//! gains on linear light, folded into each channel's 256-entry decode table
//! (sRGB 8-bit → linear); and the decode of an image row's channel through
//! it, clamped to the image's columns.

use std::sync::OnceLock;

use super::CameraDraw;

mod avx512;

/// sRGB 8-bit → linear light.
pub(super) fn decode_table() -> &'static [f32; 256] {
    static T: OnceLock<[f32; 256]> = OnceLock::new();
    T.get_or_init(|| {
        std::array::from_fn(|i| {
            let c = i as f64 / 255.0;
            let l = if c <= 0.04045 {
                c / 12.92
            } else {
                ((c + 0.055) / 1.055).powf(2.4)
            };
            l as f32
        })
    })
}

/// The input image (RGBA8, `width`×`height`) and each channel's decode
/// table with the exposure and white balance folded in ([`luts`]).
pub(super) struct Exposure<'a> {
    pub(super) rgba: &'a [u8],
    pub(super) width: i64,
    pub(super) height: i64,
    pub(super) luts: [Lut; 3],
}

/// A channel's decode table, and its values' bytes as planes for the
/// AVX-512 decode ([`avx512`]).
pub(super) struct Lut {
    values: [f32; 256],
    planes: avx512::Planes,
}

impl<'a> Exposure<'a> {
    pub(super) fn new(rgba: &'a [u8], width: u32, height: u32, draw: &CameraDraw) -> Self {
        Self {
            rgba,
            width: i64::from(width),
            height: i64::from(height),
            luts: luts(draw).map(|values| Lut {
                planes: avx512::Planes::of(&values),
                values,
            }),
        }
    }

    /// Whether the tables are the plain decode (unit gains): the encode
    /// table inverts it on all 256 levels.
    pub(super) fn is_identity(&self) -> bool {
        let unit = decode_table();
        self.luts.iter().all(|l| &l.values == unit)
    }
}

/// Each channel's decode table with the draw's exposure and white balance
/// folded in: `decode_table()[v] · gain` in f64, rounded to f32.
pub(super) fn luts(draw: &CameraDraw) -> [[f32; 256]; 3] {
    let exposure = draw.exposure_gain();
    let gains = [
        exposure * draw.white_balance_red,
        exposure,
        exposure * draw.white_balance_blue,
    ];
    let table = decode_table();
    gains.map(|g| std::array::from_fn(|i| (f64::from(table[i]) * g) as f32))
}

/// RGBA8 image row `row`'s channel `c` through `lut` at image columns
/// `first`, `first + 1`, … (as many as `out` is long), clamped to the row:
/// the columns inside the row by VBMI's byte permutes where the CPU has
/// them ([`avx512`]), else in the AVX2 build where it has AVX2, even inside
/// the AVX-512 band (AVX-512 gathers are slower than AVX2's look-ups one
/// lane at a time: 0.28 against 0.19 ns a value on the 2-core AMD EPYC
/// build machine).
#[inline(always)]
pub(super) fn decode_row(lut: &Lut, row: &[u8], c: usize, first: i64, out: &mut [f32]) {
    #[cfg(target_arch = "x86_64")]
    if crate::simd::avx512_icl() {
        let (inside, start) = decode_edges(&lut.values, row, c, first, out);
        // SAFETY: the CPU has AVX-512 F, BW and VBMI (checked by `avx512_icl`).
        #[allow(unsafe_code)]
        unsafe {
            return avx512::decode_avx512((&lut.values, &lut.planes), &row[start..], c, inside);
        }
    }
    #[cfg(target_arch = "x86_64")]
    if crate::simd::simd_level() >= 1 {
        // SAFETY: the CPU has AVX2 (checked by `simd_level`).
        #[allow(unsafe_code)]
        unsafe {
            return decode_row_avx2(&lut.values, row, c, first, out);
        }
    }
    decode_row_any(&lut.values, row, c, first, out);
}

/// [`decode_row_any`] for AVX2: a function of its own (not a closure), so
/// that its slices keep their no-alias arguments and the loop vectorises.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
#[inline(never)]
fn decode_row_avx2(lut: &[f32; 256], row: &[u8], c: usize, first: i64, out: &mut [f32]) {
    decode_row_any(lut, row, c, first, out);
}

/// The columns of [`decode_row`] outside the row (clamped: its first or
/// last pixel's value), filled; the values of the columns inside it left
/// to the caller: their part of `out`, and their first byte in `row`.
#[inline(always)]
fn decode_edges<'o>(
    lut: &[f32; 256],
    row: &[u8],
    c: usize,
    first: i64,
    out: &'o mut [f32],
) -> (&'o mut [f32], usize) {
    let (w, n) = ((row.len() / 4) as i64, out.len() as i64);
    let lo = (-first).clamp(0, n) as usize;
    let hi = (w - first).clamp(lo as i64, n) as usize;
    let (left, rest) = out.split_at_mut(lo);
    let (inside, right) = rest.split_at_mut(hi - lo);
    left.fill(lut[usize::from(row[c])]);
    right.fill(lut[usize::from(row[(w as usize - 1) * 4 + c])]);
    let start = if inside.is_empty() {
        0
    } else {
        (first + lo as i64) as usize * 4
    };
    (inside, start)
}

/// [`decode_row`] in whatever build its caller has.
#[inline(always)]
fn decode_row_any(lut: &[f32; 256], row: &[u8], c: usize, first: i64, out: &mut [f32]) {
    let (inside, start) = decode_edges(lut, row, c, first, out);
    for (o, px) in inside.iter_mut().zip(row[start..].chunks_exact(4)) {
        *o = lut[usize::from(px[c])];
    }
}

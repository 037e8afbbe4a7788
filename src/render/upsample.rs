//! The procedural environment's upsampling, on the CPU: the environment
//! pass draws at half resolution per axis (linear RGB, half floats), and
//! the frame's background is its bilinear upsampling, sRGB-encoded to 8 bits.
//!
//! On the GPU this was a full-frame pass (a filtered texture fetch and an
//! sRGB `pow` per pixel) and a full-frame readback; lavapipe spent more CPU
//! on it than the whole frame's drones. Here it is separable and exact:
//! the same sample positions and weights as the GPU pass's clamping
//! bilinear sampler (`uv = position / (2 · principal point)`), the
//! interpolation in `f32`, and the sRGB encoding rounded exactly
//! (`upsample/srgb.rs`). It differs from the GPU pass by at most one
//! 8-bit level where lavapipe's `pow` and filtering round the other way
//! (docs/benchmarks.md states how many pixels).

use std::ops::Range;

use half::slice::HalfFloatSliceExt;

#[cfg(target_arch = "x86_64")]
mod blend;
#[cfg(target_arch = "x86_64")]
mod gather;
mod parts;
#[cfg(target_arch = "x86_64")]
mod split;
mod srgb;

pub(super) use parts::upsample_parts;
pub(super) use srgb::expose;
use srgb::{Buckets, CLIP, EXPONENTIAL};
#[cfg(test)]
use srgb::{SRGB, srgb_u8};

/// Where output pixels sample along one axis: the two texels and the
/// second's weight, as a clamping bilinear sampler at
/// `(i + 0.5) / (2 · centre)` of `source` texels.
fn taps(out: u32, source: u32, centre: f32) -> Vec<(usize, usize, f32)> {
    let last = source.saturating_sub(1) as usize;
    (0..out)
        .map(|i| {
            let uv = (i as f32 + 0.5) / (2.0 * centre);
            let t = uv * source as f32 - 0.5;
            let base = t.floor();
            let w = t - base;
            let clamp = |v: f32| (v.max(0.0) as usize).min(last);
            (clamp(base), clamp(base + 1.0), w)
        })
        .collect()
}

/// How the upsampled values become display values before the sRGB encode.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) enum Tone {
    /// As they are, clipped to [0, 1] (the procedural environment; display-referred sky images).
    Clip,
    /// 1 − e^(−x) (HDR sky images, `tone_map` in environment.wgsl): applied
    /// after the interpolation, as when the full-resolution pass tone-mapped
    /// the bilinearly sampled radiance.
    Exponential,
}

impl Tone {
    /// How the upsampling applies exposure `gain` in this tone: the buckets
    /// it encodes through, the scale the texels take as they are read, and
    /// the gain the encoded levels are exposed by afterwards (1: none).
    /// Clipped values are scaled before the blend (it is linear); the
    /// exponential tone's levels are exposed by the table ([`expose`]).
    fn encoding(self, gain: f32) -> (&'static Buckets, f32, f32) {
        match self {
            Self::Clip => (&**CLIP, gain, 1.0),
            Self::Exponential => (&**EXPONENTIAL, 1.0, gain),
        }
    }
}

/// Where one output row's pixels sample the source: per column the
/// second texel's weight ([`taps`]), and the columns in runs that share
/// their two texels (`(first texel, second texel, columns)`: the taps only
/// move forward); `factor` 2 or 4 when the columns follow that exact
/// integer pattern ([`chunk_layout`]), which lets the row be blended in
/// SIMD lanes, else 0.
struct Columns {
    weight: Vec<f32>,
    runs: Vec<(usize, usize, Range<usize>)>,
    factor: usize,
}

/// The column layout of an exact `k`× upsampling of `source` texels to
/// `out` columns: `k / 2` head columns on texel 0, then `mid` chunks of
/// `k` columns, chunk c between texels c and c + 1, then the tail on texel
/// `mid` alone (both taps the same texel). `(head, mid)`.
fn chunk_layout(k: usize, out: usize, source: usize) -> (usize, usize) {
    let head = (k / 2).min(out);
    (head, ((out - head) / k).min(source.saturating_sub(1)))
}

impl Columns {
    fn new(out: u32, source: u32, centre: f32) -> Self {
        let taps = taps(out, source, centre);
        let follows = |k: usize| {
            let (head, mid) = chunk_layout(k, taps.len(), source as usize);
            source > 0
                && taps.iter().enumerate().all(|(i, &(a, b, _))| {
                    let want = if i < head {
                        (0, 0)
                    } else if i < head + mid * k {
                        ((i - head) / k, (i - head) / k + 1)
                    } else {
                        (mid, mid)
                    };
                    (a, b) == want
                })
        };
        let factor = [2, 4].into_iter().find(|&k| follows(k)).unwrap_or(0);
        let mut runs: Vec<(usize, usize, Range<usize>)> = Vec::new();
        for (i, &(a, b, _)) in taps.iter().enumerate() {
            match runs.last_mut() {
                Some((ra, rb, r)) if (*ra, *rb) == (a, b) => r.end = i + 1,
                _ => runs.push((a, b, i..i + 1)),
            }
        }
        Self {
            weight: taps.iter().map(|t| t.2).collect(),
            runs,
            factor,
        }
    }
}

/// One plane's row blended across columns laid out by [`chunk_layout`]
/// for factor `K` (checked by [`Columns::new`]); the chunks eight values
/// at a time in AVX2 when `simd` ([`blend::chunks_avx2`]; only in
/// [`upsample_row_avx2`]).
#[inline(always)]
fn blend_chunks<const K: usize>(plane: &[f32], value: &mut [f32], weight: &[f32], simd: bool) {
    let (head, mid) = chunk_layout(K, value.len(), plane.len());
    let (first, rest) = value.split_at_mut(head);
    let (chunks, tail) = rest.split_at_mut(mid * K);
    // Both texels the same: as the sampler, ±∞ and NaN included.
    for (v, w) in first.iter_mut().zip(weight) {
        *v = lerp(plane[0], plane[0], *w);
    }
    #[cfg(target_arch = "x86_64")]
    // SAFETY: only from `upsample_row_avx2`, on a CPU with AVX2.
    #[allow(unsafe_code)]
    let done = if simd {
        unsafe { blend::chunks_avx2::<K>(plane, chunks, &weight[head..]) }
    } else {
        0
    };
    #[cfg(not(target_arch = "x86_64"))]
    let done = 0;
    let _ = simd;
    let chunk_weights = weight[head + done * K..].chunks_exact(K);
    for ((v, p), w) in chunks[done * K..]
        .chunks_exact_mut(K)
        .zip(plane[done..].windows(2))
        .zip(chunk_weights)
    {
        let d = p[1] - p[0];
        for k in 0..K {
            v[k] = p[0] + d * w[k];
        }
    }
    let p = plane[mid];
    for (v, w) in tail.iter_mut().zip(&weight[head + mid * K..]) {
        *v = lerp(p, p, *w);
    }
}

/// The sampler's blend of `p` and `q` with weight `w` on `q`, in this order
/// of operations.
#[inline(always)]
fn lerp(p: f32, q: f32, w: f32) -> f32 {
    p + (q - p) * w
}

/// One source row pair, blended vertically then horizontally, in planes.
struct RowScratch {
    /// The vertical blend of the two source rows, per channel.
    planes: [Vec<f32>; 3],
    /// The output row's linear values, per channel.
    values: [Vec<f32>; 3],
}

/// A source row as planes of linear values, one per colour channel
/// ([`SourceRows`] converts each row once, or borrows it).
type Planes<'a> = [&'a [f32]; 3];

/// One output row: the source rows `a` and `b` (planes) blended with
/// weight `wy`, then across `columns`, encoded into `line` (RGBA8). The
/// same f32 operations, in the same order, as the GPU sampler's bilinear
/// filter: `p + (q − p) · w` vertically, then horizontally. `gather`: the
/// encode in AVX2 gathers ([`gather::encode_line_avx2`]; only in
/// [`upsample_row_avx2`]).
#[inline(always)]
fn upsample_row(
    (a, b, wy): (Planes<'_>, Planes<'_>, f32),
    columns: &Columns,
    scratch: &mut RowScratch,
    (buckets, gather): (&Buckets, bool),
    line: &mut [u8],
) {
    let RowScratch { planes, values } = scratch;
    for ((plane, a), b) in planes.iter_mut().zip(a).zip(b) {
        for ((o, p), q) in plane.iter_mut().zip(a).zip(b) {
            *o = p + (q - p) * wy;
        }
    }
    for (plane, value) in planes.iter().zip(values.iter_mut()) {
        let weight = &columns.weight;
        if columns.factor == 2 {
            blend_chunks::<2>(plane, value, weight, gather);
        } else if columns.factor == 4 {
            blend_chunks::<4>(plane, value, weight, gather);
        } else {
            for (a, b, run) in &columns.runs {
                let (p, q) = (plane[*a], plane[*b]);
                let d = q - p;
                for (v, w) in value[run.clone()].iter_mut().zip(&weight[run.clone()]) {
                    *v = p + d * w;
                }
            }
        }
    }
    let [r, g, b] = &*values;
    encode_values([r, g, b], buckets, line, gather);
}

/// Three planes of linear values encoded into `line` (RGBA8, alpha 255):
/// eight pixels a gather when `gather` (only where the CPU has AVX2), else
/// one at a time; the same bytes.
#[inline(always)]
fn encode_values([r, g, b]: [&[f32]; 3], buckets: &Buckets, line: &mut [u8], gather: bool) {
    #[cfg(target_arch = "x86_64")]
    if gather {
        // SAFETY: callers pass `gather` only on a CPU with AVX2.
        #[allow(unsafe_code)]
        unsafe {
            gather::encode_line_avx2([r, g, b], buckets, line);
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

/// [`upsample_row`] built for AVX2 (the same operations: the bytes are the same).
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
#[inline(never)]
fn upsample_row_avx2(
    rows: (Planes<'_>, Planes<'_>, f32),
    columns: &Columns,
    scratch: &mut RowScratch,
    buckets: &Buckets,
    line: &mut [u8],
) {
    upsample_row(rows, columns, scratch, (buckets, true), line);
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

/// The two source rows an output row blends, converted once each into
/// planes (the blends then run on whole vectors of one channel): the rows
/// only move forward, so the second of one pair is often the first of
/// the next.
struct SourceRows {
    /// Texels a row.
    width: usize,
    rows: [usize; 2],
    data: [[Vec<f32>; 3]; 2],
    /// A row's half-float texels (RGBA) as converted, before they are split.
    texels: Vec<f32>,
    /// The exposure each converted row is multiplied by (1: none).
    gain: f32,
}

impl SourceRows {
    /// Rows of `w` texels of `texels`, exposed by `gain`: slots for two
    /// converted rows unless the rows are borrowed ([`Self::borrowed`]).
    fn new(w: usize, gain: f32, texels: &Texels<'_>) -> Self {
        let mut rows = Self {
            width: w,
            rows: [usize::MAX; 2],
            data: Default::default(),
            texels: Vec::new(),
            gain,
        };
        if rows.borrowed(texels).is_none() {
            let planes = || [vec![0.0; w], vec![0.0; w], vec![0.0; w]];
            rows.data = [planes(), planes()];
        }
        rows
    }

    /// Row `r` of `texels` into slot `k`, exposed.
    fn load(&mut self, texels: &Texels<'_>, k: usize, r: usize) {
        let g = self.gain;
        match *texels {
            Texels::Planes(planes) => {
                for (to, from) in self.data[k].iter_mut().zip(planes) {
                    let w = to.len();
                    to.copy_from_slice(&from[r * w..(r + 1) * w]);
                }
            }
            Texels::F16 { bytes, stride } => self.split_f16((bytes, stride), r, k),
        }
        if g != 1.0 {
            for plane in &mut self.data[k] {
                plane.iter_mut().for_each(|v| *v *= g);
            }
        }
        self.rows[k] = r;
    }

    /// Row `r` of half floats `bytes` (rows `stride` bytes apart) into slot
    /// `k`'s planes: straight into them where the CPU converts half floats
    /// in AVX2 registers, otherwise through `self.texels`.
    fn split_f16(&mut self, (bytes, stride): (&[u8], usize), r: usize, k: usize) {
        #[cfg(target_arch = "x86_64")]
        if crate::simd::f16c() {
            let [red, green, blue] = &mut self.data[k];
            let src = &bytes[r * stride..r * stride + red.len() * 8];
            // SAFETY: the CPU has AVX2 and F16C (`f16c`).
            #[allow(unsafe_code)]
            unsafe {
                split::split_f16c(src, [red, green, blue])
            };
            return;
        }
        self.texels.resize(self.width * 4, 0.0);
        f16_row_into((bytes, stride), r, &mut self.texels);
        let [red, green, blue] = &mut self.data[k];
        let planes = red.iter_mut().zip(green.iter_mut()).zip(blue.iter_mut());
        for (((r, g), b), t) in planes.zip(self.texels.chunks_exact(4)) {
            (*r, *g, *b) = (t[0], t[1], t[2]);
        }
    }

    /// Rows `r0` and `r1` (r0 ≤ r1) of `texels`: borrowed where they are
    /// planes already and need no exposure, else converted into the slots.
    fn pair<'s>(
        &'s mut self,
        texels: &Texels<'s>,
        r0: usize,
        r1: usize,
    ) -> (Planes<'s>, Planes<'s>) {
        if let Some(planes) = self.borrowed(texels) {
            let w = self.width;
            let row = |r: usize| planes.each_ref().map(|p| &p[r * w..(r + 1) * w]);
            return (row(r0), row(r1));
        }
        if self.rows[0] != r0 {
            if self.rows[1] == r0 {
                self.rows.swap(0, 1);
                self.data.swap(0, 1);
            } else {
                self.load(texels, 0, r0);
            }
        }
        if r1 != r0 && self.rows[1] != r1 {
            self.load(texels, 1, r1);
        }
        let [a, b] = &self.data;
        let b = if r1 == r0 { a } else { b };
        (a.each_ref().map(|p| &p[..]), b.each_ref().map(|p| &p[..]))
    }

    /// `texels`' planes when the rows can be read in place (no exposure).
    fn borrowed<'t>(&self, texels: &Texels<'t>) -> Option<&'t [Vec<f32>; 3]> {
        match *texels {
            Texels::Planes(planes) if self.gain == 1.0 => Some(planes),
            _ => None,
        }
    }
}

/// Upsample a reduced pass's `texels` (`size` of them) to the frame's
/// `frame` size into `rgba` (RGBA8, sRGB, alpha 255), for a camera whose
/// principal point is `centre` (pixels), through `tone`, exposed by `gain`
/// (the camera's exposure on linear light, 1: none): the display values
/// times `gain` are encoded. With [`Tone::Clip`] the texels are scaled as
/// they are read (the blend is linear, so no pass of its own); after
/// [`Tone::Exponential`] the encoded picture goes through [`expose`].
pub(super) fn upsample_reduced(
    texels: Texels<'_>,
    size: (u32, u32),
    frame: (u32, u32),
    centre: (f32, f32),
    (tone, gain): (Tone, f32),
    rgba: &mut Vec<u8>,
) {
    let (buckets, scale, exposure) = tone.encoding(gain);
    let simd = crate::simd::avx2();
    upsample_with(texels, (size, frame), centre, (buckets, scale), rgba, simd);
    if exposure != 1.0 {
        expose(rgba, exposure);
    }
}

/// Output rows per band of [`upsample_with`]: the bands are upsampled on
/// rayon's threads, each with its own source rows and scratch (a band's
/// first row converts up to two source rows again).
const BAND_ROWS: usize = 64;

/// [`upsample_reduced`] through `buckets`, its rows in the AVX2 build when
/// `simd`, in bands of [`BAND_ROWS`] rows on rayon's threads: each row's
/// bytes depend only on its own two source rows, so the bands give the
/// bytes of one pass over the rows.
fn upsample_with(
    texels: Texels<'_>,
    (size, frame): ((u32, u32), (u32, u32)),
    centre: (f32, f32),
    (buckets, gain): (&Buckets, f32),
    rgba: &mut Vec<u8>,
    simd: bool,
) {
    use rayon::prelude::*;
    let (w, h) = (size.0 as usize, size.1 as usize);
    // Every byte is written below (no clearing pass over the old contents).
    rgba.resize(frame.0 as usize * frame.1 as usize * 4, 0);
    if w == 0 || h == 0 || !texels.holds(w, h) || frame.0 == 0 {
        rgba.fill(0);
        return;
    }
    let columns = Columns::new(frame.0, size.0, centre.0);
    let rows = taps(frame.1, size.1, centre.1);
    let stride = frame.0 as usize * 4;
    let band = |(rows, lines): (&[(usize, usize, f32)], &mut [u8])| {
        let mut source = SourceRows::new(w, gain, &texels);
        let plane = vec![0f32; w];
        let value = vec![0f32; frame.0 as usize];
        let mut scratch = RowScratch {
            planes: [plane.clone(), plane.clone(), plane],
            values: [value.clone(), value.clone(), value],
        };
        for (&(r0, r1, wy), line) in rows.iter().zip(lines.chunks_exact_mut(stride)) {
            let (a, b) = source.pair(&texels, r0, r1);
            upsample_line((a, b, wy), &columns, &mut scratch, (buckets, simd), line);
        }
    };
    rows.par_chunks(BAND_ROWS)
        .zip(rgba.par_chunks_mut(stride * BAND_ROWS))
        .for_each(band);
}

/// One output row through [`upsample_row_avx2`] when `simd`, else [`upsample_row`].
#[inline(always)]
fn upsample_line(
    pair: (Planes<'_>, Planes<'_>, f32),
    columns: &Columns,
    scratch: &mut RowScratch,
    (buckets, simd): (&Buckets, bool),
    line: &mut [u8],
) {
    #[cfg(target_arch = "x86_64")]
    if simd {
        // SAFETY: the CPU has AVX2 (checked by `avx2`).
        #[allow(unsafe_code)]
        unsafe {
            upsample_row_avx2(pair, columns, scratch, buckets, line);
        }
        return;
    }
    let _ = simd;
    upsample_row(pair, columns, scratch, (buckets, false), line);
}

/// The upsampling one pixel at a time through [`SrgbTable::encode`]: what
/// [`upsample_reduced`] computed before it was vectorised, kept as the
/// reference its bytes are checked against.
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
    let table = &*SRGB;
    let columns = taps(frame.0, size.0, centre.0);
    let rows = taps(frame.1, size.1, centre.1);
    // One source row pair blended vertically (RGB), reused across output rows.
    let mut blended = vec![0f32; w * 3];
    let stride = frame.0 as usize * 4;
    for (&(r0, r1, wy), line) in rows.iter().zip(rgba.chunks_exact_mut(stride)) {
        let (a, b) = (&half[r0 * w * 4..], &half[r1 * w * 4..]);
        for (x, out) in blended.chunks_exact_mut(3).enumerate() {
            for c in 0..3 {
                let (p, q) = (a[x * 4 + c], b[x * 4 + c]);
                out[c] = p + (q - p) * wy;
            }
        }
        for (&(c0, c1, wx), px) in columns.iter().zip(line.chunks_exact_mut(4)) {
            let (p, q) = (&blended[c0 * 3..c0 * 3 + 3], &blended[c1 * 3..c1 * 3 + 3]);
            px[0] = table.encode(p[0] + (q[0] - p[0]) * wx);
            px[1] = table.encode(p[1] + (q[1] - p[1]) * wx);
            px[2] = table.encode(p[2] + (q[2] - p[2]) * wx);
            px[3] = 255;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn upsampling_interpolates_with_the_samplers_weights() {
        // 2×1 texels (0 and 1 in red) to 4×2 pixels, centre (2, 1): the
        // columns sample at texel coordinates -0.25, 0.25, 0.75, 1.25.
        let mut rgba = Vec::new();
        let mut upsample = |half: &[f32], gain: f32| {
            let (size, frame, centre) = ((2, 1), (4, 2), (2.0, 1.0));
            upsample_reduced(
                Texels::Planes(&planes(half)),
                size,
                frame,
                centre,
                (Tone::Clip, gain),
                &mut rgba,
            );
            assert_eq!(rgba.len(), 4 * 2 * 4);
            rgba.chunks_exact(4).map(|p| p[0]).collect::<Vec<u8>>()
        };
        let red = upsample(&[0.0, 0.0, 0.0, 1.0, 1.0, 0.0, 0.0, 1.0], 1.0);
        let want = [0.0, 0.25, 0.75, 1.0].map(srgb_u8);
        assert_eq!(&red[..4], &want);
        assert_eq!(&red[4..], &want, "rows clamp at the edge");
        // Exposed by half (a power of two: exact in f32), the light halves before the encode.
        let red = upsample(&[0.0, 0.0, 0.0, 1.0, 2.0, 0.0, 0.0, 1.0], 0.5);
        assert_eq!(
            &red[..4],
            &want,
            "2.0 exposed by half is white, not clipped first"
        );
        assert!(
            rgba.chunks_exact(4)
                .all(|p| p[1] == 0 && p[2] == 0 && p[3] == 255)
        );
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
            for simd in [false, crate::simd::avx2()] {
                let mut got = Vec::new();
                upsample_with(
                    Texels::Planes(&planes(&half)),
                    (size, frame),
                    centre,
                    (&**CLIP, 1.0),
                    &mut got,
                    simd,
                );
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
        for tone in [Tone::Clip, Tone::Exponential] {
            let (mut want, mut got) = (Vec::new(), Vec::new());
            upsample_reduced(
                Texels::Planes(&planes(&exact)),
                size,
                frame,
                centre,
                (tone, 0.75),
                &mut want,
            );
            let f16 = Texels::F16 {
                bytes: &bytes,
                stride,
            };
            upsample_reduced(f16, size, frame, centre, (tone, 0.75), &mut got);
            assert!(got == want, "{tone:?}");
        }
        // A buffer one byte short of its last row is refused, not read past.
        let short = Texels::F16 {
            bytes: &bytes[..stride * (h - 1) + w * 8 - 1],
            stride,
        };
        let mut black = Vec::new();
        upsample_reduced(short, size, frame, centre, (Tone::Clip, 1.0), &mut black);
        assert!(black.iter().all(|&b| b == 0));
    }

    #[test]
    fn a_short_source_gives_a_black_frame_not_a_panic() {
        let mut rgba = vec![9; 3];
        upsample_reduced(
            Texels::Planes(&planes(&[0.5; 4])),
            (2, 2),
            (4, 4),
            (2.0, 2.0),
            (Tone::Clip, 1.0),
            &mut rgba,
        );
        assert_eq!(rgba, vec![0; 64]);
    }
}

//! The lens's inverse mapping as the picture is resampled (issue 41): the
//! exact inverse ([`LensGeometry::inverse`]) solved on a 16-pixel grid and
//! mixed along x once per grid row when a draw's map is built
//! ([`LensMap::build`]); each output row's sources then mixed from four
//! grid rows (cubic Lagrange weights) and rounded to bilinear taps as the
//! row is resampled ([`LensMap::remap`], the AVX2 kernel where the CPU has
//! it), so that no per-pixel table is stored or read back. The id layer
//! moves with the nearest taps ([`LensMap::nearest_in`]).

use std::ops::Range;
use std::sync::{Arc, Mutex, OnceLock};

use rayon::prelude::*;

use super::LensGeometry;
use crate::sensor::PixelRect;

/// One output pixel's bilinear taps, packed in a `u64`: the top-left
/// source pixel's index (bits 0–31) and the weights of the right column
/// (bits 32–47) and lower row (bits 48–63), in 1/1024.
#[derive(Clone, Copy, Debug, PartialEq)]
struct Tap(u64);

impl Tap {
    #[inline(always)]
    fn new(index: u32, wx: u32, wy: u32) -> Self {
        Self(u64::from(index) | u64::from(wx) << 32 | u64::from(wy) << 48)
    }
    #[inline(always)]
    fn index(self) -> u32 {
        self.0 as u32
    }
    #[inline(always)]
    fn wx(self) -> u32 {
        (self.0 >> 32) as u32 & 0xffff
    }
    #[inline(always)]
    fn wy(self) -> u32 {
        (self.0 >> 48) as u32
    }
}

/// The weights' scale: 1024 = the whole pixel.
const ONE: u32 = 1024;
/// The exact inverse is solved on a grid of this spacing (pixels), a node
/// past each edge, and interpolated between with cubic Lagrange weights
/// (the tests bound the difference from the exact inverse under 0.01 px).
const GRID: u32 = 16;

/// A lens's inverse mapping: each grid row's sources mixed along x.
#[derive(Debug, PartialEq)]
pub struct LensMap {
    width: u32,
    height: u32,
    /// Per grid row, the source's u and v at every column.
    along: Vec<[Vec<f64>; 2]>,
    /// Every pixel's taps, tabulated once a map is used a second time (a
    /// fixed draw: read back beats mixing again; a new draw never stores them).
    taps: OnceLock<Vec<Tap>>,
}

/// The grid's nodes along a side of `n` pixels: node k at pixel index
/// (k − 1)·GRID, from one node before pixel 0 to two past pixel n − 1.
fn node_count(n: u32) -> usize {
    (n.saturating_sub(1) / GRID) as usize + 4
}

/// The cubic Lagrange weights of the nodes at −1, 0, 1, 2 for a point at
/// `t` ∈ [0, 1) (exact for cubics; the error falls as GRID⁴).
#[inline(always)]
fn lagrange(t: f64) -> [f64; 4] {
    let (a, b, c, d) = (t + 1.0, t, t - 1.0, t - 2.0);
    [
        -b * c * d / 6.0,
        a * c * d / 2.0,
        -a * b * d / 2.0,
        a * b * c / 6.0,
    ]
}

/// Pixel `x`'s first node (of four) and its weights.
fn stencil(x: u32) -> (usize, [f64; 4]) {
    (
        (x / GRID) as usize,
        lagrange(f64::from(x % GRID) / f64::from(GRID)),
    )
}

/// The four-node cubic mix of `rows` (one value per column each) at `k`.
#[inline(always)]
fn mix(rows: [&[f64]; 4], k: [f64; 4], out: &mut [f64]) {
    let [a, b, c, d] = rows;
    for ((((o, &a), &b), &c), &d) in out.iter_mut().zip(a).zip(b).zip(c).zip(d) {
        *o = k[0] * a + k[1] * b + k[2] * c + k[3] * d;
    }
}

impl LensMap {
    /// The map of `geo` (built, or shared from the last maps built: a
    /// fixed draw is solved once).
    pub fn of(geo: &LensGeometry) -> Arc<Self> {
        static CACHE: Mutex<Vec<(LensGeometry, Arc<LensMap>)>> = Mutex::new(Vec::new());
        if let Ok(cache) = CACHE.lock()
            && let Some((_, map)) = cache.iter().find(|(g, _)| g == geo)
        {
            map.taps.get_or_init(|| map.all_taps());
            return map.clone();
        }
        let map = Arc::new(Self::build(geo));
        if let Ok(mut cache) = CACHE.lock() {
            cache.insert(0, (*geo, map.clone()));
            cache.truncate(2);
        }
        map
    }

    /// Solve `geo`'s inverse exactly on the grid and mix each grid row
    /// along x once per column (grid rows on rayon's threads); the pixel
    /// rows are mixed from four of these as they are resampled.
    pub fn build(geo: &LensGeometry) -> Self {
        let (w, h) = (geo.width, geo.height);
        let (nx, ny) = (node_count(w), node_count(h));
        let at = |k: usize| (k as f64 - 1.0) * f64::from(GRID) + 0.5;
        let cols: Vec<(usize, [f64; 4])> = (0..w).map(stencil).collect();
        let along = (0..ny)
            .into_par_iter()
            .map(|j| {
                let nodes: Vec<(f64, f64)> = (0..nx).map(|i| geo.inverse((at(i), at(j)))).collect();
                let node = |c: usize| nodes.get(c).copied().unwrap_or((0.0, 0.0));
                let mixed = |pick: fn((f64, f64)) -> f64| -> Vec<f64> {
                    let n = |c: usize| pick(node(c));
                    (cols.iter())
                        .map(|&(c, k)| {
                            k[0] * n(c) + k[1] * n(c + 1) + k[2] * n(c + 2) + k[3] * n(c + 3)
                        })
                        .collect()
                };
                [mixed(|p| p.0), mixed(|p| p.1)]
            })
            .collect();
        Self {
            width: w,
            height: h,
            along,
            taps: OnceLock::new(),
        }
    }

    /// Every pixel's taps, row by row (rows on rayon's threads).
    fn all_taps(&self) -> Vec<Tap> {
        let w = self.width as usize;
        let mut taps = vec![Tap(0); w * self.height as usize];
        taps.par_chunks_mut(w.max(1))
            .enumerate()
            .for_each_init(Scratch::default, |s, (y, row)| {
                self.row_taps(y as u32, 0..w, s);
                row.copy_from_slice(&s.taps);
            });
        taps
    }

    /// Row `y`'s taps for the columns `xs` (into `s.taps`): the four grid
    /// rows around it mixed per column, each source rounded to its taps.
    fn row_taps(&self, y: u32, xs: Range<usize>, s: &mut Scratch) {
        let n = xs.len();
        s.us.resize(n, 0.0);
        s.vs.resize(n, 0.0);
        s.taps.resize(n, Tap(0));
        let (r, k) = stencil(y);
        let plane = |p: usize| -> [&[f64]; 4] {
            std::array::from_fn(|i| {
                (self.along.get(r + i)).map_or(&[][..], |a| a[p].get(xs.clone()).unwrap_or(&[]))
            })
        };
        let (w, h) = (self.width, self.height);
        let Scratch { us, vs, taps } = s;
        super::super::simd::widest(
            #[inline(always)]
            || {
                mix(plane(0), k, us);
                mix(plane(1), k, vs);
                for ((tap, &u), &v) in taps.iter_mut().zip(us.iter()).zip(vs.iter()) {
                    *tap = tap_at((u, v), w, h);
                }
            },
        );
    }

    /// Output pixel `i`'s taps (the arithmetic of [`Self::row_taps`]).
    fn tap(&self, i: usize) -> Option<Tap> {
        let w = self.width as usize;
        if i >= w * self.height as usize {
            return None;
        }
        let (x, y) = (i % w, (i / w) as u32);
        let (r, k) = stencil(y);
        let at = |p: usize, j: usize| self.along.get(r + j).and_then(|a| a[p].get(x).copied());
        let mixed = |p: usize| {
            Some(k[0] * at(p, 0)? + k[1] * at(p, 1)? + k[2] * at(p, 2)? + k[3] * at(p, 3)?)
        };
        Some(tap_at((mixed(0)?, mixed(1)?), self.width, self.height))
    }

    /// Output pixel `i`'s source position as the map samples it (index
    /// space: pixel centres at whole numbers).
    pub fn source(&self, i: usize) -> Option<(f64, f64)> {
        let t = self.tap(i)?;
        let (x0, y0) = (t.index() % self.width, t.index() / self.width);
        let k = f64::from(ONE);
        Some((
            f64::from(x0) + f64::from(t.wx()) / k,
            f64::from(y0) + f64::from(t.wy()) / k,
        ))
    }

    /// The source pixel nearest output pixel `i`'s source (for the id layer).
    pub fn nearest(&self, i: usize) -> Option<u32> {
        self.tap(i).map(|t| self.nearest_of(t))
    }

    fn nearest_of(&self, t: Tap) -> u32 {
        let dx = u32::from(t.wx() >= ONE / 2);
        let dy = u32::from(t.wy() >= ONE / 2);
        t.index() + dx + dy * self.width
    }

    /// For each pixel of the `rects` in turn (row by row): `f(x, y, the
    /// source pixel nearest its source)`, as [`Self::nearest`] gives it.
    pub fn nearest_in(
        &self,
        rects: impl IntoIterator<Item = PixelRect>,
        mut f: impl FnMut(u32, u32, u32),
    ) {
        let mut s = Scratch::default();
        for rect in rects {
            let (x0, x1) = (rect.x0.min(self.width), rect.x1.min(self.width));
            for y in rect.y0..rect.y1.min(self.height) {
                self.row_taps(y, x0 as usize..x1 as usize, &mut s);
                for (x, &t) in (x0..).zip(&s.taps) {
                    f(x, y, self.nearest_of(t));
                }
            }
        }
    }

    /// `src` (RGBA8, the map's size) resampled through the lens: each
    /// output pixel the bilinear mix of its four taps (rows on rayon's
    /// threads, each row's taps mixed from the grid as it goes, or read
    /// from the table a map used before keeps). The
    /// picture's buffer goes back to a small pool when dropped, so that
    /// the next frame's writes over it rather than a freshly zeroed one.
    pub fn remap(&self, src: &[u8]) -> Lensed {
        let (w, n) = (
            self.width as usize,
            self.width as usize * self.height as usize,
        );
        let mut out = Lensed::take(n * 4);
        if src.len() < n * 4 || w < 2 || self.height < 2 {
            out.0.fill(0);
            return out;
        }
        out.0
            .par_chunks_mut(w * 4)
            .enumerate()
            .for_each_init(Scratch::default, |s, (y, row)| match self.taps.get() {
                Some(taps) => remap_row(src, w, &taps[y * w..(y + 1) * w], row),
                None => {
                    self.row_taps(y as u32, 0..w, s);
                    remap_row(src, w, &s.taps, row);
                }
            });
        out
    }

    /// [`Self::remap`] on the rows and columns of `rect` only, into `out`.
    pub fn remap_rect(&self, src: &[u8], out: &mut [u8], rect: PixelRect) {
        let w = self.width as usize;
        let (x0, x1) = (
            rect.x0.min(self.width) as usize,
            rect.x1.min(self.width) as usize,
        );
        let n = w * self.height as usize * 4;
        if x0 >= x1 || src.len() < n || out.len() < n || w < 2 || self.height < 2 {
            return;
        }
        let mut s = Scratch::default();
        for y in rect.y0 as usize..rect.y1.min(self.height) as usize {
            self.row_taps(y as u32, x0..x1, &mut s);
            remap_row(
                src,
                w,
                &s.taps,
                &mut out[(y * w + x0) * 4..(y * w + x1) * 4],
            );
        }
    }
}

/// A row's buffers: its pixels' sources and their taps.
#[derive(Default)]
struct Scratch {
    us: Vec<f64>,
    vs: Vec<f64>,
    taps: Vec<Tap>,
}

/// A picture resampled through the lens (RGBA8): its buffer returns to a
/// pool of a few when dropped, for the next frame's picture.
#[derive(Debug)]
pub struct Lensed(Vec<u8>);

/// The spare pictures' buffers (at most [`SPARE`]).
static POOL: Mutex<Vec<Vec<u8>>> = Mutex::new(Vec::new());
const SPARE: usize = 4;

impl Lensed {
    /// A buffer of `n` bytes, from the pool where it has one (its bytes
    /// whatever they were: every one is written).
    fn take(n: usize) -> Self {
        let spare = POOL.lock().ok().and_then(|mut p| p.pop());
        let mut buf = spare.unwrap_or_default();
        buf.resize(n, 0);
        Self(buf)
    }
}

impl std::ops::Deref for Lensed {
    type Target = [u8];
    fn deref(&self) -> &[u8] {
        &self.0
    }
}

impl Drop for Lensed {
    fn drop(&mut self) {
        if let Ok(mut pool) = POOL.lock()
            && pool.len() < SPARE
        {
            pool.push(std::mem::take(&mut self.0));
        }
    }
}

/// A source position (pixel coordinates) as its taps, clamped to the image
/// (NaN to its first pixel).
#[inline(always)]
fn tap_at((u, v): (f64, f64), w: u32, h: u32) -> Tap {
    let axis = |s: f64, n: u32| {
        // `max` takes NaN to 0, as `clamp` then `as u32` did.
        let s = (s - 0.5).max(0.0).min(f64::from(n - 1));
        let i = floor_u32(s).min(n - 2);
        let x = (s - f64::from(i)) * f64::from(ONE);
        let k = floor_u32(x);
        let f = k + u32::from(x - f64::from(k) >= 0.5);
        (i, f.min(ONE))
    };
    let (x0, wx) = axis(u, w);
    let (y0, wy) = axis(v, h);
    Tap::new(y0 * w + x0, wx, wy)
}

/// `s as u32` for `s` in [0, 2³¹): the nearest integer by adding 2⁵², one
/// less where that rounded up, read from the mantissa. Exact, and unlike
/// the saturating cast it vectorises.
#[inline(always)]
fn floor_u32(s: f64) -> u32 {
    const MAGIC: f64 = 4_503_599_627_370_496.0; // 2⁵²
    let r = (s + MAGIC) - MAGIC;
    let f = if r > s { r - 1.0 } else { r };
    (f + MAGIC).to_bits() as u32
}

/// One row of output pixels from their taps (fixed point, rounded): the
/// AVX2 kernel where the CPU has it, else the scalar one (the same bytes).
#[inline]
fn remap_row(src: &[u8], w: usize, taps: &[Tap], row: &mut [u8]) {
    #[cfg(target_arch = "x86_64")]
    if super::super::simd::simd_level() >= 1 {
        // SAFETY: the CPU has AVX2 (checked by `simd_level`).
        #[allow(unsafe_code)]
        unsafe {
            return remap_row_avx2(src, w, taps, row);
        }
    }
    remap_row_scalar(src, w, taps, row);
}

/// A pixel's two source rows' 2×2 pixels (8 bytes each), `None` past the end.
#[inline(always)]
fn quad(src: &[u8], w: usize, t: Tap) -> Option<([u8; 8], [u8; 8])> {
    let o = t.index() as usize * 4;
    let a = <[u8; 8]>::try_from(src.get(o..o + 8)?).ok()?;
    let b = <[u8; 8]>::try_from(src.get(o + w * 4..o + w * 4 + 8)?).ok()?;
    Some((a, b))
}

/// [`remap_row`] in scalar integers: per channel, the two rows mixed along
/// x, then those along y, rounded (the reference the AVX2 kernel matches).
fn remap_row_scalar(src: &[u8], w: usize, taps: &[Tap], row: &mut [u8]) {
    for (px, &t) in row.chunks_exact_mut(4).zip(taps) {
        let Some((a, b)) = quad(src, w, t) else {
            px.fill(0);
            continue;
        };
        let (wx, wy) = (t.wx(), t.wy());
        for (c, out) in px.iter_mut().enumerate() {
            let top = u32::from(a[c]) * (ONE - wx) + u32::from(a[c + 4]) * wx;
            let bottom = u32::from(b[c]) * (ONE - wx) + u32::from(b[c + 4]) * wx;
            *out = ((top * (ONE - wy) + bottom * wy + ONE * ONE / 2) / (ONE * ONE)) as u8;
        }
    }
}

/// [`remap_row_scalar`]'s integers on AVX2: the 2×2 pixels' bytes paired
/// by channel (left, right), one multiply-add gives both rows' x mixes
/// (exact in i32: ≤ 255·1024), then the y mix, rounding and packing.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
fn remap_row_avx2(src: &[u8], w: usize, taps: &[Tap], row: &mut [u8]) {
    use std::arch::x86_64::*;
    // [r0 g0 b0 a0 r1 g1 b1 a1 | the lower row's] → [r0 r1 g0 g1 b0 b1 a0 a1 | …]
    let pairs = _mm_setr_epi8(0, 4, 1, 5, 2, 6, 3, 7, 8, 12, 9, 13, 10, 14, 11, 15);
    let half = _mm_set1_epi32((ONE * ONE / 2) as i32);
    for (px, &t) in row.chunks_exact_mut(4).zip(taps) {
        let Some((a, b)) = quad(src, w, t) else {
            px.fill(0);
            continue;
        };
        let bytes = _mm_set_epi64x(i64::from_le_bytes(b), i64::from_le_bytes(a));
        let words = _mm256_cvtepu8_epi16(_mm_shuffle_epi8(bytes, pairs));
        let (wx, wy) = (t.wx() as i32, t.wy() as i32);
        let x_mix = _mm256_madd_epi16(words, _mm256_set1_epi32(wx << 16 | (ONE as i32 - wx)));
        let (top, bottom) = (
            _mm256_castsi256_si128(x_mix),
            _mm256_extracti128_si256::<1>(x_mix),
        );
        let sum = _mm_add_epi32(
            _mm_mullo_epi32(top, _mm_set1_epi32(ONE as i32 - wy)),
            _mm_mullo_epi32(bottom, _mm_set1_epi32(wy)),
        );
        let v = _mm_srli_epi32::<20>(_mm_add_epi32(sum, half));
        let v = _mm_packus_epi16(_mm_packus_epi32(v, v), _mm_setzero_si128());
        px.copy_from_slice(&_mm_cvtsi128_si32(v).to_le_bytes());
    }
}

#[cfg(test)]
mod tests {
    use super::super::LensDraw;
    use super::super::tests::bc;
    use super::*;

    /// The cubic mix of the 16-pixel grid against the exact inverse, over
    /// the whole picture (edges and corners included), for a strong
    /// Brown–Conrady lens and a fisheye.
    #[test]
    fn the_tabulated_map_is_the_exact_inverse_within_a_hundredth_of_a_pixel() {
        let fisheye = LensDraw::Fisheye {
            k1: 0.05,
            k2: -0.01,
            k3: 0.0,
            k4: 0.0,
        };
        for d in [bc(-0.3, 0.08, 0.003, 0.002), fisheye] {
            let geo = LensGeometry::new(d, 1920, 1080, 935.0).expect("a lens");
            let map = LensMap::build(&geo);
            let mut worst = 0.0f64;
            let corners = [0, 1919, 1919 * 1080, 1920 * 1080 - 1];
            for i in (0..1920 * 1080).step_by(997).chain(corners) {
                let (x, y) = ((i % 1920) as f64 + 0.5, (i / 1920) as f64 + 0.5);
                let exact = geo.inverse((x, y));
                let (u, v) = map.source(i).expect("in the map");
                worst = worst.max((u + 0.5 - exact.0).hypot(v + 0.5 - exact.1));
            }
            // The taps round to 1/1024 px (≤ 0.0007 px); the grid adds the rest.
            assert!(worst < 0.01, "{d:?}: {worst} px");
        }
    }

    /// The vectorising floor is the cast it replaces, next to whole numbers too.
    #[test]
    fn floor_u32_is_the_saturating_cast_in_range() {
        for s in [
            0.0f64,
            0.49999,
            0.5,
            1.0 - 1e-12,
            1.0,
            2.5,
            3.5,
            1_023.999_999,
            1024.0,
            2e9,
        ] {
            for s in [
                s,
                f64::from_bits(s.to_bits() + 1),
                f64::from_bits(s.to_bits().max(1) - 1),
            ] {
                assert_eq!(floor_u32(s), s as u32, "{s}");
            }
        }
        assert_eq!(tap_at((f64::NAN, 3.2), 8, 8), tap_at((0.5, 3.2), 8, 8));
    }

    /// The AVX2 kernel and the scalar one give the same bytes for every
    /// weight (0 and 1024 included) on a noisy picture.
    #[test]
    fn the_avx2_resampler_gives_the_scalar_bytes() {
        let (w, n) = (64usize, 4096usize);
        let src: Vec<u8> = (0..w * 40 * 4).map(|i| (i * 7919 % 251) as u8).collect();
        let taps: Vec<Tap> = (0..n as u32)
            .map(|i| Tap::new(i * 37 % (38 * w as u32 - 1), i * 97 % 1025, i * 61 % 1025))
            .collect();
        let mut scalar = vec![0u8; n * 4];
        remap_row_scalar(&src, w, &taps, &mut scalar);
        let mut fast = vec![0u8; n * 4];
        remap_row(&src, w, &taps, &mut fast);
        assert_eq!(scalar, fast);
        assert!(scalar.iter().any(|&v| v > 200) && scalar.iter().any(|&v| v < 50));
    }

    /// Remapping a constant picture gives it back; a horizontal ramp stays
    /// monotone along a row through the centre.
    #[test]
    fn remapping_keeps_flat_pictures_and_orders() {
        let (w, h) = (96u32, 64u32);
        let geo = LensGeometry::new(bc(-0.2, 0.0, 0.0, 0.0), w, h, 80.0).expect("a lens");
        let map = LensMap::build(&geo);
        let flat = vec![77u8; (w * h * 4) as usize];
        assert_eq!(*map.remap(&flat), flat[..]);
        let ramp: Vec<u8> = (0..w * h)
            .flat_map(|i| [(i % w * 2) as u8, 0, 0, 255])
            .collect();
        let out = map.remap(&ramp);
        let row = (h / 2 * w * 4) as usize;
        let reds: Vec<u8> = (0..w as usize).map(|x| out[row + x * 4]).collect();
        assert!(reds.windows(2).all(|p| p[0] <= p[1]), "{reds:?}");
        let mut part = flat.clone();
        let rect = PixelRect {
            x0: 3,
            y0: 5,
            x1: 40,
            y1: 30,
        };
        map.remap_rect(&ramp, &mut part, rect);
        assert_eq!(
            part[(6 * w as usize + 10) * 4],
            out[(6 * w as usize + 10) * 4]
        );
        assert_eq!(part[0], 77);
    }
}

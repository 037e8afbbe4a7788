//! The lens's inverse mapping as the picture is resampled (issue 41): the
//! exact inverse ([`LensGeometry::inverse`]) solved on a 16-pixel grid and
//! mixed along x once per grid row when a draw's map is built
//! ([`LensMap::build`]); each output row's sources then mixed from four
//! grid rows (cubic Lagrange weights) and rounded to bilinear taps as the
//! row is resampled ([`LensMap::remap`]), or read back from the taps table
//! a map keeps once it is used a second time (a fixed draw). The rows are
//! mixed by `kernel.rs`'s kernel (AVX2 where the CPU has it). The id layer
//! moves with the nearest taps ([`LensMap::nearest_in`]).

use std::ops::Range;
use std::sync::{Arc, Mutex, OnceLock};

use rayon::prelude::*;

use super::LensGeometry;
use super::kernel::{ONE, Tap, remap_row, tap_at};
use crate::sensor::PixelRect;

/// The exact inverse is solved on a grid of this spacing (pixels), a node
/// past each edge, and interpolated between with cubic Lagrange weights
/// (the tests bound the difference from the exact inverse under 0.01 px).
const GRID: u32 = 16;

/// A lens's inverse mapping: each grid row's sources mixed along x.
#[derive(Debug, PartialEq)]
pub struct LensMap {
    width: u32,
    height: u32,
    /// Per grid row, the source's u at every column, then its v (a
    /// buffer from [`ALONG`], given back when the map is dropped).
    along: Vec<f64>,
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

/// One grid row's nodes (`nodes`, one value each) mixed at every column
/// of `out` ([`stencil`]'s first node and weights): the four-node sum in
/// the order of [`mix`], a grid cell's columns at a time with the cell's
/// four nodes (`GRID` columns share them; their weights are those of the
/// column's place in the cell), a missing node read as 0.
#[inline(always)]
fn mix_along(nodes: &[f64], weights: &[[f64; GRID as usize]; 4], out: &mut [f64]) {
    for (c, cell) in out.chunks_mut(GRID as usize).enumerate() {
        let [a, b, cc, d] = match nodes.get(c..c + 4) {
            Some(&[a, b, cc, d]) => [a, b, cc, d],
            _ => std::array::from_fn(|i| nodes.get(c + i).copied().unwrap_or(0.0)),
        };
        let [k0, k1, k2, k3] = weights;
        for (t, o) in cell.iter_mut().enumerate() {
            *o = k0[t] * a + k1[t] * b + k2[t] * cc + k3[t] * d;
        }
    }
}

/// [`lagrange`]'s weights at each column of a grid cell, weight by weight.
fn cell_weights() -> [[f64; GRID as usize]; 4] {
    let k: [[f64; 4]; GRID as usize] = std::array::from_fn(|t| stencil(t as u32).1);
    std::array::from_fn(|i| std::array::from_fn(|t| k[t][i]))
}

/// The spare buffers of dropped maps' grid rows (at most 2).
static ALONG: Mutex<Vec<Vec<f64>>> = Mutex::new(Vec::new());

impl Drop for LensMap {
    fn drop(&mut self) {
        if let Ok(mut spare) = ALONG.lock()
            && spare.len() < 2
        {
            spare.push(std::mem::take(&mut self.along));
        }
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
        let weights = cell_weights();
        // A dropped map's buffer where there is one (every value is written):
        // a fresh one would be zeroed and faulted in anew each draw.
        let mut along = ALONG
            .lock()
            .ok()
            .and_then(|mut s| s.pop())
            .unwrap_or_default();
        along.resize(ny * 2 * w as usize, 0.0);
        along
            .par_chunks_mut(2 * w as usize)
            .enumerate()
            .for_each(|(j, planes)| {
                let row: Vec<(f64, f64)> = (0..nx).map(|i| (at(i), at(j))).collect();
                let nodes = geo.inverse_all(&row);
                let (us, vs) = planes.split_at_mut(w as usize);
                super::super::simd::widest(
                    #[inline(always)]
                    || {
                        mix_along(&nodes.iter().map(|p| p.0).collect::<Vec<_>>(), &weights, us);
                        mix_along(&nodes.iter().map(|p| p.1).collect::<Vec<_>>(), &weights, vs);
                    },
                );
            });
        Self {
            width: w,
            height: h,
            along,
            taps: OnceLock::new(),
        }
    }

    /// Grid row `r`'s plane `p` (0: u, 1: v) at columns `xs` (empty
    /// where the map has none).
    fn along(&self, r: usize, p: usize, xs: Range<usize>) -> &[f64] {
        let w = self.width as usize;
        let at = (2 * r + p) * w;
        (self.along.get(at..at + w))
            .and_then(|row| row.get(xs))
            .unwrap_or(&[])
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
        let plane =
            |p: usize| -> [&[f64]; 4] { std::array::from_fn(|i| self.along(r + i, p, xs.clone())) };
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
        let at = |p: usize, j: usize| self.along(r + j, p, x..x + 1).first().copied();
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
            out.fill(0);
            return out;
        }
        out.par_chunks_mut(w * 4)
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
pub type Lensed = crate::sensor::pool::Picture;

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

    /// A grid row mixed a cell at a time is the per-column four-node sum
    /// of each column's stencil, bit for bit (a width that is not a
    /// multiple of the cell, and nodes past the last read as 0).
    #[test]
    fn a_grid_row_mixed_by_cells_is_each_columns_stencil_sum() {
        let nodes: Vec<f64> = (0..17)
            .map(|i| (f64::from(i) * 1.37).sin() * 900.0)
            .collect();
        let weights = cell_weights();
        for w in [197u32, 250] {
            let mut out = vec![f64::NAN; w as usize];
            mix_along(&nodes, &weights, &mut out);
            for (x, &got) in (0..w).zip(&out) {
                let (c, k) = stencil(x);
                let n = |i: usize| nodes.get(c + i).copied().unwrap_or(0.0);
                let want = k[0] * n(0) + k[1] * n(1) + k[2] * n(2) + k[3] * n(3);
                assert_eq!(got.to_bits(), want.to_bits(), "column {x} of {w}");
            }
        }
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

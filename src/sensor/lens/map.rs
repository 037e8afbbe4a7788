//! The lens's inverse mapping as the picture is resampled (issue 41): the
//! exact inverse ([`LensGeometry::inverse`]) solved on a 16-pixel grid when
//! a draw's map is built ([`LensMap::build`]), kept as each node's source
//! displacement (1/64 px). As each output row is resampled
//! ([`LensMap::remap`]) its nodes are mixed from the four grid rows around
//! it, its pixels' taps from the four nodes around each (cubic Lagrange
//! weights, `taps.rs`) and the row from those taps by `kernel.rs`'s kernel
//! (on AVX2 the taps kept in registers for the kernel); a map used a
//! second time (a fixed draw) tabulates its taps once and reads them back.
//! The id layer moves with the nearest taps ([`LensMap::nearest_in`]).

use std::ops::Range;
use std::sync::{Arc, Mutex, OnceLock};

use rayon::prelude::*;

use super::LensGeometry;
use super::kernel::{remap_row, remap_taps};
use super::taps::{GRID as CELL, LIM, ONE, Rows, Tap, row_taps};
use crate::sensor::PixelRect;

/// The exact inverse is solved on a grid of this spacing (pixels), a node
/// past each edge, and interpolated between with cubic Lagrange weights
/// (the tests bound the mix's difference from the exact inverse under
/// 0.01 px, and the sampled position's, rounded to 1/64 px, under 1/64 px).
const GRID: u32 = CELL as u32;

/// A lens's inverse mapping: its sources' displacements at the grid's nodes.
#[derive(Debug, PartialEq)]
pub struct LensMap {
    width: u32,
    height: u32,
    /// Nodes per grid row.
    nx: usize,
    /// Per grid row, each node's source displacement in 1/64 px along u
    /// (u − the node's x, pixel coordinates), then along v (v − its y).
    nodes: Vec<f64>,
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

/// [`lagrange`]'s weights at each column of a grid cell, weight by weight
/// (`[i][t]`: node i's at column t), in f32.
fn cell_weights() -> &'static [[f32; CELL]; 4] {
    static K: OnceLock<[[f32; CELL]; 4]> = OnceLock::new();
    K.get_or_init(|| {
        let k: [[f64; 4]; CELL] = std::array::from_fn(|t| stencil(t as u32).1);
        std::array::from_fn(|i| std::array::from_fn(|t| k[t][i] as f32))
    })
}

/// A source coordinate `s` as its displacement from `at` in 1/64 px,
/// within ±[`LIM`] (NaN as the least: the picture's first pixel).
fn displacement(s: f64, at: f64) -> f64 {
    let lim = f64::from(LIM);
    ((s - at) * f64::from(ONE)).max(-lim).min(lim)
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

    /// Solve `geo`'s inverse exactly on the grid (grid rows on rayon's
    /// threads), kept as displacements; each pixel row's nodes are mixed
    /// from four grid rows, and its pixels from those, as it is resampled.
    pub fn build(geo: &LensGeometry) -> Self {
        let (w, h) = (geo.width, geo.height);
        let (nx, ny) = (node_count(w), node_count(h));
        let at = |k: usize| (k as f64 - 1.0) * f64::from(GRID) + 0.5;
        let mut nodes = vec![0.0; ny * 2 * nx];
        nodes
            .par_chunks_mut(2 * nx)
            .enumerate()
            .for_each(|(j, planes)| {
                let row: Vec<(f64, f64)> = (0..nx).map(|i| (at(i), at(j))).collect();
                let (us, vs) = planes.split_at_mut(nx);
                let solved = geo.inverse_all(&row);
                for (i, ((u, v), s)) in us.iter_mut().zip(vs).zip(solved).enumerate() {
                    (*u, *v) = (displacement(s.0, at(i)), displacement(s.1, at(j)));
                }
            });
        Self {
            width: w,
            height: h,
            nx,
            nodes,
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

    /// Row `y`'s nodes for the columns `xs` (into `s.u` and `s.v`): the
    /// four grid rows around it mixed at the nodes of the columns' cells
    /// (f64, then f32); the cell of `xs.start` is `rows`' first.
    fn row_nodes<'a>(&self, y: u32, xs: &Range<usize>, s: &'a mut Scratch) -> Rows<'a> {
        let first = xs.start / CELL;
        let last = (xs.end.max(1) - 1) / CELL + 4;
        let (r, k) = stencil(y);
        let nx = self.nx;
        let lim = f64::from(LIM);
        let grid_row = |i: usize, p: usize| {
            let at = (2 * (r + i) + p) * nx;
            self.nodes.get(at + first..at + last.min(nx)).unwrap_or(&[])
        };
        for (p, out) in [&mut s.u, &mut s.v].into_iter().enumerate() {
            let [a, b, c, d] = std::array::from_fn(|i| grid_row(i, p));
            let n = a.len().min(b.len()).min(c.len()).min(d.len());
            let (a, b, c, d) = (&a[..n], &b[..n], &c[..n], &d[..n]);
            out.resize(n, 0.0);
            // Indexed over equal lengths: the compiler vectorises it.
            for (i, o) in out.iter_mut().enumerate() {
                let m = k[0] * a[i] + k[1] * b[i] + k[2] * c[i] + k[3] * d[i];
                *o = m.max(-lim).min(lim) as f32;
            }
        }
        Rows {
            u: &s.u,
            v: &s.v,
            first: first as u32,
            k: cell_weights(),
        }
    }

    /// Row `y`'s taps for the columns `xs` (into `s.taps`): its nodes
    /// ([`Self::row_nodes`]), the pixels' taps from those (`taps.rs`).
    fn row_taps(&self, y: u32, xs: Range<usize>, s: &mut Scratch) {
        let mut taps = std::mem::take(&mut s.taps);
        taps.resize(xs.len(), Tap(0));
        let rows = self.row_nodes(y, &xs, s);
        row_taps(&rows, xs.start as u32, y, self.size(), &mut taps);
        s.taps = taps;
    }

    /// Row `y`'s columns `xs` of `src` resampled into `out` (that row's
    /// pixels `xs`): its nodes ([`Self::row_nodes`]), the pixels from
    /// those (`kernel.rs`, the taps on AVX2 in registers).
    fn remap_row(&self, src: &[u8], y: u32, xs: Range<usize>, s: &mut Scratch, out: &mut [u8]) {
        let mut taps = std::mem::take(&mut s.taps);
        let rows = self.row_nodes(y, &xs, s);
        let at = (xs.start as u32, y);
        remap_row(src, &rows, at, self.size(), &mut taps, out);
        s.taps = taps;
    }

    fn size(&self) -> (u32, u32) {
        (self.width, self.height)
    }

    /// Output pixel `i`'s taps (those [`Self::row_taps`] gives).
    fn tap(&self, i: usize) -> Option<Tap> {
        let w = self.width as usize;
        if i >= w * self.height as usize {
            return None;
        }
        let mut s = Scratch::default();
        self.row_taps((i / w) as u32, i % w..i % w + 1, &mut s);
        s.taps.first().copied()
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
    /// from the table a map used before keeps: the same taps). The
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
                Some(taps) => remap_taps(src, w, &taps[y * w..(y + 1) * w], row),
                None => self.remap_row(src, y as u32, 0..w, s, row),
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
            let row = &mut out[(y * w + x0) * 4..(y * w + x1) * 4];
            self.remap_row(src, y as u32, x0..x1, &mut s, row);
        }
    }
}

/// A row's buffers: its nodes' displacements (u, v) and its pixels' taps.
#[derive(Default)]
struct Scratch {
    u: Vec<f32>,
    v: Vec<f32>,
    taps: Vec<Tap>,
}

/// A picture resampled through the lens (RGBA8): its buffer returns to a
/// pool of a few when dropped, for the next frame's picture.
pub type Lensed = crate::sensor::pool::Picture;

#[cfg(test)]
mod tests {
    use super::super::LensDraw;
    use super::super::kernel::remap_taps_scalar;
    use super::super::tests::bc;
    use super::*;

    /// The sampled positions (the grid's cubic mix rounded to 1/64 px)
    /// against the exact inverse, over the whole picture (edges and corners
    /// included), for a strong Brown–Conrady lens and a fisheye: within
    /// 1/64 px along each axis (the rounding ≤ 1/128 px; the grid adds the
    /// rest).
    #[test]
    fn the_sampled_positions_are_the_exact_inverse_within_a_64th_of_a_pixel() {
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
                worst = worst.max((u + 0.5 - exact.0).abs().max((v + 0.5 - exact.1).abs()));
            }
            assert!(worst < 1.0 / 64.0, "{d:?}: {worst} px");
        }
    }

    /// The taps mixed in f32 from displacements against the grid's cubic
    /// mix in f64 from the exact inverse at the nodes: within the taps'
    /// rounding (half of 1/64 px) and a twentieth of that, for a strong
    /// Brown–Conrady lens and a fisheye, at the edges too (the grid's mix
    /// itself within 0.01 px of the exact inverse).
    #[test]
    fn the_f32_taps_are_the_f64_grid_mix_rounded_to_a_64th() {
        let fisheye = LensDraw::Fisheye {
            k1: 0.05,
            k2: -0.01,
            k3: 0.0,
            k4: 0.0,
        };
        let (w, h) = (1920u32, 1080u32);
        for d in [bc(-0.3, 0.08, 0.003, 0.002), fisheye] {
            let geo = LensGeometry::new(d, w, h, 935.0).expect("a lens");
            let map = LensMap::build(&geo);
            let node = |i: usize| (i as f64 - 1.0) * f64::from(GRID) + 0.5;
            let (mut worst, mut grid) = (0.0f64, 0.0f64);
            for i in (0..(w * h) as usize).step_by(1009).chain([0, 1919]) {
                let (x, y) = ((i % 1920) as u32, (i / 1920) as u32);
                let ((cx, kx), (cy, ky)) = (stencil(x), stencil(y));
                let (mut u, mut v) = (0.0, 0.0);
                for (b, ky) in ky.iter().enumerate() {
                    let mut row = (0.0, 0.0);
                    for (a, kx) in kx.iter().enumerate() {
                        let p = geo.inverse((node(cx + a), node(cy + b)));
                        row = (row.0 + kx * p.0, row.1 + kx * p.1);
                    }
                    (u, v) = (u + ky * row.0, v + ky * row.1);
                }
                let exact = geo.inverse((f64::from(x) + 0.5, f64::from(y) + 0.5));
                grid = grid.max((u - exact.0).hypot(v - exact.1));
                let inside = |s: f64, n: u32| (0.5..f64::from(n) - 0.5).contains(&s);
                if inside(u, w) && inside(v, h) {
                    let (su, sv) = map.source(i).expect("in the map");
                    worst = worst.max((su + 0.5 - u).abs().max((sv + 0.5 - v).abs()));
                }
            }
            assert!(worst * 64.0 < 0.525, "{d:?}: {} / 64 px", worst * 64.0);
            assert!(grid < 0.01, "{d:?}: the grid {grid} px");
        }
    }

    /// Each row resampled (the AVX2 kernel, its taps in registers, where
    /// the CPU has it) is the scalar taps' scalar kernel's, and the id
    /// layer's taps are those rows' (a width that is not a multiple of 8,
    /// `remap_rect` from a column that is not either).
    #[test]
    fn the_resampled_rows_are_the_scalar_taps_rows() {
        let (w, h) = (203u32, 61u32);
        let geo = LensGeometry::new(bc(-0.25, 0.03, 0.001, -0.002), w, h, 150.0).expect("a lens");
        let map = LensMap::build(&geo);
        let src: Vec<u8> = (0..w * h * 4).map(|i| (i * 7919 % 251) as u8).collect();
        let out = map.remap(&src);
        let mut part = vec![0u8; src.len()];
        let rect = PixelRect {
            x0: 5,
            y0: 0,
            x1: 190,
            y1: h,
        };
        map.remap_rect(&src, &mut part, rect);
        let mut s = Scratch::default();
        let (mut row, mut weights) = (vec![0u8; w as usize * 4], [0u32; 65]);
        for y in 0..h {
            map.row_taps(y, 0..w as usize, &mut s);
            remap_taps_scalar(&src, w as usize, &s.taps, &mut row);
            let at = (y * w * 4) as usize;
            assert_eq!(out[at..at + row.len()], row[..], "row {y}");
            assert_eq!(part[at + 20..at + 760], row[20..760], "row {y}");
            s.taps.iter().for_each(|t| weights[t.wx() as usize] += 1);
        }
        assert!(weights[1..64].iter().all(|&n| n > 0), "{weights:?}");
        // A map used a second time reads its table back: the same bytes.
        let table = map.taps.get_or_init(|| map.all_taps());
        assert_eq!(*map.remap(&src), out[..]);
        assert_eq!(
            table[37 * w as usize..38 * w as usize],
            {
                map.row_taps(37, 0..w as usize, &mut s);
                s.taps.clone()
            }[..]
        );
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

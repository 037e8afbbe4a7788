//! Lens distortion (issue 41): the lens's geometric mapping between the
//! rendered pinhole picture and the written one. [`LensDraw`] is a frame's
//! drawn coefficients (Brown–Conrady or the equidistant fisheye, the
//! formulas in `preset/lens.rs`) and the model's formula on normalised
//! coordinates; [`LensGeometry`] the mapping in pixels for one camera
//! (forward: rendered → written, for the labels' points; inverse: written →
//! rendered, for the picture), and [`LensMap`] the inverse tabulated per
//! output pixel (bilinear taps), cached per draw, that resamples a picture
//! once ([`LensMap::remap`]) and moves the id layer with nearest taps
//! ([`LensMap::nearest`]).
//!
//! The written picture keeps the render's principal point and is scaled
//! (its focal length `focal_out`) so that it shows only rendered pixels:
//! the widest view whose every pixel's source lies inside the render
//! ([`LensGeometry::new`]). Past the radius where the model stops growing
//! (its slope under [`MIN_SLOPE`], or 1.5 × the render's corner radius) the
//! radial mapping continues as a straight line, so points far outside the
//! picture (a drone crossing the near plane) never fold back into it.

use std::sync::{Arc, Mutex};

use rayon::prelude::*;
use serde::Serialize;

use crate::preset::lens::Lens;

/// A frame's drawn lens coefficients.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub enum LensDraw {
    BrownConrady {
        k1: f64,
        k2: f64,
        k3: f64,
        p1: f64,
        p2: f64,
    },
    Fisheye {
        k1: f64,
        k2: f64,
        k3: f64,
        k4: f64,
    },
}

/// Where the radial mapping's slope falls under this, it is taken as folding.
pub const MIN_SLOPE: f64 = 0.1;

/// Draw `lens`'s coefficients in order with `pick` (each uniform on its range).
pub fn draw(lens: &Lens, mut pick: impl FnMut((f64, f64)) -> f64) -> LensDraw {
    match *lens {
        Lens::BrownConrady { k1, k2, k3, p1, p2 } => LensDraw::BrownConrady {
            k1: pick(k1),
            k2: pick(k2),
            k3: pick(k3),
            p1: pick(p1),
            p2: pick(p2),
        },
        Lens::Fisheye { k1, k2, k3, k4 } => LensDraw::Fisheye {
            k1: pick(k1),
            k2: pick(k2),
            k3: pick(k3),
            k4: pick(k4),
        },
    }
}

impl LensDraw {
    /// A Brown–Conrady lens with every coefficient 0: the pinhole itself.
    pub fn is_neutral(&self) -> bool {
        matches!(*self, Self::BrownConrady { k1, k2, k3, p1, p2 } if [k1, k2, k3, p1, p2] == [0.0; 5])
    }

    /// The model's name and coefficients, as the manifest records them.
    pub fn named(&self) -> (&'static str, Vec<(&'static str, f64)>) {
        match *self {
            Self::BrownConrady { k1, k2, k3, p1, p2 } => (
                "brown_conrady",
                vec![("k1", k1), ("k2", k2), ("k3", k3), ("p1", p1), ("p2", p2)],
            ),
            Self::Fisheye { k1, k2, k3, k4 } => (
                "fisheye",
                vec![("k1", k1), ("k2", k2), ("k3", k3), ("k4", k4)],
            ),
        }
    }

    /// The model's formula: an undistorted normalised point (x, y) = (X/Z,
    /// Y/Z) → its distorted normalised point.
    pub fn distort(&self, (x, y): (f64, f64)) -> (f64, f64) {
        match *self {
            Self::BrownConrady { k1, k2, k3, p1, p2 } => {
                let r2 = x * x + y * y;
                let radial = 1.0 + r2 * (k1 + r2 * (k2 + r2 * k3));
                (
                    x * radial + 2.0 * p1 * x * y + p2 * (r2 + 2.0 * x * x),
                    y * radial + p1 * (r2 + 2.0 * y * y) + 2.0 * p2 * x * y,
                )
            }
            Self::Fisheye { .. } => {
                let r = x.hypot(y);
                if r < 1e-12 {
                    return (x, y);
                }
                let s = self.radial(r) / r;
                (x * s, y * s)
            }
        }
    }

    /// The distorted radius of a point at undistorted radius `r` (the
    /// tangential terms left out).
    pub fn radial(&self, r: f64) -> f64 {
        match *self {
            Self::BrownConrady { k1, k2, k3, .. } => {
                let r2 = r * r;
                r * (1.0 + r2 * (k1 + r2 * (k2 + r2 * k3)))
            }
            Self::Fisheye { k1, k2, k3, k4 } => {
                let t = r.atan();
                let t2 = t * t;
                t * (1.0 + t2 * (k1 + t2 * (k2 + t2 * (k3 + t2 * k4))))
            }
        }
    }

    /// The first radius in (0, `r_max`] where the radial mapping's slope
    /// falls under [`MIN_SLOPE`] (`None`: it never does there).
    pub fn fold_radius(&self, r_max: f64) -> Option<f64> {
        const STEPS: u32 = 2048;
        let dr = r_max / f64::from(STEPS);
        (1..=STEPS)
            .map(|i| f64::from(i) * dr)
            .find(|&r| (self.radial(r) - self.radial(r - dr)) / dr < MIN_SLOPE)
            .map(|r| r - dr)
    }
}

/// The lens in pixels for one camera: the render's focal length and
/// principal point, the written picture's focal length, and where the
/// radial mapping continues as a line.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LensGeometry {
    pub draw: LensDraw,
    pub width: u32,
    pub height: u32,
    /// The render's focal length, pixels.
    pub focal: f64,
    /// The written picture's focal length, pixels (fills it with rendered pixels).
    pub focal_out: f64,
    r_lim: f64,
    slope: f64,
}

impl LensGeometry {
    /// The lens `draw` on a `width`×`height` render of focal length `focal`
    /// pixels; `None` when the draw is neutral (or the picture too small to
    /// resample). The last few are kept: a fixed draw is solved once.
    pub fn new(draw: LensDraw, width: u32, height: u32, focal: f64) -> Option<Self> {
        type Key = (LensDraw, u32, u32, u64);
        static CACHE: Mutex<Vec<(Key, Option<LensGeometry>)>> = Mutex::new(Vec::new());
        let key = (draw, width, height, focal.to_bits());
        if let Ok(cache) = CACHE.lock()
            && let Some((_, geo)) = cache.iter().find(|(k, _)| *k == key)
        {
            return *geo;
        }
        let geo = Self::solve(draw, width, height, focal);
        if let Ok(mut cache) = CACHE.lock() {
            cache.insert(0, (key, geo));
            cache.truncate(4);
        }
        geo
    }

    fn solve(draw: LensDraw, width: u32, height: u32, focal: f64) -> Option<Self> {
        if draw.is_neutral() || width < 2 || height < 2 || !(focal.is_finite() && focal > 0.0) {
            return None;
        }
        let corner = f64::from(width).hypot(f64::from(height)) / 2.0 / focal;
        let r_max = 1.5 * corner;
        let r_lim = draw.fold_radius(r_max).unwrap_or(r_max).max(1e-6);
        let dr = 1e-6 * r_lim;
        let slope = ((draw.radial(r_lim) - draw.radial(r_lim - dr)) / dr).max(MIN_SLOPE);
        let mut geo = Self {
            draw,
            width,
            height,
            focal,
            focal_out: focal,
            r_lim,
            slope,
        };
        geo.focal_out = geo.fill_focal();
        Some(geo)
    }

    fn centre(&self) -> (f64, f64) {
        (f64::from(self.width) / 2.0, f64::from(self.height) / 2.0)
    }

    /// Undistorted normalised → distorted normalised, linear past `r_lim`.
    fn forward_n(&self, (x, y): (f64, f64)) -> (f64, f64) {
        // Well inside `r_lim` (the common case) without `hypot`'s cost: the
        // same branch as below, whose test this margin cannot flip.
        if x * x + y * y < self.r_lim * self.r_lim * (1.0 - 1e-9) {
            return self.draw.distort((x, y));
        }
        let r = x.hypot(y);
        if r <= self.r_lim {
            return self.draw.distort((x, y));
        }
        let s = self.r_lim / r;
        let (bx, by) = self.draw.distort((x * s, y * s));
        let extra = self.slope * (r - self.r_lim) / r;
        (bx + x * extra, by + y * extra)
    }

    /// Distorted normalised → undistorted normalised: Newton's method on
    /// [`Self::forward_n`] (its Jacobian by differences).
    fn inverse_n(&self, d: (f64, f64)) -> (f64, f64) {
        let mut p = d;
        for _ in 0..30 {
            let f = self.forward_n(p);
            let e = (f.0 - d.0, f.1 - d.1);
            if e.0.abs() + e.1.abs() < 1e-14 {
                break;
            }
            let h = 1e-7 * (1.0 + p.0.abs() + p.1.abs());
            let fx = self.forward_n((p.0 + h, p.1));
            let fy = self.forward_n((p.0, p.1 + h));
            let (a, b) = ((fx.0 - f.0) / h, (fy.0 - f.0) / h);
            let (c, dd) = ((fx.1 - f.1) / h, (fy.1 - f.1) / h);
            let det = a * dd - b * c;
            if det.is_nan() || det.abs() <= 1e-12 {
                break;
            }
            p = (
                p.0 - (dd * e.0 - b * e.1) / det,
                p.1 - (a * e.1 - c * e.0) / det,
            );
        }
        p
    }

    /// A rendered pixel position → where the lens puts it in the written
    /// picture (continuous pixel coordinates, docs/conventions.md).
    pub fn forward(&self, (u, v): (f64, f64)) -> (f64, f64) {
        let (cx, cy) = self.centre();
        let (x, y) = self.forward_n(((u - cx) / self.focal, (v - cy) / self.focal));
        (cx + self.focal_out * x, cy + self.focal_out * y)
    }

    /// A written pixel position → the rendered position its light comes from.
    pub fn inverse(&self, (u, v): (f64, f64)) -> (f64, f64) {
        self.inverse_with(self.focal_out, (u, v))
    }

    fn inverse_with(&self, focal_out: f64, (u, v): (f64, f64)) -> (f64, f64) {
        let (cx, cy) = self.centre();
        let (x, y) = self.inverse_n(((u - cx) / focal_out, (v - cy) / focal_out));
        (cx + self.focal * x, cy + self.focal * y)
    }

    /// The smallest written focal length whose border pixels' centres all
    /// come from inside the render's pixel centres (a bisection; the
    /// mapping is monotone in it).
    fn fill_focal(&self) -> f64 {
        let (w, h) = (f64::from(self.width), f64::from(self.height));
        const N: u32 = 64;
        let border: Vec<(f64, f64)> = (0..=N)
            .flat_map(|i| {
                let t = f64::from(i) / f64::from(N);
                let (x, y) = (0.5 + t * (w - 1.0), 0.5 + t * (h - 1.0));
                [(x, 0.5), (x, h - 0.5), (0.5, y), (w - 0.5, y)]
            })
            .collect();
        let eps = 1e-9;
        let inside = |fo: f64| {
            border.par_iter().all(|&b| {
                let (u, v) = self.inverse_with(fo, b);
                (0.5 - eps..=w - 0.5 + eps).contains(&u) && (0.5 - eps..=h - 0.5 + eps).contains(&v)
            })
        };
        let (mut lo, mut hi) = (self.focal / 64.0, self.focal * 64.0);
        if !inside(hi) {
            return self.focal;
        }
        for _ in 0..60 {
            let mid = 0.5 * (lo + hi);
            if inside(mid) {
                hi = mid;
            } else {
                lo = mid;
            }
        }
        hi
    }
}

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

/// A lens's inverse mapping tabulated for every output pixel.
#[derive(Debug, PartialEq)]
pub struct LensMap {
    width: u32,
    height: u32,
    taps: Vec<Tap>,
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
    /// fixed draw is tabulated once).
    pub fn of(geo: &LensGeometry) -> Arc<Self> {
        static CACHE: Mutex<Vec<(LensGeometry, Arc<LensMap>)>> = Mutex::new(Vec::new());
        if let Ok(cache) = CACHE.lock()
            && let Some((_, map)) = cache.iter().find(|(g, _)| g == geo)
        {
            return map.clone();
        }
        let map = Arc::new(Self::build(geo));
        if let Ok(mut cache) = CACHE.lock() {
            cache.insert(0, (*geo, map.clone()));
            cache.truncate(2);
        }
        map
    }

    /// Tabulate `geo`'s inverse: exact on the grid, each grid row mixed
    /// along x once per column, then each pixel row from four grid rows
    /// (rows on rayon's threads, the per-pixel loops vectorised).
    pub fn build(geo: &LensGeometry) -> Self {
        let (w, h) = (geo.width, geo.height);
        let (nx, ny) = (node_count(w), node_count(h));
        let at = |k: usize| (k as f64 - 1.0) * f64::from(GRID) + 0.5;
        // Each grid row's exact sources, then mixed along x: (u, v) planes.
        let cols: Vec<(usize, [f64; 4])> = (0..w).map(stencil).collect();
        let along: Vec<[Vec<f64>; 2]> = (0..ny)
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
        let mut taps = vec![Tap(0); w as usize * h as usize];
        taps.par_chunks_mut(w as usize).enumerate().for_each_init(
            || (vec![0.0; w as usize], vec![0.0; w as usize]),
            |(us, vs), (y, row)| {
                let (r, k) = stencil(y as u32);
                let plane = |p: usize| -> [&[f64]; 4] {
                    std::array::from_fn(|i| along.get(r + i).map_or(&[][..], |a| &a[p][..]))
                };
                super::simd::widest(
                    #[inline(always)]
                    || {
                        mix(plane(0), k, us);
                        mix(plane(1), k, vs);
                        for ((tap, &u), &v) in row.iter_mut().zip(us.iter()).zip(vs.iter()) {
                            *tap = tap_at((u, v), w, h);
                        }
                    },
                );
            },
        );
        Self {
            width: w,
            height: h,
            taps,
        }
    }

    /// Output pixel `i`'s source position as the map samples it (index
    /// space: pixel centres at whole numbers).
    pub fn source(&self, i: usize) -> Option<(f64, f64)> {
        let t = *self.taps.get(i)?;
        let (x0, y0) = (t.index() % self.width, t.index() / self.width);
        let k = f64::from(ONE);
        Some((
            f64::from(x0) + f64::from(t.wx()) / k,
            f64::from(y0) + f64::from(t.wy()) / k,
        ))
    }

    /// The source pixel nearest output pixel `i`'s source (for the id layer).
    pub fn nearest(&self, i: usize) -> Option<u32> {
        let t = *self.taps.get(i)?;
        let dx = u32::from(t.wx() >= ONE / 2);
        let dy = u32::from(t.wy() >= ONE / 2);
        Some(t.index() + dx + dy * self.width)
    }

    /// `src` (RGBA8, the map's size) resampled through the lens: each
    /// output pixel the bilinear mix of its four taps (rows on rayon's
    /// threads).
    pub fn remap(&self, src: &[u8]) -> Vec<u8> {
        let mut out = vec![0u8; self.taps.len() * 4];
        let w = self.width as usize;
        if src.len() < self.taps.len() * 4 {
            return out;
        }
        out.par_chunks_mut(w * 4)
            .zip(self.taps.par_chunks(w))
            .for_each(|(row, taps)| remap_row(src, w, taps, row));
        out
    }

    /// [`Self::remap`] on the rows and columns of `rect` only, into `out`.
    pub fn remap_rect(&self, src: &[u8], out: &mut [u8], rect: super::PixelRect) {
        let w = self.width as usize;
        let (x0, x1) = (
            rect.x0.min(self.width) as usize,
            rect.x1.min(self.width) as usize,
        );
        let (y0, y1) = (
            rect.y0.min(self.height) as usize,
            rect.y1.min(self.height) as usize,
        );
        let n = self.taps.len() * 4;
        if x0 >= x1 || src.len() < n || out.len() < n {
            return;
        }
        for y in y0..y1 {
            let taps = &self.taps[y * w + x0..y * w + x1];
            remap_row(src, w, taps, &mut out[(y * w + x0) * 4..(y * w + x1) * 4]);
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

/// A row's taps: its pixels' source positions (pixel coordinates, clamped
/// to the `w`×`h` image), as the lens map rounds them.
#[derive(Debug, Default)]
pub(super) struct RowTaps(Vec<Tap>);

impl RowTaps {
    /// Set the row's taps from each pixel's source position (`u`, `v`).
    #[inline(always)]
    pub(super) fn set(&mut self, (w, h): (u32, u32), u: &[f64], v: &[f64]) {
        self.0.resize(u.len(), Tap(0));
        for ((tap, &u), &v) in self.0.iter_mut().zip(u).zip(v) {
            *tap = tap_at((u, v), w, h);
        }
    }

    /// The row (`row`, RGBA8) sampled bilinearly from `src` (`w` wide, at
    /// least 2×2) at the taps.
    pub(super) fn resample(&self, src: &[u8], w: u32, row: &mut [u8]) {
        if w >= 2 {
            remap_row(src, w as usize, &self.0, row);
        }
    }
}

/// One row of output pixels from their taps (fixed point, rounded): the
/// AVX2 kernel where the CPU has it, else the scalar one (the same bytes).
#[inline]
fn remap_row(src: &[u8], w: usize, taps: &[Tap], row: &mut [u8]) {
    #[cfg(target_arch = "x86_64")]
    if super::simd::simd_level() >= 1 {
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
    use super::*;

    fn bc(k1: f64, k2: f64, p1: f64, p2: f64) -> LensDraw {
        LensDraw::BrownConrady {
            k1,
            k2,
            k3: 0.0,
            p1,
            p2,
        }
    }

    /// The analytic case: a point at normalised radius r on an axis maps
    /// to r·(1 + k1 r² + k2 r⁴ + k3 r⁶) (Brown–Conrady) or to
    /// θ·(1 + k1 θ² + …), θ = atan r (fisheye).
    #[test]
    fn a_point_at_radius_r_maps_to_the_models_radius() {
        let d = LensDraw::BrownConrady {
            k1: -0.2,
            k2: 0.05,
            k3: 0.01,
            p1: 0.0,
            p2: 0.0,
        };
        for r in [0.1, 0.5, 0.9] {
            let (x, y) = d.distort((r, 0.0));
            let want = r * (1.0 - 0.2 * r * r + 0.05 * r.powi(4) + 0.01 * r.powi(6));
            assert!((x - want).abs() < 1e-15 && y == 0.0, "{r}: {x} vs {want}");
            let (x, y) = d.distort((0.0, r));
            assert!((y - want).abs() < 1e-15 && x == 0.0);
        }
        let f = LensDraw::Fisheye {
            k1: 0.1,
            k2: -0.02,
            k3: 0.0,
            k4: 0.0,
        };
        let r: f64 = 0.8;
        let t = r.atan();
        let want = t * (1.0 + 0.1 * t * t - 0.02 * t.powi(4));
        let (x, y) = f.distort((r * 0.6, r * 0.8));
        assert!((x.hypot(y) - want).abs() < 1e-15);
        // Tangential terms: (x, y) = (0.3, 0.2), p1 = 0.01, p2 = −0.02.
        let (x, y) = bc(0.0, 0.0, 0.01, -0.02).distort((0.3, 0.2));
        let r2 = 0.13;
        assert!((x - (0.3 + 2.0 * 0.01 * 0.06 - 0.02 * (r2 + 0.18))).abs() < 1e-15);
        assert!((y - (0.2 + 0.01 * (r2 + 0.08) - 2.0 * 0.02 * 0.06)).abs() < 1e-15);
    }

    #[test]
    fn the_inverse_map_round_trips_within_a_thousandth_of_a_pixel() {
        let lenses = [
            bc(-0.25, 0.05, 0.002, -0.001),
            bc(0.2, 0.0, 0.0, 0.0),
            LensDraw::Fisheye {
                k1: 0.0,
                k2: 0.0,
                k3: 0.0,
                k4: 0.0,
            },
            LensDraw::Fisheye {
                k1: -0.05,
                k2: 0.01,
                k3: 0.0,
                k4: 0.0,
            },
        ];
        for d in lenses {
            let geo = LensGeometry::new(d, 1920, 1080, 1100.0).expect("a lens");
            let mut worst = 0.0f64;
            for j in 0..=27 {
                for i in 0..=48 {
                    let p = (f64::from(i) * 40.0, f64::from(j) * 40.0);
                    let back = geo.forward(geo.inverse(p));
                    worst = worst.max((back.0 - p.0).hypot(back.1 - p.1));
                }
            }
            assert!(worst < 1e-3, "{d:?}: {worst} px");
        }
    }

    /// The written picture shows only rendered pixels, and reaches the
    /// render's edge somewhere (the widest such view).
    #[test]
    fn the_written_picture_is_filled_by_the_render() {
        for d in [bc(-0.3, 0.0, 0.0, 0.0), bc(0.3, 0.0, 0.0, 0.0)] {
            let geo = LensGeometry::new(d, 640, 360, 400.0).expect("a lens");
            let corner = geo.inverse((0.5, 0.5));
            let edge = geo.inverse((320.0, 0.5));
            let reach = corner.0.min(corner.1).min(edge.1);
            assert!((0.5 - 1e-6..0.5 + 1e-3).contains(&reach), "{d:?}: {reach}");
        }
    }

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

    /// The stage's cost on a 1920×1080 frame (as `examples/lens_bench.rs`):
    /// `cargo test --release --lib lens_cost -- --ignored --nocapture`.
    #[test]
    #[ignore = "a timing, not a check"]
    fn lens_cost() {
        use std::time::Instant;
        let (w, h) = (1920u32, 1080u32);
        let focal = 540.0 / 25f64.to_radians().tan();
        let rgba: Vec<u8> = (0..w * h * 4).map(|i| (i % 251) as u8).collect();
        let median = |run: &mut dyn FnMut()| {
            let mut t: Vec<f64> = (0..15)
                .map(|_| {
                    let s = Instant::now();
                    run();
                    s.elapsed().as_secs_f64() * 1e3
                })
                .collect();
            t.sort_by(f64::total_cmp);
            t[t.len() / 2]
        };
        let geo = LensGeometry::new(bc(-0.15, 0.02, 0.0005, -0.0005), w, h, focal).expect("a lens");
        let map = LensMap::of(&geo);
        let remap = median(&mut || {
            std::hint::black_box(map.remap(&rgba));
        });
        let mut k = 0.0;
        let build = median(&mut || {
            k += 1e-6;
            let g = LensGeometry::new(bc(-0.15 + k, 0.02, 0.0005, -0.0005), w, h, focal);
            std::hint::black_box(g.map(|g| LensMap::build(&g)));
        });
        println!(
            "lens 1920x1080, {} threads: remap {remap:.2} ms, new draw (geometry + map) {build:.2} ms",
            rayon::current_num_threads()
        );
    }

    #[test]
    fn a_neutral_draw_is_no_lens() {
        assert_eq!(
            LensGeometry::new(bc(0.0, 0.0, 0.0, 0.0), 64, 48, 50.0),
            None
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
        assert_eq!(map.remap(&flat), flat);
        let ramp: Vec<u8> = (0..w * h)
            .flat_map(|i| [(i % w * 2) as u8, 0, 0, 255])
            .collect();
        let out = map.remap(&ramp);
        let row = (h / 2 * w * 4) as usize;
        let reds: Vec<u8> = (0..w as usize).map(|x| out[row + x * 4]).collect();
        assert!(reds.windows(2).all(|p| p[0] <= p[1]), "{reds:?}");
        let mut part = flat.clone();
        let rect = super::super::PixelRect {
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

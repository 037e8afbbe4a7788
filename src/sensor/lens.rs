//! Lens distortion (issue 41): the lens's geometric mapping between the
//! rendered pinhole picture and the written one. [`LensDraw`] is a frame's
//! drawn coefficients (Brown–Conrady or the equidistant fisheye, the
//! formulas in `preset/lens.rs`) and the model's formula on normalised
//! coordinates; [`LensGeometry`] the mapping in pixels for one camera
//! (forward: rendered → written, for the labels' points; inverse: written →
//! rendered, for the picture), and [`LensMap`] (`lens/map.rs`) the inverse
//! on a grid, cached per draw, that resamples a picture once
//! ([`LensMap::remap`], the bilinear kernel in `lens/kernel.rs`) and moves
//! the id layer with nearest taps ([`LensMap::nearest_in`]).
//!
//! The written picture keeps the render's principal point and is scaled
//! (its focal length `focal_out`) so that it shows only rendered pixels:
//! the widest view whose every pixel's source lies inside the render
//! ([`LensGeometry::new`]). Past the radius where the model stops growing
//! (its slope under [`MIN_SLOPE`], or 1.5 × the render's corner radius) the
//! radial mapping continues as a straight line, so points far outside the
//! picture (a drone crossing the near plane) never fold back into it.

use std::sync::Mutex;

use serde::Serialize;

use crate::preset::lens::Lens;

mod fill;
mod kernel;
mod map;
#[cfg(target_arch = "x86_64")]
mod newton;
mod taps;
pub use map::{LensMap, Lensed};

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

/// The most Newton steps an inverse takes (it stops when converged).
const NEWTON_STEPS: usize = 30;

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
    /// resample, or past the largest side a preset takes). The last few are
    /// kept: a fixed draw is solved once.
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
        let sides = 2..=crate::preset::MAX_IMAGE_SIDE;
        if draw.is_neutral()
            || !(sides.contains(&width) && sides.contains(&height))
            || !(focal.is_finite() && focal > 0.0)
        {
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
        for _ in 0..NEWTON_STEPS {
            match self.newton_step(p, d) {
                Some(next) => p = next,
                None => break,
            }
        }
        p
    }

    /// [`Self::inverse_n`] of four points at once: each point's steps are
    /// its own (the same values), in AVX2 lanes for a Brown–Conrady draw
    /// (`lens/newton.rs`), else taken in turn so that the CPU overlaps the
    /// four chains of dependent divisions.
    fn inverse_n4(&self, d: [(f64, f64); 4]) -> [(f64, f64); 4] {
        #[cfg(target_arch = "x86_64")]
        if crate::simd::simd_level() >= 1 {
            // SAFETY: the CPU has AVX2 (checked by `simd_level`).
            #[allow(unsafe_code)]
            if let Some(p) = unsafe { self.inverse_n4_avx2(d) } {
                return p;
            }
        }
        let mut p = d;
        let mut live = [true; 4];
        for _ in 0..NEWTON_STEPS {
            for ((p, &d), live) in p.iter_mut().zip(&d).zip(&mut live) {
                if *live {
                    match self.newton_step(*p, d) {
                        Some(next) => *p = next,
                        None => *live = false,
                    }
                }
            }
            if live == [false; 4] {
                break;
            }
        }
        p
    }

    /// One Newton step from `p` towards the point that maps to `d`
    /// (`None`: converged, or a singular Jacobian).
    #[inline(always)]
    fn newton_step(&self, p: (f64, f64), d: (f64, f64)) -> Option<(f64, f64)> {
        let f = self.forward_n(p);
        let e = (f.0 - d.0, f.1 - d.1);
        if e.0.abs() + e.1.abs() < 1e-14 {
            return None;
        }
        let h = 1e-7 * (1.0 + p.0.abs() + p.1.abs());
        let fx = self.forward_n((p.0 + h, p.1));
        let fy = self.forward_n((p.0, p.1 + h));
        let (a, b) = ((fx.0 - f.0) / h, (fy.0 - f.0) / h);
        let (c, dd) = ((fx.1 - f.1) / h, (fy.1 - f.1) / h);
        let det = a * dd - b * c;
        if det.is_nan() || det.abs() <= 1e-12 {
            return None;
        }
        Some((
            p.0 - (dd * e.0 - b * e.1) / det,
            p.1 - (a * e.1 - c * e.0) / det,
        ))
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

    /// [`Self::inverse`] of each of `points` (the same values), four at a
    /// time ([`Self::inverse_n4`]).
    pub fn inverse_all(&self, points: &[(f64, f64)]) -> Vec<(f64, f64)> {
        self.inverse_all_with(self.focal_out, points)
    }

    fn inverse_all_with(&self, focal_out: f64, points: &[(f64, f64)]) -> Vec<(f64, f64)> {
        let (cx, cy) = self.centre();
        let norm = |&(u, v): &(f64, f64)| ((u - cx) / focal_out, (v - cy) / focal_out);
        let mut out = Vec::with_capacity(points.len());
        for four in points.chunks(4) {
            let mut d = [(0.0, 0.0); 4];
            for (k, o) in d.iter_mut().enumerate() {
                *o = norm(&four[k.min(four.len() - 1)]);
            }
            let p = self.inverse_n4(d);
            let pixel = |(x, y): (f64, f64)| (cx + self.focal * x, cy + self.focal * y);
            out.extend(p[..four.len()].iter().copied().map(pixel));
        }
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A Brown–Conrady draw without k3 (the map's tests use it too).
    pub(super) fn bc(k1: f64, k2: f64, p1: f64, p2: f64) -> LensDraw {
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

    /// Four at a time, each point's Newton steps are its own: the same
    /// bits as one at a time (points near, across and far past the fold
    /// radius, and a count that is not a multiple of four).
    #[test]
    fn the_inverse_four_at_a_time_is_the_inverse_bit_for_bit() {
        let fisheye = LensDraw::Fisheye {
            k1: 0.05,
            k2: -0.01,
            k3: 0.0,
            k4: 0.0,
        };
        for d in [
            bc(-0.3, 0.08, 0.003, 0.002),
            bc(0.2, 0.0, -0.01, 0.0),
            fisheye,
        ] {
            let geo = LensGeometry::new(d, 640, 360, 300.0).expect("a lens");
            // A line across the fold radius, and a grid over the picture and
            // past its edges (the AVX2 lanes and their scalar steps).
            let points: Vec<(f64, f64)> = (0..23)
                .map(|i| {
                    let t = f64::from(i);
                    (-900.0 + 97.3 * t, 180.0 - 61.7 * t + (t * 1.3).sin() * 40.0)
                })
                .chain((0..41 * 25).map(|i| {
                    let (x, y) = (f64::from(i % 41), f64::from(i / 41));
                    (-80.0 + 20.0 * x + 0.37 * y, -60.0 + 20.0 * y - 0.21 * x)
                }))
                .collect();
            let one: Vec<(f64, f64)> = points.iter().map(|&p| geo.inverse(p)).collect();
            let bits = |v: &[(f64, f64)]| -> Vec<(u64, u64)> {
                v.iter().map(|p| (p.0.to_bits(), p.1.to_bits())).collect()
            };
            assert_eq!(bits(&geo.inverse_all(&points)), bits(&one), "{d:?}");
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

    #[test]
    fn a_neutral_draw_is_no_lens() {
        assert_eq!(
            LensGeometry::new(bc(0.0, 0.0, 0.0, 0.0), 64, 48, 50.0),
            None
        );
    }
}

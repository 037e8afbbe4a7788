//! The background's temperature texture (`thermal.texture`; docs/realism.md,
//! "Thermal camera"): Gaussian fractal noise, the structure a real thermal
//! sky and scene carry (cloud and air, scenery) at every scale.
//!
//! The field lives on a lattice tied to the sky, one lattice step a pixel:
//! the picture is the window of it at [`Anchor::origin`], so a camera that
//! turns sees the same field moved (a narrow lens' pan or tilt; a roll does
//! not turn it). It is a sum of octaves, each a uniform cubic B-spline
//! surface over Gaussian control points 2^L pixels apart, from L = 1 (2 px)
//! up to `size` × the frame's height (to the nearest octave), made from the
//! coarsest down: the points of level L are subdivided (B-spline
//! refinement: the same surface on a lattice twice as fine) and level
//! L−1's own points added, so each level costs its points; the last is
//! evaluated at the pixel centres. Each point's value is a hash of the
//! seed, its level and its lattice cell, so any window of the field is the
//! same wherever it is made. Rows in bands on rayon's threads, each value
//! made alone, so the split does not change a bit.
//!
//! An octave of period p carries power ∝ p^(slope − 2): the power spectrum
//! falls as 1/f^slope. The octaves' σ are set so the field's RMS is
//! `rms_k` (a B-spline surface over points of σ has a variance of
//! (151/315)² σ² averaged over positions).
//!
//! With a `sharpness` s > 0 the unit field g goes through a soft clip,
//! `clip(s·g)` (a rational tanh that reaches ±1 at ±3 with zero slope),
//! scaled back to RMS 1: the values gather on two plateaus, warmer and
//! colder, joined by steep fronts, as cloud and scenery are patches of
//! near-even temperature with edges, where a Gaussian field's curvature at
//! every scale reads as noise (docs/realism.md, "Thermal camera").

use rayon::prelude::*;

use crate::preset::thermal::Texture;

use super::super::noise::deviate;

/// Where the picture lies on the field's lattice, and whose field it is.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Anchor {
    /// The field's seed.
    pub seed: u64,
    /// The lattice coordinates (pixels) of the picture's top-left corner.
    pub origin: (f64, f64),
}

/// The mean over positions of a 1-D cubic B-spline's squared weights (∫B₃²).
const SPLINE_VARIANCE_1D: f64 = 151.0 / 315.0;
/// The finest level: control points 2 px apart.
const FINEST: u32 = 1;

/// Adds the texture to `plane` (`w`×`h`, row-major; `per_k` radiance units a kelvin)
/// times each pixel's `share` (0–1, the same size; `x.ground_only`: the background's
/// share of ground and scenery, [`super::ground_share`]): the field's value at a pixel
/// times its share, in the one pass that evaluates it.
pub fn add_on(
    x: &Texture,
    per_k: f32,
    anchor: Anchor,
    (w, h): (u32, u32),
    share: &[f32],
    plane: &mut [f32],
) {
    if share.len() >= w as usize * h as usize {
        add_with(x, per_k, anchor, (w, h), Some(share), plane);
    }
}

/// Adds the texture to `plane` (`w`×`h`, row-major; `per_k` radiance units a kelvin).
pub fn add(x: &Texture, per_k: f32, anchor: Anchor, dims: (u32, u32), plane: &mut [f32]) {
    add_with(x, per_k, anchor, dims, None, plane);
}

/// [`add`], each pixel's value times its `share` when given.
fn add_with(
    x: &Texture,
    per_k: f32,
    anchor: Anchor,
    (w, h): (u32, u32),
    share: Option<&[f32]>,
    plane: &mut [f32],
) {
    let (w, h) = (w as usize, h as usize);
    if w == 0 || h == 0 || plane.len() < w * h || x.rms_k <= 0.0 {
        return;
    }
    let top = coarsest(x.size * h as f64);
    let sigmas = level_sigmas(x, top);
    let columns = Taps::new(anchor.origin.0, w);
    let rows = Taps::new(anchor.origin.1, h);
    let mut needed = vec![(columns.span(), rows.span())];
    for _ in FINEST..top {
        let &(cx, cy) = needed.last().expect("one at least");
        needed.push((coarser(cx), coarser(cy)));
    }
    let at = |level: u32| (level - FINEST) as usize;
    let mut grid = Grid::zeros(needed[at(top)]);
    grid.add_noise(anchor.seed, top, sigmas[at(top)]);
    for level in (FINEST..top).rev() {
        let finer = grid.refine_to(needed[at(level)]);
        give(std::mem::replace(&mut grid, finer).values);
        grid.add_noise(anchor.seed, level, sigmas[at(level)]);
    }
    let gain = per_k * x.rms_k as f32;
    let shape = Shape::of(x.sharpness);
    let share = share.map(|s| &s[..w * h]);
    evaluate(
        &grid,
        (&columns, &rows),
        (gain, shape),
        share,
        &mut plane[..w * h],
    );
    give(grid.values);
}

/// How a unit field value becomes the texture's: as it is, or soft-clipped.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Shape {
    Linear,
    /// `clip(scale · g) × norm`, `norm` making the result's RMS 1 for a unit
    /// Gaussian g.
    Clipped {
        scale: f32,
        norm: f32,
    },
}

impl Shape {
    fn of(sharpness: f64) -> Self {
        if sharpness.is_finite() && sharpness > 0.0 {
            let norm = 1.0 / clipped_rms(sharpness);
            Shape::Clipped {
                scale: sharpness as f32,
                norm: norm as f32,
            }
        } else {
            Shape::Linear
        }
    }
}

/// The soft clip: x(27 + x²)/(27 + 9x²) on [−3, 3] (tanh's Padé form: slope 1 at 0,
/// ±1 with slope 0 at ±3), ±1 beyond.
#[inline(always)]
fn clip(x: f32) -> f32 {
    let x = x.clamp(-3.0, 3.0);
    let x2 = x * x;
    x * (27.0 + x2) / (27.0 + 9.0 * x2)
}

/// RMS of `clip(s·g)` for a unit Gaussian g: Simpson's rule over ±8 σ in f64 (the same
/// clip), the density's exponential of whole-step arguments.
fn clipped_rms(s: f64) -> f64 {
    const STEPS: usize = 1600;
    let h = 16.0 / STEPS as f64;
    let f = |i: usize| {
        let g = -8.0 + h * i as f64;
        let c = f64::from(clip((s * g) as f32));
        c * c * (-0.5 * g * g).exp()
    };
    let inner: f64 = (1..STEPS)
        .map(|i| if i % 2 == 1 { 4.0 } else { 2.0 } * f(i))
        .sum();
    let integral = h / 3.0 * (f(0) + inner + f(STEPS));
    (integral / (2.0 * std::f64::consts::PI).sqrt()).sqrt()
}

/// The coarsest level: its points `size_px` apart, to the nearest octave.
fn coarsest(size_px: f64) -> u32 {
    (size_px.max(1.0).log2().round() as u32).clamp(FINEST, 24)
}

/// Each level's control-point σ (finest first), for a field of RMS 1.
fn level_sigmas(x: &Texture, top: u32) -> Vec<f32> {
    let weights: Vec<f64> = (FINEST..=top)
        .map(|l| 2f64.powf(f64::from(l) * (x.slope - 2.0) * 0.5))
        .collect();
    let total: f64 = weights.iter().map(|w| w * w).sum();
    let norm = (SPLINE_VARIANCE_1D * SPLINE_VARIANCE_1D * total).sqrt();
    weights.iter().map(|w| (w / norm) as f32).collect()
}

/// A span of lattice indices, first and last (inclusive).
type Span = (i64, i64);

/// The coarser level's span whose refinement covers `span`: a refined
/// point 2i is made from coarse points i − 1 … i + 1, 2i + 1 from i, i + 1.
fn coarser((c, d): Span) -> Span {
    ((c - 1).div_euclid(2), (d + 2).div_euclid(2))
}

/// One level's control points over a span of lattice cells.
#[derive(Clone, Debug)]
struct Grid {
    xs: Span,
    ys: Span,
    values: Vec<f32>,
}

impl Grid {
    fn zeros((xs, ys): (Span, Span)) -> Self {
        let n = len(xs) * len(ys);
        Self {
            xs,
            ys,
            values: take(n),
        }
    }

    fn width(&self) -> usize {
        len(self.xs)
    }

    /// Each point's own Gaussian value of σ `sigma` at `level`, added.
    fn add_noise(&mut self, seed: u64, level: u32, sigma: f32) {
        let (w, xs) = (self.width(), self.xs);
        let salt = seed ^ (u64::from(level) << 58);
        (self.values.par_chunks_mut(w).enumerate()).for_each(|(j, row)| {
            let y = (self.ys.0 + j as i64) as u64;
            noise_row(
                row,
                salt ^ y.wrapping_mul(0xC2B2_AE3D_27D4_EB4F),
                xs.0,
                sigma,
            );
        });
    }

    /// The same surface's control points on the lattice twice as fine, over
    /// `(xs, ys)` (within what this grid's points make: [`coarser`]'s spans).
    /// A refined point 2i is (p[i−1] + 6·p[i] + p[i+1]) / 8, 2i + 1 is
    /// (p[i] + p[i+1]) / 2: along the rows first, then down the columns.
    fn refine_to(&self, (xs, ys): (Span, Span)) -> Grid {
        let (w, h) = (len(xs), len(ys));
        let gw = self.width();
        // Coarse rows ys.0 / 2 − 1 … those the refined rows read, refined along (when
        // ys.0 is odd its first refined row reads from ys.0 / 2 on, and the row before,
        // which may lie outside this grid, is clamped to its first and never read).
        let first_row = ys.0.div_euclid(2) - 1;
        let rows = (ys.1.div_euclid(2) + 1 - first_row + 1) as usize;
        let mut across = take(rows * w);
        (across.par_chunks_mut(w).enumerate()).for_each(|(r, out)| {
            let row = (first_row + r as i64 - self.ys.0).clamp(0, len(self.ys) as i64 - 1);
            let p = &self.values[row as usize * gw..][..gw];
            refine_into(p, xs.0 - 2 * self.xs.0, out);
        });
        let mut values = take(w * h);
        (values.par_chunks_mut(w).enumerate()).for_each(|(j, out)| {
            let k = ys.0 + j as i64;
            let i = (k.div_euclid(2) - first_row) as usize;
            let row = |r: usize| &across[r * w..(r + 1) * w];
            if k.rem_euclid(2) == 1 {
                refine_odd(out, row(i), row(i + 1));
            } else {
                refine_even(out, row(i - 1), row(i), row(i + 1));
            }
        });
        give(across);
        Grid { xs, ys, values }
    }
}

simd_fn! {
    /// Each point of `row` (lattice cells from `x0`) given its own Gaussian value of σ
    /// `sigma`, a hash of `row_key` and its cell.
    fn noise_row(row: &mut [f32], row_key: u64, x0: i64, sigma: f32) {
        for (i, v) in row.iter_mut().enumerate() {
            let x = (x0 + i as i64) as u64;
            let bits = crate::seed::mix64(row_key ^ x.wrapping_mul(0x9E37_79B9_7F4A_7C15));
            *v += sigma * deviate(bits as u32);
        }
    }
}

simd_fn! {
    /// Refined points between two coarse lines: their mean.
    fn refine_odd(out: &mut [f32], a: &[f32], b: &[f32]) {
        for ((o, a), b) in out.iter_mut().zip(a).zip(b) {
            *o = (a + b) * 0.5;
        }
    }
}

simd_fn! {
    /// Refined points on coarse line `b`: (a + 6b + c) / 8.
    fn refine_even(out: &mut [f32], a: &[f32], b: &[f32], c: &[f32]) {
        for (((o, a), b), c) in out.iter_mut().zip(a).zip(b).zip(c) {
            *o = (a + b * 6.0 + c) * 0.125;
        }
    }
}

fn len((a, b): Span) -> usize {
    (b - a + 1).max(0) as usize
}

/// One line of control points `p` refined into `out`: refined point k = `from` + n (in
/// the coarse line's own index, doubled) for each n of `out`; its coarse neighbours
/// clamped to the line (the spans keep them inside).
fn refine_into(p: &[f32], from: i64, out: &mut [f32]) {
    let last = p.len() as i64 - 1;
    let at = |i: i64| p[i.clamp(0, last) as usize];
    for (n, o) in out.iter_mut().enumerate() {
        let k = from + n as i64;
        let i = k.div_euclid(2);
        *o = if k.rem_euclid(2) == 1 {
            (at(i) + at(i + 1)) * 0.5
        } else {
            (at(i - 1) + at(i) * 6.0 + at(i + 1)) * 0.125
        };
    }
}

/// The cubic B-spline's four weights at fraction `t` of a step.
fn weights(t: f64) -> [f32; 4] {
    let (t2, t3) = (t * t, t * t * t);
    let s = 1.0 - t;
    [
        s * s * s / 6.0,
        (3.0 * t3 - 6.0 * t2 + 4.0) / 6.0,
        (-3.0 * t3 + 3.0 * t2 + 3.0 * t + 1.0) / 6.0,
        t3 / 6.0,
    ]
    .map(|w| w as f32)
}

/// For each pixel along one axis, its four control points on the finest
/// lattice (2 px apart) and their weights: pixels 2 apart share their
/// weights and read points one further on, so two pixels give them all.
struct Taps {
    /// The first point of pixel 0 and pixel 1.
    first: [i64; 2],
    weights: [[f32; 4]; 2],
    n: usize,
}

impl Taps {
    /// `origin`: the lattice coordinate (pixels) of the axis' first pixel's
    /// edge, rounded to 1/256 px (so a last-bit difference in the camera's
    /// angles does not move a weight); `n` pixels.
    fn new(origin: f64, n: usize) -> Self {
        let origin = (origin * 256.0).round() / 256.0;
        let step = f64::from(1u32 << FINEST);
        let tap = |i: usize| {
            let u = (origin + i as f64 + 0.5) / step;
            let base = u.floor();
            (base as i64 - 1, weights(u - base))
        };
        let ((f0, w0), (f1, w1)) = (tap(0), tap(1));
        Self {
            first: [f0, f1],
            weights: [w0, w1],
            n,
        }
    }

    /// Pixel `i`'s first point.
    fn first(&self, i: usize) -> i64 {
        self.first[i % 2] + (i / 2) as i64
    }

    /// The control points the pixels read.
    fn span(&self) -> Span {
        let last = self.n.max(1) - 1;
        let a = self.first(0).min(self.first(last.min(1)));
        let b = self.first(last).max(self.first(last.saturating_sub(1)));
        (a, b + 3)
    }
}

/// The finest grid evaluated at the pixel centres, × `gain`, added to `plane`:
/// along the rows into one line per grid row, then down the columns.
fn evaluate(
    grid: &Grid,
    (columns, rows): (&Taps, &Taps),
    (gain, shape): (f32, Shape),
    share: Option<&[f32]>,
    plane: &mut [f32],
) {
    let w = columns.n;
    let gw = grid.width();
    let mut across = take(len(grid.ys) * w);
    let from = [0, 1].map(|p| (columns.first[p] - grid.xs.0) as usize);
    (across.par_chunks_mut(w).zip(grid.values.par_chunks(gw))).for_each(|(out, line)| {
        along_row(out, line, from, &columns.weights);
    });
    (plane.par_chunks_mut(w).enumerate()).for_each(|(y, out)| {
        let (r, k) = ((rows.first(y) - grid.ys.0) as usize, rows.weights[y % 2]);
        let line = |d: usize| &across[(r + d) * w..(r + d + 1) * w];
        let lines = [line(0), line(1), line(2), line(3)];
        let on = share.map(|s| &s[y * w..(y + 1) * w]);
        match (shape, on) {
            (Shape::Linear, None) => down_row(out, lines, k, gain),
            (Shape::Clipped { scale, norm }, None) => {
                down_row_clipped(out, lines, k, scale, gain * norm);
            }
            (Shape::Linear, Some(on)) => down_row_on(out, lines, k, gain, on),
            (Shape::Clipped { scale, norm }, Some(on)) => {
                down_row_clipped_on(out, lines, k, (scale, gain * norm), on);
            }
        }
    });
    give(across);
}

thread_local! {
    /// The field's buffers, kept on the calling thread from frame to frame: a 1080p
    /// field's levels and lines take about 8 MB, and fresh ones cost the kernel's page
    /// faults and zeroing every frame.
    static POOL: std::cell::RefCell<Vec<Vec<f32>>> = const { std::cell::RefCell::new(Vec::new()) };
}

/// A buffer of `n` zeros: the pool's smallest that holds them, else its largest.
fn take(n: usize) -> Vec<f32> {
    let kept = POOL.with(|p| {
        let mut p = p.borrow_mut();
        let fits = (0..p.len()).filter(|&i| p[i].capacity() >= n);
        let pick = fits
            .min_by_key(|&i| p[i].capacity())
            .or_else(|| (0..p.len()).max_by_key(|&i| p[i].capacity()))?;
        Some(p.swap_remove(pick))
    });
    let mut v = kept.unwrap_or_default();
    v.clear();
    v.resize(n, 0.0);
    v
}

/// Returns a buffer to the pool (at most four are kept).
fn give(v: Vec<f32>) {
    POOL.with(|p| {
        let mut p = p.borrow_mut();
        if p.len() < 4 {
            p.push(v);
        }
    });
}

simd_fn! {
    /// One grid line evaluated at a row's pixels: pixel 2j + p from the four points
    /// from `from[p]` + j, with weights `k[p]`.
    fn along_row(out: &mut [f32], line: &[f32], from: [usize; 2], k: &[[f32; 4]; 2]) {
        for (p, (&f, k)) in from.iter().zip(k).enumerate() {
            let taps = line[f..].windows(4);
            for (o, t) in out[p..].iter_mut().step_by(2).zip(taps) {
                *o = t[0] * k[0] + t[1] * k[1] + t[2] * k[2] + t[3] * k[3];
            }
        }
    }
}

simd_fn! {
    /// A row of pixels from its four evaluated grid lines and their weights, × `gain`,
    /// added to `out`.
    fn down_row(out: &mut [f32], lines: [&[f32]; 4], k: [f32; 4], gain: f32) {
        let [a, b, c, d] = lines;
        for ((((o, a), b), c), d) in out.iter_mut().zip(a).zip(b).zip(c).zip(d) {
            let v = a * k[0] + b * k[1] + c * k[2] + d * k[3];
            *o += v * gain;
        }
    }
}

simd_fn! {
    /// [`down_row`] through the soft clip: `clip(scale · v) × gain` added to `out`.
    fn down_row_clipped(out: &mut [f32], lines: [&[f32]; 4], k: [f32; 4], scale: f32, gain: f32) {
        let [a, b, c, d] = lines;
        for ((((o, a), b), c), d) in out.iter_mut().zip(a).zip(b).zip(c).zip(d) {
            let v = a * k[0] + b * k[1] + c * k[2] + d * k[3];
            *o += clip(v * scale) * gain;
        }
    }
}

simd_fn! {
    /// [`down_row`] times each pixel's share `on`.
    fn down_row_on(out: &mut [f32], lines: [&[f32]; 4], k: [f32; 4], gain: f32, on: &[f32]) {
        let [a, b, c, d] = lines;
        for (((((o, a), b), c), d), s) in out.iter_mut().zip(a).zip(b).zip(c).zip(d).zip(on) {
            let v = a * k[0] + b * k[1] + c * k[2] + d * k[3];
            *o += v * gain * s;
        }
    }
}

simd_fn! {
    /// [`down_row_clipped`] times each pixel's share `on`.
    fn down_row_clipped_on(
        out: &mut [f32],
        lines: [&[f32]; 4],
        k: [f32; 4],
        scale_gain: (f32, f32),
        on: &[f32],
    ) {
        let ((scale, gain), [a, b, c, d]) = (scale_gain, lines);
        for (((((o, a), b), c), d), s) in out.iter_mut().zip(a).zip(b).zip(c).zip(d).zip(on) {
            let v = a * k[0] + b * k[1] + c * k[2] + d * k[3];
            *o += clip(v * scale) * gain * s;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn field(x: &Texture, origin: (f64, f64), seed: u64, (w, h): (u32, u32)) -> Vec<f32> {
        let mut plane = vec![0f32; (w * h) as usize];
        add(x, 1.0, Anchor { seed, origin }, (w, h), &mut plane);
        plane
    }

    /// A Gaussian field (sharpness 0) of RMS 1.
    fn texture(slope: f64, size: f64) -> Texture {
        Texture {
            rms_k: 1.0,
            slope,
            size,
            sharpness: 0.0,
            ground_only: false,
        }
    }

    #[test]
    fn the_field_has_the_rms_asked_for() {
        for x in [texture(2.5, 0.25), texture(3.0, 1.0), texture(4.0, 0.5)] {
            // The mean square over 12 fields (a field's own mean square spreads with its
            // few largest features).
            let (w, h) = (256u32, 256u32);
            let ms: f64 = (0..12u64)
                .map(|seed| {
                    let f = field(&x, (0.0, 0.0), seed, (w, h));
                    f.iter().map(|v| f64::from(*v).powi(2)).sum::<f64>() / f.len() as f64
                })
                .sum::<f64>()
                / 12.0;
            let rms = ms.sqrt();
            assert!((0.8..1.2).contains(&rms), "{x:?}: RMS {rms}");
        }
    }

    /// The clip's RMS for a unit Gaussian: the clip's slope at small values (s·σ), and
    /// about 1 when nearly every value is clipped.
    #[test]
    fn the_clipped_rms_matches_its_limits() {
        let small = clipped_rms(0.01);
        assert!((small / 0.01 - 1.0).abs() < 1e-3, "{small}");
        let large = clipped_rms(20.0);
        assert!((0.97..=1.0).contains(&large), "{large}");
        assert!(clipped_rms(1.0) < clipped_rms(3.0));
    }

    /// A sharp field keeps its RMS and gathers on two plateaus: its values' kurtosis
    /// (a Gaussian's 3) falls below 2 at sharpness 3, where the Gaussian field's stays
    /// near 3; so its gradients gather on fronts: more of its pixels are nearly flat.
    #[test]
    fn a_sharp_field_keeps_its_rms_and_steps_between_plateaus() {
        let (w, h) = (256u32, 256u32);
        let moments = |x: &Texture| {
            let (mut m2, mut m4, mut flat, mut n) = (0.0, 0.0, 0usize, 0usize);
            for seed in 0..12u64 {
                let f = field(x, (0.0, 0.0), seed, (w, h));
                for (i, v) in f.iter().enumerate() {
                    let v = f64::from(*v);
                    (m2, m4, n) = (m2 + v * v, m4 + v.powi(4), n + 1);
                    if i % w as usize + 1 < w as usize && (f[i + 1] - f[i]).abs() < 0.005 {
                        flat += 1;
                    }
                }
            }
            let (m2, m4) = (m2 / n as f64, m4 / n as f64);
            (m2.sqrt(), m4 / (m2 * m2), flat as f64 / n as f64)
        };
        let gaussian = texture(3.0, 0.5);
        let sharp = Texture {
            sharpness: 3.0,
            ..gaussian
        };
        let (rms_g, kurt_g, flat_g) = moments(&gaussian);
        let (rms_s, kurt_s, flat_s) = moments(&sharp);
        assert!((0.8..1.2).contains(&rms_s), "sharp RMS {rms_s}");
        assert!(
            (2.4..3.6).contains(&kurt_g),
            "Gaussian kurtosis {kurt_g} (RMS {rms_g})"
        );
        assert!(kurt_s < 2.0, "sharp kurtosis {kurt_s}");
        assert!(
            flat_s > 1.3 * flat_g,
            "nearly flat steps {flat_s} against {flat_g}"
        );
    }

    /// The mean squared difference of pixels `lag` apart along rows and columns.
    fn structure(f: &[f32], w: usize, lag: usize) -> f64 {
        let h = f.len() / w;
        let mut s = 0.0;
        let mut n = 0.0;
        for y in 0..h - lag {
            for x in 0..w - lag {
                let v = f64::from(f[y * w + x]);
                s += (f64::from(f[y * w + x + lag]) - v).powi(2);
                s += (f64::from(f[(y + lag) * w + x]) - v).powi(2);
                n += 2.0;
            }
        }
        s / n
    }

    #[test]
    fn the_power_falls_with_frequency_as_the_slope_says() {
        // For a power spectrum ∝ 1/f^β (2 < β < 4) the mean squared difference at lag d
        // grows as d^(β − 2): doubling the lag from 8 to 16 px multiplies it by 2^(β − 2).
        for slope in [2.5, 3.0, 3.5] {
            let x = texture(slope, 2.0);
            let (w, h) = (256u32, 256u32);
            let (mut d8, mut d16) = (0.0, 0.0);
            for seed in 0..6u64 {
                let f = field(&x, (0.0, 0.0), seed, (w, h));
                d8 += structure(&f, w as usize, 8);
                d16 += structure(&f, w as usize, 16);
            }
            let (got, want) = (d16 / d8, 2f64.powf(slope - 2.0));
            assert!(
                (got / want - 1.0).abs() < 0.25,
                "slope {slope}: ×{got:.2} from 8 to 16 px, want ×{want:.2}"
            );
        }
    }

    #[test]
    fn a_window_elsewhere_on_the_lattice_reads_the_same_field() {
        let x = texture(3.0, 1.0);
        let (w, h) = (96u32, 64u32);
        let a = field(&x, (100.0, -40.0), 7, (w, h));
        // 24 px right and 16 px down: its pixel (i, j) is a's (i + 24, j + 16).
        let b = field(&x, (124.0, -24.0), 7, (w, h));
        for j in 0..(h - 16) as usize {
            for i in 0..(w - 24) as usize {
                assert_eq!(b[j * w as usize + i], a[(j + 16) * w as usize + i + 24]);
            }
        }
        // Another seed, another field; the same call, the same bits.
        assert_ne!(a, field(&x, (100.0, -40.0), 8, (w, h)));
        assert_eq!(a, field(&x, (100.0, -40.0), 7, (w, h)));
    }

    /// On a share the texture is the whole field times it, pixel by pixel: all of it
    /// at 1, none at 0.
    #[test]
    fn on_a_share_the_texture_is_the_field_times_it() {
        let (w, h) = (40u32, 24u32);
        let share: Vec<f32> = (0..w * h)
            .map(|i| [0.0, 1.0, 0.25][(i % 3) as usize])
            .collect();
        for x in [Texture::default(), texture(3.0, 0.5)] {
            let whole = field(&x, (3.0, 5.0), 9, (w, h));
            let mut plane = vec![7.0f32; (w * h) as usize];
            let anchor = Anchor {
                seed: 9,
                origin: (3.0, 5.0),
            };
            add_on(&x, 1.0, anchor, (w, h), &share, &mut plane);
            for ((p, f), s) in plane.iter().zip(&whole).zip(&share) {
                assert_eq!(*p, 7.0 + f * s, "sharpness {}", x.sharpness);
            }
            assert!(whole.iter().any(|&f| f.abs() > 0.5));
        }
    }

    #[test]
    fn no_rms_leaves_the_plane_as_it_was() {
        let mut plane: Vec<f32> = (0..96).map(|i| i as f32 * 0.25).collect();
        let before = plane.clone();
        let x = Texture {
            rms_k: 0.0,
            ..Texture::default()
        };
        let anchor = Anchor {
            seed: 1,
            origin: (0.0, 0.0),
        };
        add(&x, 0.7, anchor, (12, 8), &mut plane);
        assert_eq!(plane, before);
    }
}

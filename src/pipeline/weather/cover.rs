//! The weather's particles as the composite draws them: each one's
//! constants solved once ([`Prepared`]), the columns a row of it reaches
//! ([`reach`]), how much of a pixel it covers ([`coverage`]), and its
//! factors into a strip's transmittances ([`draw`]).

use std::ops::Range;

use crate::scene::weather::Particle;

use super::depth::DepthLayer;

#[cfg(target_arch = "x86_64")]
mod lanes;

/// A particle as the row loops use it, its constants solved once a frame.
#[derive(Clone, Copy, Debug, Default)]
pub(super) struct Prepared {
    a: [f32; 2],
    /// Its travel b − a, pixels, its squared length and its length.
    d: [f32; 2],
    len2: f32,
    pub(super) len: f32,
    /// 1 / len and 1 / len² (0 for a path shorter than 1e-6 px: a still disc).
    inv_len: f32,
    inv_len2: f32,
    /// 1 / d per axis (0 where |d| < 1e-12), for [`reach`].
    inv_d: [f32; 2],
    r: f32,
    alpha: f32,
    depth_m: f32,
    solid: bool,
    /// Whether a drone's pixel lies in its bounds: only then is the depth tested.
    tested: bool,
    /// Its bounds ([`bounds`]): x0, y0, x1, y1.
    pub(super) bounds: [u32; 4],
    /// A streak's inner rows: those whose centre lies within `inner` below
    /// a (pixels) meet its capsule only in the band across its path (its
    /// ends' discs lie within it there), where a pixel's distance to the
    /// path is `k`·|x − the path's x on the row|: `k` = |dy| / len, the
    /// path's x `slope` = dx / dy pixels to a row, `half` = (r + ½) / k
    /// the band's half-width along the row ([`NONE`]: no such rows).
    inner: (f32, f32),
    slope: f32,
    k: f32,
    half: f32,
}

impl Prepared {
    #[cfg(test)]
    pub(super) fn of(p: &Particle, size: (u32, u32), layer: Option<&DepthLayer>) -> Self {
        Self::within(p, bounds(p, size), layer)
    }

    /// [`Prepared::of`] given the particle's [`bounds`] in the picture.
    pub(super) fn within(
        p: &Particle,
        (x0, y0, x1, y1): (u32, u32, u32, u32),
        layer: Option<&DepthLayer>,
    ) -> Self {
        let r = p.radius_px;
        let d = [p.b[0] - p.a[0], p.b[1] - p.a[1]];
        let len2 = d[0] * d[0] + d[1] * d[1];
        let len = len2.sqrt();
        let mut prepared = Self {
            a: p.a,
            d,
            len2,
            len,
            inv_len: if len2 >= STILL2 { 1.0 / len } else { 0.0 },
            inv_len2: if len2 >= STILL2 { 1.0 / len2 } else { 0.0 },
            inv_d: d.map(|v| if v.abs() < 1e-12 { 0.0 } else { 1.0 / v }),
            r,
            alpha: p.alpha,
            depth_m: p.depth_m,
            solid: p.solid,
            tested: layer.is_some_and(|l| l.any_within((x0, y0, x1, y1))),
            bounds: [x0, y0, x1, y1],
            inner: NONE,
            ..Self::default()
        };
        // Rows y (from a) with e < |y| < |dy| − e, e = (r + ½)·|dx| / len,
        // on dy's side: every point of the band across the path there
        // projects onto the path (not past its ends).
        let rho = r + 0.5;
        let e = rho * d[0].abs() / len;
        if !p.solid && len >= MIN_LEN && d[1].abs() > 2.0 * e + 2.0 * SLACK {
            prepared.inner = (d[1].min(0.0) + e + SLACK, d[1].max(0.0) - e - SLACK);
            prepared.slope = d[0] / d[1];
            prepared.k = d[1].abs() / len;
            prepared.half = rho / prepared.k;
        }
        prepared
    }
}

/// A strip's transmittances, rows `rows` of a `width`-pixel picture (each
/// slice holds exactly them): `all`, the product of every particle's
/// 1 − alpha × coverage at each pixel; `near`, of only the particles
/// nearer than the drone a pixel shows (kept at drones' pixels only).
pub(super) struct Transmit<'a> {
    pub(super) all: &'a mut [f32],
    pub(super) near: &'a mut [f32],
    pub(super) width: u32,
    pub(super) rows: Range<u32>,
    /// Whether particles not tested for depth are drawn eight columns at
    /// once (the same factors): only where the CPU has AVX2 ([`lanes_here`]).
    pub(super) lanes: bool,
}

/// Whether this CPU draws in lanes (AVX2; `simd::simd_level`,
/// which `SWARMSHOT_SIMD=base` caps).
pub(super) fn lanes_here() -> bool {
    #[cfg(target_arch = "x86_64")]
    return crate::simd::simd_level() >= 1;
    #[cfg(not(target_arch = "x86_64"))]
    false
}

/// One particle into `t`: in each of its rows, only the columns it can
/// reach, each pixel's transmittances times 1 − alpha × coverage (`near`
/// only where `layer` holds a drone farther than the particle). An inner
/// row of a streak ([`Prepared::inner`]) by its distance across the path,
/// a linear function of the column; any other row by [`reach`] and
/// [`coverage`]: the same coverage (up to f32's rounding).
#[inline]
pub(super) fn draw(t: &mut Transmit, p: &Prepared, layer: Option<&DepthLayer>) {
    let layer = layer.filter(|_| p.tested);
    #[cfg(target_arch = "x86_64")]
    if t.lanes && layer.is_none() {
        // SAFETY: `lanes` is set only where the CPU has AVX2 ([`lanes_here`]).
        #[allow(unsafe_code)]
        unsafe {
            lanes::draw_avx2(t, p)
        };
        return;
    }
    let [x0, y0, x1, y1] = p.bounds;
    let width = t.width as usize;
    for y in y0.max(t.rows.start)..y1.min(t.rows.end) {
        let row = (y - t.rows.start) as usize * width;
        let all = &mut t.all[row..row + width];
        let near = &mut t.near[row..row + width];
        let mut put = |x: u32, cover: f32| {
            if cover <= 0.0 {
                return;
            }
            let f = 1.0 - p.alpha * cover;
            all[x as usize] *= f;
            if let Some(l) = layer {
                let d = l.depth(x, y);
                if d > p.depth_m && d < f32::INFINITY {
                    near[x as usize] *= f;
                }
            }
        };
        let py = y as f32 + 0.5;
        let from_a = py - p.a[1];
        if p.inner.0 < from_a && from_a < p.inner.1 {
            let across = from_a * p.slope;
            let span = (across - p.half - SLACK, across + p.half + SLACK);
            let (xs, xe) = columns(span, p.a[0], (x0, x1));
            let centre = p.a[0] + across;
            for x in xs..xe {
                let off = (x as f32 + 0.5 - centre).abs();
                put(x, (p.r + 0.5 - p.k * off).min(1.0));
            }
        } else {
            let (xs, xe) = reach(p, py, (x0, x1));
            for x in xs..xe {
                put(x, coverage(p, (x as f32 + 0.5, py)));
            }
        }
    }
}

/// The pixels particle `p` may cover, within the `w × h` picture (x0, y0,
/// x1, y1): those whose centres lie within its reach ([`margin`]) of its
/// path's box, past which every [`coverage`] is 0 (the same pixels
/// multiplied, by the same factors, as over any larger box).
#[inline]
pub(super) fn bounds(p: &Particle, (w, h): (u32, u32)) -> (u32, u32, u32, u32) {
    let m = margin(p);
    let (ax, ay, bx, by) = (p.a[0], p.a[1], p.b[0], p.b[1]);
    // Pixel x's centre x + ½ above lo: x ≥ ⌊lo + ½⌋; below hi: x < ⌈hi − ½⌉.
    (
        floor_within(ax.min(bx) - m + 0.5, w),
        floor_within(ay.min(by) - m + 0.5, h),
        ceil_within(ax.max(bx) + m - 0.5, w),
        ceil_within(ay.max(by) + m - 0.5, h),
    )
}

/// How far past its path's box, along either axis, a pixel centre can lie
/// under `p`, plus [`SLACK`]. A streak (or a still disc): within r + ½ of
/// its path. A flake: within r + ½ across its path and, past its ends,
/// within its disc of r or, where the disc is under half a pixel deep, ½
/// along and under r + ½ across: √(¼ + (r + ½)²) from an end at most.
#[inline]
fn margin(p: &Particle) -> f32 {
    let rho = p.radius_px + 0.5;
    let reach = if p.solid {
        (0.25 + rho * rho).sqrt()
    } else {
        rho
    };
    reach + SLACK
}

/// The columns of `x0..x1` whose pixel centres on the row at `py` can lie
/// under particle `p` (a superset: [`coverage`] is 0 elsewhere, and only
/// by [`SLACK`] wider than where it is not). A streak's coverage is above 0
/// strictly within r + ½ of its path (a capsule); a flake's within r + ½
/// across its path and ½ beyond its ends (a rectangle) or within r of its
/// path (the disc's own capsule). Each shape meets the row in an interval,
/// the hull of its parts': a disc about each end and the band across the
/// path between them.
#[inline]
pub(super) fn reach(p: &Prepared, py: f32, (x0, x1): (u32, u32)) -> (u32, u32) {
    if p.len < MIN_LEN {
        // Still (or nearly): a disc of r + ½ (or the bounds).
        let span = if p.len2 <= 0.0 {
            disc(p.r + 0.5 + SLACK, (0.0, py - p.a[1]))
        } else {
            (f32::NEG_INFINITY, f32::INFINITY)
        };
        return columns(span, p.a[0], (x0, x1));
    }
    let y = py - p.a[1];
    let span = if p.solid {
        hull(
            capsule(p, p.r + SLACK, y),
            slab(p, p.r + 0.5 + SLACK, 0.5 + SLACK, y),
        )
    } else {
        capsule(p, p.r + 0.5 + SLACK, y)
    };
    columns(span, p.a[0], (x0, x1))
}

/// Squared lengths below this (paths under 1e-6 px) are covered as a still disc.
const STILL2: f32 = 1e-12;

/// Paths shorter than this, pixels, are drawn over their bounds' columns.
const MIN_LEN: f32 = 1e-2;

/// Pixels of slack in [`reach`]: far above f32's rounding there.
const SLACK: f32 = 0.05;

/// An empty interval.
const NONE: (f32, f32) = (f32::INFINITY, f32::NEG_INFINITY);

/// The smallest interval holding both.
#[inline]
fn hull(a: (f32, f32), b: (f32, f32)) -> (f32, f32) {
    (a.0.min(b.0), a.1.max(b.1))
}

/// Where the row `y` pixels below the path's start meets the capsule of
/// radius `rho` about `p`'s path, in pixels right of the start.
#[inline]
fn capsule(p: &Prepared, rho: f32, y: f32) -> (f32, f32) {
    let [dx, dy] = p.d;
    let ends = hull(disc(rho, (0.0, y)), disc(rho, (dx, y - dy)));
    hull(ends, slab(p, rho, 0.0, y))
}

/// Where the row `y` below the centre `(cx, ·)` of a disc of radius `rho`
/// (`(cx, y)`: the row's offset from the centre) meets it.
#[inline]
fn disc(rho: f32, (cx, y): (f32, f32)) -> (f32, f32) {
    if y.abs() >= rho {
        return NONE;
    }
    let half = (rho * rho - y * y).sqrt();
    (cx - half, cx + half)
}

/// Where the row `y` below the path's start meets the points within
/// `across` of `p`'s path's line whose projection lies within `beyond` of
/// the path (pixels), in pixels right of the start.
#[inline]
fn slab(p: &Prepared, across: f32, beyond: f32, y: f32) -> (f32, f32) {
    let ([dx, dy], len) = (p.d, p.len);
    // |X·dy − y·dx| < across·len and −beyond·len < X·dx + y·dy < len² + beyond·len.
    let (c, m) = (y * dx, across * len);
    let side = linear(p.inv_d[1], (c - m, c + m));
    let (lo, hi) = (-beyond * len - y * dy, p.len2 + beyond * len - y * dy);
    let along = linear(p.inv_d[0], (lo, hi));
    (side.0.max(along.0), side.1.min(along.1))
}

/// The X where `lo < k·X < hi`, given `inv` = 1 / k: an interval
/// (rounded within far less than [`SLACK`]), everything or nothing (k = 0:
/// `inv` 0).
#[inline]
fn linear(inv: f32, (lo, hi): (f32, f32)) -> (f32, f32) {
    if inv == 0.0 {
        return if lo < 0.0 && 0.0 < hi {
            (f32::NEG_INFINITY, f32::INFINITY)
        } else {
            NONE
        };
    }
    let (u, v) = (lo * inv, hi * inv);
    (u.min(v), u.max(v))
}

/// The columns of `x0..x1` whose centres lie in the interval `(lo, hi)`
/// pixels right of `ax` (rounded out).
#[inline]
fn columns((lo, hi): (f32, f32), ax: f32, (x0, x1): (u32, u32)) -> (u32, u32) {
    if lo >= hi || lo.is_nan() || hi.is_nan() {
        return (x0, x0);
    }
    let first = floor_within(ax + lo - 0.5, x1);
    let end = floor_within(ax + hi - 0.5, x1).saturating_add(1);
    (first.max(x0), end.clamp(x0, x1))
}

/// `v.floor()` clamped to 0..=`max`, without a library call.
#[inline]
fn floor_within(v: f32, max: u32) -> u32 {
    if v.is_nan() || v <= 0.0 {
        return 0;
    }
    (v as u32).min(max)
}

/// `v.ceil()` clamped to 0..=`max`, without a library call.
#[inline]
fn ceil_within(v: f32, max: u32) -> u32 {
    if v.is_nan() || v <= 0.0 {
        return 0;
    }
    let i = v as u32;
    (i + u32::from(i as f32 != v && i < u32::MAX)).min(max)
}

/// How much of the pixel centred at `(px, py)` particle `p` covers, 0–1.
/// A streak: by the distance to its path (a capsule with a half-pixel soft
/// edge). A flake: the share of the exposure its disc is over the pixel,
/// the disc's centre moving uniformly from a to b, times the same soft
/// edge across.
#[inline]
pub(super) fn coverage(p: &Prepared, (px, py): (f32, f32)) -> f32 {
    let (r, len) = (p.r, p.len);
    let ([ax, ay], [dx, dy]) = (p.a, p.d);
    if p.inv_len2 == 0.0 {
        let (ex, ey) = (px - ax, py - ay);
        return (r + 0.5 - (ex * ex + ey * ey).sqrt()).clamp(0.0, 1.0);
    }
    // Along the path (pixels from a) and across it.
    let along = (px - ax) * dx + (py - ay) * dy;
    if p.solid {
        let s = along * p.inv_len;
        let e = ((px - ax) * dy - (py - ay) * dx).abs() * p.inv_len;
        let edge = (r + 0.5 - e).clamp(0.0, 1.0);
        let h = (r * r - e * e).max(0.0).sqrt().max(0.5);
        let time = ((s + h).min(len) - (s - h).max(0.0)).max(0.0) * p.inv_len;
        return edge * time.min(1.0);
    }
    let t = (along * p.inv_len2).clamp(0.0, 1.0);
    let (ex, ey) = (px - ax - t * dx, py - ay - t * dy);
    (r + 0.5 - (ex * ex + ey * ey).sqrt()).clamp(0.0, 1.0)
}

#[cfg(test)]
mod tests {
    use rand::{Rng, SeedableRng};
    use rand_chacha::ChaCha8Rng;

    use super::*;

    /// Particles of every shape: still, nearly still, along each axis and
    /// slanted, thin and wide, streaks and flakes, some off the picture's edges.
    fn particles(n: usize) -> Vec<Particle> {
        let mut rng = ChaCha8Rng::seed_from_u64(41);
        (0..n)
            .map(|i| {
                let a = [
                    rng.random_range(-8.0f32..72.0),
                    rng.random_range(-8.0..72.0),
                ];
                let len = match i % 6 {
                    0 => 0.0,
                    1 => rng.random_range(0.0..0.02),
                    2 => rng.random_range(0.0..2.0),
                    _ => rng.random_range(0.0..40.0),
                };
                let angle: f32 = match i % 5 {
                    0 => 0.0,
                    1 => std::f32::consts::FRAC_PI_2,
                    _ => rng.random_range(0.0..std::f32::consts::TAU),
                };
                Particle {
                    a,
                    b: [a[0] + len * angle.cos(), a[1] + len * angle.sin()],
                    radius_px: 0.5 + rng.random_range(0.0f32..4.0) * f32::from(i % 3 == 0),
                    alpha: 0.5,
                    depth_m: 1.0,
                    solid: i % 2 == 0,
                }
            })
            .collect()
    }

    /// Over the whole picture: the pixels a particle's coverage reaches
    /// that [`reach`] on the rows of its [`bounds`] leaves out (so any
    /// outside its bounds), the pixels it evaluates, and those covered.
    fn reached_and_covered(p: &Particle, size: (u32, u32)) -> (usize, usize, usize) {
        let q = Prepared::of(p, size, None);
        let [x0, y0, x1, y1] = q.bounds;
        let (mut missed, mut evaluated, mut covered) = (0, 0, 0);
        for y in 0..size.1 {
            let py = y as f32 + 0.5;
            let (xs, xe) = if (y0..y1).contains(&y) {
                reach(&q, py, (x0, x1))
            } else {
                (0, 0)
            };
            evaluated += xe.saturating_sub(xs) as usize;
            for x in 0..size.0 {
                if coverage(&q, (x as f32 + 0.5, py)) > 0.0 {
                    covered += 1;
                    missed += usize::from(x < xs || x >= xe);
                }
            }
        }
        (missed, evaluated, covered)
    }

    #[test]
    fn bounds_and_reach_hold_every_pixel_a_particle_covers() {
        for p in particles(4000) {
            let (missed, _, _) = reached_and_covered(&p, (64, 64));
            assert_eq!(missed, 0, "{p:?}");
        }
    }

    #[test]
    fn reach_evaluates_few_pixels_a_particle_does_not_cover() {
        // Moving particles (longer than MIN_LEN): at most the rounding's
        // column at each end of a row beyond what they cover.
        let (mut evaluated, mut covered, mut rows) = (0, 0, 0);
        for p in particles(4000) {
            let Prepared { len, bounds, .. } = Prepared::of(&p, (64, 64), None);
            let (_, e, c) = reached_and_covered(&p, (64, 64));
            if len >= MIN_LEN {
                let r = (bounds[3] - bounds[1]) as usize;
                (evaluated, covered, rows) = (evaluated + e, covered + c, rows + r);
            }
        }
        assert!(covered > 10_000, "{covered}");
        assert!(
            evaluated <= covered + rows,
            "{evaluated} > {covered} + {rows}"
        );
    }

    /// `all` and `near` of a `w × h` picture under `q` alone.
    fn drawn_alone(
        q: &Prepared,
        layer: Option<&DepthLayer>,
        size: (u32, u32),
    ) -> (Vec<f32>, Vec<f32>) {
        drawn(std::slice::from_ref(q), layer, size, false)
    }

    /// `all` and `near` of a `w × h` picture under `qs` in turn, in lanes or not.
    fn drawn(
        qs: &[Prepared],
        layer: Option<&DepthLayer>,
        (w, h): (u32, u32),
        lanes: bool,
    ) -> (Vec<f32>, Vec<f32>) {
        let (mut all, mut near) = (
            vec![1.0f32; (w * h) as usize],
            vec![1.0f32; (w * h) as usize],
        );
        let mut t = Transmit {
            all: &mut all,
            near: &mut near,
            width: w,
            rows: 0..h,
            lanes,
        };
        for q in qs {
            draw(&mut t, q, layer);
        }
        (all, near)
    }

    #[test]
    fn draw_gives_each_pixel_its_capsule_coverage() {
        // Each particle alone into a 64×64 picture's transmittance: every
        // pixel's factor 1 − alpha × the capsule's coverage there, inner
        // rows (found on most streaks) included, within f32's rounding.
        let (w, h) = (64u32, 64u32);
        let (mut inner_rows, mut worst) = (0, 0.0f32);
        for p in particles(3000) {
            let q = Prepared::of(&p, (w, h), None);
            let (all, _) = drawn_alone(&q, None, (w, h));
            for y in 0..h {
                let py = y as f32 + 0.5;
                inner_rows += usize::from(q.inner.0 < py - q.a[1] && py - q.a[1] < q.inner.1);
                for x in 0..w {
                    let want = 1.0 - q.alpha * coverage(&q, (x as f32 + 0.5, py));
                    worst = worst.max((all[(y * w + x) as usize] - want).abs());
                }
            }
        }
        assert!(worst < 1e-5, "{worst}");
        assert!(inner_rows > 5_000, "{inner_rows}");
    }

    #[test]
    fn lanes_give_the_scalar_factors_bit_for_bit() {
        // Every shape (narrow over its bounds, wide by its rows' intervals,
        // inner rows, still discs), some past the last row's end (the
        // tail), each drawn alone and all together, in lanes and a pixel at
        // a time: the same bits.
        if !lanes_here() {
            return;
        }
        let (w, h) = (64u32, 64u32);
        let bits = |lanes: bool, qs: &[Prepared]| {
            let (all, _) = drawn(qs, None, (w, h), lanes);
            all.iter().map(|v| v.to_bits()).collect::<Vec<u32>>()
        };
        let qs: Vec<Prepared> = (particles(3000).iter())
            .map(|p| Prepared::of(p, (w, h), None))
            .collect();
        let wide = qs.iter().filter(|q| q.bounds[2] - q.bounds[0] > 16).count();
        assert!(wide > 300, "{wide}");
        for q in qs.iter().take(500) {
            let one = std::slice::from_ref(q);
            assert_eq!(bits(true, one), bits(false, one), "{q:?}");
        }
        let (lanes, scalar) = (bits(true, &qs), bits(false, &qs));
        assert!(lanes == scalar && lanes.iter().any(|&b| b != 1.0f32.to_bits()));
    }

    #[test]
    fn near_holds_only_particles_nearer_than_the_drone() {
        // A drone at 5 m over the picture's left half: a particle at 2 m
        // dims `near` there as `all`; one at 8 m dims `all` alone.
        let (w, h) = (64u32, 32u32);
        let hits: Vec<_> = (0..h).flat_map(|y| (0..32).map(move |x| (x, y))).collect();
        let layer = DepthLayer::from_depths((w, h), &hits, 5.0);
        for (depth, dims_near) in [(2.0, true), (8.0, false)] {
            let p = Particle {
                a: [20.0, 4.0],
                b: [24.0, 28.0],
                radius_px: 0.5,
                alpha: 0.5,
                depth_m: depth,
                solid: false,
            };
            let q = Prepared::of(&p, (w, h), Some(&layer));
            let (all, near) = drawn_alone(&q, Some(&layer), (w, h));
            assert!(all.iter().any(|&v| v < 1.0));
            assert_eq!(all == near, dims_near, "at {depth} m");
        }
    }
}

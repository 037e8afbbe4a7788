//! Near-field scenery (issue 22 item 2): the frame's clutter primitives
//! (`scene::clutter`) rasterised on the CPU into a layer that holds, per
//! pixel, the scenery's colour, the bit mask of the MSAA samples it covers
//! (the standard sample positions) and its depth; and the GPU side that uses
//! it ([`gpu`], `shaders/clutter.wgsl`).
//!
//! The layer is made once per distinct (scenery, camera, light, size,
//! samples) and serves twice: composited into the cached background on the
//! CPU (a sample is the scenery's or the sky's; the pixel is their mean, as
//! the MSAA resolve computes it), and drawn over each region pass after the
//! drones with its sample mask and depth, id 0, so the id samples the
//! visibility tally reads lose exactly the drone samples the scenery hides.
//! A frame without clutter never builds any of it.

mod gpu;

use glam::{DVec2, DVec3};

pub(crate) use self::gpu::shader_source;
pub(super) use self::gpu::{SceneryDraw, SceneryGpu, prepare};
use super::{FrameUniforms, linear_to_srgb};
use crate::scene::FrameScene;
use crate::scene::camera::Camera;
use crate::scene::clutter::{Primitive, Shape};

/// Sample positions within a pixel: Vulkan's and D3D's standard 4× pattern,
/// or the pixel centre.
pub fn sample_offsets(samples: u32) -> &'static [(f64, f64)] {
    if samples > 1 {
        &[
            (0.375, 0.125),
            (0.875, 0.375),
            (0.125, 0.625),
            (0.625, 0.875),
        ]
    } else {
        &[(0.5, 0.5)]
    }
}

/// The rasterised scenery of one frame.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct ClutterLayer {
    pub width: u32,
    pub height: u32,
    pub samples: u32,
    /// Per pixel (row-major): sRGB-encoded colour, alpha = the mask of the samples covered.
    pub color: Vec<[u8; 4]>,
    /// Per pixel: reversed-Z depth (near / z) of the nearest shape there; 0: none.
    pub depth: Vec<f32>,
    /// The shapes covered the frame more than [`MAX_OVERDRAW`] times over and the rest were left out.
    pub truncated: bool,
    /// Where shapes touched the layer. Only there is it cleared for the
    /// next raster and composited: the scenery covers a small part of most
    /// frames.
    touched: Touched,
}

/// Per row, the runs of columns a raster touched: a bit per chunk of the
/// row (at most 64 chunks across it, 32 columns at 1920), so that clearing and
/// compositing skip the gaps between shapes (trees apart, a wire crossing
/// the frame), not only the columns left and right of all of them.
#[derive(Clone, Debug, Default, PartialEq)]
struct Touched {
    /// Columns a chunk: 2 to this power, the least that takes the row in
    /// 64 chunks (a shift a row, not a division).
    shift: u32,
    rows: Vec<u64>,
}

impl Touched {
    fn new(width: u32, height: u32) -> Self {
        Self {
            shift: (width as usize)
                .div_ceil(64)
                .max(1)
                .next_power_of_two()
                .trailing_zeros(),
            rows: vec![0; height as usize],
        }
    }

    /// Columns `[start, end)` of row `y` touched (`start < end ≤ width`).
    #[inline(always)]
    fn mark(&mut self, y: u32, start: usize, end: usize) {
        let (first, last) = (start >> self.shift, (end - 1) >> self.shift);
        // last < 64: end ≤ width ≤ 64 chunks.
        self.rows[y as usize] |= (u64::MAX >> (63 - last)) & (u64::MAX << first);
    }

    /// Row `y`'s touched runs of columns `[a, b)`, within `width`.
    fn runs(&self, y: usize, width: usize) -> impl Iterator<Item = (usize, usize)> + use<> {
        let (mut bits, shift) = (self.rows[y], self.shift);
        std::iter::from_fn(move || {
            if bits == 0 {
                return None;
            }
            let first = bits.trailing_zeros() as usize;
            let end = first + (bits >> first).trailing_ones() as usize;
            bits &= u64::MAX.checked_shl(end as u32).unwrap_or(0);
            Some((first << shift, (end << shift).min(width)))
        })
    }
}

/// How many rows ahead of the one it paints a shape's raster prefetches
/// ([`ClutterLayer::prefetch`]).
const PREFETCH_ROWS: usize = 3;

/// The most sample writes a layer makes, in frames' worth of samples.
pub const MAX_OVERDRAW: u64 = 64;

impl ClutterLayer {
    /// Empty for a `width`×`height` frame of `samples`: only the columns
    /// the last raster touched are cleared when the size is the same.
    fn reset(&mut self, width: u32, height: u32, samples: u32) {
        let pixels = (width * height) as usize;
        let reused = (self.width, self.height) == (width, height)
            && self.color.len() == pixels
            && self.depth.len() == pixels
            && self.touched.rows.len() == height as usize;
        if reused {
            // Outside the rows' touched runs the layer is still empty.
            let w = width as usize;
            for y in 0..height as usize {
                for (a, b) in self.touched.runs(y, w) {
                    self.color[y * w + a..y * w + b].fill([0; 4]);
                    self.depth[y * w + a..y * w + b].fill(0.0);
                }
                self.touched.rows[y] = 0;
            }
        } else {
            self.color.clear();
            self.color.resize(pixels, [0; 4]);
            self.depth.clear();
            self.depth.resize(pixels, 0.0);
            self.touched = Touched::new(width, height);
        }
        self.width = width;
        self.height = height;
        self.samples = samples;
        self.truncated = false;
    }

    /// Paint one shape of `depth` and colour `rgb` on row `y`, where its
    /// samples' `spans` (columns `[start, end)`, sample bit) cover: each
    /// pixel once, with the mask of the samples covering it.
    #[inline(always)]
    fn paint_row(&mut self, y: u32, spans: &[(usize, usize, u8)], depth: f32, rgb: &[u8; 3]) {
        // One pass: the union [start, end), the run [inner_a, inner_b) every
        // span covers, and the mask of all the row's samples.
        let (mut start, mut end, mut inner_a, mut inner_b, mut all) =
            (usize::MAX, 0usize, 0usize, usize::MAX, 0u8);
        for &(a, b, bit) in spans {
            start = start.min(a);
            end = end.max(b);
            inner_a = inner_a.max(a);
            inner_b = inner_b.min(b);
            all |= bit;
        }
        if spans.is_empty() {
            return;
        }
        self.touched.mark(y, start, end);
        let row = (y * self.width) as usize;
        let colors = &mut self.color[row + start..row + end];
        let depths = &mut self.depth[row + start..row + end];
        // Where every sample's span covers, the whole mask; elsewhere each pixel's own.
        let inner_b = inner_b.max(inner_a);
        let (a, b) = (inner_a.min(end) - start, inner_b.min(end) - start);
        // The edges, each pixel with the samples whose spans cover it.
        for i in (0..a).chain(b..colors.len()) {
            let x = start + i;
            let mut bits = 0u8;
            for &(s0, s1, bit) in spans {
                if s0 <= x && x < s1 {
                    bits |= bit;
                }
            }
            if bits != 0 {
                paint(&mut colors[i], &mut depths[i], bits, depth, rgb);
            }
        }
        paint_run(&mut colors[a..b], &mut depths[a..b], all, depth, rgb);
    }

    /// Ask for pixel (`x`, `y`)'s colour and depth (`x` clamped to the
    /// row) to be brought into the cache: a shape's rows lie a frame's
    /// width apart, a stride the CPU's own prefetchers do not follow.
    #[inline(always)]
    fn prefetch(&self, y: u32, x: f64) {
        #[cfg(target_arch = "x86_64")]
        {
            use std::arch::x86_64::{_MM_HINT_T0, _mm_prefetch};
            let x = x.max(0.0).min(f64::from(self.width.max(1) - 1)) as usize;
            let at = (y * self.width) as usize + x;
            // SAFETY: a prefetch never faults (the address may pass the end).
            #[allow(unsafe_code)]
            unsafe {
                _mm_prefetch::<_MM_HINT_T0>(self.color.as_ptr().wrapping_add(at).cast());
                _mm_prefetch::<_MM_HINT_T0>(self.depth.as_ptr().wrapping_add(at).cast());
            }
        }
        let _ = (y, x);
    }

    /// The mask of the samples of pixel (x, y) the scenery covers.
    pub fn mask(&self, x: u32, y: u32) -> u8 {
        self.color[(y * self.width + x) as usize][3]
    }

    /// Pixels with at least one sample covered.
    pub fn covered_pixels(&self) -> usize {
        self.color.iter().filter(|c| c[3] != 0).count()
    }
}

/// The light the scenery is shaded with (linear RGB) and the haze's 3.912 / V (0: none).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct SceneryLight {
    pub sun: [f32; 3],
    pub ambient: [f32; 3],
    pub horizon: [f32; 3],
    pub extinction_per_m: f32,
    /// The camera's exposure as a gain on linear light (1 without a camera model).
    pub exposure: f32,
}

impl SceneryLight {
    pub(super) fn from_uniforms(u: &FrameUniforms) -> Self {
        let rgb = |v: [f32; 4], k: f32| [v[0] * k, v[1] * k, v[2] * k];
        let (z, h, g) = (u.zenith, u.horizon, u.ground);
        Self {
            sun: rgb(u.sun_color, 1.0),
            ambient: [0, 1, 2].map(|i| 0.5 * (0.6 * z[i] + 0.4 * h[i]) + 0.5 * g[i]),
            horizon: rgb(h, 1.0),
            extinction_per_m: if u.atmosphere[0] > 0.5 {
                u.atmosphere[1]
            } else {
                0.0
            },
            exposure: u.exposure[0],
        }
    }

    fn color(&self, p: &Primitive, distance_m: f64) -> [u8; 3] {
        let t = (-f64::from(self.extinction_per_m) * distance_m).exp() as f32;
        [0, 1, 2].map(|i| {
            let lit = p.albedo[i] * (p.sun_facing * self.sun[i] + self.ambient[i]);
            let hazed = lit * t + self.horizon[i] * (1.0 - t);
            (linear_to_srgb(hazed * self.exposure) * 255.0).round() as u8
        })
    }
}

/// A shape's projection: the convex polygon in pixels, and the buffers
/// clipping a polygon works in, kept from shape to shape (no allocation a
/// shape).
#[derive(Default)]
struct Projected {
    poly: Vec<DVec2>,
    cam: Vec<DVec3>,
    kept: Vec<DVec3>,
}

/// The shape in pixels into `out.poly` (a convex polygon) and its reversed-Z
/// depth, or `None` when behind the camera.
fn project(camera: &Camera, shape: &Shape, out: &mut Projected) -> Option<f64> {
    let z_min = camera.near_m.max(0.05);
    let f = camera.focal_px();
    let c = camera.principal_point();
    let to_px = |p: DVec3| DVec2::new(f * p.x / p.z + c.x, f * p.y / p.z + c.y);
    match shape {
        Shape::Segment {
            a,
            b,
            radius_a_m,
            radius_b_m,
        } => {
            let (pa, pb) = (
                camera.camera_from_world_point(*a),
                camera.camera_from_world_point(*b),
            );
            if pa.z < z_min && pb.z < z_min {
                return None;
            }
            // Clip an end behind the near distance (and its radius with it).
            let clip = |p: DVec3, q: DVec3, r: f64, rq: f64| {
                if p.z < z_min {
                    let t = (z_min - p.z) / (q.z - p.z);
                    (p.lerp(q, t), r + (rq - r) * t)
                } else {
                    (p, r)
                }
            };
            let (pa, ra) = clip(pa, pb, *radius_a_m, *radius_b_m);
            let (pb, rb) = clip(pb, pa, *radius_b_m, ra);
            let (ua, ub) = (to_px(pa), to_px(pb));
            let (wa, wb) = (f * ra / pa.z, f * rb / pb.z);
            let d = ub - ua;
            let n = if d.length() > 1e-9 {
                DVec2::new(-d.y, d.x) / d.length()
            } else {
                DVec2::X
            };
            out.poly.clear();
            out.poly
                .extend([ua + n * wa, ub + n * wb, ub - n * wb, ua - n * wa]);
            Some(camera.near_m / pa.z.min(pb.z))
        }
        Shape::Polygon(points) => {
            let Projected { poly, cam, kept } = out;
            cam.clear();
            cam.extend(points.iter().map(|p| camera.camera_from_world_point(*p)));
            // Sutherland–Hodgman against z = z_min.
            kept.clear();
            for (i, &p) in cam.iter().enumerate() {
                let q = cam[(i + 1) % cam.len()];
                if p.z >= z_min {
                    kept.push(p);
                }
                if (p.z >= z_min) != (q.z >= z_min) {
                    kept.push(p.lerp(q, (z_min - p.z) / (q.z - p.z)));
                }
            }
            if kept.len() < 3 {
                return None;
            }
            let near_z = kept.iter().map(|p| p.z).fold(f64::INFINITY, f64::min);
            poly.clear();
            poly.extend(kept.iter().map(|&p| to_px(p)));
            Some(camera.near_m / near_z)
        }
    }
}

/// Rasterise `scene`'s clutter for `samples` samples per pixel, shaded with `light`.
pub fn rasterize_with(scene: &FrameScene, samples: u32, light: &SceneryLight) -> ClutterLayer {
    let mut layer = ClutterLayer::default();
    rasterize_into(scene, samples, light, &mut layer);
    layer
}

/// [`rasterize_with`] into `layer`, its buffers reused (a new frame's
/// layer needs no fresh memory).
pub fn rasterize_into(
    scene: &FrameScene,
    samples: u32,
    light: &SceneryLight,
    layer: &mut ClutterLayer,
) {
    let camera = &scene.camera;
    let (width, height) = (camera.width, camera.height);
    layer.reset(width, height, samples);
    let offsets = sample_offsets(samples);
    let Some(clutter) = &scene.clutter else {
        return;
    };
    let shapes = (&clutter.primitives[..], offsets);
    // Compiled for the CPU's widest SIMD (the same values in every build):
    // the span and paint loops vectorise (a fifth less time than the
    // baseline build on `presets/bench/realistic_cluttered.ron`), and the
    // span ends round with SSE4.1's one instruction each, which the
    // baseline build lacks (it would call libm a sample: [`span_ends`]).
    if crate::simd::avx2() {
        crate::simd::widest(
            #[inline(always)]
            || paint_shapes::<true>(camera, light, shapes, layer),
        );
    } else {
        paint_shapes::<false>(camera, light, shapes, layer);
    }
}

/// `primitives` seen by `camera`, lit by `light`, painted into `layer`
/// one after another with the sample `offsets`; `NATIVE`: see [`span_ends`].
#[inline(always)]
fn paint_shapes<const NATIVE: bool>(
    camera: &Camera,
    light: &SceneryLight,
    (primitives, offsets): (&[Primitive], &[(f64, f64)]),
    layer: &mut ClutterLayer,
) {
    let (width, height) = (camera.width, camera.height);
    // Bounded work on any preset: past this much overdraw the remaining
    // (farther-listed) shapes are left out and the layer says so.
    let budget = MAX_OVERDRAW * u64::from(width) * u64::from(height) * offsets.len() as u64;
    let mut written = 0u64;
    let mut edges = Vec::new();
    let mut rows = RowSpans::default();
    let mut projected = Projected::default();
    for p in primitives {
        if written > budget {
            layer.truncated = true;
            break;
        }
        let Some(depth) = project(camera, &p.shape, &mut projected) else {
            continue;
        };
        let poly = &projected.poly;
        let area: f64 = (0..poly.len())
            .map(|i| poly[i].perp_dot(poly[(i + 1) % poly.len()]))
            .sum();
        if area.abs() < 1e-12 || !area.is_finite() {
            continue;
        }
        let (lo, hi) = poly.iter().fold(
            (DVec2::splat(f64::INFINITY), DVec2::splat(f64::NEG_INFINITY)),
            |(lo, hi), p| (lo.min(*p), hi.max(*p)),
        );
        let y0 = lo.y.floor().max(0.0) as u32;
        let y1 = (hi.y.ceil().min(f64::from(height))).max(0.0) as u32;
        if lo.x >= f64::from(width) || hi.x <= 0.0 || y0 >= y1 {
            continue;
        }
        let rgb = light.color(p, camera.near_m / depth);
        let depth = depth as f32;
        // Row by row, each sample row's span of the (convex) polygon: the
        // work is the rows and the pixels covered, not the bounding box.
        // A pixel is painted once with the mask of the samples covering it:
        // the shape's depth and colour are the same for all of them.
        Edge::of(poly, &mut edges);
        rows.find(&edges, offsets, (y0, y1));
        let mut spans = [(0usize, 0usize, 0u8); 4];
        for (k, (lefts, rights)) in rows.left.iter().zip(&rows.right).enumerate() {
            let y = y0 + k as u32;
            if let Some(ahead) = rows.left.get(k + PREFETCH_ROWS) {
                layer.prefetch(y + PREFETCH_ROWS as u32, ahead[0]);
            }
            let mut n = 0;
            for (s, (ox, _)) in offsets.iter().enumerate().take(4) {
                let (left, right) = (lefts[s], rights[s]);
                if left > right {
                    continue;
                }
                let (xa, xb) = span_ends::<NATIVE>(left - ox, right - ox);
                let (xa, xb) = (xa.max(0.0), xb.min(f64::from(width) - 1.0));
                if xa > xb {
                    continue;
                }
                written += (xb - xa) as u64 + 1;
                spans[n] = (xa as usize, xb as usize + 1, 1u8 << s);
                n += 1;
            }
            layer.paint_row(y, &spans[..n], depth, &rgb);
        }
    }
}

/// One pixel of a shape at `depth` covering the samples `bits`: the
/// coverage grows, and the colour is the shape's where it is nearest.
#[inline(always)]
fn paint(c: &mut [u8; 4], d: &mut f32, bits: u8, depth: f32, rgb: &[u8; 3]) {
    let word = u32::from_le_bytes(*c) | u32::from(bits) << 24;
    let near = depth >= *d;
    let shape = u32::from_le_bytes([rgb[0], rgb[1], rgb[2], 0]) | (word & 0xff00_0000);
    *c = (if near { shape } else { word }).to_le_bytes();
    *d = if near { depth } else { *d };
}

/// [`paint`] over a run of pixels that every sample of the row covers,
/// without branches, so that it vectorises.
#[inline(always)]
fn paint_run(colors: &mut [[u8; 4]], depths: &mut [f32], bits: u8, depth: f32, rgb: &[u8; 3]) {
    for (c, d) in colors.iter_mut().zip(depths.iter_mut()) {
        paint(c, d, bits, depth, rgb);
    }
}

/// A sample row's first and last sample columns before their clamps to
/// the frame: `left.ceil()` and `right.floor()`, by `f64`'s own rounding
/// (`NATIVE`, for builds with SSE4.1's `roundsd`) or by [`ceil`] and
/// [`floor`]. The two differ only past 2⁶³ in magnitude (a shape reaching
/// that far), where the clamps after them leave a span that holds no
/// column either way: the same spans.
#[inline(always)]
fn span_ends<const NATIVE: bool>(left: f64, right: f64) -> (f64, f64) {
    if NATIVE {
        (left.ceil(), right.floor())
    } else {
        (ceil(left), floor(right))
    }
}

/// `v.floor()` for finite `v` (every span end is), without the libm call
/// the baseline x86-64 build makes of it (no SSE4.1 `roundsd`): exact
/// below 2⁶³, which covers every value the clamps after it keep.
#[inline(always)]
fn floor(v: f64) -> f64 {
    let t = v as i64 as f64;
    if t > v { t - 1.0 } else { t }
}

/// `v.ceil()` as [`floor`] does `floor`.
#[inline(always)]
fn ceil(v: f64) -> f64 {
    let t = v as i64 as f64;
    if t < v { t + 1.0 } else { t }
}

/// One edge `(a, b)` of a projected polygon, as the row spans read it.
#[derive(Clone, Copy)]
struct Edge {
    a: DVec2,
    b: DVec2,
    /// Level (|Δy| < 1e-12): the edge spans its ends' x range on its row.
    level: bool,
}

impl Edge {
    /// The edges of `poly` into `out`, the last closing back to the first.
    fn of(poly: &[DVec2], out: &mut Vec<Edge>) {
        out.clear();
        out.extend(
            poly.iter()
                .zip(poly.iter().skip(1).chain(poly.first()))
                .map(|(&a, &b)| Edge {
                    a,
                    b,
                    level: (b.y - a.y).abs() < 1e-12,
                }),
        );
    }
}

/// Where a convex polygon crosses the sample rows of the pixel rows
/// `y0..y1`: per pixel row, each of its four sample rows' (left, right) x,
/// left > right where the polygon misses it (fewer samples leave the
/// other lanes at the row's top, unread). Worked out edge by edge, each
/// over the rows its y range reaches (a row's other edges miss all its
/// sample rows), four sample rows at a time without branches, so that
/// they vectorise: a thin shape's row meets two of its four edges, so
/// about half the divisions a walk of every edge at every row makes.
/// Each crossing is the same expression, and min and max take them in the
/// same edge order, as such a walk: the same bits.
#[derive(Default)]
struct RowSpans {
    left: Vec<[f64; 4]>,
    right: Vec<[f64; 4]>,
}

impl RowSpans {
    #[inline(always)]
    fn find(&mut self, edges: &[Edge], offsets: &[(f64, f64)], (y0, y1): (u32, u32)) {
        let rows = (y1 - y0) as usize;
        self.left.clear();
        self.left.resize(rows, [f64::INFINITY; 4]);
        self.right.clear();
        self.right.resize(rows, [f64::NEG_INFINITY; 4]);
        let mut oy = [0.0; 4];
        for (o, (_, y)) in oy.iter_mut().zip(offsets) {
            *o = *y;
        }
        let clamp = |v: f64| v.max(f64::from(y0)).min(f64::from(y1)) as u32;
        for e in edges {
            // Sample rows y + oy with 0 ≤ oy < 1 within [lo, hi]: pixel rows
            // past floor(lo) − 1 up to floor(hi), with a row to spare.
            let (lo, hi) = (e.a.y.min(e.b.y), e.a.y.max(e.b.y));
            let (first, end) = (clamp(floor(lo) - 1.0), clamp(floor(hi) + 2.0));
            let k = (first - y0) as usize..(end - y0) as usize;
            let (left, right) = (&mut self.left[k.clone()], &mut self.right[k]);
            if e.level {
                let span = (e.a.x.min(e.b.x), e.a.x.max(e.b.x));
                edge_rows(e, (first, oy), (left, right), |_| span);
            } else {
                let (a, b) = (e.a, e.b);
                edge_rows(e, (first, oy), (left, right), |y| {
                    let x = a.x + (y - a.y) / (b.y - a.y) * (b.x - a.x);
                    (x, x)
                });
            }
        }
    }
}

/// Edge `e`'s crossings of the sample rows (pixel row + `oy`) of the pixel
/// rows from `first`, one per entry of `left` and `right`, folded into
/// them: `x(y)` the (left, right) x of sample row y where the edge meets it.
#[inline(always)]
fn edge_rows(
    e: &Edge,
    (first, oy): (u32, [f64; 4]),
    (left, right): (&mut [[f64; 4]], &mut [[f64; 4]]),
    x: impl Fn(f64) -> (f64, f64),
) {
    let (a, b) = (e.a, e.b);
    for ((l, r), y) in left.iter_mut().zip(right.iter_mut()).zip(first..) {
        for s in 0..4 {
            let y = f64::from(y) + oy[s];
            // Both ends on one side: the edge misses the row.
            let crosses = (a.y - y) * (b.y - y) <= 0.0;
            let (xa, xb) = x(y);
            l[s] = if crosses { l[s].min(xa) } else { l[s] };
            r[s] = if crosses { r[s].max(xb) } else { r[s] };
        }
    }
}

/// The coverage of `scene`'s clutter (colours unlit): for tests and tools.
pub fn rasterize(scene: &FrameScene, samples: u32) -> ClutterLayer {
    rasterize_with(scene, samples, &SceneryLight::default())
}

/// Composite `layer` into a frame-sized RGBA8 background: each pixel the
/// mean of its samples, the scenery's where covered and the sky's elsewhere.
pub(super) fn composite(layer: &ClutterLayer, rgba: &mut [u8]) {
    let n = layer.samples.max(1);
    // sum / n rounded half up is (2·sum + n) / 2n in integers (no libm
    // call): a shift where 2n is a power of two (the usual sample counts),
    // not a division a channel; the shift's loop in the CPU's widest SIMD
    // build, where it vectorises (integers: the same bytes in every build).
    if (2 * n).is_power_of_two() {
        let shift = (2 * n).trailing_zeros();
        crate::simd::widest(
            #[inline(always)]
            || composite_with(layer, rgba, n, |x| x >> shift),
        );
    } else {
        composite_with(layer, rgba, n, |x| x / (2 * n));
    }
}

/// [`composite`] with `half_up(2·sum + n)` = (2·sum + n) / 2n.
#[inline(always)]
fn composite_with(layer: &ClutterLayer, rgba: &mut [u8], n: u32, half_up: impl Fn(u32) -> u32) {
    let width = layer.width as usize;
    for (y, (start, end)) in (0..layer.height as usize)
        .flat_map(|y| layer.touched.runs(y, width).map(move |run| (y, run)))
    {
        let (a, b) = (y * width + start, y * width + end);
        let Some(row) = rgba.get_mut(a * 4..b * 4) else {
            continue;
        };
        let (pixels, _) = row.as_chunks_mut::<4>();
        // Each pixel as one word, its channels by shifts and masks (whole
        // words in and out: the loop vectorises without byte moves).
        for (px, c) in pixels.iter_mut().zip(&layer.color[a..b]) {
            let (c, p) = (u32::from_le_bytes(*c), u32::from_le_bytes(*px));
            // No branch for an uncovered pixel (k = 0): (2·n·p + n) / 2n is p.
            let k = (c >> 24).count_ones();
            // At most (2·255·n + n) / 2n: a byte.
            let mean = |shift: u32| {
                let sum = k * (c >> shift & 0xff) + (n - k) * (p >> shift & 0xff);
                half_up(2 * sum + n) << shift
            };
            *px = (mean(0) | mean(8) | mean(16) | (p & 0xff00_0000)).to_le_bytes();
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::clutter::FrameClutter;
    use crate::scene::math::look_at_cv;

    /// An 8×8 camera at the origin looking along +Z with f = 4 px, and one shape.
    fn scene_with(shape: Shape) -> FrameScene {
        let preset = crate::preset::Preset::default();
        let mut scene = crate::scene::build_frame(&preset, 0).expect("frame");
        scene.camera = Camera {
            width: 8,
            height: 8,
            fov_y_deg: 90.0,
            position: DVec3::ZERO,
            camera_from_world: look_at_cv(DVec3::ZERO, DVec3::Z).expect("look-at"),
            near_m: 0.01,
        };
        scene.clutter = Some(FrameClutter::from_primitives(vec![Primitive {
            shape,
            albedo: [0.5; 3],
            sun_facing: 0.0,
        }]));
        scene
    }

    /// The span ends rounded by `f64` and by the baseline build's
    /// emulation paint the same layer, on shapes thin and wide, on integer
    /// and sample rows, and reaching past 2⁶³ pixels.
    #[test]
    fn both_roundings_of_the_span_ends_paint_the_same_layer() {
        use rand::{Rng, SeedableRng};
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(17);
        let mut scene = scene_with(Shape::Polygon(Vec::new()));
        scene.camera.width = 48;
        scene.camera.height = 40;
        let mut shapes = Vec::new();
        for case in 0..400 {
            let reach = [0.5, 3.0, 1e4, 1e19][case % 4];
            let mut point = || {
                let mut c = || rng.random_range(-reach..reach);
                DVec3::new(c(), c(), rng.random_range(0.5..4.0))
            };
            let shape = if case % 3 == 0 {
                Shape::Segment {
                    a: point(),
                    b: point(),
                    radius_a_m: rng.random_range(0.001..0.3),
                    radius_b_m: rng.random_range(0.001..0.3),
                }
            } else {
                Shape::Polygon((0..3 + case % 2).map(|_| point()).collect())
            };
            shapes.push(Primitive {
                shape,
                albedo: [rng.random_range(0.0..1.0); 3],
                sun_facing: 0.5,
            });
        }
        let light = SceneryLight::default();
        let mut painted = 0;
        for samples in [1, 4] {
            let offsets = sample_offsets(samples);
            // Each shape alone: none hides another's edges.
            for shape in shapes.chunks(1) {
                let (mut native, mut emulated) = (ClutterLayer::default(), ClutterLayer::default());
                native.reset(48, 40, samples);
                emulated.reset(48, 40, samples);
                let camera = &scene.camera;
                paint_shapes::<true>(camera, &light, (shape, offsets), &mut native);
                paint_shapes::<false>(camera, &light, (shape, offsets), &mut emulated);
                painted += usize::from(native.covered_pixels() > 0);
                assert!(
                    native == emulated,
                    "{samples} samples, {:?}",
                    shape[0].shape
                );
            }
        }
        assert!(painted > 200, "{painted} shapes painted");
    }

    /// Every edge at every sample row, in edge order: the walk
    /// [`RowSpans::find`] replaced (commit 9000fe7), the reference.
    fn row_spans_reference(edges: &[Edge], ys: &[f64; 4]) -> ([f64; 4], [f64; 4]) {
        let (mut left, mut right) = ([f64::INFINITY; 4], [f64::NEG_INFINITY; 4]);
        for e in edges {
            let (a, b) = (e.a, e.b);
            for s in 0..4 {
                let y = ys[s];
                let crosses = (a.y - y) * (b.y - y) <= 0.0;
                let (xa, xb) = if e.level {
                    (a.x.min(b.x), a.x.max(b.x))
                } else {
                    let x = a.x + (y - a.y) / (b.y - a.y) * (b.x - a.x);
                    (x, x)
                };
                left[s] = if crosses { left[s].min(xa) } else { left[s] };
                right[s] = if crosses { right[s].max(xb) } else { right[s] };
            }
        }
        (left, right)
    }

    #[test]
    fn row_spans_found_edge_by_edge_are_the_bits_of_every_edge_at_every_row() {
        use rand::{Rng, SeedableRng};
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(9);
        let mut rows = RowSpans::default();
        let mut edges = Vec::new();
        let mut met = 0;
        for case in 0..3000 {
            // Triangles and quads: thin, level-edged, on integer or
            // sample rows, or reaching far past the rows.
            let scale = [3.0, 40.0, 1e7][case % 3];
            let mut coordinate = |centre: f64| {
                let v: f64 = centre + rng.random_range(-scale..scale);
                if rng.random_bool(0.3) {
                    v.round() + 0.125
                } else {
                    v
                }
            };
            let mut poly: Vec<DVec2> = (0..3 + case % 2)
                .map(|_| DVec2::new(coordinate(0.0), coordinate(20.0)))
                .collect();
            if case % 5 == 0 {
                poly[1].y = poly[0].y;
            }
            let (y0, y1) = (rng.random_range(0..30u32), rng.random_range(30..60u32));
            Edge::of(&poly, &mut edges);
            for samples in [1, 4] {
                let offsets = sample_offsets(samples);
                rows.find(&edges, offsets, (y0, y1));
                for (k, y) in (y0..y1).enumerate() {
                    let mut ys = [f64::from(y); 4];
                    for (s, (_, oy)) in offsets.iter().enumerate() {
                        ys[s] += oy;
                    }
                    let (left, right) = row_spans_reference(&edges, &ys);
                    let bits = |v: [f64; 4]| v.map(f64::to_bits);
                    assert_eq!(bits(rows.left[k]), bits(left), "case {case}, row {y}");
                    assert_eq!(bits(rows.right[k]), bits(right), "case {case}, row {y}");
                    met += usize::from(left[0] <= right[0]);
                }
            }
        }
        assert!(met > 10_000, "rows met: {met}");
    }

    #[test]
    fn a_square_covers_exactly_its_pixels_and_samples() {
        // x in [-0.5, 0.5] m at 1 m is u in [2, 6]; y likewise (up in the world, up in the image).
        let square = Shape::Polygon(vec![
            DVec3::new(-0.5, -0.5, 1.0),
            DVec3::new(0.5, -0.5, 1.0),
            DVec3::new(0.5, 0.5, 1.0),
            DVec3::new(-0.5, 0.5, 1.0),
        ]);
        let scene = scene_with(square);
        for samples in [1, 4] {
            let layer = rasterize(&scene, samples);
            let full = if samples == 4 { 0b1111 } else { 1 };
            for y in 0..8 {
                for x in 0..8 {
                    let inside = (2..6).contains(&x) && (2..6).contains(&y);
                    assert_eq!(
                        layer.mask(x, y),
                        if inside { full } else { 0 },
                        "({x}, {y})"
                    );
                }
            }
            assert_eq!(layer.covered_pixels(), 16);
            assert!((layer.depth[(3 * 8 + 3) as usize] - 0.01).abs() < 1e-6);
        }
    }

    #[test]
    fn a_thin_segment_covers_some_samples_and_the_composite_is_their_mean() {
        // A vertical wire 0.1 px wide through u = 4.375: only sample 0 (x + 0.375)
        // of column 4 (world +X is the image's left: u = 4 − 4x).
        let x = -(4.375 - 4.0) / 4.0;
        let wire = Shape::Segment {
            a: DVec3::new(x, -2.0, 1.0),
            b: DVec3::new(x, 2.0, 1.0),
            radius_a_m: 0.0125,
            radius_b_m: 0.0125,
        };
        let layer = rasterize(&scene_with(wire), 4);
        assert!((0..8).all(|y| layer.mask(4, y) == 0b0001));
        assert_eq!(layer.covered_pixels(), 8);
        let mut rgba = vec![200u8; 8 * 8 * 4];
        composite(&layer, &mut rgba);
        let c = layer.color[4][0];
        let expected = ((f32::from(c) + 3.0 * 200.0) / 4.0).round() as u8;
        assert_eq!(rgba[4 * 4], expected);
        assert_eq!(rgba[3 * 4], 200, "an uncovered pixel keeps the sky");
    }

    #[test]
    fn the_composite_is_the_samples_mean_rounded_half_up_for_any_count() {
        let (w, h) = (37u32, 5u32);
        for n in 1..=4u32 {
            let mut layer = ClutterLayer::default();
            layer.reset(w, h, n);
            for (i, c) in layer.color.iter_mut().enumerate() {
                let v = (i * 73 % 256) as u8;
                *c = [v, v.wrapping_mul(3), 255 - v, (i % (1 << n)) as u8];
            }
            layer
                .touched
                .rows
                .fill(u64::MAX >> (64 - w.div_ceil(1 << layer.touched.shift)));
            let sky: Vec<u8> = (0..w * h * 4).map(|i| (i * 29 % 256) as u8).collect();
            let mut rgba = sky.clone();
            composite(&layer, &mut rgba);
            for (i, c) in layer.color.iter().enumerate() {
                let k = c[3].count_ones();
                for ch in 0..4 {
                    let (p, got) = (sky[i * 4 + ch], rgba[i * 4 + ch]);
                    let mean =
                        f64::from(k * u32::from(c[ch]) + (n - k) * u32::from(p)) / f64::from(n);
                    let want = if k == 0 || ch == 3 {
                        p
                    } else {
                        (mean + 0.5).floor() as u8
                    };
                    assert_eq!(got, want, "n {n}, pixel {i}, channel {ch}");
                }
            }
        }
    }

    #[test]
    fn every_simd_build_paints_the_same_layer() {
        use rand::{Rng, SeedableRng};
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(46);
        let mut point = || {
            DVec3::new(
                rng.random_range(-3.0..3.0),
                rng.random_range(-3.0..3.0),
                rng.random_range(-0.5..4.0),
            )
        };
        // Segments and polygons, some crossing the near plane or the frame's edges.
        let mut shapes: Vec<Shape> = (0..150)
            .map(|_| Shape::Segment {
                a: point(),
                b: point(),
                radius_a_m: 0.02,
                radius_b_m: 0.005,
            })
            .collect();
        shapes.extend((0..40).map(|_| Shape::Polygon(vec![point(), point(), point()])));
        let mut scene = scene_with(shapes[0].clone());
        scene.camera.width = 61;
        scene.camera.height = 47;
        let light = SceneryLight {
            sun: [1.0, 0.9, 0.8],
            ambient: [0.3; 3],
            horizon: [0.6; 3],
            extinction_per_m: 0.01,
            exposure: 1.0,
        };
        scene.clutter = Some(FrameClutter::from_primitives(
            (shapes.into_iter().enumerate())
                .map(|(i, shape)| Primitive {
                    shape,
                    albedo: [0.2 + (i % 7) as f32 * 0.1, 0.4, 0.3],
                    sun_facing: (i % 3) as f32 * 0.4,
                })
                .collect(),
        ));
        let primitives = &scene.clutter.as_ref().expect("clutter").primitives;
        for samples in [1, 4] {
            let paint = |build: u8| {
                let mut layer = ClutterLayer::default();
                let (camera, offsets) = (&scene.camera, sample_offsets(samples));
                layer.reset(camera.width, camera.height, samples);
                crate::simd::in_build(
                    build,
                    #[inline(always)]
                    || {
                        // As `rasterize_into` runs each build.
                        let shapes = (&primitives[..], offsets);
                        if build == 0 {
                            paint_shapes::<false>(camera, &light, shapes, &mut layer);
                        } else {
                            paint_shapes::<true>(camera, &light, shapes, &mut layer);
                        }
                    },
                );
                layer
            };
            let base = paint(0);
            assert!(
                base.covered_pixels() > 200,
                "{} pixels",
                base.covered_pixels()
            );
            #[cfg(target_arch = "x86_64")]
            for build in 1..=crate::simd::cpu_simd_level() {
                assert!(paint(build) == base, "build {build}, {samples} samples");
            }
        }
    }

    /// The touched runs are the marked columns' chunks, joined where they
    /// meet, apart where a chunk between them is untouched.
    #[test]
    fn touched_runs_are_the_marked_columns_chunks() {
        let mut t = Touched::new(1920, 2);
        assert_eq!(1 << t.shift, 32);
        t.mark(0, 5, 6); // chunk 0
        t.mark(0, 63, 65); // chunks 1 and 2
        t.mark(0, 100, 101); // chunk 3: joins the run before
        t.mark(0, 1900, 1920); // chunk 59, the last
        t.mark(0, 1800, 1801); // chunk 56: 57 and 58 between stay untouched
        let runs: Vec<_> = t.runs(0, 1920).collect();
        assert_eq!(runs, [(0, 128), (1792, 1824), (1888, 1920)]);
        assert_eq!(t.runs(1, 1920).count(), 0);
        t.mark(1, 0, 1920);
        assert_eq!(t.runs(1, 1920).collect::<Vec<_>>(), [(0, 1920)]);
        // A width that is not a whole number of chunks: the last run stops at it.
        let mut t = Touched::new(100, 1);
        t.mark(0, 98, 100);
        assert_eq!(t.runs(0, 100).collect::<Vec<_>>(), [(98, 100)]);
    }

    /// A layer rasterised after others is the layer rasterised alone: the
    /// last raster's touched runs are cleared, and nothing else was painted.
    #[test]
    fn a_reused_layer_is_the_layer_made_anew() {
        let shapes = [
            // A thin wire across the frame, a square, a segment off to one side.
            Shape::Segment {
                a: DVec3::new(-9.0, -0.5, 2.0),
                b: DVec3::new(9.0, 0.4, 2.0),
                radius_a_m: 0.01,
                radius_b_m: 0.01,
            },
            Shape::Polygon(vec![
                DVec3::new(-0.5, -0.5, 2.0),
                DVec3::new(0.5, -0.5, 2.0),
                DVec3::new(0.5, 0.5, 2.0),
                DVec3::new(-0.5, 0.5, 2.0),
            ]),
            Shape::Segment {
                a: DVec3::new(1.2, -2.0, 2.0),
                b: DVec3::new(1.5, 2.0, 2.0),
                radius_a_m: 0.05,
                radius_b_m: 0.02,
            },
        ];
        let light = SceneryLight::default();
        let mut layer = ClutterLayer::default();
        for (i, shape) in shapes.iter().chain(&shapes).enumerate() {
            let mut scene = scene_with(shape.clone());
            (scene.camera.width, scene.camera.height) = (203, 61);
            rasterize_into(&scene, 4, &light, &mut layer);
            assert!(layer.covered_pixels() > 20, "shape {i}");
            assert!(layer == rasterize_with(&scene, 4, &light), "shape {i}");
        }
    }

    #[test]
    fn overdraw_past_the_budget_is_left_out() {
        let wall = Shape::Polygon(vec![
            DVec3::new(-9.0, -9.0, 1.0),
            DVec3::new(9.0, -9.0, 1.0),
            DVec3::new(9.0, 9.0, 1.0),
            DVec3::new(-9.0, 9.0, 1.0),
        ]);
        let mut scene = scene_with(wall);
        let layer = rasterize(&scene, 4);
        assert!(!layer.truncated);
        assert_eq!(layer.covered_pixels(), 64);
        if let Some(c) = &mut scene.clutter {
            let one = c.primitives[0].clone();
            c.primitives = vec![one; 1000];
        }
        let layer = rasterize(&scene, 4);
        assert!(
            layer.truncated,
            "1000 frame-filling walls exceed {MAX_OVERDRAW}× overdraw"
        );
        assert_eq!(layer.covered_pixels(), 64);
    }
}

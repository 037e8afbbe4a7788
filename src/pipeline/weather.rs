//! Rain and snow over a rendered frame (issue 41 item 4), the pipeline's
//! weather glue: the frame's particles ([`crate::scene::weather`]) blended
//! into its pixels in sRGB, farthest first, each pixel of a particle's
//! capsule towards the particle's level by its alpha × coverage, but only
//! where what the pixel shows is farther than the particle: a drone's pixel
//! (one that differs from the drone-free background) is at the drone's depth
//! (its centre's, along the view axis; the nearest drone whose box holds
//! the pixel), every other pixel (sky, clouds, clutter, plates) is behind
//! every particle. The same particles go over the drone-free background
//! (without a depth test), and a drone's visible pixels are its rendered
//! pixels that still differ from it: a flake nearer than a drone hides the
//! pixels it covers whole, a translucent streak veils them.
//!
//! One pass over the picture in strips of rows on rayon's threads does it
//! all: the particles bucketed by strip (kept from frame to frame), each
//! strip's rows compared with the background, blended, copied into the
//! drone-free frame (a buffer the caller recycles) and blended again there
//! only where they differed; the depth is looked up only for particles
//! whose bounds meet a drone's cells. Through a lens the particles are
//! drawn in the undistorted frame and resampled with it. Under the thermal
//! camera ([`over_radiance`]) the same particles go into its radiance
//! planes instead, at the air's radiance, the drones' depths from the id
//! pass's pixels.

use std::ops::Range;

use rayon::prelude::*;

use crate::annotate::visibility::{PixelHit, Visibility};
use crate::render::{Painted, RenderedFrame, Renderer};
use crate::scene::FrameScene;
use crate::scene::projection::{LabelGeometry, PixelBox, amodal_box};
use crate::scene::weather::Particle;

/// Side of the depth layer's cells, pixels.
const CELL: u32 = 32;

/// What each pixel shows, as a depth: drones' pixels at their depth, all
/// else at infinity. Stored only in the cells drones' boxes meet.
struct DepthLayer {
    cols: u32,
    /// Per cell: its tile in `tiles` (`u32::MAX`: no drone there).
    cell_tile: Vec<u32>,
    tiles: Vec<[f32; (CELL * CELL) as usize]>,
}

impl DepthLayer {
    /// The depths of the drones of `scene` in `frame`: a pixel of a
    /// drone's box (rounded out, one pixel of margin) that differs from
    /// `background` (every pixel of the box without one) is at the depth
    /// of the nearest such drone.
    fn new(
        scene: &FrameScene,
        geometry: &[LabelGeometry],
        frame: &[u8],
        background: Option<&[u8]>,
    ) -> Self {
        let cam = &scene.camera;
        let (w, h) = (cam.width, cam.height);
        let (cols, rows) = (w.div_ceil(CELL), h.div_ceil(CELL));
        let mut layer = Self {
            cols,
            cell_tile: vec![u32::MAX; (cols * rows) as usize],
            tiles: Vec::new(),
        };
        for drone in &scene.drones {
            let Some(b) = geometry
                .get(drone.model)
                .and_then(|g| amodal_box(cam, drone, g))
            else {
                continue;
            };
            let z = cam.camera_from_world_point(drone.position).z as f32;
            let clip = |v: f64, max: u32| v.clamp(0.0, f64::from(max)) as u32;
            let (x0, y0) = (clip(b.x0.floor() - 1.0, w), clip(b.y0.floor() - 1.0, h));
            let (x1, y1) = (clip(b.x1.ceil() + 1.0, w), clip(b.y1.ceil() + 1.0, h));
            for y in y0..y1 {
                for x in x0..x1 {
                    let i = (y * w + x) as usize * 4;
                    let shows = background.is_none_or(|bg| frame[i..i + 3] != bg[i..i + 3]);
                    if shows {
                        let d = layer.depth_mut(x, y);
                        *d = d.min(z);
                    }
                }
            }
        }
        layer
    }

    /// The depths of the drones of `scene` at their id-pass pixels
    /// (`hits`): each pixel at the depth of the nearest drone there.
    fn of_hits(scene: &FrameScene, hits: &[PixelHit]) -> Self {
        let cam = &scene.camera;
        let (cols, rows) = (cam.width.div_ceil(CELL), cam.height.div_ceil(CELL));
        let mut layer = Self {
            cols,
            cell_tile: vec![u32::MAX; (cols * rows) as usize],
            tiles: Vec::new(),
        };
        let depths: Vec<f32> = (scene.drones.iter())
            .map(|d| cam.camera_from_world_point(d.position).z as f32)
            .collect();
        for hit in hits.iter().filter(|h| h.x < cam.width && h.y < cam.height) {
            if let Some(&z) = depths.get(hit.drone as usize) {
                let d = layer.depth_mut(hit.x, hit.y);
                *d = d.min(z);
            }
        }
        layer
    }

    fn depth_mut(&mut self, x: u32, y: u32) -> &mut f32 {
        let cell = ((y / CELL) * self.cols + x / CELL) as usize;
        if self.cell_tile[cell] == u32::MAX {
            self.cell_tile[cell] = self.tiles.len() as u32;
            self.tiles.push([f32::INFINITY; (CELL * CELL) as usize]);
        }
        let tile = &mut self.tiles[self.cell_tile[cell] as usize];
        &mut tile[((y % CELL) * CELL + x % CELL) as usize]
    }

    /// Whether a drone's pixel may lie in columns x0..x1 of rows y0..y1.
    fn any_within(&self, (x0, y0, x1, y1): (u32, u32, u32, u32)) -> bool {
        if self.tiles.is_empty() || x0 >= x1 || y0 >= y1 {
            return false;
        }
        let (c0, c1) = (x0 / CELL, (x1 - 1) / CELL);
        ((y0 / CELL)..=((y1 - 1) / CELL)).any(|row| {
            let cells = (row * self.cols + c0) as usize..=(row * self.cols + c1) as usize;
            (self.cell_tile.get(cells)).is_some_and(|c| c.iter().any(|&t| t != u32::MAX))
        })
    }

    #[inline]
    fn depth(&self, x: u32, y: u32) -> f32 {
        let cell = ((y / CELL) * self.cols + x / CELL) as usize;
        match self.cell_tile.get(cell) {
            Some(&t) if t != u32::MAX => {
                self.tiles[t as usize][((y % CELL) * CELL + x % CELL) as usize]
            }
            _ => f32::INFINITY,
        }
    }
}

/// Rows of the picture blended together: a strip's pixels stay in the
/// cache while its particles are drawn.
const STRIP: u32 = 16;

/// A particle as the row loops use it, its constants solved once a frame
/// (the same values [`coverage`] and [`reach`] computed per pixel before).
#[derive(Clone, Copy, Debug, Default)]
struct Prepared {
    a: [f32; 2],
    /// Its travel b − a, pixels, its squared length and its length.
    d: [f32; 2],
    len2: f32,
    len: f32,
    /// 1 / d per axis (0 where |d| < 1e-12), for [`reach`].
    inv_d: [f32; 2],
    r: f32,
    alpha: f32,
    depth_m: f32,
    level: f32,
    solid: bool,
    /// Whether a drone's pixel lies in its bounds: only then is the depth tested.
    tested: bool,
    /// Its bounds ([`bounds`]): x0, y0, x1, y1.
    bounds: [u32; 4],
}

impl Prepared {
    fn of(p: &Particle, size: (u32, u32), layer: Option<&DepthLayer>) -> Self {
        let r = p.radius_px;
        let (x0, y0, x1, y1) = bounds(p, size);
        let d = [p.b[0] - p.a[0], p.b[1] - p.a[1]];
        let len2 = d[0] * d[0] + d[1] * d[1];
        Self {
            a: p.a,
            d,
            len2,
            len: len2.sqrt(),
            inv_d: d.map(|v| if v.abs() < 1e-12 { 0.0 } else { 1.0 / v }),
            r,
            alpha: p.alpha,
            depth_m: p.depth_m,
            level: f32::from(p.level),
            solid: p.solid,
            tested: layer.is_some_and(|l| l.any_within((x0, y0, x1, y1))),
            bounds: [x0, y0, x1, y1],
        }
    }
}

/// The frame's particles bucketed by strip, kept from frame to frame (no
/// allocation once grown): strip k's are `items[starts[k]..starts[k + 1]]`,
/// farthest first as in the frame.
#[derive(Default)]
struct Strips {
    starts: Vec<u32>,
    fill: Vec<u32>,
    items: Vec<Prepared>,
}

impl Strips {
    /// Each particle of `particles` into the strips its bounds reach.
    fn fill(&mut self, particles: &[Particle], size: (u32, u32), layer: Option<&DepthLayer>) {
        let n = size.1.div_ceil(STRIP) as usize;
        let reached = |p: &Particle| {
            let (_, y0, _, y1) = bounds(p, size);
            (y0 < y1).then(|| (y0 / STRIP) as usize..=((y1 - 1) / STRIP) as usize)
        };
        self.starts.clear();
        self.starts.resize(n + 1, 0);
        for strips in particles.iter().filter_map(reached) {
            for k in strips {
                self.starts[k + 1] += 1;
            }
        }
        for k in 0..n {
            self.starts[k + 1] += self.starts[k];
        }
        self.items.clear();
        self.items
            .resize(self.starts[n] as usize, Prepared::default());
        self.fill.clear();
        self.fill.extend_from_slice(&self.starts[..n]);
        for p in particles {
            let Some(strips) = reached(p) else { continue };
            let prepared = Prepared::of(p, size, layer);
            for k in strips {
                self.items[self.fill[k] as usize] = prepared;
                self.fill[k] += 1;
            }
        }
    }

    fn of(&self, k: usize) -> &[Prepared] {
        let (a, b) = (self.starts[k] as usize, self.starts[k + 1] as usize);
        &self.items[a..b]
    }
}

thread_local! {
    /// Each thread's strips, kept from frame to frame.
    static STRIPS: std::cell::RefCell<Strips> = std::cell::RefCell::default();
}

/// Rows `rows` of a `width`-pixel RGBA8 picture: `rgba` holds exactly them.
struct Band<'a> {
    rgba: &'a mut [u8],
    width: u32,
    rows: Range<u32>,
}

impl<'a> Band<'a> {
    /// Strip `k` ([`STRIP`] rows from row k · STRIP) held by `rgba`.
    fn strip(k: usize, rgba: &'a mut [u8], width: u32) -> Self {
        let first = k as u32 * STRIP;
        let rows = (rgba.len() / (width as usize * 4).max(1)) as u32;
        Self {
            rgba,
            width,
            rows: first..first + rows,
        }
    }
}

/// The drone-free frame under the same particles, made strip by strip with
/// the frame: `clear` (the whole picture, every byte written) from
/// `background` (the drone-free frame).
struct Clear<'a> {
    clear: &'a mut [u8],
    background: &'a [u8],
}

/// Blend `particles` (farthest first) into `rgba` (`w × h`, RGBA8 sRGB),
/// a pixel only where `layer` (none: every pixel) puts what it shows
/// farther than the particle; with `clear`, the drone-free frame under the
/// same particles too: the blended frame where it agrees with `background`,
/// elsewhere (from the first to the last differing pixel of a row) the
/// background with the particles blended over it without a depth test.
/// The picture is cut into strips of [`STRIP`] rows, each with the
/// particles that reach it in their order, the strips shared among the
/// threads: each pixel still sees the particles in the same order, so the
/// bytes do not depend on the threads.
fn composite(
    rgba: &mut [u8],
    (w, h): (u32, u32),
    particles: &[Particle],
    layer: Option<&DepthLayer>,
    clear: Option<Clear>,
) {
    let run = |strips: &mut Strips| {
        strips.fill(particles, (w, h), layer);
        let strips = &*strips;
        let chunk = (STRIP as usize * w as usize * 4).max(1);
        match clear {
            None => rgba
                .par_chunks_mut(chunk)
                .enumerate()
                .for_each(|(k, rgba)| {
                    let mut band = Band::strip(k, rgba, w);
                    for p in strips.of(k) {
                        draw(&mut band, p, None, layer);
                    }
                }),
            Some(Clear { clear, background }) => (rgba.par_chunks_mut(chunk))
                .zip(clear.par_chunks_mut(chunk))
                .zip(background.par_chunks(chunk))
                .enumerate()
                .for_each(|(k, ((rgba, clear), background))| {
                    let mut spans = [(0u32, 0u32); STRIP as usize];
                    differing_spans(rgba, background, w, &mut spans);
                    let mut band = Band::strip(k, rgba, w);
                    for p in strips.of(k) {
                        draw(&mut band, p, None, layer);
                    }
                    clear.copy_from_slice(band.rgba);
                    clear_strip(Band::strip(k, clear, w), background, &spans, strips.of(k));
                }),
        }
    };
    STRIPS.with(|cell| match cell.try_borrow_mut() {
        Ok(mut strips) => run(&mut strips),
        // Called again on this thread while its strips are in use (a
        // rayon thread waiting on a frame's strips may take up another).
        Err(_) => run(&mut Strips::default()),
    });
}

/// A strip of the drone-free frame under the particles: `band` holds the
/// blended frame; where its rows differ from the drone-free `background`
/// (`spans`), the background with `particles` blended over it.
fn clear_strip(mut band: Band, background: &[u8], spans: &[(u32, u32)], particles: &[Prepared]) {
    let row = band.width as usize * 4;
    let mut any = false;
    for (y, &(x0, x1)) in spans.iter().enumerate().filter(|(_, s)| s.0 < s.1) {
        let span = y * row + x0 as usize * 4..y * row + x1 as usize * 4;
        band.rgba[span.clone()].copy_from_slice(&background[span]);
        any = true;
    }
    if any {
        for p in particles {
            draw(&mut band, p, Some(spans), None);
        }
    }
}

/// The pixels particle `p` may cover: its path's box grown by its radius
/// and a pixel, within the `w × h` picture (x0, y0, x1, y1).
#[inline]
fn bounds(p: &Particle, (w, h): (u32, u32)) -> (u32, u32, u32, u32) {
    let r = p.radius_px;
    let (ax, ay, bx, by) = (p.a[0], p.a[1], p.b[0], p.b[1]);
    (
        floor_within(ax.min(bx) - r - 1.0, w),
        floor_within(ay.min(by) - r - 1.0, h),
        ceil_within(ax.max(bx) + r + 1.0, w),
        ceil_within(ay.max(by) + r + 1.0, h),
    )
}

/// One particle into `band`: in each of its rows, only the columns its
/// capsule can reach ([`reach`]), each pixel by its coverage; with `only`,
/// only within the band's row's span (`only[y − first row]`), and where
/// `layer` holds a drone nearer than the particle, not at all.
#[inline]
fn draw(band: &mut Band, p: &Prepared, only: Option<&[(u32, u32)]>, layer: Option<&DepthLayer>) {
    let [x0, y0, x1, y1] = p.bounds;
    let layer = layer.filter(|_| p.tested);
    let (ys, ye) = (y0.max(band.rows.start), y1.min(band.rows.end));
    for y in ys..ye {
        let (lo, hi) = match only {
            Some(o) => (o.get((y - band.rows.start) as usize).copied()).unwrap_or((0, 0)),
            None => (x0, x1),
        };
        if lo >= hi {
            continue;
        }
        let py = y as f32 + 0.5;
        let (xs, xe) = reach(p, py, (x0, x1));
        let row = (y - band.rows.start) as usize * band.width as usize;
        for x in xs.max(lo)..xe.min(hi) {
            let px = x as f32 + 0.5;
            let cover = coverage(p, (px, py));
            if cover <= 0.0 || layer.is_some_and(|l| l.depth(x, y) <= p.depth_m) {
                continue;
            }
            let i = (row + x as usize) * 4;
            blend(&mut band.rgba[i..i + 4], p.level, p.alpha * cover);
        }
    }
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
fn reach(p: &Prepared, py: f32, (x0, x1): (u32, u32)) -> (u32, u32) {
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

/// The RGBA8 pixel `px`'s colour channels towards `level` by `alpha`, each
/// `round_half_up(v + (level − v) · alpha)`, its fourth byte kept. On
/// x86-64 the four lanes at once in SSE2 (part of every x86-64 CPU): the
/// same IEEE operations lane by lane, so the same bytes as `blend_scalar`.
#[inline]
fn blend(px: &mut [u8], level: f32, alpha: f32) {
    #[cfg(target_arch = "x86_64")]
    {
        let bytes = u32::from_le_bytes([px[0], px[1], px[2], px[3]]);
        // SAFETY: SSE2 is part of the x86-64 baseline: every build for it enables it.
        #[allow(unsafe_code)]
        let out = unsafe { blend_sse2(bytes, level, alpha) };
        px[..4].copy_from_slice(&out.to_le_bytes());
    }
    #[cfg(not(target_arch = "x86_64"))]
    blend_scalar(px, level, alpha);
}

/// [`blend`] of the pixel `bytes` (little-endian RGBA8) in SSE2's lanes.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "sse2")]
#[inline]
fn blend_sse2(bytes: u32, level: f32, alpha: f32) -> u32 {
    use std::arch::x86_64::*;
    let zero = _mm_setzero_si128();
    let lanes = _mm_unpacklo_epi8(_mm_cvtsi32_si128(bytes as i32), zero);
    let v = _mm_cvtepi32_ps(_mm_unpacklo_epi16(lanes, zero));
    let towards = _mm_mul_ps(_mm_sub_ps(_mm_set1_ps(level), v), _mm_set1_ps(alpha));
    let x = _mm_add_ps(v, towards);
    // x ≥ 0: truncation is `as u32`; the compare's all-ones adds 1.
    let i = _mm_cvttps_epi32(x);
    let up = _mm_cmpge_ps(_mm_sub_ps(x, _mm_cvtepi32_ps(i)), _mm_set1_ps(0.5));
    let rounded = _mm_sub_epi32(i, _mm_castps_si128(up));
    // Saturating packs: the `min(255)`.
    let packed = _mm_packus_epi16(_mm_packs_epi32(rounded, zero), zero);
    (_mm_cvtsi128_si32(packed) as u32 & 0x00ff_ffff) | (bytes & 0xff00_0000)
}

/// [`blend`] a channel at a time.
#[cfg(any(test, not(target_arch = "x86_64")))]
fn blend_scalar(px: &mut [u8], level: f32, alpha: f32) {
    for c in &mut px[..3] {
        let v = f32::from(*c);
        *c = round_half_up(v + (level - v) * alpha);
    }
}

/// `x.round()` as a level (halves away from zero, saturating to 0–255)
/// without a library call: `x − trunc(x)` is exact.
#[cfg(any(test, not(target_arch = "x86_64")))]
#[inline]
fn round_half_up(x: f32) -> u8 {
    let i = x as u32;
    let up = x - i as f32 >= 0.5;
    (i + u32::from(up)).min(255) as u8
}

/// How much of the pixel centred at `(px, py)` particle `p` covers, 0–1.
/// A streak: by the distance to its path (a capsule with a half-pixel soft
/// edge). A flake: the share of the exposure its disc is over the pixel,
/// the disc's centre moving uniformly from a to b, times the same soft
/// edge across.
#[inline]
fn coverage(p: &Prepared, (px, py): (f32, f32)) -> f32 {
    let (r, len) = (p.r, p.len);
    let ([ax, ay], [dx, dy]) = (p.a, p.d);
    if p.len2 <= 0.0 {
        let (ex, ey) = (px - ax, py - ay);
        return (r + 0.5 - (ex * ex + ey * ey).sqrt()).clamp(0.0, 1.0);
    }
    // Along the path (pixels from a) and across it.
    let s = ((px - ax) * dx + (py - ay) * dy) / len;
    if p.solid {
        let e = ((px - ax) * dy - (py - ay) * dx).abs() / len;
        let edge = (r + 0.5 - e).clamp(0.0, 1.0);
        let h = (r * r - e * e).max(0.0).sqrt().max(0.5);
        let time = ((s + h).min(len) - (s - h).max(0.0)).max(0.0) / len;
        return edge * time.min(1.0);
    }
    let t = (s / len).clamp(0.0, 1.0);
    let (ex, ey) = (px - ax - t * dx, py - ay - t * dy);
    (r + 0.5 - (ex * ex + ey * ey).sqrt()).clamp(0.0, 1.0)
}

/// The weather of `scene` over its pixels `rgba` (in place), the drones'
/// pixels told from `background` (the drone-free frame; without one every
/// pixel of a drone's box is the drone's); with a `clear` buffer (any
/// contents, reused) and a background, the drone-free frame under the same
/// particles comes back in it. Nothing without weather. The stage's whole
/// CPU work (`examples/weather_bench.rs`).
pub fn over_pixels(
    (scene, geometry): (&FrameScene, &[LabelGeometry]),
    rgba: &mut [u8],
    background: Option<&[u8]>,
    clear: Option<Vec<u8>>,
) -> Option<Vec<u8>> {
    let weather = scene.weather.as_ref()?;
    let size = (scene.camera.width, scene.camera.height);
    let particles = weather.particles(&scene.camera, scene.atmosphere.as_ref());
    let layer = DepthLayer::new(scene, geometry, rgba, background);
    let Some((mut clear, background)) = clear.zip(background) else {
        composite(rgba, size, &particles, Some(&layer), None);
        return None;
    };
    clear.resize(rgba.len(), 0);
    let both = Clear {
        clear: &mut clear,
        background,
    };
    composite(rgba, size, &particles, Some(&layer), Some(both));
    Some(clear)
}

/// Per row of two `width`-pixel RGBA8 strips, the columns from its first
/// to its last differing pixel (`(0, 0)`: the rows agree), into `spans`.
fn differing_spans(a: &[u8], b: &[u8], width: u32, spans: &mut [(u32, u32)]) {
    let row = (width as usize * 4).max(1);
    for ((ra, rb), span) in a.chunks(row).zip(b.chunks(row)).zip(spans.iter_mut()) {
        *span = if ra == rb {
            (0, 0)
        } else {
            let differs = |(p, q): (&[u8], &[u8])| p != q;
            let mut pairs = ra.chunks_exact(4).zip(rb.chunks_exact(4));
            let first = pairs.clone().position(differs).unwrap_or(0);
            let last = pairs.rposition(differs).map_or(first, |l| l + 1);
            (first as u32, last as u32)
        };
    }
}

/// The weather of `scene` over its rendered `frame` (in place); `None`
/// without weather. Under weather: the drone-free frame under the same
/// particles (`Some(None)` when nothing measures against it or the renderer
/// kept no background), each measured drone's visibility and the pixel
/// `hits` (the masks) cut to what still shows, and `frame.painted` cleared
/// (its buffer no longer holds only the background and its rects).
pub(super) fn over_frame(
    (scene, geometry): (&FrameScene, &[LabelGeometry]),
    renderer: &mut Renderer,
    frame: &mut RenderedFrame,
    measured: &mut Option<Vec<Visibility>>,
    hits: &mut Option<Vec<PixelHit>>,
) -> Option<Option<Vec<u8>>> {
    scene.weather.as_ref()?;
    let keep_clear = measured.is_some() || hits.is_some() || scene.camera_model.is_some();
    // A recycled buffer, not fresh pages, for the drone-free frame.
    let buffer = keep_clear.then(|| renderer.spare_buffer());
    let background = renderer.background_pixels(&frame.painted);
    let clear = over_pixels((scene, geometry), &mut frame.rgba, background, buffer);
    frame.painted = Painted::default();
    if let (Some(clear), Some(all)) = (&clear, hits.as_mut()) {
        let rendered = std::mem::take(all);
        *all = visible_through(
            measured.as_deref_mut(),
            rendered,
            (&frame.rgba, clear),
            scene.camera.width,
        );
    }
    Some(clear)
}

/// Each drone's visibility under the weather: its rendered pixels (`hits`)
/// where the weathered frame still differs from the weathered drone-free
/// frame; the unoccluded count stays the rendered one, so the visible
/// fraction falls by what the weather hides. Returns the hits kept (and
/// measures nothing without `vis`: the masks alone).
fn visible_through(
    vis: Option<&mut [Visibility]>,
    hits: Vec<PixelHit>,
    (rgba, clear): (&[u8], &[u8]),
    width: u32,
) -> Vec<PixelHit> {
    let shows = |i: usize| rgba[i * 4..i * 4 + 3] != clear[i * 4..i * 4 + 3];
    keep_showing(vis, hits, width, shows)
}

/// [`visible_through`] by a test of its own: the `hits` whose pixel
/// (index y · `width` + x) `shows`, and `vis` measured from them.
pub(super) fn keep_showing(
    vis: Option<&mut [Visibility]>,
    hits: Vec<PixelHit>,
    width: u32,
    shows: impl Fn(usize) -> bool,
) -> Vec<PixelHit> {
    let kept: Vec<PixelHit> = hits
        .into_iter()
        .filter(|hit| shows((hit.y * width + hit.x) as usize))
        .collect();
    let Some(vis) = vis else {
        return kept;
    };
    for v in vis.iter_mut() {
        v.visible_box = None;
        v.visible_pixels = 0;
    }
    for hit in &kept {
        let Some(v) = vis.get_mut(hit.drone as usize) else {
            continue;
        };
        let (x, y) = (f64::from(hit.x), f64::from(hit.y));
        v.visible_pixels += 1;
        PixelBox::include_pixel(&mut v.visible_box, x, y);
    }
    kept
}

/// The weather of `scene` over a thermal camera's radiance planes (in
/// place): each particle at the air's radiance `air` (drops and flakes at
/// the air's temperature, emissivity about 1), blended by its alpha ×
/// coverage as over the visible picture, into `plane` where the drone the
/// id pass puts at a pixel (`hits`, at its centre's depth) is farther than
/// the particle, and into `clear` (the drone-free plane) everywhere.
/// `v·(1 − a) + air·a` is exactly `air` at a = 1, so a flake that covers a
/// pixel whole leaves both planes equal there. Nothing without weather.
pub(super) fn over_radiance(
    scene: &FrameScene,
    hits: &[PixelHit],
    (plane, clear): (&mut [f32], &mut [f32]),
    air: f32,
) {
    let Some(weather) = scene.weather.as_ref() else {
        return;
    };
    let (w, h) = (scene.camera.width, scene.camera.height);
    let particles = weather.particles(&scene.camera, scene.atmosphere.as_ref());
    let layer = DepthLayer::of_hits(scene, hits);
    let mut strips = Strips::default();
    strips.fill(&particles, (w, h), Some(&layer));
    let chunk = (STRIP as usize * w as usize).max(1);
    (plane.par_chunks_mut(chunk))
        .zip(clear.par_chunks_mut(chunk))
        .enumerate()
        .for_each(|(k, (plane, clear))| {
            let first = k as u32 * STRIP;
            for p in strips.of(k) {
                draw_radiance((plane, first, w), p, air, Some(&layer));
                draw_radiance((clear, first, w), p, air, None);
            }
        });
}

/// One particle into rows `first..` of a `width`-pixel radiance plane
/// (`rows` holds them) at radiance `air`, as [`draw`] does into a picture.
#[inline]
fn draw_radiance(
    (rows, first, width): (&mut [f32], u32, u32),
    p: &Prepared,
    air: f32,
    layer: Option<&DepthLayer>,
) {
    let [x0, y0, x1, y1] = p.bounds;
    let layer = layer.filter(|_| p.tested);
    let end = first + (rows.len() / (width as usize).max(1)) as u32;
    for y in y0.max(first)..y1.min(end) {
        let py = y as f32 + 0.5;
        let (xs, xe) = reach(p, py, (x0, x1));
        let row = (y - first) as usize * width as usize;
        for x in xs..xe {
            let cover = coverage(p, (x as f32 + 0.5, py));
            if cover <= 0.0 || layer.is_some_and(|l| l.depth(x, y) <= p.depth_m) {
                continue;
            }
            let a = p.alpha * cover;
            let v = &mut rows[row + x as usize];
            *v = *v * (1.0 - a) + air * a;
        }
    }
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
                    level: 240,
                    solid: i % 2 == 0,
                }
            })
            .collect()
    }

    /// Over each row of each particle's bounds: the pixels its coverage
    /// reaches and the pixels [`reach`] evaluates.
    fn reached_and_covered(p: &Particle, size: (u32, u32)) -> (usize, usize, usize) {
        let q = Prepared::of(p, size, None);
        let [x0, y0, x1, y1] = q.bounds;
        let (mut missed, mut evaluated, mut covered) = (0, 0, 0);
        for y in y0..y1 {
            let py = y as f32 + 0.5;
            let (xs, xe) = reach(&q, py, (x0, x1));
            evaluated += xe.saturating_sub(xs) as usize;
            for x in x0..x1 {
                if coverage(&q, (x as f32 + 0.5, py)) > 0.0 {
                    covered += 1;
                    missed += usize::from(x < xs || x >= xe);
                }
            }
        }
        (missed, evaluated, covered)
    }

    #[test]
    fn reach_holds_every_pixel_a_particle_covers() {
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

    #[test]
    fn blend_gives_the_scalar_bytes() {
        let mut rng = ChaCha8Rng::seed_from_u64(42);
        let mut alphas: Vec<f32> = vec![0.0, 1.0, 0.5, 1.0 / 255.0, 0.999_999_9, 1e-8];
        alphas.extend((0..400).map(|_| rng.random::<f32>()));
        for level in [0.0, 1.0, 127.0, 228.0, 242.0, 255.0] {
            for &alpha in &alphas {
                for v in 0..=255u8 {
                    let px = [v, 255 - v, v / 2, 77];
                    let (mut simd, mut scalar) = (px, px);
                    blend(&mut simd, level, alpha);
                    blend_scalar(&mut scalar, level, alpha);
                    assert_eq!(simd, scalar, "level {level} alpha {alpha} pixel {px:?}");
                }
            }
        }
    }
}

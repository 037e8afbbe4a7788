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

    fn depth_mut(&mut self, x: u32, y: u32) -> &mut f32 {
        let cell = ((y / CELL) * self.cols + x / CELL) as usize;
        if self.cell_tile[cell] == u32::MAX {
            self.cell_tile[cell] = self.tiles.len() as u32;
            self.tiles.push([f32::INFINITY; (CELL * CELL) as usize]);
        }
        let tile = &mut self.tiles[self.cell_tile[cell] as usize];
        &mut tile[((y % CELL) * CELL + x % CELL) as usize]
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

/// Rows `rows` of a `width`-pixel RGBA8 picture: `rgba` holds exactly them.
struct Band<'a> {
    rgba: &'a mut [u8],
    width: u32,
    rows: Range<u32>,
}

/// Rows of the picture blended together: a strip's pixels stay in the
/// cache while its particles are drawn.
const STRIP: u32 = 16;

/// Blend `particles` (farthest first) into `rgba` (`w × h`, RGBA8 sRGB),
/// a pixel only where `behind(x, y)` is farther than the particle and, with
/// `only`, within its row's span (`only[y]`: columns x0..x1). The picture
/// is cut into strips of [`STRIP`] rows, each with the particles that reach
/// it in their order, the strips shared among the threads: each pixel still
/// sees the particles in the same order, so the bytes do not depend on the
/// threads.
fn composite(
    rgba: &mut [u8],
    (w, h): (u32, u32),
    particles: &[Particle],
    only: Option<&[(u32, u32)]>,
    behind: &(impl Fn(u32, u32) -> f32 + Sync),
) {
    let mut strips: Vec<Vec<u32>> = vec![Vec::new(); h.div_ceil(STRIP) as usize];
    for (i, p) in particles.iter().enumerate() {
        let (_, y0, _, y1) = bounds(p, (w, h));
        if y0 < y1 {
            for strip in &mut strips[(y0 / STRIP) as usize..=((y1 - 1) / STRIP) as usize] {
                strip.push(i as u32);
            }
        }
    }
    let row_bytes = w as usize * 4;
    rgba.par_chunks_mut((STRIP as usize * row_bytes).max(1))
        .zip(strips.par_iter())
        .enumerate()
        .for_each(|(k, (rgba, strip))| {
            let y0 = k as u32 * STRIP;
            let rows = y0..y0 + (rgba.len() / row_bytes.max(1)) as u32;
            // Rows without a span (or past `only`) take nothing.
            let span = rows.start as usize..rows.end as usize;
            let empty = |o: &[(u32, u32)]| {
                o.get(span.clone())
                    .is_none_or(|r| r.iter().all(|s| s.0 >= s.1))
            };
            if only.is_some_and(empty) {
                return;
            }
            let mut band = Band {
                rgba,
                width: w,
                rows,
            };
            for &i in strip {
                draw(&mut band, (w, h), &particles[i as usize], only, behind);
            }
        });
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
/// capsule can reach ([`reach`]), each pixel by its coverage.
#[inline]
fn draw(
    band: &mut Band,
    size: (u32, u32),
    p: &Particle,
    only: Option<&[(u32, u32)]>,
    behind: &impl Fn(u32, u32) -> f32,
) {
    let (dx, dy) = (p.b[0] - p.a[0], p.b[1] - p.a[1]);
    let len2 = dx * dx + dy * dy;
    let (x0, y0, x1, y1) = bounds(p, size);
    let level = f32::from(p.level);
    let (ys, ye) = (y0.max(band.rows.start), y1.min(band.rows.end));
    for y in ys..ye {
        let (lo, hi) = match only {
            Some(o) => o.get(y as usize).copied().unwrap_or((0, 0)),
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
            let cover = coverage(p, (px, py), (dx, dy, len2));
            if cover <= 0.0 || behind(x, y) <= p.depth_m {
                continue;
            }
            let alpha = p.alpha * cover;
            let i = (row + x as usize) * 4;
            for c in &mut band.rgba[i..i + 3] {
                let v = f32::from(*c);
                *c = round_half_up(v + (level - v) * alpha);
            }
        }
    }
}

/// The columns of `x0..x1` whose pixel centres on the row at `py` can lie
/// under particle `p` (a superset: [`coverage`] is 0 elsewhere). A pixel a
/// streak touches is within r + ½ of its path; one a flake touches within
/// r + ½ across its path and max(r, ½) along it (so within 2r + 1); the
/// path's part within that of the row bounds the columns, with
/// [`SLACK`] for the rounding.
#[inline]
fn reach(p: &Particle, py: f32, (x0, x1): (u32, u32)) -> (u32, u32) {
    let r = p.radius_px;
    let grow = if p.solid { 2.0 * r + 1.0 } else { r + 0.5 } + SLACK;
    let (ax, ay) = (p.a[0], p.a[1]);
    let (dx, dy) = (p.b[0] - ax, p.b[1] - ay);
    if dy.abs() < 1e-3 {
        return (x0, x1);
    }
    let (t0, t1) = ((py - grow - ay) / dy, (py + grow - ay) / dy);
    let (lo, hi) = (t0.min(t1).max(0.0), t0.max(t1).min(1.0));
    if lo > hi {
        return (x0, x0);
    }
    let (xa, xb) = (ax + lo * dx, ax + hi * dx);
    // Centres x + ½ strictly within `grow` of [min, max].
    let first = floor_within(xa.min(xb) - grow - 0.5, x1);
    let end = floor_within(xa.max(xb) + grow - 0.5, x1) + 1;
    (first.max(x0), end.clamp(x0, x1))
}

/// Pixels of slack in [`reach`]: far above f32's rounding there.
const SLACK: f32 = 0.05;

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

/// `x.round()` as a level (halves away from zero, saturating to 0–255)
/// without a library call: `x − trunc(x)` is exact.
#[inline]
fn round_half_up(x: f32) -> u8 {
    let i = x as u32;
    let up = x - i as f32 >= 0.5;
    (i + u32::from(up)).min(255) as u8
}

/// How much of the pixel centred at `(px, py)` particle `p` covers, 0–1
/// (`d`: its travel b − a in pixels and its squared length). A streak: by
/// the distance to its path (a capsule with a half-pixel soft edge). A
/// flake: the share of the exposure its disc is over the pixel, the disc's
/// centre moving uniformly from a to b, times the same soft edge across.
#[inline]
fn coverage(p: &Particle, (px, py): (f32, f32), (dx, dy, len2): (f32, f32, f32)) -> f32 {
    let r = p.radius_px;
    let (ax, ay) = (p.a[0], p.a[1]);
    if len2 <= 0.0 {
        let (ex, ey) = (px - ax, py - ay);
        return (r + 0.5 - (ex * ex + ey * ey).sqrt()).clamp(0.0, 1.0);
    }
    // Along the path (pixels from a) and across it.
    let len = len2.sqrt();
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
/// pixel of a drone's box is the drone's); when `keep_clear`, the
/// drone-free frame under the same particles comes back. Nothing without
/// weather. The stage's whole CPU work (`examples/weather_bench.rs`).
pub fn over_pixels(
    (scene, geometry): (&FrameScene, &[LabelGeometry]),
    rgba: &mut [u8],
    background: Option<&[u8]>,
    keep_clear: bool,
) -> Option<Vec<u8>> {
    let weather = scene.weather.as_ref()?;
    let size = (scene.camera.width, scene.camera.height);
    let particles = weather.particles(&scene.camera, scene.atmosphere.as_ref());
    let layer = DepthLayer::new(scene, geometry, rgba, background);
    let background = background.filter(|_| keep_clear);
    // Where the frame differs from its drone-free background: only there
    // can the drone-free frame under the same particles differ from it.
    let spans = background.map(|bg| differing_spans(rgba, bg, size.0));
    composite(rgba, size, &particles, None, &|x, y| layer.depth(x, y));
    let (background, spans) = (background?, spans?);
    let mut clear = rgba.to_vec();
    let row = size.0 as usize * 4;
    for (y, &(x0, x1)) in spans.iter().enumerate() {
        let span = y * row + x0 as usize * 4..y * row + x1 as usize * 4;
        clear[span.clone()].copy_from_slice(&background[span]);
    }
    composite(&mut clear, size, &particles, Some(&spans), &|_, _| {
        f32::INFINITY
    });
    Some(clear)
}

/// Per row of two `width`-pixel RGBA8 pictures, the columns from its first
/// to its last differing pixel (`(0, 0)`: the rows agree).
fn differing_spans(a: &[u8], b: &[u8], width: u32) -> Vec<(u32, u32)> {
    let row = width as usize * 4;
    a.par_chunks(row.max(1))
        .zip(b.par_chunks(row.max(1)))
        .map(|(ra, rb)| {
            if ra == rb {
                return (0, 0);
            }
            let differs = |(p, q): (&[u8], &[u8])| p != q;
            let mut pairs = ra.chunks_exact(4).zip(rb.chunks_exact(4));
            let first = pairs.clone().position(differs).unwrap_or(0);
            let last = pairs.rposition(differs).map_or(first, |l| l + 1);
            (first as u32, last as u32)
        })
        .collect()
}

/// The weather of `scene` over its rendered `frame` (in place); `None`
/// without weather. Under weather: the drone-free frame under the same
/// particles (`Some(None)` when nothing measures against it or the renderer
/// kept no background), each measured drone's visibility and the pixel
/// `hits` (the masks) cut to what still shows, and `frame.painted` cleared
/// (its buffer no longer holds only the background and its rects).
pub(super) fn over_frame(
    (scene, geometry): (&FrameScene, &[LabelGeometry]),
    renderer: &Renderer,
    frame: &mut RenderedFrame,
    measured: &mut Option<Vec<Visibility>>,
    hits: &mut Option<Vec<PixelHit>>,
) -> Option<Option<Vec<u8>>> {
    scene.weather.as_ref()?;
    let background = renderer.background_pixels(&frame.painted);
    let keep_clear = measured.is_some() || hits.is_some() || scene.camera_model.is_some();
    let clear = over_pixels((scene, geometry), &mut frame.rgba, background, keep_clear);
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
    let kept: Vec<PixelHit> = hits
        .into_iter()
        .filter(|hit| {
            let i = (hit.y * width + hit.x) as usize * 4;
            rgba[i..i + 3] != clear[i..i + 3]
        })
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

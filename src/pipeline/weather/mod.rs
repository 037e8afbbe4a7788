//! Rain and snow over a rendered frame (issue 41 item 4), the pipeline's
//! weather glue: the frame's particles ([`crate::scene::weather`]) over
//! its pixels in sRGB, each pixel of a particle's capsule towards the
//! frame's level by the particle's alpha × coverage, but only where what
//! the pixel shows is farther than the particle: a drone's pixel (one that
//! differs from the drone-free background) is at the drone's depth (its
//! centre's, along the view axis; the nearest drone whose box holds the
//! pixel), every other pixel (sky, clouds, clutter, plates) is behind every
//! particle. The same particles go over the drone-free background (without
//! a depth test), and a drone's visible pixels are its rendered pixels that
//! still differ from it: a flake nearer than a drone hides the pixels it
//! covers whole, a translucent streak veils them.
//!
//! Every particle blends towards the same level, so the blends' order does
//! not matter: a pixel ends at L − (L − v)·T, T the product of its
//! particles' 1 − alpha × coverage ([`resolve`]). One pass over the picture
//! in strips of rows on rayon's threads does it all: the particles
//! bucketed by strip (kept from frame to frame), each strip's
//! transmittances multiplied particle by particle in the frame's order (so
//! the bytes do not depend on the threads), `all` over every pixel and
//! `near`, of the particles nearer than the drone, at drones' pixels only
//! (the depth looked up only for particles whose bounds meet a drone's
//! cells); then the drone-free frame (a buffer the caller recycles) from
//! the background by `all`, and the frame by `near` at drones' pixels and
//! `all` elsewhere, each channel rounded once. Through a lens the particles
//! are drawn in the undistorted frame and resampled with it. Under the
//! thermal camera ([`over_radiance`]) the same transmittances go over its
//! radiance planes, at the air's radiance, the drones' depths from the id
//! pass's pixels.

mod cover;
mod depth;
mod resolve;

use rayon::prelude::*;

use crate::annotate::visibility::{PixelHit, Visibility};
use crate::render::{Painted, RenderedFrame, Renderer};
use crate::scene::FrameScene;
use crate::scene::projection::{LabelGeometry, PixelBox};
use crate::scene::weather::Particle;

use cover::{Prepared, Transmit, draw};
use depth::{CELL, DepthLayer};

/// Rows of the picture drawn together: a strip's transmittances (two
/// planes of 32 rows, 0.5 MB at 1080p) stay in the cache while its
/// particles are drawn, and a streak is bucketed once for each strip it
/// reaches (16 rows: rain's frames 15 % slower, `weather_bench`).
/// Divides [`CELL`].
const STRIP: u32 = 32;
const _: () = assert!(CELL.is_multiple_of(STRIP));

/// The frame's particles bucketed by strip, kept from frame to frame (no
/// allocation once grown): the particles cut into [`CHUNKS`] runs, each
/// run bucketed on its own (on rayon's threads) by a counting sort into
/// its own items, strip by strip; strip k's particles are each run's
/// strip k in turn, so in the frame's order.
#[derive(Default)]
struct Strips {
    runs: Vec<Run>,
}

/// Runs of particles [`Strips`] buckets in parallel.
const CHUNKS: usize = 8;

/// One run's particles bucketed: strip k's are `items[starts[k]..starts[k + 1]]`.
#[derive(Default)]
struct Run {
    starts: Vec<u32>,
    items: Vec<Prepared>,
    /// Each particle's bounds, and each strip's next slot as it fills.
    bounds: Vec<(u32, u32, u32, u32)>,
    next: Vec<u32>,
}

impl Strips {
    /// Each particle of `particles` into the strips its bounds reach.
    fn fill(&mut self, particles: &[Particle], size: (u32, u32), layer: Option<&DepthLayer>) {
        let n = size.1.div_ceil(STRIP) as usize;
        self.runs.resize_with(CHUNKS, Run::default);
        let per = particles.len().div_ceil(CHUNKS).max(1);
        (self.runs.par_iter_mut().enumerate()).for_each(|(c, run)| {
            let from = (c * per).min(particles.len());
            let to = (from + per).min(particles.len());
            run.fill(&particles[from..to], n, size, layer);
        });
    }

    /// Strip `k`'s particles, in the frame's order.
    fn of(&self, k: usize) -> impl Iterator<Item = &Prepared> {
        self.runs.iter().flat_map(move |r| r.of(k))
    }
}

impl Run {
    /// `particles` into the `n` strips their bounds reach.
    fn fill(
        &mut self,
        particles: &[Particle],
        n: usize,
        size: (u32, u32),
        layer: Option<&DepthLayer>,
    ) {
        // The strips a particle's bounds reach.
        let reached = |&(_, y0, _, y1): &(u32, u32, u32, u32)| {
            (y0 < y1).then(|| (y0 / STRIP) as usize..=((y1 - 1) / STRIP) as usize)
        };
        self.bounds.clear();
        self.bounds
            .extend(particles.iter().map(|p| cover::bounds(p, size)));
        self.starts.clear();
        self.starts.resize(n + 1, 0);
        for strips in self.bounds.iter().filter_map(reached) {
            for k in strips {
                self.starts[k + 1] += 1;
            }
        }
        for k in 0..n {
            self.starts[k + 1] += self.starts[k];
        }
        // Every slot is written below (each strip's run of slots fills
        // exactly): the last frame's items are kept, not cleared, so only
        // slots past them are first filled with defaults.
        self.items
            .resize(self.starts[n] as usize, Prepared::default());
        self.next.clear();
        self.next.extend_from_slice(&self.starts[..n]);
        for (p, bounds) in particles.iter().zip(&self.bounds) {
            let Some(strips) = reached(bounds) else {
                continue;
            };
            let prepared = Prepared::within(p, *bounds, layer);
            for k in strips {
                let at = self.next[k] as usize;
                self.items[at] = prepared;
                prefetch_slot(&self.items, at + AHEAD);
                self.next[k] += 1;
            }
        }
    }

    fn of(&self, k: usize) -> &[Prepared] {
        let (a, b) = (self.starts[k] as usize, self.starts[k + 1] as usize);
        &self.items[a..b]
    }
}

/// How many slots ahead of the one it fills [`Run::fill`] asks for a
/// strip's next slots: the strips' slots fill as many streams at once,
/// more than the hardware follows, and each slot's first store would
/// otherwise wait for its line (the items from the frame before long
/// gone from the cache).
const AHEAD: usize = 3;

/// Ask the cache for slot `at` of `items` (nothing past its end; a hint only).
#[inline]
fn prefetch_slot(items: &[Prepared], at: usize) {
    #[cfg(target_arch = "x86_64")]
    if let Some(slot) = items.get(at) {
        use std::arch::x86_64::{_MM_HINT_T0, _mm_prefetch};
        // SAFETY: a prefetch reads nothing and never faults.
        #[allow(unsafe_code)]
        unsafe {
            _mm_prefetch::<_MM_HINT_T0>(std::ptr::from_ref(slot).cast())
        };
    }
    #[cfg(not(target_arch = "x86_64"))]
    let _ = (items, at);
}

thread_local! {
    /// Each thread's strips, kept from frame to frame.
    static STRIPS: std::cell::RefCell<Strips> = std::cell::RefCell::default();
    /// Each thread's particles of a frame, kept from frame to frame.
    static PARTICLES: std::cell::RefCell<Vec<Particle>> = std::cell::RefCell::default();
    /// Each thread's transmittances of a strip, kept from strip to strip.
    static SCRATCH: std::cell::RefCell<(Vec<f32>, Vec<f32>)> = std::cell::RefCell::default();
}

/// `f` on this thread's `buffer` (kept from call to call, so it is not
/// allocated afresh), or on a fresh one when that is in use: a rayon
/// thread waiting inside `f` may take up another frame's work on the same
/// thread.
fn kept<T: Default + 'static, R>(
    buffer: &'static std::thread::LocalKey<std::cell::RefCell<T>>,
    f: impl FnOnce(&mut T) -> R,
) -> R {
    buffer.with(|cell| match cell.try_borrow_mut() {
        Ok(mut kept) => f(&mut kept),
        Err(_) => f(&mut T::default()),
    })
}

/// Strip `k`'s transmittances (`rows` rows of `width` pixels) under its
/// `particles`, given to `then` (the transmittances of a thread's own
/// buffers, or fresh ones when those are in use).
fn transmit<'a, R>(
    (k, rows, width): (usize, u32, u32),
    particles: impl Iterator<Item = &'a Prepared>,
    layer: Option<&DepthLayer>,
    then: impl FnOnce(&mut Transmit) -> R,
) -> R {
    let run = |(all, near): &mut (Vec<f32>, Vec<f32>)| {
        let n = (rows * width) as usize;
        all.clear();
        all.resize(n, 1.0);
        near.resize(n, 1.0);
        let first = k as u32 * STRIP;
        let mut t = Transmit {
            all,
            near,
            width,
            rows: first..first + rows,
            lanes: cover::lanes_here(),
        };
        // `near` is read at drones' pixels only: 1 over their cells.
        for (y, l) in (first..first + rows).zip(0usize..) {
            for (x0, _) in layer.into_iter().flat_map(|l| l.drone_cells(y)) {
                let (a, b) = (x0.min(width) as usize, (x0 + CELL).min(width) as usize);
                let row = l * width as usize;
                t.near[row + a..row + b].fill(1.0);
            }
        }
        for p in particles {
            draw(&mut t, p, layer);
        }
        then(&mut t)
    };
    kept(&SCRATCH, run)
}

/// Per row of `t`, `all` set to `near` at the pixels where `layer` holds
/// a drone (what the frame, not the drone-free frame, sees there).
fn near_at_drones(t: &mut Transmit, layer: &DepthLayer) {
    let w = t.width as usize;
    let rows = (t.all.chunks_mut(w)).zip(t.near.chunks(w));
    for (y, (all, near)) in t.rows.clone().zip(rows) {
        near_in_row((all, near), y, layer);
    }
}

/// Row `y`'s `all` set to its `near` at the pixels where `layer` holds a drone.
fn near_in_row((all, near): (&mut [f32], &[f32]), y: u32, layer: &DepthLayer) {
    for (x0, depths) in layer.drone_cells(y) {
        let x0 = (x0 as usize).min(all.len());
        for ((a, n), d) in all[x0..].iter_mut().zip(&near[x0..]).zip(depths) {
            if *d < f32::INFINITY {
                *a = *n;
            }
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

/// `particles` over `rgba` (`w × h`, RGBA8 sRGB) towards `level`, a pixel
/// only by those nearer than what `layer` puts there; with `clear`, the
/// drone-free frame under all of them too, from its background.
fn composite(
    rgba: &mut [u8],
    (w, h): (u32, u32),
    (particles, level): (&[Particle], u8),
    layer: &DepthLayer,
    clear: Option<Clear>,
) {
    let level = f32::from(level);
    let row = w as usize * 4;
    let chunk = (STRIP as usize * row).max(1);
    let strip = |k: usize, strips: &Strips, rgba: &mut [u8], clear: Option<(&mut [u8], &[u8])>| {
        let rows = (rgba.len() / row.max(1)) as u32;
        transmit((k, rows, w), strips.of(k), Some(layer), |t| {
            let Some((clear, background)) = clear else {
                near_at_drones(t, layer);
                for (px, t) in rgba.chunks_mut(row).zip(t.all.chunks(w as usize)) {
                    resolve::resolve(px, None, t, level);
                }
                return;
            };
            // Row by row, so the second pass finds the row's background,
            // drone-free row and transmittances still in the cache.
            let rows = (rgba.chunks_mut(row).zip(clear.chunks_mut(row)))
                .zip(background.chunks(row))
                .zip(t.all.chunks_mut(w as usize).zip(t.near.chunks(w as usize)));
            for (y, (((px, c), b), (all, near))) in t.rows.clone().zip(rows) {
                resolve::resolve(c, Some(b), all, level);
                near_in_row((all, near), y, layer);
                resolve::resolve_over(px, (b, c), all, level);
            }
        })
    };
    let run = |strips: &mut Strips| {
        strips.fill(particles, (w, h), Some(layer));
        let strips = &*strips;
        match clear {
            None => (rgba.par_chunks_mut(chunk).enumerate())
                .for_each(|(k, rgba)| strip(k, strips, rgba, None)),
            Some(Clear { clear, background }) => (rgba.par_chunks_mut(chunk))
                .zip(clear.par_chunks_mut(chunk))
                .zip(background.par_chunks(chunk))
                .enumerate()
                .for_each(|(k, ((rgba, clear), bg))| strip(k, strips, rgba, Some((clear, bg)))),
        }
    };
    kept(&STRIPS, run);
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
    let layer = DepthLayer::new(scene, geometry, rgba, background);
    let over = |particles: &[Particle]| {
        let drawn = (particles, weather.level());
        let Some((mut clear, background)) = clear.zip(background) else {
            composite(rgba, size, drawn, &layer, None);
            return None;
        };
        clear.resize(rgba.len(), 0);
        let both = Clear {
            clear: &mut clear,
            background,
        };
        composite(rgba, size, drawn, &layer, Some(both));
        Some(clear)
    };
    kept(&PARTICLES, |particles| {
        weather.particles_into(&scene.camera, scene.atmosphere.as_ref(), particles);
        over(particles)
    })
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
/// the air's temperature, emissivity about 1), by its alpha × coverage as
/// over the visible picture, over `plane` where the drone the id pass puts
/// at a pixel (`hits`, at its centre's depth) is farther than the
/// particle, and over `clear` (the drone-free plane) everywhere. A
/// transmittance of 0 (a flake that covers a pixel whole) leaves both
/// planes exactly `air` there. Nothing without weather.
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
    let layer = DepthLayer::of_hits(scene, hits);
    let chunk = (STRIP as usize * w as usize).max(1);
    kept(&PARTICLES, |particles| {
        weather.particles_into(&scene.camera, scene.atmosphere.as_ref(), particles);
        kept(&STRIPS, |strips| {
            strips.fill(particles, (w, h), Some(&layer));
            let strips = &*strips;
            (plane.par_chunks_mut(chunk))
                .zip(clear.par_chunks_mut(chunk))
                .enumerate()
                .for_each(|(k, (plane, clear))| {
                    let rows = (plane.len() / (w as usize).max(1)) as u32;
                    transmit((k, rows, w), strips.of(k), Some(&layer), |t| {
                        resolve::resolve_radiance(clear, t.all, air);
                        near_at_drones(t, &layer);
                        resolve::resolve_radiance(plane, t.all, air);
                    });
                });
        })
    });
}

#[cfg(test)]
mod tests {
    use rand::{Rng, SeedableRng};
    use rand_chacha::ChaCha8Rng;

    use super::*;

    /// Streaks and flakes, thin and wide, over a 200×120 picture, some
    /// nearer and some farther than a drone at 5 m.
    fn particles(n: usize) -> Vec<Particle> {
        let mut rng = ChaCha8Rng::seed_from_u64(13);
        (0..n)
            .map(|i| {
                let a = [
                    rng.random_range(-5.0f32..205.0),
                    rng.random_range(-5.0..125.0),
                ];
                let (dx, dy) = (rng.random_range(-6.0f32..6.0), rng.random_range(0.0..30.0));
                Particle {
                    a,
                    b: [a[0] + dx, a[1] + dy * f32::from(u8::from(i % 3 != 0))],
                    radius_px: 0.5
                        + rng.random_range(0.0f32..3.0) * f32::from(u8::from(i % 4 == 0)),
                    alpha: rng.random_range(0.05..1.0),
                    depth_m: rng.random_range(0.5..10.0),
                    solid: i % 2 == 0,
                }
            })
            .collect()
    }

    /// A picture of `size` with a gradient, its background, and a drone
    /// at 5 m over a block of it (the pixels that differ).
    fn scene(size: (u32, u32)) -> (Vec<u8>, Vec<u8>, DepthLayer) {
        let (w, h) = size;
        let background: Vec<u8> = (0..w * h * 4).map(|i| (i % 251) as u8).collect();
        let mut rgba = background.clone();
        let drone: Vec<(u32, u32)> = (30..70)
            .flat_map(|y| (50..110).map(move |x| (x, y)))
            .collect();
        for &(x, y) in &drone {
            rgba[((y * w + x) * 4) as usize] = 20;
            rgba[((y * w + x) * 4 + 1) as usize] = 30;
        }
        (rgba, background, DepthLayer::from_depths(size, &drone, 5.0))
    }

    /// The frame and the drone-free frame on a pool of `threads` threads.
    fn composed(threads: usize, particles: &[Particle]) -> (Vec<u8>, Vec<u8>) {
        let size = (200, 120);
        let (mut rgba, background, layer) = scene(size);
        let mut clear = vec![0u8; rgba.len()];
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .expect("pool");
        pool.install(|| {
            let both = Clear {
                clear: &mut clear,
                background: &background,
            };
            composite(&mut rgba, size, (particles, 228), &layer, Some(both));
        });
        (rgba, clear)
    }

    #[test]
    fn the_bytes_do_not_depend_on_the_threads() {
        let p = particles(3000);
        let one = composed(1, &p);
        assert_eq!(one, composed(2, &p));
        assert_eq!(one, composed(3, &p));
        assert_ne!(one.0, one.1, "the drone still shows somewhere");
    }

    #[test]
    fn each_pixel_is_its_particles_blends_in_any_order() {
        // Against the blends one by one in f64, farthest first, over the
        // pixel's own value (the frame: only particles nearer than the
        // drone at its pixels), rounded at the end: within one level.
        let size = (200u32, 120u32);
        let p = particles(600);
        let (rgba, clear) = composed(2, &p);
        let (frame0, background, layer) = scene(size);
        let mut order: Vec<&Particle> = p.iter().collect();
        order.sort_by(|a, b| b.depth_m.total_cmp(&a.depth_m));
        let prepared: Vec<Prepared> = order.iter().map(|q| Prepared::of(q, size, None)).collect();
        let mut worst = 0.0f64;
        for y in 0..size.1 {
            for x in 0..size.0 {
                let depth = layer.depth(x, y);
                let at = (x as f32 + 0.5, y as f32 + 0.5);
                let under: Vec<(f32, f64)> = (order.iter().zip(&prepared))
                    .filter(|(_, pq)| {
                        let [x0, y0, x1, y1] = pq.bounds;
                        (x0..x1).contains(&x) && (y0..y1).contains(&y)
                    })
                    .map(|(q, pq)| (q.depth_m, f64::from(q.alpha * cover::coverage(pq, at))))
                    .collect();
                for (start, out, tested) in [(&frame0, &rgba, true), (&background, &clear, false)] {
                    let i = ((y * size.0 + x) * 4) as usize;
                    for c in 0..3 {
                        let mut v = f64::from(start[i + c]);
                        for &(_, a) in under.iter().filter(|(d, _)| !tested || *d < depth) {
                            v += (228.0 - v) * a;
                        }
                        worst = worst.max((v - f64::from(out[i + c])).abs());
                    }
                    assert_eq!(out[i + 3], start[i + 3]);
                }
            }
        }
        assert!(worst < 0.5 + 1e-3, "{worst}");
    }
}

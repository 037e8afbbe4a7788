//! The thermal picture's background (docs/realism.md, "Thermal camera"):
//! every pixel's radiance from its ray's sin(elevation) and the drone-free
//! visible background's colour there. Below the horizon the ground; above
//! it the clear sky by elevation ([`SkyTable`]), turned towards the
//! clouds' radiance by the pixel's greyness (HSV saturation under
//! `clear_saturation`) and towards the ground's where the pixel is coloured
//! but not blue (scenery).
//!
//! A ray's sin(elevation) is `(u·v) / |v|` for v = (vx, vy, 1) and u the
//! world's up in camera space; vx and vx² are made once per column, so a
//! row is one loop of adds, a square root and a division, then the sky
//! table's look-ups (one for a run of pixels that all read the same
//! entry), then the colours in a loop of f32 operations. A run of 256
//! pixels whose s provably stays in one table entry (its range bounded in
//! f64 with a margin over the f32 rounding) skips the per-pixel s
//! altogether (a narrow view's usual run); a row whose rays all point
//! below the horizon is the ground's, filled without them. Rows in bands on rayon's threads (each pixel is computed alone, so
//! the split does not change a bit).

use glam::{Vec2, Vec3};
use rayon::prelude::*;

use crate::preset::thermal::Thermal;

use super::{SKY_STEPS, Scratch, SkyTable};

/// The camera as the background needs it.
#[derive(Clone, Copy, Debug)]
pub struct View {
    pub width: u32,
    pub height: u32,
    /// The world's up in camera space (x right, y down, z forward).
    pub up: Vec3,
    pub focal_px: f32,
    /// The principal point, pixels.
    pub principal: Vec2,
}

/// Rows per band handed to a thread, and pixels per run of a row.
const BAND_ROWS: usize = 16;
const RUN: usize = 256;

/// The background's radiance at every pixel into `scratch.plane`
/// (row-major), from the drone-free visible `rgba` (pixels it lacks: the
/// clear sky's or the ground's).
pub fn sky_plane(t: &Thermal, sky: &SkyTable, view: &View, rgba: &[u8], scratch: &mut Scratch) {
    let (w, h) = (view.width as usize, view.height as usize);
    let (f, c) = (view.focal_px, view.principal);
    let slopes = &mut scratch.slopes;
    slopes.clear();
    slopes.extend((0..w).map(|x| (x as f32 + 0.5 - c.x) / f));
    slopes.extend_from_within(..w);
    let (vx, vx2) = slopes.split_at_mut(w);
    vx2.iter_mut().for_each(|v| *v *= *v);
    let (vx, vx2) = (&*vx, &*vx2);
    let plane = &mut scratch.plane;
    plane.resize(w * h, 0.0);
    let colour = Colour {
        clear_saturation: t.clear_saturation as f32,
        ground: sky.ground,
        cloud: sky.cloud,
    };
    (plane.par_chunks_mut(BAND_ROWS * w.max(1)).enumerate()).for_each(|(b, band)| {
        for (j, out) in band.chunks_exact_mut(w).enumerate() {
            let y = b * BAND_ROWS + j;
            let vy = (y as f32 + 0.5 - c.y) / f;
            let row = &rgba[(y * w * 4).min(rgba.len())..((y + 1) * w * 4).min(rgba.len())];
            let ray = Ray::row(view.up, vy);
            if ray.below_horizon(vx) {
                out.fill(sky.clear(-1.0));
            } else {
                sky_row(sky, &colour, (vx, vx2), &ray, row, out);
            }
        }
    });
}

/// Each pixel's share of ground and scenery in the background [`sky_plane`] draws
/// (into `out`, row-major): 1 where the ray points below the horizon (the same
/// sin(elevation) as the background's, so the same pixels), above it the share that
/// [`Colour::mix`] gives the ground's radiance (a pixel coloured but not blue, less
/// its greyness); 0 for clear sky, cloud, and pixels `rgba` lacks above the horizon.
/// Rows in bands on rayon's threads; a row wholly below the horizon is filled.
pub fn ground_share(clear_saturation: f32, view: &View, rgba: &[u8], out: &mut Vec<f32>) {
    let (w, h) = (view.width as usize, view.height as usize);
    let (f, c) = (view.focal_px, view.principal);
    let vx: Vec<f32> = (0..w).map(|x| (x as f32 + 0.5 - c.x) / f).collect();
    let vx2: Vec<f32> = vx.iter().map(|v| v * v).collect();
    out.clear();
    out.resize(w * h, 0.0);
    (out.par_chunks_mut(BAND_ROWS * w.max(1)).enumerate()).for_each(|(b, band)| {
        for (j, row_out) in band.chunks_exact_mut(w).enumerate() {
            let y = b * BAND_ROWS + j;
            let vy = (y as f32 + 0.5 - c.y) / f;
            let ray = Ray::row(view.up, vy);
            if ray.below_horizon(&vx) {
                row_out.fill(1.0);
                continue;
            }
            let row = &rgba[(y * w * 4).min(rgba.len())..((y + 1) * w * 4).min(rgba.len())];
            share_row(clear_saturation, (&vx, &vx2), &ray, row, row_out);
        }
    });
}

simd_fn! {
    /// One row's [`ground_share`]: a pixel's share from its colour (`rgba`, the row's
    /// pixels the picture has: none above the horizon past them), 1 where its ray's
    /// sin(elevation) is below 0.
    fn share_row(
        clear_saturation: f32,
        slopes: (&[f32], &[f32]),
        ray: &Ray,
        rgba: &[u8],
        out: &mut [f32],
    ) {
        let (vx, vx2) = slopes;
        let below = |vx: f32, vx2: f32| {
            (ray.up.x * vx + ray.up_y_vy + ray.up.z) / (vx2 + ray.vy2 + 1.0).sqrt() < 0.0
        };
        let have = (rgba.len() / 4).min(out.len());
        let (seen, past) = out.split_at_mut(have);
        for (((o, &v), &v2), px) in seen.iter_mut().zip(vx).zip(vx2).zip(rgba.chunks_exact(4)) {
            let share = scenery(px, clear_saturation);
            *o = if below(v, v2) { 1.0 } else { share };
        }
        for ((o, &v), &v2) in past.iter_mut().zip(&vx[have..]).zip(&vx2[have..]) {
            *o = if below(v, v2) { 1.0 } else { 0.0 };
        }
    }
}

/// The share of ground's radiance [`Colour::mix`] gives a pixel of colour `px` above
/// the horizon (no branch: a row of them vectorises).
#[inline(always)]
fn scenery(px: &[u8], clear_saturation: f32) -> f32 {
    let (grey, blue) = colour_class(px, clear_saturation);
    if blue { 0.0 } else { 1.0 - grey }
}

/// A visible pixel's greyness (1 − HSV saturation / `clear_saturation`, within 0–1: how
/// much of it is cloud) and whether it is blue (sky) rather than coloured (scenery).
#[inline(always)]
fn colour_class(px: &[u8], clear_saturation: f32) -> (f32, bool) {
    let (r, g, b) = (f32::from(px[0]), f32::from(px[1]), f32::from(px[2]));
    let (max, min) = (r.max(g).max(b), r.min(g).min(b));
    let sat = if max > 0.0 { (max - min) / max } else { 0.0 };
    ((1.0 - sat / clear_saturation).clamp(0.0, 1.0), b >= max)
}

/// One row's rays: the world's up and the row's share of the sums.
struct Ray {
    up: Vec3,
    up_y_vy: f32,
    vy2: f32,
}

impl Ray {
    /// The rays of the row whose vertical slope is `vy`, the world's up `up`.
    #[inline(always)]
    fn row(up: Vec3, vy: f32) -> Self {
        Self {
            up,
            up_y_vy: up.y * vy,
            vy2: vy * vy,
        }
    }

    /// Whether every ray of the row with these column slopes `vx` points
    /// below the horizon (its sin(elevation)'s numerator, which is monotonic
    /// in vx, under a margin at both ends: no pixel's quotient rounds to
    /// −0), so the row is the ground's whatever its colours.
    fn below_horizon(&self, vx: &[f32]) -> bool {
        const MARGIN: f32 = -1e-20;
        let numerator = |vx: f32| self.up.x * vx + self.up_y_vy + self.up.z;
        let ends = [vx.first(), vx.last()];
        ends.into_iter()
            .all(|v| v.is_some_and(|&v| numerator(v) < MARGIN))
    }

    /// The sky table's entry that every pixel of a run whose column slopes
    /// go from `v0` to `v1` reads, where the row's sin(elevation)
    /// s(vx) = (a·vx + b) / √(vx² + c) provably keeps to one entry and one
    /// side of the horizon over the run: its range there (in f64, from the
    /// ends and the one turning point, vx = a·c / b) widened by a bound on
    /// the f32 arithmetic's error (2⁻¹⁸ of the terms' size, where its few
    /// roundings stay under 2⁻²¹), both ends in one entry. Then the pixels need
    /// no s of their own (the colour mix asks only its sign).
    fn run_index(&self, (v0, v1): (f32, f32)) -> Option<u32> {
        let (a, b1, b2) = (
            f64::from(self.up.x),
            f64::from(self.up_y_vy),
            f64::from(self.up.z),
        );
        let (b, c) = (b1 + b2, f64::from(self.vy2) + 1.0);
        let (v0, v1) = (f64::from(v0.min(v1)), f64::from(v0.max(v1)));
        let g = |v: f64| (a * v + b) / (v * v + c).sqrt();
        let (mut lo, mut hi) = (g(v0).min(g(v1)), g(v0).max(g(v1)));
        let turn = a * c / b;
        if v0 < turn && turn < v1 {
            (lo, hi) = (lo.min(g(turn)), hi.max(g(turn)));
        }
        let margin = (a.abs() * v0.abs().max(v1.abs()) + b1.abs() + b2.abs() + 1.0) / 262_144.0;
        let (lo, hi) = (lo - margin, hi + margin);
        if !(lo.is_finite() && hi.is_finite()) || (lo < 0.0 && hi >= 0.0) {
            return None;
        }
        let steps = SKY_STEPS as f64;
        let index = |s: f64| {
            if s < 0.0 {
                SKY_STEPS as u32 + 1
            } else {
                (s * steps).min(steps).floor() as u32
            }
        };
        (index(lo) == index(hi)).then_some(index(lo))
    }
}

/// What a pixel's colour turns the sky towards.
struct Colour {
    clear_saturation: f32,
    ground: f32,
    cloud: f32,
}

simd_fn! {
    /// One row's background, `RUN` pixels at a time.
    fn sky_row(
        sky: &SkyTable,
        colour: &Colour,
        slopes: (&[f32], &[f32]),
        ray: &Ray,
        rgba: &[u8],
        out: &mut [f32],
    ) {
        let (vx, vx2) = slopes;
        let (mut s, mut clear) = ([0f32; RUN], [0f32; RUN]);
        let mut index = [0u32; RUN];
        for (k, out) in out.chunks_mut(RUN).enumerate() {
            let (x0, n) = (k * RUN, out.len());
            let pixels = rgba.get(x0 * 4..).unwrap_or_default().chunks_exact(4);
            let have = pixels.len().min(n);
            if let Some(i) = ray.run_index((vx[x0], vx[x0 + n - 1])) {
                // One entry, and every ray on one side of the horizon.
                let c = sky.entry(i);
                out.fill(c);
                if i as usize <= SKY_STEPS {
                    for (o, px) in out.iter_mut().zip(pixels) {
                        *o = colour.mix(px, 0.0, c);
                    }
                }
                continue;
            }
            let (s, clear) = (&mut s[..n], &mut clear[..n]);
            for ((s, vx), vx2) in s.iter_mut().zip(&vx[x0..x0 + n]).zip(&vx2[x0..x0 + n]) {
                *s = (ray.up.x * vx + ray.up_y_vy + ray.up.z) / (vx2 + ray.vy2 + 1.0).sqrt();
            }
            sky_run(sky, s, &mut index[..n], clear);
            for (((o, px), &s), &c) in out.iter_mut().zip(pixels).zip(s.iter()).zip(clear.iter()) {
                *o = colour.mix(px, s, c);
            }
            out[have..].copy_from_slice(&clear[have..]);
        }
    }
}

/// The clear sky's radiance at each sin(elevation) of a run (`s`), through
/// the table's indices (`index`): a single entry filled when the run reads
/// only one (a row's elevation changes slowly: most runs), else one
/// look-up a pixel.
#[inline(always)]
fn sky_run(sky: &SkyTable, s: &[f32], index: &mut [u32], clear: &mut [f32]) {
    for (k, &s) in index.iter_mut().zip(s) {
        *k = SkyTable::index(s);
    }
    let (mut lo, mut hi) = (u32::MAX, 0);
    for &k in index.iter() {
        (lo, hi) = (lo.min(k), hi.max(k));
    }
    if lo == hi {
        clear.fill(sky.entry(lo));
    } else {
        for (c, &k) in clear.iter_mut().zip(index.iter()) {
            *c = sky.entry(k);
        }
    }
}

impl Colour {
    /// The background's radiance at a pixel of colour `px` whose ray has
    /// sin(elevation) `s` and clear-sky radiance `clear`.
    #[inline(always)]
    fn mix(&self, px: &[u8], s: f32, clear: f32) -> f32 {
        let (grey, blue) = colour_class(px, self.clear_saturation);
        let clear_or_scenery = if blue { clear } else { self.ground };
        let cloud = self.cloud.max(clear);
        let mixed = clear_or_scenery + (cloud - clear_or_scenery) * grey;
        if s >= 0.0 { mixed } else { clear }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The background pixel by pixel as first written (what the banded,
    /// run-wise passes must equal bit for bit).
    fn plain(t: &Thermal, sky: &SkyTable, view: &View, rgba: &[u8]) -> Vec<f32> {
        let (w, h) = (view.width as usize, view.height as usize);
        let (up, f, c) = (view.up, view.focal_px, view.principal);
        let mut plane = Vec::new();
        for y in 0..h {
            let vy = (y as f32 + 0.5 - c.y) / f;
            let row = &rgba[(y * w * 4).min(rgba.len())..((y + 1) * w * 4).min(rgba.len())];
            for x in 0..w {
                let vx = (x as f32 + 0.5 - c.x) / f;
                let s = (up.x * vx + up.y * vy + up.z) / (vx * vx + vy * vy + 1.0).sqrt();
                let clear = sky.clear(s);
                let Some(px) = row.get(x * 4..x * 4 + 3).filter(|_| s >= 0.0) else {
                    plane.push(clear);
                    continue;
                };
                let (r, g, b) = (f32::from(px[0]), f32::from(px[1]), f32::from(px[2]));
                let (max, min) = (r.max(g).max(b), r.min(g).min(b));
                let sat = if max > 0.0 { (max - min) / max } else { 0.0 };
                let grey = (1.0 - sat / t.clear_saturation as f32).clamp(0.0, 1.0);
                let base = if b >= max { clear } else { sky.ground };
                let cloud = sky.cloud.max(clear);
                plane.push(base + (cloud - base) * grey);
            }
        }
        plane
    }

    /// A 300×100 view rolled and pitched so the horizon crosses the frame at a slant and
    /// the last rows lie wholly below it (wider than a run).
    fn slanted() -> ((u32, u32), View) {
        let (w, h) = (300u32, 100u32);
        let view = View {
            width: w,
            height: h,
            up: Vec3::new(0.2, -0.95, 0.24).normalize(),
            focal_px: 150.0,
            principal: Vec2::new(150.0, 20.0),
        };
        ((w, h), view)
    }

    #[test]
    fn the_banded_background_is_the_pixel_by_pixel_one() {
        let t = Thermal::default();
        let sky = SkyTable::new(&t);
        // The last rows missing from the picture.
        let ((w, h), view) = slanted();
        let rgba: Vec<u8> = (0..w * (h - 3) * 4)
            .map(|i| (i.wrapping_mul(2_654_435_761) >> 24) as u8)
            .collect();
        let mut scratch = Scratch::default();
        sky_plane(&t, &sky, &view, &rgba, &mut scratch);
        let want = plain(&t, &sky, &view, &rgba);
        assert_eq!(scratch.plane, want);
        assert!(want.iter().any(|&v| v != sky.ground));
        let ground_rows = want.chunks_exact(w as usize);
        let ground_rows = ground_rows.filter(|row| row.iter().all(|&v| v == sky.ground));
        assert!((5..30).contains(&ground_rows.count()));
    }

    /// The ground's share is 1 exactly where the background is the ground's radiance
    /// (below the horizon, saturated scenery), 0 on blue sky and cloud, and the share of
    /// the ground's radiance a greyish scenery pixel takes between.
    #[test]
    fn the_ground_share_is_where_the_background_takes_the_grounds_radiance() {
        let t = Thermal {
            cloud_k: 300.0,
            ..Thermal::default()
        };
        let sky = SkyTable::new(&t);
        let ((w, h), view) = slanted();
        // Blue sky; a green block (scenery), a grey block (cloud) and a greyish green
        // block (scenery half cloud) high in the frame; the last rows missing.
        let px = |x: u32, y: u32| -> [u8; 4] {
            match (x, y) {
                (0..60, 0..12) => [40, 160, 50, 255],
                (100..160, 0..12) => [150, 150, 150, 255],
                (200..260, 0..12) => [140, 160, 130, 255],
                _ => [90, 140, 230, 255],
            }
        };
        let rgba: Vec<u8> = (0..h - 3)
            .flat_map(|y| (0..w).flat_map(move |x| px(x, y)))
            .collect();
        let mut scratch = Scratch::default();
        sky_plane(&t, &sky, &view, &rgba, &mut scratch);
        let mut share = Vec::new();
        ground_share(t.clear_saturation as f32, &view, &rgba, &mut share);
        assert_eq!(share.len(), scratch.plane.len());
        let (mut ones, mut zeros, mut between) = (0, 0, 0);
        for (i, (&s, &v)) in share.iter().zip(&scratch.plane).enumerate() {
            match s {
                1.0 => {
                    assert_eq!(v, sky.ground, "pixel {i}");
                    ones += 1;
                }
                0.0 => {
                    assert_ne!(v, sky.ground, "pixel {i}");
                    zeros += 1;
                }
                s => {
                    // ground + (cloud − ground) · greyness, the cloud warmer than any sky.
                    let want = sky.ground + (sky.cloud - sky.ground) * (1.0 - s);
                    assert!(s > 0.0 && s < 1.0, "pixel {i}: {s}");
                    assert!((v - want).abs() <= 1e-5 * want, "pixel {i}: {v} for {want}");
                    between += 1;
                }
            }
        }
        assert!(
            ones > 1000 && zeros > 10_000 && between > 100,
            "{ones} {zeros} {between}"
        );
    }

    #[test]
    fn a_narrow_view_whose_runs_read_one_sky_entry_is_the_pixel_by_pixel_one() {
        let t = Thermal::default();
        let sky = SkyTable::new(&t);
        // Pitched up 5°, half a degree across: most runs read one entry.
        let (w, h) = (600u32, 6u32);
        let view = View {
            width: w,
            height: h,
            up: Vec3::new(0.0, -0.996, 0.0872).normalize(),
            focal_px: 60_000.0,
            principal: Vec2::new(300.0, 3.0),
        };
        let rgba: Vec<u8> = (0..w * h * 4).map(|i| (i * 7 % 251) as u8).collect();
        let mut scratch = Scratch::default();
        sky_plane(&t, &sky, &view, &rgba, &mut scratch);
        assert_eq!(scratch.plane, plain(&t, &sky, &view, &rgba));
    }

    /// Where a run's entry is taken as proven, every pixel's own s reads
    /// it, for level, rolled and steep views over rows crossing many
    /// entries (and the horizon); and a narrow view proves most runs.
    #[test]
    fn a_run_proven_to_read_one_entry_reads_it_at_every_pixel() {
        let ups = [
            Vec3::new(0.0, -0.996, 0.0872),
            Vec3::new(0.2, -0.95, 0.24).normalize(),
            Vec3::new(-0.05, -0.6, 0.8).normalize(),
            Vec3::new(0.0, -1.0, 0.0),
        ];
        for (u, up) in ups.into_iter().enumerate() {
            for focal in [7722.0f32, 900.0] {
                let vx: Vec<f32> = (0..1920)
                    .map(|x| (x as f32 + 0.5 - 960.0) / focal)
                    .collect();
                let (mut proven, mut runs) = (0, 0);
                for y in (0..2000).map(|y| y as f32 * 0.54 - 540.0) {
                    let vy = (y + 0.5) / focal;
                    let ray = Ray::row(up, vy);
                    for run in vx.chunks(RUN) {
                        runs += 1;
                        let Some(k) = ray.run_index((run[0], run[run.len() - 1])) else {
                            continue;
                        };
                        proven += 1;
                        for &v in run {
                            let s =
                                (up.x * v + ray.up_y_vy + up.z) / (v * v + ray.vy2 + 1.0).sqrt();
                            assert_eq!(SkyTable::index(s), k, "up {u}, f {focal}, vy {vy}, vx {v}");
                        }
                    }
                }
                assert!(proven < runs, "up {u}, f {focal}: every run proven");
                if u == 0 && focal > 1000.0 {
                    assert!(proven * 2 > runs, "narrow view: {proven} of {runs} runs");
                }
            }
        }
    }
}

//! A frame's rain or snow (`weather` in the preset, issue 41 item 4) as
//! plain data: the per-frame draws ([`FrameWeather`], recorded in the
//! manifest) and the particles they give ([`FrameWeather::particles`]),
//! each a streak in pixels with its depth. Drawn from the frame's own
//! salted stream (`seed::WEATHER_SALT`), so turning weather on shifts no
//! other draw, and a frame's particles depend on the preset and its index
//! only. The pipeline composites them (`pipeline::weather`).

use glam::{DVec2, DVec3};
use rand::Rng;
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use rayon::prelude::*;
use serde::Serialize;

use crate::preset::weather::{MAX_PARTICLES, Weather, WeatherKind};
use crate::seed;

use super::camera::Camera;
use super::realism::FrameAtmosphere;

/// The weather's draws of one frame.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct FrameWeather {
    pub kind: WeatherKind,
    pub intensity_per_m3: f64,
    pub wind_mps: f64,
    pub wind_dir_deg: f64,
    pub fall_mps: f64,
    pub exposure_s: f64,
    pub opacity: f64,
    /// The preset's per-particle diameter range, millimetres.
    pub diameter_mm: (f64, f64),
    /// The preset's volume, metres along the view axis.
    pub depth_m: (f64, f64),
    /// Seed of the particles' own stream (drawn last).
    pub particle_seed: u64,
}

/// One particle as the camera sees it: a disc of radius `radius_px` that
/// moves from `a` to `b` during the exposure, blended towards `level`
/// (sRGB, each channel) with `alpha` at full coverage. A flake (`solid`)
/// covers each pixel for the share of the exposure the moving disc is over
/// it (1 where it stays over it throughout); a drop's streak (not `solid`)
/// has its alpha all along the path.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Particle {
    pub a: [f32; 2],
    pub b: [f32; 2],
    pub radius_px: f32,
    pub alpha: f32,
    /// Distance along the view axis, metres: drones farther than this are behind it.
    pub depth_m: f32,
    pub level: u8,
    pub solid: bool,
}

fn uniform(rng: &mut ChaCha8Rng, (lo, hi): (f64, f64)) -> f64 {
    let u: f64 = rng.random();
    lo + (hi - lo) * u
}

/// The weather of frame `index`: seven draws in field order, then the particles' seed.
pub fn frame_weather(w: &Weather, preset_seed: u64, index: u64) -> FrameWeather {
    let mut rng = seed::salted_rng(preset_seed, index, seed::WEATHER_SALT);
    FrameWeather {
        kind: w.kind,
        intensity_per_m3: uniform(&mut rng, w.intensity_per_m3),
        wind_mps: uniform(&mut rng, w.wind_mps),
        wind_dir_deg: uniform(&mut rng, w.wind_dir_deg),
        fall_mps: uniform(&mut rng, w.fall_mps),
        exposure_s: uniform(&mut rng, w.exposure_s),
        opacity: uniform(&mut rng, w.opacity),
        diameter_mm: w.diameter_mm,
        depth_m: w.depth_m,
        particle_seed: rng.random(),
    }
}

/// The sRGB level a particle is drawn with: drops a light grey, flakes near white.
fn level(kind: WeatherKind) -> u8 {
    match kind {
        WeatherKind::Rain => 228,
        WeatherKind::Snow => 242,
    }
}

impl FrameWeather {
    /// A particle's travel during the exposure, camera frame, metres.
    fn travel(&self, camera: &Camera) -> DVec3 {
        let dir = self.wind_dir_deg.to_radians();
        let world = DVec3::new(
            self.wind_mps * dir.cos(),
            -self.fall_mps,
            self.wind_mps * dir.sin(),
        );
        camera.camera_from_world * world * self.exposure_s
    }

    /// The frame's particles, farthest first (the order they are blended
    /// in). The volume is the view's frustum between `depth_m`, widened by
    /// a particle's travel and size so streaks that enter the view are
    /// drawn; particles are uniform in it, `intensity_per_m3` per m³ (at
    /// most [`MAX_PARTICLES`]). Per particle: depth, x, y, diameter. With an
    /// atmosphere a particle's alpha is multiplied by its transmittance.
    pub fn particles(
        &self,
        camera: &Camera,
        atmosphere: Option<&FrameAtmosphere>,
    ) -> Vec<Particle> {
        let f = camera.focal_px();
        let (sx, sy) = (
            0.5 * f64::from(camera.width) / f,
            0.5 * f64::from(camera.height) / f,
        );
        let travel = self.travel(camera);
        let d_max = self.diameter_mm.1 * 1e-3;
        let (mx, my) = (travel.x.abs() + d_max, travel.y.abs() + d_max);
        let (near, far) = self.depth_m;
        // ∫ 4·(sx·z + mx)·(sy·z + my) dz: the widened frustum's volume.
        let prim = |z: f64| {
            4.0 * (sx * sy * z.powi(3) / 3.0 + (sx * my + sy * mx) * z * z / 2.0 + mx * my * z)
        };
        let count = (self.intensity_per_m3 * (prim(far) - prim(near)))
            .round()
            .clamp(0.0, MAX_PARTICLES) as usize;
        let area = |z: f64| (sx * z + mx) * (sy * z + my);
        let mut rng = ChaCha8Rng::seed_from_u64(self.particle_seed);
        // The draws in order (one stream), then each particle on its own.
        let drawn: Vec<(DVec3, f64)> = (0..count)
            .map(|_| {
                // z with density ∝ the cross-section (rejection against the far one).
                let z = loop {
                    let z = uniform(&mut rng, (near, far));
                    let keep: f64 = rng.random();
                    if keep * area(far) <= area(z) {
                        break z;
                    }
                };
                let x = uniform(&mut rng, (-(sx * z + mx), sx * z + mx));
                let y = uniform(&mut rng, (-(sy * z + my), sy * z + my));
                let d = uniform(&mut rng, self.diameter_mm) * 1e-3;
                (DVec3::new(x, y, z), d)
            })
            .collect();
        let view = View::of(camera);
        let out: Vec<Particle> = drawn
            .par_iter()
            .filter_map(|&(start, d)| self.particle(&view, (start, start + travel), d, atmosphere))
            .collect();
        farthest_first(out)
    }

    /// One particle from its travel (camera frame) and diameter; `None`
    /// when it leaves no mark in the image.
    fn particle(
        &self,
        view: &View,
        (start, end): (DVec3, DVec3),
        diameter_m: f64,
        atmosphere: Option<&FrameAtmosphere>,
    ) -> Option<Particle> {
        let (a, b) = (view.project(start)?, view.project(end)?);
        let z = 0.5 * (start.z + end.z);
        let r_px = 0.5 * diameter_m * view.focal / z;
        // Narrower than a pixel: drawn one pixel wide, fainter by its share.
        let r = r_px.max(0.5);
        let thin = r_px / r;
        let alpha = match self.kind {
            // A drop's streak: its opacity along a line `thin` of a pixel wide.
            WeatherKind::Rain => self.opacity * thin,
            // A flake: its opacity over the share of its pixel it covers (the
            // share of the exposure is the composite's, per pixel).
            WeatherKind::Snow => self.opacity * thin * thin,
        } * atmosphere.map_or(1.0, |t| t.transmittance(z));
        let (w, h) = view.size;
        let (lo, hi) = (
            a.min(b) - DVec2::splat(r + 1.0),
            a.max(b) + DVec2::splat(r + 1.0),
        );
        if alpha * 255.0 < 0.5 || hi.x < 0.0 || hi.y < 0.0 || lo.x > w || lo.y > h {
            return None;
        }
        Some(Particle {
            a: [a.x as f32, a.y as f32],
            b: [b.x as f32, b.y as f32],
            radius_px: r as f32,
            alpha: alpha.min(1.0) as f32,
            depth_m: z as f32,
            level: level(self.kind),
            solid: self.kind == WeatherKind::Snow,
        })
    }
}

/// The camera's pinhole as the particles use it, its focal length solved
/// once (`Camera::project_camera_point`'s formula).
struct View {
    focal: f64,
    centre: DVec2,
    size: (f64, f64),
}

impl View {
    fn of(camera: &Camera) -> Self {
        Self {
            focal: camera.focal_px(),
            centre: camera.principal_point(),
            size: (f64::from(camera.width), f64::from(camera.height)),
        }
    }

    fn project(&self, p: DVec3) -> Option<DVec2> {
        if p.z.is_nan() || p.z <= 0.0 {
            return None;
        }
        let (f, c) = (self.focal, self.centre);
        Some(DVec2::new(f * p.x / p.z + c.x, f * p.y / p.z + c.y))
    }
}

/// `particles` farthest first, equal depths in drawn order: a stable
/// radix sort (three passes of 11 bits) of the depths' keys, each carried
/// with its index (the order a sort of (depth, index) keys gives).
fn farthest_first(particles: Vec<Particle>) -> Vec<Particle> {
    // f32's total order as unsigned keys, reversed: farthest first.
    let far_key = |d: f32| {
        let b = d.to_bits();
        let ordered = if b >> 31 == 1 { !b } else { b | 1 << 31 };
        u64::from(!ordered) << 32
    };
    let mut keys: Vec<u64> = (particles.iter().enumerate())
        .map(|(i, p)| far_key(p.depth_m) | i as u64)
        .collect();
    let mut spare = vec![0u64; keys.len()];
    for shift in [32, 43, 54] {
        let digit = |k: u64| ((k >> shift) & 0x7ff) as usize;
        let mut start = [0usize; 2048];
        for &k in &keys {
            start[digit(k)] += 1;
        }
        let mut sum = 0;
        for s in start.iter_mut() {
            (*s, sum) = (sum, sum + *s);
        }
        for &k in &keys {
            let d = digit(k);
            spare[start[d]] = k;
            start[d] += 1;
        }
        std::mem::swap(&mut keys, &mut spare);
    }
    keys.iter()
        .map(|k| particles[(k & u64::from(u32::MAX)) as usize])
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn farthest_first_is_a_stable_sort_by_depth() {
        let mut rng = ChaCha8Rng::seed_from_u64(7);
        let particles: Vec<Particle> = (0..5000)
            .map(|i| Particle {
                a: [i as f32, 0.0],
                b: [0.0; 2],
                radius_px: 1.0,
                alpha: 1.0,
                // Ties, zeros and the range's extremes among them.
                depth_m: match i % 7 {
                    0 => 3.0,
                    1 => 0.0,
                    2 => -0.0,
                    _ => rng.random_range(0.05f32..1000.0),
                },
                level: 0,
                solid: false,
            })
            .collect();
        let mut want = particles.clone();
        want.sort_by(|p, q| q.depth_m.total_cmp(&p.depth_m));
        assert_eq!(farthest_first(particles), want);
    }
}

//! A frame's rain or snow (`weather` in the preset, issue 41 item 4) as
//! plain data: the per-frame draws ([`FrameWeather`], recorded in the
//! manifest) and the particles they give ([`FrameWeather::particles`]),
//! each a streak in pixels with its depth. Drawn from the frame's own
//! salted stream (`seed::WEATHER_SALT`), so turning weather on shifts no
//! other draw, and a frame's particles depend on the preset and its index
//! only. The pipeline composites them (`pipeline::weather`).

use glam::{DVec2, DVec3};
use rand::Rng;
use rand_chacha::ChaCha8Rng;
use rayon::prelude::*;
use serde::Serialize;

use crate::preset::weather::{MAX_PARTICLES, Weather, WeatherKind};
use crate::seed;

use super::camera::Camera;
use super::realism::FrameAtmosphere;

#[cfg(target_arch = "x86_64")]
mod lanes;

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
/// moves from `a` to `b` during the exposure, blended towards the frame's
/// level ([`FrameWeather::level`]) with `alpha` at full coverage. A flake (`solid`)
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
    pub solid: bool,
}

impl Particle {
    /// A placeholder for slots not yet made (no mark: zero radius and alpha).
    const NONE: Self = Self {
        a: [0.0; 2],
        b: [0.0; 2],
        radius_px: 0.0,
        alpha: 0.0,
        depth_m: 0.0,
        solid: false,
    };
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

    /// The frame's particles, in the order they are drawn (index order;
    /// the composite does not depend on it). The volume is the view's
    /// frustum between `depth_m`, widened by a particle's travel and size
    /// so streaks that enter the view are drawn; particles are uniform in
    /// it, `intensity_per_m3` per m³ (at most [`MAX_PARTICLES`]). Particle
    /// i's four draws (depth, x, y, diameter) are [`Draws`]' 4i … 4i + 3,
    /// so the particles are made in parallel and each is the same on any
    /// thread. With an atmosphere a particle's alpha is multiplied by its
    /// transmittance.
    pub fn particles(
        &self,
        camera: &Camera,
        atmosphere: Option<&FrameAtmosphere>,
    ) -> Vec<Particle> {
        let mut out = Vec::new();
        self.particles_into(camera, atmosphere, &mut out);
        out
    }

    /// [`FrameWeather::particles`] into `out` (cleared first; a buffer
    /// kept from frame to frame is filled without fresh pages).
    pub fn particles_into(
        &self,
        camera: &Camera,
        atmosphere: Option<&FrameAtmosphere>,
        out: &mut Vec<Particle>,
    ) {
        #[cfg(target_arch = "x86_64")]
        let lanes = crate::simd::simd_level() >= 1;
        #[cfg(not(target_arch = "x86_64"))]
        let lanes = false;
        self.particles_made(camera, atmosphere, out, lanes);
    }

    /// [`FrameWeather::particles_into`], sixteen at once in AVX2 when
    /// `lanes` is set (the CPU must have AVX2) and the depths are a range.
    fn particles_made(
        &self,
        camera: &Camera,
        atmosphere: Option<&FrameAtmosphere>,
        out: &mut Vec<Particle>,
        lanes: bool,
    ) {
        let f = camera.focal_px();
        let (sx, sy) = (
            0.5 * f64::from(camera.width) / f,
            0.5 * f64::from(camera.height) / f,
        );
        let travel = self.travel(camera);
        let d_max = self.diameter_mm.1 * 1e-3;
        let frustum = Frustum {
            s: (sx, sy),
            m: (travel.x.abs() + d_max, travel.y.abs() + d_max),
            depth: self.depth_m,
        };
        let count = (self.intensity_per_m3 * frustum.volume())
            .round()
            .clamp(0.0, MAX_PARTICLES) as u64;
        let depths = DepthTable::of(&frustum);
        let maker = Maker {
            weather: self,
            draws: Draws(self.particle_seed),
            depths: &depths,
            view: &View::of(camera),
            travel,
            atmosphere,
        };
        #[cfg(target_arch = "x86_64")]
        if lanes && frustum.depth.1 > frustum.depth.0 {
            // In place in `out` (no fresh pages once grown): calls of
            // sixteen slots each (at most MAX_PARTICLES / 16), each call's
            // particles at the head of its slots, then moved up in order.
            const N: usize = lanes::LANES;
            let calls = count.div_ceil(N as u64) as usize;
            // Slots kept from the frame before are overwritten as made, not
            // cleared first: only the particles each call makes are read.
            out.truncate(calls * N);
            out.resize(calls * N, Particle::NONE);
            let mut made = vec![0u8; calls];
            (out.as_chunks_mut::<N>().0.par_iter_mut())
                .zip(made.par_iter_mut())
                .enumerate()
                .with_min_len(64)
                .for_each(|(q, (slots, made))| {
                    // SAFETY: the CPU has AVX2 (the caller's `lanes`).
                    #[allow(unsafe_code)]
                    let k = unsafe { lanes::sixteen(&maker, (q * N) as u64, count, slots) };
                    *made = k as u8;
                });
            let mut kept = 0;
            for (q, &k) in made.iter().enumerate() {
                out.copy_within(q * N..q * N + usize::from(k), kept);
                kept += usize::from(k);
            }
            out.truncate(kept);
            return;
        }
        #[cfg(not(target_arch = "x86_64"))]
        let _ = lanes;
        out.clear();
        out.par_extend((0..count).into_par_iter().filter_map(|i| maker.one(i)));
    }

    /// The particles' level, sRGB (each channel): every particle of a frame has it.
    pub fn level(&self) -> u8 {
        level(self.kind)
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
        self.mark(view, (a, b), (z, r_px), atmosphere)
    }

    /// The particle projected from `a` to `b`, its depth `z` and radius
    /// `r_px`; `None` when it leaves no mark in the image.
    fn mark(
        &self,
        view: &View,
        (a, b): (DVec2, DVec2),
        (z, r_px): (f64, f64),
        atmosphere: Option<&FrameAtmosphere>,
    ) -> Option<Particle> {
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
            solid: self.kind == WeatherKind::Snow,
        })
    }
}

/// What making a frame's particles needs, solved once a frame: particle i
/// is [`Maker::one`]`(i)` (and in AVX2 sixteen at once, `weather/lanes.rs`).
struct Maker<'a> {
    weather: &'a FrameWeather,
    draws: Draws,
    depths: &'a DepthTable<'a>,
    view: &'a View,
    /// A particle's travel during the exposure, camera frame, metres.
    travel: DVec3,
    atmosphere: Option<&'a FrameAtmosphere>,
}

impl Maker<'_> {
    /// Particle `i` from its four draws: depth, x, y (uniform over the
    /// cross-section at that depth) and diameter.
    fn one(&self, i: u64) -> Option<Particle> {
        let [uz, ux, uy, ud] = self.draws.of(i);
        let z = self.depths.depth(uz);
        let (hx, hy) = self.depths.frustum.half_width(z);
        let start = DVec3::new(hx * (2.0 * ux - 1.0), hy * (2.0 * uy - 1.0), z);
        let (lo, hi) = self.weather.diameter_mm;
        let d = (lo + (hi - lo) * ud) * 1e-3;
        (self.weather).particle(self.view, (start, start + self.travel), d, self.atmosphere)
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

/// The widened frustum of [`FrameWeather::particles`]: at depth z its
/// cross-section is 2·(sx·z + mx) × 2·(sy·z + my) metres, between `depth`.
struct Frustum {
    s: (f64, f64),
    m: (f64, f64),
    depth: (f64, f64),
}

/// Newton steps [`Frustum::depth_at`] takes at most (it needs about five).
const MAX_STEPS: usize = 60;

impl Frustum {
    /// Half the cross-section's sides at depth `z`, metres.
    fn half_width(&self, z: f64) -> (f64, f64) {
        (self.s.0 * z + self.m.0, self.s.1 * z + self.m.1)
    }

    /// The cross-section's area at depth `z`, m².
    fn area(&self, z: f64) -> f64 {
        let (hx, hy) = self.half_width(z);
        4.0 * hx * hy
    }

    /// ∫₀ᶻ area: a cubic in z.
    fn prim(&self, z: f64) -> f64 {
        let ((sx, sy), (mx, my)) = (self.s, self.m);
        4.0 * (sx * sy * (z * z * z) / 3.0 + (sx * my + sy * mx) * (z * z) / 2.0 + mx * my * z)
    }

    /// The volume between the depths, m³.
    fn volume(&self) -> f64 {
        self.prim(self.depth.1) - self.prim(self.depth.0)
    }

    /// The depth whose share of the volume nearer than it is `u` (0–1):
    /// the inverse of the cubic CDF, by Newton's method on the convex,
    /// rising `prim` from `far · u^¼` (at or above the root, or one step
    /// from above it), with IEEE operations only (the same bytes everywhere).
    fn depth_at(&self, u: f64) -> f64 {
        let (near, far) = self.depth;
        if far.partial_cmp(&near) != Some(std::cmp::Ordering::Greater) {
            return near;
        }
        let base = self.prim(near);
        let target = base + u * (self.prim(far) - base);
        let mut z = (far * u.sqrt().sqrt()).clamp(near, far);
        for _ in 0..MAX_STEPS {
            let step = (self.prim(z) - target) / self.area(z);
            z = (z - step).clamp(near, far);
            if step.abs() <= 1e-12 * far {
                break;
            }
        }
        z
    }
}

/// Knots of [`DepthTable`]: the inverse CDF at every 1/KNOTS of the volume.
const KNOTS: usize = 1024;

/// The inverse of a frustum's cubic CDF, fast: solved exactly
/// ([`Frustum::depth_at`]) at [`KNOTS`] + 1 shares of the volume once a
/// frame, a draw's depth then interpolated between its knots and refined
/// by Newton's method until a step is below 1e-7 of the far depth (one
/// or two steps; IEEE operations only: the same bytes everywhere).
struct DepthTable<'a> {
    frustum: &'a Frustum,
    knots: Vec<f64>,
    /// prim(near) and the volume.
    base: f64,
    volume: f64,
}

impl<'a> DepthTable<'a> {
    fn of(frustum: &'a Frustum) -> Self {
        let knots = (0..=KNOTS)
            .map(|k| frustum.depth_at(k as f64 / KNOTS as f64))
            .collect();
        Self {
            frustum,
            knots,
            base: frustum.prim(frustum.depth.0),
            volume: frustum.volume(),
        }
    }

    /// The depth whose share of the volume nearer than it is `u` (0–1).
    fn depth(&self, u: f64) -> f64 {
        let (near, far) = self.frustum.depth;
        if far.partial_cmp(&near) != Some(std::cmp::Ordering::Greater) {
            return near;
        }
        let at = u * KNOTS as f64;
        let k = (at as usize).min(KNOTS - 1);
        let (z0, z1) = (self.knots[k], self.knots[k + 1]);
        let mut z = z0 + (at - k as f64) * (z1 - z0);
        let (target, f) = (self.base + u * self.volume, self.frustum);
        for _ in 0..MAX_STEPS {
            let step = (f.prim(z) - target) / f.area(z);
            z = (z - step).clamp(near, far);
            if step.abs() <= 1e-7 * far {
                break;
            }
        }
        z
    }
}

/// Counter-based draws: draw k of the stream is SplitMix64's k-th output
/// from `seed` (`mix64(seed + (k + 1)·γ)`, γ = 0x9E3779B97F4A7C15), any
/// one of them made without the others.
#[derive(Clone, Copy)]
struct Draws(u64);

impl Draws {
    const GAMMA: u64 = 0x9E37_79B9_7F4A_7C15;

    fn bits(self, k: u64) -> u64 {
        seed::mix64((self.0).wrapping_add(k.wrapping_add(1).wrapping_mul(Self::GAMMA)))
    }

    /// Particle `i`'s four uniform draws in [0, 1): draws 4i … 4i + 3, each's top 53 bits.
    fn of(self, i: u64) -> [f64; 4] {
        let unit = |k: u64| (self.bits(k) >> 11) as f64 * (1.0 / (1u64 << 53) as f64);
        let k = i.wrapping_mul(4);
        [unit(k), unit(k + 1), unit(k + 2), unit(k + 3)]
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn draws_are_splitmix64s_stream() {
        let seed = 0x0123_4567_89ab_cdef;
        let mut state: u64 = seed;
        let draws = Draws(seed);
        for k in 0..1000 {
            state = state.wrapping_add(Draws::GAMMA);
            assert_eq!(draws.bits(k), seed::mix64(state), "draw {k}");
        }
        let [a, b, c, d] = draws.of(3);
        let unit = |k| (draws.bits(k) >> 11) as f64 / (1u64 << 53) as f64;
        assert_eq!([a, b, c, d], [unit(12), unit(13), unit(14), unit(15)]);
    }

    #[cfg(target_arch = "x86_64")]
    #[test]
    fn lanes_make_the_scalar_particles_bit_for_bit() {
        if !std::arch::is_x86_feature_detected!("avx2") {
            eprintln!("no AVX2 here: the lanes are not run");
            return;
        }
        use rand::SeedableRng;
        let mut rng = ChaCha8Rng::seed_from_u64(41);
        let bits = |ps: &[Particle]| -> Vec<([u32; 7], bool)> {
            (ps.iter())
                .map(|p| {
                    let f = [
                        p.a[0],
                        p.a[1],
                        p.b[0],
                        p.b[1],
                        p.radius_px,
                        p.alpha,
                        p.depth_m,
                    ];
                    (f.map(f32::to_bits), p.solid)
                })
                .collect()
        };
        // Rain and snow, every range the preset allows and its edges: a
        // depth range a hair thick or from a millimetre, winds across the
        // view and along it, cameras turned anywhere, with and without an
        // atmosphere; counts that are not a multiple of sixteen.
        let depths: [(f64, f64); 5] = [
            (0.5, 25.0),
            (0.001, 3.0),
            (1.0, 1.000_000_1),
            (2.0, 400.0),
            (0.3, 0.5),
        ];
        let (mut made, mut empty) = (0, 0);
        for case in 0..60 {
            let depth_m = depths[case % depths.len()];
            let weather = FrameWeather {
                kind: [WeatherKind::Rain, WeatherKind::Snow][case % 2],
                // Up to thousands of particles in each (a billion per m³ in the
                // thinnest; in the deepest most are too faint to be drawn).
                intensity_per_m3: match depth_m.1 - depth_m.0 {
                    t if t < 1e-3 => 1e9,
                    t if t > 100.0 => 1e5 / depth_m.1.powi(3),
                    _ => 3000.0 / depth_m.1.powi(3),
                } * rng.random::<f64>(),
                wind_mps: 20.0 * rng.random::<f64>(),
                wind_dir_deg: 360.0 * rng.random::<f64>(),
                fall_mps: 10.0 * rng.random::<f64>(),
                exposure_s: 0.05 * rng.random::<f64>(),
                opacity: rng.random(),
                diameter_mm: (0.5, 0.5 + 5.0 * rng.random::<f64>()),
                depth_m,
                particle_seed: rng.random(),
            };
            let at = DVec3::new(rng.random(), rng.random(), rng.random()) * 20.0;
            let look = at + DVec3::new(rng.random::<f64>() - 0.5, rng.random::<f64>() - 0.5, 1.0);
            let camera = Camera {
                width: 64 + rng.random_range(0..1900),
                height: 48 + rng.random_range(0..1000),
                fov_y_deg: 5.0 + 150.0 * rng.random::<f64>(),
                position: at,
                camera_from_world: crate::scene::math::look_at_cv(at, look).expect("look-at"),
                near_m: 0.01,
            };
            let air = FrameAtmosphere {
                visibility_m: 50.0 + 1000.0 * rng.random::<f64>(),
            };
            for atmosphere in [None, Some(&air)] {
                let (mut scalar, mut lanes) = (Vec::new(), Vec::new());
                weather.particles_made(&camera, atmosphere, &mut scalar, false);
                weather.particles_made(&camera, atmosphere, &mut lanes, true);
                assert_eq!(bits(&lanes), bits(&scalar), "case {case}: {weather:?}");
                made += scalar.len();
                empty += usize::from(scalar.is_empty());
            }
        }
        // The comparisons are not empty ones.
        assert!(
            made > 20_000 && empty < 12,
            "{made} particles, {empty} cases with none"
        );
    }

    /// Rain's frustum at 1920×1080 with a 60° field of view.
    fn frustum() -> Frustum {
        let f = 960.0 / (30f64.to_radians().tan());
        Frustum {
            s: (960.0 / f, 540.0 / f),
            m: (0.12, 0.09),
            depth: (0.5, 25.0),
        }
    }

    #[test]
    fn depth_at_inverts_the_volume_share() {
        let fr = frustum();
        let (near, far) = fr.depth;
        for i in 0..=1000 {
            let u = f64::from(i) / 1000.0;
            let z = fr.depth_at(u);
            assert!((near..=far).contains(&z), "{u}: {z}");
            let share = (fr.prim(z) - fr.prim(near)) / fr.volume();
            assert!((share - u).abs() < 1e-9, "{u}: {z} holds {share}");
        }
        // The table's depths: the same within 1e-9 m, at and between knots.
        let table = DepthTable::of(&fr);
        for i in 0..=10_000 {
            let u = f64::from(i) / 10_000.0;
            let (z, exact) = (table.depth(u), fr.depth_at(u));
            assert!((z - exact).abs() < 1e-9, "{u}: {z} against {exact}");
        }
        let flat = Frustum {
            depth: (3.0, 3.0),
            ..frustum()
        };
        assert_eq!(flat.depth_at(0.7), 3.0);
        assert_eq!(DepthTable::of(&flat).depth(0.7), 3.0);
    }

    #[test]
    fn depths_follow_the_cross_section() {
        // 200 000 depths of one stream in 20 bins of equal width against
        // each bin's share of the volume: every bin within 5 σ of its
        // binomial expectation, and χ² below its 99.9 % point (43.8 for 19
        // degrees of freedom).
        let fr = frustum();
        let (near, far) = fr.depth;
        let (n, bins) = (200_000u64, 20usize);
        let mut counts = vec![0u64; bins];
        let (draws, table) = (Draws(41), DepthTable::of(&fr));
        for i in 0..n {
            let z = table.depth(draws.of(i)[0]);
            let bin = ((z - near) / (far - near) * bins as f64) as usize;
            counts[bin.min(bins - 1)] += 1;
        }
        let edge = |k: usize| near + (far - near) * k as f64 / bins as f64;
        let mut chi2 = 0.0;
        for (k, &c) in counts.iter().enumerate() {
            let p = (fr.prim(edge(k + 1)) - fr.prim(edge(k))) / fr.volume();
            let (mean, var) = (n as f64 * p, n as f64 * p * (1.0 - p));
            assert!(
                (c as f64 - mean).abs() < 5.0 * var.sqrt(),
                "bin {k}: {c} against {mean:.0}"
            );
            chi2 += (c as f64 - mean).powi(2) / mean;
        }
        assert!(chi2 < 43.8, "χ² {chi2:.1}");
    }
}

//! The camera model's auto-exposure meter (`camera_model.auto_exposure`):
//! the picture a frame's sky draws behind everything else, evaluated on the
//! CPU along a coarse grid of the camera's rays, and the exposure that
//! brings its mean 8-bit luminance level to a target.
//!
//! What is metered is the background as the renderer draws it before the
//! camera's exposure: for a procedural environment the Preetham sky, the
//! cloud layer, the far and near silhouettes, the ground and their haze,
//! each as `shaders/environment.wgsl` shades it (the same noise, in the same
//! order); for a gradient sky its zenith-to-horizon blend and hazy ground
//! (`shaders/sky.wgsl`); for an image sky its pixels in the rays'
//! directions, turned, exposed and tone-mapped as `image_sky` does
//! ([`image_samples`]); for a backplate its pixels ([`rgba_samples`]). The
//! sun disc, the scenery (`clutter`) and the drones are not metered: they
//! cover a small part of a frame, and a camera that meters the whole picture
//! would move with each drone.
//!
//! The exposure is found by bisection on the EV (the mean level grows with
//! the gain) on a 1/64-stop grid, as a camera's exposure steps are, so that
//! a last-bit difference in a machine's `exp` or `powf` can move it only
//! where the level sits on a step's edge.

use glam::{DMat3, DVec3, Vec2, Vec3};

use crate::simd::math::{fract, smoothstep};

use super::noise::{fbm, silhouette_height, step, vnoise};
use super::{
    EnvironmentStyle, FrameEnvironment, FrameSky, Ground, Preetham, SKY_EXPOSURE, SkyImage,
    SkyImageKind, gradient_lighting, linear_to_srgb, procedural_lighting, tone_map,
};

/// The grid of rays the meter samples: columns and rows over the frame.
pub const GRID: (u32, u32) = (32, 18);

/// The metered EV's range: a camera's exposure has limits.
pub const MAX_METERED_EV: f64 = 10.0;

/// Steps of the metered EV per stop.
const EV_STEPS: f64 = 64.0;

/// Distances (metres) the far silhouette (hills, mountains, skyline) and the
/// near one (tree line) stand for when a frame's atmosphere hazes them.
pub const FAR_SILHOUETTE_M: f64 = 8_000.0;
pub const NEAR_SILHOUETTE_M: f64 = 600.0;

/// The noise patterns' offset (environment.wgsl `pattern.xy`) of a pattern
/// seed, kept small for f32 noise precision.
pub fn pattern_offset(seed: u32) -> [f32; 2] {
    [
        (seed & 0xffff) as f32 / 65536.0 * 97.0,
        (seed >> 16) as f32 / 65536.0 * 89.0,
    ]
}

/// What the meter looks through: the camera's size, focal length (pixels)
/// and rotation from world to camera (OpenCV axes: x right, y down, z ahead).
#[derive(Clone, Copy, Debug)]
pub struct View {
    pub width: u32,
    pub height: u32,
    pub focal_px: f64,
    pub camera_from_world: DMat3,
}

/// The background's display-linear colours, before the camera's exposure,
/// along the [`GRID`] of `view`'s rays (pixel centres of a coarse grid);
/// `None` for an image sky.
pub fn background_samples(
    sky: &FrameSky,
    env: &FrameEnvironment,
    view: &View,
    atmosphere_visibility_m: Option<f64>,
) -> Option<Vec<Vec3>> {
    let sun = env.sun_direction().as_vec3();
    let shade: Box<dyn Fn(Vec3) -> Vec3> = match *sky {
        FrameSky::Image { .. } => return None,
        FrameSky::Gradient { zenith, horizon } => {
            let lighting = gradient_lighting(sun, zenith, horizon);
            let (zenith, horizon, ground) = (
                Vec3::from(lighting.zenith),
                Vec3::from(lighting.horizon),
                Vec3::from(lighting.ground),
            );
            Box::new(move |dir: Vec3| {
                if dir.y >= 0.0 {
                    horizon.lerp(zenith, dir.y.powf(0.45))
                } else {
                    (horizon * 0.85).lerp(ground, (-dir.y * 6.0).clamp(0.0, 1.0))
                }
            })
        }
        FrameSky::Procedural {
            environment,
            exposure,
            sun: sunlight,
        } => {
            let p = Procedural::new(
                environment.style(),
                env,
                (exposure, sunlight),
                atmosphere_visibility_m,
            );
            Box::new(move |dir: Vec3| p.shade(dir))
        }
    };
    Some(along_rays(view, |dir| shade(dir).max(Vec3::ZERO)))
}

/// `shade` of each [`GRID`] ray of `view` (the world direction through a
/// coarse grid's pixel centres).
fn along_rays(view: &View, mut shade: impl FnMut(Vec3) -> Vec3) -> Vec<Vec3> {
    let (cols, rows) = GRID;
    let world_from_camera = view.camera_from_world.transpose();
    let (cx, cy) = (f64::from(view.width) * 0.5, f64::from(view.height) * 0.5);
    let f = view.focal_px.max(1e-9);
    let mut out = Vec::with_capacity((cols * rows) as usize);
    for j in 0..rows {
        for i in 0..cols {
            let x = (f64::from(i) + 0.5) / f64::from(cols) * f64::from(view.width);
            let y = (f64::from(j) + 0.5) / f64::from(rows) * f64::from(view.height);
            let ray = DVec3::new((x - cx) / f, (y - cy) / f, 1.0);
            out.push(shade(
                (world_from_camera * ray).normalize_or(DVec3::Z).as_vec3(),
            ));
        }
    }
    out
}

/// An image sky's display values (before the camera's exposure) along the
/// [`GRID`] of `view`'s rays: the nearest texel in each ray's direction,
/// the image turned by `rotation_deg`, times `exposure`, tone-mapped when the
/// image is HDR and clipped otherwise (environment.wgsl's `image_sky`).
pub fn image_samples(image: &SkyImage, exposure: f32, rotation_deg: f64, view: &View) -> Vec<Vec3> {
    let (s, c) = (rotation_deg as f32).to_radians().sin_cos();
    along_rays(view, |dir| {
        // `rotate_y(dir, -rotation)`.
        let d = Vec3::new(dir.x * c - dir.z * s, dir.y, dir.x * s + dir.z * c);
        let v = texel(&image.kind, d) * exposure;
        if image.hdr {
            tone_map(v)
        } else {
            v.min(Vec3::ONE)
        }
        .max(Vec3::ZERO)
    })
}

/// The texel of `kind` in direction `d` (nearest).
fn texel(kind: &SkyImageKind, d: Vec3) -> Vec3 {
    let at = |rgb: &[f32], width: u32, height: u32, u: f32, v: f32| {
        let x = ((u * width as f32) as u32).min(width.saturating_sub(1)) as usize;
        let y = ((v * height as f32) as u32).min(height.saturating_sub(1)) as usize;
        let k = (y * width as usize + x) * 3;
        rgb.get(k..k + 3)
            .map_or(Vec3::ZERO, |p| Vec3::new(p[0], p[1], p[2]))
    };
    match kind {
        SkyImageKind::Equirect { width, height, rgb } => {
            let az = d.x.atan2(d.z);
            let u = fract(0.5 - az / std::f32::consts::TAU);
            let v = d.y.clamp(-1.0, 1.0).acos() / std::f32::consts::PI;
            at(rgb, *width, *height, u, v)
        }
        SkyImageKind::Cubemap { side, faces } => {
            // The cube map face and its (s, t) as Vulkan selects them.
            let a = d.abs();
            let (face, sc, tc, ma) = if a.x >= a.y && a.x >= a.z {
                if d.x > 0.0 {
                    (0, -d.z, -d.y, a.x)
                } else {
                    (1, d.z, -d.y, a.x)
                }
            } else if a.y >= a.z {
                if d.y > 0.0 {
                    (2, d.x, d.z, a.y)
                } else {
                    (3, d.x, -d.z, a.y)
                }
            } else if d.z > 0.0 {
                (4, d.x, -d.y, a.z)
            } else {
                (5, -d.x, -d.y, a.z)
            };
            let ma = ma.max(1e-9);
            let (u, v) = (0.5 * (sc / ma + 1.0), 0.5 * (tc / ma + 1.0));
            faces
                .get(face)
                .map_or(Vec3::ZERO, |f| at(f, *side, *side, u, v))
        }
    }
}

/// The linear colours of an RGBA8 (sRGB) picture of `size` (a backplate)
/// at the [`GRID`]'s pixel centres: what a background that is a picture
/// shows before the exposure.
pub fn rgba_samples(rgba: &[u8], (width, height): (u32, u32)) -> Vec<Vec3> {
    let decode = |c: u8| super::srgb_to_linear(c) as f32;
    let (cols, rows) = GRID;
    let mut out = Vec::with_capacity((cols * rows) as usize);
    for j in 0..rows {
        for i in 0..cols {
            let x = ((2 * i + 1) * width / (2 * cols)).min(width.saturating_sub(1));
            let y = ((2 * j + 1) * height / (2 * rows)).min(height.saturating_sub(1));
            let k = (y as usize * width as usize + x as usize) * 4;
            if let Some(p) = rgba.get(k..k + 3) {
                out.push(Vec3::new(decode(p[0]), decode(p[1]), decode(p[2])));
            }
        }
    }
    out
}

/// The mean 8-bit luminance level (Rec. 601 weights on the sRGB-encoded
/// channels, as `swarmshot gap` measures brightness) of `samples` under
/// the linear `gain`, clipped at white.
pub fn mean_level(samples: &[Vec3], gain: f32) -> f64 {
    if samples.is_empty() {
        return 0.0;
    }
    let sum: f64 = samples
        .iter()
        .map(|c| {
            let e = |v: f32| f64::from(linear_to_srgb(v * gain));
            0.299 * e(c.x) + 0.587 * e(c.y) + 0.114 * e(c.z)
        })
        .sum();
    255.0 * sum / samples.len() as f64
}

/// The EV (within ±[`MAX_METERED_EV`], in 1/64 stops) under which
/// `samples`' [`mean_level`] is nearest `target_level` from below.
pub fn exposure_for(samples: &[Vec3], target_level: f64) -> f64 {
    // On the 1/64-stop grid, step k is k / 64 stops; each step's level is measured once.
    let level = |k: i64| mean_level(samples, 2f64.powf(k as f64 / EV_STEPS) as f32);
    let limit = (MAX_METERED_EV * EV_STEPS) as i64;
    let (mut a, mut b) = ((-limit, level(-limit)), (limit, level(limit)));
    if b.1 <= target_level {
        return MAX_METERED_EV;
    }
    if a.1 >= target_level {
        return -MAX_METERED_EV;
    }
    // a stays at or under the target, b above it, until they are neighbours.
    while b.0 - a.0 > 1 {
        let m = (a.0 + b.0) / 2;
        let at = (m, level(m));
        if at.1 <= target_level { a = at } else { b = at }
    }
    // The nearer of the two.
    let k = if b.1 - target_level < target_level - a.1 {
        b.0
    } else {
        a.0
    };
    k as f64 / EV_STEPS
}

/// A procedural environment's shading, as environment.wgsl's
/// `procedural_sky` computes it (the sun disc left out).
struct Procedural {
    style: EnvironmentStyle,
    sky: Preetham,
    /// Radiance → display scale (`env.mode.y`).
    k: f32,
    sun: Vec3,
    cover: f32,
    light: Vec3,
    ambient: Vec3,
    seed: Vec2,
    /// Fog's distance scale on the ground (`env.zenith_yxy.w`).
    fog_m: f32,
    /// The far and near silhouettes' haze (`ground_a.w`, `ground_b.w`).
    far_haze: f32,
    near_haze: f32,
}

impl Procedural {
    fn new(
        style: EnvironmentStyle,
        env: &FrameEnvironment,
        (exposure, sunlight): (f32, f32),
        atmosphere_visibility_m: Option<f64>,
    ) -> Self {
        let sun = env.sun_direction().as_vec3();
        let lighting = procedural_lighting(&style, env, exposure, sunlight);
        let (fog_m, far_haze, near_haze) = match atmosphere_visibility_m {
            Some(v) => {
                let k = super::KOSCHMIEDER;
                (
                    (v / k) as f32,
                    1.0 - (-k * FAR_SILHOUETTE_M / v).exp() as f32,
                    1.0 - (-k * NEAR_SILHOUETTE_M / v).exp() as f32,
                )
            }
            None => (9000.0 / env.turbidity.max(1.0) as f32, 0.55, 0.25),
        };
        Self {
            style,
            sky: Preetham::new(env.turbidity as f32, sun),
            k: SKY_EXPOSURE * exposure,
            sun,
            cover: env.cloud_cover.clamp(0.0, 1.0) as f32,
            light: Vec3::from(lighting.sun_color),
            ambient: Vec3::from(lighting.zenith),
            seed: Vec2::from(pattern_offset(env.pattern_seed)),
            fog_m,
            far_haze,
            near_haze,
        }
    }

    fn preetham(&self, dir: Vec3) -> Vec3 {
        tone_map(self.sky.radiance(dir) * self.k)
    }

    /// `horizon_haze`: the sky 0.02 above level in the ray's azimuth.
    fn haze(&self, az_c: Vec2) -> Vec3 {
        self.preetham(Vec3::new(az_c.x, 0.02, az_c.y).normalize())
    }

    /// `upper_sky`: the Preetham sky and the cloud layer.
    fn upper_sky(&self, dir: Vec3, haze: Vec3) -> Vec3 {
        let mut col = self.preetham(dir);
        if self.cover > 0.001 {
            let uv = Vec2::new(dir.x, dir.z) / (dir.y + 0.05) * 0.9 + self.seed;
            let threshold = 0.72 + (0.22 - 0.72) * self.cover;
            let coarse = fbm(uv, 2);
            let mut n = coarse;
            if coarse + 0.25 > threshold {
                n = coarse + 0.25 * fbm(uv * 4.0804 + Vec2::new(70.2, 37.5), 3);
            }
            let density = smoothstep(threshold, threshold + 0.2, n);
            let toward_sun = fbm(uv + Vec2::new(self.sun.x, self.sun.z) * 0.12, 2);
            let self_shadow = (1.0 - (toward_sun - n) * 2.5).clamp(0.45, 1.15);
            let silver = dir.dot(self.sun).max(0.0).powf(12.0);
            let cloud = (self.ambient * 0.85 + self.light * 0.5 * (0.6 + silver))
                * self_shadow
                * (1.0 - 0.35 * density);
            let fade = smoothstep(0.0, 0.1, dir.y);
            let cloud_far = haze.lerp(cloud, smoothstep(0.0, 0.3, dir.y) * 0.7 + 0.3);
            col = col.lerp(cloud_far.min(Vec3::ONE), density * fade * 0.95);
        }
        col
    }

    /// `procedural_sky` without the sun disc.
    fn shade(&self, dir: Vec3) -> Vec3 {
        let s = &self.style;
        let az_c = (Vec2::new(dir.x, dir.z) + Vec2::new(1e-6, 0.0)).normalize();
        let haze = self.haze(az_c);
        let elevation = dir.y.clamp(-1.0, 1.0).asin();
        let sun_up = self.sun.y.max(0.0);
        if dir.y >= 0.0 {
            let mut col = self.upper_sky(dir, haze);
            let seed = self.seed * 0.01;
            let far_h = silhouette_height(s.far, s.far_height_deg.to_radians(), az_c, seed);
            if elevation < far_h {
                let shade =
                    Vec3::from(s.far_albedo) * (self.light * sun_up * 0.6 + self.ambient * 0.8);
                let mut c = shade;
                if s.snow_caps && elevation > far_h * 0.6 {
                    let snow =
                        Vec3::new(0.85, 0.87, 0.9) * (self.light * sun_up * 0.5 + self.ambient);
                    c = c.lerp(snow, smoothstep(0.6, 0.75, elevation / far_h.max(1e-4)));
                }
                col = c.lerp(haze, self.far_haze);
            }
            let near_seed = self.seed * 0.013 + Vec2::new(5.0, 3.0);
            let near_h = silhouette_height(s.near, s.near_height_deg.to_radians(), az_c, near_seed);
            if elevation < near_h {
                let lit =
                    Vec3::from(s.near_albedo) * (self.light * sun_up * 0.5 + self.ambient * 0.7);
                col = lit.lerp(haze, self.near_haze);
            }
            return col;
        }
        // Ground plane 60 m below the camera.
        let t = 60.0 / (-dir.y).max(1e-4);
        let p = Vec2::new(dir.x, dir.z) * t + self.seed * 37.0;
        let [a, b] = s.ground_albedo.map(Vec3::from);
        let mut albedo = a.lerp(b, fbm(p * 0.01, 4));
        let fields = vnoise(p * 0.003);
        albedo *= 0.8 + 0.4 * step(0.5, fields);
        if s.ground == Ground::Road {
            let across = (p.x - 30.0).abs();
            if across < 3.5 {
                albedo = Vec3::new(0.05, 0.05, 0.055);
                if across < 0.12 && fract(p.y / 12.0) < 0.5 {
                    albedo = Vec3::splat(0.6);
                }
            }
        }
        let mut lit = albedo * (self.light * sun_up + self.ambient);
        if s.ground == Ground::Water {
            let ripple = (Vec2::new(vnoise(p * 0.35), vnoise(p * 0.35 + 7.0)) - 0.5) * 0.06;
            let r = Vec3::new(dir.x + ripple.x, -dir.y, dir.z + ripple.y).normalize();
            let reflected = self.preetham(r);
            let fresnel = 0.02 + 0.98 * (1.0 - (-dir.y).min(1.0)).powi(5);
            let glint = r.dot(self.sun).max(0.0).powf(300.0) * self.light * 2.0;
            lit = (albedo * self.ambient).lerp(reflected, fresnel) + glint;
        }
        let fog = 1.0 - (-t / self.fog_m).exp();
        lit.lerp(haze, fog)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_exposure_found_is_the_grid_step_nearest_the_target() {
        // A mid-grey and a blue sky: the level rises with the gain, and the
        // step found is nearer the target than its neighbours.
        let samples = vec![Vec3::splat(0.18), Vec3::new(0.2, 0.35, 0.8)];
        for target in [40.0, 118.0, 200.0] {
            let ev = exposure_for(&samples, target);
            assert_eq!((ev * EV_STEPS).fract(), 0.0, "{ev}");
            let at = |ev: f64| mean_level(&samples, 2f64.powf(ev) as f32);
            let off = (at(ev) - target).abs();
            for n in [ev - 1.0 / EV_STEPS, ev + 1.0 / EV_STEPS] {
                assert!(off <= (at(n) - target).abs(), "{target}: {ev} vs {n}");
            }
            assert!(off < 1.0, "{target}: {}", at(ev));
        }
        // Out of reach: black needs all the gain there is, a blinding sky none.
        assert_eq!(exposure_for(&[Vec3::ZERO], 100.0), MAX_METERED_EV);
        assert_eq!(exposure_for(&[Vec3::splat(1e9)], 100.0), -MAX_METERED_EV);
        assert_eq!(mean_level(&[], 1.0), 0.0);
    }

    #[test]
    fn the_metered_sky_brightens_toward_the_sun_and_darkens_with_the_ground_in_view() {
        use crate::preset::EnvironmentName;
        let env = FrameEnvironment {
            choice: 0,
            sun_elevation_deg: 30.0,
            sun_azimuth_deg: 0.0,
            azimuth_offset_deg: 0.0,
            cloud_cover: 0.0,
            turbidity: 2.5,
            pattern_seed: 3,
            exposure_offset_ev: 0.0,
            sun_offset_ev: 0.0,
        };
        let sky = FrameSky::Procedural {
            environment: EnvironmentName::BeautifulPasture,
            exposure: 1.0,
            sun: 1.0,
        };
        // Looking along azimuth `az` (degrees from +Z toward +X), `elevation` up.
        let view = |az: f64, elevation: f64| {
            let (a, e) = (az.to_radians(), elevation.to_radians());
            let forward = DVec3::new(a.sin() * e.cos(), e.sin(), a.cos() * e.cos());
            let m = crate::scene::math::look_at_cv(DVec3::ZERO, forward).expect("look-at");
            View {
                width: 320,
                height: 180,
                focal_px: 200.0,
                camera_from_world: m,
            }
        };
        let level = |v: View| {
            let s = background_samples(&sky, &env, &v, None).expect("procedural");
            assert_eq!(s.len(), (GRID.0 * GRID.1) as usize);
            mean_level(&s, 1.0)
        };
        assert!(level(view(0.0, 30.0)) > level(view(180.0, 30.0)) + 5.0);
        assert!(level(view(90.0, 40.0)) > level(view(90.0, -20.0)) + 20.0);
        let image = FrameSky::Image {
            image: 0,
            exposure: 1.0,
            rotation_deg: 0.0,
        };
        assert!(background_samples(&image, &env, &view(0.0, 0.0), None).is_none());
    }
}

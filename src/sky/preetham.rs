//! Preetham daylight (Preetham et al. 1999) and the lighting each kind of sky
//! gives the drones.

use glam::Vec3;

use super::{EnvironmentStyle, FrameEnvironment};
use crate::simd::math::smoothstep;

/// Preetham's sky model for one turbidity and sun: Perez coefficients A–E for
/// (Y, x, y) and the zenith's (Y in kcd/m², x, y).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Preetham {
    pub perez: [[f32; 3]; 5],
    pub zenith: [f32; 3],
    pub sun: Vec3,
}

/// Radiance → display scale before `1 − exp(−x)` (a day zenith of ~6 kcd/m² maps to ~0.25).
pub const SKY_EXPOSURE: f32 = 0.05;

impl Preetham {
    pub fn new(turbidity: f32, sun: Vec3) -> Self {
        let t = turbidity.clamp(1.7, 10.0);
        // The model is defined for the sun above the horizon.
        let theta_s = sun.y.clamp(0.01, 1.0).acos();
        let perez = [
            [
                0.1787 * t - 1.4630,
                -0.0193 * t - 0.2592,
                -0.0167 * t - 0.2608,
            ],
            [
                -0.3554 * t + 0.4275,
                -0.0665 * t + 0.0008,
                -0.0950 * t + 0.0092,
            ],
            [
                -0.0227 * t + 5.3251,
                -0.0004 * t + 0.2125,
                -0.0079 * t + 0.2102,
            ],
            [
                0.1206 * t - 2.5771,
                -0.0641 * t - 0.8989,
                -0.0441 * t - 1.6537,
            ],
            [
                -0.0670 * t + 0.3703,
                -0.0033 * t + 0.0452,
                -0.0109 * t + 0.0529,
            ],
        ];
        let chi = (4.0 / 9.0 - t / 120.0) * (std::f32::consts::PI - 2.0 * theta_s);
        let y_z = ((4.0453 * t - 4.9710) * chi.tan() - 0.2155 * t + 2.4192).max(0.05);
        let (t2, th, th2, th3) = (t * t, theta_s, theta_s * theta_s, theta_s.powi(3));
        let x_z = t2 * (0.00166 * th3 - 0.00375 * th2 + 0.00209 * th)
            + t * (-0.02903 * th3 + 0.06377 * th2 - 0.03202 * th + 0.00394)
            + (0.11693 * th3 - 0.21196 * th2 + 0.06052 * th + 0.25886);
        let y_zc = t2 * (0.00275 * th3 - 0.00610 * th2 + 0.00317 * th)
            + t * (-0.04214 * th3 + 0.08970 * th2 - 0.04153 * th + 0.00516)
            + (0.15346 * th3 - 0.26756 * th2 + 0.06670 * th + 0.26688);
        Self {
            perez,
            zenith: [y_z, x_z, y_zc],
            sun: sun.normalize_or(Vec3::Y),
        }
    }

    fn perez(&self, k: usize, cos_theta: f32, gamma: f32) -> f32 {
        let [a, b, c, d, e] = [0, 1, 2, 3, 4].map(|i| self.perez[i][k]);
        (1.0 + a * (b / cos_theta.max(0.01)).exp())
            * (1.0 + c * (d * gamma).exp() + e * gamma.cos().powi(2))
    }

    /// The frame's constant factors of the sky shader's Preetham sky
    /// (environment.wgsl, `sky_k` and `haze_k`), in f64 then rounded:
    /// the zenith Yxy over the Perez terms at the zenith (the sun's angle
    /// to it), twilight on Y; and that times the elevation term of the
    /// horizon haze's ray, 0.02 above level (normalised: its zenith cosine
    /// is 0.02 / √1.0004). [`Preetham::radiance`] is their product with the
    /// per-ray terms.
    pub fn shader_factors(&self) -> ([f32; 3], [f32; 3]) {
        let theta_s = f64::from(self.sun.y.clamp(0.01, 1.0)).acos();
        let twilight = f64::from(smoothstep(-0.1, 0.05, self.sun.y));
        let haze_cos = 0.02 / 1.0004f64.sqrt();
        let mut sky = [0.0; 3];
        let mut haze = [0.0; 3];
        for k in 0..3 {
            let [a, b, c, d, e] = [0, 1, 2, 3, 4].map(|i| f64::from(self.perez[i][k]));
            let at_zenith =
                (1.0 + a * b.exp()) * (1.0 + c * (d * theta_s).exp() + e * theta_s.cos().powi(2));
            let scale = if k == 0 { twilight } else { 1.0 };
            let s = f64::from(self.zenith[k]) * scale / at_zenith;
            sky[k] = s as f32;
            haze[k] = (s * (1.0 + a * (b / haze_cos).exp())) as f32;
        }
        (sky, haze)
    }

    /// The horizon haze of environment.wgsl (`horizon_haze`: the
    /// tone-mapped sky 0.02 above level, at `exposure`) as a table the
    /// shader interpolates linearly instead of evaluating the Perez terms,
    /// the colour conversion and the tone map for every pixel. γ is the
    /// ray's angle to the sun. Entry `k` of the first half is at
    /// `sin(γ/2) = k / (HALF − 1) · √½` (γ from 0 to 90°), of the second half
    /// at `cos(γ/2)` the same (γ from 180° down to 90°), `HALF` =
    /// [`HAZE_TABLE`] / 2: the steps are even in γ at both ends, where a
    /// table over `cos γ` would have a square-root kink. Values are before
    /// the clamp at 0 (the tone map of a negative colour is negative, so the
    /// shader clamps after interpolating and the table has no kink either).
    /// Computed in f64 from `haze_k` ([`Preetham::shader_factors`]).
    pub fn haze_table(&self, haze_k: [f32; 3], exposure: f32) -> Vec<[f32; 4]> {
        let half = HAZE_TABLE / 2;
        (0..HAZE_TABLE)
            .map(|i| {
                let s = (i % half) as f64 / (half - 1) as f64 * std::f64::consts::FRAC_1_SQRT_2;
                let gamma = if i < half {
                    2.0 * s.asin()
                } else {
                    std::f64::consts::PI - 2.0 * s.asin()
                };
                let rgb = self.haze_unclamped(haze_k, gamma);
                let tone = |v: f64| (1.0 - (-v * f64::from(exposure)).exp()) as f32;
                [tone(rgb[0]), tone(rgb[1]), tone(rgb[2]), 0.0]
            })
            .collect()
    }

    /// The linear RGB of the horizon haze at angle `gamma` to the sun,
    /// before its clamp at 0.
    fn haze_unclamped(&self, haze_k: [f32; 3], gamma: f64) -> [f64; 3] {
        let [y, cx, cy]: [f64; 3] = std::array::from_fn(|k| {
            let [c, d, e] = [2, 3, 4].map(|i| f64::from(self.perez[i][k]));
            f64::from(haze_k[k]) * (1.0 + c * (d * gamma).exp() + e * gamma.cos().powi(2))
        });
        let cy = cy.max(1e-4);
        let (x, z) = (cx / cy * y, (1.0 - cx - cy) / cy * y);
        [
            3.2406 * x - 1.5372 * y - 0.4986 * z,
            -0.9689 * x + 1.8758 * y + 0.0415 * z,
            0.0557 * x - 0.2040 * y + 1.0570 * z,
        ]
    }

    /// Linear sRGB radiance (kcd/m² scale) of the sky in direction `dir` (clamped to the horizon).
    pub fn radiance(&self, dir: Vec3) -> Vec3 {
        let d = Vec3::new(dir.x, dir.y.max(0.001), dir.z).normalize();
        let gamma = d.dot(self.sun).clamp(-1.0, 1.0).acos();
        let theta_s = self.sun.y.clamp(0.01, 1.0).acos();
        let yxy: [f32; 3] = std::array::from_fn(|k| {
            self.zenith[k] * self.perez(k, d.y, gamma) / self.perez(k, 1.0, theta_s)
        });
        let twilight = smoothstep(-0.1, 0.05, self.sun.y);
        yxy_to_rgb(yxy[0] * twilight, yxy[1], yxy[2])
    }
}

/// Entries of [`Preetham::haze_table`] (`HAZE_TABLE` in environment.wgsl).
pub const HAZE_TABLE: usize = 512;

/// CIE Yxy → linear sRGB.
fn yxy_to_rgb(y: f32, cx: f32, cy: f32) -> Vec3 {
    let cy = cy.max(1e-4);
    let (x, z) = (cx / cy * y, (1.0 - cx - cy) / cy * y);
    Vec3::new(
        3.2406 * x - 1.5372 * y - 0.4986 * z,
        -0.9689 * x + 1.8758 * y + 0.0415 * z,
        0.0557 * x - 0.2040 * y + 1.0570 * z,
    )
    .max(Vec3::ZERO)
}

/// Direct sunlight transmittance (R, G, B at 680/550/440 nm): Rayleigh and
/// Ångström aerosol optical depth (Preetham's β = 0.04608·T − 0.04586) over
/// the Kasten–Young air mass.
pub fn sun_transmittance(turbidity: f32, elevation_rad: f32) -> Vec3 {
    let zenith_deg = 90.0 - elevation_rad.to_degrees().clamp(-2.0, 90.0);
    let air_mass = 1.0
        / (zenith_deg.to_radians().cos().max(0.0)
            + 0.50572 * (96.07995 - zenith_deg).max(0.1).powf(-1.6364));
    let beta = 0.04608 * turbidity.clamp(1.7, 10.0) - 0.04586;
    let tau = |lambda_um: f32| {
        0.008569
            * lambda_um.powi(-4)
            * (1.0 + 0.0113 * lambda_um.powi(-2) + 0.00013 * lambda_um.powi(-4))
            + beta * lambda_um.powf(-1.3)
    };
    Vec3::new(
        (-tau(0.68) * air_mass).exp(),
        (-tau(0.55) * air_mass).exp(),
        (-tau(0.44) * air_mass).exp(),
    )
}

/// Radiance → display-linear colour, as the sky shader does it.
pub fn tone_map(radiance: Vec3) -> Vec3 {
    Vec3::ONE - (-radiance).exp()
}

/// How the drones are lit: sun colour and the hemispheric ambient's sky and
/// ground terms, all display-linear (what `FrameUniforms` carries).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Lighting {
    pub sun_color: [f32; 3],
    pub zenith: [f32; 3],
    pub horizon: [f32; 3],
    pub ground: [f32; 3],
}

/// The gradient sky's lighting (unchanged from the first renderer).
pub fn gradient_lighting(sun: Vec3, zenith: [f32; 3], horizon: [f32; 3]) -> Lighting {
    let elevation = sun.y.clamp(-1.0, 1.0);
    let warm = (1.0 - elevation).powi(3);
    let strength = (elevation * 4.0 + 0.3).clamp(0.0, 1.0) * 1.6;
    Lighting {
        sun_color: [
            strength,
            strength * (1.0 - 0.35 * warm),
            strength * (1.0 - 0.65 * warm),
        ],
        zenith,
        horizon,
        ground: [horizon[0] * 0.35, horizon[1] * 0.33, horizon[2] * 0.28],
    }
}

/// The lighting of a procedural environment: the same sky model the shader draws.
pub fn procedural_lighting(
    style: &EnvironmentStyle,
    env: &FrameEnvironment,
    exposure: f32,
    sunlight: f32,
) -> Lighting {
    let sun = env.sun_direction().as_vec3();
    let sky = Preetham::new(env.turbidity as f32, sun);
    let k = SKY_EXPOSURE * exposure;
    let zenith = tone_map(sky.radiance(Vec3::Y) * k);
    // The horizon term: the average of four horizon directions.
    let horizon = (0..4).map(|i| {
        let a = i as f32 * std::f32::consts::FRAC_PI_2;
        tone_map(sky.radiance(Vec3::new(a.sin(), 0.05, a.cos())) * k)
    });
    let horizon = horizon.sum::<Vec3>() / 4.0;
    // Clouds grey the sky light and dim the sun.
    let cloud = env.cloud_cover.clamp(0.0, 1.0) as f32;
    let overcast = Vec3::splat(horizon.element_sum() / 3.0);
    let zenith = zenith.lerp(overcast, cloud * 0.6);
    // `sunlight` (the preset's 2^sun_ev, 1 by default) sets the sun against the sky.
    let sun_strength = 1.6 * smoothstep(-0.03, 0.08, sun.y) * (1.0 - 0.55 * cloud) * sunlight;
    let sun_color =
        sun_transmittance(env.turbidity as f32, sun.y.asin()) * sun_strength * exposure.sqrt();
    let albedo = (Vec3::from(style.ground_albedo[0]) + Vec3::from(style.ground_albedo[1])) * 0.5;
    let ground = albedo * (sun_color * sun.y.max(0.0) + zenith) * 0.9 + horizon * 0.1;
    Lighting {
        sun_color: sun_color.to_array(),
        zenith: zenith.to_array(),
        horizon: horizon.to_array(),
        ground: ground.to_array(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// `horizon_haze` as environment.wgsl evaluated it before the table:
    /// the tone-mapped Preetham sky ([`Preetham::radiance`]) 0.02 above
    /// level in the azimuth of `dir`.
    fn haze_direct(model: &Preetham, exposure: f32, dir: Vec3) -> [f64; 3] {
        let rgb = model.radiance(dir) * exposure;
        rgb.to_array().map(|v| f64::from(1.0 - (-v).exp()))
    }

    /// The shader's read of the table (`horizon_haze`).
    fn haze_read(table: &[[f32; 4]], gamma: f64) -> [f64; 3] {
        let half = HAZE_TABLE / 2;
        let c = gamma.cos();
        let s = ((1.0 - c.abs()) * 0.5).max(0.0).sqrt();
        let t = s / std::f64::consts::FRAC_1_SQRT_2 * (half - 1) as f64;
        let i = (t as usize).min(half - 2) + if c >= 0.0 { 0 } else { half };
        let f = t - (i % half) as f64;
        std::array::from_fn(|k| {
            (f64::from(table[i][k]) * (1.0 - f) + f64::from(table[i + 1][k]) * f).max(0.0)
        })
    }

    #[test]
    fn the_haze_table_reads_within_a_tenth_of_a_level_of_the_formula() {
        let (mut worst, mut worst_above_3): (f64, f64) = (0.0, 0.0);
        for turbidity in [1.7, 3.0, 6.0, 10.0] {
            for elevation_deg in [0.5f32, 3.0, 8.0, 25.0, 60.0, 89.0] {
                let e = elevation_deg.to_radians();
                let sun = Vec3::new(0.3 * e.cos(), e.sin(), 0.95 * e.cos()).normalize();
                let model = Preetham::new(turbidity, sun);
                let (_, haze_k) = model.shader_factors();
                for exposure in [SKY_EXPOSURE * 0.25, SKY_EXPOSURE, SKY_EXPOSURE * 4.0] {
                    let table = model.haze_table(haze_k, exposure);
                    assert_eq!(table.len(), HAZE_TABLE);
                    for k in 0..=8000 {
                        let az = std::f32::consts::TAU * k as f32 / 8000.0;
                        let dir = Vec3::new(az.cos(), 0.02, az.sin()).normalize();
                        let gamma = f64::from(dir.dot(model.sun).clamp(-1.0, 1.0)).acos();
                        let want = haze_direct(&model, exposure, dir);
                        let got = haze_read(&table, gamma);
                        for c in 0..3 {
                            assert!(got[c].is_finite(), "γ {gamma}");
                            let d = (want[c] - got[c]).abs();
                            worst = worst.max(d);
                            if elevation_deg >= 3.0 {
                                worst_above_3 = worst_above_3.max(d);
                            }
                        }
                    }
                }
            }
        }
        // In 8-bit levels of the tone-mapped value: well inside the rounding
        // for a sun 3° or more above the horizon; under one level even for a
        // sun at 0.5°, the clearest air and 4× exposure, where the glare
        // around the sun on the horizon is steepest.
        let levels = |v: f64| v * 255.0;
        assert!(
            levels(worst_above_3) < 0.1,
            "worst {:.4} levels",
            levels(worst_above_3)
        );
        assert!(levels(worst) < 1.0, "worst {:.4} levels", levels(worst));
        // The table is not flat: the haze brightens toward the sun.
        let model = Preetham::new(3.0, Vec3::new(0.0, 0.2, 0.98).normalize());
        let table = model.haze_table(model.shader_factors().1, SKY_EXPOSURE);
        assert!(table[0][0] > table[HAZE_TABLE - 1][0] + 0.05);
    }
}

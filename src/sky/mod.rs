//! Environments: the seven named procedural skies, image skies, and the
//! per-frame draws that randomise them.
//!
//! Data flow: the preset's [`Sky`] is a static description. `build_frame`
//! calls [`frame_environment`] (pure: its draws come from a stream salted
//! apart from the scene's, so adding a random sky never changes existing
//! drone placements) to get a [`FrameEnvironment`]: which choice, the sun's
//! elevation/azimuth, cloud cover, turbidity and the pattern seed, and
//! [`resolve`]s both into the frame's [`FrameSky`] (plain scene data). The
//! renderer draws that and asks the lighting functions for the drones' sun
//! colour and ambient terms, so the sun that lights the drones is the one
//! drawn in the sky.
//!
//! The procedural sky is Preetham et al. 1999 ("A Practical Analytic Model
//! for Daylight"), evaluated here for the lighting and in
//! `shaders/environment.wgsl` per pixel, with an fbm cloud layer, a ground
//! plane (grass, snow, water, road) and far/near silhouettes (hills,
//! mountains, skyline, tree line), fogged towards the horizon. Display values
//! are `1 − exp(−exposure · radiance)`.
//!
//! Image skies (equirectangular .hdr/.exr/.png/.jpg or six cubemap faces) are
//! decoded by the `image` crate into linear RGB f32 with negative and
//! non-finite values clamped to 0, and uploaded as RGBA16F. Only the images a
//! preset references are read ([`EnvironmentAssets::load`]).

use std::path::{Path, PathBuf};

use glam::{DVec3, Vec3};
use rand::Rng;
use serde::Serialize;

pub use crate::preset::EnvironmentName;
use crate::preset::{DEFAULT_HORIZON, DEFAULT_ZENITH, Sky, SkyImageSource};

/// What covers the ground plane.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Ground {
    Grass = 0,
    Snow = 1,
    Water = 2,
    Road = 3,
}

/// A silhouette band on the horizon.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Silhouette {
    None = 0,
    Hills = 1,
    Mountains = 2,
    Skyline = 3,
    TreeLine = 4,
}

/// The look of a procedural environment; the sun, turbidity and clouds are its defaults.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct EnvironmentStyle {
    pub sun_elevation_deg: f64,
    pub sun_azimuth_deg: f64,
    pub turbidity: f64,
    pub cloud_cover: f64,
    pub ground: Ground,
    /// Two linear albedos the ground pattern mixes.
    pub ground_albedo: [[f32; 3]; 2],
    pub far: Silhouette,
    /// Angular height of the far silhouette, degrees.
    pub far_height_deg: f32,
    pub far_albedo: [f32; 3],
    /// Snow on the far silhouette's upper part.
    pub snow_caps: bool,
    pub near: Silhouette,
    pub near_height_deg: f32,
    pub near_albedo: [f32; 3],
}

impl EnvironmentName {
    /// The environment's look and default sun.
    pub fn style(self) -> EnvironmentStyle {
        const GRASS: [[f32; 3]; 2] = [[0.07, 0.16, 0.035], [0.16, 0.22, 0.06]];
        let base = EnvironmentStyle {
            sun_elevation_deg: 50.0,
            sun_azimuth_deg: 135.0,
            turbidity: 2.5,
            cloud_cover: 0.15,
            ground: Ground::Grass,
            ground_albedo: GRASS,
            far: Silhouette::Hills,
            far_height_deg: 1.2,
            far_albedo: [0.10, 0.14, 0.10],
            snow_caps: false,
            near: Silhouette::None,
            near_height_deg: 0.0,
            near_albedo: [0.03, 0.06, 0.03],
        };
        match self {
            Self::Daytime => base,
            Self::Sunset => EnvironmentStyle {
                sun_elevation_deg: 4.0,
                sun_azimuth_deg: 250.0,
                turbidity: 4.5,
                cloud_cover: 0.35,
                ground_albedo: [[0.05, 0.08, 0.03], [0.10, 0.10, 0.05]],
                far_height_deg: 1.6,
                near: Silhouette::TreeLine,
                near_height_deg: 0.8,
                ..base
            },
            Self::BeautifulPasture => EnvironmentStyle {
                sun_elevation_deg: 35.0,
                sun_azimuth_deg: 200.0,
                turbidity: 2.2,
                cloud_cover: 0.4,
                ground_albedo: [[0.08, 0.22, 0.03], [0.22, 0.30, 0.05]],
                far_height_deg: 4.0,
                far_albedo: [0.08, 0.18, 0.06],
                near: Silhouette::TreeLine,
                near_height_deg: 0.6,
                ..base
            },
            Self::SnowyBridge => EnvironmentStyle {
                sun_elevation_deg: 20.0,
                sun_azimuth_deg: 160.0,
                turbidity: 3.0,
                cloud_cover: 0.55,
                ground: Ground::Snow,
                ground_albedo: [[0.70, 0.74, 0.80], [0.85, 0.87, 0.90]],
                far: Silhouette::Mountains,
                far_height_deg: 9.0,
                far_albedo: [0.18, 0.2, 0.24],
                snow_caps: true,
                near: Silhouette::TreeLine,
                near_height_deg: 1.0,
                near_albedo: [0.02, 0.04, 0.03],
            },
            Self::SmallHarbour => EnvironmentStyle {
                sun_elevation_deg: 30.0,
                sun_azimuth_deg: 100.0,
                turbidity: 3.5,
                cloud_cover: 0.3,
                ground: Ground::Water,
                ground_albedo: [[0.01, 0.03, 0.04], [0.02, 0.05, 0.06]],
                far: Silhouette::Skyline,
                far_height_deg: 2.0,
                far_albedo: [0.25, 0.22, 0.2],
                ..base
            },
            Self::Tellsplatte => EnvironmentStyle {
                sun_elevation_deg: 40.0,
                sun_azimuth_deg: 120.0,
                turbidity: 2.0,
                cloud_cover: 0.25,
                ground: Ground::Water,
                ground_albedo: [[0.01, 0.04, 0.05], [0.02, 0.06, 0.07]],
                far: Silhouette::Mountains,
                far_height_deg: 22.0,
                far_albedo: [0.10, 0.12, 0.10],
                snow_caps: true,
                near: Silhouette::None,
                ..base
            },
            Self::CountryRoad => EnvironmentStyle {
                sun_elevation_deg: 55.0,
                sun_azimuth_deg: 60.0,
                turbidity: 2.8,
                cloud_cover: 0.2,
                ground: Ground::Road,
                ground_albedo: [[0.09, 0.15, 0.04], [0.22, 0.20, 0.08]],
                far_height_deg: 1.0,
                near: Silhouette::TreeLine,
                near_height_deg: 1.4,
                ..base
            },
        }
    }
}

/// The environment draws of one frame (plain data, part of the scene).
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct FrameEnvironment {
    /// Index into `Sky::Random.choices` (0 for any other sky).
    pub choice: usize,
    pub sun_elevation_deg: f64,
    pub sun_azimuth_deg: f64,
    /// The random turn of the environment about the vertical (already in
    /// `sun_azimuth_deg`; image skies also turn their pixels by it).
    pub azimuth_offset_deg: f64,
    /// Fraction of the sky covered by clouds, [0, 1] (procedural skies).
    pub cloud_cover: f64,
    /// Atmospheric turbidity, [1.7, 10] (procedural skies).
    pub turbidity: f64,
    /// Seed of the cloud, ground and silhouette patterns.
    pub pattern_seed: u32,
}

impl FrameEnvironment {
    /// Unit vector towards the sun (world frame).
    pub fn sun_direction(&self) -> DVec3 {
        sun_vector(self.sun_elevation_deg, self.sun_azimuth_deg)
    }
}

/// Unit vector towards the sun: azimuth from +Z towards +X, elevation above the horizon.
pub fn sun_vector(elevation_deg: f64, azimuth_deg: f64) -> DVec3 {
    let (el, az) = (elevation_deg.to_radians(), azimuth_deg.to_radians());
    DVec3::new(el.cos() * az.sin(), el.sin(), el.cos() * az.cos())
}

/// Salt of the environment's draw stream (independent of the scene's draws).
const ENVIRONMENT_SALT: u64 = 0x454E_5649_524F_4E4D; // "ENVIRONM"

/// The static (un-randomised) parameters of a sky that is not `Random`.
fn nominal(sky: &Sky) -> FrameEnvironment {
    let base = |el: f64, az: f64, turbidity: f64, cloud: f64, seed: Option<u32>| FrameEnvironment {
        choice: 0,
        sun_elevation_deg: el,
        sun_azimuth_deg: az,
        azimuth_offset_deg: 0.0,
        cloud_cover: cloud,
        turbidity,
        pattern_seed: seed.unwrap_or(0),
    };
    match sky {
        Sky::Gradient {
            sun_elevation_deg,
            sun_azimuth_deg,
            ..
        } => base(*sun_elevation_deg, *sun_azimuth_deg, 2.5, 0.0, None),
        Sky::Procedural {
            environment,
            sun_elevation_deg,
            sun_azimuth_deg,
            turbidity,
            cloud_cover,
            seed,
            ..
        } => {
            let s = environment.style();
            base(
                sun_elevation_deg.unwrap_or(s.sun_elevation_deg),
                sun_azimuth_deg.unwrap_or(s.sun_azimuth_deg),
                turbidity.unwrap_or(s.turbidity),
                cloud_cover.unwrap_or(s.cloud_cover),
                *seed,
            )
        }
        Sky::Image {
            sun_elevation_deg,
            sun_azimuth_deg,
            rotation_deg,
            ..
        } => base(
            *sun_elevation_deg,
            sun_azimuth_deg + rotation_deg,
            2.5,
            0.0,
            None,
        ),
        Sky::Random { choices, .. } => choices
            .first()
            .map_or_else(|| nominal(&Sky::default()), nominal),
    }
}

/// The sun of a sky without per-frame randomisation (the first choice of a `Random` sky).
pub fn nominal_sun_direction(sky: &Sky) -> DVec3 {
    nominal(sky).sun_direction()
}

/// The environment of frame `index` (pure). Draw order from the environment
/// stream: choice, azimuth offset, elevation, cloud cover, pattern seed — all
/// five are always drawn, so changing one range never shifts the others.
pub fn frame_environment(sky: &Sky, preset_seed: u64, index: u64) -> FrameEnvironment {
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(crate::scene::seed::mix64(
        crate::scene::seed::frame_seed(preset_seed, index) ^ ENVIRONMENT_SALT,
    ));
    let u = |rng: &mut rand_chacha::ChaCha8Rng| rng.random::<f64>();
    let (choice_u, az_u, el_u, cloud_u, seed) = (
        u(&mut rng),
        u(&mut rng),
        u(&mut rng),
        u(&mut rng),
        rng.random::<u32>(),
    );
    let lerp = |(lo, hi): (f64, f64), t: f64| lo + (hi - lo) * t;
    match sky {
        Sky::Random {
            choices,
            azimuth_offset_deg,
            sun_elevation_deg,
            cloud_cover,
        } if !choices.is_empty() => {
            let choice = ((choice_u * choices.len() as f64) as usize).min(choices.len() - 1);
            let mut env = nominal(&choices[choice]);
            env.choice = choice;
            env.azimuth_offset_deg = lerp(*azimuth_offset_deg, az_u);
            env.sun_azimuth_deg += env.azimuth_offset_deg;
            let is_image = matches!(choices[choice], Sky::Image { .. });
            if let (Some(range), false) = (sun_elevation_deg, is_image) {
                env.sun_elevation_deg = lerp(*range, el_u);
            }
            if let Some(range) = cloud_cover {
                env.cloud_cover = lerp(*range, cloud_u);
            }
            if !matches!(&choices[choice], Sky::Procedural { seed: Some(_), .. }) {
                env.pattern_seed = seed;
            }
            env
        }
        Sky::Procedural { seed: None, .. } => FrameEnvironment {
            pattern_seed: seed,
            ..nominal(sky)
        },
        _ => nominal(sky),
    }
}

/// A frame's sky as the renderer draws it: plain data, resolved from the
/// preset's sky and the frame's draws (the chosen `Random` entry, the turned
/// image), so the renderer never sees the preset.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub enum FrameSky {
    Gradient {
        zenith: [f32; 3],
        horizon: [f32; 3],
    },
    Procedural {
        environment: EnvironmentName,
        exposure: f32,
    },
    Image {
        /// Index into the preset's sky images (`Sky::image_sources` order).
        image: usize,
        exposure: f32,
        rotation_deg: f64,
    },
}

/// Zenith and horizon colours of the gradient that stands in for a sky that cannot be drawn.
pub const FALLBACK_ZENITH: [f32; 3] = [DEFAULT_ZENITH.0, DEFAULT_ZENITH.1, DEFAULT_ZENITH.2];
pub const FALLBACK_HORIZON: [f32; 3] = [DEFAULT_HORIZON.0, DEFAULT_HORIZON.1, DEFAULT_HORIZON.2];

/// The gradient that stands in when a `Random` sky has nothing to choose.
const FALLBACK_GRADIENT: FrameSky = FrameSky::Gradient {
    zenith: FALLBACK_ZENITH,
    horizon: FALLBACK_HORIZON,
};

/// The concrete sky of a frame: the preset's description with the frame's choice applied.
pub fn resolve(sky: &Sky, env: &FrameEnvironment) -> FrameSky {
    resolve_within(sky, sky, env)
}

fn resolve_within(root: &Sky, sky: &Sky, env: &FrameEnvironment) -> FrameSky {
    match sky {
        Sky::Gradient {
            zenith, horizon, ..
        } => FrameSky::Gradient {
            zenith: [zenith.0, zenith.1, zenith.2],
            horizon: [horizon.0, horizon.1, horizon.2],
        },
        Sky::Procedural {
            environment,
            exposure_ev,
            ..
        } => FrameSky::Procedural {
            environment: *environment,
            exposure: 2f32.powf(*exposure_ev as f32),
        },
        Sky::Image {
            source,
            exposure_ev,
            rotation_deg,
            ..
        } => match root.image_sources().iter().position(|s| *s == source) {
            Some(image) => FrameSky::Image {
                image,
                exposure: 2f32.powf(*exposure_ev as f32),
                rotation_deg: rotation_deg + env.azimuth_offset_deg,
            },
            None => FALLBACK_GRADIENT,
        },
        Sky::Random { choices, .. } => match choices.get(env.choice) {
            Some(choice) if !matches!(choice, Sky::Random { .. }) => {
                resolve_within(root, choice, env)
            }
            _ => FALLBACK_GRADIENT,
        },
    }
}

// --- Preetham daylight -------------------------------------------------------

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

fn smoothstep(e0: f32, e1: f32, x: f32) -> f32 {
    let t = ((x - e0) / (e1 - e0)).clamp(0.0, 1.0);
    t * t * (3.0 - 2.0 * t)
}

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
    let sun_strength = 1.6 * smoothstep(-0.03, 0.08, sun.y) * (1.0 - 0.55 * cloud);
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

// --- Image skies -------------------------------------------------------------

#[derive(Debug, thiserror::Error)]
pub enum EnvironmentError {
    #[error("sky image {}: {reason}", file.display())]
    Image { file: PathBuf, reason: String },
    #[error("sky cubemap: face {face} ({}) is {got_w}×{got_h}, but faces must be square and all {want}×{want}", file.display())]
    CubemapFace {
        face: &'static str,
        file: PathBuf,
        got_w: u32,
        got_h: u32,
        want: u32,
    },
}

/// Largest side of an uploaded sky image; larger images are downscaled on load.
pub const MAX_SKY_SIDE: u32 = 4096;

/// A decoded sky image: linear RGB, negative and non-finite values clamped to 0.
#[derive(Clone, Debug)]
pub struct SkyImage {
    pub source: SkyImageSource,
    pub kind: SkyImageKind,
    /// Radiance values (HDR/EXR: tone mapped) or display values (PNG/JPEG: shown as they are).
    pub hdr: bool,
    /// Mean colour of the upper and lower hemisphere (for the ambient term) and of the brightest spot.
    pub mean_upper: [f32; 3],
    pub mean_lower: [f32; 3],
    pub brightest: [f32; 3],
}

#[derive(Clone, Debug)]
pub enum SkyImageKind {
    /// Row-major RGB f32, top row first.
    Equirect {
        width: u32,
        height: u32,
        rgb: Vec<f32>,
    },
    /// Six square faces (+X, −X, +Y, −Y, +Z, −Z), each side × side RGB f32.
    Cubemap { side: u32, faces: Vec<Vec<f32>> },
}

fn decode_rgb32f(file: &Path) -> Result<(u32, u32, Vec<f32>, bool), EnvironmentError> {
    let err = |reason: String| EnvironmentError::Image {
        file: file.to_owned(),
        reason,
    };
    let reader = image::ImageReader::open(file)
        .map_err(|e| err(e.to_string()))?
        .with_guessed_format()
        .map_err(|e| err(e.to_string()))?;
    let hdr = matches!(
        reader.format(),
        Some(image::ImageFormat::Hdr | image::ImageFormat::OpenExr)
    );
    let img = reader.decode().map_err(|e| err(e.to_string()))?;
    let mut rgb = img.to_rgb32f();
    if !hdr {
        // 8-bit images are sRGB-encoded: decode to linear.
        for c in rgb.iter_mut() {
            *c = if *c <= 0.04045 {
                *c / 12.92
            } else {
                ((*c + 0.055) / 1.055).powf(2.4)
            };
        }
    }
    for c in rgb.iter_mut() {
        // NaN and negative radiance become 0; +∞ and huge values the largest f16.
        if c.is_nan() || *c < 0.0 {
            *c = 0.0;
        }
        *c = c.min(65_000.0);
    }
    let (w, h) = rgb.dimensions();
    if w == 0 || h == 0 {
        return Err(err("image is empty".into()));
    }
    let rgb = if w.max(h) > MAX_SKY_SIDE {
        let s = f64::from(MAX_SKY_SIDE) / f64::from(w.max(h));
        let (nw, nh) = (
            ((f64::from(w) * s) as u32).max(1),
            ((f64::from(h) * s) as u32).max(1),
        );
        image::imageops::resize(&rgb, nw, nh, image::imageops::FilterType::Triangle)
    } else {
        rgb
    };
    let (w, h) = rgb.dimensions();
    Ok((w, h, rgb.into_raw(), hdr))
}

/// Load one sky image (equirectangular file or six cubemap faces).
pub fn load_sky_image(source: &SkyImageSource) -> Result<SkyImage, EnvironmentError> {
    match source {
        SkyImageSource::Equirect(path) => {
            let (width, height, rgb, hdr) = decode_rgb32f(path)?;
            let rows = |r: std::ops::Range<u32>| mean_rows(&rgb, width, r);
            let (mean_upper, mean_lower) = (rows(0..height / 2), rows(height / 2..height));
            let brightest = brightest(&rgb);
            Ok(SkyImage {
                source: source.clone(),
                kind: SkyImageKind::Equirect { width, height, rgb },
                hdr,
                mean_upper,
                mean_lower,
                brightest,
            })
        }
        SkyImageSource::Cubemap {
            px,
            nx,
            py,
            ny,
            pz,
            nz,
        } => {
            let names = ["px", "nx", "py", "ny", "pz", "nz"];
            let mut faces = Vec::with_capacity(6);
            let mut side = 0;
            let mut any_hdr = false;
            for (i, path) in [px, nx, py, ny, pz, nz].into_iter().enumerate() {
                let (w, h, rgb, hdr) = decode_rgb32f(path)?;
                if i == 0 {
                    side = w;
                }
                if w != h || w != side {
                    return Err(EnvironmentError::CubemapFace {
                        face: names[i],
                        file: path.clone(),
                        got_w: w,
                        got_h: h,
                        want: side,
                    });
                }
                any_hdr |= hdr;
                faces.push(rgb);
            }
            let mean = |fs: &[&Vec<f32>]| {
                let m: Vec<[f32; 3]> = fs.iter().map(|f| mean_rows(f, side, 0..side)).collect();
                std::array::from_fn(|c| m.iter().map(|x| x[c]).sum::<f32>() / m.len() as f32)
            };
            let mean_upper = mean(&[&faces[2], &faces[0], &faces[1], &faces[4], &faces[5]]);
            let mean_lower = mean(&[&faces[3]]);
            let brightest = brightest(&faces.concat());
            Ok(SkyImage {
                source: source.clone(),
                kind: SkyImageKind::Cubemap { side, faces },
                hdr: any_hdr,
                mean_upper,
                mean_lower,
                brightest,
            })
        }
    }
}

fn mean_rows(rgb: &[f32], width: u32, rows: std::ops::Range<u32>) -> [f32; 3] {
    let (start, end) = (
        (rows.start * width * 3) as usize,
        (rows.end * width * 3) as usize,
    );
    let px = &rgb[start.min(rgb.len())..end.min(rgb.len())];
    let n = (px.len() / 3).max(1) as f32;
    let mut sum = [0f64; 3];
    for p in px.chunks_exact(3) {
        for c in 0..3 {
            sum[c] += f64::from(p[c]);
        }
    }
    sum.map(|s| (s / f64::from(n)) as f32)
}

fn brightest(rgb: &[f32]) -> [f32; 3] {
    rgb.chunks_exact(3)
        .max_by(|a, b| (a[0] + a[1] + a[2]).total_cmp(&(b[0] + b[1] + b[2])))
        .map_or([1.0; 3], |p| [p[0], p[1], p[2]])
}

impl SkyImage {
    /// Display value of a radiance (HDR) or of a decoded 8-bit value (LDR).
    pub fn display(&self, c: [f32; 3], exposure: f32) -> Vec3 {
        let v = Vec3::from(c) * exposure;
        if self.hdr {
            tone_map(v)
        } else {
            v.min(Vec3::ONE)
        }
    }

    /// The image's lighting: ambient from the hemisphere means, a sun tinted
    /// like the brightest spot (a visible sun is far brighter than the mean).
    pub fn lighting(&self, sun: Vec3, exposure: f32) -> Lighting {
        let upper = self.display(self.mean_upper, exposure);
        let lower = self.display(self.mean_lower, exposure);
        let b = Vec3::from(self.brightest);
        let mean = Vec3::from(self.mean_upper).element_sum().max(1e-6);
        let sun_visible = b.element_sum() > 8.0 * mean;
        let tint = (b / b.max_element().max(1e-6)).max(Vec3::splat(0.2));
        let strength = if sun_visible { 1.5 } else { 0.6 }
            * smoothstep(-0.03, 0.08, sun.y)
            * exposure.sqrt().min(2.0);
        Lighting {
            sun_color: (tint * strength).to_array(),
            zenith: upper.to_array(),
            horizon: upper.lerp(lower, 0.3).to_array(),
            ground: lower.to_array(),
        }
    }
}

/// The sky images a preset references, loaded once (and only those).
#[derive(Clone, Debug, Default)]
pub struct EnvironmentAssets {
    pub images: Vec<SkyImage>,
}

impl EnvironmentAssets {
    /// Decode every image the sky references (none for procedural and gradient skies).
    pub fn load(sky: &Sky) -> Result<Self, EnvironmentError> {
        let images = sky
            .image_sources()
            .into_iter()
            .map(load_sky_image)
            .collect::<Result<_, _>>()?;
        Ok(Self { images })
    }

    /// Index of an image by its source.
    pub fn position(&self, source: &SkyImageSource) -> Option<usize> {
        self.images.iter().position(|i| i.source == *source)
    }
}

use rand::SeedableRng;

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn preetham_sky_is_blue_at_noon_and_warm_near_the_horizon_at_sunset() {
        let noon = Preetham::new(2.5, sun_vector(60.0, 0.0).as_vec3());
        let z = noon.radiance(Vec3::Y);
        assert!(z.z > z.x, "zenith should be blue: {z}");
        // Brighter near the sun than opposite it.
        let towards = noon.radiance(sun_vector(20.0, 0.0).as_vec3());
        let away = noon.radiance(sun_vector(20.0, 180.0).as_vec3());
        assert!(towards.element_sum() > away.element_sum());
        let t_noon = sun_transmittance(2.5, 60f32.to_radians());
        let t_sunset = sun_transmittance(4.5, 3f32.to_radians());
        assert!(
            t_sunset.x / t_sunset.z > 3.0 * t_noon.x / t_noon.z,
            "{t_noon} {t_sunset}"
        );
    }

    #[test]
    fn random_skies_vary_per_frame_within_their_ranges_and_repeat_exactly() {
        let sky = Sky::Random {
            choices: EnvironmentName::ALL
                .iter()
                .map(|&e| Sky::procedural(e))
                .collect(),
            azimuth_offset_deg: (0.0, 360.0),
            sun_elevation_deg: Some((10.0, 20.0)),
            cloud_cover: Some((0.2, 0.4)),
        };
        let envs: Vec<FrameEnvironment> = (0..200).map(|i| frame_environment(&sky, 7, i)).collect();
        let chosen: std::collections::BTreeSet<usize> = envs.iter().map(|e| e.choice).collect();
        assert_eq!(chosen.len(), 7);
        for e in &envs {
            assert!((10.0..=20.0).contains(&e.sun_elevation_deg));
            assert!((0.2..=0.4).contains(&e.cloud_cover));
        }
        assert_eq!(envs[3], frame_environment(&sky, 7, 3));
        assert_ne!(envs[3], frame_environment(&sky, 8, 3));
    }
}

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

use glam::DVec3;
use rand::Rng;
use serde::Serialize;

mod builtin;
mod image;
pub mod meter;
pub(crate) mod noise;
pub mod plates;
mod preetham;
mod styles;

pub use crate::preset::EnvironmentName;
use crate::preset::{DEFAULT_HORIZON, DEFAULT_ZENITH, Sky};
pub use image::{
    EnvironmentAssets, EnvironmentError, MAX_SKY_SIDE, SkyImage, SkyImageKind, hash_sky_image,
    load_sky_image,
};
pub use preetham::{
    HAZE_TABLE, Lighting, Preetham, SKY_EXPOSURE, gradient_lighting, procedural_lighting,
    sun_transmittance, tone_map,
};
pub use styles::{EnvironmentStyle, Ground, Silhouette};

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
    /// Exposure offset in stops drawn by a `Random` sky's `exposure_ev` (0: none).
    #[serde(skip_serializing_if = "is_zero")]
    pub exposure_offset_ev: f64,
    /// Sunlight offset in stops drawn by a `Random` sky's `sun_ev` (0: none).
    #[serde(skip_serializing_if = "is_zero")]
    pub sun_offset_ev: f64,
}

fn is_zero(x: &f64) -> bool {
    *x == 0.0
}

/// Linear-to-sRGB as the shaders do it (`linear_to_srgb` in common.wgsl),
/// on a value clipped to [0, 1].
pub fn linear_to_srgb(c: f32) -> f32 {
    let x = c.clamp(0.0, 1.0);
    if x <= 0.003_130_8 {
        x * 12.92
    } else {
        1.055 * x.powf(1.0 / 2.4) - 0.055
    }
}

/// An 8-bit sRGB level as linear light (plates, pictures read on the CPU).
pub fn srgb_to_linear(c: u8) -> f64 {
    let c = f64::from(c) / 255.0;
    if c <= 0.04045 {
        c / 12.92
    } else {
        ((c + 0.055) / 1.055).powf(2.4)
    }
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
        exposure_offset_ev: 0.0,
        sun_offset_ev: 0.0,
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
/// stream: choice, azimuth offset, elevation, cloud cover, pattern seed, exposure
/// offset, sunlight offset — all seven are always drawn, so changing one range
/// never shifts the others (the exposure and the sunlight come last: skies
/// without them draw as before).
pub fn frame_environment(sky: &Sky, preset_seed: u64, index: u64) -> FrameEnvironment {
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(crate::seed::mix64(
        crate::seed::frame_seed(preset_seed, index) ^ ENVIRONMENT_SALT,
    ));
    let u = |rng: &mut rand_chacha::ChaCha8Rng| rng.random::<f64>();
    let (choice_u, az_u, el_u, cloud_u, seed) = (
        u(&mut rng),
        u(&mut rng),
        u(&mut rng),
        u(&mut rng),
        rng.random::<u32>(),
    );
    let exposure_u = u(&mut rng);
    let sun_u = u(&mut rng);
    let lerp = |(lo, hi): (f64, f64), t: f64| lo + (hi - lo) * t;
    match sky {
        Sky::Random {
            choices,
            azimuth_offset_deg,
            sun_elevation_deg,
            cloud_cover,
            exposure_ev,
            sun_ev,
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
            if let Some(range) = exposure_ev {
                env.exposure_offset_ev = lerp(*range, exposure_u);
            }
            if let Some(range) = sun_ev {
                env.sun_offset_ev = lerp(*range, sun_u);
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
        /// The sunlight's factor on the environment's own (2^`sun_ev`).
        sun: f32,
    },
    Image {
        /// Index into the preset's sky images (`Sky::image_sources` order).
        image: usize,
        exposure: f32,
        rotation_deg: f64,
    },
}

/// Koschmieder's constant: ln(1/0.02), the contrast threshold of 2 % that defines
/// visibility: a path of `d` metres in air of visibility `V` transmits exp(−K·d/V).
pub const KOSCHMIEDER: f64 = 3.912;

/// Zenith and horizon colours of the gradient that stands in for a sky that cannot be drawn.
pub const FALLBACK_ZENITH: [f32; 3] = [DEFAULT_ZENITH.0, DEFAULT_ZENITH.1, DEFAULT_ZENITH.2];
pub const FALLBACK_HORIZON: [f32; 3] = [DEFAULT_HORIZON.0, DEFAULT_HORIZON.1, DEFAULT_HORIZON.2];

/// The gradient that stands in when a `Random` sky has nothing to choose.
const FALLBACK_GRADIENT: FrameSky = FrameSky::Gradient {
    zenith: FALLBACK_ZENITH,
    horizon: FALLBACK_HORIZON,
};

/// The name of the environment a frame shows, for breakdowns: the chosen
/// sky of a `Random` sky, then `Gradient`, the procedural environment's name
/// (`Daytime`, …) or `Image:` and the image's file name.
pub fn environment_name(sky: &Sky, env: &FrameEnvironment) -> String {
    let chosen = match sky {
        Sky::Random { choices, .. } => choices.get(env.choice).unwrap_or(sky),
        other => other,
    };
    match chosen {
        Sky::Gradient { .. } => "Gradient".into(),
        Sky::Procedural { environment, .. } => environment.as_str().into(),
        Sky::Image { source, .. } => {
            let path = match source {
                crate::preset::SkyImageSource::Equirect(p) => p,
                crate::preset::SkyImageSource::Cubemap { px, .. } => px,
                crate::preset::SkyImageSource::Builtin(name) => return format!("Image:{name}"),
            };
            let name = path.file_name().map_or_else(
                || path.display().to_string(),
                |n| n.to_string_lossy().into_owned(),
            );
            format!("Image:{name}")
        }
        Sky::Random { .. } => "Random".into(),
    }
}

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
            sun_ev,
            ..
        } => FrameSky::Procedural {
            environment: *environment,
            exposure: 2f32.powf((exposure_ev + env.exposure_offset_ev) as f32),
            sun: 2f32.powf((sun_ev + env.sun_offset_ev) as f32),
        },
        Sky::Image {
            source,
            exposure_ev,
            rotation_deg,
            ..
        } => match root.image_sources().iter().position(|s| *s == source) {
            Some(image) => FrameSky::Image {
                image,
                exposure: 2f32.powf((exposure_ev + env.exposure_offset_ev) as f32),
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

use rand::SeedableRng;

#[cfg(test)]
mod tests {
    use super::*;
    use glam::Vec3;

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
            exposure_ev: None,
            sun_ev: None,
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

    #[test]
    fn a_random_sunlight_range_is_drawn_per_frame_and_moves_nothing_else() {
        let mut daytime = Sky::procedural(EnvironmentName::Daytime);
        if let Sky::Procedural { sun_ev, .. } = &mut daytime {
            *sun_ev = 0.5;
        }
        let choices = vec![daytime];
        let sky = |sun_ev| Sky::Random {
            choices: choices.clone(),
            azimuth_offset_deg: (0.0, 360.0),
            sun_elevation_deg: Some((10.0, 20.0)),
            cloud_cover: None,
            exposure_ev: None,
            sun_ev,
        };
        let (with, without) = (sky(Some((-1.0, 1.0))), sky(None));
        let mut offsets = Vec::new();
        for i in 0..50 {
            let (a, b) = (
                frame_environment(&with, 3, i),
                frame_environment(&without, 3, i),
            );
            assert!((-1.0..=1.0).contains(&a.sun_offset_ev), "{a:?}");
            assert_eq!(b.sun_offset_ev, 0.0);
            // Drawn last: the other draws are the frame's without the range.
            assert_eq!(
                FrameEnvironment {
                    sun_offset_ev: 0.0,
                    ..a.clone()
                },
                b
            );
            match resolve(&with, &a) {
                FrameSky::Procedural { sun, .. } => {
                    assert_eq!(sun, 2f32.powf((0.5 + a.sun_offset_ev) as f32));
                }
                other => panic!("{other:?}"),
            }
            offsets.push(a.sun_offset_ev);
        }
        offsets.sort_by(f64::total_cmp);
        assert!(offsets[49] - offsets[0] > 1.0, "{offsets:?}");
    }
}

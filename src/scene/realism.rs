//! The realism draws of a frame (issue 21), each from its own salted stream
//! of (preset seed, frame index) (`seed::salted_rng`): the atmosphere's
//! visibility, the drones' looks, the observer camera's pose. All are absent
//! (and draw nothing) unless the preset asks for them.

use glam::{DMat3, DVec3};
use rand::Rng;
use rand_chacha::ChaCha8Rng;
use serde::Serialize;

use super::math::look_at_cv;
use crate::preset::Preset;
use crate::preset::appearance::{Appearance, DroneColor};
use crate::preset::observer::ObserverCamera;
use crate::seed;

/// Koschmieder's constant, owned by [`crate::sky`] (the sky's haze and the meter use it
/// beneath the scene); here for the scene's atmosphere and its callers.
pub use crate::sky::KOSCHMIEDER;

/// The frame's atmosphere.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct FrameAtmosphere {
    /// Meteorological visibility V, metres.
    pub visibility_m: f64,
}

impl FrameAtmosphere {
    /// Transmittance of a path of `distance_m`: exp(−3.912·d/V).
    pub fn transmittance(&self, distance_m: f64) -> f64 {
        (-KOSCHMIEDER * distance_m / self.visibility_m).exp()
    }
}

/// One drone's material, replacing its model's glTF materials.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct DroneLook {
    /// The palette entry drawn (its albedo below).
    pub color: DroneColor,
    /// Linear base colour.
    pub albedo: [f32; 3],
    pub roughness: f32,
    pub metalness: f32,
    /// Emission as a multiple of the albedo (0: none).
    pub emissive: f32,
    /// Factor on the alpha of the model's glTF BLEND triangles (the built-in
    /// models' rotor discs): 1 draws them as the model says (opaque discs).
    pub rotor_opacity: f32,
}

fn uniform(rng: &mut ChaCha8Rng, (lo, hi): (f64, f64)) -> f64 {
    let u: f64 = rng.random();
    lo + (hi - lo) * u
}

/// The atmosphere of frame `draw_index` (the sequence's first frame in sequence mode).
pub fn frame_atmosphere(preset: &Preset, draw_index: u64) -> Option<FrameAtmosphere> {
    let a = preset.atmosphere.as_ref()?;
    let mut rng = seed::salted_rng(preset.seed, draw_index, seed::ATMOSPHERE_SALT);
    Some(FrameAtmosphere {
        visibility_m: uniform(&mut rng, a.visibility_m),
    })
}

fn srgb_to_linear(c: f64) -> f64 {
    if c <= 0.04045 {
        c / 12.92
    } else {
        ((c + 0.055) / 1.055).powf(2.4)
    }
}

/// A saturated colour of hue `h` in [0, 1) (HSV with s = 0.85, v = 0.8, as sRGB), linear.
fn hue_color(h: f64) -> [f32; 3] {
    let (s, v) = (0.85, 0.8);
    let k = |n: f64| {
        let k = (n + h * 6.0) % 6.0;
        v - v * s * k.min(4.0 - k).clamp(0.0, 1.0)
    };
    [k(5.0), k(3.0), k(1.0)].map(|c| srgb_to_linear(c) as f32)
}

/// The looks of `count` drones. Per drone, in drone order: colour, hue, roughness,
/// metalness, lights (yes/no), emission strength: always six draws, so
/// changing one range never shifts the others.
pub fn drone_looks(
    appearance: &Appearance,
    preset_seed: u64,
    draw_index: u64,
    count: usize,
) -> Vec<DroneLook> {
    let mut rng = seed::salted_rng(preset_seed, draw_index, seed::APPEARANCE_SALT);
    // Rotor opacities from their own stream: the other six draws stay as they were.
    let mut rotor_rng = seed::salted_rng(preset_seed, draw_index, seed::ROTOR_SALT);
    let total: f64 = appearance.palette.iter().map(|(_, w)| w).sum();
    (0..count)
        .map(|_| {
            let pick = uniform(&mut rng, (0.0, total));
            let hue: f64 = rng.random();
            let roughness = uniform(&mut rng, appearance.roughness) as f32;
            let metalness = uniform(&mut rng, appearance.metalness) as f32;
            let lit: f64 = rng.random();
            let strength = uniform(&mut rng, appearance.emissive_strength) as f32;
            let mut acc = 0.0;
            let color = appearance
                .palette
                .iter()
                .find(|(_, w)| {
                    acc += w;
                    pick < acc
                })
                .or_else(|| appearance.palette.iter().rev().find(|(_, w)| *w > 0.0))
                .map_or(DroneColor::LightGrey, |(c, _)| *c);
            let albedo = match color {
                DroneColor::White => [0.8; 3],
                DroneColor::LightGrey => [0.45; 3],
                DroneColor::DarkGrey => [0.12; 3],
                DroneColor::Black => [0.03; 3],
                DroneColor::Coloured => hue_color(hue),
            };
            DroneLook {
                color,
                albedo,
                roughness,
                metalness,
                emissive: if lit < appearance.emissive_share {
                    strength
                } else {
                    0.0
                },
                rotor_opacity: uniform(&mut rotor_rng, appearance.rotor_opacity) as f32,
            }
        })
        .collect()
}

/// The observer camera's pose for frame `draw_index`: (camera centre, point looked at).
/// Draw order: elevation, azimuth, distance (or apparent size). With `centre_at` the
/// volume's centre (the origin) lies at depth D on the ray through that point of the
/// frame and the camera looks along the same line of sight.
pub fn observer_pose(
    observer: &ObserverCamera,
    preset: &Preset,
    draw_index: u64,
    focal_px: f64,
) -> (DVec3, DVec3) {
    let mut rng = seed::salted_rng(preset.seed, draw_index, seed::OBSERVER_SALT);
    let elevation = uniform(&mut rng, observer.elevation_deg).to_radians();
    let azimuth = uniform(&mut rng, observer.azimuth_deg).to_radians();
    let distance_m = match observer.size_px {
        Some(range) => {
            let size_m = preset.models.iter().map(|m| m.size_m).fold(0.0, f64::max);
            let u: f64 = rng.random();
            focal_px * size_m / observer.size_at(range, u)
        }
        None => uniform(&mut rng, observer.distance_m),
    };
    let line_of_sight = DVec3::new(
        elevation.cos() * azimuth.sin(),
        elevation.sin(),
        elevation.cos() * azimuth.cos(),
    );
    let Some((x, y)) = observer.centre_at else {
        return (-line_of_sight * distance_m, DVec3::ZERO);
    };
    // The ray through (x, y) with unit depth along the line of sight, from the camera's
    // axes (rows of camera_from_world: right, down, forward).
    let axes = look_at_cv(DVec3::ZERO, line_of_sight).unwrap_or(DMat3::IDENTITY);
    let (w, h) = preset.image_size();
    let (dx, dy) = (
        (x - 0.5) * f64::from(w) / focal_px,
        (y - 0.5) * f64::from(h) / focal_px,
    );
    let ray = line_of_sight + axes.row(0) * dx + axes.row(1) * dy;
    let eye = -ray * distance_m;
    (eye, eye + line_of_sight * distance_m)
}

/// Auto-exposure (`camera_model.auto_exposure`): the metered EV of `scene`,
/// its plate and camera already set, from what its background shows
/// ([`crate::sky::meter`]): the backplate's pixels (`plates`), an image
/// sky's texels (`images`, in `Sky::image_sources` order), or the
/// procedural or gradient sky the renderer draws. Does nothing without
/// auto-exposure; a missing image or plate leaves the EV at 0.
pub fn meter_exposure(
    scene: &mut super::FrameScene,
    images: &[crate::sky::SkyImage],
    plates: &[crate::sky::plates::Plate],
) {
    use crate::sky::{FrameSky, meter};
    let Some(target) = (scene.camera_model.as_ref())
        .and_then(|d| d.auto_exposure)
        .map(|a| a.target_level)
    else {
        return;
    };
    let view = scene.camera.meter_view();
    let samples = match (&scene.backplate, scene.sky) {
        (Some(b), _) => plates
            .get(b.plate)
            .map(|p| meter::rgba_samples(&p.rgba, p.size)),
        (
            None,
            FrameSky::Image {
                image,
                exposure,
                rotation_deg,
            },
        ) => images
            .get(image)
            .map(|img| meter::image_samples(img, exposure, rotation_deg, &view)),
        (None, sky) => meter::background_samples(
            &sky,
            &scene.environment,
            &view,
            scene.atmosphere.map(|a| a.visibility_m),
        ),
    };
    let ev = samples
        .as_deref()
        .map_or(0.0, |s| meter::exposure_for(s, target));
    if let Some(auto) = (scene.camera_model.as_mut()).and_then(|d| d.auto_exposure.as_mut()) {
        auto.metered_ev = ev;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn looks_follow_the_palette_weights_and_ranges() {
        let a = Appearance {
            palette: vec![(DroneColor::White, 1.0), (DroneColor::Black, 3.0)],
            roughness: (0.2, 0.4),
            metalness: (0.5, 0.5),
            emissive_share: 0.5,
            emissive_strength: (1.0, 2.0),
            rotor_opacity: (0.2, 0.6),
        };
        let looks = drone_looks(&a, 7, 3, 4000);
        assert!(looks.iter().all(|l| (0.2..=0.6).contains(&l.rotor_opacity)));
        // The rotor draws come from their own stream: the other draws are those of solid rotors.
        let solid = drone_looks(
            &Appearance {
                rotor_opacity: (1.0, 1.0),
                ..a.clone()
            },
            7,
            3,
            4000,
        );
        assert!(looks.iter().zip(&solid).all(|(x, y)| x.albedo == y.albedo
            && x.roughness == y.roughness
            && x.emissive == y.emissive));
        let white = looks.iter().filter(|l| l.albedo == [0.8; 3]).count();
        let black = looks.iter().filter(|l| l.albedo == [0.03; 3]).count();
        assert_eq!(white + black, 4000);
        assert!((white as f64 / 4000.0 - 0.25).abs() < 0.03, "{white}");
        assert!(
            looks
                .iter()
                .all(|l| (0.2..=0.4).contains(&l.roughness) && l.metalness == 0.5)
        );
        let lit = looks.iter().filter(|l| l.emissive > 0.0).count();
        assert!((lit as f64 / 4000.0 - 0.5).abs() < 0.03, "{lit}");
        assert!(
            looks
                .iter()
                .all(|l| l.emissive == 0.0 || (1.0..=2.0).contains(&l.emissive))
        );
        // Deterministic, and another frame draws differently.
        assert_eq!(looks, drone_looks(&a, 7, 3, 4000));
        assert_ne!(looks, drone_looks(&a, 7, 4, 4000));
    }

    #[test]
    fn transmittance_is_two_percent_at_the_visibility() {
        let a = FrameAtmosphere {
            visibility_m: 900.0,
        };
        assert!((a.transmittance(900.0) - 0.02).abs() < 1e-4);
        // The case: 800 m at 900 m visibility keeps 3 % of its contrast.
        assert!((a.transmittance(800.0) - 0.031).abs() < 1e-3);
        assert_eq!(a.transmittance(0.0), 1.0);
    }
}

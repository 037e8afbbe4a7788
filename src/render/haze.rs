//! The atmosphere's and the appearance's per-drone instance data (issue 21):
//! the in-scattered sky light L_air towards each drone and each drone's drawn
//! material. The blend `L0·t + L_air·(1 − t)`, t = exp(−3.912·d/V) with d the
//! distance of each pixel's surface point, is done in `shaders/drone.wgsl`
//! in linear light before the sRGB encoding.
//!
//! Why L_air is computed here on the CPU, once per drone, rather than in the
//! shader: the drone pipeline does not bind the environment's uniforms, and
//! the horizon radiance varies slowly with azimuth, so one value per drone
//! (at the azimuth of its centre) is exact enough for drones that span a few
//! pixels, and it costs 3 floats per instance.

use glam::Vec3;

use crate::scene::FrameScene;
use crate::sky::{FrameSky, Preetham, SKY_EXPOSURE, tone_map};

/// Elevation (the y of an unnormalised direction) at which the procedural
/// sky's shader takes its haze colour.
const HAZE_ELEVATION: f32 = 0.02;

/// The air light (display-linear RGB) towards drone `i`: the sky's radiance
/// at the horizon in the azimuth of the drone, the colour the environment's
/// own fog fades into; under a backplate, the plate's colour around the
/// drone. `None` for image skies: the shader then uses the frame's horizon
/// term (`Frame.horizon`, the image's average horizon).
pub(crate) fn airlight(scene: &FrameScene, i: usize) -> Option<[f32; 3]> {
    // Under a backplate: the plate's sky around the drone (`scene::plate_air`).
    if let Some(plate) = &scene.backplate {
        return plate.air_light.get(i).copied().flatten();
    }
    match scene.sky {
        FrameSky::Gradient { horizon, .. } => Some(horizon),
        FrameSky::Procedural { exposure, .. } => {
            let d = (scene.drones[i].position - scene.camera.position).as_vec3();
            let az = Vec3::new(d.x, 0.0, d.z).normalize_or(Vec3::Z);
            let sky = Preetham::new(
                scene.environment.turbidity as f32,
                scene.sun_direction.as_vec3(),
            );
            let dir = Vec3::new(az.x, HAZE_ELEVATION, az.z);
            Some(tone_map(sky.radiance(dir) * SKY_EXPOSURE * exposure).to_array())
        }
        FrameSky::Image { .. } => None,
    }
}

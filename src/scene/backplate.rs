//! The backplate draw of a frame (`backplate` in a preset; docs/realism.md,
//! "Photographic backgrounds"): which plate, mirrored or not, and the camera
//! and sun that agree with it. From its own salted stream ("BACKPLAT"; the
//! sequence's first frame in sequence mode), always five numbers in this
//! order: plate, flip, elevation (used when the horizon is unknown), sun
//! elevation, sun azimuth. The camera's azimuth and distance are the
//! observer camera's draws (`camera.observer`, or its defaults), its
//! elevation is the one the plate's horizon implies, its field of view the
//! plate's. Pure: the plates' geometry was read when the pipeline was built.

use rand::Rng;
use serde::Serialize;

use super::FrameScene;
use super::math::look_at_cv;
use super::realism::observer_pose;
use crate::preset::Preset;
use crate::preset::observer::ObserverCamera;
use crate::seed;
use crate::sky::plates::Plate;

/// The plate a frame shows and the camera it implies.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct FramePlate {
    /// Index into the loaded plates (file-name order).
    pub plate: usize,
    /// The plate's file name.
    pub file: String,
    /// Mirrored left-right.
    pub flip: bool,
    /// The horizon's row in the output, pixels from the top (`None`: unknown).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub horizon_row_px: Option<f64>,
    /// The line of sight's elevation, degrees.
    pub elevation_deg: f64,
    /// Per drone, the haze's air light: the plate's mean linear colour around
    /// the drone (`plate_air`); empty without an atmosphere. Not written anywhere.
    #[serde(skip)]
    pub air_light: Vec<Option<[f32; 3]>>,
}

fn lerp((lo, hi): (f64, f64), t: f64) -> f64 {
    lo + (hi - lo) * t
}

/// Put the frame's plate into `scene`: the camera re-aimed from below at the
/// elevation the plate's horizon implies, with the plate's field of view;
/// the sun drawn relative to the line of sight. Does nothing without
/// `preset.backplate` or without plates.
pub fn apply(scene: &mut FrameScene, preset: &Preset, plates: &[Plate]) {
    let (Some(b), false) = (&preset.backplate, plates.is_empty()) else {
        return;
    };
    let draw_index = scene.sequence.map_or(scene.index, |s| s.first_index);
    let mut rng = seed::salted_rng(preset.seed, draw_index, seed::BACKPLATE_SALT);
    let mut u = || rng.random::<f64>();
    let (u_plate, u_flip, u_elevation, u_sun_el, u_sun_az) = (u(), u(), u(), u(), u());
    let index = ((u_plate * plates.len() as f64) as usize).min(plates.len() - 1);
    let plate = &plates[index];
    let (width, height) = (scene.camera.width, scene.camera.height);
    let (fov_y_deg, horizon_row_px) = plate.geometry.in_output((width, height));
    let focal_px = f64::from(height) * 0.5 / (fov_y_deg.to_radians() * 0.5).tan();
    // A camera without roll sees the horizon at v = cy + f·tan E.
    let elevation_deg = match horizon_row_px {
        Some(v) => ((v - f64::from(height) * 0.5) / focal_px)
            .atan()
            .to_degrees(),
        None => lerp(b.elevation_deg, u_elevation),
    }
    .clamp(-80.0, 80.0);
    let observer = ObserverCamera {
        elevation_deg: (elevation_deg, elevation_deg),
        ..preset.camera.observer.clone().unwrap_or_default()
    };
    let (eye, target) = observer_pose(&observer, preset, draw_index, focal_px);
    // Validation excludes camera.absolute: the look-at point is the swarm's shift.
    let shift = scene.look_at;
    let (eye, target) = (eye + shift, target + shift);
    scene.camera.position = eye;
    scene.camera.fov_y_deg = fov_y_deg;
    scene.camera.camera_from_world = look_at_cv(eye, target).unwrap_or(glam::DMat3::IDENTITY);
    let sight = target - eye;
    let sight_azimuth_deg = sight.x.atan2(sight.z).to_degrees();
    let env = &mut scene.environment;
    env.sun_elevation_deg = lerp(b.sun_elevation_deg, u_sun_el);
    env.sun_azimuth_deg = sight_azimuth_deg + lerp(b.sun_azimuth_deg, u_sun_az);
    scene.sun_direction = env.sun_direction();
    scene.environment_name = format!("Plate:{}", plate.name());
    let flip = b.flip && u_flip < 0.5;
    let air_light = match scene.atmosphere {
        Some(_) => super::plate_air::plate_airlights(scene, plate, flip),
        None => Vec::new(),
    };
    scene.backplate = Some(FramePlate {
        plate: index,
        file: plate.name(),
        flip,
        horizon_row_px,
        elevation_deg,
        air_light,
    });
}

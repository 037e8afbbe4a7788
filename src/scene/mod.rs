//! The scene of one frame as plain data, and the frame function that makes it.
//!
//! `build_frame(preset, index)` is pure: it reads no clock, file or global
//! RNG, so any frame can be made alone and gives the same result everywhere.
//! Draw order from the frame's sampler (see `seed`): the drone count
//! (randomized mode), then per drone its model, its position (retried until
//! it keeps the minimum separation), then roll, pitch, yaw.
//! The environment (sky choice, sun, clouds) draws from a separately salted
//! stream (`environment::frame_environment`), so it never shifts these.

use glam::{DQuat, DVec3};
use serde::Serialize;

pub mod camera;
pub mod math;
pub mod placement;
pub mod projection;

use crate::preset::sweep::decode_mixed_radix;
use crate::preset::{Preset, Sky};
use crate::seed;
use crate::sky::{FrameEnvironment, FrameSky};
use camera::Camera;
use math::{EulerDeg, look_at_cv, plane_rotation};

/// Which subset a frame belongs to.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, PartialOrd, Ord)]
#[serde(rename_all = "lowercase")]
pub enum SplitName {
    Train,
    Val,
    Test,
}

impl SplitName {
    pub const ALL: [Self; 3] = [Self::Train, Self::Val, Self::Test];
    pub fn as_str(self) -> &'static str {
        match self {
            Self::Train => "train",
            Self::Val => "val",
            Self::Test => "test",
        }
    }
}

/// The sweep values of a frame (the paper's names).
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
#[allow(non_snake_case)]
pub struct SweepValues {
    pub CameraX: f64,
    pub CameraY: f64,
    pub CameraZ: f64,
    pub PlaneRX: f64,
    pub PlaneRY: f64,
    pub PlaneRZ: f64,
    pub repeat: u64,
}

/// One placed drone.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct DronePose {
    /// Index into the preset's models.
    pub model: usize,
    /// Centre of the model's bounding box, world metres.
    pub position: DVec3,
    /// World attitude (scene rotation included), unit quaternion.
    pub rotation: DQuat,
    /// The same attitude as roll/pitch/yaw degrees.
    pub euler_deg: EulerDeg,
    /// Largest span in metres.
    pub size_m: f64,
}

/// Everything needed to render and label one frame.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct FrameScene {
    pub index: u64,
    pub seed: u64,
    pub split: SplitName,
    pub sweep: SweepValues,
    pub camera: Camera,
    pub drones: Vec<DronePose>,
    /// Unit vector towards the sun, world frame (`environment.sun_direction()`).
    pub sun_direction: DVec3,
    /// The frame's environment draws (which sky, sun, clouds, pattern seed).
    pub environment: FrameEnvironment,
    /// The sky the renderer draws: the preset's sky with those draws applied.
    pub sky: FrameSky,
    /// Radius R of the observation volume's bounding sphere (drone extent included).
    pub volume_radius_m: f64,
    /// Half extent of the observation volume before the scene rotation, metres.
    pub volume_half_extent_m: DVec3,
    /// Drones that randomized placement could not fit at the minimum separation.
    pub placement_shortfall: u32,
}

#[derive(Debug, thiserror::Error, PartialEq)]
pub enum FrameError {
    #[error("frame {index} is out of range: the preset has {count} frames")]
    OutOfRange { index: u64, count: u64 },
    #[error("the preset's sweeps are invalid: {0}")]
    Sweep(#[from] crate::preset::sweep::SweepError),
}

/// Unit vector towards the sun of a sky without its per-frame randomisation
/// (azimuth from +Z towards +X, elevation above the horizon). A frame's own
/// sun is `FrameScene::sun_direction`.
pub fn sun_direction(sky: &Sky) -> DVec3 {
    crate::sky::nominal_sun_direction(sky)
}

/// The camera centre for sweep values (CameraX, CameraY, CameraZ): X and Y in
/// units of the volume radius R, Z in units of the distance at which the
/// sphere of radius R just fits the vertical field of view.
pub fn camera_position(
    camera_x: f64,
    camera_y: f64,
    camera_z: f64,
    volume_radius_m: f64,
    fov_y_deg: f64,
) -> DVec3 {
    let d_fit = volume_radius_m / (fov_y_deg.to_radians() * 0.5).sin();
    DVec3::new(
        camera_x * volume_radius_m,
        camera_y * volume_radius_m,
        camera_z * d_fit,
    )
}

/// Build frame `index` of `preset`: sweep values from the index, drones
/// from the frame's own RNG, the camera aimed at the volume's centre, the sky
/// from its own salted stream, the split from the split draw.
pub fn build_frame(preset: &Preset, index: u64) -> Result<FrameScene, FrameError> {
    let sweep = sweep_values(preset, index)?;
    let mut rng = seed::frame_rng(preset.seed, index);
    let placed = placement::place(preset, &mut rng);
    let volume_radius_m = placed.half_extent.length() + placement::max_model_radius(preset);

    let plane = plane_rotation(sweep.PlaneRX, sweep.PlaneRY, sweep.PlaneRZ);
    let drones = placed
        .drones
        .into_iter()
        .map(|(model, position, rotation)| {
            let rotation = (plane * rotation).normalize();
            DronePose {
                model,
                position: plane * position,
                rotation,
                euler_deg: EulerDeg::from_quat(rotation),
                size_m: preset.models[model].size_m,
            }
        })
        .collect();
    let camera = frame_camera(preset, &sweep, volume_radius_m);
    // The environment draws come from their own salted stream (see `sky`).
    let environment = crate::sky::frame_environment(&preset.sky, preset.seed, index);

    Ok(FrameScene {
        index,
        seed: seed::frame_seed(preset.seed, index),
        split: split_of(preset, index),
        sweep,
        camera,
        drones,
        sun_direction: environment.sun_direction(),
        sky: crate::sky::resolve(&preset.sky, &environment),
        environment,
        volume_radius_m,
        volume_half_extent_m: placed.half_extent,
        placement_shortfall: placed.shortfall,
    })
}

/// The sweep values of frame `index` (the index decoded in mixed radix, CameraX outermost).
pub fn sweep_values(preset: &Preset, index: u64) -> Result<SweepValues, FrameError> {
    let radices = preset.frame_radices()?;
    let count = radices.iter().product::<u64>();
    if index >= count {
        return Err(FrameError::OutOfRange { index, count });
    }
    let d = decode_mixed_radix(index, &radices);
    let axes = preset.sweep_axes();
    let v = |k: usize| axes[k].1.value(d[k]);
    Ok(SweepValues {
        CameraX: v(0),
        CameraY: v(1),
        CameraZ: v(2),
        PlaneRX: v(3),
        PlaneRY: v(4),
        PlaneRZ: v(5),
        repeat: d[6],
    })
}

/// The frame's camera: placed by the sweep values relative to the volume, looking at its centre.
fn frame_camera(preset: &Preset, sweep: &SweepValues, volume_radius_m: f64) -> Camera {
    let (width, height) = preset.image_size();
    let fov_y_deg = preset.camera.fov_y_deg;
    let position = camera_position(
        sweep.CameraX,
        sweep.CameraY,
        sweep.CameraZ,
        volume_radius_m,
        fov_y_deg,
    );
    // Validation keeps the camera off the centre; fall back to identity if it ever sits there.
    let camera_from_world = look_at_cv(position, DVec3::ZERO).unwrap_or(glam::DMat3::IDENTITY);
    let min_size = preset
        .models
        .iter()
        .map(|m| m.size_m)
        .fold(f64::INFINITY, f64::min);
    Camera {
        width,
        height,
        fov_y_deg,
        position,
        camera_from_world,
        near_m: (min_size * 0.01).clamp(1e-5, 0.05),
    }
}

/// The split of frame `index`, from its split draw and the preset's shares.
fn split_of(preset: &Preset, index: u64) -> SplitName {
    let u = seed::split_uniform(preset.seed, index);
    let s = &preset.output.split;
    if u < s.train {
        SplitName::Train
    } else if u < s.train + s.val {
        SplitName::Val
    } else {
        SplitName::Test
    }
}

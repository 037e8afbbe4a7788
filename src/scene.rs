//! The scene of one frame as plain data, and the frame function that makes it.
//!
//! `build_frame(preset, index)` is pure: it reads no clock, file or global
//! RNG, so any frame can be made alone and gives the same result everywhere.
//! Draw order from the frame's sampler (see `seed`): the drone count
//! (randomized mode), then per drone its model, its position (retried until
//! it keeps the minimum separation), then roll, pitch, yaw.
//! The environment (sky choice, sun, clouds) draws from a separately salted
//! stream (`environment::frame_environment`), so it never shifts these.

use std::collections::HashMap;

use glam::{DQuat, DVec3, IVec3};
use rand::Rng;
use serde::Serialize;

use crate::camera::Camera;
use crate::environment::FrameEnvironment;
use crate::math::{EulerDeg, look_at_cv, plane_rotation};
use crate::preset::{AttitudeRanges, Placement, Preset, Sky, Volume};
use crate::seed;
use crate::sweep::decode_mixed_radix;

/// Attempts per drone before randomized placement gives up on it.
const PLACEMENT_ATTEMPTS: u32 = 200;

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
    /// Radius R of the observation volume's bounding sphere (drone extent included).
    pub volume_radius_m: f64,
    /// Drones that randomized placement could not fit at the minimum separation.
    pub placement_shortfall: u32,
}

#[derive(Debug, thiserror::Error, PartialEq)]
pub enum FrameError {
    #[error("frame {index} is out of range: the preset has {count} frames")]
    OutOfRange { index: u64, count: u64 },
    #[error("the preset's sweeps are invalid: {0}")]
    Sweep(#[from] crate::sweep::SweepError),
}

/// Unit vector towards the sun of a sky without its per-frame randomisation
/// (azimuth from +Z towards +X, elevation above the horizon). A frame's own
/// sun is `FrameScene::sun_direction`.
pub fn sun_direction(sky: &Sky) -> DVec3 {
    crate::environment::nominal_sun_direction(sky)
}

/// The bounding-sphere radius of a model of largest span `size_m` centred on its box.
fn model_radius(size_m: f64) -> f64 {
    size_m * 3f64.sqrt() * 0.5
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

/// Build frame `index` of `preset`.
pub fn build_frame(preset: &Preset, index: u64) -> Result<FrameScene, FrameError> {
    let radices = preset.frame_radices()?;
    let count = radices.iter().product::<u64>();
    if index >= count {
        return Err(FrameError::OutOfRange { index, count });
    }
    let d = decode_mixed_radix(index, &radices);
    let axes = preset.sweep_axes();
    let v = |k: usize| axes[k].1.value(d[k]);
    let sweep = SweepValues {
        CameraX: v(0),
        CameraY: v(1),
        CameraZ: v(2),
        PlaneRX: v(3),
        PlaneRY: v(4),
        PlaneRZ: v(5),
        repeat: d[6],
    };

    let frame_seed = seed::frame_seed(preset.seed, index);
    let mut rng = seed::frame_rng(preset.seed, index);
    let (local, half_extent, shortfall) = place(preset, &mut rng);
    let max_radius = preset
        .models
        .iter()
        .map(|m| model_radius(m.size_m))
        .fold(0.0, f64::max);
    let volume_radius_m = half_extent.length() + max_radius;

    let plane = plane_rotation(sweep.PlaneRX, sweep.PlaneRY, sweep.PlaneRZ);
    let drones = local
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
    let camera = Camera {
        width,
        height,
        fov_y_deg,
        position,
        camera_from_world,
        near_m: (min_size * 0.01).clamp(1e-5, 0.05),
    };

    // The environment draws come from their own salted stream (see `environment`).
    let environment = crate::environment::frame_environment(&preset.sky, preset.seed, index);
    let u = seed::split_uniform(preset.seed, index);
    let s = &preset.output.split;
    let split = if u < s.train {
        SplitName::Train
    } else if u < s.train + s.val {
        SplitName::Val
    } else {
        SplitName::Test
    };

    Ok(FrameScene {
        index,
        seed: frame_seed,
        split,
        sweep,
        camera,
        drones,
        sun_direction: environment.sun_direction(),
        environment,
        volume_radius_m,
        placement_shortfall: shortfall,
    })
}

fn sample_attitude<R: Rng>(rng: &mut R, ranges: &AttitudeRanges) -> DQuat {
    EulerDeg {
        roll: sample_range(rng, ranges.roll_deg),
        pitch: sample_range(rng, ranges.pitch_deg),
        yaw: sample_range(rng, ranges.yaw_deg),
    }
    .to_quat()
}

fn sample_range(rng: &mut impl Rng, (lo, hi): (f64, f64)) -> f64 {
    if hi > lo {
        rng.random_range(lo..=hi)
    } else {
        lo
    }
}

/// Drones in the unrotated volume: (model, position, attitude), the volume's
/// half extent, and the number that could not be placed.
fn place(preset: &Preset, rng: &mut impl Rng) -> (Vec<(usize, DVec3, DQuat)>, DVec3, u32) {
    let n_models = preset.models.len().max(1);
    let attitude = |rng: &mut _| sample_attitude(rng, &preset.attitude);
    match &preset.placement {
        Placement::Structured {
            x_count,
            y_count,
            z_count,
            load_factor,
        } => {
            let spacing = load_factor * preset.max_model_size_m();
            let counts = IVec3::new(*x_count as i32, *y_count as i32, *z_count as i32);
            let half = (counts - 1).as_dvec3() * spacing * 0.5;
            let mut out = Vec::with_capacity((x_count * y_count * z_count) as usize);
            for i in 0..counts.x {
                for j in 0..counts.y {
                    for k in 0..counts.z {
                        let model = rng.random_range(0..n_models);
                        let p = IVec3::new(i, j, k).as_dvec3() * spacing - half;
                        out.push((model, p, attitude(rng)));
                    }
                }
            }
            (out, half, 0)
        }
        Placement::Randomized {
            count: (lo, hi),
            volume,
            min_separation_m,
        } => {
            let n = if hi > lo {
                rng.random_range(*lo..=*hi)
            } else {
                *lo
            };
            let size = match volume {
                Volume::Box { size_m: (x, y, z) } => DVec3::new(*x, *y, *z),
                Volume::Density { per_m3 } => DVec3::splat((f64::from(n) / per_m3).cbrt()),
            };
            let half = size * 0.5;
            let sep = *min_separation_m;
            let mut grid = SeparationGrid::new(sep);
            let mut out = Vec::with_capacity(n as usize);
            let mut shortfall = 0;
            for _ in 0..n {
                let model = rng.random_range(0..n_models);
                let mut placed = None;
                for _ in 0..PLACEMENT_ATTEMPTS {
                    let p = DVec3::new(
                        sample_range(rng, (-half.x, half.x)),
                        sample_range(rng, (-half.y, half.y)),
                        sample_range(rng, (-half.z, half.z)),
                    );
                    if grid.is_free(p) {
                        placed = Some(p);
                        break;
                    }
                }
                match placed {
                    Some(p) => {
                        grid.insert(p);
                        out.push((model, p, attitude(rng)));
                    }
                    None => shortfall += 1,
                }
            }
            (out, half, shortfall)
        }
    }
}

/// A hash grid of cell size = separation, so the separation test looks at 27 cells.
struct SeparationGrid {
    separation: f64,
    cells: HashMap<IVec3, Vec<DVec3>>,
}

impl SeparationGrid {
    fn new(separation: f64) -> Self {
        Self {
            separation,
            cells: HashMap::new(),
        }
    }

    fn cell(&self, p: DVec3) -> IVec3 {
        (p / self.separation).floor().as_ivec3()
    }

    fn is_free(&self, p: DVec3) -> bool {
        if self.separation <= 0.0 {
            return true;
        }
        let c = self.cell(p);
        let sep2 = self.separation * self.separation;
        for dx in -1..=1 {
            for dy in -1..=1 {
                for dz in -1..=1 {
                    if let Some(points) = self.cells.get(&(c + IVec3::new(dx, dy, dz)))
                        && points.iter().any(|q| q.distance_squared(p) < sep2)
                    {
                        return false;
                    }
                }
            }
        }
        true
    }

    fn insert(&mut self, p: DVec3) {
        if self.separation > 0.0 {
            let c = self.cell(p);
            self.cells.entry(c).or_default().push(p);
        }
    }
}

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

pub mod backplate;
pub mod camera;
pub mod clutter;
pub mod confusers;
pub mod math;
pub mod motion;
pub mod placement;
pub mod plate_air;
pub mod projection;
pub mod realism;
pub mod split;
pub mod weather;

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
    /// The swept density ρ of a `DensitySweep` volume (drones per m³).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub density_per_m3: Option<f64>,
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
    /// The environment's name (a `Random` sky's choice; see `sky::environment_name`).
    pub environment_name: String,
    /// Radius R of the observation volume's bounding sphere (drone extent included).
    pub volume_radius_m: f64,
    /// Half extent of the observation volume before the scene rotation, metres.
    pub volume_half_extent_m: DVec3,
    /// Drones that randomized placement could not fit at the minimum separation.
    pub placement_shortfall: u32,
    /// Where the frame sits in its sequence (sequence mode only).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub sequence: Option<SequenceFrame>,
    /// The point the camera looks at, world metres.
    pub look_at: DVec3,
    /// The camera is the preset's absolute pose (`camera.absolute`), not the relative sweep.
    #[serde(skip_serializing_if = "std::ops::Not::not")]
    pub camera_absolute: bool,
    /// Which draw of the placement this is: 0, or the re-draw that gave the
    /// frame `labels.min_labelled` boxes (`seed` is then that draw's seed).
    #[serde(skip_serializing_if = "is_zero")]
    pub redraw: u32,
    /// The camera model's draws (only when the preset has `camera_model`).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub camera_model: Option<crate::sensor::CameraDraw>,
    /// The frame's atmosphere (`atmosphere` in the preset); `None`: no haze on the drones.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub atmosphere: Option<realism::FrameAtmosphere>,
    /// Each drone's material (`appearance` in the preset), in drone order; empty: the models' own.
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub looks: Vec<realism::DroneLook>,
    /// The frame's near-field scenery (`clutter` in the preset); `None`: none.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub clutter: Option<clutter::FrameClutter>,
    /// The frame's confusers (`confusers` in the preset): the last
    /// `confusers.len()` entries of `drones` are their poses, in this order.
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub confusers: Vec<confusers::ConfuserPose>,
    /// The preset has confusers (even if this frame drew none): its datasets are multi-class.
    #[serde(skip_serializing_if = "std::ops::Not::not")]
    pub confusers_on: bool,
    /// The frame's photographic background (`backplate` in the preset; set
    /// by `backplate::apply`, which the pipeline runs on every scene).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub backplate: Option<backplate::FramePlate>,
    /// The frame's rain or snow (`weather` in the preset); `None`: none.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub weather: Option<weather::FrameWeather>,
}

fn is_zero(n: &u32) -> bool {
    *n == 0
}

/// A frame's place in its sequence. Drone `i` of every frame of a sequence
/// is the same drone: its track id is `i + 1`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
pub struct SequenceFrame {
    /// The sequence's number: frame index / (T + 1).
    pub id: u64,
    /// The step t in 0..=T.
    pub step: u64,
    /// T.
    pub steps: u64,
    /// Index of the sequence's first frame.
    pub first_index: u64,
}

impl FrameScene {
    /// The number of real drones: `drones` before the confusers.
    pub fn drone_count(&self) -> usize {
        self.drones.len().saturating_sub(self.confusers.len())
    }

    /// The real drones (without the confusers appended to `drones`).
    pub fn real_drones(&self) -> &[DronePose] {
        &self.drones[..self.drone_count()]
    }

    /// The confuser placed as `drones[i]`, if that entry is one.
    pub fn confuser(&self, i: usize) -> Option<&confusers::ConfuserPose> {
        i.checked_sub(self.drone_count())
            .and_then(|k| self.confusers.get(k))
    }

    /// Indices of the drone models present in the frame, each once, in preset order.
    pub fn models_present(&self) -> Vec<usize> {
        let mut models: Vec<usize> = self.real_drones().iter().map(|d| d.model).collect();
        models.sort_unstable();
        models.dedup();
        models
    }
}

impl SequenceFrame {
    /// The sequence of frame `index` (`None` without sequence mode).
    pub fn of(preset: &Preset, index: u64) -> Option<Self> {
        preset.sequence.as_ref()?;
        let len = preset.sequence_len();
        Some(Self {
            id: index / len,
            step: index % len,
            steps: len - 1,
            first_index: index - index % len,
        })
    }
}

#[derive(Debug, thiserror::Error, PartialEq)]
pub enum FrameError {
    #[error("frame {index} is out of range: the preset has {count} frames")]
    OutOfRange { index: u64, count: u64 },
    #[error("the preset's sweeps are invalid: {0}")]
    Sweep(#[from] crate::preset::sweep::SweepError),
    #[error(
        "frame {index}: no draw of {attempts} gave at least labels.min_labelled = {wanted} labelled drones; lower labels.min_labelled, or bring the camera closer (camera.z) or the drones into view"
    )]
    TooFewLabelled {
        index: u64,
        wanted: u32,
        attempts: u32,
    },
}

/// The most draws of a frame `labels.min_labelled` makes (the first included).
pub const MAX_DRAWS: u32 = 100;

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
///
/// In sequence mode every draw (placement, motion, sky, split) belongs to the
/// sequence: it comes from the RNG of the sequence's first frame, so frame
/// `index` is still made alone from (seed, index).
pub fn build_frame(preset: &Preset, index: u64) -> Result<FrameScene, FrameError> {
    build_frame_draw(preset, index, 0)
}

/// Draw `attempt` of frame `index`: attempt 0 is [`build_frame`]; a later
/// attempt re-seeds the placement (count, models, positions, attitudes) from
/// [`seed::redraw_seed`] and keeps everything else: sweep values, camera
/// sweep point, sky draws and split. Used by `labels.min_labelled`.
pub fn build_frame_draw(
    preset: &Preset,
    index: u64,
    attempt: u32,
) -> Result<FrameScene, FrameError> {
    build_frame_at(preset, index, attempt, 0.0)
}

/// Draw `attempt` of frame `index` as it stands `offset_s` seconds after
/// the frame's time: in a sequence the drones (and a following camera) at
/// that fractional step of their motion (eqs. 4–5), the confusers at that
/// time; everything drawn is the frame's own. Offset 0 is
/// [`build_frame_draw`]; outside a sequence nothing moves.
pub fn build_frame_at(
    preset: &Preset,
    index: u64,
    attempt: u32,
    offset_s: f64,
) -> Result<FrameScene, FrameError> {
    let sweep = sweep_values(preset, index)?;
    let sequence = SequenceFrame::of(preset, index);
    let draw_index = sequence.map_or(index, |s| s.first_index);
    let frame_seed = seed::redraw_seed(preset.seed, draw_index, attempt);
    let mut rng = <rand_chacha::ChaCha8Rng as rand::SeedableRng>::seed_from_u64(frame_seed);
    let placed = placement::place(preset, sweep.density_per_m3, &mut rng);
    let placement_shortfall = placed.shortfall;
    let rate = preset
        .sequence
        .as_ref()
        .map_or(0.0, |s| f64::from(s.frame_rate.max(1)));
    let moved = moved_swarm(preset, (sequence, offset_s * rate), placed, &mut rng);
    let half_extent = moved.half_extent;
    let volume_radius_m = half_extent.length() + placement::max_model_radius(preset);
    let plane = plane_rotation(sweep.PlaneRX, sweep.PlaneRY, sweep.PlaneRZ);
    let mut drones = posed(preset, moved.states, plane);
    let follow = matches!(
        preset.sequence.as_ref().map(|s| s.camera),
        Some(crate::preset::SequenceCamera::Follow)
    );
    let shift = if follow {
        plane * moved.shift
    } else {
        DVec3::ZERO
    };
    let camera = frame_camera(preset, &sweep, volume_radius_m, shift, draw_index);
    let looks = match &preset.appearance {
        Some(a) => realism::drone_looks(a, preset.seed, draw_index, drones.len()),
        None => Vec::new(),
    };
    let confusers = if preset.confusers.is_empty() {
        Vec::new()
    } else {
        let mut camera0 = camera.0;
        camera0.position -= shift;
        let time_s = sequence_time_s(preset, sequence) + offset_s;
        let (poses, confusers) = confusers::place(preset, (&camera0, plane), draw_index, time_s);
        drones.extend(poses);
        confusers
    };
    // The environment draws come from their own salted stream (see `sky`).
    let environment = crate::sky::frame_environment(&preset.sky, preset.seed, draw_index);
    let clutter = (preset.clutter.as_ref()).map(|c| {
        let sun = environment.sun_direction();
        clutter::frame_clutter(c, preset.seed, draw_index, &camera.0, sun)
    });

    Ok(FrameScene {
        index,
        seed: frame_seed,
        split: split::split_of(preset, index, sequence, &environment),
        sweep,
        look_at: camera.1,
        camera: camera.0,
        drones,
        sun_direction: environment.sun_direction(),
        sky: crate::sky::resolve(&preset.sky, &environment),
        environment_name: crate::sky::environment_name(&preset.sky, &environment),
        environment,
        volume_radius_m,
        volume_half_extent_m: half_extent,
        placement_shortfall,
        sequence,
        camera_absolute: preset.camera.absolute.is_some(),
        redraw: attempt,
        camera_model: (preset.camera_model.as_ref())
            .map(|m| crate::sensor::draw(m, preset.seed, index)),
        atmosphere: realism::frame_atmosphere(preset, draw_index),
        looks,
        clutter,
        confusers,
        confusers_on: !preset.confusers.is_empty(),
        backplate: None,
        weather: (preset.weather.as_ref()).map(|w| weather::frame_weather(w, preset.seed, index)),
    })
}

/// A frame's swarm before the scene rotation: each drone's (model,
/// position, rotation), the shift of the swarm's centre since step 0, and a
/// half extent about the centre that holds every step.
struct MovedSwarm {
    states: Vec<(usize, DVec3, DQuat)>,
    shift: DVec3,
    half_extent: DVec3,
}

/// The placed drones at the frame's step (plus `offset_steps`) of their sequence motion (drawn
/// from `rng` after the placement), or as placed outside sequence mode.
fn moved_swarm(
    preset: &Preset,
    (sequence, offset_steps): (Option<SequenceFrame>, f64),
    placed: placement::Placed,
    rng: &mut rand_chacha::ChaCha8Rng,
) -> MovedSwarm {
    let (Some(spec), Some(seq)) = (&preset.sequence, sequence) else {
        return MovedSwarm {
            states: placed.drones,
            shift: DVec3::ZERO,
            half_extent: placed.half_extent,
        };
    };
    let initial: Vec<_> = placed.drones.iter().map(|d| (d.1, d.2)).collect();
    let ends = motion::endpoints(&initial, &spec.motion, rng);
    // A box about the centre that holds both ends holds every step (eq. 4 is linear).
    let half_extent = ends.iter().fold(placed.half_extent, |h, e| {
        h.max(e.p0.abs()).max(e.p_t.abs())
    });
    let n = ends.len().max(1) as f64;
    let mut shift = DVec3::ZERO;
    let states = placed
        .drones
        .iter()
        .zip(&ends)
        .map(|(d, e)| {
            let (p, q) = e.at_step(seq.step as f64 + offset_steps, seq.steps);
            shift += (p - e.p0) / n;
            (d.0, p, q)
        })
        .collect();
    MovedSwarm {
        states,
        shift,
        half_extent,
    }
}

/// The drones' poses: each state turned by the scene rotation `plane`.
fn posed(preset: &Preset, states: Vec<(usize, DVec3, DQuat)>, plane: DQuat) -> Vec<DronePose> {
    states
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
        .collect()
}

/// The frame's time since its sequence's first frame, seconds (0 outside
/// sequence mode).
fn sequence_time_s(preset: &Preset, sequence: Option<SequenceFrame>) -> f64 {
    match (&preset.sequence, sequence) {
        (Some(spec), Some(seq)) => seq.step as f64 / f64::from(spec.frame_rate.max(1)),
        _ => 0.0,
    }
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
        density_per_m3: preset.density_sweep().map(|_| v(6)),
        repeat: d[7],
    })
}

/// The frame's camera and the point it looks at: placed by the sweep values
/// relative to the volume and looking at its centre, or at the preset's
/// absolute pose; both moved by `shift` (the swarm's, for a following camera).
fn frame_camera(
    preset: &Preset,
    sweep: &SweepValues,
    volume_radius_m: f64,
    shift: DVec3,
    draw_index: u64,
) -> (Camera, DVec3) {
    let (width, height) = preset.image_size();
    let fov_y_deg = preset.camera.fov_y_deg;
    let focal_px = f64::from(height) * 0.5 / (fov_y_deg.to_radians() * 0.5).tan();
    let (position, target) = match (&preset.camera.observer, &preset.camera.absolute) {
        (Some(o), _) => realism::observer_pose(o, preset, draw_index, focal_px),
        (None, Some(a)) => (DVec3::from(a.position_m), DVec3::from(a.look_at_m)),
        (None, None) => (
            camera_position(
                sweep.CameraX,
                sweep.CameraY,
                sweep.CameraZ,
                volume_radius_m,
                fov_y_deg,
            ),
            DVec3::ZERO,
        ),
    };
    let (position, target) = (position + shift, target + shift);
    // Validation keeps the camera off the point it looks at; fall back to identity if it ever sits there.
    let camera_from_world = look_at_cv(position, target).unwrap_or(glam::DMat3::IDENTITY);
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
    (camera, target)
}

//! Placing the preset's confusers (issue 22) in a frame: birds, aircraft and
//! balloons at their drawn distance from the camera, somewhere in its view,
//! flying along their heading; birds beat their wings with a phase that
//! follows time through a sequence. They are appended to the frame's
//! `drones` after the real drones (so they are drawn, occlude and are
//! measured like any other object), and described one for one by
//! [`ConfuserPose`] in `FrameScene::confusers`.
//!
//! Every draw comes from the frame's (the sequence's first frame's) own
//! stream salted with [`CONFUSER_SALT`]; the drones' draws never shift.
//! Draw order per entry: the count, then per flock or object its distance,
//! pixel, heading, climb, bank, speed and size, then per bird its offset in
//! the flock, its phase, its beat frequency and whether it glides.
//!
//! The scene rotation (PlaneRX/RY/RZ) turns confusers as it turns the drones:
//! each one's attitude (heading, climb, bank), so its direction of flight, and
//! its flock's formation are drawn in the plane's frame and rotated into the
//! world's. Their centres stay where they were drawn (a pixel of the view at a
//! distance), so they remain in the picture whatever the rotation.

use glam::{DQuat, DVec3};
use rand::Rng;
use serde::Serialize;

use super::DronePose;
use super::camera::Camera;
use super::math::EulerDeg;
use crate::model::confusers::pose_frame;
use crate::preset::Preset;
use crate::preset::confusers::{
    Confuser, ConfuserKind, FLAP_POSES, FlockShape, first_slots, model_slots,
};

/// The salt of the confusers' stream ("CONFUSER").
pub const CONFUSER_SALT: u64 = 0x434F_4E46_5553_4552;

/// One placed confuser: the drone entry `drones[n_drones + i]` is its pose.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct ConfuserPose {
    /// Index of its entry in the preset's `confusers`.
    pub entry: usize,
    pub kind: ConfuserKind,
    /// Labelled as this class; `None`: an unlabelled hard negative.
    pub labelled_as: Option<String>,
    /// The flock it flies in (entry's flock), or `None`.
    pub flock: Option<usize>,
    /// Birds: the phase of the wing beat in [0, 1) (0: wings at the top); `None`: gliding or not a bird.
    pub flap_phase: Option<f64>,
    /// Birds: wing beats per second (the phase grows by this much per second); `None` with no phase.
    pub flap_hz: Option<f64>,
    /// Speed along its heading, m/s.
    pub speed_m_s: f64,
    /// Largest span (birds: gliding wingspan), metres.
    pub span_m: f64,
}

impl ConfuserPose {
    /// An unlabelled hard negative.
    pub fn is_negative(&self) -> bool {
        self.labelled_as.is_none()
    }
}

/// One object as drawn at step 0: body centre, attitude, velocity and wing state.
struct Drawn {
    entry: usize,
    flock: Option<usize>,
    position: DVec3,
    rotation: DQuat,
    speed_m_s: f64,
    span_m: f64,
    /// Birds: (phase at t = 0, beats per second); `None`: gliding or not a bird.
    beat: Option<(f64, f64)>,
}

fn uniform(rng: &mut impl Rng, (lo, hi): (f64, f64)) -> f64 {
    if hi > lo {
        rng.random_range(lo..=hi)
    } else {
        lo
    }
}

/// The world direction through pixel (u, v) of `camera`.
fn pixel_ray(camera: &Camera, u: f64, v: f64) -> DVec3 {
    let f = camera.focal_px();
    let c = camera.principal_point();
    let d = DVec3::new((u - c.x) / f, (v - c.y) / f, 1.0).normalize();
    camera.camera_from_world.transpose() * d
}

/// A flock member's offset from the flock's centre, in the flock's frame
/// (x across the heading, y up, z along it), in units of its spacing.
fn formation_offset(shape: FlockShape, k: usize, n: usize, rng: &mut impl Rng) -> DVec3 {
    match shape {
        FlockShape::V => {
            // The leader at the tip, then alternately right and left, each rank one step back.
            let rank = k.div_ceil(2) as f64;
            let side = if k % 2 == 1 { 1.0 } else { -1.0 };
            DVec3::new(side * rank * 0.8, 0.0, -rank * 0.6)
        }
        FlockShape::Line => DVec3::new(k as f64 - (n as f64 - 1.0) * 0.5, 0.0, 0.0),
        FlockShape::Cloud => {
            let radius = (n as f64).cbrt();
            loop {
                let p = DVec3::new(
                    rng.random_range(-1.0..=1.0),
                    rng.random_range(-1.0..=1.0),
                    rng.random_range(-1.0..=1.0),
                );
                if p.length_squared() <= 1.0 {
                    break p * radius;
                }
            }
        }
    }
}

/// The objects of one entry at step 0.
fn draw_entry(
    e: usize,
    c: &Confuser,
    (camera, plane): (&Camera, DQuat),
    rng: &mut impl Rng,
    out: &mut Vec<Drawn>,
) {
    let n = uniform_count(rng, c.count);
    let groups = if c.flock.is_some() { n.min(1) } else { n };
    let (w, h) = (f64::from(camera.width), f64::from(camera.height));
    let (climb_deg, bank_deg) = c.kind.attitude_limits_deg();
    for g in 0..groups {
        let distance = uniform(rng, c.distance_m);
        let (u, v) = (rng.random_range(0.0..=w), rng.random_range(0.0..=h));
        let centre = camera.position + pixel_ray(camera, u, v) * distance;
        let attitude = EulerDeg {
            yaw: rng.random_range(0.0..360.0),
            pitch: rng.random_range(-climb_deg..=climb_deg),
            roll: rng.random_range(-bank_deg..=bank_deg),
        }
        .to_quat();
        // In the plane's frame, as the drones' attitudes (no rotation: exactly as drawn).
        let attitude = if plane == DQuat::IDENTITY {
            attitude
        } else {
            (plane * attitude).normalize()
        };
        let speed_m_s = uniform(rng, c.speed_range_m_s());
        let span_m = uniform(rng, c.size_range_m());
        let members = if c.flock.is_some() { n } else { 1 };
        for k in 0..members {
            let offset = match &c.flock {
                Some(f) => {
                    let jitter = DVec3::new(
                        rng.random_range(-1.0..=1.0),
                        rng.random_range(-1.0..=1.0),
                        rng.random_range(-1.0..=1.0),
                    ) * f.jitter_wingspans;
                    let slot = formation_offset(f.shape, k as usize, n as usize, rng);
                    attitude * ((slot * f.spacing_wingspans + jitter) * span_m)
                }
                None => DVec3::ZERO,
            };
            let beat = c.kind.is_bird().then(|| {
                let phase = rng.random_range(0.0..1.0);
                let hz = uniform(rng, c.flap_range_hz());
                let glides = rng.random_bool(c.glide_share.clamp(0.0, 1.0));
                (!glides).then_some((phase, hz))
            });
            out.push(Drawn {
                entry: e,
                flock: c.flock.as_ref().map(|_| g as usize),
                position: centre + offset,
                rotation: attitude,
                speed_m_s,
                span_m,
                beat: beat.flatten(),
            });
        }
    }
}

fn uniform_count(rng: &mut impl Rng, (lo, hi): (u32, u32)) -> u32 {
    if hi > lo {
        rng.random_range(lo..=hi)
    } else {
        lo
    }
}

/// The preset's confusers in a frame: their poses (to append to the
/// frame's drones) and what each is. `camera0` is the camera of the
/// sequence's first frame (the frame's own outside sequences), `time_s`
/// the time since it; `draw_index` the frame whose stream they draw from;
/// `plane` the frame's scene rotation (PlaneRX/RY/RZ, `math::plane_rotation`).
pub fn place(
    preset: &Preset,
    (camera0, plane): (&Camera, DQuat),
    draw_index: u64,
    time_s: f64,
) -> (Vec<DronePose>, Vec<ConfuserPose>) {
    if preset.confusers.is_empty() {
        return (Vec::new(), Vec::new());
    }
    let mut rng = crate::seed::salted_rng(preset.seed, draw_index, CONFUSER_SALT);
    let mut drawn = Vec::new();
    for (e, c) in preset.confusers.iter().enumerate() {
        draw_entry(e, c, (camera0, plane), &mut rng, &mut drawn);
    }
    let first = first_slots(&preset.confusers);
    let names = model_slots(&preset.confusers);
    let base = preset.models.len();
    let mut poses = Vec::with_capacity(drawn.len());
    let mut infos = Vec::with_capacity(drawn.len());
    for d in drawn {
        let c = &preset.confusers[d.entry];
        let forward = d.rotation * DVec3::Z;
        let body = d.position + forward * (d.speed_m_s * time_s);
        let phase = d.beat.map(|(p0, hz)| (p0 + hz * time_s).rem_euclid(1.0));
        // Birds: the nearest flap pose, or the gliding pose (the last of the kind's slots).
        let pose = match (c.kind.is_bird(), phase) {
            (true, Some(p)) => ((p * FLAP_POSES as f64).round() as usize) % FLAP_POSES,
            (true, None) => FLAP_POSES,
            _ => 0,
        };
        let slot = first[d.entry] + pose;
        // Undo the loader's centring and unit span for this pose (see `model::confusers`).
        let (position, size_m) = match names.get(slot).and_then(|n| pose_frame(n)) {
            Some(f) => (
                body + d.rotation * (DVec3::from_array(f.centre) * d.span_m),
                f.span * d.span_m,
            ),
            None => (body, d.span_m),
        };
        poses.push(DronePose {
            model: base + slot,
            position,
            rotation: d.rotation,
            euler_deg: EulerDeg::from_quat(d.rotation),
            size_m,
        });
        infos.push(ConfuserPose {
            entry: d.entry,
            kind: c.kind,
            labelled_as: c.labelled_as.clone(),
            flock: d.flock,
            flap_phase: phase,
            flap_hz: d.beat.map(|b| b.1),
            speed_m_s: d.speed_m_s,
            span_m: d.span_m,
        });
    }
    (poses, infos)
}

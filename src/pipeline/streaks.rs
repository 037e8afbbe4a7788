//! The drones' streaks for motion blur (`camera_model.exposure_time_s`,
//! [`crate::sensor::motion`]): each drone's image motion while the shutter
//! is open, from the sequence's interpolated states (eq. 4) at the
//! neighbouring steps, projected with each step's own camera.

use crate::preset::Preset;
use crate::scene::projection::{LabelGeometry, amodal_box};
use crate::scene::{FrameScene, build_frame_draw};
use crate::sensor::motion::Streak;
use crate::sensor::{CameraDraw, PixelRect};

/// Pixels added around a drone's amodal box for its anti-aliased edge.
const EDGE_PX: f64 = 2.0;

/// Per drone of `scene` (same order), its streak under `draw`'s exposure
/// time: `None` outside a sequence, with no exposure time, or for a drone
/// not in front of the camera. The image velocity is the central difference
/// of the neighbouring steps (one-sided at a sequence's ends), times the
/// exposure in steps (`exposure_time_s · sequence.frame_rate`), centred on
/// the frame's time.
pub(super) fn streaks(
    preset: &Preset,
    geometry: &[LabelGeometry],
    scene: &FrameScene,
    draw: &CameraDraw,
) -> Vec<Option<Streak>> {
    let none = || vec![None; scene.drones.len()];
    let (Some(seq), Some(spec)) = (scene.sequence, &preset.sequence) else {
        return none();
    };
    if draw.exposure_time_s.is_nan() || draw.exposure_time_s <= 0.0 || seq.steps == 0 {
        return none();
    }
    let at = |index: u64| build_frame_draw(preset, index, scene.redraw).ok();
    let prev = if seq.step > 0 {
        at(scene.index - 1)
    } else {
        None
    };
    let next = if seq.step < seq.steps {
        at(scene.index + 1)
    } else {
        None
    };
    let (a, b, steps) = match (&prev, &next) {
        (Some(p), Some(n)) => (p, n, 2.0),
        (None, Some(n)) => (scene, n, 1.0),
        (Some(p), None) => (p, scene, 1.0),
        (None, None) => return none(),
    };
    let exposure_steps = draw.exposure_time_s * f64::from(spec.frame_rate);
    let image = |s: &FrameScene, i: usize| {
        let d = s.drones.get(i)?;
        let p = s.camera.camera_from_world_point(d.position);
        s.camera.project_camera_point(p)
    };
    scene
        .drones
        .iter()
        .enumerate()
        .map(|(i, drone)| {
            let v = (image(b, i)? - image(a, i)?) / steps * exposure_steps;
            let rect = drawn_rect(scene, drone, geometry)?;
            (v.is_finite()).then_some(Streak {
                rect,
                shift_px: (v.x, v.y),
            })
        })
        .collect()
}

/// Where `drone` is drawn in `scene`'s rendered frame: its amodal box
/// grown by its anti-aliased edge, clamped to the image (motion blur's and
/// the rolling shutter's source rect).
pub(super) fn drawn_rect(
    scene: &FrameScene,
    drone: &crate::scene::DronePose,
    geometry: &[LabelGeometry],
) -> Option<PixelRect> {
    let (w, h) = (
        f64::from(scene.camera.width),
        f64::from(scene.camera.height),
    );
    let r = amodal_box(&scene.camera, drone, geometry.get(drone.model)?)?;
    Some(PixelRect {
        x0: (r.x0 - EDGE_PX).floor().clamp(0.0, w) as u32,
        y0: (r.y0 - EDGE_PX).floor().clamp(0.0, h) as u32,
        x1: (r.x1 + EDGE_PX).ceil().clamp(0.0, w) as u32,
        y1: (r.y1 + EDGE_PX).ceil().clamp(0.0, h) as u32,
    })
}

/// A drone's rendered box `own` grown to hold what its streak reaches.
pub(super) fn grown(
    own: Option<PixelRect>,
    streak: Option<Streak>,
    (w, h): (u32, u32),
) -> Option<PixelRect> {
    let own = own?;
    let Some(s) = streak.filter(|s| s.moves()) else {
        return Some(own);
    };
    let swept = Streak { rect: own, ..s }.swept(w, h);
    Some(PixelRect {
        x0: own.x0.min(swept.x0),
        y0: own.y0.min(swept.y0),
        x1: own.x1.max(swept.x1),
        y1: own.y1.max(swept.y1),
    })
}

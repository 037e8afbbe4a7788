//! A rendered frame's fill budget: the drones (and confusers) in view may
//! cover the picture at most [`MAX_DRONE_OVERDRAW`] times over, each
//! counted by its amodal box (the projected model, clipped to the picture).
//! Every pass draws each covered pixel once per drone over it, so a few
//! thousand large drones near the camera would otherwise run for minutes on
//! a software rasteriser. Checked from the scene's geometry (the labels'
//! estimate) before anything is drawn.

use super::PipelineError;
use crate::annotate::DroneLabel;
use crate::scene::FrameScene;

/// The most times over the drones' amodal boxes may cover a rendered
/// frame. Measured on quadcopters of 3 m around a close camera at
/// 1920 × 1080, MSAA 4, two cores: 174 times over (1000 of them) drew in
/// 12 s, 345 times (2000) in 36 s, 1729 times (10 000) for two minutes.
pub const MAX_DRONE_OVERDRAW: f64 = 256.0;

/// The picture's pixels a label's amodal box covers.
fn covered_pixels(label: &DroneLabel, (w, h): (f64, f64)) -> f64 {
    let b = &label.amodal;
    let width = (b.x1.min(w) - b.x0.max(0.0)).max(0.0);
    let height = (b.y1.min(h) - b.y0.max(0.0)).max(0.0);
    if width.is_finite() && height.is_finite() {
        width * height
    } else {
        w * h
    }
}

/// Whether `scene` can exceed the budget at all: each box clipped to the
/// picture covers it at most once, so [`MAX_DRONE_OVERDRAW`] objects or
/// fewer never do, and their labels need not be estimated (most frames).
pub(super) fn may_exceed(scene: &FrameScene) -> bool {
    scene.drones.len() as f64 > MAX_DRONE_OVERDRAW
}

/// The scene's drones, by their estimated `labels`, within
/// [`MAX_DRONE_OVERDRAW`], or an error naming `placement` with how far
/// over they are.
pub(super) fn check(scene: &FrameScene, labels: &[DroneLabel]) -> Result<(), PipelineError> {
    let size = (
        f64::from(scene.camera.width),
        f64::from(scene.camera.height),
    );
    let picture = size.0 * size.1;
    let covered: f64 = labels.iter().map(|l| covered_pixels(l, size)).sum();
    if covered <= MAX_DRONE_OVERDRAW * picture {
        return Ok(());
    }
    let (n, times) = (scene.drones.len(), covered / picture);
    Err(PipelineError::Budget {
        index: scene.index,
        reason: format!(
            "placement: the {n} drones and confusers cover the picture {times:.0} times over (their amodal boxes added up), more than the {MAX_DRONE_OVERDRAW} a rendered frame may draw (its work budget); spread them out, make them smaller or fewer, or move the camera back"
        ),
    })
}

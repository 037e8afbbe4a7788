//! Photographic backgrounds (`backplate:` in a preset, issue 21 item 4): a
//! folder of the user's own still frames of empty sky and horizon, one drawn
//! per frame as the frame's background. Off unless a preset names it. The
//! plates are decoded once (`sky::plates`), the frame's draw is
//! `scene::backplate`, the renderer pastes the resampled plate where the sky
//! would be (docs/realism.md, "Photographic backgrounds").

use std::path::PathBuf;

use serde::{Deserialize, Serialize};

use super::Validator;

/// Where the horizon is in a plate.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub enum PlateHorizon {
    /// The horizon line's row as a fraction of the plate's height from its
    /// top edge (0: top, 1: bottom; values outside [0, 1] put it out of frame
    /// at that row). The camera's pitch follows from it and the field of view.
    Row(f64),
    /// Not known (out of frame): the line of sight's elevation is drawn from
    /// `backplate.elevation_deg`.
    Unknown,
}

/// The backplates: a folder of JPEG/PNG frames, the camera that took them,
/// and the sun that lights the drones.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct Backplate {
    /// Folder of plates (files ending .jpg, .jpeg or .png; other files are
    /// ignored), relative to the preset's folder. Read in file-name order.
    pub folder: PathBuf,
    /// Horizontal field of view of the camera that took the plates, degrees.
    /// A plate's sidecar `NAME.plate.ron` may set its own.
    pub hfov_deg: f64,
    /// The horizon line of the plates (a sidecar may set its own).
    pub horizon: PlateHorizon,
    /// With `Unknown` horizon: the elevation of the line of sight, degrees,
    /// drawn uniformly within (min, max).
    pub elevation_deg: (f64, f64),
    /// The sun's elevation above the horizon, degrees, drawn per frame within (min, max).
    pub sun_elevation_deg: (f64, f64),
    /// The sun's azimuth relative to the line of sight, degrees (0: the sun
    /// ahead, behind the swarm; 180: behind the camera), drawn per frame.
    pub sun_azimuth_deg: (f64, f64),
    /// Mirror a plate left-right in half of the frames (drawn per frame).
    pub flip: bool,
}

impl Default for Backplate {
    fn default() -> Self {
        Self {
            folder: PathBuf::from("plates"),
            hfov_deg: 60.0,
            horizon: PlateHorizon::Row(0.85),
            elevation_deg: (15.0, 40.0),
            sun_elevation_deg: (20.0, 60.0),
            sun_azimuth_deg: (-180.0, 180.0),
            flip: true,
        }
    }
}

/// The largest horizontal field of view accepted, degrees.
pub const MAX_PLATE_HFOV_DEG: f64 = 150.0;

/// Whether `hfov_deg` is a horizontal field of view a pinhole plate can have.
pub fn hfov_ok(hfov_deg: f64) -> bool {
    hfov_deg.is_finite() && (1.0..=MAX_PLATE_HFOV_DEG).contains(&hfov_deg)
}

/// Whether a horizon row fraction is usable (finite, within ±10 heights).
pub fn horizon_ok(horizon: PlateHorizon) -> bool {
    match horizon {
        PlateHorizon::Row(r) => r.is_finite() && (-10.0..=10.0).contains(&r),
        PlateHorizon::Unknown => true,
    }
}

impl Backplate {
    pub(super) fn validate_into(&self, v: &mut Validator, has_absolute_camera: bool) {
        v.check(
            !self.folder.as_os_str().is_empty(),
            "backplate.folder",
            || "must name a folder of JPEG/PNG plates".into(),
        );
        v.check(hfov_ok(self.hfov_deg), "backplate.hfov_deg", || {
            format!(
                "{} must be degrees within [1, {MAX_PLATE_HFOV_DEG}]",
                self.hfov_deg
            )
        });
        v.check(horizon_ok(self.horizon), "backplate.horizon", || {
            format!(
                "{:?} must be Row(fraction of the height from the top, within [-10, 10]) or Unknown",
                self.horizon
            )
        });
        let mut range = |field: &str, (lo, hi): (f64, f64), limit: f64| {
            v.check(
                lo.is_finite() && hi.is_finite() && lo <= hi && lo >= -limit && hi <= limit,
                field,
                || format!("({lo}, {hi}) must be finite degrees with min ≤ max within [-{limit}, {limit}]"),
            );
        };
        range("backplate.elevation_deg", self.elevation_deg, 80.0);
        range("backplate.sun_elevation_deg", self.sun_elevation_deg, 90.0);
        range("backplate.sun_azimuth_deg", self.sun_azimuth_deg, 360.0);
        v.check(!has_absolute_camera, "backplate", || {
            "cannot be combined with camera.absolute: the plate sets the camera's pitch and field of view".into()
        });
    }
}

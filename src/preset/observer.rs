//! The observer camera (`camera.observer:` in a preset): the camera as a
//! person on the ground points it, looking up at the swarm from below, so the
//! horizon sits low in the frame or out of it and the drones are against the
//! sky. Off unless a preset names it; the sweep's CameraX/Y/Z are then not used.

use serde::{Deserialize, Serialize};

use super::Validator;

/// The camera looks at the volume's centre from distance D along a line of
/// sight with elevation E above the horizon and azimuth A (from +Z towards
/// +X): it sits at `−D·(cos E·sin A, sin E, cos E·cos A)` with no roll.
/// E, A and D are drawn per frame; the horizon is then at
/// `v = cy + f·tan E` pixels (below the centre; out of frame when E > fov_y/2).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct ObserverCamera {
    /// Elevation E of the line of sight, degrees above the horizon, drawn uniformly within (min, max).
    pub elevation_deg: (f64, f64),
    /// Azimuth A of the line of sight, degrees, drawn uniformly within (min, max).
    pub azimuth_deg: (f64, f64),
    /// Distance D from the camera to the volume's centre, metres, drawn uniformly within (min, max).
    pub distance_m: (f64, f64),
    /// Instead of `distance_m`: the drawn apparent size s of the largest model
    /// at the volume's centre in pixels, and D = f·size_m / s (f the focal length in pixels).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub size_px: Option<(f64, f64)>,
}

impl Default for ObserverCamera {
    fn default() -> Self {
        Self {
            elevation_deg: (15.0, 60.0),
            azimuth_deg: (-180.0, 180.0),
            distance_m: (300.0, 1500.0),
            size_px: None,
        }
    }
}

impl ObserverCamera {
    pub(super) fn validate_into(&self, v: &mut Validator) {
        let (lo, hi) = self.elevation_deg;
        v.check(
            lo.is_finite() && hi.is_finite() && lo <= hi && lo >= -80.0 && hi <= 80.0,
            "camera.observer.elevation_deg",
            || format!("({lo}, {hi}) must be finite degrees with min ≤ max within [-80, 80]"),
        );
        let (lo, hi) = self.azimuth_deg;
        v.check(
            lo.is_finite() && hi.is_finite() && lo <= hi && lo >= -360.0 && hi <= 360.0,
            "camera.observer.azimuth_deg",
            || format!("({lo}, {hi}) must be finite degrees with min ≤ max within [-360, 360]"),
        );
        let (lo, hi) = self.distance_m;
        v.check(
            lo.is_finite() && hi.is_finite() && lo > 0.0 && lo <= hi && hi <= 1e6,
            "camera.observer.distance_m",
            || format!("({lo}, {hi}) must be metres with 0 < min ≤ max ≤ 1e6"),
        );
        if let Some((lo, hi)) = self.size_px {
            v.check(
                lo.is_finite() && hi.is_finite() && lo >= 0.1 && lo <= hi && hi <= 1e5,
                "camera.observer.size_px",
                || format!("({lo}, {hi}) must be pixels with 0.1 ≤ min ≤ max ≤ 1e5"),
            );
        }
    }
}

//! The rolling shutter (issue 41), `camera_model.rolling_shutter`: each image
//! row exposed at its own time, row y at t + (y / height)·readout, while the
//! drones move (a sequence's eqs. 4–5) and the camera turns at a drawn yaw
//! rate. Plain serde data and its own fields' checks; the picture and the
//! labels are made in `pipeline/rolling.rs`. docs/realism.md, "Rolling
//! shutter", describes every field.

use serde::{Deserialize, Serialize};

use super::Validator;

/// A rolling shutter's ranges, each drawn per frame (a fixed value is `(v, v)`).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RollingShutter {
    /// Time from the first row's exposure to the last row's, seconds (0: a global shutter).
    pub readout_s: (f64, f64),
    /// The camera's turn rate about its own vertical axis during the readout,
    /// degrees per second (positive: to the right), e.g. a gimbal's pan or
    /// an airframe's vibration; 0: the camera holds still.
    #[serde(default, skip_serializing_if = "is_zero_range")]
    pub yaw_rate_deg_s: (f64, f64),
}

fn is_zero_range(r: &(f64, f64)) -> bool {
    *r == (0.0, 0.0)
}

/// The longest readout accepted, seconds (a frame interval at 10 fps).
pub const MAX_READOUT_S: f64 = 0.1;
/// The fastest yaw rate accepted, degrees per second.
pub const MAX_YAW_RATE_DEG_S: f64 = 360.0;

impl RollingShutter {
    /// Each field a finite range within its bounds, named by its path.
    pub(super) fn validate(&self, v: &mut Validator) {
        for (name, (lo, hi), min, max) in [
            ("readout_s", self.readout_s, 0.0, MAX_READOUT_S),
            (
                "yaw_rate_deg_s",
                self.yaw_rate_deg_s,
                -MAX_YAW_RATE_DEG_S,
                MAX_YAW_RATE_DEG_S,
            ),
        ] {
            let field = format!("camera_model.rolling_shutter.{name}");
            let ok = lo.is_finite() && hi.is_finite() && lo <= hi;
            v.check(ok, &field, || {
                format!("({lo}, {hi}) is not a range (min, max) of finite numbers with min ≤ max")
            });
            v.check(!ok || (lo >= min && hi <= max), &field, || {
                format!("({lo}, {hi}) leaves [{min}, {max}]")
            });
        }
    }
}

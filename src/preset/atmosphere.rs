//! The atmosphere between the camera and the drones (`atmosphere:` in a
//! preset): haze with range, by Koschmieder's law. Off unless a preset names
//! it; the frame's draw is `scene::FrameAtmosphere`, the blend is done by the
//! renderer in linear light (docs/realism.md, "Atmosphere").

use serde::{Deserialize, Serialize};

use super::Validator;

/// Haze with range: every drone pixel at distance d from the camera becomes
/// `L0·t + L_air·(1 − t)` with `t = exp(−3.912·d/V)`, V the meteorological
/// visibility drawn per frame, L_air the sky's horizon radiance towards the drone.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct Atmosphere {
    /// Meteorological visibility V in metres, drawn per frame uniformly in
    /// (min, max) (min = max: fixed). 2 % contrast remains at distance V.
    pub visibility_m: (f64, f64),
}

impl Default for Atmosphere {
    fn default() -> Self {
        Self {
            visibility_m: (5_000.0, 30_000.0),
        }
    }
}

/// The largest visibility accepted (metres): beyond it haze is below one 8-bit level at any range a drone is seen.
pub const MAX_VISIBILITY_M: f64 = 1e7;

impl Atmosphere {
    pub(super) fn validate_into(&self, v: &mut Validator) {
        let (lo, hi) = self.visibility_m;
        v.check(
            lo.is_finite() && hi.is_finite() && lo > 0.0 && lo <= hi && hi <= MAX_VISIBILITY_M,
            "atmosphere.visibility_m",
            || format!("({lo}, {hi}) must be metres with 0 < min ≤ max ≤ {MAX_VISIBILITY_M}"),
        );
    }
}

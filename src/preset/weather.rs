//! Rain and snow between the camera and the swarm (`weather:` in a preset,
//! issue 41 item 4): particles in a volume in front of the camera, drawn as
//! translucent streaks (rain) or opaque flakes (snow) with perspective and
//! motion blur. Off unless a preset names it. The frame's draw is
//! `scene::weather::FrameWeather`; the pipeline composites it over the
//! rendered frame and its drone-free background (docs/realism.md, "Weather").

use serde::{Deserialize, Serialize};

use super::Validator;

/// What falls.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub enum WeatherKind {
    /// Translucent streaks: drones behind a drop are veiled, never hidden.
    #[default]
    Rain,
    /// Opaque flakes: a flake nearer than a drone hides the pixels it covers.
    Snow,
}

impl WeatherKind {
    pub fn name(self) -> &'static str {
        match self {
            Self::Rain => "rain",
            Self::Snow => "snow",
        }
    }
}

/// The particles of a frame. Ranges are drawn per frame uniformly in
/// (min, max) (min = max: fixed); each particle's place and size are drawn
/// from the frame's own stream.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct Weather {
    pub kind: WeatherKind,
    /// Particles per cubic metre of the volume in front of the camera.
    pub intensity_per_m3: (f64, f64),
    /// Horizontal wind speed, m/s (particles drift with it).
    pub wind_mps: (f64, f64),
    /// Wind direction, degrees about world +Y from +X.
    pub wind_dir_deg: (f64, f64),
    /// Fall speed, m/s (rain 4–9, snow 0.5–1.5).
    pub fall_mps: (f64, f64),
    /// Exposure time, seconds: a particle's streak is its travel during it.
    pub exposure_s: (f64, f64),
    /// Particle diameter, millimetres (drawn per particle).
    pub diameter_mm: (f64, f64),
    /// Peak opacity of a particle's streak (rain) or flake (snow), 0–1.
    pub opacity: (f64, f64),
    /// Nearest and farthest particle distance along the view axis, metres.
    pub depth_m: (f64, f64),
}

impl Default for Weather {
    fn default() -> Self {
        Self::rain()
    }
}

/// The most particles a frame draws (bounds a frame's work: a denser
/// volume is drawn with this many).
pub const MAX_PARTICLES: f64 = 400_000.0;
/// The largest accepted particle distance, metres.
pub const MAX_DEPTH_M: f64 = 1_000.0;

impl Weather {
    /// Moderate rain: thin translucent streaks.
    pub fn rain() -> Self {
        Self {
            kind: WeatherKind::Rain,
            intensity_per_m3: (0.3, 0.8),
            wind_mps: (0.0, 3.0),
            wind_dir_deg: (0.0, 360.0),
            fall_mps: (5.0, 8.0),
            exposure_s: (1.0 / 120.0, 1.0 / 60.0),
            diameter_mm: (1.0, 3.0),
            opacity: (0.15, 0.35),
            depth_m: (0.5, 25.0),
        }
    }

    /// Moderate snow: opaque flakes, slow and drifting.
    pub fn snow() -> Self {
        Self {
            kind: WeatherKind::Snow,
            intensity_per_m3: (0.2, 0.6),
            wind_mps: (0.0, 2.0),
            wind_dir_deg: (0.0, 360.0),
            fall_mps: (0.5, 1.5),
            exposure_s: (1.0 / 500.0, 1.0 / 250.0),
            diameter_mm: (3.0, 12.0),
            opacity: (1.0, 1.0),
            depth_m: (0.5, 25.0),
        }
    }

    /// The default of a kind (the app's kind switch).
    pub fn of_kind(kind: WeatherKind) -> Self {
        match kind {
            WeatherKind::Rain => Self::rain(),
            WeatherKind::Snow => Self::snow(),
        }
    }

    pub(super) fn validate_into(&self, v: &mut Validator) {
        let range = |v: &mut Validator, field: &str, (lo, hi): (f64, f64), min: f64, max: f64| {
            v.check(
                lo.is_finite() && hi.is_finite() && lo >= min && lo <= hi && hi <= max,
                field,
                || format!("({lo}, {hi}) must be numbers with {min} ≤ min ≤ max ≤ {max}"),
            );
        };
        range(
            v,
            "weather.intensity_per_m3",
            self.intensity_per_m3,
            0.0,
            10_000.0,
        );
        range(v, "weather.wind_mps", self.wind_mps, 0.0, 60.0);
        range(v, "weather.wind_dir_deg", self.wind_dir_deg, -360.0, 720.0);
        range(v, "weather.fall_mps", self.fall_mps, 0.0, 30.0);
        range(v, "weather.exposure_s", self.exposure_s, 0.0, 1.0);
        range(v, "weather.diameter_mm", self.diameter_mm, 0.01, 50.0);
        range(v, "weather.opacity", self.opacity, 0.0, 1.0);
        let (near, far) = self.depth_m;
        v.check(
            near.is_finite() && far.is_finite() && near >= 0.05 && near < far && far <= MAX_DEPTH_M,
            "weather.depth_m",
            || format!("({near}, {far}) must be metres with 0.05 ≤ near < far ≤ {MAX_DEPTH_M}"),
        );
    }
}

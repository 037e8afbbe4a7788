//! Where the drones go (`placement`, `attitude`): the paper's structured grid
//! and randomized volume, named formations, the count distribution, the
//! observation volume, the attitude ranges, and how full the volume's
//! minimum separation makes it (validation refuses a jammed volume).

use serde::{Deserialize, Serialize};

use super::Preset;
use super::formation::Formation;
use super::sweep::SweepRange;

/// The paper's two placement modes.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub enum Placement {
    /// A regular grid of XCount × YCount × ZCount drones, spaced LoadFactor × model size apart.
    Structured {
        x_count: u32,
        y_count: u32,
        z_count: u32,
        load_factor: f64,
    },
    /// Uniform random positions in the observation volume, at least `min_separation_m` apart.
    Randomized {
        /// Inclusive range of drones per frame.
        count: (u32, u32),
        /// How the count is drawn within `count` (uniform unless given).
        #[serde(default, skip_serializing_if = "CountDistribution::is_uniform")]
        count_distribution: CountDistribution,
        volume: Volume,
        /// Centre-to-centre distance no two drones come closer than.
        min_separation_m: f64,
    },
    /// A named formation (line abreast, column, echelon, wedge, ring, sphere
    /// shell, clusters) with its heading and jitter.
    Formation(Formation),
}

impl Default for Placement {
    fn default() -> Self {
        Self::Randomized {
            count: (1, 15),
            count_distribution: CountDistribution::Uniform,
            volume: Volume::default(),
            min_separation_m: 0.7,
        }
    }
}

/// How randomized placement draws a frame's drone count within its
/// inclusive `count: (min, max)`. Every distribution other than `Uniform` is
/// truncated to (min, max): it is the distribution conditioned on
/// min ≤ n ≤ max (never piled onto the ends), drawn by inverting its CDF
/// with one uniform number from the frame's own sampler.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub enum CountDistribution {
    /// Every count in (min, max) equally likely (one `random_range` draw; the default).
    #[default]
    Uniform,
    /// Listed counts with relative weights, e.g. `Table([(1, 3.0), (2, 2.0), (5, 1.0)])`;
    /// counts not listed are never drawn.
    Table(Vec<(u32, f64)>),
    /// P(n) ∝ λⁿ / n!, with λ = `mean` (the mean before truncation).
    Poisson { mean: f64 },
    /// P(n) ∝ (1 − p)^(n − min): each further drone with probability 1 − p.
    Geometric { p: f64 },
}

impl CountDistribution {
    /// Whether this is the default uniform draw.
    pub fn is_uniform(&self) -> bool {
        *self == Self::Uniform
    }
}

/// The observation volume W of randomized placement, centred at the origin.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub enum Volume {
    /// A box of the given size in metres (x, y, z).
    Box { size_m: (f64, f64, f64) },
    /// A cube whose volume gives the density ρ = N / V (drones per cubic metre).
    Density { per_m3: f64 },
    /// A box of fixed size whose density ρ is swept like CameraX/Y/Z: each
    /// frame holds N = round(ρ·V) drones (at least 1) and `count` is not used,
    /// so density and apparent size vary independently.
    DensitySweep {
        size_m: (f64, f64, f64),
        per_m3: SweepRange,
    },
}

impl Default for Volume {
    fn default() -> Self {
        Self::Box {
            size_m: (20.0, 10.0, 20.0),
        }
    }
}

/// Per-drone attitude ranges in degrees, each an inclusive (min, max).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct AttitudeRanges {
    pub roll_deg: (f64, f64),
    pub pitch_deg: (f64, f64),
    pub yaw_deg: (f64, f64),
}

impl Default for AttitudeRanges {
    fn default() -> Self {
        Self {
            roll_deg: (-15.0, 15.0),
            pitch_deg: (-15.0, 15.0),
            yaw_deg: (-180.0, 180.0),
        }
    }
}

impl Preset {
    /// Share of the volume taken by `n` balls of diameter `separation`, for the
    /// largest count the preset asks for.
    pub(super) fn packing_fraction(n: u32, volume: &Volume, separation: f64) -> f64 {
        let ball = std::f64::consts::PI / 6.0 * separation.powi(3);
        match volume {
            Volume::Box { size_m: (x, y, z) } => {
                let v = x * y * z;
                if n <= 1 {
                    0.0
                } else if v <= 0.0 {
                    if separation > 0.0 { f64::INFINITY } else { 0.0 }
                } else {
                    f64::from(n) * ball / v
                }
            }
            Volume::Density { per_m3 } => per_m3 * ball,
            Volume::DensitySweep { per_m3, .. } => per_m3.start.max(per_m3.end) * ball,
        }
    }
}

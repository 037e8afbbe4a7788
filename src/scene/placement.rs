//! Placement modes: where a frame's drones go in the observation volume, and
//! the volume's extent. The one home of each mode: adding a mode means a new
//! arm here (and its fields in the preset).

use std::collections::HashMap;

use glam::{DQuat, DVec3, IVec3};
use rand::Rng;

use super::math::EulerDeg;
use crate::preset::{AttitudeRanges, Placement, Preset, Volume};

/// Attempts per drone before randomized placement gives up on it.
const PLACEMENT_ATTEMPTS: u32 = 200;

fn sample_attitude<R: Rng>(rng: &mut R, ranges: &AttitudeRanges) -> DQuat {
    EulerDeg {
        roll: sample_range(rng, ranges.roll_deg),
        pitch: sample_range(rng, ranges.pitch_deg),
        yaw: sample_range(rng, ranges.yaw_deg),
    }
    .to_quat()
}

fn sample_range(rng: &mut impl Rng, (lo, hi): (f64, f64)) -> f64 {
    if hi > lo {
        rng.random_range(lo..=hi)
    } else {
        lo
    }
}

/// Drones placed in the unrotated volume.
pub struct Placed {
    /// (model, position, attitude) of each drone.
    pub drones: Vec<(usize, DVec3, DQuat)>,
    /// Half extent of the volume.
    pub half_extent: DVec3,
    /// Drones that could not be placed at the minimum separation.
    pub shortfall: u32,
}

/// The bounding-sphere radius of a model of largest span `size_m` centred on its box.
pub fn model_radius(size_m: f64) -> f64 {
    size_m * 3f64.sqrt() * 0.5
}

/// The largest bounding-sphere radius among the preset's models.
pub fn max_model_radius(preset: &Preset) -> f64 {
    preset
        .models
        .iter()
        .map(|m| model_radius(m.size_m))
        .fold(0.0, f64::max)
}

/// Half extent of a grid of `counts` cells at `spacing` metres.
fn grid_half_extent(counts: [u32; 3], spacing: f64) -> DVec3 {
    DVec3::new(
        f64::from(counts[0].saturating_sub(1)),
        f64::from(counts[1].saturating_sub(1)),
        f64::from(counts[2].saturating_sub(1)),
    ) * spacing
        * 0.5
}

/// Size of a randomized volume holding `n` drones.
fn random_volume_size(volume: &Volume, n: u32) -> DVec3 {
    match volume {
        Volume::Box { size_m: (x, y, z) } => DVec3::new(*x, *y, *z),
        Volume::Density { per_m3 } => DVec3::splat((f64::from(n) / per_m3).cbrt()),
    }
}

/// One line for `swarmshot check`: what the placement makes per frame.
pub fn describe(preset: &Preset) -> String {
    match &preset.placement {
        Placement::Structured {
            x_count,
            y_count,
            z_count,
            load_factor,
        } => {
            let spacing = load_factor * preset.max_model_size_m();
            let size = grid_half_extent([*x_count, *y_count, *z_count], spacing) * 2.0;
            format!(
                "structured grid {x_count}×{y_count}×{z_count} = {} drones per frame, spacing {spacing:.3} m, volume {:.3} × {:.3} × {:.3} m",
                u64::from(*x_count) * u64::from(*y_count) * u64::from(*z_count),
                size.x,
                size.y,
                size.z,
            )
        }
        Placement::Randomized {
            count: (lo, hi),
            volume,
            min_separation_m,
        } => format!(
            "randomized, {lo}–{hi} drones per frame (mean {:.1}), volume {volume:?}, min separation {min_separation_m} m",
            (f64::from(*lo) + f64::from(*hi)) / 2.0
        ),
    }
}

/// Place the drones of one frame in the unrotated volume, drawing from `rng`.
pub fn place(preset: &Preset, rng: &mut impl Rng) -> Placed {
    let n_models = preset.models.len().max(1);
    let attitude = |rng: &mut _| sample_attitude(rng, &preset.attitude);
    match &preset.placement {
        Placement::Structured {
            x_count,
            y_count,
            z_count,
            load_factor,
        } => {
            let spacing = load_factor * preset.max_model_size_m();
            let counts = IVec3::new(*x_count as i32, *y_count as i32, *z_count as i32);
            let half = grid_half_extent([*x_count, *y_count, *z_count], spacing);
            let mut out = Vec::with_capacity((x_count * y_count * z_count) as usize);
            for i in 0..counts.x {
                for j in 0..counts.y {
                    for k in 0..counts.z {
                        let model = rng.random_range(0..n_models);
                        let p = IVec3::new(i, j, k).as_dvec3() * spacing - half;
                        out.push((model, p, attitude(rng)));
                    }
                }
            }
            Placed {
                drones: out,
                half_extent: half,
                shortfall: 0,
            }
        }
        Placement::Randomized {
            count: (lo, hi),
            volume,
            min_separation_m,
        } => {
            let n = if hi > lo {
                rng.random_range(*lo..=*hi)
            } else {
                *lo
            };
            let half = random_volume_size(volume, n) * 0.5;
            let sep = *min_separation_m;
            let mut grid = SeparationGrid::new(sep);
            let mut out = Vec::with_capacity(n as usize);
            let mut shortfall = 0;
            for _ in 0..n {
                let model = rng.random_range(0..n_models);
                let mut placed = None;
                for _ in 0..PLACEMENT_ATTEMPTS {
                    let p = DVec3::new(
                        sample_range(rng, (-half.x, half.x)),
                        sample_range(rng, (-half.y, half.y)),
                        sample_range(rng, (-half.z, half.z)),
                    );
                    if grid.is_free(p) {
                        placed = Some(p);
                        break;
                    }
                }
                match placed {
                    Some(p) => {
                        grid.insert(p);
                        out.push((model, p, attitude(rng)));
                    }
                    None => shortfall += 1,
                }
            }
            Placed {
                drones: out,
                half_extent: half,
                shortfall,
            }
        }
    }
}

/// A hash grid of cell size = separation, so the separation test looks at 27 cells.
struct SeparationGrid {
    separation: f64,
    cells: HashMap<IVec3, Vec<DVec3>>,
}

impl SeparationGrid {
    fn new(separation: f64) -> Self {
        Self {
            separation,
            cells: HashMap::new(),
        }
    }

    fn cell(&self, p: DVec3) -> IVec3 {
        (p / self.separation).floor().as_ivec3()
    }

    fn is_free(&self, p: DVec3) -> bool {
        if self.separation <= 0.0 {
            return true;
        }
        let c = self.cell(p);
        let sep2 = self.separation * self.separation;
        for dx in -1..=1 {
            for dy in -1..=1 {
                for dz in -1..=1 {
                    if let Some(points) = self.cells.get(&(c + IVec3::new(dx, dy, dz)))
                        && points.iter().any(|q| q.distance_squared(p) < sep2)
                    {
                        return false;
                    }
                }
            }
        }
        true
    }

    fn insert(&mut self, p: DVec3) {
        if self.separation > 0.0 {
            let c = self.cell(p);
            self.cells.entry(c).or_default().push(p);
        }
    }
}

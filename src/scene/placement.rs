//! Placement modes: where a frame's drones go in the observation volume, and
//! the volume's extent. The one home of each mode: adding a mode means a new
//! arm here (and its fields in the preset).

use std::collections::HashMap;

use glam::{DQuat, DVec3, IVec3};
use rand::Rng;

use super::math::EulerDeg;
use crate::preset::{
    AttitudeRanges, CountDistribution, Formation, FormationShape, Placement, Preset, Volume,
};

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

/// The most counts a non-uniform distribution may span (a preset limit).
pub use crate::preset::MAX_COUNT_SPAN;

/// Relative weight of count `n` under `dist` (truncated to (lo, hi) by the
/// caller), as ln w so a Poisson of large mean neither overflows nor underflows.
fn log_weight(dist: &CountDistribution, lo: u32, n: u32) -> f64 {
    match dist {
        CountDistribution::Uniform => 0.0,
        CountDistribution::Table(rows) => rows
            .iter()
            .filter(|(k, _)| *k == n)
            .map(|(_, w)| *w)
            .sum::<f64>()
            .ln(),
        // ln(λⁿ / n!) = n ln λ − ln Γ(n + 1).
        CountDistribution::Poisson { mean } => f64::from(n) * mean.ln() - ln_factorial(n),
        CountDistribution::Geometric { p } => f64::from(n - lo) * (1.0 - p).ln(),
    }
}

fn ln_factorial(n: u32) -> f64 {
    (2..=n).map(|k| f64::from(k).ln()).sum()
}

/// Each count in lo..=hi with its probability under `dist` truncated to (lo, hi).
pub fn count_probabilities(lo: u32, hi: u32, dist: &CountDistribution) -> Vec<(u32, f64)> {
    let hi = hi.max(lo).min(lo.saturating_add(MAX_COUNT_SPAN - 1));
    let logs: Vec<(u32, f64)> = (lo..=hi).map(|n| (n, log_weight(dist, lo, n))).collect();
    let top = logs.iter().map(|l| l.1).fold(f64::NEG_INFINITY, f64::max);
    if !top.is_finite() {
        return vec![(lo, 1.0)];
    }
    let weights: Vec<(u32, f64)> = logs.iter().map(|&(n, l)| (n, (l - top).exp())).collect();
    let total: f64 = weights.iter().map(|w| w.1).sum();
    weights.into_iter().map(|(n, w)| (n, w / total)).collect()
}

/// The expected count under `dist` truncated to (lo, hi).
pub fn count_mean(lo: u32, hi: u32, dist: &CountDistribution) -> f64 {
    count_probabilities(lo, hi, dist)
        .iter()
        .map(|&(n, p)| f64::from(n) * p)
        .sum()
}

fn describe_distribution(dist: &CountDistribution) -> String {
    match dist {
        CountDistribution::Uniform => "uniform".into(),
        CountDistribution::Table(rows) => format!("table of {} counts", rows.len()),
        CountDistribution::Poisson { mean } => format!("Poisson λ = {mean}, truncated"),
        CountDistribution::Geometric { p } => format!("geometric p = {p}, truncated"),
    }
}

/// A frame's drone count in lo..=hi. `Uniform` is one `random_range` draw
/// (hi > lo) or none; the others invert the truncated CDF with one uniform
/// number in [0, 1).
pub fn draw_count(rng: &mut impl Rng, lo: u32, hi: u32, dist: &CountDistribution) -> u32 {
    if let CountDistribution::Uniform = dist {
        return if hi > lo {
            rng.random_range(lo..=hi)
        } else {
            lo
        };
    }
    let u: f64 = rng.random();
    let probabilities = count_probabilities(lo, hi, dist);
    let mut cumulative = 0.0;
    for &(n, p) in &probabilities {
        cumulative += p;
        if u < cumulative {
            return n;
        }
    }
    // Rounding left the sum a hair under 1: the last count with any weight.
    probabilities
        .iter()
        .rev()
        .find(|p| p.1 > 0.0)
        .map_or(lo, |p| p.0)
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
        Volume::Box { size_m: (x, y, z) }
        | Volume::DensitySweep {
            size_m: (x, y, z), ..
        } => DVec3::new(*x, *y, *z),
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
            count_distribution,
            volume,
            min_separation_m,
        } => format!(
            "randomized, {lo}–{hi} drones per frame ({}, mean {:.2}), volume {volume:?}, min separation {min_separation_m} m",
            describe_distribution(count_distribution),
            count_mean(*lo, *hi, count_distribution)
        ),
        Placement::Formation(f) => {
            let span = preset.max_model_size_m();
            format!(
                "formation {:?}, {} drones per frame, spacing {:.3} m, heading {:?}°, min separation {:.3} m",
                f.shape,
                f.count,
                f.spacing * span,
                f.heading_deg,
                f.min_separation * span
            )
        }
    }
}

/// Place the drones of one frame in the unrotated volume, drawing from `rng`;
/// `density_per_m3` is the frame's swept density of a `DensitySweep` volume,
/// which fixes the count at round(ρ·V) (at least 1) without a draw.
pub fn place(preset: &Preset, density_per_m3: Option<f64>, rng: &mut impl Rng) -> Placed {
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
            count_distribution,
            volume,
            min_separation_m,
        } => {
            let n = match (volume, density_per_m3) {
                (
                    Volume::DensitySweep {
                        size_m: (x, y, z), ..
                    },
                    Some(rho),
                ) => (rho * x * y * z).round().clamp(1.0, f64::from(u32::MAX)) as u32,
                _ => draw_count(rng, *lo, *hi, count_distribution),
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
        Placement::Formation(f) => place_formation(f, preset.max_model_size_m(), n_models, rng),
    }
}

/// Positions of the unjittered shape in the formation frame (forward +Z,
/// right +X, up +Y), centred on the origin, in metres for neighbours `d`
/// metres apart. `Clustered` has no fixed rule (see [`place_formation`]).
pub fn formation_shape(shape: &FormationShape, n: u32, d: f64) -> Vec<DVec3> {
    let c = |i: u32| f64::from(i) - f64::from(n.saturating_sub(1)) * 0.5;
    let points: Vec<DVec3> = match shape {
        FormationShape::LineAbreast => (0..n).map(|i| DVec3::X * c(i) * d).collect(),
        FormationShape::Column => (0..n).map(|i| DVec3::NEG_Z * c(i) * d).collect(),
        FormationShape::Echelon { angle_deg } => {
            let a = angle_deg.to_radians();
            let u = DVec3::new(a.sin(), 0.0, -a.cos());
            (0..n).map(|i| u * c(i) * d).collect()
        }
        FormationShape::Wedge { half_angle_deg } => {
            let a = half_angle_deg.to_radians();
            (0..n)
                .map(|i| {
                    let arm = f64::from(i.div_ceil(2));
                    let side = if i % 2 == 1 { -1.0 } else { 1.0 };
                    DVec3::new(side * arm * d * a.sin(), 0.0, -arm * d * a.cos())
                })
                .collect()
        }
        FormationShape::Ring { tilt_deg } => {
            let r = if n < 2 {
                0.0
            } else {
                d / (2.0 * (std::f64::consts::PI / f64::from(n)).sin())
            };
            let tilt = DQuat::from_rotation_x(tilt_deg.to_radians());
            (0..n)
                .map(|i| {
                    let t = std::f64::consts::TAU * f64::from(i) / f64::from(n);
                    tilt * DVec3::new(r * t.cos(), 0.0, r * t.sin())
                })
                .collect()
        }
        FormationShape::SphereShell => {
            let golden = std::f64::consts::PI * (3.0 - 5f64.sqrt());
            let unit: Vec<DVec3> = (0..n)
                .map(|i| {
                    let y = 1.0 - 2.0 * (f64::from(i) + 0.5) / f64::from(n);
                    let r = (1.0 - y * y).max(0.0).sqrt();
                    let phi = golden * f64::from(i);
                    DVec3::new(r * phi.cos(), y, r * phi.sin())
                })
                .collect();
            // The radius that puts the nearest two exactly `d` apart.
            let radius = min_pair_distance(&unit).map_or(0.0, |m| d / m);
            unit.into_iter().map(|p| p * radius).collect()
        }
        FormationShape::Clustered { .. } => Vec::new(),
    };
    centre_box(points)
}

/// Move points so that their bounding box is centred on the origin.
fn centre_box(points: Vec<DVec3>) -> Vec<DVec3> {
    let Some(first) = points.first() else {
        return points;
    };
    let (lo, hi) = points
        .iter()
        .fold((*first, *first), |(lo, hi), p| (lo.min(*p), hi.max(*p)));
    let mid = (lo + hi) * 0.5;
    points.into_iter().map(|p| p - mid).collect()
}

/// The smallest distance between two of `points` (`None` for fewer than two),
/// by a hash grid whose cell grows until the nearest pair falls in adjacent cells.
pub fn min_pair_distance(points: &[DVec3]) -> Option<f64> {
    if points.len() < 2 {
        return None;
    }
    let (lo, hi) = points.iter().fold((points[0], points[0]), |(lo, hi), p| {
        (lo.min(*p), hi.max(*p))
    });
    let extent = (hi - lo).max_element();
    if extent <= 0.0 {
        return Some(0.0);
    }
    // Start near the mean spacing of points filling a cube of that extent.
    let mut cell = (extent / (points.len() as f64).cbrt()).max(extent * 1e-9);
    loop {
        let mut cells: HashMap<IVec3, Vec<DVec3>> = HashMap::new();
        let mut best = f64::INFINITY;
        for p in points {
            let c = ((*p - lo) / cell).floor().as_ivec3();
            for dx in -1..=1 {
                for dy in -1..=1 {
                    for dz in -1..=1 {
                        if let Some(qs) = cells.get(&(c + IVec3::new(dx, dy, dz))) {
                            for q in qs {
                                best = best.min(q.distance(*p));
                            }
                        }
                    }
                }
            }
            cells.entry(c).or_default().push(*p);
        }
        // Any pair closer than `cell` lies in adjacent cells, so `best` is exact then.
        if best <= cell || cell > extent * 2.0 {
            return Some(best);
        }
        cell *= 2.0;
    }
}

/// A uniform point in the ball of radius `r` (rejection from the cube).
fn sample_ball(rng: &mut impl Rng, r: f64) -> DVec3 {
    loop {
        let p = DVec3::new(
            sample_range(rng, (-1.0, 1.0)),
            sample_range(rng, (-1.0, 1.0)),
            sample_range(rng, (-1.0, 1.0)),
        );
        if p.length_squared() <= 1.0 {
            return p * r;
        }
    }
}

/// Place a formation: draw its heading, then per drone its model, its
/// position jitter (x, y, z) and its attitude jitter (roll, pitch, yaw).
/// `Clustered` draws its group centres after the heading, then per drone its
/// model, its position in its group (retried until it keeps the separation;
/// a drone that never fits is a shortfall) and its attitude jitter.
/// `span` is the largest model span in metres.
pub fn place_formation(f: &Formation, span: f64, n_models: usize, rng: &mut impl Rng) -> Placed {
    let heading = DQuat::from_rotation_y(sample_range(rng, f.heading_deg).to_radians());
    let d = f.spacing * span;
    let jitter = f.position_jitter * span;
    let mut out = Vec::with_capacity(f.count as usize);
    let mut shortfall = 0;
    if let FormationShape::Clustered {
        clusters,
        cluster_gap,
    } = f.shape
    {
        let k = clusters.clamp(1, f.count.max(1));
        let sep = f.spacing.max(f.min_separation) * span;
        let sizes: Vec<u32> = (0..k)
            .map(|j| f.count / k + u32::from(j < f.count % k))
            .collect();
        let largest = sizes.iter().copied().max().unwrap_or(1);
        // Groups hold their drones' separation balls at a fifth of their volume.
        let radius = 0.5 * sep * (f64::from(largest) / 0.2).cbrt();
        let centre_gap = 2.0 * radius + cluster_gap * span;
        let half = 0.5 * centre_gap * (f64::from(k) / 0.2).cbrt();
        let mut centres_grid = SeparationGrid::new(centre_gap);
        let mut centres = Vec::with_capacity(k as usize);
        for j in 0..k {
            let mut placed = None;
            for _ in 0..PLACEMENT_ATTEMPTS {
                let p = DVec3::new(
                    sample_range(rng, (-half, half)),
                    sample_range(rng, (-half, half)) * 0.5,
                    sample_range(rng, (-half, half)),
                );
                if centres_grid.is_free(p) {
                    placed = Some(p);
                    break;
                }
            }
            // Out of the drawn cube, in a row: never overlaps a drawn group.
            let p = placed.unwrap_or_else(|| DVec3::X * (half + centre_gap * (f64::from(j) + 1.0)));
            centres_grid.insert(p);
            centres.push(p);
        }
        let mut grid = SeparationGrid::new(sep);
        for (centre, size) in centres.iter().zip(&sizes) {
            for _ in 0..*size {
                let model = rng.random_range(0..n_models);
                let mut placed = None;
                for _ in 0..PLACEMENT_ATTEMPTS {
                    let p = heading * (*centre + sample_ball(rng, radius));
                    if grid.is_free(p) {
                        placed = Some(p);
                        break;
                    }
                }
                match placed {
                    Some(p) => {
                        grid.insert(p);
                        let q = heading * sample_attitude(rng, &f.attitude_jitter);
                        out.push((model, p, q.normalize()));
                    }
                    None => shortfall += 1,
                }
            }
        }
    } else {
        for p in formation_shape(&f.shape, f.count, d) {
            let model = rng.random_range(0..n_models);
            let offset = DVec3::new(
                sample_range(rng, (-jitter, jitter)),
                sample_range(rng, (-jitter, jitter)),
                sample_range(rng, (-jitter, jitter)),
            );
            let q = heading * sample_attitude(rng, &f.attitude_jitter);
            out.push((model, heading * p + offset, q.normalize()));
        }
    }
    let half_extent = out.iter().fold(DVec3::ZERO, |h, (_, p, _)| h.max(p.abs()));
    Placed {
        drones: out,
        half_extent,
        shortfall,
    }
}

/// A multiply-rotate hasher for grid cells: the separation test hashes 27
/// cells per try, and SipHash's flood resistance buys nothing here (the
/// keys are our own). Which cells hold which points does not depend on it.
#[derive(Default)]
struct CellHasher(u64);

impl std::hash::Hasher for CellHasher {
    fn finish(&self) -> u64 {
        crate::seed::mix64(self.0)
    }

    fn write(&mut self, bytes: &[u8]) {
        for &b in bytes {
            self.write_u64(u64::from(b));
        }
    }

    fn write_i32(&mut self, v: i32) {
        self.write_u64(u64::from(v as u32));
    }

    fn write_u64(&mut self, v: u64) {
        self.0 = (self.0 ^ v)
            .wrapping_mul(0x9E37_79B9_7F4A_7C15)
            .rotate_left(23);
    }
}

type CellMap = HashMap<IVec3, Vec<DVec3>, std::hash::BuildHasherDefault<CellHasher>>;

/// A hash grid of cell size = separation, so the separation test looks at 27 cells.
struct SeparationGrid {
    separation: f64,
    cells: CellMap,
}

impl SeparationGrid {
    fn new(separation: f64) -> Self {
        Self {
            separation,
            cells: CellMap::default(),
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

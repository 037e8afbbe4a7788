//! The frame's near-field scenery (issue 22 item 2) as plain data: tree
//! lines, bare trees, poles and wires, buildings, drawn from their own salted
//! stream (`seed::CLUTTER_SALT`) and placed around the camera, inside its
//! view. World frame: +Y up; the ground is the plane `eye_height_m` below
//! the camera. The renderer rasterises the primitives (`render::scenery`).
//!
//! Draw order: per kind (tree lines, trees, poles, buildings) the count,
//! then per object its distance, azimuth, size and shape draws.

use glam::DVec3;
use rand::Rng;
use rand_chacha::ChaCha8Rng;
use serde::Serialize;

use super::camera::Camera;
use crate::preset::clutter::{Buildings, Clutter, Poles, TreeLines, Trees};
use crate::seed;

/// One opaque piece of scenery.
#[derive(Clone, Debug, PartialEq)]
pub enum Shape {
    /// A tapered cylinder from `a` to `b` (radii in metres), drawn as its
    /// silhouette: branches, trunks, poles, wires.
    Segment {
        a: DVec3,
        b: DVec3,
        radius_a_m: f64,
        radius_b_m: f64,
    },
    /// A convex polygon (world points in order), planar or nearly: walls,
    /// roofs, canopy, a tree line's body (its feet on an arc about the camera).
    Polygon(Vec<DVec3>),
}

/// A shape with its look: linear albedo and how much it faces the sun (0–1).
#[derive(Clone, Debug, PartialEq)]
pub struct Primitive {
    pub shape: Shape,
    pub albedo: [f32; 3],
    pub sun_facing: f32,
}

/// The frame's scenery: what was drawn (the manifest's record) and its primitives.
#[derive(Clone, Debug, Default, PartialEq, Serialize)]
pub struct FrameClutter {
    pub tree_lines: u32,
    pub trees: u32,
    pub poles: u32,
    pub wires: u32,
    pub buildings: u32,
    /// The shapes the renderer draws (not written to the manifest).
    #[serde(skip)]
    pub primitives: Vec<Primitive>,
}

impl FrameClutter {
    /// Scenery made of `primitives` only (tests, tools).
    pub fn from_primitives(primitives: Vec<Primitive>) -> Self {
        Self {
            primitives,
            ..Self::default()
        }
    }
}

fn uniform(rng: &mut ChaCha8Rng, (lo, hi): (f64, f64)) -> f64 {
    let u: f64 = rng.random();
    lo + (hi - lo) * u
}

fn count(rng: &mut ChaCha8Rng, (lo, hi): (u32, u32)) -> u32 {
    rng.random_range(lo..=hi)
}

/// Where objects stand: the ground under the camera and its horizontal axes.
struct Frame {
    origin: DVec3,
    forward: DVec3,
    right: DVec3,
    /// Half the horizontal field of view plus a margin, radians.
    half_span: f64,
    sun: DVec3,
    /// Metres per pixel at 1 m: the angle a pixel spans (radians).
    pixel_rad: f64,
}

impl Frame {
    fn new(camera: &Camera, eye_height_m: f64, sun: DVec3) -> Self {
        let look = camera.camera_from_world.row(2);
        let flat = DVec3::new(look.x, 0.0, look.z);
        let forward = if flat.length() > 1e-6 {
            flat.normalize()
        } else {
            DVec3::Z
        };
        let right = DVec3::Y.cross(forward).normalize();
        let aspect = f64::from(camera.width) / f64::from(camera.height.max(1));
        let half_fov_x = ((camera.fov_y_deg.to_radians() * 0.5).tan() * aspect).atan();
        Self {
            origin: camera.position - DVec3::Y * eye_height_m,
            forward,
            right,
            half_span: (half_fov_x + 5f64.to_radians()).min(std::f64::consts::PI),
            sun,
            pixel_rad: 1.0 / camera.focal_px().max(1e-9),
        }
    }

    /// The ground point at `distance` along azimuth `angle` (radians from forward).
    fn at(&self, angle: f64, distance: f64) -> DVec3 {
        self.origin + (self.forward * angle.cos() + self.right * angle.sin()) * distance
    }

    fn angle(&self, rng: &mut ChaCha8Rng) -> f64 {
        uniform(rng, (-self.half_span, self.half_span))
    }

    fn facing(&self, normal: DVec3) -> f32 {
        normal.normalize_or_zero().dot(self.sun).max(0.0) as f32
    }
}

/// The scenery of frame `draw_index` seen by `camera` (`None` without `clutter`).
pub fn frame_clutter(
    clutter: &Clutter,
    preset_seed: u64,
    draw_index: u64,
    camera: &Camera,
    sun: DVec3,
) -> FrameClutter {
    let index = if clutter.per_frame { draw_index } else { 0 };
    let mut rng = seed::salted_rng(preset_seed, index, seed::CLUTTER_SALT);
    let frame = Frame::new(camera, clutter.eye_height_m, sun);
    let mut out = FrameClutter::default();
    out.tree_lines = tree_lines(&clutter.tree_lines, &frame, &mut rng, &mut out.primitives);
    out.trees = trees(&clutter.trees, &frame, &mut rng, &mut out.primitives);
    let (poles, wires) = poles(&clutter.poles, &frame, &mut rng, &mut out.primitives);
    (out.poles, out.wires) = (poles, wires);
    out.buildings = buildings(&clutter.buildings, &frame, &mut rng, &mut out.primitives);
    out
}

fn tree_lines(spec: &TreeLines, f: &Frame, rng: &mut ChaCha8Rng, out: &mut Vec<Primitive>) -> u32 {
    let n = count(rng, spec.count);
    for _ in 0..n {
        let distance = uniform(rng, spec.distance_m);
        let centre = f.angle(rng);
        let width = uniform(rng, spec.width_deg).to_radians();
        let height = uniform(rng, spec.height_m);
        let green = uniform(rng, (0.02, 0.06)) as f32;
        let albedo = [green * 0.8, green * 1.3, green * 0.6];
        // Crowns of radius 2–5 m along the band; the top is the highest crown
        // over each point, roughened by leaves (±0.3 m).
        let length = distance * width;
        // Points every 0.5 m, or every 1.5 pixels where that is wider.
        let step = (1.5 * distance * f.pixel_rad).max(0.5);
        let points = ((length / step) as usize).clamp(8, 4000);
        let mut crowns = Vec::new();
        let mut s = 0.0;
        while s < length {
            let r = uniform(rng, (2.0, 5.0));
            crowns.push((s, r, height * uniform(rng, (0.7, 1.0)) - r));
            s += r * uniform(rng, (0.8, 1.6));
        }
        // Crowns lie in order along the band: a point looks only at those
        // within reach (the cost is the band's length, not length²).
        let mut first = 0;
        let tops: Vec<(DVec3, DVec3)> = (0..=points)
            .map(|i| {
                let s = length * i as f64 / points as f64;
                let top =
                    crown_top(&crowns, s, &mut first, height * 0.3) + uniform(rng, (-0.3, 0.3));
                let ground = f.at(centre - width * 0.5 + s / distance, distance);
                (ground - DVec3::Y, ground + DVec3::Y * top)
            })
            .collect();
        let look = (albedo, f.facing(-f.forward) * 0.5);
        let step_px = step / (distance * f.pixel_rad);
        let strips = ((BAND_CHUNK_PX / step_px) as usize).max(1);
        band_shapes(&tops, strips, look, out);
    }
    n
}

/// How wide (pixels) the pieces of a tree line's body are: see [`band_shapes`].
const BAND_CHUNK_PX: f64 = 12.0;

/// A tree line's shapes from its `(foot, top)` points along the band, the
/// strips between them taken `strips` at a time (about [`BAND_CHUNK_PX`]
/// pixels): one body up to the lowest of their tops, and over it each
/// strip's cap up to its own two. Together they cover what a polygon a
/// strip covers, but the raster's cost is per shape row, and a body's row
/// is one where the strips' were `strips` (a tree line's strips are 1.5
/// pixels wide at most distances). The strips under a body share its depth
/// and colour (the nearest of theirs), which differ from strip to strip by
/// the change in distance across a few metres of band. `strips` = 1: a
/// polygon a strip. Every shape has the band's albedo and sun term.
pub fn band_shapes(
    tops: &[(DVec3, DVec3)],
    strips: usize,
    (albedo, sun_facing): ([f32; 3], f32),
    out: &mut Vec<Primitive>,
) {
    let with = |points: Vec<DVec3>| Primitive {
        shape: Shape::Polygon(points),
        albedo,
        sun_facing,
    };
    let last = tops.len().saturating_sub(1);
    for start in (0..last).step_by(strips.max(1)) {
        let chunk = &tops[start..=(start + strips).min(last)];
        if let [(a, b), (c, d)] = chunk {
            out.push(with(vec![*a, *c, *d, *b]));
            continue;
        }
        // The cut: the same height over the ground at every point (its
        // feet are level), the lowest top's.
        let low = chunk
            .iter()
            .map(|(a, b)| b.y - a.y)
            .fold(f64::INFINITY, f64::min);
        let cut: Vec<DVec3> = chunk
            .iter()
            .map(|(a, b)| a.lerp(*b, low / (b.y - a.y)))
            .collect();
        out.push(with(
            chunk
                .iter()
                .map(|p| p.0)
                .chain(cut.iter().rev().copied())
                .collect(),
        ));
        out.extend(
            (chunk.windows(2).zip(cut.windows(2)))
                .map(|(top, foot)| with(vec![foot[0], foot[1], top[1].1, top[0].1])),
        );
    }
}

/// The highest crown over point `s` of a band (at least `floor`): crowns
/// are `(centre, radius, height)` in increasing centre, radii under 5 m, so
/// only those with a centre within 6 m of `s` can reach it. `first` is where
/// the last point's window began (points come in increasing `s`). The max is
/// exact, so the result is the same as over every crown.
fn crown_top(crowns: &[(f64, f64, f64)], s: f64, first: &mut usize, floor: f64) -> f64 {
    const REACH_M: f64 = 6.0;
    while *first < crowns.len() && crowns[*first].0 < s - REACH_M {
        *first += 1;
    }
    crowns[*first..]
        .iter()
        .take_while(|(c, _, _)| *c <= s + REACH_M)
        .filter(|(c, r, _)| (s - c).abs() < *r)
        .map(|(c, r, y)| y + (r * r - (s - c) * (s - c)).sqrt())
        .fold(floor, f64::max)
}

/// A random unit vector within `spread` radians of `axis`.
fn bend(axis: DVec3, spread: f64, rng: &mut ChaCha8Rng) -> DVec3 {
    let side = axis.any_orthonormal_vector();
    let turn = glam::DQuat::from_axis_angle(axis, uniform(rng, (0.0, std::f64::consts::TAU)));
    let tilt = glam::DQuat::from_axis_angle(turn * side, uniform(rng, (0.3, 1.0)) * spread);
    (tilt * axis).normalize()
}

fn trees(spec: &Trees, f: &Frame, rng: &mut ChaCha8Rng, out: &mut Vec<Primitive>) -> u32 {
    let n = count(rng, spec.count);
    for _ in 0..n {
        let distance = uniform(rng, spec.distance_m);
        let base = f.at(f.angle(rng), distance);
        let height = uniform(rng, spec.height_m);
        let grey = uniform(rng, (0.03, 0.08)) as f32;
        let albedo = [grey * 1.1, grey, grey * 0.85];
        let trunk = height * uniform(rng, (0.25, 0.4));
        // (start, direction, length, radius, level)
        let mut stack = vec![(base, bend(DVec3::Y, 0.1, rng), trunk, height / 45.0, 0u32)];
        while let Some((start, dir, length, radius, level)) = stack.pop() {
            let end = start + dir * length;
            let tip = radius * 0.7;
            out.push(Primitive {
                shape: Shape::Segment {
                    a: start,
                    b: end,
                    radius_a_m: radius,
                    radius_b_m: tip,
                },
                albedo,
                sun_facing: 0.3,
            });
            if level >= spec.branch_levels {
                continue;
            }
            let children = rng.random_range(2..=3);
            for _ in 0..children {
                // Children lean upward and outward; later levels spread wider.
                let mut d = bend(dir, 0.45 + 0.08 * f64::from(level), rng);
                d = (d + DVec3::Y * 0.25).normalize();
                let scale = uniform(rng, (0.6, 0.8));
                let from = start + dir * length * uniform(rng, (0.7, 1.0));
                stack.push((from, d, length * scale * 1.15, tip * 0.8, level + 1));
            }
        }
    }
    n
}

fn poles(spec: &Poles, f: &Frame, rng: &mut ChaCha8Rng, out: &mut Vec<Primitive>) -> (u32, u32) {
    let lines = count(rng, spec.count);
    let mut total = (0, 0);
    for _ in 0..lines {
        let distance = uniform(rng, spec.distance_m);
        let centre = f.at(f.angle(rng), distance);
        let height = uniform(rng, spec.height_m);
        let spacing = uniform(rng, spec.spacing_m);
        let wires = count(rng, spec.wires);
        // The line runs across the view, turned up to ±30° from square.
        let turn = glam::DQuat::from_rotation_y(uniform(rng, (-0.5, 0.5)));
        let along = turn * f.right;
        let reach = distance * f.half_span.tan() * 1.5 + spacing;
        let half = ((reach / spacing).ceil() as i64).min(20);
        let albedo = [0.05, 0.045, 0.04];
        let tops: Vec<DVec3> = (-half..=half)
            .map(|k| centre + along * (k as f64 * spacing))
            .collect();
        for &foot in &tops {
            let top = foot + DVec3::Y * height;
            out.push(segment(foot, top, 0.13, 0.1, albedo));
            let arm = along * (0.6 + 0.2 * f64::from(wires));
            out.push(segment(
                top - arm - DVec3::Y * 0.3,
                top + arm - DVec3::Y * 0.3,
                0.05,
                0.05,
                albedo,
            ));
        }
        for span in tops.windows(2) {
            for w in 0..wires {
                let offset = (f64::from(w) + 0.5 - f64::from(wires) * 0.5) * 0.4;
                let a = span[0] + DVec3::Y * (height - 0.25) + along * offset;
                let b = span[1] + DVec3::Y * (height - 0.25) + along * offset;
                let sag = spacing * 0.025;
                let steps = 16;
                let point = |i: u32| {
                    let t = f64::from(i) / f64::from(steps);
                    a.lerp(b, t) - DVec3::Y * (sag * 4.0 * t * (1.0 - t))
                };
                for i in 0..steps {
                    out.push(segment(point(i), point(i + 1), 0.012, 0.012, [0.03; 3]));
                }
            }
        }
        total.0 += tops.len() as u32;
        total.1 += wires * (tops.len() as u32).saturating_sub(1);
    }
    total
}

fn segment(a: DVec3, b: DVec3, radius_a_m: f64, radius_b_m: f64, albedo: [f32; 3]) -> Primitive {
    Primitive {
        shape: Shape::Segment {
            a,
            b,
            radius_a_m,
            radius_b_m,
        },
        albedo,
        sun_facing: 0.3,
    }
}

fn buildings(spec: &Buildings, f: &Frame, rng: &mut ChaCha8Rng, out: &mut Vec<Primitive>) -> u32 {
    const WALLS: [[f32; 3]; 4] = [
        [0.35, 0.33, 0.3],
        [0.25, 0.12, 0.08],
        [0.45, 0.4, 0.32],
        [0.18, 0.18, 0.19],
    ];
    let n = count(rng, spec.count);
    for _ in 0..n {
        let distance = uniform(rng, spec.distance_m);
        let base = f.at(f.angle(rng), distance);
        let height = uniform(rng, spec.height_m);
        let width = uniform(rng, spec.width_m);
        let depth = width * uniform(rng, (0.6, 1.2));
        let yaw = glam::DQuat::from_rotation_y(uniform(rng, (0.0, std::f64::consts::TAU)));
        let wall = WALLS[rng.random_range(0..WALLS.len())];
        let gabled = rng.random_bool(0.5);
        let (x, z) = (
            yaw * DVec3::X * (width * 0.5),
            yaw * DVec3::Z * (depth * 0.5),
        );
        let up = DVec3::Y * height;
        let corners = [base - x - z, base + x - z, base + x + z, base - x + z];
        let mut face = |points: Vec<DVec3>, albedo: [f32; 3], normal: DVec3| {
            out.push(Primitive {
                shape: Shape::Polygon(points),
                albedo,
                sun_facing: f.facing(normal),
            });
        };
        for i in 0..4 {
            let (a, b) = (corners[i], corners[(i + 1) % 4]);
            let normal = ((a + b) * 0.5 - base).normalize_or_zero();
            face(vec![a, b, b + up, a + up], wall, normal);
        }
        let roof = [0.08, 0.06, 0.05];
        if gabled {
            let ridge = DVec3::Y * (height + width * 0.25);
            let (l, r) = (base - x + ridge, base + x + ridge);
            let c = corners.map(|c| c + up);
            face(vec![c[0], c[1], r, l], roof, -z + DVec3::Y * depth * 0.5);
            face(vec![c[3], c[2], r, l], roof, z + DVec3::Y * depth * 0.5);
            face(vec![c[0], c[3], l], wall, -x);
            face(vec![c[1], c[2], r], wall, x);
        } else {
            face(corners.map(|c| c + up).to_vec(), roof, DVec3::Y);
        }
    }
    n
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::SeedableRng;

    /// The windowed crown search gives the very bytes of the search over
    /// every crown (the band's tops are unchanged).
    #[test]
    fn crown_top_equals_the_search_over_every_crown() {
        let mut rng = ChaCha8Rng::seed_from_u64(41);
        let (length, height) = (3000.0, 20.0);
        let mut crowns = Vec::new();
        let mut s = 0.0;
        while s < length {
            let r = uniform(&mut rng, (2.0, 5.0));
            crowns.push((s, r, height * uniform(&mut rng, (0.7, 1.0)) - r));
            s += r * uniform(&mut rng, (0.8, 1.6));
        }
        let mut first = 0;
        for i in 0..=4000 {
            let s = length * f64::from(i) / 4000.0;
            let all = (crowns.iter())
                .filter(|(c, r, _)| (s - c).abs() < *r)
                .map(|(c, r, y)| y + (r * r - (s - c) * (s - c)).sqrt())
                .fold(height * 0.3, f64::max);
            let windowed = crown_top(&crowns, s, &mut first, height * 0.3);
            assert_eq!(all.to_bits(), windowed.to_bits(), "point {i}");
        }
    }
}

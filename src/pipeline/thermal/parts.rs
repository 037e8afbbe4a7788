//! An object's warm spots in the thermal picture (issue 41; docs/realism.md,
//! "Thermal camera"): one Gaussian about its projected centre, σ a share of
//! its half box (the default), or, with the signature's `motor_k` or
//! `battery_k` set, its parts: a motor at each rotor hub of its model (the
//! centres of the model's rotor discs, its glTF BLEND surfaces) and a battery
//! at the body's centre, each projected by the frame's camera with a σ from
//! the part's physical size and distance.
//!
//! A part's Gaussian holds the integral of a uniform disc of the part's
//! radius a (σ = a/√2), widened by a pixel's own extent (σ² + 1/12 a side,
//! the peak lowered to keep the integral), so a motor smaller than a pixel
//! adds what it covers of it rather than vanishing between pixel centres.

use glam::{DMat3, DVec3};

use crate::model::CpuModel;
use crate::preset::thermal::Signature;
use crate::scene::DronePose;
use crate::scene::camera::Camera;

/// A motor's radius as a share of its rotor disc's (the built-in models'
/// proportion: `tools/assets.rs` gives each motor a fifth of its propeller).
const MOTOR_SHARE: f64 = 0.2;

/// A battery's half size as a share of the object's largest span (a pack of
/// about a fifth of the frame's span, as on common quadcopters).
const BATTERY_SHARE: f64 = 0.1;

/// A rotor disc is flat: its thinnest extent at most this share of its widest.
const FLAT: f64 = 0.5;

/// One warm Gaussian in the picture, kelvin above the skin at its peak.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) struct Warm {
    pub centre: (f32, f32),
    pub inv_two_sigma2: f32,
    pub peak_k: f64,
}

impl Warm {
    /// Its share of the peak at pixel (x, y)'s centre.
    pub fn at(&self, x: u32, y: u32) -> f32 {
        let (dx, dy) = (
            x as f32 + 0.5 - self.centre.0,
            y as f32 + 0.5 - self.centre.1,
        );
        (-(dx * dx + dy * dy) * self.inv_two_sigma2).exp()
    }
}

/// A rotor disc of a model, in its normalised model space.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) struct Disc {
    pub centre: DVec3,
    pub radius: f64,
    /// The disc's axis: its box's thinnest direction.
    pub axis: DVec3,
}

/// The single warm spot of an object whose pixels span `hit_box`: about
/// its projected centre (the box's centre when it does not project), σ
/// `spot_share` × half the box's larger side.
pub(super) fn box_spot(
    cam: &Camera,
    position: DVec3,
    hit_box: (u32, u32, u32, u32),
    sig: &Signature,
) -> Warm {
    let (x0, y0, x1, y1) = hit_box;
    let p = cam.camera_from_world_point(position);
    let box_centre = ((x0 + x1 + 1) as f32 * 0.5, (y0 + y1 + 1) as f32 * 0.5);
    let centre = (cam.project_camera_point(p)).map_or(box_centre, |c| (c.x as f32, c.y as f32));
    let half = ((x1 - x0 + 1).max(y1 - y0 + 1) as f32 * 0.5).max(0.5);
    let sigma = (sig.spot_share as f32 * half).max(0.3);
    Warm {
        centre,
        inv_two_sigma2: 1.0 / (2.0 * sigma * sigma),
        peak_k: sig.spot_k,
    }
}

/// The warm parts of `drone` (module docs): its battery at the centre
/// (`battery_k`), a motor at each of `discs`' centres (`motor_k`); a part
/// behind the camera or at 0 K is left out.
pub(super) fn part_spots(
    cam: &Camera,
    drone: &DronePose,
    discs: &[Disc],
    sig: &Signature,
) -> Vec<Warm> {
    let centre = cam.camera_from_world_point(drone.position);
    let rot = cam.camera_from_world * DMat3::from_quat(drone.rotation);
    let battery = (DVec3::ZERO, BATTERY_SHARE * drone.size_m);
    let motors = (discs.iter()).map(|d| (d.centre, MOTOR_SHARE * d.radius * drone.size_m));
    let battery_k = sig.battery_k.unwrap_or(0.0);
    let motor_k = sig.motor_k.unwrap_or(0.0);
    (std::iter::once((battery, battery_k)))
        .chain(motors.map(|m| (m, motor_k)))
        .filter(|&(_, k)| k > 0.0)
        .filter_map(|((at, radius_m), k)| {
            let p = centre + rot * (at * drone.size_m);
            let c = cam.project_camera_point(p)?;
            let sigma_px = cam.focal_px() * radius_m / std::f64::consts::SQRT_2 / p.z;
            let s2 = sigma_px * sigma_px;
            let wide = s2 + 1.0 / 12.0;
            Some(Warm {
                centre: (c.x as f32, c.y as f32),
                inv_two_sigma2: (1.0 / (2.0 * wide)) as f32,
                peak_k: k * s2 / wide,
            })
        })
        .collect()
}

/// A drone's spinning rotors as the frame's camera sees them (`rotor_k`):
/// each disc's centre and axis in camera space, its radius and its motor's,
/// squared (metres).
pub(super) struct Rotors {
    discs: Vec<(DVec3, DVec3, f64, f64)>,
    focal: f64,
    principal: glam::DVec2,
}

impl Rotors {
    pub fn new(cam: &Camera, drone: &DronePose, discs: &[Disc]) -> Self {
        let centre = cam.camera_from_world_point(drone.position);
        let rot = cam.camera_from_world * DMat3::from_quat(drone.rotation);
        let discs = (discs.iter())
            .map(|d| {
                let (r, a) = (
                    d.radius * drone.size_m,
                    MOTOR_SHARE * d.radius * drone.size_m,
                );
                (
                    centre + rot * (d.centre * drone.size_m),
                    rot * d.axis,
                    r * r,
                    a * a,
                )
            })
            .collect();
        Self {
            discs,
            focal: cam.focal_px(),
            principal: cam.principal_point(),
        }
    }

    /// Whether pixel (x, y)'s centre ray crosses a disc between its motor
    /// and its rim (the blades, not the hub).
    pub fn cover(&self, x: u32, y: u32) -> bool {
        let ray = DVec3::new(
            (f64::from(x) + 0.5 - self.principal.x) / self.focal,
            (f64::from(y) + 0.5 - self.principal.y) / self.focal,
            1.0,
        );
        self.discs.iter().any(|&(c, n, r2, a2)| {
            let across = n.dot(ray);
            if across.abs() < 1e-9 {
                return false;
            }
            let d2 = (ray * (n.dot(c) / across) - c).length_squared();
            a2 < d2 && d2 < r2
        })
    }
}

/// The rotor discs of `model`: its BLEND triangles (every corner marked
/// [`crate::model::BLEND_MARK`]) joined by shared corners (corners at the
/// same position are one: a flat-shaded disc repeats them), each flat
/// piece's box centre and half its widest extent; pieces whose centres lie
/// within a radius of each other are one rotor (a coaxial pair).
pub(super) fn rotor_discs(model: &CpuModel) -> Vec<Disc> {
    let v = &model.vertices;
    let blend = |i: u32| v.get(i as usize).is_some_and(|v| v.material[3] < 0.0);
    let mut parent: Vec<u32> = (0..v.len() as u32).collect();
    let mut first_at = std::collections::HashMap::new();
    for (i, vertex) in v.iter().enumerate() {
        if blend(i as u32) {
            let at = first_at
                .entry(vertex.position.map(f32::to_bits))
                .or_insert(i as u32);
            union(&mut parent, *at, i as u32);
        }
    }
    for t in model.indices.chunks_exact(3) {
        if t.iter().all(|&i| blend(i)) {
            union(&mut parent, t[0], t[1]);
            union(&mut parent, t[0], t[2]);
        }
    }
    // Each piece's box, in the order of its first corner.
    let mut pieces: Vec<(u32, Box3)> = Vec::new();
    for t in model
        .indices
        .chunks_exact(3)
        .filter(|t| t.iter().all(|&i| blend(i)))
    {
        for &i in t {
            let root = find(&mut parent, i);
            let p = DVec3::from(v[i as usize].position.map(f64::from));
            match pieces.iter_mut().find(|(r, _)| *r == root) {
                Some((_, b)) => *b = (b.0.min(p), b.1.max(p)),
                None => pieces.push((root, (p, p))),
            }
        }
    }
    let flat = (pieces.into_iter()).map(|(_, b)| b).filter(|(lo, hi)| {
        let e = *hi - *lo;
        e.max_element() > 0.0 && e.min_element() <= FLAT * e.max_element()
    });
    (merge_close(flat).into_iter())
        .map(|(lo, hi)| {
            let e = hi - lo;
            let axis = if e.x <= e.y && e.x <= e.z {
                DVec3::X
            } else if e.y <= e.z {
                DVec3::Y
            } else {
                DVec3::Z
            };
            Disc {
                centre: (lo + hi) * 0.5,
                radius: e.max_element() * 0.5,
                axis,
            }
        })
        .collect()
}

/// A box in model space (low and high corners).
type Box3 = (DVec3, DVec3);

/// Boxes whose centres lie within the larger one's half widest extent
/// merged into their union, in order of first appearance.
fn merge_close(boxes: impl Iterator<Item = Box3>) -> Vec<Box3> {
    let centre = |b: &Box3| (b.0 + b.1) * 0.5;
    let radius = |b: &Box3| (b.1 - b.0).max_element() * 0.5;
    let mut out: Vec<Box3> = Vec::new();
    for b in boxes {
        let near = |o: &&mut Box3| centre(o).distance(centre(&b)) < radius(o).max(radius(&b));
        match out.iter_mut().find(near) {
            Some(o) => *o = (o.0.min(b.0), o.1.max(b.1)),
            None => out.push(b),
        }
    }
    out
}

fn find(parent: &mut [u32], mut i: u32) -> u32 {
    while parent[i as usize] != i {
        let up = parent[parent[i as usize] as usize];
        parent[i as usize] = up;
        i = up;
    }
    i
}

fn union(parent: &mut [u32], a: u32, b: u32) {
    let (a, b) = (find(parent, a), find(parent, b));
    // The smaller index is the root: the pieces' order does not depend on the joins'.
    let (lo, hi) = (a.min(b), a.max(b));
    parent[hi as usize] = lo;
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The distance of a point from the model's vertical axis.
    fn off_axis(p: DVec3) -> f64 {
        DVec3::new(p.x, 0.0, p.z).length()
    }

    #[test]
    fn multirotors_have_a_disc_per_motor_at_equal_distances_from_their_axis() {
        // The heavy lifter's coaxial pairs are one motor each.
        for (name, n) in [
            ("quad_x", 4),
            ("hexacopter", 6),
            ("octocopter", 8),
            ("heavy_lift", 4),
        ] {
            let src = crate::preset::ModelSource::Builtin(name.into());
            let Ok(model) = crate::pipeline::load_model(&src) else {
                panic!("{name} loads");
            };
            let discs = rotor_discs(&model);
            assert_eq!(discs.len(), n, "{name}: {discs:?}");
            let r0 = off_axis(discs[0].centre);
            for d in &discs {
                assert!((off_axis(d.centre) - r0).abs() < 1e-3, "{name}: {d:?}");
                assert!((0.05..0.35).contains(&d.radius), "{name}: {d:?}");
                assert!(d.radius < r0, "{name}: {d:?}");
            }
        }
    }
}

//! Screen geometry of the scene: drones projected to pixel boxes, in f64.
//! Used by the renderer (where to draw, which drones overlap) and by the
//! labels (amodal and paper boxes).
//!
//! - `Amodal`: every convex-hull vertex of the placed model is projected and
//!   the min/max taken: the tight box of the whole silhouette, occluded parts
//!   included.
//! - `PaperAabb`: the paper's Eq. 9–10: the 8 corners of the model's world
//!   axis-aligned box (the local box transformed, as Unity's `Renderer.bounds`).
//!
//! Through a lens (`camera_model.lens`, [`frame_lens`]) both are taken of
//! the lens-mapped points ([`amodal_box_through`], [`paper_aabb_box_through`]):
//! the amodal box of the projected hull's outline with each edge sampled at
//! most a pixel apart (a straight edge bends), the paper's box of its 8
//! corners mapped.
//!
//! Both clip the point set against the near plane z = near before projecting
//! (adding the intersections of every front/back point pair, a superset of the
//! clipped polytope's vertices lying inside it), so a drone crossing the near
//! plane or partly behind the camera gets a correct box, never NaN or a box
//! wrapped across the image.

use glam::{DMat3, DVec2, DVec3};
use serde::Serialize;

use super::DronePose;
use super::camera::Camera;
use crate::sensor::lens::LensGeometry;

/// An axis-aligned box in continuous pixel coordinates (x right, y down).
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct PixelBox {
    pub x0: f64,
    pub y0: f64,
    pub x1: f64,
    pub y1: f64,
}

impl PixelBox {
    pub fn width(&self) -> f64 {
        self.x1 - self.x0
    }
    pub fn height(&self) -> f64 {
        self.y1 - self.y0
    }
    pub fn area(&self) -> f64 {
        self.width().max(0.0) * self.height().max(0.0)
    }
    /// Intersection with the image rectangle [0, W] × [0, H].
    pub fn clip(&self, width: f64, height: f64) -> Self {
        Self {
            x0: self.x0.clamp(0.0, width),
            y0: self.y0.clamp(0.0, height),
            x1: self.x1.clamp(0.0, width),
            y1: self.y1.clamp(0.0, height),
        }
    }
    pub fn iou(&self, other: &Self) -> f64 {
        let inter = Self {
            x0: self.x0.max(other.x0),
            y0: self.y0.max(other.y0),
            x1: self.x1.min(other.x1),
            y1: self.y1.min(other.y1),
        };
        let i = if inter.width() > 0.0 && inter.height() > 0.0 {
            inter.area()
        } else {
            0.0
        };
        let u = self.area() + other.area() - i;
        if u > 0.0 { i / u } else { 0.0 }
    }

    /// Grows `b` (`None`: empty) to cover the pixel whose corner is (x, y).
    pub fn include_pixel(b: &mut Option<Self>, x: f64, y: f64) {
        let nb = b.get_or_insert(Self {
            x0: x,
            y0: y,
            x1: x + 1.0,
            y1: y + 1.0,
        });
        nb.x0 = nb.x0.min(x);
        nb.y0 = nb.y0.min(y);
        nb.x1 = nb.x1.max(x + 1.0);
        nb.y1 = nb.y1.max(y + 1.0);
    }

    /// The box of `points` (`None` when there are none).
    pub fn from_points(points: impl IntoIterator<Item = DVec2>) -> Option<Self> {
        let mut b: Option<Self> = None;
        for p in points {
            let nb = b.get_or_insert(Self {
                x0: p.x,
                y0: p.y,
                x1: p.x,
                y1: p.y,
            });
            nb.x0 = nb.x0.min(p.x);
            nb.y0 = nb.y0.min(p.y);
            nb.x1 = nb.x1.max(p.x);
            nb.y1 = nb.y1.max(p.y);
        }
        b
    }
}

/// The geometry the labeller needs of each model (normalised model space).
#[derive(Clone, Debug)]
pub struct LabelGeometry {
    pub hull: Vec<DVec3>,
    pub aabb: (DVec3, DVec3),
}

impl From<&crate::model::CpuModel> for LabelGeometry {
    fn from(m: &crate::model::CpuModel) -> Self {
        Self {
            hull: m.hull.clone(),
            aabb: m.aabb,
        }
    }
}

/// Project a point set given in camera coordinates, clipped at the near plane.
pub fn project_clipped(camera: &Camera, points_cam: &[DVec3]) -> Option<PixelBox> {
    let near = camera.near_m;
    // The common case, every point in front: the same arithmetic as
    // `Camera::project_camera_point` with the focal length taken once and
    // nothing allocated (a labels-only plan projects millions of hulls).
    if !points_cam.is_empty() && points_cam.iter().all(|p| p.z >= near && p.z > 0.0) {
        let f = camera.focal_px();
        let c = camera.principal_point();
        return finite_box(
            points_cam
                .iter()
                .map(|p| DVec2::new(f * p.x / p.z + c.x, f * p.y / p.z + c.y)),
        );
    }
    if !points_cam.iter().any(|p| p.z >= near) {
        return None;
    }
    finite_box(clipped_points(camera, points_cam))
}

/// The box of `points`, `None` when empty or not finite.
fn finite_box(points: impl IntoIterator<Item = DVec2>) -> Option<PixelBox> {
    let b = PixelBox::from_points(points)?;
    [b.x0, b.y0, b.x1, b.y1]
        .iter()
        .all(|v| v.is_finite())
        .then_some(b)
}

/// [`project_clipped`]'s projected points: every point in front, and the
/// near-plane intersections of every front/back pair.
fn clipped_points(camera: &Camera, points_cam: &[DVec3]) -> Vec<DVec2> {
    let near = camera.near_m;
    let (front, back): (Vec<DVec3>, Vec<DVec3>) = points_cam.iter().partition(|p| p.z >= near);
    let mut projected: Vec<DVec2> = front
        .iter()
        .filter_map(|p| camera.project_camera_point(*p))
        .collect();
    for a in &front {
        for b in &back {
            let t = (a.z - near) / (a.z - b.z);
            let mut p = a.lerp(*b, t);
            p.z = near;
            projected.extend(camera.project_camera_point(p));
        }
    }
    projected
}

/// [`clipped_points`] that are finite (what a lens can map).
fn projected_points(camera: &Camera, points_cam: &[DVec3]) -> Vec<DVec2> {
    let mut projected = clipped_points(camera, points_cam);
    projected.retain(|p| p.is_finite());
    projected
}

/// The lens of a frame's camera, when its camera model draws one (and it is not neutral).
pub fn frame_lens(scene: &super::FrameScene) -> Option<LensGeometry> {
    let draw = scene.camera_model.as_ref()?.lens?;
    let cam = &scene.camera;
    LensGeometry::new(draw, cam.width, cam.height, cam.focal_px())
}

/// The 2D convex hull of `points` (Andrew's monotone chain), counter-clockwise.
fn outline(mut points: Vec<DVec2>) -> Vec<DVec2> {
    points.sort_by(|a, b| a.x.total_cmp(&b.x).then(a.y.total_cmp(&b.y)));
    points.dedup();
    if points.len() < 3 {
        return points;
    }
    let cross = |o: DVec2, a: DVec2, b: DVec2| (a - o).perp_dot(b - o);
    let mut hull: Vec<DVec2> = Vec::with_capacity(points.len() + 1);
    for pass in [points.clone(), points.into_iter().rev().collect()] {
        let start = hull.len();
        for p in pass {
            while hull.len() >= start + 2
                && cross(hull[hull.len() - 2], hull[hull.len() - 1], p) <= 0.0
            {
                hull.pop();
            }
            hull.push(p);
        }
        hull.pop();
    }
    hull
}

/// The most samples taken along one outline edge.
const MAX_EDGE_SAMPLES: f64 = 4096.0;

/// The box of the lens-mapped outline of `points` (rendered pixels): each
/// edge sampled at most a pixel apart, every sample mapped.
fn lens_box(lens: &LensGeometry, points: Vec<DVec2>) -> Option<PixelBox> {
    let hull = outline(points);
    let mut mapped = Vec::new();
    for (i, &a) in hull.iter().enumerate() {
        let b = hull[(i + 1) % hull.len()];
        let n = (a.distance(b).ceil()).clamp(1.0, MAX_EDGE_SAMPLES) as u32;
        mapped.extend((0..n).map(|k| through(lens, a.lerp(b, f64::from(k) / f64::from(n)))));
    }
    finite_box(mapped)
}

/// Pixel `p` of the pinhole picture where `lens` puts it.
fn through(lens: &LensGeometry, p: DVec2) -> DVec2 {
    let (x, y) = lens.forward((p.x, p.y));
    DVec2::new(x, y)
}

/// [`amodal_box`] through the frame's lens (`None`: the pinhole's box).
pub fn amodal_box_through(
    camera: &Camera,
    lens: Option<&LensGeometry>,
    drone: &DronePose,
    geom: &LabelGeometry,
) -> Option<PixelBox> {
    let Some(lens) = lens else {
        return amodal_box(camera, drone, geom);
    };
    let cam = to_camera(camera, drone, geom.hull.iter().copied());
    lens_box(lens, projected_points(camera, &cam))
}

/// [`paper_aabb_box`] through the frame's lens: its 8 corners (and their
/// near-plane intersections) mapped (`None` lens: the pinhole's box).
pub fn paper_aabb_box_through(
    camera: &Camera,
    lens: Option<&LensGeometry>,
    drone: &DronePose,
    geom: &LabelGeometry,
) -> Option<PixelBox> {
    let Some(lens) = lens else {
        return paper_aabb_box(camera, drone, geom);
    };
    let corners = projected_points(camera, &paper_corners(camera, drone, geom));
    finite_box(corners.into_iter().map(|p| through(lens, p)))
}

/// Camera-frame positions of a drone's model-space points.
fn to_camera(
    camera: &Camera,
    drone: &DronePose,
    points: impl Iterator<Item = DVec3>,
) -> Vec<DVec3> {
    // R·(p − C) = R·(position − C) + (R·q)·(s·v): the large translation is taken once, in f64.
    let centre = camera.camera_from_world_point(drone.position);
    let rot = camera.camera_from_world * DMat3::from_quat(drone.rotation);
    points.map(|v| centre + rot * (v * drone.size_m)).collect()
}

/// The tight (amodal) box of a drone, unclipped.
pub fn amodal_box(camera: &Camera, drone: &DronePose, geom: &LabelGeometry) -> Option<PixelBox> {
    project_clipped(camera, &to_camera(camera, drone, geom.hull.iter().copied()))
}

/// The paper's box: the 8 corners of the world AABB of the placed local box.
pub fn paper_aabb_box(
    camera: &Camera,
    drone: &DronePose,
    geom: &LabelGeometry,
) -> Option<PixelBox> {
    project_clipped(camera, &paper_corners(camera, drone, geom))
}

/// The 8 corners of the world AABB of a drone's placed local box, in camera coordinates.
fn paper_corners(camera: &Camera, drone: &DronePose, geom: &LabelGeometry) -> Vec<DVec3> {
    let (lo, hi) = geom.aabb;
    let rot = DMat3::from_quat(drone.rotation);
    let mut wlo = DVec3::splat(f64::INFINITY);
    let mut whi = DVec3::splat(f64::NEG_INFINITY);
    for i in 0..8 {
        let c = DVec3::new(
            if i & 1 == 0 { lo.x } else { hi.x },
            if i & 2 == 0 { lo.y } else { hi.y },
            if i & 4 == 0 { lo.z } else { hi.z },
        );
        let w = rot * (c * drone.size_m);
        wlo = wlo.min(w);
        whi = whi.max(w);
    }
    let corners = (0..8).map(|i| {
        DVec3::new(
            if i & 1 == 0 { wlo.x } else { whi.x },
            if i & 2 == 0 { wlo.y } else { whi.y },
            if i & 4 == 0 { wlo.z } else { whi.z },
        )
    });
    let centre = camera.camera_from_world_point(drone.position);
    corners
        .map(|c| centre + camera.camera_from_world * c)
        .collect()
}

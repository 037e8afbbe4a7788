//! 2D boxes from 3D poses, computed geometrically in f64.
//!
//! - `Amodal`: every convex-hull vertex of the placed model is projected and
//!   the min/max taken: the tight box of the whole silhouette, occluded parts
//!   included.
//! - `PaperAabb`: the paper's Eq. 9–10: the 8 corners of the model's world
//!   axis-aligned box (the local box transformed, as Unity's `Renderer.bounds`).
//!
//! Both clip the point set against the near plane z = near before projecting
//! (adding the intersections of every front/back point pair, a superset of the
//! clipped polytope's vertices lying inside it), so a drone crossing the near
//! plane or partly behind the camera gets a correct box, never NaN or a box
//! wrapped across the image.

use glam::{DMat3, DVec2, DVec3};
use serde::Serialize;

use crate::camera::Camera;
use crate::preset::{BoxMethod, LabelSettings};
use crate::scene::{DronePose, FrameScene};

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
    fn from_points(points: impl IntoIterator<Item = DVec2>) -> Option<Self> {
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

/// What the instance-id pass saw of one drone.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct Visibility {
    /// Min/max of the drone's visible pixels ([x, x+1) × [y, y+1) each), `None` if none is visible.
    pub visible_box: Option<PixelBox>,
    /// Pixels where this drone is the nearest surface.
    pub visible_pixels: u64,
    /// Pixels the drone would cover if nothing were in front of it.
    pub unoccluded_pixels: u64,
}

impl Visibility {
    /// visible / unoccluded (0 when the drone covers no pixel centre at all).
    pub fn fraction(&self) -> f64 {
        if self.unoccluded_pixels == 0 {
            0.0
        } else {
            self.visible_pixels as f64 / self.unoccluded_pixels as f64
        }
    }
}

/// One labelled drone.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct DroneLabel {
    /// Index of the drone in the frame's `drones`.
    pub drone: usize,
    /// Class index (0-based, order of first appearance among the preset's models).
    pub class_id: usize,
    /// The box written to the label files: the chosen method's box within the image.
    pub bbox: PixelBox,
    /// Tight projected silhouette box, unclipped.
    pub amodal: PixelBox,
    /// The paper's projected-AABB box, unclipped.
    pub paper_aabb: PixelBox,
    /// The amodal box leaves the image.
    pub truncated: bool,
    /// Distance from the camera centre to the drone centre, metres.
    pub distance_m: f64,
    /// Id-pass measurements, when the preset asked for them.
    pub visibility: Option<Visibility>,
    pub status: LabelStatus,
}

/// What the writers do with a drone's label.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum LabelStatus {
    /// A training box: written to YOLO and COCO.
    Kept,
    /// Failed a filter; written to COCO as `iscrowd: 1` only.
    Crowd,
    /// Failed a filter; recorded in the manifest only.
    Filtered,
}

impl DroneLabel {
    /// A training box (YOLO and COCO).
    pub fn is_kept(&self) -> bool {
        self.status == LabelStatus::Kept
    }
}

/// Project a point set given in camera coordinates, clipped at the near plane.
pub fn project_clipped(camera: &Camera, points_cam: &[DVec3]) -> Option<PixelBox> {
    let near = camera.near_m;
    let (front, back): (Vec<DVec3>, Vec<DVec3>) = points_cam.iter().partition(|p| p.z >= near);
    if front.is_empty() {
        return None;
    }
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
    let b = PixelBox::from_points(projected)?;
    [b.x0, b.y0, b.x1, b.y1]
        .iter()
        .all(|v| v.is_finite())
        .then_some(b)
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
    let pts: Vec<DVec3> = corners
        .map(|c| centre + camera.camera_from_world * c)
        .collect();
    project_clipped(camera, &pts)
}

/// Per-drone pixel box and pixel count from an id image (ids are drone index + 1).
pub fn pixel_stats(ids: &crate::render::IdImage, n_drones: usize) -> Vec<(Option<PixelBox>, u64)> {
    let mut out: Vec<(Option<PixelBox>, u64)> = vec![(None, 0); n_drones];
    for (row, line) in ids.ids.chunks_exact(ids.width as usize).enumerate() {
        let y = row as f64;
        for (col, &id) in line.iter().enumerate() {
            if id == 0 || id as usize > n_drones {
                continue;
            }
            let x = col as f64;
            let (b, n) = &mut out[id as usize - 1];
            *n += 1;
            let nb = b.get_or_insert(PixelBox {
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
    }
    out
}

/// Greedy layering of drones by screen overlap: drones in one layer have
/// disjoint (1-px padded) boxes, so rendering a layer alone shows each of its
/// drones unoccluded. Drones with `None` boxes get no layer. Returns the
/// layers and whether each drone overlaps any other.
pub fn overlap_layers(boxes: &[Option<PixelBox>]) -> (Vec<Vec<usize>>, Vec<bool>) {
    const TILE: f64 = 64.0;
    let pad = |b: &PixelBox| PixelBox {
        x0: b.x0 - 1.0,
        y0: b.y0 - 1.0,
        x1: b.x1 + 1.0,
        y1: b.y1 + 1.0,
    };
    let overlaps =
        |a: &PixelBox, b: &PixelBox| a.x0 < b.x1 && b.x0 < a.x1 && a.y0 < b.y1 && b.y0 < a.y1;
    let tiles_of = |b: &PixelBox| {
        let (tx0, ty0) = ((b.x0 / TILE).floor() as i64, (b.y0 / TILE).floor() as i64);
        let (tx1, ty1) = ((b.x1 / TILE).floor() as i64, (b.y1 / TILE).floor() as i64);
        (ty0..=ty1).flat_map(move |ty| (tx0..=tx1).map(move |tx| (tx, ty)))
    };
    let mut grid: std::collections::HashMap<(i64, i64), Vec<usize>> =
        std::collections::HashMap::new();
    for (i, b) in boxes.iter().enumerate() {
        if let Some(b) = b {
            for t in tiles_of(&pad(b)) {
                grid.entry(t).or_default().push(i);
            }
        }
    }
    let mut layer_of: Vec<Option<usize>> = vec![None; boxes.len()];
    let mut overlapping = vec![false; boxes.len()];
    let mut layers: Vec<Vec<usize>> = Vec::new();
    for (i, b) in boxes.iter().enumerate() {
        let Some(b) = b else { continue };
        let pb = pad(b);
        let mut taken = std::collections::BTreeSet::new();
        let mut seen = std::collections::HashSet::new();
        for t in tiles_of(&pb) {
            for &j in grid.get(&t).into_iter().flatten() {
                if j != i
                    && seen.insert(j)
                    && boxes[j].as_ref().is_some_and(|bj| overlaps(&pb, &pad(bj)))
                {
                    overlapping[i] = true;
                    if let Some(l) = layer_of[j] {
                        taken.insert(l);
                    }
                }
            }
        }
        let layer = (0..).find(|l| !taken.contains(l)).unwrap_or(0);
        if layer == layers.len() {
            layers.push(Vec::new());
        }
        layers[layer].push(i);
        layer_of[i] = Some(layer);
    }
    (layers, overlapping)
}

/// Label every drone of a frame that is in front of the camera. Drones that
/// fail a filter (smaller than `min_box_px`, below the visibility thresholds,
/// or not visible at all) get status `Crowd` or `Filtered` according to
/// `settings.filtered`; only `Kept` labels are training boxes. `visibility` is required for
/// [`BoxMethod::Visible`] and the visibility filters (`None` treats every
/// drone as invisible then).
pub fn label_frame(
    scene: &FrameScene,
    geometry: &[LabelGeometry],
    class_of_model: &[usize],
    settings: &LabelSettings,
    visibility: Option<&[Visibility]>,
) -> Vec<DroneLabel> {
    use crate::preset::FilteredDrones;
    let cam = &scene.camera;
    let (w, h) = (f64::from(cam.width), f64::from(cam.height));
    let mut out = Vec::new();
    for (i, drone) in scene.drones.iter().enumerate() {
        let geom = &geometry[drone.model];
        let (Some(amodal), Some(paper)) = (
            amodal_box(cam, drone, geom),
            paper_aabb_box(cam, drone, geom),
        ) else {
            continue;
        };
        let amodal_in_image = amodal.clip(w, h);
        let vis = visibility.and_then(|v| v.get(i)).copied();
        let chosen = match settings.box_method {
            BoxMethod::Visible => vis.and_then(|v| v.visible_box),
            BoxMethod::Amodal => Some(amodal_in_image),
            BoxMethod::PaperAabb => Some(paper.clip(w, h)),
        };
        let big_enough = |b: &PixelBox| {
            b.width() > 0.0
                && b.height() > 0.0
                && b.width() >= settings.min_box_px
                && b.height() >= settings.min_box_px
        };
        let visible_enough = !settings.needs_id_pass()
            || vis.is_some_and(|v| {
                v.visible_pixels > 0
                    && v.visible_pixels >= settings.min_visible_pixels
                    && v.fraction() >= settings.min_visible_fraction
            });
        let keep = chosen.as_ref().is_some_and(big_enough) && visible_enough;
        let amodal_shows = amodal_in_image.width() > 0.0 && amodal_in_image.height() > 0.0;
        let status = if keep {
            LabelStatus::Kept
        } else if settings.filtered == FilteredDrones::Crowd && amodal_shows {
            LabelStatus::Crowd
        } else {
            LabelStatus::Filtered
        };
        // Kept: the chosen box; otherwise the best box there is (for crowd regions and the manifest).
        let bbox = chosen.filter(|b| b.area() > 0.0).unwrap_or(amodal_in_image);
        out.push(DroneLabel {
            drone: i,
            class_id: class_of_model[drone.model],
            bbox,
            amodal,
            paper_aabb: paper,
            truncated: amodal_in_image != amodal,
            distance_m: (drone.position - cam.position).length(),
            visibility: vis,
            status,
        });
    }
    out
}

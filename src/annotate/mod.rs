//! Labels from poses and pixels: the one place where the box method is
//! chosen. `Amodal` and `PaperAabb` boxes come from the scene's geometry
//! ([`crate::scene::projection`], through the frame's lens when it has one); `Visible` boxes and the visibility filters
//! from what the renderer measured ([`visibility`], plain data the renderer
//! fills in; this module knows nothing of the GPU).

pub mod depth;
pub mod flow;
pub mod masks;
pub mod overlay;
pub mod rle;
pub mod visibility;

use serde::Serialize;

use crate::preset::{BoxMethod, LabelSettings};
pub use crate::scene::projection::{LabelGeometry, PixelBox, amodal_box, paper_aabb_box};
use crate::scene::projection::{amodal_box_through, frame_lens, paper_aabb_box_through};
use crate::scene::{DronePose, FrameScene};
use visibility::Visibility;

/// The least share of the image's width (height) a kept box spans: YOLO
/// writes sizes as shares with six decimals, so a narrower box would be
/// written with size 0 (a box of no area). A box under it is filtered, in
/// every format alike, whatever `labels.min_box_px` allows.
pub const MIN_BOX_SHARE: f64 = 1e-6;

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
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, serde::Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum LabelStatus {
    /// A training box: written to YOLO and COCO.
    Kept,
    /// Failed a filter; written to COCO as `iscrowd: 1` only.
    Crowd,
    /// Failed a filter; recorded in the manifest only.
    Filtered,
    /// An unlabelled hard negative (a confuser, `labelled_as` absent):
    /// recorded in the manifest only, never a training box or ignore region.
    Negative,
}

impl DroneLabel {
    /// A training box (YOLO and COCO).
    pub fn is_kept(&self) -> bool {
        self.status == LabelStatus::Kept
    }

    /// Written to the detection and tracking labels (COCO, MOT): a training box or an ignore region.
    pub fn is_detection_label(&self) -> bool {
        matches!(self.status, LabelStatus::Kept | LabelStatus::Crowd)
    }
}

/// Label every drone of a frame that is in front of the camera. Drones that
/// fail a filter (smaller than `min_box_px`, below the visibility thresholds,
/// not visible at all, or farther than the atmosphere's visibility V) get status `Crowd` or `Filtered` according to
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
    let cam = &scene.camera;
    // Through a lens, both geometric boxes are of the lens-mapped points.
    let lens = frame_lens(scene);
    let boxes = |_: usize, drone: &DronePose, geom: &LabelGeometry| {
        Some((
            amodal_box_through(cam, lens.as_ref(), drone, geom)?,
            paper_aabb_box_through(cam, lens.as_ref(), drone, geom)?,
        ))
    };
    let sources = (geometry, class_of_model);
    label_frame_with(scene, sources, settings, visibility, &boxes)
}

/// Drone `i`'s geometric boxes (amodal, paper's) from its pose and geometry.
pub type BoxesOf<'a> =
    dyn Fn(usize, &DronePose, &LabelGeometry) -> Option<(PixelBox, PixelBox)> + 'a;

/// [`label_frame`] with each drone's geometric boxes (amodal, paper's)
/// from `boxes(i, drone, geometry)` (the rolling shutter's own); a drone
/// without them is not labelled.
pub fn label_frame_with(
    scene: &FrameScene,
    (geometry, class_of_model): (&[LabelGeometry], &[usize]),
    settings: &LabelSettings,
    visibility: Option<&[Visibility]>,
    boxes: &BoxesOf<'_>,
) -> Vec<DroneLabel> {
    use crate::preset::FilteredDrones;
    let cam = &scene.camera;
    let (w, h) = (f64::from(cam.width), f64::from(cam.height));
    let mut out = Vec::new();
    for (i, drone) in scene.drones.iter().enumerate() {
        let geom = &geometry[drone.model];
        let Some((amodal, paper)) = boxes(i, drone, geom) else {
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
            b.width() >= settings.min_box_px.max(MIN_BOX_SHARE * w)
                && b.height() >= settings.min_box_px.max(MIN_BOX_SHARE * h)
        };
        let visible_enough = !settings.needs_id_pass()
            || vis.is_some_and(|v| {
                v.visible_pixels > 0
                    && v.visible_pixels >= settings.min_visible_pixels
                    && v.fraction() >= settings.min_visible_fraction
            });
        let distance_m = (drone.position - cam.position).length();
        // With an atmosphere, a drone farther than the visibility V keeps
        // under 2 % of its contrast (Koschmieder's threshold): not seen.
        let through_haze = scene
            .atmosphere
            .is_none_or(|a| distance_m <= a.visibility_m);
        let keep = chosen.as_ref().is_some_and(big_enough) && visible_enough && through_haze;
        let amodal_shows = amodal_in_image.width() > 0.0 && amodal_in_image.height() > 0.0;
        let negative = scene.confuser(i).is_some_and(|c| c.is_negative());
        let status = if negative {
            LabelStatus::Negative
        } else if keep {
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
            distance_m,
            visibility: vis,
            status,
        });
    }
    out
}

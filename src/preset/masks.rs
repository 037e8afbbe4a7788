//! `output.masks`: which per-object masks and per-frame maps a dataset
//! gets besides its boxes (issue 22, docs/conventions.md "Masks and maps").
//! All off by default; when all are off nothing of them is computed or
//! written and the preset's locked text leaves the field out.

use serde::{Deserialize, Serialize};

use super::{FieldError, LabelFormat, Preset};

/// The masks and maps a preset asks for (`output.masks`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct MaskOutputs {
    /// COCO `segmentation` of every annotation: the object's visible pixels
    /// as compressed RLE (pycocotools' string form), `area` = those pixels.
    pub coco_rle: bool,
    /// Ultralytics YOLO segmentation labels in `seg/labels/{split}/NAME.txt` (with `data-seg.yaml`):
    /// one polygon (the largest outer contour of the visible pixels) per training box.
    pub yolo_seg: bool,
    /// A 16-bit grey PNG per frame in `masks/{split}/NAME.png`: 0 where no
    /// drone shows, else the manifest's drone index + 1.
    pub instance_png: bool,
    /// A 16-bit grey PNG per frame in `depth/{split}/NAME.png`: at each
    /// pixel of the instance image, the camera-frame depth z of the drone it
    /// shows in units of `depth_unit_mm` (0: no drone; 65535: that far or farther).
    pub depth: bool,
    /// The depth map's unit in millimetres (1 to 1000; 1: depths up to 65.5 m).
    pub depth_unit_mm: u32,
    /// Sequence mode: the forward optical flow from each frame to the next
    /// as a KITTI 16-bit PNG per frame in `flow/{split}/NAME.png`
    /// (`annotate::flow`); the last frame of a sequence has none. Off: not
    /// written to `preset.lock.ron`, which stays as it was (a dataset made
    /// before the field existed resumes).
    #[serde(skip_serializing_if = "std::ops::Not::not")]
    pub flow: bool,
}

impl Default for MaskOutputs {
    fn default() -> Self {
        Self {
            coco_rle: false,
            yolo_seg: false,
            instance_png: false,
            depth: false,
            depth_unit_mm: 1,
            flow: false,
        }
    }
}

impl MaskOutputs {
    /// Nothing asked for (the default; left out of the locked preset).
    pub fn is_off(&self) -> bool {
        *self == Self::default()
    }

    /// Whether any output needs each drone's visible pixels.
    pub fn any(&self) -> bool {
        self.coco_rle || self.yolo_seg || self.instance_png || self.depth || self.flow
    }
}

impl Preset {
    /// `output.masks.flow`: flow is from a frame to the next of its
    /// sequence, and the background's is exact only at infinity (the sky,
    /// a backplate) or for a camera that does not move (near clutter).
    fn validate_flow(&self, push: &mut impl FnMut(&str, String)) {
        let Some(sequence) = &self.sequence else {
            push(
                "output.masks.flow",
                "is flow from each frame to the next of its sequence; add a `sequence` section or turn flow off".into(),
            );
            return;
        };
        if self.clutter.is_some() && sequence.camera == super::SequenceCamera::Follow {
            push(
                "output.masks.flow",
                "the clutter's depth is not known to the flow and sequence.camera Follow moves the camera; use camera Fixed or no clutter".into(),
            );
        }
    }
}

/// The largest drone count an instance PNG can name (16-bit ids, 0 = none).
pub const MAX_INSTANCE_ID: usize = u16::MAX as usize;

impl Preset {
    /// `output.masks`: each mask is the visible pixel set of the id pass at
    /// the output's own resolution, so it needs `labels.id_scale: 1`; the
    /// formats it adds to must be written; instance ids must fit 16 bits.
    pub(super) fn validate_masks(&self, errors: &mut Vec<FieldError>) {
        let m = &self.output.masks;
        let mut push = |field: &str, message: String| {
            errors.push(FieldError {
                field: field.to_owned(),
                message,
            });
        };
        if !(1..=1000).contains(&m.depth_unit_mm) {
            push(
                "output.masks.depth_unit_mm",
                format!("{} is out of range [1, 1000]", m.depth_unit_mm),
            );
        }
        if !m.any() {
            return;
        }
        if self.labels.id_scale != 1 {
            push(
                "output.masks",
                format!(
                    "masks are the visible pixels at the output resolution; labels.id_scale is {}, set it to 1",
                    self.labels.id_scale
                ),
            );
        }
        if m.flow {
            self.validate_flow(&mut push);
        }
        if m.coco_rle && !self.output.label_formats.contains(&LabelFormat::Coco) {
            push(
                "output.masks.coco_rle",
                "is on but output.label_formats has no Coco; add Coco or turn coco_rle off".into(),
            );
        }
        if m.yolo_seg && !self.output.label_formats.contains(&LabelFormat::Yolo) {
            push(
                "output.masks.yolo_seg",
                "is on but output.label_formats has no Yolo; add Yolo or turn yolo_seg off".into(),
            );
        }
        if (m.instance_png || m.depth) && self.max_drones_per_frame() > MAX_INSTANCE_ID as u64 {
            push(
                "output.masks.instance_png",
                format!(
                    "a frame may hold {} drones; a 16-bit instance PNG names at most {MAX_INSTANCE_ID}",
                    self.max_drones_per_frame()
                ),
            );
        }
    }
}

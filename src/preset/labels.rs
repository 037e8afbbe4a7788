//! How drones are labelled (`labels`): the box method, the filters (box
//! size, visible pixels and fraction), what a filtered drone becomes, the id
//! pass's scale and the fewest labelled drones a frame may have.

use serde::{Deserialize, Serialize};

/// How a drone's 2D box is computed.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub enum BoxMethod {
    /// Min/max of the drone's visible pixels in an instance-id pass: pixel-exact,
    /// occlusion-aware. The default for training.
    #[default]
    Visible,
    /// Min/max of the projected convex hull: the tight amodal box (occluded parts included).
    Amodal,
    /// The paper's method: project the 8 corners of the world axis-aligned box.
    PaperAabb,
}

/// What happens to a drone that fails a filter (too small, too occluded, or
/// not visible at all although it projects into the image).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub enum FilteredDrones {
    /// Written nowhere.
    #[default]
    Drop,
    /// Kept in COCO as `iscrowd: 1` (trainers ignore the region); left out of YOLO files.
    Crowd,
}

#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct LabelSettings {
    pub box_method: BoxMethod,
    /// Boxes narrower or shorter than this (after clipping to the image) are filtered.
    pub min_box_px: f64,
    /// Drones with fewer visible pixels are filtered (0: off).
    pub min_visible_pixels: u64,
    /// Drones with a smaller visible fraction (visible / unoccluded pixels) are filtered (0: off).
    pub min_visible_fraction: f64,
    pub filtered: FilteredDrones,
    /// Resolution factor of the instance-id passes: 1 (pixel-exact at the
    /// output size), 2 or 4 (supersampled, sub-pixel visible boxes; costs scale²).
    pub id_scale: u32,
    /// A frame whose geometry gives fewer kept boxes than this is drawn again
    /// (its placement re-seeded from (seed, index, attempt); 0: off). See
    /// docs/conventions.md, "Randomness".
    #[serde(skip_serializing_if = "is_zero")]
    pub min_labelled: u32,
}

fn is_zero(n: &u32) -> bool {
    *n == 0
}

impl Default for LabelSettings {
    fn default() -> Self {
        Self {
            box_method: BoxMethod::Visible,
            min_box_px: 2.0,
            min_visible_pixels: 0,
            min_visible_fraction: 0.0,
            filtered: FilteredDrones::Drop,
            id_scale: 1,
            min_labelled: 0,
        }
    }
}

impl LabelSettings {
    /// Whether labelling needs the instance-id pass (visible boxes or visibility filters).
    pub fn needs_id_pass(&self) -> bool {
        self.box_method == BoxMethod::Visible
            || self.min_visible_pixels > 0
            || self.min_visible_fraction > 0.0
    }
}

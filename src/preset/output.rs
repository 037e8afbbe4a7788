//! What a dataset holds (`output`): the image format, the label formats,
//! the split shares and what a split keeps whole, and the masks.

use serde::{Deserialize, Serialize};

use super::masks;

#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub enum ImageFormat {
    Jpeg { quality: u8 },
    Png,
}

impl ImageFormat {
    pub fn extension(self) -> &'static str {
        match self {
            Self::Jpeg { .. } => "jpg",
            Self::Png => "png",
        }
    }
}

#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub enum LabelFormat {
    /// Ultralytics YOLO: images/, labels/, data.yaml.
    Yolo,
    /// COCO: annotations/instances_{split}.json.
    Coco,
}

/// Shares of frames that go to each split; they must sum to 1.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct Split {
    pub train: f64,
    pub val: f64,
    pub test: f64,
    /// What is kept together in one split (see `scene::split`); `Frame`
    /// (the default) is left out of the locked preset, so it keeps its bytes.
    #[serde(skip_serializing_if = "SplitBy::is_frame")]
    pub by: SplitBy,
}

impl Default for Split {
    fn default() -> Self {
        Self {
            train: 0.7,
            val: 0.1,
            test: 0.2,
            by: SplitBy::Frame,
        }
    }
}

/// The groups a split keeps whole, so that no val or test frame shares its
/// group with a train frame (docs/conventions.md, "Splits").
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub enum SplitBy {
    /// Each frame (each sequence, in sequence mode) on its own: exact shares per 100.
    #[default]
    Frame,
    /// Frames with the same camera sweep values (CameraX, CameraY, CameraZ).
    CameraPose,
    /// Frames with the same environment (the `Random` sky's choice).
    Environment,
    /// Frames with the same sweep point: every swept value alike, only `repeat` differs.
    SweepPoint,
}

impl SplitBy {
    /// The default, per-frame split (left out of the locked preset).
    pub fn is_frame(&self) -> bool {
        *self == Self::Frame
    }
}

#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct OutputSettings {
    pub image_format: ImageFormat,
    pub label_formats: Vec<LabelFormat>,
    pub split: Split,
    /// Masks and maps besides the boxes (all off: left out of the lock).
    #[serde(skip_serializing_if = "masks::MaskOutputs::is_off")]
    pub masks: masks::MaskOutputs,
}

impl Default for OutputSettings {
    fn default() -> Self {
        Self {
            image_format: ImageFormat::Jpeg { quality: 85 },
            label_formats: vec![LabelFormat::Yolo, LabelFormat::Coco],
            split: Split::default(),
            masks: masks::MaskOutputs::default(),
        }
    }
}

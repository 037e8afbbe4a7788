//! How frames are rendered (`render`): the resolution, multisampling and the
//! level-of-detail error and the impostors' threshold.

use serde::{Deserialize, Serialize};

#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub enum Resolution {
    /// 1920 × 1080
    FullHd,
    /// 2560 × 1440
    Qhd,
    /// 4096 × 2160
    Uhd4k,
    Custom {
        width: u32,
        height: u32,
    },
}

impl Resolution {
    pub fn size(self) -> (u32, u32) {
        match self {
            Self::FullHd => (1920, 1080),
            Self::Qhd => (2560, 1440),
            Self::Uhd4k => (4096, 2160),
            Self::Custom { width, height } => (width, height),
        }
    }
}

#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct RenderSettings {
    pub resolution: Resolution,
    /// Multisample anti-aliasing: 1 (off) or 4.
    pub msaa: u32,
    /// Level of detail: a drone is drawn with the coarsest simplified mesh
    /// whose silhouette lies within this many pixels of the full mesh's
    /// (0: every drone at full detail). Labels' amodal boxes always come
    /// from the full mesh; visible boxes follow the pixels drawn.
    pub lod_error_px: f64,
    /// Impostors: a drone whose projected size (its span over its centre's
    /// depth) is under this many pixels is drawn as its model's silhouette
    /// baked from the nearest of 128 view directions (`model::impostor`),
    /// a textured quad, instead of its mesh. Absent: every drone is a mesh
    /// (and the field is not written to `preset.lock.ron`).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub impostor_below_px: Option<f32>,
}

/// The silhouette error a level of detail may add, by default (pixels).
pub const DEFAULT_LOD_ERROR_PX: f64 = 0.5;

impl Default for RenderSettings {
    fn default() -> Self {
        Self {
            resolution: Resolution::FullHd,
            msaa: 4,
            lod_error_px: DEFAULT_LOD_ERROR_PX,
            impostor_below_px: None,
        }
    }
}

//! What the renderer measures of each drone, as plain data: the labels are
//! made from it ([`super::label_frame`], [`super::masks`]), the renderer
//! fills it in (`render::visibility`, `render::ids`). Neither GPU nor pixels here.

use serde::Serialize;

use crate::scene::projection::PixelBox;

/// What the colour pass's samples show of one drone.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct Visibility {
    /// Min/max of the drone's visible pixels ([x, x+1) × [y, y+1) each), `None` if none is visible.
    pub visible_box: Option<PixelBox>,
    /// Pixels where this drone is the nearest surface in at least one sample.
    pub visible_pixels: u64,
    /// Pixels the drone would cover (in at least one sample) if nothing were in front of it.
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

/// One drone seen at one pixel: `samples` of the pixel's samples (1 to 4;
/// 1 without MSAA) show drone `drone` (scene index). A pixel has one hit per
/// distinct drone its samples show, so each drone's hits are exactly the
/// pixels the renderer's tally counts for it (its visible pixels).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct PixelHit {
    pub x: u32,
    pub y: u32,
    pub drone: u32,
    pub samples: u8,
}

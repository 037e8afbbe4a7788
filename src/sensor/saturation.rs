//! Saturation (the camera's processing), a per-pixel stage on linear
//! light: each pixel moved away from (or towards) its linear luminance by
//! the drawn factor, Rec. 709 weights (1: unchanged, 0: grey).

use super::{CameraDraw, PixelStage, RowFn};

/// The drawn saturation factor.
pub(super) struct Saturation(f32);

impl Saturation {
    /// The stage (`None`: saturation 1, unchanged).
    pub(super) fn of(draw: &CameraDraw) -> Option<Box<dyn PixelStage>> {
        (draw.saturation != 1.0)
            .then(|| Box::new(Self(draw.saturation as f32)) as Box<dyn PixelStage>)
    }
}

impl PixelStage for Saturation {
    fn band(&self, _x0: i64, _width: usize) -> RowFn<'_> {
        let s = self.0;
        Box::new(move |_y, [r, g, b]| {
            crate::simd::widest(
                #[inline(always)]
                || {
                    for ((r, g), b) in r.iter_mut().zip(g.iter_mut()).zip(b.iter_mut()) {
                        saturate(s, r, g, b);
                    }
                },
            );
        })
    }
}

/// Saturation `s` about each pixel's linear luminance (Rec. 709 weights),
/// on one pixel's three channels.
#[inline(always)]
fn saturate(s: f32, r: &mut f32, g: &mut f32, b: &mut f32) {
    let y = 0.2126 * *r + 0.7152 * *g + 0.0722 * *b;
    *r = y + s * (*r - y);
    *g = y + s * (*g - y);
    *b = y + s * (*b - y);
}

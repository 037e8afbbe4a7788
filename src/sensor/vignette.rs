//! Vignetting, a per-pixel stage on linear light: × (1 − v·ρ²), ρ the
//! distance of the pixel's centre to the image centre over the
//! half-diagonal.

use super::{CameraDraw, PixelStage, RowFn};

/// The drawn strength, the image centre and its squared half-diagonal.
pub(super) struct Vignette {
    strength: f64,
    centre: (f64, f64),
    corner2: f64,
}

impl Vignette {
    /// The stage for a `width`×`height` frame (`None`: no vignetting drawn).
    pub(super) fn of(draw: &CameraDraw, width: u32, height: u32) -> Option<Box<dyn PixelStage>> {
        let centre = (f64::from(width) / 2.0, f64::from(height) / 2.0);
        (draw.vignetting > 0.0).then(|| {
            Box::new(Self {
                strength: draw.vignetting,
                centre,
                corner2: centre.0 * centre.0 + centre.1 * centre.1,
            }) as Box<dyn PixelStage>
        })
    }
}

impl PixelStage for Vignette {
    fn band(&self, x0: i64, width: usize) -> RowFn<'_> {
        let dx2: Vec<f32> = (0..width as i64)
            .map(|i| radius2(x0 + i, self.centre.0, self.corner2))
            .collect();
        let mut factor = vec![0f32; width];
        let strength = self.strength as f32;
        Box::new(move |y, vals| {
            crate::simd::widest(
                #[inline(always)]
                || {
                    let dy2 = radius2(y, self.centre.1, self.corner2);
                    vignette_factors(strength, dy2, &dx2, &mut factor);
                    for v in vals {
                        for (v, f) in v.iter_mut().zip(&factor) {
                            *v *= f;
                        }
                    }
                },
            );
        })
    }
}

/// Squared distance of the centre of pixel `x` (a column or a row) to the
/// image centre's `c` on that axis, over the squared half-diagonal.
#[inline]
fn radius2(x: i64, c: f64, corner2: f64) -> f32 {
    ((x as f64 + 0.5 - c).powi(2) / corner2) as f32
}

/// Vignetting factors 1 − strength·ρ² of one row (ρ² = dx2 + dy2).
#[inline(always)]
fn vignette_factors(strength: f32, dy2: f32, dx2: &[f32], out: &mut [f32]) {
    for (f, dx2) in out.iter_mut().zip(dx2) {
        *f = 1.0 - strength * (dx2 + dy2);
    }
}

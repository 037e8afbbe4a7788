//! Photographic backgrounds in the renderer ([`Plates`]): a frame whose scene names a
//! backplate gets the plate's pixels (resampled to the frame's size when the
//! loaded size differs, e.g. a preview pane; mirrored when the frame's draw
//! says so) as its cached background instead of the sky pass. The drones
//! are then drawn over it exactly as over a sky, so the id pass, the visible
//! boxes and [`super::Renderer::background_pixels`] work unchanged.

use crate::scene::FrameScene;
use crate::scene::backplate::FramePlate;
use crate::sky::Lighting;
use crate::sky::plates::{Plate, resample_cover};

use super::RenderError;

/// The plate part of the frame: the plates frames may name
/// (`FramePlate::plate` indexes them).
#[derive(Default)]
pub(super) struct Plates(pub(super) Vec<Plate>);

impl Plates {
    /// Under a plate, the drones' ambient light is the plate's: its upper
    /// half's mean colour from above, its lower half's from below (linear),
    /// in place of the preset's sky (whose sun stays).
    pub(super) fn lighting(&self, scene: &FrameScene, lighting: &mut Lighting) {
        let Some(plate) = (scene.backplate.as_ref()).and_then(|p| self.0.get(p.plate)) else {
            return;
        };
        let (up, low) = (
            glam::Vec3::from(plate.mean_upper),
            glam::Vec3::from(plate.mean_lower),
        );
        lighting.zenith = up.to_array();
        lighting.horizon = up.lerp(low, 0.3).to_array();
        lighting.ground = low.to_array();
    }

    /// The background key of a plate frame: the plate, its mirroring and the size.
    pub(super) fn key(plate: &FramePlate, size: (u32, u32)) -> Vec<u8> {
        let mut key = b"backplate".to_vec();
        key.extend_from_slice(&(plate.plate as u64).to_le_bytes());
        key.push(u8::from(plate.flip));
        key.extend_from_slice(&size.0.to_le_bytes());
        key.extend_from_slice(&size.1.to_le_bytes());
        key
    }

    /// Write the plate's pixels at `size` (RGBA8) into `out`.
    pub(super) fn pixels(
        &self,
        plate: &FramePlate,
        size: (u32, u32),
        out: &mut Vec<u8>,
    ) -> Result<(), RenderError> {
        let loaded = self
            .0
            .get(plate.plate)
            .ok_or_else(|| RenderError::BackplateMissing {
                plate: plate.plate,
                file: plate.file.clone(),
                held: self.0.len(),
            })?;
        out.clear();
        if loaded.size == size {
            out.extend_from_slice(&loaded.rgba);
        } else {
            let image =
                image::RgbaImage::from_raw(loaded.size.0, loaded.size.1, (*loaded.rgba).clone())
                    .ok_or(RenderError::BackplateSize)?;
            out.extend_from_slice(&resample_cover(&image, size));
        }
        if plate.flip {
            let row = size.0 as usize * 4;
            for line in out.chunks_exact_mut(row) {
                for x in 0..size.0 as usize / 2 {
                    let (a, b) = (x * 4, row - 4 - x * 4);
                    for c in 0..4 {
                        line.swap(a + c, b + c);
                    }
                }
            }
        }
        Ok(())
    }
}

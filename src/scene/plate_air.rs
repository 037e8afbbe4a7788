//! The air light of haze under a backplate (docs/realism.md, "Atmosphere"):
//! the in-scattered light a hazy drone fades into is the plate's own sky
//! around the drone, not the preset's procedural sky (which is not in the
//! picture). Per drone, the mean linear colour of the plate's pixels in a
//! square window about the drone's projected centre (clamped into the frame),
//! so a drone at many times the visibility becomes the colour of the sky
//! behind it, as Koschmieder's law has it.

use super::FrameScene;
use crate::sky::plates::Plate;
// sRGB (8-bit) → linear, as the plate's means are computed.
use crate::sky::srgb_to_linear as decode;

/// Half the side of the window, as a share of the frame's height (at least
/// [`MIN_HALF_WINDOW_PX`] plate pixels).
const HALF_WINDOW_SHARE: f64 = 0.02;
const MIN_HALF_WINDOW_PX: i64 = 4;

/// Per drone of `scene` (its camera already the plate's), the plate's mean
/// linear colour around the drone's projection (`flip`: the plate mirrored);
/// `None` for a drone behind the camera (the shader then takes the frame's
/// horizon term, the plate's mean).
pub fn plate_airlights(scene: &FrameScene, plate: &Plate, flip: bool) -> Vec<Option<[f32; 3]>> {
    let (pw, ph) = (i64::from(plate.size.0), i64::from(plate.size.1));
    let (fw, fh) = (
        f64::from(scene.camera.width.max(1)),
        f64::from(scene.camera.height.max(1)),
    );
    let expected = (pw * ph * 4) as usize;
    if pw == 0 || ph == 0 || plate.rgba.len() < expected {
        return vec![None; scene.drones.len()];
    }
    let table: Vec<f64> = (0..=255u8).map(decode).collect();
    let half = ((HALF_WINDOW_SHARE * ph as f64).round() as i64).max(MIN_HALF_WINDOW_PX);
    scene
        .drones
        .iter()
        .map(|d| {
            let p = scene
                .camera
                .project_camera_point(scene.camera.camera_from_world_point(d.position))?;
            // Output pixel → plate pixel (the plate covers the frame), mirrored when flipped.
            let mut x = (p.x / fw * pw as f64).floor();
            let y = (p.y / fh * ph as f64).floor();
            if !x.is_finite() || !y.is_finite() {
                return None;
            }
            if flip {
                x = pw as f64 - 1.0 - x;
            }
            let (cx, cy) = ((x as i64).clamp(0, pw - 1), (y as i64).clamp(0, ph - 1));
            let mut sum = [0f64; 3];
            let mut n = 0f64;
            for yy in (cy - half).max(0)..=(cy + half).min(ph - 1) {
                for xx in (cx - half).max(0)..=(cx + half).min(pw - 1) {
                    let i = ((yy * pw + xx) * 4) as usize;
                    for (c, s) in sum.iter_mut().enumerate() {
                        *s += table[usize::from(plate.rgba[i + c])];
                    }
                    n += 1.0;
                }
            }
            Some(sum.map(|s| (s / n.max(1.0)) as f32))
        })
        .collect()
}

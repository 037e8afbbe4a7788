//! Each drone's visible pixels as a mask, and the frame's instance image:
//! the per-pixel form of the coverage the visible boxes and
//! `visible_pixels` come from (the renderer's id samples, or through the
//! camera model the pixels a drone changes). Built only when a preset asks
//! for masks (`output.masks`); the writers encode them ([`crate::write::formats::masks`]).

use super::visibility::PixelHit;
use crate::scene::projection::PixelBox;

/// A frame's masks.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct FrameMasks {
    pub width: u32,
    pub height: u32,
    /// Per drone (scene order): its visible pixels as column-major indices
    /// `x · height + y`, ascending (COCO's RLE order).
    pub pixels: Vec<Vec<u32>>,
    /// Every pixel that shows a drone, as (row-major index `y · width + x`,
    /// drone), ascending: the drone most of the pixel's samples show, the
    /// lower drone index on a tie.
    pub instance: Vec<(u32, u32)>,
    /// The depth (metres, camera-frame z) at each pixel of `instance`, in
    /// its order, when the preset asks for depth maps (else empty).
    pub depth_m: Vec<f64>,
    /// The flow to the next frame of the sequence, when the preset asks for
    /// it (`output.masks.flow`) and the frame has a next.
    pub flow: Option<super::flow::FrameFlow>,
}

impl FrameMasks {
    /// From the renderer's hits (every pixel and each drone its samples show).
    pub fn from_hits(width: u32, height: u32, drones: usize, hits: &[PixelHit]) -> Self {
        let mut pixels = vec![Vec::new(); drones];
        let mut shown: Vec<(u32, u8, u32)> = Vec::with_capacity(hits.len());
        for h in hits.iter().filter(|h| (h.drone as usize) < drones) {
            if h.x >= width || h.y >= height {
                continue;
            }
            pixels[h.drone as usize].push(h.x * height + h.y);
            shown.push((h.y * width + h.x, u8::MAX - h.samples, h.drone));
        }
        for p in &mut pixels {
            p.sort_unstable();
            p.dedup();
        }
        // Per pixel: most samples first, then the lower drone.
        shown.sort_unstable();
        shown.dedup_by_key(|s| s.0);
        let instance = shown.into_iter().map(|(i, _, d)| (i, d)).collect();
        Self {
            width,
            height,
            pixels,
            instance,
            depth_m: Vec::new(),
            flow: None,
        }
    }

    /// From each drone's pixel set given as (x, y) (the camera model's
    /// changed pixels): a pixel two drones claim goes to the lower index in
    /// the instance image.
    pub fn from_sets(width: u32, height: u32, sets: &[Vec<(u32, u32)>]) -> Self {
        let hits: Vec<PixelHit> = (sets.iter().enumerate())
            .flat_map(|(d, set)| {
                set.iter().map(move |&(x, y)| PixelHit {
                    x,
                    y,
                    drone: d as u32,
                    samples: 1,
                })
            })
            .collect();
        Self::from_hits(width, height, sets.len(), &hits)
    }

    /// Pixels of drone `d`'s mask.
    pub fn count(&self, d: usize) -> u64 {
        self.pixels.get(d).map_or(0, |p| p.len() as u64)
    }

    /// The box of drone `d`'s mask (exclusive ends), `None` when empty.
    pub fn bbox(&self, d: usize) -> Option<PixelBox> {
        let p = self.pixels.get(d)?;
        let h = self.height.max(1);
        let (first, last) = (*p.first()?, *p.last()?);
        let (y0, y1) = p.iter().fold((u32::MAX, 0), |(lo, hi), &i| {
            (lo.min(i % h), hi.max(i % h + 1))
        });
        Some(PixelBox {
            x0: f64::from(first / h),
            y0: f64::from(y0),
            x1: f64::from(last / h + 1),
            y1: f64::from(y1),
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn hit(x: u32, y: u32, drone: u32, samples: u8) -> PixelHit {
        PixelHit {
            x,
            y,
            drone,
            samples,
        }
    }

    #[test]
    fn a_shared_pixel_is_in_both_masks_and_goes_to_the_majority_in_the_instance_image() {
        // 4×3 image; drone 0 at (1,1) and (2,1); drone 1 shares (2,1) with 3 samples, has (3,2).
        let hits = [
            hit(1, 1, 0, 4),
            hit(2, 1, 1, 3),
            hit(2, 1, 0, 1),
            hit(3, 2, 1, 4),
        ];
        let m = FrameMasks::from_hits(4, 3, 2, &hits);
        assert_eq!(
            m.pixels[0],
            vec![3 + 1, 2 * 3 + 1],
            "column-major: x · height + y"
        );
        assert_eq!(m.pixels[1], vec![2 * 3 + 1, 3 * 3 + 2]);
        assert_eq!(m.instance, vec![(4 + 1, 0), (4 + 2, 1), (8 + 3, 1)]);
        assert_eq!(m.count(0), 2);
        assert_eq!(
            m.bbox(1),
            Some(PixelBox {
                x0: 2.0,
                y0: 1.0,
                x1: 4.0,
                y1: 3.0
            })
        );
        assert_eq!(m.bbox(5), None);
    }

    #[test]
    fn equal_claims_go_to_the_lower_drone() {
        let m = FrameMasks::from_sets(2, 2, &[vec![(1, 1)], vec![(1, 1), (0, 0)]]);
        assert_eq!(m.instance, vec![(0, 1), (3, 0)]);
        assert_eq!(m.count(1), 2);
    }
}

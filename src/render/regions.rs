//! Screen regions: where a frame's drones can put pixels. Pure CPU code.
//!
//! A drone's rasterised samples lie inside the projection of its convex hull,
//! whose bounding box is its amodal box ([`amodal_box`]: near-plane clipping
//! included). That box, padded by [`PAD_PX`] and rounded out to whole pixels,
//! is the drone's rect; rects that overlap are merged until no two regions
//! share a pixel, so each region can be "cleared" (background, id 0, far
//! depth) and drawn on its own, and each pixel is reduced exactly once.

use std::ops::Range;

use crate::scene::FrameScene;
use crate::scene::projection::{LabelGeometry, PixelBox, amodal_box};

/// Safety margin around the projected hull box (f32 rasterisation vs the f64 projection).
pub const PAD_PX: f64 = 1.0;

/// A pixel rectangle, `x0..x1` × `y0..y1` (exclusive ends).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Rect {
    pub x0: u32,
    pub y0: u32,
    pub x1: u32,
    pub y1: u32,
}

impl Rect {
    /// The whole `width`×`height` image.
    pub fn full(width: u32, height: u32) -> Self {
        Self {
            x0: 0,
            y0: 0,
            x1: width,
            y1: height,
        }
    }
    pub fn width(&self) -> u32 {
        self.x1 - self.x0
    }
    pub fn height(&self) -> u32 {
        self.y1 - self.y0
    }
    pub fn area(&self) -> u64 {
        u64::from(self.width()) * u64::from(self.height())
    }
    /// Whether the two share a pixel.
    pub fn overlaps(&self, other: &Self) -> bool {
        self.x0 < other.x1 && other.x0 < self.x1 && self.y0 < other.y1 && other.y0 < self.y1
    }
    fn union(&self, other: &Self) -> Self {
        Self {
            x0: self.x0.min(other.x0),
            y0: self.y0.min(other.y0),
            x1: self.x1.max(other.x1),
            y1: self.y1.max(other.y1),
        }
    }
    /// Tiles of at most `size`×`size` pixels covering the rect, as (x0, y0, x1, y1).
    pub fn tiles(&self, size: u32) -> impl Iterator<Item = [u32; 4]> + '_ {
        (self.y0..self.y1)
            .step_by(size as usize)
            .flat_map(move |y| {
                (self.x0..self.x1)
                    .step_by(size as usize)
                    .map(move |x| [x, y, (x + size).min(self.x1), (y + size).min(self.y1)])
            })
    }
}

/// The pixels a drone with amodal box `b` can touch, within a `width`×`height` image.
pub fn pixel_rect(b: &PixelBox, width: u32, height: u32) -> Option<Rect> {
    let (w, h) = (f64::from(width), f64::from(height));
    let x0 = (b.x0 - PAD_PX).floor().clamp(0.0, w);
    let y0 = (b.y0 - PAD_PX).floor().clamp(0.0, h);
    let x1 = (b.x1 + PAD_PX).ceil().clamp(0.0, w);
    let y1 = (b.y1 + PAD_PX).ceil().clamp(0.0, h);
    (x1 > x0 && y1 > y0).then_some(Rect {
        x0: x0 as u32,
        y0: y0 as u32,
        x1: x1 as u32,
        y1: y1 as u32,
    })
}

/// Each drone's amodal box (unclipped) and pixel rect; `None` for drones
/// behind the camera or wholly outside the image.
pub fn drone_rects(
    scene: &FrameScene,
    geometry: &[LabelGeometry],
) -> (Vec<Option<PixelBox>>, Vec<Option<Rect>>) {
    let cam = &scene.camera;
    scene
        .drones
        .iter()
        .map(|d| {
            let b = geometry.get(d.model).and_then(|g| amodal_box(cam, d, g));
            let r = b.and_then(|b| pixel_rect(&b, cam.width, cam.height));
            (b, r)
        })
        .unzip()
}

/// One region to draw and the drones inside it.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Region {
    pub rect: Rect,
    pub drones: Vec<usize>,
}

/// Merge the rects of the drones `members` until no two regions overlap.
pub fn merge(rects: &[Option<Rect>], members: impl IntoIterator<Item = usize>) -> Vec<Region> {
    let mut regions: Vec<Region> = Vec::new();
    for i in members {
        let Some(mut rect) = rects.get(i).copied().flatten() else {
            continue;
        };
        let mut drones = vec![i];
        while let Some(j) = regions.iter().position(|r| r.rect.overlaps(&rect)) {
            let other = regions.swap_remove(j);
            rect = rect.union(&other.rect);
            drones.extend(other.drones);
        }
        regions.push(Region { rect, drones });
    }
    for r in &mut regions {
        r.drones.sort_unstable();
    }
    regions
}

/// What one pass draws: its regions' rects, and the instance ranges of all
/// their drones per (model, level of detail). Regions share no pixel and a
/// drone's samples lie inside its region, so the drones of every region are
/// drawn together, one instanced draw per (model, level).
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct PassDraws {
    pub rects: Vec<Rect>,
    pub draws: Vec<((usize, usize), Range<u32>)>,
}

impl PassDraws {
    /// The smallest rect holding every region (None: no region).
    pub fn bounds(&self) -> Option<Rect> {
        self.rects.iter().copied().reduce(|a, b| a.union(&b))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn r(x0: u32, y0: u32, x1: u32, y1: u32) -> Option<Rect> {
        Some(Rect { x0, y0, x1, y1 })
    }

    #[test]
    fn merged_regions_are_disjoint_and_cover_every_rect() {
        let rects = vec![
            r(0, 0, 10, 10),
            r(5, 5, 20, 20),
            r(30, 0, 40, 5),
            None,
            r(19, 19, 31, 21),
            r(100, 100, 101, 101),
        ];
        let regions = merge(&rects, 0..rects.len());
        for (a, ra) in regions.iter().enumerate() {
            for rb in &regions[a + 1..] {
                assert!(!ra.rect.overlaps(&rb.rect), "{ra:?} {rb:?}");
            }
        }
        for (i, rect) in rects.iter().enumerate() {
            let Some(rect) = rect else { continue };
            let region = regions
                .iter()
                .find(|g| g.drones.contains(&i))
                .expect("every drone with a rect is in a region");
            assert!(region.rect.union(rect) == region.rect);
        }
        // 0, 1, 4 and (through 4) 2 chain together; 5 stays alone.
        assert_eq!(regions.len(), 2);
    }

    #[test]
    fn rects_pad_round_out_and_clip() {
        let b = PixelBox {
            x0: 10.2,
            y0: -5.0,
            x1: 12.7,
            y1: 3.1,
        };
        assert_eq!(pixel_rect(&b, 100, 100), r(9, 0, 14, 5));
        let outside = PixelBox {
            x0: 200.0,
            y0: 0.0,
            x1: 210.0,
            y1: 5.0,
        };
        assert_eq!(pixel_rect(&outside, 100, 100), None);
    }

    #[test]
    fn tiles_cover_a_rect_once() {
        let rect = Rect {
            x0: 3,
            y0: 4,
            x1: 20,
            y1: 13,
        };
        let tiles: Vec<[u32; 4]> = rect.tiles(8).collect();
        let area: u64 = tiles
            .iter()
            .map(|t| u64::from(t[2] - t[0]) * u64::from(t[3] - t[1]))
            .sum();
        assert_eq!(area, rect.area());
        assert_eq!(tiles.len(), 3 * 2);
    }
}

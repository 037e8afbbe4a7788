//! Screen regions: where a frame's drones can put pixels. Pure CPU code.
//!
//! A drone's rasterised samples lie inside the projection of its convex hull,
//! whose bounding box is its amodal box ([`amodal_box`]: near-plane clipping
//! included). That box, padded by [`PAD_PX`] and rounded out to whole pixels,
//! is the drone's rect. A pass covers the union of its drones' rects with
//! disjoint rects ([`cover`]: exactly the union, not its bounding box), so
//! each of them is "cleared" (background, id 0, far depth) before the drones
//! are drawn, and each pixel is resolved, read back and reduced exactly once.

use std::ops::Range;

use glam::DMat3;

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
    /// The pixels both hold (None: none).
    pub fn intersection(&self, other: &Self) -> Option<Self> {
        self.overlaps(other).then(|| Self {
            x0: self.x0.max(other.x0),
            y0: self.y0.max(other.y0),
            x1: self.x1.min(other.x1),
            y1: self.y1.min(other.y1),
        })
    }
    fn union(&self, other: &Self) -> Self {
        Self {
            x0: self.x0.min(other.x0),
            y0: self.y0.min(other.y0),
            x1: self.x1.max(other.x1),
            y1: self.y1.max(other.y1),
        }
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

/// A drone's extent along the camera's view axis: the nearest and farthest
/// camera-space depth (metres) of anything it can draw.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DepthRange {
    pub near: f64,
    pub far: f64,
}

/// How far (relative) one drone must be behind another before it is sure to
/// lose every depth test against it: far above the rasteriser's rounding of
/// a reversed-Z 32-bit float depth (about 1e-7 relative).
const DEPTH_MARGIN: f64 = 1e-4;

impl DepthRange {
    /// Whether every point of `self` is behind every point of `front`, by
    /// a margin no rounding of the depth test can cross.
    pub fn behind(&self, front: &DepthRange) -> bool {
        front.near > 0.0 && front.far.is_finite() && self.near > front.far * (1.0 + DEPTH_MARGIN)
    }
}

/// Whether drone `j` may hide part of drone `i`: unless `j` is wholly
/// behind `i` by their `depths` (missing or `None`: unknown, so it may).
pub fn may_hide(depths: &[Option<DepthRange>], j: usize, i: usize) -> bool {
    let depth = |k: usize| depths.get(k).copied().flatten();
    match (depth(j), depth(i)) {
        (Some(dj), Some(di)) => !dj.behind(&di),
        _ => true,
    }
}

/// Each drone's [`DepthRange`]: the nearest and farthest camera-space depth
/// of the corners of its model's bounding box as placed (every vertex, of
/// every level of detail, is inside it); `None` without the model's geometry.
pub fn drone_depths(scene: &FrameScene, geometry: &[LabelGeometry]) -> Vec<Option<DepthRange>> {
    let cam = &scene.camera;
    (scene.drones.iter())
        .map(|d| {
            let (lo, hi) = geometry.get(d.model)?.aabb;
            let centre = cam.camera_from_world_point(d.position);
            // The model's axes in camera space, scaled to the drone.
            let axes = cam.camera_from_world * DMat3::from_quat(d.rotation) * d.size_m;
            let (mut near, mut far) = (centre.z, centre.z);
            for k in 0..3 {
                let z = axes.col(k).z;
                let (a, b) = (z * lo[k], z * hi[k]);
                near += a.min(b);
                far += a.max(b);
            }
            Some(DepthRange { near, far })
        })
        .collect()
}

/// The pixels of the drones `members` as disjoint rects covering exactly the
/// union of their rects (not its bounding box: a swarm spread over the frame
/// covers a fraction of it), and those drones (the ones with a rect).
///
/// The union is cut into bands between the rects' y edges; in each band the
/// x intervals of the rects crossing it are merged, and an interval equal to
/// one in the band above extends that rect downwards.
pub fn cover(
    rects: &[Option<Rect>],
    members: impl IntoIterator<Item = usize>,
) -> (Vec<Rect>, Vec<usize>) {
    let mut drones = Vec::new();
    let mut items = Vec::new();
    for i in members {
        if let Some(r) = rects.get(i).copied().flatten() {
            drones.push(i);
            items.push(r);
        }
    }
    drones.sort_unstable();
    items.sort_unstable_by_key(|r| r.y0);
    let mut ys: Vec<u32> = items.iter().flat_map(|r| [r.y0, r.y1]).collect();
    ys.sort_unstable();
    ys.dedup();
    let mut out: Vec<Rect> = Vec::new();
    // Rects of `out` that end where the current band starts.
    let mut open: Vec<usize> = Vec::new();
    let mut active: Vec<Rect> = Vec::new();
    let mut intervals: Vec<(u32, u32)> = Vec::new();
    let mut next = 0;
    for band in ys.windows(2) {
        let (ya, yb) = (band[0], band[1]);
        active.retain(|r| r.y1 > ya);
        while let Some(r) = items.get(next).filter(|r| r.y0 <= ya) {
            active.push(*r);
            next += 1;
        }
        intervals.clear();
        intervals.extend(active.iter().map(|r| (r.x0, r.x1)));
        intervals.sort_unstable();
        let mut merged: Vec<(u32, u32)> = Vec::with_capacity(intervals.len());
        for &(a, b) in &intervals {
            match merged.last_mut() {
                Some((_, end)) if a <= *end => *end = (*end).max(b),
                _ => merged.push((a, b)),
            }
        }
        let mut still_open = Vec::with_capacity(merged.len());
        for (x0, x1) in merged {
            match open
                .iter()
                .copied()
                .find(|&k| out[k].x0 == x0 && out[k].x1 == x1)
            {
                Some(k) => {
                    out[k].y1 = yb;
                    still_open.push(k);
                }
                None => {
                    out.push(Rect {
                        x0,
                        y0: ya,
                        x1,
                        y1: yb,
                    });
                    still_open.push(out.len() - 1);
                }
            }
        }
        open = still_open;
    }
    (out, drones)
}

/// What one pass draws: its disjoint rects, and the instance ranges of its
/// drones per (model, level of detail). A drone's samples lie inside its own
/// rect, so all drones are drawn together after every rect is cleared, one
/// instanced draw per (model, level).
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct PassDraws {
    pub rects: Vec<Rect>,
    /// Where the rects begin in the frame's rect buffer (instances of `rect.wgsl`).
    pub first_rect: u32,
    pub draws: Vec<((usize, usize), Range<u32>)>,
}

impl PassDraws {
    /// The rects' instance range in the frame's rect buffer.
    pub fn rect_instances(&self) -> Range<u32> {
        self.first_rect..self.first_rect + self.rects.len() as u32
    }

    /// The smallest rect holding every rect of the pass (None: none).
    pub fn bounds(&self) -> Option<Rect> {
        self.rects.iter().copied().reduce(|a, b| a.union(&b))
    }
}

/// Places for `rects` in an atlas `width` pixels wide, in shelves (next fit,
/// tallest first: left to right, a new shelf below the last when the next
/// rect does not fit). Returns each rect's top-left corner in the atlas, in
/// the order given, and the rows used. Every rect must be at most `width`
/// wide.
pub fn pack_shelves(rects: &[Rect], width: u32) -> (Vec<(u32, u32)>, u32) {
    let mut order: Vec<usize> = (0..rects.len()).collect();
    order.sort_by_key(|&i| std::cmp::Reverse(rects[i].height()));
    let mut places = vec![(0, 0); rects.len()];
    let (mut x, mut y, mut shelf) = (0u32, 0u32, 0u32);
    for i in order {
        let r = &rects[i];
        if x + r.width() > width {
            (x, y, shelf) = (0, y + shelf, 0);
        }
        places[i] = (x, y);
        x += r.width();
        shelf = shelf.max(r.height());
    }
    (places, y + shelf)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn r(x0: u32, y0: u32, x1: u32, y1: u32) -> Option<Rect> {
        Some(Rect { x0, y0, x1, y1 })
    }

    #[test]
    fn cover_is_disjoint_and_exactly_the_union() {
        use rand::{Rng, SeedableRng};
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(9);
        for case in 0..200 {
            let n = rng.random_range(0..40);
            let side = if case % 2 == 0 { 64 } else { 160 };
            let rects: Vec<Option<Rect>> = (0..n)
                .map(|_| {
                    if rng.random_bool(0.1) {
                        return None;
                    }
                    let x0 = rng.random_range(0..side - 1);
                    let y0 = rng.random_range(0..side - 1);
                    let x1 = rng.random_range(x0 + 1..=(x0 + 30).min(side));
                    let y1 = rng.random_range(y0 + 1..=(y0 + 30).min(side));
                    Some(Rect { x0, y0, x1, y1 })
                })
                .collect();
            let (cover, drones) = cover(&rects, 0..n);
            let with_rect: Vec<usize> = (0..n).filter(|&i| rects[i].is_some()).collect();
            assert_eq!(drones, with_rect);
            for (a, ra) in cover.iter().enumerate() {
                assert!(ra.area() > 0);
                for rb in &cover[a + 1..] {
                    assert!(!ra.overlaps(rb), "case {case}: {ra:?} {rb:?}");
                }
            }
            // Pixel by pixel: inside some rect ⇔ inside the cover.
            let inside = |rs: &mut dyn Iterator<Item = Rect>, x: u32, y: u32| {
                rs.filter(|r| r.x0 <= x && x < r.x1 && r.y0 <= y && y < r.y1)
                    .count()
                    > 0
            };
            for y in 0..side {
                for x in 0..side {
                    assert_eq!(
                        inside(&mut rects.iter().flatten().copied(), x, y),
                        inside(&mut cover.iter().copied(), x, y),
                        "case {case}: pixel ({x}, {y})"
                    );
                }
            }
        }
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
    fn shelves_hold_every_rect_apart_within_the_width() {
        let r = |x0, y0, w, h| Rect {
            x0,
            y0,
            x1: x0 + w,
            y1: y0 + h,
        };
        let rects = [
            r(5, 5, 40, 10),
            r(900, 3, 50, 30),
            r(0, 0, 20, 5),
            r(7, 7, 100, 8),
        ];
        let (places, rows) = pack_shelves(&rects, 100);
        let placed: Vec<Rect> = rects
            .iter()
            .zip(&places)
            .map(|(rect, &(x, y))| r(x, y, rect.width(), rect.height()))
            .collect();
        for (i, a) in placed.iter().enumerate() {
            assert!(a.x1 <= 100 && a.y1 <= rows, "{a:?} outside 100×{rows}");
            for b in &placed[i + 1..] {
                assert!(!a.overlaps(b), "{a:?} and {b:?}");
            }
        }
        // Tallest first: 50 and 40 share a shelf (30 rows), 100 takes the
        // next (8 rows), 20 a third (5 rows).
        assert_eq!(places, vec![(50, 0), (0, 0), (0, 38), (0, 30)]);
        assert_eq!(rows, 43);
    }
}

//! The lens in the pipeline (issue 41): a frame's lens distortion
//! ([`crate::sensor::lens`]) applied between the render and the camera
//! chain. The lens comes before the sensor: its picture is resampled once,
//! after the motion streaks are smeared (the render's own space) and
//! before the PSF, vignetting, noise and encoding, which act on the
//! sensor's pixels. The labels follow: the renderer's id layer (its pixel
//! hits) is moved with the same map (nearest taps), and a drone's search
//! area for the pixels it changes is its rendered box's footprint through
//! the lens ([`footprint`]).

use std::sync::Arc;

use crate::annotate::visibility::PixelHit;
use crate::scene::FrameScene;
use crate::scene::projection::frame_lens;
use crate::sensor::PixelRect;
use crate::sensor::lens::{LensGeometry, LensMap};

/// A frame's lens: its geometry and its tabulated map.
pub(super) struct FrameLens {
    pub geo: LensGeometry,
    pub map: Arc<LensMap>,
}

/// The lens of `scene`'s camera model, when it draws one that is not neutral.
pub(super) fn of(scene: &FrameScene) -> Option<FrameLens> {
    let geo = frame_lens(scene)?;
    Some(FrameLens {
        map: LensMap::of(&geo),
        geo,
    })
}

/// The renderer's hits moved through the lens: each written pixel shows
/// the drones its nearest source pixel shows (`width`×`height` both). Only
/// the written pixels in the drones' footprints ([`footprint`] of each
/// drone's hits' box) are looked at: no other's nearest source is a hit.
pub(super) fn remap_hits(lens: &FrameLens, hits: &[PixelHit], (w, h): (u32, u32)) -> Vec<PixelHit> {
    let key = |p: &PixelHit| u64::from(p.y) * u64::from(w) + u64::from(p.x);
    // The hits by source pixel (a stable sort: each pixel's in their order).
    let mut sorted: Vec<PixelHit> = (hits.iter())
        .filter(|p| p.x < w && p.y < h)
        .copied()
        .collect();
    sorted.sort_by_key(key);
    let drones = sorted
        .iter()
        .map(|p| p.drone as usize + 1)
        .max()
        .unwrap_or(0);
    let areas: Vec<PixelRect> = (shown(drones, &sorted).into_iter().flatten())
        .map(|(r, _)| {
            // Two pixels more than the footprint's own margin.
            let f = footprint(&lens.geo, r);
            PixelRect {
                x0: f.x0.saturating_sub(2),
                y0: f.y0.saturating_sub(2),
                x1: f.x1 + 2,
                y1: f.y1 + 2,
            }
        })
        .collect();
    let mut out = Vec::new();
    lens.map.nearest_in(row_spans(&areas, h), |x, y, src| {
        let from = sorted.partition_point(|p| key(p) < u64::from(src));
        let to = from + sorted[from..].partition_point(|p| key(p) == u64::from(src));
        out.extend(sorted[from..to].iter().map(|p| PixelHit { x, y, ..*p }));
    });
    out
}

/// The union of `rects` as one-row rects, row by row and left to right
/// (each pixel once, in the picture's order), rows under `h`.
fn row_spans(rects: &[PixelRect], h: u32) -> Vec<PixelRect> {
    let mut spans = Vec::new();
    let y_end = rects.iter().map(|r| r.y1.min(h)).max().unwrap_or(0);
    let y_start = rects.iter().map(|r| r.y0).min().unwrap_or(0);
    let mut row: Vec<(u32, u32)> = Vec::new();
    for y in y_start..y_end {
        row.clear();
        row.extend((rects.iter().filter(|r| (r.y0..r.y1).contains(&y))).map(|r| (r.x0, r.x1)));
        row.sort_unstable();
        for &(x0, x1) in &row {
            let joins = (spans.last_mut()).filter(|l: &&mut PixelRect| l.y0 == y && x0 <= l.x1);
            if let Some(last) = joins {
                last.x1 = last.x1.max(x1);
            } else if x0 < x1 {
                spans.push(PixelRect {
                    x0,
                    y0: y,
                    x1,
                    y1: y + 1,
                });
            }
        }
    }
    spans
}

/// Each of `n` drones' lens-moved hits: their box and count (`None`: none).
pub(super) fn shown(n: usize, hits: &[PixelHit]) -> Vec<Option<(PixelRect, u64)>> {
    let mut found: Vec<Option<(PixelRect, u64)>> = vec![None; n];
    for p in hits {
        let Some(slot) = found.get_mut(p.drone as usize) else {
            continue;
        };
        let (r, n) = slot.get_or_insert((
            PixelRect {
                x0: p.x,
                y0: p.y,
                x1: p.x + 1,
                y1: p.y + 1,
            },
            0,
        ));
        *n += 1;
        r.x0 = r.x0.min(p.x);
        r.y0 = r.y0.min(p.y);
        r.x1 = r.x1.max(p.x + 1);
        r.y1 = r.y1.max(p.y + 1);
    }
    found
}

/// Where the rendered pixels of `r` can show in the written picture: the
/// box of the lens-mapped outline of `r` grown by the bilinear taps' pixel,
/// sampled a pixel apart, plus a pixel's margin, within the image.
pub(super) fn footprint(geo: &LensGeometry, r: PixelRect) -> PixelRect {
    let (x0, y0) = (f64::from(r.x0) - 1.0, f64::from(r.y0) - 1.0);
    let (x1, y1) = (f64::from(r.x1) + 1.0, f64::from(r.y1) + 1.0);
    let (nx, ny) = ((x1 - x0).ceil() as u32, (y1 - y0).ceil() as u32);
    let along =
        |n: u32, a: f64, b: f64| (0..=n).map(move |k| a + (b - a) * f64::from(k) / f64::from(n));
    let outline = (along(nx, x0, x1).flat_map(|x| [(x, y0), (x, y1)]))
        .chain(along(ny, y0, y1).flat_map(|y| [(x0, y), (x1, y)]));
    let (mut lo, mut hi) = (
        (f64::INFINITY, f64::INFINITY),
        (f64::NEG_INFINITY, f64::NEG_INFINITY),
    );
    for p in outline {
        let (u, v) = geo.forward(p);
        lo = (lo.0.min(u), lo.1.min(v));
        hi = (hi.0.max(u), hi.1.max(v));
    }
    let clamp = |v: f64, n: u32| v.clamp(0.0, f64::from(n)) as u32;
    PixelRect {
        x0: clamp(lo.0.floor() - 1.0, geo.width),
        y0: clamp(lo.1.floor() - 1.0, geo.height),
        x1: clamp(hi.0.ceil() + 1.0, geo.width),
        y1: clamp(hi.1.ceil() + 1.0, geo.height),
    }
}

/// The drone-free background through the lens where the labels read it:
/// `lensed` (the frame through the lens) with the rects `areas` resampled
/// from `background` (outside the drones' footprints the two agree).
pub(super) fn background(
    map: &LensMap,
    lensed: &[u8],
    background: &[u8],
    areas: &[PixelRect],
) -> Vec<u8> {
    let mut out = lensed.to_vec();
    for a in areas {
        map.remap_rect(background, &mut out, *a);
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sensor::lens::LensDraw;

    fn geo() -> LensGeometry {
        let d = LensDraw::BrownConrady {
            k1: -0.3,
            k2: 0.0,
            k3: 0.0,
            p1: 0.002,
            p2: 0.0,
        };
        LensGeometry::new(d, 80, 60, 70.0).expect("a lens")
    }

    /// Every written pixel whose taps touch a rect's pixel lies in the rect's footprint.
    #[test]
    fn a_rects_footprint_holds_every_pixel_its_pixels_reach() {
        let geo = geo();
        let map = LensMap::build(&geo);
        let r = PixelRect {
            x0: 2,
            y0: 40,
            x1: 9,
            y1: 55,
        };
        let f = footprint(&geo, r);
        let (mut reached, mut outside) = (0, 0);
        for i in 0..80 * 60 {
            let (u, v) = map.source(i).expect("in the map");
            let near = |s: f64, a: u32, b: u32| s > f64::from(a) - 1.0 && s < f64::from(b);
            if near(u, r.x0, r.x1) && near(v, r.y0, r.y1) {
                reached += 1;
                let (x, y) = ((i % 80) as u32, (i / 80) as u32);
                if !((f.x0..f.x1).contains(&x) && (f.y0..f.y1).contains(&y)) {
                    outside += 1;
                }
            }
        }
        assert!(
            reached > 20 && outside == 0,
            "{reached} reached, {outside} outside {f:?}"
        );
    }

    #[test]
    fn hits_move_with_the_nearest_source_pixel() {
        let geo = geo();
        let map = LensMap::build(&geo);
        let hits = [
            PixelHit {
                x: 40,
                y: 30,
                drone: 0,
                samples: 4,
            },
            PixelHit {
                x: 1,
                y: 1,
                drone: 1,
                samples: 2,
            },
        ];
        let lens = FrameLens {
            geo,
            map: Arc::new(LensMap::build(&geo)),
        };
        let moved = remap_hits(&lens, &hits, (80, 60));
        assert!(!moved.is_empty());
        for m in &moved {
            let src = map.nearest((m.y * 80 + m.x) as usize).expect("in the map");
            let h = hits[m.drone as usize];
            assert_eq!(src, h.y * 80 + h.x);
            assert_eq!(m.samples, h.samples);
        }
        // The centre stays at the centre.
        assert!(
            moved
                .iter()
                .any(|m| m.drone == 0 && m.x.abs_diff(40) <= 1 && m.y.abs_diff(30) <= 1)
        );
    }
}

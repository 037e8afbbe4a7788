//! Visibility: each drone's visible box, visible pixel count and unoccluded
//! pixel count, as the picture shows them.
//!
//! The renderer measures them in the colour pass itself
//! ([`Renderer::render_frame`] with `visibility`): the instance ids share the
//! colour pass's samples, and a pixel counts for every drone any of its
//! samples shows, so a thin leg that colours a pixel through one MSAA sample
//! is inside the box, and a sliver that colours no pixel is not. A drone
//! whose (padded) amodal box overlaps no other drone's cannot be occluded, so
//! its unoccluded count is its visible count, and neither is a drone whose
//! rect shows, in the main pass, no drone that may be in front of it; the
//! others are drawn again in one footprint pass, each fragment marking its
//! pixel in its drone's own bitmask (`render/frame/footprint.rs`), or, where
//! fragment shaders cannot write storage, split into layers of mutually
//! non-overlapping drones ([`overlap_layers`]), each layer drawn alone. A
//! sparse swarm costs no extra pass.
//!
//! What is measured is plain data ([`Visibility`], [`PixelHit`]): the labels
//! are made from it (`annotate`, which names these types), the renderer
//! fills it in (here and in `ids.rs`).

use serde::Serialize;

use crate::render::regions::DepthRange;
use crate::render::{RenderError, RenderRequest, Renderer};
use crate::scene::FrameScene;
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

/// Measure every drone of `scene` with `msaa` samples per pixel, at `scale` ×
/// the output resolution (1: the output's own pixels, as the picture shows
/// them; 2 or 4 supersample: boxes are divided by `scale`, pixel counts stay
/// in measured pixels, so fractions are unaffected).
pub fn measure(
    renderer: &mut Renderer,
    scene: &FrameScene,
    msaa: u32,
    scale: u32,
) -> Result<Vec<Visibility>, RenderError> {
    let scale = scale.max(1);
    let scaled;
    let scene = if scale == 1 {
        scene
    } else {
        // Scaling W and H scales K with them: the same view, finer pixels.
        let mut s = scene.clone();
        s.camera.width *= scale;
        s.camera.height *= scale;
        scaled = s;
        &scaled
    };
    let request = RenderRequest {
        msaa,
        color: false,
        visibility: true,
    };
    let measured = renderer
        .render_frame(scene, &request)?
        .visibility
        .unwrap_or_default();
    let k = f64::from(scale);
    Ok(measured
        .into_iter()
        .map(|v| Visibility {
            visible_box: v.visible_box.map(|b| PixelBox {
                x0: b.x0 / k,
                y0: b.y0 / k,
                x1: b.x1 / k,
                y1: b.y1 / k,
            }),
            ..v
        })
        .collect())
}

/// Per-drone pixel box and pixel count from an id image (ids are drone index + 1).
pub fn pixel_stats(ids: &crate::render::IdImage, n_drones: usize) -> Vec<(Option<PixelBox>, u64)> {
    let mut out: Vec<(Option<PixelBox>, u64)> = vec![(None, 0); n_drones];
    for (row, line) in ids.ids.chunks_exact(ids.width as usize).enumerate() {
        let y = row as f64;
        for (col, &id) in line.iter().enumerate() {
            if id == 0 || id as usize > n_drones {
                continue;
            }
            let x = col as f64;
            let (b, n) = &mut out[id as usize - 1];
            *n += 1;
            PixelBox::include_pixel(b, x, y);
        }
    }
    out
}

/// Greedy layering of drones by screen overlap: drones in one layer have
/// disjoint (1-px padded) boxes, so rendering a layer alone shows each of its
/// drones unoccluded. Drones with `None` boxes get no layer. Returns the
/// layers and whether each drone overlaps any other.
///
/// The work is bounded: past [`MAX_OVERLAP_TESTS`] box comparisons (drones
/// piled on one spot, where every drone meets every other) it stops with
/// [`RenderError::TooDense`](super::RenderError::TooDense) instead of running
/// for hours.
pub fn overlap_layers(
    boxes: &[Option<PixelBox>],
) -> Result<(Vec<Vec<usize>>, Vec<bool>), super::RenderError> {
    occlusion_layers(boxes, &[])
}

/// [`overlap_layers`], knowing each drone's [`DepthRange`] (`depths[i]`;
/// missing or `None`: unknown): a drone counts as overlapping only when a
/// drone whose box meets its own may be in front of it. A drone with only
/// drones behind it wins every depth test against them, so the main pass
/// already shows it whole (its visible count is its unoccluded count) and
/// it needs no layer pass. The layers are the same as [`overlap_layers`]'.
pub fn occlusion_layers(
    boxes: &[Option<PixelBox>],
    depths: &[Option<DepthRange>],
) -> Result<(Vec<Vec<usize>>, Vec<bool>), super::RenderError> {
    let may_hide = |j: usize, i: usize| super::regions::may_hide(depths, j, i);
    let padded: Vec<Option<PixelBox>> = boxes.iter().map(|b| b.as_ref().map(pad)).collect();
    let grid = TileGrid::new(&padded);
    let mut tests: u64 = 0;
    let mut layer_of: Vec<Option<usize>> = vec![None; boxes.len()];
    let mut overlapping = vec![false; boxes.len()];
    let mut layers: Vec<Vec<usize>> = Vec::new();
    // Reused from drone to drone (no allocation, no hashing per drone):
    // `taken_by[l] == i + 1` once a drone that drone `i` meets is in layer
    // `l`. A drone met in two tiles is met twice: both marks are idempotent.
    let mut taken_by: Vec<usize> = Vec::new();
    for (i, pb) in padded.iter().enumerate() {
        let Some(pb) = pb else { continue };
        let mark = i + 1;
        for t in tiles_of(pb) {
            let near = grid.near(t);
            charge(&mut tests, near.len(), boxes)?;
            for (bj, j) in near {
                let j = *j as usize;
                if j != i && overlaps(pb, bj) {
                    overlapping[i] = overlapping[i] || may_hide(j, i);
                    if let Some(l) = layer_of[j] {
                        taken_by[l] = mark;
                    }
                }
            }
        }
        // The first layer none of its neighbours is in.
        let layer = (0..layers.len())
            .find(|&l| taken_by[l] != mark)
            .unwrap_or(layers.len());
        if layer == layers.len() {
            layers.push(Vec::new());
            taken_by.push(0);
        }
        layers[layer].push(i);
        layer_of[i] = Some(layer);
    }
    Ok((layers, overlapping))
}

/// Whether each drone may be hidden by another: [`occlusion_layers`]'
/// second result without the layers (the main pass's ids then tell which of
/// these drones need a pass alone). Each drone is compared with the drones
/// sharing its [`CELL`]-px cells of a dense grid over `size_px` (boxes
/// beyond it are clamped to its edge cells) until one may hide it, so a
/// dense swarm costs a few comparisons a drone. The same budget as
/// [`overlap_layers`] bounds the work.
pub fn hidden(
    boxes: &[Option<PixelBox>],
    depths: &[Option<DepthRange>],
    size_px: (u32, u32),
) -> Result<Vec<bool>, super::RenderError> {
    let padded: Vec<Option<PixelBox>> = boxes.iter().map(|b| b.as_ref().map(pad)).collect();
    let grid = CellGrid::new(&padded, size_px);
    let mut tests: u64 = 0;
    let mut hidden = vec![false; boxes.len()];
    for (i, pb) in padded.iter().enumerate() {
        let Some(pb) = pb else { continue };
        'cells: for cell in grid.cells_of(pb) {
            let near = grid.near(cell);
            charge(&mut tests, near.len(), boxes)?;
            for &j in near {
                let j = j as usize;
                let Some(bj) = &padded[j] else { continue };
                if j != i && overlaps(pb, bj) && super::regions::may_hide(depths, j, i) {
                    hidden[i] = true;
                    break 'cells;
                }
            }
        }
    }
    Ok(hidden)
}

/// The side of [`hidden`]'s cells in pixels (a drone of 10–20 px touches
/// one to four).
const CELL: f64 = 16.0;

/// Which boxes touch each [`CELL`]-px cell of a frame: the indices of each
/// cell's boxes, cell after cell (row by row), in index order.
pub(crate) struct CellGrid {
    columns: usize,
    rows: usize,
    /// Where each cell's indices begin in `indices` (one more entry than cells).
    starts: Vec<u32>,
    indices: Vec<u32>,
}

impl CellGrid {
    pub(crate) fn new(boxes: &[Option<PixelBox>], (width, height): (u32, u32)) -> Self {
        let columns = (f64::from(width.max(1)) / CELL).ceil() as usize;
        let rows = (f64::from(height.max(1)) / CELL).ceil() as usize;
        let mut grid = Self {
            columns,
            rows,
            starts: vec![0; columns * rows + 1],
            indices: Vec::new(),
        };
        let present = || (boxes.iter().enumerate()).filter_map(|(i, b)| Some((i, b.as_ref()?)));
        for (_, b) in present() {
            for cell in grid.cells_of(b) {
                grid.starts[cell + 1] += 1;
            }
        }
        for k in 1..grid.starts.len() {
            grid.starts[k] += grid.starts[k - 1];
        }
        let mut next = grid.starts.clone();
        grid.indices = vec![0; grid.starts[columns * rows] as usize];
        for (i, b) in present() {
            for cell in grid.cells_of(b) {
                grid.indices[next[cell] as usize] = i as u32;
                next[cell] += 1;
            }
        }
        grid
    }

    /// The cells a box touches (clamped to the grid), row by row.
    pub(crate) fn cells_of(&self, b: &PixelBox) -> impl Iterator<Item = usize> + use<> {
        let clamp = |v: f64, n: usize| ((v / CELL).floor().max(0.0) as usize).min(n - 1);
        let (cx0, cx1) = (clamp(b.x0, self.columns), clamp(b.x1, self.columns));
        let (cy0, cy1) = (clamp(b.y0, self.rows), clamp(b.y1, self.rows));
        let columns = self.columns;
        (cy0..=cy1).flat_map(move |cy| (cx0..=cx1).map(move |cx| cy * columns + cx))
    }

    /// The indices of the boxes touching `cell`.
    pub(crate) fn near(&self, cell: usize) -> &[u32] {
        &self.indices[self.starts[cell] as usize..self.starts[cell + 1] as usize]
    }
}

/// The side of [`occlusion_layers`]' tiles in pixels.
const TILE: f64 = 64.0;

/// A box grown by one pixel on every side.
fn pad(b: &PixelBox) -> PixelBox {
    PixelBox {
        x0: b.x0 - 1.0,
        y0: b.y0 - 1.0,
        x1: b.x1 + 1.0,
        y1: b.y1 + 1.0,
    }
}

/// Whether two boxes share an area.
fn overlaps(a: &PixelBox, b: &PixelBox) -> bool {
    a.x0 < b.x1 && b.x0 < a.x1 && a.y0 < b.y1 && b.y0 < a.y1
}

/// The [`TILE`]-px tiles a box touches, row by row.
fn tiles_of(b: &PixelBox) -> impl Iterator<Item = (i64, i64)> + use<> {
    let (tx0, ty0) = ((b.x0 / TILE).floor() as i64, (b.y0 / TILE).floor() as i64);
    let (tx1, ty1) = ((b.x1 / TILE).floor() as i64, (b.y1 / TILE).floor() as i64);
    (ty0..=ty1).flat_map(move |ty| (tx0..=tx1).map(move |tx| (tx, ty)))
}

/// Which boxes touch each tile: (tile, box, box index) sorted by tile,
/// then index, so each tile's boxes are one slice in index order, scanned
/// in memory order.
struct TileGrid {
    tiles: Vec<(i64, i64)>,
    boxes: Vec<(PixelBox, u32)>,
}

impl TileGrid {
    fn new(boxes: &[Option<PixelBox>]) -> Self {
        let mut entries: Vec<((i64, i64), u32)> = (boxes.iter().enumerate())
            .filter_map(|(i, b)| Some((i, b.as_ref()?)))
            .flat_map(|(i, b)| tiles_of(b).map(move |t| (t, i as u32)))
            .collect();
        entries.sort_unstable();
        let tiles = entries.iter().map(|&(t, _)| t).collect();
        let boxes = (entries.into_iter())
            .filter_map(|(_, i)| Some((boxes[i as usize]?, i)))
            .collect();
        Self { tiles, boxes }
    }

    /// The boxes touching tile `t` with their indices, in index order.
    fn near(&self, t: (i64, i64)) -> &[(PixelBox, u32)] {
        let start = self.tiles.partition_point(|&k| k < t);
        let end = start + self.tiles[start..].partition_point(|&k| k == t);
        &self.boxes[start..end]
    }
}

/// The most box comparisons [`overlap_layers`] makes for one frame (about
/// a second of work). Each drone is compared with the drones sharing its
/// 64-px tiles: a few hundred drones in view need thousands, 10 000 drones
/// crowded into a 320×180 image about 10⁷.
pub const MAX_OVERLAP_TESTS: u64 = 20_000_000;

/// Counts `n` more box comparisons against [`MAX_OVERLAP_TESTS`]: past it,
/// the frame is too dense (the error names the drone count and the limit).
fn charge(tests: &mut u64, n: usize, boxes: &[Option<PixelBox>]) -> Result<(), super::RenderError> {
    *tests += n as u64;
    if *tests > MAX_OVERLAP_TESTS {
        return Err(super::RenderError::TooDense {
            drones: boxes.iter().filter(|b| b.is_some()).count(),
            limit: MAX_OVERLAP_TESTS,
        });
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn hidden_names_the_drones_occlusion_layers_calls_overlapping() {
        // A dense and a sparse crowd of 4–24 px boxes, some past the frame's
        // edges, some without a box, at depths that sometimes settle who is in front.
        let mut state = 12345u64;
        let mut next = |n: u64| {
            state = state
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            (state >> 33) % n
        };
        for (count, spread) in [(3000, 400), (400, 1400)] {
            let (boxes, depths): (Vec<_>, Vec<_>) = (0..count)
                .map(|_| {
                    let (x, y) = (next(spread) as f64 - 30.0, next(spread / 2) as f64 - 20.0);
                    let (w, h) = (4.0 + next(20) as f64, 4.0 + next(20) as f64);
                    let near = 10.0 + next(50) as f64;
                    let b = (next(10) > 0).then_some(PixelBox {
                        x0: x,
                        y0: y,
                        x1: x + w,
                        y1: y + h,
                    });
                    let d = (next(10) > 0).then_some(DepthRange {
                        near,
                        far: near + next(8) as f64,
                    });
                    (b, d)
                })
                .unzip();
            let expected = occlusion_layers(&boxes, &depths).expect("layers").1;
            let got = hidden(
                &boxes,
                &depths,
                (spread as u32 - 60, spread as u32 / 2 - 40),
            )
            .expect("hidden");
            assert_eq!(got, expected);
            let some = got.iter().filter(|&&h| h).count();
            assert!(some > 0 && some < count, "{some} of {count} hidden");
        }
    }
}

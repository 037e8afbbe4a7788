//! The depth layer of the weather's composite: what each pixel shows, as a
//! depth, kept only in the cells drones reach.

use crate::annotate::visibility::PixelHit;
use crate::scene::FrameScene;
use crate::scene::projection::{LabelGeometry, amodal_box};

/// Side of the depth layer's cells, pixels: a multiple of the composite's
/// strip height, so a strip lies in one row of cells.
pub(super) const CELL: u32 = 32;

/// What each pixel shows, as a depth: drones' pixels at their depth, all
/// else at infinity. Stored only in the cells drones' boxes meet.
pub(super) struct DepthLayer {
    cols: u32,
    /// Per cell: its tile in `tiles` (`u32::MAX`: no drone there).
    cell_tile: Vec<u32>,
    tiles: Vec<[f32; (CELL * CELL) as usize]>,
}

impl DepthLayer {
    fn empty(width: u32, height: u32) -> Self {
        let (cols, rows) = (width.div_ceil(CELL), height.div_ceil(CELL));
        Self {
            cols,
            cell_tile: vec![u32::MAX; (cols * rows) as usize],
            tiles: Vec::new(),
        }
    }

    /// The depths of the drones of `scene` in `frame`: a pixel of a
    /// drone's box (rounded out, one pixel of margin) that differs from
    /// `background` (every pixel of the box without one) is at the depth
    /// of the nearest such drone.
    pub(super) fn new(
        scene: &FrameScene,
        geometry: &[LabelGeometry],
        frame: &[u8],
        background: Option<&[u8]>,
    ) -> Self {
        let cam = &scene.camera;
        let (w, h) = (cam.width, cam.height);
        let mut layer = Self::empty(w, h);
        for drone in &scene.drones {
            let Some(b) = geometry
                .get(drone.model)
                .and_then(|g| amodal_box(cam, drone, g))
            else {
                continue;
            };
            let z = cam.camera_from_world_point(drone.position).z as f32;
            let clip = |v: f64, max: u32| v.clamp(0.0, f64::from(max)) as u32;
            let (x0, y0) = (clip(b.x0.floor() - 1.0, w), clip(b.y0.floor() - 1.0, h));
            let (x1, y1) = (clip(b.x1.ceil() + 1.0, w), clip(b.y1.ceil() + 1.0, h));
            for y in y0..y1 {
                for x in x0..x1 {
                    let i = (y * w + x) as usize * 4;
                    let shows = background.is_none_or(|bg| frame[i..i + 3] != bg[i..i + 3]);
                    if shows {
                        let d = layer.depth_mut(x, y);
                        *d = d.min(z);
                    }
                }
            }
        }
        layer
    }

    /// The depths of the drones of `scene` at their id-pass pixels
    /// (`hits`): each pixel at the depth of the nearest drone there.
    pub(super) fn of_hits(scene: &FrameScene, hits: &[PixelHit]) -> Self {
        let cam = &scene.camera;
        let mut layer = Self::empty(cam.width, cam.height);
        let depths: Vec<f32> = (scene.drones.iter())
            .map(|d| cam.camera_from_world_point(d.position).z as f32)
            .collect();
        for hit in hits.iter().filter(|h| h.x < cam.width && h.y < cam.height) {
            if let Some(&z) = depths.get(hit.drone as usize) {
                let d = layer.depth_mut(hit.x, hit.y);
                *d = d.min(z);
            }
        }
        layer
    }

    fn depth_mut(&mut self, x: u32, y: u32) -> &mut f32 {
        let cell = ((y / CELL) * self.cols + x / CELL) as usize;
        if self.cell_tile[cell] == u32::MAX {
            self.cell_tile[cell] = self.tiles.len() as u32;
            self.tiles.push([f32::INFINITY; (CELL * CELL) as usize]);
        }
        let tile = &mut self.tiles[self.cell_tile[cell] as usize];
        &mut tile[((y % CELL) * CELL + x % CELL) as usize]
    }

    /// Whether a drone's pixel may lie in columns x0..x1 of rows y0..y1.
    pub(super) fn any_within(&self, (x0, y0, x1, y1): (u32, u32, u32, u32)) -> bool {
        if self.tiles.is_empty() || x0 >= x1 || y0 >= y1 {
            return false;
        }
        let (c0, c1) = (x0 / CELL, (x1 - 1) / CELL);
        ((y0 / CELL)..=((y1 - 1) / CELL)).any(|row| {
            let cells = (row * self.cols + c0) as usize..=(row * self.cols + c1) as usize;
            (self.cell_tile.get(cells)).is_some_and(|c| c.iter().any(|&t| t != u32::MAX))
        })
    }

    /// The depth of what pixel (x, y) shows, metres (infinity: no drone).
    #[inline]
    pub(super) fn depth(&self, x: u32, y: u32) -> f32 {
        let cell = ((y / CELL) * self.cols + x / CELL) as usize;
        match self.cell_tile.get(cell) {
            Some(&t) if t != u32::MAX => {
                self.tiles[t as usize][((y % CELL) * CELL + x % CELL) as usize]
            }
            _ => f32::INFINITY,
        }
    }

    /// The cells of row `y`'s row of cells that hold a drone: each one's
    /// first column and its depths on row y (`CELL` of them).
    pub(super) fn drone_cells(&self, y: u32) -> impl Iterator<Item = (u32, &[f32])> {
        let first = ((y / CELL) * self.cols) as usize;
        let cells = self.cell_tile.get(first..first + self.cols as usize);
        let within = ((y % CELL) * CELL) as usize;
        (cells.into_iter().flatten().enumerate())
            .filter(|(_, t)| **t != u32::MAX)
            .map(move |(c, &t)| {
                let tile = &self.tiles[t as usize];
                (c as u32 * CELL, &tile[within..within + CELL as usize])
            })
    }
}

#[cfg(test)]
impl DepthLayer {
    /// A `w × h` layer with `pixels` at depth `z`, every other at infinity.
    pub(super) fn from_depths((w, h): (u32, u32), pixels: &[(u32, u32)], z: f32) -> Self {
        let mut layer = Self::empty(w, h);
        for &(x, y) in pixels {
            *layer.depth_mut(x, y) = z;
        }
        layer
    }
}

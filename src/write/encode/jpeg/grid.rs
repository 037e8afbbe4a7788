//! How an image of one size and quality is cut into restart segments: the
//! MCU side of the chroma mode, the restart interval that divides an MCU row,
//! and the tiles that interval makes.

use std::ops::Range;

use super::Area;

/// Chroma subsampling for a quality: 4:2:0 below 90, 4:4:4 from 90 up.
pub(super) fn subsampled(quality: u8) -> bool {
    quality < 90
}

/// Side in pixels of one MCU (square in both chroma modes).
fn mcu_side(quality: u8) -> u32 {
    if subsampled(quality) { 16 } else { 8 }
}

/// Widest tile, in pixels, that the restart interval aims for.
pub(super) const TILE_PX: u32 = 512;
/// Narrower tiles than this are not worth their markers: whole rows instead.
pub(super) const MIN_TILE_PX: u32 = 128;

/// How an image of one size and quality is cut into restart segments:
/// `cols` × `rows` tiles of `blocks` MCUs, row by row. `blocks` divides the
/// MCUs of a row, so no segment spans two rows.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) struct Grid {
    pub(super) width: u32,
    pub(super) height: u32,
    /// MCU side in pixels.
    pub(super) mcu: u32,
    /// MCUs per restart interval.
    pub(super) blocks: u32,
    pub(super) cols: u32,
    pub(super) rows: u32,
}

impl Grid {
    pub(super) fn new(width: u32, height: u32, quality: u8) -> Self {
        Self::sized(width, height, quality, TILE_PX, MIN_TILE_PX)
    }

    /// The interval is the largest divisor of the row's MCU count whose
    /// tile is at most `most_px` wide; a whole row when that tile would be
    /// narrower than `least_px` (e.g. a prime count) or the row is narrow.
    pub(super) fn sized(width: u32, height: u32, quality: u8, most_px: u32, least_px: u32) -> Self {
        let mcu = mcu_side(quality);
        let across = width.div_ceil(mcu).max(1);
        let most = (most_px / mcu).clamp(1, across);
        let divisor = (1..=most)
            .rev()
            .find(|&d| across.is_multiple_of(d))
            .unwrap_or(1);
        let blocks = if divisor * mcu < least_px {
            across
        } else {
            divisor
        };
        Self {
            width,
            height,
            mcu,
            blocks,
            cols: across / blocks,
            rows: height.div_ceil(mcu),
        }
    }

    pub(super) fn len(&self) -> usize {
        self.cols as usize * self.rows as usize
    }

    /// Tile width in pixels (the last column may be cut by the image edge).
    pub(super) fn tile_px(&self) -> u32 {
        self.blocks * self.mcu
    }

    /// Pixel columns and rows of tile `i` (row-major), cut at the image edge.
    pub(super) fn tile(&self, i: usize) -> (Range<u32>, Range<u32>) {
        let (r, c) = (
            (i / self.cols as usize) as u32,
            (i % self.cols as usize) as u32,
        );
        let x0 = c * self.tile_px();
        let y0 = r * self.mcu;
        (
            x0..(x0 + self.tile_px()).min(self.width),
            y0..(y0 + self.mcu).min(self.height),
        )
    }

    /// Whether tile `i` is whole: no dummy blocks, so it compresses the
    /// same anywhere (stacked with others).
    pub(super) fn whole(&self, i: usize) -> bool {
        let (x, y) = self.tile(i);
        x.len() as u32 == self.tile_px() && y.len() as u32 == self.mcu
    }

    /// Mark the tiles that `area` touches.
    pub(super) fn mark(&self, area: &Area, marks: &mut [bool]) {
        let (x0, x1) = (area.x.start.min(self.width), area.x.end.min(self.width));
        let (y0, y1) = (area.y.start.min(self.height), area.y.end.min(self.height));
        if x0 >= x1 || y0 >= y1 {
            return;
        }
        let (c0, c1) = (x0 / self.tile_px(), x1.div_ceil(self.tile_px()));
        for r in y0 / self.mcu..y1.div_ceil(self.mcu) {
            let row = r as usize * self.cols as usize;
            for m in &mut marks[row + c0 as usize..row + c1 as usize] {
                *m = true;
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn grids_cut_rows_into_tiles_of_whole_mcus() {
        let g = |w, h, q| {
            let g = Grid::new(w, h, q);
            (g.blocks * g.mcu, g.cols, g.rows)
        };
        assert_eq!(g(1920, 1080, 85), (480, 4, 68));
        assert_eq!(g(4096, 2160, 85), (512, 8, 135));
        assert_eq!(g(1920, 1080, 95), (480, 4, 135));
        // 63 MCUs: tiles of 21 (the last cut at 1000 px); 61 (prime): whole rows.
        assert_eq!(g(1000, 70, 85), (336, 3, 5));
        assert_eq!(g(976, 16, 85), (976, 1, 1));
        assert_eq!(g(1, 1, 85), (16, 1, 1));
        let grid = Grid::new(1000, 70, 85);
        assert_eq!(grid.tile(2), (672..1000, 0..16));
        assert_eq!(grid.tile(14), (672..1000, 64..70));
        assert!(grid.whole(1) && !grid.whole(2) && !grid.whole(12));
    }
}

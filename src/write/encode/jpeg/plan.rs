//! The compressions that make the tiles a frame lacks: runs of wholly
//! missing MCU rows as crops of the frame in bands of about `band_px`
//! pixels, edge tiles as crops, every other missing tile stacked into one
//! narrow image.

use std::ops::Range;
use std::sync::Arc;

use super::Grid;

/// One compression that makes some missing tiles: a crop of the frame
/// (`x`, `y`), whose segments are `tiles` in order, or (`None`) a stack of
/// whole tiles, one per MCU row of a `tile_px`-wide image.
pub(super) struct Piece {
    pub(super) tiles: Vec<usize>,
    pub(super) crop: Option<(Range<u32>, Range<u32>)>,
}

/// Most tiles stacked into one image (its height stays within JPEG's 65535).
const MAX_STACK: usize = 2048;

/// The compressions that make the tiles `have` lacks: runs of wholly
/// missing MCU rows straight from the frame, cut into bands of whole MCU
/// rows of at most `band_px` pixels (at least one row); tiles cut by the
/// image's edge (their dummy blocks depend on where that edge is) as crops
/// that reach it; every other missing tile stacked.
pub(super) fn plan(grid: &Grid, have: &[Option<Arc<[u8]>>], band_px: u64) -> Vec<Piece> {
    let (cols, rows) = (grid.cols as usize, grid.rows as usize);
    let row_px = u64::from(grid.width) * u64::from(grid.mcu);
    let band_rows = usize::try_from(band_px / row_px.max(1)).map_or(rows, |n| n.max(1));
    let row_missing = |r: usize| have[r * cols..(r + 1) * cols].iter().all(Option::is_none);
    let mut pieces = Vec::new();
    let mut stacked = Vec::new();
    let mut r = 0;
    while r < rows {
        if row_missing(r) {
            // The run's rows up to one band's worth (never read past it).
            let limit = rows.min(r.saturating_add(band_rows));
            let end = (r..limit).find(|&e| !row_missing(e)).unwrap_or(limit);
            let y = r as u32 * grid.mcu..(end as u32 * grid.mcu).min(grid.height);
            pieces.push(Piece {
                tiles: (r * cols..end * cols).collect(),
                crop: Some((0..grid.width, y)),
            });
            r = end;
            continue;
        }
        let mut c = 0;
        while c < cols {
            let i = r * cols + c;
            if have[i].is_some() {
                c += 1;
            } else if grid.whole(i) {
                stacked.push(i);
                c += 1;
            } else {
                let end = (c..cols)
                    .find(|&e| have[r * cols + e].is_some() || grid.whole(r * cols + e))
                    .unwrap_or(cols);
                let (x, y) = grid.tile(i);
                let x = x.start..grid.tile(r * cols + end - 1).0.end;
                pieces.push(Piece {
                    tiles: (i..r * cols + end).collect(),
                    crop: Some((x, y)),
                });
                c = end;
            }
        }
        r += 1;
    }
    for chunk in stacked.chunks(MAX_STACK) {
        pieces.push(Piece {
            tiles: chunk.to_vec(),
            crop: None,
        });
    }
    pieces
}

/// Whole tiles `tiles` of the frame, one above the other.
pub(super) fn stack_tiles(rgba: &[u8], grid: &Grid, tiles: &[usize]) -> Vec<u8> {
    let row_bytes = grid.tile_px() as usize * 4;
    let stride = grid.width as usize * 4;
    let mut stack = Vec::with_capacity(tiles.len() * grid.mcu as usize * row_bytes);
    for &i in tiles {
        let (x, y) = grid.tile(i);
        for py in y {
            let at = py as usize * stride + x.start as usize * 4;
            stack.extend_from_slice(&rgba[at..at + row_bytes]);
        }
    }
    stack
}

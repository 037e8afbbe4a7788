//! JPEG through libjpeg-turbo, with a restart marker every few MCUs, so a
//! frame that repaints a few small regions over a background reuses the
//! compressed rest.
//!
//! A baseline JPEG with a restart interval is a header and one
//! entropy-coded segment per interval, separated by `RST0`…`RST7` markers;
//! each segment starts with fresh DC predictors and byte-aligned, so it
//! depends on the pixels of its own MCUs alone. The interval is chosen so
//! that it divides an MCU row ([`Grid`]): segments are then tiles of the
//! image, about 512 pixels wide and one MCU row (16 pixels at 4:2:0, 8 at
//! 4:4:4) high. Colour conversion, 2×2 chroma averaging (its rounding bias
//! alternates per chroma column, and tiles start on even columns), the DCT
//! and the bottom/right edge padding (dummy blocks) are all local to a
//! tile, so compressing a crop that starts on a tile boundary, or a stack
//! of whole tiles, yields exactly the segments compressing the whole image
//! yields for them (`tests` below compare the bytes). [`JpegEncoder`]
//! therefore keeps, per background, the segments of tiles no drone touched
//! and compresses only the tiles a frame painted (and tiles it has not seen
//! clean yet): on the quickstart, a few percent of the image.
//!
//! The output is the same bytes whichever tiles were reused, and the same as
//! [`compress`] of the whole frame: deterministic, on every machine (the
//! accurate integer DCT gives the same coefficients on its SIMD and C paths).

use std::ops::Range;
use std::sync::{Arc, Mutex, PoisonError};

/// Chroma subsampling for a quality: 4:2:0 below 90, 4:4:4 from 90 up.
fn subsampled(quality: u8) -> bool {
    quality < 90
}

/// Side in pixels of one MCU (square in both chroma modes).
fn mcu_side(quality: u8) -> u32 {
    if subsampled(quality) { 16 } else { 8 }
}

/// Widest tile, in pixels, that the restart interval aims for.
const TILE_PX: u32 = 512;
/// Narrower tiles than this are not worth their markers: whole rows instead.
const MIN_TILE_PX: u32 = 128;

/// How an image of one size and quality is cut into restart segments:
/// `cols` × `rows` tiles of `blocks` MCUs, row by row. `blocks` divides the
/// MCUs of a row, so no segment spans two rows.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
struct Grid {
    width: u32,
    height: u32,
    /// MCU side in pixels.
    mcu: u32,
    /// MCUs per restart interval.
    blocks: u32,
    cols: u32,
    rows: u32,
}

impl Grid {
    fn new(width: u32, height: u32, quality: u8) -> Self {
        Self::sized(width, height, quality, TILE_PX, MIN_TILE_PX)
    }

    /// The interval is the largest divisor of the row's MCU count whose
    /// tile is at most `most_px` wide; a whole row when that tile would be
    /// narrower than `least_px` (e.g. a prime count) or the row is narrow.
    fn sized(width: u32, height: u32, quality: u8, most_px: u32, least_px: u32) -> Self {
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

    fn len(&self) -> usize {
        self.cols as usize * self.rows as usize
    }

    /// Tile width in pixels (the last column may be cut by the image edge).
    fn tile_px(&self) -> u32 {
        self.blocks * self.mcu
    }

    /// Pixel columns and rows of tile `i` (row-major), cut at the image edge.
    fn tile(&self, i: usize) -> (Range<u32>, Range<u32>) {
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
    fn whole(&self, i: usize) -> bool {
        let (x, y) = self.tile(i);
        x.len() as u32 == self.tile_px() && y.len() as u32 == self.mcu
    }

    /// Mark the tiles that `area` touches.
    fn mark(&self, area: &Area, marks: &mut [bool]) {
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

/// Why a JPEG could not be made.
#[derive(Debug, thiserror::Error)]
pub enum JpegError {
    #[error("{width}×{height} is outside JPEG's 1–65535 px sides")]
    Sides { width: u32, height: u32 },
    #[error("{len} bytes is not a {width}×{height} RGBA8 image")]
    NotRgba { len: usize, width: u32, height: u32 },
    #[error("{len} bytes do not hold {width}×{height} RGBX pixels")]
    NotRgbx { len: usize, width: u32, height: u32 },
    #[error("side {0} exceeds JPEG's 65535")]
    Side(u32),
    /// A size that does not fit libjpeg-turbo's C `int`.
    #[error(transparent)]
    Int(#[from] std::num::TryFromIntError),
    /// libjpeg-turbo's own message.
    #[error("{0}")]
    Library(String),
    #[error("libjpeg-turbo wrote {segments} restart segments for {tiles} tiles")]
    Segments { segments: usize, tiles: usize },
    /// libjpeg-turbo wrote a JPEG the tile reuse cannot split.
    #[error("unexpected JPEG from libjpeg-turbo: {0}")]
    Unexpected(&'static str),
}

/// Compress the whole `width`×`height` RGBA image (alpha ignored).
pub fn compress(rgba: &[u8], width: u32, height: u32, quality: u8) -> Result<Vec<u8>, JpegError> {
    check(rgba, width, height)?;
    compress_grid(rgba, &Grid::new(width, height, quality), quality)
}

fn compress_grid(rgba: &[u8], grid: &Grid, quality: u8) -> Result<Vec<u8>, JpegError> {
    let stride = grid.width as usize * 4;
    tj::Compressor::new(quality, grid.blocks)?.compress(rgba, grid.width, stride, grid.height)
}

fn check(rgba: &[u8], width: u32, height: u32) -> Result<(), JpegError> {
    if width == 0 || height == 0 || width > 65_535 || height > 65_535 {
        return Err(JpegError::Sides { width, height });
    }
    check_rgba(rgba, width, height)
}

/// That `rgba` holds exactly `width`×`height` RGBA8 pixels (every format's check).
pub(super) fn check_rgba(rgba: &[u8], width: u32, height: u32) -> Result<(), JpegError> {
    if (width as usize)
        .checked_mul(height as usize)
        .and_then(|n| n.checked_mul(4))
        != Some(rgba.len())
    {
        return Err(JpegError::NotRgba {
            len: rgba.len(),
            width,
            height,
        });
    }
    Ok(())
}

/// A pixel rectangle, `x` × `y` (half-open ranges).
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Area {
    pub x: Range<u32>,
    pub y: Range<u32>,
}

/// What a frame shares with others: everywhere outside the `changed`
/// areas, its pixels are exactly those of every frame with the same
/// `background` key (a key names one picture, never reused for another).
#[derive(Clone, Copy, Debug)]
pub struct Unchanged<'a> {
    pub background: u64,
    pub changed: &'a [Area],
}

/// Backgrounds whose tiles are kept (a batch moves through its camera poses
/// in order; frames in flight span at most a few).
const KEPT_BACKGROUNDS: usize = 4;

/// A JPEG encoder for one quality that reuses compressed tiles of shared
/// backgrounds across frames and threads.
pub struct JpegEncoder {
    quality: u8,
    /// Tile size bounds in pixels ([`Grid::sized`]); the defaults but in tests.
    tile_px: (u32, u32),
    kept: Mutex<Vec<Arc<Tiles>>>,
}

/// The compressed tiles of one background at one size.
struct Tiles {
    background: u64,
    grid: Grid,
    /// Everything before the first segment (SOI … SOS), for the whole image.
    header: Mutex<Option<Arc<[u8]>>>,
    /// Per tile, its segment once a frame has shown the tile unpainted.
    segments: Mutex<Vec<Option<Arc<[u8]>>>>,
}

impl JpegEncoder {
    pub fn new(quality: u8) -> Self {
        Self {
            quality,
            tile_px: (TILE_PX, MIN_TILE_PX),
            kept: Mutex::new(Vec::new()),
        }
    }

    fn grid(&self, width: u32, height: u32) -> Grid {
        Grid::sized(width, height, self.quality, self.tile_px.0, self.tile_px.1)
    }

    /// Encode a frame; with `unchanged`, tiles outside its changed areas
    /// are taken from earlier frames over the same background when known.
    /// The bytes are those of [`compress`] either way.
    pub fn encode(
        &self,
        rgba: &[u8],
        width: u32,
        height: u32,
        unchanged: Option<Unchanged<'_>>,
    ) -> Result<Vec<u8>, JpegError> {
        check(rgba, width, height)?;
        let grid = self.grid(width, height);
        let Some(unchanged) = unchanged.filter(|u| u.background != 0) else {
            return compress_grid(rgba, &grid, self.quality);
        };
        let tiles = self.tiles(unchanged.background, grid);
        let mut painted = vec![false; grid.len()];
        for area in unchanged.changed {
            grid.mark(area, &mut painted);
        }
        // Tiles to compress: painted ones, and clean ones not yet kept.
        let mut segments: Vec<Option<Arc<[u8]>>> = {
            let kept = tiles
                .segments
                .lock()
                .unwrap_or_else(PoisonError::into_inner);
            kept.iter()
                .zip(&painted)
                .map(|(s, &p)| if p { None } else { s.clone() })
                .collect()
        };
        let mut header = tiles
            .header
            .lock()
            .unwrap_or_else(PoisonError::into_inner)
            .clone();
        let mut compressor = None;
        for piece in plan(&grid, &segments) {
            let c = match &mut compressor {
                Some(c) => c,
                None => compressor.insert(tj::Compressor::new(self.quality, grid.blocks)?),
            };
            let jpeg = match &piece.crop {
                Some((x, y)) => {
                    let stride = width as usize * 4;
                    let at = y.start as usize * stride + x.start as usize * 4;
                    c.compress(&rgba[at..], x.len() as u32, stride, y.len() as u32)?
                }
                None => {
                    let stack = stack_tiles(rgba, &grid, &piece.tiles);
                    let h = piece.tiles.len() as u32 * grid.mcu;
                    c.compress(&stack, grid.tile_px(), grid.tile_px() as usize * 4, h)?
                }
            };
            let scan = Scan::parse(&jpeg)?;
            if scan.segments.len() != piece.tiles.len() {
                return Err(JpegError::Segments {
                    segments: scan.segments.len(),
                    tiles: piece.tiles.len(),
                });
            }
            if header.is_none() {
                header = Some(scan.header_for(&jpeg, width, height)?.into());
            }
            let mut kept = tiles
                .segments
                .lock()
                .unwrap_or_else(PoisonError::into_inner);
            for (&i, range) in piece.tiles.iter().zip(scan.segments) {
                let segment: Arc<[u8]> = jpeg[range].into();
                if !painted[i] {
                    kept[i] = Some(segment.clone());
                }
                segments[i] = Some(segment);
            }
        }
        let header = header.ok_or(JpegError::Unexpected("no header was made"))?;
        tiles
            .header
            .lock()
            .unwrap_or_else(PoisonError::into_inner)
            .get_or_insert_with(|| header.clone());
        let size = header.len()
            + segments
                .iter()
                .flatten()
                .map(|s| s.len() + 2)
                .sum::<usize>();
        let mut out = Vec::with_capacity(size);
        out.extend_from_slice(&header);
        for (i, segment) in segments.iter().enumerate() {
            if i > 0 {
                out.extend_from_slice(&[0xFF, 0xD0 + ((i - 1) % 8) as u8]);
            }
            out.extend_from_slice(segment.as_deref().unwrap_or_default());
        }
        out.extend_from_slice(&[0xFF, 0xD9]);
        Ok(out)
    }

    /// The kept tiles of `background` at this grid (made empty when new).
    fn tiles(&self, background: u64, grid: Grid) -> Arc<Tiles> {
        let mut kept = self.kept.lock().unwrap_or_else(PoisonError::into_inner);
        if let Some(t) = kept
            .iter()
            .find(|t| t.background == background && t.grid == grid)
        {
            return t.clone();
        }
        if kept.len() >= KEPT_BACKGROUNDS {
            kept.remove(0);
        }
        let tiles = Arc::new(Tiles {
            background,
            grid,
            header: Mutex::new(None),
            segments: Mutex::new(vec![None; grid.len()]),
        });
        kept.push(tiles.clone());
        tiles
    }
}

/// One compression that makes some missing tiles: a crop of the frame
/// (`x`, `y`), whose segments are `tiles` in order, or (`None`) a stack of
/// whole tiles, one per MCU row of a `tile_px`-wide image.
struct Piece {
    tiles: Vec<usize>,
    crop: Option<(Range<u32>, Range<u32>)>,
}

/// Most tiles stacked into one image (its height stays within JPEG's 65535).
const MAX_STACK: usize = 2048;

/// The compressions that make the tiles `have` lacks: runs of wholly
/// missing MCU rows straight from the frame; tiles cut by the image's edge
/// (their dummy blocks depend on where that edge is) as crops that reach
/// it; every other missing tile stacked.
fn plan(grid: &Grid, have: &[Option<Arc<[u8]>>]) -> Vec<Piece> {
    let (cols, rows) = (grid.cols as usize, grid.rows as usize);
    let row_missing = |r: usize| have[r * cols..(r + 1) * cols].iter().all(Option::is_none);
    let mut pieces = Vec::new();
    let mut stacked = Vec::new();
    let mut r = 0;
    while r < rows {
        if row_missing(r) {
            let end = (r..rows).find(|&e| !row_missing(e)).unwrap_or(rows);
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
fn stack_tiles(rgba: &[u8], grid: &Grid, tiles: &[usize]) -> Vec<u8> {
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

/// A baseline JPEG split at its restart markers.
struct Scan {
    /// Bytes before the first segment.
    header: Range<usize>,
    /// Offset of the SOF0 frame header's height field (the width follows).
    height_at: usize,
    /// Each restart interval's entropy-coded bytes (markers excluded).
    segments: Vec<Range<usize>>,
}

impl Scan {
    fn parse(jpeg: &[u8]) -> Result<Self, JpegError> {
        let bad = JpegError::Unexpected;
        if jpeg.get(..2) != Some(&[0xFF, 0xD8]) {
            return Err(bad("no SOI"));
        }
        let mut at = 2;
        let mut height_at = None;
        // Marker segments up to and including SOS.
        loop {
            let (Some(&0xFF), Some(&marker)) = (jpeg.get(at), jpeg.get(at + 1)) else {
                return Err(bad("marker expected"));
            };
            let len = jpeg
                .get(at + 2..at + 4)
                .map(|b| usize::from(u16::from_be_bytes([b[0], b[1]])))
                .ok_or_else(|| bad("truncated marker"))?;
            if marker == 0xC0 {
                if len < 8 {
                    return Err(bad("short SOF0"));
                }
                height_at = Some(at + 5);
            } else if (0xC1..=0xCF).contains(&marker)
                && marker != 0xC4
                && marker != 0xC8
                && marker != 0xCC
            {
                return Err(bad("not baseline"));
            }
            at += 2 + len;
            if marker == 0xDA {
                break;
            }
        }
        let height_at = height_at.ok_or_else(|| bad("no SOF0"))?;
        let header = 0..at;
        let mut segments = Vec::new();
        let mut start = at;
        let mut i = at;
        loop {
            let Some(p) = jpeg
                .get(i..)
                .and_then(|rest| rest.iter().position(|&b| b == 0xFF))
            else {
                return Err(bad("no EOI"));
            };
            i += p;
            match jpeg.get(i + 1) {
                Some(0x00) => i += 2,
                Some(m @ 0xD0..=0xD7) => {
                    if usize::from(m - 0xD0) != segments.len() % 8 {
                        return Err(bad("restart markers out of order"));
                    }
                    segments.push(start..i);
                    i += 2;
                    start = i;
                }
                Some(0xD9) => {
                    segments.push(start..i);
                    if i + 2 != jpeg.len() {
                        return Err(bad("data after EOI"));
                    }
                    break;
                }
                _ => return Err(bad("stray marker in the scan")),
            }
        }
        Ok(Self {
            header,
            height_at,
            segments,
        })
    }

    /// The header with the frame size set to `width`×`height` (nothing
    /// else in a baseline header depends on the size).
    fn header_for(&self, jpeg: &[u8], width: u32, height: u32) -> Result<Vec<u8>, JpegError> {
        let mut header = jpeg[self.header.clone()].to_vec();
        let side = |v: u32| u16::try_from(v).map_err(|_| JpegError::Side(v));
        let at = self.height_at;
        header[at..at + 2].copy_from_slice(&side(height)?.to_be_bytes());
        header[at + 2..at + 4].copy_from_slice(&side(width)?.to_be_bytes());
        Ok(header)
    }
}

/// The one place that calls TurboJPEG's C API directly: the `turbojpeg`
/// crate's `Compressor` does not expose the restart interval.
#[allow(unsafe_code)]
mod tj {
    use std::ffi::{CStr, c_int};

    use turbojpeg::raw;

    use super::JpegError;

    /// A TurboJPEG compressor set up as [`super::compress`] describes.
    pub struct Compressor {
        handle: raw::tjhandle,
    }

    impl Drop for Compressor {
        fn drop(&mut self) {
            // SAFETY: `handle` came from `tj3Init`, is not null, and is destroyed once.
            unsafe { raw::tj3Destroy(self.handle) };
        }
    }

    impl Compressor {
        /// A restart marker every `blocks` MCUs.
        pub fn new(quality: u8, blocks: u32) -> Result<Self, JpegError> {
            // SAFETY: plain constructor; a null result is handled below.
            let handle = unsafe { raw::tj3Init(raw::TJINIT_TJINIT_COMPRESS as c_int) };
            if handle.is_null() {
                return Err(JpegError::Library(
                    "libjpeg-turbo could not make a compressor".into(),
                ));
            }
            let c = Self { handle };
            let subsamp = if super::subsampled(quality) {
                raw::TJSAMP_TJSAMP_420
            } else {
                raw::TJSAMP_TJSAMP_444
            };
            c.set(raw::TJPARAM_TJPARAM_QUALITY, i32::from(quality))?;
            c.set(raw::TJPARAM_TJPARAM_SUBSAMP, subsamp)?;
            let blocks = i32::try_from(blocks)?;
            c.set(raw::TJPARAM_TJPARAM_RESTARTBLOCKS, blocks)?;
            Ok(c)
        }

        fn set(&self, param: raw::TJPARAM, value: i32) -> Result<(), JpegError> {
            // SAFETY: a live handle; TurboJPEG validates the parameter and value.
            if unsafe { raw::tj3Set(self.handle, param as c_int, value) } != 0 {
                return Err(self.error());
            }
            Ok(())
        }

        fn error(&self) -> JpegError {
            // SAFETY: a live handle; the string is owned by TurboJPEG and copied at once.
            let message = unsafe { CStr::from_ptr(raw::tj3GetErrorStr(self.handle)) };
            JpegError::Library(message.to_string_lossy().into_owned())
        }

        /// Compress `height` rows of `width` RGBX pixels, rows `pitch` bytes apart.
        pub fn compress(
            &mut self,
            pixels: &[u8],
            width: u32,
            pitch: usize,
            height: u32,
        ) -> Result<Vec<u8>, JpegError> {
            let needed = (height as usize)
                .checked_sub(1)
                .and_then(|rows| rows.checked_mul(pitch))
                .and_then(|n| n.checked_add(width as usize * 4));
            if needed.is_none_or(|n| pixels.len() < n) || pitch < width as usize * 4 {
                return Err(JpegError::NotRgbx {
                    len: pixels.len(),
                    width,
                    height,
                });
            }
            let (w, p, h) = (
                c_int::try_from(width)?,
                c_int::try_from(pitch)?,
                c_int::try_from(height)?,
            );
            let mut buf: *mut u8 = std::ptr::null_mut();
            let mut size: raw::size_t = 0;
            // SAFETY: `pixels` holds `height` rows of `pitch` bytes (checked
            // above) and outlives the call; TurboJPEG allocates `buf` itself
            // (NOREALLOC is off by default) and we free it below.
            let res = unsafe {
                raw::tj3Compress8(
                    self.handle,
                    pixels.as_ptr(),
                    w,
                    p,
                    h,
                    raw::TJPF_TJPF_RGBX,
                    &mut buf,
                    &mut size,
                )
            };
            let out = if res == 0 && !buf.is_null() {
                // SAFETY: on success `buf` points to `size` bytes TurboJPEG wrote.
                Ok(unsafe { std::slice::from_raw_parts(buf, size as usize) }.to_vec())
            } else {
                Err(self.error())
            };
            if !buf.is_null() {
                // SAFETY: `buf` was allocated by TurboJPEG and is freed once.
                unsafe { raw::tj3Free(buf.cast()) };
            }
            out
        }
    }
}

#[cfg(test)]
#[allow(clippy::unwrap_used)]
mod tests {
    use super::*;

    /// A sky-like gradient with noise and some dark blobs (deterministic).
    fn picture(width: u32, height: u32, seed: u32, blobs: &[(u32, u32, u32, u32)]) -> Vec<u8> {
        let mut state = 0x9e37_79b9_u32 ^ seed;
        let mut rgba = Vec::with_capacity((width * height * 4) as usize);
        for y in 0..height {
            for x in 0..width {
                state ^= state << 13;
                state ^= state >> 17;
                state ^= state << 5;
                let n = (state % 7) as i32 - 3;
                let inside = blobs
                    .iter()
                    .any(|&(x0, y0, x1, y1)| (x0..x1).contains(&x) && (y0..y1).contains(&y));
                let base = if inside {
                    [30 + (x * 7 % 50) as i32, 32, 38]
                } else {
                    [
                        90 + (y * 120 / height) as i32,
                        150,
                        230 - (x * 20 / width) as i32,
                    ]
                };
                rgba.extend(base.map(|c| (c + n).clamp(0, 255) as u8));
                rgba.push(255);
            }
        }
        rgba
    }

    /// The areas of blobs (x0, y0, x1, y1).
    fn areas(blobs: &[(u32, u32, u32, u32)]) -> Vec<Area> {
        blobs
            .iter()
            .map(|&(x0, y0, x1, y1)| Area {
                x: x0..x1,
                y: y0..y1,
            })
            .collect()
    }

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

    #[test]
    fn reused_tiles_give_the_bytes_of_a_whole_compress() {
        // Odd sizes (bottom MCU row partly padded, right edge padded), both
        // chroma modes, whole-row and tiled grids.
        for (width, height, quality) in [
            (333, 157, 85),
            (256, 64, 85),
            (200, 91, 95),
            (64, 16, 75),
            (1000, 70, 85),
            (1000, 64, 95),
        ] {
            let encoder = JpegEncoder::new(quality);
            let frames: Vec<Vec<(u32, u32, u32, u32)>> = vec![
                vec![(10, 3, 40, 30)],
                vec![(100, 40, 140, 60), (5, height - 9, 30, height)],
                vec![],
                vec![(0, 0, width, 5)],
                vec![(width - 10, 20, width, 50)],
            ];
            for (k, blobs) in frames.iter().enumerate() {
                let blobs: Vec<_> = blobs
                    .iter()
                    .map(|&(x0, y0, x1, y1)| {
                        (x0.min(width), y0.min(height), x1.min(width), y1.min(height))
                    })
                    .collect();
                let blobs = &blobs;
                // Outside its blobs each frame is the same background (seed 7
                // draws the same noise only where both agree, so use a fixed
                // background and paint the blobs over it).
                let mut rgba = picture(width, height, 7, &[]);
                let painted = picture(width, height, 100 + k as u32, blobs);
                let changed = areas(blobs);
                for &(x0, y0, x1, y1) in blobs {
                    for y in y0..y1 {
                        let row = (y * width) as usize * 4;
                        rgba[row + x0 as usize * 4..row + x1 as usize * 4].copy_from_slice(
                            &painted[row + x0 as usize * 4..row + x1 as usize * 4],
                        );
                    }
                }
                let whole = compress(&rgba, width, height, quality).unwrap();
                let reused = encoder
                    .encode(
                        &rgba,
                        width,
                        height,
                        Some(Unchanged {
                            background: 42,
                            changed: &changed,
                        }),
                    )
                    .unwrap();
                assert!(
                    whole == reused,
                    "{width}×{height} q{quality} frame {k}: bytes differ"
                );
                let decoded = image::load_from_memory(&whole).unwrap().to_rgb8();
                assert_eq!(decoded.dimensions(), (width, height));
            }
            // Tiles kept for background 42: every tile was clean in some frame.
            let tiles = encoder.tiles(42, encoder.grid(width, height));
            let kept = tiles.segments.lock().unwrap();
            assert!(
                kept.iter().all(Option::is_some),
                "{width}×{height}: tiles never kept"
            );
        }
    }

    proptest::proptest! {
        #![proptest_config(proptest::prelude::ProptestConfig::with_cases(24))]
        /// Any size, quality, tile size and sequence of painted areas over
        /// one background: the spliced bytes are those of a whole compress
        /// with the same grid.
        #[test]
        fn any_painted_areas_give_the_whole_compress(
            width in 1u32..140,
            height in 1u32..90,
            quality in proptest::sample::select(vec![40u8, 85, 89, 90, 100]),
            frames in proptest::collection::vec(
                proptest::collection::vec((0u32..100, 0u32..100, 1u32..40, 1u32..30), 0..4),
                1..5,
            ),
            tile_px in proptest::sample::select(vec![(8u32, 8u32), (32, 16), (48, 16), (256, 64)]),
        ) {
            let encoder = JpegEncoder { tile_px, ..JpegEncoder::new(quality) };
            let grid = encoder.grid(width, height);
            let background = picture(width, height, 9, &[]);
            for (k, blobs) in frames.iter().enumerate() {
                let blobs: Vec<(u32, u32, u32, u32)> = blobs
                    .iter()
                    .map(|&(x, y, w, h)| {
                        let (x0, y0) = (x % width, y % height);
                        (x0, y0, (x0 + w).min(width), (y0 + h).min(height))
                    })
                    .collect();
                let painted = picture(width, height, 50 + k as u32, &blobs);
                let mut rgba = background.clone();
                for &(x0, y0, x1, y1) in &blobs {
                    for y in y0..y1 {
                        let row = (y * width) as usize * 4;
                        let (a, b) = (row + x0 as usize * 4, row + x1 as usize * 4);
                        rgba[a..b].copy_from_slice(&painted[a..b]);
                    }
                }
                let changed = areas(&blobs);
                let reused = encoder
                    .encode(&rgba, width, height, Some(Unchanged { background: 3, changed: &changed }))
                    .unwrap();
                proptest::prop_assert!(reused == compress_grid(&rgba, &grid, quality).unwrap());
            }
        }
    }

    #[test]
    fn a_wrong_key_would_show_stale_tiles() {
        // The reuse is real: claiming a background the frame does not hold
        // gives the old tiles back (so the tests above check something).
        let (width, height) = (96, 64);
        let encoder = JpegEncoder::new(85);
        let a = picture(width, height, 1, &[]);
        let b = picture(width, height, 2, &[(0, 0, width, height)]);
        let unchanged = Some(Unchanged {
            background: 5,
            changed: &[],
        });
        let first = encoder.encode(&a, width, height, unchanged).unwrap();
        let stale = encoder.encode(&b, width, height, unchanged).unwrap();
        assert_eq!(first, stale);
        assert_ne!(stale, compress(&b, width, height, 85).unwrap());
    }

    #[test]
    fn restart_segments_are_the_grids_tiles() {
        let jpeg = compress(&picture(48, 40, 3, &[]), 48, 40, 85).unwrap();
        let scan = Scan::parse(&jpeg).unwrap();
        assert_eq!(scan.segments.len(), 3);
        let jpeg = compress(&picture(48, 40, 3, &[]), 48, 40, 95).unwrap();
        assert_eq!(Scan::parse(&jpeg).unwrap().segments.len(), 5);
        // 1000 px at 4:2:0: 3 tiles a row, 5 rows.
        let jpeg = compress(&picture(1000, 70, 3, &[]), 1000, 70, 85).unwrap();
        assert_eq!(Scan::parse(&jpeg).unwrap().segments.len(), 15);
    }

    #[test]
    fn bad_sizes_are_named() {
        let short = compress(&[0; 12], 2, 2, 85).unwrap_err();
        assert!(matches!(short, JpegError::NotRgba { len: 12, .. }));
        assert!(short.to_string().contains("RGBA8"));
        let empty = compress(&[], 0, 2, 85).unwrap_err();
        assert!(matches!(
            empty,
            JpegError::Sides {
                width: 0,
                height: 2
            }
        ));
        assert!(empty.to_string().contains("1–65535"));
    }
}

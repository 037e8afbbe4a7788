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
//! The tiles a frame lacks are compressed in bands of MCU rows of about
//! [`BAND_PX`] pixels (any cut along tile boundaries gives the same
//! segments), and the encoder gives way to other threads between bands: a
//! whole 1080p frame is ~4 ms of one core, and a batch's encoder, woken by
//! the frame maker it then displaces, would otherwise keep the maker off its
//! core for all of it while the kernel leaves the other core idle
//! (docs/benchmarks.md, "Moving against fixed").
//!
//! The output is the same bytes whichever tiles were reused, and the same as
//! [`compress`] of the whole frame: deterministic, on every machine (the
//! accurate integer DCT gives the same coefficients on its SIMD and C paths).
//!
//! This file holds the encoder and its tile store; `grid.rs` how an image
//! is cut into tiles, `plan.rs` the compressions that make the missing
//! tiles, `scan.rs` a JPEG split at its restart markers, `tj.rs` the
//! libjpeg-turbo calls.

use std::cell::RefCell;
use std::ops::Range;
use std::sync::{Arc, Mutex, PoisonError};

mod grid;
mod plan;
mod scan;
#[allow(unsafe_code)]
mod tj;

use grid::{Grid, MIN_TILE_PX, TILE_PX};
use plan::{plan, stack_tiles};
use scan::Scan;

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
    compress_grid(rgba, &Grid::new(width, height, quality), (quality, false))
}

fn compress_grid(
    rgba: &[u8],
    grid: &Grid,
    (quality, grey): (u8, bool),
) -> Result<Vec<u8>, JpegError> {
    let stride = grid.width as usize * 4;
    let mut c = tj::Compressor::new(quality, grid.blocks, grey)?;
    if grey {
        // R = G = B: the red bytes are the grey plane the colour conversion
        // would give (its luma weights sum to one), handed over as is.
        return GREY.with_borrow_mut(|plane| {
            plane.clear();
            plane.extend(rgba.chunks_exact(4).map(|px| px[0]));
            c.compress_grey(plane, grid.width, grid.height)
        });
    }
    c.compress(rgba, grid.width, stride, grid.height)
}

thread_local! {
    /// The grey plane handed to libjpeg-turbo, kept per thread: a fresh one
    /// each frame (2 MB at 1080p) costs its pages again.
    static GREY: RefCell<Vec<u8>> = const { RefCell::new(Vec::new()) };
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

/// Pixels per band of a frame's compression (about 0.3 ms of one core),
/// between which the encoder yields ([`JpegEncoder::encode`]).
pub const BAND_PX: u64 = 1 << 17;

/// Backgrounds whose tiles are kept (a batch moves through its camera poses
/// in order; frames in flight span at most a few).
const KEPT_BACKGROUNDS: usize = 4;

/// A JPEG encoder for one quality that reuses compressed tiles of shared
/// backgrounds across frames and threads.
pub struct JpegEncoder {
    quality: u8,
    /// One channel (grey pictures; no tiles are reused).
    grey: bool,
    /// Tile size bounds in pixels ([`Grid::sized`]); the defaults but in tests.
    tile_px: (u32, u32),
    /// Pixels per band ([`BAND_PX`]; smaller in tests).
    band_px: u64,
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
            grey: false,
            tile_px: (TILE_PX, MIN_TILE_PX),
            band_px: BAND_PX,
            kept: Mutex::new(Vec::new()),
        }
    }

    /// An encoder of grey pictures (R = G = B) as one-channel JPEG: a
    /// third of the blocks, and a reader decodes the same grey.
    pub fn grey(quality: u8) -> Self {
        Self {
            grey: true,
            ..Self::new(quality)
        }
    }

    fn grid(&self, width: u32, height: u32) -> Grid {
        Grid::sized(width, height, self.quality, self.tile_px.0, self.tile_px.1)
    }

    /// Encode a frame; with `unchanged`, tiles outside its changed areas
    /// are taken from earlier frames over the same background when known.
    /// The bytes are those of [`compress`] either way. The missing tiles are
    /// compressed band by band ([`plan`]), with a yield to the threads
    /// waiting for this core between bands.
    pub fn encode(
        &self,
        rgba: &[u8],
        width: u32,
        height: u32,
        unchanged: Option<Unchanged<'_>>,
    ) -> Result<Vec<u8>, JpegError> {
        check(rgba, width, height)?;
        let grid = self.grid(width, height);
        if self.grey {
            return compress_grid(rgba, &grid, (self.quality, true));
        }
        let reuse = unchanged.filter(|u| u.background != 0).map(|u| {
            let mut painted = vec![false; grid.len()];
            for area in u.changed {
                grid.mark(area, &mut painted);
            }
            (self.tiles(u.background, grid), painted)
        });
        // Tiles to compress: painted ones, and clean ones not yet kept.
        let (mut segments, mut header) = match &reuse {
            Some((tiles, painted)) => {
                let kept = lock(&tiles.segments);
                let have = kept.iter().zip(painted);
                let have = have.map(|(s, &p)| if p { None } else { s.clone() });
                (have.collect(), lock(&tiles.header).clone())
            }
            None => (vec![None; grid.len()], None),
        };
        let mut compressor = None;
        let pieces = plan(&grid, &segments, self.band_px);
        for (k, piece) in pieces.iter().enumerate() {
            if k > 0 {
                std::thread::yield_now();
            }
            let c = match &mut compressor {
                Some(c) => c,
                None => compressor.insert(tj::Compressor::new(self.quality, grid.blocks, false)?),
            };
            let jpeg = compress_piece(c, rgba, &grid, piece)?;
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
            let mut kept = reuse.as_ref().map(|(t, p)| (lock(&t.segments), p));
            for (&i, range) in piece.tiles.iter().zip(scan.segments) {
                let segment: Arc<[u8]> = jpeg[range].into();
                if let Some((kept, painted)) = &mut kept
                    && !painted[i]
                {
                    kept[i] = Some(segment.clone());
                }
                segments[i] = Some(segment);
            }
        }
        let header = header.ok_or(JpegError::Unexpected("no header was made"))?;
        if let Some((tiles, _)) = &reuse {
            lock(&tiles.header).get_or_insert_with(|| header.clone());
        }
        Ok(splice(&header, &segments))
    }

    /// The kept tiles of `background` at this grid (made empty when new).
    fn tiles(&self, background: u64, grid: Grid) -> Arc<Tiles> {
        let mut kept = lock(&self.kept);
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

/// `m` locked, poisoned or not (the tiles are plain bytes, never left half-written).
fn lock<T>(m: &Mutex<T>) -> std::sync::MutexGuard<'_, T> {
    m.lock().unwrap_or_else(PoisonError::into_inner)
}

/// One compression of [`plan`]: a crop of the frame, or its tiles stacked.
fn compress_piece(
    c: &mut tj::Compressor,
    rgba: &[u8],
    grid: &Grid,
    piece: &plan::Piece,
) -> Result<Vec<u8>, JpegError> {
    match &piece.crop {
        Some((x, y)) => {
            let stride = grid.width as usize * 4;
            let at = y.start as usize * stride + x.start as usize * 4;
            c.compress(&rgba[at..], x.len() as u32, stride, y.len() as u32)
        }
        None => {
            let stack = stack_tiles(rgba, grid, &piece.tiles);
            let h = piece.tiles.len() as u32 * grid.mcu;
            c.compress(&stack, grid.tile_px(), grid.tile_px() as usize * 4, h)
        }
    }
}

/// The JPEG of `header` and every tile's segment, restart markers between.
fn splice(header: &[u8], segments: &[Option<Arc<[u8]>>]) -> Vec<u8> {
    let size = header.len()
        + segments
            .iter()
            .flatten()
            .map(|s| s.len() + 2)
            .sum::<usize>();
    let mut out = Vec::with_capacity(size);
    out.extend_from_slice(header);
    for (i, segment) in segments.iter().enumerate() {
        if i > 0 {
            out.extend_from_slice(&[0xFF, 0xD0 + ((i - 1) % 8) as u8]);
        }
        out.extend_from_slice(segment.as_deref().unwrap_or_default());
    }
    out.extend_from_slice(&[0xFF, 0xD9]);
    out
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
            band_px in proptest::sample::select(vec![1u64, 2000, BAND_PX]),
        ) {
            let encoder = JpegEncoder { tile_px, band_px, ..JpegEncoder::new(quality) };
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
                proptest::prop_assert!(reused == compress_grid(&rgba, &grid, (quality, false)).unwrap());
            }
        }
    }

    #[test]
    fn a_frame_compressed_in_bands_is_the_whole_compress() {
        // 1920×1080 at q85: 68 MCU rows of 16 px, so BAND_PX makes 17
        // bands of 4 rows (the last one cut by the image's edge);
        // bands of one row each and a 4:4:4 quality as well. With and
        // without a background to keep tiles of, and again once every tile
        // is kept.
        let (width, height) = (1920, 1080);
        let rgba = picture(width, height, 5, &[(300, 200, 420, 260)]);
        for (quality, band_px) in [(85, BAND_PX), (85, 1), (95, BAND_PX)] {
            let encoder = JpegEncoder {
                band_px,
                ..JpegEncoder::new(quality)
            };
            let grid = encoder.grid(width, height);
            let pieces = plan(&grid, &vec![None; grid.len()], band_px);
            let rows = |p: &plan::Piece| p.crop.as_ref().map_or(0, |(_, y)| y.len() as u64);
            assert!(pieces.len() > 1, "q{quality}: one piece");
            assert!(
                pieces
                    .iter()
                    .all(|p| rows(p) * u64::from(width) <= band_px.max(16 * 1920)),
                "q{quality}: a band over {band_px} px"
            );
            let tiles: Vec<usize> = pieces.iter().flat_map(|p| p.tiles.clone()).collect();
            assert_eq!(tiles, (0..grid.len()).collect::<Vec<_>>());
            let whole = compress(&rgba, width, height, quality).unwrap();
            let changed = areas(&[(300, 200, 420, 260)]);
            let unchanged = Unchanged {
                background: 11,
                changed: &changed,
            };
            for frame in [None, Some(unchanged), Some(unchanged)] {
                let banded = encoder.encode(&rgba, width, height, frame).unwrap();
                assert!(
                    banded == whole,
                    "q{quality}, {band_px} px bands: bytes differ"
                );
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
    fn a_grey_picture_as_one_channel_decodes_to_the_colour_jpegs_grey() {
        let (width, height) = (200, 91);
        let rgba: Vec<u8> = (picture(width, height, 4, &[(10, 10, 60, 40)]).chunks_exact(4))
            .flat_map(|p| [p[1], p[1], p[1], 255])
            .collect();
        for quality in [75u8, 95] {
            let colour = compress(&rgba, width, height, quality).unwrap();
            let unchanged = Some(Unchanged {
                background: 9,
                changed: &[],
            });
            let grey = JpegEncoder::grey(quality)
                .encode(&rgba, width, height, unchanged)
                .unwrap();
            assert!(grey.len() < colour.len(), "q{quality}");
            // The grey plane handed over gives the bytes of libjpeg-turbo's
            // own conversion of the RGBA pixels to one channel.
            let grid = Grid::new(width, height, quality);
            let mut c = tj::Compressor::new(quality, grid.blocks, true).unwrap();
            let converted = c.compress(&rgba, width, width as usize * 4, height);
            assert_eq!(grey, converted.unwrap(), "q{quality}");
            let colour = image::load_from_memory(&colour).unwrap().to_rgb8();
            let grey = image::load_from_memory(&grey).unwrap();
            assert!(matches!(grey, image::DynamicImage::ImageLuma8(_)));
            let want: Vec<u8> = colour.pixels().map(|p| p[0]).collect();
            assert!(colour.pixels().all(|p| p[0] == p[1] && p[1] == p[2]));
            assert_eq!(grey.to_luma8().into_raw(), want, "q{quality}");
        }
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

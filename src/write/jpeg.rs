//! JPEG through libjpeg-turbo, with a restart marker after every row of
//! MCUs, so a frame that repaints only a few rows over a background
//! reuses the compressed rows of the others.
//!
//! A baseline JPEG with a restart interval of one MCU row is a header and
//! one entropy-coded segment per MCU row (16 pixel rows at 4:2:0, 8 at
//! 4:4:4), separated by `RST0`…`RST7` markers; each segment starts with
//! fresh DC predictors and byte-aligned, so it depends on the pixels of its
//! row alone. Colour conversion, 2×2 chroma averaging, the DCT and the
//! bottom/right edge padding are all local to a row too, so compressing a
//! strip of rows yields exactly the segments compressing the whole image
//! yields for them (`tests` below compare the bytes). [`JpegEncoder`]
//! therefore keeps, per background, the segments of rows no drone touched
//! and compresses only the rows a frame painted (and rows it has not seen
//! clean yet): on the quickstart's 4K twin, a fraction of the image.
//!
//! The output is the same bytes whichever rows were reused, and the same as
//! [`compress`] of the whole frame: deterministic, on every machine (the
//! accurate integer DCT gives the same coefficients on its SIMD and C paths).

use std::ops::Range;
use std::sync::{Arc, Mutex, PoisonError};

/// Chroma subsampling for a quality: 4:2:0 below 90, 4:4:4 from 90 up.
fn subsampled(quality: u8) -> bool {
    quality < 90
}

/// Height in pixels of one MCU row.
fn mcu_rows(quality: u8) -> u32 {
    if subsampled(quality) { 16 } else { 8 }
}

/// Compress the whole `width`×`height` RGBA image (alpha ignored).
pub fn compress(rgba: &[u8], width: u32, height: u32, quality: u8) -> Result<Vec<u8>, String> {
    check(rgba, width, height)?;
    tj::Compressor::new(quality)?.compress(rgba, width, width as usize * 4, height)
}

fn check(rgba: &[u8], width: u32, height: u32) -> Result<(), String> {
    if width == 0 || height == 0 || width > 65_535 || height > 65_535 {
        return Err(format!(
            "{width}×{height} is outside JPEG's 1–65535 px sides"
        ));
    }
    check_rgba(rgba, width, height)
}

/// That `rgba` holds exactly `width`×`height` RGBA8 pixels (every format's check).
pub(super) fn check_rgba(rgba: &[u8], width: u32, height: u32) -> Result<(), String> {
    if (width as usize)
        .checked_mul(height as usize)
        .and_then(|n| n.checked_mul(4))
        != Some(rgba.len())
    {
        return Err(format!(
            "{} bytes is not a {width}×{height} RGBA8 image",
            rgba.len()
        ));
    }
    Ok(())
}

/// What a frame shares with others: everywhere outside `changed` (pixel row
/// ranges), its pixels are exactly those of every frame with the same
/// `background` key (a key names one picture, never reused for another).
#[derive(Clone, Copy, Debug)]
pub struct Unchanged<'a> {
    pub background: u64,
    pub changed: &'a [Range<u32>],
}

/// Backgrounds whose rows are kept (a batch moves through its camera poses
/// in order; frames in flight span at most a few).
const KEPT_BACKGROUNDS: usize = 4;

/// A JPEG encoder for one quality that reuses compressed rows of shared
/// backgrounds across frames and threads.
pub struct JpegEncoder {
    quality: u8,
    kept: Mutex<Vec<Arc<Rows>>>,
}

/// The compressed rows of one background at one size.
struct Rows {
    background: u64,
    width: u32,
    height: u32,
    /// Everything before the first segment (SOI … SOS), for the full height.
    header: Mutex<Option<Arc<[u8]>>>,
    /// Per MCU row, its segment once a frame has shown the row unpainted.
    segments: Mutex<Vec<Option<Arc<[u8]>>>>,
}

impl JpegEncoder {
    pub fn new(quality: u8) -> Self {
        Self {
            quality,
            kept: Mutex::new(Vec::new()),
        }
    }

    /// Encode a frame; with `unchanged`, rows outside its changed ranges
    /// are taken from earlier frames over the same background when known.
    /// The bytes are those of [`compress`] either way.
    pub fn encode(
        &self,
        rgba: &[u8],
        width: u32,
        height: u32,
        unchanged: Option<Unchanged<'_>>,
    ) -> Result<Vec<u8>, String> {
        check(rgba, width, height)?;
        let Some(unchanged) = unchanged.filter(|u| u.background != 0) else {
            return compress(rgba, width, height, self.quality);
        };
        let rows = self.rows(unchanged.background, width, height);
        let mcu = mcu_rows(self.quality);
        let n = height.div_ceil(mcu) as usize;
        let mut painted = vec![false; n];
        for r in unchanged.changed {
            let (y0, y1) = (r.start.min(height), r.end.min(height));
            if y0 < y1 {
                for p in &mut painted[(y0 / mcu) as usize..y1.div_ceil(mcu) as usize] {
                    *p = true;
                }
            }
        }
        // Rows to compress: painted ones, and clean ones not yet kept.
        let mut segments: Vec<Option<Arc<[u8]>>> = {
            let kept = rows.segments.lock().unwrap_or_else(PoisonError::into_inner);
            kept.iter()
                .zip(&painted)
                .map(|(s, &p)| if p { None } else { s.clone() })
                .collect()
        };
        let mut header = rows
            .header
            .lock()
            .unwrap_or_else(PoisonError::into_inner)
            .clone();
        let mut compressor = None;
        let mut start = 0;
        while start < n {
            if segments[start].is_some() {
                start += 1;
                continue;
            }
            let end = (start..n).find(|&i| segments[i].is_some()).unwrap_or(n);
            let y0 = start as u32 * mcu;
            let y1 = (end as u32 * mcu).min(height);
            let c = match &mut compressor {
                Some(c) => c,
                None => compressor.insert(tj::Compressor::new(self.quality)?),
            };
            let stride = width as usize * 4;
            let strip = c.compress(
                &rgba[y0 as usize * stride..y1 as usize * stride],
                width,
                stride,
                y1 - y0,
            )?;
            let scan = Scan::parse(&strip)?;
            if scan.segments.len() != end - start {
                return Err(format!(
                    "libjpeg-turbo wrote {} restart segments for {} MCU rows",
                    scan.segments.len(),
                    end - start
                ));
            }
            if header.is_none() {
                header = Some(scan.header_for_height(&strip, height)?.into());
            }
            let mut kept = rows.segments.lock().unwrap_or_else(PoisonError::into_inner);
            for (i, range) in (start..end).zip(scan.segments) {
                let segment: Arc<[u8]> = strip[range].into();
                if !painted[i] {
                    kept[i] = Some(segment.clone());
                }
                segments[i] = Some(segment);
            }
            start = end;
        }
        let header = header.ok_or("no JPEG header was made")?;
        rows.header
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

    /// The kept rows of `background` at this size (made empty when new).
    fn rows(&self, background: u64, width: u32, height: u32) -> Arc<Rows> {
        let mut kept = self.kept.lock().unwrap_or_else(PoisonError::into_inner);
        if let Some(r) = kept
            .iter()
            .find(|r| r.background == background && r.width == width && r.height == height)
        {
            return r.clone();
        }
        if kept.len() >= KEPT_BACKGROUNDS {
            kept.remove(0);
        }
        let n = height.div_ceil(mcu_rows(self.quality)) as usize;
        let rows = Arc::new(Rows {
            background,
            width,
            height,
            header: Mutex::new(None),
            segments: Mutex::new(vec![None; n]),
        });
        kept.push(rows.clone());
        rows
    }
}

/// A baseline JPEG split at its restart markers.
struct Scan {
    /// Bytes before the first segment.
    header: Range<usize>,
    /// Offset of the SOF0 frame header's height field.
    height_at: usize,
    /// Each restart interval's entropy-coded bytes (markers excluded).
    segments: Vec<Range<usize>>,
}

impl Scan {
    fn parse(jpeg: &[u8]) -> Result<Self, String> {
        let bad = |what: &str| format!("unexpected JPEG from libjpeg-turbo: {what}");
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

    /// The header with the frame height set to `height`.
    fn header_for_height(&self, jpeg: &[u8], height: u32) -> Result<Vec<u8>, String> {
        let mut header = jpeg[self.header.clone()].to_vec();
        let h =
            u16::try_from(height).map_err(|_| format!("height {height} exceeds JPEG's 65535"))?;
        header[self.height_at..self.height_at + 2].copy_from_slice(&h.to_be_bytes());
        Ok(header)
    }
}

/// The one place that calls TurboJPEG's C API directly: the `turbojpeg`
/// crate's `Compressor` does not expose the restart interval.
#[allow(unsafe_code)]
mod tj {
    use std::ffi::{CStr, c_int};

    use turbojpeg::raw;

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
        pub fn new(quality: u8) -> Result<Self, String> {
            // SAFETY: plain constructor; a null result is handled below.
            let handle = unsafe { raw::tj3Init(raw::TJINIT_TJINIT_COMPRESS as c_int) };
            if handle.is_null() {
                return Err("libjpeg-turbo could not make a compressor".into());
            }
            let c = Self { handle };
            let subsamp = if super::subsampled(quality) {
                raw::TJSAMP_TJSAMP_420
            } else {
                raw::TJSAMP_TJSAMP_444
            };
            c.set(raw::TJPARAM_TJPARAM_QUALITY, i32::from(quality))?;
            c.set(raw::TJPARAM_TJPARAM_SUBSAMP, subsamp)?;
            c.set(raw::TJPARAM_TJPARAM_RESTARTROWS, 1)?;
            Ok(c)
        }

        fn set(&self, param: raw::TJPARAM, value: i32) -> Result<(), String> {
            // SAFETY: a live handle; TurboJPEG validates the parameter and value.
            if unsafe { raw::tj3Set(self.handle, param as c_int, value) } != 0 {
                return Err(self.error());
            }
            Ok(())
        }

        fn error(&self) -> String {
            // SAFETY: a live handle; the string is owned by TurboJPEG and copied at once.
            unsafe { CStr::from_ptr(raw::tj3GetErrorStr(self.handle)) }
                .to_string_lossy()
                .into_owned()
        }

        /// Compress `height` rows of `width` RGBX pixels, rows `pitch` bytes apart.
        pub fn compress(
            &mut self,
            pixels: &[u8],
            width: u32,
            pitch: usize,
            height: u32,
        ) -> Result<Vec<u8>, String> {
            let needed = (height as usize)
                .checked_sub(1)
                .and_then(|rows| rows.checked_mul(pitch))
                .and_then(|n| n.checked_add(width as usize * 4));
            if needed.is_none_or(|n| pixels.len() < n) || pitch < width as usize * 4 {
                return Err(format!(
                    "{} bytes do not hold {width}×{height} RGBX pixels",
                    pixels.len()
                ));
            }
            let (w, p, h) = (
                c_int::try_from(width).map_err(|e| e.to_string())?,
                c_int::try_from(pitch).map_err(|e| e.to_string())?,
                c_int::try_from(height).map_err(|e| e.to_string())?,
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

    #[test]
    fn reused_rows_give_the_bytes_of_a_whole_compress() {
        // Odd sizes (bottom MCU row partly padded, right edge padded), both chroma modes.
        for (width, height, quality) in [(333, 157, 85), (256, 64, 85), (200, 91, 95), (64, 16, 75)]
        {
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
                let changed: Vec<Range<u32>> = blobs.iter().map(|b| b.1..b.3).collect();
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
            // Rows kept for background 42: every row was clean in some frame.
            let rows = encoder.rows(42, width, height);
            let kept = rows.segments.lock().unwrap();
            assert!(
                kept.iter().all(Option::is_some),
                "{width}×{height}: rows never kept"
            );
        }
    }

    proptest::proptest! {
        #![proptest_config(proptest::prelude::ProptestConfig::with_cases(24))]
        /// Any size, quality and sequence of painted row bands over one
        /// background: the spliced bytes are those of a whole compress.
        #[test]
        fn any_painted_rows_give_the_whole_compress(
            width in 1u32..140,
            height in 1u32..90,
            quality in proptest::sample::select(vec![40u8, 85, 89, 90, 100]),
            frames in proptest::collection::vec(
                proptest::collection::vec((0u32..100, 0u32..100, 1u32..40, 1u32..30), 0..4),
                1..5,
            ),
        ) {
            let encoder = JpegEncoder::new(quality);
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
                let changed: Vec<Range<u32>> = blobs.iter().map(|b| b.1..b.3).collect();
                let reused = encoder
                    .encode(&rgba, width, height, Some(Unchanged { background: 3, changed: &changed }))
                    .unwrap();
                proptest::prop_assert!(reused == compress(&rgba, width, height, quality).unwrap());
            }
        }
    }

    #[test]
    fn a_wrong_key_would_show_stale_rows() {
        // The reuse is real: claiming a background the frame does not hold
        // gives the old rows back (so the test above checks something).
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
    fn restart_segments_split_per_mcu_row() {
        let jpeg = compress(&picture(48, 40, 3, &[]), 48, 40, 85).unwrap();
        let scan = Scan::parse(&jpeg).unwrap();
        assert_eq!(scan.segments.len(), 3);
        let jpeg = compress(&picture(48, 40, 3, &[]), 48, 40, 95).unwrap();
        assert_eq!(Scan::parse(&jpeg).unwrap().segments.len(), 5);
    }

    #[test]
    fn bad_sizes_are_named() {
        assert!(compress(&[0; 12], 2, 2, 85).unwrap_err().contains("RGBA8"));
        assert!(compress(&[], 0, 2, 85).unwrap_err().contains("1–65535"));
    }
}

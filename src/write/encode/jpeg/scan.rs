//! A baseline JPEG split at its restart markers: the header before the
//! first segment and each restart interval's entropy-coded bytes.

use std::ops::Range;

use super::JpegError;

/// A baseline JPEG split at its restart markers.
pub(super) struct Scan {
    /// Bytes before the first segment.
    header: Range<usize>,
    /// Offset of the SOF0 frame header's height field (the width follows).
    height_at: usize,
    /// Each restart interval's entropy-coded bytes (markers excluded).
    pub(super) segments: Vec<Range<usize>>,
}

impl Scan {
    pub(super) fn parse(jpeg: &[u8]) -> Result<Self, JpegError> {
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
    pub(super) fn header_for(
        &self,
        jpeg: &[u8],
        width: u32,
        height: u32,
    ) -> Result<Vec<u8>, JpegError> {
        let mut header = jpeg[self.header.clone()].to_vec();
        let side = |v: u32| u16::try_from(v).map_err(|_| JpegError::Side(v));
        let at = self.height_at;
        header[at..at + 2].copy_from_slice(&side(height)?.to_be_bytes());
        header[at + 2..at + 4].copy_from_slice(&side(width)?.to_be_bytes());
        Ok(header)
    }
}

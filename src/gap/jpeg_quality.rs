//! JPEG quality estimated from a file's quantisation tables.
//!
//! An encoder built on libjpeg (libjpeg-turbo, mozjpeg in its default mode, the `image`
//! crate, most cameras' "IJG" setting) writes the Annex K luminance table scaled by
//! `jpeg_quality_scaling(q)`. The DQT segment of the file therefore names q: we read the
//! luminance table (table id 0) and take the q whose scaled table is nearest (sum of
//! absolute differences). `exact` says whether some q gives the file's table exactly; a
//! camera with its own tables gets the nearest IJG quality, which is what a user tunes.

/// The Annex K luminance quantisation table, natural (row-major) order.
const STD_LUMA: [u16; 64] = [
    16, 11, 10, 16, 24, 40, 51, 61, 12, 12, 14, 19, 26, 58, 60, 55, 14, 13, 16, 24, 40, 57, 69, 56,
    14, 17, 22, 29, 51, 87, 80, 62, 18, 22, 37, 56, 68, 109, 103, 77, 24, 35, 55, 64, 81, 104, 113,
    92, 49, 64, 78, 87, 103, 121, 120, 101, 72, 92, 95, 98, 112, 100, 103, 99,
];

/// Natural-order index of the k-th coefficient in zig-zag order (as DQT stores it).
const ZIGZAG: [usize; 64] = [
    0, 1, 8, 16, 9, 2, 3, 10, 17, 24, 32, 25, 18, 11, 4, 5, 12, 19, 26, 33, 40, 48, 41, 34, 27, 20,
    13, 6, 7, 14, 21, 28, 35, 42, 49, 56, 57, 50, 43, 36, 29, 22, 15, 23, 30, 37, 44, 51, 58, 59,
    52, 45, 38, 31, 39, 46, 53, 60, 61, 54, 47, 55, 62, 63,
];

/// What the quantisation tables say about a JPEG file.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct JpegQuality {
    /// The IJG quality (1–100) whose luminance table is nearest the file's.
    pub quality: u8,
    /// True when that quality reproduces the file's table exactly.
    pub exact: bool,
}

/// The luminance table (id 0) of a JPEG stream in natural order, or `None` when the bytes
/// are not a JPEG or hold no such table before the first scan.
pub fn luma_table(bytes: &[u8]) -> Option<[u16; 64]> {
    if bytes.len() < 4 || bytes[0] != 0xFF || bytes[1] != 0xD8 {
        return None;
    }
    let mut i = 2;
    while i + 4 <= bytes.len() {
        if bytes[i] != 0xFF {
            return None;
        }
        let marker = bytes[i + 1];
        if marker == 0xFF {
            i += 1; // fill byte
            continue;
        }
        if marker == 0xD9 || marker == 0xDA {
            return None; // end of image or start of scan: no table 0 before it
        }
        if (0xD0..=0xD7).contains(&marker) || marker == 0x01 {
            i += 2;
            continue;
        }
        let len = usize::from(bytes[i + 2]) << 8 | usize::from(bytes[i + 3]);
        let end = i + 2 + len;
        if len < 2 || end > bytes.len() {
            return None;
        }
        if marker == 0xDB {
            let mut j = i + 4;
            while j < end {
                let pq = bytes[j] >> 4;
                let tq = bytes[j] & 0x0F;
                let size = if pq == 0 { 64 } else { 128 };
                if j + 1 + size > end {
                    return None;
                }
                if tq == 0 {
                    let mut table = [0u16; 64];
                    for (k, &natural) in ZIGZAG.iter().enumerate() {
                        table[natural] = if pq == 0 {
                            u16::from(bytes[j + 1 + k])
                        } else {
                            u16::from(bytes[j + 1 + 2 * k]) << 8 | u16::from(bytes[j + 2 + 2 * k])
                        };
                    }
                    return Some(table);
                }
                j += 1 + size;
            }
        }
        i = end;
    }
    None
}

/// libjpeg's luminance table for quality `q` (1–100), baseline (clamped to 1–255).
pub fn ijg_luma_table(q: u8) -> [u16; 64] {
    let q = u32::from(q.clamp(1, 100));
    let scale = if q < 50 { 5000 / q } else { 200 - 2 * q };
    let mut t = [0u16; 64];
    for (out, &base) in t.iter_mut().zip(STD_LUMA.iter()) {
        let v = (u32::from(base) * scale + 50) / 100;
        *out = v.clamp(1, 255) as u16;
    }
    t
}

/// The IJG quality nearest a JPEG file's luminance table; `None` for a non-JPEG or a file
/// without one. Ties go to the higher quality (q 98–100 all give a table of ones).
pub fn estimate(bytes: &[u8]) -> Option<JpegQuality> {
    let table = luma_table(bytes)?;
    let mut best = (u64::MAX, 1u8);
    for q in 1..=100u8 {
        let err: u64 = ijg_luma_table(q)
            .iter()
            .zip(table.iter())
            .map(|(&a, &b)| u64::from(a.abs_diff(b)))
            .sum();
        if err <= best.0 {
            best = (err, q);
        }
    }
    Some(JpegQuality {
        quality: best.1,
        exact: best.0 == 0,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn not_a_jpeg_has_no_quality() {
        assert_eq!(estimate(b"\x89PNG\r\n\x1a\n0000"), None);
        assert_eq!(estimate(&[0xFF, 0xD8, 0xFF, 0xD9]), None);
        assert_eq!(estimate(&[]), None);
        // A DQT whose length runs past the end.
        assert_eq!(estimate(&[0xFF, 0xD8, 0xFF, 0xDB, 0x00, 0x43, 0x00]), None);
    }

    #[test]
    fn quality_50_is_the_annex_k_table() {
        assert_eq!(ijg_luma_table(50), STD_LUMA);
        assert!(ijg_luma_table(100).iter().all(|&v| v == 1));
    }
}

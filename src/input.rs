//! Reading the files a user names (presets, models, buffers, images, label files):
//! bounded in size and refusing what is not a regular file, so no input can block a
//! read or make it grow without end; and decoding the images a user names (gap's
//! frames, backplates) with a pixel budget read from the header before any pixel
//! buffer is allocated, refusing truncated JPEGs. Every stage that reads a user's file
//! goes through here; it imports nothing of the project.

use std::io::{Error, ErrorKind, Read};
use std::path::Path;

/// The most pixels (width × height) an image the user names may have: 64
/// megapixels (64 000 000), e.g. 9 200 × 6 900 or 8 000 × 8 000. Checked from the
/// file's header before decoding, so a 20 000 × 20 000 PNG of a few hundred bytes is
/// refused without allocating its 1.6 GB.
pub const MAX_IMAGE_PIXELS: u64 = 64_000_000;

/// Open a file the user named: a regular file (or a link to one) of at most
/// `max_bytes`. Its type is checked before it is opened (a FIFO, device, socket
/// or folder is refused without opening it) and again on the opened handle,
/// which is opened non-blocking, so a file swapped for a FIFO in between cannot
/// block the open or the read either. Returns the file and its length.
pub fn open_input_file(path: &Path, max_bytes: u64) -> std::io::Result<(std::fs::File, u64)> {
    let not_regular = |meta: &std::fs::Metadata| {
        Error::new(
            ErrorKind::InvalidInput,
            format!("{}, not a regular file", file_kind(meta)),
        )
    };
    let meta = std::fs::metadata(path)?;
    if !meta.is_file() {
        return Err(not_regular(&meta));
    }
    let mut options = std::fs::OpenOptions::new();
    options.read(true);
    #[cfg(unix)]
    {
        use std::os::unix::fs::OpenOptionsExt;
        options.custom_flags(rustix::fs::OFlags::NONBLOCK.bits() as i32);
    }
    let file = options.open(path)?;
    let meta = file.metadata()?;
    if !meta.is_file() {
        return Err(not_regular(&meta));
    }
    if meta.len() > max_bytes {
        return Err(too_large(meta.len(), max_bytes));
    }
    Ok((file, meta.len()))
}

fn too_large(n: u64, max_bytes: u64) -> Error {
    Error::new(
        ErrorKind::InvalidData,
        format!("{n} bytes is larger than the {max_bytes}-byte limit for this kind of file"),
    )
}

/// Read a file the user named (preset, model, buffer, sky image): a regular
/// file (or a link to one) of at most `max_bytes`. FIFOs, devices such as
/// `/dev/zero`, sockets and folders are refused before they are opened, so a
/// read never blocks or grows without end ([`open_input_file`]); the cap is
/// enforced while reading too, in case the file grows.
pub fn read_input_file(path: &Path, max_bytes: u64) -> std::io::Result<Vec<u8>> {
    let (file, len) = open_input_file(path, max_bytes)?;
    let mut bytes = Vec::with_capacity(usize::try_from(len).unwrap_or(0));
    file.take(max_bytes.saturating_add(1))
        .read_to_end(&mut bytes)?;
    if bytes.len() as u64 > max_bytes {
        return Err(too_large(bytes.len() as u64, max_bytes));
    }
    Ok(bytes)
}

/// Feed the content of a file the user named to `hasher`, opened and
/// bounded as [`read_input_file`] reads it, in bounded memory (the run's
/// record of what it read: `pipeline::inputs`). Returns its length.
pub fn hash_input_file(
    path: &Path,
    max_bytes: u64,
    hasher: &mut blake3::Hasher,
) -> std::io::Result<u64> {
    let (file, _) = open_input_file(path, max_bytes)?;
    let len = std::io::copy(&mut file.take(max_bytes.saturating_add(1)), hasher)?;
    if len > max_bytes {
        return Err(too_large(len, max_bytes));
    }
    Ok(len)
}

/// What a file that is not a regular file is, for messages.
pub fn file_kind(meta: &std::fs::Metadata) -> &'static str {
    #[cfg(unix)]
    {
        use std::os::unix::fs::FileTypeExt;
        let t = meta.file_type();
        if t.is_fifo() {
            return "a FIFO (named pipe)";
        }
        if t.is_char_device() || t.is_block_device() {
            return "a device";
        }
        if t.is_socket() {
            return "a socket";
        }
    }
    if meta.is_dir() {
        "a folder"
    } else {
        "a special file"
    }
}

/// Why an image the user named cannot be decoded. The message is the reason
/// alone; the caller names the file.
#[derive(Debug, thiserror::Error)]
pub enum ImageError {
    #[error("truncated JPEG ({0})")]
    Truncated(String),
    #[error("is a 0-byte file, not a JPEG or PNG image")]
    Empty,
    #[error("is not a JPEG or PNG image")]
    Format,
    #[error("cannot be read: {0}")]
    Header(String),
    #[error("{width}×{height} is larger than the {max_side}-pixel side limit")]
    Side {
        width: u32,
        height: u32,
        max_side: u32,
    },
    #[error("{width}×{height} is {} pixels, more than the {max_pixels}-pixel limit ({} megapixels) for an image", u64::from(*.width) * u64::from(*.height), .max_pixels / 1_000_000)]
    Pixels {
        width: u32,
        height: u32,
        max_pixels: u64,
    },
    #[error("cannot be decoded: {0}")]
    Decode(image::ImageError),
}

/// Decode a JPEG or PNG image the user named (its file's bytes) within a
/// pixel budget: the format is guessed from the bytes (anything else is
/// refused), a JPEG cut short is refused as truncated ([`jpeg_truncation`]),
/// the width and height are read from the header and refused above
/// `max_pixels` (or `max_side` on either side) before any pixel buffer is
/// allocated, and the decoder runs under the same limits; the image comes
/// back turned upright by its EXIF orientation. The error is the reason
/// alone; the caller names the file.
pub fn decode_image(
    bytes: &[u8],
    max_pixels: u64,
    max_side: u32,
) -> Result<image::DynamicImage, ImageError> {
    if bytes.is_empty() {
        return Err(ImageError::Empty);
    }
    let reader = || {
        image::ImageReader::new(std::io::Cursor::new(bytes))
            .with_guessed_format()
            .map_err(|e| ImageError::Header(e.to_string()))
    };
    let format = reader()?.format();
    match format {
        Some(image::ImageFormat::Jpeg) => {
            if let Some(why) = jpeg_truncation(bytes) {
                return Err(ImageError::Truncated(why));
            }
        }
        Some(image::ImageFormat::Png) => {}
        _ => return Err(ImageError::Format),
    }
    let (w, h) = reader()?
        .into_dimensions()
        .map_err(|e| ImageError::Header(e.to_string()))?;
    let (width, height) = (w, h);
    if w.max(h) > max_side {
        return Err(ImageError::Side {
            width,
            height,
            max_side,
        });
    }
    if u64::from(w) * u64::from(h) > max_pixels {
        return Err(ImageError::Pixels {
            width,
            height,
            max_pixels,
        });
    }
    let mut reader = reader()?;
    let mut limits = image::Limits::default();
    limits.max_image_width = Some(max_side);
    limits.max_image_height = Some(max_side);
    // 16-bit RGBA is 8 bytes a pixel, the most a JPEG or PNG decodes to.
    limits.max_alloc = Some(max_pixels.saturating_mul(8));
    let mut limits_left = limits.clone();
    reader.limits(limits);
    // As `ImageReader::decode`, and turned upright by the file's EXIF
    // orientation: a camera's or phone's JPEG stored sideways is labelled
    // (CVAT, Ultralytics) as it is shown, upright.
    use image::ImageDecoder;
    let mut decoder = reader.into_decoder().map_err(ImageError::Decode)?;
    limits_left
        .reserve(decoder.total_bytes())
        .map_err(ImageError::Decode)?;
    let orientation = decoder.orientation().map_err(ImageError::Decode)?;
    let mut image = image::DynamicImage::from_decoder(decoder).map_err(ImageError::Decode)?;
    image.apply_orientation(orientation);
    Ok(image)
}

/// Why a JPEG's bytes are cut short, or `None` when its markers lead to an
/// end-of-image marker (FF D9). The decoder accepts a JPEG cut anywhere in
/// its entropy-coded data and fills the rest with grey; this walk follows the
/// file's structure instead: each marker segment is skipped by its length,
/// each scan's entropy-coded data up to the next marker (stuffed FF 00 bytes,
/// restart markers and fill bytes skipped), until FF D9. Bytes after the
/// end-of-image marker (trailers some cameras append, zero padding) are
/// allowed; bytes that are not a marker where one must start are skipped to
/// the next marker, as decoders do. Linear in the file's size.
pub fn jpeg_truncation(bytes: &[u8]) -> Option<String> {
    let n = bytes.len();
    let cut = |where_: &str| {
        Some(format!(
            "the file ends after {n} bytes {where_}, before the end-of-image marker FF D9"
        ))
    };
    if !bytes.starts_with(&[0xFF, 0xD8]) {
        return Some("no start-of-image marker FF D8".into());
    }
    let mut i = 2;
    loop {
        // Find the next marker: FF (fill FFs) then a byte that is neither 00 nor FF.
        let Some(ff) = bytes[i.min(n)..].iter().position(|&b| b == 0xFF) else {
            return cut("between segments");
        };
        i += ff;
        while i < n && bytes[i] == 0xFF {
            i += 1;
        }
        if i >= n {
            return cut("in a marker");
        }
        let marker = bytes[i];
        i += 1;
        match marker {
            0xD9 => return None,
            // Stuffed zero outside a scan, standalone markers: nothing follows.
            0x00 | 0x01 | 0xD0..=0xD8 => continue,
            _ => {}
        }
        if i + 2 > n {
            return cut("in a segment's length");
        }
        let len = usize::from(u16::from_be_bytes([bytes[i], bytes[i + 1]]));
        if len < 2 {
            // Not a segment length: resynchronise at the next marker.
            continue;
        }
        if i + len > n {
            return cut(&format!(
                "inside a {len}-byte segment (marker FF {marker:02X})"
            ));
        }
        i += len;
        if marker != 0xDA {
            continue;
        }
        // Entropy-coded data of a scan: up to a marker that is not a stuffed
        // zero or a restart marker.
        loop {
            let Some(ff) = bytes[i.min(n)..].iter().position(|&b| b == 0xFF) else {
                return cut("inside the compressed image data");
            };
            let mut j = i + ff;
            while j < n && bytes[j] == 0xFF {
                j += 1;
            }
            if j >= n {
                return cut("inside the compressed image data");
            }
            if bytes[j] == 0x00 || (0xD0..=0xD7).contains(&bytes[j]) {
                i = j + 1;
                continue;
            }
            // A marker: handled by the outer loop from its last FF.
            i = j - 1;
            break;
        }
    }
}

/// `path` made absolute and free of links as far as it exists: the nearest existing
/// ancestor canonicalised, the rest (which does not exist yet) appended with `.` and
/// `..` resolved lexically, as `create_dir_all` would walk them.
pub fn canonical_as_far_as_it_exists(path: &Path) -> std::io::Result<std::path::PathBuf> {
    let path = if path.as_os_str().is_empty() {
        Path::new(".")
    } else {
        path
    };
    let mut rest = Vec::new();
    let mut at = path;
    loop {
        match at.canonicalize() {
            Ok(mut real) => {
                for c in rest.iter().rev() {
                    match c {
                        std::path::Component::ParentDir => {
                            real.pop();
                        }
                        std::path::Component::Normal(n) => real.push(n),
                        _ => {}
                    }
                }
                return Ok(real);
            }
            Err(e) => {
                let mut comps = at.components();
                let Some(last) = comps.next_back() else {
                    return Err(e);
                };
                rest.push(last);
                at = comps.as_path();
                if at.as_os_str().is_empty() {
                    at = Path::new(".");
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A PNG of `img` whose EXIF orientation is `tag` (6: to be turned 90°
    /// clockwise to be upright).
    fn png_with_orientation(img: &image::RgbImage, tag: u16) -> Vec<u8> {
        use image::ImageEncoder;
        let mut exif = b"MM\0\x2a\0\0\0\x08\0\x01".to_vec();
        exif.extend([0x01, 0x12, 0, 3, 0, 0, 0, 1]);
        exif.extend(tag.to_be_bytes());
        exif.extend([0, 0, 0, 0, 0, 0]);
        let mut out = Vec::new();
        let mut encoder = image::codecs::png::PngEncoder::new(&mut out);
        encoder.set_exif_metadata(exif).expect("exif");
        (encoder.write_image(
            img,
            img.width(),
            img.height(),
            image::ExtendedColorType::Rgb8,
        ))
        .expect("png");
        out
    }

    #[test]
    fn an_image_stored_sideways_is_decoded_upright() {
        // 4 × 2 stored, orientation 6: shown (and labelled) 2 × 4, the stored
        // top-left pixel at the top right.
        let stored =
            image::RgbImage::from_fn(4, 2, |x, y| image::Rgb([x as u8 * 60, y as u8 * 200, 7]));
        let upright = decode_image(&png_with_orientation(&stored, 6), 1000, 1000)
            .expect("decodes")
            .to_rgb8();
        assert_eq!(upright.dimensions(), (2, 4));
        assert_eq!(upright.get_pixel(1, 0), stored.get_pixel(0, 0));
        assert_eq!(upright.get_pixel(0, 3), stored.get_pixel(3, 1));
        // Orientation 1 (as stored) leaves it as it is.
        let same = decode_image(&png_with_orientation(&stored, 1), 1000, 1000).expect("decodes");
        assert_eq!(same.to_rgb8(), stored);
    }
}

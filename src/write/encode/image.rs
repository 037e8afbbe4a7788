//! Image encoding: the preset's format, quality and chroma, nothing else.
//!
//! JPEG goes through libjpeg-turbo straight from the RGBA buffer (read as
//! RGBX, no conversion copy): baseline, default Huffman tables, the accurate
//! integer DCT (whose SIMD and plain-C paths give the same bytes, so the
//! output is identical on every machine) and a restart marker every few
//! MCUs (tiles of about 512 × 16 px), which lets [`ImageEncoder`] reuse the
//! compressed tiles a frame shares with others over the same background
//! ([`super::jpeg`]). Chroma is
//! 4:2:0 below quality 90 and 4:4:4 from 90 up.

use crate::preset::ImageFormat;

use super::EncodeError;
use super::jpeg::{JpegEncoder, Unchanged, check_rgba};
use crate::write::OutputError;

/// Encode tightly packed RGBA8 pixels as JPEG or PNG (alpha dropped).
pub fn encode_image(
    rgba: &[u8],
    width: u32,
    height: u32,
    format: ImageFormat,
) -> Result<Vec<u8>, OutputError> {
    ImageEncoder::new(format).encode(rgba, width, height, None)
}

/// [`encode_image`] of a grey picture (R = G = B): JPEG with one channel.
pub fn encode_grey_image(
    rgba: &[u8],
    width: u32,
    height: u32,
    format: ImageFormat,
) -> Result<Vec<u8>, OutputError> {
    ImageEncoder::grey(format).encode(rgba, width, height, None)
}

/// 16-bit grey pixels (`width`×`height`, row-major) as a 16-bit grey PNG.
pub fn encode_grey16_png(grey: &[u16], width: u32, height: u32) -> Result<Vec<u8>, OutputError> {
    let error = |source: EncodeError| OutputError::Encode {
        format: "PNG",
        source,
    };
    if grey.len() != width as usize * height as usize {
        return Err(error(EncodeError::Grey16Size(grey.len(), width, height)));
    }
    let mut out = Vec::new();
    let encoder = image::codecs::png::PngEncoder::new_with_quality(
        &mut out,
        image::codecs::png::CompressionType::Fast,
        image::codecs::png::FilterType::Adaptive,
    );
    // The encoder takes 16-bit samples in native byte order.
    let bytes: &[u8] = bytemuck::cast_slice(grey);
    image::ImageEncoder::write_image(encoder, bytes, width, height, image::ExtendedColorType::L16)
        .map_err(|e| error(e.into()))?;
    Ok(out)
}

/// `rgba` compressed as JPEG at `quality` (as [`encode_image`] would) and
/// decompressed again by libjpeg-turbo: the camera model's first
/// compression. RGBA8 of the same size, alpha 255.
pub fn jpeg_round_trip(
    rgba: &[u8],
    width: u32,
    height: u32,
    quality: u8,
) -> Result<Vec<u8>, OutputError> {
    let jpeg = encode_image(rgba, width, height, ImageFormat::Jpeg { quality })?;
    let image = turbojpeg::decompress(&jpeg, turbojpeg::PixelFormat::RGBA).map_err(|e| {
        OutputError::Encode {
            format: "JPEG",
            source: EncodeError::Decode(e),
        }
    })?;
    if (image.width, image.height) != (width as usize, height as usize)
        || image.pitch != width as usize * 4
    {
        return Err(OutputError::Encode {
            format: "JPEG",
            source: EncodeError::DecodedSize,
        });
    }
    Ok(image.pixels)
}

/// An encoder for one format, shared by a batch's encoder threads: JPEG
/// frames over a shared background reuse its unpainted tiles. The bytes are
/// those of [`encode_image`] whatever was reused.
pub struct ImageEncoder {
    /// `None`: PNG.
    jpeg: Option<JpegEncoder>,
}

impl ImageEncoder {
    pub fn new(format: ImageFormat) -> Self {
        let jpeg = match format {
            ImageFormat::Jpeg { quality } => Some(JpegEncoder::new(quality)),
            ImageFormat::Png => None,
        };
        Self { jpeg }
    }

    /// An encoder of grey pictures (R = G = B, the thermal camera's): JPEG
    /// as one channel, whose decoded grey is the colour JPEG's; PNG as
    /// [`ImageEncoder::new`].
    pub fn grey(format: ImageFormat) -> Self {
        let jpeg = match format {
            ImageFormat::Jpeg { quality } => Some(JpegEncoder::grey(quality)),
            ImageFormat::Png => None,
        };
        Self { jpeg }
    }

    /// Encode one frame; `unchanged` says what it shares with others.
    pub fn encode(
        &self,
        rgba: &[u8],
        width: u32,
        height: u32,
        unchanged: Option<Unchanged<'_>>,
    ) -> Result<Vec<u8>, OutputError> {
        if let Some(jpeg) = &self.jpeg {
            return jpeg
                .encode(rgba, width, height, unchanged)
                .map_err(|e| OutputError::Encode {
                    format: "JPEG",
                    source: e.into(),
                });
        }
        // PNG.
        check_rgba(rgba, width, height).map_err(|e| OutputError::Encode {
            format: "PNG",
            source: e.into(),
        })?;
        let rgb: Vec<u8> = rgba
            .chunks_exact(4)
            .flat_map(|p| [p[0], p[1], p[2]])
            .collect();
        let mut out = Vec::new();
        let encoder = image::codecs::png::PngEncoder::new_with_quality(
            &mut out,
            image::codecs::png::CompressionType::Fast,
            image::codecs::png::FilterType::Adaptive,
        );
        image::ImageEncoder::write_image(
            encoder,
            &rgb,
            width,
            height,
            image::ExtendedColorType::Rgb8,
        )
        .map_err(|e| OutputError::Encode {
            format: "PNG",
            source: e.into(),
        })?;
        Ok(out)
    }
}

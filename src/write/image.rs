//! Image encoding: the preset's format, quality and chroma, nothing else.

use crate::preset::ImageFormat;

use super::OutputError;

/// Encode tightly packed RGBA8 pixels as JPEG or PNG (alpha dropped).
pub fn encode_image(
    rgba: &[u8],
    width: u32,
    height: u32,
    format: ImageFormat,
) -> Result<Vec<u8>, OutputError> {
    let rgb: Vec<u8> = rgba
        .chunks_exact(4)
        .flat_map(|p| [p[0], p[1], p[2]])
        .collect();
    match format {
        ImageFormat::Jpeg { quality } => {
            let mut out = Vec::with_capacity(rgb.len() / 8);
            let encoder = jpeg_encoder::Encoder::new(&mut out, quality);
            let (w, h) = (u16::try_from(width), u16::try_from(height));
            let (Ok(w), Ok(h)) = (w, h) else {
                return Err(OutputError::Encode {
                    format: "JPEG",
                    reason: format!("{width}×{height} exceeds JPEG's 65535 px side"),
                });
            };
            encoder
                .encode(&rgb, w, h, jpeg_encoder::ColorType::Rgb)
                .map_err(|e| OutputError::Encode {
                    format: "JPEG",
                    reason: e.to_string(),
                })?;
            Ok(out)
        }
        ImageFormat::Png => {
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
                reason: e.to_string(),
            })?;
            Ok(out)
        }
    }
}

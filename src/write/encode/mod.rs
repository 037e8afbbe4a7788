//! Image encoding: the preset's image format ([`image`]), JPEG through
//! libjpeg-turbo with restart markers so a frame reuses the compressed
//! tiles it did not repaint ([`jpeg`]), and the sparse 16-bit PNG of the
//! instance masks ([`sparse_png`]).

pub mod image;
pub mod jpeg;
pub mod sparse_png;

pub use image::{
    ImageEncoder, encode_grey_image, encode_grey16_png, encode_image, jpeg_round_trip,
};
pub use jpeg::{Area, JpegError, Unchanged};

/// Why an image or mask file could not be encoded (inside
/// [`crate::write::OutputError::Encode`], which names the format).
#[derive(Debug, thiserror::Error)]
pub enum EncodeError {
    #[error(transparent)]
    Jpeg(#[from] JpegError),
    #[error(transparent)]
    Png(#[from] ::image::ImageError),
    #[error("decoding the first compression: {0}")]
    Decode(#[from] turbojpeg::Error),
    #[error("the first compression decoded to another size")]
    DecodedSize,
    #[error("{0} 16-bit samples for a {1}×{2} frame")]
    Grey16Size(usize, u32, u32),
    #[error("frame {0} came without its masks")]
    NoMasks(u64),
    #[error("drone {0} has no 16-bit instance id")]
    InstanceId(u32),
}

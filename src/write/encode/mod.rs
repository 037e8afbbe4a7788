//! Image encoding: the preset's image format ([`image`]), JPEG through
//! libjpeg-turbo with restart markers so a frame reuses the compressed
//! tiles it did not repaint ([`jpeg`]), and the sparse 16-bit PNG of the
//! instance masks ([`sparse_png`]).

pub mod image;
pub mod jpeg;
pub mod sparse_png;

pub use image::{ImageEncoder, encode_image, jpeg_round_trip};
pub use jpeg::{Area, Unchanged};

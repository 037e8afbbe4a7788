//! What the renderer measures of each drone, as plain data: the labels are
//! made from it ([`super::label_frame`], [`super::masks`]). The types are the
//! renderer's ([`crate::render::visibility`], which fills them in), named
//! here for the labels: annotate comes after render and imports from it,
//! never the other way.

pub use crate::render::visibility::{PixelHit, Visibility};

//! swarmshot: synthetic training data for UAV-swarm detection.
//!
//! Data flows one way: a [`preset::Preset`] (plain serde data) and a frame
//! index give a [`scene::FrameScene`] (`scene::build_frame`, pure); the
//! [`labels`] module boxes it geometrically; the [`render`] module draws it
//! with wgpu; the [`output`] writers store image, labels and manifest;
//! [`batch`] runs that pipeline for every frame. The renderer knows nothing of
//! any UI, and the writers know nothing of rendering. The desktop app
//! ([`app`]) edits presets and drives the same preview renderer and batch.

pub mod app;
pub mod assets;
pub mod batch;
pub mod bench;
pub mod camera;
pub mod environment;
pub mod gallery;
pub mod labels;
pub mod math;
pub mod model;
pub mod output;
pub mod preset;
pub mod render;
pub mod scene;
pub mod seed;
pub mod sweep;
pub mod visibility;

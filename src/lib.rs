//! swarmshot: synthetic training data for UAV-swarm detection.
//!
//! One way through the house: a validated [`preset::Preset`] (plain serde
//! data) and a frame index give a [`scene::FrameScene`] (pure; the sky is
//! resolved by [`sky`] and the models come from [`model`]); [`render`] draws
//! it with wgpu and measures what each drone shows; [`annotate`] turns poses
//! and those measurements into labels; [`write`] stores image, labels and
//! manifest. [`pipeline::FramePipeline`] runs those stages for one frame, and
//! every caller — the batch, the `frame` command, the desktop app's preview,
//! the benchmarks and the gallery — makes frames through it. Imports run one
//! way, each layer importing only those before it (`tests/suite/architecture.rs`
//! checks it): input, seed, simd, text, threads → preset → sky, model, sensor → scene →
//! render → annotate → write → pipeline, gap → fit → tools, app → cli (the
//! binary: `main.rs` and `cli/`). See docs/architecture.md.

pub mod annotate;
#[cfg(feature = "app")]
pub mod app;
pub mod fit;
pub mod gap;
pub mod input;
pub mod model;
pub mod pipeline;
pub mod preset;
pub mod render;
pub mod scene;
pub mod seed;
pub mod sensor;
pub(crate) mod simd;
pub mod sky;
pub mod text;
pub mod threads;
pub mod tools;
pub mod write;

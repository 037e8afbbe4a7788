//! What the renderers of one device share: the environment pass's
//! pipelines, compiled once per device.

use std::sync::{Arc, Mutex};

/// The environment pass's pipelines, by their key (the kinds they are
/// built for and the part), shared by every renderer of one device: their
/// shader compiles are the largest part of a short run's CPU on lavapipe,
/// and wgpu's bind group layouts are deduplicated by their entries, so a
/// pipeline one renderer built binds the groups of another.
#[derive(Clone, Default)]
pub struct SharedPipelines {
    pub(crate) environment: Arc<Mutex<EnvironmentPipelines>>,
}

/// Environment pipelines by key (see `SkyGpu::environment_pipeline`).
pub(crate) type EnvironmentPipelines = Vec<([u32; 4], wgpu::RenderPipeline)>;

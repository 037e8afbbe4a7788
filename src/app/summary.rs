//! The Summary panel's numbers, from geometry alone: frames are built and
//! labelled with [`FramePipeline::estimate_labels`] (no rendering) on an evenly spaced
//! sample, and counted with the writer's own [`DatasetStats`], so the
//! small/medium/large split uses the same √(w·h) thresholds as stats.json.

use std::sync::Arc;

use crate::pipeline::{FramePipeline, PipelineError};
use crate::preset::Preset;
use crate::scene::FrameError;
use crate::write::DatasetStats;

/// Frames sampled for the estimate.
pub const SUMMARY_SAMPLE_FRAMES: u64 = 48;

pub struct SummaryRequest {
    pub generation: u64,
    /// The preset with model paths resolved.
    pub preset: Arc<Preset>,
}

/// Estimated dataset shape.
#[derive(Clone, Debug)]
pub struct Summary {
    pub generation: u64,
    pub frames: u64,
    pub sampled_frames: u64,
    pub drones_min: usize,
    pub drones_max: usize,
    /// Counts over the sampled frames (boxes, small/medium/large, drones placed).
    pub stats: DatasetStats,
}

impl Summary {
    pub fn drones_mean(&self) -> f64 {
        self.stats.drones_placed as f64 / self.sampled_frames.max(1) as f64
    }

    /// Shares of small, medium and large boxes (0 when there are none).
    pub fn size_shares(&self) -> [f64; 3] {
        let n = self.stats.boxes.max(1) as f64;
        [
            self.stats.small as f64 / n,
            self.stats.medium as f64 / n,
            self.stats.large as f64 / n,
        ]
    }
}

/// Why the Summary panel has no numbers: the preset's models or sky images
/// cannot be loaded, or a sampled frame cannot be built (the panel shows the
/// library's message).
#[derive(Debug, thiserror::Error)]
pub enum SummaryError {
    #[error(transparent)]
    Pipeline(#[from] PipelineError),
    #[error(transparent)]
    Frame(#[from] FrameError),
}

/// Builds summaries, keeping the loaded models between requests.
#[derive(Default)]
pub struct SummaryMaker {
    pipeline: Option<FramePipeline>,
}

impl SummaryMaker {
    pub fn estimate(&mut self, request: &SummaryRequest) -> Result<Summary, SummaryError> {
        let preset = &*request.preset;
        // Reuses the loaded models while the edit leaves them alone.
        let pipeline = match self.pipeline.take() {
            Some(p) => p.update(preset.clone()),
            None => FramePipeline::new(preset.clone()),
        }?;
        let pipeline = self.pipeline.insert(pipeline);
        let frames = preset.frame_count();
        let sampled_frames = frames.min(SUMMARY_SAMPLE_FRAMES);
        let mut stats = DatasetStats::default();
        let (mut drones_min, mut drones_max) = (usize::MAX, 0);
        for k in 0..sampled_frames {
            // Evenly spaced over the sweep; u128 so the product cannot overflow.
            let index =
                u64::try_from(u128::from(k) * u128::from(frames) / u128::from(sampled_frames))
                    .unwrap_or(0);
            let scene = pipeline.scene(index)?;
            let labels = pipeline.estimate_labels(&scene);
            drones_min = drones_min.min(scene.drone_count());
            drones_max = drones_max.max(scene.drone_count());
            stats.add(&scene, &labels, pipeline.model_names(), pipeline.classes());
        }
        if sampled_frames == 0 {
            drones_min = 0;
        }
        Ok(Summary {
            generation: request.generation,
            frames,
            sampled_frames,
            drones_min,
            drones_max,
            stats,
        })
    }
}

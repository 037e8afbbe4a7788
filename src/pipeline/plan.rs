//! The labels-only plan (`swarmshot batch --labels-only`): every frame's
//! scene and labels from geometry ([`FramePipeline::plan`]), without the GPU,
//! written by the batch's own writers (labels, COCO, manifest, stats; no
//! images, no data.yaml).
//!
//! Frames are planned in chunks of [`CHUNK`] consecutive indices by one
//! worker per core; one sink writes the chunks in index order, so the output
//! does not depend on the number of workers. Amodal and PaperAabb boxes are
//! exactly the rendered batch's; `Visible` boxes are estimated by amodal ones
//! and the visibility filters do not run (see [`FramePipeline::estimate_labels`]).

use std::collections::BTreeMap;
use std::path::PathBuf;
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::time::{Duration, Instant};

use super::batch::frames_asked;
use super::{FramePipeline, Progress};
use crate::annotate::DroneLabel;
use crate::scene::FrameScene;
use crate::write::{DatasetStats, DatasetWriter, FrameTexts, WriterOptions};

/// Frames planned by one worker at a time (and written under one checkpoint).
pub const CHUNK: u64 = 256;

#[derive(Clone, Debug)]
pub struct PlanOptions {
    pub out_dir: PathBuf,
    /// Plan only the first N frames.
    pub limit: Option<u64>,
    /// Delete an earlier plan's own files in the folder and start again.
    pub overwrite: bool,
    /// Require an earlier plan of the same preset in the folder and continue it.
    pub resume: bool,
    /// Planning threads (0: one per core).
    pub threads: usize,
}

impl PlanOptions {
    pub fn new(out_dir: impl Into<PathBuf>) -> Self {
        Self {
            out_dir: out_dir.into(),
            limit: None,
            overwrite: false,
            resume: false,
            threads: 0,
        }
    }
}

/// What a finished (or cancelled) plan wrote.
#[derive(Clone, Debug)]
pub struct PlanReport {
    pub stats: DatasetStats,
    pub cancelled: bool,
    pub elapsed: Duration,
    pub out_dir: PathBuf,
    /// Frames this run planned (an earlier, continued run's not counted).
    pub planned: u64,
    /// Boxes are estimates: the preset asks for `Visible` boxes or visibility filters.
    pub estimated: bool,
}

impl PlanReport {
    /// Frames planned per second of this run.
    pub fn frames_per_s(&self) -> f64 {
        self.planned as f64 / self.elapsed.as_secs_f64().max(1e-9)
    }
}

/// Consecutive frames planned by one worker: scenes and labels, their
/// records as text and their statistics. The writer hands each chunk back
/// once written, so its buffers are reused and formatting allocates nothing.
#[derive(Default)]
struct Chunk {
    frames: Vec<(FrameScene, Vec<DroneLabel>)>,
    texts: FrameTexts,
    stats: DatasetStats,
}

/// Plan every frame (or the first `limit`) of `pipeline`'s preset into `options.out_dir`.
pub fn run_plan(
    pipeline: &FramePipeline,
    options: &PlanOptions,
    cancel: &AtomicBool,
    mut on_progress: impl FnMut(Progress) + Send,
) -> anyhow::Result<PlanReport> {
    let count = pipeline.frame_count();
    let frames = frames_asked(count, options.limit, options.resume);
    let mut writer = DatasetWriter::open(
        &options.out_dir,
        pipeline.preset(),
        pipeline.model_names().to_vec(),
        WriterOptions {
            frames,
            overwrite: options.overwrite,
            resume: options.resume,
            labels_only: true,
            shard: None,
        },
    )?;
    let first = writer.next_frame();
    let total = writer.total().min(count);
    let start = Instant::now();
    let threads = if options.threads == 0 {
        std::thread::available_parallelism().map_or(1, |n| n.get())
    } else {
        options.threads
    };
    let next_chunk = AtomicU64::new(0);
    let failed = AtomicBool::new(false);
    let chunks = (total.saturating_sub(first)).div_ceil(CHUNK);
    let (tx, rx) = crossbeam_channel::bounded::<(u64, anyhow::Result<Chunk>)>(threads * 2);
    // Written chunks go back to the workers to be filled again.
    let (spare_tx, spare_rx) = crossbeam_channel::unbounded::<Chunk>();
    let context = writer.text_context().clone();
    let (sink_result, cancelled) = std::thread::scope(|s| {
        for _ in 0..threads {
            let tx = tx.clone();
            let spare_rx = spare_rx.clone();
            let context = &context;
            let (next_chunk, failed) = (&next_chunk, &failed);
            s.spawn(move || {
                loop {
                    if failed.load(Ordering::Relaxed) || cancel.load(Ordering::Relaxed) {
                        return;
                    }
                    let c = next_chunk.fetch_add(1, Ordering::Relaxed);
                    if c >= chunks {
                        return;
                    }
                    let lo = first + c * CHUNK;
                    let hi = (lo + CHUNK).min(total);
                    let mut chunk = spare_rx.try_recv().unwrap_or_default();
                    chunk.frames.clear();
                    chunk.texts.clear();
                    chunk.stats = DatasetStats::default();
                    let planned = (lo..hi).try_for_each(|i| {
                        let (scene, labels) = pipeline.plan(i)?;
                        context.push_frame(&mut chunk.texts, &scene, &labels);
                        chunk
                            .stats
                            .add(&scene, &labels, &context.model_names, &context.classes);
                        chunk.frames.push((scene, labels));
                        anyhow::Ok(())
                    });
                    if tx.send((c, planned.map(|()| chunk))).is_err() {
                        return;
                    }
                }
            });
        }
        drop(tx);
        let failed = &failed;
        let sink = s.spawn(move || -> (anyhow::Result<DatasetWriter>, bool) {
            let mut pending: BTreeMap<u64, Chunk> = BTreeMap::new();
            let mut next = 0u64;
            for (c, planned) in rx {
                match planned {
                    Ok(chunk) => {
                        pending.insert(c, chunk);
                    }
                    Err(e) => {
                        failed.store(true, Ordering::Relaxed);
                        return (Err(e), false);
                    }
                }
                while let Some(chunk) = pending.remove(&next) {
                    if cancel.load(Ordering::Relaxed) {
                        return (Ok(writer), true);
                    }
                    if let Err(e) =
                        writer.write_plan_frames(&chunk.frames, &chunk.texts, &chunk.stats)
                    {
                        failed.store(true, Ordering::Relaxed);
                        writer.rollback();
                        return (
                            Err(anyhow::Error::from(e).context(format!(
                                "writing frames from {} failed; the same command with --resume continues the plan",
                                first + next * CHUNK
                            ))),
                            false,
                        );
                    }
                    next += 1;
                    // The workers may have finished: a chunk nobody takes is dropped.
                    let _ = spare_tx.send(chunk);
                    on_progress(Progress {
                        done: writer.next_frame(),
                        total,
                        elapsed: start.elapsed(),
                    });
                }
            }
            (Ok(writer), cancel.load(Ordering::Relaxed))
        });
        sink.join().unwrap_or_else(|_| {
            (
                Err(anyhow::anyhow!("the plan's writer thread panicked")),
                false,
            )
        })
    });
    let writer = sink_result?;
    let planned = writer.next_frame() - first;
    let stats = writer.finish()?;
    Ok(PlanReport {
        stats,
        cancelled,
        elapsed: start.elapsed(),
        out_dir: options.out_dir.clone(),
        planned,
        estimated: pipeline.preset().labels.needs_id_pass(),
    })
}

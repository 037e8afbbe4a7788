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

use std::path::PathBuf;
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::time::{Duration, Instant};

use super::batch::frames_asked;
use super::sink::{Keyed, SinkEnd, write_in_order};
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
    on_progress: impl FnMut(Progress) + Send,
) -> anyhow::Result<PlanReport> {
    let count = pipeline.frame_count();
    let frames = frames_asked(count, options.limit, 1, options.resume);
    let writer = DatasetWriter::open(
        &options.out_dir,
        pipeline.preset(),
        pipeline.model_names().to_vec(),
        WriterOptions {
            frames,
            overwrite: options.overwrite,
            resume: options.resume,
            labels_only: true,
            shard: None,
            every: None,
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
    let span = PlanSpan {
        first,
        total,
        chunks: (total.saturating_sub(first)).div_ceil(CHUNK),
        started: start,
    };
    let (sink_result, cancelled) =
        plan_stages(pipeline, writer, span, threads, cancel, on_progress);
    let writer = sink_result?;
    let cancelled = cancelled == SinkEnd::Cancelled || cancel.load(Ordering::Relaxed);
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

/// The chunks of this plan: frames `first..total` in `chunks` chunks of [`CHUNK`].
#[derive(Clone, Copy)]
struct PlanSpan {
    first: u64,
    total: u64,
    chunks: u64,
    started: Instant,
}

/// The workers (one chunk at a time) and the ordered sink that writes them.
fn plan_stages(
    pipeline: &FramePipeline,
    mut writer: DatasetWriter,
    span: PlanSpan,
    threads: usize,
    cancel: &AtomicBool,
    mut on_progress: impl FnMut(Progress) + Send,
) -> (anyhow::Result<DatasetWriter>, SinkEnd) {
    let next_chunk = &AtomicU64::new(0);
    let failed = &AtomicBool::new(false);
    let (tx, rx) = crossbeam_channel::bounded::<Keyed<Chunk>>(threads * 2);
    // Written chunks go back to the workers to be filled again.
    let (spare_tx, spare_rx) = crossbeam_channel::unbounded::<Chunk>();
    let context = &writer.text_context().clone();
    std::thread::scope(|s| {
        for _ in 0..threads {
            let (tx, spare_rx) = (tx.clone(), spare_rx.clone());
            s.spawn(move || {
                loop {
                    if failed.load(Ordering::Relaxed) || cancel.load(Ordering::Relaxed) {
                        return;
                    }
                    let c = next_chunk.fetch_add(1, Ordering::Relaxed);
                    if c >= span.chunks {
                        return;
                    }
                    let lo = span.first + c * CHUNK;
                    let hi = (lo + CHUNK).min(span.total);
                    let chunk = spare_rx.try_recv().unwrap_or_default();
                    let item = plan_chunk(pipeline, context, chunk, lo..hi);
                    if tx.send(Keyed { key: c, item }).is_err() {
                        return;
                    }
                }
            });
        }
        drop(tx);
        let sink = s.spawn(move || {
            let end = write_in_order(rx, (0, 1), cancel, failed, |c, chunk: Chunk| {
                if let Err(e) = writer.write_plan_frames(&chunk.frames, &chunk.texts, &chunk.stats) {
                    writer.rollback();
                    return Err(anyhow::Error::from(e).context(format!(
                        "writing frames from {} failed; the same command with --resume continues the plan",
                        span.first + c * CHUNK
                    )));
                }
                // The workers may have finished: a chunk nobody takes is dropped.
                let _ = spare_tx.send(chunk);
                on_progress(Progress {
                    done: writer.next_frame(),
                    total: span.total,
                    elapsed: span.started.elapsed(),
                });
                Ok(())
            });
            end.map(|end| (writer, end))
        });
        match sink.join() {
            Ok(Ok((writer, end))) => (Ok(writer), end),
            Ok(Err(e)) => (Err(e), SinkEnd::Drained),
            Err(_) => (
                Err(anyhow::anyhow!("the plan's writer thread panicked")),
                SinkEnd::Drained,
            ),
        }
    })
}

/// Plan frames `range` into `chunk` (its buffers reused).
fn plan_chunk(
    pipeline: &FramePipeline,
    context: &crate::write::TextContext,
    mut chunk: Chunk,
    range: std::ops::Range<u64>,
) -> anyhow::Result<Chunk> {
    chunk.frames.clear();
    chunk.texts.clear();
    chunk.stats = DatasetStats::default();
    for i in range {
        let (scene, labels) = pipeline.plan(i)?;
        context.push_frame(&mut chunk.texts, &scene, &labels);
        chunk
            .stats
            .add(&scene, &labels, &context.model_names, &context.classes);
        chunk.frames.push((scene, labels));
    }
    Ok(chunk)
}

//! The labels-only plan (`swarmshot batch --labels-only`): every frame's
//! scene and labels from geometry ([`FramePipeline::plan`]), without the GPU,
//! written by the batch's own writers (labels, COCO, manifest, stats; no
//! images, no data.yaml).
//!
//! Frames are planned in chunks of consecutive indices (at most [`CHUNK`]
//! frames and [`CHUNK_OBJECTS`] drones and confusers, or one frame) by one
//! worker per core; one sink writes the chunks in index order, so the output
//! does not depend on the number of workers. At most [`IN_FLIGHT_OBJECTS`]
//! objects (or one chunk) are planned and not yet written at once, so a
//! plan's memory follows the size of its frames, not their number
//! ([`PlanShape`]); a plan whose one chunk would not fit the memory
//! available is refused before anything is written, and so is one the free
//! disk cannot hold. Amodal and PaperAabb boxes are
//! exactly the rendered batch's; `Visible` boxes are estimated by amodal ones
//! and the visibility filters do not run (see [`FramePipeline::estimate_labels`]).

use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::time::{Duration, Instant};

use super::batch::frames_asked;
use super::sink::{Keyed, SinkEnd, write_in_order};
use super::{FramePipeline, Progress};
use crate::annotate::DroneLabel;
use crate::preset::Preset;
use crate::preset::budget::{DiskEstimate, human_bytes};
use crate::scene::FrameScene;
use crate::write::{DatasetStats, DatasetWriter, FrameTexts, WriterOptions};

/// Frames planned by one worker at a time (and written under one checkpoint), at most.
pub const CHUNK: u64 = 256;
/// Objects (drones and confusers, as many as a frame may hold) in one
/// chunk, at most: large frames make shorter chunks, and a frame past it
/// is a chunk alone.
pub const CHUNK_OBJECTS: u64 = 1 << 16;
/// Objects in the chunks planned and not yet written, all workers
/// together, at most (or one chunk when a chunk alone holds more).
pub const IN_FLIGHT_OBJECTS: u64 = 1 << 18;

/// How a plan of a preset is cut and how much of it is held at once: what
/// bounds its memory, whatever the frame count.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct PlanShape {
    /// The most objects a frame may hold ([`Preset::max_objects_per_frame`]).
    pub objects_per_frame: u64,
    /// Frames per chunk (the last chunk may hold fewer).
    pub frames_per_chunk: u64,
    /// Chunks planned and not yet written at once, at most.
    pub chunks_in_flight: u64,
}

impl PlanShape {
    /// The shape of a plan of `preset` on `threads` planning threads.
    pub fn of(preset: &Preset, threads: usize) -> Self {
        let objects_per_frame = preset.max_objects_per_frame().max(1);
        let frames_per_chunk = (CHUNK_OBJECTS / objects_per_frame).clamp(1, CHUNK);
        let chunk_objects = frames_per_chunk.saturating_mul(objects_per_frame);
        // As many as keep every worker busy (a chunk queued per worker, one
        // being planned, one being written), as far as the budget allows.
        let busy = 3 * threads.max(1) as u64 + 1;
        Self {
            objects_per_frame,
            frames_per_chunk,
            chunks_in_flight: (IN_FLIGHT_OBJECTS / chunk_objects).clamp(1, busy),
        }
    }

    /// Objects held at once, at most: the chunks in flight, full.
    pub fn objects_in_flight(&self) -> u64 {
        self.chunks_in_flight
            .saturating_mul(self.frames_per_chunk)
            .saturating_mul(self.objects_per_frame)
    }
}

/// A labels-only plan refused before anything is written: what it would
/// need is more than the machine has.
#[derive(Debug, thiserror::Error)]
pub enum PlanRefused {
    #[error(
        "--out {}: {frames} frames need about {} ({} labels, {} ledger; labels only, no images), but the filesystem has {} free; free space, choose another folder, or make fewer frames (--limit)",
        out.display(),
        human_bytes(estimate.total_bytes()),
        human_bytes(estimate.label_bytes),
        human_bytes(estimate.ledger_bytes),
        human_bytes(*free as f64)
    )]
    NoSpace {
        out: PathBuf,
        frames: u64,
        estimate: DiskEstimate,
        free: u64,
    },
    #[error(
        "placement: a labels-only plan holds up to {objects} drones and confusers at once ({} per frame) and needs about {} of memory for them, but {} is available (three quarters of MemAvailable, within the process's `ulimit -v` and `ulimit -d`); lower the count per frame",
        shape.objects_per_frame,
        human_bytes(*needed),
        human_bytes(*available)
    )]
    NoMemory {
        shape: PlanShape,
        objects: u64,
        needed: f64,
        available: f64,
    },
}

/// Refuse, before anything is written, a plan of `frames` frames of
/// `preset` into `out` that the free disk cannot hold
/// ([`Preset::plan_disk_estimate`]), or whose chunks in flight
/// ([`PlanShape`]) would need more memory than `available_memory` (bytes
/// it may use; `None`: not known, not checked).
pub fn check_plan_fits(
    preset: &Preset,
    shape: &PlanShape,
    (out, frames): (&Path, u64),
    (free_disk, available_memory): (Option<u64>, Option<u64>),
) -> Result<(), PlanRefused> {
    let objects = shape.objects_in_flight();
    let needed = preset.plan_memory_bytes(objects);
    if let Some(available) = available_memory
        && needed > available as f64
    {
        return Err(PlanRefused::NoMemory {
            shape: *shape,
            objects,
            needed,
            available: available as f64,
        });
    }
    let drones =
        super::check::mean_drones_per_frame(preset) + preset.max_confusers_per_frame() as f64;
    let estimate = preset.plan_disk_estimate(frames, drones);
    if let Some(free) = free_disk
        && estimate.total_bytes() > free as f64
    {
        return Err(PlanRefused::NoSpace {
            out: out.to_owned(),
            frames,
            estimate,
            free,
        });
    }
    Ok(())
}

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
    if let Some(e) = frames.and_then(|end| super::check::run_split_error(pipeline.preset(), end, 1))
    {
        anyhow::bail!("{e}");
    }
    let threads = if options.threads == 0 {
        std::thread::available_parallelism().map_or(1, |n| n.get())
    } else {
        options.threads
    };
    let shape = PlanShape::of(pipeline.preset(), threads);
    // A resumed plan's folder holds its earlier frames: only the memory is checked.
    let free_disk = match (options.resume, frames) {
        (false, Some(_)) => crate::preset::budget::free_bytes(&options.out_dir),
        _ => None,
    };
    check_plan_fits(
        pipeline.preset(),
        &shape,
        (&options.out_dir, frames.unwrap_or(count)),
        (free_disk, crate::preset::budget::usable_memory_bytes()),
    )?;
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
            merge: false,
            inputs: super::inputs::input_records(pipeline.preset())?,
        },
    )?;
    let first = writer.next_frame();
    let total = writer.total().min(count);
    let start = Instant::now();
    let span = PlanSpan {
        first,
        total,
        chunk: shape.frames_per_chunk,
        chunks: (total.saturating_sub(first)).div_ceil(shape.frames_per_chunk),
        in_flight: shape.chunks_in_flight,
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

/// The chunks of this plan: frames `first..total` in `chunks` chunks of
/// `chunk` frames, at most `in_flight` of them planned and not yet written.
#[derive(Clone, Copy)]
struct PlanSpan {
    first: u64,
    total: u64,
    chunk: u64,
    chunks: u64,
    in_flight: u64,
    started: Instant,
}

/// Sets its flag when dropped: the sink is gone, however it ended.
struct SetOnDrop<'a>(&'a AtomicBool);

impl Drop for SetOnDrop<'_> {
    fn drop(&mut self) {
        self.0.store(true, Ordering::Relaxed);
    }
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
    let sink_gone = &AtomicBool::new(false);
    let in_flight = usize::try_from(span.in_flight).unwrap_or(usize::MAX).max(1);
    let (tx, rx) = crossbeam_channel::bounded::<Keyed<Chunk>>(in_flight);
    // Written chunks go back to the workers to be filled again.
    let (spare_tx, spare_rx) = crossbeam_channel::unbounded::<Chunk>();
    // One token per chunk in flight: a worker takes one before it takes a
    // chunk number, so the tokens are held by the lowest chunks not yet
    // written, and the sink gives it back once the chunk is written.
    let (token_tx, token_rx) = crossbeam_channel::bounded::<()>(in_flight);
    for _ in 0..in_flight {
        let _ = token_tx.send(());
    }
    let context = &writer.text_context().clone();
    std::thread::scope(|s| {
        for _ in 0..threads {
            let (tx, spare_rx) = (tx.clone(), spare_rx.clone());
            let (token_tx, token_rx) = (token_tx.clone(), token_rx.clone());
            s.spawn(move || {
                let stop = || {
                    failed.load(Ordering::Relaxed)
                        || cancel.load(Ordering::Relaxed)
                        || sink_gone.load(Ordering::Relaxed)
                };
                loop {
                    // Wait for a token, or for the plan to stop.
                    loop {
                        if stop() {
                            return;
                        }
                        match token_rx.recv_timeout(Duration::from_millis(20)) {
                            Ok(()) => break,
                            Err(crossbeam_channel::RecvTimeoutError::Timeout) => {}
                            Err(crossbeam_channel::RecvTimeoutError::Disconnected) => return,
                        }
                    }
                    let c = next_chunk.fetch_add(1, Ordering::Relaxed);
                    if c >= span.chunks {
                        // Another worker may be waiting for it.
                        let _ = token_tx.try_send(());
                        return;
                    }
                    let lo = span.first + c * span.chunk;
                    let hi = (lo + span.chunk).min(span.total);
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
            let _gone = SetOnDrop(sink_gone);
            let end = write_in_order(rx, (0, 1), cancel, failed, |c, chunk: Chunk| {
                if let Err(e) = writer.write_plan_frames(&chunk.frames, &chunk.texts, &chunk.stats) {
                    writer.rollback();
                    return Err(anyhow::Error::from(e).context(format!(
                        "writing frames from {} failed; the same command with --resume continues the plan",
                        span.first + c * span.chunk
                    )));
                }
                // The workers may have finished: a chunk nobody takes is dropped.
                let _ = spare_tx.send(chunk);
                let _ = token_tx.try_send(());
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

//! The batch: every frame of a preset through the [`FramePipeline`] and into
//! a dataset folder.
//!
//! Three stages on bounded queues, so memory stays flat in the batch length:
//! maker threads (one by default), each with its own
//! [`crate::render::Renderer`] on the one device, take frame indices in order
//! and make frames (scene → render → labels); a pool of encoder threads turns
//! pixels into JPEG/PNG bytes; one sink thread
//! writes each frame's image, labels and manifest line in index order.
//! Beside them, while the makers build their renderers, one short thread
//! finds the level-of-detail bounds the first frame's drones will need
//! ([`FramePipeline::bound_picks_of`]).
//! A frame does not depend on which maker made it or on what that maker
//! made before, so the output is the same for any number of makers.
//! Cancelling stops making frames and writing them (frames made but not yet
//! written are dropped: `--resume` remakes them), so every
//! written image has its labels. The first write error stops every stage at
//! once and removes the frame in flight, so the folder holds exactly the
//! complete frames. A folder holding an earlier run of the same preset and
//! frame count is continued from its first incomplete frame (see
//! `crate::write::folder` and docs/reliability.md). [`StageTimes`] records
//! where the time went.

use std::path::PathBuf;
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::time::{Duration, Instant};

use super::sink::{Keyed, SinkEnd, write_in_order};
use super::{Frame, FramePipeline};
use crate::annotate::DroneLabel;
use crate::render::{GpuContext, Painted};
use crate::scene::FrameScene;
use crate::write::shard::Shard;
use crate::write::{Area, DatasetStats, DatasetWriter, ImageEncoder, Unchanged, WriterOptions};

#[derive(Clone, Debug)]
pub struct BatchOptions {
    pub out_dir: PathBuf,
    /// Make only the first N frames (of every `every`th, with `every`).
    pub limit: Option<u64>,
    /// Delete an earlier run's own files in the folder and start again.
    pub overwrite: bool,
    /// Require an earlier run of the same preset in the folder and continue
    /// it; with no `limit`, the earlier run's frame count is kept.
    pub resume: bool,
    /// Image encoder threads (0 = one per spare core).
    pub encoder_threads: usize,
    /// Frames made at once, each by its own renderer (0 = [`default_makers`]).
    pub makers: usize,
    /// Make only shard K of N of the frames (`--shard`, see `crate::write::shard`).
    pub shard: Option<Shard>,
    /// A trial of every Kth frame (`--every K`): frames `0, K, 2K, …` with
    /// their own indices and names, each the full run's frame of that index;
    /// `limit` then counts these frames. `None` is every frame for a new
    /// run and the earlier trial's step for a resumed one (docs/datasets.md).
    pub every: Option<u64>,
}

/// Makers by default when consecutive frames share their background (the
/// cache hits): on lavapipe (2 cores) a second maker made the quickstart
/// 1.44× slower (the rasteriser threads and the two makers contend).
pub const DEFAULT_MAKERS: usize = 1;

/// Makers by default when each frame draws a new background (camera, sky,
/// environment, sun, backplate or scenery change from frame to frame) on a
/// software rasteriser with more than two cores, and the fewest on a
/// hardware GPU: one maker's environment and CPU upsampling then overlap
/// the other's rendering. On two cores a second maker only contends with
/// lavapipe for them (release, 2 cores: one maker takes 0.91–1.04× the wall
/// time and 0.84–0.95× the CPU of two on twelve such presets;
/// docs/benchmarks.md, "Defaults these figures chose").
pub const DEFAULT_MAKERS_NEW_BACKGROUNDS: usize = 2;

/// The most cores on which a software rasteriser gets one maker even when
/// every frame draws a new background (see [`DEFAULT_MAKERS_NEW_BACKGROUNDS`]).
const FEW_CORES: usize = 2;

/// The most makers chosen by default on a hardware GPU (docs/benchmarks.md,
/// "On a GPU"): on an H200 with 16 cores, `synthswarm_table2.ron` made
/// 427–498 frames/s with 6 makers, 580–636 with 12, and no more with 16 or 24.
pub const MAX_DEFAULT_MAKERS_GPU: usize = 12;

/// Makers when the user names none. On a software rasteriser (lavapipe) the
/// makers share the cores with it, so one maker, or two when each frame draws
/// a new background and there are more than [`FEW_CORES`] cores. On a
/// hardware GPU the makers' CPU work (background upsampling, scenery, the camera stage, labels) is what limits a run whose
/// backgrounds change, so three quarters of the cores make frames (at most
/// [`MAX_DEFAULT_MAKERS_GPU`]); the encoders keep their own threads.
pub fn default_makers(device: wgpu::DeviceType, cores: usize, new_backgrounds: bool) -> usize {
    match (device, new_backgrounds) {
        (_, false) => DEFAULT_MAKERS,
        (wgpu::DeviceType::Cpu, true) if cores <= FEW_CORES => DEFAULT_MAKERS,
        (wgpu::DeviceType::Cpu, true) => DEFAULT_MAKERS_NEW_BACKGROUNDS,
        (_, true) => (cores * 3 / 4).clamp(DEFAULT_MAKERS_NEW_BACKGROUNDS, MAX_DEFAULT_MAKERS_GPU),
    }
}

/// Whether the run's first two frames draw different backgrounds: what
/// the background depends on differs between their scenes.
fn backgrounds_change(pipeline: &FramePipeline, run: &RunSpan) -> bool {
    let (a, b) = (run.first, run.first + run.every);
    if b >= run.total {
        return false;
    }
    match (pipeline.scene(a), pipeline.scene(b)) {
        (Ok(x), Ok(y)) => {
            x.camera != y.camera
                || x.sky != y.sky
                || x.environment != y.environment
                || x.sun_direction != y.sun_direction
                || x.backplate != y.backplate
                || x.clutter != y.clutter
        }
        _ => false,
    }
}

impl BatchOptions {
    pub fn new(out_dir: impl Into<PathBuf>) -> Self {
        Self {
            out_dir: out_dir.into(),
            limit: None,
            overwrite: false,
            resume: false,
            encoder_threads: 0,
            makers: 0,
            shard: None,
            every: None,
        }
    }
}

/// Progress reported after each written frame.
#[derive(Clone, Copy, Debug)]
pub struct Progress {
    pub done: u64,
    pub total: u64,
    pub elapsed: Duration,
}

impl Progress {
    pub fn images_per_s(&self) -> f64 {
        self.done as f64 / self.elapsed.as_secs_f64().max(1e-9)
    }
}

/// Busy time of each stage, summed over frames (the encoder's over all its threads).
#[derive(Clone, Copy, Debug, Default)]
pub struct StageTimes {
    /// Scene, render, readback and labels (summed over the makers).
    pub make: Duration,
    /// Image encoding.
    pub encode: Duration,
    /// Files written by the sink.
    pub write: Duration,
}

impl StageTimes {
    /// One line: each stage's busy time per frame and its share of the wall time.
    pub fn describe(&self, frames: u64, wall: Duration) -> String {
        let per = |d: Duration| d.as_secs_f64() * 1e3 / frames.max(1) as f64;
        let share = |d: Duration| 100.0 * d.as_secs_f64() / wall.as_secs_f64().max(1e-9);
        format!(
            "per frame: make {:.1} ms ({:.0} % of wall), encode {:.1} ms ({:.0} %), write {:.1} ms ({:.0} %)",
            per(self.make),
            share(self.make),
            per(self.encode),
            share(self.encode),
            per(self.write),
            share(self.write),
        )
    }
}

/// What a finished (or cancelled) batch wrote (counting frames an earlier,
/// continued run wrote).
#[derive(Clone, Debug)]
pub struct BatchReport {
    pub stats: DatasetStats,
    pub cancelled: bool,
    pub elapsed: Duration,
    pub out_dir: PathBuf,
    pub times: StageTimes,
    /// The first frame of this run's range (0, or its shard's start).
    pub start_frame: u64,
    /// The first frame this run made: above `start_frame` when it continued an
    /// earlier, interrupted run of the same preset in the folder.
    pub first_frame: u64,
    /// Frames this run wrote (`stats` counts the earlier run's too): the
    /// numerator of any rate. 0 when the folder was already complete.
    pub made: u64,
}

impl BatchReport {
    /// The folder already held every frame: nothing was made.
    pub fn already_complete(&self) -> bool {
        !self.cancelled && self.made == 0
    }

    /// The frame index this run continued from, when it continued an earlier run.
    pub fn resumed_at(&self) -> Option<u64> {
        (self.first_frame > self.start_frame).then_some(self.first_frame)
    }

    /// Frames made per second of this run (0 when none were made).
    pub fn images_per_s(&self) -> f64 {
        self.made as f64 / self.elapsed.as_secs_f64().max(1e-9)
    }
}

/// One frame through an encoder thread: what the sink writes.
struct Encoded {
    scene: FrameScene,
    labels: Vec<DroneLabel>,
    bytes: Vec<u8>,
    /// The frame's masks, encoded (`output.masks`).
    masks: Option<crate::write::formats::masks::EncodedMasks>,
    encode: Duration,
}

/// How one maker thread ended.
struct MakerEnd {
    /// Its first error (frames after it are never written).
    result: anyhow::Result<()>,
    /// It stopped because `cancel` was set.
    cancelled: bool,
    /// Time spent making frames.
    busy: Duration,
}

/// What the sink thread hands back: the writer, to finish the dataset.
struct SinkResult {
    writer: DatasetWriter,
    /// Encoding time of the written frames (over all encoder threads).
    encode: Duration,
    /// Time spent writing files.
    write: Duration,
    end: SinkEnd,
}

/// The makers' joint result.
struct MakersResult {
    result: anyhow::Result<()>,
    cancelled: bool,
    busy: Duration,
}

impl MakersResult {
    /// No maker ran (the run ended before any started).
    fn none() -> Self {
        MakersResult {
            result: Ok(()),
            cancelled: false,
            busy: Duration::ZERO,
        }
    }
}

/// The frame span a run asks its writer for: one past the last frame index
/// of the first `limit` frames of every `every`th of `count` (all with no
/// limit), or None (the locked run's own) when resuming without a limit.
pub(crate) fn frames_asked(
    count: u64,
    limit: Option<u64>,
    every: u64,
    resume: bool,
) -> Option<u64> {
    match (limit, resume) {
        (None, true) => None,
        (limit, _) => Some(limit.map_or(count, |n| n.saturating_mul(every.max(1)).min(count))),
    }
}

/// The frames a run of `options` makes of `count` (before a shard cuts them):
/// the first `limit` of frames `0, K, 2K, …` for `every: Some(K)`.
pub fn frames_of(count: u64, options: &BatchOptions) -> u64 {
    let every = options.every.unwrap_or(1).max(1);
    frames_asked(count, options.limit, every, false)
        .unwrap_or(count)
        .div_ceil(every)
}

/// Refuse `every` where it cannot hold, before the folder is touched.
fn check_every(options: &BatchOptions, preset: &crate::preset::Preset) -> anyhow::Result<()> {
    match options.every {
        Some(0) => anyhow::bail!("--every 0: the step between frames must be at least 1"),
        Some(k) if k > 1 && options.shard.is_some() => anyhow::bail!(
            "--every {k} with --shard: a trial (one frame in {k}) runs in one process; leave out one of them"
        ),
        Some(k) if k > 1 && preset.sequence.is_some() => anyhow::bail!(
            "--every {k}: the preset makes sequences (sequence), whose frames follow one another; use --limit for a trial"
        ),
        _ => Ok(()),
    }
}

/// Refuse an output folder that holds the model cache or lies inside it
/// (`SWARMSHOT_CACHE_DIR` pointed at `--out`): loading the models would put
/// the cache's files among the dataset's, and the folder, then not empty,
/// would be refused on every run. [`run_batch`] checks it; the command line
/// also before it loads the models.
pub fn check_cache_apart(out_dir: &std::path::Path) -> anyhow::Result<()> {
    let Some(cache) = crate::model::lod_cache::cache_dir() else {
        return Ok(());
    };
    let canonical = crate::input::canonical_as_far_as_it_exists;
    let (Ok(cache), Ok(out)) = (canonical(&cache), canonical(out_dir)) else {
        return Ok(());
    };
    if !(cache.starts_with(&out) || out.starts_with(&cache)) {
        return Ok(());
    }
    let set_by = match std::env::var_os(crate::model::lod_cache::CACHE_ENV) {
        Some(_) => "SWARMSHOT_CACHE_DIR",
        None => "the user's cache folder",
    };
    anyhow::bail!(
        "output folder {}: the model cache {} (from {set_by}) would lie inside it or hold it; choose another output folder, or set SWARMSHOT_CACHE_DIR to another folder (or to off)",
        out_dir.display(),
        cache.display()
    )
}

/// Run a batch. `cancel` may be set from another thread at any time.
pub fn run_batch(
    pipeline: &FramePipeline,
    options: &BatchOptions,
    ctx: &GpuContext,
    cancel: &AtomicBool,
    on_progress: impl FnMut(Progress) + Send,
) -> anyhow::Result<BatchReport> {
    let preset = pipeline.preset();
    // The frame's work budget, before the output folder is touched.
    preset
        .check_render_budget()
        .map_err(|e| anyhow::anyhow!("{e}"))?;
    check_every(options, preset)?;
    check_cache_apart(&options.out_dir)?;
    let count = pipeline.frame_count();
    // Only --resume takes the earlier trial's step; a new run says its own.
    let every = match (options.every, options.resume) {
        (None, true) => crate::write::folder::read_run(&options.out_dir)
            .ok()
            .flatten()
            .map_or(1, |earlier| earlier.run.every),
        (every, _) => every.unwrap_or(1).max(1),
    };
    // A run that keeps groups whole and holds too few, before the folder is touched.
    if let Some(end) = frames_asked(count, options.limit, every, options.resume)
        && let Some(e) = super::check::run_split_error(preset, end, every)
    {
        anyhow::bail!("{e}");
    }
    let writer = DatasetWriter::open(
        &options.out_dir,
        preset,
        pipeline.model_names().to_vec(),
        WriterOptions {
            frames: frames_asked(count, options.limit, every, options.resume),
            overwrite: options.overwrite,
            resume: options.resume,
            shard: options.shard,
            every: Some(every),
            labels_only: false,
            merge: false,
            inputs: super::inputs::input_records(preset)?,
        },
    )?;
    let run = RunSpan {
        first: writer.next_frame(),
        start: writer.start(),
        total: writer.total().min(count),
        every: writer.every(),
        started: Instant::now(),
    };
    if run.first >= run.total {
        let stats = writer.finish()?;
        return Ok(report(
            options,
            run,
            stats,
            StageTimes::default(),
            (0, false),
        ));
    }
    let (sink, makers) = run_stages(pipeline, options, ctx, cancel, writer, run, on_progress);
    let sink = sink?;
    let cancelled = makers.cancelled || sink.end == SinkEnd::Cancelled;
    makers.result?;
    let made = sink.writer.next_frame().saturating_sub(run.first) / run.every;
    let stats = sink.writer.finish()?;
    let times = StageTimes {
        make: makers.busy,
        encode: sink.encode,
        write: sink.write,
    };
    Ok(report(options, run, stats, times, (made, cancelled)))
}

/// The frames of this run: indices `first, first + every, …` below `total`
/// (`start`: the run's first frame, before an earlier run continued), and
/// when it started.
#[derive(Clone, Copy, Debug)]
struct RunSpan {
    first: u64,
    start: u64,
    total: u64,
    every: u64,
    started: Instant,
}

impl RunSpan {
    /// Frames left to make.
    fn left(&self) -> u64 {
        self.total.saturating_sub(self.first).div_ceil(self.every)
    }
}

fn report(
    options: &BatchOptions,
    run: RunSpan,
    stats: DatasetStats,
    times: StageTimes,
    (made, cancelled): (u64, bool),
) -> BatchReport {
    BatchReport {
        stats,
        cancelled,
        elapsed: run.started.elapsed(),
        out_dir: options.out_dir.clone(),
        times,
        start_frame: run.start,
        first_frame: run.first,
        made,
    }
}

/// The three stages on their bounded queues: makers → encoders → the sink.
fn run_stages(
    pipeline: &FramePipeline,
    options: &BatchOptions,
    ctx: &GpuContext,
    cancel: &AtomicBool,
    writer: DatasetWriter,
    run: RunSpan,
    on_progress: impl FnMut(Progress) + Send,
) -> (anyhow::Result<SinkResult>, MakersResult) {
    let (makers, threads) = stage_sizes(pipeline, options, ctx, &run);
    let failed = &AtomicBool::new(false);
    let next_index = &AtomicU64::new(run.first);
    let stop_making = &AtomicBool::new(false);
    let (to_encode, encode_rx) = crossbeam_channel::bounded::<Frame>(threads * 2);
    let (to_sink, sink_rx) = crossbeam_channel::bounded::<Keyed<Encoded>>(threads * 2);
    // Encoded frames' pixel buffers, back to the makers for reuse.
    // Frames in flight: being made, queued for an encoder, being encoded.
    // The channel and each maker's spares hold that many, so no buffer is
    // dropped and allocated again.
    let in_flight = makers + threads * 3;
    let (recycle_tx, recycle_rx) = crossbeam_channel::bounded::<(Vec<u8>, Painted)>(in_flight);
    // One encoder for all threads: JPEG frames over the same background
    // share its unpainted tiles (write/encode/jpeg/).
    // The thermal camera's grey frames as one-channel JPEG.
    let format = pipeline.preset().output.image_format;
    let encoder = &match pipeline.preset().thermal {
        Some(_) => ImageEncoder::grey(format),
        None => ImageEncoder::new(format),
    };
    let stages = &MakerStages {
        pipeline,
        ctx,
        cancel,
        failed,
        stop_making,
        next_index,
        run,
        in_flight,
    };
    std::thread::scope(|s| {
        // A thread the system refuses leaves the bounds to the first frame's maker.
        let _ = std::thread::Builder::new().spawn_scoped(s, || pipeline.bound_picks_of(run.first));
        for _ in 0..threads {
            let (rx, tx, recycle) = (encode_rx.clone(), to_sink.clone(), recycle_tx.clone());
            let started = spawn(s, "an encoder", move || {
                encode_frames(pipeline, encoder, rx, tx, recycle);
            });
            // Returning drops the channels: the encoders started end.
            if let Err(e) = started {
                return (Err(e), MakersResult::none());
            }
        }
        drop((to_sink, encode_rx));
        let sink = spawn(s, "the writer", move || {
            write_frames(writer, sink_rx, &run, (cancel, failed), on_progress)
        });
        let sink = match sink {
            Ok(sink) => sink,
            Err(e) => return (Err(e), MakersResult::none()),
        };
        let makers = start_makers(s, makers, stages, to_encode, recycle_rx);
        let sink = sink
            .join()
            .unwrap_or_else(|_| Err(anyhow::anyhow!("the writer thread panicked")));
        (sink, makers)
    })
}

/// How many frame makers and encoder threads a run uses: the options' own,
/// else the defaults for this device and machine (makers never more than
/// the frames left).
fn stage_sizes(
    pipeline: &FramePipeline,
    options: &BatchOptions,
    ctx: &GpuContext,
    run: &RunSpan,
) -> (usize, usize) {
    let cores = std::thread::available_parallelism().map_or(1, |n| n.get());
    let makers = if options.makers != 0 {
        options.makers
    } else {
        default_makers(
            ctx.adapter_info.device_type,
            cores,
            backgrounds_change(pipeline, run),
        )
    }
    .min(usize::try_from(run.left()).unwrap_or(usize::MAX))
    .max(1);
    let threads = if options.encoder_threads == 0 {
        cores.saturating_sub(1).max(1)
    } else {
        options.encoder_threads
    };
    (makers, threads)
}

/// An encoder thread: each frame from `rx` encoded to the sink, its pixels
/// back to a maker for a later frame (dropped when none waits).
fn encode_frames(
    pipeline: &FramePipeline,
    encoder: &ImageEncoder,
    rx: crossbeam_channel::Receiver<Frame>,
    tx: crossbeam_channel::Sender<Keyed<Encoded>>,
    recycle: crossbeam_channel::Sender<(Vec<u8>, Painted)>,
) {
    for frame in rx {
        let key = frame.scene.index;
        let (item, pixels) = encode_frame(pipeline, encoder, frame);
        let _ = recycle.try_send(pixels);
        if tx.send(Keyed { key, item }).is_err() {
            break;
        }
    }
}

/// The writer thread: the encoded frames written in frame order, progress
/// told after each; the first write error rolls the run back to its last
/// complete frame and ends it.
fn write_frames(
    mut writer: DatasetWriter,
    rx: crossbeam_channel::Receiver<Keyed<Encoded>>,
    run: &RunSpan,
    (cancel, failed): (&AtomicBool, &AtomicBool),
    mut on_progress: impl FnMut(Progress),
) -> anyhow::Result<SinkResult> {
    let (mut encode, mut write) = (Duration::ZERO, Duration::ZERO);
    let end = write_in_order(
        rx,
        (run.first, run.every),
        cancel,
        failed,
        |index, e: Encoded| {
            encode += e.encode;
            let t = Instant::now();
            if let Err(err) =
                writer.write_frame_with(&e.scene, &e.labels, &e.bytes, e.masks.as_ref())
            {
                writer.rollback();
                return Err(anyhow::Error::from(err).context(format!(
                "writing frame {index} failed; the frames before it are complete, and the same command with --resume continues from it"
            )));
            }
            write += t.elapsed();
            on_progress(Progress {
                done: (index + run.every - run.start) / run.every,
                total: run.total.saturating_sub(run.start).div_ceil(run.every),
                elapsed: run.started.elapsed(),
            });
            Ok(())
        },
    );
    end.map(|end| SinkResult {
        writer,
        encode,
        write,
        end,
    })
}

/// Start `makers` frame makers and wait for them. A maker that cannot be
/// started (the thread limit) stops the others after their frames, and the
/// run ends with that error.
fn start_makers<'scope, 'env>(
    s: &'scope std::thread::Scope<'scope, 'env>,
    makers: usize,
    stages: &'scope MakerStages<'env>,
    to_encode: crossbeam_channel::Sender<Frame>,
    recycle_rx: crossbeam_channel::Receiver<(Vec<u8>, Painted)>,
) -> MakersResult {
    let mut started = Vec::new();
    let mut not_started = None;
    for _ in 0..makers {
        let (to_encode, recycled) = (to_encode.clone(), recycle_rx.clone());
        match spawn(s, "a frame maker", move || {
            stages.make_frames(&to_encode, &recycled)
        }) {
            Ok(maker) => started.push(maker),
            Err(e) => {
                stages.stop_making.store(true, Ordering::SeqCst);
                not_started = Some(e);
                break;
            }
        }
    }
    drop(to_encode);
    let mut joint = join_makers(started);
    if let Some(e) = not_started
        && joint.result.is_ok()
    {
        joint.result = Err(e);
    }
    joint
}

/// Encode one frame's image (and masks): the sink's item, and the pixel
/// buffer to hand back to a maker.
fn encode_frame(
    pipeline: &FramePipeline,
    encoder: &ImageEncoder,
    frame: Frame,
) -> (anyhow::Result<Encoded>, (Vec<u8>, Painted)) {
    let t = Instant::now();
    let (w, h) = (frame.scene.camera.width, frame.scene.camera.height);
    let changed: Vec<Area> = (frame.painted.rects().iter())
        .map(|r| Area {
            x: r.x0..r.x1,
            y: r.y0..r.y1,
        })
        .collect();
    let unchanged = Unchanged {
        background: frame.painted.background(),
        changed: &changed,
    };
    // A frame through the camera model may have its own JPEG quality.
    let frame_format = pipeline.image_format(&frame.scene);
    let bytes = if let Some(grey) = &frame.grey16 {
        crate::write::encode_grey16_png(grey, w, h)
    } else if frame_format == pipeline.preset().output.image_format {
        encoder.encode(&frame.rgba, w, h, Some(unchanged))
    } else {
        crate::write::encode_image(&frame.rgba, w, h, frame_format)
    };
    let masks = frame.masks.as_ref().map(|m| {
        let outputs = &pipeline.preset().output.masks;
        crate::write::formats::masks::encode(m, &frame.labels, outputs)
    });
    let item = bytes
        .and_then(|bytes| Ok((bytes, masks.transpose()?)))
        .map(|(bytes, masks)| Encoded {
            scene: frame.scene,
            labels: frame.labels,
            bytes,
            masks,
            encode: t.elapsed(),
        })
        .map_err(anyhow::Error::from);
    (item, (frame.rgba, frame.painted))
}

/// What every maker thread shares.
struct MakerStages<'a> {
    pipeline: &'a FramePipeline,
    ctx: &'a GpuContext,
    cancel: &'a AtomicBool,
    /// The sink failed: stop.
    failed: &'a AtomicBool,
    /// Another maker failed: stop.
    stop_making: &'a AtomicBool,
    /// The next frame index to take (in steps of `run.every`).
    next_index: &'a AtomicU64,
    run: RunSpan,
    in_flight: usize,
}

impl MakerStages<'_> {
    /// One maker: take the next index until the batch ends, fails or is cancelled.
    fn make_frames(
        &self,
        to_encode: &crossbeam_channel::Sender<Frame>,
        recycled: &crossbeam_channel::Receiver<(Vec<u8>, Painted)>,
    ) -> MakerEnd {
        let mut renderer = self.pipeline.frame_renderer(self.ctx);
        renderer.keep_spares(self.in_flight);
        // A maker reads nothing of its renderer but each frame's pixels.
        renderer.set_lend_backgrounds(!self.pipeline.reads_backgrounds());
        let mut busy = Duration::ZERO;
        let end = |result, cancelled, busy| MakerEnd {
            result,
            cancelled,
            busy,
        };
        loop {
            if self.failed.load(Ordering::Relaxed) || self.stop_making.load(Ordering::Relaxed) {
                return end(Ok(()), false, busy); // the sink or another maker failed
            }
            if self.cancel.load(Ordering::Relaxed) {
                return end(Ok(()), true, busy);
            }
            let index = self.next_index.fetch_add(self.run.every, Ordering::Relaxed);
            if index >= self.run.total {
                return end(Ok(()), false, busy);
            }
            while let Ok((buffer, painted)) = recycled.try_recv() {
                renderer.recycle(buffer, painted);
            }
            let t = Instant::now();
            let made = self.pipeline.make(&mut renderer, index);
            busy += t.elapsed();
            match made {
                // A send fails only when the sink has stopped (its error is reported).
                Ok(frame) => {
                    if to_encode.send(frame).is_err() {
                        return end(Ok(()), false, busy);
                    }
                }
                Err(e) => {
                    // Frames after this one may be made, but the sink writes in
                    // index order and so never writes past the gap.
                    self.stop_making.store(true, Ordering::Relaxed);
                    return end(Err(e.into()), false, busy);
                }
            }
        }
    }
}

/// Join the makers: the first error, whether any was cancelled, their busy time.
/// Start `what`'s thread in `scope`; a thread the system refuses (`ulimit
/// -u`, a cgroup's pids.max) is an error naming the limit, where
/// `Scope::spawn` panicked ("failed to spawn thread: … Resource temporarily
/// unavailable").
fn spawn<'scope, T: Send + 'scope>(
    scope: &'scope std::thread::Scope<'scope, '_>,
    what: &str,
    f: impl FnOnce() -> T + Send + 'scope,
) -> anyhow::Result<std::thread::ScopedJoinHandle<'scope, T>> {
    std::thread::Builder::new().spawn_scoped(scope, f).map_err(|e| {
        anyhow::anyhow!(
            "cannot start {what} thread: {e} (the process's thread limit, `ulimit -u` or the job's task limit, is reached); lower --makers and --threads, or raise the limit; the frames written are complete, and the same command with --resume continues"
        )
    })
}

fn join_makers(makers: Vec<std::thread::ScopedJoinHandle<'_, MakerEnd>>) -> MakersResult {
    let mut joint = MakersResult::none();
    for maker in makers {
        let end = maker.join().unwrap_or_else(|_| MakerEnd {
            result: Err(anyhow::anyhow!("a frame maker thread panicked")),
            cancelled: false,
            busy: Duration::ZERO,
        });
        joint.busy += end.busy;
        joint.cancelled |= end.cancelled;
        if joint.result.is_ok() {
            joint.result = end.result;
        }
    }
    joint
}

#[cfg(test)]
mod tests {
    use super::*;

    fn span(total: u64) -> RunSpan {
        RunSpan {
            first: 0,
            start: 0,
            total,
            every: 1,
            started: Instant::now(),
        }
    }

    fn changes(preset: &str) -> bool {
        let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join(preset);
        let pipeline = FramePipeline::open(&path).expect("preset opens");
        backgrounds_change(&pipeline, &span(pipeline.preset().frame_count()))
    }

    #[test]
    fn a_new_background_every_frame_is_seen_from_the_first_two_scenes() {
        // The quickstart's frames share their camera and sky; the paper-like
        // preset draws its environment and camera anew for every frame.
        assert!(!changes("presets/quickstart.ron"));
        assert!(changes("presets/synthswarm_table2.ron"));
        assert!(changes("presets/realistic.ron"));
        // A run of one frame has no second frame to compare.
        let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("presets/realistic.ron");
        let pipeline = FramePipeline::open(&path).expect("preset opens");
        assert!(!backgrounds_change(&pipeline, &span(1)));
    }

    #[test]
    fn a_hardware_gpu_gets_more_makers_only_when_backgrounds_change() {
        use wgpu::DeviceType::{Cpu, DiscreteGpu, IntegratedGpu};
        // lavapipe on the 2-core machine: one maker, as measured there; two
        // where more cores leave room for a second one's work.
        assert_eq!(default_makers(Cpu, 2, false), 1);
        assert_eq!(default_makers(Cpu, 2, true), 1);
        assert_eq!(default_makers(Cpu, 1, true), 1);
        assert_eq!(default_makers(Cpu, 4, true), 2);
        assert_eq!(default_makers(Cpu, 64, true), 2);
        assert_eq!(default_makers(Cpu, 64, false), 1);
        // A GPU: shared backgrounds keep one maker; new ones take 3/4 of the cores.
        assert_eq!(default_makers(DiscreteGpu, 16, false), 1);
        assert_eq!(default_makers(DiscreteGpu, 16, true), 12);
        assert_eq!(default_makers(IntegratedGpu, 8, true), 6);
        // Never fewer than the CPU machine's two, never more than the cap.
        assert_eq!(default_makers(DiscreteGpu, 2, true), 2);
        assert_eq!(default_makers(DiscreteGpu, 1, true), 2);
        assert_eq!(
            default_makers(DiscreteGpu, 128, true),
            MAX_DEFAULT_MAKERS_GPU
        );
    }
}

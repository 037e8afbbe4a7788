//! The batch: every frame of a preset through the [`FramePipeline`] and into
//! a dataset folder.
//!
//! Three stages on bounded queues, so memory stays flat in the batch length:
//! maker threads (one by default), each with its own
//! [`crate::render::Renderer`] on the one device, take frame indices in order
//! and make frames (scene → render → labels); a pool of encoder threads turns
//! pixels into JPEG/PNG bytes; one sink thread
//! writes each frame's image, labels and manifest line in index order.
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

use std::collections::BTreeMap;
use std::path::PathBuf;
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::time::{Duration, Instant};

use super::{Frame, FramePipeline};
use crate::annotate::DroneLabel;
use crate::render::{GpuContext, Painted};
use crate::scene::FrameScene;
use crate::write::shard::Shard;
use crate::write::{Area, DatasetStats, DatasetWriter, ImageEncoder, Unchanged, WriterOptions};

#[derive(Clone, Debug)]
pub struct BatchOptions {
    pub out_dir: PathBuf,
    /// Make only the first N frames.
    pub limit: Option<u64>,
    /// Delete an earlier run's own files in the folder and start again.
    pub overwrite: bool,
    /// Require an earlier run of the same preset in the folder and continue
    /// it; with no `limit`, the earlier run's frame count is kept.
    pub resume: bool,
    /// Image encoder threads (0 = one per spare core).
    pub encoder_threads: usize,
    /// Frames made at once, each by its own renderer (0 = [`DEFAULT_MAKERS`]).
    pub makers: usize,
    /// Make only shard K of N of the frames (`--shard`, see `crate::write::shard`).
    pub shard: Option<Shard>,
    /// Make only every Kth frame (frames 0, K, 2K, …; `--every`).
    pub every: Option<u64>,
}

/// Makers by default. On lavapipe (2 cores) a second maker made the
/// quickstart slower (20–22 against 28 images/s: the rasteriser threads and
/// the two makers contend); on a real GPU more makers keep it busier.
pub const DEFAULT_MAKERS: usize = 1;

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

struct Encoded {
    scene: FrameScene,
    labels: Vec<DroneLabel>,
    bytes: Vec<u8>,
    /// The frame's masks, encoded (`output.masks`).
    masks: Option<crate::write::masks::EncodedMasks>,
    encode: Duration,
}

/// The frame count a run asks its writer for: the first `limit` of `count`,
/// or None (the locked run's own) when resuming without a limit.
pub(crate) fn frames_asked(count: u64, limit: Option<u64>, resume: bool) -> Option<u64> {
    match (limit, resume) {
        (None, true) => None,
        (limit, _) => Some(limit.map_or(count, |n| n.min(count))),
    }
}

/// Run a batch. `cancel` may be set from another thread at any time.
pub fn run_batch(
    pipeline: &FramePipeline,
    options: &BatchOptions,
    ctx: &GpuContext,
    cancel: &AtomicBool,
    mut on_progress: impl FnMut(Progress) + Send,
) -> anyhow::Result<BatchReport> {
    let preset = pipeline.preset();
    // The frame's work budget, before the output folder is touched.
    preset
        .check_render_budget()
        .map_err(|e| anyhow::anyhow!("{e}"))?;
    let count = pipeline.frame_count();
    let frames = frames_asked(count, options.limit, options.resume);
    let mut writer = DatasetWriter::open(
        &options.out_dir,
        preset,
        pipeline.model_names().to_vec(),
        WriterOptions {
            frames,
            overwrite: options.overwrite,
            resume: options.resume,
            shard: options.shard,
            labels_only: false,
        },
    )?;
    let first = writer.next_frame();
    let total = writer.total().min(count);
    // Progress counts this run's frames (a shard's, with --shard).
    let (done_before, run_frames) = (writer.start(), total.saturating_sub(writer.start()));
    let start = Instant::now();
    if first >= total {
        let stats = writer.finish()?;
        return Ok(BatchReport {
            stats,
            cancelled: false,
            elapsed: start.elapsed(),
            out_dir: options.out_dir.clone(),
            times: StageTimes::default(),
            start_frame: done_before,
            first_frame: first,
            made: 0,
        });
    }
    let makers = if options.makers == 0 {
        DEFAULT_MAKERS
    } else {
        options.makers
    }
    .min(usize::try_from(total - first).unwrap_or(usize::MAX))
    .max(1);
    let format = preset.output.image_format;
    let threads = if options.encoder_threads == 0 {
        std::thread::available_parallelism().map_or(1, |n| n.get().saturating_sub(1).max(1))
    } else {
        options.encoder_threads
    };
    let failed = AtomicBool::new(false);
    let next_index = AtomicU64::new(first);
    let stop_making = AtomicBool::new(false);
    let (to_encode, encode_rx) = crossbeam_channel::bounded::<Frame>(threads * 2);
    let (to_sink, sink_rx) = crossbeam_channel::bounded::<anyhow::Result<Encoded>>(threads * 2);
    // Encoded frames' pixel buffers, back to the makers for reuse.
    // Frames in flight: being made, queued for an encoder, being encoded.
    // The channel and each maker's spares hold that many, so no buffer is
    // dropped and allocated again.
    let in_flight = makers + threads * 3;
    let (recycle_tx, recycle_rx) = crossbeam_channel::bounded::<(Vec<u8>, Painted)>(in_flight);

    // One encoder for all threads: JPEG frames over the same background
    // share its unpainted tiles (write/jpeg.rs).
    let encoder = &ImageEncoder::new(format);
    let (sink_result, cancelled, make_result, make_time) = std::thread::scope(|s| {
        for _ in 0..threads {
            let rx = encode_rx.clone();
            let tx = to_sink.clone();
            let recycle = recycle_tx.clone();
            s.spawn(move || {
                for frame in rx {
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
                    let bytes = if frame_format == format {
                        encoder.encode(&frame.rgba, w, h, Some(unchanged))
                    } else {
                        crate::write::encode_image(&frame.rgba, w, h, frame_format)
                    };
                    let masks = frame.masks.as_ref().map(|m| {
                        let outputs = &pipeline.preset().output.masks;
                        crate::write::masks::encode(m, &frame.labels, outputs)
                    });
                    let msg = bytes
                        .and_then(|bytes| Ok((bytes, masks.transpose()?)))
                        .map(|(bytes, masks)| Encoded {
                            scene: frame.scene,
                            labels: frame.labels,
                            bytes,
                            masks,
                            encode: t.elapsed(),
                        })
                        .map_err(anyhow::Error::from);
                    // The pixels go back to a maker for a later frame (dropped when none waits).
                    let _ = recycle.try_send((frame.rgba, frame.painted));
                    if tx.send(msg).is_err() {
                        break;
                    }
                }
            });
        }
        drop(to_sink);
        drop(encode_rx);
        // The sink: reorder by index and write; the first error stops it.
        let failed = &failed;
        let sink = s.spawn(
            move || -> anyhow::Result<(DatasetWriter, Duration, Duration, bool)> {
                let mut pending: BTreeMap<u64, Encoded> = BTreeMap::new();
                let mut next = first;
                let (mut encode, mut write) = (Duration::ZERO, Duration::ZERO);
                let stop = |e: anyhow::Error| {
                    failed.store(true, Ordering::Relaxed);
                    Err(e)
                };
                for msg in sink_rx {
                    match msg {
                        Ok(e) => {
                            pending.insert(e.scene.index, e);
                        }
                        Err(e) => return stop(e),
                    }
                    while let Some(e) = pending.remove(&next) {
                        if cancel.load(Ordering::Relaxed) {
                            // Frames made but not yet written are dropped: a resume remakes them.
                            return Ok((writer, encode, write, true));
                        }
                        encode += e.encode;
                        let t = Instant::now();
                        if let Err(err) = writer.write_frame_with(&e.scene, &e.labels, &e.bytes, e.masks.as_ref()) {
                            writer.rollback();
                            return stop(anyhow::Error::from(err).context(format!(
                                "writing frame {next} failed; the frames before it are complete, and the same command with --resume continues from it"
                            )));
                        }
                        write += t.elapsed();
                        next += 1;
                        on_progress(Progress {
                            done: next - done_before,
                            total: run_frames,
                            elapsed: start.elapsed(),
                        });
                    }
                }
                Ok((writer, encode, write, false))
            },
        );
        // The makers: each takes the next index until the batch ends, fails or is cancelled.
        let makers: Vec<_> = (0..makers)
            .map(|_| {
                let to_encode = to_encode.clone();
                let recycled = recycle_rx.clone();
                let (next_index, stop_making) = (&next_index, &stop_making);
                s.spawn(move || -> (anyhow::Result<()>, bool, Duration) {
                    let mut renderer = pipeline.renderer(ctx);
                    renderer.keep_spares(in_flight);
                    let mut busy = Duration::ZERO;
                    loop {
                        if failed.load(Ordering::Relaxed) || stop_making.load(Ordering::Relaxed) {
                            return (Ok(()), false, busy); // the sink or another maker failed
                        }
                        if cancel.load(Ordering::Relaxed) {
                            return (Ok(()), true, busy);
                        }
                        let index = next_index.fetch_add(1, Ordering::Relaxed);
                        if index >= total {
                            return (Ok(()), false, busy);
                        }
                        while let Ok((buffer, painted)) = recycled.try_recv() {
                            renderer.recycle(buffer, painted);
                        }
                        let t = Instant::now();
                        let made = pipeline.make(&mut renderer, index);
                        busy += t.elapsed();
                        match made {
                            // A send fails only when the sink has stopped (its error is reported).
                            Ok(frame) => {
                                if to_encode.send(frame).is_err() {
                                    return (Ok(()), false, busy);
                                }
                            }
                            Err(e) => {
                                // Frames after this one may be made, but the sink writes in
                                // index order and so never writes past the gap.
                                stop_making.store(true, Ordering::Relaxed);
                                return (Err(e.into()), false, busy);
                            }
                        }
                    }
                })
            })
            .collect();
        drop(to_encode);
        let mut make_result = Ok(());
        let mut cancelled = false;
        let mut make_time = Duration::ZERO;
        for maker in makers {
            let (result, was_cancelled, busy) = maker.join().unwrap_or_else(|_| {
                (
                    Err(anyhow::anyhow!("a frame maker thread panicked")),
                    false,
                    Duration::ZERO,
                )
            });
            make_time += busy;
            cancelled |= was_cancelled;
            if make_result.is_ok() {
                make_result = result;
            }
        }
        let sink_result = sink
            .join()
            .unwrap_or_else(|_| Err(anyhow::anyhow!("the writer thread panicked")));
        (sink_result, cancelled, make_result, make_time)
    });
    let (writer, encode, write, sink_cancelled) = sink_result?;
    let cancelled = cancelled || sink_cancelled;
    make_result?;
    let made = writer.next_frame().saturating_sub(first);
    let stats = writer.finish()?;
    Ok(BatchReport {
        stats,
        cancelled,
        elapsed: start.elapsed(),
        out_dir: options.out_dir.clone(),
        times: StageTimes {
            make: make_time,
            encode,
            write,
        },
        start_frame: done_before,
        first_frame: first,
        made,
    })
}

//! The batch runner behind "Generate": [`crate::pipeline::run_batch`] (the same
//! code path as `swarmshot batch`) on a background thread, with shared
//! progress, a cancel flag and the result handed back through a channel.
//!
//! The UI is woken at most once per [`WAKE_INTERVAL`] while frames come in
//! (and always once at the end): a repaint per frame made the window's
//! drawing, not the batch, set the pace (issue 23: 5–10× the CLI's time).

use std::path::PathBuf;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use crossbeam_channel::Receiver;

use crate::pipeline::{BatchOptions, BatchReport, FramePipeline, Progress, run_batch};
use crate::preset::Preset;
use crate::render::GpuContext;

/// The shortest time between two progress wake-ups of the UI (once a second).
///
/// On lavapipe (a CPU rasteriser) one pass of the window costs about 0.2 s of
/// CPU, paid from the two cores the batch renders on: at 10 wake-ups a second
/// the quickstart's batch took 31–35 s in the window against 3.3 s on the
/// command line (debug build, loaded machine); see docs/gui.md, "Batch".
pub const WAKE_INTERVAL: Duration = Duration::from_secs(1);

/// Lets a wake-up through when at least `interval` passed since the last one let through.
#[derive(Debug)]
pub struct WakeThrottle {
    interval: Duration,
    last: Option<Instant>,
}

impl WakeThrottle {
    pub fn new(interval: Duration) -> Self {
        Self {
            interval,
            last: None,
        }
    }

    /// Whether to wake the UI for progress seen at `now`.
    pub fn due(&mut self, now: Instant) -> bool {
        let due = self
            .last
            .is_none_or(|last| now.saturating_duration_since(last) >= self.interval);
        if due {
            self.last = Some(now);
        }
        due
    }
}

/// A batch in flight.
pub struct BatchRun {
    cancel: Arc<AtomicBool>,
    /// The latest progress, and how many of its `done` frames this run made
    /// (a continued run's first report already counts the earlier run's frames).
    progress: Arc<Mutex<Option<(Progress, u64)>>>,
    result: Receiver<Result<BatchReport, anyhow::Error>>,
    /// Frames this batch will make.
    pub total: u64,
    pub out_dir: PathBuf,
    started: Instant,
    /// The batch thread: joined on drop (it holds a GPU context).
    thread: Option<std::thread::JoinHandle<()>>,
}

/// How a batch ended.
pub enum BatchOutcome {
    /// Finished or cancelled; the dataset on disk is consistent either way.
    Done(Box<BatchReport>),
    Failed(BatchError),
}

/// Why a batch did not finish.
#[derive(Debug, thiserror::Error)]
pub enum BatchError {
    /// The pipeline or the batch failed: the error chain, outermost first, each
    /// cause once (as the command line prints it).
    #[error("{}", crate::text::one_line(.0))]
    Failed(anyhow::Error),
    #[error("the batch thread stopped without a result")]
    Lost,
}

/// A progress snapshot for the UI.
#[derive(Clone, Copy, Debug)]
pub struct BatchStatus {
    pub done: u64,
    pub total: u64,
    pub images_per_s: f64,
    pub eta: Option<Duration>,
    pub cancelling: bool,
}

impl BatchRun {
    /// Start `preset` (already snapshotted and path-resolved) into `options.out_dir`.
    pub fn start(
        preset: Preset,
        options: BatchOptions,
        gpu: GpuContext,
        wake: impl Fn() + Send + Sync + 'static,
    ) -> std::io::Result<Self> {
        let cancel = Arc::new(AtomicBool::new(false));
        let progress = Arc::new(Mutex::new(None));
        let (tx, result) = crossbeam_channel::bounded(1);
        let total = options
            .limit
            .map_or(preset.frame_count(), |n| n.min(preset.frame_count()));
        let out_dir = options.out_dir.clone();
        let (thread_cancel, thread_progress) = (Arc::clone(&cancel), Arc::clone(&progress));
        let thread = std::thread::Builder::new()
            .name("swarmshot batch".into())
            .spawn(move || {
                let mut throttle = WakeThrottle::new(WAKE_INTERVAL);
                let outcome = FramePipeline::new(preset)
                    .map_err(anyhow::Error::from)
                    .and_then(|pipeline| {
                        // Reports come once per written frame: the first one
                        // counts every frame before it as made earlier.
                        let mut before: Option<u64> = None;
                        run_batch(&pipeline, &options, &gpu, &thread_cancel, |p| {
                            let earlier = *before.get_or_insert(p.done.saturating_sub(1));
                            if let Ok(mut slot) = thread_progress.lock() {
                                *slot = Some((p, p.done.saturating_sub(earlier)));
                            }
                            if throttle.due(Instant::now()) {
                                wake();
                            }
                        })
                    });
                let _ = tx.send(outcome);
                wake();
            })?;
        Ok(Self {
            cancel,
            progress,
            result,
            total,
            out_dir,
            started: Instant::now(),
            thread: Some(thread),
        })
    }

    /// Ask the batch to stop after the frames already in the pipeline.
    pub fn cancel(&self) {
        self.cancel.store(true, Ordering::Relaxed);
    }

    pub fn status(&self) -> BatchStatus {
        let p = self.progress.lock().ok().and_then(|p| *p);
        let done = p.map_or(0, |(p, _)| p.done);
        // The batch's own count once it reports (a shard's frames, with a shard).
        let total = p.map_or(self.total, |(p, _)| p.total);
        // Over the frames this run made, not those an earlier run left.
        let images_per_s = p.map_or(0.0, |(p, made)| {
            made as f64 / p.elapsed.as_secs_f64().max(1e-9)
        });
        let remaining = total.saturating_sub(done);
        let eta =
            (images_per_s > 0.0).then(|| Duration::from_secs_f64(remaining as f64 / images_per_s));
        BatchStatus {
            done,
            total,
            images_per_s,
            eta,
            cancelling: self.cancel.load(Ordering::Relaxed),
        }
    }

    pub fn elapsed(&self) -> Duration {
        self.started.elapsed()
    }

    /// The outcome, once the batch thread has finished.
    pub fn finished(&self) -> Option<BatchOutcome> {
        match self.result.try_recv() {
            Ok(Ok(report)) => Some(BatchOutcome::Done(Box::new(report))),
            Ok(Err(e)) => Some(BatchOutcome::Failed(BatchError::Failed(e))),
            Err(crossbeam_channel::TryRecvError::Empty) => None,
            Err(crossbeam_channel::TryRecvError::Disconnected) => {
                Some(BatchOutcome::Failed(BatchError::Lost))
            }
        }
    }
}

impl Drop for BatchRun {
    /// A batch still running is cancelled (the frames in flight are
    /// finished, the dataset stays consistent); its thread is waited for.
    fn drop(&mut self) {
        self.cancel();
        if let Some(thread) = self.thread.take() {
            super::worker::join_within(thread, super::worker::JOIN_WAIT);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn wake_ups_are_at_least_an_interval_apart() {
        let start = Instant::now();
        let mut throttle = WakeThrottle::new(Duration::from_millis(100));
        let at = |ms| start + Duration::from_millis(ms);
        // Progress every 5 ms for one second: the first, then one per 100 ms.
        let woken: Vec<u64> = (0..200)
            .map(|k| k * 5)
            .filter(|&ms| throttle.due(at(ms)))
            .collect();
        assert_eq!(woken, (0..10).map(|k| k * 100).collect::<Vec<_>>());
    }
}

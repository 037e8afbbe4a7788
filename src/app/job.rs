//! One long library call (the domain-gap report, a fit) on its own thread, for a
//! window: what it is doing in words, how long it has run, a cancel flag, and its
//! result through a channel.
//!
//! The window is woken only when the stage changes (at most once per
//! [`WAKE_INTERVAL`]) and once at the end, and its elapsed-time line asks for one
//! repaint a second: never a spinner, which repaints the whole window every pass.
//! On lavapipe one pass costs about 0.2 s of CPU, so a spinner's 60 passes a second
//! took both cores from the report (issue 40: the gap window took 54 s where
//! `swarmshot gap` took 16 s; see docs/gui.md, "Domain gap and Fit").

use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use crossbeam_channel::Receiver;
use egui::Ui;

use super::runner::{WAKE_INTERVAL, WakeThrottle};

/// What the job is doing, shared with its thread; setting it wakes the window (throttled).
pub struct Stage {
    text: Mutex<String>,
    throttle: Mutex<WakeThrottle>,
    ctx: egui::Context,
}

impl Stage {
    /// Show `text` as the job's stage.
    pub fn set(&self, text: impl Into<String>) {
        if let Ok(mut s) = self.text.lock() {
            *s = text.into();
        }
        let due = self
            .throttle
            .lock()
            .is_ok_and(|mut t| t.due(Instant::now()));
        if due {
            self.ctx.request_repaint();
        }
    }

    fn text(&self) -> String {
        self.text.lock().map(|s| s.clone()).unwrap_or_default()
    }
}

/// Why a job gave no result.
#[derive(Debug, thiserror::Error)]
pub enum JobError {
    #[error("cannot start the {name} thread: {source}")]
    Spawn {
        name: String,
        source: std::io::Error,
    },
    #[error("the job's thread stopped without a result")]
    Lost,
    /// The library call failed or was cancelled: its error and causes, as the window
    /// shows it (each cause once, as the command line prints it).
    #[error("{}", crate::text::one_line(.0))]
    Failed(#[from] anyhow::Error),
}

/// A job in flight; dropping it cancels it and waits for its thread.
pub struct Job<T> {
    stage: Arc<Stage>,
    cancel: Arc<AtomicBool>,
    result: Receiver<Result<T, JobError>>,
    started: Instant,
    /// The job's thread (it may render on the GPU): joined on drop.
    thread: Option<std::thread::JoinHandle<()>>,
}

impl<T: Send + 'static> Job<T> {
    /// Run `work` on a thread named `name`; the window is woken when it ends.
    pub fn spawn(
        name: &str,
        ctx: &egui::Context,
        work: impl FnOnce(&Stage, &AtomicBool) -> anyhow::Result<T> + Send + 'static,
    ) -> Result<Self, JobError> {
        let stage = Arc::new(Stage {
            text: Mutex::new("starting…".into()),
            throttle: Mutex::new(WakeThrottle::new(WAKE_INTERVAL)),
            ctx: ctx.clone(),
        });
        let cancel = Arc::new(AtomicBool::new(false));
        let (tx, result) = crossbeam_channel::bounded(1);
        let (thread_stage, thread_cancel) = (Arc::clone(&stage), Arc::clone(&cancel));
        let thread = std::thread::Builder::new()
            .name(name.into())
            .spawn(move || {
                let outcome = work(&thread_stage, &thread_cancel).map_err(JobError::Failed);
                let _ = tx.send(outcome);
                thread_stage.ctx.request_repaint();
            })
            .map_err(|source| JobError::Spawn {
                name: name.into(),
                source,
            })?;
        Ok(Self {
            stage,
            cancel,
            result,
            started: Instant::now(),
            thread: Some(thread),
        })
    }

    /// The result, once the job has ended.
    pub fn poll(&self) -> Option<Result<T, JobError>> {
        match self.result.try_recv() {
            Ok(outcome) => Some(outcome),
            Err(crossbeam_channel::TryRecvError::Empty) => None,
            Err(crossbeam_channel::TryRecvError::Disconnected) => Some(Err(JobError::Lost)),
        }
    }

    /// Ask the job to stop at its next check.
    pub fn cancel(&self) {
        self.cancel.store(true, Ordering::Relaxed);
    }

    /// The stage in words, the time so far and a Cancel button (when `cancellable`).
    pub fn status_ui(&self, ui: &mut Ui, cancellable: bool) {
        let seconds = self.started.elapsed().as_secs();
        ui.label(format!("{} ({seconds} s)", self.stage.text()));
        if cancellable && ui.button("Cancel").clicked() {
            self.cancel();
        }
        // The seconds move once a second; the end wakes the window at once.
        ui.ctx().request_repaint_after(Duration::from_secs(1));
    }
}

impl<T> Drop for Job<T> {
    fn drop(&mut self) {
        self.cancel.store(true, Ordering::Relaxed);
        if let Some(thread) = self.thread.take() {
            super::worker::join_within(thread, super::worker::JOIN_WAIT);
        }
    }
}

/// A window's one job at a time and what the last one gave: the running job,
/// its outcome once it ended, and whether one started since the app last asked.
pub struct JobSlot<T> {
    job: Option<Job<T>>,
    outcome: Option<Result<T, JobError>>,
    started: bool,
}

impl<T> Default for JobSlot<T> {
    fn default() -> Self {
        Self {
            job: None,
            outcome: None,
            started: false,
        }
    }
}

impl<T: Send + 'static> JobSlot<T> {
    /// Hold a spawned job (its outcome is cleared), or the error that kept it from starting.
    pub fn start(&mut self, spawned: Result<Job<T>, JobError>) {
        match spawned {
            Ok(job) => {
                self.outcome = None;
                self.job = Some(job);
                self.started = true;
            }
            Err(e) => self.outcome = Some(Err(e)),
        }
    }

    /// Take the running job's result once it has ended; returns it when it just did.
    pub fn poll(&mut self) -> Option<&Result<T, JobError>> {
        let outcome = self.job.as_ref().and_then(Job::poll)?;
        self.job = None;
        self.outcome = Some(outcome);
        self.outcome.as_ref()
    }

    /// The running job.
    pub fn running(&self) -> Option<&Job<T>> {
        self.job.as_ref()
    }

    /// A job is running.
    pub fn is_running(&self) -> bool {
        self.job.is_some()
    }

    /// The last job's outcome (`None` while one runs or before the first).
    pub fn outcome(&self) -> Option<&Result<T, JobError>> {
        self.outcome.as_ref()
    }

    /// The last job's result, if it succeeded.
    pub fn done(&self) -> Option<&T> {
        self.outcome.as_ref().and_then(|o| o.as_ref().ok())
    }

    /// The last job's error, if it failed.
    pub fn error(&self) -> Option<&JobError> {
        self.outcome.as_ref().and_then(|o| o.as_ref().err())
    }

    /// Whether a job started since the last call (the app then pauses playback).
    pub fn take_started(&mut self) -> bool {
        std::mem::take(&mut self.started)
    }
}

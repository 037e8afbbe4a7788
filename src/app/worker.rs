//! A background thread that always works on the newest request.
//!
//! The UI submits a request whenever its inputs change; while the thread is
//! busy, requests pile up and only the last one is served, so dragging a
//! slider never queues a backlog of stale renders. Each answer is followed by
//! a call to `wake` (the app passes `egui::Context::request_repaint`), so the
//! UI thread only ever polls a channel and never waits.

use std::thread::JoinHandle;
use std::time::{Duration, Instant};

use crossbeam_channel::{Receiver, Sender};

/// A thread that turns the newest `Req` into a `Resp`.
pub struct LatestWorker<Req, Resp> {
    /// `None` once dropped: the thread then ends after its current request.
    requests: Option<Sender<Req>>,
    responses: Receiver<Resp>,
    thread: Option<JoinHandle<()>>,
}

/// How long a dropped worker or batch is waited for before it is left to
/// finish on its own.
pub(super) const JOIN_WAIT: Duration = Duration::from_secs(60);

/// Wait for `thread` to end, for at most `limit`. A thread that touched
/// the GPU must end before the process does: lavapipe's threads and its
/// static destructors otherwise race at exit (a crash after `main`).
pub(super) fn join_within(thread: JoinHandle<()>, limit: Duration) {
    let start = Instant::now();
    while !thread.is_finished() && start.elapsed() < limit {
        std::thread::sleep(Duration::from_millis(5));
    }
    if thread.is_finished() {
        let _ = thread.join();
    }
}

impl<Req: Send + 'static, Resp: Send + 'static> LatestWorker<Req, Resp> {
    /// Start the thread; it ends when this handle is dropped.
    pub fn spawn(
        name: &str,
        wake: impl Fn() + Send + 'static,
        mut work: impl FnMut(Req) -> Resp + Send + 'static,
    ) -> std::io::Result<Self> {
        let (requests, request_rx) = crossbeam_channel::unbounded::<Req>();
        let (response_tx, responses) = crossbeam_channel::unbounded::<Resp>();
        let thread = std::thread::Builder::new()
            .name(name.to_owned())
            .spawn(move || {
                while let Ok(mut request) = request_rx.recv() {
                    while let Ok(newer) = request_rx.try_recv() {
                        request = newer;
                    }
                    if response_tx.send(work(request)).is_err() {
                        break;
                    }
                    wake();
                }
            })?;
        Ok(Self {
            requests: Some(requests),
            responses,
            thread: Some(thread),
        })
    }

    /// Queue a request; older unserved requests are skipped.
    pub fn submit(&self, request: Req) {
        // The thread only stops when this handle is dropped, so sending cannot fail while we hold it.
        if let Some(requests) = &self.requests {
            let _ = requests.send(request);
        }
    }

    /// The newest answer that arrived since the last call, if any.
    pub fn latest(&self) -> Option<Resp> {
        self.responses.try_iter().last()
    }
}

impl<Req, Resp> Drop for LatestWorker<Req, Resp> {
    /// Close the requests and wait for the thread to finish the one it is on.
    fn drop(&mut self) {
        self.requests = None;
        if let Some(thread) = self.thread.take() {
            join_within(thread, JOIN_WAIT);
        }
    }
}
